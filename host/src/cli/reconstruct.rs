//! `fringe3d reconstruct`: a decoded phase map + calibration → point cloud.

use super::cloud_out::{self, CloudArgs, CloudOut, apply_edge_filter, write_cloud};
use super::decode::{DecodeRecord, RECORD};
use super::{Global, common};
use crate::io::calibration::{Calibration, ScanPatterns};
use crate::io::image::{Pixels, ReadLimits, read_gray_limited, read_header};
use anyhow::{Result, bail};
use fringe3d_core::phase_function::Axis;
use std::path::{Path, PathBuf};

/// Arguments of `fringe3d reconstruct`.
#[derive(clap::Args, Debug)]
#[command(
    after_help = "Example:\n  fringe3d decode --patterns scan/patterns.toml scan/ --out decoded/\n  \
fringe3d reconstruct --calibration scan/calibration.toml --decoded decoded/ -o cloud.ply\n\n\
Reads phase.tif and validity.png (both required; and dc.tif, modulation.tif for the per-point\n\
intensity and modulation, when present) from the decode folder.\n\
The folder's decode.toml names the pattern set it was decoded with: one whose digest differs\n\
from the reference's (the calibration's [reference] pattern_digest, or its pattern_set file's)\n\
is refused. A folder without decode.toml (an older decode) is refused when the calibration\n\
records a pattern_digest, else accepted with a warning."
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

/// Check a decode folder's maps against each other: every validity code is known, and every
/// pixel marked valid has a finite phase.
fn check_decoded(
    phase: &[f32],
    validity: &[u8],
    w: usize,
    ppath: &Path,
    vpath: &Path,
) -> Result<()> {
    let unknown = |c: u8| c as usize >= common::CODES;
    if let Some(i) = validity.iter().position(|&c| unknown(c)) {
        bail!(
            "{}: pixel ({}, {}) has validity code {}, but the codes are 0 to {} (docs/formats.md); {} pixels have unknown codes: not a validity map written by `fringe3d decode`",
            vpath.display(),
            i % w,
            i / w,
            validity[i],
            common::CODES - 1,
            validity.iter().filter(|&&c| unknown(c)).count()
        );
    }
    if let Some(i) = (0..phase.len()).find(|&i| validity[i] == 0 && !phase[i].is_finite()) {
        bail!(
            "{}: pixel ({}, {}) has phase {}, but {} marks it valid (code 0)",
            ppath.display(),
            i % w,
            i / w,
            phase[i],
            vpath.display()
        );
    }
    Ok(())
}

/// Check the pattern set a decode folder was decoded with (its [`RECORD`]) against the
/// calibration's reference. A folder without a record (decoded by an older fringe3d) is refused
/// when the calibration records a `pattern_digest` (a current calibration: decode again), and
/// accepted with a warning when it does not (both files predate the check).
fn check_record(cal: &Calibration, cal_path: &Path, decoded: &Path, quiet: bool) -> Result<()> {
    match DecodeRecord::read(decoded)? {
        Some(r) => {
            let scan = ScanPatterns {
                source: format!(
                    "the decoded folder {} (decoded with {}, per its {RECORD})",
                    decoded.display(),
                    r.patterns
                ),
                digest: r.pattern_digest,
            };
            common::check_loaded_reference_patterns(cal, cal_path, &scan, quiet)
        }
        None => {
            let recorded = cal
                .reference
                .as_ref()
                .and_then(|r| r.pattern_digest.as_deref());
            if let Some(d) = recorded {
                bail!(
                    "{}: no {RECORD} (decoded by an older fringe3d): the pattern set of its phase cannot be checked against the reference of {} (pattern_digest {d}); decode the images again with `fringe3d decode`",
                    decoded.display(),
                    cal_path.display()
                );
            }
            if !quiet {
                errln!(
                    "warning: {}: no {RECORD} (decoded by an older fringe3d): the pattern set of its phase cannot be checked against the reference of {}",
                    decoded.display(),
                    cal_path.display()
                );
            }
            Ok(())
        }
    }
}

/// Run `fringe3d reconstruct`.
pub fn run(a: ReconstructArgs, g: Global) -> Result<()> {
    let out = CloudOut::resolve(&a.cloud.out, a.cloud.format, "--out")?;
    let axis = match a.axis.as_deref() {
        Some("eta") => Axis::Eta,
        Some(_) => Axis::Xi,
        None => {
            let cal = Calibration::load(&a.calibration)?;
            match cal.reference.as_ref().and_then(|r| r.pattern_set.as_ref()) {
                Some(ps) => {
                    let p = a.calibration.parent().unwrap_or(Path::new(".")).join(ps);
                    common::load_set(&p)?.set.axis()
                }
                None => Axis::Xi,
            }
        }
    };
    let cal = common::load_calibration(&a.calibration, axis)?;
    let (w, h) = (cal.width(), cal.height());
    let ppath = a.decoded.join("phase.tif");
    let vpath = a.decoded.join("validity.png");
    for p in [&ppath, &vpath] {
        if !p.exists() {
            bail!(
                "{}: missing; --decoded must be a folder written by `fringe3d decode` (phase.tif and validity.png)",
                p.display()
            );
        }
    }
    check_record(&cal.calibration, &a.calibration, &a.decoded, g.quiet)?;
    let phase = read_f32(&ppath, w, h)?;
    let (img, _) = read_gray_limited(&vpath, &ReadLimits::sized(w as u32, h as u32))?;
    let validity = match img.pixels {
        Pixels::U8(v) if v.len() == w * h => v,
        _ => bail!(
            "{}: expected an 8-bit {w}x{h} validity image",
            vpath.display()
        ),
    };
    check_decoded(&phase, &validity, w, &ppath, &vpath)?;
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
    common::warn_if_empty(&hist, &out.describe(), g.quiet);
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
