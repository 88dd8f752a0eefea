//! Camera calibration from checkerboard views: Zhang's closed form for the intrinsics and the
//! poses, then a Levenberg–Marquardt bundle adjustment of all intrinsics (fx, fy, α, u0, v0,
//! k1, k2, p1, p2, k3) and all poses, minimising the pixel reprojection error of every corner.
//! Views whose RMS error stands out (a mis-detected board) are rejected one at a time.

use super::CalibError;
use super::corners::Board;
use super::lens::{Lens, N_INTRINSICS, PARAM_NAMES};
use super::linalg::rodrigues;
use super::lm::{self, Eval};
use super::zhang;
use crate::math::{Mat3, Vec3};

/// The corners observed in one view.
#[derive(Clone, Debug)]
pub struct View {
    /// A name for messages and reports (the image file).
    pub name: String,
    /// Pixel positions of the board's inner corners, in [`Board::object_points`] order.
    pub corners: Vec<[f64; 2]>,
}

/// Options of [`calibrate`].
#[derive(Clone, Copy, Debug)]
pub struct CameraOptions {
    /// Hold the skew α at 0.
    pub fix_skew: bool,
    /// Hold k3 at 0.
    pub fix_k3: bool,
    /// Hold p1, p2 at 0.
    pub fix_tangential: bool,
    /// Reject a view whose RMS exceeds this multiple of the median view RMS (and 0.1 px).
    pub outlier_factor: f64,
    /// Fewest views to calibrate from (at least 3).
    pub min_views: usize,
}

impl Default for CameraOptions {
    fn default() -> Self {
        CameraOptions {
            fix_skew: false,
            fix_k3: false,
            fix_tangential: false,
            outlier_factor: 5.0,
            min_views: 3,
        }
    }
}

/// One view's result.
#[derive(Clone, Debug, serde::Serialize)]
pub struct ViewResult {
    /// The view's name.
    pub name: String,
    /// RMS reprojection error, pixels (√(mean of u² + v² residuals)).
    pub rms: f64,
    /// Largest corner error, pixels.
    pub max: f64,
    /// Board → camera rotation (row-major).
    pub rotation: Mat3,
    /// Board origin in the camera frame, mm.
    pub translation: Vec3,
    /// Residuals (projected − observed) per corner, pixels.
    #[serde(skip)]
    pub residuals: Vec<[f64; 2]>,
    /// Observed corners.
    #[serde(skip)]
    pub corners: Vec<[f64; 2]>,
}

/// A view left out, and why.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Rejected {
    /// The view's name.
    pub name: String,
    /// Why.
    pub reason: String,
}

/// The result of [`calibrate`].
#[derive(Clone, Debug)]
pub struct CameraCalibration {
    /// The camera.
    pub lens: Lens,
    /// Standard deviations of the intrinsics (`σ²(JᵀJ)⁻¹`, σ from the residuals), in
    /// [`PARAM_NAMES`] order; 0 for held parameters.
    pub std: [f64; N_INTRINSICS],
    /// The intrinsics' covariance, the same block of `σ²(JᵀJ)⁻¹`, row-major in [`PARAM_NAMES`]
    /// order; rows and columns of held parameters 0. The later steps add it to their σ.
    pub covariance: [f64; N_INTRINSICS * N_INTRINSICS],
    /// The delete-one-view jackknife's variance of each intrinsic over the formal one
    /// (`σ²(JᵀJ)⁻¹`), averaged over the free intrinsics: about 1 when the corners' errors are
    /// independent, above when they are correlated within a view.
    pub jackknife_ratio: f64,
    /// The views used.
    pub views: Vec<ViewResult>,
    /// The views left out.
    pub rejected: Vec<Rejected>,
    /// Overall RMS reprojection error, pixels (per corner: √(mean of u² + v²)).
    pub rms: f64,
    /// Estimated corner noise per coordinate, pixels: √(SSR / (2N − parameters)).
    pub sigma: f64,
    /// Corners used.
    pub corners: usize,
    /// Free parameters.
    pub parameters: usize,
    /// Bundle-adjustment iterations (last solve).
    pub iterations: usize,
    /// The closed-form (Zhang) starting intrinsics `[fx, fy, γ = α·fx, u0, v0]`.
    pub initial: [f64; 5],
}

