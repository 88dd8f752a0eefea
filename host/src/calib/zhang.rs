//! Zhang's closed-form camera calibration from plane homographies (Z. Zhang, "A flexible new
//! technique for camera calibration", IEEE PAMI 22(11), 2000, §3.1) and the homography/pose
//! estimates it needs. These give the starting point of the bundle adjustment ([`super::camera`]);
//! lens distortion is ignored here (it starts at zero).

use super::linalg::{nearest_rotation, smallest_eigenvector};
use crate::math::{Mat3, Vec3};

/// A homography: `[u, v, 1]ᵀ ∝ H [X, Y, 1]ᵀ`.
pub type Homography = Mat3;

fn normalizer(pts: &[[f64; 2]]) -> Option<Mat3> {
    let n = pts.len() as f64;
    let m = [
        pts.iter().map(|p| p[0]).sum::<f64>() / n,
        pts.iter().map(|p| p[1]).sum::<f64>() / n,
    ];
    let d = pts
        .iter()
        .map(|p| ((p[0] - m[0]).powi(2) + (p[1] - m[1]).powi(2)).sqrt())
        .sum::<f64>()
        / n;
    if !(d > 0.0 && d.is_finite()) {
        return None;
    }
    let s = std::f64::consts::SQRT_2 / d;
    Some(Mat3([
        [s, 0.0, -s * m[0]],
        [0.0, s, -s * m[1]],
        [0.0, 0.0, 1.0],
    ]))
}

/// The homography taking plane points `src` to image points `dst` by the normalised DLT (Hartley),
/// scaled so that `H[2][2] = 1` where possible. `None` for fewer than 4 points or a degenerate
/// configuration.
pub fn homography(src: &[[f64; 2]], dst: &[[f64; 2]]) -> Option<Homography> {
    if src.len() < 4 || src.len() != dst.len() {
        return None;
    }
    let ts = normalizer(src)?;
    let td = normalizer(dst)?;
    let mut ata = [0.0; 81];
    for (s, d) in src.iter().zip(dst) {
        let a = ts.mul_vec(Vec3::new(s[0], s[1], 1.0));
        let b = td.mul_vec(Vec3::new(d[0], d[1], 1.0));
        let (x, y) = (a[0], a[1]);
        let (u, v) = (b[0], b[1]);
        let r1 = [-x, -y, -1.0, 0.0, 0.0, 0.0, u * x, u * y, u];
        let r2 = [0.0, 0.0, 0.0, -x, -y, -1.0, v * x, v * y, v];
        for i in 0..9 {
            for j in 0..9 {
                ata[i * 9 + j] += r1[i] * r1[j] + r2[i] * r2[j];
            }
        }
    }
    let (h, _) = smallest_eigenvector(&ata, 9);
    let hn = Mat3([[h[0], h[1], h[2]], [h[3], h[4], h[5]], [h[6], h[7], h[8]]]);
    let h = td.inverse()?.mul_mat(&hn.mul_mat(&ts));
    let s = if h[2][2].abs() > 1e-12 {
        1.0 / h[2][2]
    } else {
        1.0 / h.row(2).norm()
    };
    let out = Mat3(h.0.map(|row| row.map(|x| x * s)));
    out.0.iter().flatten().all(|x| x.is_finite()).then_some(out)
}

fn vij(h: &Mat3, i: usize, j: usize) -> [f64; 6] {
    // Columns of H: h_k = (H[0][k], H[1][k], H[2][k]).
    let a = [h[0][i], h[1][i], h[2][i]];
    let b = [h[0][j], h[1][j], h[2][j]];
    [
        a[0] * b[0],
        a[0] * b[1] + a[1] * b[0],
        a[1] * b[1],
        a[2] * b[0] + a[0] * b[2],
        a[2] * b[1] + a[1] * b[2],
        a[2] * b[2],
    ]
}

