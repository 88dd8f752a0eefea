//! `fringe3d scan`: images + calibration → point cloud, in one go (nothing written in between).

use super::cloud_out::{self, CloudArgs, CloudOut, CloudSink, apply_edge_filter, write_cloud};
use super::{Global, common};
use crate::scan::ScanCounts;
use crate::scan::ScanError;
use crate::scan::stream::{StreamConfig, stream_image_set};
use anyhow::{Context, Result, anyhow};
use fringe3d_core::decode::Decoder;
use std::path::PathBuf;
use std::time::Instant;

/// Arguments of `fringe3d scan`.
#[derive(clap::Args, Debug)]
#[command(
    after_help = "Example:\n  fringe3d scan --patterns scan/patterns.toml --calibration scan/calibration.toml scan/ -o cloud.ply\n\n\
IMAGES: the images in set order, or one folder (the pattern file's `images` names inside it, else\n\
every PNG/TIFF/BMP/PGM sorted by name, or its NPY frames); none: the pattern file's own `images` list.\n\
The calibration names the reference phase map (float TIFF) beside it; see docs/formats.md.\n\
The pattern set must be the reference's: a set whose digest differs from the calibration's\n\
[reference] pattern_digest (or its pattern_set file's) is refused before anything is written."
)]
pub struct ScanArgs {
    /// The pattern-set file the images were captured with.
    #[arg(long, short = 'p')]
    pub patterns: PathBuf,
    /// The calibration file (TOML).
    #[arg(long, short = 'c')]
    pub calibration: PathBuf,
    /// Images in set order, or one folder; with `--hdr`, one folder per exposure.
    pub images: Vec<PathBuf>,
    /// HDR: the arguments are 2 to 4 folders, each the whole set at one exposure, longest
    /// exposure first; each pixel is decoded from the longest exposure in which none of its
    /// samples saturated (docs/hdr.md).
    #[arg(long)]
    pub hdr: bool,
    /// Output.
    #[command(flatten)]
    pub cloud: CloudArgs,
    /// The decoder's thresholds.
    #[command(flatten)]
    pub thresholds: common::ThresholdArgs,
    /// A compiled reconstruction of this calibration (`fringe3d compile`): one rational
    /// function per pixel instead of the search, the search where the file has none or the
    /// phase lies beyond its range (the summary says how many pixels; `searched` in --json).
    #[arg(long, value_name = "FILE")]
    pub compiled: Option<PathBuf>,
}

/// Run `fringe3d scan`: one streaming pass over bands of rows
/// ([`crate::scan::stream`]), the file written while later rows are still being computed.
pub fn run(a: ScanArgs, g: Global) -> Result<()> {
    run_with(a, g, Pipeline::Stream)
}

/// `fringe3d scan` the whole-frame way: decode the whole frame, reconstruct it, filter it, then
/// write it. The same file, byte for byte, as [`run`]; kept as the reference that
/// `host/tests/scan_stream.rs` compares the streaming pass with.
pub fn run_whole_frame(a: ScanArgs, g: Global) -> Result<()> {
    run_with(a, g, Pipeline::WholeFrame)
}

#[derive(Clone, Copy, PartialEq, Eq)]
enum Pipeline {
    Stream,
    WholeFrame,
}

