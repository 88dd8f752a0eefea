//! Property tests of the wire layer: arbitrary bytes never panic any parser or the stream decoder;
//! arbitrary valid messages round-trip; damaged lines never deliver a frame that was not sent.

use fringe3d_core::Validity;
use fringe3d_core::reconstruct::{MAX_MARGIN, Margin};
use fringe3d_core::wire::*;
use proptest::prelude::*;

// ------------------------------------------------------------------------------------------------
// Random valid messages

fn finite(r: &mut XorShift64) -> f64 {
    loop {
        let x = f64::from_bits(r.next_u64());
        if x.is_finite() {
            return x;
        }
    }
}

fn positive(r: &mut XorShift64) -> f64 {
    (1 + r.below(100_000)) as f64 / 64.0
}

fn target(r: &mut XorShift64) -> UploadTarget {
    match r.below(3) {
        0 => UploadTarget::PatternSet(r.next_u32() as u8),
        1 => UploadTarget::PhaseMap,
        _ => UploadTarget::Compiled,
    }
}

fn pattern_set(r: &mut XorShift64) -> PatternSetDesc {
    let bit_depth = 1 + r.below(8) as u8;
    let full = (1u32 << bit_depth) - 1;
    let axis = if r.below(2) == 0 {
        PatternAxis::Xi
    } else {
        PatternAxis::Eta
    };
    let profile = if r.below(2) == 0 {
        PhaseProfile::Linear {
            origin: finite(r),
            slope: positive(r),
        }
    } else {
        let count = 2 + r.below(MAX_KNOTS as u32 - 1) as u8;
        let mut k = Knots {
            count,
            s: [0.0; MAX_KNOTS],
            phi: [0.0; MAX_KNOTS],
            slope: [0.0; MAX_KNOTS],
        };
        for i in 0..count as usize {
            k.s[i] = finite(r);
            k.phi[i] = finite(r);
            k.slope[i] = finite(r);
        }
        PhaseProfile::Knots(k)
    };
    let level_count = 1 + r.below(MAX_LEVELS as u32) as u8;
    let mut levels = [Level::UNUSED; MAX_LEVELS];
    for l in levels.iter_mut().take(level_count as usize) {
        let shifts = if r.below(2) == 0 {
            let n = 1 + r.below(MAX_SHIFTS as u32) as u8;
            Shifts::Uniform {
                n,
                count: 1 + r.below(n as u32) as u8,
            }
        } else if r.below(4) == 0 {
            // Gray-code levels, plain, inverse or shifted (the wire's field checks only).
            let complementary = r.below(2) == 0;
            match r.below(3) {
                0 => Shifts::Gray {
                    bits: 1 + r.below(10) as u8,
                    complementary,
                },
                1 => Shifts::GrayInverse {
                    bits: 1 + r.below(7) as u8,
                    complementary,
                },
                _ => {
                    let inverse = r.below(2) == 0;
                    Shifts::GrayShifted {
                        bits: 1 + r.below(if inverse { 8 } else { 10 }) as u8,
                        inverse,
                    }
                }
            }
        } else {
            let count = 1 + r.below(MAX_SHIFTS as u32) as u8;
            let mut radians = [0.0; MAX_SHIFTS];
            for x in radians.iter_mut().take(count as usize) {
                *x = finite(r);
            }
            Shifts::Explicit { count, radians }
        };
        *l = Level {
            scale: positive(r),
            shifts,
        };
    }
    let i_max = (1 + r.below(full * 16)) as f64 / 16.0;
    PatternSetDesc {
        width: 1 + r.below(65535) as u16,
        height: 1 + r.below(65535) as u16,
        bit_depth,
        i_min: i_max * r.below(1000) as f64 / 1000.0,
        i_max,
        waveform: match r.below(6) {
            0 => Waveform::Sine,
            1 => Waveform::Cosine,
            2 => Waveform::SquareSine,
            3 => Waveform::SquareCosine,
            4 => Waveform::BayerSine,
            _ => Waveform::BayerCosine,
        },
        phase_offset: finite(r),
        phase: PhaseDesc {
            axis,
            profile,
            curvature: finite(r),
            bend_center: finite(r),
        },
        level_count,
        levels,
        relation: match r.below(3) {
            0 => Relation::Hierarchical,
            1 => Relation::Heterodyne,
            _ => Relation::Coprime,
        },
    }
}

