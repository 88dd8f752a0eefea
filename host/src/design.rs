//! Level design (issue #22 item 4): the scales of a hierarchical set's levels that reach a
//! given finest fringe density with unwrapping failures below a target rate, for a given
//! modulation-to-noise ratio, and the failure rate each step is predicted to have.
//!
//! # The model
//! An N-step level of uniform shifts (eq 14) sums its samples into a phasor of length `N·B/2`
//! with independent Gaussian noise of `σ·√(N/2)` per component (σ the camera's read noise, B
//! the modulation; B/σ the ratio the user gives), so its phase error θ has the distribution of
//! the phase of a constant plus complex Gaussian noise, with `a = (B/σ)·√(N/2)`:
//!
//! ```text
//! p(θ) = e^(−a²/2)/(2π) · [1 + a·cos θ·√(2π)·e^(a²cos²θ/2)·Φ(a·cos θ)]
//! ```
//!
//! (Φ the standard normal distribution; for large a, θ ≈ N(0, 1/a²), `σ_φ = √(2/N)·σ/B`). A
//! step from level k−1 to level k of ratio `r = c_k/c_{k−1}` (eqs 12-13) compares
//! `r·Φ_{k−1}` with `φ_k`: their residual is `e = r·θ₀ − θ₁` modulo 2π, θ₀, θ₁ independent.
//! The decoder refuses the pixel when e is more than `t` (its unwrapping tolerance, 2π/3 by
//! default) from every multiple of 2π (`unwrap-inconsistent`), and takes a wrong fringe order
//! unnoticed when e is within `t` of a multiple other than 0. Both rates are integrals of p,
//! computed here numerically (θ₀ on a grid, θ₁ through its distribution function): the Gaussian
//! approximation underestimates the far tails (by 1.7× for wrong orders at B/σ = 4).
//!
//! A pixel fails if any step does (the sum bounds it). For a ratio R between the finest and the
//! coarsest scale and L levels, equal ratios `r = R^(1/(L−1))` give every step the same odds,
//! which minimises the worst step's: the design takes the fewest levels whose summed refusal
//! rate is within the target. The coarsest scale is the largest whose phase spans 0.9 of a
//! period over the projector (the default sets' span, which leaves the decoder's range test its
//! margin). The camera's quantization (1/12 code², a 4 % increase of σ² at σ = 1 code) is left
//! to the user's B/σ.

use std::f64::consts::{PI, TAU};

use fringe3d_core::limits::MAX_LEVELS;

/// What a design is for.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DesignGoal {
    /// Modulation over read noise, B/σ, of the dimmest surface to scan.
    pub snr: f64,
    /// Shifts per level (≥ 3: every level carries its own DC term).
    pub steps: usize,
    /// The finest level's scale `c_K` (the fringe density to reach).
    pub finest: f64,
    /// The coarsest level's largest scale (its phase within one period over the projector).
    pub coarsest_max: f64,
    /// Largest accepted rate of refused pixels (all steps), per pixel.
    pub failure_target: f64,
    /// The decoder's unwrapping tolerance, radians.
    pub tolerance: f64,
}

/// A design: the levels' scales and their predicted failure rates.
#[derive(Clone, Debug, PartialEq)]
pub struct Design {
    /// Scales `c_0 < … < c_K`, coarse to fine.
    pub scales: Vec<f64>,
    /// Each step's predicted refusal rate (`scales.len() − 1` of them).
    pub step_refused: Vec<f64>,
    /// Each step's predicted rate of undetected fringe-order errors.
    pub step_wrong: Vec<f64>,
    /// The wrapped phase noise of one level, radians.
    pub phase_noise: f64,
}

impl Design {
    /// Predicted refused pixels, all steps (their sum, an upper bound).
    pub fn refused(&self) -> f64 {
        self.step_refused.iter().sum()
    }

    /// Predicted undetected order errors, all steps.
    pub fn wrong(&self) -> f64 {
        self.step_wrong.iter().sum()
    }
}

/// Why no design meets a goal (the binding constraint).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum DesignError {
    /// A parameter is out of range (named).
    Parameter(&'static str),
    /// Even [`MAX_LEVELS`] levels of equal ratios leave this refusal rate.
    Infeasible {
        /// The best rate reached.
        refused: f64,
    },
}

impl std::fmt::Display for DesignError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            DesignError::Parameter(what) => write!(f, "level design: {what}"),
            DesignError::Infeasible { refused } => write!(
                f,
                "level design: the unwrapping noise binds: even {MAX_LEVELS} levels refuse \
                 {refused:.2e} of the pixels, above the target; raise B/sigma (brighter \
                 fringes, a longer exposure), the steps per level, or the target, or lower the \
                 finest scale"
            ),
        }
    }
}

impl std::error::Error for DesignError {}

/// The wrapped phase noise of an N-step level at modulation over noise `snr`, radians.
pub fn phase_noise(snr: f64, steps: usize) -> f64 {
    (2.0 / steps as f64).sqrt() / snr
}

