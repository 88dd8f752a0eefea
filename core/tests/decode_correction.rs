//! The phase-error table ([`PhaseCorrection`]): a zero table changes no bit; with a table the row
//! and frame-sequential drivers still agree bit for bit; each level's corrected wrapped phase is
//! the f64 formula of the table (`PhaseCorrection::reference`) in every backend; bad tables are
//! refused.
#![allow(clippy::disallowed_methods)] // std f64 maths is the independent truth here

use crate::common::*;
use fringe3d_core::arith::{Backend, F32Accurate, Fixed};
use fringe3d_core::decode::{
    AnyDecoder, CORRECTION_KNOTS, CORRECTION_LSB, DecodeConfig, DecodeError, Decoder,
    PhaseCorrection, RowOut,
};
use fringe3d_core::pattern::PatternSet;

/// A table with a gamma-like shape: second and fourth harmonics of the wrapped phase, different
/// per level.
fn table(levels: usize) -> PhaseCorrection {
    let mut c = PhaseCorrection::zero(levels as u8);
    for l in 0..levels {
        for j in 0..CORRECTION_KNOTS {
            let phi =
                -std::f64::consts::PI + std::f64::consts::TAU * j as f64 / CORRECTION_KNOTS as f64;
            let a = 0.05 + 0.04 * l as f64;
            let v = a * (2.0 * phi + 0.3).sin() + 0.02 * (4.0 * phi).cos();
            c.delta[l][j] = (v / CORRECTION_LSB).round() as i16;
        }
    }
    c
}

/// Rows of the paper's set over the coarse range, with noise.
fn frames(set: &PatternSet, w: usize, h: usize, seed: u64) -> Vec<Vec<u8>> {
    let (lo, hi) = set.coarse_range();
    let mut rng = Rng(seed);
    let px: Vec<Pixel> = (0..w * h)
        .map(|i| Pixel {
            a: 120.0,
            b: 80.0,
            phi_p: (lo + (hi - lo) * ((i % w) as f64 + 0.5) / w as f64) / set.levels()[0].scale(),
        })
        .collect();
    to_u8(&images(set, &px, 1.0, 255.0, &mut rng))
}

fn decode_rows(d: &Decoder, fr: &[Vec<u8>], w: usize, h: usize) -> (Vec<u32>, Vec<u8>) {
    let (mut ph, mut mo, mut dc, mut va) =
        (vec![0f32; w], vec![0f32; w], vec![0f32; w], vec![0; w]);
    let (mut bits, mut val) = (Vec::new(), Vec::new());
    for y in 0..h {
        let rows: Vec<&[u8]> = fr.iter().map(|f| &f[y * w..(y + 1) * w]).collect();
        let out = RowOut {
            phase: &mut ph,
            modulation: &mut mo,
            dc: &mut dc,
            validity: &mut va,
        };
        d.decode_row(&rows, out).unwrap();
        bits.extend(ph.iter().map(|p| p.to_bits()));
        val.extend_from_slice(&va);
    }
    (bits, val)
}

#[test]
fn zero_table_changes_no_bit() {
    let set = paper_set();
    let (w, h) = (203, 3);
    let fr = frames(&set, w, h, 1);
    let d = Decoder::new(&set, DecodeConfig::for_bit_depth(8)).unwrap();
    let dz = d.with_correction(&PhaseCorrection::zero(3)).unwrap();
    assert!(dz.has_correction() && !d.has_correction());
    assert_eq!(decode_rows(&d, &fr, w, h), decode_rows(&dz, &fr, w, h));
}

#[test]
fn row_and_frame_sequential_agree_with_a_table() {
    let set = paper_set();
    let (w, h) = (203, 4);
    let fr = frames(&set, w, h, 2);
    let d = Decoder::new(&set, DecodeConfig::for_bit_depth(8))
        .unwrap()
        .with_correction(&table(3))
        .unwrap();
    let (row_bits, row_val) = decode_rows(&d, &fr, w, h);
    let plain = decode_rows(
        &Decoder::new(&set, DecodeConfig::for_bit_depth(8)).unwrap(),
        &fr,
        w,
        h,
    );
    assert_ne!(row_bits, plain.0, "the table must change the phase");
    let (bits, codes) = frame_sequential(&d, &fr, w, h);
    assert_eq!(bits, row_bits, "phase bits");
    assert_eq!(codes, row_val, "validity");
    assert!(row_val.iter().filter(|&&v| v == 0).count() > w * h * 9 / 10);
}

