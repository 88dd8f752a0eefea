//! Desktop data in wire form: pattern sets, calibrations, trigger tables, pattern images and the
//! reference phase map.
//!
//! The mapping between the core's types and the wire's descriptions is the core's own
//! (`fringe3d_core::wire::desc`), the same code the head runs. Since protocol version 2 it carries
//! every parameter as the f64 the core holds, so the head rebuilds the desktop's pattern set and
//! reconstructor exactly: its generated patterns are the PNGs of `fringe3d patterns` and its
//! phases and points those of `fringe3d scan`, whatever the parameters. [`fidelity`] checks that
//! (a rebuilt set that differed would be a bug).

use fringe3d_core::decode::{DecodeConfig, Decoder};
use fringe3d_core::pattern::PatternSet;
use fringe3d_core::phase_function::Axis;
use fringe3d_core::validity::Validity;
use fringe3d_core::wire::{self, LutEntry, PatternSetDesc};

use crate::io::calibration::Calibration;

/// How faithfully the head rebuilds a desktop pattern set from its wire description.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Fidelity {
    /// The rebuilt set equals the desktop's bit for bit: the head's generated patterns are the
    /// PNGs of `fringe3d patterns`, no upload needed.
    pub patterns: bool,
    /// The head's decoder equals the desktop's (same coefficients, ratios and range): phase and
    /// points bit-identical to the desktop's on the same images.
    pub decoder: bool,
}

/// The wire description of `set` for a projector of `bit_depth` bits (1 to 8): linear or knot
/// profiles, straight or curved fringes, every parameter as the core holds it.
pub fn pattern_desc(set: &PatternSet, bit_depth: u8) -> Result<PatternSetDesc, String> {
    PatternSetDesc::from_set(set, bit_depth as u32).map_err(|e| e.to_string())
}

/// The core set the head builds from `d` (the core's mapping, the head's code path), images in
/// the core's default order.
pub fn desc_to_set(d: &PatternSetDesc) -> Result<PatternSet, String> {
    d.to_set()
        .map_err(|why| format!("the head would refuse this set: {}", why.name()))
}

/// How faithfully the head rebuilds `set` from `d` (decoders compared for `camera_bits`).
pub fn fidelity(set: &PatternSet, d: &PatternSetDesc, camera_bits: u32) -> Fidelity {
    let Ok(head) =
        desc_to_set(d).and_then(|s| s.with_order(set.order()).map_err(|e| e.to_string()))
    else {
        return Fidelity {
            patterns: false,
            decoder: false,
        };
    };
    let cfg = DecodeConfig::for_bit_depth(camera_bits);
    let decoder = match (Decoder::new(set, cfg), Decoder::new(&head, cfg)) {
        (Ok(a), Ok(b)) => a == b,
        _ => false,
    };
    Fidelity {
        patterns: head == *set,
        decoder,
    }
}

/// The trigger table that captures `set` in its image order: one entry per image, each showing
/// its pattern for `exposure_us` and triggering the camera, then `dark_us` dark.
pub fn capture_sequence(
    set: &PatternSet,
    d: &PatternSetDesc,
    exposure_us: u32,
    dark_us: u32,
) -> Result<Vec<LutEntry>, String> {
    // A head decodes frame by frame: a Gray-coded set whose order puts a Gray image before the
    // DC level's last image (a `version = 2` file lists the Gray level first) is captured in the
    // built-in order, which has the DC level first (the decoded bits do not depend on it).
    let builtin;
    let mut order = set.order();
    if !set.frame_sequential_order() {
        builtin = PatternSet::new(*set.function(), set.levels(), *set.output())
            .map_err(|e| format!("the built-in order of the set: {e}"))?;
        order = builtin.order();
    }
    order
        .iter()
        .map(|&id| {
            let pattern = d.pattern_index(id).ok_or_else(|| {
                format!(
                    "image (level {}, shift {}) is not in the description",
                    id.level, id.shift
                )
            })?;
            Ok(LutEntry {
                pattern,
                exposure_us,
                dark_us,
                bit_depth: d.bit_depth,
                wait_for_trigger: false,
                trigger_out: true,
            })
        })
        .collect()
}

/// The bytes of a pattern-image upload: every pattern in wire order (levels in order, shifts in
/// order), rows top to bottom, one byte per pixel. `image(i)` gives image `i` of `set` (core
/// order), `width × height` bytes.
pub fn pattern_bytes(
    set: &PatternSet,
    d: &PatternSetDesc,
    mut image: impl FnMut(usize) -> Result<Vec<u8>, String>,
) -> Result<Vec<u8>, String> {
    let n = d.pattern_count();
    let (w, h) = (d.width as usize, d.height as usize);
    let mut out = Vec::with_capacity(n * w * h);
    for p in 0..n {
        let id = d
            .pattern_id(p as u16)
            .ok_or("pattern index outside the description")?;
        let i = set
            .order()
            .iter()
            .position(|o| *o == id)
            .ok_or("pattern missing from the set's image order")?;
        let img = image(i)?;
        if img.len() != w * h {
            return Err(format!(
                "pattern image {i} has {} pixels, the projector {}x{}",
                img.len(),
                w,
                h
            ));
        }
        out.extend_from_slice(&img);
    }
    Ok(out)
}

/// Image `i` of `set`, rendered as the 8-bit PNGs of `fringe3d patterns` are.
pub fn render_pattern(set: &PatternSet, i: usize) -> Result<Vec<u8>, String> {
    let o = set.output();
    let (w, h) = (o.width as usize, o.height as usize);
    let mut img = vec![0u8; w * h];
    for (y, row) in img.chunks_exact_mut(w).enumerate() {
        set.generate_row(i, y as u32, row)
            .map_err(|e| e.to_string())?;
    }
    Ok(img)
}

/// The wire form of a calibration: the camera's intrinsics and distortion as the desktop's core
/// camera model holds them, and the reconstruction set-up exactly as `fringe3d scan` builds it
/// (`scan::ScanCalibration::from_parts`), all f64. Needs the reference plane.
pub fn wire_calibration(c: &Calibration) -> Result<wire::Calibration, String> {
    // The axis is not carried: the head takes the pattern set's.
    let (cam, setup) = c.core_setup(Axis::Xi)?;
    wire::Calibration::from_core(cam.params(), &setup)
        .map_err(|e| format!("the calibration does not fit the wire: {e}"))
}

/// The bytes of a reference phase-map upload: per row, the f32 phases (LE) then one validity
/// byte per column — `Valid` where the phase is finite, else `ReferenceInvalid` (what the
/// desktop's scan path derives from the map).
pub fn phase_map_bytes(phase: &[f32], width: usize) -> Vec<u8> {
    let mut out = Vec::with_capacity(phase.len() * 5);
    for row in phase.chunks(width.max(1)) {
        for p in row {
            out.extend_from_slice(&p.to_le_bytes());
        }
        for p in row {
            out.push(if p.is_finite() {
                Validity::Valid as u8
            } else {
                Validity::ReferenceInvalid as u8
            });
        }
    }
    out
}
