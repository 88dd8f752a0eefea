//! Every validation rule of the wire layer's messages (pattern sets, uploads, calibration, LUT,
//! rows, scan requests). Frame-level errors are in `wire_frame_errors.rs`.

use fringe3d_core::Validity;
use fringe3d_core::reconstruct::{MAX_MARGIN, Margin};
use fringe3d_core::wire::*;

use crate::wire_support::raw_frame;

fn invalid(why: Invalid) -> Result<(), WireError> {
    Err(WireError::Invalid(why))
}

/// `n` knots (10·i, i, 0.1), the rest of the arrays zero.
fn knots(n: usize) -> Knots {
    let mut k = Knots {
        count: n as u8,
        s: [0.0; MAX_KNOTS],
        phi: [0.0; MAX_KNOTS],
        slope: [0.0; MAX_KNOTS],
    };
    for i in 0..n {
        k.s[i] = 10.0 * i as f64;
        k.phi[i] = i as f64;
        k.slope[i] = 0.1;
    }
    k
}

fn paper_set() -> PatternSetDesc {
    let mut levels = [Level::UNUSED; MAX_LEVELS];
    levels[0] = Level {
        scale: 0.0625,
        shifts: Shifts::Uniform { n: 4, count: 2 },
    };
    levels[1] = Level {
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
                slope: 0.01,
            },
            curvature: 0.0,
            bend_center: 0.0,
        },
        level_count: 2,
        levels,
        relation: Relation::Hierarchical,
    }
}

