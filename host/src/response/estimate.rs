//! The projector's response (gamma): how much light a pattern value makes, measured from
//! captures of the reference plane under uniform gray levels ([`estimate()`]),
//! and used both ways to undo it (docs/gamma.md): through its inverse to pre-distort patterns
//! ([`ProjectorResponse::inverse`]), and as the phase-error table of a pattern set for the decoder
//! ([`super::table::phase_correction`]).
//!
//! # Model
//! A camera pixel seeing the projector at pattern value `x = code / full scale` records
//! `I(x) = A₀ + K·(b + (1 − b)·r(x))`: ambient light and the projector's black level b give an
//! offset, the surface and the optics a gain K, and `r` is the projector's normalised response
//! (`r(0) = 0`, `r(1) = 1`, increasing). So the ratio `(I(x) − I(0)) / (I(1) − I(0)) = r(x)` is the
//! same at every pixel whatever its ambient light, albedo or distance: each pixel measures r, and
//! the well-lit pixels' ratio of sums (after dropping outliers from the median) estimates it. The
//! levels must include 0 and full scale. A power law `x^γ` is fitted too, for the report (the common "gamma"). The response itself is
//! the calibration file's [`ProjectorResponse`] (`[projector_response]`).

use crate::io::calibration::ProjectorResponse;
use serde::Serialize;

/// The fewest captured levels [`estimate()`] accepts.
pub const MIN_LEVELS: usize = 5;
/// The fewest usable pixels (lit, unsaturated) it accepts.
pub const MIN_PIXELS: usize = 1000;

/// What [`estimate()`] measured besides the response.
#[derive(Clone, Debug, Serialize)]
pub struct ResponseReport {
    /// Pixels used (lit at white, unsaturated in every capture).
    pub pixels: usize,
    /// Per level: the median absolute deviation of the pixels' ratios (how consistent they are).
    pub spread: Vec<f64>,
    /// RMS of the table against the fitted power law.
    pub power_law_rms: f64,
    /// Largest |r(x) − x|: how far from linear the projector is.
    pub nonlinearity: f64,
}

