//! Decoding against independent truth: the f64 reference decoder and the known synthetic phase.
// Tests use std f64 maths as the independent truth; the ban on it is for the core library.
#![allow(clippy::disallowed_methods)]

use crate::common::*;
use fringe3d_core::decode::{DecodeConfig, Decoder, RowOut};
use fringe3d_core::pattern::{Convention, Level, Output, PatternSet};
use fringe3d_core::phase_function::{Axis, PhaseFunction};
use fringe3d_core::validity::Validity;

fn out16() -> Output {
    Output {
        width: 1024,
        height: 768,
        i_min: 0.0,
        i_max: 65535.0,
    }
}

struct Decoded {
    phase: Vec<f32>,
    b: Vec<f32>,
    a: Vec<f32>,
    v: Vec<u8>,
}

fn decode<P: fringe3d_core::decode::Sample>(d: &Decoder, imgs: &[Vec<P>]) -> Decoded {
    let w = imgs[0].len();
    let mut o = Decoded {
        phase: vec![0.0; w],
        b: vec![0.0; w],
        a: vec![0.0; w],
        v: vec![0; w],
    };
    let rows: Vec<&[P]> = imgs.iter().map(|r| r.as_slice()).collect();
    d.decode_row(
        &rows,
        RowOut {
            phase: &mut o.phase,
            modulation: &mut o.b,
            dc: &mut o.a,
            validity: &mut o.v,
        },
    )
    .unwrap();
    o
}

/// Base phases spanning the set's coarse range, one per pixel.
fn ramp(set: &PatternSet, n: usize, a: f64, b: f64) -> Vec<Pixel> {
    let (lo, hi) = set.coarse_range();
    let c0 = set.levels()[0].scale();
    (0..n)
        .map(|i| Pixel {
            a,
            b,
            phi_p: (lo + (hi - lo) * (i as f64 + 0.5) / n as f64) / c0,
        })
        .collect()
}

#[test]
fn paper_set_matches_f64_reference_within_2e5_rad() {
    let set = PatternSet::default_for(Axis::Xi, out16()).unwrap();
    let d = Decoder::new(&set, DecodeConfig::for_bit_depth(16)).unwrap();
    let mut rng = Rng(7);
    let px = ramp(&set, 4096, 30000.0, 20000.0);
    let imgs = images(&set, &px, 30.0, 65535.0, &mut rng);
    let o = decode(&d, &imgs);
    let mut worst = 0.0f64;
    for (i, _) in px.iter().enumerate() {
        let samples: Vec<f64> = imgs.iter().map(|r| r[i] as f64).collect();
        let (phi, _, a) = reference_decode(&set, &samples);
        assert_eq!(o.v[i], Validity::Valid as u8, "pixel {i}");
        worst = worst.max((o.phase[i] as f64 - phi).abs());
        assert!((o.a[i] as f64 - a).abs() < 1e-2);
    }
    assert!(
        worst <= 2e-5,
        "max phase error against the f64 reference: {worst:e} rad"
    );
}

#[test]
fn noise_free_phase_equals_truth() {
    // 16-bit quantization only: σ_q = 1/√12 codes → σφ ≈ 0.29·√0.5/20000 ≈ 1e-5 rad on the
    // 4-step level, so the finest absolute phase must be within a few 1e-5 of c_K·Φ^(P).
    let set = PatternSet::default_for(Axis::Xi, out16()).unwrap();
    let d = Decoder::new(&set, DecodeConfig::for_bit_depth(16)).unwrap();
    let px = ramp(&set, 8192, 32000.0, 30000.0);
    let imgs = images(&set, &px, 0.0, 65535.0, &mut Rng(1));
    let o = decode(&d, &imgs);
    let ck = set.levels()[2].scale();
    let mut sum2 = 0.0;
    for (i, p) in px.iter().enumerate() {
        assert_eq!(o.v[i], 0);
        let e = o.phase[i] as f64 - ck * p.phi_p;
        sum2 += e * e;
        assert!(e.abs() < 1e-4, "pixel {i}: error {e:e}");
    }
    let rms = (sum2 / px.len() as f64).sqrt();
    assert!(rms < 3e-5, "rms {rms:e}");
}

fn std_of_errors(
    d: &Decoder,
    set: &PatternSet,
    level: usize,
    px: &[Pixel],
    imgs: &[Vec<u16>],
) -> f64 {
    let w = px.len();
    let rows: Vec<&[u16]> = imgs.iter().map(|r| r.as_slice()).collect();
    let mut wrapped = vec![0.0f32; w];
    let mut b = vec![0.0f32; w];
    d.decode_row_level(&rows, level, &mut wrapped, &mut b)
        .unwrap();
    let c = set.levels()[level].scale();
    let errs: Vec<f64> = (0..w)
        .map(|i| wrap(wrapped[i] as f64 - c * px[i].phi_p))
        .collect();
    let mean = errs.iter().sum::<f64>() / w as f64;
    (errs.iter().map(|e| (e - mean) * (e - mean)).sum::<f64>() / w as f64).sqrt()
}

