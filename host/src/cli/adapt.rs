//! `fringe3d adapt`: design a pattern set for one object (issue #22; the objective and its
//! constraints are in [`crate::adapt`]).

use std::path::{Path, PathBuf};

use anyhow::{Result, bail};
use fringe3d_core::pattern::PatternSet;
use serde_json::json;

use super::{Global, common, parse};
use crate::adapt::surface::{Gathered, Rig};
use crate::adapt::{Adapted, Goal, Snr, solve, template_of};
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
    #[arg(long, group = "object", required_unless_present_any = ["mesh", "decoded"])]
    pub cloud: Option<PathBuf>,
    /// A first scan decoded by `fringe3d decode` (its folder): needs only the calibration's
    /// reference, not its projector model, and measures each pixel's light (its modulation).
    #[arg(long, group = "object", requires = "first_patterns")]
    pub decoded: Option<PathBuf>,
    /// With --decoded: the pattern set the folder was decoded with (straight fringes; its
    /// calibration's reference must be of this set).
    #[arg(long, requires = "decoded")]
    pub first_patterns: Option<PathBuf>,
    /// The camera's read noise σ in codes: with a measured modulation (--decoded, or a cloud
    /// with a `modulation` property as `fringe3d scan` writes), each pixel's B/σ for the noise
    /// constraint.
    #[arg(long, conflicts_with_all = ["snr", "mesh"])]
    pub noise: Option<f64>,
    /// A model of the object (PLY or STL mesh, mm), placed by --pose.
    #[arg(long, group = "object", requires = "pose")]
    pub mesh: Option<PathBuf>,
    /// The mesh's pose "X,Y,Z,RX,RY,RZ": `X_cam = R·X + (X, Y, Z)`, R = Rz·Ry·Rx of the angles
    /// in degrees (as scene files' `euler_deg`).
    #[arg(long, value_name = "X,Y,Z,RX,RY,RZ", allow_hyphen_values = true, value_parser = parse::six, requires = "mesh")]
    pub pose: Option<[f64; 6]>,
    /// Keep only points in this box "X0,Y0,Z0,X1,Y1,Z1" (camera frame, mm): the object of a first
    /// scan without its support or background (--cloud, --decoded; a mesh is the object).
    #[arg(long, value_name = "X0,Y0,Z0,X1,Y1,Z1", allow_hyphen_values = true, value_parser = parse::six, conflicts_with = "mesh")]
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
    /// Keep the fringes straight (by default they are curved about the projector's epipole
    /// where that lowers the predicted RMS by 1 %).
    #[arg(long)]
    pub straight: bool,
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
        "{} kept; dropped: {} outside the depth range, {} off the image, {} unlit, {} cropped, {} not finite",
        g.kept, g.outside_depth, g.outside_image, g.unlit, g.cropped, g.invalid
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
    if !(a.failure_target > 0.0 && a.failure_target < 1.0) {
        bail!("--failure-target: in (0, 1), got {}", a.failure_target);
    }
    let needed = crate::design::needed_snr(set, crate::adapt::PIXEL_FAILURE);
    let mut goal = Goal {
        min_camera_period: a.min_period,
        min_projector_period: a.min_projector_period,
        projector_blur: a.projector_blur.or(cal.projector_defocus).unwrap_or(1.0),
        camera_blur: a.camera_blur,
        min_contrast: a.min_contrast,
        snr: a.snr.map(|s| Snr {
            brightest: s,
            needed,
        }),
        floor: a.floor,
        knots: a.knots,
        ..Goal::default()
    };
    // The flags are checked before any object is read.
    crate::adapt::check(&template, &goal).map_err(|e| anyhow::anyhow!("{e}"))?;
    if let Some(n) = a.noise
        && !(n.is_finite() && n > 0.0)
    {
        bail!("--noise: a read noise in camera codes above 0, got {n}");
    }
    let snr = match a.snr {
        Some(s) => Some((s, unwrap_check(set, &a.patterns, s, a.failure_target)?)),
        None => None,
    };
    let crop = a.crop.map(|b| ([b[0], b[1], b[2]], [b[3], b[4], b[5]]));
    let mut measured_light = false;
    let mut bent: Option<(Rig, crate::adapt::surface::PointMap)> = None;
    let mut bend_report: Option<(f64, f64, f64, Option<f64>, bool)> = None;
    let (source, samples, gathered, measured) = match &a.decoded {
        Some(dir) => {
            let (samples, gathered) =
                decoded_samples(&a, (set.axis(), *set.output()), &cal, dir, crop, g)?;
            (dir, samples, gathered, true)
        }
        None => {
            let Some(rig) = Rig::new(&cal, set.axis()) else {
                bail!(
                    "{}: no [projector] section: adapt maps a cloud or a mesh onto the projector \
                     with the full projector model (intrinsics, distortion, pose); run `fringe3d \
                     calibrate projector` (docs/calibration.md), or design from a decoded first \
                     scan (--decoded), which needs only the reference",
                    a.calibration.display()
                );
            };
            let (source, (map, gathered)) = match (&a.cloud, &a.mesh) {
                (Some(c), _) => {
                    common::input_file(c)?;
                    let m = crate::io::mesh::read_mesh(c)?;
                    let light = (!m.modulation.is_empty()).then_some(&m.modulation[..]);
                    measured_light = light.is_some();
                    (c, rig.map_points(&m.vertices, light, crop))
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
                (None, None) => bail!("give --cloud, --mesh or --decoded"),
            };
            let samples = rig.samples(&map);
            bent = Some((rig, map));
            (source, samples, gathered, measured_light)
        }
    };
    // A measured modulation (a decoded scan, a scan's cloud) over --noise gives the B/σ.
    if a.noise.is_some() && !measured {
        bail!(
            "{}: --noise needs each pixel's measured modulation: a decoded first scan (--decoded) \
             or a cloud with a `modulation` property (as `fringe3d scan` writes it); give --snr \
             for a modelled light instead",
            source.display()
        );
    }
    if let (Some(n), true) = (a.noise, measured) {
        let mut b: Vec<f64> = samples.iter().map(|s| s.bright).collect();
        b.sort_by(f64::total_cmp);
        if let Some(&x) = b.get(((b.len().max(1) - 1) as f64 * 0.99) as usize) {
            goal.snr = Some(Snr {
                brightest: x / n,
                needed,
            });
        }
    }
    let mut design = solve(&samples, &template, &goal)
        .map_err(|e| anyhow::anyhow!("{}: {e} ({})", source.display(), gathered_text(&gathered)))?;
    // Curved fringes where they help: circles about the projector's epipole, kept when they
    // lower the predicted RMS by 1 % without losing coverage (needs the projector model).
    let mut bend = None;
    if let (Some((rig, map)), false) = (&bent, a.straight) {
        let centre = samples.iter().map(|s| s.along).sum::<f64>() / samples.len().max(1) as f64;
        if let Some((c, w0, epipole)) = rig.epipolar_bend(centre) {
            let curved = rig.with_bend(c, w0).samples(map);
            let file_ok = |d: &crate::adapt::Adapted| {
                crate::adapt::bent_file(&ls.file, set.axis(), d, Some((c, w0)))
                    .to_pattern_set()
                    .is_ok()
            };
            let gain = match solve(&curved, &template, &goal) {
                Ok(d) => {
                    let gain = design.adaptive.rms_per_rad / d.adaptive.rms_per_rad;
                    // The same pixels, no more of them lost, and fringes across the bend no
                    // denser than 2 % over their density along the axis (the projector's period
                    // and contrast limits are taken along it).
                    let keeps = d.samples >= design.samples
                        && d.adaptive.unresolvable <= design.adaptive.unresolvable + 1e-3;
                    let across = f64::from(match set.axis() {
                        fringe3d_core::phase_function::Axis::Xi => set.output().height,
                        fringe3d_core::phase_function::Axis::Eta => set.output().width,
                    });
                    let steepest = 2.0 * c.abs() * w0.abs().max((across - 1.0 - w0).abs());
                    let mild = (1.0 + steepest * steepest).sqrt() <= 1.02;
                    if gain >= 1.01 && keeps && mild && file_ok(&d) {
                        let fixed = design.fixed;
                        design = crate::adapt::Adapted { fixed, ..d };
                        bend = Some((c, w0));
                    }
                    Some(gain)
                }
                Err(_) => None,
            };
            bend_report = Some((c, w0, epipole, gain, bend.is_some()));
        }
    }
    let file = crate::adapt::bent_file(&ls.file, set.axis(), &design, bend);
    // The core's checks of the new phase function (monotonic, continuous, the coarse range).
    file.to_pattern_set()
        .map_err(|e| anyhow::anyhow!("the designed set: {e}"))?;

    let dir = AtomicDir::create(&a.out, a.overwrite)?;
    let patterns_path = dir.join("patterns.toml");
    file.save(&patterns_path)?;
    // The new set's reference from the projector model (issue #17 item 2): no capture.
    let reference = match cal.projector {
        Some(_) => Some(
            crate::calib::virtual_reference::virtual_reference_files(
                &cal,
                &a.calibration,
                &dir.join("calibration.toml"),
                &patterns_path,
                None,
                None,
                "reference_phase.tif",
            )?
            .plane,
        ),
        None => None,
    };
    let out = dir.commit()?;
    if design.adaptive.rms_per_rad > design.fixed.rms_per_rad && !g.quiet && !g.json {
        errln!(
            "warning: the design is predicted less accurate than its template (x{:.2}): the \
             template's fringes are finer than {:.1} % of the object resolves, and the design keeps \
             those pixels; a template of smaller level ratios (`fringe3d patterns --design`) gives \
             a better one",
            design.fixed.rms_per_rad / design.adaptive.rms_per_rad,
            100.0 * design.fixed.unresolvable
        );
    }
    report(
        g,
        &design,
        &gathered,
        snr,
        reference,
        (&out, &a.calibration),
        bend_report,
    );
    Ok(())
}

