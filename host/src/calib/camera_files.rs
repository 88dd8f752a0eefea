//! The camera's calibration files: the OpenCV-style YAML and the report that
//! `fringe3d calibrate camera` writes, and reading a camera (and its covariance) back from any
//! supported file. Every error names the file.

use super::camera::{CameraCalibration, Rejected, View};
use super::corners::{Board, Image};
use super::report::{nice_scale, view_picture};
use super::{CalibError, input};
use crate::io::calibration::{Calibration, CameraCovariance, CameraParams};
use crate::io::image::read_gray;
use crate::io::import::import_any_camera;
use rayon::prelude::*;
use serde_json::json;
use std::path::{Path, PathBuf};

/// Read an image for corner detection.
pub fn load_image(path: &Path) -> Result<Image, CalibError> {
    let (g, _) = read_gray(path)?;
    Ok(Image::from_gray(&g))
}

/// The views found in a set of board images.
#[derive(Clone, Debug)]
pub struct DetectedViews {
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// Views with a board, in image order.
    pub views: Vec<View>,
    /// The image of each view.
    pub images: Vec<PathBuf>,
    /// Images without a usable board, with the reason.
    pub rejected: Vec<Rejected>,
    /// Views whose board looks the same after a half turn (labelling one of two).
    pub half_turn_ambiguous: usize,
}

/// A float for YAML/TOML: the shortest exact form.
fn num(v: f64) -> String {
    format!("{v:?}")
}

/// Write the camera as an OpenCV `cv::FileStorage` YAML file (`camera_matrix` with
/// `K[0][1] = α·fx`, `distortion_coefficients` `[k1, k2, p1, p2, k3]`, image size, RMS), readable
/// by OpenCV and by `import_opencv` (`--camera-from`).
pub fn write_opencv_yaml(
    path: &Path,
    cal: &CameraCalibration,
    board: &Board,
) -> Result<(), CalibError> {
    let p = &cal.lens.p;
    let (ni, nj) = board.inner();
    let text = format!(
        "%YAML:1.0\n---\n# fringe3d calibrate camera. Pixel centres at integers (OpenCV's convention); K[0][1] = skew * fx\n\
         # where skew is alpha of paper eq 4 (u = fx*x + alpha*fx*y + cx).\n\
         image_width: {}\nimage_height: {}\nboard_width: {ni}\nboard_height: {nj}\nsquare_size: {}\nnr_of_frames: {}\n\
         camera_matrix: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n   data: [ {}, {}, {}, 0., {}, {}, 0., 0., 1. ]\n\
         distortion_coefficients: !!opencv-matrix\n   rows: 5\n   cols: 1\n   dt: d\n   data: [ {}, {}, {}, {}, {} ]\n\
         avg_reprojection_error: {}\n\
         # fringe3d: the covariance of [fx, fy, skew, cx, cy, k1, k2, p1, p2, k3] (skew = alpha),\n\
         # for calibrate projector / reference to add the camera's uncertainty to theirs.\n\
         intrinsics_covariance: !!opencv-matrix\n   rows: 10\n   cols: 10\n   dt: d\n   data: [ {} ]\n",
        cal.lens.width,
        cal.lens.height,
        num(board.square),
        cal.views.len(),
        num(p[0]),
        num(p[2] * p[0]),
        num(p[3]),
        num(p[1]),
        num(p[4]),
        num(p[5]),
        num(p[6]),
        num(p[7]),
        num(p[8]),
        num(p[9]),
        num(cal.rms),
        cal.covariance
            .iter()
            .map(|&x| num(x))
            .collect::<Vec<_>>()
            .join(", "),
    );
    crate::io::atomic::write_atomic(path, |w| w.write_all(text.as_bytes()))
        .map_err(|e| input(path, e.to_string()))
}

