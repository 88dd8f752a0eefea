//! Deterministic arithmetic kernels.
//!
//! Everything here is written in plain IEEE-754 `+ - * /` and comparisons, with fixed operation
//! order and no fused multiply-add, so that it gives the same bits on every target (x86-64 with or
//! without AVX, Cortex-M4F) and vectorizes when the caller loops over a row. Where a function from
//! `libm` is used instead, it is named so.

/// π as f32.
pub const PI: f32 = core::f32::consts::PI;
/// π/2 as f32.
pub const FRAC_PI_2: f32 = core::f32::consts::FRAC_PI_2;
/// 2π as f32.
pub const TAU: f32 = core::f32::consts::TAU;
/// 1/(2π) as f32.
pub const INV_TAU: f32 = 1.0 / core::f32::consts::TAU;

/// Coefficients of the odd minimax polynomial `atan(t) ≈ t·P(t²)` on `t ∈ [0, 1]`, degree 13.
///
/// Fitted by a Remez exchange (`tools/fit_atan.py`). Maximum error of the polynomial itself
/// 2.5e-7 rad; evaluated in f32 by Estrin's scheme ([`atan2`]) 3.7e-7 rad.
#[allow(clippy::excessive_precision)] // the fit's digits, rounded to f32 by the compiler
pub const ATAN_COEFFS: [f32; 7] = [
    9.999_961_115e-1,
    -3.331_736_805e-1,
    1.980_781_555e-1,
    -1.323_334_204e-1,
    7.962_367_139e-2,
    -3.360_421_972e-2,
    6.811_793_011e-3,
];

/// Coefficients of the fast odd minimax polynomial `atan(t) ≈ t·P(t²)` on `t ∈ [0, 1]`, degree 9
/// (the [`crate::arith::F32Fast`] backend).
///
/// Fitted by the same Remez exchange as [`ATAN_COEFFS`] (`tools/fit_atan.py` with 5 terms).
/// Maximum error of the polynomial 1.14e-5 rad; evaluated in f32 by Horner's rule 1.15e-5 rad.
#[allow(clippy::excessive_precision)] // the fit's digits, rounded to f32 by the compiler
pub const ATAN_FAST_COEFFS: [f32; 5] = [9.998_663_295e-1, -3.303_047_855e-1, 1.801_592_946e-1, -8.515_635_084e-2, 2.084_511_418e-2];

/// Branch-free four-quadrant arctangent, `atan2(y, x)` in `[-π, π]`.
///
/// Reduces to `t = min(|x|,|y|) / max(|x|,|y|) ∈ [0, 1]`, evaluates [`ATAN_COEFFS`], and folds
/// back by octant with selects (no data-dependent branches, so a loop over a row vectorizes).
/// Maximum error against the exact atan2: about 5e-7 rad. `atan2(0, 0)` returns 0; a NaN input
/// gives NaN.
#[inline(always)]
pub fn atan2(y: f32, x: f32) -> f32 {
    atan2_fold::<true>(y, x, atan_01)
}

/// [`atan2`] for finite inputs (the decoder's S and C): the same bits, without the NaN guard.
/// For a NaN input the result is unspecified (not necessarily NaN).
#[inline(always)]
pub fn atan2_finite(y: f32, x: f32) -> f32 {
    atan2_fold::<false>(y, x, atan_01)
}

/// [`ATAN_COEFFS`] by Estrin's scheme: `atan(t)` for `t ∈ [0, 1]`.
#[inline(always)]
fn atan_01(t: f32) -> f32 {
    let s = t * t;
    let c = &ATAN_COEFFS;
    // Estrin's scheme: the same polynomial with a dependency chain of 4 multiply-adds instead of
    // Horner's 6 (the fine level's arctangent sits on the decoder's critical path).
    let s2 = s * s;
    let s4 = s2 * s2;
    let p01 = c[1] * s + c[0];
    let p23 = c[3] * s + c[2];
    let p45 = c[5] * s + c[4];
    let p = (p23 * s2 + p01) + (c[6] * s2 + p45) * s4;
    p * t
}

/// The fast arctangent of the [`crate::arith::F32Fast`] backend: [`atan2`]'s reduction and
/// folding around the degree-9 [`ATAN_FAST_COEFFS`]. Maximum error about 1.2e-5 rad; two
/// multiply-adds fewer than [`atan2`]. Same special values as [`atan2`].
#[inline(always)]
pub fn atan2_fast(y: f32, x: f32) -> f32 {
    atan2_fold::<true>(y, x, atan_fast_01)
}

/// [`atan2_fast`] for finite inputs: the same bits, without the NaN guard (see [`atan2_finite`]).
#[inline(always)]
pub fn atan2_fast_finite(y: f32, x: f32) -> f32 {
    atan2_fold::<false>(y, x, atan_fast_01)
}

/// [`ATAN_FAST_COEFFS`] by Horner's rule.
#[inline(always)]
fn atan_fast_01(t: f32) -> f32 {
    let s = t * t;
    let c = &ATAN_FAST_COEFFS;
    let p = ((((c[4] * s + c[3]) * s + c[2]) * s + c[1]) * s) + c[0];
    p * t
}

