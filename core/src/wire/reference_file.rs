//! The reference map file: the reconstruction's reference phase map as a head stores it (its
//! flash, a file), versioned and CRC-checked like the set-up blob, so that a damaged map is
//! refused at boot instead of giving wrong points (docs/setup-blob.md, "The reference map file").
//!
//! # Byte layout
//!
//! | offset | size | field |
//! |---:|---:|---|
//! | 0 | 4 | magic `F3DM` ([`REFERENCE_MAGIC`]) |
//! | 4 | 1 | format version = 1 ([`REFERENCE_VERSION`]) |
//! | 5 | 3 | reserved, 0 |
//! | 8 | 4 | map width `MW`, u32 LE (the image's plus the margin's left and right) |
//! | 12 | 4 | map height `MH`, u32 LE |
//! | 16 | 16 | the margin past the image: left, top, right, bottom, u32 LE each |
//! | 32 | `4·MW·MH` | the samples, f32 LE, row after row, prepared: the canonical NaN `0x7fc00000` where invalid |
//! | 32 + `4·MW·MH` | 4 | CRC-32C ([`crc`](super::crc)) of every byte before it, u32 LE |
//!
//! The samples start 32 bytes in, so a file at a 4-byte-aligned address (memory-mapped flash)
//! can be read in place as f32 on a little-endian head: [`ReferenceFile::check`] checks the whole
//! file and tells where the samples are; the head views them as `&[f32]` and hands them to
//! [`ReferenceMap::from_prepared`](crate::reconstruct::ReferenceMap::from_prepared), which
//! checks that each is finite or the canonical NaN.

use super::crc::crc32c;
use crate::math::canonical;
use crate::reconstruct::{MAX_MARGIN, Margin, Reconstructor};

/// First four bytes of a reference map file.
pub const REFERENCE_MAGIC: [u8; 4] = *b"F3DM";
/// The format version this core writes and reads.
pub const REFERENCE_VERSION: u8 = 1;
/// Bytes before the samples.
pub const REFERENCE_HEADER_LEN: usize = 32;
/// Largest map side, samples (a camera's 65 535 plus two margins).
pub const MAX_MAP_SIDE: u32 = 65_535 + 2 * MAX_MARGIN;

/// Why a reference map file was refused. Each names one thing.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ReferenceFileError {
    /// Shorter than a header and a CRC, or than its size says.
    Truncated,
    /// Longer than its size says.
    Length,
    /// Not a reference map file (the magic).
    Magic,
    /// A format version this core does not read (the byte found).
    Version(u8),
    /// A reserved byte is not 0.
    Reserved,
    /// A side is 0 or above [`MAX_MAP_SIDE`], or a margin side above [`MAX_MARGIN`], or the
    /// margin is not inside the map.
    Size,
    /// CRC mismatch: the file is damaged.
    Crc,
    /// The map is not the one the reconstructor reads (its size or margin).
    NotThisMap,
    /// The output buffer is too small ([`ReferenceFile::emit`]).
    BufferTooSmall,
}

impl ReferenceFileError {
    /// What is wrong, for a firmware's fixed messages.
    pub const fn what(self) -> &'static str {
        match self {
            Self::Truncated => "reference map: truncated file",
            Self::Length => "reference map: longer than its size says",
            Self::Magic => "reference map: not a reference map file (magic)",
            Self::Version(_) => "reference map: unsupported format version",
            Self::Reserved => "reference map: reserved header byte set",
            Self::Size => "reference map: bad size or margin",
            Self::Crc => "reference map: CRC mismatch (damaged)",
            Self::NotThisMap => "reference map: not the size or margin of this calibration",
            Self::BufferTooSmall => "reference map: buffer too small",
        }
    }
}

impl core::fmt::Display for ReferenceFileError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(self.what())?;
        if let Self::Version(v) = self {
            write!(f, " {v} (this core reads {REFERENCE_VERSION})")?;
        }
        Ok(())
    }
}

