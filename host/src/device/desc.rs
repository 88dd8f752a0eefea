//! Desktop data in wire form: pattern sets, calibrations, trigger tables, pattern images and the
//! reference phase map.
//!
//! The wire carries f32 where the desktop files hold f64, so a value survives the trip exactly
//! only if it is an f32. [`Fidelity`] says, for a pattern set, whether the set the head rebuilds
//! from its description (the same mapping as the head's `desc` module, repeated here and checked
//! against it by the firmware's tests) is the desktop's set bit for bit — then the head's own
//! patterns equal `fringe3d patterns` and its decoder equals the desktop's — and
//! [`calibration_is_f32`] says the same of a calibration.

use std::f64::consts::TAU;

use fringe3d_core::decode::{DecodeConfig, Decoder};
use fringe3d_core::pattern::{
    Convention, ImageId, Level, MAX_LEVELS as CORE_MAX_LEVELS, MAX_SHIFTS, Output, PatternSet,
};
use fringe3d_core::phase_function::{Axis, PhaseFunction, Profile};
use fringe3d_core::validity::Validity;
use fringe3d_core::wire::{
    self, CameraModel, LinearPhase, LutEntry, MAX_LEVELS, PatternAxis, PatternSetDesc, Shifts,
    Waveform,
};

use crate::io::calibration::Calibration;

/// How faithfully the head can rebuild a desktop pattern set from its wire description.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Fidelity {
    /// The rebuilt set equals the desktop's bit for bit: the head's generated patterns are the
    /// PNGs of `fringe3d patterns`, no upload needed.
    pub patterns: bool,
    /// The head's decoder equals the desktop's (same coefficients, ratios and range): phase and
    /// points bit-identical to the desktop's on the same images.
    pub decoder: bool,
}

/// The wire description of `set` for a projector of `bit_depth` bits (1 to 8). Fails for what the
/// wire cannot describe: non-linear or curved phase functions, `i_min ≠ 0`, more than the core's
/// levels, deeper than 8 bits.
pub fn pattern_desc(set: &PatternSet, bit_depth: u8) -> Result<PatternSetDesc, String> {
    if !(1..=8).contains(&bit_depth) {
        return Err(format!(
            "the head projects 1- to 8-bit patterns, this set is {bit_depth}-bit"
        ));
    }
    let f = set.function();
    let Profile::Linear { origin, slope } = *f.profile() else {
        return Err("the head knows linear phase functions only (no knots); this set cannot be decoded on the head".into());
    };
    if f.curvature() != 0.0 {
        return Err("the head knows straight fringes only (curvature 0); this set cannot be decoded on the head".into());
    }
    let o = set.output();
    if o.i_min != 0.0 {
        return Err(format!(
            "the head's patterns start at gray level 0; this set has i_min = {}",
            o.i_min
        ));
    }
    let levels = set.levels();
    if levels.len() > CORE_MAX_LEVELS.min(MAX_LEVELS) {
        return Err(format!(
            "{} levels; the head takes at most {}",
            levels.len(),
            CORE_MAX_LEVELS
        ));
    }
    let (a, c) = ((slope) as f32, (-slope * origin) as f32);
    let phase = match f.axis() {
        Axis::Xi => LinearPhase { a, b: 0.0, c },
        Axis::Eta => LinearPhase { a: 0.0, b: a, c },
    };
    let mut wl = [wire::Level::UNUSED; MAX_LEVELS];
    for (dst, l) in wl.iter_mut().zip(levels) {
        *dst = wire::Level {
            scale: l.scale() as f32,
            shifts: shifts(l.shifts()),
        };
    }
    let d = PatternSetDesc {
        width: u16::try_from(o.width)
            .map_err(|_| "projector wider than 65535 pixels".to_string())?,
        height: u16::try_from(o.height)
            .map_err(|_| "projector taller than 65535 pixels".to_string())?,
        bit_depth,
        i_max: o.i_max as f32,
        axis: match f.axis() {
            Axis::Xi => PatternAxis::Xi,
            Axis::Eta => PatternAxis::Eta,
        },
        waveform: match set.convention() {
            Convention::Sine => Waveform::Sine,
            Convention::Cosine => Waveform::Cosine,
        },
        phase_offset: set.phase_offset() as f32,
        phase,
        level_count: levels.len() as u8,
        levels: wl,
    };
    d.validate()
        .map_err(|e| format!("the wire description is invalid: {e}"))?;
    Ok(d)
}

