//! The direct linear transform: a pinhole camera (intrinsics with skew, pose) from 3-D points and
//! their images, the closed-form start of the projector's calibration (issue #18 item 2). The
//! points must not be coplanar (boards at several tilts, or parallel plates at several depths).
//!
//! With Hartley's normalisation of both point sets, `M` (3 × 4, `x ~ M·X`) is the eigenvector of
//! the smallest eigenvalue of `AᵀA` (two rows of `A` per point). `M = K·[R | t]` is split by an RQ
//! decomposition of its left 3 × 3 block, rows `a₁, a₂, a₃` scaled so that `|a₃| = 1` and the
//! points lie in front:
//!
//! ```text
//! r₃ = a₃,  v₀ = a₂·r₃,  f_y = |a₂ − v₀ r₃|,  r₂ = (a₂ − v₀ r₃)/f_y,
//! u₀ = a₁·r₃,  γ = a₁·r₂,  f_x = |a₁ − u₀ r₃ − γ r₂|,  r₁ = (a₁ − u₀ r₃ − γ r₂)/f_x,
//! t = K⁻¹·m₄
//! ```
//!
//! Lens distortion is ignored here; the joint adjustment adds it.

use super::linalg::{smallest_eigenvector, sym_eigen};
use crate::math::{Mat3, Vec3};

/// A camera from [`dlt`]: `x = K (R X + t)`, with `K = [[fx, γ, u0], [0, fy, v0], [0, 0, 1]]`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pinhole {
    /// `[fx, fy, γ, u0, v0]` (γ = α·fx).
    pub k: [f64; 5],
    /// World → camera rotation.
    pub rotation: Mat3,
    /// World → camera translation.
    pub translation: Vec3,
}

fn normalizer2(p: &[[f64; 2]]) -> ([f64; 2], f64) {
    let n = p.len() as f64;
    let c = [
        p.iter().map(|q| q[0]).sum::<f64>() / n,
        p.iter().map(|q| q[1]).sum::<f64>() / n,
    ];
    let d = p
        .iter()
        .map(|q| ((q[0] - c[0]).powi(2) + (q[1] - c[1]).powi(2)).sqrt())
        .sum::<f64>()
        / n;
    (c, std::f64::consts::SQRT_2 / d.max(1e-300))
}

fn normalizer3(p: &[Vec3]) -> (Vec3, f64) {
    let n = p.len() as f64;
    let c = p.iter().fold(Vec3::ZERO, |a, &b| a + b) * (1.0 / n);
    let d = p.iter().map(|&q| (q - c).norm()).sum::<f64>() / n;
    (c, 3f64.sqrt() / d.max(1e-300))
}