#[test]
fn phase_noise_follows_theory_within_10_percent() {
    // σφ = √(2/N)·σ/B for the N-step level, √1.25·σ/B for a 2-image level using A of the
    // 4-step level (I − A has variance σ²(1 + 1/4)).
    let set = PatternSet::default_for(Axis::Xi, out16()).unwrap();
    let d = Decoder::new(&set, DecodeConfig::for_bit_depth(16)).unwrap();
    let (a, b, sigma) = (30000.0, 10000.0, 500.0);
    let px = ramp(&set, 200_000, a, b);
    let imgs = images(&set, &px, sigma, 65535.0, &mut Rng(42));
    let want4 = (2.0f64 / 4.0).sqrt() * sigma / b;
    let want2 = 1.25f64.sqrt() * sigma / b;
    for (level, want) in [(2usize, want4), (1, want2), (0, want2)] {
        let got = std_of_errors(&d, &set, level, &px, &imgs);
        assert!(
            (got / want - 1.0).abs() < 0.10,
            "level {level}: σφ = {got:.5}, theory {want:.5}"
        );
    }
}

#[test]
fn no_unwrapping_error_on_valid_pixels_at_b_over_sigma_14_u8() {
    let set = PatternSet::default_for(
        Axis::Xi,
        Output {
            i_max: 255.0,
            ..out16()
        },
    )
    .unwrap();
    let d = Decoder::new(&set, DecodeConfig::for_bit_depth(8)).unwrap();
    let (a, b, sigma) = (127.0, 70.0, 5.0);
    let px = ramp(&set, 300_000, a, b);
    let imgs = to_u8(&images(&set, &px, sigma, 255.0, &mut Rng(3)));
    let o = decode(&d, &imgs);
    let ck = set.levels()[2].scale();
    let mut valid = 0usize;
    for (i, p) in px.iter().enumerate() {
        if o.v[i] == Validity::Valid as u8 {
            valid += 1;
            let e = o.phase[i] as f64 - ck * p.phi_p;
            assert!(
                e.abs() < std::f64::consts::PI,
                "pixel {i}: fringe-order error (e = {e:.3} rad) on a valid pixel"
            );
        } else {
            assert!(o.phase[i].is_nan());
        }
    }
    let frac = valid as f64 / px.len() as f64;
    assert!(frac > 0.99, "only {:.3} % valid", 100.0 * frac);
}

/// Valid pixels whose absolute phase is a whole fringe (or more) off the truth.
fn order_errors(
    set: &PatternSet,
    cfg: DecodeConfig,
    b: f64,
    sigma: f64,
    n: usize,
    seed: u64,
) -> (usize, usize) {
    let d = Decoder::new(set, cfg).unwrap();
    let px = ramp(set, n, 60.0, b);
    let imgs = to_u8(&images(set, &px, sigma, 255.0, &mut Rng(seed)));
    let o = decode(&d, &imgs);
    let ck = set.levels()[set.levels().len() - 1].scale();
    let mut wrong = 0;
    let mut valid = 0;
    for (i, p) in px.iter().enumerate() {
        if o.v[i] == Validity::Valid as u8 {
            valid += 1;
            if (o.phase[i] as f64 - ck * p.phi_p).abs() > std::f64::consts::PI {
                wrong += 1;
            }
        }
    }
    (wrong, valid)
}

#[test]
fn weak_8bit_fringes_are_refused_rather_than_unwrapped_to_a_wrong_order() {
    // Dim, weakly modulated 8-bit pixels (B = 6 to 9 codes, σ = 1 code, as on a dark or steep
    // surface): with a modulation floor of 2 % of full scale (5.1 codes) some pass every test and
    // come out whole fringes off; the default floor (12 codes at 8 bits) refuses them.
    let set = PatternSet::default_for(
        Axis::Xi,
        Output {
            i_max: 255.0,
            ..out16()
        },
    )
    .unwrap();
    let old = DecodeConfig {
        min_modulation: 0.02 * 255.0,
        ..DecodeConfig::for_bit_depth(8)
    };
    let mut silent_old = 0;
    for (k, b) in [6.0, 7.5, 9.0].into_iter().enumerate() {
        let (wrong, valid) = order_errors(&set, old, b, 1.0, 100_000, 40 + k as u64);
        assert!(
            valid > 20_000,
            "B = {b}: the old floor should accept many pixels ({valid})"
        );
        eprintln!("B = {b}, σ = 1, floor 5.1 codes: {valid} valid, {wrong} a whole fringe off");
        silent_old += wrong;
        let (wrong, _) = order_errors(
            &set,
            DecodeConfig::for_bit_depth(8),
            b,
            1.0,
            100_000,
            40 + k as u64,
        );
        assert_eq!(
            wrong, 0,
            "B = {b}: valid pixels with a wrong fringe order under the default config"
        );
    }
    assert!(
        silent_old > 10,
        "the weak-fringe case should show silent order errors at the old floor ({silent_old})"
    );
    // Pixels of healthy modulation at 8 bits stay valid under the default config.
    let (wrong, valid) = order_errors(&set, DecodeConfig::for_bit_depth(8), 20.0, 1.0, 100_000, 7);
    assert_eq!(wrong, 0);
    assert!(
        valid > 99_000,
        "B = 20, σ = 1: only {valid} of 100 000 valid"
    );
}

