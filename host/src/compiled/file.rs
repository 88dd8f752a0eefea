//! The compiled-reconstruction file: a 72-byte header, then the pixel models row by row.
//!
//! | offset | bytes | field |
//! |---:|---:|---|
//! | 0 | 8 | magic `F3DCRC03` |
//! | 8 | 4 | width, u32 LE |
//! | 12 | 4 | height, u32 LE |
//! | 16 | 4 | terms of the numerator polynomial, u32 LE (4) |
//! | 20 | 4 | bytes per pixel, u32 LE (44) |
//! | 24 | 4 | z_min, f32 LE, mm |
//! | 28 | 4 | z_max, f32 LE, mm |
//! | 32 | 4 | the build's tolerance, f32 LE, mm |
//! | 36 | 4 | reserved, 0 |
//! | 40 | 32 | SHA-256 of the calibration file's bytes followed by the reference map's |
//! | 72 | width × height × 44 | the models, rows top to bottom |
//!
//! A row is its models field by field: eleven arrays of `width` little-endian f32 (ray x, ray y,
//! Φ_c, ±k, s_c, γ, d₁…d₄, τ_far; [`PixelModel::store`]), the layout the kernel reads. A head
//! reads the header once and then one row of `width × 44` bytes per camera row
//! ([`PixelModel::parse_row`]).

use fringe3d_core::math::CANONICAL_NAN;
use fringe3d_core::reconstruct::compiled::{
    FIELDS, LEFT_TO_SEARCH, PixelModel, TERMS, compiled_row,
};
use std::path::{Path, PathBuf};

/// The file's first eight bytes.
pub const MAGIC: [u8; 8] = *b"F3DCRC03";
/// Header bytes.
pub const HEADER: usize = 72;
/// Largest file [`CompiledFile::read_any`] reads (a 16 384 × 16 384 camera is 10 GiB; 4 GiB is a
/// 10-megapixel camera ten times over).
pub const MAX_FILE_BYTES: u64 = 4 << 30;

/// A compiled reconstruction, in memory.
#[derive(Clone, Debug)]
pub struct CompiledFile {
    /// Camera width.
    pub width: u32,
    /// Camera height.
    pub height: u32,
    /// Depth range the models were compiled for, mm.
    pub z_min: f32,
    /// Far end, mm.
    pub z_max: f32,
    /// The build's tolerance, mm.
    pub tolerance_mm: f32,
    /// SHA-256 of the calibration file's bytes and then the reference map's.
    pub source_digest: [u8; 32],
    /// The models: `height` rows of [`FIELDS`] × `width` values, each row field by field
    /// ([`PixelModel::store`]).
    pub models: Vec<f32>,
}

/// Why a compiled file could not be read or used. Messages name the file.
#[derive(Debug, thiserror::Error)]
pub enum FileError {
    /// Unreadable.
    #[error("{path}: cannot read: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The error.
        source: std::io::Error,
    },
    /// Not a compiled-reconstruction file, or a damaged one.
    #[error("{path}: {message}")]
    Format {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
}

impl CompiledFile {
    /// The file's bytes.
    pub fn to_bytes(&self) -> Vec<u8> {
        let mut b = Vec::with_capacity(HEADER + 4 * self.models.len());
        b.extend_from_slice(&MAGIC);
        for v in [
            self.width,
            self.height,
            TERMS as u32,
            PixelModel::BYTES as u32,
        ] {
            b.extend_from_slice(&v.to_le_bytes());
        }
        for v in [self.z_min, self.z_max, self.tolerance_mm] {
            b.extend_from_slice(&v.to_le_bytes());
        }
        b.extend_from_slice(&0u32.to_le_bytes());
        b.extend_from_slice(&self.source_digest);
        for v in &self.models {
            b.extend_from_slice(&fringe3d_core::math::canonical(*v).to_le_bytes());
        }
        b
    }

    /// Write the file atomically.
    pub fn write(&self, path: &Path) -> Result<(), crate::io::atomic::AtomicError> {
        let bytes = self.to_bytes();
        crate::io::atomic::write_atomic(path, |w| w.write_all(&bytes))
    }

