//! Loading the ordered images of one pattern set, with every consistency check a scan needs:
//! the count matches the pattern set, all sizes and bit depths agree, no float images. Every
//! error names the offending file.

use crate::io::image::{GrayImage, ImageError, Pixels, ReadLimits, read_gray_limited, read_header};
use rayon::prelude::*;
use std::path::{Path, PathBuf};

/// The samples of every image of a set, in set order.
#[derive(Clone, Debug, PartialEq)]
pub enum Frames {
    /// 8-bit images.
    U8(Vec<Vec<u8>>),
    /// 16-bit containers (16-bit or fewer significant bits).
    U16(Vec<Vec<u16>>),
}

impl Frames {
    /// Number of images.
    pub fn len(&self) -> usize {
        match self {
            Frames::U8(v) => v.len(),
            Frames::U16(v) => v.len(),
        }
    }

    /// `true` if there are none.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// A loaded, checked image set.
#[derive(Clone, Debug)]
pub struct ImageSet {
    /// Width, pixels.
    pub width: u32,
    /// Height, pixels.
    pub height: u32,
    /// Significant bits per sample (8, or 9 to 16 for 16-bit containers).
    pub bits: u8,
    /// The samples.
    pub frames: Frames,
    /// The files, in set order.
    pub paths: Vec<PathBuf>,
    /// Things the user should know (colour images converted to luma, alpha dropped).
    pub warnings: Vec<String>,
}

/// Why an image set could not be loaded.
#[derive(Debug, thiserror::Error)]
pub enum ImageSetError {
    /// An image could not be read.
    #[error(transparent)]
    Image(#[from] ImageError),
    /// The number of images differs from the pattern set's.
    #[error("{what}: the pattern set has {expected} images but {got} were given")]
    Count {
        /// Where the list came from.
        what: String,
        /// Images in the pattern set.
        expected: usize,
        /// Images given.
        got: usize,
    },
    /// An image's size differs from the first image's.
    #[error(
        "{path}: {width}x{height} pixels, but {first} is {w0}x{h0}: all images of a set must have one size"
    )]
    Size {
        /// The offending image.
        path: PathBuf,
        /// Its width.
        width: u32,
        /// Its height.
        height: u32,
        /// The first image.
        first: PathBuf,
        /// The first image's width.
        w0: u32,
        /// The first image's height.
        h0: u32,
    },
    /// An image's bit depth differs from the first image's.
    #[error(
        "{path}: {bits}-bit samples, but {first} has {bits0}-bit samples: all images of a set must have one bit depth"
    )]
    Depth {
        /// The offending image.
        path: PathBuf,
        /// Its depth.
        bits: u8,
        /// The first image.
        first: PathBuf,
        /// The first image's depth.
        bits0: u8,
    },
    /// A float image where camera samples are expected.
    #[error("{path}: floating-point image; camera images must be 8- or 16-bit integer samples")]
    Float {
        /// The offending image.
        path: PathBuf,
    },
    /// A folder holds no usable images, or cannot be listed.
    #[error("{path}: {message}")]
    Folder {
        /// The folder.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
}

/// The image files of a folder (PNG, TIFF, BMP, PGM, headerless `.raw` by extension), sorted
/// by name; its `.npy`
/// files only when it holds none of those: `render` keeps ground-truth arrays (`points.npy`)
/// beside its PNG frames, and they are not frames.
pub fn list_folder(dir: &Path) -> Result<Vec<PathBuf>, ImageSetError> {
    let rd = std::fs::read_dir(dir).map_err(|e| ImageSetError::Folder {
        path: dir.to_path_buf(),
        message: format!("cannot list: {e}"),
    })?;
    let mut v: Vec<PathBuf> = rd
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| {
            p.is_file()
                && p.extension()
                    .and_then(|e| e.to_str())
                    .map(|e| {
                        matches!(
                            e.to_ascii_lowercase().as_str(),
                            "png" | "tif" | "tiff" | "bmp" | "pgm" | "npy" | "raw"
                        )
                    })
                    .unwrap_or(false)
        })
        .collect();
    let is_npy = |p: &PathBuf| {
        p.extension()
            .and_then(|e| e.to_str())
            .is_some_and(|e| e.eq_ignore_ascii_case("npy"))
    };
    if v.iter().any(|p| !is_npy(p)) {
        v.retain(|p| !is_npy(p));
    }
    v.sort();
    if v.is_empty() {
        return Err(ImageSetError::Folder {
            path: dir.to_path_buf(),
            message: "no PNG, TIFF, BMP, PGM, RAW or NPY images in this folder".into(),
        });
    }
    Ok(v)
}

