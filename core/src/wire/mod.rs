//! The scan-head wire protocol: frames, messages, checked parse / emit (project issue #7).
//!
//! Modelled on the command interface of TI's DLPC350/DLPC900 projector controllers, over a byte
//! stream (UART, USB CDC, PTY). Everything here is `no_std` and allocation-free: parsing borrows
//! from the caller's frame buffer, emitting writes into the caller's buffers, every size has a
//! documented maximum so the head can use static buffers, and no input can make it panic.
//!
//! # Layers
//!
//! 1. **Line**: frames COBS-encoded ([`cobs`]), each followed by one `0x00`. A receiver feeds
//!    bytes to a [`FrameReceiver`], which resynchronises at the next `0x00` after garbage or an
//!    overlong frame and counts every kind of damage ([`ReceiverStats`]).
//! 2. **Frame** ([`frame`]): [`Header`] + payload + CRC-32C ([`crc`]) over header and payload.
//! 3. **Message** ([`message`]): the payload is the [postcard] encoding of the body of the
//!    command named in the header, validated on both ends.
//! 4. **Packet**: [`emit_packet`] / [`parse_packet`] do all of the above in one call.
//!
//! [`link`] has test doubles: a [`Loopback`] ring and a seeded [`FaultInjector`], both
//! `embedded-io` readers/writers.
//!
//! Besides the link, [`setup`] defines the head set-up blob: the same parameter types (pattern
//! set, calibration, decoder thresholds, edge filter) in one versioned, CRC-checked byte string
//! a head loads at start ([`HeadSetup::parse`]; `docs/setup-blob.md`).
//!
//! # Byte layout (for a C integrator)
//!
//! ## On the line
//!
//! `COBS(decoded frame) 0x00`. COBS as in Cheshire & Baker 1999: blocks of a code byte `c`
//! (1..=255) and `c − 1` non-zero bytes; `c < 255` implies a zero after the block, except after
//! the last block. Receivers ignore empty frames (`0x00 0x00`).
//!
//! ## Decoded frame
//!
//! | offset   | size | field                                                    |
//! |---------:|-----:|----------------------------------------------------------|
//! | 0        | 1    | protocol version = 10 ([`PROTOCOL_VERSION`])             |
//! | 1        | 1    | flags (below)                                            |
//! | 2        | 1    | sequence number                                          |
//! | 3        | 1    | command id (table below)                                 |
//! | 4        | 2    | payload length `L`, u16 LE, `L <= 4096` ([`MAX_PAYLOAD`]) |
//! | 6        | `L`  | payload: postcard-encoded body                           |
//! | 6 + `L`  | 4    | CRC-32C of bytes `0 .. 6+L`, u32 LE                      |
//!
//! CRC-32C = CRC-32/ISCSI: reflected polynomial `0x82F63B78`, init and final XOR `0xFFFFFFFF`;
//! `crc("123456789") = 0xE3069283`. The longest decoded frame is 4106 bytes
//! ([`MAX_FRAME`]); with COBS and the delimiter, 4124 ([`MAX_ENCODED_FRAME`]).
//!
//! Flags: bit 0 WRITE (the request changes head state; must match the command's W column, 0 on
//! replies), bit 1 REPLY_WANTED, bit 2 ERROR (set exactly on Nak), bit 3 MORE_FOLLOWS (more frames
//! of the same answer follow), bits 4-7 reserved, 0.
//!
//! ## Exchange
//!
//! The host numbers its requests with a rolling `seq` (starting, per process, from a value that
//! is not the same every time: a new process does not reuse the numbers of the last); every
//! answer echoes it. A read request
//! (W = 0) is always answered by its reply in the table below, or a Nak. A write request is
//! answered by its reply, or a Nak, if it has REPLY_WANTED; without it, only a failure is answered
//! (Nak), so bursts of chunks need not wait. A Scan is answered by a stream: Ack, then
//! [`ResultRow`]s, then [`ScanDone`], all with the Scan's `seq` and all but ScanDone with
//! MORE_FOLLOWS. Each row and the ScanDone also carry the Scan's `scan_id`, which the host
//! chooses afresh for every scan: a host accepts only rows of the scan it asked for, so rows
//! of an earlier scan still in flight (adapter or driver buffers, a host killed mid-scan) are
//! dropped, never assembled into the new result. A `seq` (8 bits) alone cannot tell them apart.
//!
//! Uploads: BeginUpload / BeginPhaseMapUpload / BeginCompiledUpload → UploadAck{next_offset: 0}; UploadChunks, each at
//! the head's current offset → UploadAck{next_offset}; after an interruption, QueryUpload →
//! UploadAck tells where to resume; ConfirmUpload → Ack if the CRC-32C of all bytes equals the
//! announced digest, else Nak DigestMismatch. The head never uses unconfirmed data.
//!
//! ## Postcard encoding of the bodies
//!
//! Fields in the order listed, no padding, no enum tag for the body itself (the command id is the
//! tag): `u8` one byte; `u16`, `u32` unsigned LEB128 varint (7 bits per byte, least significant
//! group first, high bit = more; at most 3 / 5 bytes; emit the shortest form, receivers also
//! accept padded forms); `bool` one byte 0 or 1; `f32` 4 bytes IEEE-754 LE; `f64` 8 bytes
//! IEEE-754 LE; `[T; N]` N elements;
//! `bytes` varint length then the bytes; an enum is a varint variant index (shown as `[i]`) then
//! the variant's fields; a struct its fields.
//!
//! | id     | command             | W | body                                                                        | reply |
//! |--------|---------------------|---|-----------------------------------------------------------------------------|-------|
//! | `0x01` | Hello               | 0 | protocol_version u8                                                         | Capabilities |
//! | `0x10` | DefinePatternSet    | 1 | set_id u8, [`PatternSetDesc`]                                               | Ack |
//! | `0x11` | BeginUpload         | 1 | set_id u8, image_count u16, width u16, height u16, bit_depth u8, total_bytes u32, digest u32 | UploadAck |
//! | `0x12` | UploadChunk         | 1 | target T, offset u32, crc u32, data bytes (1..=4064)                        | UploadAck |
//! | `0x13` | QueryUpload         | 0 | target T                                                                    | UploadAck |
//! | `0x14` | ConfirmUpload       | 1 | target T                                                                    | Ack |
//! | `0x15` | DefineCorrection    | 1 | set_id u8, table: `[0]` none or `[1]` [`SetupCorrection`] (levels u8, 6 × 32 × i16 zigzag varints, 2⁻¹³ rad) | Ack |
//! | `0x16` | DefineThresholds    | 1 | set_id u8, thresholds: `[0]` none (the camera bit depth's defaults) or `[1]` dark_level, saturation_level, min_modulation, unwrap_tolerance, range_tolerance f32 ([`DecodeThresholds`]) | Ack |
//! | `0x18` | UploadCalibration   | 1 | width u16, height u16, fx, fy, cx, cy, skew f64, k1, k2, p1, p2, k3 f64, projector_centre 3×f64, plane_point 3×f64, plane_normal 3×f64, depth_min f64, depth_max f64 | Ack |
//! | `0x19` | BeginPhaseMapUpload | 1 | width u16, height u16, margin left, top, right, bottom u32 (≤ 1024 each), total_bytes u32, digest u32 | UploadAck |
//! | `0x1A` | BeginCompiledUpload | 1 | width u16, height u16, z_min f32, z_max f32, total_bytes u32, digest u32 ([`BeginCompiled`]; protocol version 9, 44 bytes a pixel since 10) | UploadAck |
//! | `0x20` | ConfigureSequence   | 1 | set_id u8, repeat bool, entries bytes (n × 12-byte [`LutEntry`], 1..=256)   | Ack |
//! | `0x21` | ValidateSequence    | 0 | (empty)                                                                     | Validation |
//! | `0x22` | Start               | 1 | (empty)                                                                     | Ack |
//! | `0x23` | Stop                | 1 | (empty)                                                                     | Ack |
//! | `0x30` | Scan                | 1 | scan_id u32, output `[0]` Phase `[1]` Points `[2]` Both, first_row u16, row_count u16, edge filter `[0]` Off `[1]` MaxAngle f64 (degrees, `0 < a < 90`), exposures: count u8 (0..=4), 4 × exposure_us u32 (longest first, unused 0; [`Exposures`]) | Ack, rows, ScanDone |
//! | `0x31` | Abort               | 1 | (empty)                                                                     | Ack |
//! | `0x32` | GetStatus           | 0 | (empty)                                                                     | Status |
//! | `0x80` | Capabilities        | 0 | protocol_version u8, fw major u8, minor u8, patch u8, sensor_width u16, sensor_height u16, projector_width u16, projector_height u16, free_memory u32, max_chunk u16, max_sets u8, max_lut_entries u16 | |
//! | `0x81` | Ack                 | 0 | command u8                                                                  | |
//! | `0x82` | Nak                 | 0 | command u8, code [`NakCode`] `[0..=15]`, detail u16                         | |
//! | `0x83` | UploadAck           | 0 | target T, next_offset u32                                                   | |
//! | `0x84` | Validation          | 0 | status u32 ([`ValidationStatus`] bits)                                      | |
//! | `0x85` | Status              | 0 | state `[0]` Idle `[1]` Uploading `[2]` Ready `[3]` Running `[4]` Scanning `[5]` Fault, errors u32 ([`HeadErrors`] bits), rx_frames u32, rx_errors u32, tx_frames u32, rows_sent u32, holds u32 ([`Holds`] bits; protocol version 10) | |
//! | `0x86` | ResultRow           | 0 | scan_id u32, row u16, first_col u16, kind `[0]` Phase `[1]` Points, data bytes | |
//! | `0x87` | ScanDone            | 0 | scan_id u32, rows u16, valid u32, decoded u32, searched u32 ([`ScanDone`]) | |
//!
//! `T` ([`UploadTarget`]) is `[0] set_id u8` (a pattern set), `[1]` (the reference phase map) or
//! `[2]` (the compiled reconstruction's models).
//!
//! [`PatternSetDesc`]: width u16, height u16, bit_depth u8, i_min f64, i_max f64, waveform `[0]`
//! sine `[1]` cosine (`[2]`/`[3]` their square waves, `[4]`/`[5]` Bayer-dithered: 1-bit patterns,
//! [`crate::binary`]), phase_offset f64, then the phase function: axis `[0]` ξ `[1]` η, profile
//! `[0]` Linear origin f64, slope f64 (`g(t) = slope·(t − origin)`) or `[1]` Knots count u8,
//! 16 × f64 positions, 16 × f64 phases, 16 × f64 slopes (monotonic cubic Hermite), curvature f64,
//! bend_center f64 (`Φ = g(t + curvature·(w − bend_center)²)`); then level_count u8 and 6 levels,
//! each: scale f64, shifts = `[0]` Uniform n u8, count u8 (shifts `2π·i/n`, `i < count`) or `[1]`
//! Explicit count u8, 16 × f64, or `[2]` Gray bits u8, complementary u8 (a Gray-code level:
//! `bits` binary images, one more if complementary, [`crate::gray`]), or `[3]` GrayInverse bits
//! u8, complementary u8 (the same, every image followed by its inverse: twice the images), or
//! `[4]` GrayShifted bits u8, inverse u8 (a Gray code whose stripes are moved by half a period,
//! twice the images with inverses; protocol version 6). Unused levels are `0.0, [0] 0 0`; unused knots and explicit shifts
//! are `0.0`. Last, the levels' relation ([`Relation`]): `[0]`
//! hierarchical (eqs 12-13 from the coarsest level or a Gray code), `[1]` heterodyne (the
//! beats of 2 or 3 phase levels) or `[2]` coprime (number-theoretic: the first two levels'
//! scales in the ratio of coprime integers). These are the parameters of the core's `PatternSet` exactly ([`desc`] maps both
//! ways), so the head's set is the desktop's bit for bit.
//!
//! [`LutEntry`] (12 bytes, LE, not postcard): pattern u16, exposure_us u32, dark_us u32,
//! bit_depth u8, flags u8 (bit 0 wait for trigger, bit 1 trigger out).
//!
//! ResultRow `data`, and each row of the reference phase map upload: first the f32 values of all
//! its columns, LE (points x, y, z interleaved), then one [`Validity`](crate::Validity) byte per
//! column. The reference map is `left + width + right` columns by `top + height + bottom` rows
//! (its [`Margin`](crate::reconstruct::Margin) past the image, [`BeginPhaseMap`]), rows from
//! the map's top. Pattern image uploads: one byte per pixel, row-major, images in order. The
//! compiled reconstruction's upload: the camera's rows from the top, each `40 × width` bytes, its
//! models field by field (ten arrays of `width` f32 LE: ray x, ray y, Φ_c, ±k, s_c, γ, d₁…d₄;
//! [`PixelModel::store`](crate::reconstruct::compiled::PixelModel::store)), the rows of a
//! `fringe3d compile` file after its 72-byte header. A head takes it after the calibration and a
//! confirmed reference map (before: Nak NotReady, its detail the [`ValidationStatus`] bits
//! `NO_CALIBRATION` / `NO_REFERENCE` of what is missing), with their size and depth range (Nak
//! Invalid Dimension / DepthRange), and forgets it when either is replaced.
//!
//! Worked example: GetStatus (`0x32`), seq 7, REPLY_WANTED, empty payload. Header
//! `07 02 07 32 00 00`; CRC-32C of those six bytes `0x66C83326`, sent LE: decoded frame
//! `07 02 07 32 00 00 26 33 C8 66`; COBS and delimiter: `05 07 02 07 32 01 05 26 33 C8 66 00`.
//!
//! Version history: 1 carried the pattern set (linear phase only) and the calibration as f32 and
//! had no edge-filter field in Scan. 2 had no `scan_id` in Scan, ResultRow and ScanDone (rows of
//! an earlier scan still in flight were taken for the new scan's; issue #21 item 1). 3 had no
//! relation at the end of [`PatternSetDesc`] (hierarchical sets only) and no
//! DefineCorrection (a head decoded every set uncorrected, so binary sets and a measured
//! projector response were scanned on the desktop only). 4 had no validity code 12
//! (`light-edge`). 5 had no margin in BeginPhaseMapUpload (a head took image-sized reference
//! maps only). 6 had no DefineThresholds (a head decoded with its camera bit depth's default
//! thresholds, whatever the host's: at 16 bit a floor of 2 % of full scale, not 12σ). 7 had no
//! exposure list in Scan (a head captured each pattern once: no HDR). 8 had no
//! BeginCompiledUpload (a head reconstructed every pixel with the §6 search). 9 had 40-byte
//! compiled models (no far threshold) and no holdings in Status. 10 had no `decoded` and
//! `searched` counts in ScanDone (a host could not tell how many pixels a compiled scan left
//! to the search). A head and a host of different versions refuse each other's
//! frames: the head answers a frame of another version with Nak Version (detail: its version),
//! which the host reports as such.
//! `core/tests/wire_vectors.rs` spells out more, one per kind of body.
//!
//! [postcard]: https://postcard.jamesmunns.com/wire-format

