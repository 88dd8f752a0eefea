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
    }
}
