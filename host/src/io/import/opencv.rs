//! OpenCV `cv::FileStorage` camera files ([`import_opencv`]).

use std::path::Path;

use super::filestorage::{Node, matrix_values, parse_filestorage};
use crate::io::calibration::{COVARIANCE_ORDER, CameraCovariance};
use crate::io::camera_check::validate_camera;
use crate::io::error::{FormatError, read_text};
use fringe3d_core::params::CameraParams;

/// A camera model from an OpenCV `cv::FileStorage` file — YAML (`%YAML:1.0`, `!!opencv-matrix`
/// maps of `rows`/`cols`/`dt`/`data`), XML (`<opencv_storage>`, `type_id="opencv-matrix"`) or
/// JSON — as written by OpenCV's calibration sample and `calibrateCamera` users.
///
/// Keys (first found wins): the camera matrix `camera_matrix` (or `cameraMatrix`, `K`, and camera
/// 1's `M1`, `cameraMatrix1`, `Kc` of a camera-only file with stereo-style names), the distortion
/// `distortion_coefficients` (or `dist_coeffs`, `distCoeffs`, `D`, `D1`, `distCoeffs1`, `kc`).
/// The camera matrix must be `[fx s cx; 0 fy cy; 0 0 1]`; `skew = s / fx`. Distortion may have 4
/// (`k3 = 0`), 5, 8, 12 or 14 coefficients; beyond the fifth (`k4 k5 k6 s1 s2 s3 s4 τx τy`) all
/// must be zero, as fringe3d's model has only `[k1, k2, p1, p2, k3]`. `image_width`/`image_height`, if present,
/// override `width`/`height`. OpenCV's pixel convention is ours. The result is validated.
pub fn import_opencv(path: &Path, width: u32, height: u32) -> Result<CameraParams, FormatError> {
    let text = read_text(path)?;
    let root = parse_filestorage(&text).map_err(|m| FormatError::parse(path, m))?;
    opencv_camera(&root, width, height).map_err(|m| FormatError::invalid(path, m))
}

/// The covariance of the camera's intrinsics an OpenCV `cv::FileStorage` camera file holds
/// under `intrinsics_covariance` (fringe3d's own key: a 10 × 10 matrix over `[fx, fy, skew, cx,
/// cy, k1, k2, p1, p2, k3]`, as `calibrate camera` writes it), validated; `None` when the file
/// has none (OpenCV's own files never do).
pub fn import_opencv_covariance(path: &Path) -> Result<Option<CameraCovariance>, FormatError> {
    let text = read_text(path)?;
    let root = parse_filestorage(&text).map_err(|m| FormatError::parse(path, m))?;
    let Some(node) = root.get("intrinsics_covariance") else {
        return Ok(None);
    };
    let v = matrix_values(node)
        .map_err(|m| FormatError::invalid(path, format!("intrinsics_covariance: {m}")))?;
    let flat: [f64; 100] = v.as_slice().try_into().map_err(|_| {
        FormatError::invalid(
            path,
            format!(
                "intrinsics_covariance has {} values, expected 100 (10x10 over {})",
                v.len(),
                COVARIANCE_ORDER.join(", ")
            ),
        )
    })?;
    let c = CameraCovariance::from_flat(&flat);
    c.validate().map_err(|m| FormatError::invalid(path, m))?;
    Ok(Some(c))
}

fn opencv_camera(root: &Node, width: u32, height: u32) -> Result<CameraParams, String> {
    let find = |names: &[&'static str]| names.iter().find_map(|&n| root.get(n).map(|v| (n, v)));
    let (kname, k) = find(&[
        "camera_matrix",
        "cameraMatrix",
        "K",
        "M1",
        "cameraMatrix1",
        "Kc",
    ])
    .ok_or("no camera matrix (looked for camera_matrix, cameraMatrix, K, M1, cameraMatrix1, Kc)")?;
    let k = matrix_values(k).map_err(|m| format!("{kname}: {m}"))?;
    if k.len() != 9 {
        return Err(format!("{kname} has {} values, expected 9 (3x3)", k.len()));
    }
    let zero_ok = |i: usize, want: f64| (k[i] - want).abs() <= 1e-9;
    if !(zero_ok(3, 0.0) && zero_ok(6, 0.0) && zero_ok(7, 0.0) && zero_ok(8, 1.0)) {
        return Err(format!(
            "{kname} must have the form [fx s cx; 0 fy cy; 0 0 1], got [{} {} {}; {} {} {}; {} {} {}]",
            k[0], k[1], k[2], k[3], k[4], k[5], k[6], k[7], k[8]
        ));
    }
    let (dname, d) = find(&[
        "distortion_coefficients",
        "dist_coeffs",
        "distCoeffs",
        "D",
        "D1",
        "distCoeffs1",
        "kc",
    ])
    .ok_or("no distortion coefficients (looked for distortion_coefficients, dist_coeffs, distCoeffs, D, D1, distCoeffs1, kc)")?;
    let d = matrix_values(d).map_err(|m| format!("{dname}: {m}"))?;
    if ![4, 5, 8, 12, 14].contains(&d.len()) {
        return Err(format!(
            "{dname} has {} values; OpenCV writes 4, 5, 8, 12 or 14",
            d.len()
        ));
    }
    const EXTRA: [&str; 9] = ["k4", "k5", "k6", "s1", "s2", "s3", "s4", "tau_x", "tau_y"];
    for (i, &v) in d.iter().enumerate().skip(5) {
        if v != 0.0 {
            return Err(format!(
                "{dname} has {} values and {} = {v} is not zero: fringe3d's model has only [k1, k2, p1, p2, k3]; \
                 calibrate without the rational, thin-prism and tilted models",
                d.len(),
                EXTRA[i - 5]
            ));
        }
    }
    let mut dist = [0.0; 5];
    for (o, v) in dist.iter_mut().zip(&d) {
        *o = *v;
    }
    let size = |name: &str, default: u32| -> Result<u32, String> {
        match root.get(name) {
            None => Ok(default),
            Some(Node::Scalar(s)) => s
                .trim()
                .parse::<u32>()
                .ok()
                .filter(|&v| v > 0)
                .ok_or_else(|| format!("{name} must be a positive integer, got `{s}`")),
            Some(_) => Err(format!("{name} must be a positive integer")),
        }
    };
    let fx = k[0];
    let cam = CameraParams {
        width: size("image_width", width)?,
        height: size("image_height", height)?,
        fx,
        fy: k[4],
        skew: if fx != 0.0 { k[1] / fx } else { f64::NAN },
        cx: k[2],
        cy: k[5],
        distortion: dist.into(),
    };
    validate_camera(&cam)?;
    Ok(cam)
}