// The transport layers (feature `wire`, on by default): a head that takes its set-up from a
// file or flash, not a serial link, leaves them out; the message bodies, the parameter
// descriptions and the set-up blob stay.
#[cfg(feature = "wire")]
pub mod cobs;
pub mod crc;
pub mod desc;
#[cfg(feature = "wire")]
pub mod frame;
#[cfg(feature = "wire")]
pub mod header;
#[cfg(feature = "wire")]
pub mod link;
pub mod message;
#[cfg(feature = "wire")]
mod packet;
pub mod reference_file;
pub mod setup;

pub use desc::{DescError, image_index};
#[cfg(feature = "wire")]
pub use frame::{FrameReceiver, MAX_ENCODED_FRAME, MAX_FRAME, MIN_FRAME, ReceiverStats};
#[cfg(feature = "wire")]
pub use header::{Flags, HEADER_LEN, Header, PROTOCOL_VERSION};
#[cfg(feature = "wire")]
pub use link::{FaultConfig, FaultInjector, FaultStats, Loopback, LoopbackError, XorShift64};
pub use message::*;
#[cfg(feature = "wire")]
pub use packet::{Packet, check_header, emit_packet, parse_packet};
pub use reference_file::{ReferenceFile, ReferenceFileError};
pub use setup::{
    CaptureOrder, DecodeThresholds, EdgeFilterParams, FrameFormat, HeadSetup, SetupError,
};

