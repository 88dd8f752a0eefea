//! Reading point clouds and triangle meshes: PLY (ASCII, binary little- and big-endian; `vertex`
//! x/y/z of any scalar type, `face` vertex lists triangulated as fans) and STL (binary and ASCII),
//! for `fringe3d adapt` (a first scan's cloud, or a model of the object).
//!
//! Every count in a header is checked against the bytes that follow it before anything is
//! allocated from it, and the file against [`MAX_MESH_BYTES`].

use std::path::Path;

use super::error::FormatError;
use super::input::read_limited;

/// The largest mesh or cloud file read, bytes (1 GiB).
pub const MAX_MESH_BYTES: u64 = 1 << 30;

/// Points (camera frame or the model's own, mm) and triangles indexing them.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Mesh {
    /// Vertices.
    pub vertices: Vec<[f64; 3]>,
    /// Triangles (empty for a point cloud).
    pub triangles: Vec<[u32; 3]>,
    /// Each vertex's `modulation` property, when the PLY has one (a `fringe3d scan` cloud: the
    /// fringe modulation B its pixel measured); empty otherwise.
    pub modulation: Vec<f64>,
}

/// Read a PLY or STL file (by its content, not its name).
pub fn read_mesh(path: &Path) -> Result<Mesh, FormatError> {
    let bytes = read_limited(path, MAX_MESH_BYTES).map_err(|e| FormatError::Io {
        path: path.to_path_buf(),
        action: "cannot read",
        source: e,
    })?;
    let bad = |m: String| FormatError::parse(path, m);
    let mesh = if bytes.starts_with(b"ply") {
        read_ply(&bytes).map_err(bad)?
    } else if is_binary_stl(&bytes) {
        read_stl_binary(&bytes)
    } else if bytes.starts_with(b"solid") {
        read_stl_ascii(&bytes).map_err(bad)?
    } else {
        return Err(bad("neither a PLY nor an STL file".into()));
    };
    // A cloud may hold non-finite points (an organized scan's invalid pixels): its reader's
    // user skips them. A mesh's vertices must all be finite.
    if let Some(i) = mesh
        .vertices
        .iter()
        .position(|v| !v.iter().all(|c| c.is_finite()))
        .filter(|_| !mesh.triangles.is_empty())
    {
        return Err(FormatError::invalid(
            path,
            format!("vertex {i} is not finite"),
        ));
    }
    let n = mesh.vertices.len() as u64;
    if let Some(i) = mesh
        .triangles
        .iter()
        .position(|t| t.iter().any(|&k| u64::from(k) >= n))
    {
        return Err(FormatError::invalid(
            path,
            format!("triangle {i} indexes a vertex past the {n} vertices"),
        ));
    }
    Ok(mesh)
}

fn is_binary_stl(b: &[u8]) -> bool {
    b.len() >= 84 && {
        let n = u32::from_le_bytes([b[80], b[81], b[82], b[83]]) as u64;
        b.len() as u64 == 84 + 50 * n
    }
}

fn read_stl_binary(b: &[u8]) -> Mesh {
    let mut m = Mesh::default();
    for rec in b[84..].chunks_exact(50) {
        let f = |o: usize| {
            f64::from(f32::from_le_bytes([
                rec[o],
                rec[o + 1],
                rec[o + 2],
                rec[o + 3],
            ]))
        };
        let base = m.vertices.len() as u32;
        for k in 0..3 {
            let o = 12 + 12 * k;
            m.vertices.push([f(o), f(o + 4), f(o + 8)]);
        }
        m.triangles.push([base, base + 1, base + 2]);
    }
    m
}

