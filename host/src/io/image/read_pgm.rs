//! The PGM reader: Netpbm's binary gray map (`P5`), one image per file, read without inflating
//! anything (a frame grabber's raw dump with a text header).
//!
//! ```text
//! P5 <ws> width <ws> height <ws> maxval <one ws> raster
//! ```
//!
//! `<ws>` is any run of blanks, tabs, CR, LF, VT or FF, and a `#` starts a comment to the end of
//! its line anywhere before the maxval. The raster holds width × height samples, row-major, top
//! row first: one byte each when maxval < 256, else two bytes, most significant first.
//!
//! fringe3d's thresholds are fractions of a sensor's full scale `2^bits − 1`, so maxval must be of
//! that form (255 for 8-bit, 1023, 4095 or 65535 for 10-, 12- or 16-bit data stored unscaled,
//! like a PNG with `sBIT`); any other maxval is refused rather than decoded with a wrong
//! saturation level. A sample above maxval, a short raster or bytes after it (Netpbm's
//! multi-image streams: one frame per file here) are errors too.

use super::{GrayImage, ImageError, ImageFormat, ImageHeader, Pixels, ReadInfo, ReadLimits};
use super::{check_dims, decode_err};
use std::path::Path;

/// The longest header accepted, bytes (comments included): a header is a few dozen bytes, and a
/// file of text with no raster must not be scanned to its end for one.
pub(super) const MAX_HEADER: usize = 4096;

/// The fields of a PGM header, checked.
struct Head {
    width: u32,
    height: u32,
    maxval: u16,
    /// Offset of the raster.
    data: usize,
}

fn is_ws(b: u8) -> bool {
    matches!(b, b' ' | b'\t' | b'\n' | b'\r' | 0x0b | 0x0c)
}

/// One decimal field after whitespace and comments, starting at `*at`; at most `max`.
fn field(b: &[u8], at: &mut usize, name: &str, max: u32, path: &Path) -> Result<u32, ImageError> {
    let bad = |m: String| decode_err(path, "PGM", m);
    loop {
        match b.get(*at) {
            Some(&c) if is_ws(c) => *at += 1,
            Some(b'#') => {
                while let Some(&c) = b.get(*at) {
                    *at += 1;
                    if c == b'\n' || c == b'\r' {
                        break;
                    }
                }
            }
            Some(_) => break,
            None => return Err(bad(format!("header ends before its {name}"))),
        }
        if *at > MAX_HEADER {
            return Err(bad(format!("no {name} in the first {MAX_HEADER} bytes")));
        }
    }
    let start = *at;
    let mut v: u64 = 0;
    while let Some(&c) = b.get(*at) {
        if !c.is_ascii_digit() {
            break;
        }
        v = v * 10 + u64::from(c - b'0');
        if v > u64::from(max) {
            return Err(bad(format!("{name} is larger than {max}")));
        }
        *at += 1;
        if *at > MAX_HEADER {
            return Err(bad(format!("the header is longer than {MAX_HEADER} bytes")));
        }
    }
    if *at == start {
        return Err(bad(format!("{name} is not a decimal number")));
    }
    Ok(v as u32)
}

fn head(b: &[u8], path: &Path) -> Result<Head, ImageError> {
    let bad = |m: &str| decode_err(path, "PGM", m);
    if b.starts_with(b"P2") {
        return Err(bad(
            "plain (ASCII, P2) gray maps are not read; convert to binary P5 (e.g. `pnmtopnm`)",
        ));
    }
    if !b.starts_with(b"P5") {
        return Err(bad("not a binary gray map (P5)"));
    }
    let mut at = 2;
    if !b.get(at).is_some_and(|&c| is_ws(c) || c == b'#') {
        return Err(bad("no whitespace after the P5 magic"));
    }
    let width = field(b, &mut at, "width", u32::MAX, path)?;
    let height = field(b, &mut at, "height", u32::MAX, path)?;
    let maxval = field(b, &mut at, "maxval", 65535, path)?;
    // Exactly one whitespace byte separates maxval from the raster (whose first byte may itself
    // look like whitespace).
    if !b.get(at).is_some_and(|&c| is_ws(c)) {
        return Err(bad("no whitespace between maxval and the raster"));
    }
    at += 1;
    if maxval == 0 || (maxval & (maxval + 1)) != 0 {
        return Err(decode_err(
            path,
            "PGM",
            format!(
                "maxval {maxval} is not 2^bits - 1 (255, 1023, 4095, 65535): fringe3d's \
                 saturation and modulation thresholds are fractions of such a full scale"
            ),
        ));
    }
    Ok(Head {
        width,
        height,
        maxval: maxval as u16,
        data: at,
    })
}

/// The size the header declares.
pub(super) fn header(b: &[u8], path: &Path) -> Result<ImageHeader, ImageError> {
    let h = head(b, path)?;
    Ok(ImageHeader {
        format: ImageFormat::Pgm,
        width: h.width,
        height: h.height,
    })
}

pub(super) fn decode(
    b: &[u8],
    path: &Path,
    lim: &ReadLimits,
) -> Result<(GrayImage, ReadInfo), ImageError> {
    let h = head(b, path)?;
    check_dims(path, h.width, h.height, lim)?;
    // Checked against the cap above: at most 2^28 pixels, so no product below overflows.
    let n = h.width as usize * h.height as usize;
    let wide = h.maxval > 255;
    let need = if wide { 2 * n } else { n };
    let raster = &b[h.data.min(b.len())..];
    if raster.len() != need {
        let what = if raster.len() < need {
            "the raster is truncated"
        } else {
            "bytes follow the raster (one image per file)"
        };
        return Err(decode_err(
            path,
            "PGM",
            format!(
                "{what}: {} bytes for {}x{} samples of {} byte(s), need {need}",
                raster.len(),
                h.width,
                h.height,
                if wide { 2 } else { 1 }
            ),
        ));
    }
    let over = |i: usize, v: u16| {
        decode_err(
            path,
            "PGM",
            format!(
                "sample {v} at ({}, {}) exceeds maxval {}",
                i % h.width as usize,
                i / h.width as usize,
                h.maxval
            ),
        )
    };
    let pixels = if wide {
        let v: Vec<u16> = raster
            .chunks_exact(2)
            .map(|c| u16::from_be_bytes([c[0], c[1]]))
            .collect();
        if let Some(i) = v.iter().position(|&s| s > h.maxval) {
            return Err(over(i, v[i]));
        }
        Pixels::U16(v)
    } else {
        if let Some(i) = raster.iter().position(|&s| u16::from(s) > h.maxval) {
            return Err(over(i, u16::from(raster[i])));
        }
        Pixels::U8(raster.to_vec())
    };
    Ok((
        GrayImage {
            width: h.width,
            height: h.height,
            pixels,
            // maxval = 2^bits − 1 (checked in `head`).
            significant_bits: (16 - h.maxval.leading_zeros()) as u8,
        },
        ReadInfo {
            format: ImageFormat::Pgm,
            converted_from_color: false,
            dropped_alpha: false,
        },
    ))
}
