//! Fixed byte vectors for the wire protocol: COBS examples from the COBS paper / Wikipedia, CRC-32C
//! check values from the CRC catalogue and RFC 3720, the header layout, and whole packets.
//!
//! The packet vectors were laid out by hand field by field (postcard rules: u8 raw, u16/u32 LEB128
//! varint, f32/f64 LE, bytes = varint length + bytes, enum = varint variant index); their CRC-32C
//! and COBS forms were computed with an independent bitwise Python implementation (checked first
//! against the CRC-32C check value and the version-1 vectors), not with this crate. Protocol
//! version 2: the version byte of every frame is 0x02.

use fringe3d_core::Validity;
use fringe3d_core::wire::crc::{self, Crc32c, crc32c};
use fringe3d_core::wire::*;

// ------------------------------------------------------------------------------------------------
// COBS

/// Wikipedia "Consistent Overhead Byte Stuffing", encoding examples 1-6 (the trailing 0x00 there
/// is the delimiter, not written by `cobs::encode`).
#[test]
fn cobs_known_examples_short() {
    let cases: &[(&[u8], &[u8])] = &[
        (&[], &[0x01]),
        (&[0x00], &[0x01, 0x01]),
        (&[0x00, 0x00], &[0x01, 0x01, 0x01]),
        (&[0x00, 0x11, 0x00], &[0x01, 0x02, 0x11, 0x01]),
        (&[0x11, 0x22, 0x00, 0x33], &[0x03, 0x11, 0x22, 0x02, 0x33]),
        (&[0x11, 0x22, 0x33, 0x44], &[0x05, 0x11, 0x22, 0x33, 0x44]),
        (&[0x11, 0x00, 0x00, 0x00], &[0x02, 0x11, 0x01, 0x01, 0x01]),
    ];
    for &(raw, enc) in cases {
        let mut out = [0u8; 16];
        let n = cobs::encode(raw, &mut out).unwrap();
        assert_eq!(&out[..n], enc, "encode {raw:02x?}");
        let mut back = [0u8; 16];
        let m = cobs::decode(enc, &mut back).unwrap();
        assert_eq!(&back[..m], raw, "decode {enc:02x?}");
        let mut inplace = [0u8; 16];
        inplace[..enc.len()].copy_from_slice(enc);
        let m = cobs::decode_in_place(&mut inplace[..enc.len()]).unwrap();
        assert_eq!(&inplace[..m], raw, "decode in place {enc:02x?}");
    }
}

/// Wikipedia examples 7-11: the 254-byte block boundary.
#[test]
fn cobs_known_examples_long_blocks() {
    let seq = |a: u32, b: u32| (a..=b).map(|x| x as u8).collect::<Vec<u8>>();
    let cat = |parts: &[&[u8]]| parts.concat();
    let cases: Vec<(Vec<u8>, Vec<u8>)> = vec![
        // 01 02 .. FE (254 bytes) -> FF 01 .. FE
        (seq(0x01, 0xFE), cat(&[&[0xFF], &seq(0x01, 0xFE)])),
        // 00 01 .. FE (255 bytes) -> 01 FF 01 .. FE
        (seq(0x00, 0xFE), cat(&[&[0x01, 0xFF], &seq(0x01, 0xFE)])),
        // 01 02 .. FF (255 bytes) -> FF 01 .. FE 02 FF
        (
            seq(0x01, 0xFF),
            cat(&[&[0xFF], &seq(0x01, 0xFE), &[0x02, 0xFF]]),
        ),
        // 02 03 .. FF 00 (255 bytes) -> FF 02 .. FF 01 01
        (
            cat(&[&seq(0x02, 0xFF), &[0x00]]),
            cat(&[&[0xFF], &seq(0x02, 0xFF), &[0x01, 0x01]]),
        ),
        // 03 04 .. FF 00 01 (255 bytes) -> FE 03 .. FF 02 01
        (
            cat(&[&seq(0x03, 0xFF), &[0x00, 0x01]]),
            cat(&[&[0xFE], &seq(0x03, 0xFF), &[0x02, 0x01]]),
        ),
    ];
    for (raw, enc) in cases {
        let mut out = vec![0u8; cobs::max_encoded_len(raw.len())];
        let n = cobs::encode(&raw, &mut out).unwrap();
        assert_eq!(&out[..n], &enc[..]);
        let mut back = vec![0u8; enc.len()];
        let m = cobs::decode(&enc, &mut back).unwrap();
        assert_eq!(&back[..m], &raw[..]);
        let mut inplace = enc.clone();
        let m = cobs::decode_in_place(&mut inplace).unwrap();
        assert_eq!(&inplace[..m], &raw[..]);
    }
}

#[test]
fn cobs_rejects_malformed() {
    let mut out = [0u8; 64];
    // Empty input, zero code byte, zero inside a block, codes running past the end.
    for bad in [
        &[][..],
        &[0x00],
        &[0x03, 0x11, 0x00],
        &[0x05, 0x11, 0x22],
        &[0x02],
    ] {
        assert_eq!(
            cobs::decode(bad, &mut out),
            Err(WireError::Cobs),
            "{bad:02x?}"
        );
        let mut b = bad.to_vec();
        assert_eq!(
            cobs::decode_in_place(&mut b),
            Err(WireError::Cobs),
            "{bad:02x?}"
        );
    }
    // A non-canonical but well-formed encoding (empty trailing block) is accepted.
    let mut enc = vec![0xFF];
    enc.extend(1..=254u8);
    enc.push(0x01);
    let m = cobs::decode(&enc, &mut [0u8; 300]).unwrap();
    assert_eq!(m, 254);
}

