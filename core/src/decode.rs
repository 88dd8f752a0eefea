//! Phase decoding: DC term, wrapped phases, modulation and validity, then hierarchical unwrapping
//! (paper §5.2, eqs 8-15).
//!
//! # Model
//! Every image of level k, shift δ_n (plus the set's offset) is modelled as (eqs 8, 14)
//!
//! ```text
//! I_n = A + B·sin(Φ + δ_n) = A + S·cos δ_n + C·sin δ_n,   S = B·sin Φ,  C = B·cos Φ
//! ```
//!
//! which is linear in (A, S, C). A level with ≥ 3 shifts estimates all three by least squares —
//! for the paper's 4-step level that is exactly eq 9 (`Φ = atan2(I₁ − I₃, I₂ − I₄)`) and eq 10
//! (`A = ΣI/4`), and for uniform N-step levels eqs 14-15. A level with 2 shifts uses the DC term A
//! of the DC level and solves the 2×2 system for (S, C): for shifts 0 and π/2 that is eq 11,
//! `Φ = atan2(I₁ − A, I₂ − A)`. Every estimator is a fixed linear combination of the images,
//! computed once per set ([`level_estimator`]), so decoding is a weighted sum per image followed by
//! one `atan2` per level — no per-pixel branching on the set's structure.
//!
//! # One kernel, two drivers
//! Per block of [`BLOCK`] pixels, pass 1 computes each level's S and C (and the DC level's A),
//! its wrapped phase and modulation measure; pass 2 unwraps (eqs 12-13) and sets validity and
//! outputs. The row API ([`Decoder::decode_row`]) runs pass 1 straight from each level's image
//! rows, with every sum in registers. The frame-sequential API ([`crate::sequential`]) folds
//! frames as they arrive into a caller buffer ([`Decoder::accumulate`]) and runs the same passes
//! from it at the end ([`Decoder::finish`]). The sums are the same products added in the same
//! order from +0 (a skipped zero product adds ±0, which changes no sum that is never −0), and the
//! rest is the same code, so both give the same bits. For the two common three-level structures
//! (the paper's 8-pattern set and the 12-pattern set) the row driver's pass 1 computes all three
//! levels in one loop with their arctangents side by side ([`crate::math::atan2_levels3_lanes`]),
//! and pass 2 computes two or four pixels side by side ([`Decoder::decode_row_lanes`]): the
//! same operations per pixel in another order.
//!
//! # Arithmetic
//! The kernel is generic over an [`Arith`] backend ([`crate::arith`]): f32 with the accurate
//! polynomial `atan2` ([`F32Accurate`], the default, and what [`Decoder::new`] builds), fast f32,
//! or fixed point for heads without an FPU. `Decoder::<A>::with_arith` builds any of them; all run
//! this one kernel.

use crate::arith::{Arith, F32Accurate, Limits, Plan};
use crate::math::CANONICAL_NAN;
use crate::pattern::{MAX_IMAGES, MAX_LEVELS, MAX_SHIFTS, PatternSet};
use crate::validity::Validity;

/// Pixels per block of the row driver; the state of one block lives on the stack.
pub const BLOCK: usize = 64;

/// A camera sample type the decoder reads: `u8` or `u16` (12- or 16-bit sensors).
pub trait Sample: Copy {
    /// Largest code of the type.
    const MAX: f32;
    /// The value as f32 (exact: every u16 is representable).
    fn to_f32(self) -> f32;
    /// The value as i32 (the fixed-point backend's input).
    #[inline(always)]
    fn to_i32(self) -> i32 {
        self.to_f32() as i32
    }
    /// The larger of two samples (the row decoder tracks the largest sample of each pixel to test
    /// saturation once, instead of once per image).
    #[inline(always)]
    fn max_of(self, other: Self) -> Self {
        if self.to_f32() > other.to_f32() {
            self
        } else {
            other
        }
    }
}

impl Sample for u8 {
    #[inline(always)]
    fn max_of(self, other: Self) -> Self {
        if self > other { self } else { other }
    }
    const MAX: f32 = 255.0;
    #[inline(always)]
    fn to_f32(self) -> f32 {
        self as f32
    }
    #[inline(always)]
    fn to_i32(self) -> i32 {
        self as i32
    }
}

impl Sample for u16 {
    #[inline(always)]
    fn max_of(self, other: Self) -> Self {
        if self > other { self } else { other }
    }
    const MAX: f32 = 65535.0;
    #[inline(always)]
    fn to_f32(self) -> f32 {
        self as f32
    }
    #[inline(always)]
    fn to_i32(self) -> i32 {
        self as i32
    }
}

/// The linear estimator of one level: `S = Σ a_n·I_n + a_dc·A`, `C = Σ b_n·I_n + b_dc·A`, and for a
/// DC level `A = Σ w_n·I_n`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LevelEstimator {
    /// Number of shifts.
    pub n: usize,
    /// Coefficients of S = B·sin Φ.
    pub a: [f32; MAX_SHIFTS],
    /// Coefficients of C = B·cos Φ.
    pub b: [f32; MAX_SHIFTS],
    /// Coefficients of A (all zero for a 2-shift level).
    pub w: [f32; MAX_SHIFTS],
    /// Coefficient of the external DC term A in S (zero for a level with ≥ 3 shifts).
    pub a_dc: f32,
    /// Coefficient of the external DC term A in C (zero for a level with ≥ 3 shifts).
    pub b_dc: f32,
}

/// Round an f64 coefficient to f32, snapping values that are zero up to f64 rounding of sin/cos
/// (e.g. cos(π/2) ≈ 6e-17) to exactly 0 and near-integers/halves to their exact value, so that the
/// paper's 4-step level gets exactly `(½, 0, −½, 0)`.
fn snap(x: f64) -> f32 {
    let q = libm::round(x * 4096.0) / 4096.0;
    if libm::fabs(x - q) < 1e-12 {
        q as f32
    } else {
        x as f32
    }
}

/// Compute the estimator of a level with effective shifts `shifts[n] + offset` (radians).
///
/// Returns `None` if the shifts cannot separate the unknowns (fewer than 2 shifts, more than
/// [`MAX_SHIFTS`], or a singular system).
pub fn level_estimator(shifts: &[f64], offset: f64) -> Option<LevelEstimator> {
    let n = shifts.len();
    if !(2..=MAX_SHIFTS).contains(&n) {
        return None;
    }
    let mut est = LevelEstimator {
        n,
        a: [0.0; MAX_SHIFTS],
        b: [0.0; MAX_SHIFTS],
        w: [0.0; MAX_SHIFTS],
        a_dc: 0.0,
        b_dc: 0.0,
    };
    let mut cs = [(0.0f64, 0.0f64); MAX_SHIFTS];
    for (i, s) in shifts.iter().enumerate() {
        let d = s + offset;
        cs[i] = (libm::cos(d), libm::sin(d));
    }
    if n == 2 {
        // [c0 s0; c1 s1]·[S; C] = [I0 − A; I1 − A]
        let (c0, s0) = cs[0];
        let (c1, s1) = cs[1];
        let det = c0 * s1 - s0 * c1;
        if libm::fabs(det) < 1e-6 {
            return None;
        }
        let (ia0, ia1) = (s1 / det, -s0 / det);
        let (ib0, ib1) = (-c1 / det, c0 / det);
        est.a[0] = snap(ia0);
        est.a[1] = snap(ia1);
        est.b[0] = snap(ib0);
        est.b[1] = snap(ib1);
        est.a_dc = snap(-(ia0 + ia1));
        est.b_dc = snap(-(ib0 + ib1));
        return Some(est);
    }
    // Least squares over rows (1, cos δ, sin δ): x = (DᵀD)⁻¹ Dᵀ I.
    let mut m = [[0.0f64; 3]; 3];
    for &(c, s) in &cs[..n] {
        let r = [1.0, c, s];
        for i in 0..3 {
            for j in 0..3 {
                m[i][j] += r[i] * r[j];
            }
        }
    }
    let inv = invert3(&m)?;
    for (k, &(c, s)) in cs[..n].iter().enumerate() {
        let r = [1.0, c, s];
        let mut x = [0.0f64; 3];
        for (i, xi) in x.iter_mut().enumerate() {
            *xi = inv[i][0] * r[0] + inv[i][1] * r[1] + inv[i][2] * r[2];
        }
        est.w[k] = snap(x[0]);
        est.a[k] = snap(x[1]);
        est.b[k] = snap(x[2]);
    }
    Some(est)
}

