//! The PNG reader: gray, gray + alpha, RGB(A) and palette images of any bit depth, decoded row by
//! row so that memory holds the gray result, not the file's colour samples.

use super::{
    GrayImage, ImageError, ImageFormat, ImageHeader, Pixels, ReadInfo, ReadLimits, check_dims,
    decode_err, luma,
};
use std::io::Cursor;
use std::path::Path;

/// The size an IHDR chunk declares (the first chunk of every PNG, right after the signature).
pub(super) fn header(bytes: &[u8], path: &Path) -> Result<ImageHeader, ImageError> {
    match bytes.get(12..24) {
        Some(h) if &h[..4] == b"IHDR" => Ok(ImageHeader {
            format: ImageFormat::Png,
            width: u32::from_be_bytes([h[4], h[5], h[6], h[7]]),
            height: u32::from_be_bytes([h[8], h[9], h[10], h[11]]),
        }),
        _ => Err(decode_err(
            path,
            "PNG",
            "no image header (IHDR) at the start",
        )),
    }
}

pub(super) fn decode(
    bytes: &[u8],
    path: &Path,
    lim: &ReadLimits,
) -> Result<(GrayImage, ReadInfo), ImageError> {
    let err = |e: png::DecodingError| decode_err(path, "PNG", e);
    let mut dec = png::Decoder::new(Cursor::new(bytes));
    dec.set_transformations(png::Transformations::EXPAND);
    let mut reader = dec.read_info().map_err(err)?;
    let (w, h) = reader.info().size();
    // Before a single pixel is allocated: the declared size against the caller's expectation
    // and the pixel cap.
    check_dims(path, w, h, lim)?;
    let sbit = reader.info().sbit.as_ref().map(|s| s.to_vec());
    let interlaced = reader.info().interlaced;
    let (color_type, bit_depth) = reader.output_color_type();
    let (channels, color, alpha) = match color_type {
        png::ColorType::Grayscale => (1, false, false),
        png::ColorType::GrayscaleAlpha => (2, false, true),
        png::ColorType::Rgb => (3, true, false),
        png::ColorType::Rgba => (4, true, true),
        png::ColorType::Indexed => return Err(decode_err(path, "PNG", "palette was not expanded")),
    };
    let sixteen = bit_depth == png::BitDepth::Sixteen;
    let bps = if sixteen { 2 } else { 1 };
    let (wu, hu) = (w as usize, h as usize);
    let line = reader
        .output_line_size(w)
        .filter(|&l| l >= wu * channels * bps)
        .ok_or_else(|| decode_err(path, "PNG", "image too large for this machine"))?;
    let n = wu * hu;
    let mut out16: Vec<u16> = Vec::new();
    let mut out8: Vec<u8> = Vec::new();
    if sixteen {
        out16.reserve_exact(n);
    } else {
        out8.reserve_exact(n);
    }
    // One decoded row (top to bottom) into the gray output.
    let mut take_row = |r: &[u8]| {
        let r = &r[..wu * channels * bps];
        if channels == 1 {
            // Grayscale (the common case): the row as it is.
            if sixteen {
                out16.extend(r.chunks_exact(2).map(|b| u16::from_be_bytes([b[0], b[1]])));
            } else {
                out8.extend_from_slice(r);
            }
            return;
        }
        let sample = |x: usize, c: usize| -> f64 {
            let off = (x * channels + c) * bps;
            if sixteen {
                u16::from_be_bytes([r[off], r[off + 1]]) as f64
            } else {
                r[off] as f64
            }
        };
        for x in 0..wu {
            let v = if color {
                luma(sample(x, 0), sample(x, 1), sample(x, 2))
            } else {
                sample(x, 0)
            };
            if sixteen {
                out16.push(v as u16);
            } else {
                out8.push(v as u8);
            }
        }
    };
    if interlaced {
        // Adam7 passes arrive out of row order: the whole frame is needed (bounded by the checks
        // above: at most the pixel cap times 8 bytes).
        let size = reader
            .output_buffer_size()
            .filter(|&s| s >= line * hu)
            .ok_or_else(|| decode_err(path, "PNG", "image too large for this machine"))?;
        let mut buf = vec![0u8; size];
        reader.next_frame(&mut buf).map_err(err)?;
        for r in buf.chunks_exact(line).take(hu) {
            take_row(r);
        }
    } else {
        for _ in 0..hu {
            match reader.next_row().map_err(err)? {
                Some(row) if row.data().len() >= wu * channels * bps => take_row(row.data()),
                _ => return Err(decode_err(path, "PNG", "truncated image data")),
            }
        }
    }
    let full_bits = if sixteen { 16 } else { 8 };
    // sBIT: one byte per channel; for gray the first is the gray channel's significant bits.
    let significant_bits = match sbit.as_deref() {
        Some([b, ..]) if !color && *b >= 1 && *b <= full_bits => *b,
        _ => full_bits,
    };
    let pixels = if sixteen {
        Pixels::U16(out16)
    } else {
        Pixels::U8(out8)
    };
    if pixels.len() != n {
        return Err(decode_err(path, "PNG", "truncated image data"));
    }
    Ok((
        GrayImage {
            width: w,
            height: h,
            pixels,
            significant_bits,
        },
        ReadInfo {
            format: ImageFormat::Png,
            converted_from_color: color,
            dropped_alpha: alpha,
        },
    ))
}
