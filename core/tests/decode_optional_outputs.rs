//! `RowOut`'s modulation and DC rows are optional (issue #23 item 3): empty rows give the phase
//! and validity bits of full ones, in every backend, for wide and short rows, through the row and
//! the frame-sequential drivers; a row of any other wrong length is still refused.

use crate::common::*;
use fringe3d_core::arith::Backend;
use fringe3d_core::decode::{AnyDecoder, DecodeConfig, DecodeError, Decoder, RowOut};
use fringe3d_core::pattern::PatternSet;
use fringe3d_core::sequential::FrameDecoder;

fn frames(set: &PatternSet, w: usize, seed: u64) -> Vec<Vec<u8>> {
    let (lo, hi) = set.coarse_range();
    let mut rng = Rng(seed);
    let px: Vec<Pixel> = (0..w)
        .map(|_| Pixel {
            a: 30.0 + 200.0 * rng.uniform(),
            b: 100.0 * rng.uniform(),
            phi_p: (lo + (hi - lo) * rng.uniform()) / set.levels()[0].scale(),
        })
        .collect();
    to_u8(&images(set, &px, 1.0, 255.0, &mut rng))
}

/// Phase bits and validity with full optional rows, and with empty ones.
fn both(
    mut decode: impl FnMut(RowOut<'_>) -> Result<(), DecodeError>,
    w: usize,
) -> [(Vec<u32>, Vec<u8>); 2] {
    let mut run = |full: bool| {
        let (mut ph, mut va) = (vec![0f32; w], vec![0u8; w]);
        let (mut mo, mut dc) = if full {
            (vec![0f32; w], vec![0f32; w])
        } else {
            (Vec::new(), Vec::new())
        };
        decode(RowOut {
            phase: &mut ph,
            modulation: &mut mo,
            dc: &mut dc,
            validity: &mut va,
        })
        .unwrap();
        (ph.iter().map(|p| p.to_bits()).collect(), va)
    };
    [run(true), run(false)]
}

#[test]
fn empty_modulation_and_dc_rows_change_no_bit() {
    let set = paper_set();
    for w in [1000, 200, 64, 37] {
        let fr = frames(&set, w, w as u64);
        let rows: Vec<&[u8]> = fr.iter().map(|f| &f[..]).collect();
        for backend in Backend::ALL {
            let d = AnyDecoder::new(&set, DecodeConfig::for_bit_depth(8), backend).unwrap();
            let [full, lean] = both(|out| d.decode_row(&rows, out), w);
            assert_eq!(full, lean, "{} at width {w}", backend.name());
            assert!(full.1.iter().filter(|&&v| v == 0).count() > w / 2);
        }
        // The frame-sequential driver.
        let d = Decoder::new(&set, DecodeConfig::for_bit_depth(8)).unwrap();
        let mut state = vec![0.0f32; FrameDecoder::state_len(&d, w, 1)];
        let mut flags = vec![0u8; w];
        let mut fd = FrameDecoder::new(&d, w, 1, &mut state, &mut flags).unwrap();
        for f in &fr {
            fd.push_frame(f).unwrap();
        }
        let [full, lean] = both(|out| fd.finish_row(0, out), w);
        assert_eq!(full, lean, "frame-sequential at width {w}");
        let [row, _] = both(|out| d.decode_row(&rows, out), w);
        assert_eq!(full, row, "frame-sequential = row at width {w}");
    }
}

#[test]
fn a_wrong_non_empty_length_is_still_refused() {
    let set = paper_set();
    let w = 200;
    let fr = frames(&set, w, 1);
    let rows: Vec<&[u8]> = fr.iter().map(|f| &f[..]).collect();
    let d = Decoder::new(&set, DecodeConfig::for_bit_depth(8)).unwrap();
    for (m, c) in [(w - 1, w), (w, w + 1), (1, 0), (0, 1)] {
        let (mut ph, mut va) = (vec![0f32; w], vec![0u8; w]);
        let (mut mo, mut dc) = (vec![0f32; m], vec![0f32; c]);
        let out = RowOut {
            phase: &mut ph,
            modulation: &mut mo,
            dc: &mut dc,
            validity: &mut va,
        };
        assert_eq!(
            d.decode_row(&rows, out),
            Err(DecodeError::Length),
            "{m}, {c}"
        );
    }
}
