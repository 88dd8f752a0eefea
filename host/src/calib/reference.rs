//! The reference plane (paper §6): its pose `(O_R, n_R)` from a board lying on it (or given),
//! and its phase map Φ_R (the decoded fringe set of the plane).

use super::corners::Board;
use super::lens::Lens;
use super::pose::{PlanePose, PoseError, board_pose};
use super::uncertainty;
use crate::io::calibration::CameraCovariance;
use crate::math::Vec3;

/// A reference plane.
#[derive(Clone, Debug, serde::Serialize)]
pub struct ReferencePose {
    /// A point O_R of the plane, camera frame, mm.
    pub point: Vec3,
    /// Unit normal n_R, towards the camera.
    pub normal: Vec3,
    /// The board poses it came from (none when given).
    pub boards: Vec<PlanePose>,
    /// Standard deviation of the plane's distance from the camera centre along n_R, mm (from the
    /// board fit, and the camera's uncertainty when known, [`ReferencePose::with_camera`]; 0 when
    /// given).
    pub distance_std_mm: f64,
    /// Standard deviation of the normal's direction, degrees (likewise).
    pub tilt_std_deg: f64,
}

impl ReferencePose {
    /// A plane given by a point and a normal (turned towards the camera).
    pub fn given(point: Vec3, normal: Vec3) -> Option<ReferencePose> {
        let mut n = normal.try_normalized()?;
        if n.dot(point) > 0.0 {
            n = n * -1.0;
        }
        (n.dot(point).abs() > 1e-6).then_some(ReferencePose {
            point,
            normal: n,
            boards: Vec::new(),
            distance_std_mm: 0.0,
            tilt_std_deg: 0.0,
        })
    }

    /// The plane of one or more boards lying on it, seen by the calibrated `lens`, moved by
    /// `offset_mm` along the normal away from the camera (the board's thickness: its printed face
    /// is `offset_mm` in front of the reference surface). Several boards (placed anywhere on the
    /// plane, turned as they come) are combined: the normal is their inverse-variance weighted
    /// mean, the distance the weighted mean of their distances along it, O_R the centroid of the
    /// board origins projected onto the plane.
    pub fn from_boards(
        lens: &Lens,
        board: &Board,
        corners: &[Vec<[f64; 2]>],
        offset_mm: f64,
    ) -> Result<ReferencePose, PoseError> {
        if corners.is_empty() {
            return Err(PoseError::Degenerate);
        }
        let poses: Vec<PlanePose> = corners
            .iter()
            .map(|c| board_pose(lens, board, c))
            .collect::<Result<_, _>>()?;
        // Per board: normal, tilt variance (rad²), distance variance (mm²).
        let stats: Vec<(Vec3, f64, f64)> = poses
            .iter()
            .map(|p| {
                let n = p.normal();
                let c = &p.covariance;
                let var_rot: f64 = (0..3).map(|i| c[i * 6 + i]).sum();
                let var_about_n: f64 = (0..3)
                    .flat_map(|i| (0..3).map(move |j| (i, j)))
                    .map(|(i, j)| n[i] * c[i * 6 + j] * n[j])
                    .sum();
                let mut var_d = 0.0;
                for i in 0..3 {
                    for j in 0..3 {
                        var_d += n[i] * c[(3 + i) * 6 + 3 + j] * n[j];
                    }
                }
                (n, (var_rot - var_about_n).max(1e-18), var_d.max(1e-18))
            })
            .collect();
        let mut nsum = Vec3::ZERO;
        let mut wt: f64 = 0.0;
        for (n, vt, _) in &stats {
            nsum = nsum + *n * (1.0 / vt);
            wt += 1.0 / vt;
        }
        let n = nsum.try_normalized().ok_or(PoseError::Degenerate)?;
        let (mut dsum, mut wd): (f64, f64) = (0.0, 0.0);
        let mut centroid = Vec3::ZERO;
        for (p, (_, _, vd)) in poses.iter().zip(&stats) {
            dsum += n.dot(p.point()) / vd;
            wd += 1.0 / vd;
            centroid = centroid + p.point() * (1.0 / poses.len() as f64);
        }
        let d = dsum / wd;
        // Project the centroid onto the plane n·X = d, then move by the offset.
        let on_plane = centroid - n * (n.dot(centroid) - d);
        let point = on_plane + n * -offset_mm;
        Ok(ReferencePose {
            point,
            normal: n,
            boards: poses,
            distance_std_mm: (1.0 / wd).sqrt(),
            tilt_std_deg: (1.0 / wt).sqrt().to_degrees(),
        })
    }

