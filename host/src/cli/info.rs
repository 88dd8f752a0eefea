//! `fringe3d info`: describe a dataset folder, calibration file, pattern-set file, image or
//! compiled reconstruction.

use super::{Global, common};
use crate::io::calibration::Calibration;
use crate::io::image::{Pixels, read_gray};
use crate::io::import::{ForeignKind, detect, import_any_camera, inspect_rig};
use crate::io::input::{MAX_TEXT_BYTES, read_text_limited};
use anyhow::{Context, Result, bail};
use serde_json::json;
use std::path::{Path, PathBuf};

/// Arguments of `fringe3d info`.
#[derive(clap::Args, Debug)]
#[command(
    after_help = "Examples:\n  fringe3d info demo-out/dataset          # a dataset folder (manifest.json)\n  \
fringe3d info calibration.toml          # a calibration\n  fringe3d info examples/patterns/paper8.toml\n  \
fringe3d info stereo.yml                # another tool's calibration (OpenCV, SLStudio, SLMaster, Bouguet)\n  \
fringe3d info phase.tif                 # an image or float map\n  \
fringe3d info reconstruction.f3c        # a compiled reconstruction (fringe3d compile)"
)]
pub struct InfoArgs {
    /// What to describe.
    pub path: PathBuf,
}

/// Run `fringe3d info`.
pub fn run(a: InfoArgs, g: Global) -> Result<()> {
    let p = &a.path;
    let v = if p.is_dir() {
        let m = p.join("manifest.json");
        if !m.is_file() {
            bail!(
                "{}: a folder without manifest.json is no fringe3d dataset",
                p.display()
            );
        }
        let text = read_text_limited(&m, MAX_TEXT_BYTES)
            .with_context(|| format!("{}: cannot read", m.display()))?;
        let mut v: serde_json::Value = serde_json::from_str(&text)
            .with_context(|| format!("{}: not valid JSON", m.display()))?;
        if let Some(o) = v.as_object_mut() {
            o.insert("kind".into(), json!("dataset"));
        }
        v
    } else {
        let ext = p
            .extension()
            .and_then(|e| e.to_str())
            .unwrap_or("")
            .to_ascii_lowercase();
        match ext.as_str() {
            "toml" => toml_info(p)?,
            "png" | "tif" | "tiff" | "bmp" | "pgm" | "npy" | "raw" => image_info(p)?,
            "yml" | "yaml" | "xml" | "json" | "m" => foreign_info(p)?,
            "f3c" => compiled_info(p)?,
            _ => bail!(
                "{}: unknown kind of file (expected a dataset folder, .toml, .png, .tif, .bmp, .pgm, .npy, .raw (with raw.toml), a compiled reconstruction .f3c, or another tool's calibration: .yml, .yaml, .xml, .json, .m)",
                p.display()
            ),
        }
    };
    if g.json {
        outln!("{}", serde_json::to_string_pretty(&v)?);
    } else if !g.quiet {
        print_tree(&v, 0);
    }
    Ok(())
}

/// A compiled reconstruction (`fringe3d compile`): its size, range and how many pixels it covers.
fn compiled_info(p: &Path) -> Result<serde_json::Value> {
    let f = crate::compiled::CompiledFile::read_any(p)?;
    let pixels = f.width as usize * f.height as usize;
    let compiled = f.compiled_count();
    let no_reference = f.no_reference_count();
    let digest: String = f.source_digest.iter().map(|b| format!("{b:02x}")).collect();
    Ok(json!({
        "kind": "compiled reconstruction",
        "width": f.width,
        "height": f.height,
        "depth_range_mm": [f.z_min, f.z_max],
        "tolerance_um": (f.tolerance_mm as f64 * 1e9).round() / 1e6,
        "pixels": pixels,
        "compiled": compiled,
        "clipped": f.clipped_count(),
        "no_reference": no_reference,
        "left_to_the_search": pixels - compiled - no_reference,
        "source_digest": format!("sha256:{digest}"),
    }))
}

