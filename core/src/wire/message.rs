//! Messages: the payloads of frames, one struct per command, postcard-encoded.
//!
//! The header's command byte says which body follows; the payload is the postcard encoding of that
//! body alone (no enum tag). Every body has a `validate` step that [`Message::decode`] and
//! [`Message::encode`] both run, so nothing invalid is sent or accepted.

use serde::{Deserialize, Deserializer, Serialize, Serializer};

use super::crc::crc32c;
use super::{Invalid, MAX_PAYLOAD, WireError};
use crate::Validity;
pub use crate::params::pattern::{
    Knots, Level, MAX_KNOTS, MAX_LEVELS, MAX_SHIFTS, PatternAxis, PatternSetDesc, PhaseDesc,
    PhaseProfile, Shifts, Waveform,
};
pub use crate::params::{CameraParams, ScanGeometry};

/// Most data bytes in one [`UploadChunk`]; a multiple of 4 so phase-map chunks can hold whole f32s.
pub const MAX_CHUNK: usize = 4064;
/// Most data bytes in one [`ResultRow`].
pub const MAX_ROW_DATA: usize = 4064;
/// Length of one packed [`LutEntry`].
pub const LUT_ENTRY_LEN: usize = 12;
/// Most entries in a trigger sequence ([`Sequence`]).
pub const MAX_LUT_ENTRIES: usize = 256;
/// Highest pattern bit depth (one byte per pixel).
pub const MAX_BIT_DEPTH: u8 = 8;
/// Bytes per pixel of the reference phase map: f32 phase plus one validity byte.
pub const PHASE_MAP_BYTES_PER_PIXEL: usize = 5;

/// Command ids, the header's byte 3. Requests (host → head) are `0x00..=0x7F`, replies and
/// notifications (head → host) `0x80..=0xFF`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[repr(u8)]
pub enum Command {
    /// [`Hello`] → [`Capabilities`].
    Hello = 0x01,
    /// [`DefinePatternSet`] → Ack.
    DefinePatternSet = 0x10,
    /// [`BeginUpload`] → [`UploadAck`].
    BeginUpload = 0x11,
    /// [`UploadChunk`] → [`UploadAck`].
    UploadChunk = 0x12,
    /// [`UploadTarget`] → [`UploadAck`] (where to resume).
    QueryUpload = 0x13,
    /// [`UploadTarget`] → Ack, or Nak [`NakCode::DigestMismatch`].
    ConfirmUpload = 0x14,
    /// [`Calibration`] → Ack.
    UploadCalibration = 0x18,
    /// [`BeginPhaseMap`] → [`UploadAck`].
    BeginPhaseMapUpload = 0x19,
    /// [`Sequence`] → Ack.
    ConfigureSequence = 0x20,
    /// (empty) → [`ValidationStatus`].
    ValidateSequence = 0x21,
    /// (empty) → Ack. Starts the configured sequence.
    Start = 0x22,
    /// (empty) → Ack. Stops it.
    Stop = 0x23,
    /// [`ScanRequest`] → Ack, then [`ResultRow`]s, then [`ScanDone`].
    Scan = 0x30,
    /// (empty) → Ack. Aborts whatever runs.
    Abort = 0x31,
    /// (empty) → [`Status`].
    GetStatus = 0x32,
    /// [`Capabilities`].
    Capabilities = 0x80,
    /// [`Ack`].
    Ack = 0x81,
    /// [`Nak`] (header flag ERROR set).
    Nak = 0x82,
    /// [`UploadAck`].
    UploadAck = 0x83,
    /// [`ValidationStatus`].
    Validation = 0x84,
    /// [`Status`].
    Status = 0x85,
    /// [`ResultRow`].
    ResultRow = 0x86,
    /// [`ScanDone`].
    ScanDone = 0x87,
}

impl Command {
    /// Every command, in id order.
    pub const ALL: [Command; 23] = [
        Command::Hello,
        Command::DefinePatternSet,
        Command::BeginUpload,
        Command::UploadChunk,
        Command::QueryUpload,
        Command::ConfirmUpload,
        Command::UploadCalibration,
        Command::BeginPhaseMapUpload,
        Command::ConfigureSequence,
        Command::ValidateSequence,
        Command::Start,
        Command::Stop,
        Command::Scan,
        Command::Abort,
        Command::GetStatus,
        Command::Capabilities,
        Command::Ack,
        Command::Nak,
        Command::UploadAck,
        Command::Validation,
        Command::Status,
        Command::ResultRow,
        Command::ScanDone,
    ];

    /// The command with id `id`, if any.
    pub const fn from_u8(id: u8) -> Option<Command> {
        let mut i = 0;
        while i < Self::ALL.len() {
            if Self::ALL[i] as u8 == id {
                return Some(Self::ALL[i]);
            }
            i += 1;
        }
        None
    }

    /// `true` for host → head requests (ids below `0x80`).
    pub const fn is_request(self) -> bool {
        (self as u8) < 0x80
    }

    /// `true` for requests that change the head's state: their frames carry
    /// [`Flags::WRITE`](super::Flags::WRITE), all others must not.
    pub const fn is_write(self) -> bool {
        !matches!(
            self,
            Command::Hello
                | Command::QueryUpload
                | Command::ValidateSequence
                | Command::GetStatus
                | Command::Capabilities
                | Command::Ack
                | Command::Nak
                | Command::UploadAck
                | Command::Validation
                | Command::Status
                | Command::ResultRow
                | Command::ScanDone
        )
    }
}

