//! The head and the host's client over an in-process link: uploads, parametric patterns, the
//! trigger timeline, scans bit-identical to the desktop's decode, static buffers. Line faults are
//! in `head_faults.rs`.

use fringe3d::device::desc::{
    capture_sequence, desc_to_set, pattern_bytes, pattern_desc, render_pattern,
};
use fringe3d::device::{Client, DeviceError};
use fringe3d_core::pattern::{Convention, Level, Output, PatternSet};
use fringe3d_core::phase_function::{Axis, KnotProfile, PhaseFunction, Profile};
use fringe3d_core::wire::{
    EdgeFilterMode, FaultConfig, HeadState, Invalid, NakCode, PhaseProfile, ScanOutput,
    ValidationStatus,
};
use fringe3d_head::desktop::{InProcess, OwnedMemory, Recorder, sim_board};
use fringe3d_head::sim::{EventKind, Line, NoSink, SimWorld};
use fringe3d_head::{Head, HeadConfig};

use crate::link_support::*;

#[test]
fn host_and_head_build_the_same_set_from_a_description() {
    // The paper's set, and sets with parameters that are not f32: knots, curved fringes, I_min,
    // cosine, an offset, explicit and 5-step shifts. The description (core::wire, used by both
    // ends) rebuilds each bit for bit, and the rebuilt set renders the same rows.
    let o = Output {
        width: PW as u32,
        height: PH as u32,
        i_min: 3.3,
        i_max: 250.7,
    };
    let knots =
        KnotProfile::from_slopes(&[0.0, 40.3, 127.0], &[0.011, 0.021, 0.013], -0.9).unwrap();
    let curved = PhaseFunction::with_profile(Axis::Xi, Profile::Knots(knots))
        .unwrap()
        .curved(1.7e-3, 47.1)
        .unwrap();
    let eta = PhaseFunction::linear(Axis::Eta, 47.3, 0.1 / 1.57).unwrap();
    let sets = [
        exact_set(),
        PatternSet::paper_eight(curved, 7.3, o).unwrap(),
        PatternSet::new(
            eta,
            &[
                Level::n_step(1.0, 5),
                Level::with_shifts(6.1, &[0.0, 2.0, 4.1]),
            ],
            o,
        )
        .unwrap()
        .with_convention(Convention::Cosine)
        .with_phase_offset(0.3)
        .unwrap(),
    ];
    for set in sets {
        let d = pattern_desc(&set, 8).unwrap();
        let back = d.to_set().unwrap();
        assert_eq!(back, set, "{d:?}");
        assert_eq!(desc_to_set(&d).unwrap(), set);
        let mut a = vec![0u8; PW as usize];
        let mut b = vec![0u8; PW as usize];
        for i in 0..set.image_count() {
            for y in [0, PH as u32 / 2, PH as u32 - 1] {
                set.generate_row(i, y, &mut a).unwrap();
                back.generate_row(i, y, &mut b).unwrap();
                assert_eq!(a, b);
            }
        }
        // Every image is addressable by its wire index and back.
        for &id in set.order() {
            let p = d.pattern_index(id).unwrap();
            assert_eq!(d.pattern_id(p), Some(id));
        }
    }
    // Not describable: a 9-bit projector; refused by the head: a set that fails the core's
    // check (slope so steep the finest level aliases).
    assert!(pattern_desc(&exact_set(), 9).is_err());
    let mut bad = pattern_desc(&exact_set(), 8).unwrap();
    bad.phase.profile = PhaseProfile::Linear {
        origin: 63.5,
        slope: 0.5,
    };
    assert_eq!(bad.validate(), Ok(()));
    assert_eq!(bad.to_set(), Err(Invalid::PhaseFunction));
}