fn toml_info(p: &Path) -> Result<serde_json::Value> {
    let text = read_text_limited(p, MAX_TEXT_BYTES)
        .with_context(|| format!("{}: cannot read", p.display()))?;
    let raw: toml::Table = text
        .parse()
        .with_context(|| format!("{}: not valid TOML", p.display()))?;
    if raw.contains_key("camera") {
        let c = Calibration::load(p)?;
        let mut v = serde_json::to_value(&c)?;
        if let Some(o) = v.as_object_mut() {
            o.insert("kind".into(), json!("calibration"));
            let reference = c.reference_map_path(p);
            o.insert(
                "reference_map_exists".into(),
                json!(reference.as_ref().map(|r| r.is_file())),
            );
            o.insert("baseline_mm".into(), json!(norm(&c.projector_centre)));
            o.insert("reference_present".into(), json!(c.reference.is_some()));
            o.insert(
                "projector_model_present".into(),
                json!(c.projector.is_some()),
            );
            // The camera's σ from its covariance (what the later steps add to theirs).
            o.insert(
                "camera_std".into(),
                json!(c.camera_covariance.map(|cv| {
                    let sd = cv.std();
                    crate::io::calibration::COVARIANCE_ORDER
                        .iter()
                        .zip(sd)
                        .map(|(n, s)| (n.to_string(), json!(s)))
                        .collect::<serde_json::Map<_, _>>()
                })),
            );
        }
        Ok(v)
    } else if raw.contains_key("projector") {
        let ls = common::load_set(p)?;
        let s = &ls.set;
        let levels: Vec<_> = s
            .levels()
            .iter()
            .map(|l| match l.gray() {
                Some(g) => json!({"scale": l.scale(), "gray_bits": g.bits(), "complementary": g.complementary(), "shifted": g.is_shifted(), "inverse": g.inverse(), "images": l.len(), "dc_level": false}),
                None => json!({"scale": l.scale(), "shifts_rad": l.shifts(), "images": l.len(), "dc_level": l.has_dc()}),
            })
            .collect();
        let o = s.output();
        let (lo, hi) = s.coarse_range();
        let finest = s.levels().last().map(|l| l.scale()).unwrap_or(1.0);
        // The coarse range is that of the start's scale: the coarsest level's, a heterodyne
        // set's beat, a coprime set's unit.
        let start = s.relation().start_scale(s.levels()).unwrap_or(1.0);
        Ok(json!({
            "kind": "pattern set",
            "images": s.image_count(),
            "axis": format!("{:?}", s.axis()),
            "projector": {"width": o.width, "height": o.height, "i_min": o.i_min, "i_max": o.i_max},
            "levels": levels,
            "order": s.order().iter().map(|i| [i.level, i.shift]).collect::<Vec<_>>(),
            "coarse_phase_range_rad": [lo, hi],
            "finest_periods_across": (hi - lo) * finest / start / std::f64::consts::TAU,
            "convention": format!("{:?}", s.convention()),
            "unwrap": format!("{:?}", s.relation()),
            "binary": crate::io::pattern_file::BinaryName::of(s.binarization()).name(),
            "phase_offset_rad": s.phase_offset(),
            "image_files": ls.file.image_paths(p),
        }))
    } else {
        bail!(
            "{}: neither a calibration ([camera]) nor a pattern set ([projector])",
            p.display()
        )
    }
}

