//! Gray codes with inverse patterns (issue #20 item 1, `GrayCode::inverted`): every code image
//! followed by its inverse, each bit thresholded against its own inverse rather than the DC
//! term A. Rendered and scored as the other Gray-code tests (`decode_gray`): no fringe-order
//! error on valid pixels at B/σ = 14 on every backend, the f64 reference, row = frame-sequential
//! bits (the code's images captured first, which the mean-intensity threshold cannot take), and
//! the case the inverse threshold is for: code images whose black and white do not straddle the
//! sinusoids' A (a projector whose 1-bit patterns are brighter than its 8-bit ones, and a
//! raised black), where the mean threshold reads every bit bright.
#![allow(clippy::disallowed_methods, clippy::needless_range_loop)] // std f64 maths is the truth

use crate::decode_gray::{
    BAR, CAM, PROJ, assert_follows_the_reference, decode, on_every_backend, output, render_row,
    score,
};
use fringe3d_core::arith::{Arith, Backend};
use fringe3d_core::decode::{AnyDecoder, DecodeConfig, DecodeError, Decoder, RowOut};
use fringe3d_core::pattern::{GrayCode, ImageId, Level, PatternError, PatternSet};
use fringe3d_core::phase_function::{Axis, PhaseFunction};
use fringe3d_core::sequential::FrameDecoder;
use std::f64::consts::TAU;

/// 20 periods of a 4-step level ordered by a `bits`-bit code, inverse or not.
fn set(bits: u8, complementary: bool, inverse: bool) -> PatternSet {
    let f = PhaseFunction::centered(Axis::Xi, PROJ, TAU).unwrap();
    let mut code = GrayCode::new(bits, complementary);
    if inverse {
        code = code.inverted();
    }
    let levels = [Level::gray_code(20.0, code), Level::n_step(20.0, 4)];
    PatternSet::new(f, &levels, output()).unwrap()
}

#[test]
fn the_images_are_the_code_and_its_inverse() {
    let code = GrayCode::new(5, true).inverted();
    assert_eq!(code.images(), 12);
    for h in 0..64 {
        for j in 0..6 {
            let plain = GrayCode::new(5, true);
            assert_eq!(code.bright(2 * j, h), plain.bright(j, h), "h {h} j {j}");
            assert_eq!(
                code.bright(2 * j + 1, h),
                !plain.bright(j, h),
                "h {h} j {j}"
            );
            assert_eq!(code.word_bit(2 * j + 1), plain.word_bit(j));
        }
    }
    // 16 images at most: 8 bits, or 7 and the complementary image.
    let f = PhaseFunction::centered(Axis::Xi, PROJ, TAU).unwrap();
    let big = [
        Level::gray_code(20.0, GrayCode::new(9, false).inverted()),
        Level::n_step(20.0, 4),
    ];
    assert_eq!(
        PatternSet::new(f, &big, output()).err(),
        Some(PatternError::GrayBits(9))
    );
}

#[test]
fn inverse_codes_order_every_pixel_on_every_backend() {
    for comp in [false, true] {
        // The plain code refuses the pixels at period edges (as with the mean threshold).
        let share = if comp { 0.95 } else { 0.9 };
        on_every_backend(&set(5, comp, true), 1..=3, |what, _, valid| {
            assert!(
                valid as f64 >= share * CAM as f64,
                "{what} complementary {comp}: {valid} of {CAM} valid"
            );
        });
    }
}

