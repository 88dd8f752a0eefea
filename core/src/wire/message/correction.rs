//! The decoder's phase-error table on the wire: [`SetupCorrection`] (the set-up blob's field 8
//! and the body of DefineCorrection), and [`DefineCorrection`].
//!
//! The table is the decoder's [`PhaseCorrection`] (docs/gamma.md, docs/binary.md): for each
//! level, [`CORRECTION_KNOTS`] knots of the wrapped-phase error the projector's light leaves
//! (its gamma, a binary set's blurred square waves), which the decoder subtracts. A head that
//! decodes without it measures the error as shape.

use serde::{Deserialize, Serialize};

use super::{Body, Invalid, WireError, check};
use crate::decode::{CORRECTION_KNOTS, PhaseCorrection};
use crate::limits::MAX_LEVELS;

/// [`PhaseCorrection`] as the wire carries it: the same integers. Postcard: levels u8, then
/// 6 × 32 i16 knots (zigzag varints, 2⁻¹³ rad; unused levels 0).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct SetupCorrection {
    /// Levels the table covers (the pattern set's level count).
    pub levels: u8,
    /// Knots per level, 2⁻¹³ rad ([`crate::decode::CORRECTION_LSB`]).
    pub knots: [[i16; CORRECTION_KNOTS]; MAX_LEVELS],
}

impl SetupCorrection {
    /// Knot `j` of level `l` (2⁻¹³ rad).
    pub fn knot(&self, l: usize, j: usize) -> i16 {
        self.knots[l % MAX_LEVELS][j % CORRECTION_KNOTS]
    }

    /// [`PhaseCorrection::is_sane`] of the same table (without building it).
    pub fn is_sane(&self) -> bool {
        let m = PhaseCorrection::MAX_DELTA;
        (1..=MAX_LEVELS).contains(&(self.levels as usize))
            && self.knots[..self.levels as usize]
                .iter()
                .flatten()
                .all(|d| (-m..=m).contains(d))
    }
}

impl From<&PhaseCorrection> for SetupCorrection {
    fn from(c: &PhaseCorrection) -> Self {
        SetupCorrection {
            levels: c.levels,
            knots: c.delta,
        }
    }
}

impl From<&SetupCorrection> for PhaseCorrection {
    fn from(c: &SetupCorrection) -> Self {
        PhaseCorrection {
            levels: c.levels,
            delta: c.knots,
        }
    }
}

/// Host → head: the phase-error table pattern set `set_id` is decoded with, or none (protocol
/// version 4). The head keeps it with the set until the set is defined anew (a different
/// description drops it) or another DefineCorrection replaces it; a binary set (waveform 2-5)
/// does not scan without one ([`super::ValidationStatus::NO_CORRECTION`]).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct DefineCorrection {
    /// A defined set's slot, `< Capabilities::max_sets`.
    pub set_id: u8,
    /// The table (`None`: decode uncorrected). Its level count must be the set's.
    pub table: Option<SetupCorrection>,
}

impl Body for DefineCorrection {
    fn validate_body(&self) -> Result<(), WireError> {
        check(
            self.table.as_ref().is_none_or(SetupCorrection::is_sane),
            Invalid::Correction,
        )
    }
}
