//! The calibration demo (`fringe3d demo --calibrate`): render the calibration datasets of the
//! default rig, run the three calibrations on the files as a user would, compare every estimate
//! with the renderer's truth, and (optionally) scan the sphere and ball-bar scenes with the true and
//! with the self-calibrated file (VDI/VDE 2634-2 style sphere-diameter and ball-bar-length errors).

use crate::accuracy::{self, Accuracy};
use crate::calib::camera::CameraOptions;
use crate::calib::corners::{Board, DetectOptions};
use crate::calib::files::{self, PlaneSource};
use crate::calib::lens::{Lens, PARAM_NAMES};
use crate::calib::linalg::{nearest_rotation, rot_log};
use crate::calib::projector_files::{self, ProjectorFileOptions};
use crate::io::calibration::Calibration;
use crate::io::image::{write_png_u8, write_png_u16};
use crate::math::{Mat3, Vec3};
use crate::render::dataset::{DatasetOptions, write_dataset};
use crate::render::objects::Geometry;
use crate::render::scene::{Overrides, Pose, SceneSpec};
use crate::render::{RenderOptions, Scene, Slide};
use crate::scan::ScanCalibration;
use anyhow::{Context, Result};
use serde_json::{Value, json};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Options of [`demo_calibrate_with`].
#[derive(Clone, Copy, Debug)]
pub struct DemoOptions {
    /// Camera image size (same field of view); `None`: the default rig's 1280 × 1024.
    pub size: Option<(u32, u32)>,
    /// Camera noise σ, gray levels (`None`: the scenes' default, noise-free).
    pub noise: Option<f64>,
    /// Camera bit depth (`None`: 16).
    pub bits: Option<u8>,
    /// Noise seed.
    pub seed: Option<u64>,
    /// Checkerboard views.
    pub views: usize,
    /// Samples per pixel side of the board images (`None`: the renderer's default).
    pub board_supersample: Option<u32>,
    /// `calibrate projector` with the rig's measurement volume as the depth range (as a user states
    /// it with `--depth-range`); `false`: the default from the plates' z range.
    pub volume_depth_range: bool,
    /// Also render and scan the sphere and ball-bar scenes with both calibrations.
    pub end_to_end: bool,
    /// Print nothing.
    pub quiet: bool,
}

impl Default for DemoOptions {
    fn default() -> Self {
        DemoOptions {
            size: None,
            noise: None,
            bits: None,
            seed: None,
            views: 15,
            board_supersample: None,
            volume_depth_range: true,
            end_to_end: true,
            quiet: true,
        }
    }
}

/// Render the calibration datasets with the default rig into `work_dir`, run `calibrate camera`,
/// `calibrate projector` and `calibrate reference` on them, scan the sphere and ball-bar scenes
/// with the true and the self-calibrated file, and return the calibration file's path and a
/// report (every estimate against the truth; scan accuracy with both calibrations).
pub fn demo_calibrate(work_dir: &Path, quiet: bool) -> Result<(PathBuf, Value)> {
    demo_calibrate_with(
        work_dir,
        &DemoOptions {
            quiet,
            ..DemoOptions::default()
        },
    )
}

fn board_of(spec: &SceneSpec) -> Result<Board> {
    let b = spec.board.as_ref().context("the scene has no board")?;
    Board::new(b.cols, b.rows, b.square).map_err(anyhow::Error::msg)
}

/// The calibration data of the default rig as [`render_calibration_data`] writes them: what a user
/// photographs before `fringe3d calibrate`.
#[derive(Clone, Debug)]
pub struct CalibrationData {
    /// Checkerboard views (`img_NN.png`, `truth/corners.json`).
    pub checkerboard: PathBuf,
    /// The checkerboard views' board.
    pub checkerboard_board: Board,
    /// Plate positions: `plate_NN/{v,h,board.png}`, `patterns_v.toml`, `patterns_h.toml`.
    pub plates: PathBuf,
    /// The plate folders, sorted.
    pub plate_dirs: Vec<PathBuf>,
    /// The board printed on the plate.
    pub plate_board: Board,
    /// The reference plane's fringe set (`img_NN.png`, `patterns.toml`).
    pub reference: PathBuf,
    /// Images of the checkerboard lying on the reference plane (three places, turned in the plane).
    pub reference_boards: Vec<PathBuf>,
    /// The rig the data were rendered with (the truth).
    pub rig: crate::render::rig::Rig,
}

