//! The physical model of a reference capture (issue #17 item 1, with the full projector of
//! #18): when the calibration holds the projector, the phase a flat plate shows at every camera
//! pixel is fixed by the plate's pose alone ([`super::virtual_reference`], steps 1-5). Fitting
//! that pose to the decoded capture
//!
//! - **finds the plane from the fringes** (triangulation), a check on the pose from the board or
//!   the one given: a plate tilted away from it (or a board not lying on it) is refused;
//! - **tests flatness**: a bent plate leaves residuals that no pose explains. They are averaged
//!   over blocks of [`BLOCK_PX`] pixels and converted to millimetres along the plane's normal by the
//!   model's own sensitivity `∂Φ/∂d`; the worst block is reported, and a block deviating by more
//!   than a limit the user sets and by more than 6 σ of its noise is refused, with the deviation
//!   and where ([`PhysicalFit::check_flat`]; [`FLATNESS_MM`] for why there is no default limit).
//!
//! The plane is `n·X = d` with `n` a unit normal; Gauss-Newton over `(δn₁, δn₂, δd)` (`n` tilted
//! in its tangent plane and renormalised), the Jacobian by central differences, 30 iterations at
//! most; pixels beyond 6 robust σ (at least [`OUTLIER_FLOOR_RAD`]) are dropped after the third.

use fringe3d_core::params::{CameraParams, ProjectorParams};
use fringe3d_core::pattern::PatternSet;
use rayon::prelude::*;

use super::lens::Lens;
use super::plane_projector::{PlaneProjector, VirtualError};
use crate::math::Vec3;

/// Side of the blocks over which the flatness residuals are averaged, pixels.
pub const BLOCK_PX: usize = 32;
/// The deviation from a plane above which `calibrate reference` warns, mm. The measured deviation
/// also holds the projector model's own error where its calibration poses did not reach: a model
/// from the built-in `boards` poses (530-700 mm) is up to 0.3 mm "unflat" at the edge of the DMD
/// on a plane at 730 mm, one from three parallel plates up to 0.63 mm at the image's edge, against
/// 0.02 mm with the true model. So the check refuses only at a limit the user sets
/// (`--flatness-limit`), knowing how much of the field the calibration covered.
pub const FLATNESS_MM: f64 = 0.5;
/// The least outlier threshold, radians (a noise-free capture keeps its pixels).
pub const OUTLIER_FLOOR_RAD: f64 = 0.02;

/// The plane fitted to a capture.
#[derive(Clone, Debug, serde::Serialize)]
pub struct PhysicalFit {
    /// A point of the plane (the start point moved along the normal), camera frame, mm.
    pub point: [f64; 3],
    /// Its unit normal, towards the camera.
    pub normal: [f64; 3],
    /// The fitted plane's distance from the start plane at the start point, mm.
    pub offset_mm: f64,
    /// The angle between the fitted and the start normal, degrees.
    pub angle_deg: f64,
    /// RMS residual of the inliers, radians.
    pub residual_rms_rad: f64,
    /// Pixels used; dropped as outliers.
    pub used: usize,
    /// Pixels dropped as outliers.
    pub outliers: usize,
    /// The largest block deviation from the plane, mm, and the block's centre pixel.
    pub worst_block_mm: f64,
    /// Where: the block's centre `(u, v)`.
    pub worst_block_at: (u32, u32),
    /// That block's significance: |mean residual| over its noise σ.
    pub worst_block_sigmas: f64,
}

impl PhysicalFit {
    /// `Err(NotFlat)` when a block deviates from the plane by more than `limit_mm` and by more
    /// than 6 σ of its noise.
    pub fn check_flat(&self, limit_mm: f64) -> Result<(), PhysicalError> {
        if self.worst_block_mm.abs() > limit_mm && self.worst_block_sigmas > 6.0 {
            return Err(PhysicalError::NotFlat {
                mm: self.worst_block_mm,
                u: self.worst_block_at.0,
                v: self.worst_block_at.1,
                sigmas: self.worst_block_sigmas,
                limit_mm,
            });
        }
        Ok(())
    }
}

