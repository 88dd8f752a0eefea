//! Parametric pattern sets on the head: the wire's [`PatternSetDesc`] as a core [`PatternSet`].
//!
//! The head renders a defined set row by row with the core's [`PatternSet::generate_row`] and
//! decodes its captures with the core's decoder, so it needs the very `PatternSet` the desktop
//! builds from the same parameters. The mapping, exactly (every f32 widened to f64 first):
//!
//! - `Φ = a·ξ + b·η + c` with axis ξ needs `b = 0` and becomes
//!   `PhaseFunction::linear(Xi, origin = −c/a, slope = a)` (η: `a = 0`, slope `b`); the slope
//!   must be positive (the core's phase increases along its axis);
//! - level `Uniform { n, count }` becomes the core's `Level::n_step(scale, n)` when `count = n`,
//!   else the shifts `2π·i/n`, `i < count` (the same f64 expression, so `{4, 2}` gives the
//!   paper's `two_step` bit for bit); `Explicit` shifts are taken as they are;
//! - `i_min = 0`, `i_max` as given; sine or cosine convention; the phase offset as given.
//!
//! At most [`fringe3d_core::pattern::MAX_LEVELS`] levels (the wire allows more). The host runs
//! the same mapping before it chooses between defining a set and uploading its images
//! (`fringe3d::device::desc`); a test checks that both agree.
//!
//! Pattern indices on the wire count levels in order and shifts in order within a level
//! ([`pattern_id`]); the core's image order (DC level first) is another numbering, so the head
//! maps between the two.

use core::f64::consts::TAU;

use fringe3d_core::pattern::{
    Convention, ImageId, Level, MAX_LEVELS as CORE_MAX_LEVELS, MAX_SHIFTS, Output, PatternError,
    PatternSet,
};
use fringe3d_core::phase_function::{Axis, PhaseFunction};
use fringe3d_core::wire::{Invalid, PatternAxis, PatternSetDesc, Shifts, Waveform, WireError};

/// The core set described by `desc`, images in the core's default order. Errors are the wire's
/// [`Invalid`] codes (sent back as a Nak's detail).
pub fn pattern_set(desc: &PatternSetDesc) -> Result<PatternSet, Invalid> {
    desc.validate().map_err(|e| match e {
        WireError::Invalid(why) => why,
        _ => Invalid::PhaseFunction,
    })?;
    let n = desc.level_count as usize;
    if !(1..=CORE_MAX_LEVELS).contains(&n) {
        return Err(Invalid::LevelCount);
    }
    let (axis, along, across) = match desc.axis {
        PatternAxis::Xi => (Axis::Xi, desc.phase.a, desc.phase.b),
        PatternAxis::Eta => (Axis::Eta, desc.phase.b, desc.phase.a),
    };
    if across != 0.0 || !(along > 0.0) {
        return Err(Invalid::PhaseFunction);
    }
    let slope = along as f64;
    let origin = -(desc.phase.c as f64) / slope;
    let function =
        PhaseFunction::linear(axis, origin, slope).map_err(|_| Invalid::PhaseFunction)?;
    let mut levels = [Level::with_shifts(0.0, &[]); CORE_MAX_LEVELS];
    for (dst, l) in levels.iter_mut().zip(desc.used_levels()) {
        *dst = level(l)?;
    }
    let output = Output {
        width: desc.width as u32,
        height: desc.height as u32,
        i_min: 0.0,
        i_max: desc.i_max as f64,
    };
    let convention = match desc.waveform {
        Waveform::Sine => Convention::Sine,
        Waveform::Cosine => Convention::Cosine,
    };
    PatternSet::new(function, &levels[..n], output)
        .map_err(invalid)?
        .with_convention(convention)
        .with_phase_offset(desc.phase_offset as f64)
        .map_err(invalid)
}

fn level(l: &fringe3d_core::wire::Level) -> Result<Level, Invalid> {
    let scale = l.scale as f64;
    match l.shifts {
        Shifts::Uniform { n, count } if count == n => Ok(Level::n_step(scale, n as usize)),
        Shifts::Uniform { n, count } => {
            let mut s = [0.0f64; MAX_SHIFTS];
            let count = (count as usize).min(MAX_SHIFTS);
            for (i, v) in s.iter_mut().enumerate().take(count) {
                *v = TAU * i as f64 / n as f64;
            }
            Ok(Level::with_shifts(scale, &s[..count]))
        }
        Shifts::Explicit { count, radians } => {
            let mut s = [0.0f64; MAX_SHIFTS];
            let count = (count as usize).min(MAX_SHIFTS);
            for (v, r) in s.iter_mut().zip(radians.iter()).take(count) {
                *v = *r as f64;
            }
            Ok(Level::with_shifts(scale, &s[..count]))
        }
    }
}

fn invalid(e: PatternError) -> Invalid {
    match e {
        PatternError::Function(_) => Invalid::PhaseFunction,
        PatternError::LevelCount(_) | PatternError::TooManyImages(_) | PatternError::ImageOrder => {
            Invalid::LevelCount
        }
        PatternError::Scale(_) | PatternError::ScalesNotIncreasing(_) => Invalid::Scale,
        PatternError::ShiftCount(..)
        | PatternError::Shift(_)
        | PatternError::DegenerateShifts(_)
        | PatternError::NoDcLevel => Invalid::Shifts,
        PatternError::Output => Invalid::Intensity,
    }
}

/// Level and shift of wire pattern index `p` (levels in order, shifts in order).
pub fn pattern_id(desc: &PatternSetDesc, p: u16) -> Option<ImageId> {
    let mut first = 0usize;
    for (k, l) in desc.used_levels().iter().enumerate() {
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

/// The wire pattern index of level `id.level`, shift `id.shift`.
pub fn pattern_index(desc: &PatternSetDesc, id: ImageId) -> Option<u16> {
    let levels = desc.used_levels();
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

/// The core image index (in `set`'s order) showing level `id.level`, shift `id.shift`.
pub fn image_index(set: &PatternSet, id: ImageId) -> Option<usize> {
    set.order().iter().position(|o| *o == id)
}
