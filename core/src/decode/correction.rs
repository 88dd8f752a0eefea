//! Phase-error compensation per level ([`PhaseCorrection`], [`Decoder::with_correction`]): a
//! small periodic table of the phase error a projector's nonlinear response (gamma) leaves in
//! each level's wrapped phase, subtracted before the unwrapping.
//!
//! # Why a table of the wrapped phase
//! A projector with response r (camera intensity `I = A₀ + K·r(p)` for a pattern value p) turns
//! the sinusoid `p = ½ + ½·sin(Φ + δ_n)` into a periodic function of `Φ + δ_n` with harmonics.
//! The level's linear estimator (eqs 9, 11, 14) then returns `φ = Φ + e(Φ)`, and `e` depends on the
//! response and the level's shifts only — not on the pixel's ambient light `A₀` or gain `K`,
//! which scale every harmonic alike. So one periodic function per level, tabulated against the
//! *measured* wrapped phase, removes it: `Φ ≈ φ − Δ(φ)` with `Δ(φ(Φ)) = e(Φ)`. The 4-step level
//! of the paper's set only sees the 3rd and 5th harmonics (a small error); its 2-image levels,
//! where the harmonics do not cancel, see all of them (0.2 rad RMS for a gamma of 2.2).
//!
//! The host computes the table from a measured response (`fringe3d calibrate gamma`); the core
//! only applies it. For patterns already pre-distorted through the inverse response the table is
//! not needed (docs/gamma.md says when each fits).
//!
//! # The table and its arithmetic
//! [`CORRECTION_KNOTS`] knots per level at `φ_j = −π + 2π·j/K`, `j = 0..K` (radians), read by
//! periodic linear interpolation:
//!
//! ```text
//! t = (φ + π)·K/(2π),  j = min(⌊t⌋, K − 1),  f = t − j,  Δ = Δ_j + f·(Δ_{(j+1) mod K} − Δ_j)
//! φ' = φ − Δ
//! ```
//!
//! in the backend's own phase unit: f32 radians (the knots `Δ_j·2⁻¹³` exact in f32, the
//! operations in that order, no fused multiply-add) or, for [`crate::arith::Fixed`], integers in
//! 2⁻²⁴ turn (knots scaled by an integer product and shift, `t` in Q19 of a knot, an exact i64
//! product and an arithmetic shift). Both are deterministic on every target, so the
//! head and the desktop apply it to the same bits. Linear interpolation with 32 knots reproduces a
//! gamma-2.2 error curve to about 5e-4 rad on the finest level (4e-3 rad on the 2-image levels,
//! which only choose fringe orders). Memory: `MAX_LEVELS × K × 2` B = 384 B in the decoder (i16 knots of 2⁻¹³ rad).

use super::BLOCK;
use super::buffers::Block;
use super::decoder::Decoder;
use crate::arith::Arith;
use crate::decode_error::DecodeError;
use crate::limits::MAX_LEVELS;
pub use crate::limits::{CORRECTION_KNOTS, CORRECTION_LSB};

/// The phase error of each level, sampled at the measured wrapped phase
/// `φ_j = −π + 2π·j/CORRECTION_KNOTS` (subtracted from the wrapped phase), in units of
/// [`CORRECTION_LSB`] = 2⁻¹³ rad: i16 knots keep the table small on a head (384 B) and convert
/// exactly to f32.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PhaseCorrection {
    /// Levels the table covers (the pattern set's level count).
    pub levels: u8,
    /// `delta[l][j]`: the error of level `l` (coarsest first) at knot `j`, in 2⁻¹³ rad.
    pub delta: [[i16; CORRECTION_KNOTS]; MAX_LEVELS],
}

impl PhaseCorrection {
    /// No correction (all knots zero) for `levels` levels.
    pub const fn zero(levels: u8) -> Self {
        PhaseCorrection {
            levels,
            delta: [[0; CORRECTION_KNOTS]; MAX_LEVELS],
        }
    }

    /// The largest |Δ| a table may hold, in [`CORRECTION_LSB`]: a quarter period (π/2 rad). A
    /// larger "error" is not a response but a wrong pattern description.
    pub const MAX_DELTA: i16 = 12_868;