impl core::error::Error for ReferenceFileError {}

/// A checked reference map file's header: where its samples are.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ReferenceFile {
    /// Map width, samples.
    pub width: u32,
    /// Map height, samples.
    pub height: u32,
    /// The margin past the image.
    pub margin: Margin,
}

impl ReferenceFile {
    /// The header of a map for `recon` (its map size and margin).
    pub fn of(recon: &Reconstructor) -> ReferenceFile {
        ReferenceFile {
            width: recon.map_width() as u32,
            height: recon.map_height() as u32,
            margin: recon.margin(),
        }
    }

    /// Bytes of the samples.
    pub fn samples_len(&self) -> usize {
        4 * self.width as usize * self.height as usize
    }

    /// Bytes of the whole file.
    pub fn file_len(&self) -> usize {
        REFERENCE_HEADER_LEN + self.samples_len() + 4
    }

    /// Byte range of the samples in the file.
    pub fn samples_range(&self) -> core::ops::Range<usize> {
        REFERENCE_HEADER_LEN..REFERENCE_HEADER_LEN + self.samples_len()
    }

    fn valid(&self) -> bool {
        let m = self.margin;
        let sides = 1..=MAX_MAP_SIDE;
        sides.contains(&self.width)
            && sides.contains(&self.height)
            && m.to_array().iter().all(|&s| s <= MAX_MARGIN)
            && m.left + m.right < self.width
            && m.top + m.bottom < self.height
    }

    /// Check a whole file: header, size, CRC. Returns its header; the samples are
    /// [`ReferenceFile::samples_range`] of `bytes`.
    pub fn check(bytes: &[u8]) -> Result<ReferenceFile, ReferenceFileError> {
        let head = bytes
            .get(..REFERENCE_HEADER_LEN)
            .ok_or(ReferenceFileError::Truncated)?;
        if head[..4] != REFERENCE_MAGIC {
            return Err(ReferenceFileError::Magic);
        }
        if head[4] != REFERENCE_VERSION {
            return Err(ReferenceFileError::Version(head[4]));
        }
        if head[5..8] != [0, 0, 0] {
            return Err(ReferenceFileError::Reserved);
        }
        let word = |i: usize| u32::from_le_bytes([head[i], head[i + 1], head[i + 2], head[i + 3]]);
        let f = ReferenceFile {
            width: word(8),
            height: word(12),
            margin: Margin::from_array([word(16), word(20), word(24), word(28)]),
        };
        if !f.valid() {
            return Err(ReferenceFileError::Size);
        }
        let end = f.samples_range().end;
        let crc = bytes
            .get(end..end + 4)
            .ok_or(ReferenceFileError::Truncated)?;
        if bytes.len() != end + 4 {
            return Err(ReferenceFileError::Length);
        }
        let want = u32::from_le_bytes([crc[0], crc[1], crc[2], crc[3]]);
        if crc32c(bytes.get(..end).ok_or(ReferenceFileError::Truncated)?) != want {
            return Err(ReferenceFileError::Crc);
        }
        Ok(f)
    }

    /// [`ReferenceFile::check`], and the map is the one `recon` reads (size and margin).
    pub fn check_for(
        bytes: &[u8],
        recon: &Reconstructor,
    ) -> Result<ReferenceFile, ReferenceFileError> {
        let f = Self::check(bytes)?;
        if f != Self::of(recon) {
            return Err(ReferenceFileError::NotThisMap);
        }
        Ok(f)
    }