/// The camera seeing `world[i]` at `image[i]`. `None` with fewer than 6 points, coplanar
/// points, or a solution that is not a proper camera (points behind it, a mirrored frame).
pub fn dlt(world: &[Vec3], image: &[[f64; 2]]) -> Option<Pinhole> {
    if world.len() != image.len() || world.len() < 6 {
        return None;
    }
    let (c2, s2) = normalizer2(image);
    let (c3, s3) = normalizer3(world);
    // Coplanar (or collinear) points leave M undetermined: refuse them.
    let mut cov = [0.0; 9];
    for x in world {
        let p = (*x - c3) * s3;
        for i in 0..3 {
            for j in 0..3 {
                cov[i * 3 + j] += p[i] * p[j];
            }
        }
    }
    let (ev, _) = sym_eigen(&cov, 3);
    let (lo, hi) = ev
        .iter()
        .fold((f64::INFINITY, 0.0f64), |(a, b), &e| (a.min(e), b.max(e)));
    if !(lo > 1e-6 * hi) {
        return None;
    }
    let mut ata = vec![0.0; 144];
    for (x, u) in world.iter().zip(image) {
        let p = (*x - c3) * s3;
        let (a, b) = ((u[0] - c2[0]) * s2, (u[1] - c2[1]) * s2);
        let ph = [p[0], p[1], p[2], 1.0];
        let mut r1 = [0.0; 12];
        let mut r2 = [0.0; 12];
        for k in 0..4 {
            r1[k] = ph[k];
            r1[8 + k] = -a * ph[k];
            r2[4 + k] = ph[k];
            r2[8 + k] = -b * ph[k];
        }
        for r in [r1, r2] {
            for i in 0..12 {
                for j in 0..12 {
                    ata[i * 12 + j] += r[i] * r[j];
                }
            }
        }
    }
    let (m, _) = smallest_eigenvector(&ata, 12);
    // Denormalise: M = T2⁻¹ · Mn · T3.
    let mn = |i: usize, j: usize| m[i * 4 + j];
    let mut mt = [[0.0; 4]; 3];
    for i in 0..3 {
        for j in 0..3 {
            mt[i][j] = mn(i, j) * s3;
        }
        mt[i][3] = mn(i, 3) - s3 * (0..3).map(|j| mn(i, j) * c3[j]).sum::<f64>();
    }
    let mut full = [[0.0; 4]; 3];
    for j in 0..4 {
        full[0][j] = mt[0][j] / s2 + c2[0] * mt[2][j];
        full[1][j] = mt[1][j] / s2 + c2[1] * mt[2][j];
        full[2][j] = mt[2][j];
    }
    let row = |i: usize| Vec3::new(full[i][0], full[i][1], full[i][2]);
    let n3 = row(2).norm();
    if !(n3 > 0.0 && n3.is_finite()) {
        return None;
    }
    // Sign: the points in front (positive depth on average).
    let depth: f64 = world
        .iter()
        .map(|x| row(2).dot(*x) + full[2][3])
        .sum::<f64>();
    let sign = if depth < 0.0 { -1.0 } else { 1.0 } / n3;
    let (a1, a2, a3) = (row(0) * sign, row(1) * sign, row(2) * sign);
    let m4 = Vec3::new(full[0][3], full[1][3], full[2][3]) * sign;
    let r3 = a3;
    let v0 = a2.dot(r3);
    let q2 = a2 - r3 * v0;
    let fy = q2.norm();
    let r2 = q2 * (1.0 / fy);
    let u0 = a1.dot(r3);
    let g = a1.dot(r2);
    let q1 = a1 - r3 * u0 - r2 * g;
    let fx = q1.norm();
    let r1 = q1 * (1.0 / fx);
    let rot = Mat3([r1.to_array(), r2.to_array(), r3.to_array()]);
    if !(fx > 0.0 && fy > 0.0 && rot.det() > 0.5) {
        return None;
    }
    // t = K⁻¹ m4.
    let tz = m4[2];
    let ty = (m4[1] - v0 * tz) / fy;
    let tx = (m4[0] - g * ty - u0 * tz) / fx;
    let t = Vec3::new(tx, ty, tz);
    let ok = world.iter().all(|x| rot.mul_vec(*x)[2] + t[2] > 0.0);
    (ok && t.is_finite()).then_some(Pinhole {
        k: [fx, fy, g, u0, v0],
        rotation: rot,
        translation: t,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Exact projections of non-coplanar points give back the camera (truth: the camera that
    /// made them).
    #[test]
    fn recovers_a_skewed_off_axis_camera() {
        let rot = Mat3::from_euler_deg([12.0, -20.0, 5.0]);
        let t = Vec3::new(-210.0, 15.0, 40.0);
        let k = [1250.0, 1245.0, 1.5, 511.5, 690.0];
        let mut w = Vec::new();
        let mut im = Vec::new();
        for i in 0..7 {
            for j in 0..5 {
                for z in [520.0, 610.0, 700.0] {
                    let x = Vec3::new(-120.0 + 40.0 * i as f64, -80.0 + 40.0 * j as f64, z);
                    let c = rot.mul_vec(x) + t;
                    let (a, b) = (c[0] / c[2], c[1] / c[2]);
                    im.push([k[0] * a + k[2] * b + k[3], k[1] * b + k[4]]);
                    w.push(x);
                }
            }
        }
        let p = dlt(&w, &im).unwrap();
        for i in 0..5 {
            assert!((p.k[i] - k[i]).abs() < 1e-6 * k[0], "{:?}", p.k);
        }
        assert!((p.translation - t).norm() < 1e-6, "{:?}", p.translation);
        for i in 0..3 {
            for j in 0..3 {
                assert!((p.rotation.0[i][j] - rot.0[i][j]).abs() < 1e-9);
            }
        }
        // Coplanar points do not determine a camera.
        let flat: Vec<usize> = (0..w.len()).filter(|i| i % 3 == 0).collect();
        let (wf, imf): (Vec<Vec3>, Vec<[f64; 2]>) = flat.iter().map(|&i| (w[i], im[i])).unzip();
        assert_eq!(dlt(&wf, &imf), None);
    }
}