fn read_stl_ascii(b: &[u8]) -> Result<Mesh, String> {
    let text = std::str::from_utf8(b).map_err(|_| {
        "starts as an ASCII STL (\"solid\") but is not text, and is not a binary STL either \
         (its size is not 84 + 50 bytes per facet of its count)"
            .to_string()
    })?;
    let mut m = Mesh::default();
    let mut corner = 0usize;
    for (line_no, line) in text.lines().enumerate() {
        let mut it = line.split_whitespace();
        match it.next() {
            Some("vertex") => {
                let mut v = [0.0; 3];
                for c in &mut v {
                    *c = it
                        .next()
                        .and_then(|s| s.parse().ok())
                        .ok_or_else(|| format!("line {}: a vertex needs 3 numbers", line_no + 1))?;
                }
                m.vertices.push(v);
                corner += 1;
            }
            Some("endloop") => {
                if corner != 3 {
                    return Err(format!(
                        "line {}: a facet with {corner} vertices (STL facets have 3)",
                        line_no + 1
                    ));
                }
                let base = (m.vertices.len() - 3) as u32;
                m.triangles.push([base, base + 1, base + 2]);
                corner = 0;
            }
            _ => {}
        }
    }
    if m.triangles.is_empty() {
        return Err("no facets".into());
    }
    Ok(m)
}

/// A PLY scalar type.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Scalar {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl Scalar {
    fn parse(s: &str) -> Option<Scalar> {
        Some(match s {
            "char" | "int8" => Scalar::I8,
            "uchar" | "uint8" => Scalar::U8,
            "short" | "int16" => Scalar::I16,
            "ushort" | "uint16" => Scalar::U16,
            "int" | "int32" => Scalar::I32,
            "uint" | "uint32" => Scalar::U32,
            "float" | "float32" => Scalar::F32,
            "double" | "float64" => Scalar::F64,
            _ => return None,
        })
    }

    fn size(self) -> usize {
        match self {
            Scalar::I8 | Scalar::U8 => 1,
            Scalar::I16 | Scalar::U16 => 2,
            Scalar::I32 | Scalar::U32 | Scalar::F32 => 4,
            Scalar::F64 => 8,
        }
    }
}

#[derive(Clone, Debug)]
struct Property {
    name: String,
    /// `Some(count type)` for a list.
    list: Option<Scalar>,
    ty: Scalar,
}

#[derive(Clone, Debug)]
struct Element {
    name: String,
    count: usize,
    props: Vec<Property>,
}

#[derive(Clone, Copy, PartialEq)]
enum Encoding {
    Ascii,
    Little,
    Big,
}

/// A cursor over a PLY body.
struct Body<'a> {
    b: &'a [u8],
    at: usize,
    enc: Encoding,
    /// ASCII tokens.
    tokens: std::str::SplitAsciiWhitespace<'a>,
}

impl Body<'_> {
    fn read(&mut self, ty: Scalar) -> Result<f64, String> {
        if self.enc == Encoding::Ascii {
            let t = self.tokens.next().ok_or("the data ends early")?;
            return t
                .parse::<f64>()
                .map_err(|_| format!("{t:?} is not a number"));
        }
        let n = ty.size();
        let s = self
            .b
            .get(self.at..self.at + n)
            .ok_or("the data ends early")?;
        self.at += n;
        let mut a = [0u8; 8];
        a[..n].copy_from_slice(s);
        if self.enc == Encoding::Big {
            a[..n].reverse();
        }
        Ok(match ty {
            Scalar::I8 => f64::from(a[0] as i8),
            Scalar::U8 => f64::from(a[0]),
            Scalar::I16 => f64::from(i16::from_le_bytes([a[0], a[1]])),
            Scalar::U16 => f64::from(u16::from_le_bytes([a[0], a[1]])),
            Scalar::I32 => f64::from(i32::from_le_bytes([a[0], a[1], a[2], a[3]])),
            Scalar::U32 => f64::from(u32::from_le_bytes([a[0], a[1], a[2], a[3]])),
            Scalar::F32 => f64::from(f32::from_le_bytes([a[0], a[1], a[2], a[3]])),
            Scalar::F64 => f64::from_le_bytes(a),
        })
    }

    /// Bytes (binary) or tokens (ASCII) left, a bound on what can still be read.
    fn left(&self) -> usize {
        self.b.len() - self.at
    }
}