/// Estimate the response from captures of a surface (the reference plane) under uniform
/// gray levels. `levels[k]` is the pattern value (code / full scale) of capture `k`; they
/// must include 0 and 1, and are sorted here. `images[k]` holds the capture's samples (all of
/// one size); samples at or above `saturation` make a pixel unusable.
pub fn estimate(
    levels: &[f64],
    images: &[&[u16]],
    saturation: f64,
) -> Result<(ProjectorResponse, ResponseReport), String> {
    if levels.len() != images.len() {
        return Err(format!(
            "{} levels for {} images",
            levels.len(),
            images.len()
        ));
    }
    if levels.len() < MIN_LEVELS {
        return Err(format!(
            "{} gray levels: at least {MIN_LEVELS} are needed (e.g. 17 from 0 to full scale)",
            levels.len()
        ));
    }
    let mut order: Vec<usize> = (0..levels.len()).collect();
    order.sort_by(|&a, &b| levels[a].total_cmp(&levels[b]));
    let x: Vec<f64> = order.iter().map(|&k| levels[k]).collect();
    if let Some(w) = x.windows(2).find(|w| w[1] <= w[0]) {
        return Err(format!("gray level {} is given twice", w[0]));
    }
    if x[0] != 0.0 || x[x.len() - 1] != 1.0 {
        return Err(format!(
            "the gray levels must include black (0) and full white; they run from {} to {} of full scale",
            x[0],
            x[x.len() - 1]
        ));
    }
    let n = images[0].len();
    if images.iter().any(|i| i.len() != n) {
        return Err("the gray captures differ in size".into());
    }
    let (black, white) = (images[order[0]], images[order[order.len() - 1]]);
    // Usable pixels: no sample saturated, and a white−black difference of at least a fifth of
    // the 99th percentile (lit by the projector, not in its shadow).
    let sat = |p: usize| images.iter().any(|i| i[p] as f64 >= saturation);
    let mut span: Vec<f64> = (0..n)
        .filter(|&p| !sat(p))
        .map(|p| white[p] as f64 - black[p] as f64)
        .collect();
    if span.is_empty() {
        return Err("every pixel is saturated in some gray capture: lower the exposure".into());
    }
    span.sort_by(f64::total_cmp);
    let p99 = span[(span.len() - 1) * 99 / 100];
    let lit: Vec<usize> = (0..n)
        .filter(|&p| !sat(p) && (white[p] as f64 - black[p] as f64) >= 0.2 * p99 && p99 > 0.0)
        .collect();
    if lit.len() < MIN_PIXELS {
        return Err(format!(
            "only {} pixels are lit and unsaturated in every gray capture (need {MIN_PIXELS}): check the exposure and that the plane fills the view",
            lit.len()
        ));
    }
    let mut r = Vec::with_capacity(x.len());
    let mut spread = Vec::with_capacity(x.len());
    for &k in &order {
        let img = images[k];
        let mut q: Vec<f64> = lit
            .iter()
            .map(|&p| (img[p] as f64 - black[p] as f64) / (white[p] as f64 - black[p] as f64))
            .collect();
        let m = median(&mut q.clone());
        let mut dev: Vec<f64> = q.iter().map(|v| (v - m).abs()).collect();
        let mad = median(&mut dev);
        spread.push(mad);
        // Ratio of sums over the pixels near the median: quantized samples make the median of
        // the ratios itself a code step (a dark level's is exactly 0), the mean is unbiased.
        let keep = 6.0 * mad + 0.02;
        let (mut num, mut den) = (0.0, 0.0);
        for (&p, v) in lit.iter().zip(q.iter_mut()) {
            if (*v - m).abs() <= keep {
                num += img[p] as f64 - black[p] as f64;
                den += white[p] as f64 - black[p] as f64;
            }
        }
        r.push(if den > 0.0 { num / den } else { m });
    }
    let last = r.len() - 1;
    (r[0], r[last]) = (0.0, 1.0);
    if let Some(i) = (1..r.len()).find(|&i| r[i] <= r[i - 1]) {
        return Err(format!(
            "the measured light does not increase with the gray level ({} at level {} after {} at level {}): are the captures in the order of the levels?",
            r[i],
            x[i],
            r[i - 1],
            x[i - 1]
        ));
    }
    let gamma = fit_gamma(&x, &r);
    let power_law_rms = rms(x.iter().zip(&r).map(|(a, b)| a.powf(gamma) - b));
    let nonlinearity = x
        .iter()
        .zip(&r)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    Ok((
        ProjectorResponse {
            levels: x,
            response: r,
            gamma,
        },
        ResponseReport {
            pixels: lit.len(),
            spread,
            power_law_rms,
            nonlinearity,
        },
    ))
}

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

fn rms(it: impl Iterator<Item = f64>) -> f64 {
    let (mut s, mut n) = (0.0, 0usize);
    for e in it {
        s += e * e;
        n += 1;
    }
    if n == 0 { 0.0 } else { (s / n as f64).sqrt() }
}

/// The γ of the least-squares power law through (x, r): golden-section search on [0.1, 10].
fn fit_gamma(x: &[f64], r: &[f64]) -> f64 {
    let cost = |g: f64| -> f64 { x.iter().zip(r).map(|(a, b)| (a.powf(g) - b).powi(2)).sum() };
    let (mut a, mut b) = (0.1f64.ln(), 10f64.ln());
    let k = (5f64.sqrt() - 1.0) / 2.0;
    for _ in 0..80 {
        let c = b - k * (b - a);
        let d = a + k * (b - a);
        if cost(c.exp()) < cost(d.exp()) {
            b = d;
        } else {
            a = c;
        }
    }
    (0.5 * (a + b)).exp()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::calibration::ProjectorResponse;

    #[test]
    fn interpolant_reproduces_a_power_law_and_inverts() {
        let x: Vec<f64> = (0..=16).map(|k| k as f64 / 16.0).collect();
        let r: Vec<f64> = x.iter().map(|v| v.powf(2.2)).collect();
        let resp = ProjectorResponse {
            levels: x,
            response: r,
            gamma: 2.2,
        };
        resp.validate().unwrap();
        for k in 0..=1000 {
            let t = k as f64 / 1000.0;
            assert!((resp.eval(t) - t.powf(2.2)).abs() < 2e-3, "at {t}");
            assert!((resp.eval(resp.inverse(t)) - t).abs() < 1e-9);
        }
        assert!((fit_gamma(&resp.levels, &resp.response) - 2.2).abs() < 1e-6);
    }
}