fn calibration(r: &mut XorShift64) -> Calibration {
    let mut f3 = || [finite(r), finite(r), finite(r)];
    let projector_centre = f3();
    let plane_point = f3();
    let mut plane_normal = f3();
    if plane_normal.iter().all(|&x| x == 0.0) {
        plane_normal[2] = 1.0;
    }
    let depth_min = r.below(2_000_000) as f64 / 1024.0 - 1000.0;
    Calibration {
        camera: CameraParams {
            width: 1 + r.below(65535),
            height: 1 + r.below(65535),
            fx: positive(r),
            fy: positive(r),
            cx: finite(r),
            cy: finite(r),
            skew: finite(r),
            distortion: [finite(r), finite(r), finite(r), finite(r), finite(r)].into(),
        },
        geometry: ScanGeometry {
            projector_centre,
            plane_point,
            plane_normal,
            depth_min,
            depth_max: depth_min + 1.0 + r.below(1000) as f64 / 3.0,
        },
    }
}

/// A random valid message of a random kind (`kind` picks the variant when given). Bulk data
/// borrows `data` (chunks, non-empty) or `buf` (rows, trigger tables).
fn random_message<'a>(
    r: &mut XorShift64,
    kind: Option<u32>,
    data: &'a [u8],
    buf: &'a mut [u8],
) -> Message<'a> {
    let kind = kind.unwrap_or_else(|| r.below(Command::ALL.len() as u32));
    match Command::ALL[kind as usize % Command::ALL.len()] {
        Command::Hello => Message::Hello(Hello {
            protocol_version: r.next_u32() as u8,
        }),
        Command::DefinePatternSet => Message::DefinePatternSet(DefinePatternSet {
            set_id: r.next_u32() as u8,
            desc: pattern_set(r),
        }),
        Command::BeginUpload => {
            let (c, w, h) = (1 + r.below(64), 1 + r.below(4096), 1 + r.below(4096));
            Message::BeginUpload(BeginUpload {
                set_id: r.next_u32() as u8,
                image_count: c as u16,
                width: w as u16,
                height: h as u16,
                bit_depth: 1 + r.below(8) as u8,
                total_bytes: c * w * h,
                digest: r.next_u32(),
            })
        }
        Command::UploadChunk => {
            let data = &data[..data.len().clamp(1, MAX_CHUNK)];
            let offset = r.next_u32() % (u32::MAX - data.len() as u32);
            Message::UploadChunk(UploadChunk::new(target(r), offset, data))
        }
        Command::QueryUpload => Message::QueryUpload(target(r)),
        Command::ConfirmUpload => Message::ConfirmUpload(target(r)),
        Command::DefineCorrection => {
            let levels = 1 + r.below(MAX_LEVELS as u32) as u8;
            let m = fringe3d_core::decode::PhaseCorrection::MAX_DELTA as u32;
            let mut knots = [[0i16; 32]; MAX_LEVELS];
            for k in knots.iter_mut().take(levels as usize).flatten() {
                *k = (r.below(2 * m + 1) as i32 - m as i32) as i16;
            }
            let table = SetupCorrection { levels, knots };
            Message::DefineCorrection(DefineCorrection {
                set_id: r.next_u32() as u8,
                table: (r.below(2) == 0).then_some(table),
            })
        }
        Command::DefineThresholds => {
            let mut v = |scale: f32| (r.below(1 << 20) as f32) * scale;
            let t = DecodeThresholds {
                dark_level: v(0.01),
                saturation_level: 1.0 + v(0.06),
                min_modulation: v(0.01),
                // Below π: 2^20 · 2.99e-6 = 3.135 (3.0e-6 reached 3.146 > π, refused).
                unwrap_tolerance: v(2.99e-6),
                range_tolerance: v(1.0e-6),
            };
            Message::DefineThresholds(DefineThresholds {
                set_id: r.next_u32() as u8,
                thresholds: (r.below(2) == 0).then_some(t),
            })
        }
        Command::UploadCalibration => Message::UploadCalibration(calibration(r)),
        Command::BeginPhaseMapUpload => {
            let (w, h) = (1 + r.below(20_000), 1 + r.below(20_000));
            let mut side = || r.below(MAX_MARGIN + 1);
            let margin = Margin::from_array([side(), side(), side(), side()]);
            let (mw, mh) = (
                w + margin.left + margin.right,
                h + margin.top + margin.bottom,
            );
            Message::BeginPhaseMapUpload(BeginPhaseMap {
                width: w as u16,
                height: h as u16,
                margin,
                total_bytes: mw * mh * PHASE_MAP_BYTES_PER_PIXEL as u32,
                digest: r.next_u32(),
            })
        }
        Command::BeginCompiledUpload => {
            let (w, h) = (1 + r.below(300), 1 + r.below(300));
            let z_min = positive(r) as f32;
            Message::BeginCompiledUpload(BeginCompiled {
                width: w as u16,
                height: h as u16,
                z_min,
                z_max: z_min + positive(r) as f32,
                total_bytes: w * h * COMPILED_BYTES_PER_PIXEL as u32,
                digest: r.next_u32(),
            })
        }
        Command::ConfigureSequence => {
            let n = 1 + r.below(MAX_LUT_ENTRIES as u32) as usize;
            let entries: Vec<LutEntry> = (0..n)
                .map(|_| LutEntry {
                    pattern: r.next_u32() as u16,
                    exposure_us: 1 + r.below(u32::MAX - 1),
                    dark_us: r.next_u32(),
                    bit_depth: 1 + r.below(8) as u8,
                    wait_for_trigger: r.below(2) == 0,
                    trigger_out: r.below(2) == 0,
                })
                .collect();
            Message::ConfigureSequence(Sequence {
                set_id: r.next_u32() as u8,
                repeat: r.below(2) == 0,
                entries: LutTable::encode(&entries, buf).unwrap(),
            })
        }
        Command::ValidateSequence => Message::ValidateSequence,
        Command::Start => Message::Start,
        Command::Stop => Message::Stop,
        Command::Scan => Message::Scan(ScanRequest {
            scan_id: r.next_u32(),
            output: [ScanOutput::Phase, ScanOutput::Points, ScanOutput::Both][r.below(3) as usize],
            first_row: r.next_u32() as u16,
            row_count: r.next_u32() as u16,
            edge_filter: if r.below(2) == 0 {
                EdgeFilterMode::Off
            } else {
                EdgeFilterMode::MaxAngle((1 + r.below(89_999)) as f64 / 1000.0)
            },
            exposures: {
                // 0 to 4 exposures in 1 ..= MAX_EXPOSURE_US, longest first, distinct.
                let mut us: Vec<u32> = (0..r.below(5))
                    .map(|_| 1 + r.below(MAX_EXPOSURE_US))
                    .collect();
                us.sort_unstable_by(|a, b| b.cmp(a));
                us.dedup();
                Exposures::new(&us).unwrap()
            },
        }),
        Command::Abort => Message::Abort,
        Command::GetStatus => Message::GetStatus,
        Command::Capabilities => Message::Capabilities(Capabilities {
            protocol_version: r.next_u32() as u8,
            firmware: FirmwareVersion {
                major: r.next_u32() as u8,
                minor: r.next_u32() as u8,
                patch: r.next_u32() as u8,
            },
            sensor_width: r.next_u32() as u16,
            sensor_height: r.next_u32() as u16,
            projector_width: r.next_u32() as u16,
            projector_height: r.next_u32() as u16,
            free_memory: r.next_u32(),
            max_chunk: 1 + r.below(MAX_CHUNK as u32) as u16,
            max_sets: r.next_u32() as u8,
            max_lut_entries: 1 + r.below(MAX_LUT_ENTRIES as u32) as u16,
        }),
        Command::Ack => Message::Ack(Ack {
            command: r.next_u32() as u8,
        }),
        Command::Nak => {
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
            Message::Nak(Nak {
                command: r.next_u32() as u8,
                code: codes[r.below(codes.len() as u32) as usize],
                detail: r.next_u32() as u16,
            })
        }
        Command::UploadAck => Message::UploadAck(UploadAck {
            target: target(r),
            next_offset: r.next_u32(),
        }),
        Command::Validation => {
            Message::Validation(ValidationStatus(r.next_u32() & ValidationStatus::ALL))
        }
        Command::Status => {
            let states = [
                HeadState::Idle,
                HeadState::Uploading,
                HeadState::Ready,
                HeadState::Running,
                HeadState::Scanning,
                HeadState::Fault,
            ];
            Message::Status(Status {
                state: states[r.below(6) as usize],
                errors: HeadErrors(r.next_u32() & HeadErrors::ALL),
                rx_frames: r.next_u32(),
                rx_errors: r.next_u32(),
                tx_frames: r.next_u32(),
                rows_sent: r.next_u32(),
                holds: Holds(r.next_u32() & Holds::ALL),
            })
        }
        Command::ResultRow => {
            let kind = if r.below(2) == 0 {
                RowKind::Phase
            } else {
                RowKind::Points
            };
            let n = 1 + r.below((MAX_ROW_DATA / kind.stride()) as u32) as usize;
            let first_col = r.below(65536 - n as u32) as u16;
            let len = n * kind.stride();
            let vals = n * 4 * kind.components();
            // Any bit patterns for the values (NaNs included: the row is bytes).
            for b in buf[..vals].iter_mut() {
                *b = r.next_u32() as u8;
            }
            for b in buf[vals..len].iter_mut() {
                *b = Validity::ALL[r.below(Validity::ALL.len() as u32) as usize] as u8;
            }
            Message::ResultRow(ResultRow {
                scan_id: r.next_u32(),
                row: r.next_u32() as u16,
                first_col,
                kind,
                data: &buf[..len],
            })
        }
        Command::ScanDone => {
            // Counts that agree (ScanDone::validate): valid and searched at most decoded.
            let decoded = r.next_u32();
            let mut at_most = |n: u32| (r.next_u64() % (u64::from(n) + 1)) as u32;
            let (valid, searched) = (at_most(decoded), at_most(decoded));
            Message::ScanDone(ScanDone {
                scan_id: r.next_u32(),
                rows: r.next_u32() as u16,
                valid,
                decoded,
                searched,
            })
        }
    }
}

