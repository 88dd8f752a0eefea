//! Point clouds: a streaming PLY writer (binary little-endian or ASCII) and an XYZ text writer.
//!
//! Points are in the camera frame (OpenCV: x right, y down, z forward), millimetres. Each vertex
//! carries, by default:
//!
//! | property     | type             | meaning                                                   |
//! |--------------|------------------|-----------------------------------------------------------|
//! | `x y z`      | float            | position, mm (NaN for invalid pixels of organized clouds) |
//! | `intensity`  | float            | the DC term A of the pixel (eqs 10, 15), gray levels      |
//! | `modulation` | float            | the modulation B of the finest level, gray levels         |
//! | `u v`        | ushort or uint   | the source camera pixel (column, row)                     |
//! | `validity`   | uchar            | organized clouds only: 0 = valid, else the [`Validity`] code |
//!
//! An *unorganized* cloud holds the valid points only, in the order written. An *organized* cloud
//! holds one vertex per camera pixel, row-major (vertex index `v·width + u`), and records the grid
//! as `obj_info num_cols W` / `obj_info num_rows H` (as PCL does) and in a comment.
//!
//! Writing streams row by row (the scan pipeline's point rows) and is atomic: nothing appears at
//! the target path until [`PlyWriter::finish`] succeeds. An organized header knows its vertex count
//! up front; for an unorganized cloud the vertices go to a scratch file beside the target and
//! are copied behind the header once their count is known, so the header is exactly standard.
//!
//! [`Validity`]: fringe3d_core::Validity

use std::fs::{self, File, OpenOptions};
use std::io::{self, BufWriter, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

use super::atomic::AtomicFile;
use super::error::FormatError;

mod encode;
mod flush;
pub use encode::{Encoded, RowEncoder};
use encode::{check_row, check_xyz_row, encode_row_body, encode_vertex, encode_xyz};
use flush::EarlySync;

/// PLY body encoding.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum PlyEncoding {
    /// `format binary_little_endian 1.0` (compact, exact).
    #[default]
    BinaryLittleEndian,
    /// `format ascii 1.0`; floats in their shortest exact decimal form, `nan` for NaN.
    Ascii,
}

/// Type of the `u`, `v` pixel properties.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum PixelIndexType {
    /// `ushort` (u16): cameras up to 65535 pixels wide and high.
    #[default]
    UShort,
    /// `uint` (u32).
    UInt,
}

/// What a PLY file holds and how it is encoded.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct PlyOptions {
    /// Body encoding; default binary little-endian.
    pub encoding: PlyEncoding,
    /// Write the `intensity` property; default `true`.
    pub intensity: bool,
    /// Write the `modulation` property; default `true`.
    pub modulation: bool,
    /// Write the `u`, `v` properties; default `true`.
    pub pixel: bool,
    /// Type of `u`, `v`; default `ushort`.
    pub pixel_type: PixelIndexType,
    /// Extra `comment` lines for the header (one line each; line breaks are replaced by spaces).
    pub comments: Vec<String>,
}

impl Default for PlyOptions {
    fn default() -> Self {
        PlyOptions {
            encoding: PlyEncoding::BinaryLittleEndian,
            intensity: true,
            modulation: true,
            pixel: true,
            pixel_type: PixelIndexType::UShort,
            comments: Vec::new(),
        }
    }
}

/// One point of an unorganized cloud.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PlyPoint {
    /// Position, camera frame, mm.
    pub xyz: [f32; 3],
    /// DC term A, gray levels.
    pub intensity: f32,
    /// Modulation B, gray levels.
    pub modulation: f32,
    /// Source pixel column.
    pub u: u32,
    /// Source pixel row.
    pub v: u32,
}

