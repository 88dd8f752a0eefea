//! Small dense linear algebra for the calibration: rotations over the host's [`Vec3`] and
//! [`Mat3`] (Rodrigues, nearest rotation), a cyclic Jacobi eigensolver for small symmetric matrices
//! and a Cholesky solver for the normal equations. Everything is f64 and allocation-light; the matrices
//! here are at most a few hundred rows (the bundle adjustment's normal equations), which is why
//! no linear-algebra crate is used (see `docs/calibration.md`).

use crate::math::{Mat3, Vec3};

/// Solve the symmetric positive-definite 3×3 system `A x = b` (`None` if singular).
pub fn solve3(a: &Mat3, b: Vec3) -> Option<Vec3> {
    a.inverse().map(|i| i.mul_vec(b))
}

/// The rotation `exp([w]×)` of the rotation vector `w` (Rodrigues).
pub fn rodrigues(w: Vec3) -> Mat3 {
    let th2 = w.dot(w);
    let th = th2.sqrt();
    let (a, b) = if th < 1e-6 {
        // Series: sin θ/θ ≈ 1 − θ²/6, (1 − cos θ)/θ² ≈ 1/2 − θ²/24.
        (1.0 - th2 / 6.0, 0.5 - th2 / 24.0)
    } else {
        (th.sin() / th, (1.0 - th.cos()) / th2)
    };
    let k = Mat3::cross_matrix(w);
    let k2 = k.mul_mat(&k);
    let mut r = Mat3::IDENTITY;
    for i in 0..3 {
        for j in 0..3 {
            r[i][j] += a * k[i][j] + b * k2[i][j];
        }
    }
    r
}

/// The rotation vector of a rotation matrix (inverse of [`rodrigues`], angle in [0, π]).
pub fn rot_log(r: &Mat3) -> Vec3 {
    let q = quat_from_rot(r);
    let (w, v) = (q[0], Vec3::new(q[1], q[2], q[3]));
    let s = v.norm();
    if s < 1e-12 {
        return v * 2.0;
    }
    let th = 2.0 * s.atan2(w);
    v * (th / s)
}

/// Unit quaternion `[w, x, y, z]` (w ≥ 0) of a rotation matrix.
pub fn quat_from_rot(r: &Mat3) -> [f64; 4] {
    let t = r[0][0] + r[1][1] + r[2][2];
    let q = if t > 0.0 {
        let s = (t + 1.0).sqrt() * 2.0;
        [
            0.25 * s,
            (r[2][1] - r[1][2]) / s,
            (r[0][2] - r[2][0]) / s,
            (r[1][0] - r[0][1]) / s,
        ]
    } else if r[0][0] > r[1][1] && r[0][0] > r[2][2] {
        let s = (1.0 + r[0][0] - r[1][1] - r[2][2]).sqrt() * 2.0;
        [
            (r[2][1] - r[1][2]) / s,
            0.25 * s,
            (r[0][1] + r[1][0]) / s,
            (r[0][2] + r[2][0]) / s,
        ]
    } else if r[1][1] > r[2][2] {
        let s = (1.0 + r[1][1] - r[0][0] - r[2][2]).sqrt() * 2.0;
        [
            (r[0][2] - r[2][0]) / s,
            (r[0][1] + r[1][0]) / s,
            0.25 * s,
            (r[1][2] + r[2][1]) / s,
        ]
    } else {
        let s = (1.0 + r[2][2] - r[0][0] - r[1][1]).sqrt() * 2.0;
        [
            (r[1][0] - r[0][1]) / s,
            (r[0][2] + r[2][0]) / s,
            (r[1][2] + r[2][1]) / s,
            0.25 * s,
        ]
    };
    let n = (q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]).sqrt();
    let sg = if q[0] < 0.0 { -1.0 } else { 1.0 };
    [sg * q[0] / n, sg * q[1] / n, sg * q[2] / n, sg * q[3] / n]
}

/// The rotation of a unit quaternion `[w, x, y, z]`.
pub fn rot_from_quat(q: [f64; 4]) -> Mat3 {
    let n = (q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]).sqrt();
    let [w, x, y, z] = [q[0] / n, q[1] / n, q[2] / n, q[3] / n];
    Mat3([
        [
            1.0 - 2.0 * (y * y + z * z),
            2.0 * (x * y - w * z),
            2.0 * (x * z + w * y),
        ],
        [
            2.0 * (x * y + w * z),
            1.0 - 2.0 * (x * x + z * z),
            2.0 * (y * z - w * x),
        ],
        [
            2.0 * (x * z - w * y),
            2.0 * (y * z + w * x),
            1.0 - 2.0 * (x * x + y * y),
        ],
    ])
}