#[test]
fn upload_then_scan_phase_is_bit_identical_to_the_desktop() {
    let set = exact_set();
    let d = pattern_desc(&set, 8).unwrap();
    let world = SimWorld::new(READOUT_NS);
    let mut mem = OwnedMemory::new(plan());
    let h = head(&world, &mut mem, &set, &d, NoSink);
    let mut c = Client::connect(
        InProcess::new(h, FaultConfig::NONE, FaultConfig::NONE, 1),
        opts(),
    )
    .unwrap();
    assert_eq!(c.capabilities().sensor_width, CW);
    c.define_pattern_set(0, &d).unwrap();
    let data = pattern_bytes(&set, &d, |i| render_pattern(&set, i)).unwrap();
    let r = c.upload_patterns(0, &d, &data, &mut |_, _| {}).unwrap();
    assert_eq!((r.total, r.resumed_from), (data.len() as u64, 0));
    c.configure_sequence(
        0,
        false,
        &capture_sequence(&set, &d, EXPOSURE_US, DARK_US).unwrap(),
    )
    .unwrap();
    let v = c.validate().unwrap();
    assert_eq!(
        v.0,
        ValidationStatus::NO_CALIBRATION | ValidationStatus::NO_REFERENCE
    );
    // Points need the calibration and the reference map: refused, with the reason.
    match c.scan(
        ScanOutput::Points,
        0,
        0,
        EdgeFilterMode::Off,
        &mut |_, _| {},
    ) {
        Err(DeviceError::Refused {
            code: NakCode::SequenceInvalid,
            reason,
            ..
        }) => assert!(reason.contains("no calibration"), "{reason}"),
        other => panic!("{other:?}"),
    }
    let out = c
        .scan(ScanOutput::Phase, 0, 0, EdgeFilterMode::Off, &mut |_, _| {})
        .unwrap();
    let (p, q) = desktop_phase(&set, &d);
    assert_eq!(bits(out.phase.as_ref().unwrap()), bits(&p));
    assert_eq!(out.phase_validity.as_ref().unwrap(), &q);
    assert!(
        q.iter().filter(|&&v| v == 0).count() > q.len() / 2,
        "mostly valid"
    );
    // A window of rows.
    let part = c
        .scan(
            ScanOutput::Phase,
            10,
            7,
            EdgeFilterMode::Off,
            &mut |_, _| {},
        )
        .unwrap();
    let w = CW as usize;
    assert_eq!(bits(part.phase.as_ref().unwrap()), bits(&p[10 * w..17 * w]));
    let st = c.status().unwrap();
    assert_eq!(st.state, HeadState::Ready);
    assert_eq!(st.rows_sent, CH as u32 + 7);
    let head = c.into_transport().device;
    assert_eq!(&head.board().pattern_store.bytes()[..data.len()], &data[..]);
    let m = head.memory_report();
    assert_eq!(m.decode_state, 7 * w * CH as usize * 4);
    assert_eq!(m.decode_flags, w * CH as usize);
    assert!(m.head_struct > 16_000 && m.head_struct < 40_000, "{m:?}");
}

