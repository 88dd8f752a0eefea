//! A small Levenberg–Marquardt least-squares solver for problems whose Jacobian rows each touch
//! a few parameters (bundle adjustment: a residual depends on the 10 intrinsics and its view's 6
//! pose parameters). The normal equations are accumulated densely from the sparse rows and solved
//! by Cholesky; updates go through a caller-supplied `apply` so that rotations can be updated
//! multiplicatively.
//!
//! Damping: Marquardt's scaled diagonal `(JᵀJ + μ·diag(JᵀJ)) δ = −Jᵀr` with Nielsen's update of μ.

use super::linalg::{cholesky, cholesky_solve, spd_inverse};

/// The residuals and (optionally) the Jacobian of a problem at one state. Row `i` of the
/// Jacobian has `width` entries: columns `cols[i*width..]`, values `vals[i*width..]` (unused
/// entries: value 0, any column).
#[derive(Clone, Debug, Default)]
pub struct Eval {
    /// Residuals.
    pub r: Vec<f64>,
    /// Entries per Jacobian row.
    pub width: usize,
    /// Column indices, `r.len() × width`.
    pub cols: Vec<usize>,
    /// Values, `r.len() × width`.
    pub vals: Vec<f64>,
}

impl Eval {
    /// Sum of squared residuals.
    pub fn cost(&self) -> f64 {
        self.r.iter().map(|x| x * x).sum()
    }

    /// `JᵀJ` (dense, `n × n`) and `Jᵀr`.
    pub fn normal_equations(&self, n: usize) -> (Vec<f64>, Vec<f64>) {
        let mut a = vec![0.0; n * n];
        let mut g = vec![0.0; n];
        let w = self.width;
        for (i, &ri) in self.r.iter().enumerate() {
            let cols = &self.cols[i * w..(i + 1) * w];
            let vals = &self.vals[i * w..(i + 1) * w];
            for (k, (&ck, &vk)) in cols.iter().zip(vals).enumerate() {
                if vk == 0.0 {
                    continue;
                }
                g[ck] += vk * ri;
                for (&cl, &vl) in cols[..=k].iter().zip(&vals[..=k]) {
                    a[ck * n + cl] += vk * vl;
                }
            }
        }
        // Mirror: the loop above filled (ck, cl) for l ≤ k; make A symmetric.
        for i in 0..n {
            for j in 0..i {
                let s = a[i * n + j] + a[j * n + i];
                a[i * n + j] = s;
                a[j * n + i] = s;
            }
        }
        // (Each unordered pair k ≠ l landed in either triangle once, so the sum is the entry;
        // diagonal entries are untouched. Rows must not repeat a column with non-zero values.)
        (a, g)
    }
}

/// Options of [`solve`].
#[derive(Clone, Copy, Debug)]
pub struct Options {
    /// Iteration limit.
    pub max_iterations: usize,
    /// Stop when the relative cost decrease of an accepted step is below this.
    pub cost_tolerance: f64,
    /// Stop when every step component is below this (in parameter units, after scaling by
    /// `sqrt(diag JᵀJ)`, i.e. a fraction of one standard deviation).
    pub step_tolerance: f64,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            max_iterations: 200,
            cost_tolerance: 1e-14,
            step_tolerance: 1e-10,
        }
    }
}

/// The result of [`solve`].
#[derive(Clone, Debug)]
pub struct Solution<S> {
    /// The final state.
    pub state: S,
    /// Its sum of squared residuals.
    pub cost: f64,
    /// Its residuals.
    pub residuals: Vec<f64>,
    /// `JᵀJ` at the final state (dense `n × n`), for covariances.
    pub jtj: Vec<f64>,
    /// Iterations done.
    pub iterations: usize,
    /// `true` if a tolerance was met (not the iteration limit).
    pub converged: bool,
}

impl<S> Solution<S> {
    /// The parameter covariance `σ² (JᵀJ)⁻¹` with `σ² = cost / (m − n)` (`None` if `JᵀJ` is
    /// singular or there are no redundant residuals).
    pub fn covariance(&self, n: usize) -> Option<Vec<f64>> {
        let m = self.residuals.len();
        if m <= n {
            return None;
        }
        let s2 = self.cost / (m - n) as f64;
        spd_inverse(&self.jtj, n).map(|mut c| {
            c.iter_mut().for_each(|x| *x *= s2);
            c
        })
    }
}

