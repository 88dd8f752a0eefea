//! Consistent Overhead Byte Stuffing (Cheshire & Baker, 1999).
//!
//! COBS rewrites a byte string so that it contains no `0x00`; a zero byte can then delimit frames
//! on a byte stream. The encoding is a sequence of blocks, each a *code* byte `c` (1..=255)
//! followed by `c - 1` non-zero data bytes. A block with `c < 255` stands for its data bytes
//! followed by one zero; a block with `c == 255` stands for its 254 data bytes alone. The zero
//! implied by the last block of a frame is not part of the data.
//!
//! [`encode`] produces the canonical encoding (the one in the paper and on Wikipedia: no empty
//! trailing block after a final 254-byte block). [`decode`] accepts any well-formed encoding.
//! Neither writes the `0x00` frame delimiter: the frame layer appends it.
//!
//! Overhead: at most `⌈n/254⌉` bytes for `n ≥ 1` input bytes, exactly 1 for the empty input;
//! [`max_encoded_len`] gives a bound.

use super::WireError;

/// An upper bound of the encoded length of `n` input bytes (without the delimiter).
pub const fn max_encoded_len(n: usize) -> usize {
    n + n / 254 + 1
}

/// COBS-encode `src` into `dst`, returning the encoded length (no delimiter is written).
///
/// The output contains no `0x00`. Fails with [`WireError::BufferTooSmall`] when `dst` cannot hold
/// the encoding; `dst.len() >= max_encoded_len(src.len())` always suffices.
pub fn encode(src: &[u8], dst: &mut [u8]) -> Result<usize, WireError> {
    // Index of the pending code byte in `dst`, and its current value (1 + data bytes so far).
    let mut code_at = 0usize;
    let mut code: u8 = 1;
    let mut out = 1usize;
    if dst.is_empty() {
        return Err(WireError::BufferTooSmall);
    }
    let last = src.len();
    for (i, &b) in src.iter().enumerate() {
        if b == 0 {
            *dst.get_mut(code_at).ok_or(WireError::BufferTooSmall)? = code;
            code_at = out;
            out += 1;
            code = 1;
            if code_at >= dst.len() {
                return Err(WireError::BufferTooSmall);
            }
        } else {
            *dst.get_mut(out).ok_or(WireError::BufferTooSmall)? = b;
            out += 1;
            code += 1;
            // A full block (254 data bytes) ends without an implied zero. Open a new block only
            // if more input follows: the canonical encoding has no empty trailing block.
            if code == 0xFF && i + 1 != last {
                *dst.get_mut(code_at).ok_or(WireError::BufferTooSmall)? = code;
                code_at = out;
                out += 1;
                code = 1;
                if code_at >= dst.len() {
                    return Err(WireError::BufferTooSmall);
                }
            }
        }
    }
    *dst.get_mut(code_at).ok_or(WireError::BufferTooSmall)? = code;
    Ok(out)
}

/// Decode the COBS encoding `src` (without its delimiter) into `dst`, returning the decoded
/// length.
///
/// Fails with [`WireError::Cobs`] if `src` is empty, contains a `0x00`, or a code byte points past
/// the end; with [`WireError::BufferTooSmall`] if `dst` is too short (`src.len()` always
/// suffices).
pub fn decode(src: &[u8], dst: &mut [u8]) -> Result<usize, WireError> {
    if src.is_empty() {
        return Err(WireError::Cobs);
    }
    let mut r = 0usize;
    let mut w = 0usize;
    while r < src.len() {
        let code = src[r] as usize;
        if code == 0 {
            return Err(WireError::Cobs);
        }
        let data = src.get(r + 1..r + code).ok_or(WireError::Cobs)?;
        if data.contains(&0) {
            return Err(WireError::Cobs);
        }
        dst.get_mut(w..w + data.len())
            .ok_or(WireError::BufferTooSmall)?
            .copy_from_slice(data);
        w += data.len();
        r += code;
        if code != 0xFF && r < src.len() {
            *dst.get_mut(w).ok_or(WireError::BufferTooSmall)? = 0;
            w += 1;
        }
    }
    Ok(w)
}

/// Decode a COBS encoding in place: `buf` holds the encoding (without delimiter) on entry and
/// the decoded bytes, at its start, on success. Returns the decoded length.
///
/// Decoding never writes ahead of where it reads, so no second buffer is needed. Errors as
/// [`decode`] ([`WireError::Cobs`]); on error the content of `buf` is unspecified.
pub fn decode_in_place(buf: &mut [u8]) -> Result<usize, WireError> {
    let len = buf.len();
    if len == 0 {
        return Err(WireError::Cobs);
    }
    let mut r = 0usize;
    let mut w = 0usize;
    while r < len {
        let code = buf[r] as usize;
        if code == 0 {
            return Err(WireError::Cobs);
        }
        let end = r + code;
        if end > len {
            return Err(WireError::Cobs);
        }
        if buf[r + 1..end].contains(&0) {
            return Err(WireError::Cobs);
        }
        // Invariant: w <= r, so the copy moves data backwards (or not at all).
        buf.copy_within(r + 1..end, w);
        w += code - 1;
        r = end;
        if code != 0xFF && r < len {
            // w < r here (w <= old r, and r grew by code while w grew by code - 1).
            buf[w] = 0;
            w += 1;
        }
    }
    Ok(w)
}
