//! Scan planning: everything a Scan request needs, checked and prepared ([`PendingScan`]).

use fringe3d_core::pattern::{ImageId, MAX_IMAGES};
use fringe3d_core::wire::{
    EdgeFilterMode, Invalid, NakCode, ScanOutput, ScanRequest, ValidationStatus,
};

use super::config::HeadConfig;
use super::control::{Control, POINTS_ONLY, PendingScan};

/// Check everything a scan needs and prepare it; on failure the Nak's code and detail.
pub(super) fn plan_scan(
    ctl: &Control,
    cfg: &HeadConfig,
    seq: u8,
    req: ScanRequest,
) -> Result<PendingScan, (NakCode, u32)> {
    let points = !matches!(req.output, ScanOutput::Phase);
    let mut v = ctl.validation(cfg);
    if !points {
        v &= !POINTS_ONLY;
    }
    if v != 0 {
        return Err((NakCode::SequenceInvalid, v));
    }
    let lut = ctl
        .lut
        .ok_or((NakCode::SequenceInvalid, ValidationStatus::NO_SEQUENCE))?;
    let slot = ctl.usable(lut.set_id).ok_or((
        NakCode::SequenceInvalid,
        ValidationStatus::SET_NOT_CONFIRMED,
    ))?;
    // The capture order: the camera-triggered entries, which must show every pattern once.
    let mut order = [ImageId { level: 0, shift: 0 }; MAX_IMAGES];
    let mut n = 0;
    for i in 0..lut.len {
        let e = lut
            .entry(i)
            .ok_or((NakCode::SequenceInvalid, ValidationStatus::PATTERN_INDEX))?;
        if !e.trigger_out {
            continue;
        }
        let id = slot
            .desc
            .pattern_id(e.pattern)
            .ok_or((NakCode::SequenceInvalid, ValidationStatus::PATTERN_INDEX))?;
        *order
            .get_mut(n)
            .ok_or((NakCode::SequenceInvalid, ValidationStatus::TRIGGER))? = id;
        n += 1;
    }
    let set = slot
        .set
        .with_order(&order[..n])
        .map_err(|_| (NakCode::SequenceInvalid, ValidationStatus::TRIGGER))?;
    if !set.frame_sequential_order() {
        return Err((NakCode::SequenceInvalid, ValidationStatus::CAPTURE_ORDER));
    }
    let (w, h) = (
        ctl.caps.sensor_width as usize,
        ctl.caps.sensor_height as usize,
    );
    let first = req.first_row;
    let count = if req.row_count == 0 {
        (h as u16).saturating_sub(first)
    } else {
        req.row_count
    };
    if first as usize >= h || first as usize + count as usize > h || count == 0 {
        return Err((NakCode::Invalid, Invalid::Dimension as u32));
    }
    let levels = set.levels().len();
    if (1 + 2 * levels) * w * h > ctl.state_capacity || w * h > ctl.flags_capacity {
        return Err((NakCode::OutOfMemory, 0));
    }
    let recon = if points {
        let cal = ctl
            .calibration
            .as_ref()
            .ok_or((NakCode::SequenceInvalid, ValidationStatus::NO_CALIBRATION))?;
        let map = ctl
            .map_confirmed
            .ok_or((NakCode::SequenceInvalid, ValidationStatus::NO_REFERENCE))?;
        // The last scan's reconstructor where it fits (the calibration is the same: a new one
        // forgets it), else a new one.
        let axis = slot.desc.phase.axis;
        let r = match ctl.recon_cache {
            Some(r) if r.setup().axis == axis.into() && r.margin() == map.margin => r,
            _ => cal
                .reconstructor_with_margin(axis, map.margin)
                .map_err(|why| (NakCode::Invalid, why as u32))?,
        };
        // The ring and the staged row are the map's width (the image's and its margin).
        let mw = r.map_width();
        if (r.band().rows() as usize).min(r.map_height()) * mw > ctl.ring_capacity
            || mw > ctl.reference_capacity
        {
            return Err((NakCode::OutOfMemory, 0));
        }
        Some(r)
    } else {
        None
    };
    let filter = match (req.edge_filter, ctl.calibration.as_ref()) {
        (EdgeFilterMode::MaxAngle(a), Some(cal)) if points => Some(
            cal.edge_filter(a)
                .ok_or((NakCode::Invalid, Invalid::EdgeFilter as u32))?,
        ),
        _ => None,
    };
    Ok(PendingScan {
        seq,
        scan_id: req.scan_id,
        output: req.output,
        first,
        count,
        set,
        slot: lut.set_id,
        recon,
        // The compiled models stand in for the search where they have a function; a scan of
        // phases only has no use for them.
        compiled: ctl.compiled_confirmed.filter(|_| points),
        compiled_settled: ctl.compiled_settled,
        filter,
        exposures: req.exposures,
    })
}