fn scene_with(name: &str, o: &DemoOptions, views: Option<usize>) -> Result<Scene> {
    let ov = Overrides {
        seed: o.seed,
        noise: o.noise,
        bits: o.bits,
        size: o.size,
        ..Overrides::default()
    };
    let mut s = SceneSpec::builtin(name)?;
    s.apply(&ov);
    if let Some(b) = s.board.as_mut() {
        if let Some(n) = views {
            b.count = n as u32;
        }
        if let Some(ss) = o.board_supersample {
            b.supersample = ss;
        }
    }
    Ok(Scene::new(s, None)?)
}

fn render_into(sc: &Scene, dir: &Path) -> Result<()> {
    write_dataset(
        sc,
        dir,
        DatasetOptions {
            overwrite: true,
            progress: None,
        },
    )
    .with_context(|| format!("rendering {}", dir.display()))?;
    Ok(())
}

/// Render the calibration data of the default rig (with `o`'s size, noise, bit depth, seed, views
/// and board supersampling) into `work_dir`: `checkerboard/`, `plates/` and `reference/` (with
/// `board_0.png` … `board_2.png`, the board lying on the reference plane).
pub fn render_calibration_data(work_dir: &Path, o: &DemoOptions) -> Result<CalibrationData> {
    let say = |s: &str| {
        if !o.quiet {
            eprintln!("{s}");
        }
    };
    std::fs::create_dir_all(work_dir)
        .with_context(|| format!("{}: cannot create", work_dir.display()))?;
    say("calibration demo 1/6: rendering the checkerboard views ...");
    let cb_scene = scene_with("checkerboard", o, Some(o.views))?;
    let cb_dir = work_dir.join("checkerboard");
    render_into(&cb_scene, &cb_dir)?;
    say("calibration demo 2/6: rendering the plate positions and the reference plane ...");
    let pl_scene = scene_with("plates", o, None)?;
    let pl_dir = work_dir.join("plates");
    render_into(&pl_scene, &pl_dir)?;
    let ref_scene = scene_with("reference", o, None)?;
    let ref_dir = work_dir.join("reference");
    render_into(&ref_scene, &ref_dir)?;
    // Three images of a board lying on the reference plane (the checkerboard scene's board, at
    // three places, turned in the plane as a hand-placed board would be), under the projector's
    // white, as a user would photograph them. (A board whose edges run exactly along pixel rows and
    // columns is the one case where the renderer's box-pixel sampling quantizes edge positions to
    // 1/16 px along whole edges, a 0.05 px corner bias.)
    let rig = ref_scene.rig.clone();
    let mut bspec = cb_scene
        .spec
        .board
        .clone()
        .context("checkerboard scene without a board")?;
    if let Some(ss) = o.board_supersample {
        bspec.supersample = ss;
    }
    let mut sensor = ref_scene.spec.camera.sensor();
    sensor.supersample = bspec.supersample;
    sensor.edge_supersample = sensor.edge_supersample.max(16).max(bspec.supersample);
    let mut ref_boards = Vec::new();
    for (k, (dx, dy, rot)) in [(0.0, 0.0, 8.0), (-70.0, -40.0, -6.0), (70.0, 40.0, 14.0)]
        .into_iter()
        .enumerate()
    {
        let o = rig.reference_point;
        let ref_pose = Pose {
            center: [o[0] + dx, o[1] + dy, o[2]],
            euler_deg: [0.0, 0.0, rot],
        };
        let geo = Geometry::build(&[crate::render::board::board_object(
            &bspec,
            &ref_pose,
            None,
            true,
            bspec.light,
        )])
        .map_err(anyhow::Error::msg)?;
        let (frames, _) = ref_scene.render_slides(
            &geo,
            &[Slide::Uniform(1.0)],
            77 + k as u64,
            RenderOptions {
                sensor: Some(sensor),
                ..Default::default()
            },
        )?;
        let path = ref_dir.join(format!("board_{k}.png"));
        if frames.bits == 8 {
            let v: Vec<u8> = frames.images[0].iter().map(|&x| x.min(255) as u8).collect();
            write_png_u8(&path, frames.width, frames.height, &v)?;
        } else {
            write_png_u16(
                &path,
                frames.width,
                frames.height,
                &frames.images[0],
                frames.bits,
            )?;
        }
        ref_boards.push(path);
    }
    let mut plate_dirs: Vec<PathBuf> = std::fs::read_dir(&pl_dir)
        .with_context(|| format!("{}: cannot list", pl_dir.display()))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| {
            p.is_dir()
                && p.file_name()
                    .and_then(|n| n.to_str())
                    .is_some_and(|n| n.starts_with("plate_"))
        })
        .collect();
    plate_dirs.sort();
    Ok(CalibrationData {
        checkerboard: cb_dir,
        checkerboard_board: board_of(&cb_scene.spec)?,
        plates: pl_dir,
        plate_dirs,
        plate_board: board_of(&pl_scene.spec)?,
        reference: ref_dir,
        reference_boards: ref_boards,
        rig,
    })
}

