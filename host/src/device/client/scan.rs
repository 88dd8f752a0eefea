//! Scans: the rows streamed by the head, assembled, and lost rows requested again.

use std::collections::HashSet;
use std::time::Instant;

use fringe3d_core::wire::{
    Command, EdgeFilterMode, Exposures, HeadState, Message, NakCode, PROTOCOL_VERSION, Packet,
    RowKind, ScanOutput, ScanRequest,
};

use super::{Client, Got, ScanOutcome, classify};
use crate::device::{DeviceError, Transport};
use crate::scan::ScanCounts;

impl<T: Transport> Client<T> {
    /// Scan: run the sequence, stream rows `first_row .. first_row + row_count` (0: to the last
    /// row) of `output`, and request lost rows again until all are in. Point rows go through the
    /// head's edge filter when `edge_filter` says so (`fringe3d scan` filters at 80° by
    /// default); the head filters each row with its true neighbours, so the rows of a partial
    /// scan or a re-request equal those of a whole-image scan.
    ///
    /// Interrupted (the flag of [`Client::set_interrupt`] set), the scan sends Abort to the head
    /// (one short exchange, while the flag is ignored) and fails with
    /// [`DeviceError::Interrupted`], saying whether the head confirmed the abort.
    pub fn scan(
        &mut self,
        output: ScanOutput,
        first_row: u16,
        row_count: u16,
        edge_filter: EdgeFilterMode,
        progress: &mut dyn FnMut(u64, u64),
    ) -> Result<ScanOutcome, DeviceError> {
        self.scan_exposed(
            output,
            first_row,
            row_count,
            edge_filter,
            Exposures::NONE,
            progress,
        )
    }

    /// [`Client::scan`] at each exposure of `exposures` (protocol version 8): the head runs
    /// the sequence once per exposure, longest first, with every camera-triggered entry exposed
    /// for it, and streams for each pixel the decode of the longest exposure in which it did
    /// not saturate (HDR, docs/hdr.md). Lost rows requested again are captured again, at every
    /// exposure.
    pub fn scan_exposed(
        &mut self,
        output: ScanOutput,
        first_row: u16,
        row_count: u16,
        edge_filter: EdgeFilterMode,
        exposures: Exposures,
        progress: &mut dyn FnMut(u64, u64),
    ) -> Result<ScanOutcome, DeviceError> {
        let spec = Spec {
            output,
            edge_filter,
            exposures,
        };
        match self.scan_rows(spec, first_row, row_count, progress) {
            Err(DeviceError::Interrupted { what, .. }) => {
                let flag = self.link.set_interrupt(None);
                let retries = std::mem::replace(&mut self.opts.retries, 1);
                let aborted = self.abort();
                self.opts.retries = retries;
                self.link.set_interrupt(flag);
                let note = match aborted {
                    Ok(()) => "; the head's scan was aborted".to_string(),
                    Err(e) => format!(
                        "; the head did not confirm the abort ({e}): run `fringe3d device abort` \
                         before the next scan"
                    ),
                };
                Err(DeviceError::Interrupted { what, note })
            }
            r => r,
        }
    }

