//! Gray code + phase shifting (issue #20): plain and complementary codes decoded by every
//! backend, on camera rows rendered here from the set's own pattern intensities through a
//! Gaussian projector blur, a linear camera and Gaussian noise. The truth is the phase function
//! at each pixel's projector column; the quality bar is the issue's: zero fringe-order errors on
//! valid pixels at B/σ = 14 (8-bit, σ = 1 code), phase noise within 10 % of the N-step
//! prediction, and for the complementary code no losses at the period edges.
#![allow(clippy::disallowed_methods, clippy::needless_range_loop)] // std f64 maths is the truth

use crate::common::{Rng, frame_sequential};
use fringe3d_core::arith::Backend;
use fringe3d_core::decode::reference::decode_pixel;
use fringe3d_core::decode::{AnyDecoder, DecodeConfig, DecodeError, Decoder, RowOut};
use fringe3d_core::pattern::{GrayCode, ImageId, Level, Output, PatternError, PatternSet};
use fringe3d_core::phase_function::{Axis, PhaseFunction};
use fringe3d_core::sequential::FrameDecoder;
use fringe3d_core::validity::Validity;
use std::f64::consts::TAU;

/// Projector columns.
pub(crate) const PROJ: u32 = 1024;
/// Camera pixels per row (about 0.85 projector columns each).
pub(crate) const CAM: usize = 1200;
/// Periods of the phase level across the projector.
const PERIODS: f64 = 20.0;

pub(crate) fn output() -> Output {
    Output {
        width: PROJ,
        height: 8,
        i_min: 0.0,
        i_max: 255.0,
    }
}

/// Gray code of `bits` bits (complementary or not) and a 4-step level of scale
/// `PERIODS` over a phase function spanning one period across the projector.
fn gray_set(bits: u8, complementary: bool) -> PatternSet {
    let f = PhaseFunction::centered(Axis::Xi, PROJ, TAU).unwrap();
    let code = GrayCode::new(bits, complementary);
    let levels = [Level::gray_code(PERIODS, code), Level::n_step(PERIODS, 4)];
    PatternSet::new(f, &levels, output()).unwrap()
}

/// One camera row of every image (set order): camera pixel `p` sees projector column
/// `ξ = p·PROJ/CAM`, the pattern there blurred by a Gaussian of `blur` projector pixels
/// (41 samples over ±3σ), through a linear camera with DC `a` and modulation `b` (pattern gray
/// level 0 → `a − b`, 255 → `a + b`), Gaussian noise `sigma`, rounded and clipped to 8 bits.
/// Returns the images and the true absolute phase `c_K·Φ(ξ)` (finest level) of each pixel.
pub(crate) fn render_row(
    set: &PatternSet,
    (a, b, sigma, blur): (f64, f64, f64, f64),
    seed: u64,
) -> (Vec<Vec<u8>>, Vec<f64>) {
    let mut rng = Rng(seed);
    let scale = set.levels().last().unwrap().scale();
    let xi = |p: usize| p as f64 * PROJ as f64 / CAM as f64;
    let taps: Vec<(f64, f64)> = if blur > 0.0 {
        let t: Vec<(f64, f64)> = (0..41)
            .map(|k| {
                let d = (k as f64 - 20.0) / 20.0 * 3.0 * blur;
                (d, (-0.5 * (d / blur).powi(2)).exp())
            })
            .collect();
        let s: f64 = t.iter().map(|x| x.1).sum();
        t.into_iter().map(|(d, w)| (d, w / s)).collect()
    } else {
        vec![(0.0, 1.0)]
    };
    let images = (0..set.image_count())
        .map(|i| {
            (0..CAM)
                .map(|p| {
                    let level: f64 = taps
                        .iter()
                        .map(|&(d, w)| {
                            let x = (xi(p) + d).clamp(0.0, PROJ as f64 - 1.0);
                            w * set.intensity(i, x, 0.0).unwrap()
                        })
                        .sum();
                    let v = a - b + 2.0 * b * level / 255.0 + sigma * rng.normal();
                    v.round().clamp(0.0, 255.0) as u8
                })
                .collect()
        })
        .collect();
    let truth = (0..CAM)
        .map(|p| scale * set.function().eval(xi(p), 0.0))
        .collect();
    (images, truth)
}

pub(crate) struct Decoded {
    pub(crate) phase: Vec<f32>,
    pub(crate) validity: Vec<u8>,
}

