//! Gray-level images: the camera frames, pattern images and float maps of fringe3d.
//!
//! | format | read | write |
//! | --- | --- | --- |
//! | PNG | 1/2/4/8/16-bit gray, gray+alpha, RGB(A), palette | 8- and 16-bit gray |
//! | TIFF | 8/16-bit gray, 32-bit float gray, 8/16-bit RGB(A) | 32-bit float gray |
//! | BMP | 8-bit palette (and 24/32-bit BGR) | — |
//!
//! Colour input is converted to luma with the Rec. 601 weights
//! `Y = 0.299·R + 0.587·G + 0.114·B` (rounded to the nearest code) and
//! [`ReadInfo::converted_from_color`] is set so that callers can warn; an alpha channel is dropped
//! ([`ReadInfo::dropped_alpha`]). 16-bit PNGs whose `sBIT` chunk declares fewer significant bits
//! (12-bit sensors stored unscaled) report them in [`GrayImage::significant_bits`].
//!
//! Writers go through [`crate::io::atomic::write_atomic`]: a file is either complete or absent.
//! The `encode_*` functions return the file bytes instead (for hashing or embedding).

use std::io::{BufReader, Cursor, Read};
use std::path::{Path, PathBuf};

/// Why an image could not be read or written. Every variant names the file.
#[derive(Debug, thiserror::Error)]
pub enum ImageError {
    /// The file could not be opened or read.
    #[error("{path}: cannot read: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The OS error.
        source: std::io::Error,
    },
    /// The file starts with neither the PNG, the TIFF nor the BMP signature.
    #[error("{path}: not a PNG, TIFF or BMP image")]
    UnknownFormat {
        /// The file.
        path: PathBuf,
    },
    /// The file is damaged or uses a feature this reader does not handle.
    #[error("{path}: {format}: {message}")]
    Decode {
        /// The file.
        path: PathBuf,
        /// `PNG`, `TIFF` or `BMP`.
        format: &'static str,
        /// What went wrong.
        message: String,
    },
    /// The pixel buffer handed to a writer does not match the stated size.
    #[error("{path}: {got} samples given for a {width}x{height} image (need {need})")]
    Size {
        /// The file.
        path: PathBuf,
        /// Samples given.
        got: usize,
        /// Width, pixels.
        width: u32,
        /// Height, pixels.
        height: u32,
        /// Samples needed.
        need: usize,
    },
    /// The image could not be encoded or written.
    #[error("{path}: cannot write: {message}")]
    Write {
        /// The file.
        path: PathBuf,
        /// What went wrong.
        message: String,
    },
}

/// The file formats read here.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ImageFormat {
    /// Portable Network Graphics.
    Png,
    /// Tagged Image File Format.
    Tiff,
    /// Windows bitmap.
    Bmp,
}

/// Samples of a gray image, row-major, top row first.
#[derive(Clone, Debug, PartialEq)]
pub enum Pixels {
    /// 8-bit codes.
    U8(Vec<u8>),
    /// 16-bit codes (also 12-bit data stored in 16-bit containers).
    U16(Vec<u16>),
    /// 32-bit floats (phase maps, depth maps; NaN marks invalid pixels by fringe3d convention).
    F32(Vec<f32>),
}

impl Pixels {
    /// Number of samples.
    pub fn len(&self) -> usize {
        match self {
            Pixels::U8(v) => v.len(),
            Pixels::U16(v) => v.len(),
            Pixels::F32(v) => v.len(),
        }
    }

    /// `true` if there are no samples.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Sample `i` as f64.
    pub fn get_f64(&self, i: usize) -> Option<f64> {
        match self {
            Pixels::U8(v) => v.get(i).map(|&x| x as f64),
            Pixels::U16(v) => v.get(i).map(|&x| x as f64),
            Pixels::F32(v) => v.get(i).map(|&x| x as f64),
        }
    }
}

/// A single-channel image.
#[derive(Clone, Debug, PartialEq)]
pub struct GrayImage {
    /// Width, pixels.
    pub width: u32,
    /// Height, pixels.
    pub height: u32,
    /// The samples.
    pub pixels: Pixels,
    /// Significant bits per sample: 8 or 16 for integer images unless the file says fewer
    /// (PNG `sBIT`), 32 for float images.
    pub significant_bits: u8,
}

