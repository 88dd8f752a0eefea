//! Value parsers for numeric options: each refuses, at parse time, a value outside its range with
//! a message that states the range (clap prints it with the option's name).

/// The most worker threads `-j` accepts.
pub const MAX_THREADS: u64 = 256;

/// A whole number in `lo..=hi`.
fn whole(s: &str, lo: u64, hi: u64, unit: &str) -> Result<u64, String> {
    let t = s.trim();
    let digits = !t.is_empty() && t.bytes().all(|b| b.is_ascii_digit());
    match t.parse::<u64>() {
        Ok(v) if (lo..=hi).contains(&v) => Ok(v),
        _ if digits => Err(format!("out of range: must be {lo} to {hi}{unit}")),
        _ => Err(format!("not a whole number: must be {lo} to {hi}{unit}")),
    }
}

/// `-j`: worker threads, 1 to [`MAX_THREADS`].
pub fn threads(s: &str) -> Result<usize, String> {
    whole(s, 1, MAX_THREADS, " worker threads").map(|v| v as usize)
}

/// `--baud`: 50 to 20 000 000 baud.
pub fn baud(s: &str) -> Result<u32, String> {
    whole(s, 50, 20_000_000, " baud").map(|v| v as u32)
}

/// `--timeout-ms`: 1 ms to one hour.
pub fn timeout_ms(s: &str) -> Result<u64, String> {
    whole(s, 1, 3_600_000, " ms")
}

/// `--retries`: 0 to 100.
pub fn retries(s: &str) -> Result<u32, String> {
    whole(s, 0, 100, "").map(|v| v as u32)
}

/// `--exposure-us`: 1 µs to 60 s.
pub fn exposure_us(s: &str) -> Result<u32, String> {
    whole(s, 1, 60_000_000, " µs").map(|v| v as u32)
}

/// `--dark-us`: 0 to 60 s.
pub fn dark_us(s: &str) -> Result<u32, String> {
    whole(s, 0, 60_000_000, " µs").map(|v| v as u32)
}

/// `--scan-timeout-s`: more than 0 and at most one day, seconds.
pub fn scan_timeout_s(s: &str) -> Result<f64, String> {
    const MAX: f64 = 86_400.0;
    match s.trim().parse::<f64>() {
        Ok(v) if v > 0.0 && v <= MAX => Ok(v),
        Ok(_) => Err(format!(
            "out of range: must be more than 0 and at most {MAX} seconds (one day)"
        )),
        Err(_) => Err(format!(
            "not a number: must be more than 0 and at most {MAX} seconds (one day)"
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ranges_are_enforced_with_the_range_in_the_message() {
        assert_eq!(threads("1"), Ok(1));
        assert_eq!(threads("256"), Ok(256));
        for bad in [
            "0",
            "257",
            "100000",
            "18446744073709551615",
            "18446744073709551616",
        ] {
            let e = threads(bad).unwrap_err();
            assert!(e.contains("1 to 256"), "{bad}: {e}");
        }
        assert!(threads("-1").unwrap_err().contains("not a whole number"));
        assert!(baud("0").unwrap_err().contains("50 to 20000000 baud"));
        assert_eq!(
            retries("4294967295").unwrap_err(),
            "out of range: must be 0 to 100"
        );
        for bad in ["0", "-1", "1e300", "inf", "NaN", "86401"] {
            let e = scan_timeout_s(bad).unwrap_err();
            assert!(e.contains("at most 86400"), "{bad}: {e}");
        }
        assert_eq!(scan_timeout_s("0.5"), Ok(0.5));
        assert!(exposure_us("0").unwrap_err().contains("1 to 60000000 µs"));
        assert_eq!(dark_us("0"), Ok(0));
    }
}