#[allow(clippy::needless_range_loop)] // cofactor indices read best as indices
fn invert3(m: &[[f64; 3]; 3]) -> Option<[[f64; 3]; 3]> {
    let det = m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
        - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
        + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
    // DᵀD of n unit-norm-ish rows: a determinant this small means the shifts coincide mod 2π.
    if !(libm::fabs(det) > 1e-6) {
        return None;
    }
    let mut r = [[0.0; 3]; 3];
    for i in 0..3 {
        for j in 0..3 {
            let (a0, a1) = ((j + 1) % 3, (j + 2) % 3);
            let (b0, b1) = ((i + 1) % 3, (i + 2) % 3);
            r[i][j] = (m[a0][b0] * m[a1][b1] - m[a0][b1] * m[a1][b0]) / det;
        }
    }
    Some(r)
}

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
    /// pixel is [`Validity::PhaseOutOfRange`].
    pub range_tolerance: f32,
}

impl DecodeConfig {
    /// Defaults for a sensor of `bits` bits per sample (8 to 16): dark below 2 % of full scale,
    /// saturated at full scale, modulation at least 2 % of full scale but not below 12 codes (as
    /// long as that is within 5 % of full scale), unwrapping residual ≤ 2π/3, coarse phase within
    /// 0.15 rad of the projected range (the range keeps 0.05 rad from ±π, and the level-0 noise at
    /// B/σ = 14 is 0.08 rad).
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

    fn is_sane(&self) -> bool {
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

/// Why a decoder could not be built or run.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DecodeError {
    /// The pattern set's shifts cannot be decoded at this level.
    Degenerate(u8),
    /// A threshold is NaN, negative, or the unwrap tolerance exceeds π.
    Config,
    /// The number of image rows differs from the set's image count.
    ImageCount,
    /// Input or output rows differ in length.
    Length,
    /// The state buffer given to the frame-sequential decoder is too small.
    StateTooSmall,
    /// A frame or row was pushed out of order, or the set was already complete.
    Sequence,
}

impl DecodeError {
    /// The error itself (all variants are argument errors; the enum is its own kind).
    pub fn kind(&self) -> DecodeError {
        *self
    }
}

impl core::fmt::Display for DecodeError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::Degenerate(l) => write!(f, "level {l}: shifts cannot be decoded"),
            Self::Config => f.write_str(
                "decode thresholds must be finite and non-negative, unwrap tolerance <= pi",
            ),
            Self::ImageCount => f.write_str("number of image rows differs from the pattern set"),
            Self::Length => f.write_str("input and output rows differ in length"),
            Self::StateTooSmall => f.write_str("state buffer too small for this frame size"),
            Self::Sequence => f.write_str("frame or row pushed out of order"),
        }
    }
}

/// Per-image coefficients, in image order.
#[derive(Clone, Copy, Debug, PartialEq)]
struct ImageCoef<K> {
    level: u8,
    a: K,
    b: K,
    w: K,
    /// How the image enters the S, C and DC planes: [`SKIP`] (zero coefficient: `acc + 0·v` is
    /// `acc` exactly, as no accumulator is ever −0), [`INIT`] (the plane's first non-zero
    /// contribution in image order: `0 + k·v`) or [`ACC`].
    mode: [u8; 3],
}

/// Plane mode: the coefficient is zero, the plane is left alone.
const SKIP: u8 = 0;
/// Plane mode: first contribution, `ZERO + k·v` (the row driver then needs no zeroed state).
const INIT: u8 = 1;
/// Plane mode: `acc + k·v`.
const ACC: u8 = 2;

/// A decoder for one pattern set: estimators, level ratios and thresholds, computed once, in the
/// number formats of the arithmetic `A` ([`crate::arith`]; the default is [`F32Accurate`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Decoder<A: Arith = F32Accurate> {
    n_levels: usize,
    n_images: usize,
    images: [ImageCoef<A::Coef>; MAX_IMAGES],
    a_dc: [A::Coef; MAX_LEVELS],
    b_dc: [A::Coef; MAX_LEVELS],
    /// `c_k / c_{k−1}` for k ≥ 1 (entry 0 unused).
    ratio: [A::Ratio; MAX_LEVELS],
    limits: Limits<A>,
    format: A::Format,
    config: DecodeConfig,
    /// Planes (DC, then S and C of each level) no image contributes to: the row driver zeroes them.
    untouched: [bool; 1 + 2 * MAX_LEVELS],
    /// The images of each level, in image order (the row driver's per-level passes).
    level_images: [LevelImages; MAX_LEVELS],
    /// The levels in the order the row driver computes them: the DC level first (the others'
    /// S and C need its A), then the rest in level order.
    level_order: [u8; MAX_LEVELS],
    /// The level whose images carry the DC term A (eq 10/15), if any.
    dc_level: Option<u8>,
    /// Whether the row driver computes every level in one loop ([`Self::fused_rows`]):
    /// [`FUSED_PAIRS`] or [`FUSED_QUADS`] for three levels whose finest is the DC level of
    /// kind [`KIND_QUAD_EXACT`] and whose coarser ones are both of kind [`KIND_PAIR_UNIT`] or
    /// both [`KIND_QUAD_EXACT`]; [`FUSED_NONE`] otherwise.
    fused: u8,
}

/// Pixels side by side in [`Decoder::fused_rows`] (pass 1 of the paper's and the 12-pattern
/// sets): pixel `j` of each of the block's `FUSED_LANES` parts per iteration. Four vectorize on
/// SSE2, AVX2 and AVX-512 alike.
const FUSED_LANES: usize = 4;

/// [`Decoder`]'s `fused`: one loop per level.
const FUSED_NONE: u8 = 0;
/// [`Decoder`]'s `fused`: the paper's 8-pattern structure (4-step finest level, two 2-image levels).
const FUSED_PAIRS: u8 = 1;
/// [`Decoder`]'s `fused`: three 4-step levels (the 12-pattern set).
const FUSED_QUADS: u8 = 2;

/// The images of one level, in image order.
#[derive(Clone, Copy, Debug, PartialEq)]
struct LevelImages {
    n: u8,
    idx: [u8; MAX_SHIFTS],
    /// Where the level's coefficients are zero, when it matches a pattern the row driver has a
    /// shorter loop for ([`KIND_GENERIC`] otherwise).
    kind: u8,
}

/// A level without a special pattern: every product is computed.
const KIND_GENERIC: u8 = 0;
/// Two images whose S and C each come from one of them (the paper's 2-image levels, shifts a
/// quarter period apart, eq 11): `S = a₀·I₀ + a_dc·A`, `C = b₁·I₁ + b_dc·A`.
const KIND_PAIR: u8 = 1;
/// Four images a quarter period apart (eq 9): `S = a₀·I₀ + a₂·I₂`, `C = b₁·I₁ + b₃·I₃`, no
/// external DC term.
const KIND_QUAD: u8 = 2;
/// [`KIND_PAIR`] with the paper's exact coefficients (shifts 0 and π/2, eq 11) in a backend whose
/// sums are exact: `S = I₀ − A`, `C = I₁ − A`, the same bits as the products and sums.
const KIND_PAIR_UNIT: u8 = 3;
/// [`KIND_QUAD`] with the paper's exact coefficients (eqs 9-10) in a backend whose sums are
/// exact: `S = ½·(I₀ − I₂)`, `C = ½·(I₁ − I₃)`, `A = ¼·(I₀ + I₁ + I₂ + I₃)`, the same bits as
/// the products and sums (every intermediate is exact, and no sum is −0 either way).
const KIND_QUAD_EXACT: u8 = 4;

/// Output rows of the decoder, all the same length.
pub struct RowOut<'a> {
    /// Absolute phase of the finest level, radians (`c_K·Φ^(P)`); canonical NaN where invalid.
    pub phase: &'a mut [f32],
    /// Modulation B of the finest level, camera codes.
    pub modulation: &'a mut [f32],
    /// DC term A (eq 10/15), camera codes.
    pub dc: &'a mut [f32],
    /// [`Validity`] code per pixel.
    pub validity: &'a mut [u8],
}

impl RowOut<'_> {
    fn len_ok(&self, n: usize) -> bool {
        self.phase.len() == n
            && self.modulation.len() == n
            && self.dc.len() == n
            && self.validity.len() == n
    }
}

