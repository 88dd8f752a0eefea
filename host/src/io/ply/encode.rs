//! Encoding point rows into the bytes of a PLY or XYZ body, shared by the writers and by
//! [`RowEncoder`], which encodes blocks of rows on other threads (the streaming scan) for the
//! writer to append in order: one function per vertex, so both give the same bytes.

use std::path::{Path, PathBuf};

use super::{PixelIndexType, PlyEncoding, PlyOptions, PlyPoint, PointRow};
use crate::io::error::FormatError;

/// A block of consecutive rows encoded by a [`RowEncoder`], ready to be appended by the writer
/// that made the encoder ([`super::PlyWriter::write_encoded`], [`super::XyzWriter::write_encoded`]).
#[derive(Clone, Debug, Default)]
pub struct Encoded {
    /// The body bytes.
    pub bytes: Vec<u8>,
    /// Vertices (points) they hold.
    pub vertices: u64,
    /// The first row of the block.
    pub first_row: u32,
    /// Rows encoded.
    pub rows: u32,
}

impl Encoded {
    /// Empty the block for rows starting at `first_row`, keeping its allocation.
    pub fn clear(&mut self, first_row: u32) {
        self.bytes.clear();
        self.vertices = 0;
        self.first_row = first_row;
        self.rows = 0;
    }
}

/// Encodes rows for one writer, on any thread (it is `Send + Sync` and holds no file).
#[derive(Clone, Debug)]
pub enum RowEncoder {
    /// For a [`super::PlyWriter`].
    Ply {
        /// The target (for messages).
        path: PathBuf,
        /// What each vertex holds.
        opts: PlyOptions,
        /// Organized cloud size.
        organized: Option<(u32, u32)>,
    },
    /// For an [`super::XyzWriter`].
    Xyz {
        /// The target (for messages).
        path: PathBuf,
    },
}

impl RowEncoder {
    /// Make room in `out` for exactly the bytes of rows whose validity codes are `codes`, when
    /// that is known in advance (binary PLY), so that a block reused band after band is never
    /// larger than its largest band (a growing vector may hold twice what it needs).
    pub fn reserve(&self, codes: &[u8], out: &mut Encoded) {
        if let RowEncoder::Ply {
            opts, organized, ..
        } = self
            && opts.encoding == PlyEncoding::BinaryLittleEndian
        {
            let n = match organized {
                Some(_) => codes.len(),
                None => codes.iter().filter(|&&c| c == 0).count(),
            };
            let need = n * binary_vertex_bytes(opts, organized.is_some());
            out.bytes
                .reserve_exact(need.saturating_sub(out.bytes.len()));
        }
    }

    /// Append `row` to `out`: its checks and bytes are those of the writer's `write_row`. The
    /// rows of a block must be consecutive (organized clouds: `out.first_row + out.rows`).
    pub fn encode_row(&self, row: &PointRow<'_>, out: &mut Encoded) -> Result<(), FormatError> {
        let mut line = String::new();
        match self {
            RowEncoder::Ply {
                path,
                opts,
                organized,
            } => {
                check_row(
                    path,
                    opts,
                    *organized,
                    out.first_row.saturating_add(out.rows),
                    row,
                )?;
                out.vertices +=
                    encode_row_body(opts, organized.is_some(), row, &mut out.bytes, &mut line);
            }
            RowEncoder::Xyz { path } => {
                check_xyz_row(path, row)?;
                for (p, &c) in row.xyz.iter().zip(row.validity) {
                    if c == 0 {
                        line.clear();
                        encode_xyz(*p, &mut line);
                        out.bytes.extend_from_slice(line.as_bytes());
                        out.vertices += 1;
                    }
                }
            }
        }
        out.rows += 1;
        Ok(())
    }
}

/// The checks of `PlyWriter::write_row` (`next` is the row an organized cloud expects).
pub(super) fn check_row(
    path: &Path,
    opts: &PlyOptions,
    organized: Option<(u32, u32)>,
    next: u32,
    row: &PointRow<'_>,
) -> Result<(), FormatError> {
    let invalid = |m: String| FormatError::invalid(path, m);
    let n = row.xyz.len();
    let need = |name: &str, len: usize, used: bool| -> Result<(), FormatError> {
        if used && len != n {
            return Err(invalid(format!(
                "row {}: {name} has {len} values, xyz has {n}",
                row.v
            )));
        }
        Ok(())
    };
    need("validity", row.validity.len(), true)?;
    need("intensity", row.intensity.len(), opts.intensity)?;
    need("modulation", row.modulation.len(), opts.modulation)?;
    if let Some((w, h)) = organized {
        if row.v != next || next >= h {
            return Err(invalid(format!(
                "organized cloud: got row {}, expected row {} of {h}",
                row.v,
                next.min(h)
            )));
        }
        if n != w as usize {
            return Err(invalid(format!(
                "row {}: {n} pixels, the cloud is {w} wide",
                row.v
            )));
        }
    }
    if opts.pixel && opts.pixel_type == PixelIndexType::UShort && (row.v > 65535 || n > 65536) {
        return Err(invalid(format!(
            "row {}: pixel indices do not fit ushort; use PixelIndexType::UInt",
            row.v
        )));
    }
    Ok(())
}