/// The density of an N-step level's phase error θ ∈ (−π, π] at phasor SNR `a` (module docs).
pub fn phase_error_pdf(theta: f64, a: f64) -> f64 {
    // e^(−a²/2)·e^(a²cos²θ/2) = e^(−a²sin²θ/2): the form that neither overflows nor loses
    // the peak at large a.
    let c = a * theta.cos();
    let s = a * theta.sin();
    let tail = 0.5 * libm::erfc(-c / std::f64::consts::SQRT_2); // Φ(c)
    ((-0.5 * a * a).exp() + c * TAU.sqrt() * (-0.5 * s * s).exp() * tail) / TAU
}

/// Grid points over (−π, π] of the numerical integrals: at least 4096, and 64 per standard
/// deviation `1/a` of the phase error (at most 2²⁰).
fn grid(a: f64) -> usize {
    ((a * 64.0 * TAU) as usize).clamp(4096, 1 << 20)
}

/// One step's (refused, wrong-order) rates for ratio `r`, for levels whose phasor SNR is
/// `a = (B/σ)·√(N/2)` (module docs), with unwrapping tolerance `tolerance`. Every probability
/// is a sum of the density's mass over intervals, each taken from the nearer end of the
/// distribution (so that rates far below 1e-16 keep their digits).
pub fn step_rates_exact(r: f64, a: f64, tolerance: f64) -> (f64, f64) {
    // The mass of θ₁ on the grid (cell k covers [−π + kh, −π + (k+1)h)), cumulated from each
    // end: `below[k]` the mass under cell k's start, `above[k]` the mass from it on.
    let n = grid(a);
    let h = TAU / n as f64;
    let mass: Vec<f64> = (0..n)
        .map(|k| phase_error_pdf(-PI + (k as f64 + 0.5) * h, a) * h)
        .collect();
    let total: f64 = mass.iter().sum();
    let mut below = vec![0.0; n + 1];
    let mut above = vec![0.0; n + 1];
    for k in 0..n {
        below[k + 1] = below[k] + mass[k] / total;
        above[n - 1 - k] = above[n - k] + mass[n - 1 - k] / total;
    }
    let at = |y: f64| {
        let u = ((y + PI) / h).clamp(0.0, n as f64);
        let k = (u as usize).min(n - 1);
        (k, u - k as f64)
    };
    // P(lo < θ₁ < hi), from the lower end below the middle and the upper end above it.
    let between = |lo: f64, hi: f64| -> f64 {
        if hi <= lo {
            return 0.0;
        }
        let low = |y: f64| {
            let (k, f) = at(y);
            below[k] + f * (below[k + 1] - below[k])
        };
        let high = |y: f64| {
            let (k, f) = at(y);
            above[k] - f * (above[k] - above[k + 1])
        };
        if hi <= 0.0 {
            low(hi) - low(lo)
        } else if lo >= 0.0 {
            high(lo) - high(hi)
        } else {
            (low(0.0) - low(lo)) + (high(0.0) - high(hi))
        }
    };
    let (mut refused, mut wrong) = (0.0, 0.0);
    for (k, m) in mass.iter().enumerate() {
        let w = m / total;
        let x = r * (-PI + (k as f64 + 0.5) * h);
        // e = x − θ₁ within t of 2πm ⇔ θ₁ ∈ (x − 2πm − t, x − 2πm + t): windows every 2π,
        // the gaps between them refused.
        let reach = (x.abs() / TAU).ceil() as i64 + 2;
        for m in -reach..=reach {
            let c = x - TAU * m as f64;
            if m != 0 {
                wrong += w * between((c - tolerance).max(-PI), (c + tolerance).min(PI));
            }
            let (lo, hi) = ((c + tolerance).max(-PI), (c + TAU - tolerance).min(PI));
            refused += w * between(lo, hi);
        }
    }
    (refused, wrong)
}

/// [`step_rates_exact`] for an N-step level at B/σ `snr`.
pub fn step_rates(r: f64, snr: f64, steps: usize, tolerance: f64) -> (f64, f64) {
    step_rates_exact(r, snr * (steps as f64 / 2.0).sqrt(), tolerance)
}

/// `x > 0` rounded down to 4 significant digits.
fn round_down(x: f64) -> f64 {
    let unit = 10f64.powi(x.log10().floor() as i32 - 3);
    (x / unit).floor() * unit
}

