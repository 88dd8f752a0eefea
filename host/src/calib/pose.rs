//! The pose of a checkerboard (and so of the plane it lies on) seen by a calibrated camera:
//! homography to undistorted normalized coordinates, decomposed, then refined by
//! Levenberg–Marquardt on the pixel reprojection error; with its covariance.

use super::camera::d_point;
use super::corners::Board;
use super::lens::Lens;
use super::linalg::{rodrigues, rot_log};
use super::lm::{self, Eval};
use super::{uncertainty, zhang};
use crate::io::calibration::CameraCovariance;
use crate::math::{Mat3, Vec3};

/// A board's pose: board frame → camera frame, `X_c = R X_b + t`.
#[derive(Clone, Debug, serde::Serialize)]
pub struct PlanePose {
    /// R (row-major).
    pub rotation: Mat3,
    /// t: the board origin (centre of its squares) in the camera frame, mm.
    pub translation: Vec3,
    /// Covariance of the local parameters `(δω, δt)` (left rotation perturbation
    /// `R ← exp([δω]×) R`, radians; translation, mm), 6 × 6 row-major, from σ²(JᵀJ)⁻¹.
    #[serde(skip)]
    pub covariance: [f64; 36],
    /// RMS reprojection error of the corners, pixels.
    pub rms: f64,
    /// Corners used.
    pub corners: usize,
}

impl PlanePose {
    /// The plane's unit normal, pointing towards the camera.
    pub fn normal(&self) -> Vec3 {
        let n = self.rotation.column(2);
        if n.dot(self.translation) > 0.0 {
            n * -1.0
        } else {
            n
        }
    }

    /// A point of the plane (the board origin).
    pub fn point(&self) -> Vec3 {
        self.translation
    }

    /// The pose moved by the local parameters `(δω, δt)`.
    pub fn perturbed(&self, d: &[f64; 6]) -> PlanePose {
        let mut p = self.clone();
        p.rotation = rodrigues(Vec3::new(d[0], d[1], d[2])).mul_mat(&self.rotation);
        p.translation = self.translation + Vec3::new(d[3], d[4], d[5]);
        p
    }

    /// Standard deviations of the local parameters (rad, rad, rad, mm, mm, mm).
    pub fn std(&self) -> [f64; 6] {
        std::array::from_fn(|i| self.covariance[i * 6 + i].max(0.0).sqrt())
    }

    /// σ of the plane's distance from the camera centre along its normal, mm: `h = n·t` moves
    /// by `(n × t)·δω + n·δt`.
    pub fn distance_std(&self) -> f64 {
        let n = self.rotation.column(2);
        let a = n.cross(self.translation);
        let g = [a[0], a[1], a[2], n[0], n[1], n[2]];
        let mut v = 0.0;
        for i in 0..6 {
            for j in 0..6 {
                v += g[i] * self.covariance[i * 6 + j] * g[j];
            }
        }
        v.max(0.0).sqrt()
    }

    /// σ of the plane's normal direction, degrees: the rotation's variance across the normal
    /// (a turn about the normal leaves the plane).
    pub fn tilt_std_deg(&self) -> f64 {
        let n = self.rotation.column(2);
        let c = &self.covariance;
        let trace: f64 = (0..3).map(|i| c[i * 6 + i]).sum();
        let about: f64 = (0..3)
            .flat_map(|i| (0..3).map(move |j| (i, j)))
            .map(|(i, j)| n[i] * c[i * 6 + j] * n[j])
            .sum();
        (trace - about).max(0.0).sqrt().to_degrees()
    }

    /// The local parameters `(δω, δt)` that move this pose to `other`.
    pub fn difference(&self, other: &PlanePose) -> [f64; 6] {
        let w = rot_log(&other.rotation.mul_mat(&self.rotation.transpose()));
        let t = other.translation - self.translation;
        [w[0], w[1], w[2], t[0], t[1], t[2]]
    }

