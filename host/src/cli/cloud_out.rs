//! Writing point clouds for `scan`, `reconstruct`, `demo` and `device scan`: PLY (binary or
//! ASCII, organized or not) or XYZ text, always atomically; or, with `-o -`, to standard output.
//!
//! Standard output gets the complete file only: the cloud is first written to a private temporary
//! folder and copied out once it is whole, so an error never leaves half a cloud in a pipe.

use crate::io::atomic::{AtomicDir, check_file_target};
use crate::io::error::FormatError;
use crate::io::ply::{
    Encoded, PlyEncoding, PlyOptions, PlyWriter, PointRow, RowEncoder, XyzWriter,
};
use crate::scan::PointCloud;
use anyhow::{Context, Result, bail};
use std::io::Write;
use std::path::{Path, PathBuf};

/// The point-cloud file formats.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum CloudFormat {
    /// PLY (binary little-endian, or ASCII with --ascii).
    Ply,
    /// Plain text, one "x y z" line per valid point.
    Xyz,
}

impl CloudFormat {
    fn extension(self) -> &'static str {
        match self {
            CloudFormat::Ply => "ply",
            CloudFormat::Xyz => "xyz",
        }
    }
}

/// Output options shared by the commands that write clouds.
#[derive(clap::Args, Debug, Clone)]
pub struct CloudArgs {
    /// Output point cloud: FILE.ply, FILE.xyz (plain "x y z" text), or - for standard output
    /// (PLY unless --format xyz; the summary then goes to standard error).
    #[arg(long, short = 'o')]
    pub out: PathBuf,
    /// Cloud format (default: by the extension of --out, which must then be .ply or .xyz; PLY for -).
    #[arg(long, value_enum)]
    pub format: Option<CloudFormat>,
    /// ASCII PLY instead of binary little-endian.
    #[arg(long)]
    pub ascii: bool,
    /// Organized cloud: one vertex per camera pixel, invalid ones flagged (NaN position).
    #[arg(long)]
    pub organized: bool,
    /// Keep points at depth discontinuities ("flying pixels" that mix two surfaces) and at the
    /// edge of the projector's light (pixels that see it only in part).
    #[arg(long)]
    pub no_edge_filter: bool,
    /// Steepest accepted surface for the edge filter, degrees from facing the camera.
    #[arg(long, default_value_t = 80.0)]
    pub max_angle: f64,
}

/// Where a cloud goes and in which format.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct CloudOut {
    /// The file, or `None` for standard output.
    pub path: Option<PathBuf>,
    /// The format.
    pub format: CloudFormat,
}

/// `true` if `p` is `-`: standard output.
pub fn is_stdout(p: &Path) -> bool {
    p.as_os_str() == "-"
}

impl CloudOut {
    /// Resolve `out` (the value of option `opt`) and an explicit `format`. Without `format` the
    /// extension decides (.ply or .xyz; any other is an error, never silently PLY); with it, the
    /// extension must agree or be unknown. The target is checked at once (a folder, a device or a
    /// FIFO is refused before any work is done).
    pub fn resolve(out: &Path, format: Option<CloudFormat>, opt: &str) -> Result<CloudOut> {
        if is_stdout(out) {
            return Ok(CloudOut {
                path: None,
                format: format.unwrap_or(CloudFormat::Ply),
            });
        }
        let ext = out
            .extension()
            .map(|e| e.to_string_lossy().to_ascii_lowercase());
        let by_ext = match ext.as_deref() {
            Some("ply") => Some(CloudFormat::Ply),
            Some("xyz") => Some(CloudFormat::Xyz),
            _ => None,
        };
        let format = match (format, by_ext) {
            (None, Some(f)) => f,
            (Some(f), None) => f,
            (Some(f), Some(e)) if f == e => f,
            (Some(f), Some(e)) => bail!(
                "{opt} {}: --format {} does not match the .{} extension",
                out.display(),
                f.extension(),
                e.extension()
            ),
            (None, None) => bail!(
                "{opt} {}: {}; point clouds are written as .ply or .xyz (or name the format with --format ply|xyz)",
                out.display(),
                match &ext {
                    Some(e) => format!("unknown extension .{e}"),
                    None => "no extension".to_string(),
                }
            ),
        };
        check_file_target(out)?;
        Ok(CloudOut {
            path: Some(out.to_path_buf()),
            format,
        })
    }

    /// `true` when the cloud goes to standard output (so messages must go to standard error).
    pub fn to_stdout(&self) -> bool {
        self.path.is_none()
    }

    /// The target for messages: the file name, or "standard output".
    pub fn describe(&self) -> String {
        match &self.path {
            Some(p) => p.display().to_string(),
            None => "standard output".into(),
        }
    }

