//! The head set-up blob (`wire::setup`): a fixed byte vector, round trips that rebuild the
//! desktop's pattern set, decoder, camera model, reconstructor and edge filter exactly, every
//! named error, and a seeded fuzz of `HeadSetup::parse` on mutated blobs (never a panic).
//!
//! The byte vectors (`wire_support/setup_blobs.rs`) were laid out by hand field by field
//! (postcard rules as in wire_vectors.rs) and their CRC-32C computed with an independent bitwise
//! Python implementation, not with this crate.

use crate::wire_support::setup_blobs::*;
use fringe3d_core::camera::{CameraCheck, CameraModel};
use fringe3d_core::decode::{DecodeConfig, Decoder, PhaseCorrection};
use fringe3d_core::filter::EdgeFilter;
use fringe3d_core::geometry::Vec3;
use fringe3d_core::params::{CameraParams, Distortion};
use fringe3d_core::pattern::{self, Binarization, Convention, ImageId, Output, PatternSet};
use fringe3d_core::phase_function::{Axis, KnotProfile, PhaseFunction, Profile};
use fringe3d_core::reconstruct::{
    MAX_BAND_ROWS, MAX_MARGIN, Margin, Reconstructor, Setup, SetupAnalysis,
};
use fringe3d_core::wire::setup::{
    MAX_SETUP_BLOB, MAX_SETUP_PAYLOAD, SETUP_CRC_LEN, SETUP_HEADER_LEN,
};
use fringe3d_core::wire::*;

fn camera() -> CameraParams {
    CameraParams {
        width: 160,
        height: 128,
        fx: 200.0,
        fy: 201.0,
        cx: 79.5,
        cy: 63.5,
        skew: 1e-4,
        distortion: Distortion::from_array([0.01, -0.002, 1e-4, -2e-4, 0.0]),
    }
}

fn rig(axis: Axis) -> Setup {
    Setup {
        // Projector beside the camera across the fringes.
        projector_centre: match axis {
            Axis::Xi => Vec3::new(200.0, -10.0, 5.0),
            Axis::Eta => Vec3::new(-10.0, 200.0, 5.0),
        },
        reference_point: Vec3::new(0.0, 0.0, 700.0),
        reference_normal: Vec3::new(0.02, -0.03, -1.0),
        axis,
        z_min: 575.0,
        z_max: 825.0,
    }
}

/// The paper's set on a 16-bit projector, images captured in reverse order.
fn paper_set() -> PatternSet {
    let out = Output {
        width: 1024,
        height: 768,
        i_min: 0.0,
        i_max: 65535.0,
    };
    let set = PatternSet::default_for(Axis::Xi, out).expect("the default set");
    let mut order: Vec<ImageId> = set.order().to_vec();
    order.reverse();
    set.with_order(&order).expect("a permutation")
}

/// Knots, curved fringes, cosine, an offset and explicit shifts on an 8-bit projector.
fn odd_set() -> PatternSet {
    let out = Output {
        width: 1024,
        height: 768,
        i_min: 10.0,
        i_max: 250.0,
    };
    let k = KnotProfile::new(
        &[0.0, 300.0, 767.0],
        &[-2.8, 0.0, 2.8],
        &[0.0073, 0.0095, 0.0073],
    )
    .expect("knots");
    let f = PhaseFunction::with_profile(Axis::Eta, Profile::Knots(k))
        .and_then(|f| f.curved(1e-6, 511.5))
        .expect("phase function");
    let levels = [
        pattern::Level::with_shifts(1.0, &[0.0, 0.3, 2.0]),
        pattern::Level::two_step(6.0),
        pattern::Level::n_step(36.0, 5),
    ];
    PatternSet::new(f, &levels, out)
        .expect("set")
        .with_convention(Convention::Cosine)
        .with_phase_offset(0.25)
        .expect("offset")
}

fn frames(sample_bits: u8) -> FrameFormat {
    FrameFormat {
        width: 160,
        height: 128,
        sample_bits,
        sample_bytes: if sample_bits > 8 { 2 } else { 1 },
    }
}

fn edge() -> EdgeFilterParams {
    EdgeFilterParams {
        focal_px: 200.0,
        max_angle_deg: 80.0,
    }
}

