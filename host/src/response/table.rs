//! The phase-error table of a pattern set under a projector response
//! ([`phase_correction`]): what the core's decoder subtracts from each level's wrapped phase
//! ([`fringe3d_core::decode::PhaseCorrection`]).
//!
//! # How it is computed
//! Convention-free, by the core's own decoder: along the set's phase axis, at 16 samples per
//! projector pixel, the set's continuous pattern values `x_k(ξ)` are turned into two synthetic
//! camera rows per image — the linear projector's `I = I₀ + G·x` and the measured one's
//! `I = I₀ + G·r(x)` (16-bit samples, so quantization is below 2e-5 rad) — and both are decoded
//! level by level ([`AnyDecoder::decode_row_level`], the decoder a scan uses). Their difference
//! `e = wrap(φ_r − φ_lin)` is the response's error at the measured phase `φ_r`; the knots are
//! the least-squares fit of the table's own periodic linear interpolation to those samples
//! (`fit_knots`; a mean of the samples around each knot would flatten the curve's peaks by
//! 5-15 %). Knots no sample reaches (a coarse level that does not span a whole period) come
//! out interpolated from their neighbours.
//!
//! What the table leaves: a 2-image level takes its DC term A from the DC level (eq 11), whose
//! estimate carries that level's 4th harmonic, a function of the *finest* phase, which no table
//! of the level's own phase removes; and its error curve is steep where the gamma compresses the
//! dark half-period, which 32 knots follow only approximately. For a gamma of 2.2 on the paper's
//! set that leaves ≈ 0.04 rad RMS on the 2-image levels (from 0.2 rad), which only choose fringe
//! orders: × the level ratio 8 it is 0.3 rad against the unwrapping tolerance of 2.1 rad. The
//! finest level keeps < 1e-3 rad.
//!
//! The table holds what the response alone does. A projector's defocus attenuates the harmonics
//! of its finest fringes (the error of a 4-step level comes from the 3rd and 5th), so on a
//! defocused projector this table over-corrects the finest level; with the blur known
//! (`projector_defocus`), [`super::binary::light_table`] models both (docs/gamma.md).

use crate::io::calibration::ProjectorResponse;
use fringe3d_core::arith::Backend;
use fringe3d_core::decode::{
    AnyDecoder, CORRECTION_KNOTS, CORRECTION_LSB, DecodeConfig, PhaseCorrection,
};
use fringe3d_core::pattern::PatternSet;
use fringe3d_core::phase_function::Axis;

/// Samples per projector pixel along the phase axis.
const OVERSAMPLE: usize = 16;

/// Per level: how large the response's phase error is, and what the table leaves.
#[derive(Clone, Debug, serde::Serialize)]
pub struct LevelError {
    /// RMS of the error before correction, radians.
    pub rms_rad: f64,
    /// Largest |error| before correction, radians.
    pub max_rad: f64,
    /// RMS after subtracting the table (its interpolation residual), radians.
    pub residual_rms_rad: f64,
    /// Largest |error| after subtracting the table, radians.
    pub residual_max_rad: f64,
}

/// The table of `set` under `response`, and each level's error before and after it.
pub fn phase_correction(
    set: &PatternSet,
    response: &ProjectorResponse,
) -> Result<(PhaseCorrection, Vec<LevelError>), String> {
    let o = *set.output();
    let along = match set.axis() {
        Axis::Xi => o.width,
        Axis::Eta => o.height,
    } as usize;
    let n = along * OVERSAMPLE;
    let mid = |len: u32| (len as f64 - 1.0) / 2.0;
    let full = if o.i_max > 255.0 { 65535.0 } else { 255.0 };
    let (i0, gain) = (1000.0, 60000.0);
    let mut lin = vec![vec![0u16; n]; set.image_count()];
    let mut meas = vec![vec![0u16; n]; set.image_count()];
    for k in 0..set.image_count() {
        for i in 0..n {
            let t = (i as f64 + 0.5) / OVERSAMPLE as f64 - 0.5;
            let (xi, eta) = match set.axis() {
                Axis::Xi => (t, mid(o.height)),
                Axis::Eta => (mid(o.width), t),
            };
            let v = set
                .intensity(k, xi, eta)
                .ok_or_else(|| format!("pattern image {k} out of range"))?;
            let x = (v / full).clamp(0.0, 1.0);
            lin[k][i] = (i0 + gain * x).round() as u16;
            meas[k][i] = (i0 + gain * response.eval(x)).round() as u16;
        }
    }
    tabulate(
        set,
        &lin,
        &meas,
        "the projector response is too far from linear to correct (pre-distort the patterns instead)",
    )
}