impl CameraCalibration {
    /// A JSON summary (intrinsics with standard deviations, per-view errors, rejections).
    pub fn to_json(&self) -> serde_json::Value {
        let mut intr = serde_json::Map::new();
        for (k, name) in PARAM_NAMES.iter().enumerate() {
            intr.insert(
                name.to_string(),
                serde_json::json!({"value": self.lens.p[k], "std": self.std[k]}),
            );
        }
        serde_json::json!({
            "width": self.lens.width, "height": self.lens.height,
            "intrinsics": intr,
            "intrinsics_covariance": {"order": PARAM_NAMES, "matrix": self.covariance.chunks(N_INTRINSICS).collect::<Vec<_>>()},
            "skew_convention": "alpha of paper eq 4: u = fx*x + alpha*fx*y + cx (OpenCV K[0][1] = alpha*fx)",
            "rms_px": self.rms, "sigma_px": self.sigma, "jackknife_ratio": self.jackknife_ratio, "corners": self.corners, "parameters": self.parameters,
            "iterations": self.iterations,
            "zhang_initial": {"fx": self.initial[0], "fy": self.initial[1], "gamma": self.initial[2], "cx": self.initial[3], "cy": self.initial[4]},
            "views": self.views, "rejected": self.rejected,
        })
    }
}

#[derive(Clone)]
struct State {
    lens: Lens,
    rot: Vec<Mat3>,
    t: Vec<Vec3>,
}

fn free_intrinsics(o: &CameraOptions) -> Vec<usize> {
    (0..N_INTRINSICS)
        .filter(|&k| {
            !(o.fix_skew && k == 2)
                && !(o.fix_k3 && k == 9)
                && !(o.fix_tangential && (k == 7 || k == 8))
        })
        .collect()
}

/// ∂(u, v)/∂X_c of the projection of a camera-frame point.
pub(crate) fn d_point(d_xy: &[[f64; 2]; 2], xc: Vec3) -> [[f64; 3]; 2] {
    let iz = 1.0 / xc[2];
    let (x, y) = (xc[0] * iz, xc[1] * iz);
    let a = [[iz, 0.0, -x * iz], [0.0, iz, -y * iz]];
    let mut o = [[0.0; 3]; 2];
    for r in 0..2 {
        for c in 0..3 {
            o[r][c] = d_xy[r][0] * a[0][c] + d_xy[r][1] * a[1][c];
        }
    }
    o
}

/// The delete-one-view jackknife variance of each intrinsic ([`PARAM_NAMES`] order): the bundle
/// adjustment re-solved without each view in turn (from `state` without it),
/// `(G − 1)/G · Σ (θ₍ᵥ₎ − θ̄)²` over the `G` views.
fn jackknife(
    board: &Board,
    views: &[View],
    state: &State,
    free: &[usize],
) -> Option<[f64; N_INTRINSICS]> {
    let g = views.len();
    if g < 4 {
        return None;
    }
    let mut thetas = Vec::with_capacity(g);
    for v in 0..g {
        let mut vs = views.to_vec();
        vs.remove(v);
        let mut st = state.clone();
        st.rot.remove(v);
        st.t.remove(v);
        thetas.push(bundle(board, &vs, st, free)?.state.lens.p);
    }
    let mut out = [0.0; N_INTRINSICS];
    for (k, o) in out.iter_mut().enumerate() {
        let mean = thetas.iter().map(|t| t[k]).sum::<f64>() / g as f64;
        *o = (g - 1) as f64 / g as f64 * thetas.iter().map(|t| (t[k] - mean).powi(2)).sum::<f64>();
    }
    Some(out)
}