fn random_header(r: &mut XorShift64, msg: &Message<'_>) -> Header {
    let h = Header::for_message(msg, r.next_u32() as u8);
    let mut flags = h.flags;
    flags = flags.with(Flags::REPLY_WANTED, r.below(2) == 0);
    flags = flags.with(Flags::MORE_FOLLOWS, r.below(2) == 0);
    Header { flags, ..h }
}

/// Every variant at least once, many times over, outside proptest (cheap and exhaustive).
#[test]
fn every_variant_round_trips() {
    let data: Vec<u8> = (0..MAX_CHUNK as u32).map(|i| (i * 13 % 7) as u8).collect();
    let mut buf = vec![0u8; MAX_PAYLOAD];
    let mut scratch = vec![0u8; MAX_FRAME];
    let mut out = vec![0u8; MAX_ENCODED_FRAME];
    let mut r = XorShift64::new(1);
    for i in 0..(Command::ALL.len() as u32 * 200) {
        let kind = i % Command::ALL.len() as u32;
        let len = 1 + r.below(MAX_CHUNK as u32) as usize;
        let msg = random_message(&mut r, Some(kind), &data[..len], &mut buf);
        assert_eq!(msg.command(), Command::ALL[kind as usize]);
        let h = random_header(&mut r, &msg);
        let n = emit_packet(&h, &msg, &mut scratch, &mut out).unwrap();
        assert!(n <= MAX_ENCODED_FRAME);
        let mut frame = out[..n - 1].to_vec();
        let m = cobs::decode_in_place(&mut frame).unwrap();
        let (h2, msg2) = parse_packet(&frame[..m]).unwrap();
        assert_eq!(msg2, msg);
        assert_eq!(h2.flags, h.flags);
        assert_eq!(h2.seq, h.seq);
    }
}

