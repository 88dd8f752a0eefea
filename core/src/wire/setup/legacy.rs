//! Payloads of the blob's older format versions, read into today's [`HeadSetup`].
//!
//! - Version 1: fields 1-7 (no field 8, the projector-response correction: none).
//! - Version 2: fields 1-8; field 3, the capture order, as a count u8 and always 32 pattern
//!   indices (unused 0).
//! - Version 3: field 3 as postcard bytes, up to 64 indices ([`CaptureOrder`]'s own serde).
//! - Version 4: field 2, the pattern set, ends with the levels' relation (hierarchical,
//!   heterodyne or coprime); versions 1-3 have no such byte and mean hierarchical.
//! - Version 5: field 9, the reference map's margin past the image; versions 1-4 have none and
//!   mean an image-sized map.
//! - Version 6 (written today): field 10, the reconstructor's set-up analysis; versions 1-5 have
//!   none and mean "analyse at boot".

use serde::Deserialize;

use super::{
    CaptureOrder, DecodeThresholds, EdgeFilterParams, FrameFormat, HeadSetup, SetupCorrection,
    SetupError,
};
use crate::pattern::{MAX_IMAGES, Relation};
use crate::reconstruct::Margin;
use crate::wire::message::{
    Calibration, Level, MAX_LEVELS, PatternAxis, PatternSetDesc, PhaseDesc, Waveform,
};

/// Decode a payload of `version` (1: fields 1-7; 2: and field 8; 3: field 3 as bytes; 4: a
/// relation in field 2; 5: and field 9; 6: and field 10). The current version decodes straight into the result (no copy of the
/// fields on the way: a head's set-up stack is tight); the old ones each in a frame of their
/// own, which only they pay for.
#[inline(never)]
pub(super) fn payload_fields(version: u8, payload: &[u8]) -> Result<HeadSetup, SetupError> {
    match version {
        1 => version_1(payload),
        2 => version_2(payload),
        3 => version_3(payload),
        4 => version_4(payload),
        5 => version_5(payload),
        _ => whole(postcard::take_from_bytes::<HeadSetup>(payload)),
    }
}

/// The value of a postcard result that used every byte.
fn whole<T>(r: postcard::Result<(T, &[u8])>) -> Result<T, SetupError> {
    match r {
        Ok((v, [])) => Ok(v),
        Ok(_) => Err(SetupError::TrailingBytes),
        Err(_) => Err(SetupError::Payload),
    }
}

#[inline(never)]
fn version_1(payload: &[u8]) -> Result<HeadSetup, SetupError> {
    let v = whole(postcard::take_from_bytes::<HeadSetupOld<()>>(payload))?;
    Ok(v.into_setup(None))
}

#[inline(never)]
fn version_2(payload: &[u8]) -> Result<HeadSetup, SetupError> {
    let v = whole(postcard::take_from_bytes::<
        HeadSetupOld<Option<SetupCorrection>>,
    >(payload))?;
    let correction = v.tail;
    Ok(v.into_setup(correction))
}

#[inline(never)]
fn version_3(payload: &[u8]) -> Result<HeadSetup, SetupError> {
    let v = whole(postcard::take_from_bytes::<
        HeadSetupOld<Option<SetupCorrection>, CaptureOrder>,
    >(payload))?;
    let correction = v.tail;
    Ok(v.into_setup(correction))
}

#[inline(never)]
fn version_4(payload: &[u8]) -> Result<HeadSetup, SetupError> {
    let v = whole(postcard::take_from_bytes::<
        HeadSetupOld<Option<SetupCorrection>, CaptureOrder, PatternSetDesc>,
    >(payload))?;
    let correction = v.tail;
    Ok(v.into_setup(correction))
}

#[inline(never)]
fn version_5(payload: &[u8]) -> Result<HeadSetup, SetupError> {
    let v = whole(postcard::take_from_bytes::<
        HeadSetupOld<(Option<SetupCorrection>, Margin), CaptureOrder, PatternSetDesc>,
    >(payload))?;
    let (correction, margin) = v.tail;
    Ok(HeadSetup {
        margin,
        ..v.into_setup(correction)
    })
}

/// Field 2 of versions 1-3: today's [`PatternSetDesc`] without its last field, the relation.
#[derive(Deserialize)]
struct PatternSetDesc3 {
    width: u16,
    height: u16,
    bit_depth: u8,
    i_min: f64,
    i_max: f64,
    waveform: Waveform,
    phase_offset: f64,
    phase: PhaseDesc,
    level_count: u8,
    levels: [Level; MAX_LEVELS],
}

impl From<PatternSetDesc3> for PatternSetDesc {
    fn from(d: PatternSetDesc3) -> Self {
        PatternSetDesc {
            width: d.width,
            height: d.height,
            bit_depth: d.bit_depth,
            i_min: d.i_min,
            i_max: d.i_max,
            waveform: d.waveform,
            phase_offset: d.phase_offset,
            phase: d.phase,
            level_count: d.level_count,
            levels: d.levels,
            relation: Relation::Hierarchical,
        }
    }
}

/// Field 3 of versions 1 and 2: a count and always 32 indices.
#[derive(Deserialize)]
struct CaptureOrder32 {
    count: u8,
    patterns: [u8; 32],
}

impl From<CaptureOrder32> for CaptureOrder {
    fn from(v: CaptureOrder32) -> Self {
        let mut c = CaptureOrder {
            count: v.count,
            patterns: [0; MAX_IMAGES],
        };
        for (d, s) in c.patterns.iter_mut().zip(v.patterns) {
            *d = s;
        }
        c
    }
}

/// The payload of a version-1 blob (fields 1-7; `T = ()`, which postcard writes as nothing), a
/// version-2 one (and field 8, `T = Option<SetupCorrection>`), with `O = CaptureOrder` a
/// version-3 one and with `P = PatternSetDesc` a version-4 one (no field 9: no margin); with
/// `T = (Option<SetupCorrection>, Margin)` a version-5 one (no field 10: no analysis).
#[derive(Deserialize)]
struct HeadSetupOld<T, O = CaptureOrder32, P = PatternSetDesc3> {
    frames: FrameFormat,
    patterns: P,
    capture_order: O,
    thresholds: DecodeThresholds,
    calibration: Calibration,
    axis: PatternAxis,
    edge_filter: EdgeFilterParams,
    tail: T,
}

impl<T, O: Into<CaptureOrder>, P: Into<PatternSetDesc>> HeadSetupOld<T, O, P> {
    fn into_setup(self, correction: Option<SetupCorrection>) -> HeadSetup {
        HeadSetup {
            frames: self.frames,
            patterns: self.patterns.into(),
            capture_order: self.capture_order.into(),
            thresholds: self.thresholds,
            calibration: self.calibration,
            axis: self.axis,
            edge_filter: self.edge_filter,
            correction,
            margin: Margin::ZERO,
            analysis: None,
        }
    }
}
