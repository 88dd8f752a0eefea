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
    let max = fringe3d_core::wire::MAX_EXPOSURE_US;
    whole(s, 1, u64::from(max), " µs").map(|v| v as u32)
}

/// `--exposures-us`: an HDR scan's exposures, 1 to 4 comma-separated values of 1 µs to 60 s,
/// longest first (each shorter than the one before), as the head takes them (the wire's
/// [`Exposures`](fringe3d_core::wire::Exposures)).
pub fn exposures_us(s: &str) -> Result<fringe3d_core::wire::Exposures, String> {
    let max = fringe3d_core::decode::hdr::MAX_EXPOSURES;
    let us = s
        .split(',')
        .map(exposure_us)
        .collect::<Result<Vec<u32>, String>>()?;
    if us.len() > max {
        return Err(format!(
            "{} exposures: at most {max}, longest first",
            us.len()
        ));
    }
    if let Some(p) = us.windows(2).find(|p| p[1] >= p[0]) {
        return Err(format!(
            "{} µs after {} µs: list the exposures longest first, each shorter than the one before",
            p[1], p[0]
        ));
    }
    fringe3d_core::wire::Exposures::new(&us).map_err(|e| e.to_string())
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

/// An image size `WxH` (also `W,H` or `W×H`), each 1 to 1 000 000 px.
pub fn size_wh(s: &str) -> Result<(u32, u32), String> {
    let t = s.trim();
    let (w, h) = t
        .split_once(['x', 'X', ',', '×'])
        .ok_or_else(|| format!("`{t}` is not a size: expected WxH, e.g. 1280x800"))?;
    let w = whole(w, 1, 1_000_000, " px").map_err(|m| format!("width: {m}"))?;
    let h = whole(h, 1, 1_000_000, " px").map_err(|m| format!("height: {m}"))?;
    Ok((w as u32, h as u32))
}

/// A range `MIN,MAX` of two finite numbers with `0 < MIN < MAX` (a depth range, mm).
pub fn min_max(s: &str) -> Result<[f64; 2], String> {
    let v: Vec<&str> = s.split(',').map(str::trim).collect();
    let [a, b] = v[..] else {
        return Err(format!("`{s}`: expected two numbers MIN,MAX"));
    };
    let num = |x: &str| {
        x.parse::<f64>()
            .ok()
            .filter(|v| v.is_finite())
            .ok_or_else(|| format!("`{x}` is not a finite number"))
    };
    let (a, b) = (num(a)?, num(b)?);
    if !(a > 0.0 && a < b) {
        return Err(format!("must satisfy 0 < MIN < MAX, got {a},{b}"));
    }
    Ok([a, b])
}

/// Six finite numbers `A,B,C,D,E,F` (a pose `X,Y,Z,RX,RY,RZ`, a box `X0,Y0,Z0,X1,Y1,Z1`).
pub fn six(s: &str) -> Result<[f64; 6], String> {
    let v: Vec<f64> = s
        .split(',')
        .map(|x| x.trim().parse::<f64>().ok().filter(|v| v.is_finite()))
        .collect::<Option<_>>()
        .ok_or_else(|| format!("`{s}`: expected six finite numbers separated by commas"))?;
    <[f64; 6]>::try_from(v).map_err(|v| format!("`{s}`: expected six numbers, got {}", v.len()))
}

/// `--margin`: `None` for auto.
pub fn margin(s: &str) -> anyhow::Result<Option<fringe3d_core::reconstruct::Margin>> {
    use fringe3d_core::reconstruct::Margin;
    if s.trim() == "auto" {
        return Ok(None);
    }
    let v: Vec<u32> = s
        .split(',')
        .map(|x| x.trim().parse::<u32>())
        .collect::<Result<_, _>>()
        .map_err(|_| {
            anyhow::anyhow!("--margin: \"auto\", N or L,T,R,B (whole pixels), got \"{s}\"")
        })?;
    match v[..] {
        [n] => Ok(Some(Margin::uniform(n))),
        [l, t, r, b] => Ok(Some(Margin::from_array([l, t, r, b]))),
        _ => anyhow::bail!("--margin: \"auto\", N or L,T,R,B (whole pixels), got \"{s}\""),
    }
}

/// `X,Y,Z` of option `what` (camera frame, mm).
pub fn point3(s: &str, what: &str) -> anyhow::Result<[f64; 3]> {
    use anyhow::Context;
    let v: Vec<f64> = s
        .split(',')
        .map(|x| x.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .with_context(|| format!("{what} {s:?}: expected X,Y,Z"))?;
    let [x, y, z] = v[..] else {
        anyhow::bail!("{what} {s:?}: expected three numbers X,Y,Z")
    };
    Ok([x, y, z])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_and_ranges() {
        assert_eq!(size_wh("912x1140"), Ok((912, 1140)));
        assert_eq!(size_wh(" 8,6 "), Ok((8, 6)));
        assert!(size_wh("0x5").unwrap_err().contains("width"));
        assert!(size_wh("12").unwrap_err().contains("WxH"));
        assert_eq!(min_max("500, 900"), Ok([500.0, 900.0]));
        assert!(min_max("900,500").unwrap_err().contains("MIN < MAX"));
        assert!(min_max("-1,5").unwrap_err().contains("0 < MIN"));
        assert!(min_max("1,nan").is_err());
    }

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
