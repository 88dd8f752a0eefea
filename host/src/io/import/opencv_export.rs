//! A fringe3d calibration with its `[projector]` written as an OpenCV stereo `cv::FileStorage`
//! YAML file ([`export_opencv_stereo`]), which [`super::import_rig`] reads back exactly.

use std::fmt::Write as _;
use std::path::Path;

use crate::io::atomic::write_atomic;
use crate::io::calibration::Calibration;
use crate::io::error::FormatError;
use fringe3d_core::params::CameraParams;

/// A float in its shortest exact form (`{:?}` always has a `.` or an exponent).
fn num(v: f64) -> String {
    format!("{v:?}")
}

fn matrix(s: &mut String, key: &str, rows: usize, cols: usize, data: &[f64]) {
    let parts: Vec<String> = data.iter().map(|&x| num(x)).collect();
    let _ = writeln!(
        s,
        "{key}: !!opencv-matrix\n   rows: {rows}\n   cols: {cols}\n   dt: d\n   data: [ {} ]",
        parts.join(", ")
    );
}

fn k_matrix(c: &CameraParams) -> [f64; 9] {
    [c.fx, c.skew * c.fx, c.cx, 0.0, c.fy, c.cy, 0.0, 0.0, 1.0]
}

/// The YAML text of [`export_opencv_stereo`].
pub fn opencv_stereo_yaml(cal: &Calibration) -> Result<String, String> {
    let p = cal.projector.as_ref().ok_or(
        "no [projector] section: an OpenCV stereo file needs the projector's intrinsics and pose",
    )?;
    let r = p.rotation; // X_cam = r·X_proj + P
    // OpenCV: x_proj = R·x_cam + T with R = rᵀ, T = −rᵀ·P.
    let rcv = [
        r[0][0], r[1][0], r[2][0], r[0][1], r[1][1], r[2][1], r[0][2], r[1][2], r[2][2],
    ];
    let c = cal.projector_centre;
    let t = [
        -(rcv[0] * c[0] + rcv[1] * c[1] + rcv[2] * c[2]),
        -(rcv[3] * c[0] + rcv[4] * c[1] + rcv[5] * c[2]),
        -(rcv[6] * c[0] + rcv[7] * c[1] + rcv[8] * c[2]),
    ];
    let mut s = String::from(
        "%YAML:1.0\n---\n\
         # fringe3d calibrate export: an OpenCV stereo calibration (cv::stereoCalibrate's keys).\n\
         # Camera 1 (M1, D1) is the camera, camera 2 (M2, D2) the projector; x2 = R*x1 + T maps a\n\
         # point from the camera's frame to the projector's, millimetres. K[0][1] = skew * fx;\n\
         # distortion [k1, k2, p1, p2, k3]; pixel centres at integers (OpenCV's convention).\n\
         # The fringe3d_* keys hold the exact skews, projector centre P = -R^T*T and depth range\n\
         # for a lossless re-import (`fringe3d calibrate import`); OpenCV ignores them.\n",
    );
    let cam = &cal.camera;
    let pr = &p.intrinsics;
    let _ = writeln!(
        s,
        "image_width: {}\nimage_height: {}",
        cam.width, cam.height
    );
    let _ = writeln!(
        s,
        "projector_width: {}\nprojector_height: {}",
        pr.width, pr.height
    );
    matrix(&mut s, "M1", 3, 3, &k_matrix(cam));
    matrix(&mut s, "D1", 1, 5, &cam.distortion.to_array());
    matrix(&mut s, "M2", 3, 3, &k_matrix(pr));
    matrix(&mut s, "D2", 1, 5, &pr.distortion.to_array());
    matrix(&mut s, "R", 3, 3, &rcv);
    matrix(&mut s, "T", 3, 1, &t);
    matrix(&mut s, "fringe3d_projector_centre", 3, 1, &c);
    matrix(&mut s, "fringe3d_skew", 2, 1, &[cam.skew, pr.skew]);
    matrix(&mut s, "fringe3d_depth_range", 2, 1, &cal.depth_range);
    Ok(s)
}

/// Write `cal` (which must have a `[projector]` section) as an OpenCV stereo YAML file at `path`,
/// atomically: `M1 D1` the camera, `M2 D2` the projector, `R T` with `x_proj = R·x_cam + T`,
/// image sizes (`image_width`/`image_height`, `projector_width`/`projector_height`) and the
/// `fringe3d_projector_centre`, `fringe3d_skew` and `fringe3d_depth_range` keys that make the
/// re-import exact. The reference plane is not exported.
pub fn export_opencv_stereo(cal: &Calibration, path: &Path) -> Result<(), FormatError> {
    cal.validate().map_err(|m| FormatError::invalid(path, m))?;
    let text = opencv_stereo_yaml(cal).map_err(|m| FormatError::invalid(path, m))?;
    write_atomic(path, |w| w.write_all(text.as_bytes()))?;
    Ok(())
}
