//! `fringe3d calibrate camera | projector | reference`: the calibration workflow of paper §7
//! (see `docs/calibration.md`).

use super::{Global, common, parse};
use crate::calib::camera::CameraOptions;
use crate::calib::corners::{Board, DetectOptions};
use crate::calib::files::{self, MapSource, PlaneSource, ReferenceOptions};
use crate::calib::lens::PARAM_NAMES;
use crate::calib::projector_centre::ProjectorOptions;
use crate::calib::projector_files::{self, ProjectorFileOptions};
use crate::calib::projector_model::{Freedom, ModelOptions};
use crate::io::calibration::Calibration;
use anyhow::{Context, Result, bail};
use serde_json::json;
use std::path::{Path, PathBuf};

/// Arguments of `fringe3d calibrate`.
#[derive(clap::Args, Debug)]
#[command(after_help = "The workflow (docs/calibration.md):\n  \
fringe3d calibrate camera boards/ --board 11x8 --square 25 -o camera.yml\n  \
fringe3d calibrate projector plates/plate_* --camera-from camera.yml --board 9x7 --square 30 -o calibration.toml\n  \
fringe3d calibrate reference ref/ --patterns ref/patterns.toml --calibration calibration.toml --board-image ref/board.png --board 11x8 --square 25\n\n\
The result is calibration.toml with reference_phase.tif beside it, as `fringe3d scan` reads them.\n\
Camera intrinsics calibrated elsewhere: `--camera-from` takes an OpenCV file (.yml/.yaml/.xml/.json),\n\
Bouguet's Calib_Results.m or a fringe3d calibration (.toml) instead of `calibrate camera`'s output,\n\
or camera 1 of a stereo-style calibration (OpenCV stereo, SLStudio, SLMaster, Calib_Results_stereo.m).\n\
Camera AND projector calibrated elsewhere: `fringe3d calibrate import FILE -o calibration.toml`, then\n\
`calibrate reference` (also --virtual).")]
pub struct CalibrateArgs {
    /// The step.
    #[command(subcommand)]
    pub step: Step,
}

/// The calibration steps.
#[derive(clap::Subcommand, Debug)]
pub enum Step {
    /// Camera intrinsics and Brown distortion from checkerboard images (Zhang's closed form, then
    /// a bundle adjustment of all parameters and poses).
    Camera(CameraArgs),
    /// The projector centre P from a flat plate at two or more parallel positions (paper §7).
    Projector(ProjectorArgs),
    /// The reference plane's pose and phase map (paper §6); completes the calibration file.
    Reference(ReferenceArgs),
    /// The projector's response (gamma) from captures of the reference plane under uniform
    /// gray levels: the calibration's `[projector_response]` (docs/gamma.md).
    Gamma(super::calibrate_gamma::GammaArgs),
    /// The projector's effective blur from a scan of binary patterns: the calibration's
    /// `projector_defocus`, which binary sets are decoded with (docs/binary.md).
    Defocus(super::calibrate_defocus::DefocusArgs),
    /// A full camera + projector calibration from another tool (OpenCV stereo, SLStudio,
    /// SLMaster, Bouguet) as a fringe3d calibration (no reference yet).
    Import(super::calibrate_import::ImportArgs),
    /// A fringe3d calibration with its `[projector]` as an OpenCV stereo YAML file.
    Export(super::calibrate_import::ExportArgs),
}

/// The checkerboard.
#[derive(clap::Args, Debug, Clone)]
pub struct BoardArgs {
    /// Board size in SQUARES, COLSxROWS (inner corners: (COLS−1)×(ROWS−1)), e.g. 11x8.
    #[arg(long, value_name = "COLSxROWS")]
    pub board: Option<String>,
    /// Square edge, mm.
    #[arg(long, value_name = "MM")]
    pub square: Option<f64>,
}

impl BoardArgs {
    fn get(&self, what: &str) -> Result<Board> {
        let (Some(b), Some(s)) = (&self.board, self.square) else {
            bail!("{what} needs the board: --board COLSxROWS (squares) and --square MM");
        };
        Board::parse(b, s).map_err(anyhow::Error::msg)
    }
}

