//! Frames: header + payload + CRC-32C, COBS-encoded and delimited by `0x00`.
//!
//! A *decoded frame* is
//!
//! | offset        | size          | field                                          |
//! |--------------:|--------------:|------------------------------------------------|
//! | 0             | 6             | [`Header`]                                     |
//! | 6             | `payload_len` | payload                                        |
//! | 6+payload_len | 4             | CRC-32C of bytes `0 .. 6+payload_len`, LE u32  |
//!
//! On the line it is COBS-encoded ([`super::cobs`]) and followed by one `0x00`. A receiver
//! collects bytes up to each `0x00` ([`FrameReceiver`]), decodes them, checks the length and CRC,
//! then parses the header ([`parse`]). Empty frames (two `0x00` in a row) are ignored, so a sender
//! may send a lone `0x00` to make the receiver drop a partial frame (after a reconnect).

use super::cobs;
use super::crc::crc32c;
use super::header::{HEADER_LEN, Header};
use super::{MAX_PAYLOAD, WireError};

/// Length of the CRC trailer.
pub const CRC_LEN: usize = 4;
/// The shortest decoded frame: header and CRC, empty payload.
pub const MIN_FRAME: usize = HEADER_LEN + CRC_LEN;
/// The longest decoded frame: header, [`MAX_PAYLOAD`] payload bytes, CRC.
pub const MAX_FRAME: usize = HEADER_LEN + MAX_PAYLOAD + CRC_LEN;
/// The longest frame on the line: COBS-encoded [`MAX_FRAME`] plus the `0x00` delimiter. A
/// buffer of this size holds any frame, encoded or decoded.
pub const MAX_ENCODED_FRAME: usize = cobs::max_encoded_len(MAX_FRAME) + 1;

/// Write a decoded frame (header, payload, CRC) into `out`; returns its length.
///
/// `header.payload_len` is ignored and replaced by `payload.len()`. Fails with
/// [`WireError::PayloadTooLarge`] if `payload.len() > MAX_PAYLOAD`, with
/// [`WireError::BufferTooSmall`] if `out` is shorter than `payload.len() + MIN_FRAME`.
pub fn emit(header: &Header, payload: &[u8], out: &mut [u8]) -> Result<usize, WireError> {
    if payload.len() > MAX_PAYLOAD {
        return Err(WireError::PayloadTooLarge);
    }
    let total = payload.len() + MIN_FRAME;
    let out = out.get_mut(..total).ok_or(WireError::BufferTooSmall)?;
    let h = Header {
        payload_len: payload.len() as u16,
        ..*header
    };
    h.emit(out)?;
    let body_end = HEADER_LEN + payload.len();
    out[HEADER_LEN..body_end].copy_from_slice(payload);
    let crc = crc32c(&out[..body_end]);
    out[body_end..].copy_from_slice(&crc.to_le_bytes());
    Ok(total)
}

/// Check the length and CRC of a decoded frame, without looking at the header.
///
/// [`WireError::Truncated`] if shorter than [`MIN_FRAME`], [`WireError::Crc`] on a mismatch.
pub fn check_crc(frame: &[u8]) -> Result<(), WireError> {
    if frame.len() < MIN_FRAME {
        return Err(WireError::Truncated);
    }
    let (body, tail) = frame.split_at(frame.len() - CRC_LEN);
    let got = u32::from_le_bytes([tail[0], tail[1], tail[2], tail[3]]);
    if crc32c(body) == got {
        Ok(())
    } else {
        Err(WireError::Crc)
    }
}

/// Parse a decoded frame: returns the header and the payload.
///
/// Checks, in order: minimum length ([`WireError::Truncated`]), CRC ([`WireError::Crc`]), the
/// header ([`Header::parse`]: version, reserved flags, length bound) and that the header's length
/// equals the payload's ([`WireError::Length`]).
pub fn parse(frame: &[u8]) -> Result<(Header, &[u8]), WireError> {
    check_crc(frame)?;
    let header = Header::parse(frame)?;
    let payload = &frame[HEADER_LEN..frame.len() - CRC_LEN];
    if payload.len() != header.payload_len as usize {
        return Err(WireError::Length);
    }
    Ok((header, payload))
}

/// COBS-encode a decoded frame into `out` and append the `0x00` delimiter; returns the number of
/// bytes to put on the line.
pub fn encode(frame: &[u8], out: &mut [u8]) -> Result<usize, WireError> {
    let n = cobs::encode(frame, out)?;
    *out.get_mut(n).ok_or(WireError::BufferTooSmall)? = 0;
    Ok(n + 1)
}

/// Counters kept by a [`FrameReceiver`]. All wrap on overflow.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ReceiverStats {
    /// Bytes received (including delimiters).
    pub bytes: u32,
    /// Frames delivered (COBS and CRC good).
    pub frames: u32,
    /// Frames dropped for malformed COBS.
    pub cobs_errors: u32,
    /// Frames dropped for a CRC mismatch.
    pub crc_errors: u32,
    /// Frames dropped for being shorter than [`MIN_FRAME`].
    pub runts: u32,
    /// Frames dropped for being longer than the receiver's buffer.
    pub overflows: u32,
}

impl ReceiverStats {
    /// Total frames dropped for any reason.
    pub const fn errors(&self) -> u32 {
        self.cobs_errors
            .wrapping_add(self.crc_errors)
            .wrapping_add(self.runts)
            .wrapping_add(self.overflows)
    }
}

