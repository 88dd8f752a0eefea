//! A scan nobody reads (issue #21 item 10): when the host stops reading while the head streams
//! (a host killed mid-scan, with the line applying back pressure), the head's port gives up after
//! its stall limit, the scan ends, and the head is back to its state before the scan — not left
//! in Scanning for good.

use std::time::{Duration, Instant};

use embedded_io::ErrorKind;
use fringe3d::device::Client;
use fringe3d::device::desc::pattern_desc;
use fringe3d_core::wire::{
    EdgeFilterMode, Exposures, FaultConfig, HeadErrors, HeadState, MAX_ENCODED_FRAME, MAX_FRAME,
    Message, Packet, ScanOutput, ScanRequest, emit_packet,
};
use fringe3d_head::LinkError;
use fringe3d_head::desktop::{InProcess, OwnedMemory};
use fringe3d_head::port::{ByteQueue, QueuePort, Wait};
use fringe3d_head::sim::{NoSink, SimWorld};

use crate::link_support::*;

/// The desktop board's waiting strategy, with a short stall limit: nobody drains the TX queue.
struct StallAfter {
    stall: Duration,
    since: Option<Instant>,
}

impl Wait for StallAfter {
    fn rx_empty(&mut self) {
        std::thread::sleep(Duration::from_millis(1));
    }

    fn tx_full(&mut self) -> bool {
        let since = *self.since.get_or_insert_with(Instant::now);
        std::thread::sleep(Duration::from_millis(1));
        since.elapsed() < self.stall
    }

    fn tx_written(&mut self) {
        self.since = None;
    }
}

#[test]
fn a_scan_nobody_reads_ends_after_the_stall_limit_and_the_head_serves_again() {
    let set = exact_set();
    let d = pattern_desc(&set, 8).unwrap();
    let world = SimWorld::new(READOUT_NS);
    let mut mem = OwnedMemory::new(plan());
    let h = head(&world, &mut mem, &set, &d, NoSink);
    let mut c = connect_uploaded(h, 10, &set, &d);
    define_and_configure(&mut c, &set, &d);
    let mut head = c.into_transport().device;

    // A Scan arrives; the host then reads nothing: the TX queue (8 KiB) fills long before the
    // 48 phase rows (about 16 KB) are out.
    let mut rxq = ByteQueue::new();
    let mut txq = ByteQueue::new();
    let (mut rx_in, rx_out) = rxq.split();
    let (tx_in, mut tx_out) = txq.split();
    let msg = Message::Scan(ScanRequest {
        scan_id: 77,
        output: ScanOutput::Phase,
        first_row: 0,
        row_count: 0,
        edge_filter: EdgeFilterMode::Off,
        exposures: Exposures::NONE,
    });
    let p = Packet::request(5, msg);
    let (mut scratch, mut line) = ([0u8; MAX_FRAME], [0u8; MAX_ENCODED_FRAME]);
    let n = emit_packet(&p.header, &msg, &mut scratch, &mut line).unwrap();
    for &b in &line[..n] {
        rx_in.enqueue(b).unwrap();
    }
    let stall = Duration::from_millis(150);
    let mut port = QueuePort::new(rx_out, tx_in, StallAfter { stall, since: None });
    let t0 = Instant::now();
    let r = head.service(&mut port);
    let took = t0.elapsed();
    assert_eq!(r, Err(LinkError::Io(ErrorKind::TimedOut)));
    assert!(took >= stall, "{took:?}");
    assert!(took < Duration::from_secs(10), "{took:?}");
    let st = head.status();
    // Not left scanning: back where it was before the Scan (idle: the sequence was configured
    // but not validated since; only a completed scan marks it ready).
    assert_eq!(st.state, HeadState::Idle, "not left scanning");
    assert!(st.errors.0 & HeadErrors::LINK != 0, "{:?}", st.errors);
    assert!(
        st.rows_sent > 0 && st.rows_sent < CH as u32,
        "{}",
        st.rows_sent
    );
    // What the head had queued is stale now; drop it.
    while tx_out.dequeue().is_some() {}

    // A new host finds the head ready and scans (the scan identity keeps any leftover row of
    // the abandoned scan out of the new result).
    let mut c = Client::connect(
        InProcess::new(head, FaultConfig::NONE, FaultConfig::NONE, 11),
        opts(),
    )
    .unwrap();
    assert_eq!(c.status().unwrap().state, HeadState::Idle);
    let out = c
        .scan(ScanOutput::Phase, 0, 0, EdgeFilterMode::Off, &mut |_, _| {})
        .unwrap();
    let (p, q) = desktop_phase(&set, &d);
    assert_eq!(bits(out.phase.as_ref().unwrap()), bits(&p));
    assert_eq!(out.phase_validity.as_ref().unwrap(), &q);
}