/// [`demo_calibrate`] with options.
pub fn demo_calibrate_with(work_dir: &Path, o: &DemoOptions) -> Result<(PathBuf, Value)> {
    let say = |s: &str| {
        if !o.quiet {
            eprintln!("{s}");
        }
    };
    let t_all = Instant::now();
    let mut times = serde_json::Map::new();
    let mut lap = Instant::now();
    let mut tick = |name: &str, t: &mut Instant| {
        times.insert(name.into(), json!(t.elapsed().as_secs_f64()));
        *t = Instant::now();
    };

    // 1. Datasets.
    let data = render_calibration_data(work_dir, o)?;
    let (cb_dir, pl_dir, ref_dir, rig) =
        (&data.checkerboard, &data.plates, &data.reference, &data.rig);
    tick("render_calibration_data", &mut lap);

    // 2. Camera.
    say("calibration demo 3/6: calibrate camera ...");
    let out_dir = work_dir.join("calibration");
    std::fs::create_dir_all(&out_dir)
        .with_context(|| format!("{}: cannot create", out_dir.display()))?;
    let cb_board = data.checkerboard_board;
    let imgs = files::image_list(std::slice::from_ref(cb_dir))?;
    let (cam, dv) = files::calibrate_camera_files(
        &imgs,
        &cb_board,
        &DetectOptions::default(),
        &CameraOptions::default(),
        &|_| {},
    )?;
    let cam_file = out_dir.join("camera.yml");
    files::write_opencv_yaml(&cam_file, &cam, &cb_board)?;
    files::write_camera_report(&out_dir.join("camera_report"), &cam, &dv, &cb_board)?;
    tick("calibrate_camera", &mut lap);

    // 3. Projector.
    say("calibration demo 4/6: calibrate projector ...");
    let pl_board = data.plate_board;
    let camera = files::load_camera(&cam_file, Some((cam.lens.width, cam.lens.height)))?;
    // As `calibrate projector --camera-from camera.yml` does: with the camera's covariance.
    let mut popts = ProjectorFileOptions::default();
    popts.model.camera_covariance = files::load_camera_covariance(&cam_file)?;
    let pr = projector_files::calibrate_projector_files(
        &camera,
        &data.plate_dirs,
        &pl_dir.join("patterns_v.toml"),
        &pl_dir.join("patterns_h.toml"),
        &pl_board,
        &DetectOptions::default(),
        &popts,
        o.volume_depth_range.then_some(rig.depth_range),
        &|_| {},
    )?;
    let cal_path = out_dir.join("calibration.toml");
    pr.calibration.save(&cal_path)?;
    tick("calibrate_projector", &mut lap);

    // 4. Reference.
    say("calibration demo 5/6: calibrate reference ...");
    let rr = files::calibrate_reference_files(
        &pr.calibration,
        &cal_path,
        &ref_dir.join("patterns.toml"),
        std::slice::from_ref(ref_dir),
        &PlaneSource::Board {
            images: data.reference_boards.clone(),
            board: cb_board,
            offset_mm: 0.0,
        },
        &files::ReferenceOptions {
            detect: DetectOptions::default(),
            map_name: "reference_phase.tif",
            source: files::MapSource::Model,
            flatness_limit_mm: None,
            margin: Some(fringe3d_core::reconstruct::Margin::ZERO),
        },
    )?;
    tick("calibrate_reference", &mut lap);

    // 5. Against the truth.
    let truth_cam = Lens::from_model(&rig.camera_model());
    let mut cam_j = serde_json::Map::new();
    for (k, n) in PARAM_NAMES.iter().enumerate() {
        cam_j.insert(n.to_string(), json!({"estimate": cam.lens.p[k], "std": cam.std[k], "truth": truth_cam.p[k], "error": cam.lens.p[k] - truth_cam.p[k]}));
    }
    let fx_rel = (cam.lens.p[0] - truth_cam.p[0]) / truth_cam.p[0];
    let fy_rel = (cam.lens.p[1] - truth_cam.p[1]) / truth_cam.p[1];
    let pp_err = ((cam.lens.p[3] - truth_cam.p[3]).powi(2)
        + (cam.lens.p[4] - truth_cam.p[4]).powi(2))
    .sqrt();
    let p_true = rig.translation;
    let p_est = pr.calibration.projector_centre;
    let p_err = Vec3::from_array(p_est) - Vec3::from_array(p_true);
    let proj_truth = Lens::from_model(&rig.projector);
    let mut proj_j = serde_json::Map::new();
    for (k, n) in PARAM_NAMES.iter().enumerate() {
        proj_j.insert(n.to_string(), json!({"estimate": pr.model.projector.p[k], "std": pr.model.std_projector[k], "truth": proj_truth.p[k], "error": pr.model.projector.p[k] - proj_truth.p[k]}));
    }
    let lines_p = pr.lines.as_ref().map(|l| json!({"estimate": l.center, "std": l.std, "lines": l.lines,
        "rms_line_distance_mm": l.rms_distance_mm, "error_norm_mm": (Vec3::from_array(l.center) - Vec3::from_array(p_true)).norm()}));
    let n_true = Vec3::from_array(rig.reference_normal);
    let plane_offset = n_true.dot(rr.plane.point - Vec3::from_array(rig.reference_point));
    let plane_angle = n_true
        .dot(rr.plane.normal)
        .clamp(-1.0, 1.0)
        .acos()
        .to_degrees();
    let corner_truth = corner_errors(cb_dir, &dv)?;
    let plates_j = plate_errors(pl_dir, &pr.plates)?;
    let mut report = json!({
        "work_dir": work_dir, "calibration": cal_path,
        "camera": {"parameters": cam_j, "fx_relative_error": fx_rel, "fy_relative_error": fy_rel, "principal_point_error_px": pp_err,
                   "reprojection_rms_px": cam.rms, "sigma_px": cam.sigma, "jackknife_ratio": cam.jackknife_ratio, "views_used": cam.views.len(), "views_rejected": cam.rejected,
                   "corner_error_vs_truth_px": corner_truth},
        "projector": {"estimate": p_est, "truth": p_true, "error": p_err, "error_norm_mm": p_err.norm(),
                      "std": pr.model.std_translation(), "intrinsics": proj_j,
                      "rms_projector_px": pr.model.rms_projector_px, "line_method": lines_p,
                      "depth_range": pr.calibration.depth_range,
                      "depth_range_source": if o.volume_depth_range { "the rig's measurement volume (--depth-range)" } else { "the plates' z range padded by 10 %" }},
        "reference": {"point": rr.plane.point, "normal": rr.plane.normal, "truth_point": rig.reference_point, "truth_normal": n_true,
                      "offset_along_normal_mm": plane_offset, "normal_angle_deg": plane_angle,
                      "distance_std_mm": rr.plane.distance_std_mm, "tilt_std_deg": rr.plane.tilt_std_deg,
                      "valid_fraction": rr.valid_fraction},
        "plates": plates_j,
    });

    // 6. Scans.
    if o.end_to_end {
        say(
            "calibration demo 6/6: scanning the sphere and the ball bar with both calibrations ...",
        );
        let mut scans = Vec::new();
        for name in ["sphere", "ballbar"] {
            let sc = scene_with(name, o, None)?;
            let dir = work_dir.join("scans").join(name);
            render_into(&sc, &dir)?;
            let truth = accuracy::load_truth(&dir)?;
            let c_true = scan_cloud(&dir, &dir.join("calibration.toml"))?;
            let c_self = scan_cloud(&dir, &cal_path)?;
            let a_true = accuracy::evaluate(&c_true, &truth)?;
            let a_self = accuracy::evaluate(&c_self, &truth)?;
            let al_true =
                aligned_error(&c_true, &truth).unwrap_or((f64::NAN, f64::NAN, f64::NAN, f64::NAN));
            let al_self =
                aligned_error(&c_self, &truth).unwrap_or((f64::NAN, f64::NAN, f64::NAN, f64::NAN));
            let al = |a: (f64, f64, f64, f64)| json!({"rms": a.0, "p95": a.1, "rotation_deg": a.2, "translation_mm": a.3});
            let mut st = summary(&a_true);
            st["interior_aligned"] = al(al_true);
            let mut ss = summary(&a_self);
            ss["interior_aligned"] = al(al_self);
            scans.push(json!({"scene": name, "dataset": dir,
                "true_calibration": st, "self_calibration": ss,
                "rms_ratio_interior": a_self.interior.rms / a_true.interior.rms,
                "rms_ratio_interior_aligned": al_self.0 / al_true.0,
                "rms_ratio_all": a_self.all.rms / a_true.all.rms}));
        }
        report["scans"] = json!(scans);
        tick("scans", &mut lap);
    }
    times.insert("total".into(), json!(t_all.elapsed().as_secs_f64()));
    report["seconds"] = Value::Object(times);
    let text = serde_json::to_string_pretty(&report)?;
    crate::io::atomic::write_atomic(&out_dir.join("demo_report.json"), |w| {
        w.write_all(text.as_bytes())
    })?;
    Ok((cal_path, report))
}

