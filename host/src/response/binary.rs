//! The phase-error table of a binary pattern set under a projector's defocus
//! ([`binary_correction`]): the decoder's model of 1-bit patterns (issue #20 item 3,
//! [`fringe3d_core::binary`]).
//!
//! # The model
//! The projector shows each 1-bit image `v_ij ∈ {0, 1}` on its pixel grid; its lens blurs it
//! with a Gaussian of σ projector pixels, so the light leaving it towards projector coordinate
//! (ξ, η) is the renderer's model (`render::light`):
//!
//! ```text
//! L(ξ, η) = Σ_ij v_ij · K(ξ − i) · K(η − j),   K(x) = ½·[erf((x + ½)/(σ√2)) − erf((x − ½)/(σ√2))]
//! ```
//!
//! (σ = 0: the pixel staircase itself; [`box_gauss`]). The camera sees `A₀ + K_cam·L`. Each
//! level's linear estimate (eqs 9, 11, 14) of those images differs from the phase `θ` the set's
//! sinusoids would give by an error that depends on θ, the pixel grid and σ only: the
//! binarization's harmonics that the defocus leaves (a square wave's 3rd and 5th alias into a
//! 4-step level), and the fraction of a pixel by which its fundamental sits off θ (the square
//! wave's edges fall on pixel boundaries). It is tabulated as the response's error is
//! (`table::tabulate`): along the set's phase axis at the projector's middle, 16 samples per
//! pixel, both the ideal sinusoids and `L` are decoded by the core's decoder, and the table's
//! knots are fitted to their difference at the measured phase. A Bayer-dithered image changes
//! along both axes: its rows are modelled over one 8-row tile (2 samples per pixel across).
//! The table must leave at most [`MAX_FINE_RESIDUAL`] RMS on the finest level, and at most
//! [`MAX_ORDER_RESIDUAL`] of the next phase at any sample of every unwrapping step (a coarser
//! level, or a heterodyne set's beats), or the set is refused.
//!
//! # What it leaves
//! - σ is the *effective* blur in projector pixels: the lens's defocus and the camera's own
//!   blur mapped onto the projector (`σ² = σ_proj² + (m·σ_cam)²` for `m` projector pixels per
//!   camera pixel). An error in σ leaves part of the harmonic error (docs/binary.md shows how much).
//! - The error repeats from period to period only where the pattern does: a square wave's period
//!   a whole (even) number of pixels, a dither's a multiple of its 8-pixel tile. Elsewhere the
//!   table holds its mean and the rest beats slowly across the projector (0.05 rad for a
//!   31.6-pixel dithered period), which the residual check refuses.

use super::table::{LevelError, tabulate};
use crate::io::calibration::ProjectorResponse;
use crate::math::box_gauss;
use fringe3d_core::binary::Binarization;
use fringe3d_core::decode::PhaseCorrection;
use fringe3d_core::pattern::{PatternSet, Relation};
use fringe3d_core::phase_function::Axis;

/// Samples per projector pixel along the phase axis.
const OVERSAMPLE: usize = 16;
pub use crate::io::calibration::MAX_DEFOCUS;

/// The table of binary `set` under a defocus of `sigma` projector pixels, and each level's error
/// before and after it.
pub fn binary_correction(
    set: &PatternSet,
    sigma: f64,
) -> Result<(PhaseCorrection, Vec<LevelError>), String> {
    let (table, report) = binary_table(set, sigma)?;
    check_residuals(set, sigma, &report)?;
    Ok((table, report))
}

/// What [`binary_correction`] advises when the table cannot correct the patterns.
const ADVICE: &str = "more defocus, a longer period, more phase steps, or binary = \"bayer\"";

/// The table of binary `set` under a blur of `sigma` projector pixels and each level's error,
/// without [`binary_correction`]'s check of what it leaves (`calibrate defocus` compares
/// candidate blurs with it).
pub fn binary_table(
    set: &PatternSet,
    sigma: f64,
) -> Result<(PhaseCorrection, Vec<LevelError>), String> {
    if !set.binarization().is_binary() {
        return Err("the set is not binary (binary = \"square\" or \"bayer\")".into());
    }
    light_table(set, sigma, None)
}

