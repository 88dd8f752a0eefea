//! The full projector model (issue #18 item 2): intrinsics with skew, Brown distortion and the
//! pose relative to the camera (paper §4.2: the projector is an inverted camera), from board
//! poses that each give the board's corners in the camera image and, through the two absolute
//! phase maps of the same pose, in the projector's image ([`super::projector_coords`]).
//!
//! 1. **Start.** Each board's pose from its corners and the camera ([`pose::board_pose`]); the
//!    corners' 3-D points in the camera frame and their `(ξ, η)` give the projector by the direct
//!    linear transform ([`dlt`]), which needs the points not to be coplanar: freely posed boards,
//!    or parallel plates at several depths (the workflow of §7) both qualify.
//! 2. **One joint Levenberg–Marquardt** over the projector's intrinsics
//!    `[fx, fy, α, u0, v0, k1, k2, p1, p2, k3]`, its pose, every board pose and (optionally) the
//!    camera's intrinsics, minimising the camera corners' pixel errors and the projector corners'
//!    DMD-pixel errors, each group weighted by its own noise (estimated from its residuals,
//!    then re-solved). Projector corners beyond 5 σ are dropped (three rounds at most).
//!
//! The projector pose is solved as camera → projector, `X_p = Q·X_c + s`; the file's
//! convention is `X_c = R·X_p + T`, so `R = Qᵀ` and `T = −Qᵀ·s` (the centre P of §6).
//! Uncertainties are `σ²(JᵀJ)⁻¹` of the weighted problem; `T`'s covariance is propagated from
//! the pose's through `∂T/∂(δω, δs) = [−Qᵀ[s]×, −Qᵀ]`. With the camera held and its
//! covariance known ([`ModelOptions::camera_covariance`], from `calibrate camera`), the camera's
//! own uncertainty is added to every parameter's ([`super::uncertainty::held_covariance`]): a
//! camera error moves the projector and the board poses alike in every seed of noise, and the
//! residuals cannot show it.

use fringe3d_core::params::ProjectorParams;

use super::CalibError;
use super::camera::d_point;
use super::corners::Board;
use super::dlt::dlt;
use super::lens::{Lens, N_INTRINSICS, PARAM_NAMES};
use super::linalg::rodrigues;
use super::lm::{self, Eval};
use super::{pose, uncertainty};
use crate::io::calibration::CameraCovariance;
use crate::math::{Mat3, Vec3};

/// The largest relative σ of the projector's focal length a calibration may have.
pub const MAX_FOCAL_STD: f64 = 2e-3;
/// The largest σ of the projector's centre a calibration may have, mm.
pub const MAX_CENTRE_STD_MM: f64 = 1.0;

/// One board pose: the corners in the camera image and in the projector's.
#[derive(Clone, Debug)]
pub struct RigView {
    /// A name for messages (the pose's folder).
    pub name: String,
    /// Camera pixels of the board's inner corners, [`Board::object_points`] order.
    pub corners: Vec<[f64; 2]>,
    /// Projector pixels `(ξ, η)` of the same corners (`None`: not lit or not decoded).
    pub projector: Vec<Option<[f64; 2]>>,
}

/// Which intrinsics of a lens are held at their start value (0 for distortion).
#[derive(Clone, Copy, Debug, Default)]
pub struct Freedom {
    /// Hold the skew α.
    pub fix_skew: bool,
    /// Hold k3.
    pub fix_k3: bool,
    /// Hold p1, p2.
    pub fix_tangential: bool,
}

impl Freedom {
    fn free(&self) -> Vec<usize> {
        (0..N_INTRINSICS)
            .filter(|&k| {
                !(self.fix_skew && k == 2)
                    && !(self.fix_k3 && k == 9)
                    && !(self.fix_tangential && (k == 7 || k == 8))
            })
            .collect()
    }
}

/// Options of [`calibrate`].
#[derive(Clone, Copy, Debug)]
pub struct ModelOptions {
    /// Adjust the camera's intrinsics too (the board poses must determine them: tilted boards).
    pub refine_camera: bool,
    /// The camera's held intrinsics when it is refined.
    pub camera: Freedom,
    /// The projector's held intrinsics (by default k3: a projector's field is narrow, and a
    /// free k3 extrapolates badly beyond the corners the boards covered).
    pub projector: Freedom,
    /// Projector corners farther than this many σ from the model are dropped.
    pub outlier_sigmas: f64,
    /// Fewest projector corners a view needs to be used.
    pub min_view_corners: usize,
    /// The held camera's covariance, to add its uncertainty to the results' (none: the σ are
    /// those of the corners' noise alone). Not used when the camera is refined.
    pub camera_covariance: Option<CameraCovariance>,
}