/// Each plate's plane against the rendered truth (`truth/plates.json` of the plates dataset):
/// the estimate's offset along the true normal, its angle, and the σ `calibrate projector`
/// reported for its distance.
fn plate_errors(pl_dir: &Path, plates: &[Value]) -> Result<Value> {
    let p = pl_dir.join("truth/plates.json");
    let truth: Value = serde_json::from_str(
        &std::fs::read_to_string(&p).with_context(|| format!("{}: cannot read", p.display()))?,
    )?;
    let v3 = |v: &Value| -> Option<Vec3> {
        let a = v.as_array()?;
        Some(Vec3::new(
            a.first()?.as_f64()?,
            a.get(1)?.as_f64()?,
            a.get(2)?.as_f64()?,
        ))
    };
    let mut out = Vec::new();
    for t in truth["plates"].as_array().into_iter().flatten() {
        let folder = t["folder"].as_str().unwrap_or_default();
        let Some(est) = plates.iter().find(|e| {
            e["plate"]
                .as_str()
                .is_some_and(|n| !folder.is_empty() && (n.ends_with(folder) || folder.ends_with(n)))
        }) else {
            continue;
        };
        let (Some(tp), Some(tn), Some(ep), Some(en)) = (
            v3(&t["plane_point"]),
            v3(&t["plane_normal"]),
            v3(&est["plane_point"]),
            v3(&est["plane_normal"]),
        ) else {
            continue;
        };
        let tn = tn.try_normalized().unwrap_or(tn);
        out.push(
            json!({"plate": est["plate"], "offset_along_normal_mm": tn.dot(ep - tp),
            "normal_angle_deg": tn.dot(en).abs().clamp(-1.0, 1.0).acos().to_degrees(),
            "distance_std_mm": est["distance_std_mm"], "tilt_std_deg": est["tilt_std_deg"]}),
        );
    }
    Ok(json!(out))
}