fn header(b: &[u8]) -> Result<(Encoding, Vec<Element>, usize), String> {
    let end = b
        .windows(10)
        .position(|w| w == b"end_header")
        .ok_or("no end_header")?;
    let text = std::str::from_utf8(&b[..end]).map_err(|_| "a header that is not text")?;
    let mut body = end + 10;
    if b.get(body) == Some(&b'\r') {
        body += 1;
    }
    if b.get(body) != Some(&b'\n') {
        return Err("end_header must end its line".into());
    }
    body += 1;
    let mut enc = None;
    let mut elements: Vec<Element> = Vec::new();
    for line in text.lines().skip(1) {
        let w: Vec<&str> = line.split_whitespace().collect();
        match w.as_slice() {
            ["format", f, _] => {
                enc = Some(match *f {
                    "ascii" => Encoding::Ascii,
                    "binary_little_endian" => Encoding::Little,
                    "binary_big_endian" => Encoding::Big,
                    _ => return Err(format!("unknown format {f}")),
                })
            }
            ["element", name, n] => elements.push(Element {
                name: name.to_string(),
                count: n
                    .parse()
                    .map_err(|_| format!("element {name}: bad count {n}"))?,
                props: Vec::new(),
            }),
            ["property", "list", c, t, name] => {
                let e = elements.last_mut().ok_or("a property before any element")?;
                let c = Scalar::parse(c).ok_or(format!("unknown type {c}"))?;
                let ty = Scalar::parse(t).ok_or(format!("unknown type {t}"))?;
                e.props.push(Property {
                    name: name.to_string(),
                    list: Some(c),
                    ty,
                });
            }
            ["property", t, name] => {
                let e = elements.last_mut().ok_or("a property before any element")?;
                let ty = Scalar::parse(t).ok_or(format!("unknown type {t}"))?;
                e.props.push(Property {
                    name: name.to_string(),
                    list: None,
                    ty,
                });
            }
            ["comment", ..] | ["obj_info", ..] | [] => {}
            _ => return Err(format!("unreadable header line {line:?}")),
        }
    }
    Ok((enc.ok_or("no format line")?, elements, body))
}