/// What reading an image found out besides the pixels.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ReadInfo {
    /// The file's format.
    pub format: ImageFormat,
    /// The file held colour samples, converted to Rec. 601 luma: callers should warn.
    pub converted_from_color: bool,
    /// The file had an alpha channel, which was dropped.
    pub dropped_alpha: bool,
}

fn decode_err(path: &Path, format: &'static str, message: impl std::fmt::Display) -> ImageError {
    ImageError::Decode {
        path: path.to_path_buf(),
        format,
        message: message.to_string(),
    }
}

/// Read a gray image from `path` (format by signature, not by extension).
pub fn read_gray(path: &Path) -> Result<(GrayImage, ReadInfo), ImageError> {
    let mut bytes = Vec::new();
    std::fs::File::open(path)
        .and_then(|f| BufReader::new(f).read_to_end(&mut bytes))
        .map_err(|source| ImageError::Io {
            path: path.to_path_buf(),
            source,
        })?;
    decode_gray(&bytes, path)
}

/// Decode a gray image from file bytes; `path` is used in error messages only.
pub fn decode_gray(bytes: &[u8], path: &Path) -> Result<(GrayImage, ReadInfo), ImageError> {
    if bytes.starts_with(b"\x89PNG\r\n\x1a\n") {
        decode_png(bytes, path)
    } else if bytes.starts_with(b"II*\0")
        || bytes.starts_with(b"MM\0*")
        || bytes.starts_with(b"II+\0")
        || bytes.starts_with(b"MM\0+")
    {
        decode_tiff(bytes, path)
    } else if bytes.starts_with(b"BM") {
        decode_bmp(bytes, path)
    } else {
        Err(ImageError::UnknownFormat {
            path: path.to_path_buf(),
        })
    }
}

/// Rec. 601 luma of 8-bit or 16-bit samples, rounded to the nearest code.
fn luma(r: f64, g: f64, b: f64) -> f64 {
    (0.299 * r + 0.587 * g + 0.114 * b).round()
}