impl TryFrom<u8> for Command {
    type Error = WireError;
    fn try_from(id: u8) -> Result<Self, WireError> {
        Command::from_u8(id).ok_or(WireError::UnknownCommand(id))
    }
}

fn check(ok: bool, why: Invalid) -> Result<(), WireError> {
    if ok {
        Ok(())
    } else {
        Err(WireError::Invalid(why))
    }
}

fn finite64(xs: &[f64]) -> Result<(), WireError> {
    check(xs.iter().all(|x| x.is_finite()), Invalid::NotFinite)
}

fn bit_depth_ok(b: u8) -> bool {
    (1..=MAX_BIT_DEPTH).contains(&b)
}

// ---------------------------------------------------------------------------------------------
// Hello / capabilities

/// Host → head greeting.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Hello {
    /// The protocol version the host speaks ([`PROTOCOL_VERSION`](super::PROTOCOL_VERSION)).
    pub protocol_version: u8,
}

/// A firmware version triple.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct FirmwareVersion {
    /// Major version.
    pub major: u8,
    /// Minor version.
    pub minor: u8,
    /// Patch level.
    pub patch: u8,
}

/// Head → host: what the head is and can do (reply to [`Hello`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Capabilities {
    /// The protocol version the head speaks.
    pub protocol_version: u8,
    /// The firmware's version.
    pub firmware: FirmwareVersion,
    /// Camera sensor width in pixels.
    pub sensor_width: u16,
    /// Camera sensor height in pixels.
    pub sensor_height: u16,
    /// Projector width in pixels.
    pub projector_width: u16,
    /// Projector height in pixels.
    pub projector_height: u16,
    /// Free memory for pattern images and maps, bytes.
    pub free_memory: u32,
    /// Largest [`UploadChunk`] data the head accepts, `1..=MAX_CHUNK`.
    pub max_chunk: u16,
    /// Number of pattern-set slots (`set_id < max_sets`).
    pub max_sets: u8,
    /// Largest trigger sequence, `1..=MAX_LUT_ENTRIES`.
    pub max_lut_entries: u16,
}

impl Capabilities {
    /// Check the fields' ranges.
    pub fn validate(&self) -> Result<(), WireError> {
        check(
            (1..=MAX_CHUNK).contains(&(self.max_chunk as usize)),
            Invalid::ChunkSize,
        )?;
        check(
            (1..=MAX_LUT_ENTRIES).contains(&(self.max_lut_entries as usize)),
            Invalid::LutLength,
        )
    }
}

// ---------------------------------------------------------------------------------------------
// Pattern sets: the description types live in `crate::params::pattern`; their field checks here.

impl Shifts {
    pub(crate) fn validate(&self) -> Result<(), WireError> {
        match *self {
            Shifts::Uniform { n, count } => check(
                count >= 1 && count <= n && n as usize <= MAX_SHIFTS,
                Invalid::Shifts,
            ),
            Shifts::Explicit { count, radians } => {
                let count = count as usize;
                check((1..=MAX_SHIFTS).contains(&count), Invalid::Shifts)?;
                let (used, unused) = radians.split_at(count);
                finite64(used)?;
                check(unused.iter().all(|x| x.to_bits() == 0), Invalid::UnusedSlot)
            }
        }
    }
}

impl PatternSetDesc {
    /// Check every field (see the field docs). What only the whole set can tell (monotonic,
    /// continuous phase, coarse range, scales increasing, shifts separating the unknowns) is
    /// checked by [`PatternSetDesc::to_set`].
    pub fn validate(&self) -> Result<(), WireError> {
        check(self.width >= 1 && self.height >= 1, Invalid::Dimension)?;
        check(bit_depth_ok(self.bit_depth), Invalid::BitDepth)?;
        let p = &self.phase;
        finite64(&[
            self.i_min,
            self.i_max,
            self.phase_offset,
            p.curvature,
            p.bend_center,
        ])?;
        let full = ((1u32 << self.bit_depth) - 1) as f64;
        check(
            self.i_min >= 0.0 && self.i_min < self.i_max && self.i_max <= full,
            Invalid::Intensity,
        )?;
        match &p.profile {
            PhaseProfile::Linear { origin, slope } => {
                finite64(&[*origin, *slope])?;
                check(*slope > 0.0, Invalid::PhaseFunction)?;
            }
            PhaseProfile::Knots(k) => {
                let n = k.count as usize;
                check((2..=MAX_KNOTS).contains(&n), Invalid::PhaseFunction)?;
                for a in [&k.s, &k.phi, &k.slope] {
                    let (used, unused) = a.split_at(n);
                    finite64(used)?;
                    check(unused.iter().all(|x| x.to_bits() == 0), Invalid::UnusedSlot)?;
                }
            }
        }
        let n = self.level_count as usize;
        check((1..=MAX_LEVELS).contains(&n), Invalid::LevelCount)?;
        let (used, unused) = self.levels.split_at(n);
        for level in used {
            finite64(&[level.scale])?;
            check(level.scale > 0.0, Invalid::Scale)?;
            level.shifts.validate()?;
        }
        check(unused.iter().all(Level::is_unused), Invalid::UnusedSlot)
    }
}