/// Arguments of `fringe3d calibrate camera`.
#[derive(clap::Args, Debug)]
#[command(
    after_help = "Example:\n  fringe3d calibrate camera data/checkerboard/ --board 11x8 --square 25 -o camera.yml\n\n\
IMAGES: board images (PNG/TIFF/BMP/PGM/NPY), or one folder (every image in it, sorted by name). The whole\n\
board must be in view; views without it are left out with the reason. Writes the camera as an\n\
OpenCV FileStorage YAML file (K[0][1] = skew·fx, distortion [k1, k2, p1, p2, k3]) and a report\n\
folder: report.json (intrinsics with standard deviations, per-view RMS, rejected views) and a PNG\n\
per view with the detected corners and the residual vectors magnified."
)]
pub struct CameraArgs {
    /// Board images, or one folder.
    #[arg(required = true)]
    pub images: Vec<PathBuf>,
    /// The board.
    #[command(flatten)]
    pub board: BoardArgs,
    /// Output camera file (OpenCV YAML).
    #[arg(long, short = 'o', default_value = "camera.yml")]
    pub out: PathBuf,
    /// Report folder (default: OUT's name with `_report`, beside it).
    #[arg(long)]
    pub report: Option<PathBuf>,
    /// Hold the skew α at 0.
    #[arg(long)]
    pub fix_skew: bool,
    /// Hold k3 at 0.
    #[arg(long)]
    pub fix_k3: bool,
    /// Hold p1 and p2 at 0.
    #[arg(long)]
    pub fix_tangential: bool,
    /// Leave out a view whose RMS exceeds this multiple of the median view's (and 0.1 px).
    #[arg(long, default_value_t = 5.0)]
    pub outlier_factor: f64,
}

/// Arguments of `fringe3d calibrate projector`.
#[derive(clap::Args, Debug)]
#[command(
    after_help = "Examples:\n  fringe3d calibrate projector data/boards/plate_00 data/boards/plate_01 data/boards/plate_02 data/boards/plate_03 \\\n      \
--camera-from camera.yml --board 9x7 --square 30 -o calibration.toml\n  \
fringe3d calibrate projector data/plates/plate_0* --camera-from camera.yml --board 9x7 --square 30\n\n\
POSES: one folder per board pose (tilted freely, as for a camera calibration) or per plate position\n\
(the plate translated to parallel positions, paper §7), each holding v/ (the images of the\n\
vertical-fringe set, phase along ξ), h/ (horizontal fringes, phase along η) and board.png (the board,\n\
same pose, under uniform light). Each board corner's projector pixel comes from the two phase maps\n\
around it; the full projector model (intrinsics, skew, distortion, pose) is fitted jointly with the\n\
board poses. Parallel plates also give P by the line method of §7, reported as a cross-check.\n\
Writes the calibration file (camera, [projector], projector_centre P = its centre, depth_range; no\n\
reference yet) and OUT's name with `_projector.json` (uncertainties, residuals, per-pose figures)."
)]
pub struct ProjectorArgs {
    /// Board-pose or plate-position folders (two or more).
    #[arg(required = true)]
    pub plates: Vec<PathBuf>,
    /// The camera: an OpenCV file (.yml/.yaml/.xml/.json, e.g. from `calibrate camera`), Bouguet's
    /// Calib_Results.m, or a fringe3d calibration (.toml).
    #[arg(long, visible_alias = "camera", value_name = "FILE")]
    pub camera_from: PathBuf,
    /// Pattern-set file of the vertical fringes (default: patterns_v.toml beside the first plate).
    #[arg(long)]
    pub patterns_v: Option<PathBuf>,
    /// Pattern-set file of the horizontal fringes (default: patterns_h.toml beside the first plate).
    #[arg(long)]
    pub patterns_h: Option<PathBuf>,
    /// The board on the plate.
    #[command(flatten)]
    pub board: BoardArgs,
    /// Output calibration file.
    #[arg(long, short = 'o', default_value = "calibration.toml")]
    pub out: PathBuf,
    /// Depth range of the measurement volume "MIN,MAX" in mm (default: the plates' z range ± 10 %).
    #[arg(long, value_name = "MIN,MAX", allow_hyphen_values = true)]
    pub depth_range: Option<String>,
    /// Sample every N-th pixel of each plate.
    #[arg(long, default_value_t = 2)]
    pub stride: usize,
    /// Largest angle between plate normals, degrees.
    #[arg(long, default_value_t = 2.0)]
    pub max_plate_angle: f64,
    /// Fit each plate position's board pose on its own instead of one rotation shared by all
    /// positions in the line method's cross-check (parallel plates only).
    #[arg(long)]
    pub independent_plates: bool,
    /// The camera's intrinsics: held as given (`fixed`), or adjusted jointly with the projector
    /// (`refine`: needs boards tilted between poses).
    #[arg(long, value_parser = ["fixed", "refine"], default_value = "fixed")]
    pub camera_intrinsics: String,
    /// Hold the projector's skew at 0.
    #[arg(long)]
    pub projector_fix_skew: bool,
    /// Fit the projector's k3 too (held at 0 by default: a projector's field is narrow, and a
    /// free k3 extrapolates badly beyond the corners the boards covered).
    #[arg(long)]
    pub projector_free_k3: bool,
    /// Hold the projector's tangential distortion (p1, p2) at 0.
    #[arg(long)]
    pub projector_fix_tangential: bool,
    /// Radius of the window around each corner whose phases are interpolated, camera pixels.
    #[arg(long, default_value_t = 5)]
    pub corner_window: usize,
}