fn decode_png(bytes: &[u8], path: &Path) -> Result<(GrayImage, ReadInfo), ImageError> {
    let mut dec = png::Decoder::new(Cursor::new(bytes));
    dec.set_transformations(png::Transformations::EXPAND);
    let mut reader = dec.read_info().map_err(|e| decode_err(path, "PNG", e))?;
    let sbit = reader.info().sbit.as_ref().map(|s| s.to_vec());
    let size = reader
        .output_buffer_size()
        .ok_or_else(|| decode_err(path, "PNG", "image too large for this machine"))?;
    let mut buf = vec![0u8; size];
    let info = reader
        .next_frame(&mut buf)
        .map_err(|e| decode_err(path, "PNG", e))?;
    buf.truncate(info.buffer_size());
    let (w, h) = (info.width, info.height);
    let n = w as usize * h as usize;
    let (channels, color, alpha) = match info.color_type {
        png::ColorType::Grayscale => (1, false, false),
        png::ColorType::GrayscaleAlpha => (2, false, true),
        png::ColorType::Rgb => (3, true, false),
        png::ColorType::Rgba => (4, true, true),
        png::ColorType::Indexed => return Err(decode_err(path, "PNG", "palette was not expanded")),
    };
    let sixteen = info.bit_depth == png::BitDepth::Sixteen;
    let line = info.line_size;
    let bps = if sixteen { 2 } else { 1 };
    let sample = |y: usize, x: usize, c: usize| -> f64 {
        let off = y * line + (x * channels + c) * bps;
        if sixteen {
            u16::from_be_bytes([buf[off], buf[off + 1]]) as f64
        } else {
            buf[off] as f64
        }
    };
    if buf.len() < line * h as usize {
        return Err(decode_err(path, "PNG", "truncated image data"));
    }
    let mut out16 = Vec::new();
    let mut out8 = Vec::new();
    if channels == 1 {
        // Grayscale (the common case): the rows as they are, without the per-sample path below.
        let rows = buf
            .chunks_exact(line)
            .take(h as usize)
            .map(|r| &r[..w as usize * bps]);
        if sixteen {
            out16.reserve_exact(n);
            for r in rows {
                out16.extend(r.chunks_exact(2).map(|b| u16::from_be_bytes([b[0], b[1]])));
            }
        } else {
            out8.reserve_exact(n);
            for r in rows {
                out8.extend_from_slice(r);
            }
        }
    } else {
        for y in 0..h as usize {
            for x in 0..w as usize {
                let v = if color {
                    luma(sample(y, x, 0), sample(y, x, 1), sample(y, x, 2))
                } else {
                    sample(y, x, 0)
                };
                if sixteen {
                    out16.push(v as u16);
                } else {
                    out8.push(v as u8);
                }
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
    debug_assert_eq!(pixels.len(), n);
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

fn decode_tiff(bytes: &[u8], path: &Path) -> Result<(GrayImage, ReadInfo), ImageError> {
    use tiff::ColorType as C;
    use tiff::decoder::DecodingResult as D;
    let err = |e: tiff::TiffError| decode_err(path, "TIFF", e);
    let mut dec = tiff::decoder::Decoder::new(Cursor::new(bytes)).map_err(err)?;
    let (w, h) = dec.dimensions().map_err(err)?;
    let ct = dec.colortype().map_err(err)?;
    let (channels, color, alpha) = match ct {
        C::Gray(_) => (1usize, false, false),
        C::GrayA(_) => (2, false, true),
        C::RGB(_) => (3, true, false),
        C::RGBA(_) => (4, true, true),
        other => {
            return Err(decode_err(
                path,
                "TIFF",
                format!("unsupported colour type {other:?}"),
            ));
        }
    };
    let data = dec.read_image().map_err(err)?;
    let n = w as usize * h as usize;
    let short = || decode_err(path, "TIFF", "fewer samples than the image size needs");
    let info = ReadInfo {
        format: ImageFormat::Tiff,
        converted_from_color: color,
        dropped_alpha: alpha,
    };
    macro_rules! reduce {
        ($v:expr, $conv:expr) => {{
            let v = $v;
            if v.len() < n * channels {
                return Err(short());
            }
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

fn decode_bmp(b: &[u8], path: &Path) -> Result<(GrayImage, ReadInfo), ImageError> {
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
    let (w, top_down, h) = (w as usize, h_raw < 0, h_raw.unsigned_abs() as usize);
    if compression != 0 && !(compression == 3 && bpp == 32) {
        return Err(bad("compressed (RLE) bitmaps are not supported"));
    }
    let stride = (w * bpp as usize).div_ceil(32) * 4;
    let need = data_off.checked_add(
        stride
            .checked_mul(h)
            .ok_or_else(|| bad("image too large"))?,
    );
    if need.is_none_or(|n| n > b.len()) {
        return Err(bad("truncated pixel data"));
    }
    let mut out = vec![0u8; w * h];
    let color;
    match bpp {
        8 => {
            let mut n_colors = u32_at(46)? as usize;
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
        }
        24 | 32 => {
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
        other => {
            return Err(decode_err(
                path,
                "BMP",
                format!("{other}-bit bitmaps are not supported"),
            ));
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

fn check_size(path: &Path, got: usize, width: u32, height: u32) -> Result<(), ImageError> {
    let need = width as usize * height as usize;
    if got != need || width == 0 || height == 0 {
        return Err(ImageError::Size {
            path: path.to_path_buf(),
            got,
            width,
            height,
            need,
        });
    }
    Ok(())
}

fn png_bytes(
    path: &Path,
    width: u32,
    height: u32,
    depth: png::BitDepth,
    sbit: Option<u8>,
    data: &[u8],
) -> Result<Vec<u8>, ImageError> {
    let werr = |e: png::EncodingError| ImageError::Write {
        path: path.to_path_buf(),
        message: e.to_string(),
    };
    let mut out = Vec::with_capacity(data.len() / 2 + 1024);
    {
        let mut enc = png::Encoder::new(&mut out, width, height);
        enc.set_color(png::ColorType::Grayscale);
        enc.set_depth(depth);
        enc.set_compression(png::Compression::Fast);
        let mut wr = enc.write_header().map_err(werr)?;
        if let Some(bits) = sbit {
            wr.write_chunk(png::chunk::sBIT, &[bits]).map_err(werr)?;
        }
        wr.write_image_data(data).map_err(werr)?;
        wr.finish().map_err(werr)?;
    }
    Ok(out)
}

/// The bytes of an 8-bit gray PNG.
pub fn encode_png_u8(
    path: &Path,
    width: u32,
    height: u32,
    data: &[u8],
) -> Result<Vec<u8>, ImageError> {
    check_size(path, data.len(), width, height)?;
    png_bytes(path, width, height, png::BitDepth::Eight, None, data)
}

/// The bytes of a 16-bit gray PNG. `significant_bits` (1..=16) below 16 writes an `sBIT` chunk:
/// the values are stored unscaled (a 12-bit camera's codes stay in 0..=4095).
pub fn encode_png_u16(
    path: &Path,
    width: u32,
    height: u32,
    data: &[u16],
    significant_bits: u8,
) -> Result<Vec<u8>, ImageError> {
    check_size(path, data.len(), width, height)?;
    let mut bytes = Vec::with_capacity(data.len() * 2);
    for v in data {
        bytes.extend_from_slice(&v.to_be_bytes());
    }
    let sbit = (1..16)
        .contains(&significant_bits)
        .then_some(significant_bits);
    png_bytes(path, width, height, png::BitDepth::Sixteen, sbit, &bytes)
}

/// The bytes of a 32-bit float gray TIFF (uncompressed, little-endian).
pub fn encode_tiff_f32(
    path: &Path,
    width: u32,
    height: u32,
    data: &[f32],
) -> Result<Vec<u8>, ImageError> {
    check_size(path, data.len(), width, height)?;
    let werr = |e: tiff::TiffError| ImageError::Write {
        path: path.to_path_buf(),
        message: e.to_string(),
    };
    let mut cur = Cursor::new(Vec::with_capacity(data.len() * 4 + 1024));
    {
        let mut enc = tiff::encoder::TiffEncoder::new(&mut cur).map_err(werr)?;
        enc.write_image::<tiff::encoder::colortype::Gray32Float>(width, height, data)
            .map_err(werr)?;
    }
    Ok(cur.into_inner())
}

/// Write `bytes` to `path` atomically.
pub fn write_bytes(path: &Path, bytes: &[u8]) -> Result<(), ImageError> {
    crate::io::atomic::write_atomic(path, |w| w.write_all(bytes)).map_err(|e| ImageError::Write {
        path: path.to_path_buf(),
        message: e.to_string(),
    })
}

/// Write an 8-bit gray PNG.
pub fn write_png_u8(path: &Path, width: u32, height: u32, data: &[u8]) -> Result<(), ImageError> {
    write_bytes(path, &encode_png_u8(path, width, height, data)?)
}

/// Write a 16-bit gray PNG (see [`encode_png_u16`] for `significant_bits`).
pub fn write_png_u16(
    path: &Path,
    width: u32,
    height: u32,
    data: &[u16],
    significant_bits: u8,
) -> Result<(), ImageError> {
    write_bytes(
        path,
        &encode_png_u16(path, width, height, data, significant_bits)?,
    )
}

/// Write a 32-bit float gray TIFF.
pub fn write_tiff_f32(
    path: &Path,
    width: u32,
    height: u32,
    data: &[f32],
) -> Result<(), ImageError> {
    write_bytes(path, &encode_tiff_f32(path, width, height, data)?)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn png_u16_roundtrip_with_sbit() {
        let p = Path::new("mem.png");
        let data: Vec<u16> = (0..12).map(|i| i * 300).collect();
        let b = encode_png_u16(p, 4, 3, &data, 12).unwrap();
        let (img, info) = decode_gray(&b, p).unwrap();
        assert_eq!(img.pixels, Pixels::U16(data));
        assert_eq!(img.significant_bits, 12);
        assert!(!info.converted_from_color);
    }

    #[test]
    fn tiff_f32_roundtrip_keeps_nan() {
        let p = Path::new("mem.tif");
        let data = vec![1.5f32, f32::NAN, -3.25, 1e-7, 0.0, 7.0];
        let b = encode_tiff_f32(p, 3, 2, &data).unwrap();
        let (img, _) = decode_gray(&b, p).unwrap();
        let Pixels::F32(v) = img.pixels else {
            panic!("not f32")
        };
        assert_eq!(v.len(), 6);
        for (a, b) in v.iter().zip(&data) {
            assert!(a == b || (a.is_nan() && b.is_nan()));
        }
    }

    #[test]
    fn bmp_palette_and_errors() {
        // 2x2 8-bit gray-palette bottom-up BMP.
        let mut b = Vec::new();
        let pal = 256 * 4;
        let off = 14 + 40 + pal;
        b.extend_from_slice(b"BM");
        b.extend_from_slice(&((off + 8) as u32).to_le_bytes());
        b.extend_from_slice(&[0; 4]);
        b.extend_from_slice(&(off as u32).to_le_bytes());
        b.extend_from_slice(&40u32.to_le_bytes());
        b.extend_from_slice(&2i32.to_le_bytes());
        b.extend_from_slice(&2i32.to_le_bytes());
        b.extend_from_slice(&1u16.to_le_bytes());
        b.extend_from_slice(&8u16.to_le_bytes());
        b.extend_from_slice(&[0; 24]);
        for i in 0..256u32 {
            let g = i as u8;
            b.extend_from_slice(&[g, g, g, 0]);
        }
        b.extend_from_slice(&[10, 20, 0, 0, 30, 40, 0, 0]); // bottom row first
        let (img, info) = decode_gray(&b, Path::new("a.bmp")).unwrap();
        assert_eq!(img.pixels, Pixels::U8(vec![30, 40, 10, 20]));
        assert!(!info.converted_from_color);
        assert!(decode_gray(&b[..60], Path::new("t.bmp")).is_err());
        assert!(decode_gray(b"hello", Path::new("x")).is_err());
    }

    #[test]
    fn color_png_is_converted() {
        let p = Path::new("c.png");
        let mut out = Vec::new();
        {
            let mut enc = png::Encoder::new(&mut out, 1, 1);
            enc.set_color(png::ColorType::Rgb);
            enc.set_depth(png::BitDepth::Eight);
            let mut w = enc.write_header().unwrap();
            w.write_image_data(&[255, 0, 0]).unwrap();
        }
        let (img, info) = decode_gray(&out, p).unwrap();
        assert_eq!(img.pixels, Pixels::U8(vec![76]));
        assert!(info.converted_from_color);
    }

    fn tiff_bytes<C: tiff::encoder::colortype::ColorType>(
        w: u32,
        h: u32,
        data: &[C::Inner],
    ) -> Vec<u8>
    where
        [C::Inner]: tiff::encoder::TiffValue,
    {
        let mut cur = Cursor::new(Vec::new());
        tiff::encoder::TiffEncoder::new(&mut cur)
            .unwrap()
            .write_image::<C>(w, h, data)
            .unwrap();
        cur.into_inner()
    }

    #[test]
    fn tiff_integer_gray_and_rgb_are_read() {
        use tiff::encoder::colortype::{Gray8, Gray16, RGB8};
        let p = Path::new("t.tif");
        let (img, info) = decode_gray(&tiff_bytes::<Gray8>(2, 1, &[3, 250]), p).unwrap();
        assert_eq!(
            (img.pixels, img.significant_bits, info.format),
            (Pixels::U8(vec![3, 250]), 8, ImageFormat::Tiff)
        );
        let (img, _) = decode_gray(&tiff_bytes::<Gray16>(1, 2, &[1000, 65535]), p).unwrap();
        assert_eq!(img.pixels, Pixels::U16(vec![1000, 65535]));
        let (img, info) = decode_gray(&tiff_bytes::<RGB8>(1, 1, &[0, 255, 0]), p).unwrap();
        assert_eq!(img.pixels, Pixels::U8(vec![150]));
        assert!(info.converted_from_color);
        let e = decode_gray(&tiff_bytes::<Gray8>(2, 1, &[3, 250])[..20], p)
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("t.tif"), "{e}");
    }

    #[test]
    fn writers_check_sizes_and_name_the_file() {
        let e = encode_png_u8(Path::new("x.png"), 3, 3, &[0; 8])
            .unwrap_err()
            .to_string();
        assert!(e.contains("x.png") && e.contains("need 9"), "{e}");
        let dir = std::env::temp_dir().join(format!("fringe3d-image-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let f = dir.join("a.png");
        write_png_u8(&f, 2, 2, &[1, 2, 3, 4]).unwrap();
        let (img, _) = read_gray(&f).unwrap();
        assert_eq!(img.pixels, Pixels::U8(vec![1, 2, 3, 4]));
        let missing = read_gray(&dir.join("missing.png")).unwrap_err().to_string();
        assert!(missing.contains("missing.png"));
        let _ = std::fs::remove_dir_all(&dir);
    }
}