/// Three-frequency heterodyne, periods 32/26/21-ish across the projector (beat of beats one).
fn heterodyne_set() -> PatternSet {
    let out = Output {
        width: 1024,
        height: 768,
        i_min: 0.0,
        i_max: 255.0,
    };
    let f = PhaseFunction::centered(Axis::Xi, 1024, 0.9 * std::f64::consts::TAU).expect("f");
    let levels = [21.0, 26.0, 32.0].map(|c| pattern::Level::n_step(c, 4));
    PatternSet::new_with_relation(f, &levels, out, pattern::Relation::Heterodyne)
        .expect("a heterodyne set")
}

fn head_setup(set: &PatternSet, pattern_bits: u32, sample_bits: u8) -> HeadSetup {
    HeadSetup::from_core(
        frames(sample_bits),
        set,
        pattern_bits,
        DecodeConfig::for_bit_depth(sample_bits as u32),
        &camera(),
        &rig(set.axis()),
        edge(),
    )
    .expect("a valid set-up")
}

#[test]
fn the_small_blob_is_laid_out_as_documented() {
    let s = small_setup();
    assert_eq!(emit(&s), SMALL_BLOB);
    assert_eq!(HeadSetup::parse(SMALL_BLOB), Ok(s));
    assert_eq!(
        HeadSetup::parse(&small_blob_v5()),
        Ok(s),
        "version 5 still reads, without an analysis"
    );
    assert_eq!(
        HeadSetup::parse(&small_blob_v4()),
        Ok(s),
        "version 4 still reads, as an image-sized map"
    );
    // Field 10: a shipped analysis travels as laid out, and one no analysis gives is refused.
    let shipped = HeadSetup {
        analysis: Some(small_analysis()),
        ..s
    };
    assert_eq!(emit(&shipped), small_blob_with_analysis());
    assert_eq!(HeadSetup::parse(&small_blob_with_analysis()), Ok(shipped));
    for bad in [
        SetupAnalysis {
            above: MAX_BAND_ROWS as u32,
            ..small_analysis()
        },
        SetupAnalysis {
            bisections: 31,
            ..small_analysis()
        },
        SetupAnalysis {
            max_segment_px: f32::NAN,
            ..small_analysis()
        },
        SetupAnalysis {
            reach: Margin::uniform(MAX_MARGIN + 1),
            ..small_analysis()
        },
        SetupAnalysis {
            camera: CameraCheck {
                monotonic_radius: -1.0,
                ..small_analysis().camera
            },
            ..small_analysis()
        },
        SetupAnalysis {
            camera: CameraCheck {
                max_error_f32: 0.01,
                ..small_analysis().camera
            },
            ..small_analysis()
        },
    ] {
        let s = HeadSetup {
            analysis: Some(bad),
            ..s
        };
        assert_eq!(s.validate(), Err(SetupError::Analysis), "{bad:?}");
        assert_eq!(HeadSetup::parse(&raw_blob(&s)), Err(SetupError::Analysis));
    }
    // Field 9: a reference map wider than the image (issue #17).
    let wide = s
        .with_margin(Margin::from_array([130, 1, 0, 300]))
        .expect("a margin within MAX_MARGIN");
    assert_eq!(emit(&wide), small_blob_with_margin());
    assert_eq!(HeadSetup::parse(&small_blob_with_margin()), Ok(wide));
    assert_eq!(
        HeadSetup::parse(&small_blob_v3()),
        Ok(s),
        "version 3 still reads"
    );
    assert_eq!(
        HeadSetup::parse(SMALL_BLOB_V2),
        Ok(s),
        "version 2 still reads"
    );
    assert_eq!(
        HeadSetup::parse(SMALL_BLOB_V1),
        Ok(s),
        "version 1 still reads"
    );
    // The capture order maps wire pattern indices to the core's images.
    let set = s.pattern_set().expect("a valid 3-step set");
    let shift = |k: u8| ImageId { level: 0, shift: k };
    assert_eq!(set.order(), &[shift(2), shift(0), shift(1)]);
    assert_eq!(s.image_count(), 3);
    assert!(s.decoder().is_ok());
}