/// Host → head: define pattern set `set_id` parametrically (the head renders it itself).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct DefinePatternSet {
    /// Slot, `< Capabilities::max_sets`.
    pub set_id: u8,
    /// The set.
    pub desc: PatternSetDesc,
}

// ---------------------------------------------------------------------------------------------
// Uploads

/// What an upload fills.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum UploadTarget {
    /// The images of pattern set `set_id` (wire value 0, then the u8).
    PatternSet(u8),
    /// The reference phase map (wire value 1).
    PhaseMap,
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
/// The data is `height` rows, each `width` little-endian f32 phases then `width` validity bytes
/// ([`Validity`] codes), as in a phase [`ResultRow`]; `digest` is the CRC-32C of all of it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct BeginPhaseMap {
    /// Map width (the camera's), `>= 1`.
    pub width: u16,
    /// Map height, `>= 1`.
    pub height: u16,
    /// `width · height · PHASE_MAP_BYTES_PER_PIXEL`.
    pub total_bytes: u32,
    /// CRC-32C of all bytes.
    pub digest: u32,
}

impl BeginPhaseMap {
    /// Check the fields' ranges and `total_bytes`.
    pub fn validate(&self) -> Result<(), WireError> {
        check(self.width >= 1 && self.height >= 1, Invalid::Dimension)?;
        let want = self.width as u64 * self.height as u64 * PHASE_MAP_BYTES_PER_PIXEL as u64;
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

// ---------------------------------------------------------------------------------------------
// Calibration

/// Host → head: everything reconstruction needs besides the reference phase map: the camera's
/// [`CameraParams`] and the [`ScanGeometry`] of the core's [`Setup`](crate::reconstruct::Setup),
/// in f64, so the head's reconstructor is the desktop's ([`Calibration::reconstructor`]).
/// Encoded as the two in turn (postcard is positional).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Calibration {
    /// The camera.
    pub camera: CameraParams,
    /// Projector centre, reference plane, depth range.
    pub geometry: ScanGeometry,
}

impl Calibration {
    /// Check finiteness and ranges.
    pub fn validate(&self) -> Result<(), WireError> {
        let c = &self.camera;
        let g = &self.geometry;
        // Sizes travel as varints and were u16 before the shared type: keep the same range.
        let side = 1..=u32::from(u16::MAX);
        check(
            side.contains(&c.width) && side.contains(&c.height),
            Invalid::Dimension,
        )?;
        finite64(&c.to_vector())?;
        finite64(&g.projector_centre)?;
        finite64(&g.plane_point)?;
        finite64(&g.plane_normal)?;
        finite64(&[g.depth_min, g.depth_max])?;
        check(c.fx > 0.0 && c.fy > 0.0, Invalid::Intrinsics)?;
        check(
            g.plane_normal.iter().any(|&x| x != 0.0),
            Invalid::PlaneNormal,
        )?;
        check(g.depth_min < g.depth_max, Invalid::DepthRange)
    }
}

// ---------------------------------------------------------------------------------------------
// Trigger sequence

/// One entry of the trigger look-up table (DLPC350-style pattern LUT).
///
/// Packed on the wire as 12 bytes, little-endian:
///
/// | offset | size | field                                            |
/// |-------:|-----:|--------------------------------------------------|
/// | 0      | 2    | `pattern`                                        |
/// | 2      | 4    | `exposure_us`                                    |
/// | 6      | 4    | `dark_us`                                        |
/// | 10     | 1    | `bit_depth`                                      |
/// | 11     | 1    | bit 0 `wait_for_trigger`, bit 1 `trigger_out`, bits 2-7 reserved 0 |
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct LutEntry {
    /// Index of the pattern in the set (levels in order, shifts in order).
    pub pattern: u16,
    /// Exposure (pattern display) time, µs, `>= 1`.
    pub exposure_us: u32,
    /// Dark time after the exposure, µs.
    pub dark_us: u32,
    /// Bit depth to display, `1..=MAX_BIT_DEPTH`.
    pub bit_depth: u8,
    /// Wait for the external trigger input before this pattern.
    pub wait_for_trigger: bool,
    /// Pulse the camera trigger output with this pattern.
    pub trigger_out: bool,
}

impl LutEntry {
    /// The packed form.
    pub fn to_bytes(&self) -> [u8; LUT_ENTRY_LEN] {
        let mut b = [0u8; LUT_ENTRY_LEN];
        b[0..2].copy_from_slice(&self.pattern.to_le_bytes());
        b[2..6].copy_from_slice(&self.exposure_us.to_le_bytes());
        b[6..10].copy_from_slice(&self.dark_us.to_le_bytes());
        b[10] = self.bit_depth;
        b[11] = self.wait_for_trigger as u8 | (self.trigger_out as u8) << 1;
        b
    }

    /// Unpack and validate one entry.
    pub fn from_bytes(b: &[u8; LUT_ENTRY_LEN]) -> Result<LutEntry, WireError> {
        let e = Self::unpack(b);
        check(b[11] & !0b11 == 0, Invalid::ReservedBits)?;
        e.validate()?;
        Ok(e)
    }