/// Decode a rendered fringe dataset and reconstruct it with `calibration`, then score it.
pub fn scan_accuracy(
    dataset: &Path,
    calibration: &Path,
    truth: &accuracy::Truth,
) -> Result<Accuracy> {
    let cloud = scan_cloud(dataset, calibration)?;
    accuracy::evaluate(&cloud, truth)
}

/// Decode a rendered fringe dataset (`patterns.toml` and its images) and reconstruct it with
/// `calibration`.
pub fn scan_cloud(dataset: &Path, calibration: &Path) -> Result<crate::scan::PointCloud> {
    let set = dataset.join("patterns.toml");
    let dec = files::decode_set(&set, &[])?;
    let cal = ScanCalibration::load(calibration, dec.axis)?;
    Ok(cal.reconstruct(&dec.phase, &dec.validity, true)?)
}

/// Point errors after the rigid motion that best aligns the cloud with the truth (as the paper's
/// §8 aligns its measurements to the CAD model before comparing): per-pixel distances over the
/// "interior" pixels of [`accuracy::evaluate`] (3 × 3 neighbourhood on one primitive). The motion
/// is fitted (Kabsch/Horn) to the interior points whose unaligned error is below 5 × the median
/// (gross errors at a few pixels would otherwise pull it), and the RMS is over all interior points.
/// Returns (RMS, 95th percentile, rotation angle in degrees, translation in mm).
pub fn aligned_error(
    cloud: &crate::scan::PointCloud,
    truth: &accuracy::Truth,
) -> Option<(f64, f64, f64, f64)> {
    let (w, h) = (truth.width, truth.height);
    if (cloud.width, cloud.height) != (w, h) {
        return None;
    }
    let interior = |i: usize| -> bool {
        let (x, y) = (i % w, i / w);
        if x == 0 || y == 0 || x + 1 >= w || y + 1 >= h {
            return false;
        }
        let id = truth.object_id[i];
        (0..3).all(|dy| {
            (0..3).all(|dx| {
                let j = (y + dy - 1) * w + x + dx - 1;
                truth.object_id[j] == id && truth.points[3 * j].is_finite()
            })
        })
    };
    let mut pairs: Vec<(Vec3, Vec3)> = Vec::new();
    for i in 0..w * h {
        if cloud.validity[i] == 0 && truth.points[3 * i].is_finite() && interior(i) {
            let p = Vec3::new(
                cloud.xyz[3 * i] as f64,
                cloud.xyz[3 * i + 1] as f64,
                cloud.xyz[3 * i + 2] as f64,
            );
            let q = Vec3::new(
                truth.points[3 * i],
                truth.points[3 * i + 1],
                truth.points[3 * i + 2],
            );
            pairs.push((p, q));
        }
    }
    if pairs.len() < 10 {
        return None;
    }
    let mut d0: Vec<f64> = pairs.iter().map(|(p, q)| (*p - *q).norm()).collect();
    d0.sort_by(f64::total_cmp);
    let lim = 5.0 * d0[d0.len() / 2];
    let fit: Vec<&(Vec3, Vec3)> = pairs
        .iter()
        .filter(|(p, q)| (*p - *q).norm() <= lim.max(1e-9))
        .collect();
    let n = fit.len() as f64;
    let mut pc = Vec3::ZERO;
    let mut qc = Vec3::ZERO;
    for (p, q) in &fit {
        for k in 0..3 {
            pc[k] += p[k] / n;
            qc[k] += q[k] / n;
        }
    }
    let mut m = Mat3([[0.0; 3]; 3]);
    for (p, q) in &fit {
        let (a, b) = (*p - pc, *q - qc);
        for i in 0..3 {
            for j in 0..3 {
                m[i][j] += b[i] * a[j];
            }
        }
    }
    let r = nearest_rotation(&m);
    let t = qc - r.mul_vec(pc);
    let mut d: Vec<f64> = pairs
        .iter()
        .map(|(p, q)| (r.mul_vec(*p) + t - *q).norm())
        .collect();
    let rms = (d.iter().map(|x| x * x).sum::<f64>() / d.len() as f64).sqrt();
    d.sort_by(f64::total_cmp);
    let p95 = d[((d.len() - 1) as f64 * 0.95) as usize];
    let angle = rot_log(&r).norm().to_degrees();
    Some((rms, p95, angle, t.norm()))
}

