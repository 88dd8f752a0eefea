//! `fringe3d render`: synthetic fringe-projection datasets with ground truth.

use crate::render::dataset::{DatasetOptions, planned_rows, write_dataset};
use crate::render::scene::{BUILTIN_SCENES, Overrides};
use crate::render::{Scene, default_rig};
use anyhow::{Context, bail};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

const AFTER_HELP: &str = "\
Built-in scenes: sphere, ballbar, cylinder, steps, freeform, plane, reference, checkerboard, plates, boards
(all on the default rig: camera 1280x1024, f = 1550 px; projector 1024x768 at 225 mm to the
right, aimed at z = 600 mm; measurement volume 280 x 220 x 250 mm, reference plane z = 730 mm).

Examples:
  fringe3d render --scene sphere --out data/sphere
  fringe3d render --scene examples/scenes/steps.toml --out data/steps --noise 2 --bits 12
  fringe3d render --scene reference --out data/ref --size 640x512 --supersample 1 --overwrite
  fringe3d render --scene checkerboard --print > my_board.toml

The dataset folder holds img_NN.png (set order) and patterns.toml, calibration.toml with
reference_phase.tif (decoded from a render of the reference plane), scene.toml, truth/ (points,
phase, projector coordinates, mask, object ids) and manifest.json (SHA-256 of every file).
See docs/render.md.";

/// Arguments of `fringe3d render`.
#[derive(clap::Args, Debug)]
#[command(after_help = AFTER_HELP)]
pub struct RenderArgs {
    /// A built-in scene name or a scene file (.toml).
    #[arg(long, value_name = "NAME|FILE.toml")]
    pub scene: Option<String>,
    /// Output dataset folder (written atomically).
    #[arg(long, value_name = "DIR")]
    pub out: Option<PathBuf>,
    /// Seed of the camera noise (and of random board poses).
    #[arg(long, value_name = "N")]
    pub seed: Option<u64>,
    /// Camera noise σ, gray levels of the output bit depth.
    #[arg(long, value_name = "SIGMA")]
    pub noise: Option<f64>,
    /// Camera bit depth.
    #[arg(long, value_parser = ["8", "12", "16"])]
    pub bits: Option<String>,
    /// Projector pattern bit depth.
    #[arg(long = "pattern-bits", value_parser = ["8", "16"])]
    pub pattern_bits: Option<String>,
    /// Samples per pixel side (n × n per pixel).
    #[arg(long, value_name = "N")]
    pub supersample: Option<u32>,
    /// Projector defocus σ, projector pixels (0 = sharp DMD pixels).
    #[arg(long, value_name = "SIGMA")]
    pub defocus: Option<f64>,
    /// Camera image size (same field of view), e.g. 640x512.
    #[arg(long, value_name = "WxH")]
    pub size: Option<String>,
    /// Relative exposure: the gain (given or automatic) times this, e.g. 0.25 for the short
    /// exposure of an HDR series (render each with its own --seed).
    #[arg(long, value_name = "F")]
    pub exposure: Option<f64>,
    /// Replace an existing, non-empty output folder.
    #[arg(long)]
    pub overwrite: bool,
    /// Print the resolved scene as TOML and exit (no rendering).
    #[arg(long)]
    pub print: bool,
    /// List the built-in scenes and exit.
    #[arg(long)]
    pub list: bool,
}

fn parse_size(s: &str) -> anyhow::Result<(u32, u32)> {
    let (w, h) = s
        .split_once(['x', 'X'])
        .with_context(|| format!("--size {s:?}: expected WxH, e.g. 640x512"))?;
    let w: u32 = w
        .trim()
        .parse()
        .with_context(|| format!("--size {s:?}: width is not a number"))?;
    let h: u32 = h
        .trim()
        .parse()
        .with_context(|| format!("--size {s:?}: height is not a number"))?;
    if !(8..=16384).contains(&w) || !(8..=16384).contains(&h) {
        bail!("--size {s:?}: width and height must be 8 to 16384");
    }
    Ok((w, h))
}

/// Run `fringe3d render`.
pub fn run(a: RenderArgs, g: super::Global) -> anyhow::Result<()> {
    if a.list {
        if g.json {
            outln!(
                "{}",
                serde_json::json!({"scenes": BUILTIN_SCENES, "default_rig": default_rig()})
            );
        } else {
            for s in BUILTIN_SCENES {
                outln!("{s}");
            }
        }
        return Ok(());
    }
    let Some(scene_arg) = a.scene.as_deref() else {
        bail!(
            "--scene is required (a built-in name: {}, or a .toml file)",
            BUILTIN_SCENES.join(", ")
        );
    };
    let o = Overrides {
        seed: a.seed,
        noise: a.noise,
        bits: a.bits.as_deref().map(|b| b.parse()).transpose()?,
        pattern_bits: a.pattern_bits.as_deref().map(|b| b.parse()).transpose()?,
        supersample: a.supersample,
        defocus: a.defocus,
        size: a.size.as_deref().map(parse_size).transpose()?,
        exposure: a.exposure,
    };
    let is_file = scene_arg.ends_with(".toml") || Path::new(scene_arg).is_file();
    let scene = if is_file {
        super::common::input_file(Path::new(scene_arg))?;
        Scene::load(Path::new(scene_arg), &o)?
    } else {
        if !BUILTIN_SCENES.contains(&scene_arg) {
            bail!(
                "--scene {scene_arg:?}: no such built-in scene ({}) and not a .toml file",
                BUILTIN_SCENES.join(", ")
            );
        }
        Scene::builtin(scene_arg, &o)?
    };
    if a.print {
        out!("{}", scene.spec.to_toml()?);
        return Ok(());
    }
    let Some(out) = a.out else {
        bail!("--out DIR is required (or --print to show the scene)");
    };
    super::common::dir_out(&out, "--out")?;
    let total = planned_rows(&scene);
    let show = !g.quiet && !g.json;
    let bar = indicatif::ProgressBar::hidden();
    bar.set_length(total);
    if let Ok(style) = indicatif::ProgressStyle::with_template(
        "{spinner} rendering {bar:40} {percent:>3}%  eta {eta}",
    ) {
        bar.set_style(style);
    }
    let start = Instant::now();
    let shown = AtomicBool::new(false);
    let progress = |n: u64| {
        bar.inc(n);
        if show
            && !shown.load(Ordering::Relaxed)
            && start.elapsed() > Duration::from_secs(1)
            && !shown.swap(true, Ordering::Relaxed)
        {
            bar.set_draw_target(indicatif::ProgressDrawTarget::stderr());
        }
    };
    let summary = write_dataset(
        &scene,
        &out,
        DatasetOptions {
            overwrite: a.overwrite,
            progress: Some(&progress),
        },
    )
    .with_context(|| {
        format!(
            "rendering scene {:?} into {}",
            scene.spec.name,
            out.display()
        )
    })?;
    bar.finish_and_clear();
    let secs = start.elapsed().as_secs_f64();
    if g.json {
        outln!(
            "{}",
            serde_json::json!({
                "path": summary.path, "scene": scene.spec.name, "kind": summary.kind, "images": summary.images,
                "files": summary.files, "bytes": summary.bytes, "seconds": secs,
                "width": scene.rig.camera.width, "height": scene.rig.camera.height,
            })
        );
    } else if !g.quiet {
        outln!(
            "wrote {} ({} images, {} files, {:.1} MB) in {:.1} s",
            summary.path.display(),
            summary.images,
            summary.files,
            summary.bytes as f64 / 1e6,
            secs
        );
    }
    Ok(())
}
