//! HDR fusion (issue #19 item 4): one set captured at three exposures, longest first, with
//! pixels bright enough to clip at the longer ones. The truth is taken from the images
//! themselves: a pixel's exposure is the first in which none of its samples reaches the
//! decoder's saturation level, and its fused output must be that exposure's own decode, bit for
//! bit. Both drivers are held to it: the row driver with [`fuse_exposure`], and the
//! frame-sequential one with [`FrameDecoder::next_exposure`] (the head's way: no store beyond
//! its state).
#![allow(clippy::disallowed_methods)] // std f64 maths is the truth

use crate::common::{Rng, paper_set};
use fringe3d_core::decode::hdr::{MAX_EXPOSURES, RowRef, any_saturated, fuse_exposure};
use fringe3d_core::decode::{DecodeConfig, DecodeError, Decoder, RowOut};
use fringe3d_core::pattern::{GrayCode, Level, PatternSet};
use fringe3d_core::phase_function::{Axis, PhaseFunction};
use fringe3d_core::sequential::FrameDecoder;
use fringe3d_core::validity::Validity;
use std::f64::consts::TAU;

const W: usize = 300;
const H: usize = 4;
const EXPOSURES: [f64; 3] = [1.0, 0.3, 0.08];

/// One decoded frame: phase bits, modulation bits, DC bits, codes.
type Out = (Vec<u32>, Vec<u32>, Vec<u32>, Vec<u8>);

/// The frames (set order) of each exposure: a phase ramp across the row; the surface's
/// brightness (modulation 40 to 1440 codes at the long exposure) rises along the row, so that
/// pixels clip at the long exposure from a third of the row on, at the middle one from about two
/// thirds, at the short one nowhere.
fn scene(set: &PatternSet, seed: u64) -> Vec<Vec<Vec<u8>>> {
    let mut rng = Rng(seed);
    let proj = set.output().width as f64;
    EXPOSURES
        .iter()
        .map(|&e| {
            let mut frames = vec![Vec::new(); set.image_count()];
            for y in 0..H {
                for x in 0..W {
                    let t = x as f64 / (W - 1) as f64;
                    let b = 40.0 * 36f64.powf(t);
                    let xi = proj * (x as f64 + 0.5 + 0.3 * y as f64) / (W + 1) as f64;
                    for (i, f) in frames.iter_mut().enumerate() {
                        // Gray level 0 → 10 codes, 255 → 10 + 2b (at the long exposure).
                        let level = set.intensity(i, xi, 0.0).unwrap() / 255.0;
                        let v = e * (10.0 + 2.0 * b * level) + rng.normal();
                        f.push(v.round().clamp(0.0, 255.0) as u8);
                    }
                }
            }
            frames
        })
        .collect()
}

fn decode_rows(d: &Decoder, frames: &[Vec<u8>]) -> Out {
    let mut o: Out = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    for y in 0..H {
        let rows: Vec<&[u8]> = frames.iter().map(|f| &f[y * W..(y + 1) * W]).collect();
        let (mut ph, mut mo, mut dc, mut va) =
            (vec![0f32; W], vec![0f32; W], vec![0f32; W], vec![0; W]);
        d.decode_row(
            &rows,
            RowOut {
                phase: &mut ph,
                modulation: &mut mo,
                dc: &mut dc,
                validity: &mut va,
            },
        )
        .unwrap();
        o.0.extend(ph.iter().map(|v| v.to_bits()));
        o.1.extend(mo.iter().map(|v| v.to_bits()));
        o.2.extend(dc.iter().map(|v| v.to_bits()));
        o.3.extend(va);
    }
    o
}

