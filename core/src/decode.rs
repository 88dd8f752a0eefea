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
//! Decoding is split into `accumulate` (fold one image's samples into a per-pixel state) and
//! `finish` (state → phase, B, A, validity). The row API ([`Decoder::decode_row`]) runs both on a
//! small stack state; the frame-sequential API ([`crate::sequential`]) runs `accumulate` over whole
//! frames as they arrive into a caller buffer and `finish` at the end. The operations per pixel
//! are the same, in the same order, so both give the same bits.
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
        if self.to_f32() > other.to_f32() { self } else { other }
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
    if libm::fabs(x - q) < 1e-12 { q as f32 } else { x as f32 }
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
    let det = m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
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
        let floor = if 12.0 < 0.05 * full { 12.0 } else { 0.05 * full };
        let two_percent = 0.02 * full;
        DecodeConfig {
            dark_level: 0.02 * full,
            saturation_level: full,
            min_modulation: if two_percent > floor { two_percent } else { floor },
            unwrap_tolerance: 2.0 * core::f32::consts::PI / 3.0,
            range_tolerance: 0.15,
        }
    }

    fn is_sane(&self) -> bool {
        let all = [self.dark_level, self.saturation_level, self.min_modulation, self.unwrap_tolerance, self.range_tolerance];
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
            Self::Config => f.write_str("decode thresholds must be finite and non-negative, unwrap tolerance <= pi"),
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
}

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
        self.phase.len() == n && self.modulation.len() == n && self.dc.len() == n && self.validity.len() == n
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
const NO_ESTIMATOR: LevelEstimator = LevelEstimator { n: 0, a: [0.0; MAX_SHIFTS], b: [0.0; MAX_SHIFTS], w: [0.0; MAX_SHIFTS], a_dc: 0.0, b_dc: 0.0 };

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
        let plan = Plan { levels: &est[..n_levels], dc_level, ratios: &ratios[..n_levels], coarse_range: set.coarse_range(), config: &config };
        let format = A::format(&plan)?;
        let zero = ImageCoef { level: 0, a: A::COEF_ZERO, b: A::COEF_ZERO, w: A::COEF_ZERO, mode: [SKIP; 3] };
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
        };
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
            let w = if dc_level == Some(l) { c.w[s] } else { A::COEF_ZERO };
            let mut mode = [SKIP; 3];
            for (m, (k, plane)) in mode.iter_mut().zip([(c.a[s], 1 + 2 * l), (c.b[s], 2 + 2 * l), (w, 0)]) {
                if !A::is_zero(k) {
                    *m = if d.untouched[plane] { INIT } else { ACC };
                    d.untouched[plane] = false;
                }
            }
            d.images[k] = ImageCoef { level: id.level, a: c.a[s], b: c.b[s], w, mode };
        }
        Ok(d)
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
    /// Runs the kernel of [`Self::accumulate`] and [`Self::finish`] block by block on a stack
    /// state, with two shortcuts that leave every bit alone: a plane's first contribution is
    /// written as `0 + k·v` instead of being added to a zeroed plane, and saturation is tested once
    /// on the largest sample of the pixel (`v ≥ t` for some sample ⇔ `max v ≥ t`).
    #[inline(always)]
    pub fn decode_row<P: Sample>(&self, rows: &[&[P]], out: RowOut<'_>) -> Result<(), DecodeError> {
        if rows.len() != self.n_images {
            return Err(DecodeError::ImageCount);
        }
        let w = out.phase.len();
        if !out.len_ok(w) || rows.iter().any(|r| r.len() != w) {
            return Err(DecodeError::Length);
        }
        let RowOut { phase, modulation, dc, validity } = out;
        let sat = self.limits.saturation;
        // The block state, zeroed once per row: every plane an image contributes to is overwritten
        // by its first contribution ([`INIT`]), the others stay zero.
        let mut st_dc = [A::ZERO; BLOCK];
        let mut st_s = [[A::ZERO; BLOCK]; MAX_LEVELS];
        let mut st_c = [[A::ZERO; BLOCK]; MAX_LEVELS];
        let mut flags = [0u8; 0];
        let Some(&first) = rows.first().and_then(|r| r.first()) else {
            return Ok(());
        };
        let mut peak = [first; BLOCK];
        let mut start = 0;
        while start < w {
            let end = if w - start > BLOCK { start + BLOCK } else { w };
            let n = end - start;
            let mut st = block_state(&mut st_dc, &mut st_s, &mut st_c, &mut flags, n);
            // A loop over the decoder's image count (known at run time only), so that it is never
            // unrolled into copies of the per-image loops even when the caller's row count is
            // a constant (that left the finishing loop unvectorized in such callers).
            for i in 0..self.n_images {
                let r = rows.get(i).map(|r| &r[start..end]).ok_or(DecodeError::ImageCount)?;
                self.accumulate_modes::<P, false, false>(i, r, &mut st)?;
                if i == 0 {
                    peak[..n].copy_from_slice(r);
                } else {
                    for (p, v) in peak[..n].iter_mut().zip(r) {
                        *p = v.max_of(*p);
                    }
                }
            }
            let peak = &peak[..n];
            self.finish_levels(
                &st,
                |i| A::saturated(A::input(peak[i]), sat),
                RowOut {
                    phase: &mut phase[start..end],
                    modulation: &mut modulation[start..end],
                    dc: &mut dc[start..end],
                    validity: &mut validity[start..end],
                },
            )?;
            start = end;
        }
        Ok(())
    }

    /// Fold the samples of image `image` (set order) into the state (the first half of the
    /// kernel). The state must have been zeroed before the first image.
    #[inline(always)]
    pub fn accumulate<P: Sample>(&self, image: usize, row: &[P], st: &mut State<'_, A::Acc>) -> Result<(), DecodeError> {
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
        let coef = *self.images.get(image).filter(|_| image < self.n_images).ok_or(DecodeError::Sequence)?;
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
        let k = Coefs { a: coef.a, b: coef.b, w: coef.w, sat: self.limits.saturation };
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
        self.finish_levels(st, |i| flags[i] & 1 != 0, out)
    }

    /// [`Self::finish`] with the saturation test of pixel `i` given by `saturated(i)`: one pass over
    /// the pixels computing every level in registers, compiled once per level count.
    #[inline(always)]
    fn finish_levels(&self, st: &State<'_, A::Acc>, saturated: impl Fn(usize) -> bool, out: RowOut<'_>) -> Result<(), DecodeError> {
        let n = st.dc.len();
        if !out.len_ok(n) || (0..self.n_levels).any(|l| st.s[l].len() != n || st.c[l].len() != n) {
            return Err(DecodeError::Length);
        }
        match self.n_levels {
            1 => self.finish_fused::<1>(st, saturated, out),
            2 => self.finish_fused::<2>(st, saturated, out),
            3 => self.finish_fused::<3>(st, saturated, out),
            4 => self.finish_fused::<4>(st, saturated, out),
            5 => self.finish_fused::<5>(st, saturated, out),
            _ => self.finish_fused::<6>(st, saturated, out),
        }
        Ok(())
    }

    /// The finishing kernel for `L` levels (lengths checked by the caller).
    #[inline(always)]
    fn finish_fused<const L: usize>(&self, st: &State<'_, A::Acc>, saturated: impl Fn(usize) -> bool, out: RowOut<'_>) {
        let n = st.dc.len();
        let lim = &self.limits;
        let fmt = &self.format;
        let (min_b2, lo, hi) = (lim.min_modulation, lim.coarse_lo, lim.coarse_hi);
        let (tol, dark) = (lim.unwrap_tolerance, lim.dark);
        let a = &st.dc[..n];
        let s: [&[A::Acc]; L] = core::array::from_fn(|l| &st.s[l][..n]);
        let c: [&[A::Acc]; L] = core::array::from_fn(|l| &st.c[l][..n]);
        if s.iter().chain(c.iter()).any(|p| p.len() != n) {
            return;
        }
        let (vo, po, mo, ao) = (&mut out.validity[..n], &mut out.phase[..n], &mut out.modulation[..n], &mut out.dc[..n]);
        let outs = vo.iter_mut().zip(po.iter_mut()).zip(mo.iter_mut()).zip(ao.iter_mut()).zip(a);
        for (i, ((((vo, po), mo), ao), a)) in outs.enumerate() {
            let a = *a;
            let mut phi = A::Phase::default();
            let mut bmin = A::MAG_MAX;
            let mut blast = A::Mag::default();
            let (mut out_of_range, mut inconsistent) = (false, false);
            for l in 0..L {
                let (s, c) = A::level_sc(s[l][i], c[l][i], self.a_dc[l], self.b_dc[l], a, fmt);
                let (wrapped, b2) = A::polar(s, c);
                bmin = A::min_mag(b2, bmin);
                blast = b2;
                if l == 0 {
                    out_of_range = !A::in_range(wrapped, lo, hi);
                    phi = wrapped;
                } else {
                    let (abs, res) = A::unwrap(phi, self.ratio[l], wrapped);
                    inconsistent |= !A::consistent(res, tol);
                    phi = abs;
                }
            }
            // Priority (highest last): unwrap inconsistent, out of range, low modulation, dark,
            // saturated. Selects, not branches, so the loop vectorizes.
            let mut v = Validity::Valid as u8;
            v = if inconsistent { Validity::UnwrapInconsistent as u8 } else { v };
            v = if out_of_range { Validity::PhaseOutOfRange as u8 } else { v };
            v = if !A::mag_at_least(bmin, min_b2) { Validity::LowModulation as u8 } else { v };
            v = if !A::dc_at_least(a, dark) { Validity::Dark as u8 } else { v };
            v = if saturated(i) { Validity::Saturated as u8 } else { v };
            *vo = v;
            *po = if v == 0 { A::phase_out(phi) } else { CANONICAL_NAN };
            *ao = A::dc_out(a, fmt);
            *mo = A::mag_out(blast, fmt);
        }
    }

    /// Wrapped phase φ^(k) ∈ [−π, π] (eqs 9, 11) and modulation B of one level from a complete
    /// state, for diagnostics, golden vectors and noise studies. Same operations as [`Self::finish`].
    pub fn finish_level(&self, st: &State<'_, A::Acc>, level: usize, wrapped: &mut [f32], modulation: &mut [f32]) -> Result<(), DecodeError> {
        let n = st.dc.len();
        if level >= self.n_levels {
            return Err(DecodeError::Sequence);
        }
        if wrapped.len() != n || modulation.len() != n || st.s[level].len() != n || st.c[level].len() != n {
            return Err(DecodeError::Length);
        }
        let (ad, bd, fmt) = (self.a_dc[level], self.b_dc[level], &self.format);
        for i in 0..n {
            let (s, c) = A::level_sc(st.s[level][i], st.c[level][i], ad, bd, st.dc[i], fmt);
            let (w, m) = A::polar(s, c);
            wrapped[i] = A::phase_out(w);
            modulation[i] = A::mag_out(m, fmt);
        }
        Ok(())
    }

    /// Row API for one level: wrapped phase and modulation of `level` from the rows of every image
    /// (set order). See [`Self::finish_level`].
    pub fn decode_row_level<P: Sample>(&self, rows: &[&[P]], level: usize, wrapped: &mut [f32], modulation: &mut [f32]) -> Result<(), DecodeError> {
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
            self.finish_level(&st, level, &mut wrapped[start..end], &mut modulation[start..end])?;
            start = end;
        }
        Ok(())
    }
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
        s: [&mut s0[..n], &mut s1[..n], &mut s2[..n], &mut s3[..n], &mut s4[..n], &mut s5[..n]],
        c: [&mut c0[..n], &mut c1[..n], &mut c2[..n], &mut c3[..n], &mut c4[..n], &mut c5[..n]],
        flags: {
            let k = n.min(flags.len());
            &mut flags[..k]
        },
    }
}