#[test]
fn the_kernel_follows_the_reference_and_both_drivers_agree_code_first() {
    let s = set(5, true, true);
    let d = Decoder::new(&s, DecodeConfig::for_bit_depth(8)).unwrap();
    let (images, _) = render_row(&s, BAR, 7);
    let got = decode(&AnyDecoder::F32Accurate(d), &images);
    assert_follows_the_reference(&s, &images, &got, 1e-3);
    // Captured code first (pairs in turn), then the phase level: a frame-sequential decoder
    // takes it (the mean threshold would need A first).
    let mut order: Vec<ImageId> = (0..12).map(|k| ImageId { level: 0, shift: k }).collect();
    order.extend((0..4).map(|k| ImageId { level: 1, shift: k }));
    let code_first = s.with_order(&order).unwrap();
    assert!(code_first.frame_sequential_order());
    let plain_first = set(5, true, false);
    let order: Vec<ImageId> = (0..6)
        .map(|k| ImageId { level: 0, shift: k })
        .chain((0..4).map(|k| ImageId { level: 1, shift: k }))
        .collect();
    assert!(
        !plain_first
            .with_order(&order)
            .unwrap()
            .frame_sequential_order()
    );
    let d = Decoder::new(&code_first, DecodeConfig::for_bit_depth(8)).unwrap();
    let (images, _) = render_row(&code_first, BAR, 7);
    let got = decode(&AnyDecoder::F32Accurate(d), &images);
    for backend in Backend::ALL {
        let any = AnyDecoder::new(&code_first, DecodeConfig::for_bit_depth(8), backend).unwrap();
        let row = decode(&any, &images);
        let (bits, codes) = match any {
            AnyDecoder::F32Accurate(d) => frames(&d, &images).unwrap(),
            AnyDecoder::F32Fast(d) => frames(&d, &images).unwrap(),
            AnyDecoder::F32Micromath(d) => frames(&d, &images).unwrap(),
            AnyDecoder::Fixed(d) => frames(&d, &images).unwrap(),
        };
        assert_eq!(codes, row.validity, "{backend:?}");
        let row_bits: Vec<u32> = row.phase.iter().map(|p| p.to_bits()).collect();
        assert_eq!(bits, row_bits, "{backend:?}");
    }
    assert!(got.validity.iter().filter(|&&v| v == 0).count() as f64 >= 0.95 * CAM as f64);
    // A pair split by another code image cannot be taken frame by frame.
    let mut split: Vec<ImageId> = (0..12).map(|k| ImageId { level: 0, shift: k }).collect();
    split.swap(1, 2);
    split.extend((0..4).map(|k| ImageId { level: 1, shift: k }));
    let split = s.with_order(&split).unwrap();
    assert!(!split.frame_sequential_order());
    let d = Decoder::new(&split, DecodeConfig::for_bit_depth(8)).unwrap();
    let e = frames(&d, &render_row(&split, BAR, 7).0).err();
    assert_eq!(e, Some(DecodeError::GrayBeforeDc));
}

/// The frame-sequential decode of one camera row per image by any backend: the phase bits and
/// the codes, or the first error.
fn frames<A: Arith>(
    d: &Decoder<A>,
    images: &[Vec<u8>],
) -> Result<(Vec<u32>, Vec<u8>), DecodeError> {
    let mut state = vec![A::ZERO; FrameDecoder::state_len(d, CAM, 1)];
    let mut flags = vec![0u8; CAM];
    let mut fd = FrameDecoder::new(d, CAM, 1, &mut state, &mut flags)?;
    for f in images {
        fd.push_frame(f)?;
    }
    let (mut ph, mut mo, mut dc, mut va) = (
        vec![0f32; CAM],
        vec![0f32; CAM],
        vec![0f32; CAM],
        vec![0; CAM],
    );
    let out = RowOut {
        phase: &mut ph,
        modulation: &mut mo,
        dc: &mut dc,
        validity: &mut va,
    };
    fd.finish_row(0, out)?;
    Ok((ph.iter().map(|p| p.to_bits()).collect(), va))
}

/// The code's images brighter than the phase levels' (gain 1.3) over a raised black (+40
/// codes): black and white both above the sinusoids' A (about 178 and 214 codes against 120),
/// none saturated.
fn brighter_code(s: &PatternSet, images: &mut [Vec<u8>]) {
    for (i, img) in images.iter_mut().enumerate() {
        if s.image(i).unwrap().level == 0 {
            for v in img.iter_mut() {
                *v = (*v as f64 * 1.3 + 40.0).round().min(254.0) as u8;
            }
        }
    }
}

#[test]
fn the_inverse_threshold_holds_where_the_mean_one_fails() {
    for inverse in [false, true] {
        let s = set(5, true, inverse);
        let d = AnyDecoder::new(&s, DecodeConfig::for_bit_depth(8), Backend::F32Accurate).unwrap();
        let (mut images, truth) = render_row(&s, BAR, 11);
        brighter_code(&s, &mut images);
        let got = decode(&d, &images);
        let (valid, wrong) = score(&got, &truth);
        if inverse {
            assert_eq!(wrong, 0);
            assert!(valid as f64 >= 0.95 * CAM as f64, "inverse: {valid}");
        } else {
            // Every bit reads bright: the mean threshold loses the scan (flagged or wrong).
            let lost = CAM - valid + wrong;
            assert!(
                lost as f64 >= 0.5 * CAM as f64,
                "mean threshold: {valid} valid, {wrong} wrong"
            );
        }
    }
}
