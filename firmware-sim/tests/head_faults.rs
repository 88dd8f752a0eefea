//! The head and the host's client under line faults: thousands of seeded faults (drops,
//! corruption, duplicates, cuts), uploads that resume from the last acknowledged chunk, hostile
//! lines that end in clean errors, never in wrong data.

use fringe3d::device::desc::{capture_sequence, pattern_bytes, pattern_desc, render_pattern};
use fringe3d::device::{Client, DeviceError};
use fringe3d_core::wire::{
    EdgeFilterMode, FaultConfig, HeadState, NakCode, ScanOutput, ValidationStatus,
};
use fringe3d_head::desktop::{InProcess, OwnedMemory};
use fringe3d_head::sim::{NoSink, SimWorld};

use crate::link_support::*;

/// Everything in one run under faults: connect, define, upload patterns, configure, scan phase.
/// `Ok` only with correct results; errors must be the line's, with a message.
fn faulty_session(
    seed: u64,
    up: FaultConfig,
    down: FaultConfig,
    truth: &(Vec<f32>, Vec<u8>),
    data: &[u8],
) -> (Result<(), String>, u64) {
    let set = exact_set();
    let d = pattern_desc(&set, 8).unwrap();
    let world = SimWorld::new(READOUT_NS);
    let mut mem = OwnedMemory::new(plan());
    let h = head(&world, &mut mem, &set, &d, NoSink);
    let mut link = InProcess::new(h, up, down, seed);
    let mut result = Err("no session".to_string());
    // Up to three sessions (a user running the command again after a failure).
    for _session in 0..3 {
        let mut c = Client::open(link, opts());
        let r = (|| -> Result<(), DeviceError> {
            c.hello()?;
            c.define_pattern_set(0, &d)?;
            let rep = c.upload_patterns(0, &d, data, &mut |_, _| {})?;
            assert_eq!(rep.total, data.len() as u64);
            // Confirmed: the head must hold exactly the data.
            let held = &c.link().transport().device.board().pattern_store.bytes()[..data.len()];
            assert!(
                held == data,
                "seed {seed}: confirmed upload differs from the data"
            );
            c.configure_sequence(
                0,
                false,
                &capture_sequence(&set, &d, EXPOSURE_US, DARK_US).unwrap(),
            )?;
            let out = c.scan(ScanOutput::Phase, 0, 0, EdgeFilterMode::Off, &mut |_, _| {})?;
            assert!(
                bits(out.phase.as_ref().unwrap()) == bits(&truth.0),
                "seed {seed}: phases differ"
            );
            assert!(
                out.phase_validity.as_ref().unwrap() == &truth.1,
                "seed {seed}: validity differs"
            );
            Ok(())
        })();
        link = c.into_transport();
        match r {
            Ok(()) => {
                result = Ok(());
                break;
            }
            Err(e) => {
                let msg = e.to_string();
                assert!(
                    e.is_transient(),
                    "seed {seed}: non-line error under line faults: {msg}"
                );
                assert!(msg.len() > 20, "seed {seed}: unclear error {msg:?}");
                // Whatever failed, an unconfirmed set is refused.
                let head = &link.device;
                let st = head.status();
                assert_ne!(st.state, HeadState::Scanning);
                result = Err(msg);
            }
        }
    }
    let (a, b) = link.fault_stats();
    (result, a.faults() + b.faults())
}

#[test]
fn thousands_of_seeded_line_faults() {
    let set = exact_set();
    let d = pattern_desc(&set, 8).unwrap();
    let truth = desktop_phase(&set, &d);
    let data = pattern_bytes(&set, &d, |i| render_pattern(&set, i)).unwrap();
    let up = FaultConfig {
        drop_ppm: 25,
        corrupt_ppm: 25,
        duplicate_ppm: 25,
        cut_ppm: 10,
        max_cut_len: 6000,
    };
    let down = FaultConfig {
        drop_ppm: 150,
        corrupt_ppm: 150,
        duplicate_ppm: 150,
        cut_ppm: 40,
        max_cut_len: 3000,
    };
    let (mut ok, mut failed, mut faults) = (0, 0, 0u64);
    let t0 = std::time::Instant::now();
    for seed in 0..120u64 {
        let (r, f) = faulty_session(seed, up, down, &truth, &data);
        faults += f;
        match r {
            Ok(()) => ok += 1,
            Err(e) => {
                if failed < 12 {
                    eprintln!("seed {seed}: {e}");
                }
                failed += 1
            }
        }
    }
    eprintln!(
        "{ok} sessions completed, {failed} failed cleanly, {faults} faults injected in {:.1} s",
        t0.elapsed().as_secs_f64()
    );
    assert!(faults >= 2000, "only {faults} faults");
    assert!(ok >= 110, "too few sessions completed: {ok}");
}

