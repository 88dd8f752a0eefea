//! Stale frames (issue #21 item 1): rows of an earlier scan still in flight when a new scan ends
//! must never be assembled into the new scan's result. Every Scan carries a scan identity that
//! the head copies into its rows and ScanDone; the host drops, and counts, rows of any other
//! scan. The tap below replays the rows of an earlier scan (with marked values, as a different
//! scene would give) just before the ScanDone of the next scan, and re-numbers them with the new
//! scan's `seq`, as a host process that restarted its sequence numbers would see them: the scan
//! identity is then the only thing that tells them apart.

use std::collections::VecDeque;
use std::time::Instant;

use embedded_io::{ErrorType, Read, Write};
use fringe3d::device::desc::{pattern_bytes, pattern_desc, render_pattern};
use fringe3d::device::{Client, Transport};
use fringe3d_core::wire::{
    EdgeFilterMode, FaultConfig, Flags, Header, MAX_ENCODED_FRAME, MAX_FRAME, Message, ResultRow,
    ScanOutput, cobs, emit_packet, parse_packet,
};
use fringe3d_head::desktop::{InProcess, OwnedMemory};
use fringe3d_head::sim::{NoSink, SimWorld};

use crate::link_support::*;

/// A marker no decoded phase takes.
const MARK: f32 = 1.0e6;

/// A transport between the host and `inner` that records the rows the host receives and, when
/// armed, replays them (marked) just before the next ScanDone, under that ScanDone's `seq`.
struct Tap<T> {
    inner: T,
    partial: Vec<u8>,
    out: VecDeque<u8>,
    recording: bool,
    recorded: Vec<Vec<u8>>,
    armed: bool,
    replayed: u64,
}

impl<T> Tap<T> {
    fn new(inner: T) -> Self {
        Tap {
            inner,
            partial: Vec::new(),
            out: VecDeque::new(),
            recording: false,
            recorded: Vec::new(),
            armed: false,
            replayed: 0,
        }
    }

    /// One frame from the head (COBS bytes without the delimiter).
    fn frame(&mut self, enc: &[u8]) {
        let mut f = vec![0u8; enc.len()];
        let passed = |out: &mut VecDeque<u8>| {
            out.extend(enc);
            out.push_back(0);
        };
        let Ok(n) = cobs::decode(enc, &mut f) else {
            return passed(&mut self.out);
        };
        f.truncate(n);
        let Ok((h, msg)) = parse_packet(&f) else {
            return passed(&mut self.out);
        };
        match msg {
            Message::ResultRow(_) if self.recording => self.recorded.push(f.clone()),
            Message::ScanDone(_) if self.armed => {
                self.armed = false;
                for old in std::mem::take(&mut self.recorded) {
                    let (_, Message::ResultRow(r)) = parse_packet(&old).unwrap() else {
                        unreachable!()
                    };
                    // The earlier scan's row, marked, under the current scan's seq.
                    let mut data = r.data.to_vec();
                    let n = r.columns() * r.kind.components();
                    for v in data[..4 * n].chunks_exact_mut(4) {
                        v.copy_from_slice(&MARK.to_le_bytes());
                    }
                    for c in &mut data[4 * n..] {
                        *c = 0; // Valid
                    }
                    let stale = Message::ResultRow(ResultRow { data: &data, ..r });
                    let mut hdr = Header::for_message(&stale, h.seq);
                    hdr.flags = hdr.flags.with(Flags::MORE_FOLLOWS, true);
                    let mut scratch = [0u8; MAX_FRAME];
                    let mut line = [0u8; MAX_ENCODED_FRAME];
                    let k = emit_packet(&hdr, &stale, &mut scratch, &mut line).unwrap();
                    self.out.extend(&line[..k]);
                    self.replayed += 1;
                }
            }
            _ => {}
        }
        passed(&mut self.out);
    }
}

impl<T> ErrorType for Tap<T> {
    type Error = core::convert::Infallible;
}

impl<T: Transport + ErrorType<Error = core::convert::Infallible>> Read for Tap<T> {
    fn read(&mut self, buf: &mut [u8]) -> Result<usize, Self::Error> {
        if self.out.is_empty() {
            let mut tmp = [0u8; 4096];
            let n = self.inner.read(&mut tmp)?;
            for &b in &tmp[..n] {
                if b == 0 {
                    let enc = std::mem::take(&mut self.partial);
                    if !enc.is_empty() {
                        self.frame(&enc);
                    }
                } else {
                    self.partial.push(b);
                }
            }
        }
        let n = buf.len().min(self.out.len());
        for (d, b) in buf.iter_mut().zip(self.out.drain(..n)) {
            *d = b;
        }
        Ok(n)
    }
}

