//! `fringe3d demo`: render a built-in scene, scan it as a user would (files in, files out), and
//! report the accuracy against ground truth.

use super::cloud_out::{CloudArgs, CloudOut, apply_edge_filter, write_cloud};
use super::{Global, common};
use crate::accuracy::{self, Accuracy};
use crate::io::atomic::AtomicDir;
use crate::io::preview;
use crate::render::Scene;
use crate::render::dataset::{DatasetOptions, write_dataset};
use crate::render::scene::{BUILTIN_SCENES, Overrides};
use crate::scan::ScanCalibration;
use anyhow::{Context, Result, bail};
use std::path::PathBuf;
use std::time::Instant;

/// Arguments of `fringe3d demo`.
#[derive(clap::Args, Debug)]
#[command(
    after_help = "Example:\n  fringe3d demo                          # ball bar, default rig, into ./fringe3d-demo\n  \
fringe3d demo --scene sphere --noise 1 --bits 8 --out /tmp/demo\n  \
fringe3d demo --calibrate --noise 1     # calibrate from rendered data, compare with the truth\n\n\
Writes DIR/dataset (the rendered scan with its calibration and ground truth), DIR/cloud.ply,\n\
DIR/phase.png, DIR/depth.png, DIR/error.png (false colour) and DIR/report.json, replacing DIR."
)]
pub struct DemoArgs {
    /// Output folder (replaced if it exists).
    #[arg(long, short = 'o', default_value = "fringe3d-demo")]
    pub out: PathBuf,
    /// Built-in scene to scan.
    #[arg(long, default_value = "ballbar")]
    pub scene: String,
    /// Camera noise σ, gray levels (default: the scene's, noise-free).
    #[arg(long)]
    pub noise: Option<f64>,
    /// Camera bit depth (8, 12 or 16; default: the scene's, 16).
    #[arg(long)]
    pub bits: Option<u8>,
    /// Camera image size, e.g. 640x512 (same field of view; default 1280x1024).
    #[arg(long)]
    pub size: Option<String>,
    /// Noise seed.
    #[arg(long)]
    pub seed: Option<u64>,
    /// Keep points at depth discontinuities and light edges (to see what the edge filter removes).
    #[arg(long)]
    pub no_edge_filter: bool,
    /// Instead of scanning one scene: render the calibration data (checkerboard views, the plate
    /// at two positions, the reference plane), run `calibrate camera`, `calibrate projector` and
    /// `calibrate reference` on the files (with the rig's measurement volume as `--depth-range`),
    /// compare every estimate with the truth, then scan the
    /// sphere and the ball bar with the true and with the self-calibrated file (sphere diameter
    /// and ball-bar length errors, VDI/VDE 2634-2 style).
    #[arg(long)]
    pub calibrate: bool,
    /// Checkerboard views rendered for `--calibrate`.
    #[arg(long, default_value_t = 15)]
    pub views: usize,
}

