//! The head set-up blob: everything a scan head needs to decode and reconstruct, besides the
//! images and the reference phase map, as one versioned, CRC-checked byte string.
//!
//! The desktop writes it (the golden vectors' `input/setup.bin`, `fringe3d vectors`), a head
//! reads it with [`HeadSetup::parse`] and builds the core's working objects with the core's own
//! constructors ([`HeadSetup::pattern_set`], [`HeadSetup::decoder`],
//! [`HeadSetup::camera_model`], [`HeadSetup::reconstructor`], [`HeadSetup::edge_filter`]), so
//! nothing the desktop computed is recomputed differently: every parameter travels as the value
//! the desktop holds (f64 or f32, bit for bit) and the head derives the rest (estimators, band,
//! kernel constants) with the same code. Full description: `docs/setup-blob.md`.
//!
//! # Byte layout
//!
//! | offset  | size | field                                                             |
//! |--------:|-----:|-------------------------------------------------------------------|
//! | 0       | 4    | magic `F3DS` ([`SETUP_MAGIC`])                                    |
//! | 4       | 1    | format version = 6 ([`SETUP_VERSION`]; 1 to 5 are still read)     |
//! | 5       | 1    | reserved, 0                                                       |
//! | 6       | 2    | payload length `L`, u16 LE, `L <= 4096` ([`MAX_SETUP_PAYLOAD`])   |
//! | 8       | `L`  | payload: the postcard encoding of a [`HeadSetup`]                 |
//! | 8 + `L` | 4    | CRC-32C ([`crc`](super::crc)) of bytes `0 .. 8+L`, u32 LE          |
//!
//! The payload's fields, in order (postcard as in the frame bodies: `u8` raw, `u16`/`u32`
//! varint, `f32`/`f64` LE, enums a varint index):
//!
//! 1. [`FrameFormat`]: width u16, height u16, sample_bits u8, sample_bytes u8;
//! 2. the pattern set, a [`PatternSetDesc`] as in DefinePatternSet, except that its bit depth
//!    may be up to 16 ([`MAX_SETUP_BIT_DEPTH`]: the projector the camera saw, not the head's
//!    8-bit renderer); versions 1 to 3: without its last field, the levels' relation
//!    (hierarchical);
//! 3. [`CaptureOrder`]: varint count ≤ 64, then count × u8 wire pattern indices (versions 1
//!    and 2: count u8, then always 32 × u8, unused = 0);
//! 4. [`DecodeThresholds`]: 5 × f32;
//! 5. [`Calibration`]: as in UploadCalibration;
//! 6. the reconstruction's axis, [`PatternAxis`] `[0]` ξ `[1]` η;
//! 7. [`EdgeFilterParams`]: focal_px f64, max_angle_deg f64;
//! 8. (version 2) the projector-response correction, an `Option` (one byte 0 = none, 1 = some)
//!    of [`SetupCorrection`]: levels u8, then 6 × 32 × i16 knots (zigzag varints, 2⁻¹³ rad;
//!    unused levels 0) — the decoder's [`PhaseCorrection`] (docs/gamma.md). A version-1 blob has no field 8 and
//!    means "no correction";
//! 9. (version 5) the reference map's [`Margin`] past the image: left, top, right, bottom as
//!    u32 varints, each at most [`MAX_MARGIN`] (issue #17: a map wider than the image keeps
//!    the search of a point near the camera on the map). The head's map is
//!    `(left + width + right) × (top + height + bottom)` samples. Versions 1 to 4 have no
//!    field 9 and mean an image-sized map.
//! 10. (version 6) the reconstructor's set-up analysis, an `Option` of [`SetupAnalysis`]: the
//!     camera model's check (three f64), band above and below (u32 varints), fallback
//!     bisections (u32 varint), the longest search segment (f32), the segments' reach past the
//!     image (four u32 varints). With it the head builds the camera model and the
//!     reconstructor without the analysis ([`Reconstructor::from_analysis`]: none of its
//!     soft-f64 grid walks, 154 M Cortex-M4F instructions at 320 × 240); the desktop fills it
//!     with [`HeadSetup::with_analysis`]. Versions 1 to 5 have no field 10 and mean "analyse
//!     at boot".
//!
//! Everything is checked on [`HeadSetup::emit`] and [`HeadSetup::parse`] ([`HeadSetup::validate`]);
//! what only the whole set can tell (monotonic phase, coarse range, …) is checked when the head
//! builds the pattern set. No input makes the parser panic (`core/tests/wire_setup.rs` fuzzes it).