    /// Read a file for a camera of `width × height`: the header is checked against it, and the
    /// file's length against the header, before anything is allocated from it; the models are
    /// read straight into their rows and checked rows in parallel.
    pub fn read(path: &Path, width: u32, height: u32) -> Result<CompiledFile, FileError> {
        use std::io::Read;
        let (mut f, h) = open_checked(path, width, height)?;
        let mut models = vec![0f32; h.values()];
        let read = f.read_exact(bytemuck::cast_slice_mut(&mut models));
        read.map_err(|source| FileError::Io {
            path: path.to_path_buf(),
            source,
        })?;
        for v in models.iter_mut() {
            *v = f32::from_bits(u32::from_le(v.to_bits()));
        }
        check_models(&mut models, width as usize).map_err(|message| FileError::Format {
            path: path.to_path_buf(),
            message,
        })?;
        Ok(h.with(models))
    }

    /// Read a file whatever camera it was compiled for (`fringe3d info`): the size comes from
    /// its header, and the file's length must match it (at most [`MAX_FILE_BYTES`]).
    pub fn read_any(path: &Path) -> Result<CompiledFile, FileError> {
        use std::io::Read;
        let io = |source| FileError::Io {
            path: path.to_path_buf(),
            source,
        };
        let (mut f, len) = crate::io::input::open_regular(path).map_err(io)?;
        let mut head = [0u8; HEADER];
        if len < HEADER as u64 || len > MAX_FILE_BYTES {
            return Err(FileError::Format {
                path: path.to_path_buf(),
                message: format!(
                    "{len} bytes: not a compiled reconstruction (a header of {HEADER} bytes, at most {MAX_FILE_BYTES} in all)"
                ),
            });
        }
        f.read_exact(&mut head).map_err(io)?;
        let u = |o: usize| u32::from_le_bytes([head[o], head[o + 1], head[o + 2], head[o + 3]]);
        Self::read(path, u(8), u(12))
    }

    /// Parse the file's bytes for a camera of `width × height`.
    pub fn parse(b: &[u8], width: u32, height: u32) -> Result<CompiledFile, String> {
        let head = b
            .get(..HEADER)
            .ok_or("not a compiled reconstruction (no F3DCRC03 header)")?;
        let h = Header::parse(head, width, height)?;
        let want = HEADER + 4 * h.values();
        if b.len() != want {
            return Err(format!(
                "{} bytes, but a {width}x{height} compiled reconstruction is {want} (truncated or padded)",
                b.len()
            ));
        }
        let mut models: Vec<f32> = b[HEADER..]
            .chunks_exact(4)
            .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
            .collect();
        check_models(&mut models, width as usize)?;
        Ok(h.with(models))
    }

    /// Pixels with a function.
    pub fn compiled_count(&self) -> usize {
        self.count(|m| m.is_compiled())
    }

    /// Pixels with no reference along their ray ([`PixelModel::NO_REFERENCE`]): answered
    /// without the search.
    pub fn no_reference_count(&self) -> usize {
        self.count(|m| m.is_no_reference())
    }

    /// Pixels whose range is clipped to the map ([`PixelModel::is_clipped`]).
    pub fn clipped_count(&self) -> usize {
        self.count(|m| m.is_compiled() && m.is_clipped())
    }

    /// Pixels whose model satisfies `pred`.
    pub fn count(&self, pred: impl Fn(&PixelModel) -> bool) -> usize {
        let w = self.width as usize;
        self.models
            .chunks_exact(FIELDS * w.max(1))
            .map(|row| {
                (0..w)
                    .filter(|&u| PixelModel::load(row, u).is_some_and(|m| pred(&m)))
                    .count()
            })
            .sum()
    }

    /// The model of pixel `(u, v)`.
    pub fn model(&self, u: usize, v: usize) -> Option<PixelModel> {
        let w = self.width as usize;
        PixelModel::load(self.models.get(v * FIELDS * w..(v + 1) * FIELDS * w)?, u)
    }

