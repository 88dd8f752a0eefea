//! The decoder's thresholds ([`DecodeConfig`]): the validity tests of every pixel (dark,
//! saturated, low modulation, unwrapping residual, phase range), with defaults per sensor bit
//! depth. Below the decoding arithmetic ([`crate::arith`], which converts them to its units) and
//! the decoder ([`crate::decode`], which re-exports it as `fringe3d_core::decode::DecodeConfig`).

#[cfg(doc)]
use crate::validity::Validity;

/// Thresholds of the validity tests. All intensities are in camera codes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DecodeConfig {
    /// A pixel whose DC term A is below this is [`Validity::Dark`].
    pub dark_level: f32,
    /// A pixel with any sample `≥` this is [`Validity::Saturated`].
    pub saturation_level: f32,
    /// A pixel whose modulation B is below this in any level is [`Validity::LowModulation`].
    pub min_modulation: f32,
    /// Largest accepted unwrapping residual, radians ([`crate::unwrap::consistent`]).
    pub unwrap_tolerance: f32,
    /// How far (radians) the coarsest phase may lie outside the range the set produces before the
    /// pixel is [`Validity::PhaseOutOfRange`]; also the half-width of the band around the coarse
    /// level's wrap seam where pixels are refused when the range reaches it (a coarse level of one
    /// whole period: [`crate::arith::Plan::accepted_coarse`]).
    pub range_tolerance: f32,
}

impl DecodeConfig {
    /// Defaults for a sensor of `bits` bits per sample (8 to 16): dark below 2 % of full scale,
    /// saturated at full scale, modulation at least 2 % of full scale but not below 12 codes (as
    /// long as that is within 5 % of full scale), unwrapping residual ≤ 2π/3, coarse phase within
    /// 0.15 rad of the projected range (the level-0 noise at B/σ = 14 is 0.08 rad; the default
    /// 0.9·2π span keeps 0.31 rad from ±π, and a coarse level of one whole period loses the
    /// 0.15 rad band at its wrap seam, [`crate::arith::Plan::accepted_coarse`]).
    ///
    /// Why 12 codes: the hierarchical unwrapping (eqs 12-13) picks a wrong fringe order *without
    /// noticing* only when the residual's noise exceeds 2π minus the tolerance, 4π/3. With the
    /// paper's set (2-step levels sharing A, level ratio 8) that noise is ≈ 9·σ_I/B rad, so at
    /// B = 12 and σ_I = 1 code (a typical 8-bit sensor) a silent order error needs a 5.6σ event
    /// (≈ 2e-8 per pixel); at 2 % of an 8-bit scale (5 codes) it was a 2.3σ event, and rendered
    /// 8-bit scans showed dozens of valid-looking pixels a whole number of fringes off. From 10
    /// bits up, 2 % of full scale is already ≥ 20 codes and the rule changes nothing.
    pub fn for_bit_depth(bits: u32) -> Self {
        let bits = bits.clamp(1, 16);
        let full = ((1u32 << bits) - 1) as f32;
        let floor = if 12.0 < 0.05 * full {
            12.0
        } else {
            0.05 * full
        };
        let two_percent = 0.02 * full;
        DecodeConfig {
            dark_level: 0.02 * full,
            saturation_level: full,
            min_modulation: if two_percent > floor {
                two_percent
            } else {
                floor
            },
            unwrap_tolerance: 2.0 * core::f32::consts::PI / 3.0,
            range_tolerance: 0.15,
        }
    }

    /// Defaults for a sensor of `bits` bits whose read noise is `sigma` codes per sample: those
    /// of [`Self::for_bit_depth`] with the modulation floor in the physical terms of its
    /// derivation, `B ≥ 12σ` (σ taken at least 1/√12 code, the rounding's own noise). The
    /// 12-code floor of 8-bit images is this rule at σ = 1 code; for deeper images, whose codes
    /// say nothing of the noise (a 12-bit sensor in a 16-bit container has σ ≥ 16 codes, a
    /// rendered one what its scene says), 2 % of full scale admits pixels at B/σ ≈ 5 when σ is
    /// 1/256 of full scale: a silent fringe-order error is then a 2σ event, not a 5.6σ one.
    /// `for_sensor(8, 1.0) == for_bit_depth(8)`.
    pub fn for_sensor(bits: u32, sigma: f32) -> Self {
        let q = 0.288_675_13; // 1/√12
        let s = if sigma > q { sigma } else { q };
        DecodeConfig {
            min_modulation: 12.0 * s,
            ..Self::for_bit_depth(bits)
        }
    }

    pub(crate) fn is_sane(&self) -> bool {
        let all = [
            self.dark_level,
            self.saturation_level,
            self.min_modulation,
            self.unwrap_tolerance,
            self.range_tolerance,
        ];
        all.iter().all(|v| v.is_finite() && *v >= 0.0)
            && self.unwrap_tolerance <= core::f32::consts::PI
            && self.saturation_level > 0.0
    }
}