/// Largest payload of one frame, bytes.
pub const MAX_PAYLOAD: usize = 4096;

/// Everything that can go wrong on the wire.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum WireError {
    /// A caller's output buffer is too small.
    BufferTooSmall,
    /// The input is shorter than its layout requires (a frame under [`MIN_FRAME`] bytes).
    Truncated,
    /// Malformed COBS.
    Cobs,
    /// A frame on the line was longer than the receive buffer.
    Overflow,
    /// CRC mismatch.
    Crc,
    /// Unsupported protocol version (the byte received).
    Version(u8),
    /// A reserved header flag bit is set.
    ReservedFlags,
    /// The header's payload length exceeds [`MAX_PAYLOAD`] or disagrees with the frame.
    Length,
    /// A payload would exceed [`MAX_PAYLOAD`].
    PayloadTooLarge,
    /// Unknown command id (the byte received).
    UnknownCommand(u8),
    /// Header flags contradict the command (WRITE, ERROR).
    FlagMismatch,
    /// The header's command is not the message's.
    CommandMismatch,
    /// The payload is not a valid postcard encoding of the command's body.
    Payload,
    /// Bytes left over after the body.
    TrailingBytes,
    /// A field is out of range.
    Invalid(Invalid),
}

/// Coarse classes of [`WireError`], for deciding what to do about one.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum WireErrorKind {
    /// A local buffer is too small: a bug or misconfiguration on this side.
    Buffer,
    /// The frame was damaged in transit (COBS, length, overflow): retrying may help.
    Framing,
    /// The CRC failed: damaged in transit, retrying may help.
    Integrity,
    /// The peer speaks another version or command set: retrying will not help.
    Unsupported,
    /// The frame arrived intact but does not follow the protocol: a bug on the peer's side.
    Malformed,
    /// A field's value is out of range.
    Invalid,
}