pub(crate) fn decode(d: &AnyDecoder, images: &[Vec<u8>]) -> Decoded {
    let rows: Vec<&[u8]> = images.iter().map(|r| &r[..]).collect();
    let (mut phase, mut mo, mut dc, mut validity) = (
        vec![0f32; CAM],
        vec![0f32; CAM],
        vec![0f32; CAM],
        vec![0u8; CAM],
    );
    let out = RowOut {
        phase: &mut phase,
        modulation: &mut mo,
        dc: &mut dc,
        validity: &mut validity,
    };
    d.decode_row(&rows, out).unwrap();
    Decoded { phase, validity }
}

/// (valid pixels, valid pixels more than 1 rad from the truth: fringe-order errors).
pub(crate) fn score(d: &Decoded, truth: &[f64]) -> (usize, usize) {
    let valid: Vec<usize> = (0..CAM)
        .filter(|&p| d.validity[p] == Validity::Valid as u8)
        .collect();
    let wrong = valid
        .iter()
        .filter(|&&p| (d.phase[p] as f64 - truth[p]).abs() > 1.0)
        .count();
    (valid.len(), wrong)
}

/// B/σ = 14 on an 8-bit camera (σ = 1 code), a 1.5-pixel projector blur.
pub(crate) const BAR: (f64, f64, f64, f64) = (120.0, 14.0, 1.0, 1.5);

/// Decode rows rendered at [`BAR`] with seeds `seeds` by every backend: no fringe-order error
/// on a valid pixel, then `check(what, decoded, valid pixels)`.
pub(crate) fn on_every_backend(
    set: &PatternSet,
    seeds: std::ops::RangeInclusive<u64>,
    check: impl Fn(&str, &Decoded, usize),
) {
    let cfg = DecodeConfig::for_bit_depth(8);
    for seed in seeds {
        let (images, truth) = render_row(set, BAR, seed);
        for backend in Backend::ALL {
            let d = AnyDecoder::new(set, cfg, backend).unwrap();
            let got = decode(&d, &images);
            let (valid, wrong) = score(&got, &truth);
            let what = format!("{backend:?} seed {seed}");
            assert_eq!(wrong, 0, "{what}: order errors");
            check(&what, &got, valid);
        }
    }
}

/// Rows of `set` rendered at [`BAR`] with seeds `seeds`, decoded by the f32 backend: no
/// fringe-order error on a valid pixel, and at least 95 % of the pixels valid.
pub(crate) fn assert_orders_every_pixel(set: &PatternSet, seeds: std::ops::RangeInclusive<u64>) {
    let d = AnyDecoder::new(set, DecodeConfig::for_bit_depth(8), Backend::F32Accurate).unwrap();
    for seed in seeds {
        let (images, truth) = render_row(set, BAR, seed);
        let (valid, wrong) = score(&decode(&d, &images), &truth);
        assert_eq!(wrong, 0, "seed {seed}");
        assert!(valid as f64 >= 0.95 * CAM as f64, "seed {seed}: {valid}");
    }
}

/// [`on_every_backend`] for a set that unwraps without a code (heterodyne, coprime): at most
/// 1 % of the pixels refused for the order or the range, at least 95 % valid.
pub(crate) fn assert_orders_on_every_backend(set: &PatternSet) {
    on_every_backend(set, 1..=4, |what, got, valid| {
        let order = refused(
            got,
            &[Validity::UnwrapInconsistent, Validity::PhaseOutOfRange],
        );
        assert!(order <= CAM / 100, "{what}: {order} refused");
        assert!(
            valid as f64 >= 0.95 * CAM as f64,
            "{what}: {valid} of {CAM} valid"
        );
    });
}

/// Pixels refused with one of `codes`.
pub(crate) fn refused(got: &Decoded, codes: &[Validity]) -> usize {
    got.validity
        .iter()
        .filter(|&&v| codes.iter().any(|c| *c as u8 == v))
        .count()
}

#[test]
fn complementary_gray_orders_every_pixel_and_refuses_none_at_edges() {
    // No pixel refused for its code or its order (the plain code's edge losses); the 12-code
    // modulation floor of 8-bit sensors takes its ~1 % at B = 14.
    on_every_backend(&gray_set(5, true), 1..=4, |what, got, valid| {
        let edge = refused(
            got,
            &[Validity::CodeAmbiguous, Validity::UnwrapInconsistent],
        );
        assert_eq!(edge, 0, "{what}: edge refusals");
        assert!(
            valid as f64 >= 0.98 * CAM as f64,
            "{what}: {valid} of {CAM} valid"
        );
    });
}

