//! A span of a row (`Reconstructor::reconstruct_span`) and the search over a compiled row's
//! leftovers (`Reconstructor::search_left`) give the bits of the whole row: against the simple
//! form (`search_mask`, `reconstruct_row` over the whole row, `merge_search`), on noisy rows
//! (every stage of the search runs), at a width that is a multiple of the chunk and at one that
//! is not (a short last chunk). Misaligned spans are refused.
// Integration tests are std: std f64 maths is the independent truth here.
#![allow(clippy::disallowed_methods)]

use crate::reconstruct_support as support;

use fringe3d_core::Validity;
use fringe3d_core::reconstruct::compiled::{
    LEFT_TO_SEARCH, SearchScratch, merge_search, next_search_span, search_mask,
};
use fringe3d_core::reconstruct::{LANES, ReconstructError, Reconstructor, ReferenceMap};
use support::*;

const ROWS: [usize; 4] = [97, 400, 640, 950];

/// A rig of width `w`, its reconstructor, prepared reference map and a noisy object on `ROWS`.
fn scene(w: u32) -> (Reconstructor, Vec<f32>, PhaseMap) {
    let mut rig = Rig::default_rig();
    rig.cam.width = w;
    let recon = Reconstructor::new(&rig.cam.model(), &rig.setup()).expect("reconstructor");
    let mut reference = render_reference(&rig);
    let (surfaces, bounds) = bench_surfaces(&rig);
    let mut obj = render(&rig, &surfaces, bounds, ROWS.iter().copied());
    add_phase_noise([&mut reference, &mut obj], 0.01, 11);
    let (mw, mh) = (reference.width, reference.height);
    let mut prep = reference.phase.clone();
    ReferenceMap::prepare(&mut prep, &reference.validity, mw, mh).expect("map");
    (recon, prep, obj)
}

fn bits(x: &[f32]) -> Vec<u32> {
    x.iter().map(|c| c.to_bits()).collect()
}

/// Marks as a compiled row would: `LEFT_TO_SEARCH` on runs and isolated pixels (the last
/// column among them), a compiled code with a made-up point elsewhere.
fn compiled_codes(w: usize, seed: u64) -> (Vec<f32>, Vec<u8>) {
    let mut rng = Rng(seed);
    let mut codes = vec![Validity::OutOfDepth as u8; w];
    let mut xyz = vec![7.0f32; 3 * w];
    for u in 0..w {
        let r = rng.uniform();
        let run = (u / 100) % 3 == 0 && r < 0.6;
        if run || r < 0.01 || u == w - 1 {
            codes[u] = LEFT_TO_SEARCH;
            xyz[3 * u..3 * u + 3].fill(f32::NAN);
        } else if r < 0.5 {
            codes[u] = Validity::Valid as u8;
        }
    }
    (xyz, codes)
}