/// Arguments of `fringe3d calibrate reference`.
#[derive(clap::Args, Debug)]
#[command(
    after_help = "Example:\n  fringe3d calibrate reference data/ref/ --patterns data/ref/patterns.toml --calibration calibration.toml \\\n      \
--board-image data/ref/board.png --board 11x8 --square 25\n\n\
IMAGES: the reference plane's fringe images in set order, or one folder (the pattern file's `images`\n\
names inside it, else every image sorted by name); none: the pattern file's own `images` list.\n\
The plane's pose comes from a board lying on it (--board-image; --board-offset for its thickness) or\n\
is given (--plane-point and --plane-normal, camera frame, mm). Writes reference_phase.tif and\n\
reference_patterns.toml beside OUT and OUT itself (the calibration with its [reference] section)."
)]
pub struct ReferenceArgs {
    /// The reference plane's fringe images, or one folder (none with --virtual).
    pub images: Vec<PathBuf>,
    /// The pattern-set file of the reference images (scans must use the same set).
    #[arg(long, short = 'p')]
    pub patterns: PathBuf,
    /// The calibration from `calibrate projector`.
    #[arg(long, short = 'c')]
    pub calibration: PathBuf,
    /// Output calibration (default: update --calibration in place).
    #[arg(long, short = 'o')]
    pub out: Option<PathBuf>,
    /// An image of a board lying on the reference plane (repeat for several boards/positions on
    /// the plane: they are combined).
    #[arg(long)]
    pub board_image: Vec<PathBuf>,
    /// The board.
    #[command(flatten)]
    pub board: BoardArgs,
    /// Board thickness: its printed face lies this far in front of the reference surface, mm.
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    pub board_offset: f64,
    /// A point of the plane "X,Y,Z" (camera frame, mm), instead of a board image.
    #[arg(long, value_name = "X,Y,Z", allow_hyphen_values = true)]
    pub plane_point: Option<String>,
    /// The plane's normal "X,Y,Z", with --plane-point.
    #[arg(long, value_name = "X,Y,Z", allow_hyphen_values = true)]
    pub plane_normal: Option<String>,
    /// File name of the phase map written beside OUT.
    #[arg(long, default_value = "reference_phase.tif")]
    pub map: String,
    /// With a calibration holding the projector model: refuse a reference plate that deviates
    /// from a plane by more than this, mm (the fringes, through the model, measure its flatness).
    /// Without it the deviation is reported, and a warning printed above 0.5 mm.
    #[arg(long, value_name = "MM")]
    pub flatness_limit: Option<f64>,
    /// Write the decoded capture itself as the phase map instead of the smooth model fitted to
    /// it (the model removes the capture's noise from every scan; see docs/reference-model.md).
    #[arg(long)]
    pub raw: bool,
    /// No capture: compute the map from the calibration's full projector model (`[projector]`) for
    /// the pattern set of --patterns, on the plane of --plane-point/--plane-normal (default:
    /// perpendicular to the camera's axis at the far end of the depth range). No IMAGES, no board.
    #[arg(long = "virtual")]
    pub virtual_map: bool,
    /// How far the map extends past the image, pixels: "auto" (what the depth range and the
    /// geometry need, so that every pixel's search stays on the map), one number for every side,
    /// or "LEFT,TOP,RIGHT,BOTTOM"; 0 for an image-sized map. Default: auto with --virtual, 0 for
    /// a captured plane, whose map is extended only on request, by the calibration's projector
    /// model (`[projector]`, not with --raw; its error grows with the distance from the image:
    /// docs/reference-model.md).
    #[arg(long, value_name = "auto|N|L,T,R,B")]
    pub margin: Option<String>,
}