#[test]
fn plain_gray_refuses_period_edges_rather_than_misordering_them() {
    let set = gray_set(5, false);
    let cfg = DecodeConfig::for_bit_depth(8);
    let (mut misordered_by_reference, mut refused) = (0, 0);
    for seed in 1..=4 {
        let (images, truth) = render_row(&set, BAR, seed);
        for backend in Backend::ALL {
            let d = AnyDecoder::new(&set, cfg, backend).unwrap();
            let got = decode(&d, &images);
            let (valid, wrong) = score(&got, &truth);
            assert_eq!(wrong, 0, "{backend:?} seed {seed}: order errors");
            assert!(
                valid as f64 >= 0.85 * CAM as f64,
                "{backend:?} seed {seed}: {valid} of {CAM} valid"
            );
            refused += CAM - valid;
        }
        // The reference decoder (no validity tests) shows what was refused: plain codes do
        // misorder pixels at the period edges, so the refusals above are needed.
        for p in 0..CAM {
            let s: Vec<f64> = images.iter().map(|r| r[p] as f64).collect();
            let r = decode_pixel(&set, &s).unwrap();
            misordered_by_reference += ((r.phase - truth[p]).abs() > 1.0) as usize;
        }
    }
    assert!(misordered_by_reference > 0, "the edges never misordered");
    assert!(refused > 0);
}

#[test]
fn the_complementary_code_beats_the_plain_one_at_the_edges() {
    let cfg = DecodeConfig::for_bit_depth(8);
    let valid = |comp: bool| {
        let set = gray_set(5, comp);
        let d = AnyDecoder::new(&set, cfg, Backend::F32Accurate).unwrap();
        let (images, truth) = render_row(&set, BAR, 9);
        score(&decode(&d, &images), &truth).0
    };
    let (plain, comp) = (valid(false), valid(true));
    assert!(comp > plain, "complementary {comp}, plain {plain}");
}

/// The finest phase's noise on 40 blur-free rows (seeds `first..first + 40`) at B = 14,
/// σ = 1 code, held to within 10 % of the 4-step prediction `√(2/N)·σ/B` (σ² = 1 + 1/12 for
/// the rounding; eq 14's least squares).
pub(crate) fn assert_four_step_noise(set: &PatternSet, first: u64) {
    let d = AnyDecoder::new(set, DecodeConfig::for_bit_depth(8), Backend::F32Accurate).unwrap();
    let (b, sigma) = (14.0, 1.0);
    let (mut sum, mut n) = (0.0, 0usize);
    for seed in first..first + 40 {
        let (images, truth) = render_row(set, (120.0, b, sigma, 0.0), seed);
        let got = decode(&d, &images);
        for p in 0..CAM {
            if got.validity[p] == Validity::Valid as u8 {
                sum += (got.phase[p] as f64 - truth[p]).powi(2);
                n += 1;
            }
        }
    }
    let rms = (sum / n as f64).sqrt();
    let predicted = 0.5f64.sqrt() * (sigma * sigma + 1.0 / 12.0).sqrt() / b;
    assert!(
        (rms / predicted - 1.0).abs() <= 0.10,
        "phase RMS {rms:.5} rad, predicted {predicted:.5}"
    );
}

/// Decode `set`'s row (seed `seed`) with the images of level `level` half a period off on the
/// first half of the row (as a moving or glossy surface gives): every pixel of that half
/// refused (a valid one would be off by a fringe), at least 85 % as inconsistent (the rest for
/// their modulation), none with a wrong order; the unshifted row decodes.
pub(crate) fn assert_a_disagreeing_level_is_flagged(set: &PatternSet, level: u8, seed: u64) {
    let d = AnyDecoder::new(set, DecodeConfig::for_bit_depth(8), Backend::F32Accurate).unwrap();
    let (images, truth) = render_row(set, BAR, seed);
    let shifted = set.with_phase_offset(std::f64::consts::PI).unwrap();
    let (other, _) = render_row(&shifted, BAR, seed);
    let mut mixed = images.clone();
    for i in 0..set.image_count() {
        if set.image(i).unwrap().level == level {
            mixed[i][..CAM / 2].copy_from_slice(&other[i][..CAM / 2]);
        }
    }
    let got = decode(&d, &mixed);
    let refused = got.validity[..CAM / 2].iter().filter(|&&v| v != 0).count();
    assert_eq!(refused, CAM / 2, "followed a disagreeing level");
    let flagged = got.validity[..CAM / 2]
        .iter()
        .filter(|&&v| v == Validity::UnwrapInconsistent as u8)
        .count();
    assert!(
        flagged as f64 >= 0.85 * (CAM / 2) as f64,
        "{flagged} of {} flagged",
        CAM / 2
    );
    assert_eq!(score(&got, &truth).1, 0);
    let (valid, wrong) = score(&decode(&d, &images), &truth);
    assert!(
        wrong == 0 && valid as f64 >= 0.95 * CAM as f64,
        "unshifted: {valid}"
    );
}