    fn scan_rows(
        &mut self,
        spec: Spec,
        first_row: u16,
        row_count: u16,
        progress: &mut dyn FnMut(u64, u64),
    ) -> Result<ScanOutcome, DeviceError> {
        let output = spec.output;
        let t0 = Instant::now();
        let recv0 = self.link.stats().bytes_received;
        let (w, h) = (
            self.caps.sensor_width as usize,
            self.caps.sensor_height as usize,
        );
        let first = first_row as usize;
        let rows = if row_count == 0 {
            h.saturating_sub(first)
        } else {
            row_count as usize
        };
        if first >= h || first + rows > h || rows == 0 {
            return Err(DeviceError::Input(format!(
                "rows {first}..{} outside the camera's {h} rows",
                first + rows
            )));
        }
        let phase = matches!(output, ScanOutput::Phase | ScanOutput::Both);
        let points = matches!(output, ScanOutput::Points | ScanOutput::Both);
        let mut acc = Assembly {
            width: w,
            first,
            rows,
            phase: phase.then(|| vec![f32::NAN; rows * w]),
            phase_validity: phase.then(|| vec![u8::MAX; rows * w]),
            xyz: points.then(|| vec![f32::NAN; rows * w * 3]),
            point_validity: points.then(|| vec![u8::MAX; rows * w]),
            covered: vec![[0usize; 2]; rows],
            seen: HashSet::new(),
            need: [if phase { w } else { 0 }, if points { w } else { 0 }],
            done_rows: 0,
            stale: 0,
            counts: None,
        };
        let mut ranges = vec![(first, rows)];
        let mut rescans = 0u32;
        loop {
            for &(f, n) in &ranges {
                self.scan_stream(spec, f as u16, n as u16, &mut acc, progress)?;
            }
            let missing: Vec<usize> = (0..rows).filter(|&r| !acc.complete(r)).collect();
            if missing.is_empty() {
                break;
            }
            if rescans >= self.opts.retries {
                return Err(DeviceError::ScanIncomplete {
                    missing: missing.len(),
                    rows,
                    attempts: rescans,
                });
            }
            rescans += 1;
            ranges.clear();
            for r in missing {
                match ranges.last_mut() {
                    Some((f, n)) if *f + *n == first + r => *n += 1,
                    _ => ranges.push((first + r, 1)),
                }
            }
        }
        Ok(ScanOutcome {
            width: w,
            first_row: first,
            rows,
            phase: acc.phase,
            phase_validity: acc.phase_validity,
            xyz: acc.xyz,
            point_validity: acc.point_validity,
            rescans,
            counts: acc.counts.filter(|_| rescans == 0),
            stale_rows: acc.stale,
            wire_bytes: self.link.stats().bytes_received - recv0,
            seconds: t0.elapsed().as_secs_f64(),
        })
    }

    /// One Scan request and its stream. Returns when the stream ended (ScanDone, or silence
    /// after which the head says it no longer scans); rows lost meanwhile are the caller's to
    /// request again.
    fn scan_stream(
        &mut self,
        spec: Spec,
        first: u16,
        count: u16,
        acc: &mut Assembly,
        progress: &mut dyn FnMut(u64, u64),
    ) -> Result<(), DeviceError> {
        let what = "Scan";
        // A fresh identity per request: only rows carrying it belong to this stream.
        let scan_id = self.link.next_scan_id();
        let msg = Message::Scan(ScanRequest {
            scan_id,
            output: spec.output,
            first_row: first,
            row_count: count,
            edge_filter: spec.edge_filter,
            exposures: spec.exposures,
        });
        let mut seqs: Vec<u8> = Vec::new();
        let mut started = false;
        let mut attempts = 0u32;
        let mut silences = 0u32;
        let bad_before = self.link.stats().bad_frames;
        loop {
            if !started {
                attempts += 1;
                if attempts > self.opts.retries + 1 {
                    return Err(self.no_response(what, attempts - 1, bad_before));
                }
                let seq = self.link.next_seq();
                let p = Packet::request(seq, msg);
                self.link.send(what, &p.header, &msg)?;
                seqs.push(seq);
            }
            let wait = if started {
                self.opts.scan_timeout
            } else {
                self.opts.timeout
            };
            let mut deadline = Instant::now() + wait;
            while let Some(f) = self.link.recv(what, deadline)? {
                let (seq, m) = match classify(&f) {
                    Got::Version(v) => {
                        return Err(DeviceError::Version {
                            device: v,
                            host: PROTOCOL_VERSION,
                        });
                    }
                    Got::Damaged => {
                        self.link.stats_mut().bad_frames += 1;
                        continue;
                    }
                    Got::Frame { seq, msg } => (seq, msg),
                };
                // Rows and ScanDones of another scan (an earlier one, still in flight): dropped,
                // whatever their seq (a seq has 8 bits and restarts with every process).
                if let Message::ResultRow(fringe3d_core::wire::ResultRow { scan_id: id, .. })
                | Message::ScanDone(fringe3d_core::wire::ScanDone { scan_id: id, .. }) = m
                    && id != scan_id
                {
                    acc.stale += 1;
                    continue;
                }
                if !seqs.contains(&seq) {
                    continue;
                }
                match m {
                    Message::Ack(a) if a.command == Command::Scan as u8 => started = true,
                    Message::ResultRow(r) => {
                        started = true;
                        acc.store(&r);
                        progress(acc.done_rows as u64, acc.rows as u64);
                    }
                    Message::ScanDone(d) => {
                        acc.counts = Some(ScanCounts {
                            decoded: d.decoded as usize,
                            searched: d.searched as usize,
                        });
                        return Ok(());
                    }
                    // A Nak of another command under this seq: an earlier session's, not ours.
                    Message::Nak(n) if n.command != Command::Scan as u8 => {}
                    Message::Nak(n) if n.code == NakCode::Busy && seqs.len() > 1 => started = true,
                    Message::Nak(n)
                        if matches!(n.code, NakCode::Crc | NakCode::Framing) && !started =>
                    {
                        break;
                    }
                    Message::Nak(n) => {
                        self.link.stats_mut().naks += 1;
                        return Err(self.nak_error(what, n));
                    }
                    _ => {}
                }
                deadline = Instant::now()
                    + if started {
                        self.opts.scan_timeout
                    } else {
                        self.opts.timeout
                    };
            }
            if started {
                // Silence: is the head still at it?
                silences += 1;
                match self.status()? {
                    s if s.state == HeadState::Scanning && silences <= self.opts.retries => {
                        continue;
                    }
                    _ => return Ok(()),
                }
            }
            self.link.stats_mut().retries += 1;
        }
    }
}