/// The rotation nearest to `m` in the Frobenius norm (maximises `tr(Rᵀ M)`), by Horn's
/// quaternion method: the eigenvector of the largest eigenvalue of a symmetric 4×4 matrix.
pub fn nearest_rotation(m: &Mat3) -> Mat3 {
    let (sxx, sxy, sxz) = (m[0][0], m[0][1], m[0][2]);
    let (syx, syy, syz) = (m[1][0], m[1][1], m[1][2]);
    let (szx, szy, szz) = (m[2][0], m[2][1], m[2][2]);
    // tr(Rᵀ M) = qᵀ N q for R = R(q) (Horn 1987, with M in place of the correlation matrix).
    let n = [
        sxx + syy + szz,
        szy - syz,
        sxz - szx,
        syx - sxy,
        szy - syz,
        sxx - syy - szz,
        sxy + syx,
        sxz + szx,
        sxz - szx,
        sxy + syx,
        -sxx + syy - szz,
        syz + szy,
        syx - sxy,
        sxz + szx,
        syz + szy,
        -sxx - syy + szz,
    ];
    let (vals, vecs) = sym_eigen(&n, 4);
    let k = (0..4)
        .max_by(|&a, &b| vals[a].total_cmp(&vals[b]))
        .unwrap_or(3);
    rot_from_quat([vecs[k], vecs[4 + k], vecs[8 + k], vecs[12 + k]])
}

/// Eigen-decomposition of the symmetric `n × n` matrix `a` (row-major) by cyclic Jacobi
/// rotations. Returns the eigenvalues (unsorted) and the eigenvectors as the *columns* of a
/// row-major `n × n` matrix (`vecs[i * n + k]` is component `i` of eigenvector `k`).
pub fn sym_eigen(a: &[f64], n: usize) -> (Vec<f64>, Vec<f64>) {
    let mut m = a.to_vec();
    // Symmetrise against rounding in the caller.
    for i in 0..n {
        for j in i + 1..n {
            let s = 0.5 * (m[i * n + j] + m[j * n + i]);
            m[i * n + j] = s;
            m[j * n + i] = s;
        }
    }
    let mut v = vec![0.0; n * n];
    for i in 0..n {
        v[i * n + i] = 1.0;
    }
    for _sweep in 0..100 {
        let mut off = 0.0;
        let mut diag = 0.0;
        for i in 0..n {
            diag += m[i * n + i] * m[i * n + i];
            for j in i + 1..n {
                off += m[i * n + j] * m[i * n + j];
            }
        }
        if off <= 1e-30 * diag || off == 0.0 {
            break;
        }
        for p in 0..n {
            for q in p + 1..n {
                let apq = m[p * n + q];
                if apq == 0.0 {
                    continue;
                }
                let app = m[p * n + p];
                let aqq = m[q * n + q];
                let theta = (aqq - app) / (2.0 * apq);
                let t = theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt());
                let t = if theta == 0.0 { 1.0 } else { t };
                let c = 1.0 / (t * t + 1.0).sqrt();
                let s = t * c;
                // A ← Jᵀ A J with J the rotation in the (p, q) plane.
                for k in 0..n {
                    let akp = m[k * n + p];
                    let akq = m[k * n + q];
                    m[k * n + p] = c * akp - s * akq;
                    m[k * n + q] = s * akp + c * akq;
                }
                for k in 0..n {
                    let apk = m[p * n + k];
                    let aqk = m[q * n + k];
                    m[p * n + k] = c * apk - s * aqk;
                    m[q * n + k] = s * apk + c * aqk;
                }
                for k in 0..n {
                    let vkp = v[k * n + p];
                    let vkq = v[k * n + q];
                    v[k * n + p] = c * vkp - s * vkq;
                    v[k * n + q] = s * vkp + c * vkq;
                }
            }
        }
    }
    ((0..n).map(|i| m[i * n + i]).collect(), v)
}

/// The unit eigenvector of the smallest eigenvalue of the symmetric `n × n` matrix `a`, and
/// that eigenvalue.
pub fn smallest_eigenvector(a: &[f64], n: usize) -> (Vec<f64>, f64) {
    let (vals, vecs) = sym_eigen(a, n);
    let k = (0..n)
        .min_by(|&x, &y| vals[x].total_cmp(&vals[y]))
        .unwrap_or(0);
    ((0..n).map(|i| vecs[i * n + k]).collect(), vals[k])
}