#[test]
fn cobs_buffer_too_small() {
    let mut out = [0u8; 4];
    assert_eq!(
        cobs::encode(&[1, 2, 3, 4], &mut out),
        Err(WireError::BufferTooSmall)
    );
    assert_eq!(cobs::encode(&[], &mut []), Err(WireError::BufferTooSmall));
    let mut out = [0u8; 2];
    assert_eq!(
        cobs::decode(&[0x03, 0x11, 0x22, 0x01], &mut out),
        Err(WireError::BufferTooSmall)
    );
}

// ------------------------------------------------------------------------------------------------
// CRC-32C

#[test]
fn crc32c_check_values() {
    // The catalogue check value of CRC-32/ISCSI.
    assert_eq!(crc32c(b"123456789"), 0xE306_9283);
    assert_eq!(crc::CHECK, 0xE306_9283);
    assert_eq!(crc32c(b""), 0);
    // RFC 3720 (iSCSI) appendix B.4 test vectors.
    assert_eq!(crc32c(&[0u8; 32]), 0x8A91_36AA);
    assert_eq!(crc32c(&[0xFFu8; 32]), 0x62A8_AB43);
    let inc: Vec<u8> = (0..32).collect();
    assert_eq!(crc32c(&inc), 0x46DD_794E);
    let dec: Vec<u8> = (0..32).rev().collect();
    assert_eq!(crc32c(&dec), 0x113F_DB5C);
}

#[test]
fn crc32c_incremental_equals_one_shot() {
    let data: Vec<u8> = (0..1000u32).map(|i| (i * 7 + 3) as u8).collect();
    for split in [0, 1, 13, 500, 999, 1000] {
        let mut c = Crc32c::new();
        c.update(&data[..split]);
        c.update(&data[split..]);
        assert_eq!(c.finish(), crc32c(&data));
    }
}

// ------------------------------------------------------------------------------------------------
// Header

#[test]
fn header_layout() {
    let h = Header {
        flags: Flags::WRITE | Flags::MORE_FOLLOWS,
        seq: 0xA5,
        command: 0x12,
        payload_len: 0x0102,
    };
    let mut out = [0u8; HEADER_LEN];
    assert_eq!(h.emit(&mut out), Ok(6));
    // version, flags (bit 0 + bit 3), seq, command, length LE.
    assert_eq!(out, [0x02, 0x09, 0xA5, 0x12, 0x02, 0x01]);
    assert_eq!(Header::parse(&out), Ok(h));

    assert_eq!(Flags::WRITE.bits(), 0x01);
    assert_eq!(Flags::REPLY_WANTED.bits(), 0x02);
    assert_eq!(Flags::ERROR.bits(), 0x04);
    assert_eq!(Flags::MORE_FOLLOWS.bits(), 0x08);
    assert_eq!(HEADER_LEN, 6);
    assert_eq!(MAX_PAYLOAD, 4096);
    assert_eq!(MAX_FRAME, 4106);
    assert_eq!(MAX_ENCODED_FRAME, 4106 + 4106 / 254 + 1 + 1);
}

#[test]
fn header_rejects() {
    assert_eq!(
        Header::parse(&[0x01, 0, 0, 0, 0, 0]),
        Err(WireError::Version(1))
    );
    assert_eq!(
        Header::parse(&[0x02, 0x10, 0, 0, 0, 0]),
        Err(WireError::ReservedFlags)
    );
    // 4097 = 0x1001 > MAX_PAYLOAD.
    assert_eq!(
        Header::parse(&[0x02, 0, 0, 0, 0x01, 0x10]),
        Err(WireError::Length)
    );
    assert_eq!(
        Header::parse(&[0x02, 0, 0, 0, 0]),
        Err(WireError::Truncated)
    );
    let h = Header {
        flags: Flags::NONE,
        seq: 0,
        command: 0,
        payload_len: 4097,
    };
    assert_eq!(h.emit(&mut [0u8; 6]), Err(WireError::Length));
    assert_eq!(
        Header {
            payload_len: 0,
            ..h
        }
        .emit(&mut [0u8; 5]),
        Err(WireError::BufferTooSmall)
    );
}

#[test]
fn command_ids() {
    let expected: &[(Command, u8, bool)] = &[
        (Command::Hello, 0x01, false),
        (Command::DefinePatternSet, 0x10, true),
        (Command::BeginUpload, 0x11, true),
        (Command::UploadChunk, 0x12, true),
        (Command::QueryUpload, 0x13, false),
        (Command::ConfirmUpload, 0x14, true),
        (Command::UploadCalibration, 0x18, true),
        (Command::BeginPhaseMapUpload, 0x19, true),
        (Command::ConfigureSequence, 0x20, true),
        (Command::ValidateSequence, 0x21, false),
        (Command::Start, 0x22, true),
        (Command::Stop, 0x23, true),
        (Command::Scan, 0x30, true),
        (Command::Abort, 0x31, true),
        (Command::GetStatus, 0x32, false),
        (Command::Capabilities, 0x80, false),
        (Command::Ack, 0x81, false),
        (Command::Nak, 0x82, false),
        (Command::UploadAck, 0x83, false),
        (Command::Validation, 0x84, false),
        (Command::Status, 0x85, false),
        (Command::ResultRow, 0x86, false),
        (Command::ScanDone, 0x87, false),
    ];
    assert_eq!(expected.len(), Command::ALL.len());
    for &(c, id, w) in expected {
        assert_eq!(c as u8, id);
        assert_eq!(Command::from_u8(id), Some(c));
        assert_eq!(c.is_write(), w, "{c:?}");
        assert_eq!(c.is_request(), id < 0x80);
    }
    let known: Vec<u8> = expected.iter().map(|e| e.1).collect();
    for id in 0..=255u8 {
        if !known.contains(&id) {
            assert_eq!(Command::from_u8(id), None);
        }
    }
}