/// One camera row of reconstruction output, in caller-owned buffers (pixel `i` is column
/// `u = i`). `intensity` and `modulation` may be empty when the writer does not write them;
/// otherwise every slice has the row's length.
#[derive(Clone, Copy, Debug)]
pub struct PointRow<'a> {
    /// Camera row index `v`.
    pub v: u32,
    /// Positions, camera frame, mm.
    pub xyz: &'a [[f32; 3]],
    /// DC term A per pixel.
    pub intensity: &'a [f32],
    /// Modulation B per pixel.
    pub modulation: &'a [f32],
    /// Validity code per pixel (`Validity as u8`; 0 = valid).
    pub validity: &'a [u8],
}

/// A scratch file beside the target, removed when dropped.
struct Scratch {
    path: PathBuf,
    out: BufWriter<File>,
}

impl Drop for Scratch {
    fn drop(&mut self) {
        let _ = fs::remove_file(&self.path);
    }
}

static SCRATCH: AtomicU64 = AtomicU64::new(0);

impl Scratch {
    fn beside(target: &Path) -> io::Result<Scratch> {
        let dir = match target.parent() {
            Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
            _ => PathBuf::from("."),
        };
        let name = target
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        let mut last = io::Error::other("name collision");
        for _ in 0..16 {
            let n = SCRATCH.fetch_add(1, Ordering::Relaxed);
            let path = dir.join(format!(".{name}.body-{}-{n}", std::process::id()));
            match OpenOptions::new()
                .read(true)
                .write(true)
                .create_new(true)
                .open(&path)
            {
                Ok(f) => {
                    return Ok(Scratch {
                        path,
                        out: BufWriter::with_capacity(1 << 16, f),
                    });
                }
                Err(e) if e.kind() == io::ErrorKind::AlreadyExists => last = e,
                Err(e) => return Err(e),
            }
        }
        Err(last)
    }
}

enum Body {
    /// Organized: the header is written; rows go straight into the atomic file.
    Direct,
    /// Unorganized: vertices go to a scratch file until the count is known.
    Scratch(Scratch),
    /// Unorganized with a bound on the count: the vertices go straight into the file behind room
    /// for the longest header the bound allows (`start` bytes); [`PlyWriter::finish`] writes the
    /// header there, moving the vertices forward if it is shorter.
    Reserved {
        /// Where the vertices start.
        start: u64,
        /// The bound.
        max: u64,
    },
}

/// A streaming, atomic PLY writer. Create it with [`PlyWriter::create`] (unorganized) or
/// [`PlyWriter::create_organized`], feed rows or points, then [`PlyWriter::finish`]. Dropping it
/// unfinished (or any error) leaves the target untouched and removes the temporary files.
pub struct PlyWriter {
    /// Early write-back ([`PlyWriter::sync_early`]); stopped before `out` is committed or dropped.
    early: Option<EarlySync>,
    path: PathBuf,
    opts: PlyOptions,
    organized: Option<(u32, u32)>,
    out: AtomicFile,
    body: Body,
    rows: u32,
    count: u64,
    /// The vertex count already written in the header ([`PlyWriter::create_with_count`]).
    announced: Option<u64>,
    line: String,
    /// Binary vertices not yet handed to the file (written in blocks of [`PENDING_BYTES`], not
    /// one small write per vertex).
    pending: Vec<u8>,
}

/// Size of the blocks binary vertices are written in.
const PENDING_BYTES: usize = 1 << 16;

impl std::fmt::Debug for PlyWriter {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("PlyWriter")
            .field("path", &self.path)
            .field("organized", &self.organized)
            .field("count", &self.count)
            .finish_non_exhaustive()
    }
}

impl PlyWriter {
    /// A writer that has written nothing past its header yet.
    fn fresh(
        path: &Path,
        opts: PlyOptions,
        organized: Option<(u32, u32)>,
        out: AtomicFile,
        body: Body,
    ) -> PlyWriter {
        PlyWriter {
            early: None,
            path: path.to_path_buf(),
            opts,
            organized,
            out,
            body,
            rows: 0,
            count: 0,
            announced: None,
            line: String::new(),
            pending: Vec::new(),
        }
    }

