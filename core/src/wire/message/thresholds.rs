//! The decoder's thresholds for a pattern set on a head: [`DefineThresholds`] (protocol
//! version 7), and [`DecodeThresholds`], which it carries and the set-up blob's field 4 is.
//!
//! Without it a head decodes with its camera bit depth's defaults
//! ([`DecodeConfig::for_bit_depth`]); with it, with the host's: the minimum modulation in the
//! sensor's noise (`12σ`, [`DecodeConfig::for_sensor`]), the saturation level
//! and the tolerances a user set, so that the head's points are the desktop `scan`'s bit for bit.

use serde::{Deserialize, Serialize};

use super::{Body, Invalid, WireError, check};
use crate::decode::DecodeConfig;

/// Host → head: the thresholds pattern set `set_id` is decoded with, or none (the camera bit
/// depth's defaults). The head keeps them with the set until the set is defined anew (a
/// different description drops them) or another DefineThresholds replaces them.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct DefineThresholds {
    /// A defined set's slot, `< Capabilities::max_sets`.
    pub set_id: u8,
    /// The thresholds (`None`: the camera bit depth's defaults).
    pub thresholds: Option<DecodeThresholds>,
}

impl Body for DefineThresholds {
    fn validate_body(&self) -> Result<(), WireError> {
        check(
            self.thresholds.is_none_or(|t| t.validate().is_ok()),
            Invalid::Thresholds,
        )
    }
}

/// The wire description of the decoder's thresholds ([`DecodeConfig`]), field for field, as the
/// f32 the desktop holds.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct DecodeThresholds {
    /// [`DecodeConfig::dark_level`].
    pub dark_level: f32,
    /// [`DecodeConfig::saturation_level`].
    pub saturation_level: f32,
    /// [`DecodeConfig::min_modulation`].
    pub min_modulation: f32,
    /// [`DecodeConfig::unwrap_tolerance`].
    pub unwrap_tolerance: f32,
    /// [`DecodeConfig::range_tolerance`].
    pub range_tolerance: f32,
}

impl From<DecodeConfig> for DecodeThresholds {
    fn from(c: DecodeConfig) -> Self {
        DecodeThresholds {
            dark_level: c.dark_level,
            saturation_level: c.saturation_level,
            min_modulation: c.min_modulation,
            unwrap_tolerance: c.unwrap_tolerance,
            range_tolerance: c.range_tolerance,
        }
    }
}

impl From<DecodeThresholds> for DecodeConfig {
    fn from(t: DecodeThresholds) -> Self {
        DecodeConfig {
            dark_level: t.dark_level,
            saturation_level: t.saturation_level,
            min_modulation: t.min_modulation,
            unwrap_tolerance: t.unwrap_tolerance,
            range_tolerance: t.range_tolerance,
        }
    }
}

impl DecodeThresholds {
    /// The decoder's rules ([`DecodeConfig`]'s, the one check): every threshold finite and
    /// `>= 0`, the saturation level `> 0`, the unwrapping tolerance `<= π` (eqs 12-13 cannot
    /// tell fringe orders apart beyond it).
    pub fn validate(&self) -> Result<(), Invalid> {
        if DecodeConfig::from(*self).is_sane() {
            Ok(())
        } else {
            Err(Invalid::Thresholds)
        }
    }
}
