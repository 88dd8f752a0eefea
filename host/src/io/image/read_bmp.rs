//! The BMP reader: 8-bit palette (and 24/32-bit BGR, converted to luma), uncompressed.

use super::{
    GrayImage, ImageError, ImageFormat, ImageHeader, Pixels, ReadInfo, ReadLimits, check_dims,
    decode_err, luma,
};
use std::path::Path;

/// The fields of a BITMAPINFOHEADER this reader uses, checked.
struct Head {
    data_off: usize,
    hdr: usize,
    width: usize,
    height: usize,
    top_down: bool,
    bpp: u16,
}

fn head(b: &[u8], path: &Path) -> Result<Head, ImageError> {
    let bad = |m: &str| decode_err(path, "BMP", m);
    let u16_at = |o: usize| -> Result<u16, ImageError> {
        b.get(o..o + 2)
            .map(|s| u16::from_le_bytes([s[0], s[1]]))
            .ok_or_else(|| bad("truncated header"))
    };
    let u32_at = |o: usize| -> Result<u32, ImageError> {
        b.get(o..o + 4)
            .map(|s| u32::from_le_bytes([s[0], s[1], s[2], s[3]]))
            .ok_or_else(|| bad("truncated header"))
    };
    let data_off = u32_at(10)? as usize;
    let hdr = u32_at(14)? as usize;
    if hdr < 40 {
        return Err(bad("OS/2 bitmap headers are not supported"));
    }
    let w = u32_at(18)? as i32;
    let h_raw = u32_at(22)? as i32;
    let bpp = u16_at(28)?;
    let compression = u32_at(30)?;
    if w <= 0 || h_raw == 0 || h_raw == i32::MIN {
        return Err(bad("invalid image size"));
    }
    // The sample layout is checked before anything is sized from the header (a bpp of 0 would
    // make every row zero bytes long, and the file "long enough" for any size).
    if !matches!(bpp, 8 | 24 | 32) {
        return Err(decode_err(
            path,
            "BMP",
            format!("{bpp}-bit bitmaps are not supported (8, 24 or 32)"),
        ));
    }
    if compression != 0 && !(compression == 3 && bpp == 32) {
        return Err(bad("compressed (RLE) bitmaps are not supported"));
    }
    Ok(Head {
        data_off,
        hdr,
        width: w as usize,
        height: h_raw.unsigned_abs() as usize,
        top_down: h_raw < 0,
        bpp,
    })
}

/// The size the header declares.
pub(super) fn header(b: &[u8], path: &Path) -> Result<ImageHeader, ImageError> {
    let h = head(b, path)?;
    Ok(ImageHeader {
        format: ImageFormat::Bmp,
        width: h.width as u32,
        height: h.height as u32,
    })
}

pub(super) fn decode(
    b: &[u8],
    path: &Path,
    lim: &ReadLimits,
) -> Result<(GrayImage, ReadInfo), ImageError> {
    let bad = |m: &str| decode_err(path, "BMP", m);
    let Head {
        data_off,
        hdr,
        width: w,
        height: h,
        top_down,
        bpp,
    } = head(b, path)?;
    check_dims(path, w as u32, h as u32, lim)?;
    let stride = (w * bpp as usize).div_ceil(32) * 4;
    let need = data_off.checked_add(
        stride
            .checked_mul(h)
            .ok_or_else(|| bad("image too large"))?,
    );
    if need.is_none_or(|n| n > b.len()) {
        return Err(bad("truncated pixel data"));
    }
    // The file holds every row: the output is no larger than the file.
    let mut out = vec![0u8; w * h];
    let color;
    if bpp == 8 {
        let mut n_colors = b
            .get(46..50)
            .map(|s| u32::from_le_bytes([s[0], s[1], s[2], s[3]]))
            .ok_or_else(|| bad("truncated header"))? as usize;
        if n_colors == 0 {
            n_colors = 256;
        }
        let pal_off = 14 + hdr;
        let mut pal = [[0u8; 3]; 256];
        let mut gray = true;
        for (i, p) in pal.iter_mut().enumerate().take(n_colors.min(256)) {
            let e = b
                .get(pal_off + 4 * i..pal_off + 4 * i + 3)
                .ok_or_else(|| bad("truncated palette"))?;
            *p = [e[2], e[1], e[0]];
            gray &= e[0] == e[1] && e[1] == e[2];
        }
        color = !gray;
        for y in 0..h {
            let src_y = if top_down { y } else { h - 1 - y };
            let row = &b[data_off + src_y * stride..];
            for x in 0..w {
                let [r, g, bl] = pal[row[x] as usize];
                out[y * w + x] = if gray {
                    r
                } else {
                    luma(r as f64, g as f64, bl as f64) as u8
                };
            }
        }
    } else {
        // 24 or 32 bits per pixel (checked by `head`).
        color = true;
        let step = bpp as usize / 8;
        for y in 0..h {
            let src_y = if top_down { y } else { h - 1 - y };
            let row = &b[data_off + src_y * stride..];
            for x in 0..w {
                let p = &row[x * step..];
                out[y * w + x] = luma(p[2] as f64, p[1] as f64, p[0] as f64) as u8;
            }
        }
    }
    Ok((
        GrayImage {
            width: w as u32,
            height: h as u32,
            pixels: Pixels::U8(out),
            significant_bits: 8,
        },
        ReadInfo {
            format: ImageFormat::Bmp,
            converted_from_color: color,
            dropped_alpha: false,
        },
    ))
}