fn bundle(
    board: &Board,
    views: &[View],
    start: State,
    free: &[usize],
) -> Option<lm::Solution<State>> {
    let obj = board.object_points();
    let nf = free.len();
    let n = nf + 6 * views.len();
    let eval = |s: &State, _j: bool| -> Option<Eval> {
        let mut e = Eval {
            width: nf + 6,
            ..Default::default()
        };
        let m = 2 * obj.len() * views.len();
        e.r.reserve(m);
        e.cols.reserve(m * e.width);
        e.vals.reserve(m * e.width);
        for (vi, v) in views.iter().enumerate() {
            let (r, t) = (&s.rot[vi], s.t[vi]);
            for (o, c) in obj.iter().zip(&v.corners) {
                let rx = r.mul_vec(Vec3::new(o[0], o[1], 0.0));
                let xc = rx + t;
                if !(xc[2] > 1e-9) {
                    return None;
                }
                let ((u, vv), j) = s.lens.project_jac(xc[0] / xc[2], xc[1] / xc[2]);
                let dp = d_point(&j.d_xy, xc);
                // ∂X_c/∂δω = −[R X]×, ∂X_c/∂δt = I.
                let sk = Mat3::cross_matrix(rx);
                for (row, res) in [(0usize, u - c[0]), (1, vv - c[1])] {
                    e.r.push(res);
                    for &k in free {
                        e.vals.push(j.d_intr[row][k]);
                    }
                    e.cols.extend(0..nf);
                    for a in 0..3 {
                        let mut s_ = 0.0;
                        for b in 0..3 {
                            s_ -= dp[row][b] * sk[b][a];
                        }
                        e.vals.push(s_);
                        e.cols.push(nf + 6 * vi + a);
                    }
                    for a in 0..3 {
                        e.vals.push(dp[row][a]);
                        e.cols.push(nf + 6 * vi + 3 + a);
                    }
                }
            }
        }
        Some(e)
    };
    let apply = |s: &State, d: &[f64]| -> State {
        let mut o = s.clone();
        for (i, &k) in free.iter().enumerate() {
            o.lens.p[k] += d[i];
        }
        for vi in 0..o.rot.len() {
            let b = nf + 6 * vi;
            o.rot[vi] = rodrigues(Vec3::new(d[b], d[b + 1], d[b + 2])).mul_mat(&o.rot[vi]);
            o.t[vi] = o.t[vi] + Vec3::new(d[b + 3], d[b + 4], d[b + 5]);
        }
        o
    };
    lm::solve(start, n, eval, apply, lm::Options::default())
}