/// In-place Cholesky factorisation `A = L Lᵀ` of a symmetric positive-definite `n × n` matrix
/// (row-major; the lower triangle receives L). `false` if A is not positive definite.
pub fn cholesky(a: &mut [f64], n: usize) -> bool {
    for j in 0..n {
        let mut d = a[j * n + j];
        for k in 0..j {
            d -= a[j * n + k] * a[j * n + k];
        }
        if !(d > 0.0) || !d.is_finite() {
            return false;
        }
        let d = d.sqrt();
        a[j * n + j] = d;
        for i in j + 1..n {
            let mut s = a[i * n + j];
            for k in 0..j {
                s -= a[i * n + k] * a[j * n + k];
            }
            a[i * n + j] = s / d;
        }
    }
    true
}

/// Solve `L Lᵀ x = b` with the factor from [`cholesky`]; `b` is overwritten with x.
pub fn cholesky_solve(l: &[f64], n: usize, b: &mut [f64]) {
    for i in 0..n {
        let mut s = b[i];
        for k in 0..i {
            s -= l[i * n + k] * b[k];
        }
        b[i] = s / l[i * n + i];
    }
    for i in (0..n).rev() {
        let mut s = b[i];
        for k in i + 1..n {
            s -= l[k * n + i] * b[k];
        }
        b[i] = s / l[i * n + i];
    }
}

/// The inverse of a symmetric positive-definite matrix (`None` if it is not).
pub fn spd_inverse(a: &[f64], n: usize) -> Option<Vec<f64>> {
    let mut l = a.to_vec();
    if !cholesky(&mut l, n) {
        return None;
    }
    let mut inv = vec![0.0; n * n];
    let mut e = vec![0.0; n];
    for j in 0..n {
        e.iter_mut().for_each(|x| *x = 0.0);
        e[j] = 1.0;
        cholesky_solve(&l, n, &mut e);
        for i in 0..n {
            inv[i * n + j] = e[i];
        }
    }
    Some(inv)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rodrigues_log_roundtrip() {
        for w in [
            [0.1, -0.2, 0.3],
            [1e-9, 0.0, 2e-9],
            [2.0, 1.0, -0.5],
            [0.0, 3.1, 0.0],
        ] {
            let w = Vec3::from_array(w);
            let r = rodrigues(w);
            let (e, d) = {
                let rt = r.transpose().mul_mat(&r);
                let mut e: f64 = 0.0;
                for i in 0..3 {
                    for j in 0..3 {
                        e = e.max((rt[i][j] - Mat3::IDENTITY[i][j]).abs());
                    }
                }
                (e, r.det())
            };
            assert!(e < 1e-14 && (d - 1.0).abs() < 1e-14);
            let back = rot_log(&r);
            assert!((back - w).norm() < 1e-10, "{w:?} -> {back:?}");
        }
    }

    #[test]
    fn nearest_rotation_recovers_a_rotation() {
        let r = rodrigues(Vec3::new(0.3, -0.7, 0.2));
        let mut m = r;
        m[0][1] += 1e-3;
        m[2][2] *= 1.01;
        let n = nearest_rotation(&m);
        for i in 0..3 {
            for j in 0..3 {
                assert!((n[i][j] - r[i][j]).abs() < 1e-2);
            }
        }
        assert!((n.det() - 1.0).abs() < 1e-12);
        let exact = nearest_rotation(&r);
        for i in 0..3 {
            for j in 0..3 {
                assert!((exact[i][j] - r[i][j]).abs() < 1e-12);
            }
        }
    }

    #[test]
    fn jacobi_and_cholesky() {
        let a = [4.0, 1.0, 0.5, 1.0, 3.0, 0.2, 0.5, 0.2, 2.0];
        let (vals, vecs) = sym_eigen(&a, 3);
        for k in 0..3 {
            let v = Vec3::new(vecs[k], vecs[3 + k], vecs[6 + k]);
            let m = Mat3([[a[0], a[1], a[2]], [a[3], a[4], a[5]], [a[6], a[7], a[8]]]);
            assert!((m.mul_vec(v) - v * vals[k]).norm() < 1e-12);
        }
        let inv = spd_inverse(&a, 3).unwrap();
        for i in 0..3 {
            for j in 0..3 {
                let s: f64 = (0..3).map(|k| a[i * 3 + k] * inv[k * 3 + j]).sum();
                assert!((s - if i == j { 1.0 } else { 0.0 }).abs() < 1e-12);
            }
        }
    }
}