fn read_ply(b: &[u8]) -> Result<Mesh, String> {
    let (enc, elements, start) = header(b)?;
    let text = if enc == Encoding::Ascii {
        std::str::from_utf8(&b[start..]).map_err(|_| "an ASCII body that is not text")?
    } else {
        ""
    };
    let mut body = Body {
        b,
        at: start,
        enc,
        tokens: text.split_ascii_whitespace(),
    };
    let mut m = Mesh::default();
    for e in &elements {
        // Each record takes at least one byte (binary) or one token of 2 bytes (ASCII): bound the
        // count by the bytes left before allocating from it.
        let min_record: usize = e
            .props
            .iter()
            .map(|p| p.list.map_or(p.ty.size(), Scalar::size))
            .sum::<usize>()
            .max(1);
        let min_record = if enc == Encoding::Ascii {
            2 * e.props.len().max(1)
        } else {
            min_record
        };
        if e.count > body.left() / min_record + 1 {
            return Err(format!(
                "element {} declares {} records but the file holds at most {}",
                e.name,
                e.count,
                body.left() / min_record
            ));
        }
        let is_vertex = e.name == "vertex";
        let is_face = e.name == "face";
        let xyz: Vec<Option<usize>> = ["x", "y", "z"]
            .iter()
            .map(|n| {
                e.props
                    .iter()
                    .position(|p| p.name == *n && p.list.is_none())
            })
            .collect();
        if is_vertex && xyz.iter().any(Option::is_none) {
            return Err("the vertex element needs x, y and z".into());
        }
        let modulation = e
            .props
            .iter()
            .position(|p| p.name == "modulation" && p.list.is_none())
            .filter(|_| is_vertex);
        let list_at = e.props.iter().position(|p| {
            p.list.is_some() && (p.name == "vertex_indices" || p.name == "vertex_index")
        });
        if is_vertex && enc != Encoding::Ascii {
            m.vertices.reserve(e.count);
        }
        let mut vals = vec![0.0; e.props.len()];
        let mut poly: Vec<u32> = Vec::new();
        for r in 0..e.count {
            for (k, p) in e.props.iter().enumerate() {
                match p.list {
                    None => vals[k] = body.read(p.ty)?,
                    Some(ct) => {
                        let n = body.read(ct)?;
                        if !(0.0..=1024.0).contains(&n) || n.fract() != 0.0 {
                            return Err(format!("{} {r}: a list of {n} items", e.name));
                        }
                        poly.clear();
                        for _ in 0..n as usize {
                            let v = body.read(p.ty)?;
                            if Some(k) == list_at {
                                if !(0.0..=f64::from(u32::MAX)).contains(&v) || v.fract() != 0.0 {
                                    return Err(format!("face {r}: vertex index {v}"));
                                }
                                poly.push(v as u32);
                            }
                        }
                    }
                }
            }
            if is_vertex {
                let g = |i: Option<usize>| i.map_or(0.0, |i| vals[i]);
                m.vertices.push([g(xyz[0]), g(xyz[1]), g(xyz[2])]);
                if let Some(k) = modulation {
                    m.modulation.push(vals[k]);
                }
            } else if is_face && list_at.is_some() {
                for i in 2..poly.len() {
                    m.triangles.push([poly[0], poly[i - 1], poly[i]]);
                }
            }
        }
    }
    Ok(m)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ply_encodings_and_stl_read_the_same_triangle() {
        let tri: [[f64; 3]; 3] = [[0.0, 0.0, 600.0], [10.0, 0.0, 600.0], [0.0, 10.0, 601.5]];
        let mut ascii = String::from(
            "ply\nformat ascii 1.0\ncomment x\nelement vertex 3\nproperty float x\nproperty float y\n\
             property float z\nproperty uchar red\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n",
        );
        for v in tri {
            ascii += &format!("{} {} {} 7\n", v[0], v[1], v[2]);
        }
        ascii += "3 0 1 2\n";
        let a = read_ply(ascii.as_bytes()).unwrap();
        for (enc, big) in [("binary_little_endian", false), ("binary_big_endian", true)] {
            let mut b = format!(
                "ply\nformat {enc} 1.0\nelement vertex 3\nproperty double x\nproperty double y\n\
                 property double z\nproperty uchar red\nelement face 1\nproperty list uchar uint vertex_indices\nend_header\n"
            )
            .into_bytes();
            for v in tri {
                for c in v {
                    b.extend(if big {
                        c.to_be_bytes()
                    } else {
                        c.to_le_bytes()
                    });
                }
                b.push(7);
            }
            b.push(3);
            for i in 0u32..3 {
                b.extend(if big {
                    i.to_be_bytes()
                } else {
                    i.to_le_bytes()
                });
            }
            assert_eq!(read_ply(&b).unwrap(), a, "{enc}");
        }
        let mut stl = vec![0u8; 80];
        stl.extend(1u32.to_le_bytes());
        stl.extend([0u8; 12]);
        for v in tri {
            for c in v {
                stl.extend((c as f32).to_le_bytes());
            }
        }
        stl.extend([0u8; 2]);
        assert!(is_binary_stl(&stl));
        assert_eq!(read_stl_binary(&stl), a);
        let text = format!(
            "solid t\nfacet normal 0 0 1\nouter loop\n{}endloop\nendfacet\nendsolid t\n",
            tri.iter()
                .map(|v| format!("vertex {} {} {}\n", v[0], v[1], v[2]))
                .collect::<String>()
        );
        assert_eq!(read_stl_ascii(text.as_bytes()).unwrap(), a);
    }

    #[test]
    fn a_scan_clouds_modulation_is_kept() {
        let b = b"ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\n\
                  property float z\nproperty float intensity\nproperty float modulation\nend_header\n\
                  1 2 600 50 31.5\nnan nan nan 0 0\n";
        let m = read_ply(b).unwrap();
        assert_eq!(m.modulation, vec![31.5, 0.0]);
        assert!(m.vertices[1][0].is_nan());
        let plain =
            b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n\
                      property float z\nend_header\n1 2 600\n";
        assert!(read_ply(plain).unwrap().modulation.is_empty());
    }

    #[test]
    fn a_count_past_the_data_is_refused_before_allocating() {
        let b =
            b"ply\nformat binary_little_endian 1.0\nelement vertex 4000000000\nproperty float x\n\
                  property float y\nproperty float z\nend_header\n\0\0\0\0";
        let e = read_ply(b).unwrap_err();
        assert!(e.contains("declares 4000000000"), "{e}");
        let short =
            b"ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\n\
                      property float z\nend_header\n1 2 3\n4 5\n";
        assert!(read_ply(short).unwrap_err().contains("ends early"));
    }
}
