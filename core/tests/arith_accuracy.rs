//! Every arithmetic backend against independent truth: phase error against the f64 reference
//! decoder of the same samples, unwrapping failures at B/σ_I = 14 and 20, validity codes, and the
//! two drivers (row and frame-sequential) agreeing bit for bit.
//!
//! `cargo test --release -p fringe3d-core --test suite arith_accuracy:: -- --nocapture` prints the rows of the
//! tables in docs/arithmetic.md.
// Tests use std f64 maths as the independent truth; the ban on it is for the core library.
#![allow(clippy::disallowed_methods)]

use crate::common::*;
use fringe3d_core::arith::{Arith, Backend, F32Accurate, F32Fast, F32Micromath, Fixed};
use fringe3d_core::decode::{AnyDecoder, DecodeConfig, Decoder, RowOut, Sample};
use fringe3d_core::math::canonical;
use fringe3d_core::pattern::{Level, Output, PatternSet};
use fringe3d_core::phase_function::{Axis, PhaseFunction};
use fringe3d_core::sequential::FrameDecoder;
use fringe3d_core::validity::Validity;

fn out(i_max: f64) -> Output {
    Output {
        width: 1024,
        height: 768,
        i_min: 0.0,
        i_max,
    }
}

struct Decoded {
    phase: Vec<f32>,
    b: Vec<f32>,
    a: Vec<f32>,
    v: Vec<u8>,
}