/// The fewest levels of equal ratios that reach `goal.finest` within `goal.failure_target`.
pub fn design_levels(goal: &DesignGoal) -> Result<Design, DesignError> {
    let g = goal;
    if !(g.snr.is_finite() && g.snr > 0.0) {
        return Err(DesignError::Parameter("B/sigma must be positive"));
    }
    if !(3..=fringe3d_core::limits::MAX_SHIFTS).contains(&g.steps) {
        return Err(DesignError::Parameter("3 to 16 steps per level"));
    }
    if !(g.failure_target > 0.0 && g.failure_target < 1.0) {
        return Err(DesignError::Parameter(
            "the failure target must be in (0, 1)",
        ));
    }
    if !(g.finest.is_finite() && g.finest > 0.0 && g.coarsest_max > 0.0) {
        return Err(DesignError::Parameter("the scales must be positive"));
    }
    if !(g.tolerance > 0.0 && g.tolerance <= PI) {
        return Err(DesignError::Parameter(
            "the unwrapping tolerance must be in (0, pi]",
        ));
    }
    let sigma = phase_noise(g.snr, g.steps);
    let coarsest = g.coarsest_max.min(g.finest);
    let total = g.finest / coarsest;
    let mut best = f64::INFINITY;
    for levels in 1..=MAX_LEVELS {
        if levels == 1 && total > 1.0 + 1e-12 {
            continue;
        }
        let steps = levels.saturating_sub(1);
        let r = if steps == 0 {
            1.0
        } else {
            total.powf(1.0 / steps as f64)
        };
        // The coarser scales rounded down to 4 significant digits (a file's readable values; the
        // coarsest stays within its period), the finest exact; the rates are those of the
        // rounded ratios.
        let scales: Vec<f64> = (0..levels)
            .map(|k| {
                if k + 1 == levels {
                    g.finest
                } else {
                    round_down(coarsest * r.powi(k as i32))
                }
            })
            .collect();
        let rates: Vec<(f64, f64)> = scales
            .windows(2)
            .map(|w| step_rates(w[1] / w[0], g.snr, g.steps, g.tolerance))
            .collect();
        let sum: f64 = rates.iter().map(|r| r.0).sum();
        if sum <= g.failure_target {
            return Ok(Design {
                scales,
                step_refused: rates.iter().map(|r| r.0).collect(),
                step_wrong: rates.iter().map(|r| r.1).collect(),
                phase_noise: sigma,
            });
        }
        best = best.min(sum);
    }
    Err(DesignError::Infeasible { refused: best })
}

/// The least B/σ at which the set's level ratios refuse at most `target` of the pixels
/// ([`set_refusals`]).
pub fn needed_snr(set: &fringe3d_core::pattern::PatternSet, target: f64) -> f64 {
    let (mut a, mut b) = (1.0f64, 1e4f64);
    for _ in 0..60 {
        let m = (a * b).sqrt();
        if set_refusals(set, m) <= target {
            b = m;
        } else {
            a = m;
        }
    }
    b
}

/// The template's predicted unwrapping refusals at B/σ `snr` (hierarchical sets).
pub fn set_refusals(set: &fringe3d_core::pattern::PatternSet, snr: f64) -> f64 {
    let tol = fringe3d_core::decode::DecodeConfig::for_bit_depth(8).unwrap_tolerance as f64;
    let phase: Vec<_> = set.levels().iter().filter(|l| l.gray().is_none()).collect();
    if set.relation() != fringe3d_core::pattern::Relation::Hierarchical {
        return 0.0;
    }
    phase
        .windows(2)
        .map(|w| {
            let steps = w[0].shifts().len().min(w[1].shifts().len()).max(3);
            step_rates(w[1].scale() / w[0].scale(), snr, steps, tol).0
        })
        .sum()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn goal(snr: f64, finest: f64) -> DesignGoal {
        DesignGoal {
            snr,
            steps: 4,
            finest,
            coarsest_max: 1.0,
            failure_target: 1e-6,
            tolerance: 2.0 * PI / 3.0,
        }
    }

    #[test]
    fn more_noise_needs_more_levels_and_too_much_is_named() {
        let a = design_levels(&goal(14.0, 64.0)).unwrap();
        let b = design_levels(&goal(5.0, 64.0)).unwrap();
        assert!(b.scales.len() > a.scales.len(), "{a:?} {b:?}");
        assert!(a.refused() <= 1e-6 && b.refused() <= 1e-6);
        assert_eq!(*a.scales.last().unwrap(), 64.0);
        assert!(matches!(
            design_levels(&goal(0.5, 64.0)),
            Err(DesignError::Infeasible { .. })
        ));
        // Fewer levels would not do: one level fewer misses the target.
        let n = a.scales.len();
        let r = 64f64.powf(1.0 / (n - 2) as f64);
        let (p, _) = step_rates(r, 14.0, 4, 2.0 * PI / 3.0);
        assert!(p * (n - 2) as f64 > 1e-6);
    }

    #[test]
    fn tiny_scales_keep_their_digits() {
        // A phase function of thousands of radians: scales far below 1e-3 (a rounding to
        // decimals would make the coarsest 0 and the ratio infinite).
        let g = DesignGoal {
            coarsest_max: 1.234_567e-5,
            ..goal(14.0, 6.4e-4)
        };
        let d = design_levels(&g).unwrap();
        assert_eq!(d.scales[0], 1.234e-5);
        assert!(
            d.scales.windows(2).all(|w| w[0] > 0.0 && w[1] > w[0]),
            "{d:?}"
        );
    }
}