    /// Whether every knot is within [`Self::MAX_DELTA`] and the level count fits.
    pub fn is_sane(&self) -> bool {
        (1..=MAX_LEVELS).contains(&(self.levels as usize))
            && self.delta[..self.levels as usize]
                .iter()
                .flatten()
                .all(|d| (-Self::MAX_DELTA..=Self::MAX_DELTA).contains(d))
    }

    /// The f64 reference of the correction of level `level` at wrapped phase `phi` (radians): the
    /// formula of the module documentation in f64, for tests and readers.
    pub fn reference(&self, level: usize, phi: f64) -> f64 {
        let k = CORRECTION_KNOTS as f64;
        let t = (phi + core::f64::consts::PI) * k / core::f64::consts::TAU;
        let t = if t >= 0.0 { t } else { 0.0 };
        let j = (t as usize).min(CORRECTION_KNOTS - 1);
        let f = t - j as f64;
        let row = &self.delta[level.min(MAX_LEVELS - 1)];
        let knot = |k: usize| row[k % CORRECTION_KNOTS] as f64 * CORRECTION_LSB;
        let (a, b) = (knot(j), knot(j + 1));
        phi - (a + f * (b - a))
    }
}

impl<A: Arith> Decoder<A> {
    /// This decoder with the phase-error table `c` applied to every level's wrapped phase before
    /// the unwrapping (eqs 12-13), in every driver (row, frame-sequential, one level).
    ///
    /// Refuses ([`DecodeError::Config`]) a table for another level count, or with a knot beyond
    /// [`PhaseCorrection::MAX_DELTA`].
    pub fn with_correction(self, c: &PhaseCorrection) -> Result<Self, DecodeError> {
        self.with_correction_knots(c.levels, |l, j| c.delta[l][j])
    }

    /// [`Self::with_correction`] from knots given by `knot(level, j)` (radians) for `levels`
    /// levels, written straight into the decoder (no table on the stack). Same checks, same
    /// result.
    pub fn with_correction_knots(
        mut self,
        levels: u8,
        knot: impl Fn(usize, usize) -> i16,
    ) -> Result<Self, DecodeError> {
        self.set_correction_knots(levels, knot)?;
        Ok(self)
    }

    /// [`Self::with_correction_knots`] in place (no copy of the decoder: a head's set-up builds
    /// it this way). On error the decoder is left without a table.
    pub fn set_correction_knots(
        &mut self,
        levels: u8,
        knot: impl Fn(usize, usize) -> i16,
    ) -> Result<(), DecodeError> {
        if levels as usize != self.n_levels {
            return Err(DecodeError::Config);
        }
        let t = self.correction.insert([[0; CORRECTION_KNOTS]; MAX_LEVELS]);
        for (l, dst) in t.iter_mut().enumerate().take(levels as usize) {
            for (j, d) in dst.iter_mut().enumerate() {
                let v = knot(l, j);
                let m = PhaseCorrection::MAX_DELTA;
                if !(-m..=m).contains(&v) {
                    self.correction = None;
                    return Err(DecodeError::Config);
                }
                *d = v;
            }
        }
        Ok(())
    }

    /// Whether a phase-error table is applied ([`Self::with_correction`]).
    pub fn has_correction(&self) -> bool {
        self.correction.is_some()
    }

    /// Subtract the table from every level's wrapped phase of a block (nothing without a table).
    #[inline(always)]
    pub(super) fn correct_block(&self, blk: &mut Block<A>) {
        if let Some(t) = &self.correction {
            // A Gray-code level's entry is its estimate, not a wrapped phase: left alone.
            let skip = self.gray.is_some() as usize;
            let levels = blk.wrapped.iter_mut().zip(t).take(self.n_levels);
            for (w, tab) in levels.skip(skip) {
                for p in w.iter_mut().take(BLOCK) {
                    *p = A::correct(*p, tab);
                }
            }
        }
    }

    /// The correction of one wrapped phase of level `level` (the one-level diagnostics).
    #[inline(always)]
    pub(super) fn correct_one(&self, level: usize, p: A::Phase) -> A::Phase {
        match (&self.correction, level < MAX_LEVELS) {
            (Some(t), true) => A::correct(p, &t[level]),
            _ => p,
        }
    }
}