// ------------------------------------------------------------------------------------------------
// Whole packets

/// Emit `msg` under `header` and compare with the hand-made vector; decode the vector and compare
/// with the message.
fn check_vector(header: Header, msg: Message<'_>, payload: &[u8], crc: u32, line: &[u8]) {
    // The decoded frame, assembled from the layout table.
    // Version byte 0x02: protocol version 2.
    let mut frame = vec![0x02, header.flags.bits(), header.seq, header.command];
    frame.extend((payload.len() as u16).to_le_bytes());
    frame.extend(payload);
    assert_eq!(crc32c(&frame), crc, "CRC of {msg:?}");
    frame.extend(crc.to_le_bytes());

    // Body alone.
    let mut p = [0u8; MAX_PAYLOAD];
    let k = msg.encode(&mut p).unwrap();
    assert_eq!(&p[..k], payload, "payload of {msg:?}");

    // Emit.
    let mut scratch = [0u8; MAX_FRAME];
    let mut out = [0u8; MAX_ENCODED_FRAME];
    let n = emit_packet(&header, &msg, &mut scratch, &mut out).unwrap();
    assert_eq!(&out[..n], line, "line bytes of {msg:?}");
    let n2 = Packet {
        header,
        message: msg,
    }
    .emit(&mut scratch, &mut out)
    .unwrap();
    assert_eq!(&out[..n2], line);

    // The line is COBS(frame) 0x00.
    assert_eq!(line.last(), Some(&0));
    assert!(!line[..line.len() - 1].contains(&0));
    let mut dec = vec![0u8; line.len()];
    let m = cobs::decode(&line[..line.len() - 1], &mut dec).unwrap();
    assert_eq!(&dec[..m], &frame[..]);

    // Parse back, directly and through the stream decoder.
    let full = Header {
        payload_len: payload.len() as u16,
        ..header
    };
    let (h, parsed) = parse_packet(&frame).unwrap();
    assert_eq!(h, full);
    assert_eq!(parsed, msg);
    let mut sd = FrameReceiver::new([0u8; MAX_ENCODED_FRAME]);
    let mut got = None;
    for &b in line {
        if let Some(ev) = sd.push(b) {
            let f = ev.unwrap();
            assert_eq!(f, &frame[..]);
            got = Some(parse_packet(f).unwrap().1 == msg);
        }
    }
    assert_eq!(got, Some(true));
}

#[test]
fn vector_get_status() {
    // GetStatus 0x32, seq 7, REPLY_WANTED; empty body.
    let header = Header::for_message(&Message::GetStatus, 7);
    let header = Header {
        flags: header.flags | Flags::REPLY_WANTED,
        ..header
    };
    check_vector(
        header,
        Message::GetStatus,
        &[],
        0x3B0D_6F48,
        &[
            0x05, 0x02, 0x02, 0x07, 0x32, 0x01, 0x05, 0x48, 0x6F, 0x0D, 0x3B, 0x00,
        ],
    );
    // Packet::request gives the same header.
    assert_eq!(Packet::request(7, Message::GetStatus).header, header);
}

#[test]
fn vector_hello() {
    let msg = Message::Hello(Hello {
        protocol_version: 2,
    });
    check_vector(
        Packet::request(1, msg).header,
        msg,
        &[0x02],
        0x119A_B4A3,
        &[
            0x06, 0x02, 0x02, 0x01, 0x01, 0x01, 0x06, 0x02, 0xA3, 0xB4, 0x9A, 0x11, 0x00,
        ],
    );
}

#[test]
fn vector_ack() {
    let msg = Message::Ack(Ack { command: 0x12 });
    let req = Packet::request(9, Message::Abort).header;
    let header = Packet::reply(&req, msg).header;
    assert_eq!(header.flags, Flags::NONE);
    assert_eq!(header.seq, 9);
    check_vector(
        header,
        msg,
        &[0x12],
        0x4D8F_11A1,
        &[
            0x02, 0x02, 0x04, 0x09, 0x81, 0x01, 0x06, 0x12, 0xA1, 0x11, 0x8F, 0x4D, 0x00,
        ],
    );
}

#[test]
fn vector_nak() {
    // command 0x12, code DigestMismatch = [9], detail 300 = varint AC 02; flags ERROR.
    let msg = Message::Nak(Nak {
        command: 0x12,
        code: NakCode::DigestMismatch,
        detail: 300,
    });
    let header = Header::for_message(&msg, 10);
    assert_eq!(header.flags, Flags::ERROR);
    check_vector(
        header,
        msg,
        &[0x12, 0x09, 0xAC, 0x02],
        0x9472_D80B,
        &[
            0x06, 0x02, 0x04, 0x0A, 0x82, 0x04, 0x09, 0x12, 0x09, 0xAC, 0x02, 0x0B, 0xD8, 0x72,
            0x94, 0x00,
        ],
    );
}