    /// This pose with the covariance the camera's intrinsics (covariance `cov`) add to it: the
    /// pose re-fitted to the same `corners` with the camera moved by one σ of each intrinsic
    /// ([`uncertainty::camera_part`]). Unchanged if a re-fit fails.
    pub fn with_camera(
        mut self,
        lens: &Lens,
        board: &Board,
        corners: &[[f64; 2]],
        cov: &CameraCovariance,
    ) -> PlanePose {
        let add = uncertainty::camera_part::<6>(lens, cov, |l| {
            board_pose(l, board, corners)
                .ok()
                .map(|p| self.difference(&p))
        });
        if let Some(a) = add {
            for i in 0..6 {
                for j in 0..6 {
                    self.covariance[i * 6 + j] += a[i][j];
                }
            }
        }
        self
    }
}

/// Why a pose could not be found.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum PoseError {
    /// A corner pixel lies outside the lens model's range.
    #[error("corner {0} is outside the camera model's range (wrong camera for this image?)")]
    Undistort(usize),
    /// The homography or its decomposition failed.
    #[error("degenerate corner layout (no homography)")]
    Degenerate,
    /// The refinement failed.
    #[error("pose refinement failed (board behind the camera)")]
    Refine,
}

/// The pose of `board` from its detected `corners` (object-point order) with a calibrated lens.
pub fn board_pose(
    lens: &Lens,
    board: &Board,
    corners: &[[f64; 2]],
) -> Result<PlanePose, PoseError> {
    let obj = board.object_points();
    if corners.len() != obj.len() || obj.len() < 4 {
        return Err(PoseError::Degenerate);
    }
    let norm_pts: Vec<[f64; 2]> = corners
        .iter()
        .enumerate()
        .map(|(i, c)| {
            lens.undistort(c[0], c[1])
                .map(|(x, y)| [x, y])
                .ok_or(PoseError::Undistort(i))
        })
        .collect::<Result<_, _>>()?;
    let h = zhang::homography(&obj, &norm_pts).ok_or(PoseError::Degenerate)?;
    let (r0, t0) = zhang::pose_from_homography(&h).ok_or(PoseError::Degenerate)?;
    let eval = |s: &(Mat3, Vec3), _j: bool| -> Option<Eval> {
        let mut e = Eval {
            width: 6,
            ..Default::default()
        };
        for (o, c) in obj.iter().zip(corners) {
            let rx = s.0.mul_vec(Vec3::new(o[0], o[1], 0.0));
            let xc = rx + s.1;
            if !(xc[2] > 1e-9) {
                return None;
            }
            let ((u, v), j) = lens.project_jac(xc[0] / xc[2], xc[1] / xc[2]);
            let dp = d_point(&j.d_xy, xc);
            let sk = Mat3::cross_matrix(rx);
            for (row, res) in [(0usize, u - c[0]), (1, v - c[1])] {
                e.r.push(res);
                for a in 0..3 {
                    let mut s_ = 0.0;
                    for b in 0..3 {
                        s_ -= dp[row][b] * sk[b][a];
                    }
                    e.vals.push(s_);
                }
                e.vals.extend(dp[row]);
                e.cols.extend(0..6);
            }
        }
        Some(e)
    };
    let apply = |s: &(Mat3, Vec3), d: &[f64]| {
        (
            rodrigues(Vec3::new(d[0], d[1], d[2])).mul_mat(&s.0),
            s.1 + Vec3::new(d[3], d[4], d[5]),
        )
    };
    let sol =
        lm::solve((r0, t0), 6, eval, apply, lm::Options::default()).ok_or(PoseError::Refine)?;
    let cov = sol.covariance(6).unwrap_or_else(|| vec![0.0; 36]);
    let m = sol.residuals.len();
    Ok(PlanePose {
        rotation: sol.state.0,
        translation: sol.state.1,
        covariance: std::array::from_fn(|i| cov[i]),
        rms: (sol.cost / (m / 2) as f64).sqrt(),
        corners: m / 2,
    })
}

/// The point where the viewing ray of pixel `(u, v)` meets the plane `(o, n)` (`None` if the
/// pixel cannot be undistorted or the ray is parallel to the plane or meets it behind the camera).
pub fn ray_plane(lens: &Lens, u: f64, v: f64, o: Vec3, n: Vec3) -> Option<Vec3> {
    let (x, y) = lens.undistort(u, v)?;
    ray_dir_plane(Vec3::new(x, y, 1.0), o, n)
}