/// The table from two synthetic camera rows per image (set order, equal lengths): `lin`, what
/// the set's ideal sinusoids give, and `meas`, what the modelled projector gives. Shared by
/// [`phase_correction`] and [`super::binary::binary_correction`]; `too_large` ends the error of
/// a table too large to correct.
pub(super) fn tabulate(
    set: &PatternSet,
    lin: &[Vec<u16>],
    meas: &[Vec<u16>],
    too_large: &str,
) -> Result<(PhaseCorrection, Vec<LevelError>), String> {
    let n = lin.first().map_or(0, |r| r.len());
    let mut cfg = DecodeConfig::for_bit_depth(16);
    cfg.min_modulation = 0.0;
    cfg.dark_level = 0.0;
    let dec = AnyDecoder::new(set, cfg, Backend::F32Accurate).map_err(|e| e.to_string())?;
    let lin_rows: Vec<&[u16]> = lin.iter().map(|r| r.as_slice()).collect();
    let meas_rows: Vec<&[u16]> = meas.iter().map(|r| r.as_slice()).collect();
    let levels = set.levels().len();
    let mut table = PhaseCorrection::zero(levels as u8);
    let mut report = Vec::with_capacity(levels);
    let (mut wl, mut wm, mut m) = (vec![0f32; n], vec![0f32; n], vec![0f32; n]);
    // A Gray-code level (level 0) is binary: it has no wrapped phase, and no error to tabulate.
    let first = usize::from(set.gray().is_some());
    for _ in 0..first {
        report.push(LevelError {
            rms_rad: 0.0,
            max_rad: 0.0,
            residual_rms_rad: 0.0,
            residual_max_rad: 0.0,
        });
    }
    for l in first..levels {
        dec.decode_row_level(&lin_rows, l, &mut wl, &mut m)
            .map_err(|e| e.to_string())?;
        dec.decode_row_level(&meas_rows, l, &mut wm, &mut m)
            .map_err(|e| e.to_string())?;
        let samples: Vec<(f64, f64)> = wl
            .iter()
            .zip(&wm)
            .filter(|(a, b)| a.is_finite() && b.is_finite())
            .map(|(&a, &b)| (b as f64, wrap(b as f64 - a as f64)))
            .collect();
        let Some(vals) = fit_knots(&samples) else {
            return Err(format!(
                "level {l}: too few samples to tabulate its phase error"
            ));
        };
        for j in 0..CORRECTION_KNOTS {
            table.delta[l][j] = (vals[j] / CORRECTION_LSB)
                .round()
                .clamp(-(i16::MAX as f64), i16::MAX as f64) as i16;
        }
        let errs: Vec<f64> = samples.iter().map(|s| s.1).collect();
        let resid: Vec<f64> = samples
            .iter()
            .map(|&(phi, e)| {
                let corrected = table.reference(l, phi);
                wrap(corrected - (phi - e))
            })
            .collect();
        report.push(LevelError {
            rms_rad: rms(&errs),
            max_rad: errs.iter().fold(0.0, |a, b| f64::max(a, b.abs())),
            residual_rms_rad: rms(&resid),
            residual_max_rad: resid.iter().fold(0.0, |a, b| f64::max(a, b.abs())),
        });
    }
    if !table.is_sane() {
        return Err(format!(
            "a phase error above {:.2} rad: {too_large}",
            PhaseCorrection::MAX_DELTA as f64 * CORRECTION_LSB
        ));
    }
    Ok((table, report))
}

