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
/// π/4 as f32.
pub const FRAC_PI_4: f32 = core::f32::consts::FRAC_PI_4;
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
pub const ATAN_FAST_COEFFS: [f32; 5] = [
    9.998_663_295e-1,
    -3.303_047_855e-1,
    1.801_592_946e-1,
    -8.515_635_084e-2,
    2.084_511_418e-2,
];

/// Branch-free four-quadrant arctangent, `atan2(y, x)` in `[-π, π]`.
///
/// Reduces from the diagonal to `p = (|y| − |x|)/(|y| + |x|) ∈ [−1, 1]`, evaluates the odd
/// [`ATAN_COEFFS`] there, and folds back with one sign flip: `atan2(|y|, x) = π/2 ± (atan p − π/4)`
/// (`unfold`); no data-dependent branches, so a loop over a row vectorizes. Maximum absolute
/// error against the exact atan2: 6.5e-7 rad (the unit tests measure it). The error is absolute,
/// not relative: near 0 the result comes from `π/2 − (π/2 − θ)`. Odd in `y`, zeros included;
/// `atan2(±0, +0) = ±0`, `atan2(±0, x < 0) = ±π`, `atan2(±0, −0) = ±π` as in IEEE; a NaN input
/// gives NaN.
#[inline(always)]
pub fn atan2(y: f32, x: f32) -> f32 {
    let p = diagonal(y, x).0;
    unfold::<true>(y, x, atan_11(p))
}

/// [`atan2`] for finite inputs (the decoder's S and C): the same bits, without the NaN guard.
/// For a NaN input the result is unspecified (not necessarily NaN).
#[inline(always)]
pub fn atan2_finite(y: f32, x: f32) -> f32 {
    let p = diagonal(y, x).0;
    unfold::<false>(y, x, atan_11(p))
}

/// [`atan2_finite`] and the magnitude `√(y² + x²)` of finite inputs, sharing the reduction: the
/// decoder's finest level (phase and modulation B) without a square root.
///
/// With `p` and `s = |x| + |y|` from the diagonal reduction, `x² + y² = s²·(1 + p²)/2`, so the
/// magnitude is `s·g(p²)` with `g(u) = √((1 + u)/2)`, a degree-7 polynomial ([`HYPOT_COEFFS`]).
/// Relative error below 4e-7 (the unit tests measure it); `(0, 0)` gives `(0, 0)`.
#[inline(always)]
pub fn atan2_hypot_finite(y: f32, x: f32) -> (f32, f32) {
    let (p, s) = diagonal(y, x);
    (unfold::<false>(y, x, atan_11(p)), s * hypot_factor(p * p))
}

/// The decoder's three levels of `N` pixels at once (the paper's 8-pattern and the 12-pattern
/// sets): the finest level's [`atan2_hypot_finite`] and two coarser levels'
/// [`atan2_coarse_finite`], with every step written for the `3·N` inputs side by side.
///
/// The same operations on each input as the separate functions, so the same bits. Why: each
/// arctangent is a long dependency chain (division, polynomial, folding); one after the other in
/// program order, the chain of the first fills the out-of-order core's scheduler while the next
/// has not yet been fetched. Side by side, the core always finds independent work.
#[inline(always)]
pub fn atan2_levels3_lanes<const N: usize>(
    fine: [(f32, f32); N],
    c1: [(f32, f32); N],
    c2: [(f32, f32); N],
) -> [((f32, f32), f32, f32); N] {
    use core::array::from_fn as lanes;
    let df: [(f32, f32); N] = lanes(|k| diagonal(fine[k].0, fine[k].1));
    let p1: [f32; N] = lanes(|k| diagonal(c1[k].0, c1[k].1).0);
    let p2: [f32; N] = lanes(|k| diagonal(c2[k].0, c2[k].1).0);
    let af: [f32; N] = lanes(|k| atan_11(df[k].0));
    let a1: [f32; N] = lanes(|k| atan_coarse_11(p1[k]));
    let a2: [f32; N] = lanes(|k| atan_coarse_11(p2[k]));
    let rf: [f32; N] = lanes(|k| unfold::<false>(fine[k].0, fine[k].1, af[k]));
    let r1: [f32; N] = lanes(|k| unfold::<false>(c1[k].0, c1[k].1, a1[k]));
    let r2: [f32; N] = lanes(|k| unfold::<false>(c2[k].0, c2[k].1, a2[k]));
    lanes(|k| {
        (
            (rf[k], df[k].1 * hypot_factor(df[k].0 * df[k].0)),
            r1[k],
            r2[k],
        )
    })
}

