//! The reference decoder: one pixel, plain f64, the paper's equations as written (§5.2, eqs 8-15).
//!
//! **Read this before the lanes.** Everything else in [`crate::decode`] computes what this
//! module computes, reorganised for speed: linear estimators computed once per set instead of the
//! formulas below, blocks of pixels, sums in registers, arctangent polynomials side by side, f32
//! or fixed point. Here there is nothing of that: the samples of one pixel go in, the equations
//! run in order, and out come the wrapped phase and modulation of every level, the DC term and
//! the finest absolute phase. A unit test below ties the fast decoder to it within stated bounds,
//! and the integration tests (`core/tests/decode_accuracy.rs`, `arith_accuracy.rs`) measure every
//! backend against it.
//!
//! # The model (eqs 8, 14)
//! Image n of level k shows, at every pixel, `I_n = A + B·sin(Φ^(k) + δ_n + o)`: the DC term A,
//! the modulation B, the level's absolute phase `Φ^(k) = c_k·Φ^(P)`, the image's shift δ_n and
//! the set's offset o ([`PatternSet::effective_offset`]: 0 in the paper's sine convention).
//!
//! # The steps
//! 1. **A** (eq 10; eq 15 for N steps): the mean of the images of the DC level (the level with
//!    the most shifts, at least 3; the finest of those on a tie, as the decoder chooses).
//! 2. **Wrapped phase of a level of N ≥ 3 uniform shifts** δ_n = 2π(n−1)/N (eq 14):
//!    `φ = atan2(Σ I_n·cos(δ_n + o), Σ I_n·sin(δ_n + o))`, which for the paper's 4-step level
//!    (δ = 0, π/2, π, 3π/2, o = 0) is eq 9, `φ = atan2(I₁ − I₃, I₂ − I₄)`; B is `2/N` times the
//!    length of that vector.
//! 3. **Wrapped phase of a 2-image level** with shifts 0 and π/2 (eq 11):
//!    `φ = atan2(I₁ − A, I₂ − A) − o`, wrapped to (−π, π]; B is the length of `(I₁ − A, I₂ − A)`.
//! 4. **Gray code** (issue #20, [`crate::gray`]), when level 0 is a Gray-code level: image j is
//!    bright where `I_j > A` (an inverse code: where `I_2j > I_2j+1`, its inverse); the word of bright bits, read back as a binary number, gives the
//!    stripe, and `Φ^(0)` is its centre ([`crate::gray::GrayCode::quarter_turns`] quarter turns).
//! 5. **Unwrapping** (eqs 12-13): `Φ^(0) = φ^(0)`; for k ≥ 1 the fringe order
//!    `n_k = round((c_k/c_{k−1}·Φ^(k−1) − φ^(k)) / 2π)` and `Φ^(k) = φ^(k) + 2π·n_k`.
//! 6. **Heterodyne** (issue #20), for a set of [`Relation::Heterodyne`] in place of step 5: the
//!    beats of the wrapped phases give the absolute start, and the chain unwraps from it
//!    (`heterodyne` below).
//! 7. **Coprime** (issue #20), for a set of [`Relation::Coprime`] (`c₀ = a·u`, `c₁ = b·u`, `a`
//!    and `b` coprime): by the classic lookup-table method, `d = round((b·φ₀ − a·φ₁)/2π)` equals
//!    `a·k₁ − b·k₀`, which fixes `k₀` modulo `a`; of the orders with `|φ₀ + 2πk₀| < a·π` (`u·Φ`
//!    within one period) the one with `a | d + b·k₀` gives `Φ^(0) = φ₀ + 2πk₀`, then step 5
//!    from level 1 on (`coprime` below). The decoder finds the same order by testing every
//!    candidate's prediction of level 1 instead ([`Relation::Coprime`]).
//!
//! Nothing else: no validity tests (those are thresholds on these quantities, applied by the
//! decoder), and only the sets these equations cover — every level of ≥ 3 shifts uniform, every
//! 2-image level shifted by 0 and π/2 (the paper's 8- and 12-pattern sets, uniform N-step sets).
//! For any other set [`decode_pixel`] returns `None`; the fast decoder handles those through
//! its least-squares estimators ([`crate::estimator`]).
//!
//! `no_std`, no allocation, every transcendental from `libm`.