#[test]
fn round_trips_rebuild_the_desktop_objects_exactly() {
    // (The binary sets: waveform values 2-5, the binarization carried with the set.)
    let square = paper_set().with_binarization(Binarization::Square);
    let bayer = odd_set().with_binarization(Binarization::Bayer);
    for (set, pattern_bits, sample_bits) in [
        (paper_set(), 16, 12),
        (odd_set(), 8, 8),
        (square, 16, 12),
        (bayer, 8, 8),
        (heterodyne_set(), 8, 8),
    ] {
        let mut s = head_setup(&set, pattern_bits, sample_bits);
        let mut table = None;
        if set.binarization().is_binary() {
            // A binary set's blob needs its phase-error table (docs/binary.md).
            let mut out = [0u8; MAX_SETUP_BLOB];
            assert_eq!(s.emit(&mut out), Err(SetupError::Correction));
            let mut t = PhaseCorrection::zero(set.levels().len() as u8);
            t.delta[set.levels().len() - 1][3] = 77;
            s = s.with_correction(&t).expect("table");
            table = Some(t);
        }
        let blob = emit(&s);
        assert!(blob.len() <= MAX_SETUP_BLOB);
        let back = HeadSetup::parse(&blob).expect("parse");
        assert_eq!(back, s);
        // Every object the head builds is the desktop's.
        let cfg = DecodeConfig::for_bit_depth(sample_bits as u32);
        assert_eq!(back.pattern_set(), Ok(set));
        assert_eq!(back.image_count(), set.image_count());
        let mut want = Decoder::new(&set, cfg).expect("decoder");
        if let Some(t) = &table {
            want = want.with_correction(t).expect("table");
        }
        assert_eq!(back.decoder(), Ok(want));
        let cam = CameraModel::new(camera()).expect("camera");
        assert_eq!(back.camera_model(), Ok(cam));
        assert_eq!(back.setup(), rig(set.axis()));
        let recon = Reconstructor::new(&cam, &rig(set.axis())).expect("reconstructor");
        assert_eq!(back.reconstructor(), Ok(recon));
        assert_eq!(
            back.edge_filter(),
            Ok(EdgeFilter::new(200.0, 80.0).expect("filter"))
        );
        // The same set-up gives the same bytes.
        assert_eq!(emit(&back), blob);
        // With a reference map wider than the image: the desktop's reconstructor for it.
        let m = Margin::from_array([40, 3, 17, 9]);
        let wide = HeadSetup::parse(&emit(&s.with_margin(m).expect("margin"))).expect("parse");
        assert_eq!(wide.reconstructor().ok(), recon.with_margin(m).ok());
        assert_eq!(wide.reconstructor().map(|r| r.map_width()), Ok(160 + 57));
        // With the analysis shipped (field 10): the same reconstructors, built without it.
        for (setup, want) in [
            (s, Ok(recon)),
            (s.with_margin(m).expect("margin"), recon.with_margin(m)),
        ] {
            let shipped = setup.with_analysis().expect("analysis");
            let a = shipped.analysis.expect("field 10 filled");
            assert_eq!(Ok(a), want.map(|r| r.analysis()));
            let back = HeadSetup::parse(&emit(&shipped)).expect("parse");
            assert_eq!(back.analysis, Some(a));
            assert_eq!(back.reconstructor().ok(), want.ok());
        }
        // A margin changed after the analysis drops it (it was for the old margin).
        let s2 = s
            .with_analysis()
            .expect("analysis")
            .with_margin(m)
            .expect("margin");
        assert_eq!(s2.analysis, None);
    }
}

#[test]
fn emit_needs_room() {
    let s = small_setup();
    let mut out = [0u8; 363];
    assert_eq!(s.emit(&mut out), Ok(363));
    for n in [0, 11, 12, 100, 362] {
        let mut short = vec![0u8; n];
        assert_eq!(
            s.emit(&mut short),
            Err(SetupError::BufferTooSmall),
            "{n} bytes"
        );
    }
}

