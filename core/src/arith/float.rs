//! The f32 backends: one implementation of [`Arith`] over f32, differing only in `atan2` and the
//! square root of the modulation output.

use super::{Arith, LevelCoefs, Limits, Plan, Sealed};
use crate::decode_error::DecodeError;
use crate::limits::{CORRECTION_KNOTS, CORRECTION_LSB};
use crate::math;
use crate::sample::Sample;
use crate::unwrap::{consistent, unwrap_step};

/// The default backend: f32 accumulators, [`math::atan2`] (degree-13 polynomial, 6.5e-7 rad) for
/// the finest level, [`math::atan2_coarse_finite`] (degree 5, 6.2e-4 rad) for the coarser ones,
/// whose phase only picks fringe orders, and the modulation from the finest arctangent's
/// reduction without a square root ([`math::atan2_hypot_finite`], 4e-7 relative).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct F32Accurate;

/// Fast f32: [`math::atan2_fast`] (degree-9 polynomial, 1.3e-5 rad) and [`math::sqrt_fast`]
/// (Newton reciprocal square root, no division, 5e-6 relative). Everything else as
/// [`F32Accurate`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct F32Fast;

/// f32 with `micromath`'s approximations: `micromath::F32::atan2` (error up to 2.8e-3 rad) and
/// `micromath::F32::sqrt` (about 5 %). Kept for comparison (`docs/arithmetic.md`); [`F32Fast`] is
/// both faster and far more accurate.
///
/// The functions are called on micromath's own `F32` type, never through its `F32Ext` trait:
/// under `std` the inherent `f32` methods shadow that trait's and would silently change results.
///
/// Behind the core's `micromath` feature (on by default).
#[cfg(feature = "micromath")]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct F32Micromath;

/// What distinguishes the f32 backends.
pub trait FloatKernels:
    Sealed + Copy + core::fmt::Debug + PartialEq + Default + Send + Sync + 'static
{
    /// [`Arith::NAME`].
    const NAME: &'static str;
    /// Four-quadrant arctangent, radians.
    fn atan2(y: f32, x: f32) -> f32;
    /// The arctangent of the coarser levels ([`Arith::polar_coarse`]); [`Self::atan2`] unless a
    /// backend has a cheaper one.
    #[inline(always)]
    fn atan2_coarse(y: f32, x: f32) -> f32 {
        Self::atan2(y, x)
    }
    /// [`Self::atan2`] and `√(y² + x²)` of finite inputs: the finest level's phase and
    /// modulation B ([`Arith::polar_fine`]).
    fn atan2_hypot(y: f32, x: f32) -> (f32, f32);
    /// [`Self::atan2_hypot`] of `fine` and [`Self::atan2_coarse`] of `c1` and `c2`, for `N`
    /// pixels ([`Arith::polar_levels3_lanes`]), side by side where a backend has written them so.
    #[inline(always)]
    fn atan2_levels3_lanes<const N: usize>(
        fine: [(f32, f32); N],
        c1: [(f32, f32); N],
        c2: [(f32, f32); N],
    ) -> [((f32, f32), f32, f32); N] {
        core::array::from_fn(|k| {
            (
                Self::atan2_hypot(fine[k].0, fine[k].1),
                Self::atan2_coarse(c1[k].0, c1[k].1),
                Self::atan2_coarse(c2[k].0, c2[k].1),
            )
        })
    }
}

impl Sealed for F32Accurate {}
impl Sealed for F32Fast {}
#[cfg(feature = "micromath")]
impl Sealed for F32Micromath {}

impl FloatKernels for F32Accurate {
    const NAME: &'static str = "f32";
    #[inline(always)]
    fn atan2(y: f32, x: f32) -> f32 {
        // S and C are finite (sums of products of finite samples and coefficients): the guard of
        // `math::atan2` against NaN inputs would never fire.
        math::atan2_finite(y, x)
    }
    #[inline(always)]
    fn atan2_coarse(y: f32, x: f32) -> f32 {
        math::atan2_coarse_finite(y, x)
    }
    #[inline(always)]
    fn atan2_hypot(y: f32, x: f32) -> (f32, f32) {
        math::atan2_hypot_finite(y, x)
    }
    #[inline(always)]
    fn atan2_levels3_lanes<const N: usize>(
        fine: [(f32, f32); N],
        c1: [(f32, f32); N],
        c2: [(f32, f32); N],
    ) -> [((f32, f32), f32, f32); N] {
        math::atan2_levels3_lanes(fine, c1, c2)
    }
}