use crate::limits::MAX_LEVELS;
use crate::pattern::{PatternSet, Relation};
use core::f64::consts::{FRAC_PI_2, PI, TAU};

/// How far (radians) a level's shifts may be from the paper's before [`decode_pixel`] refuses
/// the set (the shifts of [`crate::pattern::Level::n_step`] are `2π·k/N` rounded in f64).
pub const SHIFT_TOLERANCE: f64 = 1e-9;

/// The reference decode of one pixel.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ReferencePixel {
    /// Absolute phase of the finest level, `Φ^(K) = c_K·Φ^(P)` (eqs 12-13), radians.
    pub phase: f64,
    /// Wrapped phase φ^(k) ∈ (−π, π] of every level (eqs 9, 11, 14); 0 past the set's levels.
    /// For a Gray-code level 0, its absolute phase estimate (step 4).
    pub wrapped: [f64; MAX_LEVELS],
    /// Modulation B of every level, camera codes; 0 past the set's levels.
    pub modulation: [f64; MAX_LEVELS],
    /// DC term A (eqs 10, 15), camera codes.
    pub dc: f64,
}

/// `x` wrapped to (−π, π] (up to the rounding of `x`).
pub fn wrap(x: f64) -> f64 {
    let w = x - TAU * libm::round(x / TAU);
    if w <= -PI { w + TAU } else { w }
}

/// Decode one pixel of `set` from its samples (`samples[i]` is image `i` in the set's order,
/// [`PatternSet::image`]), following eqs 8-15 as written (see the module documentation).
///
/// `None` if the number of samples is not the set's image count, the set has no level of ≥ 3
/// shifts, a level of ≥ 3 shifts is not uniform (eq 14), or a 2-image level is not shifted by 0
/// and π/2 (eq 11), all within [`SHIFT_TOLERANCE`].
pub fn decode_pixel(set: &PatternSet, samples: &[f64]) -> Option<ReferencePixel> {
    let levels = set.levels();
    if samples.len() != set.image_count() || levels.is_empty() || levels.len() > MAX_LEVELS {
        return None;
    }
    let o = set.effective_offset();
    // The samples of each level, in shift order: I_1 … I_N of eqs 8-15.
    let mut by_level = [[0.0f64; crate::limits::MAX_SHIFTS]; MAX_LEVELS];
    for (i, &v) in samples.iter().enumerate() {
        let id = set.image(i)?;
        *by_level
            .get_mut(id.level as usize)?
            .get_mut(id.shift as usize)? = v;
    }
    // Step 1 (eqs 10, 15): A is the mean of the DC level's images.
    let mut dc_level = None;
    for (k, l) in levels.iter().enumerate() {
        if l.has_dc() && dc_level.is_none_or(|d: usize| l.len() >= levels[d].len()) {
            dc_level = Some(k);
        }
    }
    let d = dc_level?;
    let n_dc = levels[d].len();
    let a = by_level[d][..n_dc].iter().sum::<f64>() / n_dc as f64;

    let mut wrapped = [0.0f64; MAX_LEVELS];
    let mut modulation = [0.0f64; MAX_LEVELS];
    for (k, l) in levels.iter().enumerate() {
        let i = &by_level[k][..l.len()];
        let shifts = l.shifts();
        if let Some(code) = l.gray() {
            // Step 4: the code word of bright bits, its stripe's centre. An inverse code's bit
            // is bright where the image outshines its inverse (the next image).
            let mut word = 0u32;
            for (j, &v) in i.iter().enumerate() {
                let bright = if code.inverse() {
                    j % 2 == 0 && v > i.get(j + 1).copied().unwrap_or(f64::INFINITY)
                } else {
                    v > a
                };
                if bright {
                    word |= 1 << code.word_bit(j);
                }
            }
            wrapped[k] = code.quarter_turns(word) as f64 * FRAC_PI_2;
            modulation[k] = f64::INFINITY;
        } else if l.len() >= 3 {
            // Step 2 (eq 14; eq 9 for N = 4): uniform shifts δ_n = 2π(n−1)/N.
            let n = l.len() as f64;
            let mut s = 0.0;
            let mut c = 0.0;
            for (idx, (&v, &delta)) in i.iter().zip(shifts).enumerate() {
                if !(libm::fabs(wrap(delta - TAU * idx as f64 / n)) <= SHIFT_TOLERANCE) {
                    return None;
                }
                s += v * libm::cos(delta + o);
                c += v * libm::sin(delta + o);
            }
            wrapped[k] = libm::atan2(s, c);
            modulation[k] = 2.0 / n * libm::sqrt(s * s + c * c);
        } else {
            // Step 3 (eq 11): shifts 0 and π/2, A from the DC level.
            let ok = libm::fabs(wrap(shifts[0])) <= SHIFT_TOLERANCE
                && libm::fabs(wrap(shifts[1] - FRAC_PI_2)) <= SHIFT_TOLERANCE;
            if !ok {
                return None;
            }
            let (y, x) = (i[0] - a, i[1] - a);
            wrapped[k] = wrap(libm::atan2(y, x) - o);
            modulation[k] = libm::sqrt(y * y + x * x);
        }
    }
    if set.relation() == Relation::Heterodyne {
        return Some(ReferencePixel {
            phase: heterodyne(levels, &wrapped)?,
            wrapped,
            modulation,
            dc: a,
        });
    }
    // Step 5 (eqs 12-13): Φ^(0) = φ^(0) (step 7 for a coprime set), then one level after
    // another.
    let mut phi = wrapped[0];
    if set.relation() == Relation::Coprime {
        phi = coprime(levels, &wrapped)?;
    }
    for k in 1..levels.len() {
        let predicted = levels[k].scale() / levels[k - 1].scale() * phi;
        let n_k = libm::round((predicted - wrapped[k]) / TAU);
        phi = wrapped[k] + TAU * n_k;
    }
    Some(ReferencePixel {
        phase: phi,
        wrapped,
        modulation,
        dc: a,
    })
}