/// The knots whose periodic linear interpolation fits the `(measured phase, error)` samples best
/// in the least-squares sense (the interpolant is linear in the knots: the normal equations of
/// its tent functions, a cyclic band). A small penalty on consecutive differences (10⁻⁶ of a
/// knot's mean weight) makes knots no sample reaches (a coarse level that does not span a whole
/// period) the linear interpolation of their neighbours. `None` with fewer than 2 knots reached.
fn fit_knots(samples: &[(f64, f64)]) -> Option<[f64; CORRECTION_KNOTS]> {
    const K: usize = CORRECTION_KNOTS;
    let step = std::f64::consts::TAU / K as f64;
    let mut m = [[0.0f64; K]; K];
    let mut rhs = [0.0f64; K];
    let mut reach = [0.0f64; K];
    for &(phi, e) in samples {
        let t = (phi + std::f64::consts::PI) / step;
        let j = t.floor();
        let f = t - j;
        let j = (j as i64).rem_euclid(K as i64) as usize;
        let j1 = (j + 1) % K;
        let (a, b) = (1.0 - f, f);
        m[j][j] += a * a;
        m[j][j1] += a * b;
        m[j1][j] += a * b;
        m[j1][j1] += b * b;
        rhs[j] += a * e;
        rhs[j1] += b * e;
        reach[j] += a;
        reach[j1] += b;
    }
    if reach.iter().filter(|&&w| w > 0.5).count() < 2 {
        return None;
    }
    let lambda = 1e-6 * samples.len() as f64 / K as f64;
    for j in 0..K {
        let j1 = (j + 1) % K;
        m[j][j] += lambda;
        m[j1][j1] += lambda;
        m[j][j1] -= lambda;
        m[j1][j] -= lambda;
    }
    // Gaussian elimination with partial pivoting (32 unknowns; positive definite).
    for c in 0..K {
        let p = (c..K).max_by(|&a, &b| m[a][c].abs().total_cmp(&m[b][c].abs()))?;
        m.swap(c, p);
        rhs.swap(c, p);
        if m[c][c].abs() < 1e-300 {
            return None;
        }
        for r in c + 1..K {
            let q = m[r][c] / m[c][c];
            if q != 0.0 {
                for k in c..K {
                    m[r][k] -= q * m[c][k];
                }
                rhs[r] -= q * rhs[c];
            }
        }
    }
    let mut x = [0.0f64; K];
    for r in (0..K).rev() {
        let s: f64 = (r + 1..K).map(|k| m[r][k] * x[k]).sum();
        x[r] = (rhs[r] - s) / m[r][r];
    }
    Some(x)
}

fn wrap(x: f64) -> f64 {
    let t = std::f64::consts::TAU;
    x - t * (x / t).round()
}

fn rms(v: &[f64]) -> f64 {
    if v.is_empty() {
        0.0
    } else {
        (v.iter().map(|e| e * e).sum::<f64>() / v.len() as f64).sqrt()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use fringe3d_core::pattern::Output;

    fn gamma(g: f64) -> ProjectorResponse {
        let x: Vec<f64> = (0..=32).map(|k| k as f64 / 32.0).collect();
        let r = x.iter().map(|v| v.powf(g)).collect();
        ProjectorResponse {
            levels: x,
            response: r,
            gamma: g,
        }
    }

    #[test]
    fn linear_response_gives_a_zero_table_and_gamma_a_corrected_one() {
        let out = Output {
            width: 1024,
            height: 768,
            i_min: 0.0,
            i_max: 255.0,
        };
        let set = PatternSet::default_for(Axis::Xi, out).unwrap();
        let (t, rep) = phase_correction(&set, &ProjectorResponse::linear()).unwrap();
        assert!(t.delta.iter().flatten().all(|d| d.abs() <= 1));
        assert!(rep.iter().all(|r| r.rms_rad < 1e-4));
        let (_, rep) = phase_correction(&set, &gamma(2.2)).unwrap();
        // The 2-image levels carry the harmonics (≈ 0.2 rad); the 4-step level a small error.
        // The table leaves < 1e-3 rad of the finest level's and < 25 % of the 2-image levels'
        // (their error curve is steep where the gamma compresses the dark half-period, which 32
        // knots follow to ≈ 0.04 rad; and the DC level's 4th harmonic, a function of the finest
        // phase, stays). × the level ratio 8 that is 0.3 rad, far inside the unwrap tolerance.
        assert!(rep[0].rms_rad > 0.1 && rep[1].rms_rad > 0.1, "{rep:?}");
        assert!(rep[2].rms_rad < 0.05, "{rep:?}");
        assert!(rep[2].residual_rms_rad < 1e-3, "{rep:?}");
        assert!(
            rep[..2]
                .iter()
                .all(|r| r.residual_rms_rad < 0.25 * r.rms_rad),
            "{rep:?}"
        );
    }
}
