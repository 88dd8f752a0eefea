//! Selectable arithmetic for phase decoding: f32 (accurate or fast) and fixed point.
//!
//! Scan heads differ: a Cortex-M4F or a desktop has a single-precision FPU, a Cortex-M0/M3 has
//! none, and an FPGA computes in fixed point. The decoding kernel ([`crate::decode`]) is written
//! once, generic over an [`Arith`] backend that supplies the number types and the few primitive
//! operations (multiply-accumulate, `atan2` with the modulation measure, the unwrapping step,
//! threshold tests, conversions to the f32 outputs). Every backend is deterministic and gives the
//! same bits on every target (x86-64 with or without AVX2, thumbv7m, thumbv7em): plain IEEE `+ - *
//! /` without fusion for the f32 backends, explicit wrapping integer operations for fixed point.
//!
//! | backend | accumulators | `atan2` | modulation | unwrapping | for |
//! |---|---|---|---|---|---|
//! | [`F32Accurate`] (default) | f32 | degree-13 polynomial ([`crate::math::atan2`], 6.5e-7 rad); coarser levels degree 5 ([`crate::math::atan2_coarse_finite`]) | from the arctangent's reduction, no square root ([`crate::math::atan2_hypot_finite`], 4e-7 relative) | radians, f32 | desktop, FPU heads |
//! | [`F32Fast`] | f32 | degree-9 polynomial ([`crate::math::atan2_fast`], 1.3e-5 rad) | Newton `rsqrt` ([`crate::math::sqrt_fast`]) | radians, f32 | FPU heads short of time |
//! | [`F32Micromath`] | f32 | `micromath` (2.8e-3 rad) | `micromath` (≈ 5 %) | radians, f32 | comparison only |
//! | [`Fixed`] | i32, Q format per decoder | 24-step CORDIC ([`cordic_atan2`], 2.5e-7 rad) | CORDIC magnitude | turns, `I8F24` | FPU-less heads (Cortex-M0/M3), FPGA reference |
//!
//! Measured errors, unwrapping failure rates, depth errors and costs (ns per pixel on the desktop,
//! instructions per pixel on Cortex-M3 and M4F under QEMU) are in `docs/arithmetic.md`; from them,
//! [`TargetDefault`] names the recommended backend of the target being compiled.
//!
//! # Choosing
//! [`crate::decode::Decoder::new`] builds the default backend, exactly the decoder of before
//! (same public API, same bits) on every target. Any backend: `Decoder::<Fixed>::with_arith(&set,
//! config)` (or `Decoder::<TargetDefault>::with_arith`), whose row API,
//! [`crate::decode::Decoder::accumulate`]/[`crate::decode::Decoder::finish`] and frame-sequential
//! decoder ([`crate::sequential::FrameDecoder`]) are the same generic code. For a choice made at
//! run time (tools, golden vectors) use [`crate::decode::AnyDecoder`] with a [`Backend`].
//!
//! # Outputs
//! Whatever the backend, the outputs are the decoder's f32 rows (phase and wrapped phase in
//! radians, modulation and DC term in camera codes) and validity codes. The fixed-point backend
//! converts at the very end: an exact integer product (phase: turns × 2π), one correctly rounded
//! integer-to-f32 conversion and an exact power-of-two scale, which is deterministic on every
//! target, soft float included.

mod backend;
mod cordic;
mod fixed;
mod float;

pub use crate::qnum::{I0F32, I8F24, I16F16, U8F24};
pub use backend::Backend;
pub use cordic::{CORDIC_ANGLES, CORDIC_INV_GAIN_Q32, CORDIC_ITERATIONS, cordic_atan2};
pub use fixed::{Fixed, FixedFormat, PHASE_TURNS_LIMIT};
#[cfg(feature = "micromath")]
pub use float::F32Micromath;
pub use float::{F32Accurate, F32Fast};