impl Default for ModelOptions {
    fn default() -> Self {
        ModelOptions {
            refine_camera: false,
            camera: Freedom::default(),
            projector: Freedom {
                fix_k3: true,
                ..Freedom::default()
            },
            outlier_sigmas: 5.0,
            min_view_corners: 8,
            camera_covariance: None,
        }
    }
}

/// One view's result.
#[derive(Clone, Debug, serde::Serialize)]
pub struct ModelView {
    /// The view.
    pub name: String,
    /// Camera corners' RMS error, pixels.
    pub rms_camera_px: f64,
    /// Projector corners' RMS error, projector pixels.
    pub rms_projector_px: f64,
    /// Projector corners used.
    pub projector_corners: usize,
    /// Board → camera rotation.
    pub rotation: Mat3,
    /// Board origin, camera frame, mm.
    pub translation: Vec3,
    /// σ of the board plane's distance from the camera centre along its normal, mm (the held
    /// camera's uncertainty included when known).
    pub distance_std_mm: f64,
}

/// The result of [`calibrate`].
#[derive(Clone, Debug)]
pub struct ProjectorModel {
    /// The camera (adjusted or as given).
    pub camera: Lens,
    /// The projector's lens; its image is the DMD.
    pub projector: Lens,
    /// R: projector → camera rotation.
    pub rotation: Mat3,
    /// T: the projector's centre P, camera frame, mm.
    pub translation: Vec3,
    /// σ of the camera's intrinsics ([`PARAM_NAMES`] order; 0 when held).
    pub std_camera: [f64; N_INTRINSICS],
    /// The camera's covariance: the joint adjustment's when the camera is refined, the given
    /// one when it is held (what the calibration file records for the next steps).
    pub covariance_camera: Option<CameraCovariance>,
    /// σ of the projector's intrinsics.
    pub std_projector: [f64; N_INTRINSICS],
    /// Covariance of T, mm², row-major.
    pub covariance_translation: [f64; 9],
    /// σ of the projector's orientation (small rotations about the camera axes), degrees.
    pub std_rotation_deg: [f64; 3],
    /// Per view.
    pub views: Vec<ModelView>,
    /// Camera corners' RMS error, pixels.
    pub rms_camera_px: f64,
    /// Projector corners' RMS error, projector pixels.
    pub rms_projector_px: f64,
    /// The noise per coordinate the weights used: camera, projector (pixels).
    pub sigma_px: [f64; 2],
    /// Projector corners used; dropped as outliers.
    pub projector_corners: [usize; 2],
    /// The DLT start of the projector `[fx, fy, γ, u0, v0]` and its centre.
    pub initial: ([f64; 5], Vec3),
    /// Iterations of the last solve; whether it converged.
    pub iterations: (usize, bool),
}

impl ProjectorModel {
    /// The calibration file's projector section.
    pub fn params(&self) -> ProjectorParams {
        ProjectorParams {
            intrinsics: self.projector.to_model(),
            rotation: self.rotation.0,
            translation: self.translation.to_array(),
        }
    }

    /// σ of T per axis, mm.
    pub fn std_translation(&self) -> [f64; 3] {
        std::array::from_fn(|i| self.covariance_translation[i * 4].max(0.0).sqrt())
    }