fn decode<P: Sample>(d: &AnyDecoder, imgs: &[Vec<P>]) -> Decoded {
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

/// Random pixels well inside the valid region: A in [0.3, 0.6]·full, B in [0.1, 0.28]·full
/// (above the 2 % modulation threshold, never clipped), phase uniform over the coarse range.
fn random_pixels(set: &PatternSet, n: usize, full: f64, rng: &mut Rng) -> Vec<Pixel> {
    let (lo, hi) = set.coarse_range();
    let c0 = set.levels()[0].scale();
    (0..n)
        .map(|_| {
            let a = full * (0.3 + 0.3 * rng.uniform());
            let b = full * (0.1 + 0.18 * rng.uniform());
            Pixel {
                a,
                b,
                phi_p: (lo + (hi - lo) * (0.02 + 0.96 * rng.uniform())) / c0,
            }
        })
        .collect()
}

/// Errors against the f64 reference decode of the same (quantized, noise-free) samples, over
/// pixels valid in the backend's decode (asserts all are valid): (max, RMS) of the finest absolute
/// phase, and (max, RMS) of the finest level's wrapped phase (`decode_row_level`, the `atan2`
/// alone, without the f32 rounding of a large absolute phase).
fn phase_error(
    backend: Backend,
    set: &PatternSet,
    bits: u32,
    n: usize,
) -> ((f64, f64), (f64, f64)) {
    let full = ((1u32 << bits) - 1) as f64;
    let d = AnyDecoder::new(set, DecodeConfig::for_bit_depth(bits), backend).unwrap();
    let mut rng = Rng(11 + bits as u64);
    let px = random_pixels(set, n, full, &mut rng);
    let imgs = images(set, &px, 0.0, full, &mut rng);
    let finest = set.levels().len() - 1;
    let (o, wrapped) = if bits == 8 {
        let i8 = to_u8(&imgs);
        let rows: Vec<&[u8]> = i8.iter().map(|r| r.as_slice()).collect();
        let (mut w, mut m) = (vec![0.0f32; n], vec![0.0f32; n]);
        d.decode_row_level(&rows, finest, &mut w, &mut m).unwrap();
        (decode(&d, &i8), w)
    } else {
        let rows: Vec<&[u16]> = imgs.iter().map(|r| r.as_slice()).collect();
        let (mut w, mut m) = (vec![0.0f32; n], vec![0.0f32; n]);
        d.decode_row_level(&rows, finest, &mut w, &mut m).unwrap();
        (decode(&d, &imgs), w)
    };
    let (mut worst, mut sum2, mut wworst, mut wsum2) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
    for i in 0..n {
        assert_eq!(
            o.v[i],
            0,
            "{backend} {bits}-bit: pixel {i} invalid ({:?})",
            Validity::from_u8(o.v[i])
        );
        let samples: Vec<f64> = imgs.iter().map(|r| r[i] as f64).collect();
        let (phi, w, _) = reference_decode(set, &samples);
        let e = o.phase[i] as f64 - phi;
        worst = worst.max(e.abs());
        sum2 += e * e;
        let ew = wrap(wrapped[i] as f64 - w[finest]);
        wworst = wworst.max(ew.abs());
        wsum2 += ew * ew;
    }
    (
        (worst, (sum2 / n as f64).sqrt()),
        (wworst, (wsum2 / n as f64).sqrt()),
    )
}

fn paper(bits: u32) -> PatternSet {
    PatternSet::default_for(Axis::Xi, out(((1u32 << bits) - 1) as f64)).unwrap()
}

fn steps357(bits: u32) -> PatternSet {
    let f = PhaseFunction::centered(Axis::Eta, 768, 0.9 * std::f64::consts::TAU).unwrap();
    PatternSet::new(
        f,
        &[
            Level::n_step(1.0, 3),
            Level::n_step(6.0, 5),
            Level::n_step(36.0, 7),
        ],
        out(((1u32 << bits) - 1) as f64),
    )
    .unwrap()
}

/// Largest errors each backend may have against the f64 reference: finest absolute phase (the
/// f32 output's own rounding at |Φ| ≈ 200 rad is 7.6e-6) and wrapped phase.
fn bounds(b: Backend) -> (f64, f64) {
    match b {
        Backend::F32Accurate => (1e-5, 1e-6),
        Backend::F32Fast => (3e-5, 2e-5),
        Backend::F32Micromath => (4e-3, 4e-3),
        // exact coefficients (the paper set) give 4e-7 wrapped; a non-dyadic estimator adds up to N·2^−(F+1)
        Backend::Fixed => (1.5e-5, 1e-5),
    }
}

#[test]
fn phase_error_against_f64_reference() {
    for backend in Backend::ALL {
        for (name, set, bits) in [
            ("paper8", paper(8), 8),
            ("paper8", paper(16), 16),
            ("3/5/7", steps357(12), 12),
        ] {
            let ((max, rms), (wmax, wrms)) = phase_error(backend, &set, bits, 100_000);
            println!(
                "phase error | {backend} | {name} {bits}-bit | finest max {max:.2e} RMS {rms:.2e} rad | wrapped max {wmax:.2e} RMS {wrms:.2e} rad"
            );
            let (b, wb) = bounds(backend);
            assert!(
                max <= b && wmax <= wb,
                "{backend} {name} {bits}-bit: max error {max:e} rad, wrapped {wmax:e} rad"
            );
        }
    }
}

/// Fringe-order errors on valid pixels and pixels refused as unwrap-inconsistent, per pixel.
fn unwrap_failures(backend: Backend, b_over_sigma: f64, n: usize) -> (f64, f64, f64) {
    let set = paper(8);
    let d = AnyDecoder::new(&set, DecodeConfig::for_bit_depth(8), backend).unwrap();
    let (a, b) = (127.0, 70.0);
    let px = {
        let (lo, hi) = set.coarse_range();
        let c0 = set.levels()[0].scale();
        (0..n)
            .map(|i| Pixel {
                a,
                b,
                phi_p: (lo + (hi - lo) * (i as f64 + 0.5) / n as f64) / c0,
            })
            .collect::<Vec<_>>()
    };
    let imgs = to_u8(&images(&set, &px, b / b_over_sigma, 255.0, &mut Rng(3)));
    let o = decode(&d, &imgs);
    let ck = set.levels()[2].scale();
    let (mut order, mut refused, mut valid) = (0usize, 0usize, 0usize);
    for (i, p) in px.iter().enumerate() {
        if o.v[i] == Validity::Valid as u8 {
            valid += 1;
            if (o.phase[i] as f64 - ck * p.phi_p).abs() > std::f64::consts::PI {
                order += 1;
            }
        } else if o.v[i] == Validity::UnwrapInconsistent as u8 {
            refused += 1;
        }
    }
    (
        order as f64 / n as f64,
        refused as f64 / n as f64,
        valid as f64 / n as f64,
    )
}

#[test]
fn unwrapping_failures_at_b_over_sigma_14_and_20() {
    let n = 1_000_000;
    for backend in Backend::ALL {
        for bs in [14.0, 20.0] {
            let (order, refused, valid) = unwrap_failures(backend, bs, n);
            println!(
                "unwrapping | {backend} | B/σ = {bs} | order errors {order:.1e} | refused {refused:.2e} | valid {valid:.4}"
            );
            assert_eq!(
                order, 0.0,
                "{backend}, B/σ = {bs}: fringe-order errors on valid pixels"
            );
            assert!(valid > 0.99, "{backend}, B/σ = {bs}: only {valid} valid");
        }
    }
}

/// The row API and the frame-sequential decoder of one backend give the same bits.
fn drivers_agree<A: Arith>(set: &PatternSet, bits: u32) {
    let full = ((1u32 << bits) - 1) as f64;
    let d = Decoder::<A>::with_arith(set, DecodeConfig::for_bit_depth(bits)).unwrap();
    let (w, h) = (150, 3);
    let mut rng = Rng(77);
    let (lo, hi) = set.coarse_range();
    let px: Vec<Pixel> = (0..w * h)
        .map(|_| {
            let a = full * (0.02 + 0.8 * rng.uniform());
            Pixel {
                a,
                b: a * rng.uniform(),
                phi_p: (lo - 0.3 + (hi - lo + 0.6) * rng.uniform()) / set.levels()[0].scale(),
            }
        })
        .collect();
    let frames = images(set, &px, 0.02 * full, full, &mut rng);
    let n = w * h;
    let mut row = (
        vec![0.0f32; n],
        vec![0.0f32; n],
        vec![0.0f32; n],
        vec![0u8; n],
    );
    for y in 0..h {
        let rows: Vec<&[u16]> = frames.iter().map(|f| &f[y * w..(y + 1) * w]).collect();
        let r = y * w..(y + 1) * w;
        d.decode_row(
            &rows,
            RowOut {
                phase: &mut row.0[r.clone()],
                modulation: &mut row.1[r.clone()],
                dc: &mut row.2[r.clone()],
                validity: &mut row.3[r],
            },
        )
        .unwrap();
    }
    let mut state = vec![A::ZERO; FrameDecoder::state_len(&d, w, h)];
    let mut flags = vec![0u8; n];
    let mut fd = FrameDecoder::new(&d, w, h, &mut state, &mut flags).unwrap();
    for f in &frames {
        fd.push_frame(f).unwrap();
    }
    let mut seq = (
        vec![0.0f32; n],
        vec![0.0f32; n],
        vec![0.0f32; n],
        vec![0u8; n],
    );
    for y in (0..h).rev() {
        let r = y * w..(y + 1) * w;
        fd.finish_row(
            y,
            RowOut {
                phase: &mut seq.0[r.clone()],
                modulation: &mut seq.1[r.clone()],
                dc: &mut seq.2[r.clone()],
                validity: &mut seq.3[r],
            },
        )
        .unwrap();
    }
    let bits_of = |v: &[f32]| {
        v.iter()
            .map(|x| canonical(*x).to_bits())
            .collect::<Vec<_>>()
    };
    assert_eq!(bits_of(&row.0), bits_of(&seq.0), "{}: phase", A::NAME);
    assert_eq!(bits_of(&row.1), bits_of(&seq.1), "{}: modulation", A::NAME);
    assert_eq!(bits_of(&row.2), bits_of(&seq.2), "{}: dc", A::NAME);
    assert_eq!(row.3, seq.3, "{}: validity", A::NAME);
    assert!(
        row.3.contains(&0) && row.3.iter().any(|v| *v != 0),
        "{}: want valid and invalid pixels",
        A::NAME
    );
}

#[test]
fn row_and_frame_sequential_agree_for_every_backend() {
    for (set, bits) in [(paper(16), 16), (paper(8), 8), (steps357(12), 12)] {
        drivers_agree::<F32Accurate>(&set, bits);
        drivers_agree::<F32Fast>(&set, bits);
        drivers_agree::<F32Micromath>(&set, bits);
        drivers_agree::<Fixed>(&set, bits);
    }
}

#[test]
fn each_failure_gets_its_own_code_in_every_backend() {
    let set = paper(8);
    let (lo, hi) = set.coarse_range();
    let mid = 0.5 * (lo + hi) / set.levels()[0].scale();
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
        good, // level 1 shifted by π below: unwrap inconsistent
        Pixel {
            phi_p: (hi + 0.25) / set.levels()[0].scale(),
            ..good
        }, // out of range
    ];
    let mut imgs = images(&set, &px, 0.0, 255.0, &mut Rng(9));
    for (i, row) in imgs.iter_mut().enumerate() {
        let id = set.image(i).unwrap();
        if id.level == 1 {
            let lv = &set.levels()[1];
            let p = &px[4];
            row[4] = (p.a
                + p.b
                    * (lv.scale() * p.phi_p
                        + lv.shifts()[id.shift as usize]
                        + std::f64::consts::PI)
                        .sin())
            .round() as u16;
        }
    }
    let want = [
        Validity::Valid,
        Validity::Saturated,
        Validity::Dark,
        Validity::LowModulation,
        Validity::UnwrapInconsistent,
        Validity::PhaseOutOfRange,
    ];
    for backend in Backend::ALL {
        let d = AnyDecoder::new(&set, DecodeConfig::for_bit_depth(8), backend).unwrap();
        let o = decode(&d, &to_u8(&imgs));
        for (i, w) in want.iter().enumerate() {
            assert_eq!(Validity::from_u8(o.v[i]), Some(*w), "{backend}: pixel {i}");
            assert_eq!(o.phase[i].is_nan(), !w.is_valid());
        }
        // DC and modulation of the good pixel, in camera codes
        assert!(
            (o.a[0] - 120.0).abs() < 0.5 && (o.b[0] - 80.0).abs() < 0.1 * 80.0,
            "{backend}: A {} B {}",
            o.a[0],
            o.b[0]
        );
    }
}