/// Borrowed per-pixel decoding state: one plane for the DC accumulator, two per level (S and C
/// accumulators) and a flag byte. All planes have the same length. The element type is the
/// backend's accumulator ([`Arith::Acc`]): f32 by default, i32 for [`crate::arith::Fixed`].
pub struct State<'a, T = f32> {
    /// DC accumulator `Σ w_n·I_n` of the DC level.
    pub dc: &'a mut [T],
    /// S accumulators, one plane per level.
    pub s: [&'a mut [T]; MAX_LEVELS],
    /// C accumulators, one plane per level.
    pub c: [&'a mut [T]; MAX_LEVELS],
    /// Bit 0: some sample was saturated.
    pub flags: &'a mut [u8],
}

impl Decoder<F32Accurate> {
    /// Build the decoder of `set` with thresholds `config`, in the default arithmetic
    /// ([`F32Accurate`]). See [`Decoder::with_arith`] for the others.
    pub fn new(set: &PatternSet, config: DecodeConfig) -> Result<Self, DecodeError> {
        Self::with_arith(set, config)
    }
}

/// An all-zero estimator (a placeholder for unused levels).
const NO_ESTIMATOR: LevelEstimator = LevelEstimator {
    n: 0,
    a: [0.0; MAX_SHIFTS],
    b: [0.0; MAX_SHIFTS],
    w: [0.0; MAX_SHIFTS],
    a_dc: 0.0,
    b_dc: 0.0,
};

impl<A: Arith> Decoder<A> {
    /// Build the decoder of `set` with thresholds `config` in the arithmetic `A`, e.g.
    /// `Decoder::<Fixed>::with_arith(&set, config)`.
    ///
    /// Besides the errors of [`Decoder::new`], a backend may refuse a set its number formats cannot
    /// hold ([`crate::arith::Fixed`]: a level whose absolute phase could exceed the fixed-point
    /// range, or coefficients too large for the accumulators), as [`DecodeError::Degenerate`] of
    /// that level.
    pub fn with_arith(set: &PatternSet, config: DecodeConfig) -> Result<Self, DecodeError> {
        if !config.is_sane() {
            return Err(DecodeError::Config);
        }
        let levels = set.levels();
        let offset = set.effective_offset();
        let mut est = [NO_ESTIMATOR; MAX_LEVELS];
        for (i, l) in levels.iter().enumerate() {
            est[i] = level_estimator(l.shifts(), offset).ok_or(DecodeError::Degenerate(i as u8))?;
        }
        // The DC level: most shifts, finest on ties.
        let mut dc_level = None;
        for (i, l) in levels.iter().enumerate() {
            if l.has_dc() && dc_level.is_none_or(|d: usize| l.len() >= levels[d].len()) {
                dc_level = Some(i);
            }
        }
        let mut ratios = [1.0f64; MAX_LEVELS];
        for i in 1..levels.len() {
            ratios[i] = levels[i].scale() / levels[i - 1].scale();
        }
        let n_levels = levels.len();
        let plan = Plan {
            levels: &est[..n_levels],
            dc_level,
            ratios: &ratios[..n_levels],
            coarse_range: set.coarse_range(),
            config: &config,
        };
        let format = A::format(&plan)?;
        let zero = ImageCoef {
            level: 0,
            a: A::COEF_ZERO,
            b: A::COEF_ZERO,
            w: A::COEF_ZERO,
            mode: [SKIP; 3],
        };
        let mut d = Decoder {
            n_levels,
            n_images: set.image_count(),
            images: [zero; MAX_IMAGES],
            a_dc: [A::COEF_ZERO; MAX_LEVELS],
            b_dc: [A::COEF_ZERO; MAX_LEVELS],
            ratio: [A::ratio(1.0, &format); MAX_LEVELS],
            limits: A::limits(&plan, &format),
            format,
            config,
            untouched: [true; 1 + 2 * MAX_LEVELS],
            level_images: [LevelImages {
                n: 0,
                idx: [0; MAX_SHIFTS],
                kind: KIND_GENERIC,
            }; MAX_LEVELS],
            level_order: [0; MAX_LEVELS],
            dc_level: dc_level.map(|l| l as u8),
            fused: FUSED_NONE,
        };
        let order = dc_level
            .into_iter()
            .chain((0..n_levels).filter(|&l| Some(l) != dc_level));
        for (slot, l) in d.level_order.iter_mut().zip(order) {
            *slot = l as u8;
        }
        let mut coefs = [None; MAX_LEVELS];
        for i in 0..n_levels {
            let c = A::level_coefs(&plan, i, &format);
            d.a_dc[i] = c.a_dc;
            d.b_dc[i] = c.b_dc;
            if i > 0 {
                d.ratio[i] = A::ratio(ratios[i], &format);
            }
            coefs[i] = Some(c);
        }
        for (k, id) in set.order().iter().enumerate() {
            let l = id.level as usize;
            let s = id.shift as usize;
            let c = coefs[l].ok_or(DecodeError::Degenerate(id.level))?;
            let w = if dc_level == Some(l) {
                c.w[s]
            } else {
                A::COEF_ZERO
            };
            let mut mode = [SKIP; 3];
            for (m, (k, plane)) in
                mode.iter_mut()
                    .zip([(c.a[s], 1 + 2 * l), (c.b[s], 2 + 2 * l), (w, 0)])
            {
                if !A::is_zero(k) {
                    *m = if d.untouched[plane] { INIT } else { ACC };
                    d.untouched[plane] = false;
                }
            }
            d.images[k] = ImageCoef {
                level: id.level,
                a: c.a[s],
                b: c.b[s],
                w,
                mode,
            };
            let li = &mut d.level_images[l];
            if let Some(slot) = li.idx.get_mut(li.n as usize) {
                *slot = k as u8;
                li.n += 1;
            } else {
                return Err(DecodeError::Degenerate(id.level));
            }
        }
        for l in 0..n_levels {
            d.level_images[l].kind = d.level_kind(l);
        }
        let kinds = [
            d.level_images[0].kind,
            d.level_images[1].kind,
            d.level_images[2].kind,
        ];
        if n_levels == 3 && dc_level == Some(2) && kinds[2] == KIND_QUAD_EXACT {
            d.fused = match kinds[..2] {
                [KIND_PAIR_UNIT, KIND_PAIR_UNIT] => FUSED_PAIRS,
                [KIND_QUAD_EXACT, KIND_QUAD_EXACT] => FUSED_QUADS,
                _ => FUSED_NONE,
            };
        }
        Ok(d)
    }

    /// The zero pattern of level `l`'s coefficients ([`KIND_PAIR`], [`KIND_QUAD`] or
    /// [`KIND_GENERIC`]). Skipping a zero product changes no bit: it adds ±0 to a sum that
    /// started at +0 and so is never −0 (and 0 in the integer backends).
    fn level_kind(&self, l: usize) -> u8 {
        let li = &self.level_images[l];
        let coef = |j: usize| self.images[li.idx[j] as usize];
        let z = |k: A::Coef| A::is_zero(k);
        let kind = match li.n {
            2 if !z(coef(0).a)
                && z(coef(1).a)
                && z(coef(0).b)
                && !z(coef(1).b)
                && (0..2).all(|j| z(coef(j).w)) =>
            {
                KIND_PAIR
            }
            4 if (0..4).all(|j| (j % 2 == 0) != z(coef(j).a) && (j % 2 == 1) != z(coef(j).b))
                && z(self.a_dc[l])
                && z(self.b_dc[l]) =>
            {
                let e = |k: A::Coef, v: f32| A::exact_coef(k, v);
                // The weights of A only matter for the DC level (the others never compute it).
                let exact = e(coef(0).a, 0.5)
                    && e(coef(2).a, -0.5)
                    && e(coef(1).b, 0.5)
                    && e(coef(3).b, -0.5)
                    && (self.dc_level != Some(l as u8) || (0..4).all(|j| e(coef(j).w, 0.25)));
                if exact { KIND_QUAD_EXACT } else { KIND_QUAD }
            }
            _ => KIND_GENERIC,
        };
        match kind {
            KIND_PAIR
                if A::exact_coef(coef(0).a, 1.0)
                    && A::exact_coef(coef(1).b, 1.0)
                    && A::exact_coef(self.a_dc[l], -1.0)
                    && A::exact_coef(self.b_dc[l], -1.0) =>
            {
                KIND_PAIR_UNIT
            }
            k => k,
        }
    }

    /// The run-time number format of the backend (e.g. the accumulator fraction bits of
    /// [`crate::arith::Fixed`]; `()` for f32).
    pub fn format(&self) -> &A::Format {
        &self.format
    }

    /// The thresholds in use.
    pub fn config(&self) -> &DecodeConfig {
        &self.config
    }

    /// Number of levels.
    pub fn level_count(&self) -> usize {
        self.n_levels
    }

    /// Number of images per set.
    pub fn image_count(&self) -> usize {
        self.n_images
    }

    /// Decode one row: `rows[i]` is the row of image `i` (in the set's order), all of the same
    /// length as the outputs. Writes the finest absolute phase, its modulation B, the DC term A and
    /// a validity code for every pixel.
    ///
    /// Works block by block of [`BLOCK`] pixels on a [`DecodeScratch`] of its own (about 3.4 KiB
    /// of stack in f32); a caller decoding many rows saves clearing it every row by keeping one
    /// and calling [`Self::decode_row_with`]. Same bits either way.
    #[inline(always)]
    pub fn decode_row<P: Sample>(&self, rows: &[&[P]], out: RowOut<'_>) -> Result<(), DecodeError> {
        self.decode_row_with(&mut DecodeScratch::new(), rows, out)
    }

    /// [`Self::decode_row`] with caller-kept scratch (e.g. one in a `static` on a head, or one
    /// per worker on the desktop).
    ///
    /// Per block: the largest sample of every pixel (saturation is tested once on it:
    /// `v ≥ t` for some sample ⇔ `max v ≥ t`); pass 1 per level, DC level first, straight from
    /// the level's image rows (`level_from_rows`); pass 2, the unwrapping and validity
    /// (`unwrap_block`). The frame-sequential path ([`Self::accumulate`] then
    /// [`Self::finish`]) computes the same values in the same order: the same bits.
    #[inline(always)]
    pub fn decode_row_with<P: Sample>(
        &self,
        scratch: &mut DecodeScratch<A>,
        rows: &[&[P]],
        out: RowOut<'_>,
    ) -> Result<(), DecodeError> {
        self.decode_row_lanes::<P, 1>(scratch, rows, out)
    }

    /// [`Self::decode_row_with`] computing several pixels side by side: `N` (1, 2 or 4) in the
    /// finishing pass (pass 2) and, for `N > 1`, four in the fused first pass of the paper's and
    /// the 12-pattern sets. [`Self::decode_row_with`] takes 1. The lane count only orders the
    /// work: every `N` gives the same bits. It is a scheduling choice for the core the caller is
    /// compiled for: one pixel at a time suits a scalar in-order core (Cortex-M4F: 352
    /// instructions per pixel against 460 with lanes); on x86-64 with 16-byte vectors (SSE2)
    /// four independent chains per iteration are the fastest, while the AVX2 and AVX-512 builds
    /// of a four-lane pass 2 do not vectorize (LLVM 20) and take 2-4× longer, so they take 2.
    /// The host's batch path picks per ISA.
    #[inline(always)]
    pub fn decode_row_lanes<P: Sample, const N: usize>(
        &self,
        scratch: &mut DecodeScratch<A>,
        rows: &[&[P]],
        out: RowOut<'_>,
    ) -> Result<(), DecodeError> {
        if rows.len() != self.n_images {
            return Err(DecodeError::ImageCount);
        }
        let w = out.phase.len();
        if !out.len_ok(w) || rows.iter().any(|r| r.len() != w) {
            return Err(DecodeError::Length);
        }
        if w == 0 {
            return Ok(());
        }
        if w < BLOCK {
            return self.decode_short_row::<P, N>(scratch, rows, out);
        }
        let RowOut {
            phase,
            modulation,
            dc,
            validity,
        } = out;
        let blk = &mut scratch.0;
        // Whole blocks only, so that every loop has the constant trip count BLOCK (no remainder
        // loops, whatever the vector width): the last block ends at the row's end and may overlap
        // the one before, whose pixels it computes again to the same bits.
        let mut start = 0;
        loop {
            let r = start..start + BLOCK;
            let out = BlockOut {
                phase: block_mut(phase, r.clone())?,
                modulation: block_mut(modulation, r.clone())?,
                dc: block_mut(dc, r.clone())?,
                validity: block_mut(validity, r.clone())?,
            };
            self.decode_block::<P, N>(blk, rows, start, out)?;
            if start + BLOCK == w {
                return Ok(());
            }
            start = if w - (start + BLOCK) >= BLOCK {
                start + BLOCK
            } else {
                w - BLOCK
            };
        }
    }

    /// A row shorter than [`BLOCK`]: copied into a padded block (the padding decodes to values
    /// that are dropped).
    fn decode_short_row<P: Sample, const N: usize>(
        &self,
        scratch: &mut DecodeScratch<A>,
        rows: &[&[P]],
        out: RowOut<'_>,
    ) -> Result<(), DecodeError> {
        let n = out.phase.len();
        let first = rows
            .first()
            .and_then(|r| r.first())
            .copied()
            .ok_or(DecodeError::Length)?;
        let mut padded = [[first; BLOCK]; MAX_IMAGES];
        let mut refs: [&[P]; MAX_IMAGES] = [&[]; MAX_IMAGES];
        for ((p, r), slot) in padded.iter_mut().zip(rows).zip(refs.iter_mut()) {
            p[..n].copy_from_slice(r);
            *slot = &p[..];
        }
        let (mut ph, mut mo, mut dc) = ([0.0f32; BLOCK], [0.0f32; BLOCK], [0.0f32; BLOCK]);
        let mut va = [0u8; BLOCK];
        let o = BlockOut {
            phase: &mut ph,
            modulation: &mut mo,
            dc: &mut dc,
            validity: &mut va,
        };
        self.decode_block::<P, N>(&mut scratch.0, &refs[..rows.len()], 0, o)?;
        out.phase.copy_from_slice(&ph[..n]);
        out.modulation.copy_from_slice(&mo[..n]);
        out.dc.copy_from_slice(&dc[..n]);
        out.validity.copy_from_slice(&va[..n]);
        Ok(())
    }

    /// Decode the block of pixels `start..start + BLOCK` of every row.
    ///
    /// The largest sample of every pixel first (saturation is tested once on it: `v ≥ t` for
    /// some sample ⇔ `max v ≥ t`); pass 1 per level, DC level first, straight from the level's
    /// image rows ([`Self::level_from_rows`]); pass 2, the unwrapping and validity
    /// ([`Self::unwrap_block`]).
    #[inline(always)]
    fn decode_block<P: Sample, const N: usize>(
        &self,
        blk: &mut Block<A>,
        rows: &[&[P]],
        start: usize,
        out: BlockOut<'_>,
    ) -> Result<(), DecodeError> {
        let peak = match rows.len() {
            8 => peak_of::<P, 8>(rows, start)?,
            12 => peak_of::<P, 12>(rows, start)?,
            _ => {
                let r = start..start + BLOCK;
                let mut peak: [P; BLOCK] = *block(rows.first().copied().unwrap_or(&[]), r.clone())?;
                for row in rows.iter().skip(1) {
                    let row = block(row, r.clone())?;
                    for (p, v) in peak.iter_mut().zip(row) {
                        *p = v.max_of(*p);
                    }
                }
                peak
            }
        };
        match self.fused {
            FUSED_PAIRS if N == 1 => {
                self.fused_rows::<P, KIND_PAIR_UNIT, 1>(rows, start, blk, out.modulation)?
            }
            FUSED_QUADS if N == 1 => {
                self.fused_rows::<P, KIND_QUAD_EXACT, 1>(rows, start, blk, out.modulation)?
            }
            FUSED_PAIRS => {
                self.fused_rows::<P, KIND_PAIR_UNIT, FUSED_LANES>(rows, start, blk, out.modulation)?
            }
            FUSED_QUADS => self.fused_rows::<P, KIND_QUAD_EXACT, FUSED_LANES>(
                rows,
                start,
                blk,
                out.modulation,
            )?,
            _ => {
                blk.dc = [A::ZERO; BLOCK];
                for k in 0..self.n_levels {
                    let l = self.level_order[k] as usize;
                    self.level_from_rows(l, rows, start, blk, out.modulation)?;
                }
            }
        }
        let sat = self.limits.saturation;
        self.unwrap_block::<P, N>(blk, &peak, |p| A::saturated(A::input(p), sat), out);
        Ok(())
    }

    /// Pass 1 of the row driver for level `l`: its S and C straight from its images' rows
    /// (the block at `start`), then as [`Self::polar_into`]. For the DC level also A, into the
    /// block.
    ///
    /// The sums are those of [`Self::accumulate`] bit for bit: the same products added in the same
    /// (image) order from +0, where a zero coefficient adds ±0, which leaves a sum that is never
    /// −0 unchanged (the accumulate path skips those products).
    #[inline(always)]
    fn level_from_rows<P: Sample>(
        &self,
        l: usize,
        rows: &[&[P]],
        start: usize,
        blk: &mut Block<A>,
        modulation: &mut [f32; BLOCK],
    ) -> Result<(), DecodeError> {
        let li = self.level_images.get(l).ok_or(DecodeError::Sequence)?;
        let is_dc = self.dc_level == Some(l as u8);
        let fine = l + 1 == self.n_levels;
        let range = start..start + BLOCK;
        let row_of = |k: u8| {
            rows.get(k as usize)
                .ok_or(DecodeError::ImageCount)
                .and_then(|row| block(row, range.clone()))
        };
        macro_rules! fixed_n {
            ($n:literal, $k:expr) => {{
                let mut r: [&[P; BLOCK]; $n] = [row_of(li.idx[0])?; $n];
                for (slot, &k) in r.iter_mut().zip(&li.idx[..$n]) {
                    *slot = row_of(k)?;
                }
                match (is_dc, fine) {
                    (false, false) => {
                        self.level_rows::<P, $n, $k, false, false>(l, &r, blk, modulation)
                    }
                    (false, true) => {
                        self.level_rows::<P, $n, $k, false, true>(l, &r, blk, modulation)
                    }
                    (true, false) => {
                        self.level_rows::<P, $n, $k, true, false>(l, &r, blk, modulation)
                    }
                    (true, true) => {
                        self.level_rows::<P, $n, $k, true, true>(l, &r, blk, modulation)
                    }
                }
            }};
        }
        match (li.n, li.kind) {
            (2, KIND_PAIR_UNIT) => fixed_n!(2, KIND_PAIR_UNIT),
            (2, KIND_PAIR) => fixed_n!(2, KIND_PAIR),
            (2, _) => fixed_n!(2, KIND_GENERIC),
            (3, _) => fixed_n!(3, KIND_GENERIC),
            (4, KIND_QUAD_EXACT) => fixed_n!(4, KIND_QUAD_EXACT),
            (4, KIND_QUAD) => fixed_n!(4, KIND_QUAD),
            (4, _) => fixed_n!(4, KIND_GENERIC),
            _ => {
                // Any other number of images: fold them one by one into S and C planes (and A),
                // in image order from +0, then the same polar pass as the frame-sequential path.
                let mut sp = [A::ZERO; BLOCK];
                let mut cp = [A::ZERO; BLOCK];
                for &k in &li.idx[..li.n as usize] {
                    let coef = self.images.get(k as usize).ok_or(DecodeError::Sequence)?;
                    let row = row_of(k)?;
                    for i in 0..BLOCK {
                        let v = A::input(row[i]);
                        sp[i] = A::mac(sp[i], coef.a, v);
                        cp[i] = A::mac(cp[i], coef.b, v);
                        if is_dc {
                            blk.dc[i] = A::mac(blk.dc[i], coef.w, v);
                        }
                    }
                }
                self.polar_into(l, &sp, &cp, blk, modulation);
            }
        }
        Ok(())
    }

    /// [`Self::level_from_rows`] for a level of `N` images: one loop over the block, every sum
    /// in registers.
    #[inline(always)]
    fn level_rows<P: Sample, const N: usize, const KIND: u8, const DC: bool, const FINE: bool>(
        &self,
        l: usize,
        rows: &[&[P; BLOCK]; N],
        blk: &mut Block<A>,
        mo: &mut [f32; BLOCK],
    ) {
        let (mut ka, mut kb, mut kw) = ([A::COEF_ZERO; N], [A::COEF_ZERO; N], [A::COEF_ZERO; N]);
        for j in 0..N {
            let k = self.level_images[l].idx[j] as usize;
            if let Some(c) = self.images.get(k) {
                (ka[j], kb[j], kw[j]) = (c.a, c.b, c.w);
            }
        }
        let (ad, bd, fmt) = (self.a_dc[l], self.b_dc[l], &self.format);
        if KIND == KIND_PAIR_UNIT || KIND == KIND_QUAD_EXACT {
            return self.level_rows_exact::<P, N, KIND, DC, FINE>(
                l,
                rows,
                (ka[0], kb[1 % N], kw[0]),
                blk,
                mo,
            );
        }
        let Block { dc, wrapped, mag } = blk;
        let (w, mag) = (&mut wrapped[l], &mut mag[l]);
        for i in 0..BLOCK {
            let (mut s, mut c, mut a) = (A::ZERO, A::ZERO, A::ZERO);
            for j in 0..N {
                let v = A::input(rows[j][i]);
                // The kinds' zero products are skipped (known at compile time).
                let (sj, cj) = if KIND == KIND_GENERIC {
                    (true, true)
                } else {
                    (j % 2 == 0, j % 2 == 1)
                };
                if sj {
                    s = A::mac(s, ka[j], v);
                }
                if cj {
                    c = A::mac(c, kb[j], v);
                }
                if DC {
                    a = A::mac(a, kw[j], v);
                }
            }
            if DC {
                dc[i] = a;
            } else {
                a = dc[i];
            }
            let (s, c) = if KIND == KIND_QUAD {
                (s, c)
            } else {
                A::level_sc(s, c, ad, bd, a, fmt)
            };
            if FINE {
                let (p, b2, b) = A::polar_fine(s, c, fmt);
                (w[i], mag[i], mo[i]) = (p, b2, b);
            } else {
                (w[i], mag[i]) = A::polar_coarse(s, c);
            }
        }
    }

    /// [`Self::level_rows`] for the regrouped kinds [`KIND_PAIR_UNIT`] and [`KIND_QUAD_EXACT`]
    /// (`k` = a₀, b₁, w₀): the same bits with fewer operations.
    #[inline(always)]
    fn level_rows_exact<
        P: Sample,
        const N: usize,
        const KIND: u8,
        const DC: bool,
        const FINE: bool,
    >(
        &self,
        l: usize,
        rows: &[&[P; BLOCK]; N],
        (ka, kb, kw): (A::Coef, A::Coef, A::Coef),
        blk: &mut Block<A>,
        mo: &mut [f32; BLOCK],
    ) {
        let fmt = &self.format;
        let Block { dc, wrapped, mag } = blk;
        let (w, mag) = (&mut wrapped[l], &mut mag[l]);
        let (r0, r1, r2, r3) = (rows[0], rows[1 % N], rows[2 % N], rows[3 % N]);
        for i in 0..BLOCK {
            let (v0, v1) = (A::input(r0[i]), A::input(r1[i]));
            let (s, c) = if KIND == KIND_PAIR_UNIT {
                // S = 1·I₀ − 1·A, C = 1·I₁ − 1·A (not the DC level: its coefficients are zero).
                (A::in_minus_acc(v0, dc[i]), A::in_minus_acc(v1, dc[i]))
            } else {
                let (v2, v3) = (A::input(r2[i]), A::input(r3[i]));
                // k = 0.25, 0.5, 0.5 (`level_kind`): positive.
                if DC {
                    dc[i] =
                        A::regrouped_product(kw, A::in_add(A::in_add(A::in_add(v0, v1), v2), v3));
                }
                (
                    A::regrouped_product(ka, A::in_sub(v0, v2)),
                    A::regrouped_product(kb, A::in_sub(v1, v3)),
                )
            };
            if FINE {
                let (p, b2, b) = A::polar_fine(s, c, fmt);
                (w[i], mag[i], mo[i]) = (p, b2, b);
            } else {
                (w[i], mag[i]) = A::polar_coarse(s, c);
            }
        }
    }

    /// Pass 1 of the row driver for the sets of [`Decoder::fused`]: every level in one loop over
    /// the block. The finest level is the DC level of four images ([`KIND_QUAD_EXACT`]); the
    /// coarser levels, two of them, are all of kind `K` ([`KIND_PAIR_UNIT`]: the paper's
    /// 8-pattern set, or [`KIND_QUAD_EXACT`]: the 12-pattern set).
    ///
    /// Each pixel's operations are those of [`Self::level_rows_exact`] for each level, in the
    /// same order: the same bits. What changes is the order: each iteration takes pixel `j` of
    /// each of the block's [`FUSED_LANES`] parts, and the arctangents of the three levels of
    /// those pixels are written step by step side by side ([`Arith::polar_levels3_lanes`]).
    /// An arctangent is a long dependency chain (division, polynomial, folding); one loop per
    /// level ran at the latency of one chain, twelve independent chains keep the core busy.
    #[inline(always)]
    fn fused_rows<P: Sample, const K: u8, const NL: usize>(
        &self,
        rows: &[&[P]],
        start: usize,
        blk: &mut Block<A>,
        mo: &mut [f32; BLOCK],
    ) -> Result<(), DecodeError> {
        let range = start..start + BLOCK;
        let fmt = &self.format;
        // Levels: the finest (the DC level, level 2 of the three), then the two coarser ones.
        let lv = [2, 0, 1];
        let mut r = [[&[] as &[P]; 4]; 3];
        let mut k = [(A::COEF_ZERO, A::COEF_ZERO, A::COEF_ZERO); 3];
        for (slot, (kslot, &l)) in r.iter_mut().zip(k.iter_mut().zip(&lv)) {
            let li = self.level_images.get(l).ok_or(DecodeError::Sequence)?;
            for (j, row) in slot.iter_mut().enumerate() {
                let img = li.idx[j % li.n.max(1) as usize] as usize;
                *row = rows
                    .get(img)
                    .ok_or(DecodeError::ImageCount)?
                    .get(range.clone())
                    .ok_or(DecodeError::Length)?;
            }
            let coef = |j: usize| {
                self.images
                    .get(li.idx[j] as usize)
                    .ok_or(DecodeError::Sequence)
            };
            *kslot = (coef(0)?.a, coef(1)?.b, coef(0)?.w);
        }
        let rb = |l: usize, j: usize| -> Result<&[P; BLOCK], DecodeError> {
            r[l][j].try_into().map_err(|_| DecodeError::Length)
        };
        let f = [rb(0, 0)?, rb(0, 1)?, rb(0, 2)?, rb(0, 3)?];
        let c1 = [rb(1, 0)?, rb(1, 1)?, rb(1, 2)?, rb(1, 3)?];
        let c2 = [rb(2, 0)?, rb(2, 1)?, rb(2, 2)?, rb(2, 3)?];
        let Block { dc, wrapped, mag } = blk;
        let [w0, w1, w2, ..] = wrapped;
        let [m0, m1, m2, ..] = mag;
        let (wf, mf) = (w2, m2);
        let ((kaf, kbf, kwf), k1, k2) = (k[0], k[1], k[2]);
        // S and C of a coarser level (not the DC level: a pair's coefficients are ±1, a quad's
        // regrouped with its positive ½).
        #[inline(always)]
        fn coarse<A: Arith, P: Sample, const K: u8>(
            r: &[&[P; BLOCK]; 4],
            i: usize,
            a: A::Acc,
            (ka, kb, _): (A::Coef, A::Coef, A::Coef),
        ) -> (A::Acc, A::Acc) {
            let (v0, v1) = (A::input(r[0][i]), A::input(r[1][i]));
            if K == KIND_PAIR_UNIT {
                (A::in_minus_acc(v0, a), A::in_minus_acc(v1, a))
            } else {
                let (v2, v3) = (A::input(r[2][i]), A::input(r[3][i]));
                (
                    A::regrouped_product(ka, A::in_sub(v0, v2)),
                    A::regrouped_product(kb, A::in_sub(v1, v3)),
                )
            }
        }
        if NL == 1 {
            // One pixel at a time (a scalar core): the levels' polar calls one after the other.
            // Written out rather than through a closure shared with the lanes below: the closure
            // cost the Cortex-M4F 33 instructions per pixel (385 against 352).
            for i in 0..BLOCK {
                let (v0, v1, v2, v3) = (
                    A::input(f[0][i]),
                    A::input(f[1][i]),
                    A::input(f[2][i]),
                    A::input(f[3][i]),
                );
                let a = A::regrouped_product(kwf, A::in_add(A::in_add(A::in_add(v0, v1), v2), v3));
                dc[i] = a;
                let (s, c) = (
                    A::regrouped_product(kaf, A::in_sub(v0, v2)),
                    A::regrouped_product(kbf, A::in_sub(v1, v3)),
                );
                (wf[i], mf[i], mo[i]) = A::polar_fine(s, c, fmt);
                let (s, c) = coarse::<A, P, K>(&c1, i, a, k1);
                (w0[i], m0[i]) = A::polar_coarse(s, c);
                let (s, c) = coarse::<A, P, K>(&c2, i, a, k2);
                (w1[i], m1[i]) = A::polar_coarse(s, c);
            }
            return Ok(());
        }
        for j in 0..BLOCK / NL {
            let ix: [usize; NL] = core::array::from_fn(|k| j + k * (BLOCK / NL));
            let (mut ff, mut g, mut h) = (
                [(A::ZERO, A::ZERO); NL],
                [(A::ZERO, A::ZERO); NL],
                [(A::ZERO, A::ZERO); NL],
            );
            for k in 0..NL {
                let i = ix[k];
                let (v0, v1, v2, v3) = (
                    A::input(f[0][i]),
                    A::input(f[1][i]),
                    A::input(f[2][i]),
                    A::input(f[3][i]),
                );
                let a = A::regrouped_product(kwf, A::in_add(A::in_add(A::in_add(v0, v1), v2), v3));
                dc[i] = a;
                ff[k] = (
                    A::regrouped_product(kaf, A::in_sub(v0, v2)),
                    A::regrouped_product(kbf, A::in_sub(v1, v3)),
                );
                g[k] = coarse::<A, P, K>(&c1, i, a, k1);
                h[k] = coarse::<A, P, K>(&c2, i, a, k2);
            }
            let r = A::polar_levels3_lanes(ff, g, h, fmt);
            for k in 0..NL {
                let i = ix[k];
                let (pf, p1, p2) = r[k];
                (wf[i], mf[i], mo[i]) = pf;
                (w0[i], m0[i]) = p1;
                (w1[i], m1[i]) = p2;
            }
        }
        Ok(())
    }

    /// Fold the samples of image `image` (set order) into the state (the first half of the
    /// kernel). The state must have been zeroed before the first image.
    #[inline(always)]
    pub fn accumulate<P: Sample>(
        &self,
        image: usize,
        row: &[P],
        st: &mut State<'_, A::Acc>,
    ) -> Result<(), DecodeError> {
        self.accumulate_modes::<P, true, true>(image, row, st)
    }

    /// [`Self::accumulate`] with the plane modes of the image. `ZEROED`: the state was zeroed, so
    /// a first contribution may be added (the bits of `0 + k·v` either way); `FLAGS`: update the
    /// saturation flags.
    #[inline(always)]
    fn accumulate_modes<P: Sample, const ZEROED: bool, const FLAGS: bool>(
        &self,
        image: usize,
        row: &[P],
        st: &mut State<'_, A::Acc>,
    ) -> Result<(), DecodeError> {
        let coef = *self
            .images
            .get(image)
            .filter(|_| image < self.n_images)
            .ok_or(DecodeError::Sequence)?;
        let n = row.len();
        let l = coef.level as usize;
        let (dc, flags) = (&mut st.dc[..], &mut st.flags[..]);
        let (s, c) = match (st.s.get_mut(l), st.c.get_mut(l)) {
            (Some(s), Some(c)) => (&mut s[..], &mut c[..]),
            _ => return Err(DecodeError::Sequence),
        };
        if dc.len() != n || s.len() != n || c.len() != n || (FLAGS && flags.len() != n) {
            return Err(DecodeError::Length);
        }
        let k = Coefs {
            a: coef.a,
            b: coef.b,
            w: coef.w,
            sat: self.limits.saturation,
        };
        let m = |x: u8| if ZEROED && x == INIT { ACC } else { x };
        let [ms, mc, mw] = coef.mode;
        // One loop per combination of plane modes (chosen per image by the plan, never by the
        // data), each a straight-line body over zipped slices that vectorizes.
        macro_rules! go {
            ($($a:literal $b:literal $c:literal),*) => {
                match (m(ms), m(mc), m(mw)) {
                    $(($a, $b, $c) => acc_loop::<A, P, $a, $b, $c, FLAGS>(row, s, c, dc, flags, &k),)*
                    _ => {}
                }
            };
        }
        go!(0 0 0, 0 0 1, 0 0 2, 0 1 0, 0 1 1, 0 1 2, 0 2 0, 0 2 1, 0 2 2,
            1 0 0, 1 0 1, 1 0 2, 1 1 0, 1 1 1, 1 1 2, 1 2 0, 1 2 1, 1 2 2,
            2 0 0, 2 0 1, 2 0 2, 2 1 0, 2 1 1, 2 1 2, 2 2 0, 2 2 1, 2 2 2);
        Ok(())
    }

    /// Turn a complete state into outputs (the second half of the kernel): S and C per level,
    /// wrapped phase by the backend's `atan2` ([`crate::math::atan2`] by default), modulation,
    /// hierarchical unwrapping, validity.
    ///
    /// Always inlined (as are [`Self::decode_row`] and [`Self::accumulate`]) so that a caller
    /// compiled for a wider instruction set (the host's AVX2 batch path) vectorizes the same
    /// operations wider; IEEE arithmetic without contraction gives the same bits.
    #[inline(always)]
    pub fn finish(&self, st: &State<'_, A::Acc>, out: RowOut<'_>) -> Result<(), DecodeError> {
        let flags = &st.flags[..];
        if flags.len() != st.dc.len() {
            return Err(DecodeError::Length);
        }
        self.finish_levels(st, flags, |f| f & 1 != 0, out)
    }

    /// [`Self::finish`] with the saturation test of pixel `i` given by `saturated(sat[i])`,
    /// compiled once per level count.
    #[inline(always)]
    fn finish_levels<T: Copy>(
        &self,
        st: &State<'_, A::Acc>,
        sat: &[T],
        saturated: impl Fn(T) -> bool,
        out: RowOut<'_>,
    ) -> Result<(), DecodeError> {
        let n = st.dc.len();
        if !out.len_ok(n)
            || sat.len() != n
            || (0..self.n_levels).any(|l| st.s[l].len() != n || st.c[l].len() != n)
        {
            return Err(DecodeError::Length);
        }
        if n == 0 {
            return Ok(());
        }
        let mut blk = Block::<A>::new();
        if n < BLOCK {
            // Short: padded copies of the state (the padding's results are dropped).
            let pad = |p: &[A::Acc]| {
                let mut b = [A::ZERO; BLOCK];
                b[..n].copy_from_slice(p);
                b
            };
            let mut sat_b = [sat[0]; BLOCK];
            sat_b[..n].copy_from_slice(sat);
            blk.dc = pad(st.dc);
            let (mut ph, mut mo, mut dc) = ([0.0f32; BLOCK], [0.0f32; BLOCK], [0.0f32; BLOCK]);
            let mut va = [0u8; BLOCK];
            for l in 0..self.n_levels {
                self.polar_into(l, &pad(st.s[l]), &pad(st.c[l]), &mut blk, &mut mo);
            }
            self.unwrap_block::<T, 1>(
                &blk,
                &sat_b,
                &saturated,
                BlockOut {
                    phase: &mut ph,
                    modulation: &mut mo,
                    dc: &mut dc,
                    validity: &mut va,
                },
            );
            out.phase.copy_from_slice(&ph[..n]);
            out.modulation.copy_from_slice(&mo[..n]);
            out.dc.copy_from_slice(&dc[..n]);
            out.validity.copy_from_slice(&va[..n]);
            return Ok(());
        }
        // Whole blocks, the last one overlapping (see `decode_row_with`).
        let mut start = 0;
        loop {
            let r = start..start + BLOCK;
            blk.dc = *block(st.dc, r.clone())?;
            let mo = block_mut(out.modulation, r.clone())?;
            for l in 0..self.n_levels {
                self.polar_into(
                    l,
                    block(st.s[l], r.clone())?,
                    block(st.c[l], r.clone())?,
                    &mut blk,
                    mo,
                );
            }
            let o = BlockOut {
                phase: block_mut(out.phase, r.clone())?,
                modulation: mo,
                dc: block_mut(out.dc, r.clone())?,
                validity: block_mut(out.validity, r.clone())?,
            };
            self.unwrap_block::<T, 1>(&blk, block(sat, r)?, &saturated, o);
            if start + BLOCK == n {
                return Ok(());
            }
            start = if n - (start + BLOCK) >= BLOCK {
                start + BLOCK
            } else {
                n - BLOCK
            };
        }
    }

    /// Pass 1 for level `l` from its S and C accumulators and the block's A: S and C (eq 11 for
    /// the 2-shift levels), the wrapped phase and the modulation measure. The coarser levels only
    /// choose fringe orders, so they take the backend's cheaper arctangent
    /// ([`Arith::polar_coarse`]); the finest level, whose phase is the output, the accurate one,
    /// and it writes B into `modulation`.
    #[inline(always)]
    fn polar_into(
        &self,
        l: usize,
        s: &[A::Acc; BLOCK],
        c: &[A::Acc; BLOCK],
        blk: &mut Block<A>,
        modulation: &mut [f32; BLOCK],
    ) {
        if l + 1 < self.n_levels {
            self.polar_from_planes::<false>(l, s, c, blk, modulation);
        } else {
            self.polar_from_planes::<true>(l, s, c, blk, modulation);
        }
    }

    /// [`Self::polar_into`] for a coarser (`FINE = false`) or the finest level.
    #[inline(always)]
    fn polar_from_planes<const FINE: bool>(
        &self,
        l: usize,
        s: &[A::Acc; BLOCK],
        c: &[A::Acc; BLOCK],
        blk: &mut Block<A>,
        mo: &mut [f32; BLOCK],
    ) {
        let (ad, bd, fmt) = (self.a_dc[l], self.b_dc[l], &self.format);
        let Block { dc, wrapped, mag } = blk;
        let (w, mag) = (&mut wrapped[l], &mut mag[l]);
        for i in 0..BLOCK {
            let (s, c) = A::level_sc(s[i], c[i], ad, bd, dc[i], fmt);
            if FINE {
                let (p, b2, b) = A::polar_fine(s, c, fmt);
                (w[i], mag[i], mo[i]) = (p, b2, b);
            } else {
                (w[i], mag[i]) = A::polar_coarse(s, c);
            }
        }
    }

    /// Pass 2, compiled once per level count: both unwrapping steps (eqs 12-13), the range test,
    /// the validity selects and the phase, DC and validity outputs of one block. Pixel `i` is
    /// saturated if `saturated(sat[i])`.
    ///
    /// Splitting the finishing work into these two passes keeps each loop body short, with
    /// independent iterations an out-of-order core overlaps; one fused body (arctangents →
    /// unwrapping → validity, ~300 instructions per vector) ran at the latency of its chain.
    #[inline(always)]
    fn unwrap_block<T: Copy, const N: usize>(
        &self,
        blk: &Block<A>,
        sat: &[T; BLOCK],
        saturated: impl Fn(T) -> bool,
        out: BlockOut<'_>,
    ) {
        match self.n_levels {
            1 => self.unwrap_levels::<1, T, N>(blk, sat, saturated, out),
            2 => self.unwrap_levels::<2, T, N>(blk, sat, saturated, out),
            3 => self.unwrap_levels::<3, T, N>(blk, sat, saturated, out),
            4 => self.unwrap_levels::<4, T, N>(blk, sat, saturated, out),
            5 => self.unwrap_levels::<5, T, N>(blk, sat, saturated, out),
            _ => self.unwrap_levels::<6, T, N>(blk, sat, saturated, out),
        }
    }

    /// [`Self::unwrap_block`] for `L` levels, pixel `j` of each of the block's `N` parts side by
    /// side ([`Self::finish_lanes`]).
    // Indices, not iterators, over the levels: the iterator form left this loop unvectorized
    // (5× slower with AVX-512).
    #[allow(clippy::needless_range_loop)]
    #[inline(always)]
    fn unwrap_levels<const L: usize, T: Copy, const N: usize>(
        &self,
        blk: &Block<A>,
        sat: &[T; BLOCK],
        saturated: impl Fn(T) -> bool,
        out: BlockOut<'_>,
    ) {
        let fmt = &self.format;
        let (wrapped, mag, a) = (&blk.wrapped, &blk.mag, &blk.dc);
        let BlockOut {
            phase: po,
            dc: ao,
            validity: vo,
            ..
        } = out;
        const { assert!(N > 0 && BLOCK.is_multiple_of(N)) };
        for j in 0..BLOCK / N {
            let ix: [usize; N] = core::array::from_fn(|k| j + k * (BLOCK / N));
            let av: [A::Acc; N] = core::array::from_fn(|k| a[ix[k]]);
            let w: [[A::Phase; L]; N] =
                core::array::from_fn(|k| core::array::from_fn(|l| wrapped[l][ix[k]]));
            let m: [[A::Mag; L]; N] =
                core::array::from_fn(|k| core::array::from_fn(|l| mag[l][ix[k]]));
            let st: [bool; N] = core::array::from_fn(|k| saturated(sat[ix[k]]));
            let r = self.finish_lanes(&w, &m, &av, &st);
            for k in 0..N {
                (po[ix[k]], vo[ix[k]]) = r[k];
                ao[ix[k]] = A::dc_out(av[k], fmt);
            }
        }
    }

    /// Pass 2 of `N` pixels of `L` levels, every step written for the `N` side by side (each
    /// pixel's operations are the same whatever `N`): both unwrapping steps (eqs 12-13) from the
    /// wrapped phases `w` (coarsest first), the range test, the smallest modulation measure of
    /// `m`, the dark test on `a` and the validity code (`saturated` given). Returns the phase
    /// output and the code of each pixel.
    #[allow(clippy::needless_range_loop)]
    #[inline(always)]
    fn finish_lanes<const L: usize, const N: usize>(
        &self,
        w: &[[A::Phase; L]; N],
        m: &[[A::Mag; L]; N],
        a: &[A::Acc; N],
        saturated: &[bool; N],
    ) -> [(f32, u8); N] {
        use core::array::from_fn as lanes;
        let lim = &self.limits;
        let mut phi: [A::Phase; N] = lanes(|k| w[k][0]);
        let out_of_range: [bool; N] = lanes(|k| !A::in_range(phi[k], lim.coarse_lo, lim.coarse_hi));
        let mut inconsistent = [false; N];
        for l in 1..L {
            let st: [(A::Phase, A::Phase); N] =
                lanes(|k| A::unwrap(phi[k], self.ratio[l], w[k][l]));
            for k in 0..N {
                inconsistent[k] |= !A::consistent(st[k].1, lim.unwrap_tolerance);
                phi[k] = st[k].0;
            }
        }
        let mut bm = [A::MAG_MAX; N];
        for l in 0..L {
            for k in 0..N {
                bm[k] = A::min_mag(m[k][l], bm[k]);
            }
        }
        // Priority (highest last): unwrap inconsistent, out of range, low modulation, dark,
        // saturated. Masks, not branches or a chain of selects (which LLVM may fold into
        // branches), so the loop vectorizes.
        let pick = |cond: bool, code: Validity, v: u32| {
            let m = (cond as u32).wrapping_neg();
            (v & !m) | (code as u32 & m)
        };
        lanes(|k| {
            let mut v = Validity::Valid as u32;
            v = pick(inconsistent[k], Validity::UnwrapInconsistent, v);
            v = pick(out_of_range[k], Validity::PhaseOutOfRange, v);
            v = pick(
                !A::mag_at_least(bm[k], lim.min_modulation),
                Validity::LowModulation,
                v,
            );
            v = pick(!A::dc_at_least(a[k], lim.dark), Validity::Dark, v);
            v = pick(saturated[k], Validity::Saturated, v);
            (
                if v == 0 {
                    A::phase_out(phi[k])
                } else {
                    CANONICAL_NAN
                },
                v as u8,
            )
        })
    }

    /// Wrapped phase φ^(k) ∈ [−π, π] (eqs 9, 11) and modulation B of one level from a complete
    /// state, for diagnostics, golden vectors and noise studies. Same operations as [`Self::finish`].
    pub fn finish_level(
        &self,
        st: &State<'_, A::Acc>,
        level: usize,
        wrapped: &mut [f32],
        modulation: &mut [f32],
    ) -> Result<(), DecodeError> {
        let n = st.dc.len();
        if level >= self.n_levels {
            return Err(DecodeError::Sequence);
        }
        if wrapped.len() != n
            || modulation.len() != n
            || st.s[level].len() != n
            || st.c[level].len() != n
        {
            return Err(DecodeError::Length);
        }
        let (ad, bd, fmt) = (self.a_dc[level], self.b_dc[level], &self.format);
        for i in 0..n {
            let (s, c) = A::level_sc(st.s[level][i], st.c[level][i], ad, bd, st.dc[i], fmt);
            let (w, _, b) = A::polar_fine(s, c, fmt);
            wrapped[i] = A::phase_out(w);
            modulation[i] = b;
        }
        Ok(())
    }

    /// Row API for one level: wrapped phase and modulation of `level` from the rows of every image
    /// (set order). See [`Self::finish_level`].
    pub fn decode_row_level<P: Sample>(
        &self,
        rows: &[&[P]],
        level: usize,
        wrapped: &mut [f32],
        modulation: &mut [f32],
    ) -> Result<(), DecodeError> {
        if rows.len() != self.n_images {
            return Err(DecodeError::ImageCount);
        }
        let w = wrapped.len();
        if modulation.len() != w || rows.iter().any(|r| r.len() != w) {
            return Err(DecodeError::Length);
        }
        let mut start = 0;
        while start < w {
            let end = if w - start > BLOCK { start + BLOCK } else { w };
            let n = end - start;
            let mut st_dc = [A::ZERO; BLOCK];
            let mut st_s = [[A::ZERO; BLOCK]; MAX_LEVELS];
            let mut st_c = [[A::ZERO; BLOCK]; MAX_LEVELS];
            let mut flags = [0u8; BLOCK];
            let mut st = block_state(&mut st_dc, &mut st_s, &mut st_c, &mut flags, n);
            for (i, r) in rows.iter().enumerate() {
                self.accumulate(i, &r[start..end], &mut st)?;
            }
            self.finish_level(
                &st,
                level,
                &mut wrapped[start..end],
                &mut modulation[start..end],
            )?;
            start = end;
        }
        Ok(())
    }
}

/// Scratch memory of the row decoder ([`Decoder::decode_row_with`]): one block of A, the wrapped
/// phase and the modulation measure of every level (about 3.3 KiB with f32 backends). Its
/// contents never carry over from one row to the next.
pub struct DecodeScratch<A: Arith = F32Accurate>(Block<A>);

impl<A: Arith> DecodeScratch<A> {
    /// A cleared scratch.
    pub fn new() -> Self {
        DecodeScratch(Block::new())
    }
}

impl<A: Arith> Default for DecodeScratch<A> {
    fn default() -> Self {
        Self::new()
    }
}

/// The per-block scratch of the finishing passes: A, the wrapped phase and the modulation
/// measure of every level, for one block of [`BLOCK`] pixels.
struct Block<A: Arith> {
    dc: [A::Acc; BLOCK],
    wrapped: [[A::Phase; BLOCK]; MAX_LEVELS],
    /// The modulation measure of every level (the smallest is taken in pass 2: a running minimum
    /// stored back per level becomes a masked store, which is slow on some x86 cores).
    mag: [[A::Mag; BLOCK]; MAX_LEVELS],
}

impl<A: Arith> Block<A> {
    fn new() -> Self {
        Block {
            dc: [A::ZERO; BLOCK],
            wrapped: [[A::Phase::default(); BLOCK]; MAX_LEVELS],
            mag: [[A::Mag::default(); BLOCK]; MAX_LEVELS],
        }
    }
}

/// The outputs of one block.
struct BlockOut<'a> {
    phase: &'a mut [f32; BLOCK],
    modulation: &'a mut [f32; BLOCK],
    dc: &'a mut [f32; BLOCK],
    validity: &'a mut [u8; BLOCK],
}