/// The row driver: each exposure decoded, folded in longest first; a row of a shorter exposure
/// is decoded only where the fusion so far has a saturated pixel.
fn fused_rows(d: &Decoder, exposures: &[Vec<Vec<u8>>]) -> (Out, [usize; 3]) {
    let mut o: Out = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    let mut taken = [0usize; 3];
    for y in 0..H {
        let (mut ph, mut mo, mut dc, mut va) =
            (vec![0f32; W], vec![0f32; W], vec![0f32; W], vec![0; W]);
        for (e, frames) in exposures.iter().enumerate() {
            let rows: Vec<&[u8]> = frames.iter().map(|f| &f[y * W..(y + 1) * W]).collect();
            let mut best = RowOut {
                phase: &mut ph,
                modulation: &mut mo,
                dc: &mut dc,
                validity: &mut va,
            };
            if e == 0 {
                d.decode_row(&rows, best).unwrap();
                taken[0] += W;
                continue;
            }
            if !any_saturated(best.validity) {
                break;
            }
            let (mut p2, mut m2, mut d2, mut v2) =
                (vec![0f32; W], vec![0f32; W], vec![0f32; W], vec![0; W]);
            d.decode_row(
                &rows,
                RowOut {
                    phase: &mut p2,
                    modulation: &mut m2,
                    dc: &mut d2,
                    validity: &mut v2,
                },
            )
            .unwrap();
            let next = RowRef {
                phase: &p2,
                modulation: &m2,
                dc: &d2,
                validity: &v2,
            };
            let n = fuse_exposure(&mut best, &next).unwrap();
            taken[e] += n;
            taken[e - 1] -= n;
        }
        o.0.extend(ph.iter().map(|v| v.to_bits()));
        o.1.extend(mo.iter().map(|v| v.to_bits()));
        o.2.extend(dc.iter().map(|v| v.to_bits()));
        o.3.extend(va);
    }
    (o, taken)
}

/// The frame-sequential driver: every exposure's frames pushed, `next_exposure` between them.
fn fused_frames(d: &Decoder, exposures: &[Vec<Vec<u8>>]) -> Out {
    let mut state = vec![0.0f32; FrameDecoder::state_len(d, W, H)];
    let mut flags = vec![0u8; W * H];
    let mut fd = FrameDecoder::new(d, W, H, &mut state, &mut flags).unwrap();
    let sat = d.config().saturation_level;
    for (e, frames) in exposures.iter().enumerate() {
        if e > 0 {
            fd.next_exposure().unwrap();
        }
        assert_eq!(fd.exposure(), e);
        for f in frames {
            fd.push_frame(f).unwrap();
        }
        // Some pixel still saturated, from the images: one that clipped in every exposure so
        // far (`saturated_left` lets a head skip the shorter exposures when there is none).
        let clipped_in = |k: usize, i: usize| exposures[k].iter().any(|f| f32::from(f[i]) >= sat);
        let left = (0..W * H).any(|i| (0..=e).all(|k| clipped_in(k, i)));
        assert_eq!(fd.saturated_left(), left, "exposure {e}");
    }
    let mut o: Out = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    let (mut ph, mut mo, mut dc, mut va) =
        (vec![0f32; W], vec![0f32; W], vec![0f32; W], vec![0; W]);
    for y in 0..H {
        let out = RowOut {
            phase: &mut ph,
            modulation: &mut mo,
            dc: &mut dc,
            validity: &mut va,
        };
        fd.finish_row(y, out).unwrap();
        o.0.extend(ph.iter().map(|v| v.to_bits()));
        o.1.extend(mo.iter().map(|v| v.to_bits()));
        o.2.extend(dc.iter().map(|v| v.to_bits()));
        o.3.extend_from_slice(&va);
    }
    o
}

