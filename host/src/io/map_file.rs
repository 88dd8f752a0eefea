//! A reference phase map read row by row where it lies, for scans whose memory must not hold the
//! whole map (docs/performance.md, "Memory").
//!
//! An uncompressed baseline TIFF of 32-bit float samples, one per pixel, in strips, is what
//! `fringe3d calibrate reference` and `fringe3d render` write: row `r` is `4 × width` bytes at
//! a known offset, so a scan reads the rows it needs with positional reads on one open handle
//! (several threads at once, none moving a shared file offset) and keeps none of them. Any other
//! layout (compressed, tiled, 64-bit samples, BigTIFF) is [`MapFile::probe`]'s `None`: the
//! caller decodes that map whole.
//!
//! The handle is the one the layout was read from, so a map replaced by a new file (a rename)
//! while a scan runs is still read from the old one. A map rewritten in place is not detected.

use super::image::ImageError;
use super::input::{open_regular, read_at};
use std::fs::File;
use std::io::BufReader;
use std::path::{Path, PathBuf};
use tiff::tags::Tag;

/// Rows read with one positional read at most (bytes: `4 × width × READ_ROWS`).
const READ_ROWS: usize = 16;

/// Where the rows of an uncompressed float TIFF lie, and its open handle.
#[derive(Debug)]
pub struct MapFile {
    path: PathBuf,
    file: File,
    width: usize,
    height: usize,
    big_endian: bool,
    rows_per_strip: usize,
    /// File offset of each strip's first byte.
    strip_offsets: Vec<u64>,
}

/// Reads rows of a [`MapFile`]; one per thread (it owns its buffers).
#[derive(Debug)]
pub struct MapRows<'a> {
    map: &'a MapFile,
    bytes: Vec<u8>,
    row: Vec<f32>,
}

impl MapFile {
    /// Open the map at `path` for reading row by row if it is an uncompressed `width × height`
    /// TIFF of one 32-bit float sample per pixel in strips; `Ok(None)` for anything else (another
    /// format, another size, a layout that must be decoded, or a file the TIFF decoder refuses:
    /// the caller's whole decode then reports what is wrong). `Err` only when the file cannot be
    /// opened or read.
    pub fn probe(path: &Path, width: usize, height: usize) -> Result<Option<MapFile>, ImageError> {
        let io = |source| ImageError::Io {
            path: path.to_path_buf(),
            source,
        };
        let (file, len) = open_regular(path).map_err(io)?;
        let mut magic = [0u8; 4];
        if read_at(&file, &mut magic, 0).is_err() {
            return Ok(None);
        }
        let big_endian = match &magic {
            b"II*\0" => false,
            b"MM\0*" => true,
            _ => return Ok(None),
        };
        let Ok(layout) = Self::layout(&file, width, height) else {
            return Ok(None);
        };
        let Some((rows_per_strip, strip_offsets)) = layout else {
            return Ok(None);
        };
        // Every row inside the file (the counts were checked against the rows of each strip).
        let row_bytes = 4 * width as u64;
        let inside = strip_offsets.iter().enumerate().all(|(k, &o)| {
            let rows = (height - k * rows_per_strip).min(rows_per_strip) as u64;
            o.checked_add(rows * row_bytes)
                .is_some_and(|end| end <= len)
        });
        if !inside {
            return Ok(None);
        }
        Ok(Some(MapFile {
            path: path.to_path_buf(),
            file,
            width,
            height,
            big_endian,
            rows_per_strip,
            strip_offsets,
        }))
    }

    /// Rows per strip and the strips' offsets, if the layout is one this reader takes.
    fn layout(
        file: &File,
        width: usize,
        height: usize,
    ) -> tiff::TiffResult<Option<(usize, Vec<u64>)>> {
        use tiff::decoder::{ChunkType, Decoder};
        // A handle of its own, read from the start (a clone would share the file offset).
        let mut d = Decoder::new(BufReader::new(file.try_clone()?))?;
        let (w, h) = d.dimensions()?;
        let plain = (w as usize, h as usize) == (width, height)
            && width > 0
            && height > 0
            && d.get_chunk_type() == ChunkType::Strip
            && d.find_tag_unsigned::<u16>(Tag::Compression)?.unwrap_or(1) == 1
            && d.find_tag_unsigned::<u16>(Tag::Predictor)?.unwrap_or(1) == 1
            && d.find_tag_unsigned::<u16>(Tag::SamplesPerPixel)?
                .unwrap_or(1)
                == 1
            && d.find_tag_unsigned_vec::<u16>(Tag::BitsPerSample)? == Some(vec![32])
            && d.find_tag_unsigned_vec::<u16>(Tag::SampleFormat)? == Some(vec![3]);
        if !plain {
            return Ok(None);
        }
        let rps = d
            .find_tag_unsigned::<u64>(Tag::RowsPerStrip)?
            .unwrap_or(height as u64)
            .clamp(1, height as u64) as usize;
        let offsets = d.get_tag_u64_vec(Tag::StripOffsets)?;
        let counts = d.get_tag_u64_vec(Tag::StripByteCounts)?;
        let strips = height.div_ceil(rps);
        let row_bytes = 4 * width as u64;
        let counts_fit = counts.iter().enumerate().all(|(k, &c)| {
            let rows = (height.saturating_sub(k * rps)).min(rps) as u64;
            c >= rows * row_bytes
        });
        if offsets.len() != strips || counts.len() != strips || !counts_fit {
            return Ok(None);
        }
        Ok(Some((rps, offsets)))
    }