/// Run `fringe3d demo`.
pub fn run(a: DemoArgs, g: Global) -> Result<()> {
    common::dir_out(&a.out, "--out")?;
    if a.calibrate {
        return run_calibrate(a, g);
    }
    if !BUILTIN_SCENES.contains(&a.scene.as_str())
        || matches!(
            a.scene.as_str(),
            "reference" | "checkerboard" | "plates" | "boards"
        )
    {
        bail!(
            "--scene {:?}: the demo scans one of sphere, ballbar, cylinder, steps, freeform, plane",
            a.scene
        );
    }
    let size = parse_size(a.size.as_deref())?;
    let o = Overrides {
        seed: a.seed,
        noise: a.noise,
        bits: a.bits,
        size,
        ..Overrides::default()
    };
    let say = |s: String| {
        if !g.quiet && !g.json {
            outln!("{s}");
        }
    };
    let t0 = Instant::now();
    let dir = AtomicDir::create(&a.out, true)?;
    let scene = Scene::builtin(&a.scene, &o)?;
    let ds = dir.join("dataset");
    say(format!(
        "1/4 rendering scene {:?} with ground truth ...",
        a.scene
    ));
    let pb = common::progress(
        crate::render::dataset::planned_rows(&scene),
        "rendering",
        g.quiet || g.json,
    );
    let inc = |n: u64| pb.inc(n);
    write_dataset(
        &scene,
        &ds,
        DatasetOptions {
            overwrite: true,
            progress: Some(&inc),
        },
    )?;
    pb.finish_and_clear();
    let t_render = t0.elapsed();

    say("2/4 scanning: decode (paper §5.2) and reconstruct (§6) ...".into());
    let ls = common::load_set(&ds.join("patterns.toml"))?;
    let cal = ScanCalibration::load(&ds.join("calibration.toml"), ls.set.axis())?;
    let t1 = Instant::now();
    let imgs = common::load_images(&ls, &[], g.quiet)?;
    let d = common::decode(&ls.set, &imgs, common::decode_config(&imgs))?;
    let mut cloud = cal.reconstruct(&d.phase, &d.validity, true)?;
    let cloud_args = CloudArgs {
        out: dir.join("cloud.ply"),
        format: None,
        ascii: false,
        organized: false,
        no_edge_filter: a.no_edge_filter,
        max_angle: 80.0,
    };
    apply_edge_filter(&cloud_args, &cal, &mut cloud)?;
    let t_scan = t1.elapsed();
    let n = write_cloud(
        &cloud_args,
        &CloudOut::resolve(&cloud_args.out, None, "--out")?,
        &cloud,
        &d.dc,
        &d.modulation,
        vec![format!("fringe3d demo, scene {}", a.scene)],
    )?;

    say("3/4 comparing with ground truth ...".into());
    let truth = accuracy::load_truth(&ds)?;
    let acc = accuracy::evaluate(&cloud, &truth)?;

    say("4/4 writing previews ...".into());
    let (w, h) = (cloud.width as u32, cloud.height as u32);
    preview::write_rgb_png(
        &dir.join("phase.png"),
        w,
        h,
        &preview::colourize(&d.phase, &d.validity),
    )
    .map_err(anyhow::Error::msg)?;
    let z: Vec<f32> = cloud.xyz.chunks_exact(3).map(|p| p[2]).collect();
    preview::write_rgb_png(
        &dir.join("depth.png"),
        w,
        h,
        &preview::colourize(&z, &cloud.validity),
    )
    .map_err(anyhow::Error::msg)?;
    let err: Vec<f32> = (0..cloud.width * cloud.height)
        .map(|i| {
            let t = &truth.points[3 * i..3 * i + 3];
            let p = &cloud.xyz[3 * i..3 * i + 3];
            (((p[0] as f64 - t[0]).powi(2)
                + (p[1] as f64 - t[1]).powi(2)
                + (p[2] as f64 - t[2]).powi(2))
            .sqrt()) as f32
        })
        .collect();
    preview::write_rgb_png(
        &dir.join("error.png"),
        w,
        h,
        &preview::colourize(&err, &cloud.validity),
    )
    .map_err(anyhow::Error::msg)?;
    let hist = common::histogram(&cloud.validity);
    let report = serde_json::json!({
        "command": "demo", "scene": a.scene, "points": n,
        "width": w, "height": h, "bits": imgs.bits,
        "validity": common::validity_json(&hist),
        "accuracy": &acc,
        "seconds": {"render": t_render.as_secs_f64(), "scan": t_scan.as_secs_f64(), "total": t0.elapsed().as_secs_f64()},
    });
    let text = serde_json::to_string_pretty(&report)?;
    crate::io::atomic::write_atomic(&dir.join("report.json"), |wr| wr.write_all(text.as_bytes()))?;
    let out = dir.commit()?;
    if g.json {
        outln!("{text}");
    } else if !g.quiet {
        print_report(&acc, &hist, n, t_scan.as_secs_f64(), &out);
    }
    Ok(())
}

/// Parse `--size WxH`.
fn parse_size(s: Option<&str>) -> Result<Option<(u32, u32)>> {
    let Some(s) = s else { return Ok(None) };
    let (w, h) = s
        .split_once('x')
        .with_context(|| format!("--size {s:?}: expected WxH, e.g. 640x512"))?;
    Ok(Some((
        w.parse()
            .with_context(|| format!("--size {s:?}: bad width"))?,
        h.parse()
            .with_context(|| format!("--size {s:?}: bad height"))?,
    )))
}

/// `fringe3d demo --calibrate`.
fn run_calibrate(a: DemoArgs, g: Global) -> Result<()> {
    if a.views < 3 {
        bail!(
            "--views {}: the camera calibration needs at least 3 checkerboard views",
            a.views
        );
    }
    let dir = AtomicDir::create(&a.out, true)?;
    let opts = super::demo_calibrate::DemoOptions {
        size: parse_size(a.size.as_deref())?,
        noise: a.noise,
        bits: a.bits,
        seed: a.seed,
        views: a.views,
        quiet: g.quiet || g.json,
        ..super::demo_calibrate::DemoOptions::default()
    };
    let (_, report) = super::demo_calibrate::demo_calibrate_with(dir.path(), &opts)?;
    // The report names files inside the temporary folder: name them where they will be.
    let tmp = serde_json::to_string(&dir.path().display().to_string())?;
    let fin = serde_json::to_string(&dir.target().display().to_string())?;
    let text = serde_json::to_string_pretty(&report)?
        .replace(tmp.trim_end_matches('"'), fin.trim_end_matches('"'));
    let report: serde_json::Value = serde_json::from_str(&text)?;
    crate::io::atomic::write_atomic(&dir.join("calibration").join("demo_report.json"), |w| {
        w.write_all(text.as_bytes())
    })?;
    let out = dir.commit()?;
    if g.json {
        outln!("{text}");
    } else if !g.quiet {
        print_calibration_report(&report, &out);
    }
    Ok(())
}