use serde::{Deserialize, Serialize};

use super::crc::crc32c;
use super::desc::DescError;
use super::message::{Calibration, PatternAxis, PatternSetDesc, Waveform};
pub use super::message::{DecodeThresholds, SetupCorrection};
use super::{Invalid, WireError};
use crate::camera::CameraModel;
use crate::decode::{DecodeConfig, Decoder, PhaseCorrection};
use crate::filter::EdgeFilter;
use crate::params::CameraParams;
use crate::pattern::PatternSet;
use crate::reconstruct::{MAX_MARGIN, Margin, Reconstructor, Setup, SetupAnalysis};

mod capture_order;
mod legacy;
pub use capture_order::CaptureOrder;
use legacy::payload_fields;

/// First four bytes of a set-up blob.
pub const SETUP_MAGIC: [u8; 4] = *b"F3DS";
/// The blob format version this core writes (it also reads version 5: no analysis; 1 to 4 no
/// margin; 1 to 3 no relation in the pattern set; 1 and 2 a capture order of 32 fixed entries; 1
/// no correction field).
pub const SETUP_VERSION: u8 = 6;
/// Bytes before the payload: magic, version, reserved, length.
pub const SETUP_HEADER_LEN: usize = 8;
/// Bytes of the trailing CRC-32C.
pub const SETUP_CRC_LEN: usize = 4;
/// Largest payload (the largest valid set-up is about 1.5 KiB, 2.1 KiB with a correction).
pub const MAX_SETUP_PAYLOAD: usize = 4096;
/// Largest blob: header, payload, CRC.
pub const MAX_SETUP_BLOB: usize = SETUP_HEADER_LEN + MAX_SETUP_PAYLOAD + SETUP_CRC_LEN;
/// Highest projector bit depth a set-up's pattern set may have (the core's 16-bit output).
pub const MAX_SETUP_BIT_DEPTH: u8 = 16;

/// Why a set-up blob was refused (or could not be written). Each names one thing.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum SetupError {
    /// The output buffer is too small.
    BufferTooSmall,
    /// Shorter than a header and a CRC.
    Truncated,
    /// Not a set-up blob (the magic).
    Magic,
    /// A format version this core does not read (the byte found).
    Version(u8),
    /// The reserved header byte is not 0.
    Reserved,
    /// The payload length exceeds [`MAX_SETUP_PAYLOAD`] or disagrees with the blob's length.
    Length,
    /// CRC mismatch.
    Crc,
    /// The payload is not a postcard-encoded [`HeadSetup`].
    Payload,
    /// Bytes left over after the payload's fields.
    TrailingBytes,
    /// A field breaks a wire rule (the wire's code says which).
    Invalid(Invalid),
    /// Sample bits not in `1..=8 · sample_bytes`, or sample bytes not 1 or 2.
    FrameFormat,
    /// The frame size is not the calibrated camera's.
    ImageSize,
    /// The capture order is not a permutation of the set's patterns.
    CaptureOrder,
    /// A decoder threshold is not finite, negative, or out of range.
    Thresholds,
    /// The edge filter's focal length is not positive or its angle not in `(0, 90)` degrees.
    EdgeFilter,
    /// The core refused the pattern set (the wire's code says why).
    PatternSet(Invalid),
    /// The core's decoder refused the set.
    Decoder,
    /// The core refused the camera model or the reconstruction set-up (the wire's code).
    Reconstruction(Invalid),
    /// The phase-correction table is for another level count, or a knot is not finite or too
    /// large ([`PhaseCorrection::is_sane`]); or a binary set (waveform 2-5) has none, without
    /// which its decoding would carry the binarization's error ([`crate::binary`]).
    Correction,
    /// The shipped set-up analysis (field 10) holds numbers no analysis gives
    /// ([`SetupAnalysis::is_sane`]).
    Analysis,
}

