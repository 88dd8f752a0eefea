//! Helpers shared by the render tests: an independent f64 phase decoder and an independent
//! pinhole + Brown projector model (nothing here comes from the renderer or the core's decoder).
#![allow(dead_code)]

use fringe3d::render::{Frames, Rig};
use fringe3d_core::pattern::PatternSet;

/// f64 decode of one pixel: (absolute finest phase, modulation B of the finest level, DC A).
///
/// Model `I = A + B·sin(c_k·Φ + δ)`: every level with ≥ 3 shifts is solved by least squares for
/// (A, B sin, B cos); the 2-shift levels use the A of the level with most shifts. Levels are
/// unwrapped coarse to fine by `Φ_k = φ_k + 2π·round((r_k·Φ_{k−1} − φ_k)/2π)`.
pub fn decode_pixel(set: &PatternSet, samples: &[f64]) -> (f64, f64, f64) {
    let levels = set.levels();
    let off = set.effective_offset();
    // Per level: list of (I, δ).
    let mut per: Vec<Vec<(f64, f64)>> = vec![Vec::new(); levels.len()];
    for (i, id) in set.order().iter().enumerate() {
        let d = levels[id.level as usize].shifts()[id.shift as usize] + off;
        per[id.level as usize].push((samples[i], d));
    }
    // DC from the level with most shifts (≥ 3): least squares [1, sin δ, cos δ].
    let dc_level = (0..levels.len())
        .filter(|&l| per[l].len() >= 3)
        .max_by_key(|&l| (per[l].len(), l))
        .expect("a DC level");
    let lsq = |v: &[(f64, f64)]| -> (f64, f64, f64) {
        // Normal equations for x = (A, S, C): I = A + S·cos δ + C·sin δ, S = B sin Φ, C = B cos Φ.
        let mut m = [[0.0f64; 4]; 3];
        for &(i, d) in v {
            let r = [1.0, d.cos(), d.sin()];
            for a in 0..3 {
                for b in 0..3 {
                    m[a][b] += r[a] * r[b];
                }
                m[a][3] += r[a] * i;
            }
        }
        // Gauss-Jordan.
        for c in 0..3 {
            let p = (c..3)
                .max_by(|&a, &b| m[a][c].abs().total_cmp(&m[b][c].abs()))
                .unwrap();
            m.swap(c, p);
            for r in 0..3 {
                if r != c {
                    let f = m[r][c] / m[c][c];
                    let pivot = m[c];
                    for (v, p) in m[r].iter_mut().zip(pivot) {
                        *v -= f * p;
                    }
                }
            }
        }
        (m[0][3] / m[0][0], m[1][3] / m[1][1], m[2][3] / m[2][2])
    };
    let (a_dc, _, _) = lsq(&per[dc_level]);
    let mut phi = 0.0;
    let mut b_last = 0.0;
    for (l, v) in per.iter().enumerate() {
        let (s, c) = if v.len() >= 3 {
            let (_, s, c) = lsq(v);
            (s, c)
        } else {
            // Two shifts: I − A = S cos δ + C sin δ, 2×2 solve.
            let (i0, d0) = v[0];
            let (i1, d1) = v[1];
            let det = d0.cos() * d1.sin() - d0.sin() * d1.cos();
            let (r0, r1) = (i0 - a_dc, i1 - a_dc);
            (
                (r0 * d1.sin() - r1 * d0.sin()) / det,
                (d0.cos() * r1 - d1.cos() * r0) / det,
            )
        };
        let wrapped = s.atan2(c);
        b_last = (s * s + c * c).sqrt();
        if l == 0 {
            phi = wrapped;
        } else {
            let r = levels[l].scale() / levels[l - 1].scale();
            let pred = r * phi;
            let n = ((pred - wrapped) / std::f64::consts::TAU).round();
            phi = wrapped + n * std::f64::consts::TAU;
        }
    }
    (phi, b_last, a_dc)
}

/// Decode whole frames (codes) in f64: (phase, B, A) per pixel.
pub fn decode_frames(set: &PatternSet, f: &Frames) -> Vec<(f64, f64, f64)> {
    let n = (f.width * f.height) as usize;
    let mut s = vec![0.0; f.images.len()];
    (0..n)
        .map(|p| {
            for (k, img) in f.images.iter().enumerate() {
                s[k] = img[p] as f64;
            }
            decode_pixel(set, &s)
        })
        .collect()
}

/// Decode the unquantized float images.
pub fn decode_float(set: &PatternSet, f: &Frames) -> Vec<(f64, f64, f64)> {
    let fl = f.float.as_ref().expect("render with keep_float");
    let n = (f.width * f.height) as usize;
    let mut s = vec![0.0; fl.len()];
    (0..n)
        .map(|p| {
            for (k, img) in fl.iter().enumerate() {
                s[k] = img[p];
            }
            decode_pixel(set, &s)
        })
        .collect()
}

/// Independent forward projector model: camera-frame point → (ξ, η).
pub fn project_to_projector(rig: &Rig, x: [f64; 3]) -> (f64, f64) {
    let r = rig.rotation;
    let t = rig.translation;
    let d = [x[0] - t[0], x[1] - t[1], x[2] - t[2]];
    // X_proj = Rᵀ (X − T)
    let p = [
        r[0][0] * d[0] + r[1][0] * d[1] + r[2][0] * d[2],
        r[0][1] * d[0] + r[1][1] * d[1] + r[2][1] * d[2],
        r[0][2] * d[0] + r[1][2] * d[1] + r[2][2] * d[2],
    ];
    let i = &rig.projector;
    let (xn, yn) = (p[0] / p[2], p[1] / p[2]);
    let [k1, k2, p1, p2, k3] = i.distortion.to_array();
    let r2 = xn * xn + yn * yn;
    let radial = 1.0 + k1 * r2 + k2 * r2 * r2 + k3 * r2 * r2 * r2;
    let xd = xn * radial + 2.0 * p1 * xn * yn + p2 * (r2 + 2.0 * xn * xn);
    let yd = yn * radial + p1 * (r2 + 2.0 * yn * yn) + 2.0 * p2 * xn * yn;
    (i.fx * xd + i.skew * i.fx * yd + i.cx, i.fy * yd + i.cy)
}

/// Independent camera projection (pinhole + Brown + skew).
pub fn project_to_camera(rig: &Rig, p: [f64; 3]) -> (f64, f64) {
    let i = &rig.camera;
    let (xn, yn) = (p[0] / p[2], p[1] / p[2]);
    let [k1, k2, p1, p2, k3] = i.distortion.to_array();
    let r2 = xn * xn + yn * yn;
    let radial = 1.0 + k1 * r2 + k2 * r2 * r2 + k3 * r2 * r2 * r2;
    let xd = xn * radial + 2.0 * p1 * xn * yn + p2 * (r2 + 2.0 * xn * xn);
    let yd = yn * radial + p1 * (r2 + 2.0 * yn * yn) + 2.0 * p2 * xn * yn;
    (i.fx * xd + i.skew * i.fx * yd + i.cx, i.fy * yd + i.cy)
}

/// RMS and max of |v|.
pub fn rms_max(v: &[f64]) -> (f64, f64) {
    let n = v.len().max(1) as f64;
    let rms = (v.iter().map(|x| x * x).sum::<f64>() / n).sqrt();
    let max = v.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    (rms, max)
}
