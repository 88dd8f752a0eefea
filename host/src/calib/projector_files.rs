//! `calibrate projector` on files: one folder per board pose (or plate position) in; the full
//! projector model ([`projector_model`]) and the calibration file's content out. When the poses
//! are parallel plates (paper §7), P is also estimated by the line method of
//! [`projector_centre`] as a second, independent method, and the two are compared.

use super::corners::{Board, DetectOptions};
use super::files::{Progress, input, load_plate};
use super::lens::Lens;
use super::projector_centre::{self, ProjectorCentre, ProjectorOptions, check_parallel};
use super::projector_coords::{PhaseMap, corner_coords};
use super::projector_model::{self, ModelOptions, ProjectorModel, RigView};
use super::{CalibError, pose};
use crate::io::calibration::{Calibration, CameraParams};
use crate::io::pattern_file::PatternSetFile;
use crate::math::Vec3;
use fringe3d_core::pattern::PatternSet;
use fringe3d_core::phase_function::Axis;
use serde_json::json;
use std::path::{Path, PathBuf};

/// Options of [`calibrate_projector_files`].
#[derive(Clone, Copy, Debug)]
pub struct ProjectorFileOptions {
    /// The line method's options (parallel plates only).
    pub lines: ProjectorOptions,
    /// The full model's options.
    pub model: ModelOptions,
    /// Radius of the window around each corner over which the phases are interpolated, camera
    /// pixels ([`super::projector_coords::local_phase`]).
    pub corner_radius: usize,
}

impl Default for ProjectorFileOptions {
    fn default() -> Self {
        ProjectorFileOptions {
            lines: ProjectorOptions::default(),
            model: ModelOptions::default(),
            corner_radius: 5,
        }
    }
}

/// The result of [`calibrate_projector_files`].
#[derive(Clone, Debug)]
pub struct ProjectorRun {
    /// The full projector model; its centre is the calibration's P.
    pub model: ProjectorModel,
    /// P by the line method of §7 (parallel plates only).
    pub lines: Option<ProjectorCentre>,
    /// Why the line method was not run (poses not parallel).
    pub lines_skipped: Option<String>,
    /// The calibration file's content (camera, projector, P, depth range; no reference yet).
    pub calibration: Calibration,
    /// Per pose: folder, plane, board RMS, valid phase fractions, corners with projector
    /// coordinates.
    pub plates: Vec<serde_json::Value>,
}

impl ProjectorRun {
    /// `|P_model − P_lines|`, mm, and the combined σ along that difference (both methods'
    /// covariances), when both ran.
    pub fn agreement(&self) -> Option<(f64, f64)> {
        let l = self.lines.as_ref()?;
        let d = self.model.translation - Vec3::from_array(l.center);
        let n = d.norm();
        let u = d * (1.0 / n.max(1e-300));
        let c = |m: &[f64; 9]| -> f64 {
            (0..3)
                .map(|i| (0..3).map(|j| u[i] * m[i * 3 + j] * u[j]).sum::<f64>())
                .sum()
        };
        Some((
            n,
            (c(&self.model.covariance_translation) + c(&l.covariance))
                .max(0.0)
                .sqrt(),
        ))
    }
}

/// Check that two pattern-set files are a vertical (phase along ξ) and a horizontal (along η) set,
/// and return them.
fn load_sets(set_v: &Path, set_h: &Path) -> Result<(PatternSet, PatternSet), CalibError> {
    let sv = PatternSetFile::load(set_v)?.to_pattern_set()?;
    let sh = PatternSetFile::load(set_h)?.to_pattern_set()?;
    if sv.axis() != Axis::Xi {
        return Err(input(
            set_v,
            "this pattern set has its phase along η (horizontal fringes); --patterns-v needs vertical fringes (phase along ξ)",
        ));
    }
    if sh.axis() != Axis::Eta {
        return Err(input(
            set_h,
            "this pattern set has its phase along ξ (vertical fringes); --patterns-h needs horizontal fringes (phase along η)",
        ));
    }
    for (set, path) in [(&sv, set_v), (&sh, set_h)] {
        if set.binarization().is_binary() {
            return Err(input(
                path,
                "a binary pattern set: projector calibration decodes without a model of the \
                 projector's blur, which binary sets need; calibrate with a gray-level or \
                 Gray-code set (docs/binary.md)",
            ));
        }
    }
    let (a, b) = (sv.output(), sh.output());
    if (a.width, a.height) != (b.width, b.height) {
        return Err(input(
            set_h,
            format!(
                "a {}x{} projector, but {} is for {}x{}",
                b.width,
                b.height,
                set_v.display(),
                a.width,
                a.height
            ),
        ));
    }
    Ok((sv, sh))
}

