//! The wire layer's frame-level error paths: header/message agreement, frame checks, buffer
//! limits, error classes and the NAKs they map to. (Message validation rules are in
//! `wire_validation.rs`.)

use fringe3d_core::wire::crc::crc32c;
use fringe3d_core::wire::*;

use crate::wire_support::raw_frame;

#[test]
fn header_must_agree_with_message() {
    let mut scratch = [0u8; MAX_FRAME];
    let mut out = [0u8; MAX_ENCODED_FRAME];
    let msg = Message::Start;
    let good = Header::for_message(&msg, 1);
    assert_eq!(good.flags, Flags::WRITE);
    assert!(emit_packet(&good, &msg, &mut scratch, &mut out).is_ok());
    let cases = [
        (
            Header {
                command: 0x23,
                ..good
            },
            WireError::CommandMismatch,
        ),
        (
            Header {
                flags: Flags::NONE,
                ..good
            },
            WireError::FlagMismatch,
        ),
        (
            Header {
                flags: Flags::WRITE | Flags::ERROR,
                ..good
            },
            WireError::FlagMismatch,
        ),
    ];
    for (h, e) in cases {
        assert_eq!(emit_packet(&h, &msg, &mut scratch, &mut out), Err(e));
        assert_eq!(check_header(&h, &msg), Err(e));
    }
    // A Nak needs ERROR.
    let nak = Message::Nak(Nak::for_error(0x22, WireError::Crc));
    let h = Header::for_message(&nak, 3);
    assert_eq!(h.flags, Flags::ERROR);
    assert_eq!(
        check_header(
            &Header {
                flags: Flags::NONE,
                ..h
            },
            &nak
        ),
        Err(WireError::FlagMismatch)
    );
    // Received frames are checked the same way: Start without WRITE.
    assert_eq!(
        parse_packet(&raw_frame(PROTOCOL_VERSION, 0x00, 0, 0x22, &[])),
        Err(WireError::FlagMismatch)
    );
    // Ack with ERROR.
    assert_eq!(
        parse_packet(&raw_frame(PROTOCOL_VERSION, 0x04, 0, 0x81, &[0x22])),
        Err(WireError::FlagMismatch)
    );
    // Reply to a request keeps its seq.
    let req = Packet::request(77, Message::Start);
    assert_eq!(req.header.flags, Flags::WRITE | Flags::REPLY_WANTED);
    let rep = Packet::reply(&req.header, nak);
    assert_eq!(rep.header.seq, 77);
    assert_eq!(rep.header.flags, Flags::ERROR);
}

#[test]
fn frame_level_errors() {
    let good = raw_frame(PROTOCOL_VERSION, 0x02, 5, 0x32, &[]);
    assert_eq!(
        parse_packet(&good).map(|(h, m)| (h.seq, m)),
        Ok((5, Message::GetStatus))
    );
    assert_eq!(parse_packet(&good[..9]), Err(WireError::Truncated));
    assert_eq!(parse_packet(&[]), Err(WireError::Truncated));
    let mut bad = good.clone();
    bad[2] ^= 0x40;
    assert_eq!(parse_packet(&bad), Err(WireError::Crc));
    assert_eq!(
        parse_packet(&raw_frame(1, 0x02, 5, 0x32, &[])),
        Err(WireError::Version(1))
    );
    assert_eq!(
        parse_packet(&raw_frame(PROTOCOL_VERSION, 0x42, 5, 0x32, &[])),
        Err(WireError::ReservedFlags)
    );
    assert_eq!(
        parse_packet(&raw_frame(PROTOCOL_VERSION, 0x02, 5, 0x7F, &[])),
        Err(WireError::UnknownCommand(0x7F))
    );
    assert_eq!(
        parse_packet(&raw_frame(PROTOCOL_VERSION, 0x02, 5, 0x32, &[0])),
        Err(WireError::TrailingBytes)
    );
    // Ack body is one byte: two is trailing, zero is a decode failure.
    assert_eq!(
        parse_packet(&raw_frame(PROTOCOL_VERSION, 0x00, 5, 0x81, &[1, 2])),
        Err(WireError::TrailingBytes)
    );
    assert_eq!(
        parse_packet(&raw_frame(PROTOCOL_VERSION, 0x00, 5, 0x81, &[])),
        Err(WireError::Payload)
    );
    // bool must be 0 or 1 (ConfigureSequence.repeat).
    let mut seq = vec![0x00, 0x02, 0x0C];
    seq.extend([0, 0, 1, 0, 0, 0, 0, 0, 0, 0, 8, 0]);
    assert_eq!(
        parse_packet(&raw_frame(PROTOCOL_VERSION, 0x01, 0, 0x20, &seq)),
        Err(WireError::Payload)
    );
    seq[1] = 1;
    assert!(parse_packet(&raw_frame(PROTOCOL_VERSION, 0x01, 0, 0x20, &seq)).is_ok());
    // Enum index out of range (ScanOutput [3], EdgeFilterMode [2]).
    assert_eq!(
        parse_packet(&raw_frame(
            PROTOCOL_VERSION,
            0x01,
            0,
            0x30,
            &[7, 3, 0, 0, 0]
        )),
        Err(WireError::Payload)
    );
    assert_eq!(
        parse_packet(&raw_frame(
            PROTOCOL_VERSION,
            0x01,
            0,
            0x30,
            &[7, 1, 0, 0, 2]
        )),
        Err(WireError::Payload)
    );
    // A version-1 Scan body (no edge-filter field, no scan id) is a truncated version-3 body.
    assert_eq!(
        parse_packet(&raw_frame(PROTOCOL_VERSION, 0x01, 0, 0x30, &[1, 0, 0])),
        Err(WireError::Payload)
    );
    // So is a version-2 body (no scan id): Points, rows 0.., filter Off.
    assert_eq!(
        parse_packet(&raw_frame(PROTOCOL_VERSION, 0x01, 0, 0x30, &[1, 0, 0, 0])),
        Err(WireError::Payload)
    );
    // Header length disagreeing with the frame, with a valid CRC.
    let mut f = vec![PROTOCOL_VERSION, 0x02, 5, 0x32, 1, 0];
    let c = crc32c(&f);
    f.extend(c.to_le_bytes());
    assert_eq!(parse_packet(&f), Err(WireError::Length));
    // Message::decode bounds the payload.
    assert_eq!(
        Message::decode(0x32, &[0u8; MAX_PAYLOAD + 1]),
        Err(WireError::PayloadTooLarge)
    );
    // frame::emit bounds the payload and the buffer.
    let h = Header::for_message(&Message::GetStatus, 0);
    assert_eq!(
        frame::emit(&h, &[0u8; MAX_PAYLOAD + 1], &mut [0u8; 5000]),
        Err(WireError::PayloadTooLarge)
    );
    assert_eq!(
        frame::emit(&h, &[1, 2], &mut [0u8; 11]),
        Err(WireError::BufferTooSmall)
    );
    let mut out = [0u8; 12];
    assert_eq!(frame::emit(&h, &[1, 2], &mut out), Ok(12));
    assert_eq!(
        frame::parse(&out).map(|(h, p)| (h.payload_len, p)),
        Ok((2, &[1u8, 2][..]))
    );
}

