//! Gray-level images: the camera frames, pattern images and float maps of fringe3d.
//!
//! | format | read | write |
//! | --- | --- | --- |
//! | PNG | 1/2/4/8/16-bit gray, gray+alpha, RGB(A), palette | 8- and 16-bit gray |
//! | TIFF | 8/16-bit gray, 32-bit float gray, 8/16-bit RGB(A) | 32-bit float gray |
//! | BMP | 8-bit palette (and 24/32-bit BGR) | — |
//! | PGM (P5) | 8-bit, and 16-bit with maxval `2^bits − 1` (10, 12 bits stored unscaled) | — |
//! | NPY | `(h, w)` or `(h, w, 1)` arrays of uint8, uint16 (either byte order), float32 | — |
//!
//! PGM and NPY are raw: the samples are copied, not inflated, so they load fastest
//! (`docs/formats.md`).
//!
//! Colour input is converted to luma with the Rec. 601 weights
//! `Y = 0.299·R + 0.587·G + 0.114·B` (rounded to the nearest code) and
//! [`ReadInfo::converted_from_color`] is set so that callers can warn; an alpha channel is dropped
//! ([`ReadInfo::dropped_alpha`]). 16-bit PNGs whose `sBIT` chunk declares fewer significant bits
//! (12-bit sensors stored unscaled) report them in [`GrayImage::significant_bits`].
//!
//! Readers check the size a file declares before they allocate anything for its pixels: against
//! the size the caller expects ([`ReadLimits::size`]: the first image of a set, the calibrated
//! camera) and against a cap of [`MAX_PIXELS`] pixels (16384 × 16384, `render`'s largest size),
//! so a small file that declares a huge image (a decompression bomb) is refused at once.
//! [`read_header`] reads only the declared format and size.
//!
//! Writers go through [`crate::io::atomic::write_atomic`]: a file is either complete or absent.
//! The `encode_*` functions return the file bytes instead (for hashing or embedding).

use crate::io::input::{MAX_IMAGE_BYTES, open_regular, read_limited};
use std::io::{BufReader, Cursor, Read};
use std::path::{Path, PathBuf};

mod read_bmp;
mod read_npy;
mod read_pgm;
mod read_png;
mod read_raw;
mod read_tiff;

/// The most pixels an image may declare: 16384 × 16384 (the largest `render --size`).
pub const MAX_PIXELS: u64 = 1 << 28;

/// The most bytes a reader may decode an image into before it is reduced to gray (e.g. a
/// 16384 × 16384 gray float TIFF is 1 GiB; RGB(A) files of that size are refused).
pub const MAX_DECODED_BYTES: u64 = 2 << 30;

/// What a reader accepts: checked against the header, before any pixel is allocated.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ReadLimits {
    /// The most pixels (width × height) the image may declare.
    pub max_pixels: u64,
    /// The exact size the image must have, when the caller knows it.
    pub size: Option<(u32, u32)>,
}

impl Default for ReadLimits {
    fn default() -> Self {
        ReadLimits {
            max_pixels: MAX_PIXELS,
            size: None,
        }
    }
}

impl ReadLimits {
    /// The default cap and an exact expected size.
    pub fn sized(width: u32, height: u32) -> Self {
        ReadLimits {
            size: Some((width, height)),
            ..Self::default()
        }
    }
}

