//! The streaming frame decoder, the loopback and fault-injector test doubles, and thousands of
//! seeded fault-injected transfers.

use embedded_io::{Read, ReadReady, Write, WriteReady};
use fringe3d_core::Validity;
use fringe3d_core::wire::*;

/// Line bytes and decoded frame of a packet.
fn packet_bytes(seq: u8, msg: Message<'_>) -> (Vec<u8>, Vec<u8>) {
    let p = Packet::request(seq, msg);
    let mut scratch = vec![0u8; MAX_FRAME];
    let mut out = vec![0u8; MAX_ENCODED_FRAME];
    let n = p.emit(&mut scratch, &mut out).unwrap();
    let line = out[..n].to_vec();
    let mut frame = vec![0u8; n];
    let m = cobs::decode(&line[..n - 1], &mut frame).unwrap();
    frame.truncate(m);
    (line, frame)
}

fn status_packet(seq: u8) -> (Vec<u8>, Vec<u8>) {
    // Replies are fine to stream too; use a request so Packet::request applies.
    packet_bytes(seq, Message::GetStatus)
}

fn chunk_packet(seq: u8, data: &[u8]) -> (Vec<u8>, Vec<u8>) {
    packet_bytes(
        seq,
        Message::UploadChunk(UploadChunk::new(
            UploadTarget::PatternSet(1),
            seq as u32 * 1000,
            data,
        )),
    )
}

/// Feed `input` to a decoder in pieces of `step` bytes; collect frames and errors.
fn run_decoder<B: AsRef<[u8]> + AsMut<[u8]>>(
    dec: &mut FrameReceiver<B>,
    input: &[u8],
    step: usize,
) -> (Vec<Vec<u8>>, Vec<WireError>) {
    let mut frames = Vec::new();
    let mut errors = Vec::new();
    for piece in input.chunks(step.max(1)) {
        let mut rest = piece;
        while !rest.is_empty() {
            let (used, ev) = dec.feed(rest);
            assert!(used >= 1 && used <= rest.len());
            match ev {
                Some(Ok(f)) => frames.push(f.to_vec()),
                Some(Err(e)) => errors.push(e),
                None => assert_eq!(used, rest.len()),
            }
            rest = &rest[used..];
        }
    }
    (frames, errors)
}

#[test]
fn byte_by_byte_and_in_chunks() {
    let data: Vec<u8> = (0..700u32).map(|i| (i % 5) as u8 * 60).collect();
    let packets = [
        status_packet(1),
        chunk_packet(2, &data),
        chunk_packet(3, &data[..1]),
        status_packet(4),
    ];
    let line: Vec<u8> = packets.iter().flat_map(|p| p.0.clone()).collect();
    let expect: Vec<Vec<u8>> = packets.iter().map(|p| p.1.clone()).collect();

    // Byte by byte with push.
    let mut dec = FrameReceiver::new([0u8; MAX_ENCODED_FRAME]);
    let mut frames = Vec::new();
    for &b in &line {
        if let Some(ev) = dec.push(b) {
            frames.push(ev.unwrap().to_vec());
        }
    }
    assert_eq!(frames, expect);
    assert_eq!(dec.stats().frames, 4);
    assert_eq!(dec.stats().errors(), 0);
    assert_eq!(dec.stats().bytes as usize, line.len());

    // In chunks of various sizes with feed.
    for step in [1, 2, 3, 7, 64, 255, 1000, line.len()] {
        let mut buf = vec![0u8; MAX_ENCODED_FRAME];
        let mut dec = FrameReceiver::new(&mut buf[..]);
        let (frames, errors) = run_decoder(&mut dec, &line, step);
        assert_eq!(frames, expect, "step {step}");
        assert!(errors.is_empty());
    }

    // The frames parse back to the messages.
    for f in &frames {
        parse_packet(f).unwrap();
    }
    let (_, m) = parse_packet(&frames[1]).unwrap();
    match m {
        Message::UploadChunk(c) => assert_eq!(c.data, &data[..]),
        other => panic!("{other:?}"),
    }
}