impl WireErrorKind {
    /// `true` for classes caused by line damage (retry the transfer).
    pub const fn is_transient(self) -> bool {
        matches!(self, WireErrorKind::Framing | WireErrorKind::Integrity)
    }
}

impl WireError {
    /// The class of the error.
    pub const fn kind(self) -> WireErrorKind {
        match self {
            WireError::BufferTooSmall => WireErrorKind::Buffer,
            WireError::Truncated | WireError::Cobs | WireError::Overflow => WireErrorKind::Framing,
            WireError::Crc => WireErrorKind::Integrity,
            WireError::Version(_) | WireError::UnknownCommand(_) => WireErrorKind::Unsupported,
            WireError::ReservedFlags
            | WireError::Length
            | WireError::PayloadTooLarge
            | WireError::FlagMismatch
            | WireError::CommandMismatch
            | WireError::Payload
            | WireError::TrailingBytes => WireErrorKind::Malformed,
            WireError::Invalid(_) => WireErrorKind::Invalid,
        }
    }
}

impl core::fmt::Display for WireError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            WireError::BufferTooSmall => f.write_str("buffer too small"),
            WireError::Truncated => f.write_str("truncated frame"),
            WireError::Cobs => f.write_str("malformed COBS"),
            WireError::Overflow => f.write_str("frame longer than the receive buffer"),
            WireError::Crc => f.write_str("CRC mismatch"),
            WireError::Version(v) => write!(f, "unsupported protocol version {v}"),
            WireError::ReservedFlags => f.write_str("reserved flag bit set"),
            WireError::Length => f.write_str("bad payload length"),
            WireError::PayloadTooLarge => f.write_str("payload too large"),
            WireError::UnknownCommand(c) => write!(f, "unknown command 0x{c:02x}"),
            WireError::FlagMismatch => f.write_str("flags contradict the command"),
            WireError::CommandMismatch => f.write_str("header command is not the message's"),
            WireError::Payload => f.write_str("payload does not decode"),
            WireError::TrailingBytes => f.write_str("trailing bytes after the payload"),
            WireError::Invalid(why) => write!(f, "invalid field: {}", why.name()),
        }
    }
}