/// Minimise `Σ r²` over the state. `eval(state, want_jacobian)` returns the residuals (and the
/// Jacobian with respect to the `n` local parameters when asked) or `None` if the state is
/// invalid (e.g. a point behind the camera), which counts as a rejected step; `apply(state, δ)`
/// moves the state by δ. `None` if the starting state cannot be evaluated.
pub fn solve<S: Clone>(
    start: S,
    n: usize,
    eval: impl Fn(&S, bool) -> Option<Eval>,
    apply: impl Fn(&S, &[f64]) -> S,
    opts: Options,
) -> Option<Solution<S>> {
    let mut state = start;
    let mut e = eval(&state, true)?;
    let mut cost = e.cost();
    let (mut a, mut g) = e.normal_equations(n);
    let mut mu = 1e-3;
    let mut nu = 2.0;
    let mut converged = false;
    let mut it = 0;
    while it < opts.max_iterations {
        it += 1;
        if g.iter().all(|x| *x == 0.0) {
            converged = true;
            break;
        }
        // Damped system with the scaled diagonal.
        let diag: Vec<f64> = (0..n).map(|i| a[i * n + i].max(1e-12)).collect();
        let mut m = a.clone();
        for i in 0..n {
            m[i * n + i] += mu * diag[i];
        }
        if !cholesky(&mut m, n) {
            mu *= nu;
            nu *= 2.0;
            continue;
        }
        let mut delta: Vec<f64> = g.iter().map(|x| -x).collect();
        cholesky_solve(&m, n, &mut delta);
        // Predicted decrease: δᵀ(μ D δ − g)·… (for the linear model).
        let pred: f64 = (0..n)
            .map(|i| delta[i] * (mu * diag[i] * delta[i] - g[i]))
            .sum();
        let cand = apply(&state, &delta);
        let small_step = (0..n).all(|i| (delta[i] * diag[i].sqrt()).abs() < opts.step_tolerance);
        match eval(&cand, true) {
            Some(ec) if ec.cost() < cost => {
                let newc = ec.cost();
                let rho = if pred > 0.0 {
                    (cost - newc) / pred
                } else {
                    1.0
                };
                let rel = (cost - newc) / cost.max(1e-300);
                state = cand;
                e = ec;
                cost = newc;
                let ne = e.normal_equations(n);
                a = ne.0;
                g = ne.1;
                mu *= (1.0 - (2.0 * rho - 1.0).powi(3)).max(1.0 / 3.0);
                nu = 2.0;
                if rel < opts.cost_tolerance || small_step {
                    converged = true;
                    break;
                }
            }
            _ => {
                if small_step {
                    converged = true;
                    break;
                }
                mu *= nu;
                nu *= 2.0;
                if mu > 1e30 {
                    converged = true;
                    break;
                }
            }
        }
    }
    Some(Solution {
        state,
        cost,
        residuals: e.r,
        jtj: a,
        iterations: it,
        converged,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fits_an_exponential() {
        // y = a·exp(b·x) + c, exact data.
        let (a0, b0, c0) = (2.5, -0.7, 0.3);
        let xs: Vec<f64> = (0..30).map(|i| i as f64 * 0.2).collect();
        let ys: Vec<f64> = xs.iter().map(|x| a0 * (b0 * x).exp() + c0).collect();
        let eval = |p: &Vec<f64>, _j: bool| -> Option<Eval> {
            let mut e = Eval {
                width: 3,
                ..Default::default()
            };
            for (x, y) in xs.iter().zip(&ys) {
                let ex = (p[1] * x).exp();
                e.r.push(p[0] * ex + p[2] - y);
                e.cols.extend([0, 1, 2]);
                e.vals.extend([ex, p[0] * x * ex, 1.0]);
            }
            Some(e)
        };
        let apply =
            |p: &Vec<f64>, d: &[f64]| p.iter().zip(d).map(|(a, b)| a + b).collect::<Vec<f64>>();
        let s = solve(vec![1.0, 0.0, 0.0], 3, eval, apply, Options::default()).unwrap();
        assert!(s.converged);
        assert!(
            (s.state[0] - a0).abs() < 1e-8
                && (s.state[1] - b0).abs() < 1e-8
                && (s.state[2] - c0).abs() < 1e-8,
            "{:?}",
            s.state
        );
    }
}