/// The table of any set under the light model above: each DMD pixel emits `r(code/full)` for
/// the measured `response` r (the pattern's code quantized as `generate_row` does; without a
/// response, the linear light of the pattern's value), blurred by `sigma` projector pixels.
/// For a gray-level set with a measured response this is the response's table
/// ([`super::table::phase_correction`]) with the projector's defocus, which attenuates the
/// harmonics the response makes (docs/gamma.md).
pub fn light_table(
    set: &PatternSet,
    sigma: f64,
    response: Option<&ProjectorResponse>,
) -> Result<(PhaseCorrection, Vec<LevelError>), String> {
    if !(sigma.is_finite() && (0.0..=MAX_DEFOCUS).contains(&sigma)) {
        return Err(format!(
            "the defocus must be in [0, {MAX_DEFOCUS}] projector pixels, got {sigma}"
        ));
    }
    let o = *set.output();
    let (along, across) = match set.axis() {
        Axis::Xi => (o.width, o.height),
        Axis::Eta => (o.height, o.width),
    };
    // Rows modelled across the fringes: one for square waves (constant across), one 8-pixel
    // Bayer tile at 2 samples per pixel for dithered images.
    let mid = ((across as f64 - 1.0) / 2.0).floor();
    let cross: Vec<f64> = match set.binarization() {
        Binarization::Bayer => (0..16).map(|s| mid - 3.75 + 0.5 * s as f64).collect(),
        _ => vec![mid],
    };
    let at = |t: f64, c: f64| match set.axis() {
        Axis::Xi => (t, c),
        Axis::Eta => (c, t),
    };
    let ideal = set.with_binarization(Binarization::Off);
    // Samples along the axis, away from the DMD's ends by the blur's reach (where its edge, not
    // the pattern, shapes the light).
    let reach = if sigma > 0.0 {
        (7.0 * sigma + 0.5).ceil() as i64
    } else {
        0
    };
    let (first, last) = (reach as f64 + 0.5, along as f64 - 1.5 - reach as f64);
    if last - first < 8.0 {
        return Err(format!(
            "the projector ({along} pixels along the phase axis) is too small for a defocus of {sigma} pixels"
        ));
    }
    let n = ((last - first) * OVERSAMPLE as f64) as usize;
    let samples: Vec<f64> = (0..n)
        .map(|i| first + i as f64 / OVERSAMPLE as f64)
        .collect();
    let span = o.i_max - o.i_min;
    let full = if o.i_max > 255.0 { 65535.0 } else { 255.0 };
    let (i0, gain) = (1000.0, 60000.0);
    let code = |x: f64| (i0 + gain * x.clamp(0.0, 1.0)).round() as u16;
    // The kernel's taps at each sub-pixel phase of the samples (sample s and s + OVERSAMPLE are
    // one pixel apart): `taps[s % OVERSAMPLE][d]` is K(t − (c + d − reach)) for the pixel c
    // nearest t.
    let taps: Vec<Vec<f64>> = samples
        .iter()
        .take(OVERSAMPLE)
        .map(|&t| {
            let c = t.round();
            (-reach..=reach)
                .map(|d| kernel(t - (c + d as f64), sigma))
                .collect()
        })
        .collect();
    let mut lin = vec![Vec::with_capacity(n * cross.len()); set.image_count()];
    let mut meas = vec![Vec::with_capacity(n * cross.len()); set.image_count()];
    // A square wave of straight fringes is the same in every row: one row, whose blur across
    // sums to 1 (the modelled row is far from the DMD's edges). A dithered or curved one is
    // blurred across over the rows within reach.
    let uniform = set.binarization() != Binarization::Bayer && set.function().curvature() == 0.0;
    let (lo, hi) = if uniform {
        (mid as i64, mid as i64)
    } else {
        (
            (cross[0] - reach as f64).floor() as i64 - 1,
            (cross[cross.len() - 1] + reach as f64).ceil() as i64 + 1,
        )
    };
    // Each modelled row's weights across, over the rows `lo..=hi`.
    let weights: Vec<Vec<f64>> = cross
        .iter()
        .map(|&c| {
            (lo..=hi)
                .map(|j| {
                    if uniform {
                        1.0
                    } else {
                        kernel(c - j as f64, sigma)
                    }
                })
                .collect()
        })
        .collect();
    for k in 0..set.image_count() {
        // A Gray-code image: binary already, and no level's phase (`tabulate` skips it).
        if set.gray().is_some() && set.image(k).is_some_and(|id| id.level == 0) {
            lin[k] = vec![0; n * cross.len()];
            meas[k] = vec![0; n * cross.len()];
            continue;
        }
        // The 1-bit image over the rows the modelled ones reach (pixel-index space; nothing is
        // emitted past the DMD's edges).
        let rows: Vec<Vec<f64>> = (lo..=hi)
            .map(|j| {
                (0..along as i64)
                    .map(|i| {
                        let (x, y) = at(i as f64, j as f64);
                        let v = set.intensity(k, x, y).unwrap_or(o.i_min);
                        if !(span > 0.0 && (0..across as i64).contains(&j)) {
                            0.0
                        } else if let Some(r) = response {
                            r.eval(v.round() / full)
                        } else {
                            (v - o.i_min) / span
                        }
                    })
                    .collect()
            })
            .collect();
        // Blur along the axis at every sample (the DMD's extent ends the sum), then across.
        let along_blur: Vec<Vec<f64>> = rows
            .iter()
            .map(|r| {
                samples
                    .iter()
                    .enumerate()
                    .map(|(s, &t)| blur_at(r, t, &taps[s % OVERSAMPLE], reach))
                    .collect()
            })
            .collect();
        for (ci, &c) in cross.iter().enumerate() {
            for (s, &t) in samples.iter().enumerate() {
                let mut l = 0.0;
                for (r, w) in along_blur.iter().zip(&weights[ci]) {
                    l += r[s] * w;
                }
                meas[k].push(code(l));
                let (x, y) = at(t, c);
                let v = ideal.intensity(k, x, y).unwrap_or(o.i_min);
                lin[k].push(code(if span > 0.0 {
                    (v - o.i_min) / span
                } else {
                    0.0
                }));
            }
        }
    }
    tabulate(
        set,
        &lin,
        &meas,
        &format!(
            "the binary patterns are too far from sinusoids at this defocus to correct ({ADVICE})"
        ),
    )
}