#[test]
fn a_cut_line_fails_clearly_the_upload_resumes_and_nothing_unconfirmed_is_used() {
    let set = exact_set();
    let d = pattern_desc(&set, 8).unwrap();
    let data = pattern_bytes(&set, &d, |i| render_pattern(&set, i)).unwrap();
    let truth = desktop_phase(&set, &d);
    let world = SimWorld::new(READOUT_NS);
    let mut mem = OwnedMemory::new(plan());
    let h = head(&world, &mut mem, &set, &d, NoSink);
    let mut c = Client::connect(
        InProcess::new(h, FaultConfig::NONE, FaultConfig::NONE, 5),
        opts(),
    )
    .unwrap();
    define_and_configure(&mut c, &set, &d);

    // Unplug a third of the way through.
    let sent = c.link().stats().bytes_sent;
    c.link_mut()
        .transport_mut()
        .cut_after(sent + data.len() as u64 / 3);
    let err = c.upload_patterns(0, &d, &data, &mut |_, _| {}).unwrap_err();
    let msg = err.to_string();
    let DeviceError::UploadInterrupted { acked, total, .. } = err else {
        panic!("{msg}")
    };
    assert!(acked > 0 && acked < total, "{msg}");
    assert!(
        msg.contains(&format!("stopped at byte {acked} of {total}")) && msg.contains("resume"),
        "{msg}"
    );

    // Plugged in again: the set is not usable until confirmed.
    c.link_mut().transport_mut().set_connected(true);
    let mut c = Client::connect(c.into_transport(), opts()).unwrap();
    assert!(
        c.validate()
            .unwrap()
            .has(ValidationStatus::SET_NOT_CONFIRMED)
    );
    match c.scan(ScanOutput::Phase, 0, 0, EdgeFilterMode::Off, &mut |_, _| {}) {
        Err(DeviceError::Refused {
            code: NakCode::SequenceInvalid,
            reason,
            ..
        }) => assert!(reason.contains("not confirmed"), "{reason}"),
        other => panic!("{other:?}"),
    }

    // A storage fault in what the head holds: the resumed upload completes, the digest check
    // catches it, nothing is used.
    c.link_mut()
        .transport_mut()
        .device
        .board_mut()
        .pattern_store
        .bytes_mut()[7] ^= 0x40;
    let before = c.link().stats().bytes_sent;
    let err = c.upload_patterns(0, &d, &data, &mut |_, _| {}).unwrap_err();
    assert!(matches!(err, DeviceError::DigestMismatch { .. }), "{err}");
    let resumed_bytes = c.link().stats().bytes_sent - before;
    assert!(
        resumed_bytes < data.len() as u64,
        "the upload resumed: {resumed_bytes} bytes sent"
    );
    assert!(
        c.validate()
            .unwrap()
            .has(ValidationStatus::SET_NOT_CONFIRMED)
    );
    assert!(
        c.scan(ScanOutput::Phase, 0, 0, EdgeFilterMode::Off, &mut |_, _| {})
            .is_err()
    );

    // Uploaded again in full: confirmed, and the scan is right.
    let r = c.upload_patterns(0, &d, &data, &mut |_, _| {}).unwrap();
    assert_eq!(r.resumed_from, 0);
    let out = c
        .scan(ScanOutput::Phase, 0, 0, EdgeFilterMode::Off, &mut |_, _| {})
        .unwrap();
    assert_eq!(bits(out.phase.as_ref().unwrap()), bits(&truth.0));
}

#[test]
fn an_interrupted_upload_resumes_from_the_last_acknowledged_chunk() {
    let set = exact_set();
    let d = pattern_desc(&set, 8).unwrap();
    let data = pattern_bytes(&set, &d, |i| render_pattern(&set, i)).unwrap();
    let world = SimWorld::new(READOUT_NS);
    let mut mem = OwnedMemory::new(plan());
    let h = head(&world, &mut mem, &set, &d, NoSink);
    let mut c = Client::connect(
        InProcess::new(h, FaultConfig::NONE, FaultConfig::NONE, 6),
        opts(),
    )
    .unwrap();
    c.define_pattern_set(0, &d).unwrap();
    let sent = c.link().stats().bytes_sent;
    c.link_mut()
        .transport_mut()
        .cut_after(sent + data.len() as u64 / 2);
    let DeviceError::UploadInterrupted { acked, .. } =
        c.upload_patterns(0, &d, &data, &mut |_, _| {}).unwrap_err()
    else {
        panic!("expected an interrupted upload")
    };
    c.link_mut().transport_mut().set_connected(true);
    let mut c = Client::connect(c.into_transport(), opts()).unwrap();
    let r = c.upload_patterns(0, &d, &data, &mut |_, _| {}).unwrap();
    // The head may hold more than the client saw acknowledged (acks lost in the cut).
    assert!(
        r.resumed_from >= acked && r.resumed_from < data.len() as u64,
        "{r:?}, acked {acked}"
    );
    assert!(
        r.wire_bytes < (data.len() as u64 - acked) + data.len() as u64 / 8,
        "{r:?}"
    );
    assert_eq!(
        &c.link().transport().device.board().pattern_store.bytes()[..data.len()],
        &data[..]
    );
}

#[test]
fn a_hostile_line_ends_in_clean_errors_never_in_wrong_data() {
    let set = exact_set();
    let d = pattern_desc(&set, 8).unwrap();
    let truth = desktop_phase(&set, &d);
    let data = pattern_bytes(&set, &d, |i| render_pattern(&set, i)).unwrap();
    let up = FaultConfig {
        drop_ppm: 150,
        corrupt_ppm: 150,
        duplicate_ppm: 150,
        cut_ppm: 40,
        max_cut_len: 20_000,
    };
    let down = FaultConfig {
        drop_ppm: 800,
        corrupt_ppm: 800,
        duplicate_ppm: 800,
        cut_ppm: 150,
        max_cut_len: 5000,
    };
    let (mut ok, mut failed, mut faults) = (0, 0, 0u64);
    for seed in 1000..1030u64 {
        // `faulty_session` asserts: Ok only with the exact data and phases, errors only of the
        // line's kind and with a message.
        let (r, f) = faulty_session(seed, up, down, &truth, &data);
        faults += f;
        if r.is_ok() { ok += 1 } else { failed += 1 }
    }
    eprintln!("hostile line: {ok} completed, {failed} failed cleanly, {faults} faults");
    assert!(faults >= 1000, "{faults}");
}