fn run_with(a: ScanArgs, g: Global, pipeline: Pipeline) -> Result<()> {
    let t0 = Instant::now();
    let out = CloudOut::resolve(&a.cloud.out, a.cloud.format, "--out")?;
    let ls = common::load_set(&a.patterns)?;
    common::check_reference_patterns(&a.calibration, &ls.scan_patterns()?, g.quiet)?;
    // The calibration (with its reference map) and the images load side by side.
    let (cal, imgs) = rayon::join(
        || {
            let cal = match pipeline {
                // The streaming pass reads the map row by row from its file where it can.
                Pipeline::Stream => common::load_calibration_streamed,
                Pipeline::WholeFrame => common::load_calibration,
            }(&a.calibration, ls.set.axis())?;
            match (&a.compiled, pipeline) {
                // The streaming pass reads each band's rows of models from their file.
                (Some(p), Pipeline::Stream) => Ok(cal.with_compiled_streamed(p)?),
                (Some(p), Pipeline::WholeFrame) => Ok(cal.with_compiled(p)?),
                (None, _) => anyhow::Ok(cal),
            }
        },
        || match a.hdr {
            true => common::load_exposures(&ls, &a.images, g.quiet),
            false => common::load_images(&ls, &a.images, g.quiet),
        },
    );
    let (cal, imgs) = (cal?, imgs?);
    if (imgs.width as usize, imgs.height as usize) != (cal.width(), cal.height()) {
        anyhow::bail!(
            "{}: images are {}x{} but the calibrated camera ({}) is {}x{}",
            imgs.paths[0].display(),
            imgs.width,
            imgs.height,
            a.calibration.display(),
            cal.width(),
            cal.height()
        );
    }
    let t_load = t0.elapsed();
    let comments = vec![format!("fringe3d scan of {}", a.patterns.display())];
    let config = a
        .thresholds
        .config(&ls.set, &imgs, cal.calibration.sensor.as_ref())?;
    let corr = common::response_correction(&cal.calibration, &a.calibration, &ls)?;
    // The whole-frame reference does not count what the search did: `counts` is `None` there.
    let (n, hist, seconds, counts) = if pipeline == Pipeline::WholeFrame {
        let d = common::decode_corrected(&ls.set, &imgs, config, corr.as_ref())?;
        let t_decode = t0.elapsed();
        let mut cloud = cal.reconstruct(&d.phase, &d.validity, true)?;
        apply_edge_filter(&a.cloud, &cal, &mut cloud)?;
        let t_recon = t0.elapsed();
        let n = write_cloud(&a.cloud, &out, &cloud, &d.dc, &d.modulation, comments)?;
        let seconds = serde_json::json!({"load": t_load.as_secs_f64(),
            "decode": (t_decode - t_load).as_secs_f64(),
            "reconstruct": (t_recon - t_decode).as_secs_f64(),
            "total": t0.elapsed().as_secs_f64()});
        (n, common::histogram(&cloud.validity), seconds, None)
    } else {
        let mut decoder = Decoder::new(&ls.set, config).map_err(|e| anyhow!("decoder: {e}"))?;
        if let Some(c) = &corr {
            decoder = decoder
                .with_correction(c)
                .map_err(|e| anyhow!("gamma correction: {e}"))?;
        }
        let cfg = StreamConfig {
            edge_filter: match a.cloud.no_edge_filter {
                true => None,
                false => Some(cal.edge_filter(a.cloud.max_angle)?),
            },
            ..StreamConfig::default()
        };
        let (w, h) = (cal.width(), cal.height());
        let mut done = None;
        let n = out.deliver(|file| {
            let mut sink = CloudSink::create(&a.cloud, out.format, file, w, h, comments)?;
            let encoder = sink.encoder();
            let stats = stream_image_set(&cal, &decoder, &imgs, &encoder, &cfg, |e| {
                sink.write(e).map_err(ScanError::from)
            })
            .context("scanning the image set")?;
            let t = Instant::now();
            let n = sink.finish()?;
            done = Some((stats, t.elapsed()));
            Ok(n)
        })?;
        let (stats, finish) = done.ok_or_else(|| anyhow!("the cloud was not written"))?;
        // Worker steps are thread time summed over the workers; the rest is wall time.
        let steps = &stats.steps;
        let seconds = serde_json::json!({"load": t_load.as_secs_f64(),
            "decode": steps.decode.as_secs_f64(),
            "reconstruct": steps.reconstruct.as_secs_f64(),
            "filter": steps.filter.as_secs_f64(),
            "encode": steps.encode.as_secs_f64(),
            "stream": stats.wall.as_secs_f64(),
            "write": stats.write.as_secs_f64(),
            "finish": finish.as_secs_f64(),
            "total": t0.elapsed().as_secs_f64()});
        (n, stats.histogram, seconds, Some(stats.counts))
    };
    common::warn_if_empty(&hist, &out.describe(), g.quiet);
    if g.json {
        cloud_out::say(
            &out,
            &serde_json::json!({"command": "scan", "out": a.cloud.out, "points": n, "width": imgs.width, "height": imgs.height,
                "validity": common::validity_json(&hist),
                "decoded": counts.map(|t| t.decoded), "searched": counts.map(|t| t.searched),
                "seconds": seconds, "peak_rss_bytes": common::peak_rss_bytes()})
            .to_string(),
        );
    } else if !g.quiet {
        cloud_out::say(&out, &common::validity_summary(&hist));
        if let (Some(t), Some(_)) = (counts, &a.compiled) {
            cloud_out::say(&out, &compiled_summary(t));
        }
        cloud_out::say(
            &out,
            &format!(
                "wrote {n} points to {} in {:.0} ms",
                out.describe(),
                t0.elapsed().as_secs_f64() * 1e3
            ),
        );
    }
    Ok(())
}

/// What a compiled scan left to the search: its fallback rate.
fn compiled_summary(t: ScanCounts) -> String {
    let share = 100.0 * t.searched as f64 / t.decoded.max(1) as f64;
    format!(
        "compiled models answered {} of the {} decoded pixels; {} ({share:.2} %) were left to the search",
        t.decoded - t.searched.min(t.decoded),
        t.decoded,
        t.searched
    )
}