/// Streaming frame receiver: accepts line bytes one at a time or in chunks, yields each complete,
/// CRC-checked decoded frame.
///
/// Every run of bytes ended by a `0x00` yields exactly one event: the decoded frame, or the error
/// that made it unusable ([`WireError::Cobs`], [`WireError::Truncated`], [`WireError::Crc`],
/// [`WireError::Overflow`]); empty runs yield nothing. After an error the receiver is synchronised
/// again at the next `0x00`. The frame slice borrows the receiver's buffer, so it must be consumed
/// (e.g. with [`parse_packet`](super::parse_packet)) before more bytes are pushed.
///
/// The buffer `B` is anything that derefs to a byte slice, owned (`[u8; MAX_ENCODED_FRAME]`, for a
/// `static`) or borrowed (`&mut [u8]`); frames longer than it are dropped as overflows. Use at
/// least [`MAX_ENCODED_FRAME`] bytes to receive every legal frame.
#[derive(Debug)]
pub struct FrameReceiver<B> {
    buf: B,
    len: usize,
    discarding: bool,
    stats: ReceiverStats,
}

impl<B: AsRef<[u8]> + AsMut<[u8]>> FrameReceiver<B> {
    /// A receiver collecting into `buf`.
    pub const fn new(buf: B) -> Self {
        FrameReceiver {
            buf,
            len: 0,
            discarding: false,
            stats: ReceiverStats {
                bytes: 0,
                frames: 0,
                cobs_errors: 0,
                crc_errors: 0,
                runts: 0,
                overflows: 0,
            },
        }
    }

    /// The counters so far.
    pub const fn stats(&self) -> &ReceiverStats {
        &self.stats
    }

    /// Bytes of the frame being collected (0 between frames or while discarding).
    pub const fn pending(&self) -> usize {
        self.len
    }

    /// Drop the partial frame, if any (the counters are kept).
    pub fn reset(&mut self) {
        self.len = 0;
        self.discarding = false;
    }

    /// Give back the buffer.
    pub fn into_inner(self) -> B {
        self.buf
    }

    /// Accept one byte. Returns `Some` when the byte was a delimiter ending a non-empty frame.
    pub fn push(&mut self, byte: u8) -> Option<Result<&[u8], WireError>> {
        match self.step(byte) {
            None => None,
            Some(Ok(n)) => Some(Ok(&self.buf.as_ref()[..n])),
            Some(Err(e)) => Some(Err(e)),
        }
    }

    /// Accept bytes from `input` up to and including the first delimiter that ends a non-empty
    /// frame. Returns how many bytes were consumed and the event, if any; call again with the rest
    /// of `input`.
    ///
    /// ```
    /// # use fringe3d_core::wire::{FrameReceiver, MAX_ENCODED_FRAME};
    /// let mut dec = FrameReceiver::new([0u8; MAX_ENCODED_FRAME]);
    /// let mut input: &[u8] = &[0x03, 0x11, 0x22, 0x00];
    /// while !input.is_empty() {
    ///     let (used, event) = dec.feed(input);
    ///     if let Some(e) = event {
    ///         assert!(e.is_err()); // far too short for a frame
    ///     }
    ///     input = &input[used..];
    /// }
    /// ```
    pub fn feed(&mut self, input: &[u8]) -> (usize, Option<Result<&[u8], WireError>>) {
        let mut event = None;
        let mut used = 0;
        for &b in input {
            used += 1;
            if let Some(e) = self.step(b) {
                event = Some(e);
                break;
            }
        }
        let event = event.map(|r| r.map(|n| &self.buf.as_ref()[..n]));
        (used, event)
    }

    /// One byte; on a frame, its decoded length (the frame is at the start of the buffer).
    fn step(&mut self, byte: u8) -> Option<Result<usize, WireError>> {
        self.stats.bytes = self.stats.bytes.wrapping_add(1);
        if byte != 0 {
            if self.discarding {
                return None;
            }
            let buf = self.buf.as_mut();
            match buf.get_mut(self.len) {
                Some(slot) => {
                    *slot = byte;
                    self.len += 1;
                }
                None => {
                    self.discarding = true;
                    self.len = 0;
                }
            }
            return None;
        }
        // Delimiter.
        if self.discarding {
            self.discarding = false;
            self.stats.overflows = self.stats.overflows.wrapping_add(1);
            return Some(Err(WireError::Overflow));
        }
        let n = self.len;
        self.len = 0;
        if n == 0 {
            return None;
        }
        let res = self
            .buf
            .as_mut()
            .get_mut(..n)
            .ok_or(WireError::Overflow)
            .and_then(cobs::decode_in_place)
            .and_then(|m| {
                check_crc(&self.buf.as_ref()[..m])?;
                Ok(m)
            });
        let s = &mut self.stats;
        match res {
            Ok(_) => s.frames = s.frames.wrapping_add(1),
            Err(WireError::Truncated) => s.runts = s.runts.wrapping_add(1),
            Err(WireError::Crc) => s.crc_errors = s.crc_errors.wrapping_add(1),
            Err(WireError::Overflow) => s.overflows = s.overflows.wrapping_add(1),
            Err(_) => s.cobs_errors = s.cobs_errors.wrapping_add(1),
        }
        Some(res)
    }
}
