//! The fixed-point backend: integer accumulators in a Q format chosen per decoder, CORDIC
//! `atan2`, unwrapping in fixed-point turns.
//!
//! # Number formats (analysis)
//! * **Samples** are integers `v ≤ V`, where `V = ⌈saturation level⌉ − 1` (at most 65535): a pixel
//!   with any larger sample is [`crate::validity::Validity::Saturated`] whatever its phase.
//! * **Coefficients** of the estimators are stored as `round(k·2^F)` in an i32, with the rounding
//!   of each level corrected so that the quantized coefficients keep the exact sums of the real
//!   ones (Σa = Σb = 0, Σw = 1 for a level of ≥ 3 shifts; `a_dc = −(a₀ + a₁)` for a 2-shift level).
//!   A constant image therefore gives S = C = 0 exactly, so a bright background never leaks into
//!   the phase; the only coefficient error left is proportional to B (at most `N·2^−(F+1)` rad).
//!   The paper's estimators (±½, ±1, ¼) are exact for every F ≥ 2.
//! * **Accumulators** are i32 sums `Σ round(k·2^F)·v`, exact integer arithmetic. With `G` the
//!   largest L1 norm of a plane's coefficients (including `|a_dc|·Σ|w|`), F is the largest value
//!   (at most [`MAX_FRAC`]) with `G·V·2^F ≤ 2^30`, so no sum of a pixel that is not saturated can
//!   overflow, with one bit to spare: F = 21 for 8-bit and 13 for 16-bit samples with the paper's
//!   set (G = 2). `S = s + a_dc·A` takes one 64-bit product, rounded to nearest.
//! * **Angles**: [`super::cordic_atan2`] returns turns with 32 fraction bits ([`I0F32`]), rounded
//!   to 24 ([`I8F24`]) for the phases.
//! * **Phases** are in turns, [`I8F24`] (±128 turns, resolution 2⁻²⁴ turn = 3.7e-7 rad). From the
//!   level ratios the decoder bounds the absolute phase of every level (`|Φ_k| ≤ r_k·|Φ_{k−1}| + ½`
//!   turns, from `|Φ_0| ≤ ½`) and refuses a set whose bound exceeds [`PHASE_TURNS_LIMIT`], so no
//!   pixel, valid or not, can wrap. Ratios are [`I16F16`].
//! * **Modulation** is the CORDIC magnitude with its gain removed, in units of `2^−F` codes (u32).
//!
//! Every operation is an explicit `wrapping_*` (or provably in range), so debug and release builds
//! give the same bits; none rounds by a mode register.

use super::cordic::cordic_atan2;
use super::{Arith, LevelCoefs, Limits, Plan, Sealed, max_unsaturated};
use crate::decode_error::DecodeError;
use crate::limits::{CORRECTION_KNOTS, MAX_SHIFTS};
use crate::qnum::{I8F24, I16F16, U8F24};
use crate::sample::Sample;
use crate::unwrap::{consistent_turns, unwrap_step_turns};

/// Fixed-point arithmetic (see the module documentation of [`crate::arith`] and the format
/// analysis in `docs/arithmetic.md`): i32 accumulators, CORDIC, turns.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct Fixed;

impl Sealed for Fixed {}

/// The largest fraction width of the accumulators.
pub const MAX_FRAC: u32 = 24;

/// The accumulators of a pixel that is not saturated stay below `2^ACC_BITS`.
const ACC_BITS: u32 = 30;

/// The largest absolute phase (turns) the analysis accepts for any level of a set: the [`I8F24`]
/// range (±128) less a margin.
pub const PHASE_TURNS_LIMIT: f64 = 120.0;

/// The run-time part of the fixed-point format, chosen per decoder.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FixedFormat {
    /// Fraction bits F of coefficients and accumulators.
    pub frac: u32,
    /// `2^−F` (exact), to convert accumulators and magnitudes to camera codes.
    pub inv_scale: f32,
    /// The largest unsaturated sample the analysis assumed.
    pub max_sample: u32,
    /// The largest L1 norm of a plane's coefficients, G.
    pub l1: f64,
    /// The bound on the finest absolute phase, turns.
    pub max_turns: f64,
}

/// Quantize `vals·2^frac` to integers whose sum is the rounded exact sum (largest remainder:
/// the entries rounded furthest the wrong way move by one, lowest index first on ties).
fn quantize(vals: &[f32], frac: u32) -> [i32; MAX_SHIFTS] {
    let scale = (1u64 << frac) as f64;
    let mut q = [0i32; MAX_SHIFTS];
    let mut exact = [0.0f64; MAX_SHIFTS];
    let mut sum = 0.0;
    let mut qsum = 0i64;
    for (i, v) in vals.iter().enumerate() {
        exact[i] = *v as f64 * scale;
        q[i] = libm::round(exact[i]) as i32;
        sum += exact[i];
        qsum += q[i] as i64;
    }
    let mut diff = libm::round(sum) as i64 - qsum;
    while diff != 0 {
        let up = diff > 0;
        let mut best = 0;
        let mut best_r = if up { f64::NEG_INFINITY } else { f64::INFINITY };
        for i in 0..vals.len() {
            let r = exact[i] - q[i] as f64;
            if (up && r > best_r) || (!up && r < best_r) {
                best = i;
                best_r = r;
            }
        }
        q[best] += if up { 1 } else { -1 };
        diff += if up { -1 } else { 1 };
    }
    q
}

