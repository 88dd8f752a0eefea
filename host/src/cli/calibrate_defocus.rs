//! `fringe3d calibrate defocus`: the projector's effective blur from one scan of a binary
//! pattern set (the reference plane is ideal), into the calibration's `projector_defocus`
//! (docs/binary.md, [`crate::response::defocus`]).

use super::{Global, common};
use crate::io::calibration::Calibration;
use crate::response::defocus::estimate_defocus;
use anyhow::{Result, bail};
use std::path::PathBuf;

/// Arguments of `fringe3d calibrate defocus`.
#[derive(clap::Args, Debug)]
#[command(
    after_help = "Example:\n  fringe3d calibrate defocus -c calibration.toml -p binary.toml captures/plane/\n\n\
IMAGES: the set's images of a surface crossing many fringes (the reference plane), in the set's\n\
order, or one folder; none: the set file's own `images` list. The set must be binary\n\
(binary = \"square\" or \"bayer\"). They are decoded without correction, and the blur whose\n\
phase-error table makes the finest level's phase uniform again is written to the calibration's\n\
projector_defocus (the lens's defocus and the camera's blur together, in projector pixels)."
)]
pub struct DefocusArgs {
    /// The scan's images, or one folder (default: the set file's `images`).
    pub images: Vec<PathBuf>,
    /// The binary pattern-set file the images were captured with.
    #[arg(long, short = 'p')]
    pub patterns: PathBuf,
    /// The calibration to add `projector_defocus` to.
    #[arg(long, short = 'c')]
    pub calibration: PathBuf,
    /// Output calibration (default: update --calibration in place).
    #[arg(long, short = 'o')]
    pub out: Option<PathBuf>,
}

/// Run `fringe3d calibrate defocus`.
pub fn run(a: DefocusArgs, g: Global) -> Result<()> {
    let mut cal = Calibration::load(&a.calibration)?;
    let ls = common::load_set(&a.patterns)?;
    if !ls.set.binarization().is_binary() {
        bail!(
            "{}: not a binary pattern set (binary = \"square\" or \"bayer\"): only binary sets \
             need the projector's blur",
            a.patterns.display()
        );
    }
    let imgs = common::load_images(&ls, &a.images, g.quiet)?;
    if (imgs.width, imgs.height) != (cal.camera.width, cal.camera.height) {
        bail!(
            "the images are {}x{} but the calibrated camera ({}) is {}x{}",
            imgs.width,
            imgs.height,
            a.calibration.display(),
            cal.camera.width,
            cal.camera.height
        );
    }
    let cfg = fringe3d_core::decode::DecodeConfig::for_bit_depth(imgs.bits as u32);
    let d = common::decode_corrected(&ls.set, &imgs, cfg, None)?;
    // The finest level's wrapped phase of the valid pixels (the decoder's absolute phase,
    // wrapped back: `c_K·Φ` modulo 2π).
    let tau = std::f64::consts::TAU;
    let phi: Vec<f64> = d
        .phase
        .iter()
        .zip(&d.validity)
        .filter(|&(p, &v)| v == 0 && p.is_finite())
        .map(|(&p, _)| {
            let p = p as f64;
            p - tau * (p / tau).round()
        })
        .collect();
    let fit = estimate_defocus(&ls.set, &phi)
        .map_err(|m| anyhow::anyhow!("{}: {m}", a.patterns.display()))?;
    cal.projector_defocus = Some((fit.sigma * 100.0).round() / 100.0);
    let out = common::save_calibration(&cal, a.out.as_deref(), &a.calibration)?;
    if g.json {
        outln!(
            "{}",
            serde_json::json!({"command": "calibrate defocus", "out": out,
                "projector_defocus": cal.projector_defocus, "fit": fit})
        );
    } else if !g.quiet {
        outln!(
            "projector blur sigma {:.2} projector pixels, from {} pixels: phase non-uniformity {:.4} uncorrected, {:.4} with its table",
            fit.sigma,
            fit.pixels,
            fit.uncorrected,
            fit.corrected
        );
        outln!("wrote projector_defocus to {}", out.display());
    }
    Ok(())
}
