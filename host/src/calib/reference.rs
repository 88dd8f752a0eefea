//! The reference plane (paper §6): its pose `(O_R, n_R)` from a board lying on it (or given),
//! and its phase map Φ_R (the decoded fringe set of the plane).

use super::corners::Board;
use super::lens::Lens;
use super::pose::{PlanePose, PoseError, board_pose};
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
    /// board fit; 0 when given).
    pub distance_std_mm: f64,
    /// Standard deviation of the normal's direction, degrees (from the board fit; 0 when given).
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
}