    /// The map's file.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Width in samples.
    pub fn width(&self) -> usize {
        self.width
    }

    /// Height in rows.
    pub fn height(&self) -> usize {
        self.height
    }

    /// A reader of rows (one per thread).
    pub fn rows(&self) -> MapRows<'_> {
        MapRows {
            map: self,
            bytes: Vec::new(),
            row: vec![0.0; self.width],
        }
    }
}

impl MapRows<'_> {
    /// Hand the rows `r0..r1` to `each(row index, samples)` in order, the samples as the file
    /// holds them (`width` of them). An error of `each` stops the reading and is returned.
    pub fn for_rows<E: From<ImageError>>(
        &mut self,
        r0: usize,
        r1: usize,
        mut each: impl FnMut(usize, &[f32]) -> Result<(), E>,
    ) -> Result<(), E> {
        let m = self.map;
        let row_bytes = 4 * m.width;
        if r1 > m.height || r0 > r1 {
            return Err(E::from(ImageError::Decode {
                path: m.path.clone(),
                format: "TIFF",
                message: format!("rows {r0}..{r1} asked of a map of {} rows", m.height),
            }));
        }
        let mut r = r0;
        while r < r1 {
            let (strip, in_strip) = (r / m.rows_per_strip, r % m.rows_per_strip);
            let n = (m.rows_per_strip - in_strip).min(r1 - r).min(READ_ROWS);
            let offset = m.strip_offsets[strip] + (in_strip * row_bytes) as u64;
            self.bytes.resize(n * row_bytes, 0);
            read_at(&m.file, &mut self.bytes, offset).map_err(|source| ImageError::Io {
                path: m.path.clone(),
                source,
            })?;
            for (k, b) in self.bytes.chunks_exact(row_bytes).enumerate() {
                for (o, s) in self.row.iter_mut().zip(b.as_chunks::<4>().0) {
                    *o = match m.big_endian {
                        false => f32::from_le_bytes(*s),
                        true => f32::from_be_bytes(*s),
                    };
                }
                each(r + k, &self.row)?;
            }
            r += n;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::image::{read_gray, write_tiff_f32};

    /// The rows read in place are the samples the whole decode gives, bit for bit, for maps of
    /// several strips, and other layouts are left to the decoder.
    #[test]
    fn rows_read_in_place_are_the_decoded_samples() {
        let dir = std::env::temp_dir().join(format!("fringe3d-map-file-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        // Over a megabyte: the encoder writes strips of about one.
        let (w, h) = (1500usize, 301usize);
        let data: Vec<f32> = (0..w * h)
            .map(|i| match i % 97 {
                5 => f32::NAN,
                6 => -0.0,
                _ => (i as f32 * 0.37).sin() * 1e3,
            })
            .collect();
        let p = dir.join("map.tif");
        write_tiff_f32(&p, w as u32, h as u32, &data).unwrap();
        let (img, _) = read_gray(&p).unwrap();
        let crate::io::image::Pixels::F32(whole) = img.pixels else {
            panic!("not f32")
        };
        let m = MapFile::probe(&p, w, h)
            .unwrap()
            .expect("a plain float TIFF");
        assert!(m.strip_offsets.len() > 1, "a map of one strip tests less");
        let mut got = Vec::new();
        let mut rows = m.rows();
        rows.for_rows(0, h, |r, s| {
            assert_eq!(r, got.len() / w);
            got.extend_from_slice(s);
            Ok::<_, ImageError>(())
        })
        .unwrap();
        assert!(
            got.iter()
                .map(|x| x.to_bits())
                .eq(whole.iter().map(|x| x.to_bits()))
        );
        let mut mid = Vec::new();
        rows.for_rows(190, 211, |_, s| {
            mid.extend_from_slice(s);
            Ok::<_, ImageError>(())
        })
        .unwrap();
        assert!(
            mid.iter()
                .map(|x| x.to_bits())
                .eq(whole[190 * w..211 * w].iter().map(|x| x.to_bits()))
        );
        assert!(
            rows.for_rows(0, h + 1, |_, _| Ok::<_, ImageError>(()))
                .is_err()
        );
        // Another size, and a PNG, go to the whole decode.
        assert!(MapFile::probe(&p, w + 1, h).unwrap().is_none());
        let png = dir.join("map.png");
        crate::io::image::write_png_u8(&png, 4, 4, &[0; 16]).unwrap();
        assert!(MapFile::probe(&png, 4, 4).unwrap().is_none());
        // A file cut short after its header: the rows are not all inside it.
        let bytes = std::fs::read(&p).unwrap();
        let cut = dir.join("cut.tif");
        std::fs::write(&cut, &bytes[..bytes.len() - 8]).unwrap();
        assert!(MapFile::probe(&cut, w, h).unwrap().is_none());
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
