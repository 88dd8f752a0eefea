//! Pattern sets: the description types live in [`crate::params::pattern`]; their field checks
//! and the DefinePatternSet body here.

use serde::{Deserialize, Serialize};

use super::{
    Body, Invalid, Level, MAX_BIT_DEPTH, MAX_KNOTS, MAX_LEVELS, MAX_SHIFTS, PatternSetDesc,
    PhaseProfile, Shifts, WireError, check, finite64,
};

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
            Shifts::Gray { bits, .. } => check(
                bits >= 1 && bits as usize <= crate::limits::MAX_GRAY_BITS,
                Invalid::Shifts,
            ),
            Shifts::GrayInverse { bits, .. } => {
                check(bits >= 1 && self.count() <= MAX_SHIFTS, Invalid::Shifts)
            }
            Shifts::GrayShifted { bits, .. } => check(
                bits >= 1
                    && bits as usize <= crate::limits::MAX_GRAY_BITS
                    && self.count() <= MAX_SHIFTS,
                Invalid::Shifts,
            ),
        }
    }
}

impl PatternSetDesc {
    /// Check every field (see the field docs). What only the whole set can tell (monotonic,
    /// continuous phase, coarse range, scales increasing, shifts separating the unknowns) is
    /// checked by [`PatternSetDesc::to_set`].
    pub fn validate(&self) -> Result<(), WireError> {
        self.validate_up_to(MAX_BIT_DEPTH)
    }

    /// [`PatternSetDesc::validate`] for projectors of up to `max_bits` bits: the head renders
    /// 1..=[`MAX_BIT_DEPTH`]-bit patterns, a set-up blob describes the projector the camera saw,
    /// up to the core's 16 bits.
    pub(crate) fn validate_up_to(&self, max_bits: u8) -> Result<(), WireError> {
        check(self.width >= 1 && self.height >= 1, Invalid::Dimension)?;
        check((1..=max_bits).contains(&self.bit_depth), Invalid::BitDepth)?;
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

impl Body for DefinePatternSet {
    fn validate_body(&self) -> Result<(), WireError> {
        self.desc.validate()
    }
}
