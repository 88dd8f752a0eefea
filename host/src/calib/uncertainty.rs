//! The camera's own uncertainty in what is estimated with the camera held (issue #18 item 4).
//!
//! `calibrate projector` (with the camera held) and `calibrate reference` fit their parameters
//! to corners and phases *through* the camera's model, taken as exact. Its error from its own
//! calibration then moves every estimate the same way in every seed of noise, and no residual
//! shows it: a plate's distance errs by its fx error (0.002 % of 730 mm is 15 µm) while the pose
//! fit's σ from its residuals is a few µm. The camera's covariance (`calibrate camera`'s,
//! carried in the files as `intrinsics_covariance` / `[camera_covariance]`) is propagated:
//!
//! - into a least-squares fit's free parameters by the implicit function theorem
//!   ([`held_covariance`]): at the solution, a change `δc` of the held parameters moves the free
//!   ones by `δa = S·δc`, `S = −N_aa⁻¹·N_ac` (blocks of the normal matrix over `[c, a]`), so they
//!   gain `S·Σ_c·Sᵀ`;
//! - into any estimate that is a function of the camera's model ([`camera_part`]): its
//!   central-difference Jacobian `G` over the intrinsics, steps of one σ each, gives `G·Σ_c·Gᵀ`
//!   (the whole estimator is re-run: corners detected once, poses re-fitted, boards combined).

use super::lens::{Lens, N_INTRINSICS};
use super::linalg::spd_inverse;
use crate::io::calibration::CameraCovariance;

/// The covariance that held parameters `c` (covariance `sigma_c`, `nc × nc`, row-major) add to
/// the free parameters `a` of a least-squares fit, from the fit's normal matrix `JᵀJ` over
/// `[c, a]` (`(nc + na)²`, row-major; any weighting, which cancels): `S·Σ_c·Sᵀ` with
/// `S = −N_aa⁻¹·N_ac`, `na × na`. `None` if `N_aa` is singular.
pub fn held_covariance(normal: &[f64], nc: usize, sigma_c: &[f64]) -> Option<Vec<f64>> {
    let n = (normal.len() as f64).sqrt() as usize;
    if n * n != normal.len() || nc > n || sigma_c.len() != nc * nc {
        return None;
    }
    let na = n - nc;
    let n_aa: Vec<f64> = (0..na * na)
        .map(|i| normal[(nc + i / na) * n + nc + i % na])
        .collect();
    let inv = spd_inverse(&n_aa, na)?;
    // S = −N_aa⁻¹·N_ac (na × nc).
    let mut s = vec![0.0; na * nc];
    for i in 0..na {
        for j in 0..nc {
            s[i * nc + j] = -(0..na)
                .map(|k| inv[i * na + k] * normal[(nc + k) * n + j])
                .sum::<f64>();
        }
    }
    // S·Σ_c·Sᵀ.
    let mut sc = vec![0.0; na * nc];
    for i in 0..na {
        for j in 0..nc {
            sc[i * nc + j] = (0..nc).map(|k| s[i * nc + k] * sigma_c[k * nc + j]).sum();
        }
    }
    let mut out = vec![0.0; na * na];
    for i in 0..na {
        for j in 0..na {
            out[i * na + j] = (0..nc).map(|k| sc[i * nc + k] * s[j * nc + k]).sum();
        }
    }
    Some(out)
}

/// The intrinsics a covariance leaves free (a positive variance): what a propagation perturbs.
pub fn uncertain_intrinsics(cov: &CameraCovariance) -> Vec<usize> {
    (0..N_INTRINSICS)
        .filter(|&k| cov.matrix[k][k] > 0.0)
        .collect()
}

/// The covariance the camera's intrinsics (covariance `cov`) add to the `M` values `f(lens)`:
/// `G·Σ·Gᵀ`, `G` the central differences of `f` at `lens` with steps of one σ per intrinsic
/// (intrinsics of zero variance held). `None` if `f` fails at a step.
pub fn camera_part<const M: usize>(
    lens: &Lens,
    cov: &CameraCovariance,
    f: impl Fn(&Lens) -> Option<[f64; M]>,
) -> Option<[[f64; M]; M]> {
    let free = uncertain_intrinsics(cov);
    let mut g = vec![[0.0; M]; free.len()];
    for (gi, &k) in g.iter_mut().zip(&free) {
        let h = cov.matrix[k][k].sqrt();
        let at = |s: f64| {
            let mut l = *lens;
            l.p[k] += s * h;
            f(&l)
        };
        let (plus, minus) = (at(1.0)?, at(-1.0)?);
        for m in 0..M {
            gi[m] = (plus[m] - minus[m]) / (2.0 * h);
        }
    }
    let mut out = [[0.0; M]; M];
    for (a, ka) in free.iter().enumerate() {
        for (b, kb) in free.iter().enumerate() {
            let c = cov.matrix[*ka][*kb];
            for (i, row) in out.iter_mut().enumerate() {
                for (j, x) in row.iter_mut().enumerate() {
                    *x += g[a][i] * c * g[b][j];
                }
            }
        }
    }
    Some(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Fit `y = a₀ + a₁·c·x` with `c` held, to points on the line (zero residuals, where
    /// the Gauss–Newton normal matrix is the exact Hessian): the implicit function theorem's
    /// `S·Σ_c·Sᵀ` against the sensitivity of re-fitting with `c` moved.
    #[test]
    fn held_covariance_is_the_refit_sensitivity() {
        let xs = [0.0, 1.0, 2.0, 4.0, 7.0];
        let ys: Vec<f64> = xs.iter().map(|x| 1.0 + 2.0 * x).collect();
        let fit = |c: f64| {
            let n = xs.len() as f64;
            let sx: f64 = xs.iter().map(|x| c * x).sum();
            let sxx: f64 = xs.iter().map(|x| (c * x) * (c * x)).sum();
            let sy: f64 = ys.iter().sum();
            let sxy: f64 = xs.iter().zip(&ys).map(|(x, y)| c * x * y).sum();
            let det = n * sxx - sx * sx;
            [(sxx * sy - sx * sxy) / det, (n * sxy - sx * sy) / det]
        };
        let c0 = 1.0;
        let a = fit(c0);
        // Normal matrix over [c, a₀, a₁] of r = a₀ + a₁·c·x − y.
        let mut normal = [0.0; 9];
        for x in &xs {
            let j = [a[1] * x, 1.0, c0 * x];
            for i in 0..3 {
                for k in 0..3 {
                    normal[i * 3 + k] += j[i] * j[k];
                }
            }
        }
        let var_c = 1e-4;
        let got = held_covariance(&normal, 1, &[var_c]).unwrap();
        let h = 1e-6;
        let (p, m) = (fit(c0 + h), fit(c0 - h));
        let s = [(p[0] - m[0]) / (2.0 * h), (p[1] - m[1]) / (2.0 * h)];
        for i in 0..2 {
            for k in 0..2 {
                let want = s[i] * var_c * s[k];
                let scale = var_c * (s[0] * s[0] + s[1] * s[1]);
                assert!(
                    (got[i * 2 + k] - want).abs() <= 1e-6 * scale,
                    "({i}, {k}): {} vs {want}",
                    got[i * 2 + k]
                );
            }
        }
        assert!(got[3] > 0.0, "the slope moves with c");
    }
}