#[test]
fn generic_n_step_arbitrary_shifts_cosine_and_offset() {
    // N = 3, 5 and 7-step levels, then a level of non-uniform measured shifts, cosine convention
    // and an extra offset: the decoder must recover the synthetic phase.
    let f = PhaseFunction::centered(Axis::Eta, 768, 0.9 * std::f64::consts::TAU).unwrap();
    let cases: Vec<(PatternSet, &str)> = vec![
        (
            PatternSet::new(
                f,
                &[
                    Level::n_step(1.0, 3),
                    Level::n_step(6.0, 5),
                    Level::n_step(36.0, 7),
                ],
                out16(),
            )
            .unwrap(),
            "3/5/7-step",
        ),
        (
            PatternSet::new(
                f,
                &[
                    Level::two_step(1.0),
                    Level::with_shifts(7.0, &[0.0, 1.1, 2.0, 3.5, 5.2]),
                ],
                out16(),
            )
            .unwrap(),
            "measured shifts",
        ),
        (
            PatternSet::twelve_pattern(f, 8.0, out16())
                .unwrap()
                .with_convention(Convention::Cosine)
                .with_phase_offset(0.37)
                .unwrap(),
            "cosine+offset",
        ),
        (
            PatternSet::paper_eight(f, 8.0, out16())
                .unwrap()
                .with_convention(Convention::Cosine),
            "paper8 cosine",
        ),
    ];
    for (set, name) in cases {
        let d = Decoder::new(&set, DecodeConfig::for_bit_depth(16)).unwrap();
        let px = ramp(&set, 5000, 30000.0, 25000.0);
        let imgs = images(&set, &px, 0.0, 65535.0, &mut Rng(5));
        let o = decode(&d, &imgs);
        let ck = set.levels().last().unwrap().scale();
        for (i, p) in px.iter().enumerate() {
            assert_eq!(
                o.v[i],
                0,
                "{name}: pixel {i} invalid ({})",
                Validity::from_u8(o.v[i]).unwrap().name()
            );
            let e = o.phase[i] as f64 - ck * p.phi_p;
            assert!(e.abs() < 2e-4, "{name}: pixel {i} error {e:e}");
        }
    }
}

#[test]
fn each_failure_gets_its_own_code() {
    let set = PatternSet::default_for(
        Axis::Xi,
        Output {
            i_max: 255.0,
            ..out16()
        },
    )
    .unwrap();
    let d = Decoder::new(&set, DecodeConfig::for_bit_depth(8)).unwrap();
    let (lo, hi) = set.coarse_range();
    let mid = 0.5 * (lo + hi);
    let good = Pixel {
        a: 120.0,
        b: 80.0,
        phi_p: mid,
    };
    let px = vec![
        good,
        Pixel {
            a: 200.0,
            b: 80.0,
            ..good
        }, // clipped at 255: saturated
        Pixel {
            a: 2.0,
            b: 1.0,
            ..good
        }, // dark
        Pixel {
            a: 120.0,
            b: 2.0,
            ..good
        }, // low modulation
    ];
    let mut imgs = images(&set, &px, 0.0, 255.0, &mut Rng(9));
    // Pixel 4: level 1 inconsistent with level 0 (its phase shifted by π: predicted vs measured differ by π).
    // Pixel 5: coarse phase outside the projected range (beyond the 0.15 rad tolerance).
    let mut extra = vec![
        good,
        Pixel {
            phi_p: hi + 0.25,
            ..good
        },
    ];
    extra[0].phi_p = mid;
    let mut e_imgs = images(&set, &extra, 0.0, 255.0, &mut Rng(9));
    for (i, row) in e_imgs.iter_mut().enumerate() {
        let id = set.image(i).unwrap();
        if id.level == 1 {
            let lv = &set.levels()[1];
            let p = &extra[0];
            row[0] = (p.a
                + p.b
                    * (lv.scale() * p.phi_p
                        + lv.shifts()[id.shift as usize]
                        + std::f64::consts::PI)
                        .sin())
            .round() as u16;
        }
    }
    for (r, e) in imgs.iter_mut().zip(e_imgs) {
        r.extend(e);
    }
    let o = decode(&d, &to_u8(&imgs));
    let want = [
        Validity::Valid,
        Validity::Saturated,
        Validity::Dark,
        Validity::LowModulation,
        Validity::UnwrapInconsistent,
        Validity::PhaseOutOfRange,
    ];
    for (i, w) in want.iter().enumerate() {
        assert_eq!(Validity::from_u8(o.v[i]), Some(*w), "pixel {i}");
        assert_eq!(o.phase[i].is_nan(), !w.is_valid());
    }
}