fn check(set: &PatternSet) {
    let cfg = DecodeConfig::for_bit_depth(8);
    let d = Decoder::new(set, cfg).unwrap();
    let exposures = scene(set, 19);
    let singles: Vec<Out> = exposures.iter().map(|f| decode_rows(&d, f)).collect();
    // The truth from the images: the first exposure none of whose samples saturates.
    let sat = cfg.saturation_level;
    let chosen: Vec<usize> = (0..W * H)
        .map(|i| {
            (0..EXPOSURES.len())
                .find(|&e| exposures[e].iter().all(|f| f32::from(f[i]) < sat))
                .unwrap_or(EXPOSURES.len() - 1)
        })
        .collect();
    let mut per = [0usize; 3];
    for &e in &chosen {
        per[e] += 1;
    }
    // Each exposure supplies pixels, or the test proves nothing.
    assert!(per.iter().all(|&n| n >= 40), "pixels per exposure {per:?}");
    let (rows, taken) = fused_rows(&d, &exposures);
    assert_eq!(taken, per, "pixels taken per exposure by the row driver");
    for i in 0..W * H {
        let s = &singles[chosen[i]];
        let got = (rows.0[i], rows.1[i], rows.2[i], rows.3[i]);
        assert_eq!(
            got,
            (s.0[i], s.1[i], s.2[i], s.3[i]),
            "pixel {i}, exposure {}",
            chosen[i]
        );
    }
    // Without fusion the long exposure loses the highlight; fused, only what clips at all three.
    let lost = |o: &Out| {
        o.3.iter()
            .filter(|&&v| v == Validity::Saturated as u8)
            .count()
    };
    let all_clip = (0..W * H)
        .filter(|&i| exposures[2].iter().any(|f| f32::from(f[i]) >= sat))
        .count();
    assert!(lost(&singles[0]) >= W * H / 2, "{}", lost(&singles[0]));
    assert_eq!(lost(&rows), all_clip);
    let valid = rows.3.iter().filter(|&&v| v == 0).count();
    assert!(
        valid + all_clip >= W * H * 95 / 100,
        "valid {valid} of {}",
        W * H
    );
    // The frame-sequential driver: the same bits.
    assert_eq!(fused_frames(&d, &exposures), rows);
}

#[test]
fn each_pixel_is_its_longest_unsaturated_exposure_in_both_drivers() {
    check(&paper_set());
}

#[test]
fn gray_code_sets_fuse_the_same_way() {
    let f = PhaseFunction::centered(Axis::Xi, 640, TAU).unwrap();
    let levels = [
        Level::gray_code(8.0, GrayCode::new(4, false)),
        Level::n_step(8.0, 4),
    ];
    let out = fringe3d_core::pattern::Output {
        width: 640,
        height: 480,
        i_min: 0.0,
        i_max: 255.0,
    };
    check(&PatternSet::new(f, &levels, out).unwrap());
}

#[test]
fn exposures_follow_a_complete_set_and_are_bounded() {
    let set = paper_set();
    let d = Decoder::new(&set, DecodeConfig::for_bit_depth(8)).unwrap();
    let mut state = vec![0.0f32; FrameDecoder::state_len(&d, W, H)];
    let mut flags = vec![0u8; W * H];
    let mut fd = FrameDecoder::new(&d, W, H, &mut state, &mut flags).unwrap();
    assert_eq!(fd.next_exposure(), Err(DecodeError::Sequence));
    let frame = vec![100u8; W * H];
    for e in 0..MAX_EXPOSURES {
        for _ in 0..set.image_count() {
            fd.push_frame(&frame).unwrap();
        }
        // Nothing clipped: nothing left for a shorter exposure.
        assert!(!fd.saturated_left());
        let r = fd.next_exposure();
        if e + 1 < MAX_EXPOSURES {
            r.unwrap();
        } else {
            assert_eq!(r, Err(DecodeError::Sequence));
        }
    }
    let mut short = RowOut {
        phase: &mut [0.0; 3],
        modulation: &mut [],
        dc: &mut [],
        validity: &mut [2; 3],
    };
    let next = RowRef {
        phase: &[0.0; 2],
        modulation: &[],
        dc: &[],
        validity: &[0; 2],
    };
    assert_eq!(fuse_exposure(&mut short, &next), Err(DecodeError::Length));
}