    fn unpack(b: &[u8; LUT_ENTRY_LEN]) -> LutEntry {
        LutEntry {
            pattern: u16::from_le_bytes([b[0], b[1]]),
            exposure_us: u32::from_le_bytes([b[2], b[3], b[4], b[5]]),
            dark_us: u32::from_le_bytes([b[6], b[7], b[8], b[9]]),
            bit_depth: b[10],
            wait_for_trigger: b[11] & 1 != 0,
            trigger_out: b[11] & 2 != 0,
        }
    }

    /// Check the bit depth and exposure.
    pub fn validate(&self) -> Result<(), WireError> {
        check(
            bit_depth_ok(self.bit_depth) && self.exposure_us >= 1,
            Invalid::LutEntry,
        )
    }
}

/// A borrowed table of packed [`LutEntry`]s; on the wire a postcard byte string (varint length,
/// then the entries). The length is always a multiple of [`LUT_ENTRY_LEN`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LutTable<'a>(&'a [u8]);

impl<'a> LutTable<'a> {
    /// Wrap packed entries, validating every one and the count (`1..=MAX_LUT_ENTRIES`).
    pub fn new(bytes: &'a [u8]) -> Result<Self, WireError> {
        let t = LutTable::from_raw(bytes)?;
        t.validate()?;
        Ok(t)
    }

    fn from_raw(bytes: &'a [u8]) -> Result<Self, WireError> {
        check(
            bytes.len().is_multiple_of(LUT_ENTRY_LEN),
            Invalid::LutLength,
        )?;
        Ok(LutTable(bytes))
    }

    /// Pack `entries` into `out` and wrap the result.
    pub fn encode(entries: &[LutEntry], out: &'a mut [u8]) -> Result<Self, WireError> {
        let n = entries.len() * LUT_ENTRY_LEN;
        let out = out.get_mut(..n).ok_or(WireError::BufferTooSmall)?;
        for (e, dst) in entries.iter().zip(out.chunks_exact_mut(LUT_ENTRY_LEN)) {
            dst.copy_from_slice(&e.to_bytes());
        }
        LutTable::new(out)
    }

    /// The packed bytes.
    pub const fn as_bytes(&self) -> &'a [u8] {
        self.0
    }

    /// Number of entries.
    pub const fn len(&self) -> usize {
        self.0.len() / LUT_ENTRY_LEN
    }

    /// `true` if there are no entries.
    pub const fn is_empty(&self) -> bool {
        self.0.len() < LUT_ENTRY_LEN
    }

    /// Entry `i`.
    pub fn get(&self, i: usize) -> Option<LutEntry> {
        let start = i.checked_mul(LUT_ENTRY_LEN)?;
        let b = self.0.get(start..start.checked_add(LUT_ENTRY_LEN)?)?;
        b.try_into().ok().map(LutEntry::unpack)
    }

    /// The entries in order.
    pub fn iter(&self) -> impl Iterator<Item = LutEntry> + 'a {
        self.0
            .chunks_exact(LUT_ENTRY_LEN)
            .filter_map(|c| c.try_into().ok().map(LutEntry::unpack))
    }

    /// Check the count and every entry.
    pub fn validate(&self) -> Result<(), WireError> {
        check(
            (1..=MAX_LUT_ENTRIES).contains(&self.len()),
            Invalid::LutLength,
        )?;
        for c in self.0.chunks_exact(LUT_ENTRY_LEN) {
            let b: &[u8; LUT_ENTRY_LEN] = c
                .try_into()
                .map_err(|_| WireError::Invalid(Invalid::LutLength))?;
            LutEntry::from_bytes(b)?;
        }
        Ok(())
    }
}

impl Serialize for LutTable<'_> {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_bytes(self.0)
    }
}

impl<'de: 'a, 'a> Deserialize<'de> for LutTable<'a> {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let bytes = <&'de [u8]>::deserialize(d)?;
        LutTable::from_raw(bytes)
            .map_err(|_| serde::de::Error::invalid_length(bytes.len(), &"a multiple of 12 bytes"))
    }
}

/// Host → head: the trigger sequence over pattern set `set_id`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Sequence<'a> {
    /// The pattern set the entries index.
    pub set_id: u8,
    /// Repeat the sequence until Stop (otherwise run it once per Start).
    pub repeat: bool,
    /// The entries, `1..=MAX_LUT_ENTRIES`.
    #[serde(borrow)]
    pub entries: LutTable<'a>,
}

/// A bit-field: what the head's Validate found wrong with the configured sequence (0 = valid).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct ValidationStatus(pub u32);