    /// A JSON summary.
    pub fn to_json(&self) -> serde_json::Value {
        let lens = |l: &Lens, s: &[f64; N_INTRINSICS]| {
            let mut m = serde_json::Map::new();
            m.insert("width".into(), l.width.into());
            m.insert("height".into(), l.height.into());
            for (k, n) in PARAM_NAMES.iter().enumerate() {
                m.insert(
                    n.to_string(),
                    serde_json::json!({"value": l.p[k], "std": s[k]}),
                );
            }
            serde_json::Value::Object(m)
        };
        serde_json::json!({
            "projector": lens(&self.projector, &self.std_projector),
            "camera": lens(&self.camera, &self.std_camera),
            "rotation": self.rotation.0,
            "translation": self.translation.to_array(),
            "translation_std": self.std_translation(),
            "translation_covariance": self.covariance_translation,
            "rotation_std_deg": self.std_rotation_deg,
            "rms_camera_px": self.rms_camera_px,
            "rms_projector_px": self.rms_projector_px,
            "sigma_camera_px": self.sigma_px[0],
            "sigma_projector_px": self.sigma_px[1],
            "projector_corners": self.projector_corners[0],
            "projector_corners_dropped": self.projector_corners[1],
            "dlt_start": {"fx": self.initial.0[0], "fy": self.initial.0[1], "gamma": self.initial.0[2],
                          "cx": self.initial.0[3], "cy": self.initial.0[4], "centre": self.initial.1.to_array()},
            "iterations": self.iterations.0, "converged": self.iterations.1,
            "views": self.views,
        })
    }
}

#[derive(Clone)]
struct State {
    cam: Lens,
    proj: Lens,
    q: Mat3,
    s: Vec3,
    rot: Vec<Mat3>,
    t: Vec<Vec3>,
}

struct Problem<'a> {
    obj: Vec<[f64; 2]>,
    views: &'a [RigView],
    /// Per view and corner: the projector observation is used.
    use_proj: Vec<Vec<bool>>,
    cam_free: Vec<usize>,
    proj_free: Vec<usize>,
    /// 1/σ of the camera and projector residuals.
    weight: [f64; 2],
}

