//! `fringe3d calibrate gamma`: the projector's response from captures of the reference plane under
//! uniform gray levels (`fringe3d patterns --gray N` writes them), or a power law from its fringe
//! captures (`--fringes`), into the calibration's `[projector_response]` (docs/gamma.md).

use super::{Global, common};
use crate::io::calibration::Calibration;
use crate::io::image_set::{self, Frames};
use crate::response::estimate::estimate;
use crate::response::gray_codes;
use crate::response::table::phase_correction;
use anyhow::{Result, bail};
use std::path::PathBuf;

/// Arguments of `fringe3d calibrate gamma`.
#[derive(clap::Args, Debug)]
#[command(
    after_help = "Example:\n  fringe3d patterns --gray 17 -o gray/      # project these onto the reference plane, capture each\n  \
fringe3d calibrate gamma -c calibration.toml captures/gray/ -p scan/patterns.toml\n\n\
IMAGES: the captures in level order, or one folder (every PNG/TIFF/BMP/PGM/NPY sorted by name). The levels are\n\
--levels (projector codes), default N evenly spaced codes from 0 to full scale (what --gray N writes).\n\
Black (0) and full white must be among them. The camera's exposure must stay fixed and leave white\n\
unsaturated. Writes [projector_response] into the calibration: `scan`, `decode` and `calibrate\n\
reference` then correct the phase for it, and `patterns --response` pre-distorts patterns through it.\n\n\
Without gray captures, for a power-law projector:\n  \
fringe3d calibrate gamma --fringes -c calibration.toml -p plane/patterns.toml plane/\n\
fits gamma to the fringe captures of the set (e.g. the reference plane's)."
)]
pub struct GammaArgs {
    /// The captures of the gray levels, or one folder.
    #[arg(required = true)]
    pub images: Vec<PathBuf>,
    /// The calibration to add the response to.
    #[arg(long, short = 'c')]
    pub calibration: PathBuf,
    /// Output calibration (default: update --calibration in place).
    #[arg(long, short = 'o')]
    pub out: Option<PathBuf>,
    /// The projector codes of the captures, comma-separated, in image order (default: N evenly
    /// spaced from 0 to full scale).
    #[arg(long, value_delimiter = ',')]
    pub levels: Vec<u32>,
    /// Bits of the projector's codes (8 or 16): full scale is 2^bits − 1.
    #[arg(long, default_value_t = 8, value_parser = clap::value_parser!(u8).range(1..=16))]
    pub projector_bits: u8,
    /// Also report the phase error the response makes in this pattern set, per level, and what
    /// the decoder's correction leaves of it. With --fringes: the set the IMAGES were captured
    /// with.
    #[arg(long, short = 'p')]
    pub patterns: Option<PathBuf>,
    /// IMAGES are not gray levels but the fringe captures of --patterns (e.g. the reference
    /// plane's, as `calibrate reference` takes them): the gamma of a power-law projector is
    /// fitted to the samples of every pixel (docs/gamma.md, "From the fringes"). A response
    /// of another shape needs the gray levels.
    #[arg(long, requires = "patterns", conflicts_with_all = ["levels"])]
    pub fringes: bool,
}

/// Run `fringe3d calibrate gamma`.
pub fn run(a: GammaArgs, g: Global) -> Result<()> {
    if a.fringes {
        return from_fringes(a, g);
    }
    let mut cal = Calibration::load(&a.calibration)?;
    let paths = match a.images.as_slice() {
        [d] if d.is_dir() => image_set::list_folder(d)?,
        p => p.to_vec(),
    };
    let full = ((1u64 << a.projector_bits) - 1) as u32;
    let codes = if a.levels.is_empty() {
        gray_codes(paths.len(), full)
    } else {
        a.levels.clone()
    };
    if codes.len() != paths.len() {
        bail!(
            "--levels lists {} codes for {} images ({})",
            codes.len(),
            paths.len(),
            paths[0].display()
        );
    }
    if let Some(c) = codes.iter().find(|&&c| c > full) {
        bail!(
            "--levels: code {c} exceeds the {}-bit full scale {full}",
            a.projector_bits
        );
    }
    let set = image_set::load(&paths, paths.len(), "the gray captures")?;
    let (cam_w, cam_h) = (cal.camera.width, cal.camera.height);
    if (set.width, set.height) != (cam_w, cam_h) {
        bail!(
            "{}: the captures are {}x{} but the calibrated camera ({}) is {}x{}",
            paths[0].display(),
            set.width,
            set.height,
            a.calibration.display(),
            cam_w,
            cam_h
        );
    }
    let frames = widen(&set.frames);
    let imgs: Vec<&[u16]> = frames.iter().map(|f| f.as_slice()).collect();
    let levels: Vec<f64> = codes.iter().map(|&c| c as f64 / full as f64).collect();
    let saturation = ((1u64 << set.bits) - 1) as f64;
    let (resp, report) = estimate(&levels, &imgs, saturation)
        .map_err(|m| anyhow::anyhow!("{} and the other gray captures: {m}", paths[0].display()))?;
    let per_level = match &a.patterns {
        Some(p) => {
            let ls = common::load_set(p)?;
            let (_, errs) = phase_correction(&ls.set, &resp)
                .map_err(|m| anyhow::anyhow!("{}: {m}", p.display()))?;
            Some(errs)
        }
        None => None,
    };
    cal.projector_response = Some(resp.clone());
    let out = common::save_calibration(&cal, a.out.as_deref(), &a.calibration)?;
    if g.json {
        outln!(
            "{}",
            serde_json::json!({"command": "calibrate gamma", "out": out, "gamma": resp.gamma,
                "levels": resp.levels, "response": resp.response, "report": report,
                "phase_error": per_level})
        );
    } else if !g.quiet {
        outln!(
            "projector response from {} levels over {} pixels: closest power law gamma {:.3} (table off it by {:.4} RMS); nonlinearity {:.1} % of full scale",
            resp.levels.len(),
            report.pixels,
            resp.gamma,
            report.power_law_rms,
            100.0 * report.nonlinearity
        );
        if let Some(errs) = &per_level {
            print_level_errors(errs);
        }
        outln!("wrote [projector_response] to {}", out.display());
    }
    Ok(())
}

