//! Writing point clouds for `scan`, `reconstruct` and `demo`: PLY (binary or ASCII, organized or
//! not) or XYZ text, always atomically.

use crate::io::ply::{PlyEncoding, PlyOptions, PlyWriter, PointRow, XyzWriter};
use crate::scan::PointCloud;
use anyhow::Result;
use std::path::PathBuf;

/// Output options shared by the commands that write clouds.
#[derive(clap::Args, Debug, Clone)]
pub struct CloudArgs {
    /// Output point cloud (.ply, or .xyz for plain "x y z" text).
    #[arg(long, short = 'o')]
    pub out: PathBuf,
    /// ASCII PLY instead of binary little-endian.
    #[arg(long)]
    pub ascii: bool,
    /// Organized cloud: one vertex per camera pixel, invalid ones flagged (NaN position).
    #[arg(long)]
    pub organized: bool,
    /// Keep points at depth discontinuities ("flying pixels" that mix two surfaces).
    #[arg(long)]
    pub no_edge_filter: bool,
    /// Steepest accepted surface for the edge filter, degrees from facing the camera.
    #[arg(long, default_value_t = 80.0)]
    pub max_angle: f64,
}

/// Apply the depth-edge filter unless `--no-edge-filter`.
pub fn apply_edge_filter(
    args: &CloudArgs,
    cal: &crate::scan::ScanCalibration,
    cloud: &mut PointCloud,
) -> Result<()> {
    if !args.no_edge_filter {
        let f = cal.edge_filter(args.max_angle)?;
        crate::scan::filter_edges(cloud, &f);
    }
    Ok(())
}

/// Write `cloud` with per-pixel intensity (A) and modulation (B) as `args` say. Returns the
/// number of vertices written.
pub fn write_cloud(
    args: &CloudArgs,
    cloud: &PointCloud,
    intensity: &[f32],
    modulation: &[f32],
    comments: Vec<String>,
) -> Result<u64> {
    let (w, h) = (cloud.width, cloud.height);
    let xyz: &[[f32; 3]] = bytemuck_xyz(&cloud.xyz);
    let row = |v: usize| PointRow {
        v: v as u32,
        xyz: &xyz[v * w..(v + 1) * w],
        intensity: &intensity[v * w..(v + 1) * w],
        modulation: &modulation[v * w..(v + 1) * w],
        validity: &cloud.validity[v * w..(v + 1) * w],
    };
    let is_xyz = args
        .out
        .extension()
        .and_then(|e| e.to_str())
        .map(|e| e.eq_ignore_ascii_case("xyz"))
        .unwrap_or(false);
    if is_xyz {
        let mut wr = XyzWriter::create(&args.out)?;
        for v in 0..h {
            wr.write_row(&row(v))?;
        }
        return Ok(wr.finish()?);
    }
    let opts = PlyOptions {
        encoding: if args.ascii {
            PlyEncoding::Ascii
        } else {
            PlyEncoding::BinaryLittleEndian
        },
        comments,
        ..PlyOptions::default()
    };
    let mut wr = if args.organized {
        PlyWriter::create_organized(&args.out, w as u32, h as u32, opts)?
    } else {
        // The valid points are known: the header can carry their count from the start.
        let n = cloud.validity.iter().filter(|&&c| c == 0).count() as u64;
        PlyWriter::create_with_count(&args.out, n, opts)?
    };
    for v in 0..h {
        wr.write_row(&row(v))?;
    }
    Ok(wr.finish()?)
}

/// View a flat `[x0, y0, z0, x1, …]` buffer as points.
fn bytemuck_xyz(flat: &[f32]) -> &[[f32; 3]] {
    let (chunks, _) = flat.as_chunks::<3>();
    chunks
}