/// The block `range` (of length [`BLOCK`]) of a row, as an array.
#[inline(always)]
fn block<T>(row: &[T], range: core::ops::Range<usize>) -> Result<&[T; BLOCK], DecodeError> {
    row.get(range)
        .and_then(|r| r.try_into().ok())
        .ok_or(DecodeError::Length)
}

/// [`block`], mutable.
#[inline(always)]
fn block_mut<T>(
    row: &mut [T],
    range: core::ops::Range<usize>,
) -> Result<&mut [T; BLOCK], DecodeError> {
    row.get_mut(range)
        .and_then(|r| r.try_into().ok())
        .ok_or(DecodeError::Length)
}

/// The largest sample of every pixel of the block at `start` of `N` image rows (the common set
/// sizes, 8 and 12): every row read side by side, the running maximum in registers. A fold row
/// by row stores and reloads the running maximum once per row. The maximum of integers does not
/// depend on the order: the bits of the fold.
#[inline(always)]
fn peak_of<P: Sample, const N: usize>(
    rows: &[&[P]],
    start: usize,
) -> Result<[P; BLOCK], DecodeError> {
    let r = start..start + BLOCK;
    let first = block(rows.first().copied().unwrap_or(&[]), r.clone())?;
    let mut b: [&[P; BLOCK]; N] = [first; N];
    if rows.len() != N {
        return Err(DecodeError::ImageCount);
    }
    for (slot, row) in b.iter_mut().zip(rows) {
        *slot = block(row, r.clone())?;
    }
    let mut peak = *first;
    for (i, p) in peak.iter_mut().enumerate() {
        let mut m = b[0][i];
        for row in &b[1..] {
            m = row[i].max_of(m);
        }
        *p = m;
    }
    Ok(peak)
}

