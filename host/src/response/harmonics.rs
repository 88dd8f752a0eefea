//! The projector's response from the fringe captures themselves ([`from_fringes`]): no gray
//! levels to capture, only the phase-shifted images a scan or `calibrate reference` already
//! has (issue #19 item 2).
//!
//! # Model
//! At a camera pixel whose absolute phase is Φ, image `k` of level `l` shows the pattern value
//! `x_k = (I_min + (I_max − I_min)·(1 + sin((c_l/c_K)·Φ + δ_k + offset))/2) / full` (eq 5), and
//! the camera records `C_k = a + b·r(x_k)`: ambient light and the projector's black level give
//! the offset `a`, the surface and the optics the gain `b`, both the pixel's own. A power-law
//! projector has `r(x) = x^γ`. With two unknowns per pixel and more samples, each pixel's
//! `(a, b)` is the linear least-squares fit for a given γ, and γ is the one that minimises the
//! sum of all pixels' squared residuals (a one-dimensional search: a scan of log γ, then a
//! golden section). A linear projector leaves only the noise; any other γ bends the predicted
//! samples away from the captured ones in the way the harmonics of the captured sinusoids show.
//!
//! # Which samples
//! The phase comes from a decode of the same images, which the response biases: on the
//! finest level by its harmonics' error (the 3rd and 5th for 4 steps), on a coarser level by
//! that error divided by the level ratio. So each image of a coarser phase-shift level is a
//! sample of its own (its predicted value barely moves with the phase error), and the finest
//! level contributes the mean of its images, predicted as the mean of `r(x_k)` over its
//! shifts, which for N ≥ 3 uniform shifts depends on the phase only through r's N-th
//! harmonics. A set with one level uses that level's images one by one (the phase error then
//! biases γ a little). Coarse levels also escape the blur: the camera's and the projector's
//! defocus attenuate the harmonics of fine fringes, not of fringes many pixels wide.
//!
//! # What it cannot do
//! It measures a power law: a projector with another curve (an S-curve, a measured LUT) needs
//! the gray levels of [`super::estimate::estimate`]. The fit's residual against the noise says
//! how well the power law holds (the report's `residual_rms` in camera codes).

use crate::io::calibration::ProjectorResponse;
use fringe3d_core::pattern::PatternSet;
use fringe3d_core::validity::Validity;
use serde::Serialize;

/// The fewest usable pixels [`from_fringes`] accepts.
pub const MIN_PIXELS: usize = 1000;
/// At most this many pixels are used (evenly strided over the image).
const MAX_PIXELS: usize = 200_000;
/// The range of γ searched.
const GAMMA_RANGE: (f64, f64) = (0.2, 5.0);

/// What [`from_fringes`] measured besides the response.
#[derive(Clone, Debug, Serialize)]
pub struct FringeReport {
    /// Pixels used (valid decode, no sample saturated).
    pub pixels: usize,
    /// Samples per pixel (coarse images one by one, the finest level's mean).
    pub samples: usize,
    /// RMS of the samples against the fitted model, camera codes (the noise, if the power law
    /// holds).
    pub residual_rms: f64,
    /// The same for a linear projector (γ = 1): what the fit removed.
    pub linear_rms: f64,
    /// Largest |x^γ − x| over the pattern values the set uses.
    pub nonlinearity: f64,
    /// The pattern values the set uses, `[I_min, I_max] / full`.
    pub used_range: [f64; 2],
}

/// Every used pixel's samples, flat: the groups of images each sample averages (one image, or
/// the finest level's shifts for its mean) are the same at every pixel.
struct Samples {
    /// `groups[j]`: the images sample `j` averages.
    groups: Vec<Vec<usize>>,
    /// Per pixel, the camera value of each sample (`groups.len()` values).
    c: Vec<f64>,
    /// Per pixel, the pattern value of each image of each group, groups in order
    /// (`image_count` values).
    x: Vec<f64>,
}

impl Samples {
    fn pixels(&self) -> usize {
        self.c.len() / self.groups.len().max(1)
    }
}