#[test]
fn garbage_is_skipped_and_counted() {
    let (good, frame) = status_packet(9);
    let mut line = Vec::new();
    // Leading garbage without a delimiter: joins the first frame's run, which then fails.
    line.extend([0x41, 0x42, 0x43]);
    line.extend(&good);
    // Garbage runs ended by delimiters.
    line.extend([0x02, 0x11, 0x00]); // decodes to 1 byte: runt
    line.extend([0x05, 0x11, 0x00]); // code past the end: COBS error
    line.extend([0xFF; 40]);
    line.push(0x00); // 40 bytes that decode fine but fail the CRC (or COBS)
    line.extend(&good);
    line.extend(&good);
    let mut dec = FrameReceiver::new([0u8; MAX_ENCODED_FRAME]);
    let (frames, errors) = run_decoder(&mut dec, &line, 1);
    assert_eq!(frames, vec![frame.clone(), frame]);
    assert_eq!(errors.len(), 4, "{errors:?}");
    let s = *dec.stats();
    assert_eq!(s.frames, 2);
    assert_eq!(s.errors(), 4);
    assert_eq!(s.runts, 1);
    assert!(s.cobs_errors >= 1);
    assert_eq!(s.cobs_errors + s.crc_errors, 3);
}

#[test]
fn empty_frames_are_ignored() {
    let (good, frame) = status_packet(3);
    let mut line = vec![0x00, 0x00, 0x00];
    line.extend(&good);
    line.extend([0x00, 0x00]);
    line.extend(&good);
    let mut dec = FrameReceiver::new([0u8; MAX_ENCODED_FRAME]);
    let (frames, errors) = run_decoder(&mut dec, &line, 5);
    assert_eq!(frames, vec![frame.clone(), frame]);
    assert!(errors.is_empty());
    assert_eq!(dec.stats().errors(), 0);
}

#[test]
fn runt_frame() {
    let mut dec = FrameReceiver::new([0u8; 64]);
    let (frames, errors) = run_decoder(&mut dec, &[0x03, 0x11, 0x22, 0x00], 1);
    assert!(frames.is_empty());
    assert_eq!(errors, vec![WireError::Truncated]);
    assert_eq!(dec.stats().runts, 1);
}

#[test]
fn oversized_frame_overflows_then_resyncs() {
    let (good, frame) = status_packet(5);
    let mut line = vec![0x7E; 5000];
    line.push(0x00);
    line.extend(&good);
    let mut dec = FrameReceiver::new([0u8; MAX_ENCODED_FRAME]);
    let (frames, errors) = run_decoder(&mut dec, &line, 333);
    assert_eq!(errors, vec![WireError::Overflow]);
    assert_eq!(frames, vec![frame.clone()]);
    assert_eq!(dec.stats().overflows, 1);

    // A small receive buffer: a legal but long frame overflows it, the short one after it passes.
    let (long, _) = chunk_packet(6, &[0x55; 100]);
    let mut line = long.clone();
    line.extend(&good);
    let mut buf = [0u8; 32];
    let mut dec = FrameReceiver::new(&mut buf[..]);
    assert_eq!(dec.pending(), 0);
    let (frames, errors) = run_decoder(&mut dec, &line, 1);
    assert_eq!(errors, vec![WireError::Overflow]);
    assert_eq!(frames, vec![frame]);
    // Exactly filling the buffer is fine.
    let mut buf = vec![0u8; good.len() - 1];
    let mut dec = FrameReceiver::new(&mut buf[..]);
    let (frames, errors) = run_decoder(&mut dec, &good, 1);
    assert_eq!((frames.len(), errors.len()), (1, 0));
}