/// The coefficients of one image and the saturation threshold, for [`acc_loop`].
struct Coefs<A: Arith> {
    a: A::Coef,
    b: A::Coef,
    w: A::Coef,
    sat: A::In,
}

/// Fold one image row into the S, C and DC planes with the plane modes `MS`, `MC`, `MW`
/// ([`SKIP`], [`INIT`], [`ACC`]), and into the saturation flags if `FLAGS`.
#[inline(always)]
fn acc_loop<A: Arith, P: Sample, const MS: u8, const MC: u8, const MW: u8, const FLAGS: bool>(
    row: &[P],
    s: &mut [A::Acc],
    c: &mut [A::Acc],
    dc: &mut [A::Acc],
    flags: &mut [u8],
    k: &Coefs<A>,
) {
    let n = row.len();
    let (s, c, dc) = (&mut s[..n], &mut c[..n], &mut dc[..n]);
    #[inline(always)]
    fn plane<A: Arith, const M: u8>(acc: &mut A::Acc, k: A::Coef, v: A::In) {
        if M == INIT {
            *acc = A::mac(A::ZERO, k, v);
        } else if M == ACC {
            *acc = A::mac(*acc, k, v);
        }
    }
    if FLAGS {
        let flags = &mut flags[..n];
        for i in 0..n {
            let v = A::input(row[i]);
            plane::<A, MS>(&mut s[i], k.a, v);
            plane::<A, MC>(&mut c[i], k.b, v);
            plane::<A, MW>(&mut dc[i], k.w, v);
            flags[i] |= A::saturated(v, k.sat) as u8;
        }
    } else {
        for i in 0..n {
            let v = A::input(row[i]);
            plane::<A, MS>(&mut s[i], k.a, v);
            plane::<A, MC>(&mut c[i], k.b, v);
            plane::<A, MW>(&mut dc[i], k.w, v);
        }
    }
}

/// A zeroed stack state for one block of `n ≤ BLOCK` pixels.
fn block_state<'a, T>(
    dc: &'a mut [T; BLOCK],
    s: &'a mut [[T; BLOCK]; MAX_LEVELS],
    c: &'a mut [[T; BLOCK]; MAX_LEVELS],
    flags: &'a mut [u8],
    n: usize,
) -> State<'a, T> {
    let [s0, s1, s2, s3, s4, s5] = s;
    let [c0, c1, c2, c3, c4, c5] = c;
    State {
        dc: &mut dc[..n],
        s: [
            &mut s0[..n],
            &mut s1[..n],
            &mut s2[..n],
            &mut s3[..n],
            &mut s4[..n],
            &mut s5[..n],
        ],
        c: [
            &mut c0[..n],
            &mut c1[..n],
            &mut c2[..n],
            &mut c3[..n],
            &mut c4[..n],
            &mut c5[..n],
        ],
        flags: {
            let k = n.min(flags.len());
            &mut flags[..k]
        },
    }
}