impl FloatKernels for F32Fast {
    const NAME: &'static str = "f32-fast";
    #[inline(always)]
    fn atan2(y: f32, x: f32) -> f32 {
        math::atan2_fast_finite(y, x)
    }
    #[inline(always)]
    fn atan2_coarse(y: f32, x: f32) -> f32 {
        math::atan2_coarse_finite(y, x)
    }
    #[inline(always)]
    fn atan2_hypot(y: f32, x: f32) -> (f32, f32) {
        (
            math::atan2_fast_finite(y, x),
            math::sqrt_fast(y * y + x * x),
        )
    }
}

#[cfg(feature = "micromath")]
impl FloatKernels for F32Micromath {
    const NAME: &'static str = "f32-micromath";
    #[inline(always)]
    fn atan2(y: f32, x: f32) -> f32 {
        // Fully qualified: micromath's own kernel on its `F32` newtype, never std's `f32::atan2`.
        micromath::F32::atan2(micromath::F32(y), micromath::F32(x)).0
    }
    #[inline(always)]
    fn atan2_hypot(y: f32, x: f32) -> (f32, f32) {
        (
            Self::atan2(y, x),
            micromath::F32::sqrt(micromath::F32(y * y + x * x)).0,
        )
    }
}

impl<K: FloatKernels> Arith for K {
    const NAME: &'static str = K::NAME;
    type Acc = f32;
    type In = f32;
    type Coef = f32;
    type Phase = f32;
    type Ratio = f32;
    type Tolerance = f32;
    type Mag = f32;
    type Format = ();

    const ZERO: f32 = 0.0;
    const COEF_ZERO: f32 = 0.0;
    const MAG_MAX: f32 = f32::INFINITY;
    const PHASE_ZERO: f32 = 0.0;
    const MAG_ZERO: f32 = 0.0;

    fn format(_plan: &Plan<'_>) -> Result<(), DecodeError> {
        Ok(())
    }

    fn level_coefs(plan: &Plan<'_>, level: usize, _format: &()) -> LevelCoefs<f32> {
        let e = &plan.levels[level];
        LevelCoefs {
            a: e.a,
            b: e.b,
            w: e.w,
            a_dc: e.a_dc,
            b_dc: e.b_dc,
        }
    }

    fn ratio(r: f64, _format: &()) -> f32 {
        r as f32
    }

    fn limits(plan: &Plan<'_>, _format: &()) -> Limits<Self> {
        let cfg = plan.config;
        // `Plan::accepted_coarse`, with the tolerance bounds formed in f32 as they always were
        // (a wide gap leaves these bits as before the seam guard).
        let lo = plan.coarse_range.0 as f32 - cfg.range_tolerance;
        let hi = plan.coarse_range.1 as f32 + cfg.range_tolerance;
        let (seam_lo, seam_hi) = plan.accepted_coarse();
        let (seam_lo, seam_hi) = (seam_lo as f32, seam_hi as f32);
        Limits {
            saturation: cfg.saturation_level,
            dark: cfg.dark_level,
            min_modulation: cfg.min_modulation * cfg.min_modulation,
            coarse_lo: if seam_lo > lo { seam_lo } else { lo },
            coarse_hi: if seam_hi < hi { seam_hi } else { hi },
            unwrap_tolerance: cfg.unwrap_tolerance,
            gray_tolerance: plan.gray_tolerance() as f32,
            gray_dark: plan.gray_margin() as f32,
            gray_bright: -(plan.gray_margin() as f32),
        }
    }

    #[inline(always)]
    fn is_zero(k: f32) -> bool {
        k == 0.0
    }

    #[inline(always)]
    fn input<P: Sample>(v: P) -> f32 {
        v.to_f32()
    }

    #[inline(always)]
    fn dc_minus_input(a: f32, v: f32, _format: &()) -> f32 {
        a - v
    }

    #[inline(always)]
    fn input_acc(v: f32, _format: &()) -> f32 {
        v
    }

    #[inline(always)]
    fn acc_word(a: f32) -> u16 {
        a as u16
    }

    #[inline(always)]
    fn word_acc(w: u16) -> f32 {
        w as f32
    }

    #[inline(always)]
    fn quarter_turns(n: i32) -> f32 {
        n as f32 * core::f32::consts::FRAC_PI_2
    }

    #[inline(always)]
    fn add_turns(p: f32, k: i32) -> f32 {
        p + k as f32 * core::f32::consts::TAU
    }