/// The recommended backend for the target being compiled (`docs/arithmetic.md`): [`Fixed`] on
/// ARM without the hard-float ABI (thumbv6m/thumbv7m/thumbv7em-none-eabi: no FPU in use, f32 would
/// run in software at about 5× the instructions), [`F32Accurate`] everywhere else (desktop,
/// Cortex-M4F/M7 with `eabihf`). [`crate::decode::Decoder::new`] stays [`F32Accurate`] on every
/// target; use `Decoder::<TargetDefault>::with_arith` to follow the recommendation.
#[cfg(all(target_arch = "arm", not(target_abi = "eabihf")))]
pub type TargetDefault = Fixed;
/// The recommended backend for the target being compiled (`docs/arithmetic.md`): [`Fixed`] on
/// ARM without the hard-float ABI (thumbv6m/thumbv7m/thumbv7em-none-eabi: no FPU in use, f32 would
/// run in software at about 5× the instructions), [`F32Accurate`] everywhere else (desktop,
/// Cortex-M4F/M7 with `eabihf`). [`crate::decode::Decoder::new`] stays [`F32Accurate`] on every
/// target; use `Decoder::<TargetDefault>::with_arith` to follow the recommendation.
#[cfg(not(all(target_arch = "arm", not(target_abi = "eabihf"))))]
pub type TargetDefault = F32Accurate;

use crate::decode_config::DecodeConfig;
use crate::decode_error::DecodeError;
use crate::estimator::LevelEstimator;
use crate::gray::GrayCode;
use crate::limits::{CORRECTION_KNOTS, MAX_SHIFTS};
use crate::sample::Sample;
use core::fmt::Debug;

mod sealed {
    pub trait Sealed {}
}
pub(crate) use sealed::Sealed;

/// Everything a backend needs to choose its number formats, computed by the decoder from the
/// pattern set and thresholds (backend-independent, in f64 where it matters).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Plan<'a> {
    /// The estimator of every level.
    pub levels: &'a [LevelEstimator],
    /// The level whose DC term A the decoder accumulates (the one with most shifts), if any.
    pub dc_level: Option<usize>,
    /// `c_k / c_{k−1}` per level (entry 0 unused, 1.0).
    pub ratios: &'a [f64],
    /// The coarsest level's phase range (radians), as the set reports it.
    pub coarse_range: (f64, f64),
    /// The thresholds.
    pub config: &'a DecodeConfig,
    /// The set's Gray-code level (level 0), if any: then `coarse_range` is the range of the
    /// Gray-coded phase `c₀·Φ` (many periods) and the range test applies to that phase once
    /// unwrapped.
    pub gray: Option<GrayCode>,
    /// A coprime set's `a` ([`crate::pattern::Relation::Coprime`], `c₀ = a·u`): then
    /// `coarse_range` is the range of `c₀·Φ` (`a` times the set's, which is `u·Φ`'s), whose
    /// candidates `φ₀ + 2πk` are tested against it, and the step to level 1 decides the order
    /// with the tolerance `π/a`.
    pub coprime: Option<u32>,
}