impl SetupError {
    /// What is wrong, without the detail (for a firmware's fixed messages).
    pub const fn what(self) -> &'static str {
        match self {
            SetupError::BufferTooSmall => "set-up: buffer too small",
            SetupError::Truncated => "set-up: truncated blob",
            SetupError::Magic => "set-up: not a set-up blob (magic)",
            SetupError::Version(_) => "set-up: unsupported format version",
            SetupError::Reserved => "set-up: reserved header byte set",
            SetupError::Length => "set-up: payload length disagrees with the blob",
            SetupError::Crc => "set-up: CRC mismatch",
            SetupError::Payload => "set-up: payload does not decode",
            SetupError::TrailingBytes => "set-up: trailing bytes after the payload",
            SetupError::Invalid(_) => "set-up: a field is out of range",
            SetupError::FrameFormat => "set-up: bad sample format",
            SetupError::ImageSize => "set-up: frame size is not the camera's",
            SetupError::CaptureOrder => "set-up: capture order is not a permutation of the set",
            SetupError::Thresholds => "set-up: bad decoder thresholds",
            SetupError::EdgeFilter => "set-up: bad edge filter",
            SetupError::PatternSet(_) => "set-up: the core refused the pattern set",
            SetupError::Decoder => "set-up: the decoder refused the pattern set",
            SetupError::Reconstruction(_) => "set-up: the core refused the calibration",
            SetupError::Correction => "set-up: bad phase-correction table",
            SetupError::Analysis => "set-up: the shipped reconstructor analysis is out of range",
        }
    }
}

impl core::fmt::Display for SetupError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(self.what())?;
        match self {
            SetupError::Version(v) => write!(f, " {v} (this core reads 1 to {SETUP_VERSION})"),
            SetupError::Invalid(why)
            | SetupError::PatternSet(why)
            | SetupError::Reconstruction(why) => write!(f, " ({})", why.name()),
            _ => Ok(()),
        }
    }
}

impl core::error::Error for SetupError {}

fn field(e: WireError) -> SetupError {
    match e {
        WireError::Invalid(why) => SetupError::Invalid(why),
        _ => SetupError::Payload,
    }
}

fn desc_error(e: DescError) -> SetupError {
    match e {
        DescError::BitDepth(_) => SetupError::Invalid(Invalid::BitDepth),
        DescError::Size => SetupError::Invalid(Invalid::Dimension),
        DescError::Invalid(why) => SetupError::Invalid(why),
    }
}

/// The camera frames a scan decodes: their size and sample format.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct FrameFormat {
    /// Width, pixels: the calibrated camera's.
    pub width: u16,
    /// Height, pixels: the calibrated camera's.
    pub height: u16,
    /// Significant bits per sample, `1..=8 · sample_bytes`.
    pub sample_bits: u8,
    /// Bytes per sample: 1 (u8 frames) or 2 (u16, little-endian).
    pub sample_bytes: u8,
}

impl FrameFormat {
    /// Check the sample format.
    pub fn validate(&self) -> Result<(), SetupError> {
        let bytes_ok = self.sample_bytes == 1 || self.sample_bytes == 2;
        if bytes_ok && (1..=8 * self.sample_bytes).contains(&self.sample_bits) {
            Ok(())
        } else {
            Err(SetupError::FrameFormat)
        }
    }
}

/// The edge filter's parameters ([`EdgeFilter::new`]).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct EdgeFilterParams {
    /// Focal length, pixels (the desktop uses `min(fx, fy)`), finite and `> 0`.
    pub focal_px: f64,
    /// Steepest accepted surface, degrees from facing the camera, `0 < angle < 90`.
    pub max_angle_deg: f64,
}

impl EdgeFilterParams {
    /// Check the ranges [`EdgeFilter::new`] accepts.
    pub fn validate(&self) -> Result<(), SetupError> {
        let (f, a) = (self.focal_px, self.max_angle_deg);
        if f.is_finite() && f > 0.0 && a > 0.0 && a < 90.0 {
            Ok(())
        } else {
            Err(SetupError::EdgeFilter)
        }
    }
}

