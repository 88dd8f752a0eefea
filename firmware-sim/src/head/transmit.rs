//! The transmit side: replies and Naks as frames, result rows in segments.

use embedded_io::Write;
use fringe3d_core::math::CANONICAL_NAN;
use fringe3d_core::validity::Validity;
use fringe3d_core::wire::{
    Flags, Header, MAX_ENCODED_FRAME, MAX_FRAME, MAX_ROW_DATA, Message, Nak, NakCode, ResultRow,
    RowKind, WireError, emit_packet,
};

use super::error::{LinkError, io_err};

/// Which scan's stream a row belongs to: the Scan's `seq` and its `scan_id`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) struct Stream {
    /// The Scan request's sequence number (every frame of the answer echoes it).
    pub(super) seq: u8,
    /// The Scan request's identity (every row and the ScanDone carry it).
    pub(super) scan_id: u32,
}

/// The transmit side: frame buffers and a counter.
pub(super) struct Tx {
    scratch: [u8; MAX_FRAME],
    out: [u8; MAX_ENCODED_FRAME],
    row: [u8; MAX_ROW_DATA],
    pub(super) frames: u32,
}

impl Tx {
    /// Empty buffers, no frame sent yet.
    pub(super) fn new() -> Tx {
        Tx {
            scratch: [0; MAX_FRAME],
            out: [0; MAX_ENCODED_FRAME],
            row: [0; MAX_ROW_DATA],
            frames: 0,
        }
    }

    pub(super) fn send<T: Write>(
        &mut self,
        io: &mut T,
        header: &Header,
        msg: &Message<'_>,
    ) -> Result<(), LinkError> {
        let n =
            emit_packet(header, msg, &mut self.scratch, &mut self.out).map_err(LinkError::Wire)?;
        io.write_all(&self.out[..n]).map_err(io_err)?;
        self.frames = self.frames.wrapping_add(1);
        Ok(())
    }

    pub(super) fn reply<T: Write>(
        &mut self,
        io: &mut T,
        seq: u8,
        msg: Message<'_>,
        more: bool,
    ) -> Result<(), LinkError> {
        let mut h = Header::for_message(&msg, seq);
        h.flags = h.flags.with(Flags::MORE_FOLLOWS, more);
        self.send(io, &h, &msg)
    }

    pub(super) fn nak<T: Write>(
        &mut self,
        io: &mut T,
        seq: u8,
        command: u8,
        code: NakCode,
        detail: u16,
    ) -> Result<(), LinkError> {
        self.reply(
            io,
            seq,
            Message::Nak(Nak {
                command,
                code,
                detail,
            }),
            false,
        )
    }

    /// Stream one result row as segments of at most [`MAX_ROW_DATA`] bytes.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn rows<T: Write>(
        &mut self,
        io: &mut T,
        stream: Stream,
        row: u16,
        kind: RowKind,
        values: &[f32],
        validity: &[u8],
        before_filter: Option<&[u8]>,
    ) -> Result<(), LinkError> {
        let k = kind.components();
        let stride = kind.stride();
        let per = MAX_ROW_DATA / stride;
        let n = validity.len();
        let mut c0 = 0;
        while c0 < n {
            let c1 = (c0 + per).min(n);
            let m = c1 - c0;
            let vals = values
                .get(c0 * k..c1 * k)
                .ok_or(LinkError::Wire(WireError::BufferTooSmall))?;
            for (j, (v, dst)) in vals.iter().zip(self.row.chunks_exact_mut(4)).enumerate() {
                // Points the edge filter flagged (valid before, a depth or light edge now) go as
                // canonical NaN, like every invalid point.
                let c = c0 + j / k;
                let flagged = before_filter.is_some_and(|b| {
                    validity.get(c).is_some_and(|v| *v != Validity::Valid as u8)
                        && b.get(c) == Some(&(Validity::Valid as u8))
                });
                let v = if flagged { CANONICAL_NAN } else { *v };
                dst.copy_from_slice(&v.to_le_bytes());
            }
            let codes = self
                .row
                .get_mut(4 * m * k..m * stride)
                .ok_or(LinkError::Wire(WireError::BufferTooSmall))?;
            codes.copy_from_slice(&validity[c0..c1]);
            let msg = Message::ResultRow(ResultRow {
                scan_id: stream.scan_id,
                row,
                first_col: c0 as u16,
                kind,
                data: &self.row[..m * stride],
            });
            let mut h = Header::for_message(&msg, stream.seq);
            h.flags = h.flags.with(Flags::MORE_FOLLOWS, true);
            let len =
                emit_packet(&h, &msg, &mut self.scratch, &mut self.out).map_err(LinkError::Wire)?;
            io.write_all(&self.out[..len]).map_err(io_err)?;
            self.frames = self.frames.wrapping_add(1);
            c0 = c1;
        }
        Ok(())
    }
}
