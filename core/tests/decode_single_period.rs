//! A coarse level of exactly one period across the projector (the usual "phase cue", issue #20):
//! the set is accepted, and the decoder's seam band ([`Plan::accepted_coarse`]) keeps every
//! accepted pixel's fringe order right, in every backend.
//!
//! Truth: the pixel's projector phase Φ^(P), from which the images are synthesized in f64 (the
//! model of eq 14, independent of the decoder), and the perturbation applied to its coarse level.
//!
//! [`Plan::accepted_coarse`]: fringe3d_core::arith::Plan::accepted_coarse
#![allow(clippy::disallowed_methods)] // std f64 maths is the independent truth here

use crate::common::*;
use fringe3d_core::arith::Backend;
use fringe3d_core::decode::{AnyDecoder, DecodeConfig, RowOut};
use fringe3d_core::pattern::{Output, PatternSet};
use fringe3d_core::phase_function::{Axis, PhaseFunction};
use fringe3d_core::validity::Validity;
use std::f64::consts::{PI, TAU};

const W: u32 = 1024;

fn out(bits: u32) -> Output {
    Output {
        width: W,
        height: 8,
        i_min: 0.0,
        i_max: ((1u32 << bits) - 1) as f64,
    }
}

/// Three 4-step levels, ratio 8, the coarse one spanning one whole period (2π) across `W`.
fn phase_cue_set(bits: u32) -> PatternSet {
    let f = PhaseFunction::centered(Axis::Xi, W, TAU).unwrap();
    PatternSet::twelve_pattern(f, 8.0, out(bits)).unwrap()
}

/// Φ^(P) of projector column `p` (the centred linear function: `(p − (W−1)/2)·2π/W`).
fn phi_p(set: &PatternSet, p: f64) -> f64 {
    let (lo, hi) = set.coarse_range();
    (lo + (hi - lo) * p / (W - 1) as f64) / set.levels()[0].scale()
}

/// The set's images for pixels of projector phase `phi[j]` whose coarse level is perturbed by
/// `coarse_err[j]` radians, with Gaussian noise `sigma` (codes) around A + B·sin(·).
fn frames(
    set: &PatternSet,
    phi: &[f64],
    coarse_err: &[f64],
    a: f64,
    b: f64,
    sigma: f64,
    rng: &mut Rng,
) -> Vec<Vec<u16>> {
    let max = set.output().i_max;
    (0..set.image_count())
        .map(|i| {
            let id = set.image(i).unwrap();
            let level = &set.levels()[id.level as usize];
            let delta = level.shifts()[id.shift as usize] + set.effective_offset();
            phi.iter()
                .zip(coarse_err)
                .map(|(&ph, &e)| {
                    let e = if id.level == 0 { e } else { 0.0 };
                    let v = a + b * (level.scale() * ph + e + delta).sin() + sigma * rng.normal();
                    v.round().clamp(0.0, max) as u16
                })
                .collect()
        })
        .collect()
}

fn decode(d: &AnyDecoder, frames: &[Vec<u16>]) -> (Vec<f32>, Vec<u8>) {
    let w = frames[0].len();
    let rows: Vec<&[u16]> = frames.iter().map(|f| &f[..]).collect();
    let (mut ph, mut mo, mut dc, mut va) =
        (vec![0f32; w], vec![0f32; w], vec![0f32; w], vec![0; w]);
    let out = RowOut {
        phase: &mut ph,
        modulation: &mut mo,
        dc: &mut dc,
        validity: &mut va,
    };
    d.decode_row(&rows, out).unwrap();
    (ph, va)
}

#[test]
fn one_period_is_accepted_where_the_old_margin_refused_it() {
    let f = PhaseFunction::centered(Axis::Xi, W, TAU).unwrap();
    let set = phase_cue_set(8);
    let (lo, hi) = set.coarse_range();
    assert!(lo < -PI + 0.01 && hi > PI - 0.01, "range [{lo}, {hi}]");
    // The 0.05 rad margin of before refused it.
    assert!(f.check(W, 8, 1.0, 64.0, 0.05).is_err());
}