    /// The pixels (`v × width + u`) of a scan's phase map (`phase` and its decoded codes,
    /// `width × height`) that the compiled kernel leaves to the search: what a scan costs
    /// beyond one division a pixel. `None` if the map is not this file's size.
    pub fn left_to_search(&self, phase: &[f32], decoded: &[u8]) -> Option<Vec<usize>> {
        let w = self.width as usize;
        if phase.len() != w * self.height as usize || decoded.len() != phase.len() {
            return None;
        }
        let (mut xyz, mut codes) = (vec![0f32; 3 * w], vec![0u8; w]);
        let mut left = Vec::new();
        let rows = (self.models.chunks_exact(FIELDS * w.max(1))).zip(
            phase
                .chunks_exact(w.max(1))
                .zip(decoded.chunks_exact(w.max(1))),
        );
        for (v, (m, (p, q))) in rows.enumerate() {
            compiled_row(m, self.z_min, self.z_max, p, q, &mut xyz, &mut codes).ok()?;
            left.extend(
                (0..w)
                    .filter(|&u| codes[u] == LEFT_TO_SEARCH)
                    .map(|u| v * w + u),
            );
        }
        Some(left)
    }
}

/// Open a compiled file for a camera of `width × height` and check its header against it, and
/// the file's length against the header (nothing is allocated from the header); the file is
/// left at its first model.
pub(super) fn open_checked(
    path: &Path,
    width: u32,
    height: u32,
) -> Result<(std::fs::File, Header), FileError> {
    use std::io::Read;
    let io = |source| FileError::Io {
        path: path.to_path_buf(),
        source,
    };
    let bad = |m: String| FileError::Format {
        path: path.to_path_buf(),
        message: m,
    };
    let (mut f, len) = crate::io::input::open_regular(path).map_err(io)?;
    let mut head = [0u8; HEADER];
    if len < HEADER as u64 {
        return Err(bad(format!(
            "{len} bytes: not a compiled reconstruction (no F3DCRC03 header)"
        )));
    }
    f.read_exact(&mut head).map_err(io)?;
    let h = Header::parse(&head, width, height).map_err(bad)?;
    let want = HEADER as u64 + 4 * h.values() as u64;
    if len != want {
        return Err(bad(format!(
            "{len} bytes, but a {width}x{height} compiled reconstruction is {want} (truncated or padded)"
        )));
    }
    Ok((f, h))
}

/// A checked header.
#[derive(Debug)]
pub(super) struct Header {
    pub(super) width: u32,
    pub(super) height: u32,
    pub(super) z_min: f32,
    pub(super) z_max: f32,
    pub(super) tolerance_mm: f32,
    pub(super) source_digest: [u8; 32],
}

impl Header {
    /// Check the header (`b` holds at least [`HEADER`] bytes) against the camera.
    pub(super) fn parse(b: &[u8], width: u32, height: u32) -> Result<Header, String> {
        if b.len() >= 8 && b[..8] == *b"F3DCRC01" {
            return Err(
                "a compiled reconstruction of an older format (F3DCRC01, without the far rule \
                 of clipped pixels): re-run `fringe3d compile`"
                    .into(),
            );
        }
        if b.len() >= 8 && b[..8] == *b"F3DCRC02" {
            return Err(
                "a compiled reconstruction of an older format (F3DCRC02, one far threshold for \
                 every clipped pixel): re-run `fringe3d compile`"
                    .into(),
            );
        }
        if b.len() < HEADER || b[..8] != MAGIC {
            return Err("not a compiled reconstruction (no F3DCRC03 header)".into());
        }
        let u = |o: usize| u32::from_le_bytes([b[o], b[o + 1], b[o + 2], b[o + 3]]);
        let f = |o: usize| f32::from_bits(u(o));
        let (w, h, terms, rec) = (u(8), u(12), u(16), u(20));
        if terms != TERMS as u32 || rec != PixelModel::BYTES as u32 {
            return Err(format!(
                "models of {terms} terms and {rec} bytes; this build reads {TERMS} terms of {} bytes",
                PixelModel::BYTES
            ));
        }
        if (w, h) != (width, height) {
            return Err(format!(
                "compiled for a {w}x{h} camera, but the calibrated camera is {width}x{height}"
            ));
        }
        let (z_min, z_max) = (f(24), f(28));
        if !(z_min.is_finite() && z_max.is_finite() && z_min < z_max) {
            return Err(format!(
                "depth range [{z_min}, {z_max}] is not finite and increasing"
            ));
        }
        let mut source_digest = [0u8; 32];
        source_digest.copy_from_slice(&b[40..72]);
        Ok(Header {
            width,
            height,
            z_min,
            z_max,
            tolerance_mm: f(32),
            source_digest,
        })
    }