    /// An unorganized cloud at `path`: valid points only.
    pub fn create(path: &Path, opts: PlyOptions) -> Result<PlyWriter, FormatError> {
        let out = AtomicFile::create(path)?;
        let scratch = Scratch::beside(path)
            .map_err(|e| FormatError::io(path, "cannot create a scratch file beside it", e))?;
        Ok(PlyWriter::fresh(
            path,
            opts,
            None,
            out,
            Body::Scratch(scratch),
        ))
    }

    /// An organized cloud of `width × height` vertices at `path`: one per camera pixel, written
    /// with [`PlyWriter::write_row`] for rows 0, 1, … in order. Invalid pixels get NaN positions.
    pub fn create_organized(
        path: &Path,
        width: u32,
        height: u32,
        opts: PlyOptions,
    ) -> Result<PlyWriter, FormatError> {
        if width == 0 || height == 0 {
            return Err(FormatError::invalid(
                path,
                format!("organized cloud size must be positive, got {width} x {height}"),
            ));
        }
        if opts.pixel
            && opts.pixel_type == PixelIndexType::UShort
            && (width > 65536 || height > 65536)
        {
            return Err(FormatError::invalid(
                path,
                format!(
                    "{width} x {height} pixels do not fit ushort u, v; use PixelIndexType::UInt"
                ),
            ));
        }
        let mut out = AtomicFile::create(path)?;
        let header = header(
            &opts,
            Some((width, height)),
            u64::from(width) * u64::from(height),
        );
        out.write_all(header.as_bytes())
            .map_err(|e| FormatError::io(path, "cannot write", e))?;
        Ok(PlyWriter::fresh(
            path,
            opts,
            Some((width, height)),
            out,
            Body::Direct,
        ))
    }

    /// An unorganized cloud of at most `max_count` vertices whose count is not known before
    /// writing (a streaming scan): the vertices go straight into the (atomic) target behind room
    /// for the header, without the scratch file of [`PlyWriter::create`]. When the count has as
    /// many digits as `max_count` the header fills that room exactly; otherwise
    /// [`PlyWriter::finish`] moves the vertices forward by the difference (a few bytes), a copy
    /// within the file. The file is the same either way. `finish` refuses (and writes nothing)
    /// if more than `max_count` vertices were written.
    pub fn create_bounded(
        path: &Path,
        max_count: u64,
        opts: PlyOptions,
    ) -> Result<PlyWriter, FormatError> {
        let mut out = AtomicFile::create(path)?;
        let room = header(&opts, None, max_count);
        out.write_all(room.as_bytes())
            .map_err(|e| FormatError::io(path, "cannot write", e))?;
        Ok(PlyWriter::fresh(
            path,
            opts,
            None,
            out,
            Body::Reserved {
                start: room.len() as u64,
                max: max_count,
            },
        ))
    }

    /// An unorganized cloud whose vertex count is known before writing: the header goes out at
    /// once and the vertices straight into the (atomic) target, without the scratch file and the
    /// copy that [`PlyWriter::create`] needs. [`PlyWriter::finish`] refuses (and writes nothing)
    /// if a different number of vertices was written.
    pub fn create_with_count(
        path: &Path,
        count: u64,
        opts: PlyOptions,
    ) -> Result<PlyWriter, FormatError> {
        let mut out = AtomicFile::create(path)?;
        out.write_all(header(&opts, None, count).as_bytes())
            .map_err(|e| FormatError::io(path, "cannot write", e))?;
        Ok(PlyWriter {
            announced: Some(count),
            ..PlyWriter::fresh(path, opts, None, out, Body::Direct)
        })
    }

    /// The target path.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Vertices written so far.
    pub fn count(&self) -> u64 {
        self.count
    }

    fn invalid(&self, m: String) -> FormatError {
        FormatError::invalid(&self.path, m)
    }