/// What a scan asks of the head besides its rows.
#[derive(Clone, Copy)]
struct Spec {
    output: ScanOutput,
    edge_filter: EdgeFilterMode,
    exposures: Exposures,
}

/// Rows being assembled.
struct Assembly {
    width: usize,
    first: usize,
    rows: usize,
    phase: Option<Vec<f32>>,
    phase_validity: Option<Vec<u8>>,
    xyz: Option<Vec<f32>>,
    point_validity: Option<Vec<u8>>,
    covered: Vec<[usize; 2]>,
    seen: HashSet<(u8, u16, u16)>,
    need: [usize; 2],
    done_rows: usize,
    stale: u64,
    /// The counts of the last ScanDone.
    counts: Option<ScanCounts>,
}

impl Assembly {
    fn complete(&self, r: usize) -> bool {
        self.covered[r][0] >= self.need[0] && self.covered[r][1] >= self.need[1]
    }

    fn store(&mut self, r: &fringe3d_core::wire::ResultRow<'_>) {
        let row = r.row as usize;
        let n = r.columns();
        let c0 = r.first_col as usize;
        if row < self.first || row >= self.first + self.rows || c0 + n > self.width {
            return;
        }
        let i = row - self.first;
        let k = match r.kind {
            RowKind::Phase => 0,
            RowKind::Points => 1,
        };
        let (vals, codes) = match r.kind {
            RowKind::Phase => (self.phase.as_mut(), self.phase_validity.as_mut()),
            RowKind::Points => (self.xyz.as_mut(), self.point_validity.as_mut()),
        };
        let (Some(vals), Some(codes)) = (vals, codes) else {
            return;
        };
        let comps = r.kind.components();
        for c in 0..n {
            for j in 0..comps {
                vals[(i * self.width + c0 + c) * comps + j] = r.value(c, j).unwrap_or(f32::NAN);
            }
            codes[i * self.width + c0 + c] = r.validity(c).map(|v| v as u8).unwrap_or(u8::MAX);
        }
        let was = self.complete(i);
        if self.seen.insert((k as u8, r.row, r.first_col)) {
            self.covered[i][k] += n;
        }
        if !was && self.complete(i) {
            self.done_rows += 1;
        }
    }
}
