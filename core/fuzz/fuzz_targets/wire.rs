//! Arbitrary bytes into every wire parser and the stream decoder: nothing may panic, every frame
//! the decoder delivers passes its CRC, and whatever parses re-emits to the same message.
#![no_main]

use fringe3d_core::wire::*;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    // Raw parsers.
    let _ = Header::parse(data);
    let _ = frame::parse(data);
    let mut out = [0u8; MAX_ENCODED_FRAME];
    let _ = cobs::decode(data, &mut out);
    if let Some((&cmd, body)) = data.split_first() {
        let _ = Message::decode(cmd, body);
        // The same body under a correct header and CRC, so postcard and validation are reached.
        let mut f = [0u8; MAX_FRAME];
        let body = &body[..body.len().min(MAX_PAYLOAD)];
        let flags = Flags::from_bits(cmd & 0x0F).unwrap_or(Flags::NONE);
        let h = Header {
            flags,
            seq: 0,
            command: cmd,
            payload_len: 0,
        };
        if let Ok(n) = frame::emit(&h, body, &mut f) {
            if let Ok((h, m)) = parse_packet(&f[..n]) {
                let mut scratch = [0u8; MAX_FRAME];
                let k = emit_packet(&h, &m, &mut scratch, &mut out).expect("re-emit");
                let mut g = [0u8; MAX_ENCODED_FRAME];
                let j = cobs::decode(&out[..k - 1], &mut g).expect("own COBS");
                assert_eq!(parse_packet(&g[..j]).expect("re-parse").1, m);
            }
        }
    }

    // The stream decoder, fed in uneven pieces.
    let mut dec = FrameReceiver::new([0u8; MAX_ENCODED_FRAME]);
    let mut rest = data;
    let mut step = 1;
    while !rest.is_empty() {
        let piece = &rest[..step.min(rest.len())];
        rest = &rest[piece.len()..];
        step = step % 97 + 13;
        let mut p = piece;
        while !p.is_empty() {
            let (used, ev) = dec.feed(p);
            p = &p[used..];
            if let Some(Ok(f)) = ev {
                assert!(frame::check_crc(f).is_ok());
                let _ = parse_packet(f);
            }
        }
    }
});