#[test]
fn pattern_set_rules() {
    let ok = paper_set();
    assert_eq!(ok.validate(), Ok(()));
    assert_eq!(ok.pattern_count(), 6);
    assert_eq!(ok.used_levels().len(), 2);

    let cases: Vec<(PatternSetDesc, Invalid)> = vec![
        (PatternSetDesc { width: 0, ..ok }, Invalid::Dimension),
        (PatternSetDesc { height: 0, ..ok }, Invalid::Dimension),
        (PatternSetDesc { bit_depth: 0, ..ok }, Invalid::BitDepth),
        (PatternSetDesc { bit_depth: 9, ..ok }, Invalid::BitDepth),
        (PatternSetDesc { i_max: 0.0, ..ok }, Invalid::Intensity),
        (PatternSetDesc { i_max: 256.0, ..ok }, Invalid::Intensity),
        (
            PatternSetDesc {
                bit_depth: 1,
                i_max: 1.5,
                ..ok
            },
            Invalid::Intensity,
        ),
        (
            PatternSetDesc {
                i_max: f64::NAN,
                ..ok
            },
            Invalid::NotFinite,
        ),
        (
            PatternSetDesc {
                phase_offset: f64::INFINITY,
                ..ok
            },
            Invalid::NotFinite,
        ),
        (PatternSetDesc { i_min: 255.0, ..ok }, Invalid::Intensity),
        (PatternSetDesc { i_min: -1.0, ..ok }, Invalid::Intensity),
        (
            PatternSetDesc {
                phase: PhaseDesc {
                    profile: PhaseProfile::Linear {
                        origin: 0.0,
                        slope: 0.0,
                    },
                    ..ok.phase
                },
                ..ok
            },
            Invalid::PhaseFunction,
        ),
        (
            PatternSetDesc {
                phase: PhaseDesc {
                    curvature: f64::NAN,
                    ..ok.phase
                },
                ..ok
            },
            Invalid::NotFinite,
        ),
        (
            PatternSetDesc {
                phase: PhaseDesc {
                    profile: PhaseProfile::Knots(knots(1)),
                    ..ok.phase
                },
                ..ok
            },
            Invalid::PhaseFunction,
        ),
        (
            PatternSetDesc {
                phase: PhaseDesc {
                    profile: PhaseProfile::Knots(Knots {
                        count: 2,
                        ..knots(3)
                    }),
                    ..ok.phase
                },
                ..ok
            },
            Invalid::UnusedSlot,
        ),
        (
            PatternSetDesc {
                phase: PhaseDesc {
                    profile: PhaseProfile::Knots(Knots {
                        count: MAX_KNOTS as u8 + 1,
                        ..knots(3)
                    }),
                    ..ok.phase
                },
                ..ok
            },
            Invalid::PhaseFunction,
        ),
        (
            PatternSetDesc {
                level_count: 0,
                ..ok
            },
            Invalid::LevelCount,
        ),
        (
            PatternSetDesc {
                level_count: MAX_LEVELS as u8 + 1,
                ..ok
            },
            Invalid::LevelCount,
        ),
        // A third level slot is UNUSED, so using it breaks the scale rule.
        (
            PatternSetDesc {
                level_count: 3,
                ..ok
            },
            Invalid::Scale,
        ),
        // Dropping a level leaves a used slot past the count.
        (
            PatternSetDesc {
                level_count: 1,
                ..ok
            },
            Invalid::UnusedSlot,
        ),
    ];
    for (desc, why) in cases {
        assert_eq!(desc.validate(), invalid(why), "{desc:?}");
        let msg = Message::DefinePatternSet(DefinePatternSet { set_id: 0, desc });
        assert_eq!(msg.encode(&mut [0u8; 4096]), Err(WireError::Invalid(why)));
    }
    let knotted = PatternSetDesc {
        phase: PhaseDesc {
            profile: PhaseProfile::Knots(knots(3)),
            ..ok.phase
        },
        ..ok
    };
    assert_eq!(knotted.validate(), Ok(()));

    let with_level = |l: Level| {
        let mut d = ok;
        d.levels[1] = l;
        d
    };
    let mut radians = [0.0f64; MAX_SHIFTS];
    radians[1] = 1.0;
    let level_cases = [
        (
            Level {
                scale: -1.0,
                shifts: Shifts::Uniform { n: 3, count: 3 },
            },
            Invalid::Scale,
        ),
        (
            Level {
                scale: f64::NAN,
                shifts: Shifts::Uniform { n: 3, count: 3 },
            },
            Invalid::NotFinite,
        ),
        (
            Level {
                scale: 1.0,
                shifts: Shifts::Uniform { n: 3, count: 4 },
            },
            Invalid::Shifts,
        ),
        (
            Level {
                scale: 1.0,
                shifts: Shifts::Uniform { n: 0, count: 0 },
            },
            Invalid::Shifts,
        ),
        (
            Level {
                scale: 1.0,
                shifts: Shifts::Uniform { n: 17, count: 3 },
            },
            Invalid::Shifts,
        ),
        (
            Level {
                scale: 1.0,
                shifts: Shifts::Explicit { count: 0, radians },
            },
            Invalid::Shifts,
        ),
        (
            Level {
                scale: 1.0,
                shifts: Shifts::Explicit { count: 17, radians },
            },
            Invalid::Shifts,
        ),
        (
            Level {
                scale: 1.0,
                shifts: Shifts::Explicit { count: 1, radians },
            },
            Invalid::UnusedSlot,
        ),
    ];
    for (l, why) in level_cases {
        assert_eq!(with_level(l).validate(), invalid(why), "{l:?}");
    }
    let mut nan = radians;
    nan[0] = f64::NAN;
    assert_eq!(
        with_level(Level {
            scale: 1.0,
            shifts: Shifts::Explicit {
                count: 2,
                radians: nan
            }
        })
        .validate(),
        invalid(Invalid::NotFinite)
    );
    assert_eq!(
        with_level(Level {
            scale: 1.0,
            shifts: Shifts::Explicit { count: 2, radians }
        })
        .validate(),
        Ok(())
    );
    // -0.0 in an unused slot is not the canonical filler.
    let mut d = ok;
    d.levels[5].scale = -0.0;
    assert_eq!(d.validate(), invalid(Invalid::UnusedSlot));
}