/// Intrinsics `(fx, fy, γ, u0, v0)` from three or more homographies (γ = α·fx is Zhang's skew in
/// pixels). `zero_skew` adds the constraint γ = 0 (needed with two views). Pixel coordinates are
/// pre-scaled about `centre` by `half_size` for conditioning. Falls back to a principal point at
/// `centre` and square-free focal lengths when the closed form is not positive definite (too little
/// perspective in the views). `None` if nothing works.
pub fn intrinsics(
    hs: &[Homography],
    zero_skew: bool,
    centre: [f64; 2],
    half_size: f64,
) -> Option<[f64; 5]> {
    let nrm = Mat3([
        [1.0 / half_size, 0.0, -centre[0] / half_size],
        [0.0, 1.0 / half_size, -centre[1] / half_size],
        [0.0, 0.0, 1.0],
    ]);
    let hn: Vec<Mat3> = hs.iter().map(|h| nrm.mul_mat(h)).collect();
    let closed = || -> Option<[f64; 5]> {
        let mut vtv = [0.0; 36];
        let mut add = |row: [f64; 6], w: f64| {
            for i in 0..6 {
                for j in 0..6 {
                    vtv[i * 6 + j] += w * row[i] * row[j];
                }
            }
        };
        for h in &hn {
            // Each homography's columns are scaled to unit norm for balance.
            let s = 1.0 / h.column(0).norm().max(h.column(1).norm()).max(1e-300);
            let h = Mat3(h.0.map(|r| r.map(|x| x * s)));
            let v12 = vij(&h, 0, 1);
            let v11 = vij(&h, 0, 0);
            let v22 = vij(&h, 1, 1);
            add(v12, 1.0);
            add(std::array::from_fn(|k| v11[k] - v22[k]), 1.0);
        }
        if zero_skew || hs.len() < 3 {
            add([0.0, 1.0, 0.0, 0.0, 0.0, 0.0], 1e3);
        }
        let (b, _) = smallest_eigenvector(&vtv, 6);
        let (b11, b12, b22, b13, b23, b33) = (b[0], b[1], b[2], b[3], b[4], b[5]);
        let den = b11 * b22 - b12 * b12;
        if den.abs() < 1e-300 || b11.abs() < 1e-300 {
            return None;
        }
        let v0 = (b12 * b13 - b11 * b23) / den;
        let lambda = b33 - (b13 * b13 + v0 * (b12 * b13 - b11 * b23)) / b11;
        let a2 = lambda / b11;
        let b2 = lambda * b11 / den;
        if !(a2 > 0.0 && b2 > 0.0) {
            return None;
        }
        let alpha = a2.sqrt();
        let beta = b2.sqrt();
        let gamma = -b12 * alpha * alpha * beta / lambda;
        let u0 = gamma * v0 / beta - b13 * alpha * alpha / lambda;
        Some([alpha, beta, gamma, u0, v0])
    };
    let fallback = || -> Option<[f64; 5]> {
        // Principal point at the centre (the origin after normalisation), no skew:
        // B = diag(1/fx², 1/fy², 1) up to scale; unknowns (B11, B22, B33).
        let mut m = [0.0; 9];
        for h in &hn {
            let c = |k: usize| [h[0][k], h[1][k], h[2][k]];
            let (h1, h2) = (c(0), c(1));
            let r1 = [h1[0] * h2[0], h1[1] * h2[1], h1[2] * h2[2]];
            let r2 = [
                h1[0] * h1[0] - h2[0] * h2[0],
                h1[1] * h1[1] - h2[1] * h2[1],
                h1[2] * h1[2] - h2[2] * h2[2],
            ];
            for i in 0..3 {
                for j in 0..3 {
                    m[i * 3 + j] += r1[i] * r1[j] + r2[i] * r2[j];
                }
            }
        }
        let (b, _) = smallest_eigenvector(&m, 3);
        let (fx2, fy2) = (b[2] / b[0], b[2] / b[1]);
        (fx2 > 0.0 && fy2 > 0.0).then(|| [fx2.sqrt(), fy2.sqrt(), 0.0, 0.0, 0.0])
    };
    let k = closed()
        .filter(|k| k.iter().all(|x| x.is_finite()) && k[3].abs() < 1.0 && k[4].abs() < 1.0)
        .or_else(fallback)?;
    // Undo the normalisation: A = N⁻¹ A'.
    let [a, b, g, u0, v0] = k;
    let out = [
        a * half_size,
        b * half_size,
        g * half_size,
        u0 * half_size + centre[0],
        v0 * half_size + centre[1],
    ];
    out.iter().all(|x| x.is_finite()).then_some(out)
}