#[test]
fn fixed_formats_follow_bit_depth_and_ratios() {
    // F: the largest with G·V·2^F ≤ 2^30 (G = 2 for the paper set).
    for (bits, want) in [(8u32, 21u32), (12, 17), (16, 13)] {
        let d =
            Decoder::<Fixed>::with_arith(&paper(bits), DecodeConfig::for_bit_depth(bits)).unwrap();
        assert_eq!(d.format().frac, want, "{bits}-bit");
        assert!((d.format().max_turns - (8.0 * (8.0 * 0.5 + 0.5) + 0.5)).abs() < 1e-12);
    }
    // A set whose finest phase could pass ±120 turns is refused by the fixed backend only.
    let f = PhaseFunction::centered(Axis::Xi, 1024, 5.6).unwrap();
    let steep = PatternSet::new(
        f,
        &[
            Level::n_step(1.0, 4),
            Level::two_step(16.0),
            Level::two_step(256.0),
        ],
        out(255.0),
    )
    .unwrap();
    assert!(Decoder::new(&steep, DecodeConfig::for_bit_depth(8)).is_ok());
    assert_eq!(
        Decoder::<Fixed>::with_arith(&steep, DecodeConfig::for_bit_depth(8)).err(),
        Some(fringe3d_core::decode::DecodeError::Degenerate(2))
    );
}