/// The point where the ray `s·d` (s > 0) meets the plane `(o, n)`.
pub fn ray_dir_plane(d: Vec3, o: Vec3, n: Vec3) -> Option<Vec3> {
    let den = n.dot(d);
    if den.abs() < 1e-12 {
        return None;
    }
    let s = n.dot(o) / den;
    (s > 0.0).then(|| d * s)
}

/// The poses of one board seen at several positions of a plate that is *translated without
/// turning* (paper §7: the plate moves from `(O_P^(S), n_P)` to `(O_P^(T), n_P)`): one rotation
/// shared by all views and a translation per view, fitted jointly to all corners. Returns the poses
/// (each with the marginal covariance of `(δω, δt_k)`) and the joint covariance of
/// `(δω, δt_1, …, δt_n)` (`(3 + 3n)²`, row-major).
pub fn translated_board_poses(
    lens: &Lens,
    board: &Board,
    views: &[Vec<[f64; 2]>],
) -> Result<(Vec<PlanePose>, Vec<f64>), PoseError> {
    let n = views.len();
    let obj = board.object_points();
    let single: Vec<PlanePose> = views
        .iter()
        .map(|c| board_pose(lens, board, c))
        .collect::<Result<_, _>>()?;
    // Start: the mean rotation.
    let mut sum = Mat3([[0.0; 3]; 3]);
    for p in &single {
        for i in 0..3 {
            for j in 0..3 {
                sum[i][j] += p.rotation[i][j];
            }
        }
    }
    let r0 = super::linalg::nearest_rotation(&sum);
    let t0: Vec<Vec3> = single.iter().map(|p| p.translation).collect();
    let np = 3 + 3 * n;
    let eval = |s: &(Mat3, Vec<Vec3>), _j: bool| -> Option<Eval> {
        let mut e = Eval {
            width: 6,
            ..Default::default()
        };
        for (k, corners) in views.iter().enumerate() {
            for (o, c) in obj.iter().zip(corners) {
                let rx = s.0.mul_vec(Vec3::new(o[0], o[1], 0.0));
                let xc = rx + s.1[k];
                if !(xc[2] > 1e-9) {
                    return None;
                }
                let ((u, v), j) = lens.project_jac(xc[0] / xc[2], xc[1] / xc[2]);
                let dp = d_point(&j.d_xy, xc);
                let sk = Mat3::cross_matrix(rx);
                for (row, res) in [(0usize, u - c[0]), (1, v - c[1])] {
                    e.r.push(res);
                    for a in 0..3 {
                        let mut s_ = 0.0;
                        for b in 0..3 {
                            s_ -= dp[row][b] * sk[b][a];
                        }
                        e.vals.push(s_);
                    }
                    e.vals.extend(dp[row]);
                    e.cols.extend([0, 1, 2, 3 + 3 * k, 4 + 3 * k, 5 + 3 * k]);
                }
            }
        }
        Some(e)
    };
    let apply = |s: &(Mat3, Vec<Vec3>), d: &[f64]| {
        let r = rodrigues(Vec3::new(d[0], d[1], d[2])).mul_mat(&s.0);
        let t =
            s.1.iter()
                .enumerate()
                .map(|(k, t)| *t + Vec3::new(d[3 + 3 * k], d[4 + 3 * k], d[5 + 3 * k]))
                .collect();
        (r, t)
    };
    let sol =
        lm::solve((r0, t0), np, eval, apply, lm::Options::default()).ok_or(PoseError::Refine)?;
    let cov = sol.covariance(np).unwrap_or_else(|| vec![0.0; np * np]);
    let per = obj.len();
    let poses = (0..n)
        .map(|k| {
            let idx = [0, 1, 2, 3 + 3 * k, 4 + 3 * k, 5 + 3 * k];
            let ss: f64 = (0..2 * per)
                .map(|i| sol.residuals[2 * per * k + i].powi(2))
                .sum();
            PlanePose {
                rotation: sol.state.0,
                translation: sol.state.1[k],
                covariance: std::array::from_fn(|i| cov[idx[i / 6] * np + idx[i % 6]]),
                rms: (ss / per as f64).sqrt(),
                corners: per,
            }
        })
        .collect();
    Ok((poses, cov))
}