#[test]
fn vector_upload_chunk() {
    let data = [0x00, 0x11, 0x22, 0x00, 0x33];
    let chunk = UploadChunk::new(UploadTarget::PatternSet(3), 200, &data);
    assert_eq!(chunk.crc, 0xFCCB_7EEC);
    let msg = Message::UploadChunk(chunk);
    let header = Header {
        flags: Flags::WRITE | Flags::REPLY_WANTED | Flags::MORE_FOLLOWS,
        seq: 0x20,
        command: 0x12,
        payload_len: 0,
    };
    check_vector(
        header,
        msg,
        &[
            0x00, 0x03, // target: [0] PatternSet(3)
            0xC8, 0x01, // offset 200
            0xEC, 0xFD, 0xAD, 0xE6, 0x0F, // crc 0xFCCB7EEC varint
            0x05, 0x00, 0x11, 0x22, 0x00, 0x33, // data: len 5 + bytes
        ],
        0xD840_B265,
        &[
            0x06, 0x02, 0x0B, 0x20, 0x12, 0x0F, 0x01, 0x0A, 0x03, 0xC8, 0x01, 0xEC, 0xFD, 0xAD,
            0xE6, 0x0F, 0x05, 0x03, 0x11, 0x22, 0x06, 0x33, 0x65, 0xB2, 0x40, 0xD8, 0x00,
        ],
    );
}

#[test]
fn vector_upload_ack() {
    // target [1] PhaseMap, next_offset 70000 = varint F0 A2 04.
    let msg = Message::UploadAck(UploadAck {
        target: UploadTarget::PhaseMap,
        next_offset: 70000,
    });
    check_vector(
        Header::for_message(&msg, 0x20),
        msg,
        &[0x01, 0xF0, 0xA2, 0x04],
        0xE675_3D24,
        &[
            0x02, 0x02, 0x04, 0x20, 0x83, 0x04, 0x09, 0x01, 0xF0, 0xA2, 0x04, 0x24, 0x3D, 0x75,
            0xE6, 0x00,
        ],
    );
}

#[test]
fn vector_status() {
    let msg = Message::Status(Status {
        state: HeadState::Scanning,
        errors: HeadErrors(HeadErrors::LINK | HeadErrors::OVERRUN),
        rx_frames: 1000,
        rx_errors: 2,
        tx_frames: 129,
        rows_sent: 480,
    });
    check_vector(
        Header::for_message(&msg, 0xFF),
        msg,
        &[
            0x04, // [4] Scanning
            0x21, // errors
            0xE8, 0x07, // 1000
            0x02, // 2
            0x81, 0x01, // 129
            0xE0, 0x03, // 480
        ],
        0x48A6_0FAE,
        &[
            0x02, 0x02, 0x04, 0xFF, 0x85, 0x09, 0x0E, 0x04, 0x21, 0xE8, 0x07, 0x02, 0x81, 0x01,
            0xE0, 0x03, 0xAE, 0x0F, 0xA6, 0x48, 0x00,
        ],
    );
}

#[test]
fn vector_result_row() {
    let mut buf = [0u8; 16];
    let data = ResultRow::write_data(
        RowKind::Phase,
        &[1.5, -0.25],
        &[Validity::Valid, Validity::LowModulation],
        &mut buf,
    )
    .unwrap();
    assert_eq!(
        data,
        &[0x00, 0x00, 0xC0, 0x3F, 0x00, 0x00, 0x80, 0xBE, 0x00, 0x03]
    );
    let row = ResultRow {
        row: 5,
        first_col: 640,
        kind: RowKind::Phase,
        data,
    };
    assert_eq!(row.columns(), 2);
    assert_eq!(row.value(0, 0), Some(1.5));
    assert_eq!(row.value(1, 0), Some(-0.25));
    assert_eq!(row.value(1, 1), None);
    assert_eq!(row.value(2, 0), None);
    assert_eq!(row.validity(1), Some(Validity::LowModulation));
    assert_eq!(row.validity(2), None);
    let msg = Message::ResultRow(row);
    let header = Header {
        flags: Flags::MORE_FOLLOWS,
        ..Header::for_message(&msg, 0x30)
    };
    check_vector(
        header,
        msg,
        &[
            0x05, // row 5
            0x80, 0x05, // first_col 640
            0x00, // [0] Phase
            0x0A, // 10 data bytes
            0x00, 0x00, 0xC0, 0x3F, 0x00, 0x00, 0x80, 0xBE, 0x00, 0x03,
        ],
        0x25DE_23E6,
        &[
            0x06, 0x02, 0x08, 0x30, 0x86, 0x0F, 0x04, 0x05, 0x80, 0x05, 0x02, 0x0A, 0x01, 0x03,
            0xC0, 0x3F, 0x01, 0x03, 0x80, 0xBE, 0x06, 0x03, 0xE6, 0x23, 0xDE, 0x25, 0x00,
        ],
    );
}

#[test]
fn vector_configure_sequence() {
    let entry = |pattern| LutEntry {
        pattern,
        exposure_us: 8333,
        dark_us: 100,
        bit_depth: 8,
        wait_for_trigger: false,
        trigger_out: true,
    };
    let mut buf = [0u8; 24];
    let entries = LutTable::encode(&[entry(0), entry(1)], &mut buf).unwrap();
    assert_eq!(entries.len(), 2);
    assert_eq!(entries.get(1), Some(entry(1)));
    assert_eq!(entries.iter().collect::<Vec<_>>(), vec![entry(0), entry(1)]);
    let msg = Message::ConfigureSequence(Sequence {
        set_id: 2,
        repeat: true,
        entries,
    });
    check_vector(
        Packet::request(0x41, msg).header,
        msg,
        &[
            0x02, // set_id
            0x01, // repeat
            0x18, // 24 bytes of entries
            0x00, 0x00, 0x8D, 0x20, 0x00, 0x00, 0x64, 0x00, 0x00, 0x00, 0x08, 0x02, // #0
            0x01, 0x00, 0x8D, 0x20, 0x00, 0x00, 0x64, 0x00, 0x00, 0x00, 0x08, 0x02, // #1
        ],
        0x76A8_6C67,
        &[
            0x06, 0x02, 0x03, 0x41, 0x20, 0x1B, 0x04, 0x02, 0x01, 0x18, 0x01, 0x03, 0x8D, 0x20,
            0x01, 0x02, 0x64, 0x01, 0x01, 0x04, 0x08, 0x02, 0x01, 0x03, 0x8D, 0x20, 0x01, 0x02,
            0x64, 0x01, 0x01, 0x07, 0x08, 0x02, 0x67, 0x6C, 0xA8, 0x76, 0x00,
        ],
    );
}

