//! A minimal NumPy `.npy` writer (format 1.0, little-endian f64/f32 arrays), a header parser
//! (formats 1.0 to 3.0; camera frames are read from it by `io::image`) and an f64 reader.

/// Element types written here.
pub trait NpyElem: Copy {
    /// NumPy dtype string.
    const DESCR: &'static str;
    /// Append the little-endian bytes.
    fn put(self, out: &mut Vec<u8>);
}

impl NpyElem for f64 {
    const DESCR: &'static str = "<f8";
    fn put(self, out: &mut Vec<u8>) {
        out.extend_from_slice(&self.to_le_bytes());
    }
}

impl NpyElem for f32 {
    const DESCR: &'static str = "<f4";
    fn put(self, out: &mut Vec<u8>) {
        out.extend_from_slice(&self.to_le_bytes());
    }
}

/// The bytes of a C-order `.npy` file of `shape` holding `data` (length = product of shape).
pub fn encode<T: NpyElem>(shape: &[usize], data: &[T]) -> Vec<u8> {
    debug_assert_eq!(shape.iter().product::<usize>(), data.len());
    let dims: Vec<String> = shape.iter().map(|d| d.to_string()).collect();
    let shape_s = if dims.len() == 1 {
        format!("({},)", dims[0])
    } else {
        format!("({})", dims.join(", "))
    };
    let mut header = format!(
        "{{'descr': '{}', 'fortran_order': False, 'shape': {}, }}",
        T::DESCR,
        shape_s
    );
    // Magic (6) + version (2) + length (2) + header + '\n' must be a multiple of 64.
    let total = 10 + header.len() + 1;
    header.push_str(&" ".repeat((64 - total % 64) % 64));
    header.push('\n');
    let mut out = Vec::with_capacity(10 + header.len() + std::mem::size_of_val(data));
    out.extend_from_slice(b"\x93NUMPY\x01\x00");
    out.extend_from_slice(&(header.len() as u16).to_le_bytes());
    out.extend_from_slice(header.as_bytes());
    for &v in data {
        v.put(&mut out);
    }
    out
}

/// The longest `.npy` header read, bytes: numpy writes 128 or so; a file claiming more is not one
/// of ours or a camera's, and its "header" must not be scanned through.
pub const MAX_HEADER: usize = 65536;

/// A `.npy` header (format 1.0, 2.0 or 3.0), parsed.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Header {
    /// The dtype string, e.g. `<f8`, `|u1`, `<u2`.
    pub descr: String,
    /// Column-major data (`fortran_order: True`).
    pub fortran_order: bool,
    /// The array's shape.
    pub shape: Vec<usize>,
    /// Offset of the data in the file.
    pub data: usize,
}

/// The value text after `'key':` (either quote style) in a header dict.
fn value_of<'a>(dict: &'a str, key: &str) -> Option<&'a str> {
    ["'", "\""].iter().find_map(|q| {
        let k = format!("{q}{key}{q}");
        let at = dict.find(&k)? + k.len();
        let rest = dict[at..].trim_start();
        Some(rest.strip_prefix(':')?.trim_start())
    })
}

/// How many bytes of a `.npy` file hold its header, from its first 12 (or fewer: then 12), at most
/// `12 + MAX_HEADER`: what a header-only reader must read.
pub fn header_span(first: &[u8]) -> usize {
    let len = match (first.get(6), first.get(8..12)) {
        (Some(1), Some(b)) => 10 + u16::from_le_bytes([b[0], b[1]]) as usize,
        (Some(2 | 3), Some(b)) => 12 + u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as usize,
        _ => 12,
    };
    len.min(12 + MAX_HEADER)
}

/// Parse the header of a `.npy` file from its first bytes (at least the whole header).
pub fn parse_header(bytes: &[u8]) -> Result<Header, String> {
    if bytes.len() < 10 || &bytes[..6] != b"\x93NUMPY" {
        return Err("not a .npy file (no \\x93NUMPY magic)".into());
    }
    let (hl, start) = match bytes[6] {
        1 => (u16::from_le_bytes([bytes[8], bytes[9]]) as usize, 10),
        2 | 3 if bytes.len() >= 12 => (
            u32::from_le_bytes([bytes[8], bytes[9], bytes[10], bytes[11]]) as usize,
            12,
        ),
        v => return Err(format!("unsupported .npy version {v}")),
    };
    if hl > MAX_HEADER {
        return Err(format!("header of {hl} bytes, more than {MAX_HEADER}"));
    }
    let dict = std::str::from_utf8(bytes.get(start..start + hl).ok_or("truncated header")?)
        .map_err(|_| "header is not text")?;
    let descr = value_of(dict, "descr")
        .and_then(|v| {
            let q = v.chars().next().filter(|c| *c == '\'' || *c == '"')?;
            let v = &v[1..];
            v.find(q).map(|e| v[..e].to_string())
        })
        .ok_or("no 'descr' string in the header")?;
    let fortran_order = match value_of(dict, "fortran_order") {
        Some(v) if v.starts_with("False") => false,
        Some(v) if v.starts_with("True") => true,
        _ => return Err("no 'fortran_order' True/False in the header".into()),
    };
    let shape_text = value_of(dict, "shape")
        .and_then(|v| v.strip_prefix('('))
        .and_then(|v| v.find(')').map(|e| &v[..e]))
        .ok_or("no 'shape' tuple in the header")?;
    let shape: Vec<usize> = shape_text
        .split(',')
        .map(str::trim)
        .filter(|t| !t.is_empty())
        .map(|t| {
            t.parse::<usize>()
                .map_err(|_| format!("bad shape ({shape_text})"))
        })
        .collect::<Result<_, _>>()?;
    Ok(Header {
        descr,
        fortran_order,
        shape,
        data: start + hl,
    })
}

/// Read a little-endian f64 `.npy` (C order): (shape, data). For tests and tools.
pub fn decode_f64(bytes: &[u8]) -> Result<(Vec<usize>, Vec<f64>), String> {
    let h = parse_header(bytes)?;
    if h.descr != "<f8" || h.fortran_order {
        return Err("only little-endian f64 in C order is read".into());
    }
    // A shape whose size overflows cannot fit the file (checked: no overflow panic).
    let bytes_needed = h
        .shape
        .iter()
        .try_fold(8usize, |a, &d| a.checked_mul(d))
        .ok_or("the shape's size overflows")?;
    let body = &bytes[h.data..];
    if body.len() < bytes_needed {
        return Err("truncated data".into());
    }
    let data = body[..bytes_needed]
        .chunks_exact(8)
        .map(|c| f64::from_le_bytes(c.try_into().unwrap_or([0; 8])))
        .collect();
    Ok((h.shape, data))
}

#[cfg(test)]
mod tests {
    #[test]
    fn roundtrip_and_alignment() {
        let d: Vec<f64> = (0..24).map(|i| i as f64 * 0.5).collect();
        let b = super::encode(&[2, 4, 3], &d);
        let hl = u16::from_le_bytes([b[8], b[9]]) as usize;
        assert_eq!((10 + hl) % 64, 0);
        let (s, back) = super::decode_f64(&b).unwrap();
        assert_eq!(s, vec![2, 4, 3]);
        assert_eq!(back, d);
    }
}
