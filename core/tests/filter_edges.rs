//! The edge filter (`fringe3d_core::filter`) on hand-made rows: the depth-edge limit against its
//! formula, the light-edge rule's neighbours and codes, and the codes it leaves alone. Its effect
//! on rendered scans (the flagged pixels are the renderer's light edges, and the errors they
//! carried) is measured in `tests/tests/reference_quality.rs`.

use fringe3d_core::Validity;
use fringe3d_core::filter::EdgeFilter;

const W: usize = 7;
const V: u8 = Validity::Valid as u8;

/// Points of one row at depth `z` (x, y irrelevant to the filter).
fn row(z: &[f32]) -> Vec<f32> {
    z.iter().flat_map(|&z| [0.0, 0.0, z]).collect()
}

fn filter() -> EdgeFilter {
    // 80° at f = 1000 px: a step of tan 80° / 1000 = 0.5671 % of the depth.
    EdgeFilter::new(1000.0, 80.0).expect("filter")
}

fn run(
    above: Option<(&[f32], &[u8])>,
    cur: (&[f32], &[u8]),
    below: Option<(&[f32], &[u8])>,
) -> Vec<u8> {
    let mut out = vec![0xAA; cur.1.len()];
    assert!(filter().filter_row(above, cur, below, &mut out));
    out
}

#[test]
fn a_depth_step_beyond_the_slope_limit_is_flagged_on_both_sides() {
    let step = (libm::tan(80f64.to_radians()) / 1000.0) as f32;
    // Within the limit (0.99 of it) between pixels 2 and 3; beyond it (1.01) between 4 and 5.
    let z0 = 600.0f32;
    let z: Vec<f32> = (0..W)
        .map(|i| match i {
            0..=2 => z0,
            3 | 4 => z0 * (1.0 + 0.99 * step),
            _ => z0 * (1.0 + 0.99 * step) * (1.0 + 1.01 * step),
        })
        .collect();
    let out = run(None, (&row(&z), &[V; W]), None);
    let edge = Validity::DepthEdge as u8;
    assert_eq!(out, [V, V, V, V, edge, edge, V]);
}

#[test]
fn a_pixel_beside_one_without_light_is_a_light_edge() {
    let z = row(&[600.0; W]);
    for unlit in [Validity::Dark, Validity::Saturated, Validity::LowModulation] {
        let u = unlit as u8;
        // In the row: both horizontal neighbours of pixel 3.
        let mut codes = [V; W];
        codes[3] = u;
        let out = run(None, (&z, &codes), None);
        let le = Validity::LightEdge as u8;
        assert_eq!(out, [V, V, le, u, le, V, V], "{unlit:?} in the row");
        // Above and below: the pixel under and over it only (4-neighbours, not diagonals).
        let mut other = [V; W];
        other[3] = u;
        for (a, b) in [(Some(&other), None), (None, Some(&other))] {
            let out = run(
                a.map(|c| (z.as_slice(), c.as_slice())),
                (&z, &[V; W]),
                b.map(|c| (z.as_slice(), c.as_slice())),
            );
            assert_eq!(out, [V, V, V, le, V, V, V], "{unlit:?} above or below");
        }
    }
}

#[test]
fn other_refusals_do_not_make_a_light_edge() {
    // A neighbour refused for its geometry or its fringe order had light: its neighbours keep
    // their points.
    let z = row(&[600.0; W]);
    for code in Validity::ALL {
        if matches!(
            code,
            Validity::Valid | Validity::Dark | Validity::Saturated | Validity::LowModulation
        ) {
            continue;
        }
        let mut codes = [V; W];
        codes[3] = code as u8;
        let out = run(Some((&z, &codes)), (&z, &codes), Some((&z, &codes)));
        assert_eq!(out, codes, "{code:?}");
    }
}

#[test]
fn a_depth_edge_wins_and_invalid_points_keep_their_codes() {
    let mut z = [600.0f32; W];
    z[4] = 700.0;
    let mut codes = [V; W];
    codes[2] = Validity::Dark as u8;
    codes[6] = Validity::NoCrossing as u8;
    let out = run(None, (&row(&z), &codes), None);
    let (de, le) = (Validity::DepthEdge as u8, Validity::LightEdge as u8);
    // Pixel 3 borders both the dark pixel 2 and the step to pixel 4.
    assert_eq!(out, [V, le, Validity::Dark as u8, de, de, de, codes[6]]);
}

#[test]
fn rows_of_other_lengths_are_refused() {
    let z = row(&[600.0; W]);
    let mut out = [0u8; W];
    let f = filter();
    assert!(!f.filter_row(None, (&z[..3 * W - 3], &[V; W]), None, &mut out));
    assert!(!f.filter_row(None, (&z, &[V; W]), None, &mut out[..W - 1]));
    assert!(!f.filter_row(Some((&z, &[V; W - 1])), (&z, &[V; W]), None, &mut out));
}