/// The check of `XyzWriter::write_row`.
pub(super) fn check_xyz_row(path: &Path, row: &PointRow<'_>) -> Result<(), FormatError> {
    if row.validity.len() != row.xyz.len() {
        return Err(FormatError::invalid(
            path,
            format!(
                "row {}: validity has {} values, xyz has {}",
                row.v,
                row.validity.len(),
                row.xyz.len()
            ),
        ));
    }
    Ok(())
}

/// Append the vertices of a checked row to `out`: every pixel when `organized` (invalid ones
/// with NaN positions), else the valid ones. Returns the number of vertices.
pub(super) fn encode_row_body(
    opts: &PlyOptions,
    organized: bool,
    row: &PointRow<'_>,
    out: &mut Vec<u8>,
    line: &mut String,
) -> u64 {
    if opts.encoding == PlyEncoding::BinaryLittleEndian {
        return encode_binary_row(opts, organized, row, out);
    }
    let mut count = 0;
    for i in 0..row.xyz.len() {
        let code = row.validity[i];
        if code != 0 && !organized {
            continue;
        }
        let xyz = if code == 0 { row.xyz[i] } else { [f32::NAN; 3] };
        let p = PlyPoint {
            xyz,
            intensity: row.intensity.get(i).copied().unwrap_or(0.0),
            modulation: row.modulation.get(i).copied().unwrap_or(0.0),
            u: i as u32,
            v: row.v,
        };
        encode_vertex(opts, organized, &p, code, out, line);
        count += 1;
    }
    count
}

/// [`encode_row_body`] for binary PLY: the row's vertices laid out in one block of fixed-size
/// records, each field written as [`encode_vertex`] writes it (the same bytes).
/// The bytes of one binary vertex.
fn binary_vertex_bytes(opts: &PlyOptions, organized: bool) -> usize {
    let pixel = match (opts.pixel, opts.pixel_type) {
        (false, _) => 0,
        (true, PixelIndexType::UShort) => 4,
        (true, PixelIndexType::UInt) => 8,
    };
    12 + 4 * usize::from(opts.intensity)
        + 4 * usize::from(opts.modulation)
        + pixel
        + usize::from(organized)
}

fn encode_binary_row(
    opts: &PlyOptions,
    organized: bool,
    row: &PointRow<'_>,
    out: &mut Vec<u8>,
) -> u64 {
    // One instance of the vertex loop per layout, so that every field's offset is a constant
    // and the record size one too (the loop runs once per point of the cloud).
    const NONE: u8 = 0;
    const USHORT: u8 = 1;
    const UINT: u8 = 2;
    let pixel = match (opts.pixel, opts.pixel_type) {
        (false, _) => NONE,
        (true, PixelIndexType::UShort) => USHORT,
        (true, PixelIndexType::UInt) => UINT,
    };
    macro_rules! layouts {
        ($(($i:literal, $m:literal, $p:ident, $o:literal)),*) => {
            match (opts.intensity, opts.modulation, pixel, organized) {
                $(($i, $m, $p, $o) => encode_vertices::<$i, $m, $p, $o>(row, out),)*
                // `pixel` is one of the three above: every layout is listed.
                _ => 0,
            }
        };
    }
    layouts!(
        (false, false, NONE, false),
        (false, false, NONE, true),
        (false, false, USHORT, false),
        (false, false, USHORT, true),
        (false, false, UINT, false),
        (false, false, UINT, true),
        (false, true, NONE, false),
        (false, true, NONE, true),
        (false, true, USHORT, false),
        (false, true, USHORT, true),
        (false, true, UINT, false),
        (false, true, UINT, true),
        (true, false, NONE, false),
        (true, false, NONE, true),
        (true, false, USHORT, false),
        (true, false, USHORT, true),
        (true, false, UINT, false),
        (true, false, UINT, true),
        (true, true, NONE, false),
        (true, true, NONE, true),
        (true, true, USHORT, false),
        (true, true, USHORT, true),
        (true, true, UINT, false),
        (true, true, UINT, true)
    )
}

