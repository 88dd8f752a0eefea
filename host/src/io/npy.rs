//! A minimal NumPy `.npy` (format 1.0) writer and reader for little-endian f64/f32 arrays.

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

/// Read a little-endian f64 `.npy` (C order): (shape, data). For tests and tools.
pub fn decode_f64(bytes: &[u8]) -> Result<(Vec<usize>, Vec<f64>), String> {
    if bytes.len() < 10 || &bytes[..6] != b"\x93NUMPY" {
        return Err("not a .npy file".into());
    }
    let (hl, start) = match bytes[6] {
        1 => (u16::from_le_bytes([bytes[8], bytes[9]]) as usize, 10),
        2 | 3 if bytes.len() >= 12 => (
            u32::from_le_bytes([bytes[8], bytes[9], bytes[10], bytes[11]]) as usize,
            12,
        ),
        v => return Err(format!("unsupported .npy version {v}")),
    };
    let header = std::str::from_utf8(bytes.get(start..start + hl).ok_or("truncated header")?)
        .map_err(|_| "header is not text")?;
    if !header.contains("'descr': '<f8'") || header.contains("'fortran_order': True") {
        return Err("only little-endian f64 in C order is read".into());
    }
    let s = header.find("'shape': (").ok_or("no shape")? + 10;
    let e = header[s..].find(')').ok_or("bad shape")? + s;
    let shape: Vec<usize> = header[s..e]
        .split(',')
        .map(str::trim)
        .filter(|t| !t.is_empty())
        .map(|t| t.parse::<usize>().map_err(|_| "bad shape".to_string()))
        .collect::<Result<_, _>>()?;
    // A shape whose size overflows cannot fit the file (checked: no overflow panic).
    let bytes_needed = shape
        .iter()
        .try_fold(8usize, |a, &d| a.checked_mul(d))
        .ok_or("the shape's size overflows")?;
    let body = &bytes[start + hl..];
    if body.len() < bytes_needed {
        return Err("truncated data".into());
    }
    let data = body[..bytes_needed]
        .chunks_exact(8)
        .map(|c| f64::from_le_bytes(c.try_into().unwrap_or([0; 8])))
        .collect();
    Ok((shape, data))
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