/// `round(k·d / 2^frac)` (half up), exact 64-bit product.
#[inline(always)]
fn mul_q(k: i32, d: i32, frac: u32) -> i32 {
    let p = (k as i64).wrapping_mul(d as i64);
    let half = (1i64 << frac) >> 1;
    (p.wrapping_add(half) >> frac) as i32
}

/// Clamp a non-negative f64 threshold (already scaled) to an integer range, rounding up.
fn ceil_to(x: f64, max: f64) -> f64 {
    let c = libm::ceil(x);
    if !(c >= 0.0) {
        0.0
    } else if c > max {
        max
    } else {
        c
    }
}

/// 2π·2²⁸, rounded (relative error 4e-11): turns with 24 fraction bits times this are radians
/// with 52, exactly, in an i64.
const TAU_Q28: i64 = 1_686_629_713;

/// 2⁻⁵² (exact in f32).
const Q52: f32 = 1.0 / 4_503_599_627_370_496.0;

impl Arith for Fixed {
    const NAME: &'static str = "fixed";
    type Acc = i32;
    type In = i32;
    type Coef = i32;
    type Phase = I8F24;
    type Ratio = I16F16;
    type Tolerance = U8F24;
    type Mag = u32;
    type Format = FixedFormat;

    const ZERO: i32 = 0;
    const COEF_ZERO: i32 = 0;
    const MAG_MAX: u32 = u32::MAX;
    const PHASE_ZERO: I8F24 = I8F24::ZERO;
    const MAG_ZERO: u32 = 0;

    fn format(plan: &Plan<'_>) -> Result<FixedFormat, DecodeError> {
        let v = max_unsaturated(plan.config);
        let w1 = match plan.dc_level {
            Some(d) => {
                let e = &plan.levels[d];
                e.w[..e.n]
                    .iter()
                    .map(|x| libm::fabs(*x as f64))
                    .sum::<f64>()
            }
            None => 0.0,
        };
        let mut g = w1;
        let mut worst = 0usize;
        for (l, e) in plan.levels.iter().enumerate() {
            let la = e.a[..e.n]
                .iter()
                .map(|x| libm::fabs(*x as f64))
                .sum::<f64>()
                + libm::fabs(e.a_dc as f64) * w1;
            let lb = e.b[..e.n]
                .iter()
                .map(|x| libm::fabs(*x as f64))
                .sum::<f64>()
                + libm::fabs(e.b_dc as f64) * w1;
            let m = if la > lb { la } else { lb };
            if m > g {
                g = m;
                worst = l;
            }
        }
        let limit = (1u64 << ACC_BITS) as f64;
        if !(g * v <= limit) {
            return Err(DecodeError::Degenerate(worst as u8));
        }
        let mut frac = 0;
        while frac < MAX_FRAC && g * v * ((1u64 << (frac + 1)) as f64) <= limit {
            frac += 1;
        }
        // Phase range from the level ratios: |Φ_0| ≤ ½ turn for every pixel, |Φ_k| ≤ r_k·|Φ_{k−1}| + ½.
        let mut turns = plan.coarse_turns();
        if !(turns <= PHASE_TURNS_LIMIT) {
            return Err(DecodeError::Degenerate(0));
        }
        for (k, r) in plan.ratios.iter().enumerate().skip(1) {
            turns = r * turns + 0.5;
            if !(turns <= PHASE_TURNS_LIMIT) {
                return Err(DecodeError::Degenerate(k as u8));
            }
        }
        Ok(FixedFormat {
            frac,
            inv_scale: 1.0 / (1u64 << frac) as f32,
            max_sample: v as u32,
            l1: g,
            max_turns: turns,
        })
    }