/// A row of `set` (seed `seed`) decoded by the f32 row driver follows the f64 reference within
/// 1e-3 rad on every valid pixel, and the frame-sequential driver gives its bits and codes.
pub(crate) fn assert_reference_and_drivers_agree(set: &PatternSet, seed: u64) {
    let d = Decoder::new(set, DecodeConfig::for_bit_depth(8)).unwrap();
    let (images, _) = render_row(set, BAR, seed);
    let got = decode(&AnyDecoder::F32Accurate(d), &images);
    assert_follows_the_reference(set, &images, &got, 1e-3);
    let (bits, codes) = crate::common::frame_sequential(&d, &images, CAM, 1);
    assert_eq!(codes, got.validity);
    assert_eq!(
        bits,
        got.phase.iter().map(|p| p.to_bits()).collect::<Vec<_>>()
    );
}

/// Every valid pixel of `got` (decoded from `images`) within `tol` rad of the f64 reference.
pub(crate) fn assert_follows_the_reference(
    set: &PatternSet,
    images: &[Vec<u8>],
    got: &Decoded,
    tol: f64,
) {
    for p in 0..CAM {
        if got.validity[p] != Validity::Valid as u8 {
            continue;
        }
        let s: Vec<f64> = images.iter().map(|r| r[p] as f64).collect();
        let r = decode_pixel(set, &s).unwrap();
        assert!(
            (got.phase[p] as f64 - r.phase).abs() < tol,
            "pixel {p}: {} vs {}",
            got.phase[p],
            r.phase
        );
    }
}

#[test]
fn phase_noise_matches_the_four_step_prediction() {
    assert_four_step_noise(&gray_set(5, true), 101);
}

#[test]
fn row_and_frame_sequential_paths_give_the_same_bits() {
    for comp in [false, true] {
        let set = gray_set(6, comp);
        let d = Decoder::new(&set, DecodeConfig::for_bit_depth(8)).unwrap();
        let h = 3;
        let mut frames = vec![Vec::new(); set.image_count()];
        let mut row_bits = Vec::new();
        let mut row_codes = Vec::new();
        for y in 0..h {
            let (images, _) = render_row(&set, BAR, 50 + y as u64);
            for (f, r) in frames.iter_mut().zip(&images) {
                f.extend_from_slice(r);
            }
            let got = decode(&AnyDecoder::F32Accurate(d), &images);
            row_bits.extend(got.phase.iter().map(|p| p.to_bits()));
            row_codes.extend(got.validity);
        }
        let (bits, codes) = frame_sequential(&d, &frames, CAM, h);
        assert_eq!(codes, row_codes, "complementary {comp}");
        assert_eq!(bits, row_bits, "complementary {comp}");
    }
}

#[test]
fn the_kernel_follows_the_reference_decoder() {
    let set = gray_set(5, true);
    let d = AnyDecoder::new(&set, DecodeConfig::for_bit_depth(8), Backend::F32Accurate).unwrap();
    let (images, _) = render_row(&set, BAR, 77);
    assert_follows_the_reference(&set, &images, &decode(&d, &images), 1e-4);
}

#[test]
fn ambiguous_codes_are_flagged_not_guessed() {
    // Flat gray Gray images (every bit at A): every bit ambiguous.
    let set = gray_set(5, true);
    let d = AnyDecoder::new(&set, DecodeConfig::for_bit_depth(8), Backend::F32Accurate).unwrap();
    let (mut images, _) = render_row(&set, (120.0, 40.0, 0.0, 0.0), 3);
    let first_gray = (0..set.image_count())
        .filter(|&i| set.image(i).unwrap().level == 0)
        .collect::<Vec<_>>();
    for &i in &first_gray[..2] {
        let dc: Vec<u8> = (0..CAM)
            .map(|p| {
                let s: f64 = (0..set.image_count())
                    .filter(|&k| set.image(k).unwrap().level == 1)
                    .map(|k| images[k][p] as f64)
                    .sum();
                (s / 4.0).round() as u8
            })
            .collect();
        images[i] = dc;
    }
    let got = decode(&d, &images);
    assert!(
        got.validity
            .iter()
            .all(|&v| v == Validity::CodeAmbiguous as u8),
        "{:?}",
        &got.validity[..8]
    );
}

