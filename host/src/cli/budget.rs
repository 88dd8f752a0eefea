//! `fringe3d budget`: the static memory a scan head needs for a pattern set and a calibration
//! (the core's `budget::RowBudget`, issue #23 item 4), buffer by buffer.

use super::{Global, common};
use crate::device::desc::wire_calibration;
use crate::io::calibration::Calibration;
use anyhow::{Context, Result, bail};
use fringe3d_core::budget::{RowBudget, RowLayout};
use fringe3d_core::frame_store::FrameStore;
use fringe3d_core::sequential::FrameDecoder;
use fringe3d_core::wire::PatternAxis;
use serde_json::json;
use std::path::PathBuf;

/// Arguments of `fringe3d budget`.
#[derive(clap::Args, Debug)]
#[command(
    after_help = "Examples:\n  fringe3d budget -p examples/patterns/paper8.toml -c calibration.toml\n  \
fringe3d budget -p set.toml --width 640 --band 16 --bits 16 --layout board\n\n\
Prints each buffer of the core's row pipeline (the statics of a head's firmware) per image\n\
column and in total, and the frame-sequential decoder's state. The stack comes on top\n\
(docs/integration.md). See docs/integration.md, \"Buffers and their sizes\"."
)]
pub struct BudgetArgs {
    /// The pattern-set file (its image and level counts).
    #[arg(long, short = 'p')]
    pub patterns: PathBuf,
    /// A calibration: the camera's size and the reconstruction's band of reference rows.
    #[arg(long, short = 'c')]
    pub calibration: Option<PathBuf>,
    /// Image width the buffers hold (default: the calibration's camera).
    #[arg(long)]
    pub width: Option<usize>,
    /// Image height, for the frame-sequential state (default: the calibration's camera).
    #[arg(long)]
    pub height: Option<usize>,
    /// Reference rows the ring holds (default: the calibration's band).
    #[arg(long)]
    pub band: Option<usize>,
    /// Columns of the reference map past the image, left + right (default: the calibration's
    /// `[reference] margin`, 0 without one): the ring and the staging row are this much wider.
    #[arg(long)]
    pub margin_columns: Option<usize>,
    /// Camera bits per sample: 8 (one byte) or up to 16 (two).
    #[arg(long, default_value_t = 8, value_parser = clap::value_parser!(u32).range(1..=16))]
    pub bits: u32,
    /// Which buffers the firmware keeps: `minimal` (examples/head-minimal: the reference map
    /// read in place from memory-mapped flash or PSRAM, no ring), `minimal-ring` (the same with
    /// the map streamed through the band's ring), `board` (firmware-sim/board-mps2: a ring, the
    /// edge filter, the decoder in a static) or `phase` (no points).
    #[arg(long, default_value = "minimal", value_parser = ["minimal", "minimal-ring", "board", "phase"])]
    pub layout: String,
}

/// Largest width or band accepted (a row of 65 535 pixels is the wire's limit).
const MAX_SIZE: usize = 65_535;