    fn level_coefs(plan: &Plan<'_>, level: usize, format: &FixedFormat) -> LevelCoefs<i32> {
        let e = &plan.levels[level];
        let f = format.frac;
        let n = e.n;
        let mut c = LevelCoefs {
            a: [0; MAX_SHIFTS],
            b: [0; MAX_SHIFTS],
            w: [0; MAX_SHIFTS],
            a_dc: 0,
            b_dc: 0,
        };
        if n >= 3 {
            c.a = quantize(&e.a[..n], f);
            c.b = quantize(&e.b[..n], f);
            c.w = quantize(&e.w[..n], f);
        } else {
            // S = a₀v₀ + a₁v₁ + a_dc·A vanishes for constant images: a_dc = −(a₀ + a₁) exactly
            // (Σw = 1 exactly in the DC level's quantization).
            let scale = (1u64 << f) as f64;
            for i in 0..n {
                c.a[i] = libm::round(e.a[i] as f64 * scale) as i32;
                c.b[i] = libm::round(e.b[i] as f64 * scale) as i32;
            }
            c.a_dc = -(c.a[..n].iter().sum::<i32>());
            c.b_dc = -(c.b[..n].iter().sum::<i32>());
        }
        c
    }

    fn ratio(r: f64, _format: &FixedFormat) -> I16F16 {
        I16F16::wrapping_from_f64(r)
    }

    fn limits(plan: &Plan<'_>, format: &FixedFormat) -> Limits<Self> {
        let cfg = plan.config;
        let scale = (1u64 << format.frac) as f64;
        let turns = |x: f64| x / core::f64::consts::TAU;
        let lsb = 16_777_216.0; // 2^24 per turn
        let (lo, hi) = plan.accepted_coarse();
        let (lo, hi) = (turns(lo), turns(hi));
        Limits {
            saturation: ceil_to(cfg.saturation_level as f64, i32::MAX as f64) as i32,
            dark: ceil_to(cfg.dark_level as f64 * scale, i32::MAX as f64) as i32,
            min_modulation: ceil_to(cfg.min_modulation as f64 * scale, u32::MAX as f64) as u32,
            coarse_lo: I8F24::from_bits(libm::ceil(lo * lsb) as i32),
            coarse_hi: I8F24::from_bits(libm::floor(hi * lsb) as i32),
            unwrap_tolerance: U8F24::from_bits(
                libm::floor(turns(cfg.unwrap_tolerance as f64) * lsb) as u32,
            ),
            gray_tolerance: U8F24::from_bits(libm::floor(turns(plan.gray_tolerance()) * lsb) as u32),
            gray_dark: ceil_to(plan.gray_margin() * scale, i32::MAX as f64) as i32,
            gray_bright: -(ceil_to(plan.gray_margin() * scale, i32::MAX as f64) as i32),
        }
    }

    #[inline(always)]
    fn is_zero(k: i32) -> bool {
        k == 0
    }

    #[inline(always)]
    fn input<P: Sample>(v: P) -> i32 {
        v.to_i32()
    }

    #[inline(always)]
    fn mac(acc: i32, k: i32, v: i32) -> i32 {
        acc.wrapping_add(k.wrapping_mul(v))
    }

    // `exact_coef` keeps its default (never): the regrouped kinds are for the f32 backends.
    #[inline(always)]
    fn in_add(a: i32, b: i32) -> i32 {
        a.wrapping_add(b)
    }

    #[inline(always)]
    fn in_sub(a: i32, b: i32) -> i32 {
        a.wrapping_sub(b)
    }

    #[inline(always)]
    fn in_minus_acc(v: i32, dc: i32) -> i32 {
        v.wrapping_sub(dc)
    }

    #[inline(always)]
    fn saturated(v: i32, threshold: i32) -> bool {
        v >= threshold
    }

    #[inline(always)]
    fn dc_minus_input(a: i32, v: i32, format: &FixedFormat) -> i32 {
        // v·2^F fits: the DC term of unsaturated samples does (Σw = 1, `format`).
        a.wrapping_sub(v.wrapping_shl(format.frac))
    }

    #[inline(always)]
    fn input_acc(v: i32, format: &FixedFormat) -> i32 {
        // As `dc_minus_input` scales the sample (an unsaturated sample·2^F fits, `format`).
        v.wrapping_shl(format.frac)
    }

    #[inline(always)]
    fn acc_word(a: i32) -> u16 {
        a as u16
    }

    #[inline(always)]
    fn word_acc(w: u16) -> i32 {
        w as i32
    }

    #[inline(always)]
    fn quarter_turns(n: i32) -> I8F24 {
        // A quarter turn is 2^22 in 2^-24 turns (|n| < 512 within the format's ±128 turns).
        I8F24::from_bits(n.wrapping_shl(22))
    }

    #[inline(always)]
    fn add_turns(p: I8F24, k: i32) -> I8F24 {
        // A turn is 2^24 (|k| ≤ 33 stays within the format's ±128 turns).
        I8F24::from_bits(p.to_bits().wrapping_add(k.wrapping_shl(24)))
    }

    #[inline(always)]
    fn level_sc(s: i32, c: i32, a_dc: i32, b_dc: i32, dc: i32, format: &FixedFormat) -> (i32, i32) {
        (
            s.wrapping_add(mul_q(a_dc, dc, format.frac)),
            c.wrapping_add(mul_q(b_dc, dc, format.frac)),
        )
    }