#[test]
fn corrupted_byte_reports_crc_and_next_frame_decodes() {
    let (good1, _) = status_packet(1);
    let (good2, frame2) = status_packet(2);
    // 05 01 02 07 32 01 05 92 A4 B1 0F 00: byte 2 is the flags, a data byte inside a block.
    for (pos, val) in [(2, 0x03), (3, 0x08), (7, 0x93), (10, 0x1F)] {
        let mut bad = good1.clone();
        bad[pos] = val;
        let mut line = bad;
        line.extend(&good2);
        let mut dec = FrameReceiver::new([0u8; MAX_ENCODED_FRAME]);
        let (frames, errors) = run_decoder(&mut dec, &line, 1);
        assert_eq!(errors, vec![WireError::Crc], "pos {pos}");
        assert_eq!(frames, vec![frame2.clone()]);
        assert_eq!(dec.stats().crc_errors, 1);
    }
    // A corrupted code byte breaks the COBS structure or the CRC: an error either way.
    let mut bad = good1.clone();
    bad[0] = 0x09;
    let mut line = bad;
    line.extend(&good2);
    let mut dec = FrameReceiver::new([0u8; MAX_ENCODED_FRAME]);
    let (frames, errors) = run_decoder(&mut dec, &line, 4);
    assert_eq!(errors.len(), 1);
    assert_eq!(frames, vec![frame2.clone()]);
    // A byte turned into 0x00 splits the frame: two errors, then the next frame.
    let mut bad = good1.clone();
    bad[4] = 0x00;
    let mut line = bad;
    line.extend(&good2);
    let mut dec = FrameReceiver::new([0u8; MAX_ENCODED_FRAME]);
    let (frames, errors) = run_decoder(&mut dec, &line, 1);
    assert_eq!(errors.len(), 2, "{errors:?}");
    assert_eq!(frames, vec![frame2]);
}

#[test]
fn reset_drops_partial_frame() {
    let (good, frame) = status_packet(1);
    let mut dec = FrameReceiver::new([0u8; MAX_ENCODED_FRAME]);
    for &b in &good[..5] {
        assert!(dec.push(b).is_none());
    }
    assert_eq!(dec.pending(), 5);
    dec.reset();
    assert_eq!(dec.pending(), 0);
    let (frames, errors) = run_decoder(&mut dec, &good, 1);
    assert_eq!(frames, vec![frame]);
    assert!(errors.is_empty());
    let _buf: [u8; MAX_ENCODED_FRAME] = dec.into_inner();
}

// ------------------------------------------------------------------------------------------------
// Loopback and fault injector

#[test]
fn loopback_fifo() {
    let mut lb: Loopback<8> = Loopback::new();
    assert!(lb.is_empty());
    assert_eq!(lb.read_ready(), Ok(false));
    assert_eq!(lb.write_ready(), Ok(true));
    assert_eq!(lb.write(&[1, 2, 3, 4, 5]), Ok(5));
    let mut b = [0u8; 3];
    assert_eq!(lb.read(&mut b), Ok(3));
    assert_eq!(b, [1, 2, 3]);
    // Wraps around; partial write when nearly full.
    assert_eq!(lb.write(&[6, 7, 8, 9, 10, 11, 12]), Ok(6));
    assert_eq!(lb.len(), 8);
    assert_eq!(lb.free(), 0);
    assert_eq!(lb.write(&[13]), Err(LoopbackError::Full));
    assert_eq!(lb.write(&[]), Ok(0));
    assert_eq!(lb.write_ready(), Ok(false));
    let mut all = [0u8; 16];
    assert_eq!(lb.read(&mut all), Ok(8));
    assert_eq!(&all[..8], &[4, 5, 6, 7, 8, 9, 10, 11]);
    assert_eq!(lb.read(&mut all), Ok(0));
    assert_eq!(
        LoopbackError::Full.kind(),
        embedded_io::ErrorKind::WriteZero
    );
    lb.write_all(&[1, 2]).unwrap();
    lb.clear();
    assert!(lb.is_empty());
}