impl ValidationStatus {
    /// Nothing wrong.
    pub const OK: ValidationStatus = ValidationStatus(0);
    /// No sequence configured.
    pub const NO_SEQUENCE: u32 = 1 << 0;
    /// The sequence's pattern set is not defined.
    pub const NO_PATTERN_SET: u32 = 1 << 1;
    /// The pattern set's upload digest has not been confirmed.
    pub const SET_NOT_CONFIRMED: u32 = 1 << 2;
    /// An entry's pattern index is beyond the set.
    pub const PATTERN_INDEX: u32 = 1 << 3;
    /// An exposure is shorter than the hardware allows for its bit depth.
    pub const EXPOSURE: u32 = 1 << 4;
    /// A dark time is shorter than the camera readout.
    pub const DARK_TIME: u32 = 1 << 5;
    /// An entry's bit depth differs from the set's.
    pub const BIT_DEPTH: u32 = 1 << 6;
    /// Trigger settings are inconsistent (e.g. no entry triggers the camera).
    pub const TRIGGER: u32 = 1 << 7;
    /// No calibration uploaded.
    pub const NO_CALIBRATION: u32 = 1 << 8;
    /// No confirmed reference phase map.
    pub const NO_REFERENCE: u32 = 1 << 9;
    /// A sequence or scan is running.
    pub const BUSY: u32 = 1 << 10;
    /// All defined bits.
    pub const ALL: u32 = (1 << 11) - 1;

    /// `true` if no bit is set.
    pub const fn is_ok(self) -> bool {
        self.0 == 0
    }

    /// `true` if bit(s) `bit` are all set.
    pub const fn has(self, bit: u32) -> bool {
        self.0 & bit == bit
    }

    /// Check that no reserved bit is set.
    pub fn validate(&self) -> Result<(), WireError> {
        check(self.0 & !Self::ALL == 0, Invalid::ReservedBits)
    }
}

// ---------------------------------------------------------------------------------------------
// Scanning

/// What a scan streams back.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum ScanOutput {
    /// Absolute phase rows (wire value 0).
    Phase,
    /// Point rows (wire value 1).
    Points,
    /// Both, phase row first (wire value 2).
    Both,
}

/// Whether a point scan runs the depth-edge filter ([`EdgeFilter`](crate::filter::EdgeFilter),
/// as `fringe3d scan` does by default).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum EdgeFilterMode {
    /// No filter (wire value 0).
    Off,
    /// Flag points steeper than this many degrees from facing the camera, `0 < angle < 90`
    /// (wire value 1, then the f64).
    MaxAngle(f64),
}

/// Host → head: run the configured sequence, decode, stream rows.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ScanRequest {
    /// What to stream.
    pub output: ScanOutput,
    /// First camera row to stream.
    pub first_row: u16,
    /// Number of rows (0 = to the last row).
    pub row_count: u16,
    /// The depth-edge filter of point rows (ignored for phase rows).
    pub edge_filter: EdgeFilterMode,
}

impl ScanRequest {
    /// Check the filter angle.
    pub fn validate(&self) -> Result<(), WireError> {
        match self.edge_filter {
            EdgeFilterMode::Off => Ok(()),
            EdgeFilterMode::MaxAngle(a) => {
                finite64(&[a])?;
                check(a > 0.0 && a < 90.0, Invalid::EdgeFilter)
            }
        }
    }
}

/// The kind of a [`ResultRow`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum RowKind {
    /// One f32 per column: the absolute phase (wire value 0).
    Phase,
    /// Three f32 per column: x, y, z in mm, camera frame (wire value 1).
    Points,
}

impl RowKind {
    /// f32 values per column.
    pub const fn components(self) -> usize {
        match self {
            RowKind::Phase => 1,
            RowKind::Points => 3,
        }
    }

    /// Data bytes per column: the f32s and one validity byte.
    pub const fn stride(self) -> usize {
        4 * self.components() + 1
    }
}

/// Head → host: a segment of one result row, columns `first_col ..`.
///
/// `data` holds `n` columns: first `n · components` little-endian f32s (points interleaved
/// x, y, z), then `n` [`Validity`] bytes. A row wider than [`MAX_ROW_DATA`] allows is sent as
/// several segments with increasing `first_col`. Like every frame answering a Scan except the
/// final [`ScanDone`], row frames carry [`Flags::MORE_FOLLOWS`](super::Flags::MORE_FOLLOWS).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct ResultRow<'a> {
    /// Camera row.
    pub row: u16,
    /// Column of the segment's first value.
    pub first_col: u16,
    /// Phase or points.
    pub kind: RowKind,
    /// Values then validity bytes, `n · kind.stride()` bytes, `1..=MAX_ROW_DATA`.
    pub data: &'a [u8],
}

