//! A compiled-reconstruction file read row by row where it lies ([`ModelFile`]), for scans whose
//! memory must not hold every pixel's model (44 bytes a pixel: 55 MiB at 1280 × 1024).
//!
//! The header is read and checked, and the file's length against it, when the file is opened;
//! the handle is kept, and each band of a scan reads its rows of models with one positional
//! read (several threads at once, none moving a shared file offset), checked as
//! [`CompiledFile::read`] checks the whole file. A file replaced by a new one (a rename) while a
//! scan runs is still read from the old one; a file rewritten in place is not detected, but a
//! damaged model still is (an error naming the file and the pixel).

use super::file::{FileError, HEADER, Header, check_row, open_checked};
use crate::io::input::read_at;
use fringe3d_core::reconstruct::compiled::FIELDS;
use std::fs::File;
use std::path::{Path, PathBuf};

/// A compiled-reconstruction file, open, its header checked: the models are read on demand
/// ([`ModelFile::read_rows`]).
#[derive(Debug)]
pub struct ModelFile {
    path: PathBuf,
    file: File,
    header: Header,
}

impl ModelFile {
    /// Open the file at `path` for a camera of `width × height`: its header is checked against
    /// the camera, and its length against the header. Nothing is allocated from the header.
    pub fn open(path: &Path, width: u32, height: u32) -> Result<ModelFile, FileError> {
        let (file, header) = open_checked(path, width, height)?;
        Ok(ModelFile {
            path: path.to_path_buf(),
            file,
            header,
        })
    }

    /// The depth range the models were compiled for, mm.
    pub fn z_range(&self) -> (f32, f32) {
        (self.header.z_min, self.header.z_max)
    }

    /// SHA-256 of the calibration file's bytes and then the reference map's, as the file
    /// carries it.
    pub fn source_digest(&self) -> [u8; 32] {
        self.header.source_digest
    }

    /// The file's path.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Read the models of camera rows `v0..v1` into `out` (resized to [`FIELDS`] × width values
    /// a row, the layout [`super::CompiledFile::models`] has), each row checked: a damaged model
    /// is an error naming the file and the pixel, a model that cannot be used becomes
    /// [`fringe3d_core::reconstruct::compiled::PixelModel::SEARCH`].
    pub fn read_rows(&self, v0: usize, v1: usize, out: &mut Vec<f32>) -> Result<(), FileError> {
        let w = self.header.width as usize;
        if v0 > v1 || v1 > self.header.height as usize {
            return Err(FileError::Format {
                path: self.path.clone(),
                message: format!("rows {v0}..{v1} asked of {} rows", self.header.height),
            });
        }
        let row = FIELDS * w;
        out.resize((v1 - v0) * row, 0.0);
        let offset = HEADER as u64 + 4 * (v0 * row) as u64;
        read_at(&self.file, bytemuck::cast_slice_mut(out), offset).map_err(|source| {
            FileError::Io {
                path: self.path.clone(),
                source,
            }
        })?;
        for (j, r) in out.chunks_exact_mut(row.max(1)).enumerate() {
            for v in r.iter_mut() {
                *v = f32::from_bits(u32::from_le(v.to_bits()));
            }
            check_row(r, w, v0 + j).map_err(|message| FileError::Format {
                path: self.path.clone(),
                message,
            })?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::super::file::CompiledFile;
    use super::*;
    use fringe3d_core::reconstruct::compiled::PixelModel;

    /// Rows read in place against the whole file read at once, bit for bit; a damaged row is
    /// refused when it is read, naming the pixel; bad headers and lengths when it is opened.
    #[test]
    fn rows_read_in_place_are_the_whole_files() {
        let (w, h) = (5usize, 7usize);
        let mut f = CompiledFile {
            width: w as u32,
            height: h as u32,
            z_min: 500.0,
            z_max: 900.0,
            tolerance_mm: 1e-3,
            source_digest: [3; 32],
            models: vec![0.0; FIELDS * w * h],
        };
        for v in 0..h {
            for u in 0..w {
                let m = if (u + v) % 4 == 0 {
                    PixelModel::SEARCH
                } else {
                    PixelModel {
                        ray: [0.01 * u as f32, -0.02 * v as f32],
                        phase_centre: 40.0 + u as f32,
                        phase_scale: if v == 3 { -0.02 } else { 0.02 },
                        depth_centre: 700.0 + v as f32,
                        pole: 0.01,
                        slope: [150.0, 1.5, 0.2, 0.01],
                        far: if v == 3 { 1.05 } else { f32::INFINITY },
                    }
                };
                m.store(&mut f.models[v * FIELDS * w..(v + 1) * FIELDS * w], u)
                    .expect("store");
            }
        }
        let dir = std::env::temp_dir().join(format!("f3d-model-rows-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("dir");
        let path = dir.join("m.f3c");
        f.write(&path).expect("write");
        let whole = CompiledFile::read(&path, w as u32, h as u32).expect("read");
        let file = ModelFile::open(&path, w as u32, h as u32).expect("open");
        assert_eq!(
            (file.z_range(), file.source_digest()),
            ((500.0, 900.0), [3; 32])
        );
        let mut buf = Vec::new();
        for (v0, v1) in [(0, h), (0, 1), (2, 5), (6, 7), (4, 4)] {
            file.read_rows(v0, v1, &mut buf).expect("rows");
            let want = &whole.models[v0 * FIELDS * w..v1 * FIELDS * w];
            assert_eq!(buf.len(), want.len());
            assert!(
                buf.iter()
                    .zip(want)
                    .all(|(a, b)| a.to_bits() == b.to_bits())
            );
        }
        assert!(file.read_rows(3, 8, &mut buf).is_err());
        // Pixel (2, 4)'s d₁ made infinite: rows 4.. are refused, rows before it are not.
        let mut bytes = std::fs::read(&path).expect("bytes");
        let at = HEADER + 4 * (4 * FIELDS * w + 6 * w + 2);
        bytes[at..at + 4].copy_from_slice(&f32::INFINITY.to_le_bytes());
        std::fs::write(&path, &bytes).expect("write");
        let file = ModelFile::open(&path, w as u32, h as u32).expect("open");
        file.read_rows(0, 4, &mut buf)
            .expect("rows before the damage");
        let e = file.read_rows(3, 6, &mut buf).unwrap_err().to_string();
        assert!(e.contains("m.f3c") && e.contains("pixel (2, 4)"), "{e}");
        // Opening checks the header against the camera, and the length against the header.
        let e = ModelFile::open(&path, w as u32, h as u32 + 1)
            .unwrap_err()
            .to_string();
        assert!(e.contains("5x7"), "{e}");
        std::fs::write(&path, &bytes[..bytes.len() - 4]).expect("write");
        let e = ModelFile::open(&path, w as u32, h as u32)
            .unwrap_err()
            .to_string();
        assert!(e.contains("truncated"), "{e}");
        std::fs::write(&path, &bytes[..10]).expect("write");
        let e = ModelFile::open(&path, w as u32, h as u32)
            .unwrap_err()
            .to_string();
        assert!(e.contains("not a compiled reconstruction"), "{e}");
        let _ = std::fs::remove_dir_all(&dir);
    }
}