/// Step 6, for a heterodyne set ([`Relation::Heterodyne`]) in place of step 5: the beat of
/// levels a and b, `β = wrap(φ_b − φ_a)`, is the wrapped phase of scale `c_b − c_a`. With 2 levels
/// the beat is absolute; then `Φ₀` and `Φ₁` by eqs 12-13. With 3 levels the beat of the beats
/// `wrap(β₁₂ − β₀₁)` (scale `c₂ − 2c₁ + c₀`) is absolute; then `β₀₁`, `Φ₁`, `Φ₂` unwrap in turn.
fn heterodyne(levels: &[crate::pattern::Level], w: &[f64; MAX_LEVELS]) -> Option<f64> {
    let c = |i: usize| levels.get(i).map(|l| l.scale());
    let step = |coarse: f64, ratio: f64, wrapped: f64| {
        wrapped + TAU * libm::round((ratio * coarse - wrapped) / TAU)
    };
    match levels.len() {
        2 => {
            let b = c(1)? - c(0)?;
            let start = wrap(w[1] - w[0]);
            let p0 = step(start, c(0)? / b, w[0]);
            Some(step(p0, c(1)? / c(0)?, w[1]))
        }
        3 => {
            let (b01, b12) = (c(1)? - c(0)?, c(2)? - c(1)?);
            let (beat01, beat12) = (wrap(w[1] - w[0]), wrap(w[2] - w[1]));
            let start = wrap(beat12 - beat01);
            let p01 = step(start, b01 / (b12 - b01), beat01);
            let p1 = step(p01, c(1)? / b01, w[1]);
            Some(step(p1, c(2)? / c(1)?, w[2]))
        }
        _ => None,
    }
}