/// [`ATAN_COARSE_COEFFS`] by Horner's rule, `p ∈ [−1, 1]`.
#[inline(always)]
fn atan_coarse_11(p: f32) -> f32 {
    let s = p * p;
    let c = &ATAN_COARSE_COEFFS;
    ((c[2] * s + c[1]) * s + c[0]) * p
}

/// Coefficients (lowest first) of the minimax polynomial `g(u) ≈ √((1 + u)/2)` on `u ∈ [0, 1]`,
/// degree 7, relative error ([`atan2_hypot_finite`]).
///
/// Fitted by a Remez exchange (`tools/fit_hypot.py`). Maximum relative error of the polynomial
/// 2.0e-8; evaluated in f32 by Estrin's scheme 2.0e-7.
#[allow(clippy::excessive_precision)] // the fit's digits, rounded to f32 by the compiler
pub const HYPOT_COEFFS: [f32; 8] = [
    7.071_067_956e-1,
    3.535_512_998e-1,
    -8.833_876_169e-2,
    4.374_242_113e-2,
    -2.554_466_971e-2,
    1.383_619_586e-2,
    -5.371_839_823e-3,
    1.018_579_172e-3,
];

/// [`HYPOT_COEFFS`] by Estrin's scheme: `√((1 + u)/2)` for `u ∈ [0, 1]`.
#[inline(always)]
fn hypot_factor(u: f32) -> f32 {
    let c = &HYPOT_COEFFS;
    let u2 = u * u;
    let u4 = u2 * u2;
    let p01 = c[1] * u + c[0];
    let p23 = c[3] * u + c[2];
    let p45 = c[5] * u + c[4];
    let p67 = c[7] * u + c[6];
    (p23 * u2 + p01) + (p67 * u2 + p45) * u4
}

/// [`ATAN_COEFFS`] by Estrin's scheme: `atan(p)` for `p ∈ [−1, 1]` (the polynomial is odd).
#[inline(always)]
fn atan_11(t: f32) -> f32 {
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
    let p = diagonal(y, x).0;
    unfold::<true>(y, x, atan_fast_11(p))
}

/// [`atan2_fast`] for finite inputs: the same bits, without the NaN guard (see [`atan2_finite`]).
#[inline(always)]
pub fn atan2_fast_finite(y: f32, x: f32) -> f32 {
    let p = diagonal(y, x).0;
    unfold::<false>(y, x, atan_fast_11(p))
}

/// [`ATAN_FAST_COEFFS`] by Horner's rule, `p ∈ [−1, 1]`.
#[inline(always)]
fn atan_fast_11(t: f32) -> f32 {
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
    let p = diagonal(y, x).0;
    unfold::<false>(y, x, atan_coarse_11(p))
}

/// The sign bit of an f32.
const SIGN: u32 = 0x8000_0000;

/// The reduction shared by the arctangents and [`atan2_hypot_finite`]: `p = (|y| − |x|)/(|y| +
/// |x|) ∈ [−1, 1]` and `|y| + |x|`. One division; `|p| ≤ 1` holds after rounding too (rounding
/// is monotonic and `||y| − |x|| ≤ |y| + |x|`). `p` is NaN only for 0/0 (both inputs zero, or a
/// NaN input): the comparison takes `p = −1` then (one `max` instruction on x86), so that
/// `atan2(±0, +0) = ±0` and `atan2(±0, −0) = ±π`.
#[inline(always)]
fn diagonal(y: f32, x: f32) -> (f32, f32) {
    let (ax, ay) = (fabs(x), fabs(y));
    let sum = ay + ax;
    let p = (ay - ax) / sum;
    (if p > -1.0 { p } else { -1.0 }, sum)
}

