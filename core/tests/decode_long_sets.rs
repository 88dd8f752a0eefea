//! Long pattern sets (issue #20): 12 steps × 4 levels = 48 images, within the 64-image cap
//! (`MAX_IMAGES`). The set decodes in every backend with the phase noise the N-step formula
//! predicts, the frame-sequential decoder gives the row decoder's bits, and 65 images are refused.
//!
//! Truth: Φ^(P) of each pixel, from which the images are synthesized in f64 (eq 14, independent
//! of the decoder); the noise prediction is the least-squares N-step formula
//! σ_φ = σ / (B·√(N/2)).
#![allow(clippy::disallowed_methods)] // std f64 maths is the independent truth here

use crate::common::*;
use fringe3d_core::arith::Backend;
use fringe3d_core::decode::{AnyDecoder, DecodeConfig, Decoder, RowOut};
use fringe3d_core::pattern::{Level, MAX_IMAGES, Output, PatternError, PatternSet};
use fringe3d_core::phase_function::{Axis, PhaseFunction};
use fringe3d_core::validity::Validity;

const W: u32 = 1024;

fn long_set(steps: usize, scales: &[f64]) -> Result<PatternSet, PatternError> {
    let out = Output {
        width: W,
        height: 8,
        i_min: 0.0,
        i_max: 255.0,
    };
    let f = PhaseFunction::centered(Axis::Xi, W, 0.9 * std::f64::consts::TAU).unwrap();
    let levels: Vec<Level> = scales.iter().map(|&c| Level::n_step(c, steps)).collect();
    PatternSet::new(f, &levels, out)
}

/// `rows` rows of `W` pixels spread over the whole coarse range: 8-bit images with noise σ.
fn frames(
    set: &PatternSet,
    rows: usize,
    b: f64,
    sigma: f64,
    seed: u64,
) -> (Vec<Pixel>, Vec<Vec<u16>>) {
    let (lo, hi) = set.coarse_range();
    let c0 = set.levels()[0].scale();
    let mut rng = Rng(seed);
    let px: Vec<Pixel> = (0..rows * W as usize)
        .map(|i| Pixel {
            a: 120.0,
            b,
            phi_p: (lo + (hi - lo) * ((i % W as usize) as f64 + 0.5) / W as f64) / c0,
        })
        .collect();
    let imgs = images(set, &px, sigma, 255.0, &mut rng);
    (px, imgs)
}

fn decode_rows(d: &AnyDecoder, imgs: &[Vec<u16>], rows: usize) -> (Vec<f32>, Vec<u8>) {
    let w = W as usize;
    let (mut ph, mut mo, mut dc, mut va) =
        (vec![0f32; w], vec![0f32; w], vec![0f32; w], vec![0; w]);
    let (mut phase, mut val) = (Vec::new(), Vec::new());
    for y in 0..rows {
        let r: Vec<&[u16]> = imgs.iter().map(|f| &f[y * w..(y + 1) * w]).collect();
        let out = RowOut {
            phase: &mut ph,
            modulation: &mut mo,
            dc: &mut dc,
            validity: &mut va,
        };
        d.decode_row(&r, out).unwrap();
        phase.extend_from_slice(&ph);
        val.extend_from_slice(&va);
    }
    (phase, val)
}

#[test]
fn twelve_steps_by_four_levels_decode_at_the_n12_noise() {
    let set = long_set(12, &[1.0, 4.0, 16.0, 64.0]).expect("48 images fit");
    assert_eq!(set.image_count(), 48);
    let fine = set.levels()[3].scale();
    let (b, sigma, rows) = (60.0, 1.0, 16);
    let (px, imgs) = frames(&set, rows, b, sigma, 48);
    // Rounding to 8 bits adds 1/12 code² of variance.
    let predicted = (sigma * sigma + 1.0 / 12.0).sqrt() / (b * (12.0f64 / 2.0).sqrt());
    for backend in Backend::ALL {
        let d = AnyDecoder::new(&set, DecodeConfig::for_bit_depth(8), backend).unwrap();
        let (phase, val) = decode_rows(&d, &imgs, rows);
        let (mut sum, mut n, mut orders) = (0.0, 0usize, 0usize);
        for (j, p) in px.iter().enumerate() {
            if val[j] != Validity::Valid as u8 {
                continue;
            }
            let e = phase[j] as f64 - fine * p.phi_p;
            if e.abs() > std::f64::consts::PI {
                orders += 1;
            } else {
                sum += e * e;
                n += 1;
            }
        }
        let rms = (sum / n as f64).sqrt();
        println!(
            "{}: phase RMS {rms:.5} rad, predicted {predicted:.5} ({:.3}×); valid {n} of {}; \
             order errors {orders}",
            backend.name(),
            rms / predicted,
            px.len()
        );
        assert_eq!(orders, 0, "{}", backend.name());
        assert!(n > px.len() * 99 / 100, "{}: {n} valid", backend.name());
        // Within 10 % of the prediction (the fixed-point backend's quantization included).
        assert!(
            (rms / predicted - 1.0).abs() < 0.10,
            "{}: {rms} vs {predicted}",
            backend.name()
        );
    }
}

#[test]
fn the_frame_sequential_decoder_gives_the_row_bits_for_48_images() {
    let set = long_set(12, &[1.0, 4.0, 16.0, 64.0]).unwrap();
    let (w, h) = (W as usize, 3);
    let (_, imgs) = frames(&set, h, 60.0, 1.0, 7);
    let d = Decoder::new(&set, DecodeConfig::for_bit_depth(8)).unwrap();
    let any = AnyDecoder::new(&set, DecodeConfig::for_bit_depth(8), Backend::F32Accurate).unwrap();
    let (row_phase, row_val) = decode_rows(&any, &imgs, h);
    let (bits, codes) = frame_sequential(&d, &imgs, w, h);
    let row_bits: Vec<u32> = row_phase.iter().map(|p| p.to_bits()).collect();
    assert_eq!(bits, row_bits, "phase bits");
    assert_eq!(codes, row_val, "validity");
}

#[test]
fn the_cap_is_64_images() {
    // 16 steps × 4 levels: exactly the cap.
    assert_eq!(
        long_set(16, &[1.0, 4.0, 16.0, 64.0]).unwrap().image_count(),
        MAX_IMAGES
    );
    // 13 × 5 = 65: refused by name.
    assert_eq!(
        long_set(13, &[1.0, 2.0, 4.0, 8.0, 16.0]).unwrap_err(),
        PatternError::TooManyImages(65)
    );
}