    /// Values of the models.
    pub(super) fn values(&self) -> usize {
        self.width as usize * self.height as usize * FIELDS
    }

    fn with(self, models: Vec<f32>) -> CompiledFile {
        CompiledFile {
            width: self.width,
            height: self.height,
            z_min: self.z_min,
            z_max: self.z_max,
            tolerance_mm: self.tolerance_mm,
            source_digest: self.source_digest,
            models,
        }
    }
}

/// Check every model (rows in parallel, [`check_row`]).
fn check_models(models: &mut [f32], w: usize) -> Result<(), String> {
    use rayon::prelude::*;
    models
        .par_chunks_exact_mut(FIELDS * w.max(1))
        .enumerate()
        .try_for_each(|(v, row)| check_row(row, w, v))
}

/// Check the models of row `v` (`row`, as the file holds it, [`FIELDS`] × `w` values): one with
/// a finite non-zero scale must be usable ([`PixelModel::usable`], the rule of
/// [`PixelModel::from_array`]), or the file is damaged; the others become
/// [`PixelModel::SEARCH`] or [`PixelModel::NO_REFERENCE`] (a zero scale), canonical.
pub(super) fn check_row(row: &mut [f32], w: usize, v: usize) -> Result<(), String> {
    if w == 0 || row.len() < FIELDS * w {
        return Ok(());
    }
    // Field by field, each a contiguous array (vectorized): a flag for each pixel whose numbers
    // but τ_far are not all finite, or that breaks the rest of the rule.
    let mut bad = vec![0u32; w];
    for field in row.chunks_exact(w).take(FIELDS - 1) {
        for (b, x) in bad.iter_mut().zip(field) {
            // Not finite: every exponent bit set.
            *b |= u32::from(x.to_bits() & 0x7f80_0000 == 0x7f80_0000);
        }
    }
    let field = |i: usize| &row[i * w..(i + 1) * w];
    let (k, s_c, far) = (field(3), field(4), field(FIELDS - 1));
    for (((b, &k), &s), &f) in bad.iter_mut().zip(k).zip(s_c).zip(far) {
        *b |= u32::from(!PixelModel::usable(true, k, s, f));
    }
    // The flagged pixels (few: those without a function). One with a finite non-zero scale is
    // damaged; the others are [`PixelModel::NO_REFERENCE`] (a zero scale) or
    // [`PixelModel::SEARCH`], written canonical: every number the canonical NaN but a zero
    // scale, +0.
    for u in (0..w).filter(|&u| bad[u] != 0) {
        let k = row[3 * w + u];
        if k.is_finite() && k != 0.0 {
            return Err(format!(
                "pixel ({u}, {v}): a model with a non-finite coefficient, a negative depth or a bad far threshold (a damaged file)"
            ));
        }
        for f in 0..FIELDS {
            row[f * w + u] = CANONICAL_NAN;
        }
        if k == 0.0 {
            row[3 * w + u] = 0.0;
        }
    }
    Ok(())
}

/// The digest a compiled file carries: SHA-256 of the calibration file's bytes, then the
/// reference map's.
pub fn source_digest(calibration: &[u8], map: &[u8]) -> [u8; 32] {
    use sha2::{Digest, Sha256};
    let mut h = Sha256::new();
    h.update(calibration);
    h.update(map);
    h.finalize().into()
}

/// [`source_digest`] of the files `calibration` and `map`, read a piece at a time (neither is
/// held whole: a map is 4 bytes a pixel). An error names the file it comes from.
pub fn source_digest_of_files(
    calibration: &Path,
    map: &Path,
) -> Result<[u8; 32], (PathBuf, std::io::Error)> {
    use sha2::{Digest, Sha256};
    use std::io::Read;
    let mut h = Sha256::new();
    let mut buf = vec![0u8; 1 << 16];
    for path in [calibration, map] {
        let fail = |e| (path.to_path_buf(), e);
        let (mut f, _) = crate::io::input::open_regular(path).map_err(fail)?;
        loop {
            match f.read(&mut buf) {
                Ok(0) => break,
                Ok(n) => h.update(&buf[..n]),
                Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
                Err(e) => return Err(fail(e)),
            }
        }
    }
    Ok(h.finalize().into())
}