impl Plan<'_> {
    /// The threshold margin of a Gray-code bit, camera codes: half the smallest accepted
    /// modulation. A bright stripe lies about B above the DC term and a dark one B below it, so
    /// on a pixel with `B ≥ min_modulation` a bit within `min_modulation/2` of A is an edge
    /// (blur mixes the two) or noise, and is counted ambiguous ([`crate::gray`]).
    ///
    /// An inverse code ([`GrayCode::inverted`]) thresholds each image against its inverse: the
    /// difference is about ±2B, and the margin `min_modulation` is the same fraction of it.
    pub fn gray_margin(&self) -> f64 {
        match self.gray {
            Some(g) if g.inverse() => self.config.min_modulation as f64,
            _ => 0.5 * self.config.min_modulation as f64,
        }
    }

    /// The largest accepted residual (radians) of the unwrapping step from the Gray code
    /// ([`GrayCode::tolerance`]), or of a coprime set's step from level 0 to level 1 (`π/a`,
    /// which at most one candidate order meets); the configured unwrapping tolerance else.
    pub fn gray_tolerance(&self) -> f64 {
        match (self.gray, self.coprime) {
            (Some(g), _) => g.tolerance(self.config.range_tolerance as f64),
            (None, Some(a)) => core::f64::consts::PI / a as f64,
            (None, None) => self.config.unwrap_tolerance as f64,
        }
    }

    /// The largest absolute coarsest phase, turns: ½ (a wrapped phase), or a Gray-coded
    /// phase's largest magnitude over the projector plus ½.
    pub fn coarse_turns(&self) -> f64 {
        if self.gray.is_none() && self.coprime.is_none() {
            return 0.5;
        }
        let (lo, hi) = self.coarse_range;
        let m = if -lo > hi { -lo } else { hi };
        m / core::f64::consts::TAU + 0.5
    }

    /// The range of the coarsest *wrapped* phase the decoder accepts (radians); a pixel outside
    /// it is [`crate::validity::Validity::PhaseOutOfRange`].
    ///
    /// The set produces `[lo, hi]` ⊂ (−π, π) ([`crate::pattern::PatternSet::coarse_range`]); the
    /// gap `(hi, lo + 2π)` of the circle holds the wrap seam, and a phase measured in it belongs to
    /// no projector pixel. With `t` the range tolerance (the coarse phase's noise allowance),
    /// accepted is `[lo − t, hi + t]` less a band of `t` either side of the gap's middle
    /// `m = (hi + lo + 2π)/2`:
    ///
    /// ```text
    /// accepted = [max(lo − t, m + t − 2π), min(hi + t, m − t)]
    /// ```
    ///
    /// With a wide gap (`2π − (hi − lo) ≥ 4t`, as the default 0.9·2π span with t = 0.15) the
    /// band changes nothing. With a coarse level of one whole period (the "phase cue") the ends
    /// of the range reach the seam and the band decides: a pixel whose coarse phase lies within
    /// `t` of the seam is refused, and one wrapped in from the far end of the projector is
    /// accepted only if its noise carried it more than `t` past the seam, the same allowance as
    /// at the ends of any range. Decoding such a set loses the projector columns within `t` of
    /// each end (t/2π of the width each: 2.4 % at 0.15 rad).
    ///
    /// A Gray-coded set has no seam (its coarse phase is absolute): accepted is `[lo − t,
    /// hi + t]`. A coprime set's range is that of `c₀·Φ = a·u·Φ`, whose seam repeats every
    /// `2π·a`: the same rule with that period, so that no two candidates `φ₀ + 2πk` and
    /// `φ₀ + 2π(k + a)` (which predict level 1 alike) are both accepted.
    pub fn accepted_coarse(&self) -> (f64, f64) {
        let (lo, hi) = self.coarse_range;
        let t = self.config.range_tolerance as f64;
        if self.gray.is_some() {
            return (lo - t, hi + t);
        }
        let period = core::f64::consts::TAU * self.coprime.unwrap_or(1) as f64;
        let m = 0.5 * (hi + lo + period);
        let (seam_lo, seam_hi) = (m + t - period, m - t);
        (
            if seam_lo > lo - t { seam_lo } else { lo - t },
            if seam_hi < hi + t { seam_hi } else { hi + t },
        )
    }
}

/// Quantized coefficients of one level in a backend's [`Arith::Coef`] type.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LevelCoefs<K> {
    /// Coefficients of S per shift.
    pub a: [K; MAX_SHIFTS],
    /// Coefficients of C per shift.
    pub b: [K; MAX_SHIFTS],
    /// Coefficients of A per shift (used only for the DC level).
    pub w: [K; MAX_SHIFTS],
    /// Coefficient of A in S.
    pub a_dc: K,
    /// Coefficient of A in C.
    pub b_dc: K,
}