/// Coefficients of the coarse odd minimax polynomial `atan(t) ≈ t·P(t²)` on `t ∈ [0, 1]`,
/// degree 5 (the decoder's coarser levels, which only choose fringe orders).
///
/// Fitted by the same Remez exchange as [`ATAN_COEFFS`] (`tools/fit_atan.py` with 3 terms).
/// Maximum error 6.1e-4 rad, in f32 as well.
#[allow(clippy::excessive_precision)] // the fit's digits, rounded to f32 by the compiler
pub const ATAN_COARSE_COEFFS: [f32; 3] = [9.953_579_548e-1, -2.886_902_381e-1, 7.933_904_149e-2];

/// The coarse arctangent of the decoder's coarser levels: [`atan2`]'s reduction and folding
/// around the degree-5 [`ATAN_COARSE_COEFFS`], for finite inputs (as [`atan2_finite`]). Maximum
/// error 6.1e-4 rad: a coarser level's phase only picks the next level's fringe order, where it
/// enters multiplied by the level ratio (8 in the paper's set: 5e-3 rad, against a tolerance of
/// 2π/3 and noise of 0.6 rad at B/σ = 14).
#[inline(always)]
pub fn atan2_coarse_finite(y: f32, x: f32) -> f32 {
    atan2_fold::<false>(y, x, |t| {
        let s = t * t;
        let c = &ATAN_COARSE_COEFFS;
        ((c[2] * s + c[1]) * s + c[0]) * t
    })
}

/// The octant reduction and folding shared by the arctangents: `atan_01(t)` approximates
/// `atan(t)` for `t ∈ [0, 1]`; `NAN_GUARD` makes NaN inputs give NaN.
#[inline(always)]
fn atan2_fold<const NAN_GUARD: bool>(y: f32, x: f32, atan_01: impl Fn(f32) -> f32) -> f32 {
    let ax = fabs(x);
    let ay = fabs(y);
    let hi = if ax > ay { ax } else { ay };
    let lo = if ax > ay { ay } else { ax };
    // lo/hi is NaN only for 0/0 (both inputs zero; the NaN inputs are handled below): the
    // comparison takes t = 0 then, and the result is 0. One `max` instruction on x86.
    let q = lo / hi;
    let t = if q > 0.0 { q } else { 0.0 };
    let r = atan_01(t);
    // (Written as masked sign flips plus masked constants, these two folds take fewer SSE2
    // instructions but 5 % more time with AVX-512, whose selects are single instructions.)
    let r = if ay > ax { FRAC_PI_2 - r } else { r };
    let r = if x < 0.0 { PI - r } else { r };
    // NaN inputs fail every comparison above; make sure they come out as NaN.
    let r = if NAN_GUARD && (x.is_nan() || y.is_nan()) { f32::NAN } else { r };
    // r ≥ +0 here (or NaN): or-ing in the sign of y is `copysign`.
    f32::from_bits(r.to_bits() | (y.to_bits() & 0x8000_0000))
}

/// Fast square root of a finite `x ≥ 0` (the [`crate::arith::F32Fast`] backend's modulation):
/// the classic reciprocal-square-root estimate from the bit pattern, two Newton steps, times `x`.
/// Plain `* -` only (no division). Relative error below 5e-6; `sqrt_fast(0) = 0`; NaN gives NaN.
#[inline(always)]
pub fn sqrt_fast(x: f32) -> f32 {
    let y = f32::from_bits(0x5f37_5a86u32.wrapping_sub(x.to_bits() >> 1));
    let h = 0.5 * x;
    let y = y * (1.5 - h * y * y);
    let y = y * (1.5 - h * y * y);
    x * y
}

/// Square root of a finite `x ≥ 0` to within 3 ulp (relative error below 4e-7), in plain f32
/// `* -`: [`sqrt_fast`]'s estimate refined by three Newton steps instead of two. The default
/// decoder's modulation output: it vectorizes in f32 lanes (a correctly rounded root either is a
/// scalar instruction behind inline assembly, `libm::sqrtf` on x86, or needs f64 lanes,
/// [`sqrt`], at three times the cost), and it is the same arithmetic on every target.
/// `sqrt_newton(0) = 0`; +∞ and NaN give NaN.
#[inline(always)]
pub fn sqrt_newton(x: f32) -> f32 {
    let y = f32::from_bits(0x5f37_5a86u32.wrapping_sub(x.to_bits() >> 1));
    let h = 0.5 * x;
    let y = y * (1.5 - h * y * y);
    let y = y * (1.5 - h * y * y);
    let y = y * (1.5 - h * y * y);
    x * y
}