/// [`binary_correction`]'s check of what the table of `sigma` leaves (`report`).
fn check_residuals(set: &PatternSet, sigma: f64, report: &[LevelError]) -> Result<(), String> {
    let advice = ADVICE;
    // What the 32-knot table cannot follow (an error curve too steep where the defocus leaves
    // strong harmonics) must not pass silently. The finest level's residual goes into every
    // point (its RMS into the noise); a coarser level's largest residual, times the ratio of
    // the unwrapping step it starts, into fringe orders.
    let c: Vec<f64> = set.levels().iter().map(|l| l.scale()).collect();
    let fine = c.len() - 1;
    let r = &report[fine];
    if r.residual_rms_rad > MAX_FINE_RESIDUAL {
        return Err(format!(
            "at a defocus of {sigma} projector pixels, the finest level's binary patterns keep \
             {:.3} rad RMS of error after correction (of {:.3}), more than the {MAX_FINE_RESIDUAL} \
             rad the phase may carry: {advice}",
            r.residual_rms_rad, r.rms_rad
        ));
    }
    // Each unwrapping step: (the residual it starts from, in radians of `from`, its scale
    // `from`, the scale `to` it unwraps). A heterodyne beat adds its levels' errors: at most
    // 2 (a beat) or 4 (the beat of beats) times the largest.
    let worst = report.iter().fold(0.0f64, |m, r| m.max(r.residual_max_rad));
    let steps: Vec<(f64, f64, f64, String)> = match (set.relation(), c.len()) {
        (Relation::Heterodyne, 2) => vec![
            (2.0 * worst, c[1] - c[0], c[0], "the beat".into()),
            (report[0].residual_max_rad, c[0], c[1], "level 0".into()),
        ],
        (Relation::Heterodyne, _) => vec![
            (
                4.0 * worst,
                c[2] - 2.0 * c[1] + c[0],
                c[1] - c[0],
                "the beat of beats".into(),
            ),
            (
                2.0 * worst,
                c[1] - c[0],
                c[1],
                "the beat of levels 0 and 1".into(),
            ),
            (report[1].residual_max_rad, c[1], c[2], "level 1".into()),
        ],
        // A coprime pair's order is decided within π/a of level 1 (`Relation::Coprime`): its
        // residual, `r₁ + (b/a)·r₀` in level 1's radians, counts `a` times against the limit;
        // then the chain from level 1.
        (Relation::Coprime, _) => {
            let (a, b) = fringe3d_core::pattern::coprime_ratio(c[0], c[1]).unwrap_or((1, 2));
            let (a, b) = (a as f64, b as f64);
            let pair = report[1].residual_max_rad + b / a * report[0].residual_max_rad;
            std::iter::once((a * pair, 1.0, 1.0, "the coprime pair's order".into()))
                .chain((1..fine).map(|l| {
                    (
                        report[l].residual_max_rad,
                        c[l],
                        c[l + 1],
                        format!("level {l}"),
                    )
                }))
                .collect()
        }
        (Relation::Hierarchical, _) => (0..fine)
            .map(|l| {
                (
                    report[l].residual_max_rad,
                    c[l],
                    c[l + 1],
                    format!("level {l}"),
                )
            })
            .collect(),
    };
    for (residual, from, to, what) in steps {
        if residual * to / from > MAX_ORDER_RESIDUAL {
            return Err(format!(
                "at a defocus of {sigma} projector pixels, {what} keeps up to {residual:.3} rad of \
                 the binary patterns' error after correction: {:.2} rad of the next phase, more \
                 than the {MAX_ORDER_RESIDUAL:.2} rad its fringe order may take: {advice}",
                residual * to / from
            ));
        }
    }
    Ok(())
}