/// The format and size an image file declares.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ImageHeader {
    /// The format.
    pub format: ImageFormat,
    /// Declared width, pixels.
    pub width: u32,
    /// Declared height, pixels.
    pub height: u32,
}

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
    /// The file starts with none of the PNG, TIFF, BMP, PGM (P5) and NPY signatures (and is not
    /// a headerless `.raw` frame).
    #[error(
        "{path}: not a PNG, TIFF, BMP, PGM (P5) or NPY image (a headerless frame needs the .raw extension and a raw.toml beside it)"
    )]
    UnknownFormat {
        /// The file.
        path: PathBuf,
    },
    /// The file is damaged or uses a feature this reader does not handle.
    #[error("{path}: {format}: {message}")]
    Decode {
        /// The file.
        path: PathBuf,
        /// `PNG`, `TIFF`, `BMP`, `PGM` or `NPY`.
        format: &'static str,
        /// What went wrong.
        message: String,
    },
    /// The file declares more pixels than the reader accepts ([`ReadLimits::max_pixels`]).
    #[error(
        "{path}: declares {width}x{height} pixels, more than the {max} (16384x16384) an image may have; not decoded"
    )]
    TooLarge {
        /// The file.
        path: PathBuf,
        /// Declared width.
        width: u32,
        /// Declared height.
        height: u32,
        /// The cap.
        max: u64,
    },
    /// The file declares another size than the caller expects ([`ReadLimits::size`]).
    #[error("{path}: {width}x{height} pixels, expected {expected_width}x{expected_height}")]
    WrongSize {
        /// The file.
        path: PathBuf,
        /// Declared width.
        width: u32,
        /// Declared height.
        height: u32,
        /// Expected width.
        expected_width: u32,
        /// Expected height.
        expected_height: u32,
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
    /// Netpbm binary gray map (`P5`).
    Pgm,
    /// NumPy array file (`.npy`).
    Npy,
    /// Headerless samples (`.raw`), described by the folder's `raw.toml`.
    Raw,
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

/// Check a declared size against `lim`, before anything is allocated for it.
fn check_dims(path: &Path, width: u32, height: u32, lim: &ReadLimits) -> Result<(), ImageError> {
    if width == 0 || height == 0 {
        return Err(ImageError::Decode {
            path: path.to_path_buf(),
            format: "image",
            message: format!("declares an empty {width}x{height} image"),
        });
    }
    if u64::from(width) * u64::from(height) > lim.max_pixels {
        return Err(ImageError::TooLarge {
            path: path.to_path_buf(),
            width,
            height,
            max: lim.max_pixels,
        });
    }
    if let Some((ew, eh)) = lim.size
        && (ew, eh) != (width, height)
    {
        return Err(ImageError::WrongSize {
            path: path.to_path_buf(),
            width,
            height,
            expected_width: ew,
            expected_height: eh,
        });
    }
    Ok(())
}

/// The file's bytes: a regular file of at most [`MAX_IMAGE_BYTES`] (never a device or a FIFO).
fn read_file(path: &Path) -> Result<Vec<u8>, ImageError> {
    read_limited(path, MAX_IMAGE_BYTES).map_err(|source| ImageError::Io {
        path: path.to_path_buf(),
        source,
    })
}

/// Read a gray image from `path` (format by signature, not by extension; a headerless `.raw` frame by its extension and its folder's `raw.toml`), with the default
/// [`ReadLimits`].
pub fn read_gray(path: &Path) -> Result<(GrayImage, ReadInfo), ImageError> {
    read_gray_limited(path, &ReadLimits::default())
}

/// Read a gray image from `path`, refusing (before decoding) a declared size that `lim` does not
/// accept.
pub fn read_gray_limited(
    path: &Path,
    lim: &ReadLimits,
) -> Result<(GrayImage, ReadInfo), ImageError> {
    let bytes = read_file(path)?;
    decode_gray_limited(&bytes, path, lim)
}

/// The format and declared size of the image at `path`, from its header only (the pixels are
/// not read).
pub fn read_header(path: &Path) -> Result<ImageHeader, ImageError> {
    if read_raw::is_raw(path) {
        return read_raw::header(path);
    }
    let io = |source| ImageError::Io {
        path: path.to_path_buf(),
        source,
    };
    let (mut f, _) = open_regular(path).map_err(io)?;
    // 64 bytes hold a PNG's, a BMP's or a TIFF's first fields; a PGM header (comments included)
    // may run to its cap, and an NPY header says its own length (numpy writes about 128 bytes).
    let mut head = Vec::with_capacity(256);
    (&mut f).take(64).read_to_end(&mut head).map_err(io)?;
    // The signature is in the first bytes, so reading more below does not change it.
    let format = format_of(&head);
    let want = match format {
        Some(ImageFormat::Pgm) => read_pgm::MAX_HEADER + 1,
        Some(ImageFormat::Npy) => crate::io::npy::header_span(&head),
        _ => 0,
    };
    if want > head.len() {
        let more = (want - head.len()) as u64;
        (&mut f).take(more).read_to_end(&mut head).map_err(io)?;
    }
    match format {
        Some(ImageFormat::Png) => read_png::header(&head, path),
        Some(ImageFormat::Bmp) => read_bmp::header(&head, path),
        Some(ImageFormat::Pgm) => read_pgm::header(&head, path),
        Some(ImageFormat::Npy) => read_npy::header(&head, path),
        Some(ImageFormat::Tiff) => {
            use std::io::Seek;
            f.seek(std::io::SeekFrom::Start(0)).map_err(io)?;
            read_tiff::header(BufReader::new(f), path)
        }
        Some(ImageFormat::Raw) | None => Err(ImageError::UnknownFormat {
            path: path.to_path_buf(),
        }),
    }
}

/// The format a file's first bytes announce.
fn format_of(bytes: &[u8]) -> Option<ImageFormat> {
    if bytes.starts_with(b"\x89PNG\r\n\x1a\n") {
        Some(ImageFormat::Png)
    } else if bytes.starts_with(b"II*\0")
        || bytes.starts_with(b"MM\0*")
        || bytes.starts_with(b"II+\0")
        || bytes.starts_with(b"MM\0+")
    {
        Some(ImageFormat::Tiff)
    } else if bytes.starts_with(b"BM") {
        Some(ImageFormat::Bmp)
    } else if bytes.starts_with(b"P5") || bytes.starts_with(b"P2") {
        Some(ImageFormat::Pgm)
    } else if bytes.starts_with(b"\x93NUMPY") {
        Some(ImageFormat::Npy)
    } else {
        None
    }
}

/// Decode a gray image from file bytes; `path` is used in error messages only.
pub fn decode_gray(bytes: &[u8], path: &Path) -> Result<(GrayImage, ReadInfo), ImageError> {
    decode_gray_limited(bytes, path, &ReadLimits::default())
}

/// Decode a gray image from file bytes within `lim`; `path` is used in error messages only.
pub fn decode_gray_limited(
    bytes: &[u8],
    path: &Path,
    lim: &ReadLimits,
) -> Result<(GrayImage, ReadInfo), ImageError> {
    if read_raw::is_raw(path) {
        return read_raw::decode(bytes, path, lim);
    }
    match format_of(bytes) {
        Some(ImageFormat::Png) => read_png::decode(bytes, path, lim),
        Some(ImageFormat::Tiff) => read_tiff::decode(bytes, path, lim),
        Some(ImageFormat::Bmp) => read_bmp::decode(bytes, path, lim),
        Some(ImageFormat::Pgm) => read_pgm::decode(bytes, path, lim),
        Some(ImageFormat::Npy) => read_npy::decode(bytes, path, lim),
        Some(ImageFormat::Raw) | None => Err(ImageError::UnknownFormat {
            path: path.to_path_buf(),
        }),
    }
}

/// Rec. 601 luma of 8-bit or 16-bit samples, rounded to the nearest code.
fn luma(r: f64, g: f64, b: f64) -> f64 {
    (0.299 * r + 0.587 * g + 0.114 * b).round()
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

/// The bytes of a 1-bit gray PNG (a DLP's binary pattern): pixel `i` is white where
/// `data[i] != 0`. Rows are packed 8 pixels a byte, most significant bit first (PNG's order).
pub fn encode_png_u1(
    path: &Path,
    width: u32,
    height: u32,
    data: &[u8],
) -> Result<Vec<u8>, ImageError> {
    check_size(path, data.len(), width, height)?;
    let w = width as usize;
    let stride = w.div_ceil(8);
    let mut packed = vec![0u8; stride * height as usize];
    for (src, dst) in data
        .chunks_exact(w.max(1))
        .zip(packed.chunks_exact_mut(stride.max(1)))
    {
        for (x, &v) in src.iter().enumerate() {
            if v != 0 {
                dst[x / 8] |= 0x80 >> (x % 8);
            }
        }
    }
    png_bytes(path, width, height, png::BitDepth::One, None, &packed)
}

/// Write a 1-bit gray PNG ([`encode_png_u1`]).
pub fn write_png_u1(path: &Path, width: u32, height: u32, data: &[u8]) -> Result<(), ImageError> {
    write_bytes(path, &encode_png_u1(path, width, height, data)?)
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