fn check_width(w: u32) {
    let (recon, prep, obj) = scene(w);
    let w = w as usize;
    let map = ReferenceMap::from_prepared(&prep, w, obj.height).expect("map");
    let mut searched = 0;
    for (k, &v) in ROWS.iter().enumerate() {
        let (p, q) = (
            &obj.phase[v * w..(v + 1) * w],
            &obj.validity[v * w..(v + 1) * w],
        );
        let (xyz0, codes0) = compiled_codes(w, 3 + k as u64);
        // The simple form: the whole row searched.
        let (mut o1, mut c1) = (xyz0.clone(), codes0.clone());
        let (mut mask, mut sx, mut sq) = (vec![0u8; w], vec![0f32; 3 * w], vec![0u8; w]);
        search_mask(&c1, q, &mut mask).expect("mask");
        recon
            .reconstruct_row(&map, v as u32, p, &mask, &mut sx, &mut sq)
            .expect("row");
        merge_search(&sx, &sq, &mut o1, &mut c1).expect("merge");
        // The runs only.
        let (mut o2, mut c2) = (xyz0.clone(), codes0.clone());
        let scratch = SearchScratch {
            mask: &mut mask,
            xyz: &mut sx,
            codes: &mut sq,
        };
        recon
            .search_left(&map, v as u32, p, q, &mut o2, &mut c2, scratch)
            .expect("search_left");
        assert_eq!(c2, c1, "codes, row {v}");
        assert_eq!(bits(&o2), bits(&o1), "points, row {v}");
        assert!(!c2.contains(&LEFT_TO_SEARCH));
        searched += codes0.iter().filter(|&&c| c == LEFT_TO_SEARCH).count();
        let valid = c1
            .iter()
            .zip(&codes0)
            .filter(|&(&c, &c0)| c0 == LEFT_TO_SEARCH && c == Validity::Valid as u8)
            .count();
        assert!(valid > 100, "row {v}: only {valid} searched pixels valid");

        // Every chunk-aligned span of the whole row, alone, gives the row's bits.
        let (mut xw, mut cw) = (vec![0f32; 3 * w], vec![0u8; w]);
        recon
            .reconstruct_row(&map, v as u32, p, q, &mut xw, &mut cw)
            .expect("row");
        for (a, b) in [(0, LANES), (LANES * 3, LANES * 7), (LANES * 10, w)] {
            let (mut xs, mut cs) = (vec![0f32; 3 * (b - a)], vec![0u8; b - a]);
            let (ps, qs) = (&p[a..b], &q[a..b]);
            recon
                .reconstruct_span(&map, v as u32, a, ps, qs, &mut xs, &mut cs)
                .expect("span");
            assert_eq!(cs, cw[a..b], "span {a}..{b} codes, row {v}");
            assert_eq!(bits(&xs), bits(&xw[3 * a..3 * b]), "span {a}..{b}, row {v}");
        }
    }
    assert!(searched > 1000, "only {searched} pixels searched");

    // Spans that do not start a chunk, or end inside one before the row's end, are refused.
    let v = ROWS[0] as u32;
    let (p, q) = (&obj.phase[..w], &obj.validity[..w]);
    for (a, b) in [(1, LANES + 1), (LANES, 2 * LANES - 3), (w - 5, w)] {
        if a % LANES == 0 && (b % LANES == 0 || b == w) {
            continue;
        }
        let (mut xs, mut cs) = (vec![0f32; 3 * (b - a)], vec![0u8; b - a]);
        let r = recon.reconstruct_span(&map, v, a, &p[a..b], &q[a..b], &mut xs, &mut cs);
        assert_eq!(r, Err(ReconstructError::Length), "span {a}..{b}");
    }
    let r = recon.reconstruct_span(&map, v, w, &[], &[], &mut [], &mut []);
    assert_eq!(r, Ok(()), "an empty span at the row's end");
}

#[test]
fn spans_and_leftovers_match_the_whole_row_at_a_multiple_of_the_chunk() {
    assert_eq!(1280 % LANES, 0);
    check_width(1280);
}

#[test]
fn spans_and_leftovers_match_the_whole_row_with_a_short_last_chunk() {
    assert_ne!(1270 % LANES, 0);
    check_width(1270);
}

#[test]
fn the_runs_of_chunks_that_hold_a_left_pixel() {
    let w = 3 * LANES + 5;
    let mut codes = vec![0u8; w];
    assert_eq!(next_search_span(&codes, 0), None);
    codes[LANES + 3] = LEFT_TO_SEARCH;
    codes[w - 1] = LEFT_TO_SEARCH;
    assert_eq!(next_search_span(&codes, 0), Some((LANES, 2 * LANES)));
    assert_eq!(next_search_span(&codes, 2 * LANES), Some((3 * LANES, w)));
    assert_eq!(next_search_span(&codes, w), None);
    // Neighbouring chunks make one run; a start inside a chunk is rounded down to it.
    codes[2 * LANES] = LEFT_TO_SEARCH;
    assert_eq!(next_search_span(&codes, 0), Some((LANES, w)));
    assert_eq!(
        next_search_span(&codes, 2 * LANES + 1),
        Some((2 * LANES, w))
    );
}