/// Run `fringe3d calibrate`.
pub fn run(a: CalibrateArgs, g: Global) -> Result<()> {
    match a.step {
        Step::Camera(c) => camera(c, g),
        Step::Projector(p) => projector(p, g),
        Step::Reference(r) => reference(r, g),
        Step::Gamma(x) => super::calibrate_gamma::run(x, g),
        Step::Defocus(x) => super::calibrate_defocus::run(x, g),
        Step::Import(i) => super::calibrate_import::import(i, g),
        Step::Export(e) => super::calibrate_import::export(e, g),
    }
}

/// Create the folder an output file goes into (after the computation succeeded: no partial output).
fn make_parent(out: &Path) -> Result<()> {
    if let Some(d) = out.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(d)
            .with_context(|| format!("{}: cannot create the output folder", d.display()))?;
    }
    Ok(())
}

fn sibling(out: &Path, suffix: &str) -> PathBuf {
    let stem = out
        .file_stem()
        .and_then(|s| s.to_str())
        .unwrap_or("calibration");
    out.with_file_name(format!("{stem}{suffix}"))
}

fn camera(a: CameraArgs, g: Global) -> Result<()> {
    common::file_out(&a.out, "--out")?;
    if let Some(r) = &a.report {
        common::dir_out(r, "--report")?;
    }
    let board = a.board.get("calibrate camera")?;
    let paths = files::image_list(&a.images)?;
    let opts = CameraOptions {
        fix_skew: a.fix_skew,
        fix_k3: a.fix_k3,
        fix_tangential: a.fix_tangential,
        outlier_factor: a.outlier_factor,
        ..Default::default()
    };
    // Two detection passes: before and after the lens is known (calibrate_camera_files).
    let pb = common::progress(2 * paths.len() as u64, "corners", g.quiet || g.json);
    let inc = |n: u64| pb.inc(n);
    let (cal, dv) =
        files::calibrate_camera_files(&paths, &board, &DetectOptions::default(), &opts, &inc)?;
    pb.finish_and_clear();
    make_parent(&a.out)?;
    files::write_opencv_yaml(&a.out, &cal, &board)?;
    let report_dir = a
        .report
        .clone()
        .unwrap_or_else(|| sibling(&a.out, "_report"));
    let report = files::write_camera_report(&report_dir, &cal, &dv, &board)?;
    if g.json {
        let mut j = report;
        j["command"] = json!("calibrate camera");
        j["out"] = json!(a.out);
        j["report_dir"] = json!(report_dir);
        outln!("{}", serde_json::to_string_pretty(&j)?);
    } else if !g.quiet {
        outln!(
            "{} of {} views used ({} corners each); overall reprojection RMS {:.4} px (corner noise σ ≈ {:.4} px)",
            cal.views.len(),
            paths.len(),
            board.corner_count(),
            cal.rms,
            cal.sigma
        );
        for (k, n) in PARAM_NAMES.iter().enumerate() {
            outln!("  {n:>4} = {:>14.6} ± {:.6}", cal.lens.p[k], cal.std[k]);
        }
        for v in &cal.views {
            outln!(
                "  view {}: RMS {:.4} px, max {:.4} px",
                v.name,
                v.rms,
                v.max
            );
        }
        for r in &cal.rejected {
            outln!("  left out {}: {}", r.name, r.reason);
        }
        outln!(
            "wrote {} and {}/ (report.json, a picture per view)",
            a.out.display(),
            report_dir.display()
        );
    }
    Ok(())
}