#[test]
fn header_errors_are_named() {
    let good = SMALL_BLOB.to_vec();
    let with = |f: &dyn Fn(&mut Vec<u8>)| {
        let mut b = good.clone();
        f(&mut b);
        HeadSetup::parse(&b)
    };
    assert_eq!(HeadSetup::parse(&good[..11]), Err(SetupError::Truncated));
    assert_eq!(HeadSetup::parse(&[]), Err(SetupError::Truncated));
    assert_eq!(with(&|b| b[0] = b'G'), Err(SetupError::Magic));
    assert_eq!(with(&|b| b[4] = 7), Err(SetupError::Version(7)));
    assert_eq!(with(&|b| b[4] = 0), Err(SetupError::Version(0)));
    assert_eq!(with(&|b| b[5] = 1), Err(SetupError::Reserved));
    assert_eq!(with(&|b| b[6] += 1), Err(SetupError::Length));
    assert_eq!(with(&|b| b.push(0)), Err(SetupError::Length));
    assert_eq!(with(&|b| b[7] = 0x10), Err(SetupError::Length)); // 4185 > MAX_SETUP_PAYLOAD
    assert_eq!(with(&|b| b[40] ^= 1), Err(SetupError::Crc));
    assert_eq!(with(&|b| b[362] ^= 0x80), Err(SetupError::Crc));
    // Past the CRC: a byte too many, and a payload that is not a set-up.
    let payload = &good[SETUP_HEADER_LEN..good.len() - SETUP_CRC_LEN];
    let mut longer = payload.to_vec();
    longer.push(0);
    assert_eq!(
        HeadSetup::parse(&seal(&longer)),
        Err(SetupError::TrailingBytes)
    );
    assert_eq!(
        HeadSetup::parse(&seal(&payload[..payload.len() - 1])),
        Err(SetupError::Payload)
    );
    let mut bad_enum = payload.to_vec();
    bad_enum[4 + 3 + 16] = 7; // waveform variant 7
    assert_eq!(HeadSetup::parse(&seal(&bad_enum)), Err(SetupError::Payload));
}

#[test]
fn field_errors_are_named_on_both_ends() {
    type Edit = fn(&mut HeadSetup);
    let cases: &[(Edit, SetupError)] = &[
        (|s| s.frames.sample_bits = 17, SetupError::FrameFormat),
        (|s| s.frames.sample_bytes = 3, SetupError::FrameFormat),
        (|s| s.frames.sample_bits = 0, SetupError::FrameFormat),
        (|s| s.frames.width = 5, SetupError::ImageSize),
        (|s| s.calibration.camera.height = 4, SetupError::ImageSize),
        (
            |s| s.capture_order.patterns[1] = 2,
            SetupError::CaptureOrder,
        ),
        (
            |s| s.capture_order.patterns[2] = 3,
            SetupError::CaptureOrder,
        ),
        (
            |s| s.capture_order.patterns[5] = 1,
            SetupError::CaptureOrder,
        ),
        (|s| s.capture_order.count = 2, SetupError::CaptureOrder),
        (|s| s.capture_order.count = 40, SetupError::CaptureOrder),
        (
            |s| s.thresholds.dark_level = f32::NAN,
            SetupError::Thresholds,
        ),
        (
            |s| s.thresholds.min_modulation = -1.0,
            SetupError::Thresholds,
        ),
        (
            |s| s.thresholds.unwrap_tolerance = 3.5,
            SetupError::Thresholds,
        ),
        (
            |s| s.thresholds.saturation_level = 0.0,
            SetupError::Thresholds,
        ),
        (
            |s| s.edge_filter.max_angle_deg = 90.0,
            SetupError::EdgeFilter,
        ),
        (
            |s| s.edge_filter.focal_px = f64::INFINITY,
            SetupError::EdgeFilter,
        ),
        (|s| s.edge_filter.focal_px = 0.0, SetupError::EdgeFilter),
        (
            |s| s.patterns.bit_depth = 17,
            SetupError::Invalid(Invalid::BitDepth),
        ),
        (
            |s| s.patterns.i_max = 300.0,
            SetupError::Invalid(Invalid::Intensity),
        ),
        (
            |s| s.calibration.geometry.depth_min = 1000.0,
            SetupError::Invalid(Invalid::DepthRange),
        ),
        (
            |s| s.calibration.camera.fx = f64::NAN,
            SetupError::Invalid(Invalid::NotFinite),
        ),
        (
            |s| s.margin.bottom = MAX_MARGIN + 1,
            SetupError::Invalid(Invalid::Margin),
        ),
    ];
    for (i, (edit, want)) in cases.iter().enumerate() {
        let mut s = small_setup();
        edit(&mut s);
        assert_eq!(s.validate(), Err(*want), "case {i}");
        let mut out = [0u8; MAX_SETUP_BLOB];
        assert_eq!(s.emit(&mut out), Err(*want), "case {i}: emit");
        // Unused entries do not travel (version 3 writes `count` indices): a set-up whose only
        // fault lies there reads back as the valid one.
        let mut clean = s;
        let n = clean.capture_order.count as usize;
        if let Some(unused) = clean.capture_order.patterns.get_mut(n..) {
            unused.fill(0);
        }
        if clean.validate().is_ok() {
            assert_eq!(HeadSetup::parse(&raw_blob(&s)), Ok(clean), "case {i}");
            continue;
        }
        assert_eq!(
            HeadSetup::parse(&raw_blob(&s)),
            Err(*want),
            "case {i}: parse"
        );
    }
    // A 16-bit projector is fine in a set-up (not in a DefinePatternSet).
    let mut s = small_setup();
    s.patterns.bit_depth = 16;
    s.patterns.i_max = 65535.0;
    assert_eq!(HeadSetup::parse(&raw_blob(&s)), Ok(s));
    assert_eq!(
        s.patterns.validate(),
        Err(WireError::Invalid(Invalid::BitDepth))
    );
}