/// A head's set-up: the payload of the blob (field order = wire order, see the module docs).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct HeadSetup {
    /// The camera frames.
    pub frames: FrameFormat,
    /// The projected pattern set (bit depth up to [`MAX_SETUP_BIT_DEPTH`]).
    pub patterns: PatternSetDesc,
    /// Which pattern each captured image shows.
    pub capture_order: CaptureOrder,
    /// The decoder's thresholds.
    pub thresholds: DecodeThresholds,
    /// Camera model and scan geometry.
    pub calibration: Calibration,
    /// The projector axis the reference phase is monotonic along (the reconstruction's; the
    /// pattern set's axis for a consistent rig).
    pub axis: PatternAxis,
    /// The edge filter.
    pub edge_filter: EdgeFilterParams,
    /// The decoder's phase-error table for the projector's response, if any (version 2).
    pub correction: Option<SetupCorrection>,
    /// The reference map's margin past the image (version 5; [`Margin::ZERO`] before).
    pub margin: Margin,
    /// The reconstructor's set-up analysis for this calibration and margin (version 6; `None`
    /// before, or when the maker did not compute it: the head then analyses at boot).
    pub analysis: Option<SetupAnalysis>,
}

impl HeadSetup {
    /// The set-up of a desktop scan: frames of `frames`' format, the images of `set` (in its
    /// order) from a `pattern_bits`-bit projector, decoded with `thresholds`, reconstructed with
    /// `camera` and `setup` (its axis included), filtered with `edge_filter`. Checked like
    /// [`HeadSetup::parse`].
    pub fn from_core(
        frames: FrameFormat,
        set: &PatternSet,
        pattern_bits: u32,
        thresholds: DecodeConfig,
        camera: &CameraParams,
        setup: &Setup,
        edge_filter: EdgeFilterParams,
    ) -> Result<Self, SetupError> {
        let patterns = PatternSetDesc::from_set_up_to(set, pattern_bits, MAX_SETUP_BIT_DEPTH)
            .map_err(desc_error)?;
        let s = HeadSetup {
            frames,
            patterns,
            capture_order: CaptureOrder::of(&patterns, set.order())
                .ok_or(SetupError::CaptureOrder)?,
            thresholds: thresholds.into(),
            calibration: Calibration::from_core(camera, setup).map_err(desc_error)?,
            axis: setup.axis.into(),
            edge_filter,
            correction: None,
            margin: Margin::ZERO,
            analysis: None,
        };
        s.validate()?;
        Ok(s)
    }

    /// This set-up for a reference map with margin `m` past the image (field 9,
    /// [`Reconstructor::with_margin`]), checked like [`HeadSetup::parse`]. An analysis (field 10)
    /// is for one margin: it is dropped (call [`Self::with_analysis`] after this).
    pub fn with_margin(mut self, m: Margin) -> Result<Self, SetupError> {
        self.margin = m;
        self.analysis = None;
        self.validate()?;
        Ok(self)
    }

    /// This set-up with the reconstructor's set-up analysis (field 10), computed here
    /// ([`Reconstructor::new`], [`Reconstructor::with_margin`]): a head that reads it builds the
    /// same reconstructor without the analysis. Call it last, on the desktop (it is the
    /// expensive part of a head's boot).
    pub fn with_analysis(mut self) -> Result<Self, SetupError> {
        self.analysis = None;
        let a = self.reconstructor()?.analysis();
        self.analysis = Some(a);
        self.validate()?;
        Ok(self)
    }

    /// This set-up with the decoder's phase-error table `c` (field 8), checked like
    /// [`HeadSetup::parse`].
    pub fn with_correction(mut self, c: &PhaseCorrection) -> Result<Self, SetupError> {
        self.correction = Some(c.into());
        self.validate()?;
        Ok(self)
    }

