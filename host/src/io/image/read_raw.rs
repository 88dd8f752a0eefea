//! Headerless raw frames (`*.raw`): a frame grabber's dump of `width × height` samples with no
//! header at all, described once per folder by a `raw.toml` beside them (issue #24 item 3):
//!
//! ```toml
//! width = 1280
//! height = 1024
//! bits = 12                 # significant bits, 1 to 16: 1 byte a sample up to 8, else 2
//! byte_order = "little"     # of 2-byte samples: "little" (default) or "big"
//! ```
//!
//! A `.raw` file is read by its extension (it has no signature), row-major, top row first, and
//! must hold exactly `width × height` samples. As for PGM, the thresholds scale with `bits`, so a
//! sample above `2^bits − 1` is refused rather than read with a wrong saturation level.

use super::{GrayImage, ImageError, ImageFormat, ImageHeader, Pixels, ReadInfo, ReadLimits};
use super::{check_dims, decode_err};
use std::path::{Path, PathBuf};

/// The descriptor's file name, in the folder of the frames.
pub const DESCRIPTOR: &str = "raw.toml";

/// The largest descriptor read, bytes.
const MAX_DESCRIPTOR: u64 = 4096;

/// `raw.toml`.
#[derive(Clone, Debug, serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct Desc {
    width: u32,
    height: u32,
    bits: u8,
    #[serde(default)]
    byte_order: Option<String>,
}

/// A checked descriptor.
#[derive(Clone, Copy, Debug)]
struct Layout {
    width: u32,
    height: u32,
    bits: u8,
    big_endian: bool,
}

impl Layout {
    fn sample_bytes(&self) -> usize {
        if self.bits <= 8 { 1 } else { 2 }
    }

    fn len(&self) -> u64 {
        u64::from(self.width) * u64::from(self.height) * self.sample_bytes() as u64
    }
}

/// Whether `path` names a headerless raw frame (its extension, any case).
pub(super) fn is_raw(path: &Path) -> bool {
    path.extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("raw"))
}

/// The descriptor beside `path`, read and checked; errors name the frame and the descriptor.
fn layout(path: &Path, lim: &ReadLimits) -> Result<Layout, ImageError> {
    let desc_path: PathBuf = path
        .parent()
        .unwrap_or_else(|| Path::new("."))
        .join(DESCRIPTOR);
    let bad = |m: String| decode_err(path, "raw", m);
    let text = crate::io::input::read_limited(&desc_path, MAX_DESCRIPTOR).map_err(|e| {
        bad(format!(
            "a headerless frame needs its size and bit depth in {} ({e})",
            desc_path.display()
        ))
    })?;
    let text = String::from_utf8(text)
        .map_err(|_| bad(format!("{}: not UTF-8 text", desc_path.display())))?;
    let d: Desc = toml::from_str(&text)
        .map_err(|e| bad(format!("{}: {}", desc_path.display(), e.message())))?;
    if !(1..=16).contains(&d.bits) {
        return Err(bad(format!(
            "{}: bits must be 1 to 16, got {}",
            desc_path.display(),
            d.bits
        )));
    }
    let big_endian = match d.byte_order.as_deref() {
        None | Some("little") => false,
        Some("big") => true,
        Some(o) => {
            return Err(bad(format!(
                "{}: byte_order must be \"little\" or \"big\", got \"{o}\"",
                desc_path.display()
            )));
        }
    };
    check_dims(path, d.width, d.height, lim)?;
    Ok(Layout {
        width: d.width,
        height: d.height,
        bits: d.bits,
        big_endian,
    })
}

/// The size of the raw frame at `path` (its descriptor's, checked against the file's length).
pub(super) fn header(path: &Path) -> Result<ImageHeader, ImageError> {
    let l = layout(path, &ReadLimits::default())?;
    let len = std::fs::metadata(path)
        .map_err(|source| ImageError::Io {
            path: path.to_path_buf(),
            source,
        })?
        .len();
    check_len(path, &l, len)?;
    Ok(ImageHeader {
        format: ImageFormat::Raw,
        width: l.width,
        height: l.height,
    })
}

fn check_len(path: &Path, l: &Layout, len: u64) -> Result<(), ImageError> {
    if len != l.len() {
        return Err(decode_err(
            path,
            "raw",
            format!(
                "{len} bytes, but {DESCRIPTOR} describes {}x{} samples of {} byte(s): {} bytes",
                l.width,
                l.height,
                l.sample_bytes(),
                l.len()
            ),
        ));
    }
    Ok(())
}

/// Decode the raw frame `bytes` read from `path`.
pub(super) fn decode(
    bytes: &[u8],
    path: &Path,
    lim: &ReadLimits,
) -> Result<(GrayImage, ReadInfo), ImageError> {
    let l = layout(path, lim)?;
    check_len(path, &l, bytes.len() as u64)?;
    let max = (1u32 << l.bits) - 1;
    let over = |i: usize, v: u32| {
        decode_err(
            path,
            "raw",
            format!(
                "sample {i} is {v}, above {max}, the full scale of bits = {} in {DESCRIPTOR}",
                l.bits
            ),
        )
    };
    let pixels = if l.sample_bytes() == 1 {
        if let Some(i) = bytes.iter().position(|&v| u32::from(v) > max) {
            return Err(over(i, u32::from(bytes[i])));
        }
        Pixels::U8(bytes.to_vec())
    } else {
        let v: Vec<u16> = bytes
            .chunks_exact(2)
            .map(|b| {
                if l.big_endian {
                    u16::from_be_bytes([b[0], b[1]])
                } else {
                    u16::from_le_bytes([b[0], b[1]])
                }
            })
            .collect();
        if let Some(i) = v.iter().position(|&s| u32::from(s) > max) {
            return Err(over(i, u32::from(v[i])));
        }
        Pixels::U16(v)
    };
    Ok((
        GrayImage {
            width: l.width,
            height: l.height,
            pixels,
            significant_bits: l.bits,
        },
        ReadInfo {
            format: ImageFormat::Raw,
            converted_from_color: false,
            dropped_alpha: false,
        },
    ))
}