#[test]
fn upload_rules() {
    let b = BeginUpload {
        set_id: 0,
        image_count: 2,
        width: 3,
        height: 4,
        bit_depth: 8,
        total_bytes: 24,
        digest: 0,
    };
    assert_eq!(b.validate(), Ok(()));
    assert_eq!(
        BeginUpload {
            total_bytes: 23,
            ..b
        }
        .validate(),
        invalid(Invalid::TotalBytes)
    );
    assert_eq!(
        BeginUpload {
            image_count: 0,
            total_bytes: 0,
            ..b
        }
        .validate(),
        invalid(Invalid::Dimension)
    );
    assert_eq!(
        BeginUpload { bit_depth: 9, ..b }.validate(),
        invalid(Invalid::BitDepth)
    );
    // 65535³ overflows u32: never equal.
    assert_eq!(
        BeginUpload {
            image_count: 65535,
            width: 65535,
            height: 65535,
            total_bytes: u32::MAX,
            ..b
        }
        .validate(),
        invalid(Invalid::TotalBytes)
    );

    let p = BeginPhaseMap {
        width: 10,
        height: 2,
        margin: Margin::ZERO,
        total_bytes: 100,
        digest: 0,
    };
    assert_eq!(p.validate(), Ok(()));
    // A map wider than the image: (3 + 10 + 1) × (2 + 2 + 0) samples of 5 bytes.
    let wide = BeginPhaseMap {
        margin: Margin::from_array([3, 2, 1, 0]),
        total_bytes: 14 * 4 * 5,
        ..p
    };
    assert_eq!(wide.validate(), Ok(()));
    assert_eq!(
        BeginPhaseMap {
            total_bytes: 100,
            ..wide
        }
        .validate(),
        invalid(Invalid::TotalBytes)
    );
    assert_eq!(
        BeginPhaseMap {
            margin: Margin::from_array([0, MAX_MARGIN + 1, 0, 0]),
            total_bytes: 10 * (2 + MAX_MARGIN + 1) * 5,
            ..p
        }
        .validate(),
        invalid(Invalid::Margin)
    );
    assert_eq!(
        BeginPhaseMap {
            total_bytes: 80,
            ..p
        }
        .validate(),
        invalid(Invalid::TotalBytes)
    );
    assert_eq!(
        BeginPhaseMap { width: 0, ..p }.validate(),
        invalid(Invalid::Dimension)
    );

    // The compiled models: 44 bytes a pixel, a finite, increasing depth range.
    let m = BeginCompiled {
        width: 10,
        height: 2,
        z_min: 450.0,
        z_max: 750.0,
        total_bytes: 10 * 2 * 44,
        digest: 0,
    };
    assert_eq!(m.validate(), Ok(()));
    assert_eq!(m.row_bytes(), 440);
    let bad = |b: BeginCompiled| b.validate();
    assert_eq!(
        bad(BeginCompiled {
            total_bytes: 10 * 2 * 5,
            ..m
        }),
        invalid(Invalid::TotalBytes)
    );
    assert_eq!(
        bad(BeginCompiled { height: 0, ..m }),
        invalid(Invalid::Dimension)
    );
    assert_eq!(
        bad(BeginCompiled { z_max: 450.0, ..m }),
        invalid(Invalid::DepthRange)
    );
    assert_eq!(
        bad(BeginCompiled {
            z_min: f32::NAN,
            ..m
        }),
        invalid(Invalid::NotFinite)
    );
    assert_eq!(
        bad(BeginCompiled {
            z_max: f32::INFINITY,
            ..m
        }),
        invalid(Invalid::NotFinite)
    );

    let data = [1u8, 2, 3];
    let c = UploadChunk::new(UploadTarget::PhaseMap, 0, &data);
    assert_eq!(c.validate(), Ok(()));
    assert_eq!(
        UploadChunk {
            crc: c.crc ^ 1,
            ..c
        }
        .validate(),
        invalid(Invalid::ChunkCrc)
    );
    assert_eq!(
        UploadChunk::new(UploadTarget::PhaseMap, 0, &[]).validate(),
        invalid(Invalid::ChunkSize)
    );
    let big = vec![7u8; MAX_CHUNK + 1];
    assert_eq!(
        UploadChunk::new(UploadTarget::PhaseMap, 0, &big).validate(),
        invalid(Invalid::ChunkSize)
    );
    assert_eq!(
        UploadChunk::new(UploadTarget::PhaseMap, 0, &big[..MAX_CHUNK]).validate(),
        Ok(())
    );
    assert_eq!(
        UploadChunk::new(UploadTarget::PhaseMap, u32::MAX - 1, &data).validate(),
        invalid(Invalid::Offset)
    );
    assert_eq!(
        UploadChunk::new(UploadTarget::PhaseMap, u32::MAX - 3, &data).validate(),
        Ok(())
    );
}

fn calibration() -> Calibration {
    Calibration {
        camera: CameraParams {
            width: 640,
            height: 480,
            fx: 800.0,
            fy: 810.0,
            cx: 320.0,
            cy: 240.0,
            skew: 0.0,
            distortion: Default::default(),
        },
        geometry: ScanGeometry {
            projector_centre: [100.0, 0.0, 0.0],
            plane_point: [0.0, 0.0, 500.0],
            plane_normal: [0.0, 0.0, 1.0],
            depth_min: 300.0,
            depth_max: 700.0,
        },
    }
}

