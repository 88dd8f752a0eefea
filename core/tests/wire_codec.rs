//! Fixed byte vectors for the wire protocol's framing layer: COBS examples from the COBS paper /
//! Wikipedia, CRC-32C check values from the CRC catalogue and RFC 3720, the header layout, the
//! command ids and every enum's wire values. Whole packets are in `wire_vectors.rs`.

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
    assert_eq!(out, [0x0B, 0x09, 0xA5, 0x12, 0x02, 0x01]);
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
    // Versions 2 (before the scan identity) and 3 (before the relation) are refused too.
    assert_eq!(
        Header::parse(&[0x02, 0, 0, 0, 0, 0]),
        Err(WireError::Version(2))
    );
    assert_eq!(
        Header::parse(&[0x03, 0, 0, 0, 0, 0]),
        Err(WireError::Version(3))
    );
    // Version 4 (before the light-edge code) too, and 5 (before the map's margin).
    assert_eq!(
        Header::parse(&[0x04, 0, 0, 0, 0, 0]),
        Err(WireError::Version(4))
    );
    assert_eq!(
        Header::parse(&[0x05, 0, 0, 0, 0, 0]),
        Err(WireError::Version(5))
    );
    // Version 6 (before DefineThresholds) too, and 7 (before the exposure list).
    assert_eq!(
        Header::parse(&[0x06, 0, 0, 0, 0, 0]),
        Err(WireError::Version(6))
    );
    assert_eq!(
        Header::parse(&[0x07, 0, 0, 0, 0, 0]),
        Err(WireError::Version(7))
    );
    // Version 8 (before the compiled reconstruction's upload) too.
    assert_eq!(
        Header::parse(&[0x08, 0, 0, 0, 0, 0]),
        Err(WireError::Version(8))
    );
    // Version 9 (compiled models of 40 bytes a pixel, without their own far threshold) too.
    assert_eq!(
        Header::parse(&[0x09, 0, 0, 0, 0, 0]),
        Err(WireError::Version(9))
    );
    // Version 10 (a ScanDone without the decoded and searched counts) too.
    assert_eq!(
        Header::parse(&[0x0A, 0, 0, 0, 0, 0]),
        Err(WireError::Version(10))
    );
    assert_eq!(
        Header::parse(&[0x0B, 0x10, 0, 0, 0, 0]),
        Err(WireError::ReservedFlags)
    );
    // 4097 = 0x1001 > MAX_PAYLOAD.
    assert_eq!(
        Header::parse(&[0x0B, 0, 0, 0, 0x01, 0x10]),
        Err(WireError::Length)
    );
    assert_eq!(
        Header::parse(&[0x0B, 0, 0, 0, 0]),
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
        (Command::DefineCorrection, 0x15, true),
        (Command::DefineThresholds, 0x16, true),
        (Command::UploadCalibration, 0x18, true),
        (Command::BeginPhaseMapUpload, 0x19, true),
        (Command::BeginCompiledUpload, 0x1A, true),
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
// Enum wire values

#[test]
fn enum_wire_values() {
    // Enum variant indices are part of the format: check a few directly.
    let mut b = [0u8; 16];
    let enc = |m: Message<'_>, b: &mut [u8; 16]| {
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
            holds: Holds(0),
        });
        assert_eq!(enc(m, &mut b)[0], i as u8);
    }
    for (i, output) in [ScanOutput::Phase, ScanOutput::Points, ScanOutput::Both]
        .into_iter()
        .enumerate()
    {
        let m = Message::Scan(ScanRequest {
            scan_id: 300,
            output,
            first_row: 1,
            row_count: 2,
            edge_filter: EdgeFilterMode::Off,
            exposures: Exposures::NONE,
        });
        // scan_id 300 = varint AC 02 first; no exposure list: count 0 and four zeros.
        assert_eq!(
            enc(m, &mut b),
            vec![0xAC, 0x02, i as u8, 1, 2, 0, 0, 0, 0, 0, 0]
        );
    }
    assert_eq!(
        enc(Message::QueryUpload(UploadTarget::PatternSet(7)), &mut b),
        vec![0, 7]
    );
    assert_eq!(
        enc(Message::ConfirmUpload(UploadTarget::PhaseMap), &mut b),
        vec![1]
    );
    // A level's shifts: [2] Gray, [3] GrayInverse, [4] GrayShifted (protocol version 6), each
    // after the level's scale (32.0 = 00 00 00 00 00 00 40 40).
    let level = |shifts| {
        let mut out = [0u8; 32];
        postcard::to_slice(
            &Level {
                scale: 32.0,
                shifts,
            },
            &mut out,
        )
        .unwrap()
        .to_vec()
    };
    let scale = [0, 0, 0, 0, 0, 0, 0x40, 0x40];
    for (shifts, tail) in [
        (
            Shifts::Gray {
                bits: 6,
                complementary: true,
            },
            [2, 6, 1],
        ),
        (
            Shifts::GrayInverse {
                bits: 6,
                complementary: false,
            },
            [3, 6, 0],
        ),
        (
            Shifts::GrayShifted {
                bits: 6,
                inverse: true,
            },
            [4, 6, 1],
        ),
    ] {
        assert_eq!(
            level(shifts),
            [&scale[..], &tail[..]].concat(),
            "{shifts:?}"
        );
    }
}

#[test]
fn invalid_codes_round_trip() {
    for code in 0..=255u8 {
        if let Some(i) = Invalid::from_u8(code) {
            assert_eq!(i as u8, code);
            assert!(!i.name().is_empty());
        } else {
            assert!(code == 0 || code > 25);
        }
    }
}