    /// Write one camera row. Organized: every pixel, rows strictly in order `0..height`, each of
    /// exactly `width` pixels. Unorganized: only the pixels whose validity is 0, any row order.
    pub fn write_row(&mut self, row: &PointRow<'_>) -> Result<(), FormatError> {
        check_row(&self.path, &self.opts, self.organized, self.rows, row)?;
        self.count += encode_row_body(
            &self.opts,
            self.organized.is_some(),
            row,
            &mut self.pending,
            &mut self.line,
        );
        self.rows += 1;
        if self.pending.len() >= PENDING_BYTES {
            self.flush_pending()?;
        }
        Ok(())
    }

    /// Write points of an unorganized cloud (not allowed for organized clouds).
    pub fn write_points(&mut self, points: &[PlyPoint]) -> Result<(), FormatError> {
        if self.organized.is_some() {
            return Err(self.invalid("organized cloud: write whole rows with write_row".into()));
        }
        for p in points {
            if self.opts.pixel
                && self.opts.pixel_type == PixelIndexType::UShort
                && (p.u > 65535 || p.v > 65535)
            {
                return Err(self.invalid(format!(
                    "pixel ({}, {}) does not fit ushort; use PixelIndexType::UInt",
                    p.u, p.v
                )));
            }
            self.put(p, 0)?;
        }
        Ok(())
    }

    fn put(&mut self, p: &PlyPoint, code: u8) -> Result<(), FormatError> {
        encode_vertex(
            &self.opts,
            self.organized.is_some(),
            p,
            code,
            &mut self.pending,
            &mut self.line,
        );
        self.count += 1;
        if self.pending.len() >= PENDING_BYTES {
            self.flush_pending()?;
        }
        Ok(())
    }

    /// An encoder of rows for this file, to run on other threads: what it produces,
    /// [`PlyWriter::write_encoded`] appends, byte for byte what [`PlyWriter::write_row`] writes
    /// for the same rows.
    pub fn row_encoder(&self) -> RowEncoder {
        RowEncoder::Ply {
            path: self.path.clone(),
            opts: self.opts.clone(),
            organized: self.organized,
        }
    }

    /// Append rows encoded by this writer's [`PlyWriter::row_encoder`]. Organized: the blocks
    /// must come in row order, each starting at the next row.
    pub fn write_encoded(&mut self, e: &Encoded) -> Result<(), FormatError> {
        if let Some((_, h)) = self.organized
            && (e.first_row != self.rows || self.rows.saturating_add(e.rows) > h)
        {
            return Err(self.invalid(format!(
                "organized cloud: got rows from {}, expected row {} of {h}",
                e.first_row,
                self.rows.min(h)
            )));
        }
        self.flush_pending()?;
        let res = match &mut self.body {
            Body::Direct | Body::Reserved { .. } => self.out.write_all(&e.bytes),
            Body::Scratch(s) => s.out.write_all(&e.bytes),
        };
        res.map_err(|err| FormatError::io(&self.path, "cannot write", err))?;
        if let (Some(s), Body::Direct | Body::Reserved { .. }) = (&mut self.early, &self.body) {
            s.wrote(e.bytes.len() as u64, &mut self.out)
                .map_err(|err| FormatError::io(&self.path, "cannot write", err))?;
        }
        self.count += e.vertices;
        self.rows += e.rows;
        Ok(())
    }

    /// Write the data back to disk in the background as it is written with
    /// [`PlyWriter::write_encoded`], so that the `fsync` of [`PlyWriter::finish`] (which stays)
    /// has little left to do. For files written while the rest is still being computed.
    pub fn sync_early(&mut self) -> Result<(), FormatError> {
        EarlySync::ensure(&mut self.early, &mut self.out, &self.path)
    }

    /// Hand the pending binary vertices to the file.
    fn flush_pending(&mut self) -> Result<(), FormatError> {
        let res = match &mut self.body {
            Body::Direct | Body::Reserved { .. } => self.out.write_all(&self.pending),
            Body::Scratch(s) => s.out.write_all(&self.pending),
        };
        self.pending.clear();
        res.map_err(|e| FormatError::io(&self.path, "cannot write", e))
    }