#[test]
fn builders_report_what_the_core_refuses() {
    // Field-valid, but the coarse phase spans more than 2π: the core refuses the set.
    let mut s = small_setup();
    s.patterns.phase.profile = PhaseProfile::Linear {
        origin: 3.5,
        slope: 2.0,
    };
    let blob = raw_blob(&s);
    let back = HeadSetup::parse(&blob).expect("fields are in range");
    assert!(matches!(back.pattern_set(), Err(SetupError::PatternSet(_))));
    assert!(matches!(back.decoder(), Err(SetupError::PatternSet(_))));
    // The reference plane through the projector centre: no reconstruction.
    let mut s = small_setup();
    s.calibration.geometry.plane_point = [200.0, 0.0, 0.0];
    s.calibration.geometry.plane_normal = [1.0, 0.0, 0.0];
    let back = HeadSetup::parse(&raw_blob(&s)).expect("fields are in range");
    assert!(matches!(
        back.reconstructor(),
        Err(SetupError::Reconstruction(_))
    ));
    // from_core refuses a projector deeper than 16 bits and a camera wider than the wire's u16.
    let set = paper_set();
    let e = HeadSetup::from_core(
        frames(12),
        &set,
        17,
        DecodeConfig::for_bit_depth(12),
        &camera(),
        &rig(Axis::Xi),
        edge(),
    );
    assert_eq!(e, Err(SetupError::Invalid(Invalid::BitDepth)));
    let wide = CameraParams {
        width: 70_000,
        ..camera()
    };
    let e = HeadSetup::from_core(
        frames(12),
        &set,
        16,
        DecodeConfig::for_bit_depth(12),
        &wide,
        &rig(Axis::Xi),
        edge(),
    );
    assert_eq!(e, Err(SetupError::Invalid(Invalid::Dimension)));
}

