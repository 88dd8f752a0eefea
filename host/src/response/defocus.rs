//! The projector's effective blur, measured from a scan of binary patterns
//! ([`estimate_defocus`], `fringe3d calibrate defocus`; docs/binary.md).
//!
//! # Why the phase histogram tells σ
//! A binary set's finest level measures `φ = θ + e_σ(θ)`: the binarization's error `e_σ`, a
//! periodic function of the true phase θ whose harmonics are those the level's N steps alias
//! (frequencies N, 2N, … in θ), shrinks as the blur σ grows ([`super::binary`]). Where `e_σ`
//! compresses the measured phase its values crowd: on a surface that spans many fringe periods θ
//! is uniform modulo 2π, so the histogram of φ is not, and its circular moments
//! `M_k = |mean e^{ikφ}|` at `k = N, 2N, 3N` are ≈ the error's harmonics. The decoder's table
//! for a candidate σ turns φ back into `θ_σ = φ − Δ_σ(φ)`; for the true σ the result is uniform
//! again. So the estimate is the σ that minimises `Σ_k M_k(θ_σ)`: a grid of candidates (the
//! tables [`super::binary::binary_table`] computes), then a parabola through the best one and
//! its neighbours.
//!
//! What it needs: one scan, decoded without correction, of a surface crossing at least ~20
//! periods of the finest level (the reference plane is ideal) and ≥ 10 000 valid pixels. The
//! statistic's noise is ≈ 1/√n per moment; camera noise only scales every moment alike. The
//! blur it finds is the *effective* one (lens and camera together, in projector pixels), which
//! is what the decoder's model needs.

use super::binary::binary_table;
use fringe3d_core::decode::PhaseCorrection;
use fringe3d_core::pattern::PatternSet;

/// The candidate blurs, projector pixels: 0.5 to 8 in steps of 0.5 (then refined).
pub const CANDIDATES: (f64, f64, f64) = (0.5, 8.0, 0.5);
/// The fewest valid pixels an estimate is made from.
pub const MIN_PIXELS: usize = 10_000;

/// The estimate and what it rests on.
#[derive(Clone, Debug, serde::Serialize)]
pub struct DefocusFit {
    /// The effective blur σ, projector pixels.
    pub sigma: f64,
    /// Valid pixels of the finest level used.
    pub pixels: usize,
    /// The non-uniformity `Σ_k M_k` of the measured phase (no correction).
    pub uncorrected: f64,
    /// The same after the table of [`Self::sigma`].
    pub corrected: f64,
    /// `(σ, Σ_k M_k)` at every candidate whose table exists.
    pub curve: Vec<(f64, f64)>,
}

/// The blur σ whose table makes the finest level's wrapped phases `phi` (radians, valid pixels
/// of a scan decoded without correction) uniform, for binary `set`.
pub fn estimate_defocus(set: &PatternSet, phi: &[f64]) -> Result<DefocusFit, String> {
    if !set.binarization().is_binary() {
        return Err("the set is not binary (binary = \"square\" or \"bayer\")".into());
    }
    if phi.len() < MIN_PIXELS {
        return Err(format!(
            "{} valid pixels of the finest level; the estimate needs at least {MIN_PIXELS} (a \
             plane filling the view)",
            phi.len()
        ));
    }
    let levels = set.levels();
    let fine = levels.len() - 1;
    let n = levels[fine].len() as f64;
    let score = |t: &PhaseCorrection| nonuniformity(phi.iter().map(|&p| t.reference(fine, p)), n);
    let at = |sigma: f64| -> Option<f64> { binary_table(set, sigma).ok().map(|(t, _)| score(&t)) };
    let (lo, hi, step) = CANDIDATES;
    let mut curve = Vec::new();
    let mut s = lo;
    while s <= hi + 1e-9 {
        if let Some(v) = at(s) {
            curve.push((s, v));
        }
        s += step;
    }
    let best = (0..curve.len())
        .min_by(|&a, &b| curve[a].1.total_cmp(&curve[b].1))
        .ok_or("no candidate blur gives a phase-error table for this set")?;
    // A parabola through the best candidate and its neighbours (when it has both).
    let mut sigma = curve[best].0;
    if best > 0 && best + 1 < curve.len() {
        let (x0, y0) = curve[best - 1];
        let (x1, y1) = curve[best];
        let (x2, y2) = curve[best + 1];
        let d = (x0 - x1) * (x0 - x2) * (x1 - x2);
        let a = (x2 * (y1 - y0) + x1 * (y0 - y2) + x0 * (y2 - y1)) / d;
        let b = (x2 * x2 * (y0 - y1) + x1 * x1 * (y2 - y0) + x0 * x0 * (y1 - y2)) / d;
        if a > 0.0 {
            sigma = (-b / (2.0 * a)).clamp(x0, x2);
        }
    }
    let corrected = at(sigma).unwrap_or(curve[best].1);
    Ok(DefocusFit {
        sigma,
        pixels: phi.len(),
        uncorrected: nonuniformity(phi.iter().copied(), n),
        corrected,
        curve,
    })
}

/// `Σ_{m=1..3} |mean e^{i·m·n·θ}|`: the circular moments of `theta` at the frequencies an
/// `n`-step level's harmonic error has.
fn nonuniformity(theta: impl Iterator<Item = f64>, n: f64) -> f64 {
    let mut acc = [(0.0f64, 0.0f64); 3];
    let mut count = 0usize;
    for t in theta {
        for (m, a) in acc.iter_mut().enumerate() {
            let k = (m + 1) as f64 * n * t;
            a.0 += k.cos();
            a.1 += k.sin();
        }
        count += 1;
    }
    let c = count.max(1) as f64;
    acc.iter().map(|(x, y)| (x * x + y * y).sqrt() / c).sum()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::response::binary::binary_correction;
    use fringe3d_core::binary::Binarization;
    use fringe3d_core::pattern::{GrayCode, Level, Output};
    use fringe3d_core::phase_function::{Axis, PhaseFunction};

    #[test]
    fn the_blur_of_a_modelled_scan_is_found_again() {
        // The measured phases of a uniform θ under the table of σ = 2.6 (its inverse: φ with
        // φ − Δ(φ) = θ), as an ideal scan would give them; the estimate must find 2.6.
        let out = Output {
            width: 768,
            height: 64,
            i_min: 0.0,
            i_max: 255.0,
        };
        let f = PhaseFunction::centered(Axis::Xi, 768, std::f64::consts::TAU).unwrap();
        let levels = [
            Level::gray_code(32.0, GrayCode::new(6, true)),
            Level::n_step(32.0, 4),
        ];
        let set = PatternSet::new(f, &levels, out)
            .unwrap()
            .with_binarization(Binarization::Square);
        let (t, _) = binary_correction(&set, 2.6).unwrap();
        let phi: Vec<f64> = (0..40_000)
            .map(|i| {
                let theta =
                    -std::f64::consts::PI + std::f64::consts::TAU * (i as f64 + 0.5) / 40_000.0;
                let mut p = theta;
                for _ in 0..60 {
                    p = theta + (p - t.reference(1, p));
                }
                p
            })
            .collect();
        let fit = estimate_defocus(&set, &phi).unwrap();
        assert!((fit.sigma - 2.6).abs() < 0.1, "{fit:?}");
        assert!(fit.corrected < 0.2 * fit.uncorrected, "{fit:?}");
        // Too few pixels, or a gray-level set: refused.
        assert!(estimate_defocus(&set, &phi[..100]).is_err());
        let gray = set.with_binarization(Binarization::Off);
        assert!(estimate_defocus(&gray, &phi).is_err());
    }
}
