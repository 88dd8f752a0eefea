//! Hierarchical (temporal) phase unwrapping across levels (paper eqs 12-13).
//!
//! Level 0's phase is absolute by design (its range stays inside (−π, π)). Each finer level k has
//! `Φ^(k) = (c_k / c_{k−1})·Φ^(k−1)` (eq 12) and `Φ^(k) = φ^(k) + 2π·n_k` (eq 13): the fringe order
//! `n_k` is the integer that brings the wrapped phase closest to the scaled coarser one. The
//! residual between the two tells whether the step was trustworthy.
//!
//! Two forms of the same step: [`unwrap_step`] in f32 radians (the f32 backends of
//! [`crate::arith`]) and [`unwrap_step_turns`] in fixed-point turns (the [`crate::arith::Fixed`]
//! backend), where the period is exactly 1 and every operation is exact integer arithmetic.

use crate::math::{INV_TAU, fabs, round_half_even};
use crate::qnum::{I8F24, I16F16, U8F24};

/// 2π split for exact fringe-order products: `TAU_HI` has 16 significant bits, so `n·TAU_HI` is
/// exact for every `|n| < 2⁸` (finest levels up to 256 periods), and `TAU_LO = 2π − TAU_HI` (rounded) carries the rest.
#[allow(clippy::excessive_precision)]
const TAU_HI: f32 = 6.283_081_054_687_5; // bits 0x40c9_0f00: low 8 mantissa bits clear
#[allow(clippy::excessive_precision)]
const TAU_LO: f32 = 1.042_524_891_090_579_3e-4;

/// One unwrapping step (eqs 12-13): from the coarser level's absolute phase `coarse`, the level
/// ratio `ratio = c_k / c_{k−1}` and this level's wrapped phase `wrapped` ∈ [−π, π], return this
/// level's absolute phase and the residual `ratio·coarse − Φ^(k)` (radians).
///
/// The absolute phase is formed as `n·TAU_HI + (wrapped + n·TAU_LO)` so that it carries only the
/// final rounding of its f32 representation.
#[inline(always)]
pub fn unwrap_step(coarse: f32, ratio: f32, wrapped: f32) -> (f32, f32) {
    let predicted = ratio * coarse;
    let n = round_half_even((predicted - wrapped) * INV_TAU);
    let absolute = n * TAU_HI + (wrapped + n * TAU_LO);
    (absolute, predicted - absolute)
}

/// `true` if a residual from [`unwrap_step`] is within `tolerance` (radians).
///
/// A true fringe-order error of the step (prediction error `e` with `|e| > π`) leaves a residual
/// of magnitude `2π − |e|`; with a tolerance `T` every error with `|e| < 2π − T` is caught, while
/// correct pixels are rejected only when their prediction error exceeds `T`.
#[inline(always)]
pub fn consistent(residual: f32, tolerance: f32) -> bool {
    fabs(residual) <= tolerance
}

/// One unwrapping step in fixed-point *turns* (1 turn = 2π rad): eqs 12-13 with the period 1.
///
/// `coarse` is the coarser level's absolute phase and `wrapped` this level's wrapped phase
/// (in `[-½, ½]`), both in turns with 24 fraction bits; `ratio = c_k / c_{k−1}` has 16. Returns
/// this level's absolute phase and the residual `ratio·coarse − Φ^(k)`, in turns.
///
/// The prediction `ratio·coarse` is the exact 64-bit product truncated to 24 fraction bits
/// (towards −∞), the fringe order is rounded half to even, and the absolute phase `n + wrapped` is
/// exact. Every operation wraps explicitly, so debug and release builds give the same bits; the
/// decoder's phase-range analysis ([`crate::arith::Fixed`]) keeps all values far from the ±128
/// turn limit of the format.
#[inline(always)]
pub fn unwrap_step_turns(coarse: I8F24, ratio: I16F16, wrapped: I8F24) -> (I8F24, I8F24) {
    let predicted = ratio.mul_phase(coarse);
    let n = predicted.wrapping_sub(wrapped).wrapping_round_ties_even();
    let absolute = n.wrapping_add(wrapped);
    (absolute, predicted.wrapping_sub(absolute))
}

/// `true` if a residual from [`unwrap_step_turns`] is within `tolerance` (turns).
#[inline(always)]
pub fn consistent_turns(residual: I8F24, tolerance: U8F24) -> bool {
    residual.unsigned_abs() <= tolerance
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tau_split_is_exact_enough() {
        // TAU_HI has its low 8 mantissa bits clear, so n·TAU_HI is exact for |n| < 256.
        assert_eq!(TAU_HI.to_bits() & 0xff, 0);
        let sum = TAU_HI as f64 + TAU_LO as f64;
        // TAU_LO is an f32 of magnitude 1e-4: its own rounding is below 1e-11.
        assert!((sum - core::f64::consts::TAU).abs() < 1e-11);
    }
}