#[test]
fn the_largest_set_up_fits_the_payload_limit() {
    // Every varint at its longest, every array full: the postcard encoding's upper bound.
    let mut s = small_setup();
    s.frames.width = u16::MAX;
    s.frames.height = u16::MAX;
    s.patterns.width = u16::MAX;
    s.patterns.height = u16::MAX;
    s.patterns.phase.profile = PhaseProfile::Knots(Knots {
        count: MAX_KNOTS as u8,
        s: [1.0; MAX_KNOTS],
        phi: [1.0; MAX_KNOTS],
        slope: [1.0; MAX_KNOTS],
    });
    s.patterns.level_count = MAX_LEVELS as u8;
    s.patterns.levels = [Level {
        scale: 1.0,
        shifts: Shifts::Explicit {
            count: MAX_SHIFTS as u8,
            radians: [1.0; MAX_SHIFTS],
        },
    }; MAX_LEVELS];
    s.calibration.camera.width = u32::MAX;
    s.calibration.camera.height = u32::MAX;
    s.correction = Some(SetupCorrection {
        levels: MAX_LEVELS as u8,
        knots: [[-12_000; 32]; MAX_LEVELS],
    });
    let mut buf = [0u8; 4 * MAX_SETUP_PAYLOAD];
    let n = postcard::to_slice(&s, &mut buf).expect("postcard").len();
    assert!(n <= MAX_SETUP_PAYLOAD, "{n} bytes");
    assert!(n > 1900, "{n} bytes: not the worst case");
}

#[test]
fn a_correction_table_travels_bit_for_bit_and_is_checked() {
    use fringe3d_core::decode::PhaseCorrection;
    let set = paper_set();
    let mut c = PhaseCorrection::zero(3);
    for (l, row) in c.delta.iter_mut().take(3).enumerate() {
        for (j, d) in row.iter_mut().enumerate() {
            *d = (80 * (l as i32 + 1) * (j as i32 - 10)) as i16;
        }
    }
    let s = head_setup(&set, 16, 12)
        .with_correction(&c)
        .expect("a sane table");
    let blob = emit(&s);
    let back = HeadSetup::parse(&blob).expect("parse");
    assert_eq!(back, s);
    let cfg = DecodeConfig::for_bit_depth(12);
    let want = Decoder::new(&set, cfg)
        .unwrap()
        .with_correction(&c)
        .unwrap();
    assert_eq!(back.decoder(), Ok(want));
    // A table for another level count, or with a knot out of range, is refused both ways.
    let bad = PhaseCorrection::zero(2);
    assert_eq!(
        head_setup(&set, 16, 12).with_correction(&bad),
        Err(SetupError::Correction)
    );
    let mut wrong = s;
    wrong.correction = Some(SetupCorrection::from(&bad));
    assert_eq!(
        HeadSetup::parse(&raw_blob(&wrong)),
        Err(SetupError::Correction)
    );
    let mut nan = c;
    nan.delta[1][5] = PhaseCorrection::MAX_DELTA + 1;
    wrong.correction = Some(SetupCorrection::from(&nan));
    assert_eq!(
        HeadSetup::parse(&raw_blob(&wrong)),
        Err(SetupError::Correction)
    );
}

/// xorshift64*, seeded.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }
}

/// Mutate a blob: bit flips, random bytes, small integers and special floats at random places,
/// truncation or growth; half the time the header length and CRC are fixed up afterwards so the
/// payload parser and the field checks see the damage.
fn mutate(r: &mut Rng, blob: &[u8]) -> Vec<u8> {
    let mut b = blob.to_vec();
    for _ in 0..1 + r.below(4) {
        let at = r.below(b.len());
        match r.below(6) {
            0 => b[at] ^= 1 << r.below(8),
            1 => b[at] = r.next() as u8,
            2 => b[at] = r.below(4) as u8,
            3 => {
                let f = [f64::NAN, f64::INFINITY, -1.0, 0.0, 1e300, 90.0][r.below(6)];
                let end = (at + 8).min(b.len());
                b[at..end].copy_from_slice(&f.to_le_bytes()[..end - at]);
            }
            4 => b.truncate(at),
            _ => {
                let extra = r.below(16);
                b.splice(at..at, (0..extra).map(|_| r.next() as u8));
            }
        }
        if b.is_empty() {
            break;
        }
    }
    if r.below(2) == 0 && b.len() >= SETUP_HEADER_LEN + SETUP_CRC_LEN {
        let end = b.len() - SETUP_CRC_LEN;
        b = seal(&b[SETUP_HEADER_LEN..end]);
    }
    b
}