/// Why the physical model does not fit a capture.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum PhysicalError {
    /// The projector model is unusable.
    #[error(transparent)]
    Model(#[from] VirtualError),
    /// Too few pixels where both the capture and the model have a phase.
    #[error(
        "only {0} pixels have a phase in both the capture and the projector model on this plane (is the plane's pose right?)"
    )]
    TooFew(usize),
    /// The plate is not flat.
    #[error(
        "the plate is not flat: around pixel ({u}, {v}) it deviates from the best plane by {mm:+.3} mm ({sigmas:.0} σ; limit {limit_mm} mm, --flatness-limit)"
    )]
    NotFlat {
        /// Deviation, mm.
        mm: f64,
        /// Block centre.
        u: u32,
        /// Block centre.
        v: u32,
        /// Significance.
        sigmas: f64,
        /// The limit, mm.
        limit_mm: f64,
    },
}

fn unit(v: Vec3) -> Vec3 {
    v * (1.0 / v.norm())
}

/// Fit the plane to the decoded `phase` (`width × height`, NaN where invalid) of `set`, starting
/// from `(point, normal)`.
pub fn fit_physical(
    camera: &CameraParams,
    projector: &ProjectorParams,
    set: &PatternSet,
    phase: &[f32],
    (width, height): (usize, usize),
    (point, normal): ([f64; 3], [f64; 3]),
) -> Result<PhysicalFit, PhysicalError> {
    let pp = PlaneProjector::new(projector)?;
    let cam = Lens::from_model(camera);
    // Rays of every second valid pixel (both axes).
    let samples: Vec<(usize, (f64, f64), f64)> = (0..height)
        .step_by(2)
        .flat_map(|v| (0..width).step_by(2).map(move |u| (u, v)))
        .collect::<Vec<_>>()
        .par_iter()
        .filter_map(|&(u, v)| {
            let p = *phase.get(v * width + u)?;
            if !p.is_finite() {
                return None;
            }
            cam.undistort(u as f64, v as f64)
                .map(|ray| (v * width + u, ray, f64::from(p)))
        })
        .collect();
    let n0 = unit(Vec3::from_array(normal));
    let p0 = Vec3::from_array(point);
    let mut n = n0;
    let mut d = n0.dot(p0);
    let mut keep = vec![true; samples.len()];
    let model = |n: Vec3, d: f64, ray: (f64, f64)| pp.phase(set, ray, (n.to_array(), d));
    let basis = |n: Vec3| {
        let a = if n[0].abs() < 0.9 {
            Vec3::new(1.0, 0.0, 0.0)
        } else {
            Vec3::new(0.0, 1.0, 0.0)
        };
        let e1 = unit(a - n * a.dot(n));
        (e1, n.cross(e1))
    };
    const HA: f64 = 1e-6;
    const HD: f64 = 1e-3;
    let mut sigma = f64::INFINITY;
    for it in 0..30 {
        let (e1, e2) = basis(n);
        // Residuals and central-difference Jacobian rows, in parallel.
        let rows: Vec<Option<(f64, [f64; 3])>> = samples
            .par_iter()
            .zip(&keep)
            .map(|(&(_, ray, p), &k)| {
                if !k {
                    return None;
                }
                let m = model(n, d, ray)?;
                let fd = |dn: Vec3, dd: f64| -> Option<f64> {
                    let a = model(unit(n + dn), d + dd, ray)?;
                    let b = model(unit(n - dn), d - dd, ray)?;
                    Some((a - b) / 2.0)
                };
                let j = [
                    fd(e1 * HA, 0.0)? / HA,
                    fd(e2 * HA, 0.0)? / HA,
                    fd(Vec3::ZERO, HD)? / HD,
                ];
                Some((p - m, j))
            })
            .collect();
        let used: Vec<f64> = rows.iter().flatten().map(|r| r.0).collect();
        if used.len() < 100 {
            return Err(PhysicalError::TooFew(used.len()));
        }
        if it == 3 {
            let mut a: Vec<f64> = used.iter().map(|r| r.abs()).collect();
            a.sort_by(f64::total_cmp);
            sigma = 1.4826 * a[a.len() / 2];
            let lim = (6.0 * sigma).max(OUTLIER_FLOOR_RAD);
            for (k, r) in keep.iter_mut().zip(&rows) {
                if let Some((res, _)) = r
                    && res.abs() > lim
                {
                    *k = false;
                }
            }
            continue;
        }
        let mut ata = [[0.0; 3]; 3];
        let mut atb = [0.0; 3];
        for (r, j) in rows.iter().flatten() {
            for a in 0..3 {
                atb[a] += j[a] * r;
                for b in 0..3 {
                    ata[a][b] += j[a] * j[b];
                }
            }
        }
        let Some(step) =
            super::linalg::solve3(&crate::math::Mat3(ata), Vec3::new(atb[0], atb[1], atb[2]))
        else {
            return Err(PhysicalError::TooFew(used.len()));
        };
        n = unit(n + e1 * step[0] + e2 * step[1]);
        d += step[2];
        if it > 3 && step[0].abs() < 1e-10 && step[1].abs() < 1e-10 && step[2].abs() < 1e-7 {
            break;
        }
    }
    // Final residuals and sensitivities ∂Φ/∂d (rad/mm) per kept sample.
    let finals: Vec<Option<(usize, f64, f64)>> = samples
        .par_iter()
        .zip(&keep)
        .map(|(&(i, ray, p), &k)| {
            if !k {
                return None;
            }
            let m = model(n, d, ray)?;
            let a = model(n, d + HD, ray)?;
            let b = model(n, d - HD, ray)?;
            Some((i, p - m, (a - b) / (2.0 * HD)))
        })
        .collect();
    let used = finals.iter().flatten().count();
    let rms = (finals.iter().flatten().map(|x| x.1 * x.1).sum::<f64>() / used.max(1) as f64).sqrt();
    if !sigma.is_finite() {
        sigma = rms;
    }
    // Blocks.
    let (bw, bh) = (width.div_ceil(BLOCK_PX), height.div_ceil(BLOCK_PX));
    let mut acc = vec![(0.0f64, 0.0f64, 0usize); bw * bh];
    for &(i, r, s) in finals.iter().flatten() {
        let (u, v) = (i % width, i / width);
        let b = (v / BLOCK_PX) * bw + u / BLOCK_PX;
        acc[b].0 += r;
        acc[b].1 += s;
        acc[b].2 += 1;
    }
    let mut worst = (0.0f64, (0u32, 0u32), 0.0f64);
    for (b, &(sr, ss, c)) in acc.iter().enumerate() {
        // Blocks with too few samples say little (edges of the light).
        if c < (BLOCK_PX * BLOCK_PX) / 16 {
            continue;
        }
        let (mean, sens) = (sr / c as f64, ss / c as f64);
        // Neighbouring pixels' phase noise is correlated (decoder filters, blur): count a
        // quarter of the samples as independent.
        let sd = sigma.max(1e-4) / ((c as f64) / 4.0).sqrt();
        let mm = if sens.abs() > 1e-12 { mean / sens } else { 0.0 };
        if mm.abs() > worst.0.abs() {
            let (bu, bv) = (b % bw, b / bw);
            worst = (
                mm,
                (
                    (bu * BLOCK_PX + BLOCK_PX / 2).min(width - 1) as u32,
                    (bv * BLOCK_PX + BLOCK_PX / 2).min(height - 1) as u32,
                ),
                mean.abs() / sd,
            );
        }
    }
    let nn = if n.dot(Vec3::from_array(point)) > 0.0 {
        n * -1.0
    } else {
        n
    };
    let fit = PhysicalFit {
        point: (p0 + n * (d - n.dot(p0))).to_array(),
        normal: nn.to_array(),
        offset_mm: d - n.dot(p0),
        angle_deg: n.dot(n0).abs().clamp(-1.0, 1.0).acos().to_degrees(),
        residual_rms_rad: rms,
        used,
        outliers: keep.iter().filter(|k| !**k).count(),
        worst_block_mm: worst.0,
        worst_block_at: worst.1,
        worst_block_sigmas: worst.2,
    };
    Ok(fit)
}