/// The folding shared by the arctangents: `atan2(y, x)` from `a ≈ atan p` of the [`diagonal`].
///
/// `atan2(|y|, |x|) = π/4 + atan p`, and for `x < 0` (sign bit set) π minus that, so
/// `atan2(|y|, x) = π/2 + (atan p − π/4)` with the sign of the bracket flipped by the sign of
/// `x`: one exclusive or, no selects. The result is clamped to `[0, π]` (two `max`/`min`
/// instructions): a polynomial's error at `p = ±1` could otherwise leave it an ulp outside, or
/// give `−ε` instead of `+0` on the positive x axis. The sign of `y` is or-ed in last (that is
/// `copysign`, the result being ≥ +0), which makes the function odd in `y`. `NAN_GUARD` makes NaN
/// inputs give NaN.
#[inline(always)]
fn unfold<const NAN_GUARD: bool>(y: f32, x: f32, a: f32) -> f32 {
    let u = a - FRAC_PI_4;
    let r = FRAC_PI_2 + f32::from_bits(u.to_bits() ^ (x.to_bits() & SIGN));
    let r = if r > 0.0 { r } else { 0.0 };
    let r = if r < PI { r } else { PI };
    let r = if NAN_GUARD && (x.is_nan() || y.is_nan()) {
        f32::NAN
    } else {
        r
    };
    f32::from_bits(r.to_bits() | (y.to_bits() & SIGN))
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
            assert_eq!(
                check_range(b.saturating_sub(300), b + 300, 1),
                0,
                "binade {e}"
            );
        }
        assert_eq!(sqrt(0.0).to_bits(), 0);
        assert_eq!(sqrt(-0.0).to_bits(), (-0.0f32).to_bits());
        assert_eq!(sqrt(f32::INFINITY), f32::INFINITY);
        assert!(sqrt(f32::NAN).is_nan());
        assert_eq!(sqrt(4.0), 2.0);
        assert_eq!(sqrt(2.0), core::f32::consts::SQRT_2);
    }

    /// Inputs over every quadrant and many magnitudes: a grid of angles (the axes and diagonals
    /// included) times radii from 1e-3 to 1e5, plus pseudo-random pairs.
    fn atan2_inputs() -> impl Iterator<Item = (f32, f32)> {
        let grid = (0..20_000).flat_map(|k| {
            let th = -core::f64::consts::PI + core::f64::consts::TAU * k as f64 / 20_000.0;
            [1e-3f64, 0.7, 1.0, 255.0, 1e5]
                .into_iter()
                .map(move |r| ((r * libm::sin(th)) as f32, (r * libm::cos(th)) as f32))
        });
        let mut z = 0x2545_f491_4f6c_dd1du64;
        let random = (0..200_000).map(move |_| {
            z ^= z << 13;
            z ^= z >> 7;
            z ^= z << 17;
            let y = ((z & 0xffff) as f32 - 32768.0) / 64.0;
            let x = (((z >> 16) & 0xffff) as f32 - 32768.0) / 64.0;
            (y, x)
        });
        grid.chain(random)
    }

    /// The largest absolute error of `f` against the f64 `atan2` over [`atan2_inputs`].
    fn atan2_error(f: impl Fn(f32, f32) -> f32) -> f64 {
        atan2_inputs()
            .map(|(y, x)| libm::fabs(f(y, x) as f64 - libm::atan2(y as f64, x as f64)))
            .fold(0.0, f64::max)
    }

    #[test]
    fn arctangents_meet_their_error_bounds() {
        for (name, f, bound) in [
            ("atan2", atan2 as fn(f32, f32) -> f32, 6.5e-7),
            ("atan2_finite", atan2_finite, 6.5e-7),
            ("atan2_fast", atan2_fast, 1.3e-5),
            ("atan2_coarse_finite", atan2_coarse_finite, 6.2e-4),
        ] {
            let e = atan2_error(f);
            assert!(e < bound, "{name}: {e:e} rad");
        }
    }

    #[test]
    fn arctangents_special_values_and_symmetry() {
        let fs: [fn(f32, f32) -> f32; 4] = [atan2, atan2_finite, atan2_fast, atan2_coarse_finite];
        for f in fs {
            // The axes exactly, and the signed zeros as IEEE atan2.
            assert_eq!(f(0.0, 1.0).to_bits(), 0.0f32.to_bits());
            assert_eq!(f(-0.0, 1.0).to_bits(), (-0.0f32).to_bits());
            assert_eq!(f(0.0, 0.0).to_bits(), 0.0f32.to_bits());
            assert_eq!(f(-0.0, 0.0).to_bits(), (-0.0f32).to_bits());
            assert_eq!(f(0.0, -1.0), PI);
            assert_eq!(f(-0.0, -1.0), -PI);
            assert_eq!(f(0.0, -0.0), PI);
            assert_eq!(f(-0.0, -0.0), -PI);
            assert!(libm::fabsf(f(1.0, 0.0) - FRAC_PI_2) < 1e-3);
            assert!(libm::fabsf(f(-1.0, -0.0) + FRAC_PI_2) < 1e-3);
            // Odd in y, bit for bit, and never outside [−π, π].
            for (y, x) in atan2_inputs().step_by(7) {
                let (a, b) = (f(y, x), f(-y, x));
                assert_eq!(a.to_bits(), (-b).to_bits(), "({y}, {x})");
                assert!(fabs(a) <= PI, "({y}, {x}): {a}");
            }
        }
        for (y, x) in [(f32::NAN, 1.0), (1.0, f32::NAN), (f32::NAN, f32::NAN)] {
            assert!(atan2(y, x).is_nan());
            assert!(atan2_fast(y, x).is_nan());
        }
    }

    #[test]
    fn hypot_of_the_reduction_meets_its_bound() {
        let mut worst = 0.0f64;
        for (y, x) in atan2_inputs() {
            let (p, b) = atan2_hypot_finite(y, x);
            assert_eq!(p.to_bits(), atan2_finite(y, x).to_bits());
            let want = libm::hypot(y as f64, x as f64);
            worst = worst.max(libm::fabs(b as f64 - want) / want);
        }
        assert!(worst < 4e-7, "relative error {worst:e}");
        assert_eq!(atan2_hypot_finite(0.0, 0.0), (0.0, 0.0));
        assert_eq!(atan2_hypot_finite(-0.0, -3.0).1, 3.0);
    }

    #[test]
    fn three_levels_side_by_side_are_the_separate_functions() {
        let mut w = [(1.0f32, 0.0f32); 3];
        for next in atan2_inputs().step_by(3) {
            w = [w[1], w[2], next];
            // Lane k of four takes the inputs rotated by k, so that every lane sees every input.
            let rot = |k: usize| [w[k % 3], w[(k + 1) % 3], w[(k + 2) % 3]];
            let r = atan2_levels3_lanes(
                core::array::from_fn::<_, 4, _>(|k| rot(k)[0]),
                core::array::from_fn(|k| rot(k)[1]),
                core::array::from_fn(|k| rot(k)[2]),
            );
            for (k, ((p, b), c1, c2)) in r.into_iter().enumerate() {
                let x = rot(k);
                let (pw, bw) = atan2_hypot_finite(x[0].0, x[0].1);
                assert_eq!((p.to_bits(), b.to_bits()), (pw.to_bits(), bw.to_bits()));
                assert_eq!(c1.to_bits(), atan2_coarse_finite(x[1].0, x[1].1).to_bits());
                assert_eq!(c2.to_bits(), atan2_coarse_finite(x[2].0, x[2].1).to_bits());
            }
        }
    }

    /// Every non-negative f32, +∞ and the positive NaNs (about 10 s optimised).
    #[test]
    #[ignore]
    fn sqrt_exhaustive() {
        assert_eq!(check_range(0, 0x8000_0000, 1), 0);
    }
}