#[test]
fn parse_never_panics_on_mutated_blobs() {
    let seeds = [
        SMALL_BLOB.to_vec(),
        SMALL_BLOB_V2.to_vec(),
        emit(&head_setup(&paper_set(), 16, 12)),
        emit(&head_setup(&odd_set(), 8, 8)),
    ];
    let mut r = Rng(0x5EED_F3D5_0001);
    let (mut ok, mut crc, mut payload, mut fields) = (0, 0, 0, 0);
    for i in 0..30_000 {
        let b = mutate(&mut r, &seeds[i % seeds.len()]);
        match HeadSetup::parse(&b) {
            Ok(s) => {
                ok += 1;
                // Whatever parses round-trips, and builds or is refused without a panic (the
                // builders check a whole projector: every 8th, to keep the test quick).
                assert_eq!(HeadSetup::parse(&emit(&s)), Ok(s));
                if ok % 8 == 0 {
                    let _ = (
                        s.pattern_set(),
                        s.decoder(),
                        s.reconstructor(),
                        s.edge_filter(),
                    );
                }
            }
            Err(SetupError::Crc) => crc += 1,
            Err(SetupError::Payload | SetupError::TrailingBytes) => payload += 1,
            Err(
                SetupError::Invalid(_)
                | SetupError::FrameFormat
                | SetupError::ImageSize
                | SetupError::CaptureOrder
                | SetupError::Thresholds
                | SetupError::EdgeFilter,
            ) => fields += 1,
            Err(_) => {}
        }
    }
    // The mutations reach every layer.
    assert!(
        ok > 100 && crc > 1000 && payload > 100 && fields > 1000,
        "ok {ok}, crc {crc}, payload {payload}, fields {fields}"
    );
}

/// Issue #20: a 48-image set (12 steps × 4 levels) travels whole, in a shuffled capture order; a
/// blob naming more than `MAX_IMAGES` (64) images is refused as a payload error, not cut short.
#[test]
fn a_48_image_set_travels_and_65_images_are_refused() {
    let out = Output {
        width: 1024,
        height: 768,
        i_min: 0.0,
        i_max: 255.0,
    };
    let f = PhaseFunction::centered(Axis::Xi, 1024, 0.9 * std::f64::consts::TAU).expect("linear");
    let levels: Vec<pattern::Level> = [1.0, 4.0, 16.0, 64.0]
        .iter()
        .map(|&c| pattern::Level::n_step(c, 12))
        .collect();
    let set = PatternSet::new(f, &levels, out).expect("a 48-image set");
    assert_eq!(set.image_count(), 48);
    // Every third image first, then the rest: an order no default produces.
    let mut order: Vec<ImageId> = set.order().iter().step_by(3).copied().collect();
    order.extend(
        set.order()
            .iter()
            .enumerate()
            .filter(|(i, _)| i % 3 != 0)
            .map(|(_, id)| *id),
    );
    let set = set.with_order(&order).expect("a permutation");
    let s = head_setup(&set, 8, 8);
    let blob = emit(&s);
    let back = HeadSetup::parse(&blob).expect("parse");
    assert_eq!(back, s);
    assert_eq!(back.image_count(), 48);
    assert_eq!(back.pattern_set().expect("set").order(), set.order());
    assert_eq!(
        back.decoder().expect("decoder"),
        Decoder::new(&set, DecodeConfig::for_bit_depth(8)).expect("decoder")
    );

    // Field 3 rewritten by hand with 65 indices: varint 65, then 65 bytes.
    let mut payload = [0u8; MAX_SETUP_PAYLOAD];
    let n = postcard::to_slice(&s, &mut payload)
        .expect("postcard")
        .len();
    let field3 = 1 + 48; // varint 48, 48 indices
    let start = {
        let mut before = [0u8; MAX_SETUP_PAYLOAD];
        let a = postcard::to_slice(&s.frames, &mut before)
            .expect("frames")
            .len();
        let b = postcard::to_slice(&s.patterns, &mut before)
            .expect("patterns")
            .len();
        a + b
    };
    assert_eq!(payload[start], 48);
    let mut long = payload[..start].to_vec();
    long.push(65);
    long.extend((0..65u8).map(|i| i % 48));
    long.extend_from_slice(&payload[start + field3..n]);
    assert_eq!(HeadSetup::parse(&seal(&long)), Err(SetupError::Payload));
}