/// Thresholds and range limits in a backend's units.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Limits<A: Arith> {
    /// A sample at or above this is saturated.
    pub saturation: A::In,
    /// A DC accumulator below this is dark.
    pub dark: A::Acc,
    /// A modulation measure below this is low.
    pub min_modulation: A::Mag,
    /// Accepted range of the coarsest wrapped phase (tolerance included).
    pub coarse_lo: A::Phase,
    /// See `coarse_lo`.
    pub coarse_hi: A::Phase,
    /// Largest accepted unwrapping residual.
    pub unwrap_tolerance: A::Tolerance,
    /// Largest accepted residual of the unwrapping step from a Gray code
    /// ([`Plan::gray_tolerance`]).
    pub gray_tolerance: A::Tolerance,
    /// `A − v` at or above this: the Gray-code bit is firmly dark ([`Plan::gray_margin`]).
    pub gray_dark: A::Acc,
    /// `A − v` below this: the Gray-code bit is firmly bright (minus [`Plan::gray_margin`]).
    pub gray_bright: A::Acc,
}

/// A decoding arithmetic: number types and the primitive operations of the kernel.
///
/// Implemented by [`F32Accurate`], [`F32Fast`], [`F32Micromath`] and [`Fixed`] only (sealed). The
/// kernel ([`crate::decode::Decoder`]) calls the per-pixel methods in a fixed order with no
/// data-dependent branching; they are all `#[inline(always)]` so that the host's wide-ISA builds
/// vectorize them. Construction-time methods run once per decoder.
pub trait Arith: Sealed + Copy + Debug + PartialEq + Default + Send + Sync + 'static {
    /// Short name (`"f32"`, `"f32-fast"`, `"f32-micromath"`, `"fixed"`).
    const NAME: &'static str;
    /// Element of the per-pixel state planes (S, C and DC accumulators).
    type Acc: Copy + Default + Debug + PartialEq + Send + Sync + 'static;
    /// A camera sample as the kernel multiplies it.
    type In: Copy + Debug + PartialEq + Send + Sync;
    /// A linear coefficient of an estimator.
    type Coef: Copy + Debug + PartialEq + Send + Sync;
    /// Wrapped and absolute phase (radians for f32, turns for fixed point).
    type Phase: Copy + Default + Debug + PartialEq + Send + Sync;
    /// A level ratio `c_k / c_{k−1}`.
    type Ratio: Copy + Debug + PartialEq + Send + Sync;
    /// The unwrapping tolerance (absolute residual).
    type Tolerance: Copy + Debug + PartialEq + Send + Sync;
    /// The modulation measure compared against the threshold (B² for f32, B for fixed point).
    type Mag: Copy + Default + Debug + PartialEq + Send + Sync;
    /// The run-time part of the number format, chosen per decoder (`()` for f32).
    type Format: Copy + Debug + PartialEq + Send + Sync;

    /// The zero accumulator.
    const ZERO: Self::Acc;
    /// The zero coefficient.
    const COEF_ZERO: Self::Coef;
    /// A modulation measure above every real one (start of the per-pixel minimum).
    const MAG_MAX: Self::Mag;
    /// The zero phase (= `Phase::default()`, usable in `const` contexts).
    const PHASE_ZERO: Self::Phase;
    /// The zero modulation measure (= `Mag::default()`, usable in `const` contexts).
    const MAG_ZERO: Self::Mag;

    // ---- construction (once per decoder) ----

    /// Choose the number format for a plan, or refuse the set.
    fn format(plan: &Plan<'_>) -> Result<Self::Format, DecodeError>;
    /// The coefficients of level `level` of the plan.
    fn level_coefs(plan: &Plan<'_>, level: usize, format: &Self::Format) -> LevelCoefs<Self::Coef>;
    /// A level ratio.
    fn ratio(r: f64, format: &Self::Format) -> Self::Ratio;
    /// The thresholds and ranges.
    fn limits(plan: &Plan<'_>, format: &Self::Format) -> Limits<Self>;
    /// `true` if a coefficient is exactly zero (the kernel then skips that product).
    fn is_zero(k: Self::Coef) -> bool;

    // ---- per pixel: accumulate ----

    /// A sample as the kernel multiplies it.
    fn input<P: Sample>(v: P) -> Self::In;
    /// `acc + k·v`.
    fn mac(acc: Self::Acc, k: Self::Coef, v: Self::In) -> Self::Acc;
    /// `true` if `k` equals `value` and the backend's sums of samples times `k` are exact, so
    /// that the kernel may regroup them (`k·v₀ − k·v₂ = k·(v₀ − v₂)`) without changing a bit.
    /// The f32 backends: `k == value` (samples are integers below 2¹⁷); fixed point: never.
    #[inline(always)]
    fn exact_coef(_k: Self::Coef, _value: f32) -> bool {
        false
    }
    /// `a + b` of two samples (used only where [`Self::exact_coef`] allowed a regrouping).
    fn in_add(a: Self::In, b: Self::In) -> Self::In;
    /// `a − b` of two samples (as [`Self::in_add`]).
    fn in_sub(a: Self::In, b: Self::In) -> Self::In;
    /// `v − dc`, a sample minus a DC accumulator (as [`Self::in_add`]).
    fn in_minus_acc(v: Self::In, dc: Self::Acc) -> Self::Acc;
    /// `mac(ZERO, k, v)` for `k > 0` and `v` a sum or difference of samples (as
    /// [`Self::in_add`]): then `k·v` is never −0, so the f32 backends drop the `0 +`.
    #[inline(always)]
    fn regrouped_product(k: Self::Coef, v: Self::In) -> Self::Acc {
        Self::mac(Self::ZERO, k, v)
    }
    /// `v ≥ threshold`.
    fn saturated(v: Self::In, threshold: Self::In) -> bool;
    /// `A − v`, a DC term minus a sample, in accumulator units: a Gray-code bit is bright where
    /// it is negative ([`crate::gray`]).
    fn dc_minus_input(a: Self::Acc, v: Self::In, format: &Self::Format) -> Self::Acc;
    /// A sample in accumulator units, as [`Self::dc_minus_input`] scales it:
    /// `dc_minus_input(input_acc(v), w)` is `v − w` exactly (an inverse Gray code's pair,
    /// [`crate::gray`]).
    fn input_acc(v: Self::In, format: &Self::Format) -> Self::Acc;
    /// A packed Gray-code word kept in an accumulator plane (the frame-sequential path), back
    /// to 16 bits: exact for every word ([`Self::word_acc`]).
    fn acc_word(a: Self::Acc) -> u16;
    /// A packed Gray-code word (below 2¹⁶) as an accumulator value, exactly.
    fn word_acc(w: u16) -> Self::Acc;
    /// `n·π/2` as a phase: a Gray code's phase estimate ([`GrayCode::quarter_turns`]).
    fn quarter_turns(n: i32) -> Self::Phase;
    /// `p + 2π·k`, no rounding: a coprime set's candidate orders
    /// ([`crate::pattern::Relation::Coprime`]; `|k| ≤ 33`).
    fn add_turns(p: Self::Phase, k: i32) -> Self::Phase;

    // ---- per pixel: finish ----

    /// S and C of a level from its accumulators and the DC accumulator: `S = s + a_dc·A`,
    /// `C = c + b_dc·A`.
    fn level_sc(
        s: Self::Acc,
        c: Self::Acc,
        a_dc: Self::Coef,
        b_dc: Self::Coef,
        dc: Self::Acc,
        format: &Self::Format,
    ) -> (Self::Acc, Self::Acc);
    /// Wrapped phase `atan2(S, C)` and the modulation measure of (S, C).
    fn polar(s: Self::Acc, c: Self::Acc) -> (Self::Phase, Self::Mag);
    /// [`Self::polar`] for the coarser levels, whose phase only chooses the next level's fringe
    /// order: a backend may use a cheaper, less accurate arctangent (the f32 backends:
    /// [`crate::math::atan2_coarse_finite`], 6.1e-4 rad). The default is [`Self::polar`].
    #[inline(always)]
    fn polar_coarse(s: Self::Acc, c: Self::Acc) -> (Self::Phase, Self::Mag) {
        Self::polar(s, c)
    }
    /// [`Self::polar`] for the finest level, whose modulation B is an output: the phase, the
    /// measure and B in camera codes ([`F32Accurate`] computes B from the arctangent's reduction
    /// without a square root, [`crate::math::atan2_hypot_finite`]).
    fn polar_fine(
        s: Self::Acc,
        c: Self::Acc,
        format: &Self::Format,
    ) -> (Self::Phase, Self::Mag, f32);
    /// [`Self::polar_fine`] of the finest level and [`Self::polar_coarse`] of two coarser ones,
    /// for `N` pixels: the row driver's fused pass over three levels
    /// ([`crate::decode::Decoder`] for the paper's 8-pattern and the 12-pattern sets). A backend
    /// may write the `3·N` computations side by side; each gives the bits of the separate calls.
    #[inline(always)]
    #[allow(clippy::type_complexity)]
    fn polar_levels3_lanes<const N: usize>(
        fine: [(Self::Acc, Self::Acc); N],
        c1: [(Self::Acc, Self::Acc); N],
        c2: [(Self::Acc, Self::Acc); N],
        format: &Self::Format,
    ) -> [(
        (Self::Phase, Self::Mag, f32),
        (Self::Phase, Self::Mag),
        (Self::Phase, Self::Mag),
    ); N] {
        core::array::from_fn(|k| {
            (
                Self::polar_fine(fine[k].0, fine[k].1, format),
                Self::polar_coarse(c1[k].0, c1[k].1),
                Self::polar_coarse(c2[k].0, c2[k].1),
            )
        })
    }
    /// The smaller of two measures (the first if they are unordered).
    fn min_mag(m: Self::Mag, current: Self::Mag) -> Self::Mag;
    /// `lo ≤ w ≤ hi`.
    fn in_range(w: Self::Phase, lo: Self::Phase, hi: Self::Phase) -> bool;
    /// One unwrapping step: absolute phase and residual (see [`crate::unwrap`]).
    fn unwrap(
        coarse: Self::Phase,
        ratio: Self::Ratio,
        wrapped: Self::Phase,
    ) -> (Self::Phase, Self::Phase);
    /// `|residual| ≤ tolerance`.
    fn consistent(residual: Self::Phase, tolerance: Self::Tolerance) -> bool;
    /// `m ≥ threshold` (false for NaN).
    fn mag_at_least(m: Self::Mag, threshold: Self::Mag) -> bool;
    /// `a ≥ threshold` (false for NaN).
    fn dc_at_least(a: Self::Acc, threshold: Self::Acc) -> bool;

    /// `p` minus the periodic linear interpolation at `p` of `table`, knots in
    /// [`crate::decode::CORRECTION_LSB`] units ([`crate::decode::PhaseCorrection`] gives the
    /// formula).
    fn correct(p: Self::Phase, table: &[i16; CORRECTION_KNOTS]) -> Self::Phase;

    // ---- outputs ----

    /// A phase in radians.
    fn phase_out(p: Self::Phase) -> f32;
    /// A DC term A in camera codes.
    fn dc_out(a: Self::Acc, format: &Self::Format) -> f32;
}

/// The largest sample a pixel that is not saturated can hold: `⌈saturation⌉ − 1`, at most 65535
/// (the widest [`Sample`]) and at least 1.
pub(crate) fn max_unsaturated(config: &DecodeConfig) -> f64 {
    (libm::ceil(config.saturation_level as f64) - 1.0).clamp(1.0, 65535.0)
}