/// Write `report.json` and one PNG per used view (corners, residuals magnified) into `dir`.
/// Returns the report.
pub fn write_camera_report(
    dir: &Path,
    cal: &CameraCalibration,
    dv: &DetectedViews,
    board: &Board,
) -> Result<serde_json::Value, CalibError> {
    std::fs::create_dir_all(dir).map_err(|e| input(dir, format!("cannot create: {e}")))?;
    let mut all: Vec<f64> = cal
        .views
        .iter()
        .flat_map(|v| {
            v.residuals
                .iter()
                .map(|r| (r[0] * r[0] + r[1] * r[1]).sqrt())
        })
        .collect();
    all.sort_by(f64::total_cmp);
    let p95 = all
        .get(((all.len().max(1) - 1) as f64 * 0.95) as usize)
        .cloned()
        .unwrap_or(0.0);
    let scale = nice_scale(p95, 15.0);
    let pics: Vec<Result<String, CalibError>> = cal
        .views
        .par_iter()
        .map(|v| {
            let src = dv
                .images
                .iter()
                .find(|p| p.display().to_string() == v.name)
                .cloned()
                .unwrap_or_else(|| PathBuf::from(&v.name));
            let img = load_image(&src)?;
            let stem = src
                .file_stem()
                .and_then(|s| s.to_str())
                .unwrap_or("view")
                .to_string();
            let name = format!("view_{stem}.png");
            let c = view_picture(
                img.width,
                img.height,
                &img.data,
                &v.corners,
                &v.residuals,
                scale,
            );
            c.save(&dir.join(&name))
                .map_err(|m| input(&dir.join(&name), m))?;
            Ok(name)
        })
        .collect();
    let pics: Vec<String> = pics.into_iter().collect::<Result<_, _>>()?;
    let mut j = cal.to_json();
    j["board"] = json!({"cols": board.cols, "rows": board.rows, "square_mm": board.square, "inner_corners": [board.inner().0, board.inner().1]});
    j["pictures"] = json!({"files": pics, "residual_scale": scale, "scale_bar_px": 0.1,
        "legend": "green +: detected corner; red arrow: reprojection residual (projected - detected) x residual_scale; cyan ring: corner (0, 0); yellow bar: 0.1 px x residual_scale"});
    j["half_turn_ambiguous_views"] = json!(dv.half_turn_ambiguous);
    let text = serde_json::to_string_pretty(&j).unwrap_or_default();
    let rp = dir.join("report.json");
    crate::io::atomic::write_atomic(&rp, |w| w.write_all(text.as_bytes()))
        .map_err(|e| input(&rp, e.to_string()))?;
    super::report::write_corners_json(dir, board, (dv.width, dv.height), &dv.views, cal)
        .map_err(|m| input(&dir.join("corners.json"), m))?;
    Ok(j)
}

/// A camera model from a file: a fringe3d calibration (`.toml`, its `[camera]`), an OpenCV
/// `cv::FileStorage` file (`.yml`, `.yaml`, `.xml`, `.json`), Bouguet's `Calib_Results.m`, or
/// camera 1 of a full calibration from another tool (OpenCV stereo, SLStudio, SLMaster, Bouguet's
/// `Calib_Results_stereo.m`; see [`crate::io::import::import_any_camera`]). `size` (the images'
/// size) fills in a size the file does not state and is checked against one it does.
pub fn load_camera(path: &Path, size: Option<(u32, u32)>) -> Result<CameraParams, CalibError> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .unwrap_or("")
        .to_ascii_lowercase();
    let cam = match ext.as_str() {
        "toml" => Calibration::load(path)?.camera,
        "m" | "yml" | "yaml" | "xml" | "json" => import_any_camera(path, size)?,
        _ => {
            return Err(input(
                path,
                "unknown camera file type: use a fringe3d calibration (.toml), an OpenCV, SLStudio or SLMaster file (.yml, .yaml, .xml, .json) or Bouguet's Calib_Results.m / Calib_Results_stereo.m",
            ));
        }
    };
    if let Some((w, h)) = size
        && (cam.width, cam.height) != (w, h)
    {
        return Err(input(
            path,
            format!(
                "the camera was calibrated for {}x{} images, these are {w}x{h}",
                cam.width, cam.height
            ),
        ));
    }
    Ok(cam)
}

/// The covariance of the camera's intrinsics a camera file holds, if any: a fringe3d
/// calibration's `[camera_covariance]`, or the `intrinsics_covariance` of `calibrate camera`'s
/// OpenCV file; `None` for files without one (other tools' files).
pub fn load_camera_covariance(path: &Path) -> Result<Option<CameraCovariance>, CalibError> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .unwrap_or("")
        .to_ascii_lowercase();
    Ok(match ext.as_str() {
        "toml" => Calibration::load(path)?.camera_covariance,
        "yml" | "yaml" | "xml" | "json" => crate::io::import::import_opencv_covariance(path)?,
        _ => None,
    })
}