#[test]
fn vector_upload_calibration() {
    let msg = Message::UploadCalibration(Calibration {
        camera: CameraParams {
            width: 640,
            height: 480,
            fx: 800.0,
            fy: 800.0,
            cx: 320.0,
            cy: 240.0,
            skew: 0.0,
            distortion: [-0.125, 0.0625, 0.0, 0.0, 0.0].into(),
        },
        geometry: ScanGeometry {
            projector_centre: [100.0, 0.0, 0.0],
            plane_point: [0.0, 0.0, 500.0],
            plane_normal: [0.0, 0.0, -1.0],
            depth_min: 300.0,
            depth_max: 700.0,
        },
    });
    // f64 LE: sign, 11-bit exponent (bias 1023), 52-bit fraction.
    let z = [0u8; 8];
    let payload: Vec<u8> = [
        &[0x80, 0x05, 0xE0, 0x03][..],   // 640, 480
        &[0, 0, 0, 0, 0, 0, 0x89, 0x40], // fx 800 = 0x4089000000000000
        &[0, 0, 0, 0, 0, 0, 0x89, 0x40], // fy 800
        &[0, 0, 0, 0, 0, 0, 0x74, 0x40], // cx 320 = 0x4074000000000000
        &[0, 0, 0, 0, 0, 0, 0x6E, 0x40], // cy 240 = 0x406E000000000000
        &z,                              // skew
        &[0, 0, 0, 0, 0, 0, 0xC0, 0xBF], // k1 -0.125 = 0xBFC0000000000000
        &[0, 0, 0, 0, 0, 0, 0xB0, 0x3F], // k2 0.0625 = 0x3FB0000000000000
        &z,
        &z,
        &z,                              // p1 p2 k3
        &[0, 0, 0, 0, 0, 0, 0x59, 0x40], // projector x 100 = 0x4059000000000000
        &z,
        &z,
        &z,
        &z,
        &[0, 0, 0, 0, 0, 0x40, 0x7F, 0x40], // plane point z 500 = 0x407F400000000000
        &z,
        &z,
        &[0, 0, 0, 0, 0, 0, 0xF0, 0xBF], // normal z -1 = 0xBFF0000000000000
        &[0, 0, 0, 0, 0, 0xC0, 0x72, 0x40], // depth 300 = 0x4072C00000000000
        &[0, 0, 0, 0, 0, 0xE0, 0x85, 0x40], // depth 700 = 0x4085E00000000000
    ]
    .concat();
    check_vector(
        Header {
            flags: Flags::WRITE,
            ..Header::for_message(&msg, 0x42)
        },
        msg,
        &payload,
        0x1D55_EC6B,
        &[
            0x06, 0x02, 0x01, 0x42, 0x18, 0xAC, 0x05, 0x80, 0x05, 0xE0, 0x03, 0x01, 0x01, 0x01,
            0x01, 0x01, 0x03, 0x89, 0x40, 0x01, 0x01, 0x01, 0x01, 0x01, 0x03, 0x89, 0x40, 0x01,
            0x01, 0x01, 0x01, 0x01, 0x03, 0x74, 0x40, 0x01, 0x01, 0x01, 0x01, 0x01, 0x03, 0x6E,
            0x40, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01,
            0x03, 0xC0, 0xBF, 0x01, 0x01, 0x01, 0x01, 0x01, 0x03, 0xB0, 0x3F, 0x01, 0x01, 0x01,
            0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01,
            0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x03, 0x59,
            0x40, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01,
            0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01,
            0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x04, 0x40, 0x7F, 0x40, 0x01,
            0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01,
            0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x03, 0xF0, 0xBF, 0x01, 0x01, 0x01, 0x01, 0x04,
            0xC0, 0x72, 0x40, 0x01, 0x01, 0x01, 0x01, 0x08, 0xE0, 0x85, 0x40, 0x6B, 0xEC, 0x55,
            0x1D, 0x00,
        ],
    );
}

/// The paper's eq 7 set: three levels, shifts {0, π/2}, {0, π/2}, {0, π/2, π, 3π/2}.
pub fn paper_pattern_set() -> PatternSetDesc {
    let mut levels = [Level::UNUSED; MAX_LEVELS];
    levels[0] = Level {
        scale: 0.0625,
        shifts: Shifts::Uniform { n: 4, count: 2 },
    };
    levels[1] = Level {
        scale: 0.25,
        shifts: Shifts::Uniform { n: 4, count: 2 },
    };
    levels[2] = Level {
        scale: 1.0,
        shifts: Shifts::Uniform { n: 4, count: 4 },
    };
    PatternSetDesc {
        width: 912,
        height: 1140,
        bit_depth: 8,
        i_min: 0.0,
        i_max: 255.0,
        waveform: Waveform::Sine,
        phase_offset: 0.0,
        phase: PhaseDesc {
            axis: PatternAxis::Xi,
            profile: PhaseProfile::Linear {
                origin: 455.5,
                slope: 0.0625,
            },
            curvature: 0.0,
            bend_center: 0.0,
        },
        level_count: 3,
        levels,
    }
}