fn projector(a: ProjectorArgs, g: Global) -> Result<()> {
    common::file_out(&a.out, "--out")?;
    let board = a.board.get("calibrate projector")?;
    if a.plates.len() < 2 {
        bail!(
            "calibrate projector: {} plate folder(s) given; at least two plate positions are needed (paper §7)",
            a.plates.len()
        );
    }
    let base = a.plates[0]
        .parent()
        .map(Path::to_path_buf)
        .unwrap_or_default();
    let set_v = a
        .patterns_v
        .clone()
        .unwrap_or_else(|| base.join("patterns_v.toml"));
    let set_h = a
        .patterns_h
        .clone()
        .unwrap_or_else(|| base.join("patterns_h.toml"));
    check_plate_inputs(&a, &set_v, &set_h)?;
    // The image size, to complete camera files that do not state it.
    let size = crate::io::image::read_gray(&a.plates[0].join("board.png"))
        .ok()
        .map(|(i, _)| (i.width, i.height));
    common::input_file(&a.camera_from)?;
    let camera = files::load_camera(&a.camera_from, size)?;
    // Its covariance, when the file records it (calibrate camera's), for honest σ.
    let camera_covariance = files::load_camera_covariance(&a.camera_from)?;
    let depth = match &a.depth_range {
        Some(s) => {
            let v: Vec<f64> = s
                .split(',')
                .map(|x| x.trim().parse::<f64>())
                .collect::<Result<_, _>>()
                .with_context(|| format!("--depth-range {s:?}: expected MIN,MAX in mm"))?;
            let [z0, z1] = v[..] else {
                bail!("--depth-range {s:?}: expected MIN,MAX")
            };
            Some([z0, z1])
        }
        None => None,
    };
    if !(2..=50).contains(&a.corner_window) {
        bail!(
            "--corner-window {}: expected 2 to 50 pixels",
            a.corner_window
        );
    }
    let opts = ProjectorFileOptions {
        lines: ProjectorOptions {
            stride: a.stride.max(1),
            max_plate_angle_deg: a.max_plate_angle,
            translated: !a.independent_plates,
            ..Default::default()
        },
        model: ModelOptions {
            refine_camera: a.camera_intrinsics == "refine",
            projector: Freedom {
                fix_skew: a.projector_fix_skew,
                fix_k3: !a.projector_free_k3,
                fix_tangential: a.projector_fix_tangential,
            },
            camera_covariance,
            ..Default::default()
        },
        corner_radius: a.corner_window,
    };
    let pb = common::progress(a.plates.len() as u64, "poses", g.quiet || g.json);
    let inc = |n: u64| pb.inc(n);
    let run = projector_files::calibrate_projector_files(
        &camera,
        &a.plates,
        &set_v,
        &set_h,
        &board,
        &DetectOptions::default(),
        &opts,
        depth,
        &inc,
    )?;
    pb.finish_and_clear();
    make_parent(&a.out)?;
    run.calibration.save(&a.out)?;
    let m = &run.model;
    let agreement = run
        .agreement()
        .map(|(d, s)| json!({"difference_mm": d, "combined_std_mm": s}));
    let report = json!({"command": "calibrate projector", "out": a.out, "camera_from": a.camera_from,
        "projector_centre": run.calibration.projector_centre, "projector_centre_std": m.std_translation(),
        "depth_range": run.calibration.depth_range,
        "camera_intrinsics": a.camera_intrinsics,
        "model": m.to_json(),
        "line_method": run.lines, "line_method_skipped": run.lines_skipped, "line_method_agreement": agreement,
        "plates": run.plates});
    let rp = sibling(&a.out, "_projector.json");
    let text = serde_json::to_string_pretty(&report)?;
    crate::io::atomic::write_atomic(&rp, |w| w.write_all(text.as_bytes()))?;
    if g.json {
        outln!("{text}");
    } else if !g.quiet {
        let (p, sp) = (&m.projector.p, &m.std_projector);
        outln!(
            "projector {}x{}: fx {:.3} ± {:.3}, fy {:.3} ± {:.3}, cx {:.3} ± {:.3}, cy {:.3} ± {:.3} px, skew {:.2e}, k1 {:.5}, k2 {:.5}, p1 {:.2e}, p2 {:.2e}, k3 {:.5}",
            m.projector.width,
            m.projector.height,
            p[0],
            sp[0],
            p[1],
            sp[1],
            p[3],
            sp[3],
            p[4],
            sp[4],
            p[2],
            p[5],
            p[6],
            p[7],
            p[8],
            p[9]
        );
        let [x, y, z] = run.calibration.projector_centre;
        let st = m.std_translation();
        outln!(
            "P = ({x:.4}, {y:.4}, {z:.4}) mm ± ({:.4}, {:.4}, {:.4}) mm; reprojection RMS: projector {:.4} px ({} corners, {} dropped), camera {:.4} px",
            st[0],
            st[1],
            st[2],
            m.rms_projector_px,
            m.projector_corners[0],
            m.projector_corners[1],
            m.rms_camera_px
        );
        for v in &m.views {
            outln!(
                "  {}: {} corners, projector RMS {:.4} px, camera RMS {:.4} px",
                v.name,
                v.projector_corners,
                v.rms_projector_px,
                v.rms_camera_px
            );
        }
        match (&run.lines, run.agreement()) {
            (Some(r), Some((d, s))) => {
                let [x, y, z] = r.center;
                outln!(
                    "line method of §7 (parallel plates): P = ({x:.4}, {y:.4}, {z:.4}) mm ± ({:.4}, {:.4}, {:.4}) mm from {} lines; differs from the model's by {d:.4} mm ({:.1} σ)",
                    r.std[0],
                    r.std[1],
                    r.std[2],
                    r.lines,
                    d / s.max(1e-300)
                );
            }
            _ => {
                if let Some(why) = &run.lines_skipped {
                    outln!("line method of §7 not run: {why}");
                }
            }
        }
        outln!(
            "depth range [{:.1}, {:.1}] mm",
            run.calibration.depth_range[0],
            run.calibration.depth_range[1]
        );
        outln!("wrote {} and {}", a.out.display(), rp.display());
    }
    Ok(())
}