#[test]
fn calibration_rules() {
    let ok = calibration();
    assert_eq!(ok.validate(), Ok(()));
    let mut c = ok;
    c.camera.fx = 0.0;
    assert_eq!(c.validate(), invalid(Invalid::Intrinsics));
    let mut c = ok;
    c.camera.fy = -1.0;
    assert_eq!(c.validate(), invalid(Invalid::Intrinsics));
    let mut c = ok;
    c.camera.width = 0;
    assert_eq!(c.validate(), invalid(Invalid::Dimension));
    // Sizes were u16 on the wire before the shared parameter type: the range stays.
    let mut c = ok;
    c.camera.height = 65_536;
    assert_eq!(c.validate(), invalid(Invalid::Dimension));
    let mut c = ok;
    c.camera.distortion.k3 = f64::NAN;
    assert_eq!(c.validate(), invalid(Invalid::NotFinite));
    let mut c = ok;
    c.geometry.plane_point[1] = f64::NEG_INFINITY;
    assert_eq!(c.validate(), invalid(Invalid::NotFinite));
    let mut c = ok;
    c.geometry.plane_normal = [0.0, -0.0, 0.0];
    assert_eq!(c.validate(), invalid(Invalid::PlaneNormal));
    let mut c = ok;
    c.geometry.depth_max = c.geometry.depth_min;
    assert_eq!(c.validate(), invalid(Invalid::DepthRange));
}

#[test]
fn lut_rules() {
    let e = LutEntry {
        pattern: 3,
        exposure_us: 1000,
        dark_us: 0,
        bit_depth: 8,
        wait_for_trigger: true,
        trigger_out: false,
    };
    assert_eq!(LutEntry::from_bytes(&e.to_bytes()), Ok(e));
    let mut b = e.to_bytes();
    b[11] |= 0x04;
    assert_eq!(
        LutEntry::from_bytes(&b),
        Err(WireError::Invalid(Invalid::ReservedBits))
    );
    assert_eq!(
        LutEntry {
            exposure_us: 0,
            ..e
        }
        .validate(),
        invalid(Invalid::LutEntry)
    );
    assert_eq!(
        LutEntry { bit_depth: 0, ..e }.validate(),
        invalid(Invalid::LutEntry)
    );
    let mut buf = vec![0u8; 12 * (MAX_LUT_ENTRIES + 1)];
    assert_eq!(
        LutTable::encode(&[], &mut buf).err(),
        Some(WireError::Invalid(Invalid::LutLength))
    );
    let many = vec![e; MAX_LUT_ENTRIES + 1];
    assert_eq!(
        LutTable::encode(&many, &mut buf).err(),
        Some(WireError::Invalid(Invalid::LutLength))
    );
    let t = LutTable::encode(&many[..MAX_LUT_ENTRIES], &mut buf).unwrap();
    assert_eq!(t.len(), MAX_LUT_ENTRIES);
    assert!(!t.is_empty());
    assert_eq!(t.get(MAX_LUT_ENTRIES), None);
    assert_eq!(
        LutTable::encode(&[e], &mut [0u8; 11]).err(),
        Some(WireError::BufferTooSmall)
    );
    assert_eq!(
        LutTable::new(&[0u8; 13]).err(),
        Some(WireError::Invalid(Invalid::LutLength))
    );
    // A payload whose byte string is not a whole number of entries fails to decode.
    let bad = [0x00, 0x00, 0x05, 1, 2, 3, 4, 5];
    assert_eq!(
        parse_packet(&raw_frame(PROTOCOL_VERSION, 0x01, 0, 0x20, &bad)),
        Err(WireError::Payload)
    );
    // A whole entry with bit depth 0 decodes but fails validation.
    let mut bad = vec![0x00, 0x00, 0x0C];
    bad.extend(LutEntry { bit_depth: 0, ..e }.to_bytes());
    assert_eq!(
        parse_packet(&raw_frame(PROTOCOL_VERSION, 0x01, 0, 0x20, &bad)),
        Err(WireError::Invalid(Invalid::LutEntry))
    );
}