fn summary(a: &Accuracy) -> Value {
    json!({
        "interior": a.interior, "all": a.all, "valid_pixels": a.valid_pixels, "truth_pixels": a.truth_pixels,
        "spheres": a.spheres.iter().map(|s| json!({"name": s.name, "diameter_error_mm": s.diameter_error, "center_error_mm": s.center_error, "form_rms_mm": s.form_rms, "points": s.points})).collect::<Vec<_>>(),
        "ball_bars": a.ball_bars.iter().map(|b| json!({"length_error_mm": b.length_error, "true_length_mm": b.true_length, "measured_length_mm": b.measured_length})).collect::<Vec<_>>(),
    })
}

/// Detected corners against the renderer's true corners (`truth/corners.json`): RMS and max over
/// all used views, pixels. The labelling is matched per view (also under a half turn).
pub fn corner_errors(dataset: &Path, dv: &files::DetectedViews) -> Result<Value> {
    let p = dataset.join("truth/corners.json");
    let j: Value = serde_json::from_str(
        &std::fs::read_to_string(&p).with_context(|| format!("{}: cannot read", p.display()))?,
    )?;
    let mut all = Vec::new();
    for pose in j["poses"].as_array().into_iter().flatten() {
        let name = pose["image"].as_str().unwrap_or("");
        let Some(k) = dv
            .images
            .iter()
            .position(|q| q.file_name().and_then(|n| n.to_str()) == Some(name))
        else {
            continue;
        };
        let t: Vec<[f64; 2]> = pose["corners_px"]
            .as_array()
            .into_iter()
            .flatten()
            .map(|c| {
                [
                    c[0].as_f64().unwrap_or(f64::NAN),
                    c[1].as_f64().unwrap_or(f64::NAN),
                ]
            })
            .collect();
        all.extend(match_errors(&dv.views[k].corners, &t));
    }
    let n = all.len().max(1) as f64;
    let rms = (all.iter().map(|e| e * e).sum::<f64>() / n).sqrt();
    let max = all.iter().cloned().fold(0.0, f64::max);
    Ok(json!({"rms": rms, "max": max, "corners": all.len()}))
}

/// Per-corner distances between a detection and the truth, under the labelling (identity or
/// half turn) that fits best.
pub fn match_errors(det: &[[f64; 2]], truth: &[[f64; 2]]) -> Vec<f64> {
    if det.len() != truth.len() {
        return Vec::new();
    }
    let d = |a: &[f64; 2], b: &[f64; 2]| ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2)).sqrt();
    let same: Vec<f64> = det.iter().zip(truth).map(|(a, b)| d(a, b)).collect();
    let turned: Vec<f64> = det
        .iter()
        .zip(truth.iter().rev())
        .map(|(a, b)| d(a, b))
        .collect();
    if same.iter().sum::<f64>() <= turned.iter().sum::<f64>() {
        same
    } else {
        turned
    }
}

/// The true calibration of the default rig (for comparisons).
pub fn true_calibration(dataset: &Path) -> Result<Calibration> {
    Ok(Calibration::load(&dataset.join("calibration.toml"))?)
}