/// Step 7, for a coprime set ([`Relation::Coprime`]): level 0's absolute phase by the lookup-table
/// method.
fn coprime(levels: &[crate::pattern::Level], w: &[f64; MAX_LEVELS]) -> Option<f64> {
    let (c0, c1) = (levels.first()?.scale(), levels.get(1)?.scale());
    let (a, b) = crate::pattern::coprime_ratio(c0, c1)?;
    let (a, b) = (a as i64, b as i64);
    let d = libm::round((b as f64 * w[0] - a as f64 * w[1]) / TAU) as i64;
    (-a..=a)
        .filter(|k| libm::fabs(w[0] + TAU * *k as f64) < a as f64 * PI)
        .find(|k| (d + b * k).rem_euclid(a) == 0)
        .map(|k| w[0] + TAU * k as f64)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::arith::Backend;
    use crate::decode::{AnyDecoder, DecodeConfig, Decoder, RowOut};
    use crate::pattern::{Level, Output};
    use crate::phase_function::{Axis, PhaseFunction};
    use crate::validity::Validity;

    /// Pixels per test row.
    const W: usize = 512;

    fn out(i_max: f64) -> Output {
        Output {
            width: 1024,
            height: 768,
            i_min: 0.0,
            i_max,
        }
    }

    /// SplitMix64 with a Gaussian by Box-Muller (`libm`), as the integration tests' `Rng`.
    struct Rng(u64);

    impl Rng {
        fn uniform(&mut self) -> f64 {
            self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
            let mut z = self.0;
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
        }
        fn normal(&mut self) -> f64 {
            let u1 = self.uniform().max(1e-300);
            let u2 = self.uniform();
            libm::sqrt(-2.0 * libm::log(u1)) * libm::cos(TAU * u2)
        }
    }

    /// Images (set order) of `W` pixels with phases across the coarse range (eq 8/14 in f64),
    /// DC `a`, modulation `b`, Gaussian noise `sigma`, rounded and clipped to `[0, full]`.
    fn images(
        set: &PatternSet,
        a: f64,
        b: f64,
        sigma: f64,
        full: f64,
        seed: u64,
    ) -> [[u16; W]; 16] {
        let mut rng = Rng(seed);
        let (lo, hi) = set.coarse_range();
        let c0 = set.levels()[0].scale();
        let mut imgs = [[0u16; W]; 16];
        for (i, img) in imgs.iter_mut().enumerate().take(set.image_count()) {
            let id = set.image(i).unwrap();
            let level = &set.levels()[id.level as usize];
            let delta = level.shifts()[id.shift as usize] + set.effective_offset();
            for (p, v) in img.iter_mut().enumerate() {
                let phi_p = (lo + (hi - lo) * (p as f64 + 0.5) / W as f64) / c0;
                let x = a + b * libm::sin(level.scale() * phi_p + delta) + sigma * rng.normal();
                *v = libm::round(x).clamp(0.0, full) as u16;
            }
        }
        imgs
    }

    fn samples(imgs: &[[u16; W]; 16], n: usize, p: usize) -> [f64; 16] {
        let mut s = [0.0; 16];
        for (slot, img) in s.iter_mut().zip(&imgs[..n]) {
            *slot = img[p] as f64;
        }
        s
    }

    /// The paper's set, 16-bit, σ = 30 codes: the default decoder's finest absolute phase is
    /// within 2e-5 rad of the reference and its A within 1e-2 codes (the bounds of
    /// `core/tests/decode_accuracy.rs`).
    #[test]
    fn default_decoder_matches_the_reference_on_the_paper_set() {
        let set = PatternSet::default_for(Axis::Xi, out(65535.0)).unwrap();
        let d = Decoder::new(&set, DecodeConfig::for_bit_depth(16)).unwrap();
        let n = set.image_count();
        let imgs = images(&set, 30000.0, 20000.0, 30.0, 65535.0, 7);
        let rows: [&[u16]; 8] = core::array::from_fn(|i| &imgs[i][..]);
        let (mut ph, mut mo, mut dc, mut va) = ([0f32; W], [0f32; W], [0f32; W], [0u8; W]);
        let o = RowOut {
            phase: &mut ph,
            modulation: &mut mo,
            dc: &mut dc,
            validity: &mut va,
        };
        d.decode_row(&rows, o).unwrap();
        let mut worst = 0.0f64;
        for p in 0..W {
            let r = decode_pixel(&set, &samples(&imgs, n, p)[..n]).unwrap();
            assert_eq!(va[p], Validity::Valid as u8, "pixel {p}");
            worst = worst.max(libm::fabs(ph[p] as f64 - r.phase));
            assert!(
                libm::fabs(dc[p] as f64 - r.dc) < 1e-2,
                "pixel {p}: A {} vs {}",
                dc[p],
                r.dc
            );
            // B of the finest level: f32 arithmetic on a 20000-code vector.
            let fine = set.levels().len() - 1;
            assert!(
                libm::fabs(mo[p] as f64 - r.modulation[fine]) < 0.05,
                "pixel {p}: B"
            );
        }
        assert!(
            worst <= 2e-5,
            "finest phase against the reference: {worst:e} rad"
        );
    }

    /// A 3/5/7-step set, 12-bit, noise-free: [`crate::arith::F32Accurate`]'s finest absolute phase within
    /// 1e-5 rad and its finest wrapped phase within 1e-6 rad of the reference (the bounds of
    /// `core/tests/arith_accuracy.rs` for that backend).
    #[test]
    fn f32_accurate_matches_the_reference_on_uniform_n_step_levels() {
        let f = PhaseFunction::centered(Axis::Eta, 768, 0.9 * TAU).unwrap();
        let levels = [
            Level::n_step(1.0, 3),
            Level::n_step(6.0, 5),
            Level::n_step(36.0, 7),
        ];
        let set = PatternSet::new(f, &levels, out(4095.0)).unwrap();
        let d =
            AnyDecoder::new(&set, DecodeConfig::for_bit_depth(12), Backend::F32Accurate).unwrap();
        let n = set.image_count();
        let imgs = images(&set, 2000.0, 900.0, 0.0, 4095.0, 11);
        let mut rows: [&[u16]; 16] = [&[]; 16];
        for (r, img) in rows.iter_mut().zip(&imgs) {
            *r = &img[..];
        }
        let rows = &rows[..n];
        let (mut ph, mut mo, mut dc, mut va) = ([0f32; W], [0f32; W], [0f32; W], [0u8; W]);
        let o = RowOut {
            phase: &mut ph,
            modulation: &mut mo,
            dc: &mut dc,
            validity: &mut va,
        };
        d.decode_row(rows, o).unwrap();
        let fine = set.levels().len() - 1;
        let (mut w, mut m) = ([0f32; W], [0f32; W]);
        d.decode_row_level(rows, fine, &mut w, &mut m).unwrap();
        let (mut worst, mut wworst) = (0.0f64, 0.0f64);
        for p in 0..W {
            let r = decode_pixel(&set, &samples(&imgs, n, p)[..n]).unwrap();
            assert_eq!(va[p], Validity::Valid as u8, "pixel {p}");
            worst = worst.max(libm::fabs(ph[p] as f64 - r.phase));
            wworst = wworst.max(libm::fabs(wrap(w[p] as f64 - r.wrapped[fine])));
        }
        assert!(
            worst <= 1e-5 && wworst <= 1e-6,
            "against the reference: finest {worst:e} rad, wrapped {wworst:e} rad"
        );
    }

    /// The reference itself on exact (unquantized) samples: eqs 8-15 invert the model to f64
    /// rounding, and it refuses a set the equations do not cover.
    #[test]
    fn reference_inverts_the_model() {
        let set = PatternSet::default_for(Axis::Xi, out(65535.0)).unwrap();
        let (lo, hi) = set.coarse_range();
        let c0 = set.levels()[0].scale();
        let fine = set.levels().len() - 1;
        for p in 0..200 {
            let phi_p = (lo + (hi - lo) * (p as f64 + 0.5) / 200.0) / c0;
            let mut s = [0.0; 8];
            for (i, v) in s.iter_mut().enumerate() {
                let id = set.image(i).unwrap();
                let l = &set.levels()[id.level as usize];
                let delta = l.shifts()[id.shift as usize] + set.effective_offset();
                *v = 30000.0 + 20000.0 * libm::sin(l.scale() * phi_p + delta);
            }
            let r = decode_pixel(&set, &s).unwrap();
            let want = set.levels()[fine].scale() * phi_p;
            assert!(
                libm::fabs(r.phase - want) < 1e-9,
                "pixel {p}: {} vs {want}",
                r.phase
            );
            assert!(libm::fabs(r.dc - 30000.0) < 1e-8);
            for b in &r.modulation[..set.levels().len()] {
                assert!(libm::fabs(b - 20000.0) < 1e-8, "B {b}");
            }
        }
        assert_eq!(decode_pixel(&set, &[0.0; 7]), None);
        let f = PhaseFunction::centered(Axis::Xi, 1024, 0.9 * TAU).unwrap();
        let odd = Level::with_shifts(1.0, &[0.0, 1.0]);
        let set = PatternSet::new(f, &[odd, Level::n_step(8.0, 4)], out(255.0)).unwrap();
        assert_eq!(decode_pixel(&set, &[100.0; 6]), None);
    }
}