#[test]
fn fault_injector_none_is_transparent_and_seeds_reproduce() {
    let data: Vec<u8> = (0..5000u32).map(|i| (i * 31 + 7) as u8).collect();
    let mut fi = FaultInjector::new(Loopback::<8192>::new(), FaultConfig::NONE, 42);
    fi.write_all(&data).unwrap();
    let mut got = vec![0u8; 8192];
    let n = fi.read(&mut got).unwrap();
    assert_eq!(&got[..n], &data[..]);
    assert_eq!(fi.stats().faults(), 0);
    assert_eq!(fi.stats().bytes, 5000);

    let cfg = FaultConfig {
        drop_ppm: 5_000,
        corrupt_ppm: 5_000,
        duplicate_ppm: 5_000,
        cut_ppm: 1_000,
        max_cut_len: 20,
    };
    let run = |seed| {
        let mut fi = FaultInjector::new(Loopback::<16384>::new(), cfg, seed);
        fi.write_all(&data).unwrap();
        let mut got = vec![0u8; 16384];
        let n = fi.inner_mut().read(&mut got).unwrap();
        got.truncate(n);
        (got, *fi.stats())
    };
    let (a, sa) = run(7);
    let (b, sb) = run(7);
    let (c, _) = run(8);
    assert_eq!(a, b);
    assert_eq!(sa, sb);
    assert_ne!(a, c);
    assert!(sa.dropped > 0 && sa.corrupted > 0 && sa.duplicated > 0 && sa.cuts > 0);
    assert_eq!(
        a.len() as u64,
        5000 - sa.dropped - sa.cut_bytes + sa.duplicated
    );

    // A cut line loses everything written.
    let mut fi = FaultInjector::new(Loopback::<64>::new(), FaultConfig::NONE, 1);
    fi.set_connected(false);
    assert_eq!(fi.write(&[1, 2, 3]), Ok(3));
    fi.set_connected(true);
    assert_eq!(fi.write(&[4]), Ok(1));
    let mut b = [0u8; 8];
    assert_eq!(fi.read(&mut b), Ok(1));
    assert_eq!(b[0], 4);
    assert_eq!(fi.stats().cut_bytes, 3);

    // A full inner link is reported, with the count that got through.
    let mut fi = FaultInjector::new(Loopback::<4>::new(), FaultConfig::NONE, 1);
    assert_eq!(fi.write(&[1, 2, 3, 4, 5, 6]), Ok(4));
    assert_eq!(fi.write(&[5]), Err(LoopbackError::Full));
    assert_eq!(fi.stats().bytes, 4);
}

#[test]
fn xorshift_is_deterministic_and_spread() {
    let mut a = XorShift64::new(0);
    let mut b = XorShift64::new(0);
    let xs: Vec<u64> = (0..100).map(|_| a.next_u64()).collect();
    let ys: Vec<u64> = (0..100).map(|_| b.next_u64()).collect();
    assert_eq!(xs, ys);
    assert!(xs.iter().all(|&x| x != 0));
    let mut r = XorShift64::new(99);
    let mut hist = [0u32; 10];
    for _ in 0..100_000 {
        hist[r.below(10) as usize] += 1;
    }
    assert!(
        hist.iter().all(|&h| (9_000..11_000).contains(&h)),
        "{hist:?}"
    );
    assert_eq!(r.below(0), 0);
}

/// A varied message for transfer `i`, borrowing `data`.
fn transfer_message<'a>(rng: &mut XorShift64, data: &'a [u8], row: &'a mut Vec<u8>) -> Message<'a> {
    match rng.below(4) {
        0 => Message::UploadChunk(UploadChunk::new(
            UploadTarget::PatternSet(rng.below(4) as u8),
            rng.next_u32() >> 4,
            data,
        )),
        1 => {
            let n = 1 + rng.below(150) as usize;
            let values: Vec<f32> = (0..n * 3)
                .map(|_| (rng.below(20_000) as f32 - 10_000.0) / 8.0)
                .collect();
            let validity: Vec<Validity> = (0..n)
                .map(|_| Validity::ALL[rng.below(Validity::ALL.len() as u32) as usize])
                .collect();
            row.resize(n * RowKind::Points.stride(), 0);
            let d = ResultRow::write_data(RowKind::Points, &values, &validity, row).unwrap();
            Message::ResultRow(ResultRow {
                scan_id: rng.next_u32(),
                row: rng.below(2000) as u16,
                first_col: 0,
                kind: RowKind::Points,
                data: d,
            })
        }
        2 => Message::Status(Status {
            state: HeadState::Running,
            errors: HeadErrors(rng.below(256)),
            rx_frames: rng.next_u32(),
            rx_errors: rng.next_u32(),
            tx_frames: rng.next_u32(),
            rows_sent: rng.next_u32(),
            holds: Holds(rng.below(8)),
        }),
        _ => Message::GetStatus,
    }
}

