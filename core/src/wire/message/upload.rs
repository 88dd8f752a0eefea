//! Uploads: pattern images, the reference phase map and the compiled reconstruction, chunk by
//! chunk, digest-checked.

use serde::{Deserialize, Serialize};

use super::{Body, Invalid, MAX_CHUNK, PHASE_MAP_BYTES_PER_PIXEL, WireError, bit_depth_ok, check};
use crate::reconstruct::compiled::PixelModel;
use crate::reconstruct::{MAX_MARGIN, Margin};
use crate::wire::crc::crc32c;
#[cfg(doc)]
use {
    super::{Command, ResultRow},
    crate::Validity,
};

/// What an upload fills.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum UploadTarget {
    /// The images of pattern set `set_id` (wire value 0, then the u8).
    PatternSet(u8),
    /// The reference phase map (wire value 1).
    PhaseMap,
    /// The compiled reconstruction's models (wire value 2, protocol version 9; 44
    /// bytes a pixel since version 10).
    Compiled,
}

/// Host → head: start uploading explicit pattern images into set `set_id`.
///
/// The data is `image_count` images of `height` rows of `width` pixels, one byte per pixel, images
/// in projection order; `digest` is the CRC-32C of all of it. The head answers with an
/// [`UploadAck`] at offset 0 and never uses the set before a [`Command::ConfirmUpload`] whose
/// digest check passed.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct BeginUpload {
    /// Slot.
    pub set_id: u8,
    /// Number of images, `>= 1`.
    pub image_count: u16,
    /// Image width, `>= 1`.
    pub width: u16,
    /// Image height, `>= 1`.
    pub height: u16,
    /// Significant bits per pixel, `1..=MAX_BIT_DEPTH`.
    pub bit_depth: u8,
    /// `image_count · width · height`.
    pub total_bytes: u32,
    /// CRC-32C of all image bytes.
    pub digest: u32,
}

impl BeginUpload {
    /// Check the fields' ranges and `total_bytes`.
    pub fn validate(&self) -> Result<(), WireError> {
        check(
            self.image_count >= 1 && self.width >= 1 && self.height >= 1,
            Invalid::Dimension,
        )?;
        check(bit_depth_ok(self.bit_depth), Invalid::BitDepth)?;
        let want = self.image_count as u64 * self.width as u64 * self.height as u64;
        check(want == self.total_bytes as u64, Invalid::TotalBytes)
    }
}

/// Host → head: start uploading the reference phase map.
///
/// The map covers the image and `margin` past it on each side (issue #17 item 3,
/// [`Margin`]): `(left + width + right)` columns by `(top + height + bottom)` rows, its
/// sample `(i, j)` at image pixel `(i − left, j − top)`. The data is the map's rows from the
/// top, each its columns' little-endian f32 phases then as many validity bytes ([`Validity`]
/// codes), as in a phase [`ResultRow`]; `digest` is the CRC-32C of all of it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct BeginPhaseMap {
    /// The image width (the camera's), `>= 1`.
    pub width: u16,
    /// The image height, `>= 1`.
    pub height: u16,
    /// How far the map extends past the image, each side at most [`MAX_MARGIN`]
    /// ([`Margin::ZERO`]: an image-sized map).
    pub margin: Margin,
    /// `map_width · map_height · PHASE_MAP_BYTES_PER_PIXEL`.
    pub total_bytes: u32,
    /// CRC-32C of all bytes.
    pub digest: u32,
}

impl BeginPhaseMap {
    /// Columns of the map: the image's and the left and right margins.
    pub fn map_width(&self) -> u32 {
        u32::from(self.width) + self.margin.left + self.margin.right
    }

    /// Rows of the map: the image's and the top and bottom margins.
    pub fn map_height(&self) -> u32 {
        u32::from(self.height) + self.margin.top + self.margin.bottom
    }

    /// Check the fields' ranges and `total_bytes`.
    pub fn validate(&self) -> Result<(), WireError> {
        check(self.width >= 1 && self.height >= 1, Invalid::Dimension)?;
        check(
            self.margin.to_array().iter().all(|&m| m <= MAX_MARGIN),
            Invalid::Margin,
        )?;
        let want = u64::from(self.map_width())
            * u64::from(self.map_height())
            * PHASE_MAP_BYTES_PER_PIXEL as u64;
        check(want == self.total_bytes as u64, Invalid::TotalBytes)
    }
}

