//! `fringe3d compile`: a calibration's reconstruction compiled to one rational function of the
//! phase per pixel ([`crate::compiled`]), checked against the §6 search pixel by pixel, for
//! `fringe3d scan --compiled` and for a head that reads the models row by row.

use super::{Global, common};
use crate::compiled::{DEFAULT_TOLERANCE_MM, compile};
use anyhow::{Context, Result, bail};
use fringe3d_core::reconstruct::compiled::PixelModel;
use std::path::PathBuf;
use std::time::Instant;

/// Arguments of `fringe3d compile`.
#[derive(clap::Args, Debug)]
#[command(
    after_help = "Example:\n  fringe3d compile -p scan/patterns.toml -c scan/calibration.toml -o scan/reconstruction.f3c\n  \
fringe3d scan -p scan/patterns.toml -c scan/calibration.toml --compiled scan/reconstruction.f3c scan/ -o cloud.ply\n\n\
Each pixel's depth becomes a rational function of its phase, fitted to the reference map along\n\
the pixel's ray and checked against the exact search at 33 phases over the depth range; a pixel\n\
whose function misses by more than the tolerance on any coordinate keeps the search. A\n\
reference map that is a model (`calibrate reference --virtual` or `--fit`) compiles nearly\n\
every pixel; a captured map's noise does not fit a smooth function, and few pixels compile.\n\
The file is tied to the calibration and map it was compiled from (a digest of their bytes).\n\
See docs/formats.md, \"Compiled reconstruction\"."
)]
pub struct CompileArgs {
    /// The pattern-set file (its fringe axis).
    #[arg(long, short = 'p')]
    pub patterns: PathBuf,
    /// The calibration file (TOML) and the reference map it names.
    #[arg(long, short = 'c')]
    pub calibration: PathBuf,
    /// The compiled file to write.
    #[arg(long, short = 'o')]
    pub out: PathBuf,
    /// Largest difference from the search a compiled pixel may have on any coordinate, µm.
    #[arg(long, default_value_t = DEFAULT_TOLERANCE_MM * 1e3, value_name = "UM")]
    pub tolerance: f64,
}

/// Run `fringe3d compile`.
pub fn run(a: CompileArgs, g: Global) -> Result<()> {
    if !(a.tolerance.is_finite() && a.tolerance > 0.0 && a.tolerance <= 1000.0) {
        bail!("--tolerance must be in (0, 1000] µm, got {}", a.tolerance);
    }
    crate::io::atomic::check_file_target(&a.out)
        .with_context(|| format!("{}: cannot write the compiled file", a.out.display()))?;
    let t0 = Instant::now();
    let ls = common::load_set(&a.patterns)?;
    let cal = common::load_calibration(&a.calibration, ls.set.axis())?;
    let digest = cal.source_digest()?;
    let (mut file, rep) = compile(&cal.recon, &cal.reference_phase, a.tolerance * 1e-3);
    file.source_digest = digest;
    file.write(&a.out)?;
    let bytes = 4 * file.models.len();
    if g.json {
        println!(
            "{}",
            serde_json::json!({"command": "compile", "out": a.out, "report": rep,
                "bytes": bytes, "seconds": t0.elapsed().as_secs_f64()})
        );
    } else if !g.quiet {
        let pct = |n: usize| 100.0 * n as f64 / rep.pixels.max(1) as f64;
        println!(
            "compiled {} of {} pixels ({:.2} %, {} clipped to the map), {} with no reference along the ray; the search keeps {} ({} off the map, {} not monotonic, {} fits and {} checks missing the tolerance)",
            rep.compiled,
            rep.pixels,
            pct(rep.compiled),
            rep.clipped,
            rep.no_reference,
            rep.pixels - rep.compiled - rep.no_reference,
            rep.off_map,
            rep.not_monotonic,
            rep.fit_failed,
            rep.check_failed
        );
        println!(
            "largest difference from the search {:.3} µm (tolerance {} µm, {} phases a pixel); fit alone {:.4} µm",
            rep.max_difference_mm * 1e3,
            a.tolerance,
            rep.checks,
            rep.max_fit_error_mm * 1e3
        );
        println!(
            "wrote {} ({:.1} MiB, {} bytes a pixel) in {:.1} s",
            a.out.display(),
            bytes as f64 / (1 << 20) as f64,
            PixelModel::BYTES,
            t0.elapsed().as_secs_f64()
        );
    }
    Ok(())
}
