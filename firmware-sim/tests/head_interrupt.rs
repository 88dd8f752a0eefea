//! An interrupted scan (issue #21 item 10): Ctrl-C during `device scan` sets the client's
//! interrupt flag; the client aborts the head's scan before it gives up, so the head is not left
//! scanning, and the next scan works. A head kept busy names the command that ends it.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

use embedded_io::{ErrorType, Read, Write};

use fringe3d::device::desc::{capture_sequence, pattern_bytes, pattern_desc, render_pattern};
use fringe3d::device::{Client, DeviceError, Transport};
use fringe3d_core::wire::{
    Command, EdgeFilterMode, FaultConfig, FrameReceiver, HeadState, MAX_ENCODED_FRAME, NakCode,
    ScanOutput,
};
use fringe3d_head::desktop::{InProcess, OwnedMemory};
use fringe3d_head::sim::{NoSink, SimWorld};

use crate::link_support::*;

/// A transport that notes the command of every frame the host sends.
struct Spy<T> {
    inner: T,
    rx: FrameReceiver<Box<[u8]>>,
    sent: Vec<u8>,
}

impl<T> ErrorType for Spy<T> {
    type Error = core::convert::Infallible;
}

impl<T: Transport + ErrorType<Error = core::convert::Infallible>> Read for Spy<T> {
    fn read(&mut self, buf: &mut [u8]) -> Result<usize, Self::Error> {
        self.inner.read(buf)
    }
}

impl<T: Transport + ErrorType<Error = core::convert::Infallible>> Write for Spy<T> {
    fn write(&mut self, buf: &[u8]) -> Result<usize, Self::Error> {
        let n = self.inner.write(buf)?;
        let mut input = &buf[..n];
        while !input.is_empty() {
            let (used, ev) = self.rx.feed(input);
            input = &input[used..];
            if let Some(Ok(f)) = ev {
                self.sent.push(f[3]);
            }
        }
        Ok(n)
    }

    fn flush(&mut self) -> Result<(), Self::Error> {
        Ok(())
    }
}

impl<T: Transport + ErrorType<Error = core::convert::Infallible>> Transport for Spy<T> {
    fn wait(&mut self, deadline: Instant) -> bool {
        self.inner.wait(deadline)
    }
}

#[test]
fn an_interrupted_scan_is_aborted_on_the_head() {
    let set = exact_set();
    let d = pattern_desc(&set, 8).unwrap();
    let world = SimWorld::new(READOUT_NS);
    let mut mem = OwnedMemory::new(plan());
    let h = head(&world, &mut mem, &set, &d, NoSink);
    let io = Spy {
        inner: InProcess::new(h, FaultConfig::NONE, FaultConfig::NONE, 31),
        rx: FrameReceiver::new(vec![0u8; MAX_ENCODED_FRAME].into_boxed_slice()),
        sent: Vec::new(),
    };
    let mut c = Client::connect(io, opts()).unwrap();
    c.define_pattern_set(0, &d).unwrap();
    let data = pattern_bytes(&set, &d, |i| render_pattern(&set, i)).unwrap();
    c.upload_patterns(0, &d, &data, &mut |_, _| {}).unwrap();
    define_and_configure(&mut c, &set, &d);

    // Ctrl-C after 5 of the 48 rows.
    let flag = Arc::new(AtomicBool::new(false));
    c.set_interrupt(flag.clone());
    let f = flag.clone();
    let e = c
        .scan(
            ScanOutput::Phase,
            0,
            0,
            EdgeFilterMode::Off,
            &mut |done, _| {
                if done >= 5 {
                    f.store(true, Ordering::SeqCst);
                }
            },
        )
        .unwrap_err();
    let m = e.to_string();
    assert!(matches!(e, DeviceError::Interrupted { .. }), "{m}");
    assert!(m.contains("the head's scan was aborted"), "{m}");
    // The host sent Abort after the Scan, and the head acknowledged it (the in-process head has
    // streamed every row by then; on a line, the Abort ends the stream early).
    let sent = &c.link_mut().transport_mut().sent;
    let scan = sent
        .iter()
        .rposition(|&b| b == Command::Scan as u8)
        .unwrap();
    assert_eq!(&sent[scan + 1..], &[Command::Abort as u8], "{sent:02x?}");
    // Still interrupted: any further request fails at once.
    assert!(matches!(c.status(), Err(DeviceError::Interrupted { .. })));

    // The head is not scanning; the next session scans at once.
    flag.store(false, Ordering::SeqCst);
    let st = c.status().unwrap();
    assert_ne!(st.state, HeadState::Scanning);
    let out = c
        .scan(ScanOutput::Phase, 0, 0, EdgeFilterMode::Off, &mut |_, _| {})
        .unwrap();
    let (p, q) = desktop_phase(&set, &d);
    assert_eq!(bits(out.phase.as_ref().unwrap()), bits(&p));
    assert_eq!(out.phase_validity.as_ref().unwrap(), &q);
}

#[test]
fn a_busy_head_names_the_command_that_ends_what_runs() {
    let set = exact_set();
    let d = pattern_desc(&set, 8).unwrap();
    let world = SimWorld::new(READOUT_NS);
    let mut mem = OwnedMemory::new(plan());
    let h = head(&world, &mut mem, &set, &d, NoSink);
    let mut c = connect_uploaded(h, 32, &set, &d);
    // A repeating sequence keeps the head busy until stopped or aborted.
    c.configure_sequence(
        0,
        true,
        &capture_sequence(&set, &d, EXPOSURE_US, DARK_US).unwrap(),
    )
    .unwrap();
    c.start().unwrap();
    match c.scan(ScanOutput::Phase, 0, 0, EdgeFilterMode::Off, &mut |_, _| {}) {
        Err(
            e @ DeviceError::Refused {
                code: NakCode::Busy,
                ..
            },
        ) => {
            let m = e.to_string();
            assert!(m.contains("`fringe3d device abort` ends either"), "{m}");
            assert!(
                m.contains("`fringe3d device stop` ends a running sequence"),
                "{m}"
            );
        }
        other => panic!("{other:?}"),
    }
    c.abort().unwrap();
    assert_ne!(c.status().unwrap().state, HeadState::Running);
}