/// Load `paths` (in set order) and check them against each other and against `expected` images.
/// `what` names the list's origin in a count error (e.g. the pattern-set file).
pub fn load(paths: &[PathBuf], expected: usize, what: &str) -> Result<ImageSet, ImageSetError> {
    if paths.len() != expected {
        return Err(ImageSetError::Count {
            what: what.to_string(),
            expected,
            got: paths.len(),
        });
    }
    // Every declared size first, from the headers alone: all must be the first image's (which
    // is itself capped), so nothing larger than one frame per image is ever decoded.
    let Some(first) = paths.first() else {
        return Err(ImageSetError::Count {
            what: what.to_string(),
            expected,
            got: 0,
        });
    };
    let h0 = read_header(first)?;
    for p in &paths[1..] {
        let h = read_header(p)?;
        if (h.width, h.height) != (h0.width, h0.height) {
            return Err(ImageSetError::Size {
                path: p.clone(),
                width: h.width,
                height: h.height,
                first: first.clone(),
                w0: h0.width,
                h0: h0.height,
            });
        }
    }
    let lim = ReadLimits::sized(h0.width, h0.height);
    let read: Vec<(GrayImage, crate::io::image::ReadInfo)> = paths
        .par_iter()
        .map(|p| read_gray_limited(p, &lim))
        .collect::<Result<_, _>>()?;
    let mut warnings = Vec::new();
    let (w0, h0, b0) = match read.first() {
        Some((g, _)) => (g.width, g.height, g.significant_bits),
        None => {
            return Err(ImageSetError::Count {
                what: what.to_string(),
                expected,
                got: 0,
            });
        }
    };
    let container = |g: &GrayImage| match g.pixels {
        Pixels::U8(_) => 8u8,
        Pixels::U16(_) => 16,
        Pixels::F32(_) => 32,
    };
    let c0 = container(&read[0].0);
    for ((g, info), p) in read.iter().zip(paths) {
        if matches!(g.pixels, Pixels::F32(_)) {
            return Err(ImageSetError::Float { path: p.clone() });
        }
        if (g.width, g.height) != (w0, h0) {
            return Err(ImageSetError::Size {
                path: p.clone(),
                width: g.width,
                height: g.height,
                first: paths[0].clone(),
                w0,
                h0,
            });
        }
        if container(g) != c0 || g.significant_bits != b0 {
            return Err(ImageSetError::Depth {
                path: p.clone(),
                bits: g.significant_bits,
                first: paths[0].clone(),
                bits0: b0,
            });
        }
        if info.converted_from_color {
            warnings.push(format!(
                "{}: colour image converted to luma (Rec. 601)",
                p.display()
            ));
        }
        if info.dropped_alpha {
            warnings.push(format!("{}: alpha channel ignored", p.display()));
        }
    }
    let frames = if c0 == 8 {
        Frames::U8(
            read.into_iter()
                .map(|(g, _)| {
                    if let Pixels::U8(v) = g.pixels {
                        v
                    } else {
                        Vec::new()
                    }
                })
                .collect(),
        )
    } else {
        Frames::U16(
            read.into_iter()
                .map(|(g, _)| {
                    if let Pixels::U16(v) = g.pixels {
                        v
                    } else {
                        Vec::new()
                    }
                })
                .collect(),
        )
    };
    Ok(ImageSet {
        width: w0,
        height: h0,
        bits: b0,
        frames,
        paths: paths.to_vec(),
        warnings,
    })
}