    /// This plane (from [`ReferencePose::from_boards`] of the same arguments) with the camera's
    /// uncertainty (covariance `cov`) added to its σ: the whole estimate, every board re-fitted
    /// and the boards combined, repeated with the camera moved by one σ of each intrinsic
    /// ([`uncertainty::camera_part`]). The camera's error is common to the boards, so it does not
    /// average down as their noise does: with a calibrated camera it is most of the plane's
    /// distance error (a focal length 2·10⁻⁵ off moves a plane at 730 mm by 15 µm).
    pub fn with_camera(
        mut self,
        lens: &Lens,
        board: &Board,
        corners: &[Vec<[f64; 2]>],
        offset_mm: f64,
        cov: &CameraCovariance,
    ) -> ReferencePose {
        let plane = |p: &ReferencePose| {
            let n = p.normal;
            [-n.dot(p.point), n[0], n[1], n[2]]
        };
        let add = uncertainty::camera_part::<4>(lens, cov, |l| {
            ReferencePose::from_boards(l, board, corners, offset_mm)
                .ok()
                .map(|p| plane(&p))
        });
        if let Some(a) = add {
            let d = self.distance_std_mm;
            self.distance_std_mm = (d * d + a[0][0]).sqrt();
            // The unit normal moves across itself: the trace is the tilt's variance.
            let t = self.tilt_std_deg.to_radians();
            self.tilt_std_deg = (t * t + a[1][1] + a[2][2] + a[3][3]).sqrt().to_degrees();
        }
        self
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::calib::linalg::cholesky;
    use crate::math::Mat3;
    use crate::render::rig::default_rig;
    use crate::render::rng::Rng;

    /// The camera part of the plane's σ against Monte Carlo: boards seen exactly by the true
    /// camera, the plane estimated again with cameras drawn from a covariance (correlated focal
    /// lengths, principal point, distortion); the spread of the estimates' distance and tilt is
    /// the propagated σ.
    #[test]
    fn the_camera_part_of_the_plane_sigma_matches_monte_carlo() {
        let cam = Lens::from_model(&default_rig().camera);
        let board = Board {
            cols: 11,
            rows: 8,
            square: 25.0,
        };
        let obj = board.object_points();
        let corners: Vec<Vec<[f64; 2]>> =
            [(0.0, 0.0, 8.0), (-70.0, -40.0, -6.0), (70.0, 40.0, 14.0)]
                .iter()
                .map(|&(dx, dy, rot)| {
                    let r = Mat3::from_euler_deg([0.0, 0.0, rot]);
                    let t = Vec3::new(dx, dy, 730.0);
                    obj.iter()
                        .map(|o| {
                            let x = r.mul_vec(Vec3::new(o[0], o[1], 0.0)) + t;
                            let (u, v) = cam.project_point(x.to_array()).unwrap();
                            [u, v]
                        })
                        .collect()
                })
                .collect();
        // A covariance of a calibrated camera's size: σ(fx, fy) 0.06 px correlated 0.9, σ(cx,
        // cy) 0.08 px, σ(k1) 1e-4, σ(k2) 5e-4 (k1, k2 anticorrelated −0.8), skew and the rest held.
        let sd = [0.06, 0.06, 0.0, 0.08, 0.08, 1e-4, 5e-4, 0.0, 0.0, 0.0];
        let mut m = [[0.0; 10]; 10];
        for (i, row) in m.iter_mut().enumerate() {
            row[i] = sd[i] * sd[i];
        }
        for (a, b, rho) in [(0, 1, 0.9), (5, 6, -0.8), (0, 3, 0.3)] {
            m[a][b] = rho * sd[a] * sd[b];
            m[b][a] = m[a][b];
        }
        let cov = CameraCovariance { matrix: m };
        let plane = ReferencePose::from_boards(&cam, &board, &corners, 0.0).unwrap();
        let with = plane.clone().with_camera(&cam, &board, &corners, 0.0, &cov);
        // The noise-free boards leave only the camera's part.
        assert!(plane.distance_std_mm < 1e-6 && plane.tilt_std_deg < 1e-6);
        // Monte Carlo over cameras N(c, Σ) (Cholesky of the free block).
        let free: Vec<usize> = (0..10).filter(|&k| sd[k] > 0.0).collect();
        let nf = free.len();
        let mut l: Vec<f64> = free
            .iter()
            .flat_map(|&i| free.iter().map(move |&j| m[i][j]))
            .collect();
        assert!(cholesky(&mut l, nf));
        let mut rng = Rng::new(7);
        let (mut sd2, mut st2, mut n) = (0.0, 0.0, 0usize);
        for _ in 0..400 {
            let z: Vec<f64> = (0..nf).map(|_| rng.gauss()).collect();
            let mut lens = cam;
            for (i, &k) in free.iter().enumerate() {
                lens.p[k] += (0..=i).map(|j| l[i * nf + j] * z[j]).sum::<f64>();
            }
            let p = ReferencePose::from_boards(&lens, &board, &corners, 0.0).unwrap();
            let dh = -p.normal.dot(p.point) + plane.normal.dot(plane.point);
            let tilt = p.normal.dot(plane.normal).clamp(-1.0, 1.0).acos();
            sd2 += dh * dh;
            st2 += tilt * tilt;
            n += 1;
        }
        let (mc_d, mc_t) = (
            (sd2 / n as f64).sqrt(),
            (st2 / n as f64).sqrt().to_degrees(),
        );
        let (rd, rt) = (with.distance_std_mm / mc_d, with.tilt_std_deg / mc_t);
        assert!(
            (0.9..=1.1).contains(&rd) && (0.85..=1.15).contains(&rt),
            "distance σ {:.5} mm vs Monte Carlo {mc_d:.5} ({rd:.3}); tilt σ {:.6}° vs {mc_t:.6}° ({rt:.3})",
            with.distance_std_mm,
            with.tilt_std_deg
        );
    }
}
