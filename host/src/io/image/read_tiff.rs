//! The TIFF reader: 8/16-bit gray, 32/64-bit float gray, and 8/16-bit RGB(A) (converted to luma).

use super::{
    GrayImage, ImageError, ImageFormat, ImageHeader, MAX_DECODED_BYTES, Pixels, ReadInfo,
    ReadLimits, check_dims, decode_err, luma,
};
use std::io::{Read, Seek};
use std::path::Path;
use tiff::ColorType as C;

fn err(path: &Path) -> impl Fn(tiff::TiffError) -> ImageError + '_ {
    move |e| decode_err(path, "TIFF", e)
}

/// The size the first image directory declares (read through `r`, which may be the open file).
pub(super) fn header<R: Read + Seek>(r: R, path: &Path) -> Result<ImageHeader, ImageError> {
    let mut dec = tiff::decoder::Decoder::new(r).map_err(err(path))?;
    let (width, height) = dec.dimensions().map_err(err(path))?;
    Ok(ImageHeader {
        format: ImageFormat::Tiff,
        width,
        height,
    })
}

pub(super) fn decode(
    bytes: &[u8],
    path: &Path,
    lim: &ReadLimits,
) -> Result<(GrayImage, ReadInfo), ImageError> {
    use tiff::decoder::DecodingResult as D;
    let err = err(path);
    let mut dec = tiff::decoder::Decoder::new(std::io::Cursor::new(bytes)).map_err(&err)?;
    let (w, h) = dec.dimensions().map_err(&err)?;
    check_dims(path, w, h, lim)?;
    let ct = dec.colortype().map_err(&err)?;
    let (channels, color, alpha, bits) = match ct {
        C::Gray(b) => (1usize, false, false, b),
        C::GrayA(b) => (2, false, true, b),
        C::RGB(b) => (3, true, false, b),
        C::RGBA(b) => (4, true, true, b),
        other => {
            return Err(decode_err(
                path,
                "TIFF",
                format!("unsupported colour type {other:?}"),
            ));
        }
    };
    // The decoded buffer, bounded before it is allocated: the declared size (already checked
    // against the pixel cap) times the samples, and a ceiling on the total.
    let need = (w as u64 * h as u64)
        .saturating_mul(channels as u64)
        .saturating_mul(u64::from(bits).div_ceil(8).max(1));
    if need > MAX_DECODED_BYTES {
        return Err(decode_err(
            path,
            "TIFF",
            format!(
                "{w}x{h} pixels of {ct:?} decode to {need} bytes, more than the {MAX_DECODED_BYTES} this reader accepts"
            ),
        ));
    }
    let mut limits = tiff::decoder::Limits::default();
    limits.decoding_buffer_size = (need as usize).max(limits.decoding_buffer_size);
    let mut dec = dec.with_limits(limits);
    let data = dec.read_image().map_err(&err)?;
    let n = w as usize * h as usize;
    let short = || decode_err(path, "TIFF", "fewer samples than the image size needs");
    let info = ReadInfo {
        format: ImageFormat::Tiff,
        converted_from_color: color,
        dropped_alpha: alpha,
    };
    macro_rules! reduce {
        ($v:expr, $conv:expr) => {{
            let mut v = $v;
            if v.len() < n * channels {
                return Err(short());
            }
            if channels == 1 {
                // Gray (a reference phase map): the decoded samples as they are, not a copy.
                v.truncate(n);
                v
            } else {
                (0..n)
                    .map(|i| {
                        let s = &v[i * channels..];
                        if color {
                            $conv(luma(s[0] as f64, s[1] as f64, s[2] as f64))
                        } else {
                            s[0]
                        }
                    })
                    .collect::<Vec<_>>()
            }
        }};
    }
    let (pixels, bits) = match data {
        D::U8(v) => (Pixels::U8(reduce!(v, |x: f64| x as u8)), 8),
        D::U16(v) => (Pixels::U16(reduce!(v, |x: f64| x as u16)), 16),
        D::F32(v) => (Pixels::F32(reduce!(v, |x: f64| x as f32)), 32),
        D::F64(v) => {
            if v.len() < n * channels {
                return Err(short());
            }
            let v: Vec<f32> = (0..n)
                .map(|i| {
                    let s = &v[i * channels..];
                    if color {
                        (0.299 * s[0] + 0.587 * s[1] + 0.114 * s[2]) as f32
                    } else {
                        s[0] as f32
                    }
                })
                .collect();
            (Pixels::F32(v), 32)
        }
        _ => {
            return Err(decode_err(
                path,
                "TIFF",
                format!("unsupported sample format for colour type {ct:?}"),
            ));
        }
    };
    Ok((
        GrayImage {
            width: w,
            height: h,
            pixels,
            significant_bits: bits,
        },
        info,
    ))
}