#[test]
fn the_frame_sequential_path_needs_the_dc_level_first() {
    let set = gray_set(5, true);
    // Gray images first, then the 4-step level.
    let order: Vec<ImageId> = (0..6)
        .map(|s| ImageId { level: 0, shift: s })
        .chain((0..4).map(|s| ImageId { level: 1, shift: s }))
        .collect();
    let reordered = set.with_order(&order).unwrap();
    let d = Decoder::new(&reordered, DecodeConfig::for_bit_depth(8)).unwrap();
    let (w, h) = (64, 1);
    let mut state = vec![0f32; FrameDecoder::state_len(&d, w, h)];
    let mut flags = vec![0u8; w * h];
    assert!(!d.frame_sequential_order());
    let fd = FrameDecoder::new(&d, w, h, &mut state, &mut flags);
    assert_eq!(fd.err(), Some(DecodeError::GrayBeforeDc));
    // Fed image by image anyway, the first Gray image is refused.
    let mut st = fringe3d_core::decode::State {
        dc: &mut vec![0f32; w],
        s: Default::default(),
        c: Default::default(),
        flags: &mut vec![0u8; w],
    };
    let mut planes = vec![vec![0f32; w]; 4];
    let [s0, c0, s1, c1] = &mut planes[..] else {
        unreachable!()
    };
    st.s[0] = s0;
    st.c[0] = c0;
    st.s[1] = s1;
    st.c[1] = c1;
    assert_eq!(
        d.accumulate(0, &[100u8; 64], &mut st),
        Err(DecodeError::GrayBeforeDc)
    );
    // The row path takes any order: the same phases as the default order.
    let (images, _) = render_row(&set, BAR, 5);
    let by_id = |s: &PatternSet, id: ImageId| s.order().iter().position(|o| *o == id).unwrap();
    let reimages: Vec<Vec<u8>> = order
        .iter()
        .map(|&id| images[by_id(&set, id)].clone())
        .collect();
    let a = decode(
        &AnyDecoder::F32Accurate(Decoder::new(&set, DecodeConfig::for_bit_depth(8)).unwrap()),
        &images,
    );
    let b = decode(&AnyDecoder::F32Accurate(d), &reimages);
    assert_eq!(a.validity, b.validity);
    assert_eq!(
        a.phase.iter().map(|p| p.to_bits()).collect::<Vec<_>>(),
        b.phase.iter().map(|p| p.to_bits()).collect::<Vec<_>>()
    );
}

#[test]
fn malformed_gray_sets_are_refused() {
    let f = PhaseFunction::centered(Axis::Xi, PROJ, TAU).unwrap();
    let g = |bits, comp| Level::gray_code(PERIODS, GrayCode::new(bits, comp));
    let four = Level::n_step(PERIODS, 4);
    let (fine, finer) = (
        Level::n_step(4.0 * PERIODS, 4),
        Level::n_step(16.0 * PERIODS, 4),
    );
    let cases: [(&[Level], PatternError); 7] = [
        (
            &[g(5, true), four, fine, finer],
            PatternError::LevelCount(4),
        ),
        (&[g(5, true)], PatternError::GrayPlacement(0)),
        (&[four, g(5, true)], PatternError::GrayPlacement(1)),
        (
            &[g(5, true), Level::n_step(2.0 * PERIODS, 4)],
            PatternError::GrayPlacement(0),
        ),
        (&[g(0, true), four], PatternError::GrayBits(0)),
        (&[g(11, false), four], PatternError::GrayBits(11)),
        (
            &[g(5, true), Level::two_step(PERIODS)],
            PatternError::GrayNoDc,
        ),
    ];
    for (levels, want) in cases {
        assert_eq!(PatternSet::new(f, levels, output()).err(), Some(want));
    }
    // 20 periods need 5 bits (4 cover [−8.5, 7.5)).
    let e = PatternSet::new(f, &[g(4, true), four], output()).err();
    assert!(
        matches!(e, Some(PatternError::GrayRange { bits: 4, .. })),
        "{e:?}"
    );
}