    /// Check every field and their agreement (frame size = camera size, capture order a
    /// permutation of the set's patterns).
    pub fn validate(&self) -> Result<(), SetupError> {
        self.frames.validate()?;
        self.patterns
            .validate_up_to(MAX_SETUP_BIT_DEPTH)
            .map_err(field)?;
        self.capture_order.validate(&self.patterns)?;
        self.thresholds
            .validate()
            .map_err(|_| SetupError::Thresholds)?;
        self.calibration.validate().map_err(field)?;
        let c = &self.calibration.camera;
        if u32::from(self.frames.width) != c.width || u32::from(self.frames.height) != c.height {
            return Err(SetupError::ImageSize);
        }
        self.edge_filter.validate()?;
        if self.margin.to_array().iter().any(|&m| m > MAX_MARGIN) {
            return Err(SetupError::Invalid(Invalid::Margin));
        }
        if self.analysis.is_some_and(|a| !a.is_sane()) {
            return Err(SetupError::Analysis);
        }
        match &self.correction {
            Some(c) if !c.is_sane() || c.levels != self.patterns.level_count => {
                Err(SetupError::Correction)
            }
            _ => Ok(()),
        }
    }

    /// [`Self::validate`], and a binary set has its phase-correction table: what a blob must be
    /// ([`Self::emit`], [`Self::parse`]); a set-up under construction ([`Self::from_core`]) may
    /// lack the table until [`Self::with_correction`].
    pub fn validate_complete(&self) -> Result<(), SetupError> {
        self.validate()?;
        let binary = !matches!(self.patterns.waveform, Waveform::Sine | Waveform::Cosine);
        if binary && self.correction.is_none() {
            return Err(SetupError::Correction);
        }
        Ok(())
    }

    /// Validate ([`Self::validate_complete`]), then write the blob into `out`; returns its
    /// length.
    pub fn emit(&self, out: &mut [u8]) -> Result<usize, SetupError> {
        self.validate_complete()?;
        let room = out
            .len()
            .checked_sub(SETUP_HEADER_LEN + SETUP_CRC_LEN)
            .ok_or(SetupError::BufferTooSmall)?
            .min(MAX_SETUP_PAYLOAD);
        let body = out
            .get_mut(SETUP_HEADER_LEN..SETUP_HEADER_LEN + room)
            .ok_or(SetupError::BufferTooSmall)?;
        let len = match postcard::to_slice(self, body) {
            Ok(used) => used.len(),
            Err(postcard::Error::SerializeBufferFull) => return Err(SetupError::BufferTooSmall),
            Err(_) => return Err(SetupError::Payload),
        };
        let end = SETUP_HEADER_LEN + len;
        let l16 = u16::try_from(len).map_err(|_| SetupError::Length)?;
        let head = out
            .get_mut(..SETUP_HEADER_LEN)
            .ok_or(SetupError::BufferTooSmall)?;
        head[..4].copy_from_slice(&SETUP_MAGIC);
        head[4] = SETUP_VERSION;
        head[5] = 0;
        head[6..8].copy_from_slice(&l16.to_le_bytes());
        let crc = crc32c(out.get(..end).ok_or(SetupError::BufferTooSmall)?);
        out.get_mut(end..end + SETUP_CRC_LEN)
            .ok_or(SetupError::BufferTooSmall)?
            .copy_from_slice(&crc.to_le_bytes());
        Ok(end + SETUP_CRC_LEN)
    }

    /// Check and decode a whole blob (header, length, CRC, payload, every field).
    pub fn parse(blob: &[u8]) -> Result<HeadSetup, SetupError> {
        let (Some(head), Some(rest)) = (blob.get(..SETUP_HEADER_LEN), blob.get(SETUP_HEADER_LEN..))
        else {
            return Err(SetupError::Truncated);
        };
        if rest.len() < SETUP_CRC_LEN {
            return Err(SetupError::Truncated);
        }
        if head[..4] != SETUP_MAGIC {
            return Err(SetupError::Magic);
        }
        if !(1..=SETUP_VERSION).contains(&head[4]) {
            return Err(SetupError::Version(head[4]));
        }
        if head[5] != 0 {
            return Err(SetupError::Reserved);
        }
        let len = u16::from_le_bytes([head[6], head[7]]) as usize;
        if len > MAX_SETUP_PAYLOAD || rest.len() != len + SETUP_CRC_LEN {
            return Err(SetupError::Length);
        }
        let (payload, crc) = rest.split_at(len);
        let end = SETUP_HEADER_LEN + len;
        let want = u32::from_le_bytes([crc[0], crc[1], crc[2], crc[3]]);
        if crc32c(blob.get(..end).ok_or(SetupError::Truncated)?) != want {
            return Err(SetupError::Crc);
        }
        let s = payload_fields(head[4], payload)?;
        s.validate_complete()?;
        Ok(s)
    }