impl<'a> ResultRow<'a> {
    /// Lay out `values` (`n · kind.components()` f32s) and `validity` (`n` codes) into `out` as a
    /// row segment's `data`; returns the data slice.
    pub fn write_data<'o>(
        kind: RowKind,
        values: &[f32],
        validity: &[Validity],
        out: &'o mut [u8],
    ) -> Result<&'o [u8], WireError> {
        let n = validity.len();
        check(values.len() == n * kind.components(), Invalid::RowData)?;
        let vbytes = values.len() * 4;
        let out = out
            .get_mut(..n * kind.stride())
            .ok_or(WireError::BufferTooSmall)?;
        let (vals, codes) = out.split_at_mut(vbytes);
        for (x, dst) in values.iter().zip(vals.chunks_exact_mut(4)) {
            dst.copy_from_slice(&x.to_le_bytes());
        }
        for (v, dst) in validity.iter().zip(codes.iter_mut()) {
            *dst = *v as u8;
        }
        Ok(out)
    }

    /// Number of columns in the segment.
    pub const fn columns(&self) -> usize {
        self.data.len() / self.kind.stride()
    }

    /// Component `comp` of column `i` (relative to `first_col`).
    pub fn value(&self, i: usize, comp: usize) -> Option<f32> {
        let k = self.kind.components();
        if comp >= k || i >= self.columns() {
            return None;
        }
        let at = (i * k + comp) * 4;
        let b = self.data.get(at..at + 4)?;
        Some(f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
    }

    /// Validity of column `i` (relative to `first_col`).
    pub fn validity(&self, i: usize) -> Option<Validity> {
        let n = self.columns();
        if i >= n {
            return None;
        }
        let b = *self.data.get(n * 4 * self.kind.components() + i)?;
        Validity::from_u8(b)
    }

    /// Check the length and the validity codes.
    pub fn validate(&self) -> Result<(), WireError> {
        let stride = self.kind.stride();
        let len = self.data.len();
        check(
            (1..=MAX_ROW_DATA).contains(&len) && len.is_multiple_of(stride),
            Invalid::RowData,
        )?;
        let n = len / stride;
        check(
            self.first_col as usize + n <= u16::MAX as usize + 1,
            Invalid::RowData,
        )?;
        let codes = &self.data[n * 4 * self.kind.components()..];
        check(
            codes.iter().all(|&b| Validity::from_u8(b).is_some()),
            Invalid::ValidityCode,
        )
    }
}

/// Head → host: the scan finished (after its last [`ResultRow`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct ScanDone {
    /// Rows streamed.
    pub rows: u16,
    /// Valid pixels (phase) or points over all rows.
    pub valid: u32,
}

// ---------------------------------------------------------------------------------------------
// Status, ack, nak

/// The head's state machine.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum HeadState {
    /// Nothing configured or running (wire value 0).
    Idle,
    /// An upload is open (1).
    Uploading,
    /// A validated sequence is ready to start (2).
    Ready,
    /// The sequence is projecting (3).
    Running,
    /// A scan is capturing and streaming (4).
    Scanning,
    /// A fault stopped the head; see the error flags (5).
    Fault,
}

/// A bit-field of faults the head has seen since the last status read.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct HeadErrors(pub u32);

impl HeadErrors {
    /// Frames were dropped on the link (COBS, CRC, overflow).
    pub const LINK: u32 = 1 << 0;
    /// An upload failed its digest.
    pub const UPLOAD: u32 = 1 << 1;
    /// A trigger input did not arrive in time.
    pub const TRIGGER_TIMEOUT: u32 = 1 << 2;
    /// Camera fault.
    pub const CAMERA: u32 = 1 << 3;
    /// Projector fault.
    pub const PROJECTOR: u32 = 1 << 4;
    /// Result rows were dropped because the link was too slow.
    pub const OVERRUN: u32 = 1 << 5;
    /// Out of memory.
    pub const MEMORY: u32 = 1 << 6;
    /// Internal error.
    pub const INTERNAL: u32 = 1 << 7;
    /// All defined bits.
    pub const ALL: u32 = 0xFF;

    /// Check that no reserved bit is set.
    pub fn validate(&self) -> Result<(), WireError> {
        check(self.0 & !Self::ALL == 0, Invalid::ReservedBits)
    }
}

/// Head → host: state and counters.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Status {
    /// State machine state.
    pub state: HeadState,
    /// Faults seen.
    pub errors: HeadErrors,
    /// Frames received intact.
    pub rx_frames: u32,
    /// Frames received damaged.
    pub rx_errors: u32,
    /// Frames sent.
    pub tx_frames: u32,
    /// Result rows sent.
    pub rows_sent: u32,
}

/// Head → host: the request with the header's `seq` succeeded.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Ack {
    /// The command acknowledged.
    pub command: u8,
}

/// Why a request failed. The wire value is the position in this list (shown in brackets).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum NakCode {
    /// \[0] The frame's CRC was wrong.
    Crc,
    /// \[1] The frame was malformed (COBS, length, truncated).
    Framing,
    /// \[2] Unsupported protocol version.
    Version,
    /// \[3] Unknown command id.
    UnknownCommand,
    /// \[4] The payload did not decode, or flags contradict the command.
    Malformed,
    /// \[5] A field is out of range; `detail` is the [`Invalid`] code.
    Invalid,
    /// \[6] The head is busy (a sequence or scan runs).
    Busy,
    /// \[7] The request is not allowed in the current state.
    NotReady,
    /// \[8] No such pattern set (or not confirmed).
    NoSuchSet,
    /// \[9] The uploaded data does not match the announced digest.
    DigestMismatch,
    /// \[10] Not enough memory.
    OutOfMemory,
    /// \[11] The chunk does not start at the expected offset; `detail` is unused, query the
    /// offset with QueryUpload.
    BadOffset,
    /// \[12] No upload is open for the target.
    NoUpload,
    /// \[13] The sequence is invalid (Validate tells why).
    SequenceInvalid,
    /// \[14] Aborted by the host.
    Aborted,
    /// \[15] Internal error.
    Internal,
}

/// Head → host: the request with the header's `seq` failed. Sent with
/// [`Flags::ERROR`](super::Flags::ERROR).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Nak {
    /// The command refused (0 if unknown).
    pub command: u8,
    /// Why.
    pub code: NakCode,
    /// Code-specific detail (e.g. the [`Invalid`] code), else 0.
    pub detail: u16,
}