/// The pose `(R, t)` of a plane (board frame: z = 0) from its homography `H = K [r1 r2 t]` to
/// *normalized* image coordinates (`K = I`): the columns scaled by their mean norm, the rotation
/// made orthonormal, the sign chosen so that the board is in front of the camera.
pub fn pose_from_homography(h: &Homography) -> Option<(Mat3, Vec3)> {
    let (h1, h2, h3) = (h.column(0), h.column(1), h.column(2));
    let l = 2.0 / (h1.norm() + h2.norm());
    if !l.is_finite() {
        return None;
    }
    let sgn = if h3.z < 0.0 { -1.0 } else { 1.0 };
    let r1 = h1 * (sgn * l);
    let r2 = h2 * (sgn * l);
    let t = h3 * (sgn * l);
    let r3 = r1.cross(r2);
    Some((nearest_rotation(&Mat3::from_columns(r1, r2, r3)), t))
}

/// `K⁻¹ H`: a pixel homography turned into one to normalized coordinates (no distortion).
pub fn normalize_homography(h: &Homography, k: [f64; 5]) -> Option<Homography> {
    let [fx, fy, g, u0, v0] = k;
    let km = Mat3([[fx, g, u0], [0.0, fy, v0], [0.0, 0.0, 1.0]]);
    Some(km.inverse()?.mul_mat(h))
}

#[cfg(test)]
mod tests {
    use super::super::linalg::rodrigues;
    use super::*;

    #[test]
    fn closed_form_recovers_a_distortion_free_camera() {
        let k = [1500.0, 1490.0, 0.0, 640.0, 500.0];
        let km = Mat3([[k[0], k[2], k[3]], [0.0, k[1], k[4]], [0.0, 0.0, 1.0]]);
        let board: Vec<[f64; 2]> = (0..7)
            .flat_map(|j| (0..10).map(move |i| [i as f64 * 25.0 - 112.5, j as f64 * 25.0 - 75.0]))
            .collect();
        let mut hs = Vec::new();
        for (w, t) in [
            ([0.3, 0.1, 0.05], [10.0, -20.0, 600.0]),
            ([-0.2, 0.35, -0.1], [-40.0, 10.0, 550.0]),
            ([0.1, -0.4, 0.2], [30.0, 30.0, 650.0]),
            ([-0.35, -0.2, 0.0], [0.0, 0.0, 700.0]),
        ] {
            let r = rodrigues(Vec3::from_array(w));
            let img: Vec<[f64; 2]> = board
                .iter()
                .map(|p| {
                    let x = r.mul_vec(Vec3::new(p[0], p[1], 0.0));
                    let q = km.mul_vec(Vec3::new(x[0] + t[0], x[1] + t[1], x[2] + t[2]));
                    [q[0] / q[2], q[1] / q[2]]
                })
                .collect();
            let h = homography(&board, &img).unwrap();
            hs.push(h);
            let hn = normalize_homography(&h, k).unwrap();
            let (rr, tt) = pose_from_homography(&hn).unwrap();
            for i in 0..3 {
                assert!((tt[i] - t[i]).abs() < 1e-6 * 600.0, "{tt:?}");
                for j in 0..3 {
                    assert!((rr[i][j] - r[i][j]).abs() < 1e-8);
                }
            }
        }
        let est = intrinsics(&hs, false, [640.0, 512.0], 640.0).unwrap();
        for i in 0..5 {
            assert!((est[i] - k[i]).abs() < 1e-5, "{est:?}");
        }
    }
}