#[cfg(test)]
mod tests {
    use super::*;
    use fringe3d_core::validity::Validity;

    /// The pixels a scan leaves to the search: those without a function, and no others (one
    /// with a function and its phase in range, one with no reference along its ray, one whose
    /// decoded code is not valid, whatever its model).
    #[test]
    fn left_to_search_names_the_pixels_without_a_function() {
        let (w, h) = (4usize, 3usize);
        let good = PixelModel {
            ray: [0.1, -0.2],
            phase_centre: 50.0,
            phase_scale: 0.01,
            depth_centre: 600.0,
            pole: 0.05,
            slope: [100.0, 1.0, 0.1, 0.01],
            far: f32::INFINITY,
        };
        let mut models = vec![0f32; FIELDS * w * h];
        let (mut phase, mut decoded) = (vec![50.0f32; w * h], vec![0u8; w * h]);
        let mut want = Vec::new();
        for i in 0..w * h {
            let m = match i % 4 {
                0 => good,
                1 => PixelModel::SEARCH,
                2 => PixelModel::NO_REFERENCE,
                _ => PixelModel::SEARCH,
            };
            if i % 4 == 3 {
                decoded[i] = Validity::LowModulation as u8;
                phase[i] = f32::NAN;
            }
            if i % 4 == 1 {
                want.push(i);
            }
            let row = &mut models[(i / w) * FIELDS * w..(i / w + 1) * FIELDS * w];
            m.store(row, i % w).unwrap();
        }
        let file = CompiledFile {
            width: w as u32,
            height: h as u32,
            z_min: 400.0,
            z_max: 800.0,
            tolerance_mm: 1e-3,
            source_digest: [0; 32],
            models,
        };
        assert_eq!(file.left_to_search(&phase, &decoded), Some(want));
        assert_eq!(file.left_to_search(&phase[1..], &decoded[1..]), None);
    }