/// Uniform `2π·i/n` shifts when they are exactly that, else explicit f32 shifts.
fn shifts(s: &[f64]) -> Shifts {
    let count = s.len();
    for n in count.max(1)..=MAX_SHIFTS {
        if s.iter()
            .enumerate()
            .all(|(i, &v)| v.to_bits() == (TAU * i as f64 / n as f64).to_bits())
        {
            return Shifts::Uniform {
                n: n as u8,
                count: count as u8,
            };
        }
    }
    let mut radians = [0.0f32; MAX_SHIFTS];
    for (d, v) in radians.iter_mut().zip(s) {
        *d = *v as f32;
    }
    Shifts::Explicit {
        count: count as u8,
        radians,
    }
}

/// The core set the head builds from `d` (its mapping, repeated: see the module documentation),
/// images in the core's default order.
pub fn desc_to_set(d: &PatternSetDesc) -> Result<PatternSet, String> {
    d.validate().map_err(|e| e.to_string())?;
    let (axis, along, across) = match d.axis {
        PatternAxis::Xi => (Axis::Xi, d.phase.a, d.phase.b),
        PatternAxis::Eta => (Axis::Eta, d.phase.b, d.phase.a),
    };
    if across != 0.0 || along.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
        return Err("the phase must increase along its axis only".into());
    }
    let slope = along as f64;
    let function = PhaseFunction::linear(axis, -(d.phase.c as f64) / slope, slope)
        .map_err(|e| e.to_string())?;
    let mut levels = Vec::new();
    for l in d.used_levels() {
        let scale = l.scale as f64;
        levels.push(match l.shifts {
            Shifts::Uniform { n, count } if count == n => Level::n_step(scale, n as usize),
            Shifts::Uniform { n, count } => {
                let s: Vec<f64> = (0..count as usize)
                    .map(|i| TAU * i as f64 / n as f64)
                    .collect();
                Level::with_shifts(scale, &s)
            }
            Shifts::Explicit { count, radians } => {
                let s: Vec<f64> = radians[..count as usize]
                    .iter()
                    .map(|&r| r as f64)
                    .collect();
                Level::with_shifts(scale, &s)
            }
        });
    }
    let output = Output {
        width: d.width as u32,
        height: d.height as u32,
        i_min: 0.0,
        i_max: d.i_max as f64,
    };
    let conv = match d.waveform {
        Waveform::Sine => Convention::Sine,
        Waveform::Cosine => Convention::Cosine,
    };
    PatternSet::new(function, &levels, output)
        .map_err(|e| e.to_string())?
        .with_convention(conv)
        .with_phase_offset(d.phase_offset as f64)
        .map_err(|e| e.to_string())
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

/// Wire pattern index (levels in order, shifts in order) of `id`.
pub fn pattern_index(d: &PatternSetDesc, id: ImageId) -> Option<u16> {
    let levels = d.used_levels();
    let l = levels.get(id.level as usize)?;
    if id.shift as usize >= l.shifts.count() {
        return None;
    }
    let first: usize = levels[..id.level as usize]
        .iter()
        .map(|l| l.shifts.count())
        .sum();
    u16::try_from(first + id.shift as usize).ok()
}