/// The vertices of one row in the layout the parameters name ([`binary_vertex_bytes`]): x y z,
/// then intensity (`INT`), modulation (`MOD`), the pixel's u v (`PIX`: none, ushort or uint)
/// and the code (`ORG`, organized clouds, whose every pixel is a vertex).
fn encode_vertices<const INT: bool, const MOD: bool, const PIX: u8, const ORG: bool>(
    row: &PointRow<'_>,
    out: &mut Vec<u8>,
) -> u64 {
    let n = row.xyz.len();
    let count = if ORG {
        n
    } else {
        row.validity.iter().filter(|&&c| c == 0).count()
    };
    // [`binary_vertex_bytes`], with constants.
    let size =
        12 + 4 * usize::from(INT) + 4 * usize::from(MOD) + 4 * PIX as usize + usize::from(ORG);
    let start = out.len();
    out.resize(start + count * size, 0);
    let recs = out[start..].chunks_exact_mut(size);
    let pixels = (0..n).filter(|&i| ORG || row.validity.get(i) == Some(&0));
    for (r, i) in recs.zip(pixels) {
        let code = row.validity.get(i).copied().unwrap_or(0);
        let xyz = if code == 0 { row.xyz[i] } else { [f32::NAN; 3] };
        r[0..4].copy_from_slice(&xyz[0].to_le_bytes());
        r[4..8].copy_from_slice(&xyz[1].to_le_bytes());
        r[8..12].copy_from_slice(&xyz[2].to_le_bytes());
        let mut k = 12;
        if INT {
            let v = row.intensity.get(i).copied().unwrap_or(0.0);
            r[k..k + 4].copy_from_slice(&v.to_le_bytes());
            k += 4;
        }
        if MOD {
            let v = row.modulation.get(i).copied().unwrap_or(0.0);
            r[k..k + 4].copy_from_slice(&v.to_le_bytes());
            k += 4;
        }
        if PIX == 1 {
            r[k..k + 2].copy_from_slice(&(i as u16).to_le_bytes());
            r[k + 2..k + 4].copy_from_slice(&(row.v as u16).to_le_bytes());
            k += 4;
        } else if PIX == 2 {
            r[k..k + 4].copy_from_slice(&(i as u32).to_le_bytes());
            r[k + 4..k + 8].copy_from_slice(&row.v.to_le_bytes());
            k += 8;
        }
        if ORG {
            r[k] = code;
        }
    }
    count as u64
}

/// Append one vertex to `out` (`line` is scratch for ASCII); `code` is written for organized
/// clouds only.
pub(super) fn encode_vertex(
    o: &PlyOptions,
    organized: bool,
    p: &PlyPoint,
    code: u8,
    out: &mut Vec<u8>,
    line: &mut String,
) {
    match o.encoding {
        PlyEncoding::BinaryLittleEndian => {
            let mut buf = [0u8; 32];
            let mut k = 0;
            let mut push = |b: &[u8]| {
                buf[k..k + b.len()].copy_from_slice(b);
                k += b.len();
            };
            for c in p.xyz {
                push(&c.to_le_bytes());
            }
            if o.intensity {
                push(&p.intensity.to_le_bytes());
            }
            if o.modulation {
                push(&p.modulation.to_le_bytes());
            }
            if o.pixel {
                match o.pixel_type {
                    PixelIndexType::UShort => {
                        push(&(p.u as u16).to_le_bytes());
                        push(&(p.v as u16).to_le_bytes());
                    }
                    PixelIndexType::UInt => {
                        push(&p.u.to_le_bytes());
                        push(&p.v.to_le_bytes());
                    }
                }
            }
            if organized {
                push(&[code]);
            }
            out.extend_from_slice(&buf[..k]);
        }
        PlyEncoding::Ascii => {
            use std::fmt::Write as _;
            let l = line;
            l.clear();
            let mut first = true;
            let mut f = |v: f32| {
                if !first {
                    l.push(' ');
                }
                first = false;
                if v.is_nan() {
                    l.push_str("nan");
                } else {
                    let _ = write!(l, "{v}");
                }
            };
            for c in p.xyz {
                f(c);
            }
            if o.intensity {
                f(p.intensity);
            }
            if o.modulation {
                f(p.modulation);
            }
            if o.pixel {
                let _ = write!(l, " {} {}", p.u, p.v);
            }
            if organized {
                let _ = write!(l, " {code}");
            }
            l.push('\n');
            out.extend_from_slice(l.as_bytes());
        }
    }
}

/// Append one XYZ line, `x y z\n`, to `line`.
pub(super) fn encode_xyz(xyz: [f32; 3], line: &mut String) {
    use std::fmt::Write as _;
    let _ = writeln!(line, "{} {} {}", xyz[0], xyz[1], xyz[2]);
}