#[test]
fn row_and_bitfield_rules() {
    let mut buf = [0u8; 64];
    let d = ResultRow::write_data(
        RowKind::Points,
        &[1.0, 2.0, 3.0],
        &[Validity::OutOfDepth],
        &mut buf,
    )
    .unwrap()
    .to_vec();
    let row = ResultRow {
        scan_id: 1,
        row: 0,
        first_col: 0,
        kind: RowKind::Points,
        data: &d,
    };
    assert_eq!(row.validate(), Ok(()));
    assert_eq!(row.value(0, 2), Some(3.0));
    assert_eq!(row.validity(0), Some(Validity::OutOfDepth));
    assert_eq!(
        ResultRow {
            kind: RowKind::Phase,
            ..row
        }
        .validate(),
        invalid(Invalid::RowData)
    );
    // The last column is 65535: one column may start there, two may not.
    assert_eq!(
        ResultRow {
            first_col: u16::MAX,
            ..row
        }
        .validate(),
        Ok(())
    );
    let mut two = [0u8; 32];
    let two = ResultRow::write_data(
        RowKind::Points,
        &[1.0, 2.0, 3.0, 4.0, 5.0, 6.0],
        &[Validity::Valid, Validity::Dark],
        &mut two,
    )
    .unwrap();
    assert_eq!(
        ResultRow {
            first_col: u16::MAX,
            data: two,
            ..row
        }
        .validate(),
        invalid(Invalid::RowData)
    );
    assert_eq!(
        ResultRow { data: &[], ..row }.validate(),
        invalid(Invalid::RowData)
    );
    let mut bad = d.clone();
    bad[12] = 200;
    assert_eq!(
        ResultRow { data: &bad, ..row }.validate(),
        invalid(Invalid::ValidityCode)
    );
    assert_eq!(
        ResultRow::write_data(RowKind::Points, &[1.0], &[Validity::Valid], &mut buf).err(),
        Some(WireError::Invalid(Invalid::RowData))
    );
    assert_eq!(
        ResultRow::write_data(RowKind::Phase, &[1.0], &[Validity::Valid], &mut [0u8; 4]).err(),
        Some(WireError::BufferTooSmall)
    );

    assert_eq!(
        ValidationStatus(1 << 13).validate(),
        invalid(Invalid::ReservedBits)
    );
    assert!(ValidationStatus::OK.is_ok());
    assert!(ValidationStatus(ValidationStatus::BUSY | 1).has(ValidationStatus::BUSY));
    assert_eq!(HeadErrors(0x100).validate(), invalid(Invalid::ReservedBits));
    // What the head holds: three bits; a Status with another is refused.
    assert_eq!(Holds(1 << 3).validate(), invalid(Invalid::ReservedBits));
    assert!(Holds(Holds::ALL).validate().is_ok());
    assert!(Holds(Holds::CALIBRATION | Holds::COMPILED).has(Holds::COMPILED));
    assert!(!Holds(Holds::CALIBRATION).has(Holds::CALIBRATION | Holds::REFERENCE));
    let st = Status {
        state: HeadState::Idle,
        errors: HeadErrors(0),
        rx_frames: 0,
        rx_errors: 0,
        tx_frames: 0,
        rows_sent: 0,
        holds: Holds(0x8),
    };
    let mut b = [0u8; 32];
    let n = postcard::to_slice(&st, &mut b).map(|s| s.len()).unwrap();
    assert_eq!(
        Message::decode(Command::Status as u8, &b[..n]),
        Err(WireError::Invalid(Invalid::ReservedBits))
    );
    let caps = Capabilities {
        protocol_version: 1,
        firmware: FirmwareVersion::default(),
        sensor_width: 1,
        sensor_height: 1,
        projector_width: 1,
        projector_height: 1,
        free_memory: 0,
        max_chunk: 0,
        max_sets: 1,
        max_lut_entries: 1,
    };
    assert_eq!(caps.validate(), invalid(Invalid::ChunkSize));
    assert_eq!(
        Capabilities {
            max_chunk: 1,
            max_lut_entries: 257,
            ..caps
        }
        .validate(),
        invalid(Invalid::LutLength)
    );
}

#[test]
fn scan_request_rules() {
    let req = |edge_filter| ScanRequest {
        scan_id: 0,
        output: ScanOutput::Points,
        first_row: 0,
        row_count: 0,
        edge_filter,
        exposures: Exposures::NONE,
    };
    assert_eq!(req(EdgeFilterMode::Off).validate(), Ok(()));
    assert_eq!(req(EdgeFilterMode::MaxAngle(80.0)).validate(), Ok(()));
    for a in [0.0, -1.0, 90.0, 180.0] {
        assert_eq!(
            req(EdgeFilterMode::MaxAngle(a)).validate(),
            invalid(Invalid::EdgeFilter),
            "{a}"
        );
        let msg = Message::Scan(req(EdgeFilterMode::MaxAngle(a)));
        assert_eq!(
            msg.encode(&mut [0u8; 64]),
            Err(WireError::Invalid(Invalid::EdgeFilter))
        );
    }
    assert_eq!(
        req(EdgeFilterMode::MaxAngle(f64::NAN)).validate(),
        invalid(Invalid::NotFinite)
    );
    // An out-of-range angle on the wire is refused on decode: scan_id 9, [1] Points, 0, 0,
    // [1] 90.0, no exposure list.
    let mut p = vec![0x09, 0x01, 0x00, 0x00, 0x01];
    p.extend(90.0f64.to_le_bytes());
    p.extend([0, 0, 0, 0, 0]);
    assert_eq!(
        Message::decode(Command::Scan as u8, &p),
        Err(WireError::Invalid(Invalid::EdgeFilter))
    );
}

