//! `[projector_response]`: the projector's measured response r(x) ([`ProjectorResponse`]), the
//! calibration file's record of it (`fringe3d calibrate gamma` writes it; docs/gamma.md).
//!
//! r is stored as its values at the measured levels and read by monotone piecewise-cubic
//! (Fritsch–Carlson) interpolation, which is increasing wherever the data are, so its inverse is
//! well defined.

use serde::{Deserialize, Serialize};

/// A projector's normalised response `r(x)`, `x` and `r` in [0, 1].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ProjectorResponse {
    /// Pattern values `x` (code / full scale), increasing, from 0 to 1.
    pub levels: Vec<f64>,
    /// `r` at those values, increasing, from 0 to 1.
    pub response: Vec<f64>,
    /// The power law `x^γ` closest to the table (least squares), for the report.
    pub gamma: f64,
}

impl ProjectorResponse {
    /// A linear projector (r(x) = x).
    pub fn linear() -> Self {
        ProjectorResponse {
            levels: vec![0.0, 1.0],
            response: vec![0.0, 1.0],
            gamma: 1.0,
        }
    }

    /// Check the table: at least two levels, equal lengths, both increasing, from 0 to 1.
    pub fn validate(&self) -> Result<(), String> {
        let (x, r) = (&self.levels, &self.response);
        if x.len() < 2 || x.len() != r.len() {
            return Err(format!(
                "projector_response: levels ({}) and response ({}) need the same length, at least 2",
                x.len(),
                r.len()
            ));
        }
        for (name, v) in [("levels", x), ("response", r)] {
            if v.iter().any(|a| !a.is_finite()) {
                return Err(format!("projector_response.{name}: not a number"));
            }
            if v[0] != 0.0 || v[v.len() - 1] != 1.0 {
                return Err(format!(
                    "projector_response.{name} must run from 0 to 1 (normalised), got {} .. {}",
                    v[0],
                    v[v.len() - 1]
                ));
            }
            if let Some(i) = (1..v.len()).find(|&i| v[i] <= v[i - 1]) {
                return Err(format!(
                    "projector_response.{name} must increase: entry {i} ({}) after {}",
                    v[i],
                    v[i - 1]
                ));
            }
        }
        if !(self.gamma.is_finite() && self.gamma > 0.0) {
            return Err(format!("projector_response.gamma = {}", self.gamma));
        }
        Ok(())
    }

    /// Whether the response is the identity (no correction needed).
    pub fn is_linear(&self) -> bool {
        self.levels == self.response
    }

    /// `r(x)` (x clamped to [0, 1]).
    pub fn eval(&self, x: f64) -> f64 {
        hermite(&self.levels, &self.response, x.clamp(0.0, 1.0))
    }

    /// `r⁻¹(y)`: the pattern value that makes relative light `y` (clamped to [0, 1]); bisection
    /// to 1e-12 on the increasing interpolant.
    pub fn inverse(&self, y: f64) -> f64 {
        let y = y.clamp(0.0, 1.0);
        let (mut lo, mut hi) = (0.0f64, 1.0f64);
        for _ in 0..48 {
            let mid = 0.5 * (lo + hi);
            if self.eval(mid) < y {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        0.5 * (lo + hi)
    }
}

/// Monotone cubic Hermite interpolation (Fritsch–Carlson slopes) of increasing data.
fn hermite(x: &[f64], y: &[f64], t: f64) -> f64 {
    let n = x.len();
    if n < 2 {
        return t;
    }
    let i = match x.iter().position(|&xi| xi > t) {
        Some(0) => 0,
        Some(i) => i - 1,
        None => n - 2,
    };
    let d = |k: usize| (y[k + 1] - y[k]) / (x[k + 1] - x[k]);
    // Slopes at the knots: harmonic mean of the neighbouring secants (zero at a turn), one-sided
    // at the ends; this keeps the interpolant increasing.
    let slope = |k: usize| -> f64 {
        if k == 0 {
            d(0)
        } else if k == n - 1 {
            d(n - 2)
        } else {
            let (a, b) = (d(k - 1), d(k));
            if a * b <= 0.0 {
                0.0
            } else {
                let (ha, hb) = (x[k] - x[k - 1], x[k + 1] - x[k]);
                let (w1, w2) = (2.0 * hb + ha, hb + 2.0 * ha);
                (w1 + w2) / (w1 / a + w2 / b)
            }
        }
    };
    let h = x[i + 1] - x[i];
    let s = ((t - x[i]) / h).clamp(0.0, 1.0);
    let (m0, m1) = (slope(i) * h, slope(i + 1) * h);
    let (s2, s3) = (s * s, s * s * s);
    (2.0 * s3 - 3.0 * s2 + 1.0) * y[i]
        + (s3 - 2.0 * s2 + s) * m0
        + (-2.0 * s3 + 3.0 * s2) * y[i + 1]
        + (s3 - s2) * m1
}