/// The inputs of `calibrate projector`, checked before any work, each missing one named with the
/// option or argument that fixes it.
fn check_plate_inputs(a: &ProjectorArgs, set_v: &Path, set_h: &Path) -> Result<()> {
    for (set, opt, given) in [
        (set_v, "--patterns-v", a.patterns_v.is_some()),
        (set_h, "--patterns-h", a.patterns_h.is_some()),
    ] {
        if !set.is_file() {
            if given {
                bail!("{opt} {}: no such pattern-set file", set.display());
            }
            bail!(
                "{}: no such pattern-set file (the default of {opt}: {} beside the plate folders); give {opt} FILE",
                set.display(),
                set.file_name().and_then(|n| n.to_str()).unwrap_or("")
            );
        }
    }
    for plate in &a.plates {
        if !plate.is_dir() {
            bail!(
                "{}: not a folder; PLATES are the plate-position folders, each holding v/, h/ and board.png",
                plate.display()
            );
        }
        for (sub, what) in [
            ("v", "vertical-fringe images (the set of --patterns-v)"),
            ("h", "horizontal-fringe images (the set of --patterns-h)"),
        ] {
            if !plate.join(sub).is_dir() {
                bail!(
                    "{}: no {sub}/ folder (the {what}); each PLATES folder holds v/, h/ and board.png",
                    plate.display()
                );
            }
        }
    }
    Ok(())
}