/// Every column of the projector, the coarse level pushed by up to ±0.14 rad (just inside the
/// default range tolerance of 0.15): no accepted pixel has a wrong fringe order, and only
/// pixels whose pushed coarse phase lies within the band of the seam are refused.
#[test]
fn the_seam_band_refuses_wrapped_pixels_and_nothing_else() {
    let set = phase_cue_set(16);
    let cfg = DecodeConfig::for_bit_depth(16);
    let t = cfg.range_tolerance as f64;
    let c0 = set.levels()[0].scale();
    let fine = set.levels()[2].scale();
    let (mut phi, mut err) = (Vec::new(), Vec::new());
    for e in [-0.14, -0.1, -0.05, -0.01, 0.0, 0.01, 0.05, 0.1, 0.14] {
        for p in 0..W {
            phi.push(phi_p(&set, p as f64));
            err.push(e);
        }
    }
    let mut rng = Rng(20);
    let fr = frames(&set, &phi, &err, 30_000.0, 25_000.0, 0.0, &mut rng);
    for backend in Backend::ALL {
        let d = AnyDecoder::new(&set, cfg, backend).unwrap();
        let (ph, va) = decode(&d, &fr);
        let (mut wrong, mut lost, mut refused) = (0, 0, 0);
        for j in 0..phi.len() {
            let coarse = c0 * phi[j] + err[j];
            // Distance of the pushed coarse phase from the seam (±π).
            let to_seam = PI - coarse.abs();
            if va[j] == Validity::Valid as u8 {
                if (ph[j] as f64 - fine * phi[j]).abs() > 0.05 {
                    wrong += 1;
                }
            } else {
                refused += 1;
                assert_eq!(va[j], Validity::PhaseOutOfRange as u8, "pixel {j}");
                // Refused though clear of the band (with 0.01 rad for the backends' rounding).
                if to_seam > t + 0.01 {
                    lost += 1;
                }
            }
        }
        assert_eq!(
            wrong,
            0,
            "{}: pixels with a wrong fringe order",
            backend.name()
        );
        assert_eq!(
            lost,
            0,
            "{}: pixels refused clear of the seam",
            backend.name()
        );
        // Some pixels do wrap (|coarse| > π) and must have been refused.
        assert!(refused > 0, "{}", backend.name());
    }
}

/// With camera noise: at B/σ = 40 no fringe-order error anywhere across the projector; at
/// B/σ = 14 (8-bit, σ = 1 code) the errors are the rare pixels whose noise carries the coarse
/// phase more than the band past the seam, as many as the Gaussian tail predicts.
#[test]
fn noise_at_the_seam_follows_the_gaussian_tail() {
    let set = phase_cue_set(8);
    let cfg = DecodeConfig::for_bit_depth(8);
    let t = cfg.range_tolerance as f64;
    let c0 = set.levels()[0].scale();
    let fine = set.levels()[2].scale();
    let rows = 200;
    for (b, seed) in [(40.0, 1u64), (14.0, 2)] {
        let sigma_phi = 1.0 / (b * (4.0f64 / 2.0).sqrt()); // 4-step: σ/(B·√(N/2))
        let mut rng = Rng(seed);
        let (mut wrong, mut valid, mut expected) = (0usize, 0usize, 0.0);
        for _ in 0..rows {
            let phi: Vec<f64> = (0..W).map(|p| phi_p(&set, p as f64)).collect();
            let zero = vec![0.0; phi.len()];
            let fr = frames(&set, &phi, &zero, 120.0, b, 1.0, &mut rng);
            let d = AnyDecoder::new(&set, cfg, Backend::F32Accurate).unwrap();
            let (ph, va) = decode(&d, &fr);
            for j in 0..phi.len() {
                // A wrong order needs noise past the seam by more than the band: the pixel's
                // distance to the seam plus t, on the side it is near.
                let gap = PI - (c0 * phi[j]).abs() + t;
                expected += 0.5 * erfc(gap / (sigma_phi * 2f64.sqrt()));
                if va[j] == Validity::Valid as u8 {
                    valid += 1;
                    if (ph[j] as f64 - fine * phi[j]).abs() > PI {
                        wrong += 1;
                    }
                }
            }
        }
        let n = (rows * W as usize) as f64;
        println!(
            "B/σ = {b}: {wrong} fringe-order errors in {valid} valid pixels \
             (expected {expected:.2}); coverage {:.2} % (the band: {:.2} %)",
            100.0 * valid as f64 / n,
            100.0 * (1.0 - 2.0 * t / TAU)
        );
        assert!(
            (wrong as f64) <= expected + 4.0 * expected.sqrt() + 1.0,
            "B/σ = {b}: {wrong} errors, {expected:.2} expected"
        );
        if b >= 40.0 {
            assert_eq!(wrong, 0);
        }
        // Coverage: the band's columns, and little more.
        assert!(valid as f64 >= n * (1.0 - 2.0 * t / TAU - 0.01));
    }
}

/// erfc by the Numerical Recipes Chebyshev fit (relative error < 1.2e-7).
fn erfc(x: f64) -> f64 {
    // Its polynomial in t, lowest power first, evaluated by Horner's rule. (Written as one
    // nested expression it cost rustfmt 17 s of CI time.)
    const C: [f64; 10] = [
        -1.265_512_23,
        1.000_023_68,
        0.374_091_96,
        0.096_784_18,
        -0.186_288_06,
        0.278_868_07,
        -1.135_203_98,
        1.488_515_87,
        -0.822_152_23,
        0.170_872_77,
    ];
    let z = x.abs();
    let t = 1.0 / (1.0 + 0.5 * z);
    let poly = C.iter().rev().fold(0.0, |p, c| c + t * p);
    let r = t * (-z * z + poly).exp();
    if x >= 0.0 { r } else { 2.0 - r }
}