    /// Complete the file and move it into place; returns the number of vertices. An organized
    /// cloud must have received all its rows.
    pub fn finish(mut self) -> Result<u64, FormatError> {
        self.flush_pending()?;
        if let Some(s) = &mut self.early {
            s.stop();
        }
        if let Some((_, h)) = self.organized
            && self.rows != h
        {
            return Err(self.invalid(format!(
                "organized cloud: {} of {h} rows written",
                self.rows
            )));
        }
        if let Some(n) = self.announced
            && n != self.count
        {
            return Err(self.invalid(format!(
                "{} vertices written, {n} announced in the header",
                self.count
            )));
        }
        let path = self.path.clone();
        let ioe = |e| FormatError::io(&path, "cannot write", e);
        if let Body::Reserved { start, max } = self.body {
            if self.count > max {
                return Err(self.invalid(format!(
                    "{} vertices written, at most {max} expected",
                    self.count
                )));
            }
            let head = header(&self.opts, None, self.count);
            let tmp = self.out.temp_path().to_path_buf();
            let f = self.out.get_file().map_err(ioe)?;
            place_header(f, &tmp, head.as_bytes(), start).map_err(ioe)?;
        }
        if let Body::Scratch(s) = &mut self.body {
            let head = header(&self.opts, None, self.count);
            self.out.write_all(head.as_bytes()).map_err(ioe)?;
            s.out.flush().map_err(ioe)?;
            let f = s.out.get_mut();
            f.seek(SeekFrom::Start(0)).map_err(ioe)?;
            io::copy(f, &mut self.out).map_err(ioe)?;
        }
        let count = self.count;
        let PlyWriter { out, body, .. } = self;
        drop(body);
        out.commit()?;
        Ok(count)
    }
}

/// Write `head` in front of the vertices that start at `start` in `f` (the file at `path`,
/// opened for writing only): in place when it is `start` bytes long, else after moving the
/// vertices forward to end right behind it, and cutting the file there.
fn place_header(f: &mut File, path: &Path, head: &[u8], start: u64) -> io::Result<()> {
    let len = head.len() as u64;
    if len > start {
        return Err(io::Error::other("the header outgrew its room"));
    }
    if len < start {
        let mut src = File::open(path)?;
        src.seek(SeekFrom::Start(start))?;
        f.seek(SeekFrom::Start(len))?;
        let mut buf = vec![0u8; 1 << 20];
        let mut end = len;
        loop {
            let n = io::Read::read(&mut src, &mut buf)?;
            if n == 0 {
                break;
            }
            f.write_all(&buf[..n])?;
            end += n as u64;
        }
        f.set_len(end)?;
    }
    f.seek(SeekFrom::Start(0))?;
    f.write_all(head)?;
    f.flush()
}

/// The PLY header.
fn header(o: &PlyOptions, organized: Option<(u32, u32)>, count: u64) -> String {
    let mut h = String::from("ply\n");
    h.push_str(match o.encoding {
        PlyEncoding::BinaryLittleEndian => "format binary_little_endian 1.0\n",
        PlyEncoding::Ascii => "format ascii 1.0\n",
    });
    h.push_str(
        "comment fringe3d point cloud: camera frame (x right, y down, z forward), millimetres\n",
    );
    if let Some((w, hh)) = organized {
        h.push_str(&format!(
            "comment organized {w} x {hh}: one vertex per camera pixel, row-major (index v*{w} + u); \
             validity 0 = valid, else the fringe3d validity code, and x y z are NaN\n"
        ));
    }
    for c in &o.comments {
        h.push_str("comment ");
        h.push_str(&c.replace(['\n', '\r'], " "));
        h.push('\n');
    }
    if let Some((w, hh)) = organized {
        h.push_str(&format!("obj_info num_cols {w}\nobj_info num_rows {hh}\n"));
    }
    h.push_str(&format!("element vertex {count}\n"));
    h.push_str("property float x\nproperty float y\nproperty float z\n");
    if o.intensity {
        h.push_str("property float intensity\n");
    }
    if o.modulation {
        h.push_str("property float modulation\n");
    }
    if o.pixel {
        let t = match o.pixel_type {
            PixelIndexType::UShort => "ushort",
            PixelIndexType::UInt => "uint",
        };
        h.push_str(&format!("property {t} u\nproperty {t} v\n"));
    }
    if organized.is_some() {
        h.push_str("property uchar validity\n");
    }
    h.push_str("end_header\n");
    h
}

