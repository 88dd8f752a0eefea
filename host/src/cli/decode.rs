//! `fringe3d decode`: images → absolute phase, modulation, DC term and validity.

use super::{Global, common};
use crate::io::atomic::AtomicDir;
use crate::io::calibration::{Calibration, is_digest};
use crate::io::image::{write_png_u8, write_tiff_f32};
use crate::io::preview;
use anyhow::{Context, Result, bail};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// The decode record's file name in a decode folder.
pub const RECORD: &str = "decode.toml";

/// The decode record's format version.
pub const RECORD_VERSION: u32 = 1;

/// `decode.toml`: what a decode folder's phase was decoded with, so that `fringe3d reconstruct`
/// can check it against the calibration's reference (docs/formats.md).
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DecodeRecord {
    /// Format version, [`RECORD_VERSION`].
    pub version: u32,
    /// The pattern-set file as given to `fringe3d decode` (for messages only).
    pub patterns: String,
    /// Its digest (`io::calibration::pattern_digest`).
    pub pattern_digest: String,
}

impl DecodeRecord {
    /// The record of folder `dir`; `None` if it has none (a folder decoded by an older fringe3d).
    pub fn read(dir: &Path) -> Result<Option<DecodeRecord>> {
        let p = dir.join(RECORD);
        if !p.exists() {
            return Ok(None);
        }
        common::input_file(&p)?;
        let text =
            std::fs::read_to_string(&p).with_context(|| format!("{}: cannot read", p.display()))?;
        let r: DecodeRecord = toml::from_str(&text).map_err(|e| {
            anyhow::anyhow!("{}: not a decode record: {}", p.display(), e.message())
        })?;
        if r.version != RECORD_VERSION {
            bail!(
                "{}: decode record version {} (this build reads {RECORD_VERSION})",
                p.display(),
                r.version
            );
        }
        if !is_digest(&r.pattern_digest) {
            bail!(
                "{}: pattern_digest must be \"sha256:\" and 64 lowercase hex digits, got \"{}\"",
                p.display(),
                r.pattern_digest
            );
        }
        Ok(Some(r))
    }

    fn text(&self) -> Result<String> {
        let body = toml::to_string(self).context("writing the decode record")?;
        Ok(format!(
            "# fringe3d decode record, version {RECORD_VERSION} (docs/formats.md): the pattern set this\n\
             # folder's phase was decoded with; `fringe3d reconstruct` checks it against the reference.\n{body}"
        ))
    }
}

/// Arguments of `fringe3d decode`.
#[derive(clap::Args, Debug)]
#[command(
    after_help = "Example:\n  fringe3d decode --patterns scan/patterns.toml scan/ --out decoded/\n\n\
IMAGES: the images in set order, or one folder (the pattern file's `images` names inside it, else\n\
every PNG/TIFF/BMP/PGM sorted by name, or its NPY frames); none: the pattern file's own `images` list.\n\
Writes phase.tif, modulation.tif, dc.tif (32-bit float TIFF; phase NaN where invalid),\n\
validity.png (8-bit codes, see docs/formats.md), preview.png (false colour) and decode.toml\n\
(the pattern set's digest, which `fringe3d reconstruct` checks against the reference)."
)]
pub struct DecodeArgs {
    /// The pattern-set file the images were captured with.
    #[arg(long, short = 'p')]
    pub patterns: PathBuf,
    /// Images in set order, or one folder.
    pub images: Vec<PathBuf>,
    /// Output folder (must not exist or be empty, unless --overwrite).
    #[arg(long, short = 'o')]
    pub out: PathBuf,
    /// The decoder's thresholds.
    #[command(flatten)]
    pub thresholds: common::ThresholdArgs,
    /// Replace the output folder if it exists.
    #[arg(long)]
    pub overwrite: bool,
    /// Correct the phase for the projector response this calibration records
    /// (`[projector_response]`, from `calibrate gamma`; docs/gamma.md), or for a binary set, for
    /// its `projector_defocus` (required then; docs/binary.md); and decode with the modulation
    /// floor of its `[sensor]` noise (12σ, as `scan` does; `--noise` and the single thresholds
    /// override it).
    #[arg(long, short = 'c', value_name = "CALIBRATION")]
    pub calibration: Option<PathBuf>,
}

/// Run `fringe3d decode`.
pub fn run(a: DecodeArgs, g: Global) -> Result<()> {
    let t0 = Instant::now();
    common::dir_out(&a.out, "--out")?;
    let ls = common::load_set(&a.patterns)?;
    let record = DecodeRecord {
        version: RECORD_VERSION,
        patterns: a.patterns.to_string_lossy().into_owned(),
        pattern_digest: ls.scan_patterns()?.digest,
    }
    .text()?;
    let cal = match &a.calibration {
        Some(c) => Some((c, Calibration::load(c)?)),
        None => None,
    };
    let corr = match &cal {
        Some((c, cal)) => common::response_correction(cal, c, &ls)?,
        None if ls.set.binarization().is_binary() => anyhow::bail!(
            "{}: {}; pass it with --calibration",
            a.patterns.display(),
            crate::calib::files::BINARY_NEEDS_DEFOCUS
        ),
        None => None,
    };
    let imgs = common::load_images(&ls, &a.images, g.quiet)?;
    // The calibration's `[sensor]` noise sets the modulation floor, as for `scan`.
    let sensor = cal.as_ref().and_then(|(_, c)| c.sensor.as_ref());
    let cfg = a.thresholds.config(&ls.set, &imgs, sensor)?;
    let dir = AtomicDir::create(&a.out, a.overwrite)?;
    let d = common::decode_corrected(&ls.set, &imgs, cfg, corr.as_ref())?;
    let (w, h) = (imgs.width, imgs.height);
    write_tiff_f32(&dir.join("phase.tif"), w, h, &d.phase)?;
    write_tiff_f32(&dir.join("modulation.tif"), w, h, &d.modulation)?;
    write_tiff_f32(&dir.join("dc.tif"), w, h, &d.dc)?;
    write_png_u8(&dir.join("validity.png"), w, h, &d.validity)?;
    preview::write_rgb_png(
        &dir.join("preview.png"),
        w,
        h,
        &preview::colourize(&d.phase, &d.validity),
    )
    .map_err(anyhow::Error::msg)?;
    std::fs::write(dir.join(RECORD), record)
        .with_context(|| format!("{}: cannot write", dir.join(RECORD).display()))?;
    let out = dir.commit()?;
    let hist = d.histogram();
    if g.json {
        outln!(
            "{}",
            serde_json::json!({"command": "decode", "out": out, "width": w, "height": h, "bits": imgs.bits,
                "validity": common::validity_json(&hist), "seconds": t0.elapsed().as_secs_f64()})
        );
    } else if !g.quiet {
        outln!(
            "decoded {}x{} ({}-bit, {} images): {}",
            w,
            h,
            imgs.bits,
            imgs.paths.len(),
            common::validity_summary(&hist)
        );
        outln!(
            "wrote phase.tif, modulation.tif, dc.tif, validity.png, preview.png, {RECORD} to {}",
            out.display()
        );
    }
    Ok(())
}