#[test]
fn parametric_patterns_equal_the_fringe3d_patterns_pngs() {
    // A linear set, and the curved and variable-width examples of examples/patterns/ scaled to
    // this 128 x 96 projector (ratio 4 keeps the finest level resolvable): the head renders each
    // from its wire description, and every projected pattern equals `fringe3d patterns`' PNG.
    let head_of = "version = 1\npreset = \"paper8\"\n";
    let proj = format!("[projector]\nwidth = {PW}\nheight = {PH}\nbit_depth = 8\n");
    let files = [
        (
            "exact",
            format!(
                "{head_of}ratio = 8.0\n{proj}[phase]\naxis = \"xi\"\nkind = \"linear\"\norigin = 63.5\nslope = 0.015625\n"
            ),
        ),
        (
            "curved",
            format!(
                "{head_of}ratio = 4.0\n{proj}[phase]\naxis = \"xi\"\nkind = \"centered\"\nspan = 5.2\ncurvature = 0.002\nbend_center = 47.5\n"
            ),
        ),
        (
            "variable-width",
            format!(
                "{head_of}ratio = 4.0\n{proj}[phase]\naxis = \"xi\"\nkind = \"knots\"\n\
                 positions = [0.0, 32.0, 64.0, 96.0, 127.0]\nslopes = [0.024, 0.048, 0.0576, 0.048, 0.024]\n"
            ),
        ),
    ];
    let dir = std::env::temp_dir().join(format!("fringe3d-head-pngs-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    for (k, (name, text)) in files.iter().enumerate() {
        let file = dir.join(format!("{name}.toml"));
        std::fs::write(&file, text).unwrap();
        let out = dir.join(name);
        fringe3d::cli::run([
            "fringe3d",
            "--quiet",
            "patterns",
            "--patterns",
            file.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ])
        .unwrap();
        let ls = fringe3d::cli::common::load_set(&file).unwrap();
        let set = ls.set;
        if *name == "variable-width" {
            assert!(matches!(set.function().profile(), Profile::Knots(_)));
        }
        if *name == "curved" {
            assert!(set.function().curvature() != 0.0);
        }
        let d = pattern_desc(&set, 8).unwrap();
        let fid = fringe3d::device::desc::fidelity(&set, &d, 8);
        assert!(fid.patterns && fid.decoder, "{name}: {fid:?}");

        let world = SimWorld::new(READOUT_NS);
        let mut mem = OwnedMemory::new(plan());
        let h = head(&world, &mut mem, &set, &d, Recorder::default());
        let mut c = Client::connect(
            InProcess::new(h, FaultConfig::NONE, FaultConfig::NONE, 2 + k as u64),
            opts(),
        )
        .unwrap();
        c.define_pattern_set(0, &d).unwrap(); // no upload: the head renders the set itself
        c.configure_sequence(
            0,
            false,
            &capture_sequence(&set, &d, EXPOSURE_US, DARK_US).unwrap(),
        )
        .unwrap();
        let out_scan = c
            .scan(ScanOutput::Phase, 0, 0, EdgeFilterMode::Off, &mut |_, _| {})
            .unwrap();
        let head = c.into_transport().device;
        let rec = head.board().projector.sink();
        assert_eq!(rec.patterns.len(), 8);
        for (i, id) in set.order().iter().enumerate() {
            let p = d.pattern_index(*id).unwrap();
            let (img, _) =
                fringe3d::io::image::read_gray(&out.join(format!("pattern_{i:02}.png"))).unwrap();
            let fringe3d::io::image::Pixels::U8(px) = img.pixels else {
                panic!("8-bit PNG expected")
            };
            assert_eq!(
                rec.patterns[&p], px,
                "{name}: pattern {i} (wire {p}) differs from the PNG"
            );
        }
        // And the head decodes the set as the desktop does.
        let (p, q) = desktop_phase(&set, &d);
        assert_eq!(bits(out_scan.phase.as_ref().unwrap()), bits(&p), "{name}");
        assert_eq!(out_scan.phase_validity.as_ref().unwrap(), &q, "{name}");
        assert!(
            q.iter().filter(|&&v| v == 0).count() > q.len() / 2,
            "{name}: mostly valid"
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn trigger_timeline_follows_the_sequence() {
    let set = exact_set();
    let d = pattern_desc(&set, 8).unwrap();
    let world = SimWorld::new(READOUT_NS);
    let mut mem = OwnedMemory::new(plan());
    let h = head(&world, &mut mem, &set, &d, NoSink);
    let mut c = Client::connect(
        InProcess::new(h, FaultConfig::NONE, FaultConfig::NONE, 3),
        opts(),
    )
    .unwrap();
    c.define_pattern_set(0, &d).unwrap();
    let lut = capture_sequence(&set, &d, EXPOSURE_US, DARK_US).unwrap();
    c.configure_sequence(0, false, &lut).unwrap();
    world.clear_timeline();
    c.scan(ScanOutput::Phase, 0, 1, EdgeFilterMode::Off, &mut |_, _| {})
        .unwrap();
    let mut ev = Vec::new();
    world.for_each_event(|e| ev.push(*e));
    // Per entry: load, projector on, camera on, (exposure) camera off + capture, projector off,
    // (dark) ready seen, frame read.
    assert_eq!(ev.len(), lut.len() * 8, "{ev:#?}");
    for (k, (e, chunk)) in lut.iter().zip(ev.chunks(8)).enumerate() {
        let p = e.pattern;
        let kinds: Vec<EventKind> = chunk.iter().map(|x| x.kind).collect();
        assert_eq!(
            kinds,
            vec![
                EventKind::PatternLoaded {
                    pattern: p,
                    crc: match kinds[0] {
                        EventKind::PatternLoaded { crc, .. } => crc,
                        _ => 0,
                    }
                },
                EventKind::Drive {
                    line: Line::ProjectorTrigger,
                    high: true
                },
                EventKind::Drive {
                    line: Line::CameraTrigger,
                    high: true
                },
                EventKind::Drive {
                    line: Line::CameraTrigger,
                    high: false
                },
                EventKind::Captured {
                    pattern: Some(p),
                    exposure_ns: EXPOSURE_US as u64 * 1000
                },
                EventKind::Drive {
                    line: Line::ProjectorTrigger,
                    high: false
                },
                EventKind::Sensed {
                    line: Line::CameraReady
                },
                EventKind::FrameRead { pattern: Some(p) },
            ],
            "entry {k}"
        );
        let t = |i: usize| chunk[i].t_ns;
        assert_eq!(t(2) - t(1), 0, "camera starts with the projector");
        assert_eq!(t(3) - t(2), EXPOSURE_US as u64 * 1000, "exposure");
        assert_eq!(
            t(6) - t(5),
            DARK_US as u64 * 1000,
            "dark time covers the readout"
        );
        if k > 0 {
            assert!(t(0) >= ev[8 * k - 1].t_ns);
        }
    }
    let s = world.stats();
    assert_eq!((s.exposures, s.blurred, s.lost_frames), (8, 0, 0));
}

/// A complete set of working buffers in one `static`, as on a board.
static BUFFERS: std::sync::Mutex<
    fringe3d_head::HeadBuffers<
        { 7 * 64 * 48 },
        { 64 * 48 },
        64,
        { 9 * 64 },
        { 4 * 64 },
        128,
        { 16 * 64 },
        64,
        { 13 * 64 },
        { 2 * 64 },
    >,
> = std::sync::Mutex::new(fringe3d_head::HeadBuffers::new());

#[test]
fn the_head_runs_in_static_buffers() {
    let set = exact_set();
    let d = pattern_desc(&set, 8).unwrap();
    let world = SimWorld::new(READOUT_NS);
    let mut bufs = BUFFERS.lock().unwrap();
    let board = sim_board(
        &world,
        view(&set, &d),
        NoSink,
        (PW, PH),
        1 << 20,
        CW as usize * CH as usize * 5,
    );
    let h = Head::new(board, bufs.memory(), HeadConfig::DEFAULT).unwrap();
    let mut c = Client::connect(
        InProcess::new(h, FaultConfig::NONE, FaultConfig::NONE, 8),
        opts(),
    )
    .unwrap();
    define_and_configure(&mut c, &set, &d);
    let out = c
        .scan(ScanOutput::Phase, 0, 0, EdgeFilterMode::Off, &mut |_, _| {})
        .unwrap();
    assert_eq!(
        bits(out.phase.as_ref().unwrap()),
        bits(&desktop_phase(&set, &d).0)
    );
    // A set of more levels than the buffers hold is refused, not overrun.
    let f = PhaseFunction::linear(Axis::Xi, 63.5, 1.0 / 256.0).unwrap();
    let big = PatternSet::new(
        f,
        &[
            Level::n_step(1.0, 3),
            Level::two_step(4.0),
            Level::two_step(16.0),
            Level::two_step(64.0),
        ],
        Output {
            width: PW as u32,
            height: PH as u32,
            i_min: 0.0,
            i_max: 255.0,
        },
    )
    .unwrap();
    let bd = pattern_desc(&big, 8).unwrap();
    c.define_pattern_set(1, &bd).unwrap();
    c.configure_sequence(
        1,
        false,
        &capture_sequence(&big, &bd, EXPOSURE_US, DARK_US).unwrap(),
    )
    .unwrap();
    match c.scan(ScanOutput::Phase, 0, 0, EdgeFilterMode::Off, &mut |_, _| {}) {
        Err(DeviceError::Refused {
            code: NakCode::OutOfMemory,
            ..
        }) => {}
        other => panic!("{other:?}"),
    }
}