fn reference(a: ReferenceArgs, g: Global) -> Result<()> {
    if let Some(l) = a.flatness_limit
        && !(l > 0.0 && l <= 1000.0)
    {
        bail!("--flatness-limit {l}: expected a positive number of millimetres (at most 1000)");
    }
    if !a.patterns.is_file() {
        bail!(
            "--patterns {}: no such pattern-set file (the set the reference plane's images were captured with)",
            a.patterns.display()
        );
    }
    if !a.calibration.is_file() {
        bail!(
            "--calibration {}: no such file (the calibration from `calibrate projector` or `calibrate import`)",
            a.calibration.display()
        );
    }
    if a.virtual_map {
        return virtual_reference(a, g);
    }
    let cal = Calibration::load(&a.calibration)?;
    let imgs = !a.board_image.is_empty();
    let plane = match (imgs, &a.plane_point, &a.plane_normal) {
        (true, None, None) => PlaneSource::Board {
            images: a.board_image.clone(),
            board: a.board.get("--board-image")?,
            offset_mm: a.board_offset,
        },
        (false, Some(p), Some(n)) => PlaneSource::Given {
            point: parse::point3(p, "--plane-point")?,
            normal: parse::point3(n, "--plane-normal")?,
        },
        (false, None, None) => bail!(
            "calibrate reference: give the plane's pose, either --board-image (with --board, --square) or --plane-point and --plane-normal"
        ),
        _ => bail!(
            "calibrate reference: give either --board-image or both --plane-point and --plane-normal, not a mix"
        ),
    };
    let margin = match &a.margin {
        None => Some(fringe3d_core::reconstruct::Margin::ZERO),
        Some(m) => parse::margin(m)?,
    };
    crate::calib::reference_margin::check_request(&cal, !a.raw, margin)
        .map_err(|m| anyhow::anyhow!("{}: {m}", a.calibration.display()))?;
    let out = a.out.clone().unwrap_or_else(|| a.calibration.clone());
    common::file_out(&out, "--out")?;
    let run = files::calibrate_reference_files(
        &cal,
        &out,
        &a.patterns,
        &a.images,
        &plane,
        &ReferenceOptions {
            detect: DetectOptions::default(),
            map_name: &a.map,
            source: if a.raw {
                MapSource::Raw
            } else {
                MapSource::Model
            },
            flatness_limit_mm: a.flatness_limit,
            margin,
        },
    )?;
    let model = run.fit.as_ref().map(|f| {
        json!({"spacing_px": f.spacing_px, "residual_rms_rad": f.residual_rms_rad,
            "noise_rad": f.noise_rad, "structure_rad": f.structure_rad, "used": f.used,
            "outliers": f.outliers, "candidates": f.candidates})
    });
    let j = json!({"command": "calibrate reference", "out": out, "map": run.map_path, "valid_fraction": run.valid_fraction,
        "plane": run.plane, "model": model, "projector_model_check": run.physical,
        "margin": run.margin.to_array(), "seam_rad": run.seam_rad,
        "sensor": run.calibration.sensor.map(|s| json!({"bits": s.bits, "noise": s.noise,
            "min_modulation": s.decode_config(s.bits).min_modulation}))});
    if let Some(f) = &run.physical
        && !g.quiet
        && a.flatness_limit.is_none()
        && f.worst_block_mm.abs() > crate::calib::reference_physical::FLATNESS_MM
    {
        errln!(
            "warning: through the projector model the plate deviates from a plane by {:+.3} mm around pixel ({}, {}): the plate is bent there, or the projector model extrapolates beyond what its calibration poses covered (--flatness-limit MM refuses such a plate)",
            f.worst_block_mm,
            f.worst_block_at.0,
            f.worst_block_at.1
        );
    }
    if g.json {
        outln!("{}", serde_json::to_string_pretty(&j)?);
    } else if !g.quiet {
        let p = &run.plane;
        outln!(
            "reference plane O_R = ({:.4}, {:.4}, {:.4}) mm, n_R = ({:.6}, {:.6}, {:.6}); distance σ {:.4} mm, tilt σ {:.5} degrees",
            p.point[0],
            p.point[1],
            p.point[2],
            p.normal[0],
            p.normal[1],
            p.normal[2],
            p.distance_std_mm,
            p.tilt_std_deg
        );
        outln!(
            "reference capture: {:.1} % of the pixels valid",
            100.0 * run.valid_fraction
        );
        if let Some(s) = &run.calibration.sensor {
            outln!(
                "sensor read noise σ {:.3} codes ({}-bit images): scans decode with a minimum \
                 modulation of 12σ = {:.1} codes unless told otherwise",
                s.noise,
                s.bits,
                s.decode_config(s.bits).min_modulation
            );
        }
        match &run.fit {
            Some(f) => outln!(
                "phase map: smooth model (cubic spline, knots every {} px) fitted to {} pixels ({} outliers dropped); residual {:.2e} rad RMS, noise {:.2e} rad, structure {:.2e} rad",
                f.spacing_px,
                f.used,
                f.outliers,
                f.residual_rms_rad,
                f.noise_rad,
                f.structure_rad
            ),
            None => outln!("phase map: the decoded capture (--raw)"),
        }
        if let Some(seam) = run.seam_rad {
            let m = run.margin;
            outln!(
                "past the image by {}/{}/{}/{} px (left/top/right/bottom): the projector model's map on the plane the fringes show, meeting the capture's model at the border (largest shift {seam:.2e} rad)",
                m.left,
                m.top,
                m.right,
                m.bottom
            );
        }
        if let Some(f) = &run.physical {
            outln!(
                "through the projector model: the fringes put the plane {:+.4} mm and {:.4} degrees from that pose; flat to {:+.4} mm (worst {BLOCK}-px block, around pixel ({}, {})); residual {:.2e} rad RMS",
                f.offset_mm,
                f.angle_deg,
                f.worst_block_mm,
                f.worst_block_at.0,
                f.worst_block_at.1,
                f.residual_rms_rad,
                BLOCK = crate::calib::reference_physical::BLOCK_PX,
            );
        }
        outln!(
            "wrote {} (with {} and reference_patterns.toml beside it)",
            out.display(),
            a.map
        );
    }
    Ok(())
}