impl Nak {
    /// The Nak answering a request that failed to parse with `err`.
    pub const fn for_error(command: u8, err: WireError) -> Nak {
        let (code, detail) = match err {
            WireError::Crc => (NakCode::Crc, 0),
            WireError::Cobs | WireError::Truncated | WireError::Overflow | WireError::Length => {
                (NakCode::Framing, 0)
            }
            WireError::Version(_) => (NakCode::Version, 0),
            WireError::UnknownCommand(_) => (NakCode::UnknownCommand, 0),
            WireError::Invalid(why) => (NakCode::Invalid, why as u16),
            WireError::BufferTooSmall | WireError::PayloadTooLarge => (NakCode::Internal, 0),
            WireError::ReservedFlags
            | WireError::FlagMismatch
            | WireError::CommandMismatch
            | WireError::Payload
            | WireError::TrailingBytes => (NakCode::Malformed, 0),
        };
        Nak {
            command,
            code,
            detail,
        }
    }
}

// ---------------------------------------------------------------------------------------------
// The message enum

/// Every message, request or reply. The variant's [`Command`] is the header's command byte; its
/// body, postcard-encoded, is the payload (empty for the unit variants).
///
/// About 1.4 KB, nearly all of it the pattern-set variant; without alloc there is nothing to box
/// it into, and a head keeps one message at a time.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Message<'a> {
    /// Host greeting.
    Hello(Hello),
    /// Define a parametric pattern set.
    DefinePatternSet(DefinePatternSet),
    /// Start a pattern-image upload.
    BeginUpload(BeginUpload),
    /// One upload chunk.
    UploadChunk(UploadChunk<'a>),
    /// Ask where an upload stands.
    QueryUpload(UploadTarget),
    /// Ask the head to check an upload's digest and adopt it (the "ConfirmSet" of issue #7).
    ConfirmUpload(UploadTarget),
    /// Upload the calibration.
    UploadCalibration(Calibration),
    /// Start the reference phase map upload.
    BeginPhaseMapUpload(BeginPhaseMap),
    /// Configure the trigger sequence.
    ConfigureSequence(Sequence<'a>),
    /// Validate the configured sequence.
    ValidateSequence,
    /// Start the sequence.
    Start,
    /// Stop the sequence.
    Stop,
    /// Scan.
    Scan(ScanRequest),
    /// Abort whatever runs.
    Abort,
    /// Ask for the status.
    GetStatus,
    /// Head capabilities.
    Capabilities(Capabilities),
    /// Success.
    Ack(Ack),
    /// Failure.
    Nak(Nak),
    /// Upload progress.
    UploadAck(UploadAck),
    /// Result of ValidateSequence.
    Validation(ValidationStatus),
    /// Status.
    Status(Status),
    /// A result row segment.
    ResultRow(ResultRow<'a>),
    /// End of a scan.
    ScanDone(ScanDone),
}

fn ser<T: Serialize>(value: &T, out: &mut [u8]) -> Result<usize, WireError> {
    match postcard::to_slice(value, out) {
        Ok(used) => Ok(used.len()),
        Err(postcard::Error::SerializeBufferFull) => Err(WireError::BufferTooSmall),
        Err(_) => Err(WireError::Payload),
    }
}

fn de<'a, T: Deserialize<'a>>(payload: &'a [u8]) -> Result<T, WireError> {
    match postcard::take_from_bytes(payload) {
        Ok((v, [])) => Ok(v),
        Ok(_) => Err(WireError::TrailingBytes),
        Err(_) => Err(WireError::Payload),
    }
}

fn empty(payload: &[u8]) -> Result<(), WireError> {
    if payload.is_empty() {
        Ok(())
    } else {
        Err(WireError::TrailingBytes)
    }
}

impl<'a> Message<'a> {
    /// The command id of this message.
    pub const fn command(&self) -> Command {
        match self {
            Message::Hello(_) => Command::Hello,
            Message::DefinePatternSet(_) => Command::DefinePatternSet,
            Message::BeginUpload(_) => Command::BeginUpload,
            Message::UploadChunk(_) => Command::UploadChunk,
            Message::QueryUpload(_) => Command::QueryUpload,
            Message::ConfirmUpload(_) => Command::ConfirmUpload,
            Message::UploadCalibration(_) => Command::UploadCalibration,
            Message::BeginPhaseMapUpload(_) => Command::BeginPhaseMapUpload,
            Message::ConfigureSequence(_) => Command::ConfigureSequence,
            Message::ValidateSequence => Command::ValidateSequence,
            Message::Start => Command::Start,
            Message::Stop => Command::Stop,
            Message::Scan(_) => Command::Scan,
            Message::Abort => Command::Abort,
            Message::GetStatus => Command::GetStatus,
            Message::Capabilities(_) => Command::Capabilities,
            Message::Ack(_) => Command::Ack,
            Message::Nak(_) => Command::Nak,
            Message::UploadAck(_) => Command::UploadAck,
            Message::Validation(_) => Command::Validation,
            Message::Status(_) => Command::Status,
            Message::ResultRow(_) => Command::ResultRow,
            Message::ScanDone(_) => Command::ScanDone,
        }
    }

    /// Check every field of the body ([`WireError::Invalid`] says which rule failed).
    pub fn validate(&self) -> Result<(), WireError> {
        match self {
            Message::DefinePatternSet(m) => m.desc.validate(),
            Message::BeginUpload(m) => m.validate(),
            Message::UploadChunk(m) => m.validate(),
            Message::UploadCalibration(m) => m.validate(),
            Message::BeginPhaseMapUpload(m) => m.validate(),
            Message::ConfigureSequence(m) => m.entries.validate(),
            Message::Capabilities(m) => m.validate(),
            Message::Validation(m) => m.validate(),
            Message::Status(m) => m.errors.validate(),
            Message::ResultRow(m) => m.validate(),
            Message::Scan(m) => m.validate(),
            Message::Hello(_)
            | Message::QueryUpload(_)
            | Message::ConfirmUpload(_)
            | Message::ValidateSequence
            | Message::Start
            | Message::Stop
            | Message::Abort
            | Message::GetStatus
            | Message::Ack(_)
            | Message::Nak(_)
            | Message::UploadAck(_)
            | Message::ScanDone(_) => Ok(()),
        }
    }

    /// Validate, then postcard-encode the body into `out`; returns the payload length.
    ///
    /// [`WireError::BufferTooSmall`] if `out` is too short; [`WireError::PayloadTooLarge`] if the
    /// payload would exceed [`MAX_PAYLOAD`].
    pub fn encode(&self, out: &mut [u8]) -> Result<usize, WireError> {
        self.validate()?;
        let limited = out.len() > MAX_PAYLOAD;
        let out = if limited {
            &mut out[..MAX_PAYLOAD]
        } else {
            out
        };
        let r = match self {
            Message::Hello(m) => ser(m, out),
            Message::DefinePatternSet(m) => ser(m, out),
            Message::BeginUpload(m) => ser(m, out),
            Message::UploadChunk(m) => ser(m, out),
            Message::QueryUpload(m) | Message::ConfirmUpload(m) => ser(m, out),
            Message::UploadCalibration(m) => ser(m, out),
            Message::BeginPhaseMapUpload(m) => ser(m, out),
            Message::ConfigureSequence(m) => ser(m, out),
            Message::ValidateSequence
            | Message::Start
            | Message::Stop
            | Message::Abort
            | Message::GetStatus => Ok(0),
            Message::Scan(m) => ser(m, out),
            Message::Capabilities(m) => ser(m, out),
            Message::Ack(m) => ser(m, out),
            Message::Nak(m) => ser(m, out),
            Message::UploadAck(m) => ser(m, out),
            Message::Validation(m) => ser(m, out),
            Message::Status(m) => ser(m, out),
            Message::ResultRow(m) => ser(m, out),
            Message::ScanDone(m) => ser(m, out),
        };
        match r {
            Err(WireError::BufferTooSmall) if limited => Err(WireError::PayloadTooLarge),
            r => r,
        }
    }

    /// Decode the payload of a frame with command id `command`, then validate it.
    ///
    /// [`WireError::UnknownCommand`], [`WireError::Payload`] (postcard failed),
    /// [`WireError::TrailingBytes`] (bytes left after the body), [`WireError::Invalid`].
    pub fn decode(command: u8, payload: &'a [u8]) -> Result<Message<'a>, WireError> {
        let cmd = Command::try_from(command)?;
        if payload.len() > MAX_PAYLOAD {
            return Err(WireError::PayloadTooLarge);
        }
        let p = payload;
        let msg = match cmd {
            Command::Hello => Message::Hello(de(p)?),
            Command::DefinePatternSet => Message::DefinePatternSet(de(p)?),
            Command::BeginUpload => Message::BeginUpload(de(p)?),
            Command::UploadChunk => Message::UploadChunk(de(p)?),
            Command::QueryUpload => Message::QueryUpload(de(p)?),
            Command::ConfirmUpload => Message::ConfirmUpload(de(p)?),
            Command::UploadCalibration => Message::UploadCalibration(de(p)?),
            Command::BeginPhaseMapUpload => Message::BeginPhaseMapUpload(de(p)?),
            Command::ConfigureSequence => Message::ConfigureSequence(de(p)?),
            Command::ValidateSequence => empty(p).map(|_| Message::ValidateSequence)?,
            Command::Start => empty(p).map(|_| Message::Start)?,
            Command::Stop => empty(p).map(|_| Message::Stop)?,
            Command::Scan => Message::Scan(de(p)?),
            Command::Abort => empty(p).map(|_| Message::Abort)?,
            Command::GetStatus => empty(p).map(|_| Message::GetStatus)?,
            Command::Capabilities => Message::Capabilities(de(p)?),
            Command::Ack => Message::Ack(de(p)?),
            Command::Nak => Message::Nak(de(p)?),
            Command::UploadAck => Message::UploadAck(de(p)?),
            Command::Validation => Message::Validation(de(p)?),
            Command::Status => Message::Status(de(p)?),
            Command::ResultRow => Message::ResultRow(de(p)?),
            Command::ScanDone => Message::ScanDone(de(p)?),
        };
        msg.validate()?;
        Ok(msg)
    }
}
