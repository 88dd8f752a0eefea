//! The linear estimator of one level (paper §5.2, eqs 8-11 and 14-15): the fixed weights that
//! turn a level's images into `S = B·sin Φ`, `C = B·cos Φ` and, for a level of ≥ 3 shifts, the
//! DC term A.
//!
//! Every image of a level with shift δ_n (plus the set's offset) is `I_n = A + B·sin(Φ + δ_n) =
//! A + S·cos δ_n + C·sin δ_n` (eqs 8, 14), linear in (A, S, C). A level with ≥ 3 shifts estimates
//! all three by least squares (the paper's 4-step level: eqs 9-10; uniform N-step: eqs 14-15); a
//! 2-shift level takes A from the DC level and solves the 2×2 system for (S, C) (shifts 0 and
//! π/2: eq 11).
//!
//! Its own module, below both the pattern sets ([`crate::pattern`], which checks with
//! [`level_estimator`] that a level's shifts can be decoded) and the decoder ([`crate::decode`],
//! which builds its per-image coefficients from it, and re-exports both items).

use crate::limits::MAX_SHIFTS;

/// The linear estimator of one level: `S = Σ a_n·I_n + a_dc·A`, `C = Σ b_n·I_n + b_dc·A`, and for a
/// DC level `A = Σ w_n·I_n`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LevelEstimator {
    /// Number of shifts.
    pub n: usize,
    /// Coefficients of S = B·sin Φ.
    pub a: [f32; MAX_SHIFTS],
    /// Coefficients of C = B·cos Φ.
    pub b: [f32; MAX_SHIFTS],
    /// Coefficients of A (all zero for a 2-shift level).
    pub w: [f32; MAX_SHIFTS],
    /// Coefficient of the external DC term A in S (zero for a level with ≥ 3 shifts).
    pub a_dc: f32,
    /// Coefficient of the external DC term A in C (zero for a level with ≥ 3 shifts).
    pub b_dc: f32,
}

/// Round an f64 coefficient to f32, snapping values that are zero up to f64 rounding of sin/cos
/// (e.g. cos(π/2) ≈ 6e-17) to exactly 0 and near-integers/halves to their exact value, so that the
/// paper's 4-step level gets exactly `(½, 0, −½, 0)`.
fn snap(x: f64) -> f32 {
    let q = libm::round(x * 4096.0) / 4096.0;
    if libm::fabs(x - q) < 1e-12 {
        q as f32
    } else {
        x as f32
    }
}

/// Compute the estimator of a level with effective shifts `shifts[n] + offset` (radians).
///
/// Returns `None` if the shifts cannot separate the unknowns (fewer than 2 shifts, more than
/// [`MAX_SHIFTS`], or a singular system).
pub fn level_estimator(shifts: &[f64], offset: f64) -> Option<LevelEstimator> {
    let n = shifts.len();
    if !(2..=MAX_SHIFTS).contains(&n) {
        return None;
    }
    let mut est = LevelEstimator {
        n,
        a: [0.0; MAX_SHIFTS],
        b: [0.0; MAX_SHIFTS],
        w: [0.0; MAX_SHIFTS],
        a_dc: 0.0,
        b_dc: 0.0,
    };
    let mut cs = [(0.0f64, 0.0f64); MAX_SHIFTS];
    for (i, s) in shifts.iter().enumerate() {
        let d = s + offset;
        cs[i] = (libm::cos(d), libm::sin(d));
    }
    if n == 2 {
        // [c0 s0; c1 s1]·[S; C] = [I0 − A; I1 − A]
        let (c0, s0) = cs[0];
        let (c1, s1) = cs[1];
        let det = c0 * s1 - s0 * c1;
        if libm::fabs(det) < 1e-6 {
            return None;
        }
        let (ia0, ia1) = (s1 / det, -s0 / det);
        let (ib0, ib1) = (-c1 / det, c0 / det);
        est.a[0] = snap(ia0);
        est.a[1] = snap(ia1);
        est.b[0] = snap(ib0);
        est.b[1] = snap(ib1);
        est.a_dc = snap(-(ia0 + ia1));
        est.b_dc = snap(-(ib0 + ib1));
        return Some(est);
    }
    // Least squares over rows (1, cos δ, sin δ): x = (DᵀD)⁻¹ Dᵀ I.
    let mut m = [[0.0f64; 3]; 3];
    for &(c, s) in &cs[..n] {
        let r = [1.0, c, s];
        for i in 0..3 {
            for j in 0..3 {
                m[i][j] += r[i] * r[j];
            }
        }
    }
    let inv = invert3(&m)?;
    for (k, &(c, s)) in cs[..n].iter().enumerate() {
        let r = [1.0, c, s];
        let mut x = [0.0f64; 3];
        for (i, xi) in x.iter_mut().enumerate() {
            *xi = inv[i][0] * r[0] + inv[i][1] * r[1] + inv[i][2] * r[2];
        }
        // `get_mut`: k < n <= MAX_SHIFTS; no panic path is compiled in.
        let (Some(w), Some(a), Some(b)) = (est.w.get_mut(k), est.a.get_mut(k), est.b.get_mut(k))
        else {
            return None;
        };
        (*w, *a, *b) = (snap(x[0]), snap(x[1]), snap(x[2]));
    }
    Some(est)
}

#[allow(clippy::needless_range_loop)] // cofactor indices read best as indices
fn invert3(m: &[[f64; 3]; 3]) -> Option<[[f64; 3]; 3]> {
    let det = m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
        - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
        + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
    // DᵀD of n unit-norm-ish rows: a determinant this small means the shifts coincide mod 2π.
    if !(libm::fabs(det) > 1e-6) {
        return None;
    }
    let mut r = [[0.0; 3]; 3];
    for i in 0..3 {
        for j in 0..3 {
            let (a0, a1) = ((j + 1) % 3, (j + 2) % 3);
            let (b0, b1) = ((i + 1) % 3, (i + 2) % 3);
            r[i][j] = (m[a0][b0] * m[a1][b1] - m[a0][b1] * m[a1][b0]) / det;
        }
    }
    Some(r)
}