    #[inline(always)]
    fn mac(acc: f32, k: f32, v: f32) -> f32 {
        acc + k * v
    }

    #[inline(always)]
    fn exact_coef(k: f32, value: f32) -> bool {
        k == value
    }

    #[inline(always)]
    fn in_add(a: f32, b: f32) -> f32 {
        a + b
    }

    #[inline(always)]
    fn in_sub(a: f32, b: f32) -> f32 {
        a - b
    }

    #[inline(always)]
    fn in_minus_acc(v: f32, dc: f32) -> f32 {
        v - dc
    }

    #[inline(always)]
    fn regrouped_product(k: f32, v: f32) -> f32 {
        // A sum or difference of integer-valued samples is +0, never −0 (x − x = +0 in
        // round-to-nearest), so with k > 0 the product is not −0 and `0 + k·v` is `k·v`.
        k * v
    }

    #[inline(always)]
    fn saturated(v: f32, threshold: f32) -> bool {
        v >= threshold
    }

    #[inline(always)]
    fn level_sc(s: f32, c: f32, a_dc: f32, b_dc: f32, dc: f32, _format: &()) -> (f32, f32) {
        (s + a_dc * dc, c + b_dc * dc)
    }

    #[inline(always)]
    fn polar(s: f32, c: f32) -> (f32, f32) {
        (K::atan2(s, c), s * s + c * c)
    }

    #[inline(always)]
    fn polar_coarse(s: f32, c: f32) -> (f32, f32) {
        (K::atan2_coarse(s, c), s * s + c * c)
    }

    #[inline(always)]
    fn polar_fine(s: f32, c: f32, _format: &()) -> (f32, f32, f32) {
        let (p, b) = K::atan2_hypot(s, c);
        (p, s * s + c * c, b)
    }

    #[inline(always)]
    fn polar_levels3_lanes<const N: usize>(
        fine: [(f32, f32); N],
        c1: [(f32, f32); N],
        c2: [(f32, f32); N],
        _format: &(),
    ) -> [((f32, f32, f32), (f32, f32), (f32, f32)); N] {
        let r = K::atan2_levels3_lanes(fine, c1, c2);
        let m = |(s, c): (f32, f32)| s * s + c * c;
        core::array::from_fn(|k| {
            let ((pf, b), p1, p2) = r[k];
            ((pf, m(fine[k]), b), (p1, m(c1[k])), (p2, m(c2[k])))
        })
    }

    #[inline(always)]
    fn min_mag(m: f32, current: f32) -> f32 {
        if m < current { m } else { current }
    }

    #[inline(always)]
    fn in_range(w: f32, lo: f32, hi: f32) -> bool {
        w >= lo && w <= hi
    }

    #[inline(always)]
    fn unwrap(coarse: f32, ratio: f32, wrapped: f32) -> (f32, f32) {
        unwrap_step(coarse, ratio, wrapped)
    }

    #[inline(always)]
    fn consistent(residual: f32, tolerance: f32) -> bool {
        consistent(residual, tolerance)
    }

    #[inline(always)]
    fn mag_at_least(m: f32, threshold: f32) -> bool {
        m >= threshold
    }

    #[inline(always)]
    fn dc_at_least(a: f32, threshold: f32) -> bool {
        a >= threshold
    }

    #[inline(always)]
    fn correct(p: f32, table: &[i16; CORRECTION_KNOTS]) -> f32 {
        const SCALE: f32 = CORRECTION_KNOTS as f32 / core::f32::consts::TAU;
        const LSB: f32 = CORRECTION_LSB as f32;
        let t = (p + core::f32::consts::PI) * SCALE;
        // NaN and the rounding just below −π both land on knot 0.
        let t = if t >= 0.0 { t } else { 0.0 };
        let j = (t as usize).min(CORRECTION_KNOTS - 1);
        let f = t - j as f32;
        // Masks (K is a power of two): `j` unchanged, `next` wraps, and no bounds check.
        const MASK: usize = CORRECTION_KNOTS - 1;
        const _: () = assert!(CORRECTION_KNOTS.is_power_of_two());
        let (j, next) = (j & MASK, (j + 1) & MASK);
        // i16 → f32 and the power-of-two scale are exact.
        let (a, b) = (table[j] as f32 * LSB, table[next] as f32 * LSB);
        p - (a + f * (b - a))
    }

    #[inline(always)]
    fn phase_out(p: f32) -> f32 {
        p
    }

    #[inline(always)]
    fn dc_out(a: f32, _format: &()) -> f32 {
        a
    }
}