    #[inline(always)]
    fn polar(s: i32, c: i32) -> (I8F24, u32) {
        let (angle, mag) = cordic_atan2(s, c);
        // 32 → 24 fraction bits, rounded half up; +½ turn wraps to −½, the same angle.
        (
            I8F24::from_bits(angle.to_bits().wrapping_add(1 << 7) >> 8),
            mag,
        )
    }

    #[inline(always)]
    fn min_mag(m: u32, current: u32) -> u32 {
        if m < current { m } else { current }
    }

    #[inline(always)]
    fn in_range(w: I8F24, lo: I8F24, hi: I8F24) -> bool {
        w >= lo && w <= hi
    }

    #[inline(always)]
    fn unwrap(coarse: I8F24, ratio: I16F16, wrapped: I8F24) -> (I8F24, I8F24) {
        unwrap_step_turns(coarse, ratio, wrapped)
    }

    #[inline(always)]
    fn consistent(residual: I8F24, tolerance: U8F24) -> bool {
        consistent_turns(residual, tolerance)
    }

    #[inline(always)]
    fn mag_at_least(m: u32, threshold: u32) -> bool {
        m >= threshold
    }

    #[inline(always)]
    fn dc_at_least(a: i32, threshold: i32) -> bool {
        a >= threshold
    }

    #[inline(always)]
    fn correct(p: I8F24, table: &[i16; CORRECTION_KNOTS]) -> I8F24 {
        // u = p + ½ turn in 2^-24 turn, clamped to one period; knot j = u·K >> 24 and the
        // fraction in Q(24 − log2 K).
        const SHIFT: u32 = 24 - CORRECTION_KNOTS.trailing_zeros();
        const _: () = assert!(CORRECTION_KNOTS.is_power_of_two());
        let u = (p.to_bits() as i64 + (1 << 23)).clamp(0, 1 << 24);
        let j = ((u >> SHIFT) as usize).min(CORRECTION_KNOTS - 1);
        let f = u - ((j as i64) << SHIFT);
        // Masks: `j` unchanged, `next` wraps, and no bounds check.
        let (j, next) = (j & (CORRECTION_KNOTS - 1), (j + 1) & (CORRECTION_KNOTS - 1));
        // Knots from 2^-13 rad to 2^-24 turn: × 2^10/π, as × round(2^26/π) >> 16 (exact integer
        // arithmetic, within one 2^-24 turn).
        const RAD13_TO_Q24: i64 = 21_361_415;
        let q24 = |k: i16| (k as i64 * RAD13_TO_Q24) >> 16;
        let (a, b) = (q24(table[j]), q24(table[next]));
        let delta = a + (((b - a) * f) >> SHIFT);
        I8F24::from_bits((p.to_bits() as i64 - delta) as i32)
    }

    #[inline(always)]
    fn phase_out(p: I8F24) -> f32 {
        // The exact product, one correctly rounded conversion, an exact power-of-two scale: the
        // f32 nearest the fixed-point phase (to 4e-11 relative).
        (p.to_bits() as i64).wrapping_mul(TAU_Q28) as f32 * Q52
    }

    #[inline(always)]
    fn polar_fine(s: i32, c: i32, format: &FixedFormat) -> (I8F24, u32, f32) {
        let (p, m) = Self::polar(s, c);
        // B in camera codes: one correctly rounded conversion, an exact power-of-two scale.
        (p, m, m as f32 * format.inv_scale)
    }

    #[inline(always)]
    fn dc_out(a: i32, format: &FixedFormat) -> f32 {
        a as f32 * format.inv_scale
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quantization_keeps_exact_sums() {
        let third = [2.0f32 / 3.0, -1.0 / 3.0, -1.0 / 3.0];
        for f in [3, 13, 21] {
            let q = quantize(&third, f);
            assert_eq!(q[..3].iter().sum::<i32>(), 0, "F = {f}");
            let w = quantize(&[1.0 / 3.0; 3], f);
            assert_eq!(w[..3].iter().sum::<i32>(), 1 << f, "F = {f}");
        }
        assert_eq!(
            &quantize(&[0.5, 0.0, -0.5, 0.0], 13)[..4],
            &[4096, 0, -4096, 0]
        );
    }

    #[test]
    fn mul_q_rounds_and_is_exact_for_powers_of_two() {
        assert_eq!(mul_q(-(1 << 13), 123_456, 13), -123_456);
        assert_eq!(mul_q(3, 3, 2), 2); // 9/4 = 2.25
        assert_eq!(mul_q(3, 2, 2), 2); // 1.5 → 2 (half up)
        assert_eq!(mul_q(-3, 2, 2), -1); // −1.5 → −1 (half up)
        assert_eq!(mul_q(5, 7, 0), 35);
    }
}