#[test]
fn emit_buffer_limits() {
    let data = vec![9u8; 1000];
    let msg = Message::UploadChunk(UploadChunk::new(UploadTarget::PatternSet(0), 0, &data));
    let h = Packet::request(0, msg).header;
    let mut out = [0u8; MAX_ENCODED_FRAME];
    let payload_len = msg.encode(&mut [0u8; MAX_PAYLOAD]).unwrap();
    let need = HEADER_LEN + payload_len + 4;
    // Scratch too small for the header, the payload, the CRC.
    for len in [0, 5, 500, need - 4, need - 1] {
        let mut scratch = vec![0u8; len];
        assert_eq!(
            emit_packet(&h, &msg, &mut scratch, &mut out),
            Err(WireError::BufferTooSmall),
            "scratch {len}"
        );
    }
    let mut scratch = vec![0u8; need];
    let n = emit_packet(&h, &msg, &mut scratch, &mut out).unwrap();
    // Output too small by one.
    let mut small = vec![0u8; n - 1];
    assert_eq!(
        emit_packet(&h, &msg, &mut scratch, &mut small),
        Err(WireError::BufferTooSmall)
    );
    let mut exact = vec![0u8; n];
    assert_eq!(emit_packet(&h, &msg, &mut scratch, &mut exact), Ok(n));
    // Header flags cannot carry reserved bits.
    assert_eq!(
        Flags::from_bits(0x0B),
        Some(Flags::WRITE | Flags::REPLY_WANTED | Flags::MORE_FOLLOWS)
    );
    assert_eq!(Flags::from_bits(0x1B), None);
}

#[test]
fn error_classes_and_naks() {
    use WireErrorKind as K;
    let table = [
        (WireError::BufferTooSmall, K::Buffer, NakCode::Internal),
        (WireError::Truncated, K::Framing, NakCode::Framing),
        (WireError::Cobs, K::Framing, NakCode::Framing),
        (WireError::Overflow, K::Framing, NakCode::Framing),
        (WireError::Crc, K::Integrity, NakCode::Crc),
        (WireError::Version(3), K::Unsupported, NakCode::Version),
        (
            WireError::UnknownCommand(9),
            K::Unsupported,
            NakCode::UnknownCommand,
        ),
        (WireError::ReservedFlags, K::Malformed, NakCode::Malformed),
        (WireError::Length, K::Malformed, NakCode::Framing),
        (WireError::PayloadTooLarge, K::Malformed, NakCode::Internal),
        (WireError::FlagMismatch, K::Malformed, NakCode::Malformed),
        (WireError::CommandMismatch, K::Malformed, NakCode::Malformed),
        (WireError::Payload, K::Malformed, NakCode::Malformed),
        (WireError::TrailingBytes, K::Malformed, NakCode::Malformed),
        (
            WireError::Invalid(Invalid::ChunkCrc),
            K::Invalid,
            NakCode::Invalid,
        ),
    ];
    for (e, kind, code) in table {
        assert_eq!(e.kind(), kind, "{e:?}");
        assert_eq!(
            e.kind().is_transient(),
            matches!(kind, K::Framing | K::Integrity)
        );
        let nak = Nak::for_error(0x12, e);
        assert_eq!(nak.code, code, "{e:?}");
        assert_eq!(nak.command, 0x12);
        assert!(!format!("{e}").is_empty());
    }
    let nak = Nak::for_error(0x12, WireError::Invalid(Invalid::ChunkCrc));
    assert_eq!(nak.detail, 12);
    assert_eq!(Invalid::from_u8(nak.detail as u8), Some(Invalid::ChunkCrc));
    assert_eq!(
        WireError::from(Invalid::Scale),
        WireError::Invalid(Invalid::Scale)
    );
    assert_eq!(
        format!("{}", WireError::Invalid(Invalid::Scale)),
        "invalid field: scale"
    );
}
