//! The link budget at 921600 baud, from the bytes the real emitters put on the line: an upload of
//! an 8-pattern 1024 × 768 set and the stream of a 1280 × 1024 point cloud. Printed for
//! docs/performance.md, and bounded here so that a change in framing shows.
//!
//! Payloads are worst case for COBS (no zero bytes: one extra byte per 254), so the figures are
//! upper bounds; real patterns and points contain zeros and come out slightly smaller.

use fringe3d_core::wire::crc::crc32c;
use fringe3d_core::wire::{
    Ack, Header, MAX_CHUNK, MAX_ENCODED_FRAME, MAX_FRAME, MAX_ROW_DATA, Message, Packet, ResultRow,
    RowKind, ScanDone, UploadAck, UploadChunk, UploadTarget, emit_packet,
};

/// 8N1: ten bits per byte.
const BYTES_PER_S: f64 = 921_600.0 / 10.0;

fn line_bytes(h: &Header, m: &Message<'_>) -> u64 {
    let mut s = vec![0u8; MAX_FRAME];
    let mut o = vec![0u8; MAX_ENCODED_FRAME];
    emit_packet(h, m, &mut s, &mut o).unwrap() as u64
}

#[test]
fn link_budget_at_921600_baud() {
    // Upload: 8 × 1024 × 768 bytes in MAX_CHUNK chunks, each answered by an UploadAck.
    let total = 8 * 1024 * 768usize;
    let data = vec![0x5Au8; MAX_CHUNK];
    let (mut up, mut down, mut chunks) = (0u64, 0u64, 0u64);
    let mut off = 0usize;
    while off < total {
        let n = MAX_CHUNK.min(total - off);
        // A CRC of 5 varint bytes, as most CRCs take.
        let mut c = UploadChunk::new(UploadTarget::PatternSet(0), off as u32, &data[..n]);
        c.crc = crc32c(&data[..n]) | 0xF000_0000;
        let m = Message::UploadChunk(c);
        let p = Packet::request(7, m);
        // `emit_packet` validates the chunk CRC: emit with the true CRC, count the worst-case
        // varint (5 bytes) by hand.
        let m_ok = Message::UploadChunk(UploadChunk::new(
            UploadTarget::PatternSet(0),
            off as u32,
            &data[..n],
        ));
        let b = line_bytes(&p.header, &m_ok);
        let crc_len = {
            let mut v = crc32c(&data[..n]);
            let mut k = 1;
            while v >= 0x80 {
                v >>= 7;
                k += 1;
            }
            k
        };
        up += b + (5 - crc_len) as u64;
        let ack = Message::UploadAck(UploadAck {
            target: UploadTarget::PatternSet(0),
            next_offset: (off + n) as u32,
        });
        down += line_bytes(&Header::for_message(&ack, 7), &ack);
        chunks += 1;
        off += n;
    }
    let up_s = up as f64 / BYTES_PER_S;
    let raw_s = total as f64 / BYTES_PER_S;
    println!(
        "upload 8x1024x768: {total} data bytes in {chunks} chunks, {up} bytes on the line host->head ({:.2} % framing), \
         {down} bytes of acks head->host; {up_s:.1} s at 921600 baud (data alone {raw_s:.1} s)",
        100.0 * (up as f64 / total as f64 - 1.0)
    );
    assert_eq!(chunks, 1549);
    assert!(
        up < total as u64 * 1012 / 1000,
        "framing overhead above 1.2 %"
    );

    // Points: 1280 × 1024, x y z f32 + a validity byte per pixel, rows cut into segments.
    let (w, h) = (1280usize, 1024usize);
    let stride = RowKind::Points.stride();
    let per = MAX_ROW_DATA / stride;
    let seg = vec![0x41u8; per * stride];
    let mut stream = 0u64;
    let ack = Message::Ack(Ack { command: 0x30 });
    stream += line_bytes(&Header::for_message(&ack, 9), &ack);
    for row in 0..h {
        let mut c0 = 0;
        while c0 < w {
            let n = per.min(w - c0);
            let data = &seg[..n * stride];
            // Validity bytes must be codes: 0 (valid) is a zero byte; the worst case for COBS is
            // no zeros, so count the frame with code 1 and treat it as non-zero.
            let mut d = data.to_vec();
            for b in &mut d[n * 12..] {
                *b = 1;
            }
            // The longest scan id (a 5-byte varint).
            let m = Message::ResultRow(ResultRow {
                scan_id: u32::MAX,
                row: row as u16,
                first_col: c0 as u16,
                kind: RowKind::Points,
                data: &d,
            });
            stream += line_bytes(&Header::for_message(&m, 9), &m);
            c0 += n;
        }
    }
    let done = Message::ScanDone(ScanDone {
        scan_id: u32::MAX,
        rows: h as u16,
        valid: (w * h) as u32,
        decoded: (w * h) as u32,
        searched: (w * h) as u32,
    });
    stream += line_bytes(&Header::for_message(&done, 9), &done);
    let payload = (w * h * stride) as u64;
    let s = stream as f64 / BYTES_PER_S;
    println!(
        "points 1280x1024: {payload} data bytes, {stream} bytes on the line ({:.2} % framing); {s:.1} s at 921600 baud (data alone {:.1} s)",
        100.0 * (stream as f64 / payload as f64 - 1.0),
        payload as f64 / BYTES_PER_S
    );
    assert!(stream < payload * 1012 / 1000);
}