    /// Number of images per scan.
    pub fn image_count(&self) -> usize {
        self.capture_order.used().len()
    }

    /// The core pattern set, images in capture order ([`PatternSetDesc::to_set`], then
    /// [`PatternSet::with_order`]): the desktop's set bit for bit.
    ///
    /// Not inlined: on a head its temporaries (1.4 KB sets) stay out of the callers' frames.
    #[inline(never)]
    pub fn pattern_set(&self) -> Result<PatternSet, SetupError> {
        self.capture_order.validate(&self.patterns)?;
        let (ids, n) = self.capture_order.image_ids(&self.patterns)?;
        let order = ids.get(..n).ok_or(SetupError::CaptureOrder)?;
        self.patterns
            .build_set_up_to(MAX_SETUP_BIT_DEPTH, Some(order))
            .map_err(SetupError::PatternSet)
    }

    /// The decoder of the pattern set with the thresholds ([`Decoder::new`]) and the
    /// phase-error table, if any ([`Decoder::with_correction`]).
    pub fn decoder(&self) -> Result<Decoder, SetupError> {
        let mut slot = None;
        self.decoder_into(&mut slot)?;
        slot.ok_or(SetupError::Decoder)
    }

    /// [`Self::decoder`] built into `slot` (e.g. a head's `static`): no copy of the decoder on
    /// the caller's stack, which on a head is the set-up's deepest. On error `slot` is `None`.
    #[inline(never)]
    pub fn decoder_into(&self, slot: &mut Option<Decoder>) -> Result<(), SetupError> {
        *slot = None;
        let set = self.pattern_set();
        let set = set.as_ref().map_err(|e| *e)?;
        Decoder::build_into(slot, set, self.thresholds.into()).map_err(|_| SetupError::Decoder)?;
        let Some(d) = slot.as_mut() else {
            return Err(SetupError::Decoder);
        };
        if let Some(c) = &self.correction
            && d.set_correction_knots(c.levels, |l, j| c.knot(l, j))
                .is_err()
        {
            *slot = None;
            return Err(SetupError::Correction);
        }
        Ok(())
    }

    /// The camera model ([`CameraModel::new`]).
    pub fn camera_model(&self) -> Result<CameraModel, SetupError> {
        self.calibration
            .camera_model()
            .map_err(SetupError::Reconstruction)
    }

    /// The reconstruction's set-up (geometry and axis).
    pub fn setup(&self) -> Setup {
        self.calibration.setup(self.axis)
    }

    /// The reconstructor ([`Reconstructor::new`] over the camera model and set-up) for the
    /// reference map of field 9's margin ([`Reconstructor::with_margin`]); from field 10's
    /// analysis when the blob has one ([`Reconstructor::from_analysis`]: the same reconstructor,
    /// without the analysis's cost).
    pub fn reconstructor(&self) -> Result<Reconstructor, SetupError> {
        let Some(a) = &self.analysis else {
            return self
                .calibration
                .reconstructor_with_margin(self.axis, self.margin)
                .map_err(SetupError::Reconstruction);
        };
        self.calibration
            .reconstructor_from_analysis(self.axis, self.margin, a)
            .map_err(SetupError::Reconstruction)
    }

    /// The edge filter ([`EdgeFilter::new`]).
    pub fn edge_filter(&self) -> Result<EdgeFilter, SetupError> {
        let e = self.edge_filter;
        EdgeFilter::new(e.focal_px, e.max_angle_deg).ok_or(SetupError::EdgeFilter)
    }
}