fn norm(v: &[f64; 3]) -> f64 {
    (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()
}

/// Another tool's calibration: a full camera + projector calibration (what `calibrate import`
/// would make of it) or a camera alone (what `--camera-from` reads).
fn foreign_info(p: &Path) -> Result<serde_json::Value> {
    common::input_file(p)?;
    match detect(p, None)? {
        ForeignKind::Rig(format) => {
            let (rig, [cam_size, proj_size]) = inspect_rig(p)?;
            let pr = &rig.projector;
            let mut projector = serde_json::to_value(pr.intrinsics)?;
            if let Some(o) = projector.as_object_mut() {
                o.insert("size_in_file".into(), json!(proj_size));
            }
            let mut camera = serde_json::to_value(rig.camera)?;
            if let Some(o) = camera.as_object_mut() {
                o.insert("size_in_file".into(), json!(cam_size));
            }
            let mut note = Vec::new();
            if !cam_size {
                note.push("the camera's size is not in the file (shown: twice the principal point); `calibrate import` needs --camera-size");
            }
            if !proj_size {
                note.push("the projector's size is not in the file (shown: twice the principal point); `calibrate import` needs --projector-size");
            }
            Ok(json!({
                "kind": "full calibration (camera + projector)",
                "format": format.name(),
                "camera": camera,
                "projector": projector,
                "projector_rotation": pr.rotation,
                "projector_centre": pr.translation,
                "baseline_mm": norm(&pr.translation),
                "depth_range": rig.depth_range,
                "reference_present": false,
                "notes": note,
                "next": "fringe3d calibrate import FILE -o calibration.toml, then fringe3d calibrate reference",
            }))
        }
        kind => {
            let cam = import_any_camera(p, None)?;
            let what = if kind == ForeignKind::BouguetCamera {
                "Bouguet Calib_Results.m"
            } else {
                "opencv"
            };
            Ok(json!({
                "kind": "camera",
                "format": what,
                "camera": cam,
                "projector": null,
                "reference_present": false,
                "next": "fringe3d calibrate projector PLATES... --camera-from FILE",
            }))
        }
    }
}

fn image_info(p: &Path) -> Result<serde_json::Value> {
    let (img, info) = read_gray(p)?;
    let (kind, stats) = match &img.pixels {
        Pixels::F32(v) => {
            let finite: Vec<f32> = v.iter().copied().filter(|x| x.is_finite()).collect();
            let (lo, hi) = finite
                .iter()
                .fold((f32::INFINITY, f32::NEG_INFINITY), |(a, b), x| {
                    (a.min(*x), b.max(*x))
                });
            (
                "float",
                json!({"finite": finite.len(), "nan_or_inf": v.len() - finite.len(), "min": lo, "max": hi}),
            )
        }
        px => {
            let n = px.len();
            let (mut lo, mut hi, mut sum) = (f64::INFINITY, f64::NEG_INFINITY, 0.0);
            for i in 0..n {
                let x = px.get_f64(i).unwrap_or(0.0);
                lo = lo.min(x);
                hi = hi.max(x);
                sum += x;
            }
            (
                "integer",
                json!({"min": lo, "max": hi, "mean": sum / n.max(1) as f64}),
            )
        }
    };
    Ok(json!({
        "kind": "image",
        "format": format!("{:?}", info.format),
        "width": img.width, "height": img.height,
        "samples": kind, "significant_bits": img.significant_bits,
        "converted_from_color": info.converted_from_color,
        "stats": stats,
    }))
}

fn print_tree(v: &serde_json::Value, indent: usize) {
    let pad = "  ".repeat(indent);
    match v {
        serde_json::Value::Object(m) => {
            for (k, x) in m {
                match x {
                    serde_json::Value::Object(_) => {
                        outln!("{pad}{k}:");
                        print_tree(x, indent + 1);
                    }
                    serde_json::Value::Array(a) if a.iter().any(|e| e.is_object()) => {
                        outln!("{pad}{k}:");
                        for (i, e) in a.iter().enumerate() {
                            outln!("{pad}  [{i}]");
                            print_tree(e, indent + 2);
                        }
                    }
                    _ => outln!("{pad}{k}: {x}"),
                }
            }
        }
        other => outln!("{pad}{other}"),
    }
}
