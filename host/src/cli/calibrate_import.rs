//! `fringe3d calibrate import` and `calibrate export`: full camera + projector calibrations from
//! and to other tools (OpenCV stereo files, SLStudio, SLMaster, Bouguet's stereo results).

use super::{Global, parse};
use crate::io::calibration::{CALIBRATION_VERSION, Calibration};
use crate::io::import::{RigFormat, RigSizes, export_opencv_stereo, import_rig};
use anyhow::{Context, Result, bail};
use serde_json::json;
use std::path::{Path, PathBuf};

/// Arguments of `fringe3d calibrate import`.
#[derive(clap::Args, Debug)]
#[command(
    after_help = "Example:\n  fringe3d calibrate import stereo.yml --projector-size 912x1140 --depth-range 500,900 -o calibration.toml\n  \
fringe3d calibrate reference --virtual --patterns patterns.toml --calibration calibration.toml\n\n\
FILE: an OpenCV stereo file (M1 D1 M2 D2 R T, or cameraMatrix1 distCoeffs1 cameraMatrix2 distCoeffs2 R T;\n\
camera 1 = the camera, camera 2 = the projector, x2 = R*x1 + T), SLStudio's calibration.xml (Kc kc Kp kp Rp Tp),\n\
SLMaster's caliInfo.yml (M1 D1 M4 D4 Rlp Tlp) or Bouguet's Calib_Results_stereo.m (left = camera,\n\
right = projector). Lengths must be in millimetres. Writes the calibration (camera, projector_centre\n\
P = -R^T*T, depth_range and the [projector] section; no reference yet): make the reference next with\n\
`fringe3d calibrate reference` (captured, or --virtual from the imported projector model).\n\
See docs/formats.md for each format's convention."
)]
pub struct ImportArgs {
    /// The calibration file of the other tool.
    pub file: PathBuf,
    /// Its format: opencv, slstudio, slmaster or bouguet (default: recognised from the keys).
    #[arg(long, value_parser = RigFormat::parse)]
    pub format: Option<RigFormat>,
    /// The camera's image size WxH, if the file does not state it.
    #[arg(long, value_name = "WxH", value_parser = parse::size_wh)]
    pub camera_size: Option<(u32, u32)>,
    /// The projector's image (DMD) size WxH, if the file does not state it (SLMaster never does).
    #[arg(long, value_name = "WxH", value_parser = parse::size_wh)]
    pub projector_size: Option<(u32, u32)>,
    /// Depth range of the measurement volume "MIN,MAX", camera z in mm (required unless the file
    /// is fringe3d's own export, which records it).
    #[arg(long, value_name = "MIN,MAX", allow_hyphen_values = true, value_parser = parse::min_max)]
    pub depth_range: Option<[f64; 2]>,
    /// Output calibration file.
    #[arg(long, short = 'o', default_value = "calibration.toml")]
    pub out: PathBuf,
}

/// Arguments of `fringe3d calibrate export`.
#[derive(clap::Args, Debug)]
#[command(
    after_help = "Example:\n  fringe3d calibrate export calibration.toml -o stereo.yml\n\n\
Writes the camera (M1, D1), the projector (M2, D2) and R, T with x_proj = R*x_cam + T (OpenCV's\n\
stereoCalibrate convention), image sizes, and fringe3d_* keys that make `calibrate import` of the\n\
file give back exactly the same camera, projector and P. The calibration needs its [projector]\n\
section; the reference plane is not exported."
)]
pub struct ExportArgs {
    /// The fringe3d calibration file.
    pub calibration: PathBuf,
    /// Output OpenCV stereo YAML file.
    #[arg(long, short = 'o', default_value = "stereo.yml")]
    pub out: PathBuf,
}

fn make_parent(out: &Path) -> Result<()> {
    if let Some(d) = out.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(d)
            .with_context(|| format!("{}: cannot create the output folder", d.display()))?;
    }
    Ok(())
}

fn is_toml(p: &Path) -> bool {
    p.extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("toml"))
}

/// Run `fringe3d calibrate import`.
pub fn import(a: ImportArgs, g: Global) -> Result<()> {
    super::common::file_out(&a.out, "--out")?;
    super::common::input_file(&a.file)?;
    if is_toml(&a.file) {
        bail!(
            "{}: a fringe3d calibration already; import reads other tools' files (OpenCV, SLStudio, SLMaster, Bouguet)",
            a.file.display()
        );
    }
    let rig = import_rig(
        &a.file,
        a.format,
        RigSizes {
            camera: a.camera_size,
            projector: a.projector_size,
        },
    )?;
    let depth_range = match (a.depth_range, rig.depth_range) {
        (Some(d), _) | (None, Some(d)) => d,
        (None, None) => bail!(
            "{}: the file does not record the measurement volume: give --depth-range MIN,MAX (the nearest and farthest camera z, mm)",
            a.file.display()
        ),
    };
    let cal = Calibration {
        version: CALIBRATION_VERSION,
        camera: rig.camera,
        projector_centre: rig.projector_centre(),
        reference: None,
        depth_range,
        projector: Some(rig.projector),
        projector_response: None,
        projector_defocus: None,
        camera_covariance: None,
        sensor: None,
    };
    cal.validate()
        .map_err(|m| anyhow::anyhow!("{}: {m}", a.file.display()))?;
    make_parent(&a.out)?;
    cal.save(&a.out)?;
    let p = cal.projector_centre;
    let baseline = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
    let next = format!(
        "fringe3d calibrate reference --virtual --patterns PATTERNS.toml --calibration {}  (or with the reference plane's images)",
        a.out.display()
    );
    if g.json {
        let j = json!({"command": "calibrate import", "file": a.file, "format": rig.format.name(),
            "out": a.out, "projector_centre": p, "baseline_mm": baseline, "depth_range": depth_range,
            "camera": cal.camera, "projector": cal.projector, "next": next});
        outln!("{}", serde_json::to_string_pretty(&j)?);
    } else if !g.quiet {
        outln!(
            "{} ({}): camera {}x{}, projector {}x{}, P = ({:.4}, {:.4}, {:.4}) mm, baseline {:.4} mm",
            a.file.display(),
            rig.format.name(),
            cal.camera.width,
            cal.camera.height,
            rig.projector.intrinsics.width,
            rig.projector.intrinsics.height,
            p[0],
            p[1],
            p[2],
            baseline
        );
        outln!("wrote {} (no reference yet); next: {next}", a.out.display());
    }
    Ok(())
}

/// Run `fringe3d calibrate export`.
pub fn export(a: ExportArgs, g: Global) -> Result<()> {
    super::common::file_out(&a.out, "--out")?;
    super::common::input_file(&a.calibration)?;
    let cal = Calibration::load(&a.calibration)?;
    if cal.projector.is_none() {
        bail!(
            "{}: no [projector] section (the projector's intrinsics and pose): an OpenCV stereo file needs it",
            a.calibration.display()
        );
    }
    make_parent(&a.out)?;
    export_opencv_stereo(&cal, &a.out)?;
    if g.json {
        let j = json!({"command": "calibrate export", "calibration": a.calibration, "out": a.out,
            "format": "opencv"});
        outln!("{}", serde_json::to_string_pretty(&j)?);
    } else if !g.quiet {
        outln!(
            "wrote {} (OpenCV stereo YAML: M1 D1 camera, M2 D2 projector, x_proj = R*x_cam + T)",
            a.out.display()
        );
    }
    Ok(())
}
