//! The NPY reader: camera frames saved by NumPy (`np.save`), read without inflating anything.
//!
//! Accepted: C-order arrays of shape `(height, width)` or `(height, width, 1)` with dtype `|u1`
//! (8-bit), `<u2` or `>u2` (16-bit; full scale 65535, as a 16-bit PNG without `sBIT`), and `<f4`
//! (float maps, like a float TIFF). Anything else (colour `(h, w, 3)`, Fortran order, other
//! dtypes, a data size that is not exactly the shape's) is refused with the reason.

use super::{GrayImage, ImageError, ImageFormat, ImageHeader, Pixels, ReadInfo, ReadLimits};
use super::{check_dims, decode_err};
use crate::io::npy;
use std::path::Path;

/// A checked frame header: size, sample kind and where the data starts.
struct Head {
    width: u32,
    height: u32,
    kind: Kind,
    data: usize,
}

#[derive(Clone, Copy, PartialEq)]
enum Kind {
    U8,
    U16 { big: bool },
    F32,
}

impl Kind {
    fn bytes(self) -> usize {
        match self {
            Kind::U8 => 1,
            Kind::U16 { .. } => 2,
            Kind::F32 => 4,
        }
    }
}

fn head(b: &[u8], path: &Path) -> Result<Head, ImageError> {
    let bad = |m: String| decode_err(path, "NPY", m);
    let h = npy::parse_header(b).map_err(bad)?;
    let kind = match h.descr.as_str() {
        "|u1" | "<u1" | ">u1" | "u1" => Kind::U8,
        "<u2" => Kind::U16 { big: false },
        ">u2" => Kind::U16 { big: true },
        "<f4" => Kind::F32,
        d => {
            return Err(bad(format!(
                "dtype '{d}' is not read (uint8 '|u1', uint16 '<u2'/'>u2', float32 '<f4')"
            )));
        }
    };
    if h.fortran_order {
        return Err(bad(
            "Fortran-order (column-major) arrays are not read; save with np.ascontiguousarray"
                .into(),
        ));
    }
    let (height, width) = match h.shape.as_slice() {
        [hh, ww] | [hh, ww, 1] => (*hh, *ww),
        s => {
            return Err(bad(format!(
                "shape {s:?} is not a gray frame (height, width) or (height, width, 1)"
            )));
        }
    };
    let dim = |v: usize, name: &str| {
        u32::try_from(v).map_err(|_| bad(format!("{name} {v} is larger than {}", u32::MAX)))
    };
    Ok(Head {
        width: dim(width, "width")?,
        height: dim(height, "height")?,
        kind,
        data: h.data,
    })
}

/// The size the header declares.
pub(super) fn header(b: &[u8], path: &Path) -> Result<ImageHeader, ImageError> {
    let h = head(b, path)?;
    Ok(ImageHeader {
        format: ImageFormat::Npy,
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
    let need = n * h.kind.bytes();
    let data = b.get(h.data..).unwrap_or(&[]);
    if data.len() != need {
        return Err(decode_err(
            path,
            "NPY",
            format!(
                "{} data bytes for a {}x{} array of {}-byte samples, need {need}",
                data.len(),
                h.width,
                h.height,
                h.kind.bytes()
            ),
        ));
    }
    let (pixels, significant_bits) = match h.kind {
        Kind::U8 => (Pixels::U8(data.to_vec()), 8),
        Kind::U16 { big } => (
            Pixels::U16(
                data.chunks_exact(2)
                    .map(|c| {
                        if big {
                            u16::from_be_bytes([c[0], c[1]])
                        } else {
                            u16::from_le_bytes([c[0], c[1]])
                        }
                    })
                    .collect(),
            ),
            16,
        ),
        Kind::F32 => (
            Pixels::F32(
                data.chunks_exact(4)
                    .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
                    .collect(),
            ),
            32,
        ),
    };
    Ok((
        GrayImage {
            width: h.width,
            height: h.height,
            pixels,
            significant_bits,
        },
        ReadInfo {
            format: ImageFormat::Npy,
            converted_from_color: false,
            dropped_alpha: false,
        },
    ))
}
