//! `fringe3d adapt`: design a pattern set for one object (issue #22; the objective and its
//! constraints are in [`crate::adapt`]).

use std::path::{Path, PathBuf};

use anyhow::{Result, bail};
use fringe3d_core::pattern::PatternSet;
use serde_json::json;

use super::{Global, common, parse};
use crate::adapt::surface::{Gathered, Rig};
use crate::adapt::{Adapted, Goal, Snr, adapted_file, solve, template_of};
use crate::io::atomic::AtomicDir;
use crate::io::calibration::Calibration;
use crate::math::{Mat3, Vec3};

/// Arguments of `fringe3d adapt`.
#[derive(clap::Args, Debug)]
#[command(
    after_help = "Examples:\n  fringe3d adapt --calibration cal.toml --patterns examples/patterns/paper8.toml \\\n      --cloud first_scan.ply --crop -150,-120,450,150,120,700 -o adapted/\n  \
fringe3d adapt --calibration cal.toml --patterns paper8.toml --mesh part.stl --pose 0,0,600,0,30,0 -o adapted/\n\n\
Writes adapted/patterns.toml (the template's levels and order, its phase function replaced by\n\
designed knots) and adapted/calibration.toml: the calibration with a virtual reference for\n\
the new set from its full projector model ([projector]): scan with both, no capture needed. Objective and constraints: docs/adaptive.md."
)]
pub struct AdaptArgs {
    /// The calibration (camera, depth range, and the full projector model `[projector]`).
    #[arg(long, short = 'c')]
    pub calibration: PathBuf,
    /// The template: a pattern-set file whose levels, order and projector the design keeps.
    #[arg(long, short = 'p')]
    pub patterns: PathBuf,
    /// A first scan's point cloud (PLY, camera frame, mm).
    #[arg(long, group = "object", required_unless_present = "mesh")]
    pub cloud: Option<PathBuf>,
    /// A model of the object (PLY or STL mesh, mm), placed by --pose.
    #[arg(long, group = "object", requires = "pose")]
    pub mesh: Option<PathBuf>,
    /// The mesh's pose "X,Y,Z,RX,RY,RZ": `X_cam = R·X + (X, Y, Z)`, R = Rz·Ry·Rx of the angles
    /// in degrees (as scene files' `euler_deg`).
    #[arg(long, value_name = "X,Y,Z,RX,RY,RZ", allow_hyphen_values = true, value_parser = parse::six)]
    pub pose: Option<[f64; 6]>,
    /// Keep only points in this box "X0,Y0,Z0,X1,Y1,Z1" (camera frame, mm): the object without
    /// its support or background.
    #[arg(long, value_name = "X0,Y0,Z0,X1,Y1,Z1", allow_hyphen_values = true, value_parser = parse::six)]
    pub crop: Option<[f64; 6]>,
    /// Least finest fringe period in the camera image, pixels.
    #[arg(long, default_value_t = 3.0)]
    pub min_period: f64,
    /// Least finest fringe period on the projector, pixels.
    #[arg(long, default_value_t = 4.0)]
    pub min_projector_period: f64,
    /// Least share of the fringe contrast the projector's defocus and the camera's blur may
    /// leave at the finest period.
    #[arg(long, default_value_t = 0.5)]
    pub min_contrast: f64,
    /// Projector defocus, Gaussian σ in DMD pixels (default: the calibration's
    /// `projector_defocus`, else 1).
    #[arg(long)]
    pub projector_blur: Option<f64>,
    /// Camera blur, Gaussian σ in camera pixels.
    #[arg(long, default_value_t = 0.5)]
    pub camera_blur: f64,
    /// Least slope where no object is, as a fraction of the template's mean slope.
    #[arg(long, default_value_t = 0.1)]
    pub floor: f64,
    /// Knots of the designed slope profile (2 to 16).
    #[arg(long, default_value_t = 16)]
    pub knots: usize,
    /// Modulation over read noise B/σ of the brightest object surface (at coarse fringes): checks
    /// that the template's levels unwrap there within --failure-target, predicts the RMS in mm,
    /// and has every pixel keep, given its light, the B/σ at which the levels refuse at most
    /// 1e-3 of the pixels (conservative: see docs/adaptive.md).
    #[arg(long, value_name = "B_OVER_SIGMA")]
    pub snr: Option<f64>,
    /// With --snr: the largest rate of pixels the unwrapping may refuse.
    #[arg(long, default_value_t = 1e-6, requires = "snr")]
    pub failure_target: f64,
    /// Output folder (must not exist or be empty, unless --overwrite).
    #[arg(long, short = 'o')]
    pub out: PathBuf,
    /// Replace the output folder if it exists.
    #[arg(long)]
    pub overwrite: bool,
}