#[test]
fn vector_define_pattern_set_uniform() {
    let desc = paper_pattern_set();
    assert_eq!(desc.pattern_count(), 8);
    let msg = Message::DefinePatternSet(DefinePatternSet { set_id: 5, desc });
    let z = [0u8; 8];
    let unused: &[u8] = &[0; 11]; // scale 0.0 (8 bytes), [0] Uniform n 0 count 0
    let payload: Vec<u8> = [
        &[0x05][..],                        // set_id
        &[0x90, 0x07, 0xF4, 0x08],          // 912, 1140
        &[0x08],                            // bit depth
        &z,                                 // i_min 0
        &[0, 0, 0, 0, 0, 0xE0, 0x6F, 0x40], // i_max 255 = 0x406FE00000000000
        &[0x00],                            // [0] Sine
        &z,                                 // phase offset
        &[0x00, 0x00],                      // [0] Xi, [0] Linear
        &[0, 0, 0, 0, 0, 0x78, 0x7C, 0x40], // origin 455.5 = 0x407C780000000000
        &[0, 0, 0, 0, 0, 0, 0xB0, 0x3F],    // slope 0.0625 = 0x3FB0000000000000
        &z,
        &z,                                                // curvature, bend centre
        &[0x03],                                           // level count
        &[0, 0, 0, 0, 0, 0, 0xB0, 0x3F, 0x00, 0x04, 0x02], // 0.0625, [0] Uniform 4 2
        &[0, 0, 0, 0, 0, 0, 0xD0, 0x3F, 0x00, 0x04, 0x02], // 0.25 = 0x3FD0000000000000
        &[0, 0, 0, 0, 0, 0, 0xF0, 0x3F, 0x00, 0x04, 0x04], // 1.0 = 0x3FF0000000000000, 4 4
        unused,
        unused,
        unused,
    ]
    .concat();
    check_vector(
        Packet::request(0x43, msg).header,
        msg,
        &payload,
        0xBE98_D880,
        &[
            0x06, 0x02, 0x03, 0x43, 0x10, 0x84, 0x07, 0x05, 0x90, 0x07, 0xF4, 0x08, 0x08, 0x01,
            0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x04, 0xE0, 0x6F,
            0x40, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01,
            0x01, 0x01, 0x04, 0x78, 0x7C, 0x40, 0x01, 0x01, 0x01, 0x01, 0x01, 0x03, 0xB0, 0x3F,
            0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01,
            0x01, 0x02, 0x03, 0x01, 0x01, 0x01, 0x01, 0x01, 0x03, 0xB0, 0x3F, 0x03, 0x04, 0x02,
            0x01, 0x01, 0x01, 0x01, 0x01, 0x03, 0xD0, 0x3F, 0x03, 0x04, 0x02, 0x01, 0x01, 0x01,
            0x01, 0x01, 0x03, 0xF0, 0x3F, 0x03, 0x04, 0x04, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01,
            0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01,
            0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x05, 0x80,
            0xD8, 0x98, 0xBE, 0x00,
        ],
    );
}