#[test]
fn each_level_follows_the_f64_formula_in_every_backend() {
    let set = paper_set();
    let (w, h) = (640, 1);
    let fr = frames(&set, w, h, 3);
    let rows: Vec<&[u8]> = fr.iter().map(|f| &f[..]).collect();
    let t = table(3);
    for backend in [Backend::F32Accurate, Backend::F32Fast, Backend::Fixed] {
        let plain = AnyDecoder::new(&set, DecodeConfig::for_bit_depth(8), backend).unwrap();
        let corr = plain.with_correction(&t).unwrap();
        for level in 0..3 {
            let (mut w0, mut w1, mut m) = (vec![0f32; w], vec![0f32; w], vec![0f32; w]);
            plain
                .decode_row_level(&rows, level, &mut w0, &mut m)
                .unwrap();
            corr.decode_row_level(&rows, level, &mut w1, &mut m)
                .unwrap();
            let worst = w0
                .iter()
                .zip(&w1)
                .map(|(a, b)| (t.reference(level, *a as f64) - *b as f64).abs())
                .fold(0.0, f64::max);
            // f32 rounding of φ (|φ| ≤ π) and of the interpolation; 2^-24 turn for fixed point.
            assert!(
                worst < 2e-6,
                "{backend:?} level {level}: {worst:e} rad from the formula"
            );
        }
    }
}

#[test]
fn fixed_and_f32_correct_alike_on_whole_rows() {
    let set = paper_set();
    let (w, h) = (640, 2);
    let fr = frames(&set, w, h, 4);
    let cfg = DecodeConfig::for_bit_depth(8);
    let f = Decoder::<F32Accurate>::with_arith(&set, cfg)
        .unwrap()
        .with_correction(&table(3))
        .unwrap();
    let x = Decoder::<Fixed>::with_arith(&set, cfg)
        .unwrap()
        .with_correction(&table(3))
        .unwrap();
    let (mut pf, mut px) = (vec![0f32; w], vec![0f32; w]);
    let (mut m, mut d, mut vf, mut vx) = (vec![0f32; w], vec![0f32; w], vec![0; w], vec![0; w]);
    for y in 0..h {
        let rows: Vec<&[u8]> = fr.iter().map(|fr| &fr[y * w..(y + 1) * w]).collect();
        f.decode_row(
            &rows,
            RowOut {
                phase: &mut pf,
                modulation: &mut m,
                dc: &mut d,
                validity: &mut vf,
            },
        )
        .unwrap();
        x.decode_row(
            &rows,
            RowOut {
                phase: &mut px,
                modulation: &mut m,
                dc: &mut d,
                validity: &mut vx,
            },
        )
        .unwrap();
        assert_eq!(vf, vx);
        for (a, b) in pf.iter().zip(&px) {
            if a.is_finite() {
                assert!((a - b).abs() < 2e-4, "f32 {a} vs fixed {b}");
            }
        }
    }
}

#[test]
fn bad_tables_are_refused() {
    let set = paper_set();
    let d = Decoder::new(&set, DecodeConfig::for_bit_depth(8)).unwrap();
    assert_eq!(
        d.with_correction(&PhaseCorrection::zero(2)).err(),
        Some(DecodeError::Config)
    );
    let mut t = table(3);
    t.delta[1][7] = PhaseCorrection::MAX_DELTA + 1;
    assert_eq!(d.with_correction(&t).err(), Some(DecodeError::Config));
    let mut t = table(3);
    t.delta[2][0] = -PhaseCorrection::MAX_DELTA - 1;
    assert_eq!(d.with_correction(&t).err(), Some(DecodeError::Config));
}