/// The samples of a decoded first scan (`--decoded`, with `--first-patterns`): checked against
/// its decode record and the calibration's reference, reconstructed, and mapped onto the
/// projector through its own phase ([`crate::adapt::decoded`]).
fn decoded_samples(
    a: &AdaptArgs,
    (ls_axis, ls_output): (
        fringe3d_core::phase_function::Axis,
        fringe3d_core::pattern::Output,
    ),
    cal: &Calibration,
    dir: &Path,
    crop: Option<([f64; 3], [f64; 3])>,
    g: Global,
) -> Result<(Vec<crate::adapt::Sample>, Gathered)> {
    use crate::calib::files::read_phase_map;
    let Some(fp) = &a.first_patterns else {
        bail!("--decoded needs --first-patterns: the pattern set the folder was decoded with");
    };
    common::input_file(fp)?;
    let first = common::load_set(fp)?;
    // ξ is measured along the first set's axis and extent: the template's must be the same.
    let (fo, to) = (first.set.output(), ls_output);
    if first.set.axis() != ls_axis || (fo.width, fo.height) != (to.width, to.height) {
        bail!(
            "--first-patterns {} ({:?} fringes, {}x{}) and --patterns {} ({:?} fringes, {}x{}) \
             must share the fringe axis and the projector size",
            fp.display(),
            first.set.axis(),
            fo.width,
            fo.height,
            a.patterns.display(),
            ls_axis,
            to.width,
            to.height
        );
    }
    let digest = crate::io::calibration::pattern_digest(&first.set)
        .map_err(|m| anyhow::anyhow!("{}: {m}", fp.display()))?;
    match super::decode::DecodeRecord::read(dir)? {
        Some(r) if r.pattern_digest != digest => bail!(
            "{}: decoded with {} ({}), not with --first-patterns {} ({digest})",
            dir.display(),
            r.patterns,
            r.pattern_digest,
            fp.display()
        ),
        Some(_) => {}
        None => bail!(
            "{}: no {} (not written by `fringe3d decode`): the set its phase was decoded with \
             cannot be checked",
            dir.display(),
            super::decode::RECORD
        ),
    }
    common::check_loaded_reference_patterns(cal, &a.calibration, &first.scan_patterns()?, g.quiet)?;
    if first.set.function().curvature() != 0.0 {
        bail!(
            "{}: a first scan with curved fringes: decode one with straight fringes",
            fp.display()
        );
    }
    let read = |name: &str| -> Result<(u32, u32, Vec<f32>)> {
        let p = dir.join(name);
        common::input_file(&p)?;
        Ok(read_phase_map(&p)?)
    };
    let (w, h, phase) = read("phase.tif")?;
    let (mw, mh, modulation) = read("modulation.tif")?;
    if (w, h) != (cal.camera.width, cal.camera.height) || (mw, mh) != (w, h) {
        bail!(
            "{}: phase.tif is {w}x{h} and modulation.tif {mw}x{mh}, but the camera of {} is {}x{}",
            dir.display(),
            a.calibration.display(),
            cal.camera.width,
            cal.camera.height
        );
    }
    let sc = crate::scan::ScanCalibration::load(&a.calibration, first.set.axis())?;
    let validity: Vec<u8> = phase.iter().map(|p| u8::from(!p.is_finite())).collect();
    let cloud = sc.reconstruct(&phase, &validity, true)?;
    let map_path = cal
        .reference_map_path(&a.calibration)
        .ok_or_else(|| anyhow::anyhow!("{}: no [reference]", a.calibration.display()))?;
    let (rw, rh, raw) = read_phase_map(&map_path)?;
    let reference = crate::adapt::decoded::Reference {
        calibration: cal,
        map: (&raw, rw as usize, rh as usize),
    };
    Ok(crate::adapt::decoded::samples(
        &reference,
        &first.set,
        &cloud,
        &phase,
        &modulation,
        crop,
    ))
}