/// The phase noise (rad) at B/σ `snr` of a set's finest level, and the template's predicted
/// unwrapping refusals; `Err` naming the binding constraint when they exceed `target`.
fn unwrap_check(set: &PatternSet, path: &Path, snr: f64, target: f64) -> Result<(f64, f64)> {
    use crate::design::phase_noise;
    if !(snr.is_finite() && snr > 0.0) {
        bail!("--snr must be a positive number, got {snr}");
    }
    let finest = set.levels().iter().rfind(|l| l.gray().is_none());
    let sigma = finest.map_or(0.0, |l| phase_noise(snr, l.shifts().len().max(3)));
    let refused = crate::design::set_refusals(set, snr);
    if refused > target {
        bail!(
            "{}: the unwrapping binds: the template's levels refuse {refused:.2e} of the pixels at \
             B/sigma = {snr} (--failure-target {target:.0e}); `fringe3d patterns --design {snr}` \
             proposes levels that do not",
            path.display()
        );
    }
    Ok((sigma, refused))
}

fn gathered_text(g: &Gathered) -> String {
    format!(
        "{} kept; dropped: {} outside the depth range, {} off the image, {} unlit, {} cropped",
        g.kept, g.outside_depth, g.outside_image, g.unlit, g.cropped
    )
}

/// Run `fringe3d adapt`.
pub fn run(a: AdaptArgs, g: Global) -> Result<()> {
    common::input_file(&a.calibration)?;
    common::input_file(&a.patterns)?;
    common::dir_out(&a.out, "--out")?;
    let cal = Calibration::load(&a.calibration)?;
    let ls = common::load_set(&a.patterns)?;
    let set = &ls.set;
    let Some(rig) = Rig::new(&cal, set.axis()) else {
        bail!(
            "{}: no [projector] section: adapt maps the object onto the projector with the full \
             projector model (intrinsics, distortion, pose); run `fringe3d calibrate projector` \
             (docs/calibration.md) or import it",
            a.calibration.display()
        );
    };
    if let Some(p) = &cal.projector {
        let o = set.output();
        if (o.width, o.height) != (p.intrinsics.width, p.intrinsics.height) {
            bail!(
                "{}: patterns of {}x{}, but the calibration's projector is {}x{} ({})",
                a.patterns.display(),
                o.width,
                o.height,
                p.intrinsics.width,
                p.intrinsics.height,
                a.calibration.display()
            );
        }
    }
    let template =
        template_of(set).map_err(|m| anyhow::anyhow!("{}: {m}", a.patterns.display()))?;
    let snr = match a.snr {
        Some(s) => Some((s, unwrap_check(set, &a.patterns, s, a.failure_target)?)),
        None => None,
    };
    let (source, (map, gathered)) = match (&a.cloud, &a.mesh) {
        (Some(c), _) => {
            common::input_file(c)?;
            let m = crate::io::mesh::read_mesh(c)?;
            let crop = a.crop.map(|b| ([b[0], b[1], b[2]], [b[3], b[4], b[5]]));
            (c, rig.map_points(&m.vertices, crop))
        }
        (None, Some(p)) => {
            common::input_file(p)?;
            let m = crate::io::mesh::read_mesh(p)?;
            if m.triangles.is_empty() {
                bail!(
                    "{}: no triangles: a mesh is needed (a point cloud goes to --cloud)",
                    p.display()
                );
            }
            let [x, y, z, rx, ry, rz] = a.pose.unwrap_or_default();
            let r = Mat3::from_euler_deg([rx, ry, rz]);
            (p, rig.map_mesh(&m, r, Vec3::new(x, y, z)))
        }
        (None, None) => bail!("give --cloud or --mesh"),
    };
    let samples = rig.samples(&map);
    let goal = Goal {
        min_camera_period: a.min_period,
        min_projector_period: a.min_projector_period,
        projector_blur: a.projector_blur.or(cal.projector_defocus).unwrap_or(1.0),
        camera_blur: a.camera_blur,
        min_contrast: a.min_contrast,
        snr: a.snr.map(|s| Snr {
            brightest: s,
            needed: crate::design::needed_snr(set, crate::adapt::PIXEL_FAILURE),
        }),
        floor: a.floor,
        knots: a.knots,
        ..Goal::default()
    };
    let design = solve(&samples, &template, &goal)
        .map_err(|e| anyhow::anyhow!("{}: {e} ({})", source.display(), gathered_text(&gathered)))?;
    let file = adapted_file(&ls.file, set.axis(), &design);
    // The core's checks of the new phase function (monotonic, continuous, the coarse range).
    file.to_pattern_set()
        .map_err(|e| anyhow::anyhow!("the designed set: {e}"))?;

    let dir = AtomicDir::create(&a.out, a.overwrite)?;
    let patterns_path = dir.join("patterns.toml");
    file.save(&patterns_path)?;
    // The new set's reference from the projector model (issue #17 item 2): no capture.
    let reference = crate::calib::virtual_reference::virtual_reference_files(
        &cal,
        &a.calibration,
        &dir.join("calibration.toml"),
        &patterns_path,
        None,
        None,
        "reference_phase.tif",
    )?
    .plane;
    let out = dir.commit()?;
    report(g, &design, &gathered, snr, reference, &out);
    Ok(())
}