/// The exposure list of an HDR scan (protocol version 8): at most four, each 1 µs to 60 s,
/// longest first and distinct; unused slots zero; refused on encode and on decode alike.
#[test]
fn scan_exposure_rules() {
    let req = |exposures| ScanRequest {
        scan_id: 0,
        output: ScanOutput::Points,
        first_row: 0,
        row_count: 0,
        edge_filter: EdgeFilterMode::Off,
        exposures,
    };
    for ok in [
        &[][..],
        &[1],
        &[MAX_EXPOSURE_US],
        &[10_000, 2_500],
        &[4, 3, 2, 1],
    ] {
        let e = Exposures::new(ok).unwrap();
        assert_eq!(e.as_slice(), ok);
        assert_eq!(e.passes(), ok.len().max(1));
        assert_eq!(req(e).validate(), Ok(()));
    }
    for bad in [
        &[0][..],
        &[MAX_EXPOSURE_US + 1],
        &[2_500, 10_000],
        &[5_000, 5_000],
        &[5, 4, 3, 2, 1],
    ] {
        assert_eq!(
            Exposures::new(bad).map(|_| ()),
            invalid(Invalid::Exposures),
            "{bad:?}"
        );
    }
    let mut e = Exposures::new(&[10_000]).unwrap();
    e.exposure_us[2] = 7;
    assert_eq!(req(e).validate(), invalid(Invalid::UnusedSlot));
    let e = Exposures {
        count: 5,
        exposure_us: [4, 3, 2, 1],
    };
    assert_eq!(req(e).validate(), invalid(Invalid::Exposures));
    assert_eq!(
        Message::Scan(req(e)).encode(&mut [0u8; 64]),
        Err(WireError::Invalid(Invalid::Exposures))
    );
    // On the wire: scan_id 9, [1] Points, 0, 0, [0] Off, then count 2, 2500 (C4 13), 10000
    // (90 4E), 0, 0: increasing, refused.
    let p = [
        0x09, 0x01, 0x00, 0x00, 0x00, 0x02, 0xC4, 0x13, 0x90, 0x4E, 0x00, 0x00,
    ];
    assert_eq!(
        Message::decode(Command::Scan as u8, &p),
        Err(WireError::Invalid(Invalid::Exposures))
    );
    let p = [
        0x09, 0x01, 0x00, 0x00, 0x00, 0x02, 0x90, 0x4E, 0xC4, 0x13, 0x00, 0x00,
    ];
    assert!(Message::decode(Command::Scan as u8, &p).is_ok());
}

#[test]
fn scan_done_counts_agree() {
    let done = ScanDone {
        scan_id: 7,
        rows: 2,
        valid: 5,
        decoded: 6,
        searched: 6,
    };
    assert_eq!(done.validate(), Ok(()));
    assert_eq!(
        ScanDone {
            searched: 7,
            ..done
        }
        .validate(),
        invalid(Invalid::Counts)
    );
    assert_eq!(
        ScanDone { valid: 7, ..done }.validate(),
        invalid(Invalid::Counts)
    );
    // On the wire: scan_id 7, rows 2, valid 5, decoded 6, searched 7 (one more than decoded).
    let body = [0x07, 0x02, 0x05, 0x06, 0x07];
    assert_eq!(
        parse_packet(&raw_frame(PROTOCOL_VERSION, 0x00, 0, 0x87, &body)),
        Err(WireError::Invalid(Invalid::Counts))
    );
    let (mut scratch, mut out) = ([0u8; 64], [0u8; 96]);
    let bad = Message::ScanDone(ScanDone {
        searched: 7,
        ..done
    });
    let header = Header::for_message(&bad, 0);
    assert_eq!(
        emit_packet(&header, &bad, &mut scratch, &mut out),
        Err(WireError::Invalid(Invalid::Counts))
    );
}