/// The largest residual error (radians RMS) the finest level of a binary set may keep after its
/// table: 0.02 rad adds under 10 % to the phase noise of a 4-step level at a modulation of 14
/// noise levels (0.05 rad).
pub const MAX_FINE_RESIDUAL: f64 = 0.02;
/// The largest residual error (radians, its largest) a level may leave in the phase it
/// unwraps: a quarter of the unwrapping's ±π.
pub const MAX_ORDER_RESIDUAL: f64 = std::f64::consts::FRAC_PI_4;

/// K(x): the box ⊗ Gaussian kernel, or the box itself for σ = 0.
fn kernel(x: f64, sigma: f64) -> f64 {
    if sigma > 0.0 {
        box_gauss(x, sigma)
    } else if (-0.5..0.5).contains(&x) {
        1.0
    } else {
        0.0
    }
}

/// `Σ_i row_i · K(t − i)` over the pixels within `reach` of the pixel nearest `t`, with `taps`
/// the kernel at t's sub-pixel phase (pixels past the DMD's ends emit nothing).
fn blur_at(row: &[f64], t: f64, taps: &[f64], reach: i64) -> f64 {
    let c = t.round() as i64;
    let mut acc = 0.0;
    for (d, w) in taps.iter().enumerate() {
        let i = c + d as i64 - reach;
        if let Some(v) = usize::try_from(i).ok().and_then(|i| row.get(i)) {
            acc += v * w;
        }
    }
    acc
}

#[cfg(test)]
mod tests {
    use super::*;
    use fringe3d_core::pattern::{GrayCode, Level, Output};
    use fringe3d_core::phase_function::PhaseFunction;

    /// The classic binary scheme: a complementary Gray code and a 4-step level of `period`
    /// pixels over a 384-pixel projector.
    fn four_step(period: f64, b: Binarization) -> PatternSet {
        four_step_along(Axis::Xi, period, b)
    }

    /// [`four_step`] with its phase along `axis` (the projector transposed for η).
    fn four_step_along(axis: Axis, period: f64, b: Binarization) -> PatternSet {
        let (w, h) = if axis == Axis::Xi {
            (384, 64)
        } else {
            (64, 384)
        };
        let out = Output {
            width: w,
            height: h,
            i_min: 0.0,
            i_max: 255.0,
        };
        let f = PhaseFunction::centered(axis, 384, std::f64::consts::TAU).unwrap();
        let scale = 384.0 / period;
        let levels = [
            Level::gray_code(scale, GrayCode::new(5, true)),
            Level::n_step(scale, 4),
        ];
        PatternSet::new(f, &levels, out)
            .unwrap()
            .with_binarization(b)
    }