fn report(
    g: Global,
    d: &Adapted,
    gathered: &Gathered,
    snr: Option<(f64, (f64, f64))>,
    reference: Option<([f64; 3], [f64; 3])>,
    (out, calibration): (&Path, &Path),
    bend: Option<(f64, f64, f64, Option<f64>, bool)>,
) {
    let capture = format!(
        "{}: no projector model, so no virtual reference: project {} onto the reference plane, \
         capture it and run `fringe3d calibrate reference -p {} -c {} IMAGES` before scanning \
         with the new set",
        calibration.display(),
        out.join("patterns.toml").display(),
        out.join("patterns.toml").display(),
        calibration.display()
    );
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
                "reference": reference.map(|(point, normal)| json!({"calibration":
                    out.join("calibration.toml"), "point": point, "normal": normal})),
                "capture": reference.is_none().then_some(&capture),
                "bend": bend.map(|(c, w0, e, gain, used)| json!({"curvature": c, "bend_center": w0,
                    "epipole": e, "predicted_rms_gain": gain, "used": used}))})
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
    if let Some((c, w0, e, bgain, used)) = bend {
        let bgain = bgain.map_or("no design".to_string(), |x| format!("x{x:.3}"));
        if used {
            outln!(
                "  fringes curved about the projector's epipole (at {e:.0} px along the axis): \
                 curvature {c:.3e}, bend_center {w0:.1}; predicted RMS {bgain} against straight ones"
            );
        } else {
            outln!(
                "  fringes straight: bending them about the projector's epipole (at {e:.0} px \
                 along the axis) is predicted at {bgain}: not kept (it must gain 1 % on the same \
                 pixels, lose none, and keep the fringes within 2 % of their density along the axis)"
            );
        }
    }
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
    match reference {
        Some((point, normal)) => outln!(
            "wrote {} with a virtual reference for the new set (plane through {point:?}, normal {normal:?}): no capture needed",
            out.join("calibration.toml").display()
        ),
        None => outln!("{capture}"),
    }
}