/// A streaming, atomic XYZ text writer: one `x y z` line per valid point (mm, camera frame),
/// floats in their shortest exact decimal form.
pub struct XyzWriter {
    /// Early write-back ([`XyzWriter::sync_early`]); stopped before `out` is committed or dropped.
    early: Option<EarlySync>,
    path: PathBuf,
    out: AtomicFile,
    count: u64,
    line: String,
}

impl std::fmt::Debug for XyzWriter {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("XyzWriter")
            .field("path", &self.path)
            .field("count", &self.count)
            .finish_non_exhaustive()
    }
}

impl XyzWriter {
    /// Start writing `path`.
    pub fn create(path: &Path) -> Result<XyzWriter, FormatError> {
        Ok(XyzWriter {
            early: None,
            path: path.to_path_buf(),
            out: AtomicFile::create(path)?,
            count: 0,
            line: String::new(),
        })
    }

    /// Write one point.
    pub fn write_point(&mut self, xyz: [f32; 3]) -> Result<(), FormatError> {
        self.line.clear();
        encode_xyz(xyz, &mut self.line);
        self.out
            .write_all(self.line.as_bytes())
            .map_err(|e| FormatError::io(&self.path, "cannot write", e))?;
        self.count += 1;
        Ok(())
    }

    /// Write the valid pixels (validity 0) of a row.
    pub fn write_row(&mut self, row: &PointRow<'_>) -> Result<(), FormatError> {
        check_xyz_row(&self.path, row)?;
        for (p, &c) in row.xyz.iter().zip(row.validity) {
            if c == 0 {
                self.write_point(*p)?;
            }
        }
        Ok(())
    }

    /// An encoder of rows for this file, to run on other threads: what it produces,
    /// [`XyzWriter::write_encoded`] appends, byte for byte what [`XyzWriter::write_row`] writes.
    pub fn row_encoder(&self) -> RowEncoder {
        RowEncoder::Xyz {
            path: self.path.clone(),
        }
    }

    /// Append rows encoded by this writer's [`XyzWriter::row_encoder`].
    pub fn write_encoded(&mut self, e: &Encoded) -> Result<(), FormatError> {
        self.out
            .write_all(&e.bytes)
            .map_err(|err| FormatError::io(&self.path, "cannot write", err))?;
        if let Some(s) = &mut self.early {
            s.wrote(e.bytes.len() as u64, &mut self.out)
                .map_err(|err| FormatError::io(&self.path, "cannot write", err))?;
        }
        self.count += e.vertices;
        Ok(())
    }

    /// [`PlyWriter::sync_early`] for XYZ files.
    pub fn sync_early(&mut self) -> Result<(), FormatError> {
        EarlySync::ensure(&mut self.early, &mut self.out, &self.path)
    }

    /// Complete the file and move it into place; returns the number of points.
    pub fn finish(mut self) -> Result<u64, FormatError> {
        if let Some(s) = &mut self.early {
            s.stop();
        }
        let n = self.count;
        self.out.commit()?;
        Ok(n)
    }
}

/// Write a whole unorganized PLY cloud at once.
pub fn write_ply(path: &Path, points: &[PlyPoint], opts: PlyOptions) -> Result<u64, FormatError> {
    let mut w = PlyWriter::create(path, opts)?;
    w.write_points(points)?;
    w.finish()
}