    /// [`check_row`] against the simple form, pixel by pixel: [`PixelModel::load`] (which
    /// applies [`PixelModel::from_array`]'s rule) and [`PixelModel::store`], on rows of models
    /// with every kind of defect; the same bits, or the same damaged pixel.
    #[test]
    fn check_row_is_load_and_store_pixel_by_pixel() {
        let w = 37;
        let mut seed = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            seed
        };
        let odd = [
            f32::NAN,
            -f32::NAN,
            f32::INFINITY,
            f32::NEG_INFINITY,
            0.0,
            -0.0,
            -1.0,
            0.5,
            f32::from_bits(0x7fc0_1234),
        ];
        let good = PixelModel {
            ray: [0.1, -0.2],
            phase_centre: 50.0,
            phase_scale: -0.01,
            depth_centre: 700.0,
            pole: 0.05,
            slope: [100.0, 1.0, 0.1, 0.01],
            far: 1.2,
        };
        let (mut damaged, mut rows) = (0, 0);
        while rows < 400 {
            let mut row = vec![0f32; FIELDS * w];
            for u in 0..w {
                let mut a = good.to_array();
                if u % 2 == 1 {
                    a[3] = 0.02;
                    a[FIELDS - 1] = f32::INFINITY;
                }
                // Now and then a number replaced by an odd one, at any field.
                for _ in 0..(next() % 3) {
                    if next() % 8 == 0 {
                        a[(next() % FIELDS as u64) as usize] = odd[(next() % 9) as usize];
                    }
                }
                // Now and then a model without a function, written any way.
                if next() % 9 == 0 {
                    a[3] = [f32::NAN, 0.0, -0.0, f32::INFINITY][(next() % 4) as usize];
                }
                for (f, x) in a.iter().enumerate() {
                    row[f * w + u] = *x;
                }
            }
            let mut simple = row.clone();
            let mut want = Ok(());
            for u in 0..w {
                let k = simple[3 * w + u];
                let m = PixelModel::load(&simple, u).unwrap();
                if k.is_finite() && k != 0.0 && !m.is_compiled() {
                    want = Err(u);
                    break;
                }
                m.store(&mut simple, u).unwrap();
            }
            let got = check_row(&mut row, w, 9);
            match want {
                Ok(()) => {
                    assert_eq!(got, Ok(()));
                    assert!(
                        row.iter()
                            .zip(&simple)
                            .all(|(a, b)| a.to_bits() == b.to_bits())
                    );
                }
                Err(u) => {
                    let e = got.unwrap_err();
                    assert!(e.starts_with(&format!("pixel ({u}, 9):")), "{e}");
                    damaged += 1;
                }
            }
            rows += 1;
        }
        assert!(
            damaged > 20 && damaged < 380,
            "{damaged} damaged rows of {rows}"
        );
    }

    /// The digest of two files read a piece at a time is the digest of their bytes, also for
    /// files longer than a piece; a missing file is named.
    #[test]
    fn digest_of_files_is_that_of_their_bytes() {
        let dir = std::env::temp_dir().join(format!("f3d-digest-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let (a, b) = (dir.join("a.toml"), dir.join("b.tif"));
        let cal = b"[camera]\nwidth = 3\n".to_vec();
        let map: Vec<u8> = (0..200_001u32).map(|i| (i * 7 + i / 251) as u8).collect();
        std::fs::write(&a, &cal).unwrap();
        std::fs::write(&b, &map).unwrap();
        assert_eq!(
            source_digest_of_files(&a, &b).unwrap(),
            source_digest(&cal, &map)
        );
        // Where the calibration's bytes end and the map's begin matters to neither: one stream.
        let mut joined = cal.clone();
        joined.extend_from_slice(&map);
        assert_eq!(source_digest(&joined, &[]), source_digest(&cal, &map));
        let missing = dir.join("missing.tif");
        assert_eq!(source_digest_of_files(&a, &missing).unwrap_err().0, missing);
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn round_trip_and_refusals() {
        let m = PixelModel {
            ray: [0.1, 0.2],
            phase_centre: 50.0,
            phase_scale: 0.01,
            depth_centre: 700.0,
            pole: 0.05,
            slope: [100.0, 1.0, 0.1, 0.01],
            far: f32::INFINITY,
        };
        let f = CompiledFile {
            width: 3,
            height: 2,
            z_min: 500.0,
            z_max: 900.0,
            tolerance_mm: 1e-4,
            source_digest: [7; 32],
            models: vec![0.0; 6 * FIELDS],
        };
        let mut f = f;
        for (i, x) in [m, PixelModel::SEARCH, m, m, m, m].iter().enumerate() {
            x.store(
                &mut f.models[(i / 3) * 3 * FIELDS..(i / 3 + 1) * 3 * FIELDS],
                i % 3,
            )
            .unwrap();
        }
        let b = f.to_bytes();
        assert_eq!(b.len(), HEADER + 6 * 44);
        let g = CompiledFile::parse(&b, 3, 2).unwrap();
        assert_eq!(g.model(0, 0), Some(m));
        assert!(!g.model(1, 0).unwrap().is_compiled());
        assert_eq!(g.model(2, 1), Some(m));
        assert_eq!(g.compiled_count(), 5);
        assert_eq!(g.source_digest, [7; 32]);
        assert!(CompiledFile::parse(&b, 2, 3).unwrap_err().contains("3x2"));
        assert!(
            CompiledFile::parse(&b[..b.len() - 1], 3, 2)
                .unwrap_err()
                .contains("truncated")
        );
        let mut c = b.clone();
        c[0] = b'X';
        assert!(
            CompiledFile::parse(&c, 3, 2)
                .unwrap_err()
                .contains("header")
        );
        let mut c = b.clone();
        c[16] = 5;
        assert!(CompiledFile::parse(&c, 3, 2).unwrap_err().contains("terms"));
        let mut c = b.clone();
        c[24..28].copy_from_slice(&f32::NAN.to_le_bytes());
        assert!(
            CompiledFile::parse(&c, 3, 2)
                .unwrap_err()
                .contains("depth range")
        );
        // Pixel (0, 0)'s d₁ (field 6 of row 0) made infinite: a damaged model.
        let mut c = b;
        let at = HEADER + 4 * (6 * 3);
        c[at..at + 4].copy_from_slice(&f32::INFINITY.to_le_bytes());
        assert!(
            CompiledFile::parse(&c, 3, 2)
                .unwrap_err()
                .contains("pixel (0, 0)")
        );
    }
}