impl Problem<'_> {
    fn n(&self) -> usize {
        self.cam_free.len() + self.proj_free.len() + 6 + 6 * self.views.len()
    }

    /// Residuals (camera u, v per corner, then projector ξ, η per used corner, per view) and the
    /// Jacobian.
    fn eval(&self, s: &State) -> Option<Eval> {
        let (nc, np) = (self.cam_free.len(), self.proj_free.len());
        let pp = nc + np; // projector pose columns start
        let width = nc + np + 12;
        let mut e = Eval {
            width,
            ..Default::default()
        };
        for (vi, v) in self.views.iter().enumerate() {
            let (r, t) = (&s.rot[vi], s.t[vi]);
            let vc = nc + np + 6 + 6 * vi;
            for (k, o) in self.obj.iter().enumerate() {
                let rx = r.mul_vec(Vec3::new(o[0], o[1], 0.0));
                let xc = rx + t;
                if !(xc[2] > 1e-9) {
                    return None;
                }
                let sk = Mat3::cross_matrix(rx);
                // Camera corner.
                let c = v.corners[k];
                let ((u, vv), j) = s.cam.project_jac(xc[0] / xc[2], xc[1] / xc[2]);
                let dp = d_point(&j.d_xy, xc);
                for (row, res) in [(0usize, u - c[0]), (1, vv - c[1])] {
                    let w = self.weight[0];
                    e.r.push(w * res);
                    for (i, &kk) in self.cam_free.iter().enumerate() {
                        e.cols.push(i);
                        e.vals.push(w * j.d_intr[row][kk]);
                    }
                    for _ in 0..np + 6 {
                        e.cols.push(0);
                        e.vals.push(0.0);
                    }
                    for a in 0..3 {
                        let d: f64 = (0..3).map(|b| -dp[row][b] * sk[b][a]).sum();
                        e.cols.push(vc + a);
                        e.vals.push(w * d);
                    }
                    for a in 0..3 {
                        e.cols.push(vc + 3 + a);
                        e.vals.push(w * dp[row][a]);
                    }
                }
                // Projector corner: the point where the camera's ray through the detected corner
                // meets the board's plane. The corner's own error moves the phase it is sampled
                // at and that ray alike, so it cancels: the residual is the phase's noise, and
                // the projector's rows are independent of the camera's (a point of the board's
                // model would carry the corner's error into both, counted twice).
                let Some(pc) = v.projector[k].filter(|_| self.use_proj[vi][k]) else {
                    continue;
                };
                let (x, y) = s.cam.undistort(c[0], c[1])?;
                let ((_, _), jr) = s.cam.project_jac(x, y);
                let d = Vec3::new(x, y, 1.0);
                let nrm = r.column(2);
                let (h, nd) = (nrm.dot(t), nrm.dot(d));
                if !(nd.abs() > 1e-9) {
                    return None;
                }
                let lam = h / nd;
                let xr = d * lam;
                if !(xr[2] > 1e-9) {
                    return None;
                }
                let qx = s.q.mul_vec(xr);
                let xp = qx + s.s;
                if !(xp[2] > 1e-9) {
                    return None;
                }
                let ((xi, eta), jp) = s.proj.project_jac(xp[0] / xp[2], xp[1] / xp[2]);
                let dq = d_point(&jp.d_xy, xp); // ∂(ξ, η)/∂X_p
                // ∂(ξ, η)/∂X_c = dq·Q.
                let mut dc = [[0.0; 3]; 2];
                for (rr, row) in dc.iter_mut().enumerate() {
                    for (cc, x) in row.iter_mut().enumerate() {
                        *x = (0..3).map(|b| dq[rr][b] * s.q.0[b][cc]).sum();
                    }
                }
                let skq = Mat3::cross_matrix(qx);
                // λ = h / (n·d), h = n·t, n = R·e_z: δn = δω × n, δh = δω·(n × t) + n·δt.
                let dl_dw = (nrm.cross(t) * nd - nrm.cross(d) * h) * (1.0 / (nd * nd));
                let dl_dt = nrm * (1.0 / nd);
                // The ray's dependence on the camera's intrinsics: project(x, y) = corner, so
                // ∂(x, y)/∂c = −(∂(u, v)/∂(x, y))⁻¹·∂(u, v)/∂c.
                let [[a0, b0], [c0, d0]] = jr.d_xy;
                let det = a0 * d0 - b0 * c0;
                if !(det.abs() > 1e-300) {
                    return None;
                }
                let dxy = |kk: usize| {
                    let (ju, jv) = (jr.d_intr[0][kk], jr.d_intr[1][kk]);
                    [-(d0 * ju - b0 * jv) / det, -(-c0 * ju + a0 * jv) / det]
                };
                for (row, res) in [(0usize, xi - pc[0]), (1, eta - pc[1])] {
                    let w = self.weight[1];
                    e.r.push(w * res);
                    let dd: f64 = (0..3).map(|b| dc[row][b] * d[b]).sum();
                    for (i, &kk) in self.cam_free.iter().enumerate() {
                        // ∂X/∂c = λ·∂d/∂c + d·∂λ/∂c, ∂λ/∂c = −h·(n·∂d/∂c)/(n·d)².
                        let g = dxy(kk);
                        let ddc = Vec3::new(g[0], g[1], 0.0);
                        let dlc = -h * nrm.dot(ddc) / (nd * nd);
                        let dx: f64 = (0..3).map(|b| dc[row][b] * (lam * ddc[b])).sum();
                        e.cols.push(i);
                        e.vals.push(w * (dx + dd * dlc));
                    }
                    for (i, &kk) in self.proj_free.iter().enumerate() {
                        e.cols.push(nc + i);
                        e.vals.push(w * jp.d_intr[row][kk]);
                    }
                    // Projector pose: ∂X_p/∂δω = −[Q X_c]×, ∂X_p/∂δs = I.
                    for a in 0..3 {
                        let g: f64 = (0..3).map(|b| -dq[row][b] * skq[b][a]).sum();
                        e.cols.push(pp + a);
                        e.vals.push(w * g);
                    }
                    for a in 0..3 {
                        e.cols.push(pp + 3 + a);
                        e.vals.push(w * dq[row][a]);
                    }
                    // Board pose through the plane: ∂X/∂(δω, δt) = d·∂λ/∂(δω, δt).
                    for a in 0..3 {
                        e.cols.push(vc + a);
                        e.vals.push(w * dd * dl_dw[a]);
                    }
                    for a in 0..3 {
                        e.cols.push(vc + 3 + a);
                        e.vals.push(w * dd * dl_dt[a]);
                    }
                }
            }
        }
        Some(e)
    }

    fn apply(&self, s: &State, d: &[f64]) -> State {
        let (nc, np) = (self.cam_free.len(), self.proj_free.len());
        let mut o = s.clone();
        for (i, &k) in self.cam_free.iter().enumerate() {
            o.cam.p[k] += d[i];
        }
        for (i, &k) in self.proj_free.iter().enumerate() {
            o.proj.p[k] += d[nc + i];
        }
        let b = nc + np;
        o.q = rodrigues(Vec3::new(d[b], d[b + 1], d[b + 2])).mul_mat(&s.q);
        o.s = s.s + Vec3::new(d[b + 3], d[b + 4], d[b + 5]);
        for vi in 0..o.rot.len() {
            let b = nc + np + 6 + 6 * vi;
            o.rot[vi] = rodrigues(Vec3::new(d[b], d[b + 1], d[b + 2])).mul_mat(&s.rot[vi]);
            o.t[vi] = s.t[vi] + Vec3::new(d[b + 3], d[b + 4], d[b + 5]);
        }
        o
    }

    fn solve(&self, start: State) -> Option<lm::Solution<State>> {
        lm::solve(
            start,
            self.n(),
            |s, _| self.eval(s),
            |s, d| self.apply(s, d),
            lm::Options::default(),
        )
    }

    /// Unweighted residuals per view: camera pairs, projector pairs (with corner indices).
    #[allow(clippy::type_complexity)]
    fn split(&self, r: &[f64]) -> Vec<(Vec<[f64; 2]>, Vec<(usize, [f64; 2])>)> {
        let mut out = Vec::new();
        let mut i = 0;
        for (vi, v) in self.views.iter().enumerate() {
            let mut cam = Vec::new();
            let mut proj = Vec::new();
            for k in 0..self.obj.len() {
                cam.push([r[i] / self.weight[0], r[i + 1] / self.weight[0]]);
                i += 2;
                if v.projector[k].is_some() && self.use_proj[vi][k] {
                    proj.push((k, [r[i] / self.weight[1], r[i + 1] / self.weight[1]]));
                    i += 2;
                }
            }
            out.push((cam, proj));
        }
        out
    }
}