    /// Write the file of `samples` (`width × height`, prepared) into `out`; returns its length.
    pub fn emit(&self, samples: &[f32], out: &mut [u8]) -> Result<usize, ReferenceFileError> {
        if !self.valid() || samples.len() != self.samples_len() / 4 {
            return Err(ReferenceFileError::Size);
        }
        let n = self.file_len();
        let out = out.get_mut(..n).ok_or(ReferenceFileError::BufferTooSmall)?;
        let (head, rest) = out.split_at_mut(REFERENCE_HEADER_LEN);
        head[..4].copy_from_slice(&REFERENCE_MAGIC);
        head[4..8].copy_from_slice(&[REFERENCE_VERSION, 0, 0, 0]);
        let m = self.margin.to_array();
        let words = [self.width, self.height, m[0], m[1], m[2], m[3]];
        for (d, w) in head[8..].chunks_exact_mut(4).zip(words) {
            d.copy_from_slice(&w.to_le_bytes());
        }
        for (d, s) in rest.chunks_exact_mut(4).zip(samples) {
            d.copy_from_slice(&canonical(*s).to_le_bytes());
        }
        let end = n - 4;
        let crc = crc32c(out.get(..end).ok_or(ReferenceFileError::BufferTooSmall)?);
        out[end..].copy_from_slice(&crc.to_le_bytes());
        Ok(n)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::CANONICAL_NAN;

    #[test]
    fn a_map_file_round_trips_and_every_damage_is_named() {
        let f = ReferenceFile {
            width: 3,
            height: 2,
            margin: Margin::from_array([1, 0, 0, 1]),
        };
        let samples = [1.5, -f32::NAN, 2.0, 3.25, f32::NAN, -0.5];
        let mut b = [0u8; 60];
        assert_eq!(
            f.emit(&samples, &mut b[..59]),
            Err(ReferenceFileError::BufferTooSmall)
        );
        assert_eq!(f.emit(&samples, &mut b), Ok(60));
        // The layout: magic, version, reserved, sizes and margin at their offsets, samples 32
        // bytes in (every NaN canonical), the CRC last.
        assert_eq!(&b[..8], b"F3DM\x01\x00\x00\x00");
        assert_eq!(&b[8..16], &[3, 0, 0, 0, 2, 0, 0, 0]);
        assert_eq!(
            &b[16..32],
            &[1, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 1, 0, 0, 0]
        );
        assert_eq!(&b[32..36], &1.5f32.to_le_bytes());
        assert_eq!(&b[36..40], &CANONICAL_NAN.to_le_bytes());
        assert_eq!(&b[56..60], &crc32c(&b[..56]).to_le_bytes());
        assert_eq!(ReferenceFile::check(&b), Ok(f));
        assert_eq!(f.samples_range(), 32..56);
        let with = |i: usize, x: u8| {
            let mut c = b;
            c[i] ^= x;
            ReferenceFile::check(&c)
        };
        assert_eq!(with(0, 1), Err(ReferenceFileError::Magic));
        assert_eq!(with(4, 3), Err(ReferenceFileError::Version(2)));
        assert_eq!(with(6, 1), Err(ReferenceFileError::Reserved));
        assert_eq!(with(40, 0x10), Err(ReferenceFileError::Crc));
        assert_eq!(with(57, 1), Err(ReferenceFileError::Crc));
        // A width of 0, or a margin wider than the map: the header's size is refused first.
        assert_eq!(with(8, 3), Err(ReferenceFileError::Size));
        assert_eq!(with(28, 2), Err(ReferenceFileError::Size));
        // A larger size than the bytes hold, or bytes past the CRC.
        assert_eq!(with(12, 1), Err(ReferenceFileError::Truncated));
        let mut long = [0u8; 61];
        long[..60].copy_from_slice(&b);
        assert_eq!(ReferenceFile::check(&long), Err(ReferenceFileError::Length));
        assert_eq!(
            ReferenceFile::check(&b[..59]),
            Err(ReferenceFileError::Truncated)
        );
        assert_eq!(
            ReferenceFile::check(&b[..20]),
            Err(ReferenceFileError::Truncated)
        );
        // Samples of another size are not written.
        assert_eq!(f.emit(&samples[..5], &mut b), Err(ReferenceFileError::Size));
    }
}