#[test]
fn vector_define_pattern_set_explicit() {
    // Knots, curved fringes, I_min, cosine, an offset and explicit shifts.
    let arr = |v: [f64; 3]| {
        let mut a = [0.0f64; MAX_KNOTS];
        a[..3].copy_from_slice(&v);
        a
    };
    let mut radians = [0.0f64; MAX_SHIFTS];
    radians[1] = 2.0;
    radians[2] = 4.0;
    let mut levels = [Level::UNUSED; MAX_LEVELS];
    levels[0] = Level {
        scale: 1.0,
        shifts: Shifts::Explicit { count: 3, radians },
    };
    let desc = PatternSetDesc {
        width: 1024,
        height: 768,
        bit_depth: 7,
        i_min: 10.0,
        i_max: 100.0,
        waveform: Waveform::Cosine,
        phase_offset: 0.5,
        phase: PhaseDesc {
            axis: PatternAxis::Eta,
            profile: PhaseProfile::Knots(Knots {
                count: 3,
                s: arr([0.0, 256.0, 767.0]),
                phi: arr([-1.0, 0.0, 2.0]),
                slope: arr([0.0078125, 0.00390625, 0.0078125]),
            }),
            curvature: 1.0 / 8192.0,
            bend_center: 512.0,
        },
        level_count: 1,
        levels,
    };
    let msg = Message::DefinePatternSet(DefinePatternSet { set_id: 0, desc });
    let z = [0u8; 8];
    let mut payload: Vec<u8> = [
        &[0x00][..],                        // set_id
        &[0x80, 0x08, 0x80, 0x06],          // 1024, 768
        &[0x07],                            // bit depth
        &[0, 0, 0, 0, 0, 0, 0x24, 0x40],    // i_min 10 = 0x4024000000000000
        &[0, 0, 0, 0, 0, 0, 0x59, 0x40],    // i_max 100
        &[0x01],                            // [1] Cosine
        &[0, 0, 0, 0, 0, 0, 0xE0, 0x3F],    // phase offset 0.5 = 0x3FE0000000000000
        &[0x01, 0x01, 0x03],                // [1] Eta, [1] Knots, count 3
        &z,                                 // s: 0
        &[0, 0, 0, 0, 0, 0, 0x70, 0x40],    //    256 = 0x4070000000000000
        &[0, 0, 0, 0, 0, 0xF8, 0x87, 0x40], //    767 = 0x4087F80000000000
    ]
    .concat();
    payload.extend([0u8; 13 * 8]); // unused positions
    payload.extend([0, 0, 0, 0, 0, 0, 0xF0, 0xBF]); // phi: -1
    payload.extend(z); //      0
    payload.extend([0, 0, 0, 0, 0, 0, 0x00, 0x40]); //      2 = 0x4000000000000000
    payload.extend([0u8; 13 * 8]);
    payload.extend([0, 0, 0, 0, 0, 0, 0x80, 0x3F]); // slope: 2^-7 = 0x3F80000000000000
    payload.extend([0, 0, 0, 0, 0, 0, 0x70, 0x3F]); //        2^-8 = 0x3F70000000000000
    payload.extend([0, 0, 0, 0, 0, 0, 0x80, 0x3F]); //        2^-7
    payload.extend([0u8; 13 * 8]);
    payload.extend([0, 0, 0, 0, 0, 0, 0x20, 0x3F]); // curvature 2^-13 = 0x3F20000000000000
    payload.extend([0, 0, 0, 0, 0, 0, 0x80, 0x40]); // bend centre 512 = 0x4080000000000000
    payload.extend([0x01]); // level count
    payload.extend([0, 0, 0, 0, 0, 0, 0xF0, 0x3F]); // scale 1
    payload.extend([0x01, 0x03]); // [1] Explicit, count 3
    payload.extend(z); // 0
    payload.extend([0, 0, 0, 0, 0, 0, 0x00, 0x40]); // 2
    payload.extend([0, 0, 0, 0, 0, 0, 0x10, 0x40]); // 4 = 0x4010000000000000
    payload.extend([0u8; 13 * 8]); // unused shifts
    for _ in 0..5 {
        payload.extend([0u8; 11]); // unused levels
    }
    check_vector(
        Header {
            flags: Flags::WRITE,
            ..Header::for_message(&msg, 0x44)
        },
        msg,
        &payload,
        0x7F84_A6BD,
        &[
            0x07, 0x02, 0x01, 0x44, 0x10, 0x74, 0x02, 0x06, 0x80, 0x08, 0x80, 0x06, 0x07, 0x01,
            0x01, 0x01, 0x01, 0x01, 0x03, 0x24, 0x40, 0x01, 0x01, 0x01, 0x01, 0x01, 0x04, 0x59,
            0x40, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x06, 0xE0, 0x3F, 0x01, 0x01, 0x03, 0x01,
            0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x03, 0x70,
            0x40, 0x01, 0x01, 0x01, 0x01, 0x04, 0xF8, 0x87, 0x40, 0x01, 0x01, 0x01, 0x01, 0x01,
            0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01,
            0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01,
            0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01,
            0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01,
            0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01,
            0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01,
            0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01,
            0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x03, 0xF0, 0xBF, 0x01, 0x01, 0x01, 0x01, 0x01,
            0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x02, 0x40, 0x01, 0x01, 0x01,
            0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01,
            0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01,
            0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01,
            0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01,
            0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01,
            0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01,
            0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01,
            0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x03, 0x80, 0x3F, 0x01, 0x01, 0x01,
            0x01, 0x01, 0x03, 0x70, 0x3F, 0x01, 0x01, 0x01, 0x01, 0x01, 0x03, 0x80, 0x3F, 0x01,
            0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01,
            0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01,
            0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01,
            0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01,
            0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01,
            0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01,
            0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01,
            0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x03, 0x20, 0x3F, 0x01,
            0x01, 0x01, 0x01, 0x01, 0x04, 0x80, 0x40, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x05,
            0xF0, 0x3F, 0x01, 0x03, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01,
            0x01, 0x01, 0x01, 0x01, 0x02, 0x40, 0x01, 0x01, 0x01, 0x01, 0x01, 0x03, 0x10, 0x40,
            0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01,
            0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01,
            0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01,
            0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01,
            0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01,
            0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01,
            0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01,
            0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01,
            0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01,
            0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01,
            0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01,
            0x01, 0x01, 0x01, 0x01, 0x05, 0xBD, 0xA6, 0x84, 0x7F, 0x00,
        ],
    );
}

#[test]
fn vector_begin_upload() {
    // 8 images of 912 × 1140, digest 0xDEADBEEF.
    let msg = Message::BeginUpload(BeginUpload {
        set_id: 1,
        image_count: 8,
        width: 912,
        height: 1140,
        bit_depth: 8,
        total_bytes: 8 * 912 * 1140,
        digest: 0xDEAD_BEEF,
    });
    check_vector(
        Packet::request(0x45, msg).header,
        msg,
        &[
            0x01, 0x08, 0x90, 0x07, 0xF4, 0x08, 0x08, // set, count, w, h, depth
            0x80, 0xD4, 0xFB, 0x03, // 8317440
            0xEF, 0xFD, 0xB6, 0xF5, 0x0D, // 0xDEADBEEF
        ],
        0x407F_DA0F,
        &[
            0x06, 0x02, 0x03, 0x45, 0x11, 0x10, 0x15, 0x01, 0x08, 0x90, 0x07, 0xF4, 0x08, 0x08,
            0x80, 0xD4, 0xFB, 0x03, 0xEF, 0xFD, 0xB6, 0xF5, 0x0D, 0x0F, 0xDA, 0x7F, 0x40, 0x00,
        ],
    );
}