/// `calibrate gamma --fringes`: γ from the fringe captures of the set `--patterns`.
fn from_fringes(a: GammaArgs, g: Global) -> Result<()> {
    let Some(patterns) = &a.patterns else {
        bail!("--fringes needs --patterns, the set the images were captured with");
    };
    let mut cal = Calibration::load(&a.calibration)?;
    let ls = common::load_set(patterns)?;
    let imgs = common::load_images(&ls, &a.images, g.quiet)?;
    let what = imgs.paths.first().map_or_else(
        || patterns.display().to_string(),
        |p| p.display().to_string(),
    );
    if (imgs.width, imgs.height) != (cal.camera.width, cal.camera.height) {
        bail!(
            "{what}: the captures are {}x{} but the calibrated camera ({}) is {}x{}",
            imgs.width,
            imgs.height,
            a.calibration.display(),
            cal.camera.width,
            cal.camera.height
        );
    }
    // The phase of the same images, uncorrected (the estimate allows for its error).
    let cfg = common::ThresholdArgs::default().config(&ls.set, &imgs, cal.sensor.as_ref())?;
    let d = common::decode(&ls.set, &imgs, cfg)?;
    let frames = widen(&imgs.frames);
    let refs: Vec<&[u16]> = frames.iter().map(|f| f.as_slice()).collect();
    let full = ((1u64 << ls.file.bit_depth()) - 1) as f64;
    let (resp, report) = crate::response::harmonics::from_fringes(
        &ls.set,
        full,
        &refs,
        &d.phase,
        &d.validity,
        cfg.saturation_level as f64,
    )
    .map_err(|m| anyhow::anyhow!("{what} and the other fringe captures: {m}"))?;
    let (_, errs) = phase_correction(&ls.set, &resp)
        .map_err(|m| anyhow::anyhow!("{}: {m}", patterns.display()))?;
    cal.projector_response = Some(resp.clone());
    let out = common::save_calibration(&cal, a.out.as_deref(), &a.calibration)?;
    if g.json {
        outln!(
            "{}",
            serde_json::json!({"command": "calibrate gamma", "from": "fringes", "out": out,
                "gamma": resp.gamma, "levels": resp.levels, "response": resp.response,
                "report": report, "phase_error": errs})
        );
    } else if !g.quiet {
        outln!(
            "projector gamma {:.3} from the fringes of {} pixels ({} samples each): residual {:.2} codes RMS (linear: {:.2}); nonlinearity {:.1} % of full scale over the patterns' range",
            resp.gamma,
            report.pixels,
            report.samples,
            report.residual_rms,
            report.linear_rms,
            100.0 * report.nonlinearity
        );
        print_level_errors(&errs);
        outln!("wrote [projector_response] to {}", out.display());
    }
    Ok(())
}

/// Each level's phase error before and after the decoder's table, a line each.
fn print_level_errors(errs: &[crate::response::table::LevelError]) {
    for (l, e) in errs.iter().enumerate() {
        outln!(
            "  level {l}: phase error {:.4} rad RMS ({:.4} max) uncorrected, {:.4} after the decoder's table",
            e.rms_rad,
            e.max_rad,
            e.residual_rms_rad
        );
    }
}

/// The frames as 16-bit samples.
fn widen(frames: &Frames) -> Vec<Vec<u16>> {
    match frames {
        Frames::U8(v) => v
            .iter()
            .map(|i| i.iter().map(|&x| x as u16).collect())
            .collect(),
        Frames::U16(v) => v.clone(),
    }
}