fn rms2(v: impl Iterator<Item = [f64; 2]>) -> (f64, usize) {
    let (mut s, mut n) = (0.0, 0);
    for r in v {
        s += r[0] * r[0] + r[1] * r[1];
        n += 1;
    }
    ((s / n.max(1) as f64).sqrt(), n)
}

/// Calibrate the projector (and optionally refine the camera) from board views.
pub fn calibrate(
    board: &Board,
    camera: &Lens,
    projector_size: (u32, u32),
    views: &[RigView],
    opts: &ModelOptions,
) -> Result<ProjectorModel, CalibError> {
    let obj = board.object_points();
    let degenerate = |what: String| CalibError::Degenerate { what };
    // 1. Board poses and the DLT start.
    let mut rot = Vec::new();
    let mut t = Vec::new();
    let mut world = Vec::new();
    let mut image = Vec::new();
    let mut used: Vec<RigView> = Vec::new();
    let mut skipped = Vec::new();
    for v in views {
        if v.corners.len() != obj.len() || v.projector.len() != obj.len() {
            return Err(CalibError::Input {
                what: v.name.clone(),
                message: format!("{} corners, the board has {}", v.corners.len(), obj.len()),
            });
        }
        let lit = v.projector.iter().filter(|p| p.is_some()).count();
        if lit < opts.min_view_corners {
            skipped.push(format!(
                "{}: {lit} corners with projector coordinates (need {})",
                v.name, opts.min_view_corners
            ));
            continue;
        }
        let p = pose::board_pose(camera, board, &v.corners).map_err(|e| CalibError::Input {
            what: v.name.clone(),
            message: format!("board pose: {e}"),
        })?;
        for (o, q) in obj.iter().zip(&v.projector) {
            if let Some(q) = q {
                world.push(p.rotation.mul_vec(Vec3::new(o[0], o[1], 0.0)) + p.translation);
                image.push(*q);
            }
        }
        rot.push(p.rotation);
        t.push(p.translation);
        used.push(v.clone());
    }
    if used.len() < 2 {
        return Err(CalibError::TooFewViews {
            usable: used.len(),
            needed: 2,
            used: used.iter().map(|v| v.name.clone()).collect(),
            rejected: skipped,
        });
    }
    let start = dlt(&world, &image).ok_or_else(|| {
        degenerate(format!(
            "the projector's closed-form start: the board corners of {} are coplanar (tilt the boards between poses, or move the plate to several depths)",
            used.iter().map(|v| v.name.as_str()).collect::<Vec<_>>().join(", ")
        ))
    })?;
    let mut proj = Lens {
        width: projector_size.0,
        height: projector_size.1,
        p: [0.0; N_INTRINSICS],
    };
    let k = start.k;
    proj.p[..5].copy_from_slice(&[k[0], k[1], k[2] / k[0], k[3], k[4]]);
    let initial = (
        k,
        start.rotation.transpose().mul_vec(start.translation) * -1.0,
    );
    let mut state = State {
        cam: *camera,
        proj,
        q: start.rotation,
        s: start.translation,
        rot,
        t,
    };
    let mut problem = Problem {
        obj,
        views: &used,
        use_proj: used.iter().map(|v| vec![true; v.projector.len()]).collect(),
        cam_free: if opts.refine_camera {
            opts.camera.free()
        } else {
            Vec::new()
        },
        proj_free: opts.projector.free(),
        weight: [1.0, 1.0],
    };
    // 2. Joint adjustment: equal weights, then each group weighted by its own noise, then
    // projector outliers dropped.
    let mut dropped = 0;
    let mut sol = None;
    for round in 0..5 {
        let s = problem.solve(state.clone()).ok_or_else(|| {
            degenerate(
                "joint adjustment: a board ends up behind the camera or the projector".into(),
            )
        })?;
        let per = problem.split(&s.residuals);
        let rc = rms2(per.iter().flat_map(|(c, _)| c.iter().copied())).0;
        let rp = rms2(per.iter().flat_map(|(_, p)| p.iter().map(|x| x.1))).0;
        let dof =
            (s.residuals.len() as f64 - problem.n() as f64).max(1.0) / s.residuals.len() as f64;
        let sc = (rc / 2f64.sqrt() / dof.sqrt()).max(1e-6);
        let sp = (rp / 2f64.sqrt() / dof.sqrt()).max(1e-6);
        state = s.state.clone();
        let new_weight = [1.0 / sc, 1.0 / sp];
        let mut changed = round == 0;
        if round >= 1 {
            for (vi, (_, p)) in per.iter().enumerate() {
                for (k, r) in p {
                    let d = (r[0] * r[0] + r[1] * r[1]).sqrt();
                    if d > opts.outlier_sigmas * sp * 2f64.sqrt() {
                        problem.use_proj[vi][*k] = false;
                        dropped += 1;
                        changed = true;
                    }
                }
            }
        }
        problem.weight = new_weight;
        sol = Some(s);
        if !changed && round >= 1 {
            break;
        }
    }
    // The final solve with the final weights.
    let sol = problem
        .solve(state)
        .or(sol)
        .ok_or_else(|| degenerate("joint adjustment".into()))?;
    let st = &sol.state;
    let n = problem.n();
    let mut cov = sol.covariance(n);
    let (nc, np) = (problem.cam_free.len(), problem.proj_free.len());
    // The held camera's uncertainty, through the normal matrix with its columns.
    let mut covariance_camera = None;
    match (&opts.camera_covariance, cov.as_mut()) {
        (Some(cc), Some(c)) if !opts.refine_camera => {
            let held = uncertainty::uncertain_intrinsics(cc);
            let with = Problem {
                obj: problem.obj.clone(),
                views: problem.views,
                use_proj: problem.use_proj.clone(),
                cam_free: held.clone(),
                proj_free: problem.proj_free.clone(),
                weight: problem.weight,
            };
            let normal = with
                .eval(st)
                .map(|e| e.normal_equations(with.n()).0)
                .ok_or_else(|| degenerate("the camera's uncertainty: no Jacobian".into()))?;
            let sigma: Vec<f64> = held
                .iter()
                .flat_map(|&i| held.iter().map(move |&j| cc.matrix[i][j]))
                .collect();
            if let Some(add) = uncertainty::held_covariance(&normal, held.len(), &sigma) {
                c.iter_mut().zip(add).for_each(|(x, a)| *x += a);
            }
            covariance_camera = Some(*cc);
        }
        (_, Some(c)) if opts.refine_camera => {
            let mut m = [[0.0; N_INTRINSICS]; N_INTRINSICS];
            for (i, &k) in problem.cam_free.iter().enumerate() {
                for (j, &l) in problem.cam_free.iter().enumerate() {
                    m[k][l] = c[i * n + j];
                }
            }
            covariance_camera = Some(CameraCovariance { matrix: m });
        }
        _ => {}
    }
    let diag = |i: usize| cov.as_ref().map_or(0.0, |c| c[i * n + i].max(0.0).sqrt());
    let mut std_camera = [0.0; N_INTRINSICS];
    for (i, &k) in problem.cam_free.iter().enumerate() {
        std_camera[k] = diag(i);
    }
    let mut std_projector = [0.0; N_INTRINSICS];
    for (i, &k) in problem.proj_free.iter().enumerate() {
        std_projector[k] = diag(nc + i);
    }
    let b = nc + np;
    let qt = st.q.transpose();
    // J_T = [−Qᵀ[s]×, −Qᵀ].
    let sx = Mat3::cross_matrix(st.s);
    let qsx = qt.mul_mat(&sx);
    let mut jt = [[0.0; 6]; 3];
    for i in 0..3 {
        for j in 0..3 {
            jt[i][j] = -qsx.0[i][j];
            jt[i][3 + j] = -qt.0[i][j];
        }
    }
    let mut cov_t = [0.0; 9];
    let mut std_rot = [0.0; 3];
    if let Some(c) = &cov {
        for i in 0..3 {
            for j in 0..3 {
                let mut acc = 0.0;
                for a in 0..6 {
                    for bb in 0..6 {
                        acc += jt[i][a] * c[(b + a) * n + b + bb] * jt[j][bb];
                    }
                }
                cov_t[i * 3 + j] = acc;
            }
            std_rot[i] = c[(b + i) * n + b + i].max(0.0).sqrt().to_degrees();
        }
    }
    // A model the poses do not determine is refused rather than written.
    let st_t = (0..3).map(|i| cov_t[i * 4]).sum::<f64>().max(0.0).sqrt();
    let rel_f = std_projector[0] / st.proj.p[0].abs().max(1e-300);
    if cov.is_none() || !(rel_f <= MAX_FOCAL_STD && st_t <= MAX_CENTRE_STD_MM) {
        return Err(degenerate(format!(
            "the poses do not determine the projector: σ(fx) = {:.3} %, σ(P) = {st_t:.3} mm (limits {:.1} %, {MAX_CENTRE_STD_MM} mm) from {} corners lit in {} ({}); add poses tilted differently and spread over the measurement volume, with more of the board lit",
            100.0 * rel_f,
            100.0 * MAX_FOCAL_STD,
            problem.use_proj.iter().flatten().filter(|&&u| u).count(),
            used.len(),
            used.iter()
                .map(|v| v.name.as_str())
                .collect::<Vec<_>>()
                .join(", ")
        )));
    }
    let per = problem.split(&sol.residuals);
    let mut mviews = Vec::new();
    for (vi, (c, p)) in per.iter().enumerate() {
        // The plane's distance h = n·t (n its unit normal): δh = (n × t)·δω + n·δt.
        let (rot, t) = (st.rot[vi], st.t[vi]);
        let nrm = rot.column(2);
        let g = {
            let a = nrm.cross(t);
            [a[0], a[1], a[2], nrm[0], nrm[1], nrm[2]]
        };
        let vb = nc + np + 6 + 6 * vi;
        let var_h = cov.as_ref().map_or(0.0, |c| {
            (0..6)
                .flat_map(|i| (0..6).map(move |j| (i, j)))
                .map(|(i, j)| g[i] * c[(vb + i) * n + vb + j] * g[j])
                .sum::<f64>()
        });
        mviews.push(ModelView {
            name: used[vi].name.clone(),
            rms_camera_px: rms2(c.iter().copied()).0,
            rms_projector_px: rms2(p.iter().map(|x| x.1)).0,
            projector_corners: p.len(),
            rotation: rot,
            translation: t,
            distance_std_mm: var_h.max(0.0).sqrt(),
        });
    }
    let (rc, _) = rms2(per.iter().flat_map(|(c, _)| c.iter().copied()));
    let (rp, used_p) = rms2(per.iter().flat_map(|(_, p)| p.iter().map(|x| x.1)));
    Ok(ProjectorModel {
        camera: st.cam,
        projector: st.proj,
        rotation: qt,
        translation: qt.mul_vec(st.s) * -1.0,
        std_camera,
        covariance_camera,
        std_projector,
        covariance_translation: cov_t,
        std_rotation_deg: std_rot,
        views: mviews,
        rms_camera_px: rc,
        rms_projector_px: rp,
        sigma_px: [1.0 / problem.weight[0], 1.0 / problem.weight[1]],
        projector_corners: [used_p, dropped],
        initial,
        iterations: (sol.iterations, sol.converged),
    })
}

#[cfg(test)]
mod tests;