/// Host → head: start uploading the compiled reconstruction (docs/compiled.md; protocol
/// version 9; each model eleven numbers, 44 bytes, since version 10).
///
/// The data is the models of a `width × height` camera, row after row from the top, each row
/// its [`PixelModel`]s field by field ([`PixelModel::store`]: eleven arrays of `width`
/// little-endian f32), exactly the rows of a `fringe3d compile` file after its header; `digest`
/// is the CRC-32C of all of it. The models were compiled for the depth range `[z_min, z_max]` (the
/// calibration's, rounded to f32) from one calibration and reference map: a head takes them only
/// after that calibration and a confirmed map, checks the size and the depth range against its
/// calibration, and forgets them when either is replaced. A head reconstructs the pixels with a
/// model through it and the others with the §6 search, which the map serves.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct BeginCompiled {
    /// The camera width, `>= 1`.
    pub width: u16,
    /// The camera height, `>= 1`.
    pub height: u16,
    /// The near end of the depth range the models were compiled for, mm.
    pub z_min: f32,
    /// The far end, mm, `> z_min`.
    pub z_max: f32,
    /// `width · height ·` [`COMPILED_BYTES_PER_PIXEL`].
    pub total_bytes: u32,
    /// CRC-32C of all bytes.
    pub digest: u32,
}

/// Bytes per pixel of the compiled reconstruction's models ([`PixelModel::BYTES`]).
pub const COMPILED_BYTES_PER_PIXEL: usize = PixelModel::BYTES;

impl BeginCompiled {
    /// Bytes of one row of models.
    pub fn row_bytes(&self) -> u32 {
        u32::from(self.width) * COMPILED_BYTES_PER_PIXEL as u32
    }

    /// Check the fields' ranges and `total_bytes`.
    pub fn validate(&self) -> Result<(), WireError> {
        check(self.width >= 1 && self.height >= 1, Invalid::Dimension)?;
        check(
            self.z_min.is_finite() && self.z_max.is_finite(),
            Invalid::NotFinite,
        )?;
        check(self.z_min < self.z_max, Invalid::DepthRange)?;
        let want = u64::from(self.width) * u64::from(self.height) * COMPILED_BYTES_PER_PIXEL as u64;
        check(want == self.total_bytes as u64, Invalid::TotalBytes)
    }
}

/// Host → head: bytes `offset .. offset + data.len()` of the open upload of `target`.
///
/// The head accepts a chunk only at its current offset (the one of its last [`UploadAck`]); an
/// interrupted upload resumes from there after a [`Command::QueryUpload`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct UploadChunk<'a> {
    /// Which upload.
    pub target: UploadTarget,
    /// Byte offset of `data` in the upload.
    pub offset: u32,
    /// CRC-32C of `data` (checked by [`UploadChunk::validate`]).
    pub crc: u32,
    /// `1..=MAX_CHUNK` bytes.
    pub data: &'a [u8],
}

impl<'a> UploadChunk<'a> {
    /// A chunk with its CRC computed.
    pub fn new(target: UploadTarget, offset: u32, data: &'a [u8]) -> Self {
        UploadChunk {
            target,
            offset,
            crc: crc32c(data),
            data,
        }
    }

    /// Check the length, that the end offset fits a u32, and the CRC.
    pub fn validate(&self) -> Result<(), WireError> {
        check(
            (1..=MAX_CHUNK).contains(&self.data.len()),
            Invalid::ChunkSize,
        )?;
        check(
            self.offset as u64 + self.data.len() as u64 <= u32::MAX as u64,
            Invalid::Offset,
        )?;
        check(crc32c(self.data) == self.crc, Invalid::ChunkCrc)
    }
}

/// Head → host: the upload of `target` holds bytes `0 .. next_offset` (the next chunk must start
/// there). `next_offset == total_bytes` means complete (awaiting confirmation).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct UploadAck {
    /// Which upload.
    pub target: UploadTarget,
    /// First byte not yet received.
    pub next_offset: u32,
}

impl Body for UploadTarget {}

impl Body for BeginUpload {
    fn validate_body(&self) -> Result<(), WireError> {
        self.validate()
    }
}

impl Body for BeginPhaseMap {
    fn validate_body(&self) -> Result<(), WireError> {
        self.validate()
    }
}

impl Body for BeginCompiled {
    fn validate_body(&self) -> Result<(), WireError> {
        self.validate()
    }
}

impl Body for UploadChunk<'_> {
    fn validate_body(&self) -> Result<(), WireError> {
        self.validate()
    }
}

impl Body for UploadAck {}