impl<T: Transport + ErrorType<Error = core::convert::Infallible>> Write for Tap<T> {
    fn write(&mut self, buf: &[u8]) -> Result<usize, Self::Error> {
        self.inner.write(buf)
    }

    fn flush(&mut self) -> Result<(), Self::Error> {
        Ok(())
    }
}

impl<T: Transport + ErrorType<Error = core::convert::Infallible>> Transport for Tap<T> {
    fn wait(&mut self, deadline: Instant) -> bool {
        !self.out.is_empty() || self.inner.wait(deadline)
    }
}

#[test]
fn rows_of_an_earlier_scan_before_scan_done_are_dropped_and_counted() {
    let set = exact_set();
    let d = pattern_desc(&set, 8).unwrap();
    let world = SimWorld::new(READOUT_NS);
    let mut mem = OwnedMemory::new(plan());
    let h = head(&world, &mut mem, &set, &d, NoSink);
    let io = Tap::new(InProcess::new(h, FaultConfig::NONE, FaultConfig::NONE, 21));
    let mut c = Client::connect(io, opts()).unwrap();
    c.define_pattern_set(0, &d).unwrap();
    let data = pattern_bytes(&set, &d, |i| render_pattern(&set, i)).unwrap();
    c.upload_patterns(0, &d, &data, &mut |_, _| {}).unwrap();
    define_and_configure(&mut c, &set, &d);

    // Scan 1: its rows are recorded on the way.
    c.link_mut().transport_mut().recording = true;
    let first = c
        .scan(ScanOutput::Phase, 0, 0, EdgeFilterMode::Off, &mut |_, _| {})
        .unwrap();
    let tap = c.link_mut().transport_mut();
    tap.recording = false;
    assert_eq!(tap.recorded.len(), CH as usize, "one segment per row");
    tap.armed = true;

    // Scan 2: scan 1's rows (marked) arrive just before its ScanDone, under its seq.
    let second = c
        .scan(ScanOutput::Phase, 0, 0, EdgeFilterMode::Off, &mut |_, _| {})
        .unwrap();
    let tap = c.link_mut().transport_mut();
    assert_eq!(tap.replayed, CH as u64, "the replay happened");
    assert!(!tap.armed);
    // None of them is in the result, and the host says so.
    assert_eq!(second.stale_rows, CH as u64);
    assert_eq!(first.stale_rows, 0);
    let phase = second.phase.as_ref().unwrap();
    assert!(
        phase.iter().all(|&p| p != MARK),
        "a stale row was assembled"
    );
    // The second scan is exactly the first (and the desktop's decode).
    assert_eq!(bits(phase), bits(first.phase.as_ref().unwrap()));
    assert_eq!(second.phase_validity, first.phase_validity);
    let (p, q) = desktop_phase(&set, &d);
    assert_eq!(bits(phase), bits(&p));
    assert_eq!(second.phase_validity.as_ref().unwrap(), &q);
    assert_eq!(second.rescans, 0);
}

#[test]
fn sequence_numbers_and_scan_ids_do_not_restart_with_a_new_link() {
    // Two links in one process start from different numbers (the process's seed mixed with a
    // count of links); the first frame of a new link is not seq 1 of every run.
    use fringe3d::device::Link;
    let mk = || {
        Link::new(InProcess::new(
            NoDevice,
            FaultConfig::NONE,
            FaultConfig::NONE,
            0,
        ))
    };
    let (mut a, mut b) = (mk(), mk());
    let (sa, sb) = (a.next_scan_id(), b.next_scan_id());
    assert_ne!(sa, sb);
    assert_eq!(a.next_scan_id(), sa.wrapping_add(1));
    // Sequence numbers: 8 bits, so compare several links' starts: not all the same.
    let starts: Vec<u8> = (0..8).map(|_| mk().next_seq()).collect();
    assert!(starts.iter().any(|&s| s != starts[0]), "{starts:?}");
}

/// A device that never answers.
struct NoDevice;

impl fringe3d_head::desktop::Device for NoDevice {
    fn service_io<T: embedded_io::Read + embedded_io::ReadReady + embedded_io::Write>(
        &mut self,
        _io: &mut T,
    ) -> Result<fringe3d_head::head::Activity, fringe3d_head::head::LinkError> {
        Ok(fringe3d_head::head::Activity::Idle)
    }
}
