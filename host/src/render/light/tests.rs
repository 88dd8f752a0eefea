//! Tests of the projector light against the defining sum.

use super::*;
use fringe3d_core::pattern::Output;
use fringe3d_core::phase_function::{Axis, PhaseFunction};

fn set(curvature: f64) -> PatternSet {
    let out = Output {
        width: 256,
        height: 192,
        i_min: 0.0,
        i_max: 65535.0,
    };
    let mut f = PhaseFunction::centered(Axis::Xi, 256, 0.9 * std::f64::consts::TAU).unwrap();
    if curvature != 0.0 {
        f = f.curved(curvature, 95.5).unwrap();
    }
    // Finest level: 0.9·16 = 14.4 periods over 256 px (17.8 px period, as the default set).
    PatternSet::paper_eight(f, 4.0, out).unwrap()
}

/// The defining sum Σ v_ij K(ξ − i) K(η − j) over every DMD pixel.
fn brute(s: &PatternSet, index: usize, sigma: f64, xi: f64, eta: f64) -> f64 {
    let mut row = vec![0u16; 256];
    let mut acc = 0.0;
    for j in 0..192 {
        let ky = box_gauss(eta - j as f64, sigma);
        if ky < 1e-15 {
            continue;
        }
        s.generate_row::<u16>(index, j, &mut row).unwrap();
        for (i, &c) in row.iter().enumerate() {
            acc += c as f64 / 65535.0 * box_gauss(xi - i as f64, sigma) * ky;
        }
    }
    acc
}

/// Worst error (interior points ≥ 3σ + 2 inside the DMD, points near or beyond its edges).
fn worst(curvature: f64, sigma: f64) -> (f64, f64) {
    let s = set(curvature);
    let slides: Vec<Slide> = (0..s.image_count())
        .map(|index| Slide::Pattern {
            set: &s,
            index,
            bits: 16,
        })
        .collect();
    let optics = Optics {
        mode: ProjectorMode::Pixelated,
        defocus: sigma,
        gamma: 1.0,
        black_level: 0.0,
        response: None,
    };
    let ls = LightSet::new(256, 192, &slides, optics).unwrap();
    let mut out = vec![0.0; slides.len()];
    let (mut w, mut we): (f64, f64) = (0.0, 0.0);
    for k in 0..80 {
        // Points all over the DMD, edges and beyond included.
        let xi = -4.0 + 263.0 * ((k as f64 * 0.618_034) % 1.0);
        let eta = -4.0 + 199.0 * ((k as f64 * 0.414_214 + 0.1) % 1.0);
        ls.eval(xi, eta, &mut out);
        let interior = ls.frame_margin(xi, eta) >= 3.0 * sigma + 2.0;
        for i in [0, 3, 6] {
            let e = (out[i] - brute(&s, i, sigma, xi, eta)).abs();
            if interior {
                w = w.max(e);
            } else {
                we = we.max(e);
            }
        }
    }
    (w, we)
}

#[test]
fn separable_table_matches_the_defining_sum() {
    for sigma in [0.3, 1.0, 2.5] {
        let (e, edge) = worst(0.0, sigma);
        assert!(e < 2e-7 && edge < 2e-7, "σ = {sigma}: {e} {edge}");
    }
}

#[test]
fn grid_and_direct_paths_match_the_defining_sum() {
    // Curved fringes: σ ≥ 1 uses the ½-pixel grid, ½ ≤ σ < 1 the ¼-pixel grid, σ < ½ the
    // direct sum. Near the DMD's edges (a unit step, blurred) the grid's cubic interpolation is
    // less accurate; those points are never CLEAN in the renderer's mask.
    for (sigma, tol, tol_edge) in [(1.0, 3e-5, 2e-3), (0.7, 3e-5, 2e-3), (0.3, 1e-7, 1e-7)] {
        let (e, edge) = worst(0.0005, sigma);
        eprintln!("σ = {sigma}: interior {e:.2e}, edges {edge:.2e}");
        assert!(e < tol && edge < tol_edge, "σ = {sigma}: {e} {edge}");
    }
}