    /// Run `write` on the file path (or, for standard output, on a path in a private temporary
    /// folder, then copy the finished file to standard output). Returns `write`'s count.
    pub fn deliver(&self, write: impl FnOnce(&Path) -> Result<u64>) -> Result<u64> {
        match &self.path {
            Some(p) => write(p),
            None => {
                let scratch =
                    AtomicDir::create(&std::env::temp_dir().join("fringe3d-stdout"), true)?;
                let file = scratch.join(format!("cloud.{}", self.format.extension()));
                let n = write(&file)?;
                let mut f = std::fs::File::open(&file)
                    .with_context(|| format!("{}: cannot read back", file.display()))?;
                let mut out = std::io::stdout().lock();
                match std::io::copy(&mut f, &mut out).and_then(|_| out.flush()) {
                    Ok(()) => {}
                    // The reader went away: not this command's failure (see `print`).
                    Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => {
                        super::print::note_stdout_error(e)
                    }
                    Err(e) => return Err(e).context("standard output: cannot write the cloud"),
                }
                Ok(n)
            }
        }
    }
}

/// Apply the edge filter (depth and light edges) unless `--no-edge-filter`.
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

/// Write `height` rows (`row(v)`) of a cloud `width` pixels wide to `out`. PLY: `opts` say what
/// each vertex holds; `organized` keeps every pixel. XYZ: the valid points only. Returns the
/// number of vertices written.
pub fn write_rows<'a>(
    out: &CloudOut,
    width: usize,
    height: usize,
    row: impl Fn(usize) -> PointRow<'a>,
    opts: PlyOptions,
    organized: bool,
) -> Result<u64> {
    out.deliver(|path| {
        if out.format == CloudFormat::Xyz {
            let mut wr = XyzWriter::create(path)?;
            for v in 0..height {
                wr.write_row(&row(v))?;
            }
            return Ok(wr.finish()?);
        }
        let mut wr = if organized {
            PlyWriter::create_organized(path, width as u32, height as u32, opts)?
        } else {
            // The valid points are known: the header can carry their count from the start.
            let n = (0..height)
                .map(|v| row(v).validity.iter().filter(|&&c| c == 0).count() as u64)
                .sum();
            PlyWriter::create_with_count(path, n, opts)?
        };
        for v in 0..height {
            wr.write_row(&row(v))?;
        }
        Ok(wr.finish()?)
    })
}

/// Write `cloud` with per-pixel intensity (A) and modulation (B) as `args` say. Returns the
/// number of vertices written.
pub fn write_cloud(
    args: &CloudArgs,
    out: &CloudOut,
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
    write_rows(out, w, h, row, ply_options(args, comments), args.organized)
}

/// The PLY options `args` ask for, with header `comments`.
pub fn ply_options(args: &CloudArgs, comments: Vec<String>) -> PlyOptions {
    PlyOptions {
        encoding: if args.ascii {
            PlyEncoding::Ascii
        } else {
            PlyEncoding::BinaryLittleEndian
        },
        comments,
        ..PlyOptions::default()
    }
}

/// An open cloud file fed with blocks of rows encoded on other threads (the streaming scan):
/// the same file, byte for byte, as [`write_cloud`] writes for the same rows.
pub enum CloudSink {
    /// PLY, organized or not (unorganized: behind room for the header, whose vertex count is
    /// known at the end; see [`PlyWriter::create_bounded`]).
    Ply(PlyWriter),
    /// XYZ text.
    Xyz(XyzWriter),
}

impl CloudSink {
    /// Start writing a `width × height` cloud in `format` at `path` as `args` say.
    pub fn create(
        args: &CloudArgs,
        format: CloudFormat,
        path: &Path,
        width: usize,
        height: usize,
        comments: Vec<String>,
    ) -> Result<CloudSink> {
        // The data goes to disk while the rest is computed; the fsync before the rename stays.
        Ok(match format {
            CloudFormat::Xyz => {
                let mut w = XyzWriter::create(path)?;
                w.sync_early()?;
                CloudSink::Xyz(w)
            }
            CloudFormat::Ply => {
                let opts = ply_options(args, comments);
                let mut w = if args.organized {
                    PlyWriter::create_organized(path, width as u32, height as u32, opts)?
                } else {
                    PlyWriter::create_bounded(path, (width * height) as u64, opts)?
                };
                w.sync_early()?;
                CloudSink::Ply(w)
            }
        })
    }

    /// The encoder of this file's rows.
    pub fn encoder(&self) -> RowEncoder {
        match self {
            CloudSink::Ply(w) => w.row_encoder(),
            CloudSink::Xyz(w) => w.row_encoder(),
        }
    }

    /// Append a block of encoded rows.
    pub fn write(&mut self, e: &Encoded) -> Result<(), FormatError> {
        match self {
            CloudSink::Ply(w) => w.write_encoded(e),
            CloudSink::Xyz(w) => w.write_encoded(e),
        }
    }

    /// Complete the file and move it into place; returns the number of vertices.
    pub fn finish(self) -> Result<u64, FormatError> {
        match self {
            CloudSink::Ply(w) => w.finish(),
            CloudSink::Xyz(w) => w.finish(),
        }
    }
}

/// Print a summary line: to standard output, or to standard error when the cloud itself goes to
/// standard output.
pub fn say(out: &CloudOut, line: &str) {
    if out.to_stdout() {
        errln!("{line}");
    } else {
        outln!("{line}");
    }
}

/// View a flat `[x0, y0, z0, x1, …]` buffer as points.
fn bytemuck_xyz(flat: &[f32]) -> &[[f32; 3]] {
    let (chunks, _) = flat.as_chunks::<3>();
    chunks
}
