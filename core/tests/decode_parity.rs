//! The row API and the frame-sequential API run one kernel: their outputs must be bit-identical,
//! for u8 and u16 inputs. Property tests: arbitrary inputs never panic and keep the invariants.
// Tests use std f64 maths as the independent truth; the ban on it is for the core library.
#![allow(clippy::disallowed_methods)]

use crate::common::*;
use fringe3d_core::decode::{DecodeConfig, Decoder, RowOut, Sample};
use fringe3d_core::math::canonical;
use fringe3d_core::pattern::{Level, Output, PatternSet};
use fringe3d_core::phase_function::{Axis, PhaseFunction};
use fringe3d_core::sequential::FrameDecoder;
use fringe3d_core::validity::Validity;
use proptest::prelude::*;

type Planes = (Vec<f32>, Vec<f32>, Vec<f32>, Vec<u8>);

fn row_api<P: Sample>(d: &Decoder, frames: &[Vec<P>], w: usize, h: usize) -> Planes {
    let mut o = (
        vec![0.0; w * h],
        vec![0.0; w * h],
        vec![0.0; w * h],
        vec![0u8; w * h],
    );
    for y in 0..h {
        let rows: Vec<&[P]> = frames.iter().map(|f| &f[y * w..(y + 1) * w]).collect();
        let r = y * w..(y + 1) * w;
        d.decode_row(
            &rows,
            RowOut {
                phase: &mut o.0[r.clone()],
                modulation: &mut o.1[r.clone()],
                dc: &mut o.2[r.clone()],
                validity: &mut o.3[r],
            },
        )
        .unwrap();
    }
    o
}

fn frame_api<P: Sample>(d: &Decoder, frames: &[Vec<P>], w: usize, h: usize) -> Planes {
    let mut state = vec![0.0f32; FrameDecoder::state_len(d, w, h)];
    let mut flags = vec![0u8; w * h];
    let mut fd = FrameDecoder::new(d, w, h, &mut state, &mut flags).unwrap();
    for f in frames {
        assert!(!fd.is_complete());
        fd.push_frame(f).unwrap();
    }
    assert!(fd.is_complete());
    let mut o = (
        vec![0.0; w * h],
        vec![0.0; w * h],
        vec![0.0; w * h],
        vec![0u8; w * h],
    );
    // Rows finished in reverse order: finishing must not depend on order.
    for y in (0..h).rev() {
        let r = y * w..(y + 1) * w;
        fd.finish_row(
            y,
            RowOut {
                phase: &mut o.0[r.clone()],
                modulation: &mut o.1[r.clone()],
                dc: &mut o.2[r.clone()],
                validity: &mut o.3[r],
            },
        )
        .unwrap();
    }
    o
}

/// The 8-bit decoder of `sets(255.0)[set_idx]` and one row of `w` random samples per image.
fn random_rows(set_idx: usize, w: usize, seed: u64) -> (Decoder, Vec<Vec<u8>>) {
    let set = &sets(255.0)[set_idx];
    let d = Decoder::new(set, DecodeConfig::for_bit_depth(8)).unwrap();
    let mut rng = Rng(seed);
    let frames = (0..set.image_count())
        .map(|_| (0..w).map(|_| (rng.next_u64() & 0xff) as u8).collect())
        .collect();
    (d, frames)
}

fn bits(v: &[f32]) -> Vec<u32> {
    v.iter().map(|x| canonical(*x).to_bits()).collect()
}

fn sets(max: f64) -> Vec<PatternSet> {
    let out = Output {
        width: 640,
        height: 480,
        i_min: 0.0,
        i_max: max,
    };
    let f = PhaseFunction::centered(Axis::Xi, 640, 5.6).unwrap();
    vec![
        PatternSet::default_for(Axis::Xi, out).unwrap(),
        PatternSet::twelve_pattern(f, 6.0, out).unwrap(),
        PatternSet::new(
            f,
            &[
                Level::two_step(1.0),
                Level::n_step(5.0, 3),
                Level::two_step(25.0),
            ],
            out,
        )
        .unwrap(),
    ]
}

fn synth(set: &PatternSet, w: usize, h: usize, sigma: f64, max: f64, seed: u64) -> Vec<Vec<u16>> {
    let (lo, hi) = set.coarse_range();
    let mut rng = Rng(seed);
    let px: Vec<Pixel> = (0..w * h)
        .map(|i| {
            let x = (i % w) as f64 / w as f64;
            // some pixels dark, saturated or flat, so every code path runs
            let a = 0.5 * max * (0.2 + 1.2 * rng.uniform());
            Pixel {
                a,
                b: a * rng.uniform(),
                phi_p: (lo + (hi - lo) * x) / set.levels()[0].scale(),
            }
        })
        .collect();
    images(set, &px, sigma, max, &mut rng)
}