    #[test]
    fn a_square_wave_4_step_level_errs_by_its_edge_offset_and_its_aliased_harmonics() {
        // Analytic: the 1-bit square wave of period P = 24 px is the continuous square wave
        // (Fourier series (4/π)·Σ_{k odd} sin kθ / k) with its edges moved onto pixel boundaries
        // by d ∈ [−½, ½) px; a Gaussian of σ pixels scales harmonic k by
        // g_k = exp(−2π²k²σ²/P²). A 4-step level's S + iC is then
        // e^{iθ}·(1 + Σ_{k ≡ 1 (4)} a_k e^{i(k−1)θ} − Σ_{k ≡ 3 (4)} a_k e^{−i(k+1)θ}),
        // a_k = g_k/(k·g_1), so the measured phase is θ − 2πd/P + arg(…). The table, indexed by
        // the measured phase, must follow that curve.
        let p = 24.0;
        let set = four_step(p, Binarization::Square);
        let l = set.levels()[1];
        let u = |x: f64| {
            (l.scale() * set.function().eval(x, 0.0) + set.effective_offset())
                / std::f64::consts::TAU
        };
        let xe = (u(0.0).ceil() - u(0.0)) * p;
        let d = xe.ceil() - 0.5 - xe;
        let offset = -std::f64::consts::TAU * d / p;
        for sigma in [2.0f64, 3.0] {
            let (t, rep) = binary_correction(&set, sigma).unwrap();
            let g = |k: f64| {
                (-2.0 * std::f64::consts::PI.powi(2) * k * k * sigma * sigma / (p * p)).exp()
            };
            let err = |theta: f64| {
                let (mut re, mut im) = (1.0, 0.0);
                for k in (3..40).step_by(2) {
                    let a = g(k as f64) / (k as f64 * g(1.0));
                    let (arg, sign) = if k % 4 == 1 {
                        ((k - 1) as f64 * theta, 1.0)
                    } else {
                        (-((k + 1) as f64) * theta, -1.0)
                    };
                    re += sign * a * arg.cos();
                    im += sign * a * arg.sin();
                }
                offset + im.atan2(re)
            };
            // The table's curve against the analytic one over the measured phase.
            let (mut d2, mut w2) = (0.0, 0.0);
            for j in 0..512 {
                let phi = -std::f64::consts::PI + std::f64::consts::TAU * j as f64 / 512.0;
                // θ with θ + e(θ) = φ (a contraction: |e'| < 1 here).
                let mut theta = phi;
                for _ in 0..200 {
                    theta = phi - err(theta);
                }
                let want = err(theta);
                // (`reference` is the corrected phase φ − Δ(φ).)
                let delta = phi - t.reference(1, phi);
                d2 += (delta - want).powi(2);
                w2 += (want - offset).powi(2);
            }
            let (d, w) = ((d2 / 512.0).sqrt(), (w2 / 512.0).sqrt());
            assert!(w > 0.01, "σ {sigma}: the harmonic error {w} rad RMS");
            assert!(
                d < 0.1 * w,
                "σ {sigma}: the table is off the analytic curve by {d} rad RMS (of {w})"
            );
            assert!(rep[1].rms_rad > 0.01, "{rep:?}");
            assert!(rep[1].residual_rms_rad < 0.1 * rep[1].rms_rad, "{rep:?}");
            assert!(t.is_sane());
        }
    }

    #[test]
    fn horizontal_fringes_get_the_table_of_the_transposed_projector() {
        for sigma in [0.0, 2.0] {
            let v = binary_correction(&four_step(24.0, Binarization::Square), sigma);
            let h = binary_correction(
                &four_step_along(Axis::Eta, 24.0, Binarization::Square),
                sigma,
            );
            match (v, h) {
                (Ok((tv, _)), Ok((th, _))) => assert_eq!(tv, th, "σ {sigma}"),
                (v, h) => assert_eq!(v.err(), h.err(), "σ {sigma}"),
            }
        }
    }

    #[test]
    fn a_square_wave_too_sharp_to_invert_is_refused_with_what_to_change() {
        // σ = 0.5 on 24-pixel fringes: the 3rd harmonic keeps 97 % of its 1/3, the measured
        // phase nearly stalls where it compresses, and 32 knots cannot follow the curve.
        let e = binary_correction(&four_step(24.0, Binarization::Square), 0.5).unwrap_err();
        assert!(
            e.contains("finest level") && e.contains("more defocus"),
            "{e}"
        );
    }

    #[test]
    fn the_table_refuses_a_gray_level_set_and_a_bad_defocus() {
        let set = four_step(24.0, Binarization::Off);
        assert!(binary_correction(&set, 2.0).is_err());
        let set = four_step(24.0, Binarization::Bayer);
        assert!(binary_correction(&set, -1.0).is_err());
        assert!(binary_correction(&set, f64::NAN).is_err());
    }
}