/// γ of a power-law projector from the fringe captures `frames` of `set` (in the set's image
/// order), their decoded absolute phase `phase` and `validity` (a decode of the same images,
/// uncorrected), the patterns' full scale `pattern_full` (2^bits − 1) and the camera's
/// `saturation` level. The response is tabulated as [`super::power_law`].
pub fn from_fringes(
    set: &PatternSet,
    pattern_full: f64,
    frames: &[&[u16]],
    phase: &[f32],
    validity: &[u8],
    saturation: f64,
) -> Result<(ProjectorResponse, FringeReport), String> {
    if set.gray().is_some() || set.binarization().is_binary() {
        return Err(
            "the response is measured from sinusoidal fringes; this set has Gray-code or binary \
             levels (use the gray levels of `calibrate gamma` without --fringes)"
                .into(),
        );
    }
    let n = set.image_count();
    if frames.len() != n {
        return Err(format!("{} images for a set of {n}", frames.len()));
    }
    let len = phase.len();
    if validity.len() != len || frames.iter().any(|f| f.len() != len) {
        return Err("the images and the decoded phase differ in size".into());
    }
    let levels = set.levels();
    let finest = levels.len() - 1;
    let c_k = levels[finest].scale();
    let o = *set.output();
    let offset = set.effective_offset();
    // Image k's pattern value at absolute (finest) phase `p`.
    let value = |k: usize, p: f64| -> Option<f64> {
        let id = set.image(k)?;
        let l = &levels[id.level as usize];
        let arg = l.scale() / c_k * p + l.shifts()[id.shift as usize] + offset;
        Some((o.i_min + 0.5 * (o.i_max - o.i_min) * (1.0 + arg.sin())) / pattern_full)
    };
    // Samples: every image of a coarser level alone; the finest level's images as one mean
    // (alone too when the set has a single level).
    let mut groups: Vec<Vec<usize>> = Vec::new();
    let mut fine = Vec::new();
    for k in 0..n {
        match set.image(k) {
            Some(id) if id.level as usize == finest && finest > 0 => fine.push(k),
            Some(_) => groups.push(vec![k]),
            None => return Err(format!("image {k} outside the set")),
        }
    }
    if !fine.is_empty() {
        groups.push(fine);
    }
    if groups.len() < 3 {
        return Err(format!(
            "{} samples per pixel: at least 3 are needed (two coarse images and a finest level, \
             or one level of 3 or more shifts)",
            groups.len()
        ));
    }
    let stride = (len / MAX_PIXELS).max(1);
    let mut samples = Samples {
        groups,
        c: Vec::new(),
        x: Vec::new(),
    };
    for i in (0..len).step_by(stride) {
        let p = phase[i] as f64;
        if validity[i] != Validity::Valid as u8 || !p.is_finite() {
            continue;
        }
        if frames.iter().any(|f| f64::from(f[i]) >= saturation) {
            continue;
        }
        for g in &samples.groups {
            let sum: f64 = g.iter().map(|&k| f64::from(frames[k][i])).sum();
            samples.c.push(sum / g.len() as f64);
            for &k in g {
                samples
                    .x
                    .push(value(k, p).ok_or("an image outside the set")?);
            }
        }
    }
    let pixels = samples.pixels();
    if pixels < MIN_PIXELS {
        return Err(format!(
            "{pixels} usable pixels (validly decoded, none of their samples saturated): at least \
             {MIN_PIXELS} are needed"
        ));
    }
    // Scan log γ, then refine the best bracket by golden section.
    let cost = |g: f64| residual(&samples, g);
    let (lo, hi) = (GAMMA_RANGE.0.ln(), GAMMA_RANGE.1.ln());
    let steps = 48;
    let at = |j: usize| lo + (hi - lo) * j as f64 / steps as f64;
    let costs: Vec<f64> = (0..=steps).map(|j| cost(at(j).exp())).collect();
    let best = (0..=steps)
        .min_by(|&a, &b| costs[a].total_cmp(&costs[b]))
        .unwrap_or(0);
    if best == 0 || best == steps {
        return Err(format!(
            "the fit runs to the end of the searched range (gamma {:.2}): not a power-law \
             projector, or the phase does not belong to these images",
            at(best).exp()
        ));
    }
    let (mut a, mut b) = (at(best - 1), at(best + 1));
    let phi = 0.5 * (5f64.sqrt() - 1.0);
    let (mut x1, mut x2) = (b - phi * (b - a), a + phi * (b - a));
    let (mut f1, mut f2) = (cost(x1.exp()), cost(x2.exp()));
    for _ in 0..40 {
        if f1 < f2 {
            b = x2;
            x2 = x1;
            f2 = f1;
            x1 = b - phi * (b - a);
            f1 = cost(x1.exp());
        } else {
            a = x1;
            x1 = x2;
            f1 = f2;
            x2 = a + phi * (b - a);
            f2 = cost(x2.exp());
        }
    }
    let gamma = (0.5 * (a + b)).exp();
    let dof = samples.c.len().saturating_sub(2 * pixels).max(1) as f64;
    let used = [o.i_min / pattern_full, o.i_max / pattern_full];
    let nonlinearity = (0..=200)
        .map(|j| used[0] + (used[1] - used[0]) * j as f64 / 200.0)
        .map(|x| (x.powf(gamma) - x).abs())
        .fold(0.0, f64::max);
    let report = FringeReport {
        pixels,
        samples: samples.groups.len(),
        residual_rms: (cost(gamma) / dof).sqrt(),
        linear_rms: (cost(1.0) / dof).sqrt(),
        nonlinearity,
        used_range: used,
    };
    Ok((super::power_law(gamma), report))
}

/// The sum over pixels of the squared residuals of each pixel's best `a + b·r` with
/// `r(x) = x^gamma`. One buffer of `r` for all pixels: this runs some 90 times over up to
/// 200 000 pixels.
fn residual(s: &Samples, gamma: f64) -> f64 {
    let (m, n) = (s.groups.len(), s.x.len() / s.pixels().max(1));
    let mut r = vec![0.0f64; m];
    let mut total = 0.0;
    for (c, x) in s.c.chunks_exact(m).zip(s.x.chunks_exact(n)) {
        let mut at = 0;
        for (rj, g) in r.iter_mut().zip(&s.groups) {
            let xs = &x[at..at + g.len()];
            at += g.len();
            *rj = xs.iter().map(|x| x.max(0.0).powf(gamma)).sum::<f64>() / xs.len() as f64;
        }
        let mf = m as f64;
        let (mr, mc) = (r.iter().sum::<f64>() / mf, c.iter().sum::<f64>() / mf);
        let (mut srr, mut src, mut scc) = (0.0, 0.0, 0.0);
        for (ri, ci) in r.iter().zip(c) {
            let (dr, dc) = (ri - mr, ci - mc);
            srr += dr * dr;
            src += dr * dc;
            scc += dc * dc;
        }
        total += if srr > 0.0 {
            scc - src * src / srr
        } else {
            scc
        };
    }
    total
}