#[test]
fn vector_capabilities() {
    let msg = Message::Capabilities(Capabilities {
        protocol_version: 2,
        firmware: FirmwareVersion {
            major: 0,
            minor: 3,
            patch: 7,
        },
        sensor_width: 1280,
        sensor_height: 1024,
        projector_width: 912,
        projector_height: 1140,
        free_memory: 8 << 20,
        max_chunk: 4064,
        max_sets: 4,
        max_lut_entries: 256,
    });
    check_vector(
        Header::for_message(&msg, 0x01),
        msg,
        &[
            0x02, 0x00, 0x03, 0x07, // version, firmware 0.3.7
            0x80, 0x0A, 0x80, 0x08, // 1280, 1024
            0x90, 0x07, 0xF4, 0x08, // 912, 1140
            0x80, 0x80, 0x80, 0x04, // 8 MiB
            0xE0, 0x1F, // 4064
            0x04, // max sets
            0x80, 0x02, // 256
        ],
        0x3F40_9674,
        &[
            0x02, 0x02, 0x04, 0x01, 0x80, 0x15, 0x02, 0x02, 0x18, 0x03, 0x07, 0x80, 0x0A, 0x80,
            0x08, 0x90, 0x07, 0xF4, 0x08, 0x80, 0x80, 0x80, 0x04, 0xE0, 0x1F, 0x04, 0x80, 0x02,
            0x74, 0x96, 0x40, 0x3F, 0x00,
        ],
    );
}

#[test]
fn vector_validation_and_scan() {
    let msg = Message::Validation(ValidationStatus(
        ValidationStatus::SET_NOT_CONFIRMED | ValidationStatus::NO_REFERENCE,
    ));
    check_vector(
        Header::for_message(&msg, 0x46),
        msg,
        &[0x84, 0x04], // 0x204
        0x3A7E_C0CC,
        &[
            0x02, 0x02, 0x04, 0x46, 0x84, 0x02, 0x07, 0x84, 0x04, 0xCC, 0xC0, 0x7E, 0x3A, 0x00,
        ],
    );
    let msg = Message::Scan(ScanRequest {
        output: ScanOutput::Both,
        first_row: 0,
        row_count: 0,
        edge_filter: EdgeFilterMode::MaxAngle(80.0),
    });
    check_vector(
        Packet::request(0x47, msg).header,
        msg,
        // [2] Both, 0, 0, [1] MaxAngle 80.0 = 0x4054000000000000.
        &[0x02, 0x00, 0x00, 0x01, 0, 0, 0, 0, 0, 0, 0x54, 0x40],
        0xB0D8_B8DB,
        &[
            0x06, 0x02, 0x03, 0x47, 0x30, 0x0C, 0x02, 0x02, 0x01, 0x02, 0x01, 0x01, 0x01, 0x01,
            0x01, 0x01, 0x07, 0x54, 0x40, 0xDB, 0xB8, 0xD8, 0xB0, 0x00,
        ],
    );
}

#[test]
fn enum_wire_values() {
    // Enum variant indices are part of the format: check a few directly.
    let mut b = [0u8; 8];
    let enc = |m: Message<'_>, b: &mut [u8; 8]| {
        let n = m.encode(b).unwrap();
        b[..n].to_vec()
    };
    let codes = [
        NakCode::Crc,
        NakCode::Framing,
        NakCode::Version,
        NakCode::UnknownCommand,
        NakCode::Malformed,
        NakCode::Invalid,
        NakCode::Busy,
        NakCode::NotReady,
        NakCode::NoSuchSet,
        NakCode::DigestMismatch,
        NakCode::OutOfMemory,
        NakCode::BadOffset,
        NakCode::NoUpload,
        NakCode::SequenceInvalid,
        NakCode::Aborted,
        NakCode::Internal,
    ];
    for (i, code) in codes.into_iter().enumerate() {
        let m = Message::Nak(Nak {
            command: 1,
            code,
            detail: 0,
        });
        assert_eq!(enc(m, &mut b), vec![1, i as u8, 0]);
    }
    let states = [
        HeadState::Idle,
        HeadState::Uploading,
        HeadState::Ready,
        HeadState::Running,
        HeadState::Scanning,
        HeadState::Fault,
    ];
    for (i, state) in states.into_iter().enumerate() {
        let m = Message::Status(Status {
            state,
            errors: HeadErrors(0),
            rx_frames: 0,
            rx_errors: 0,
            tx_frames: 0,
            rows_sent: 0,
        });
        assert_eq!(enc(m, &mut b)[0], i as u8);
    }
    for (i, output) in [ScanOutput::Phase, ScanOutput::Points, ScanOutput::Both]
        .into_iter()
        .enumerate()
    {
        let m = Message::Scan(ScanRequest {
            output,
            first_row: 1,
            row_count: 2,
            edge_filter: EdgeFilterMode::Off,
        });
        assert_eq!(enc(m, &mut b), vec![i as u8, 1, 2, 0]);
    }
    assert_eq!(
        enc(Message::QueryUpload(UploadTarget::PatternSet(7)), &mut b),
        vec![0, 7]
    );
    assert_eq!(
        enc(Message::ConfirmUpload(UploadTarget::PhaseMap), &mut b),
        vec![1]
    );
}

#[test]
fn invalid_codes_round_trip() {
    for code in 0..=255u8 {
        if let Some(i) = Invalid::from_u8(code) {
            assert_eq!(i as u8, code);
            assert!(!i.name().is_empty());
        } else {
            assert!(code == 0 || code > 22);
        }
    }
}