/// Calibrate from views of `board`. Views that cannot be used (too few corners, degenerate) or
/// whose error stands out are listed in [`CameraCalibration::rejected`] with the reason.
pub fn calibrate(
    board: &Board,
    views: &[View],
    width: u32,
    height: u32,
    opts: &CameraOptions,
) -> Result<CameraCalibration, CalibError> {
    let obj = board.object_points();
    let min_views = opts.min_views.max(3);
    let mut rejected = Vec::new();
    let mut used: Vec<View> = Vec::new();
    let mut hs = Vec::new();
    for v in views {
        if v.corners.len() != obj.len() {
            rejected.push(Rejected {
                name: v.name.clone(),
                reason: format!("{} corners, the board has {}", v.corners.len(), obj.len()),
            });
            continue;
        }
        match zhang::homography(&obj, &v.corners) {
            Some(h) => {
                hs.push(h);
                used.push(v.clone());
            }
            None => rejected.push(Rejected {
                name: v.name.clone(),
                reason: "degenerate corner layout (no homography)".into(),
            }),
        }
    }
    let too_few = |used: &[View], rejected: &[Rejected]| CalibError::TooFewViews {
        usable: used.len(),
        needed: min_views,
        used: used.iter().map(|v| v.name.clone()).collect(),
        rejected: rejected
            .iter()
            .map(|r| format!("{}: {}", r.name, r.reason))
            .collect(),
    };
    if used.len() < min_views {
        return Err(too_few(&used, &rejected));
    }
    let centre = [0.5 * (width as f64 - 1.0), 0.5 * (height as f64 - 1.0)];
    let half = 0.5 * width.max(height) as f64;
    let free = free_intrinsics(opts);
    loop {
        let k0 = zhang::intrinsics(&hs, opts.fix_skew, centre, half).ok_or_else(|| CalibError::Degenerate {
            what: "the closed-form intrinsics: the views lack perspective (tilt the board more between views)".into(),
        })?;
        let mut lens = Lens {
            width,
            height,
            p: [0.0; N_INTRINSICS],
        };
        lens.p[0] = k0[0];
        lens.p[1] = k0[1];
        lens.p[2] = if opts.fix_skew { 0.0 } else { k0[2] / k0[0] };
        lens.p[3] = k0[3];
        lens.p[4] = k0[4];
        let mut rot = Vec::new();
        let mut t = Vec::new();
        let kk = [
            k0[0],
            k0[1],
            if opts.fix_skew { 0.0 } else { k0[2] },
            k0[3],
            k0[4],
        ];
        for (h, v) in hs.iter().zip(&used) {
            let (r, tt) = zhang::normalize_homography(h, kk)
                .and_then(|hn| zhang::pose_from_homography(&hn))
                .ok_or_else(|| CalibError::Degenerate {
                    what: format!("{}: no pose from the homography", v.name),
                })?;
            rot.push(r);
            t.push(tt);
        }
        let sol = bundle(board, &used, State { lens, rot, t }, &free).ok_or_else(|| {
            CalibError::Degenerate {
                what: "bundle adjustment: a board ends up behind the camera".into(),
            }
        })?;
        // Per-view errors.
        let per = obj.len();
        let mut vr = Vec::new();
        for (vi, v) in used.iter().enumerate() {
            let res: Vec<[f64; 2]> = (0..per)
                .map(|k| {
                    [
                        sol.residuals[2 * (vi * per + k)],
                        sol.residuals[2 * (vi * per + k) + 1],
                    ]
                })
                .collect();
            let ss: f64 = res.iter().map(|r| r[0] * r[0] + r[1] * r[1]).sum();
            let max = res
                .iter()
                .map(|r| (r[0] * r[0] + r[1] * r[1]).sqrt())
                .fold(0.0, f64::max);
            vr.push(ViewResult {
                name: v.name.clone(),
                rms: (ss / per as f64).sqrt(),
                max,
                rotation: sol.state.rot[vi],
                translation: sol.state.t[vi],
                residuals: res,
                corners: v.corners.clone(),
            });
        }
        let mut rms_sorted: Vec<f64> = vr.iter().map(|v| v.rms).collect();
        rms_sorted.sort_by(f64::total_cmp);
        let median = rms_sorted[rms_sorted.len() / 2];
        let limit = (opts.outlier_factor * median).max(0.1);
        let worst = (0..vr.len()).max_by(|&a, &b| vr[a].rms.total_cmp(&vr[b].rms));
        if let Some(w) = worst.filter(|&w| vr[w].rms > limit) {
            rejected.push(Rejected {
                name: vr[w].name.clone(),
                reason: format!(
                    "reprojection RMS {:.3} px, above {:.1} x the median view ({:.3} px)",
                    vr[w].rms, opts.outlier_factor, median
                ),
            });
            used.remove(w);
            hs.remove(w);
            if used.len() < min_views {
                return Err(too_few(&used, &rejected));
            }
            continue;
        }
        let n = free.len() + 6 * used.len();
        let cov = sol.covariance(n);
        let mut std = [0.0; N_INTRINSICS];
        let mut covariance = [0.0; N_INTRINSICS * N_INTRINSICS];
        if let Some(c) = &cov {
            for (i, &k) in free.iter().enumerate() {
                std[k] = c[i * n + i].max(0.0).sqrt();
                for (j, &l) in free.iter().enumerate() {
                    covariance[k * N_INTRINSICS + l] = c[i * n + j];
                }
            }
        }
        let jackknife_ratio = jackknife(board, &used, &sol.state, &free).map_or(f64::NAN, |jk| {
            let r: Vec<f64> = free
                .iter()
                .filter(|&&k| std[k] > 0.0)
                .map(|&k| jk[k] / (std[k] * std[k]))
                .collect();
            r.iter().sum::<f64>() / r.len().max(1) as f64
        });
        let m = sol.residuals.len();
        let ss: f64 = sol.cost;
        return Ok(CameraCalibration {
            lens: sol.state.lens,
            std,
            covariance,
            jackknife_ratio,
            views: vr,
            rejected,
            rms: (ss / (m / 2) as f64).sqrt(),
            sigma: if m > n {
                (ss / (m - n) as f64).sqrt()
            } else {
                f64::NAN
            },
            corners: m / 2,
            parameters: n,
            iterations: sol.iterations,
            initial: k0,
        });
    }
}