/// Correctly rounded square root (IEEE `sqrt`: the same bits as `libm::sqrtf` and every
/// hardware square root) in plain `* -` and conversions, so that a loop over a row vectorizes
/// (`libm::sqrtf` is a scalar `sqrtss` in inline assembly on x86, which no loop around it can
/// vectorize).
///
/// The f32 is widened to f64 (exactly), its reciprocal square root estimated from the bit pattern
/// (3.4 % error) and refined by four Newton steps (error ≈ 1e-21 before rounding), and `x·y` is
/// rounded to f32. Why that is the correctly rounded result: an f32 square root can lie no closer
/// than 2⁻⁵¹ (relative) to a rounding midpoint between two f32 (`x − m²` is a non-zero multiple of
/// ¼ of the scale of `x` for a 25-bit midpoint `m`), and the f64 result is closer than that to
/// the true root. Checked against `libm::sqrtf` for every non-negative f32, +∞ and NaN
/// (the tests below; an exhaustive run over all 2³¹ is `cargo test -p fringe3d-core --lib --release
/// -- --ignored sqrt_exhaustive`). `sqrt(−0) = −0` as in IEEE; other negative inputs are outside
/// its contract (they do not give NaN); the decoder only takes roots of sums of squares.
#[inline(always)]
pub fn sqrt(x: f32) -> f32 {
    let d = x as f64;
    let hd = 0.5 * d;
    let mut y = f64::from_bits(0x5fe6_eb50_c7b5_37a9u64.wrapping_sub(d.to_bits() >> 1));
    y = y * (1.5 - hd * y * y);
    y = y * (1.5 - hd * y * y);
    y = y * (1.5 - hd * y * y);
    y = y * (1.5 - hd * y * y);
    let r = (d * y) as f32;
    if x == f32::INFINITY { x } else { r }
}

/// `|x|`, by clearing the sign bit.
#[inline(always)]
pub fn fabs(x: f32) -> f32 {
    f32::from_bits(x.to_bits() & 0x7fff_ffff)
}

/// The magnitude of `x` with the sign bit of `s`.
#[inline(always)]
pub fn copysign(x: f32, s: f32) -> f32 {
    f32::from_bits((x.to_bits() & 0x7fff_ffff) | (s.to_bits() & 0x8000_0000))
}

/// 1.5·2²³: adding and subtracting it rounds an f32 of magnitude below 2²² to an integer.
const ROUND_MAGIC: f32 = 12_582_912.0;

/// Round to the nearest integer, ties to even, for `|x| < 2²²` (returned as f32).
///
/// Uses the add-and-subtract trick, which is exact IEEE arithmetic in round-to-nearest-even mode
/// and vectorizes. For larger magnitudes the result is still a nearby integer-valued float but
/// callers must not rely on it; phase fringe orders are far below 2²².
#[inline(always)]
pub fn round_half_even(x: f32) -> f32 {
    (x + ROUND_MAGIC) - ROUND_MAGIC
}

/// Wrap an angle into `[-π, π]` by subtracting the nearest multiple of 2π.
#[inline(always)]
pub fn wrap_pi(x: f32) -> f32 {
    x - TAU * round_half_even(x * INV_TAU)
}

/// The canonical quiet NaN every output uses, so that bit comparisons of results are meaningful.
pub const CANONICAL_NAN: f32 = f32::from_bits(0x7fc0_0000);

/// Replace any NaN by [`CANONICAL_NAN`]; other values pass unchanged.
#[inline(always)]
pub fn canonical(x: f32) -> f32 {
    if x.is_nan() { CANONICAL_NAN } else { x }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check_range(from: u32, to: u32, step: u32) -> u64 {
        let mut bad = 0;
        let mut b = from;
        while b < to {
            let x = f32::from_bits(b);
            let (got, want) = (sqrt(x), libm::sqrtf(x));
            if got.to_bits() != want.to_bits() && !(got.is_nan() && want.is_nan()) {
                bad += 1;
            }
            b = match b.checked_add(step) {
                Some(n) => n,
                None => break,
            };
        }
        bad
    }

    #[test]
    fn sqrt_is_correctly_rounded() {
        // A spread of every binade (every 97th pattern: odd and even mantissas, subnormals), both
        // ends of every binade, and the specials.
        assert_eq!(check_range(0, 0x7f80_0001, 97), 0);
        for e in 0..255u32 {
            let b = e << 23;
            assert_eq!(check_range(b.saturating_sub(300), b + 300, 1), 0, "binade {e}");
        }
        assert_eq!(sqrt(0.0).to_bits(), 0);
        assert_eq!(sqrt(-0.0).to_bits(), (-0.0f32).to_bits());
        assert_eq!(sqrt(f32::INFINITY), f32::INFINITY);
        assert!(sqrt(f32::NAN).is_nan());
        assert_eq!(sqrt(4.0), 2.0);
        assert_eq!(sqrt(2.0), core::f32::consts::SQRT_2);
    }

    /// Every non-negative f32, +∞ and the positive NaNs (about 10 s optimised).
    #[test]
    #[ignore]
    fn sqrt_exhaustive() {
        assert_eq!(check_range(0, 0x8000_0000, 1), 0);
    }
}