impl core::error::Error for WireError {}

impl From<Invalid> for WireError {
    fn from(why: Invalid) -> Self {
        WireError::Invalid(why)
    }
}

/// Which validation rule a message broke. The numeric value is sent as a Nak's `detail`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[repr(u8)]
pub enum Invalid {
    /// A width, height or count is zero.
    Dimension = 1,
    /// A bit depth is outside `1..=MAX_BIT_DEPTH`.
    BitDepth = 2,
    /// `I_max` is not in `(0, 2^bit_depth − 1]`.
    Intensity = 3,
    /// A float is NaN or infinite.
    NotFinite = 4,
    /// The phase function is constant along the pattern axis.
    PhaseFunction = 5,
    /// The level count is outside `1..=MAX_LEVELS`.
    LevelCount = 6,
    /// A level's scale `c_k` is not positive.
    Scale = 7,
    /// A level's shifts are malformed.
    Shifts = 8,
    /// An unused array slot is not zero.
    UnusedSlot = 9,
    /// `total_bytes` does not match the dimensions.
    TotalBytes = 10,
    /// A chunk size is outside `1..=MAX_CHUNK`.
    ChunkSize = 11,
    /// A chunk's CRC does not match its data.
    ChunkCrc = 12,
    /// An offset range overflows u32.
    Offset = 13,
    /// Focal lengths are not positive.
    Intrinsics = 14,
    /// The reference plane normal is zero.
    PlaneNormal = 15,
    /// `depth_min >= depth_max`.
    DepthRange = 16,
    /// A trigger table is empty, too long or not a whole number of entries.
    LutLength = 17,
    /// A trigger table entry is out of range.
    LutEntry = 18,
    /// A reserved bit is set in a bit-field.
    ReservedBits = 19,
    /// Result row data has the wrong length.
    RowData = 20,
    /// A validity byte is not a [`Validity`](crate::Validity) code.
    ValidityCode = 21,
    /// The edge-filter angle is not in `(0, 90)` degrees.
    EdgeFilter = 22,
    /// A phase-error table's knot is beyond `PhaseCorrection::MAX_DELTA`, its level count is
    /// outside `1..=MAX_LEVELS` or not the set's.
    Correction = 23,
    /// A side of a reference map's margin exceeds
    /// [`MAX_MARGIN`](crate::reconstruct::MAX_MARGIN).
    Margin = 24,
    /// A decoder threshold is not finite or negative, the saturation level is zero, or the
    /// unwrapping tolerance exceeds π (DefineThresholds, protocol version 7).
    Thresholds = 25,
    /// A scan's exposure list holds more than `MAX_EXPOSURES` values, an exposure outside
    /// `1..=MAX_EXPOSURE_US`, or exposures not strictly decreasing (Scan, protocol version 8).
    Exposures = 26,
    /// ScanDone's counts contradict each other: more valid phases or points, or more pixels
    /// searched, than pixels decoded (protocol version 11).
    Counts = 27,
}