/// Thousands of seeded transfers through a faulty line: every frame is delivered intact or not
/// at all (reported as an error, or missing from the in-order sequence), never corrupt.
#[test]
fn fault_injected_transfers_never_deliver_corrupt_frames() {
    const TRANSFERS: u64 = 3000;
    const FRAMES: usize = 6;
    let mut totals = (0u64, 0u64, 0u64, 0u64); // delivered, errors, clean transfers, faults
    for t in 0..TRANSFERS {
        let mut rng = XorShift64::new(t);
        // Half the transfers on a mildly bad line, half on a very bad one.
        let scale = if t % 2 == 0 { 1 } else { 10 };
        let cfg = FaultConfig {
            drop_ppm: 100 * scale,
            corrupt_ppm: 150 * scale,
            duplicate_ppm: 100 * scale,
            cut_ppm: 20 * scale,
            max_cut_len: 1 + rng.below(300),
        };
        let mut link = FaultInjector::new(Loopback::<65536>::new(), cfg, t ^ 0xF00D);

        // Send.
        let mut sent = Vec::new();
        for k in 0..FRAMES {
            let len = if rng.below(20) == 0 {
                MAX_CHUNK
            } else {
                1 + rng.below(400) as usize
            };
            let data: Vec<u8> = (0..len)
                .map(|_| {
                    if rng.below(4) == 0 {
                        0
                    } else {
                        rng.next_u32() as u8
                    }
                })
                .collect();
            let mut row = Vec::new();
            let msg = transfer_message(&mut rng, &data, &mut row);
            let (line, frame) = packet_bytes(k as u8, msg);
            link.write_all(&line).unwrap();
            sent.push(frame);
        }
        let faults = link.stats().faults();

        // Receive in random-sized reads.
        let mut dec = FrameReceiver::new([0u8; MAX_ENCODED_FRAME]);
        let mut next = 0usize; // index of the earliest sent frame that may still arrive
        let mut delivered = 0;
        let mut errors = 0;
        let mut buf = [0u8; 512];
        loop {
            let want = 1 + rng.below(buf.len() as u32) as usize;
            let n = link.read(&mut buf[..want]).unwrap();
            if n == 0 {
                break;
            }
            let mut rest = &buf[..n];
            while !rest.is_empty() {
                let (used, ev) = dec.feed(rest);
                rest = &rest[used..];
                match ev {
                    Some(Ok(f)) => {
                        // Must equal a sent frame, later than the previous delivered one.
                        let at = sent[next..]
                            .iter()
                            .position(|s| s[..] == *f)
                            .unwrap_or_else(|| panic!("transfer {t}: corrupt frame delivered"));
                        let idx = next + at;
                        let (h, _) = parse_packet(f).expect("intact frame parses");
                        assert_eq!(h.seq as usize, idx);
                        next = idx + 1;
                        delivered += 1;
                    }
                    Some(Err(e)) => {
                        assert!(e.kind().is_transient(), "{e:?}");
                        errors += 1;
                    }
                    None => {}
                }
            }
        }
        assert_eq!(dec.stats().frames, delivered);
        assert_eq!(dec.stats().errors(), errors);
        if faults == 0 {
            assert_eq!(
                delivered as usize, FRAMES,
                "transfer {t}: clean line lost frames"
            );
            assert_eq!(errors, 0);
            totals.2 += 1;
        }
        // A frame can also vanish without an error (a cut swallowing it with its delimiter); the
        // packet layer sees that as a gap in the sequence numbers, checked above to be in order.
        totals.0 += delivered as u64;
        totals.1 += errors as u64;
        totals.3 += faults;
    }
    let (delivered, errors, clean, faults) = totals;
    // The mix exercised both outcomes.
    assert!(clean > 100, "clean transfers: {clean}");
    assert!(errors > 1000, "errors: {errors}");
    assert!(
        delivered > TRANSFERS * FRAMES as u64 / 2,
        "delivered: {delivered}"
    );
    assert!(faults > 1000);
}