/// Calibrate the projector from pose folders (see [`load_plate`]: `v/`, `h/`, `board.png`) with
/// a calibrated camera, and build the calibration file's content. `depth_range` defaults to the
/// board corners' z range padded by 10 % of its span.
#[allow(clippy::too_many_arguments)]
pub fn calibrate_projector_files(
    camera: &CameraParams,
    plate_dirs: &[PathBuf],
    set_v: &Path,
    set_h: &Path,
    board: &Board,
    detect_opts: &DetectOptions,
    opts: &ProjectorFileOptions,
    depth_range: Option<[f64; 2]>,
    progress: Progress<'_>,
) -> Result<ProjectorRun, CalibError> {
    let (sv, sh) = load_sets(set_v, set_h)?;
    let lens = Lens::from_model(camera);
    // The boards' corners with the camera's distortion straightened out of their windows.
    let detect_opts = &DetectOptions {
        lens: Some(lens),
        ..*detect_opts
    };
    if plate_dirs.len() < 2 {
        return Err(CalibError::Input {
            what: "projector calibration".into(),
            message: format!(
                "{} pose folder(s) given; at least two are needed (paper §7)",
                plate_dirs.len()
            ),
        });
    }
    let mut plates = Vec::new();
    let mut corners = Vec::new();
    let mut views = Vec::new();
    for d in plate_dirs {
        let (p, c) = load_plate(d, &lens, board, set_v, set_h, detect_opts)?;
        let (width, height) = (p.width, p.height);
        let mv = PhaseMap {
            width,
            height,
            phase: &p.phase_v,
        };
        let mh = PhaseMap {
            width,
            height,
            phase: &p.phase_h,
        };
        let cc = corner_coords(&mv, &mh, &sv, &sh, &c, opts.corner_radius);
        views.push(RigView {
            name: p.name.clone(),
            corners: c.clone(),
            projector: cc.coords,
        });
        plates.push(p);
        corners.push(c);
        progress(1);
    }
    let out = sv.output();
    let model =
        projector_model::calibrate(board, &lens, (out.width, out.height), &views, &opts.model)?;
    // The line method, when the poses are parallel plates.
    let (lines, lines_skipped) = match check_parallel(&plates, opts.lines.max_plate_angle_deg) {
        Ok(angles) => {
            let r =
                if opts.lines.translated {
                    let (poses, cov) = pose::translated_board_poses(&lens, board, &corners)
                        .map_err(|e| CalibError::Degenerate {
                            what: format!("joint board fit of the plate positions: {e}"),
                        })?;
                    // The joint poses replace the independent ones (the summary reports them).
                    for (p, q) in plates.iter_mut().zip(poses) {
                        p.pose = q;
                    }
                    projector_centre::estimate(&lens, &plates, &opts.lines, Some(&cov))
                } else {
                    projector_centre::estimate(&lens, &plates, &opts.lines, None)
                };
            match r {
                Ok(mut r) => {
                    r.plate_angles_deg = angles;
                    (Some(r), None)
                }
                Err(e) => (None, Some(format!("the line method failed: {e}"))),
            }
        }
        Err(e) => (None, Some(e.to_string())),
    };
    let dr = depth_range.unwrap_or_else(|| {
        let obj = board.object_points();
        let (mut a, mut b) = (f64::INFINITY, f64::NEG_INFINITY);
        for v in &model.views {
            for o in &obj {
                let z = (v.rotation.mul_vec(Vec3::new(o[0], o[1], 0.0)) + v.translation)[2];
                a = a.min(z);
                b = b.max(z);
            }
        }
        let pad = 0.1 * (b - a).max(10.0);
        [(a - pad).max(1.0), b + pad]
    });
    let params = model.params();
    let calibration = Calibration {
        version: 1,
        camera: model.camera.to_model(),
        projector_centre: params.translation,
        reference: None,
        depth_range: dr,
        projector: Some(params),
        projector_response: None,
        projector_defocus: None,
        camera_covariance: model.covariance_camera,
        sensor: None,
    };
    calibration.validate().map_err(|m| CalibError::Degenerate {
        what: format!("the resulting calibration: {m}"),
    })?;
    let summary = plates
        .iter()
        .zip(&views)
        .zip(&corners)
        .map(|((p, v), c)| {
            let frac = |m: &[f32]| m.iter().filter(|x| x.is_finite()).count() as f64 / m.len().max(1) as f64;
            let lit = v.projector.iter().filter(|x| x.is_some()).count();
            // The plate pose's σ with the held camera's uncertainty when known.
            let pose = match &opts.model.camera_covariance {
                Some(cc) if !opts.model.refine_camera => p.pose.clone().with_camera(&lens, board, c, cc),
                _ => p.pose.clone(),
            };
            json!({"plate": p.name, "plane_point": p.pose.point(), "plane_normal": p.pose.normal(), "board_rms_px": p.pose.rms,
                   "pose_std": pose.std(), "distance_std_mm": pose.distance_std(), "tilt_std_deg": pose.tilt_std_deg(),
                   "distance_mm": p.pose.normal().dot(p.pose.point()).abs(),
                   "valid_v": frac(&p.phase_v), "valid_h": frac(&p.phase_h),
                   "corners_with_projector_coordinates": lit})
        })
        .collect();
    Ok(ProjectorRun {
        model,
        lines,
        lines_skipped,
        calibration,
        plates: summary,
    })
}