fn report(
    g: Global,
    d: &Adapted,
    gathered: &Gathered,
    snr: Option<(f64, (f64, f64))>,
    (point, normal): ([f64; 3], [f64; 3]),
    out: &Path,
) {
    let gain = d.fixed.rms_per_rad / d.adaptive.rms_per_rad;
    if g.json {
        outln!(
            "{}",
            json!({"command": "adapt", "out": out, "pixels": d.samples, "gathered": gathered,
                "template": d.fixed, "adaptive": d.adaptive, "predicted_rms_gain": gain,
                "span": d.span, "positions": d.positions, "slopes": d.slopes, "regions": d.regions,
                "snr": snr.map(|(s, (sigma, refused))| json!({"b_over_sigma": s,
                    "phase_noise_rad": sigma, "template_rms_mm": sigma * d.fixed.rms_per_rad,
                    "adaptive_rms_mm": sigma * d.adaptive.rms_per_rad, "refused": refused})),
                "reference": {"calibration": out.join("calibration.toml"), "point": point,
                    "normal": normal}})
        );
        return;
    }
    if g.quiet {
        return;
    }
    outln!(
        "adapt: {} object pixels ({})",
        d.samples,
        gathered_text(gathered)
    );
    let line = |name: &str, p: &crate::adapt::Prediction| {
        format!(
            "  {name}: RMS {:.4} mm per rad of phase noise, {:.2} % unresolvable, finest period on the object >= {:.2} camera px",
            p.rms_per_rad,
            100.0 * p.unresolvable,
            p.min_camera_period
        )
    };
    outln!("{}", line("template", &d.fixed));
    outln!("{}", line("adaptive", &d.adaptive));
    outln!("  predicted RMS gain x{gain:.2}");
    if let Some((s, (sigma, refused))) = snr {
        outln!(
            "  at B/sigma = {s}: phase noise {sigma:.4} rad, RMS {:.2} um -> {:.2} um; the levels refuse {refused:.1e} of the pixels",
            1e3 * sigma * d.fixed.rms_per_rad,
            1e3 * sigma * d.adaptive.rms_per_rad
        );
    }
    outln!("  regions (projector columns along the axis):");
    for r in &d.regions {
        outln!(
            "    {:>5} - {:<5} {:>8} px  gain x{:.2}  bound by {}",
            r.columns.0,
            r.columns.1,
            r.pixels,
            r.gain,
            serde_json::to_value(r.binding)
                .ok()
                .and_then(|v| v.as_str().map(str::to_owned))
                .unwrap_or_default()
        );
    }
    outln!("wrote {}", out.join("patterns.toml").display());
    outln!(
        "wrote {} with a virtual reference for the new set (plane through {point:?}, normal {normal:?}): no capture needed",
        out.join("calibration.toml").display()
    );
}