/// Run `fringe3d budget`.
pub fn run(a: BudgetArgs, g: Global) -> Result<()> {
    let ls = common::load_set(&a.patterns)?;
    let set = &ls.set;
    let (mut width, mut height, mut band) = (a.width, a.height, a.band);
    let mut margin_columns = a.margin_columns;
    if let Some(path) = &a.calibration {
        let cal = Calibration::load(path)?;
        let axis = PatternAxis::from(set.axis());
        let margin = cal
            .reference
            .as_ref()
            .map(|r| r.margin())
            .unwrap_or_default();
        let recon = wire_calibration(&cal)
            .map_err(|m| anyhow::anyhow!("{}: {m}", path.display()))?
            .reconstructor_with_margin(axis, margin)
            .map_err(|why| anyhow::anyhow!("{}: no reconstruction: {}", path.display(), why.name()))
            .with_context(|| "the band of reference rows".to_string())?;
        width.get_or_insert(cal.camera.width as usize);
        height.get_or_insert(cal.camera.height as usize);
        band.get_or_insert(recon.band().rows() as usize);
        margin_columns.get_or_insert(recon.map_width() - recon.width());
    }
    let margin_columns = margin_columns.unwrap_or(0);
    if margin_columns > 2 * fringe3d_core::reconstruct::MAX_MARGIN as usize {
        bail!(
            "--margin-columns: {margin_columns} is more than two margins of {} pixels",
            fringe3d_core::reconstruct::MAX_MARGIN
        );
    }
    let layout = match a.layout.as_str() {
        "board" => RowLayout::BOARD,
        "minimal-ring" => RowLayout::MINIMAL_RING,
        "phase" => RowLayout {
            points: false,
            ..RowLayout::MINIMAL_RING
        },
        _ => RowLayout::MINIMAL,
    };
    let Some(width) = width.filter(|w| (1..=MAX_SIZE).contains(w)) else {
        bail!("give --calibration or --width (1 to {MAX_SIZE} pixels)");
    };
    let band = match band {
        Some(b) if (1..=MAX_SIZE).contains(&b) => b,
        Some(b) => bail!("--band: {b} rows is not in 1 to {MAX_SIZE}"),
        None if !layout.points || layout.map_in_place => 0,
        None => bail!(
            "the reference ring's rows depend on the rig: give --calibration (its band) or --band"
        ),
    };
    let b = RowBudget {
        width,
        images: set.image_count(),
        sample_bytes: if a.bits > 8 { 2 } else { 1 },
        band_rows: band,
        margin_columns: if layout.points && !layout.map_in_place {
            margin_columns
        } else {
            0
        },
        layout,
    };
    let (lines, n) = b.lines();
    let lines = &lines[..n];
    let levels = set.levels().len();
    let per_pixel = FrameDecoder::bytes_per_pixel(levels);
    let frame = height.map(|h| per_pixel * width * h);
    // The frames themselves (`FrameStore`): N images of the sample size.
    let store_pixel = match b.sample_bytes {
        1 => FrameStore::<u8>::bytes_per_pixel(b.images),
        _ => FrameStore::<u16>::bytes_per_pixel(b.images),
    };
    let store = height.map(|h| store_pixel * width * h);
    if g.json {
        let rows: Vec<_> = lines
            .iter()
            .map(|l| json!({"buffer": l.name, "bytes_per_column": l.per_column, "bytes": l.bytes}))
            .collect();
        outln!(
            "{}",
            json!({"command": "budget", "width": width, "height": height, "images": b.images,
                "levels": levels, "sample_bytes": b.sample_bytes, "band_rows": band,
                "margin_columns": b.margin_columns,
                "layout": a.layout, "buffers": rows, "bytes_per_column": b.per_column(),
                "total_bytes": b.total(),
                "frame_sequential": {"bytes_per_pixel": per_pixel, "bytes": frame},
                "frame_store": {"bytes_per_pixel": store_pixel, "bytes": store}})
        );
    } else if !g.quiet {
        let reference = if !layout.points {
            "no points".to_string()
        } else if layout.map_in_place {
            "the reference map read in place (memory-mapped: no ring)".to_string()
        } else if b.margin_columns > 0 {
            format!(
                "{band} reference rows of {} columns (the map's margin)",
                width + b.margin_columns
            )
        } else {
            format!("{band} reference rows")
        };
        outln!(
            "row pipeline, {} layout: {} images of {} byte(s) per sample, {} pixels wide, {reference}",
            a.layout,
            b.images,
            b.sample_bytes,
            width,
        );
        outln!("  {:<44} {:>10} {:>12}", "buffer", "B/column", "bytes");
        for l in lines {
            let per = if l.per_column > 0 {
                l.per_column.to_string()
            } else {
                "-".into()
            };
            outln!("  {:<44} {:>10} {:>12}", l.name, per, l.bytes);
        }
        let total = b.total();
        outln!(
            "  {:<44} {:>10} {:>12} ({:.1} KiB; the stack comes on top, docs/integration.md)",
            "total",
            b.per_column(),
            total,
            total as f64 / 1024.0
        );
        if lines.iter().any(|l| l.per_column == 0) {
            outln!(
                "  (fixed sizes as this machine builds the core; on a 32-bit target the decoder and \
                 the scratch are a little smaller: docs/integration.md)"
            );
        }
        match frame {
            Some(f) => outln!(
                "frame-sequential decoder (whole frames, {levels} levels): {per_pixel} B per pixel, {f} bytes ({:.1} MiB) at {width}x{}",
                f as f64 / (1024.0 * 1024.0),
                height.unwrap_or(0)
            ),
            None => outln!(
                "frame-sequential decoder (whole frames, {levels} levels): {per_pixel} B per pixel (give --height or --calibration for the total)"
            ),
        }
        match store {
            Some(f) => outln!(
                "frame store (whole frames, decoded after the last): {store_pixel} B per pixel, {f} bytes ({:.1} MiB)",
                f as f64 / (1024.0 * 1024.0)
            ),
            None => outln!(
                "frame store (whole frames, decoded after the last): {store_pixel} B per pixel"
            ),
        }
    }
    Ok(())
}