/// The trigger table that captures `set` in its image order: one entry per image, each showing
/// its pattern for `exposure_us` and triggering the camera, then `dark_us` dark.
pub fn capture_sequence(
    set: &PatternSet,
    d: &PatternSetDesc,
    exposure_us: u32,
    dark_us: u32,
) -> Result<Vec<LutEntry>, String> {
    set.order()
        .iter()
        .map(|&id| {
            let pattern = pattern_index(d, id).ok_or_else(|| {
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
        let id = pattern_id(d, p as u16).ok_or("pattern index outside the description")?;
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

/// Level and shift of wire pattern `p`.
pub fn pattern_id(d: &PatternSetDesc, p: u16) -> Option<ImageId> {
    let mut first = 0usize;
    for (k, l) in d.used_levels().iter().enumerate() {
        let n = l.shifts.count();
        if (p as usize) < first + n {
            return Some(ImageId {
                level: k as u8,
                shift: (p as usize - first) as u8,
            });
        }
        first += n;
    }
    None
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

/// The wire form of a calibration (values rounded to f32). Needs the reference plane.
pub fn wire_calibration(c: &Calibration) -> Result<wire::Calibration, String> {
    let r = c
        .reference
        .as_ref()
        .ok_or("the calibration has no [reference] section (plane and phase map)")?;
    let f3 = |v: &[f64; 3]| [v[0] as f32, v[1] as f32, v[2] as f32];
    let cam = &c.camera;
    let d = &cam.distortion;
    let w = wire::Calibration {
        camera: CameraModel {
            width: u16::try_from(cam.width).map_err(|_| "camera wider than 65535 pixels")?,
            height: u16::try_from(cam.height).map_err(|_| "camera taller than 65535 pixels")?,
            fx: cam.fx as f32,
            fy: cam.fy as f32,
            cx: cam.cx as f32,
            cy: cam.cy as f32,
            skew: cam.skew as f32,
            distortion: [
                d[0] as f32,
                d[1] as f32,
                d[2] as f32,
                d[3] as f32,
                d[4] as f32,
            ],
        },
        projector_centre: f3(&c.projector_center),
        plane_point: f3(&r.point),
        plane_normal: f3(&r.normal),
        depth_min: c.depth_range[0] as f32,
        depth_max: c.depth_range[1] as f32,
    };
    w.validate()
        .map_err(|e| format!("the calibration does not fit the wire: {e}"))?;
    Ok(w)
}

fn f32_exact(v: f64) -> bool {
    (v as f32) as f64 == v
}

/// `true` if every number the head uses from `c` is an f32 (then the head reconstructs with the
/// desktop's exact calibration).
pub fn calibration_is_f32(c: &Calibration) -> bool {
    let cam = &c.camera;
    let mut all = vec![cam.fx, cam.fy, cam.cx, cam.cy, cam.skew];
    all.extend_from_slice(&cam.distortion);
    all.extend_from_slice(&c.projector_center);
    all.extend_from_slice(&c.depth_range);
    if let Some(r) = &c.reference {
        all.extend_from_slice(&r.point);
        all.extend_from_slice(&r.normal);
    }
    all.into_iter().all(f32_exact)
}

/// `c` with every number the head uses rounded to f32 (a calibration the head and the desktop
/// share exactly).
pub fn round_calibration_to_f32(c: &Calibration) -> Calibration {
    let r = |v: f64| (v as f32) as f64;
    let r3 = |v: [f64; 3]| [r(v[0]), r(v[1]), r(v[2])];
    let mut o = c.clone();
    o.camera.fx = r(o.camera.fx);
    o.camera.fy = r(o.camera.fy);
    o.camera.cx = r(o.camera.cx);
    o.camera.cy = r(o.camera.cy);
    o.camera.skew = r(o.camera.skew);
    o.camera.distortion = o.camera.distortion.map(r);
    o.projector_center = r3(o.projector_center);
    o.depth_range = [r(o.depth_range[0]), r(o.depth_range[1])];
    if let Some(re) = o.reference.as_mut() {
        re.point = r3(re.point);
        re.normal = r3(re.normal);
    }
    if let Some(p) = o.projector.as_mut() {
        p.translation = o.projector_center;
    }
    o
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