#[test]
fn row_and_frame_sequential_are_bit_identical_u16_and_u8() {
    let (w, h) = (200, 7); // width not a multiple of the block size
    for (k, set) in sets(65535.0).iter().enumerate() {
        let d = Decoder::new(set, DecodeConfig::for_bit_depth(16)).unwrap();
        let frames = synth(set, w, h, 300.0, 65535.0, k as u64);
        let a = row_api(&d, &frames, w, h);
        let b = frame_api(&d, &frames, w, h);
        assert_eq!(bits(&a.0), bits(&b.0), "set {k}: phase");
        assert_eq!(bits(&a.1), bits(&b.1), "set {k}: modulation");
        assert_eq!(bits(&a.2), bits(&b.2), "set {k}: dc");
        assert_eq!(a.3, b.3, "set {k}: validity");
        assert!(
            a.3.contains(&0) && a.3.iter().any(|&v| v != 0),
            "set {k}: want both valid and invalid pixels"
        );
    }
    for (k, set) in sets(255.0).iter().enumerate() {
        let d = Decoder::new(set, DecodeConfig::for_bit_depth(8)).unwrap();
        let frames: Vec<Vec<u8>> = to_u8(&synth(set, w, h, 2.0, 255.0, 100 + k as u64));
        let a = row_api(&d, &frames, w, h);
        let b = frame_api(&d, &frames, w, h);
        assert_eq!(bits(&a.0), bits(&b.0), "u8 set {k}: phase");
        assert_eq!(a.3, b.3, "u8 set {k}: validity");
    }
}

#[test]
fn frame_decoder_refuses_misuse() {
    let set = &sets(255.0)[0];
    let d = Decoder::new(set, DecodeConfig::for_bit_depth(8)).unwrap();
    let mut small = vec![0.0f32; 10];
    let mut flags = vec![0u8; 100];
    assert!(FrameDecoder::new(&d, 10, 10, &mut small, &mut flags).is_err());
    let mut state = vec![0.0f32; FrameDecoder::state_len(&d, 10, 10)];
    let mut fd = FrameDecoder::new(&d, 10, 10, &mut state, &mut flags).unwrap();
    assert!(fd.push_row(&[0u8; 9]).is_err());
    let mut o = [0.0f32; 10];
    let (mut m, mut a, mut v) = ([0.0f32; 10], [0.0f32; 10], [0u8; 10]);
    assert!(
        fd.finish_row(
            0,
            RowOut {
                phase: &mut o,
                modulation: &mut m,
                dc: &mut a,
                validity: &mut v
            }
        )
        .is_err()
    );
    for _ in 0..set.image_count() {
        fd.push_frame(&[100u8; 100]).unwrap();
    }
    assert!(
        fd.push_row(&[0u8; 10]).is_err(),
        "pushing past the last frame"
    );
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]

    #[test]
    fn arbitrary_rows_never_panic_and_keep_invariants(
        w in 1usize..150,
        seed in any::<u64>(),
        set_idx in 0usize..3,
    ) {
        let (d, frames) = random_rows(set_idx, w, seed);
        let o = row_api(&d, &frames, w, 1);
        for i in 0..w {
            let v = Validity::from_u8(o.3[i]);
            prop_assert!(v.is_some());
            prop_assert_eq!(o.0[i].is_finite(), v.unwrap().is_valid());
            prop_assert!(o.1[i].is_finite() && o.1[i] >= 0.0);
        }
    }

    /// Rows are decoded in whole 64-pixel blocks, the last one overlapping the one before, and
    /// rows shorter than a block through a padded copy: every pixel must come out exactly as it
    /// does when decoded alone (a one-pixel row), wherever it sits, for both APIs.
    #[test]
    fn every_pixel_decodes_as_it_does_alone(
        w in 1usize..200,
        seed in any::<u64>(),
        set_idx in 0usize..3,
    ) {
        let (d, frames) = random_rows(set_idx, w, seed);
        let row = row_api(&d, &frames, w, 1);
        let seq = frame_api(&d, &frames, w, 1);
        prop_assert_eq!((bits(&row.0), bits(&row.1), bits(&row.2), &row.3), (bits(&seq.0), bits(&seq.1), bits(&seq.2), &seq.3));
        for i in 0..w {
            let one: Vec<Vec<u8>> = frames.iter().map(|f| vec![f[i]]).collect();
            let o = row_api(&d, &one, 1, 1);
            prop_assert_eq!(
                (canonical(o.0[0]).to_bits(), o.1[0].to_bits(), o.2[0].to_bits(), o.3[0]),
                (canonical(row.0[i]).to_bits(), row.1[i].to_bits(), row.2[i].to_bits(), row.3[i]),
                "pixel {} of {}", i, w
            );
        }
    }

    #[test]
    fn random_a_b_phase_decode_to_truth(
        a in 5000.0f64..40000.0,
        b_frac in 0.3f64..0.6, // B ≥ 1500 codes, above the 2 % modulation threshold
        t in 0.0f64..1.0,
    ) {
        // noise-free 16-bit: error bounded by quantization, σφ ≈ 0.3·√0.5/B per pixel; allow 6σ + f32
        let set = &sets(65535.0)[0];
        let d = Decoder::new(set, DecodeConfig::for_bit_depth(16)).unwrap();
        let b = a * b_frac;
        let (lo, hi) = set.coarse_range();
        let px = [Pixel { a, b, phi_p: lo + (hi - lo) * t }];
        let imgs = images(set, &px, 0.0, 65535.0, &mut Rng(0));
        let o = row_api(&d, &imgs, 1, 1);
        prop_assert_eq!(o.3[0], 0);
        let ck = set.levels()[2].scale();
        let e = o.0[0] as f64 - ck * px[0].phi_p;
        let bound = 6.0 * 0.3 * 1.2 / b + 3e-5;
        prop_assert!(e.abs() < bound, "error {} bound {}", e, bound);
    }
}
