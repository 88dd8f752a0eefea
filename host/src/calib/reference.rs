//! The reference plane (paper §6): its pose `(O_R, n_R)` from a board lying on it (or given),
//! and its phase map Φ_R (the decoded fringe set of the plane).

use super::corners::Board;
use super::lens::Lens;
use super::linalg::{V3, add, normalize, scale};
use super::pose::{PlanePose, PoseError, board_pose};

/// A reference plane.
#[derive(Clone, Debug, serde::Serialize)]
pub struct ReferencePose {
    /// A point O_R of the plane, camera frame, mm.
    pub point: V3,
    /// Unit normal n_R, towards the camera.
    pub normal: V3,
    /// The board pose it came from, if any.
    pub board: Option<PlanePose>,
    /// Standard deviation of the plane's distance from the camera centre along n_R, mm (from the
    /// board fit; 0 when given).
    pub distance_std_mm: f64,
    /// Standard deviation of the normal's direction, degrees (from the board fit; 0 when given).
    pub tilt_std_deg: f64,
}

impl ReferencePose {
    /// A plane given by a point and a normal (turned towards the camera).
    pub fn given(point: V3, normal: V3) -> Option<ReferencePose> {
        let mut n = normalize(normal)?;
        if super::linalg::dot(n, point) > 0.0 {
            n = scale(n, -1.0);
        }
        (super::linalg::dot(n, point).abs() > 1e-6).then_some(ReferencePose { point, normal: n, board: None, distance_std_mm: 0.0, tilt_std_deg: 0.0 })
    }

    /// The plane of a board seen by the calibrated `lens`, moved by `offset_mm` along the normal
    /// away from the camera (the board's thickness when it lies on the reference surface: the
    /// printed face is `offset_mm` in front of the surface).
    pub fn from_board(lens: &Lens, board: &Board, corners: &[[f64; 2]], offset_mm: f64) -> Result<ReferencePose, PoseError> {
        let pose = board_pose(lens, board, corners)?;
        let n = pose.normal();
        let point = add(pose.point(), scale(n, -offset_mm));
        // σ of the distance n·O: the translation's covariance along n; tilt: the rotation's
        // covariance perpendicular to n.
        let c = &pose.covariance;
        let mut var_d = 0.0;
        for i in 0..3 {
            for j in 0..3 {
                var_d += n[i] * c[(3 + i) * 6 + 3 + j] * n[j];
            }
        }
        let var_rot: f64 = (0..3).map(|i| c[i * 6 + i]).sum::<f64>();
        let var_about_n: f64 = (0..3).flat_map(|i| (0..3).map(move |j| (i, j))).map(|(i, j)| n[i] * c[i * 6 + j] * n[j]).sum();
        let tilt = (var_rot - var_about_n).max(0.0).sqrt().to_degrees();
        Ok(ReferencePose { point, normal: n, board: Some(pose), distance_std_mm: var_d.max(0.0).sqrt(), tilt_std_deg: tilt })
    }
}