impl Invalid {
    /// A short lowercase name.
    pub const fn name(self) -> &'static str {
        match self {
            Invalid::Dimension => "dimension",
            Invalid::BitDepth => "bit-depth",
            Invalid::Intensity => "intensity",
            Invalid::NotFinite => "not-finite",
            Invalid::PhaseFunction => "phase-function",
            Invalid::LevelCount => "level-count",
            Invalid::Scale => "scale",
            Invalid::Shifts => "shifts",
            Invalid::UnusedSlot => "unused-slot",
            Invalid::TotalBytes => "total-bytes",
            Invalid::ChunkSize => "chunk-size",
            Invalid::ChunkCrc => "chunk-crc",
            Invalid::Offset => "offset",
            Invalid::Intrinsics => "intrinsics",
            Invalid::PlaneNormal => "plane-normal",
            Invalid::DepthRange => "depth-range",
            Invalid::LutLength => "lut-length",
            Invalid::LutEntry => "lut-entry",
            Invalid::ReservedBits => "reserved-bits",
            Invalid::RowData => "row-data",
            Invalid::ValidityCode => "validity-code",
            Invalid::EdgeFilter => "edge-filter",
            Invalid::Correction => "correction",
            Invalid::Margin => "margin",
            Invalid::Thresholds => "thresholds",
            Invalid::Exposures => "exposures",
            Invalid::Counts => "counts",
        }
    }

    /// The rule with code `code`, if any.
    pub const fn from_u8(code: u8) -> Option<Invalid> {
        const ALL: [Invalid; 27] = [
            Invalid::Dimension,
            Invalid::BitDepth,
            Invalid::Intensity,
            Invalid::NotFinite,
            Invalid::PhaseFunction,
            Invalid::LevelCount,
            Invalid::Scale,
            Invalid::Shifts,
            Invalid::UnusedSlot,
            Invalid::TotalBytes,
            Invalid::ChunkSize,
            Invalid::ChunkCrc,
            Invalid::Offset,
            Invalid::Intrinsics,
            Invalid::PlaneNormal,
            Invalid::DepthRange,
            Invalid::LutLength,
            Invalid::LutEntry,
            Invalid::ReservedBits,
            Invalid::RowData,
            Invalid::ValidityCode,
            Invalid::EdgeFilter,
            Invalid::Correction,
            Invalid::Margin,
            Invalid::Thresholds,
            Invalid::Exposures,
            Invalid::Counts,
        ];
        if code >= 1 && (code as usize) <= ALL.len() {
            Some(ALL[code as usize - 1])
        } else {
            None
        }
    }
}