// ------------------------------------------------------------------------------------------------
// Properties

proptest! {
    #[test]
    fn cobs_round_trips(data in prop::collection::vec(any::<u8>(), 0..3000)) {
        let mut enc = vec![0u8; cobs::max_encoded_len(data.len())];
        let n = cobs::encode(&data, &mut enc).unwrap();
        prop_assert!(!enc[..n].contains(&0));
        prop_assert!(n <= data.len() + data.len().div_ceil(254).max(1));
        let mut dec = vec![0u8; n];
        let m = cobs::decode(&enc[..n], &mut dec).unwrap();
        prop_assert_eq!(&dec[..m], &data[..]);
        let mut inplace = enc[..n].to_vec();
        let m = cobs::decode_in_place(&mut inplace).unwrap();
        prop_assert_eq!(&inplace[..m], &data[..]);
    }

    #[test]
    fn cobs_decode_arbitrary_never_panics(data in prop::collection::vec(any::<u8>(), 0..1000)) {
        let mut out = vec![0u8; data.len()];
        let a = cobs::decode(&data, &mut out).map(|m| out[..m].to_vec());
        let mut inplace = data.clone();
        let b = cobs::decode_in_place(&mut inplace).map(|m| inplace[..m].to_vec());
        prop_assert_eq!(&a, &b);
        // Too small an output buffer is an error, never a panic.
        let _ = cobs::decode(&data, &mut out[..data.len() / 2]);
        if let Ok(raw) = a {
            let mut enc = vec![0u8; cobs::max_encoded_len(raw.len())];
            let n = cobs::encode(&raw, &mut enc).unwrap();
            let mut back = vec![0u8; n];
            let m = cobs::decode(&enc[..n], &mut back).unwrap();
            prop_assert_eq!(&back[..m], &raw[..]);
        }
    }

    #[test]
    fn parsers_never_panic_on_arbitrary_bytes(
        data in prop::collection::vec(any::<u8>(), 0..5000),
        cmd in any::<u8>(),
        flags in any::<u8>(),
    ) {
        let _ = parse_packet(&data);
        let _ = frame::parse(&data);
        let _ = Header::parse(&data);
        let _ = Message::decode(cmd, &data);
        for c in Command::ALL {
            let _ = Message::decode(c as u8, &data[..data.len().min(600)]);
        }
        // With a valid CRC the parser reaches postcard; whatever it accepts re-emits to the same.
        let payload = &data[..data.len().min(MAX_PAYLOAD)];
        let mut f = vec![1, flags & 0x0F, 0, cmd];
        f.extend((payload.len() as u16).to_le_bytes());
        f.extend(payload);
        let c = crc::crc32c(&f);
        f.extend(c.to_le_bytes());
        if let Ok((h, m)) = parse_packet(&f) {
            let mut scratch = vec![0u8; MAX_FRAME];
            let mut out = vec![0u8; MAX_ENCODED_FRAME];
            let n = emit_packet(&h, &m, &mut scratch, &mut out).unwrap();
            let mut g = out[..n - 1].to_vec();
            let k = cobs::decode_in_place(&mut g).unwrap();
            let (h2, m2) = parse_packet(&g[..k]).unwrap();
            prop_assert_eq!(h2.flags, h.flags);
            prop_assert_eq!(m2, m);
        }
    }

    #[test]
    fn stream_decoder_never_panics(
        data in prop::collection::vec(any::<u8>(), 0..6000),
        step in 1usize..700,
        cap in 0usize..300,
    ) {
        let mut big = FrameReceiver::new([0u8; MAX_ENCODED_FRAME]);
        let mut small_buf = vec![0u8; cap];
        let mut small = FrameReceiver::new(&mut small_buf[..]);
        for dec_is_small in [false, true] {
            let mut delivered = 0u32;
            let mut errors = 0u32;
            for piece in data.chunks(step) {
                let mut rest = piece;
                while !rest.is_empty() {
                    let (used, ev) = if dec_is_small { small.feed(rest) } else { big.feed(rest) };
                    rest = &rest[used..];
                    match ev {
                        Some(Ok(f)) => {
                            prop_assert!(frame::check_crc(f).is_ok());
                            delivered += 1;
                        }
                        Some(Err(_)) => errors += 1,
                        None => {}
                    }
                }
            }
            let s = if dec_is_small { *small.stats() } else { *big.stats() };
            prop_assert_eq!(s.frames, delivered);
            prop_assert_eq!(s.errors(), errors);
            prop_assert_eq!(s.bytes as usize, data.len());
        }
    }

    #[test]
    fn random_messages_round_trip(
        seed in any::<u64>(),
        data in prop::collection::vec(any::<u8>(), 1..MAX_CHUNK + 1),
        step in 1usize..2000,
    ) {
        let mut r = XorShift64::new(seed);
        let mut buf = vec![0u8; MAX_PAYLOAD];
        let msg = random_message(&mut r, None, &data, &mut buf);
        prop_assert_eq!(msg.validate(), Ok(()));
        // Body alone.
        let mut p = vec![0u8; MAX_PAYLOAD];
        let n = msg.encode(&mut p).unwrap();
        prop_assert_eq!(Message::decode(msg.command() as u8, &p[..n]), Ok(msg));
        // Whole packet through the stream decoder.
        let h = random_header(&mut r, &msg);
        let mut scratch = vec![0u8; MAX_FRAME];
        let mut out = vec![0u8; MAX_ENCODED_FRAME];
        let n = emit_packet(&h, &msg, &mut scratch, &mut out).unwrap();
        let mut dec = FrameReceiver::new([0u8; MAX_ENCODED_FRAME]);
        let mut got = 0;
        for piece in out[..n].chunks(step) {
            let mut rest = piece;
            while !rest.is_empty() {
                let (used, ev) = dec.feed(rest);
                rest = &rest[used..];
                if let Some(ev) = ev {
                    let f = ev.unwrap();
                    let pk = Packet::parse(f).unwrap();
                    prop_assert_eq!(pk.message, msg);
                    prop_assert_eq!(pk.header, Header { payload_len: pk.header.payload_len, ..h });
                    got += 1;
                }
            }
        }
        prop_assert_eq!(got, 1);
    }

    #[test]
    fn damaged_lines_never_deliver_unsent_frames(
        seed in any::<u64>(),
        data in prop::collection::vec(any::<u8>(), 1..600),
        damage in prop::collection::vec((any::<u16>(), any::<u8>(), 0u8..4), 1..6),
    ) {
        let mut r = XorShift64::new(seed);
        let mut buf = vec![0u8; MAX_PAYLOAD];
        let mut scratch = vec![0u8; MAX_FRAME];
        let mut out = vec![0u8; MAX_ENCODED_FRAME];
        let mut line = Vec::new();
        let mut frames = Vec::new();
        for _ in 0..3 {
            let msg = random_message(&mut r, None, &data, &mut buf);
            let h = random_header(&mut r, &msg);
            let n = emit_packet(&h, &msg, &mut scratch, &mut out).unwrap();
            line.extend_from_slice(&out[..n]);
            let mut f = out[..n - 1].to_vec();
            let m = cobs::decode_in_place(&mut f).unwrap();
            f.truncate(m);
            frames.push(f);
        }
        for (pos, val, op) in damage {
            let at = pos as usize % line.len();
            match op {
                0 => line[at] ^= val.max(1),
                1 => { line.remove(at); }
                2 => line.insert(at, val),
                _ => { let b = line[at]; line.insert(at, b); }
            }
            if line.is_empty() { break; }
        }
        let mut dec = FrameReceiver::new([0u8; MAX_ENCODED_FRAME]);
        for &b in &line {
            if let Some(Ok(f)) = dec.push(b) {
                prop_assert!(frames.iter().any(|s| s[..] == *f), "unsent frame delivered");
                prop_assert!(parse_packet(f).is_ok());
            }
        }
    }

    #[test]
    fn mutated_payloads_parse_or_fail_cleanly(
        seed in any::<u64>(),
        data in prop::collection::vec(any::<u8>(), 1..300),
        edits in prop::collection::vec((any::<u16>(), any::<u8>(), 0u8..3), 1..4),
    ) {
        // A valid body with a few bytes changed, inserted or removed, under a correct CRC: the
        // parser must reach postcard and validation, and reject or accept without panicking;
        // whatever it accepts must re-emit to the same message.
        let mut r = XorShift64::new(seed);
        let mut buf = vec![0u8; MAX_PAYLOAD];
        let msg = random_message(&mut r, None, &data, &mut buf);
        let mut p = vec![0u8; MAX_PAYLOAD];
        let n = msg.encode(&mut p).unwrap();
        let mut p = p[..n].to_vec();
        for (pos, val, op) in edits {
            let at = if p.is_empty() { 0 } else { pos as usize % p.len() };
            match op {
                0 if !p.is_empty() => p[at] = val,
                1 if !p.is_empty() => { p.remove(at); }
                _ => p.insert(at, val),
            }
        }
        let cmd = msg.command();
        let flags = Header::for_message(&msg, 0).flags;
        let mut f = vec![1, flags.bits(), 0, cmd as u8];
        f.extend((p.len() as u16).to_le_bytes());
        f.extend(&p);
        let c = crc::crc32c(&f);
        f.extend(c.to_le_bytes());
        if let Ok((h, m)) = parse_packet(&f) {
            let mut scratch = vec![0u8; MAX_FRAME];
            let mut out = vec![0u8; MAX_ENCODED_FRAME];
            let n = emit_packet(&h, &m, &mut scratch, &mut out).unwrap();
            let mut g = out[..n - 1].to_vec();
            let k = cobs::decode_in_place(&mut g).unwrap();
            prop_assert_eq!(parse_packet(&g[..k]).unwrap().1, m);
        }
    }
}