fn print_calibration_report(r: &serde_json::Value, out: &std::path::Path) {
    let f = |v: &serde_json::Value| v.as_f64().unwrap_or(f64::NAN);
    let c = &r["camera"];
    outln!();
    outln!(
        "camera: {} views used; reprojection RMS {:.3} px; corners vs truth RMS {:.3} px; fx {:+.4} %, fy {:+.4} %, principal point off by {:.3} px",
        c["views_used"],
        f(&c["reprojection_rms_px"]),
        f(&c["corner_error_vs_truth_px"]["rms"]),
        100.0 * f(&c["fx_relative_error"]),
        100.0 * f(&c["fy_relative_error"]),
        f(&c["principal_point_error_px"])
    );
    let p = &r["projector"];
    outln!(
        "projector centre: off by {:.3} mm from truth ({} lines, RMS line distance {:.3} mm)",
        f(&p["error_norm_mm"]),
        p["lines"],
        f(&p["rms_line_distance_mm"])
    );
    if let Some(d) = p["depth_range"].as_array() {
        outln!(
            "depth range [{:.1}, {:.1}] mm: {}",
            d.first().map(f).unwrap_or(f64::NAN),
            d.get(1).map(f).unwrap_or(f64::NAN),
            p["depth_range_source"].as_str().unwrap_or("")
        );
    }
    let rf = &r["reference"];
    outln!(
        "reference plane: {:+.3} mm along the normal, normal off by {:.4}°",
        f(&rf["offset_along_normal_mm"]),
        f(&rf["normal_angle_deg"])
    );
    for s in r["scans"].as_array().into_iter().flatten() {
        let um = |v: &serde_json::Value| 1e3 * f(v);
        let (t, o) = (&s["true_calibration"], &s["self_calibration"]);
        outln!(
            "scan {}: interior RMS {:.1} µm with the true calibration, {:.1} µm self-calibrated (ratio {:.2}; after a rigid alignment {:.2}); max error {:.3} / {:.3} mm",
            s["scene"].as_str().unwrap_or("?"),
            um(&t["interior"]["rms"]),
            um(&o["interior"]["rms"]),
            f(&s["rms_ratio_interior"]),
            f(&s["rms_ratio_interior_aligned"]),
            f(&t["interior"]["max"]),
            f(&o["interior"]["max"])
        );
        for (name, cal) in [("true", t), ("self", o)] {
            for sp in cal["spheres"].as_array().into_iter().flatten() {
                outln!(
                    "  {name}: sphere {} diameter error {:+.1} µm",
                    sp["name"].as_str().unwrap_or("?"),
                    um(&sp["diameter_error_mm"])
                );
            }
            for b in cal["ball_bars"].as_array().into_iter().flatten() {
                outln!(
                    "  {name}: ball-bar length error {:+.1} µm",
                    um(&b["length_error_mm"])
                );
            }
        }
    }
    outln!(
        "wrote {}/{{checkerboard, plates, reference, scans, calibration/}} (report: calibration/demo_report.json)",
        out.display()
    );
}

fn print_report(
    acc: &Accuracy,
    hist: &common::Histogram,
    n: u64,
    scan_s: f64,
    out: &std::path::Path,
) {
    outln!();
    outln!(
        "scan: {} points in {:.0} ms (decode + reconstruct, all cores); {}",
        n,
        scan_s * 1e3,
        common::validity_summary(hist)
    );
    outln!(
        "coverage: {} of {} lit pixels reconstructed ({:.1} %), {} spurious points",
        acc.valid_pixels,
        acc.truth_pixels,
        100.0 * acc.valid_pixels as f64 / acc.truth_pixels.max(1) as f64,
        acc.spurious_points
    );
    let um = |x: f64| x * 1e3;
    outln!(
        "error against ground truth, away from depth edges: RMS {:.1} µm, 95 % {:.1} µm, max {:.1} µm ({} points)",
        um(acc.interior.rms),
        um(acc.interior.p95),
        um(acc.interior.max),
        acc.interior.count
    );
    outln!(
        "error against ground truth, all points (nearest surface in the pixel's 3x3 neighbourhood): RMS {:.1} µm, 95 % {:.1} µm, max {:.1} µm",
        um(acc.all.rms),
        um(acc.all.p95),
        um(acc.all.max)
    );
    for s in &acc.spheres {
        outln!(
            "sphere {}: diameter {:.4} mm (true {:.4}), error {:+.1} µm, form RMS {:.1} µm",
            s.name,
            s.fitted_diameter,
            s.true_diameter,
            um(s.diameter_error),
            um(s.form_rms)
        );
    }
    for b in &acc.ball_bars {
        outln!(
            "ball bar: length {:.4} mm (true {:.4}), error {:+.1} µm",
            b.measured_length,
            b.true_length,
            um(b.length_error)
        );
    }
    outln!(
        "wrote {}/{{cloud.ply, phase.png, depth.png, error.png, report.json, dataset/}}",
        out.display()
    );
}