/// `calibrate reference --virtual`.
fn virtual_reference(a: ReferenceArgs, g: Global) -> Result<()> {
    if !a.images.is_empty() || !a.board_image.is_empty() || a.raw {
        bail!(
            "calibrate reference --virtual computes the map from the projector model: give no images, no --board-image and no --raw"
        );
    }
    let plane = match (&a.plane_point, &a.plane_normal) {
        (Some(p), Some(n)) => Some((
            parse::point3(p, "--plane-point")?,
            parse::point3(n, "--plane-normal")?,
        )),
        (None, None) => None,
        _ => bail!(
            "calibrate reference --virtual: give both --plane-point and --plane-normal, or neither"
        ),
    };
    let margin = parse::margin(a.margin.as_deref().unwrap_or("auto"))?;
    let cal = Calibration::load(&a.calibration)?;
    let out = a.out.clone().unwrap_or_else(|| a.calibration.clone());
    common::file_out(&out, "--out")?;
    let run = crate::calib::virtual_reference::virtual_reference_files(
        &cal,
        &a.calibration,
        &out,
        &a.patterns,
        plane,
        margin,
        &a.map,
    )?;
    let (p, n) = run.plane;
    let j = json!({"command": "calibrate reference --virtual", "out": out, "map": run.map_path,
        "valid_fraction": run.valid_fraction, "plane": {"point": p, "normal": n},
        "margin": run.margin.to_array()});
    if g.json {
        outln!("{}", serde_json::to_string_pretty(&j)?);
    } else if !g.quiet {
        outln!(
            "virtual reference on the plane through ({:.4}, {:.4}, {:.4}) mm, normal ({:.6}, {:.6}, {:.6}): {:.1} % of the pixels see it lit",
            p[0],
            p[1],
            p[2],
            n[0],
            n[1],
            n[2],
            100.0 * run.valid_fraction
        );
        let m = run.margin;
        outln!(
            "the map extends past the image by {} px left, {} top, {} right, {} bottom",
            m.left,
            m.top,
            m.right,
            m.bottom
        );
        outln!(
            "wrote {} (with {} and reference_patterns.toml beside it)",
            out.display(),
            a.map
        );
    }
    Ok(())
}
