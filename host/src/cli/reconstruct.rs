//! `fringe3d reconstruct`: a decoded phase map + calibration → point cloud.

use super::cloud_out::{self, CloudArgs, CloudOut, apply_edge_filter, write_cloud};
use super::{Global, common};
use crate::io::image::{Pixels, ReadLimits, read_gray_limited, read_header};
use crate::scan::ScanCalibration;
use anyhow::{Result, bail};
use fringe3d_core::phase_function::Axis;
use std::path::{Path, PathBuf};

/// Arguments of `fringe3d reconstruct`.
#[derive(clap::Args, Debug)]
#[command(
    after_help = "Example:\n  fringe3d decode --patterns scan/patterns.toml scan/ --out decoded/\n  \
fringe3d reconstruct --calibration scan/calibration.toml --decoded decoded/ -o cloud.ply\n\n\
Reads phase.tif and validity.png (and dc.tif, modulation.tif for the per-point intensity and\n\
modulation, when present) from the decode folder."
)]
pub struct ReconstructArgs {
    /// The calibration file (TOML).
    #[arg(long, short = 'c')]
    pub calibration: PathBuf,
    /// A folder written by `fringe3d decode`.
    #[arg(long, short = 'd')]
    pub decoded: PathBuf,
    /// Fringe direction of the phase: `xi` (vertical fringes) or `eta` (horizontal). Default: the
    /// reference's pattern set when the calibration names one, else xi.
    #[arg(long, value_parser = ["xi", "eta"])]
    pub axis: Option<String>,
    /// Output.
    #[command(flatten)]
    pub cloud: CloudArgs,
}

/// Read a float map of the calibrated camera's size (checked from the header, before decoding).
fn read_f32(p: &Path, w: usize, h: usize) -> Result<Vec<f32>> {
    let hdr = read_header(p)?;
    if (hdr.width as usize, hdr.height as usize) != (w, h) {
        bail!(
            "{}: {}x{} pixels, but the calibrated camera is {w}x{h}",
            p.display(),
            hdr.width,
            hdr.height
        );
    }
    let (img, _) = read_gray_limited(p, &ReadLimits::sized(w as u32, h as u32))?;
    match img.pixels {
        Pixels::F32(v) => Ok(v),
        _ => bail!("{}: expected a 32-bit float TIFF", p.display()),
    }
}

/// Run `fringe3d reconstruct`.
pub fn run(a: ReconstructArgs, g: Global) -> Result<()> {
    let out = CloudOut::resolve(&a.cloud.out, a.cloud.format, "--out")?;
    let axis = match a.axis.as_deref() {
        Some("eta") => Axis::Eta,
        Some(_) => Axis::Xi,
        None => {
            let cal = crate::io::calibration::Calibration::load(&a.calibration)?;
            match cal.reference.as_ref().and_then(|r| r.pattern_set.as_ref()) {
                Some(ps) => {
                    let p = a.calibration.parent().unwrap_or(Path::new(".")).join(ps);
                    common::load_set(&p)?.set.axis()
                }
                None => Axis::Xi,
            }
        }
    };
    let cal = ScanCalibration::load(&a.calibration, axis)?;
    let (w, h) = (cal.width(), cal.height());
    let phase = read_f32(&a.decoded.join("phase.tif"), w, h)?;
    let vpath = a.decoded.join("validity.png");
    let validity: Vec<u8> = if vpath.is_file() {
        let (img, _) = read_gray_limited(&vpath, &ReadLimits::sized(w as u32, h as u32))?;
        match img.pixels {
            Pixels::U8(v) if v.len() == w * h => v,
            _ => bail!(
                "{}: expected an 8-bit {w}x{h} validity image",
                vpath.display()
            ),
        }
    } else {
        phase
            .iter()
            .map(|p| {
                if p.is_finite() {
                    0
                } else {
                    fringe3d_core::Validity::PhaseOutOfRange as u8
                }
            })
            .collect()
    };
    let opt = |name: &str| -> Result<Vec<f32>> {
        let p = a.decoded.join(name);
        if p.is_file() {
            read_f32(&p, w, h)
        } else {
            Ok(vec![f32::NAN; w * h])
        }
    };
    let (dc, modulation) = (opt("dc.tif")?, opt("modulation.tif")?);
    let mut cloud = cal.reconstruct(&phase, &validity, true)?;
    apply_edge_filter(&a.cloud, &cal, &mut cloud)?;
    let n = write_cloud(
        &a.cloud,
        &out,
        &cloud,
        &dc,
        &modulation,
        vec![format!("fringe3d reconstruct of {}", a.decoded.display())],
    )?;
    let hist = common::histogram(&cloud.validity);
    if g.json {
        cloud_out::say(
            &out,
            &serde_json::json!({"command": "reconstruct", "out": a.cloud.out, "points": n, "validity": common::validity_json(&hist)})
            .to_string(),
        );
    } else if !g.quiet {
        cloud_out::say(&out, &common::validity_summary(&hist));
        cloud_out::say(&out, &format!("wrote {n} points to {}", out.describe()));
    }
    Ok(())
}