#[test]
fn sharp_pixels_are_exact() {
    let s = set(0.0);
    let slides = [Slide::Pattern {
        set: &s,
        index: 0,
        bits: 16,
    }];
    let optics = Optics {
        mode: ProjectorMode::Pixelated,
        defocus: 0.0,
        gamma: 1.0,
        black_level: 0.0,
        response: None,
    };
    let ls = LightSet::new(256, 192, &slides, optics).unwrap();
    let mut row = vec![0u16; 256];
    s.generate_row::<u16>(0, 7, &mut row).unwrap();
    let mut out = [0.0];
    for (i, &code) in row.iter().enumerate() {
        ls.eval(i as f64 + 0.49, 7.3, &mut out);
        assert_eq!(out[0], code as f64 / 65535.0);
    }
    ls.eval(-0.51, 7.0, &mut out);
    assert_eq!(out[0], 0.0);
}

#[test]
fn response_tables_are_checked() {
    use super::ResponseLut;
    assert!(ResponseLut::new(&[0.0, 0.3, 1.0]).is_ok());
    for bad in [
        &[0.0][..],
        &[0.0, 0.5, 0.4, 1.0],
        &[0.1, 0.5, 1.0],
        &[0.0, 0.5, 0.9],
        &[0.0, f64::NAN, 1.0],
    ] {
        assert!(ResponseLut::new(bad).is_err(), "{bad:?}");
    }
    assert!(ResponseLut::new(&vec![0.5; 66]).is_err());
    // The table is the model: at its knots the light is the table's value.
    let t = ResponseLut::new(&[0.0, 0.1, 0.45, 1.0])
        .unwrap()
        .to_response();
    for (k, v) in [0.0, 0.1, 0.45, 1.0].iter().enumerate() {
        assert!((t.eval(k as f64 / 3.0) - v).abs() < 1e-12);
    }
}

/// The column pass of the 2-D tables gives, for every column, the bits of [`kernels::blur_1d`]
/// down that column, at the edges as inside.
#[test]
fn blur_columns_is_blur_1d_down_each_column() {
    let (nx, h, m) = (7usize, 23usize, 4usize);
    let sigma = 0.8;
    let taps = kernels::tap_table(sigma, m, reach_of(sigma));
    let mut x = 0x2545_f491_4f6c_dd1du64;
    let rows: Vec<f64> = (0..nx * h)
        .map(|_| {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            (x >> 11) as f64 / (1u64 << 53) as f64
        })
        .collect();
    let (t0, len) = (-9.0, (h + 18) * m);
    let mut out = vec![0f32; nx * len];
    kernels::blur_columns(&rows, nx, t0, m, len, &taps, &mut out);
    for i in 0..nx {
        let col: Vec<f64> = (0..h).map(|j| rows[j * nx + i]).collect();
        let want = blur_1d(&col, t0, m, len, &taps);
        for (q, w) in want.iter().enumerate() {
            assert_eq!(
                out[q * nx + i].to_bits(),
                (*w as f32).to_bits(),
                "column {i} row {q}"
            );
        }
    }
    // And the interior path of blur_1d is the checked sum's.
    let col: Vec<f64> = (0..h).map(|j| rows[j * nx]).collect();
    let fast = blur_1d(&col, t0, m, len, &taps);
    for (q, f) in fast.iter().enumerate() {
        let (lo, ks) = &taps[q % m];
        let mut acc = 0.0;
        for (d, k) in ks.iter().enumerate() {
            let j = t0 as i64 + (q / m) as i64 + lo + d as i64;
            if j >= 0 && j < h as i64 {
                acc += col[j as usize] * k;
            }
        }
        assert_eq!(f.to_bits(), acc.to_bits(), "row {q}");
    }
}
