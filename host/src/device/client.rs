//! The commands of the scan head, with timeouts and retries.
//!
//! # Reliability
//! - Every request carries a fresh sequence number; answers with another number are stale and
//!   ignored. A request whose answer does not come in time, or comes back as a Nak for line
//!   damage (CRC, framing), is sent again, up to [`ClientOptions::retries`] times; any other Nak
//!   is an error naming the reason.
//! - Uploads keep up to [`ClientOptions::window`] chunks in flight. The head accepts a chunk only
//!   at its current offset; on a timeout or a Nak the client asks where the head stands
//!   (QueryUpload) and goes on from there. A second `upload` of the same data after an
//!   interruption resumes from the last acknowledged chunk: the head answers an identical
//!   BeginUpload with its current offset. The upload ends with ConfirmUpload; the head uses the
//!   data only if the CRC-32C of what it stored equals the digest.
//! - A scan streams rows; rows lost on the line are requested again (a Scan of the missing rows)
//!   until every row is in, at most [`ClientOptions::retries`] times.

use std::collections::{HashSet, VecDeque};
use std::time::{Duration, Instant};

use fringe3d_core::wire::crc::crc32c;
use fringe3d_core::wire::{
    BeginPhaseMap, BeginUpload, Calibration, Capabilities, Command, DefinePatternSet,
    EdgeFilterMode, FirmwareVersion, HeadState, Hello, LutEntry, LutTable, Message, Nak, NakCode,
    PHASE_MAP_BYTES_PER_PIXEL, PROTOCOL_VERSION, Packet, PatternSetDesc, RowKind, ScanOutput,
    ScanRequest, Sequence, Status, UploadAck, UploadChunk, UploadTarget, ValidationStatus,
    WireError, check_header, frame,
};

use super::{DeviceError, Link, Transport, nak_reason};

/// Timeouts and retry limits.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ClientOptions {
    /// Time allowed for an answer, on top of the time its bytes take on the line.
    pub timeout: Duration,
    /// Times a request is sent again (and upload stalls tolerated) before giving up.
    pub retries: u32,
    /// Upload chunks in flight.
    pub window: usize,
    /// Silence tolerated during a scan (capture and decoding take a while).
    pub scan_timeout: Duration,
}

impl Default for ClientOptions {
    fn default() -> Self {
        ClientOptions {
            timeout: Duration::from_millis(500),
            retries: 8,
            window: 4,
            scan_timeout: Duration::from_secs(30),
        }
    }
}

/// What an upload did.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct UploadReport {
    /// Bytes of data.
    pub total: u64,
    /// Offset the head had already (a resumed upload), bytes.
    pub resumed_from: u64,
    /// Bytes put on the line (framing, retries and the confirmation included).
    pub wire_bytes: u64,
    /// Chunks sent (repeats included).
    pub chunks: u64,
    /// Go-backs after losses.
    pub recoveries: u64,
    /// Wall time, seconds.
    pub seconds: f64,
}

/// A scan's result rows, assembled (rows `first_row ..` of the camera).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ScanOutcome {
    /// Camera width.
    pub width: usize,
    /// First row.
    pub first_row: usize,
    /// Rows.
    pub rows: usize,
    /// Absolute phases, `rows × width` (with Phase or Both).
    pub phase: Option<Vec<f32>>,
    /// Their validity codes.
    pub phase_validity: Option<Vec<u8>>,
    /// Points x, y, z, `rows × width × 3` (with Points or Both).
    pub xyz: Option<Vec<f32>>,
    /// Their validity codes.
    pub point_validity: Option<Vec<u8>>,
    /// Scans of missing rows sent after the first.
    pub rescans: u32,
    /// Bytes received during the scan.
    pub wire_bytes: u64,
    /// Wall time, seconds.
    pub seconds: f64,
}

/// An answer, owned.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Copy, Debug, PartialEq)]
enum Reply {
    Capabilities(Capabilities),
    Ack(u8),
    UploadAck(UploadAck),
    Validation(ValidationStatus),
    Status(Status),
}

/// A received frame, sorted.
#[allow(clippy::large_enum_variant)]
enum Got<'a> {
    Version(u8),
    Damaged,
    Frame { seq: u8, msg: Message<'a> },
}

fn classify(f: &[u8]) -> Got<'_> {
    match frame::parse(f) {
        Err(WireError::Version(v)) => Got::Version(v),
        Err(_) => Got::Damaged,
        Ok((h, payload)) => match Message::decode(h.command, payload) {
            Ok(msg) if check_header(&h, &msg).is_ok() => Got::Frame { seq: h.seq, msg },
            _ => Got::Damaged,
        },
    }
}

fn owned(m: &Message<'_>) -> Option<Reply> {
    Some(match *m {
        Message::Capabilities(c) => Reply::Capabilities(c),
        Message::Ack(a) => Reply::Ack(a.command),
        Message::UploadAck(a) => Reply::UploadAck(a),
        Message::Validation(v) => Reply::Validation(v),
        Message::Status(s) => Reply::Status(s),
        _ => return None,
    })
}

/// A connected scan head.
pub struct Client<T> {
    link: Link<T>,
    opts: ClientOptions,
    caps: Capabilities,
}

fn unexpected(what: &str, r: Reply) -> DeviceError {
    DeviceError::Protocol(format!("unexpected answer to {what}: {r:?}"))
}

impl<T: Transport> Client<T> {
    /// Greet the head on `io` (Hello → Capabilities) and check that it speaks our protocol
    /// version: [`Client::open`] then [`Client::hello`].
    pub fn connect(io: T, opts: ClientOptions) -> Result<Self, DeviceError> {
        let mut c = Self::open(io, opts);
        c.hello()?;
        Ok(c)
    }

    /// A client on `io` that has not greeted the head yet (its capabilities are unknown until
    /// [`Client::hello`] succeeds).
    pub fn open(io: T, opts: ClientOptions) -> Self {
        let caps = Capabilities {
            protocol_version: PROTOCOL_VERSION,
            firmware: FirmwareVersion::default(),
            sensor_width: 0,
            sensor_height: 0,
            projector_width: 0,
            projector_height: 0,
            free_memory: 0,
            max_chunk: 1,
            max_sets: 0,
            max_lut_entries: 1,
        };
        Client {
            link: Link::new(io),
            opts,
            caps,
        }
    }

    /// Resynchronise the line and greet the head: Hello → Capabilities, with a version check.
    pub fn hello(&mut self) -> Result<&Capabilities, DeviceError> {
        let what = "Hello";
        self.link.resync(what)?;
        match self.request(
            what,
            Message::Hello(Hello {
                protocol_version: PROTOCOL_VERSION,
            }),
        )? {
            Reply::Capabilities(caps) => {
                if caps.protocol_version != PROTOCOL_VERSION {
                    return Err(DeviceError::Version {
                        device: caps.protocol_version,
                        host: PROTOCOL_VERSION,
                    });
                }
                self.caps = caps;
                Ok(&self.caps)
            }
            r => Err(unexpected(what, r)),
        }
    }

    /// What the head reported on connection.
    pub fn capabilities(&self) -> &Capabilities {
        &self.caps
    }

    /// The link (counters).
    pub fn link(&self) -> &Link<T> {
        &self.link
    }

    /// The link, mutably (tests reach the transport through it).
    pub fn link_mut(&mut self) -> &mut Link<T> {
        &mut self.link
    }

    /// Unwrap the transport.
    pub fn into_transport(self) -> T {
        self.link.into_transport()
    }

    /// The options.
    pub fn options(&self) -> &ClientOptions {
        &self.opts
    }

    fn timeout_for(&self, bytes: usize) -> Duration {
        let line = self
            .link
            .transport()
            .bytes_per_second()
            .map(|bps| Duration::from_secs_f64(2.0 * bytes as f64 / bps));
        self.opts.timeout + line.unwrap_or_default()
    }

    fn nak_error(&mut self, what: &str, n: Nak) -> DeviceError {
        DeviceError::Refused {
            what: what.to_string(),
            code: n.code,
            detail: n.detail,
            reason: nak_reason(n.code, n.detail),
        }
    }

    fn no_response(&self, what: &str, attempts: u32, bad_before: u64) -> DeviceError {
        let bad = self.link.stats().bad_frames - bad_before;
        let noise = if bad > 0 {
            format!(
                " ({bad} damaged frames received: wrong baud rate, or a device speaking another protocol?)"
            )
        } else {
            String::new()
        };
        DeviceError::NoResponse {
            what: what.to_string(),
            attempts,
            noise,
        }
    }

    /// Send `msg` and wait for its answer, retrying on silence and on line-damage Naks.
    fn request(&mut self, what: &str, msg: Message<'_>) -> Result<Reply, DeviceError> {
        let bad_before = self.link.stats().bad_frames;
        let attempts = self.opts.retries + 1;
        for attempt in 1..=attempts {
            if attempt > 1 {
                self.link.stats_mut().retries += 1;
            }
            let seq = self.link.next_seq();
            let p = Packet::request(seq, msg);
            let n = self.link.send(what, &p.header, &msg)?;
            let deadline = Instant::now() + self.timeout_for(n + 64);
            while let Some(f) = self.link.recv(what, deadline)? {
                match classify(&f) {
                    Got::Version(v) => {
                        return Err(DeviceError::Version {
                            device: v,
                            host: PROTOCOL_VERSION,
                        });
                    }
                    Got::Damaged => self.link.stats_mut().bad_frames += 1,
                    Got::Frame { seq: s, .. } if s != seq => {}
                    Got::Frame {
                        msg: Message::Nak(nak),
                        ..
                    } => {
                        self.link.stats_mut().naks += 1;
                        if matches!(nak.code, NakCode::Crc | NakCode::Framing) {
                            break;
                        }
                        return Err(self.nak_error(what, nak));
                    }
                    Got::Frame { msg, .. } => {
                        if let Some(r) = owned(&msg) {
                            return Ok(r);
                        }
                    }
                }
            }
        }
        Err(self.no_response(what, attempts, bad_before))
    }

    fn expect_ack(&mut self, what: &str, msg: Message<'_>) -> Result<(), DeviceError> {
        match self.request(what, msg)? {
            Reply::Ack(_) => Ok(()),
            r => Err(unexpected(what, r)),
        }
    }

    /// The head's status (its error bits are cleared by reading them).
    pub fn status(&mut self) -> Result<Status, DeviceError> {
        match self.request("GetStatus", Message::GetStatus)? {
            Reply::Status(s) => Ok(s),
            r => Err(unexpected("GetStatus", r)),
        }
    }

    /// Define pattern set `set_id` parametrically (the head can then render it itself).
    pub fn define_pattern_set(
        &mut self,
        set_id: u8,
        desc: &PatternSetDesc,
    ) -> Result<(), DeviceError> {
        self.expect_ack(
            "DefinePatternSet",
            Message::DefinePatternSet(DefinePatternSet {
                set_id,
                desc: *desc,
            }),
        )
    }

    /// Upload the calibration.
    pub fn upload_calibration(&mut self, cal: &Calibration) -> Result<(), DeviceError> {
        self.expect_ack("UploadCalibration", Message::UploadCalibration(*cal))
    }

    /// Configure the trigger sequence over set `set_id`.
    pub fn configure_sequence(
        &mut self,
        set_id: u8,
        repeat: bool,
        entries: &[LutEntry],
    ) -> Result<(), DeviceError> {
        let mut buf = vec![0u8; entries.len() * fringe3d_core::wire::LUT_ENTRY_LEN];
        let table = LutTable::encode(entries, &mut buf)
            .map_err(|e| DeviceError::Input(format!("trigger table: {e}")))?;
        self.expect_ack(
            "ConfigureSequence",
            Message::ConfigureSequence(Sequence {
                set_id,
                repeat,
                entries: table,
            }),
        )
    }

    /// Validate the configured sequence.
    pub fn validate(&mut self) -> Result<ValidationStatus, DeviceError> {
        match self.request("ValidateSequence", Message::ValidateSequence)? {
            Reply::Validation(v) => Ok(v),
            r => Err(unexpected("ValidateSequence", r)),
        }
    }

    /// Start the configured sequence.
    pub fn start(&mut self) -> Result<(), DeviceError> {
        self.expect_ack("Start", Message::Start)
    }

    /// Stop it.
    pub fn stop(&mut self) -> Result<(), DeviceError> {
        self.expect_ack("Stop", Message::Stop)
    }

    /// Abort whatever runs (and clear a fault).
    pub fn abort(&mut self) -> Result<(), DeviceError> {
        self.expect_ack("Abort", Message::Abort)
    }

    /// Upload the images of pattern set `set_id` (`data`: every pattern in wire order, rows top to
    /// bottom, a byte per pixel) and confirm them.
    pub fn upload_patterns(
        &mut self,
        set_id: u8,
        desc: &PatternSetDesc,
        data: &[u8],
        progress: &mut dyn FnMut(u64, u64),
    ) -> Result<UploadReport, DeviceError> {
        let total = u32::try_from(data.len())
            .map_err(|_| DeviceError::Input("pattern images exceed 4 GiB".into()))?;
        let begin = BeginUpload {
            set_id,
            image_count: desc.pattern_count() as u16,
            width: desc.width,
            height: desc.height,
            bit_depth: desc.bit_depth,
            total_bytes: total,
            digest: crc32c(data),
        };
        if let Err(e) = begin.validate() {
            return Err(DeviceError::Input(format!(
                "pattern images do not match the set: {e}"
            )));
        }
        self.upload(
            &format!("pattern set {set_id}"),
            UploadTarget::PatternSet(set_id),
            Message::BeginUpload(begin),
            data,
            progress,
        )
    }

    /// Upload the reference phase map (`data` as [`super::desc::phase_map_bytes`] lays it out) and
    /// confirm it.
    pub fn upload_phase_map(
        &mut self,
        width: u16,
        height: u16,
        data: &[u8],
        progress: &mut dyn FnMut(u64, u64),
    ) -> Result<UploadReport, DeviceError> {
        let want = width as usize * height as usize * PHASE_MAP_BYTES_PER_PIXEL;
        if data.len() != want {
            return Err(DeviceError::Input(format!(
                "phase map: {} bytes, expected {want} for {width}x{height}",
                data.len()
            )));
        }
        let begin = BeginPhaseMap {
            width,
            height,
            total_bytes: want as u32,
            digest: crc32c(data),
        };
        self.upload(
            "the reference phase map",
            UploadTarget::PhaseMap,
            Message::BeginPhaseMapUpload(begin),
            data,
            progress,
        )
    }

    fn upload(
        &mut self,
        what: &str,
        target: UploadTarget,
        begin: Message<'_>,
        data: &[u8],
        progress: &mut dyn FnMut(u64, u64),
    ) -> Result<UploadReport, DeviceError> {
        let t0 = Instant::now();
        let sent0 = self.link.stats().bytes_sent;
        let total = data.len() as u64;
        let wrap = |acked: u64, e: DeviceError| -> DeviceError {
            if e.is_transient() {
                DeviceError::UploadInterrupted {
                    what: what.to_string(),
                    acked,
                    total,
                    cause: Box::new(e),
                }
            } else {
                e
            }
        };
        let mut acked = match self.request(&format!("BeginUpload ({what})"), begin) {
            Ok(Reply::UploadAck(a)) if a.target == target => (a.next_offset as u64).min(total),
            Ok(r) => return Err(unexpected("BeginUpload", r)),
            Err(e) => return Err(wrap(0, e)),
        };
        let mut report = UploadReport {
            total,
            resumed_from: acked,
            ..Default::default()
        };
        progress(acked, total);
        let chunk = (self.caps.max_chunk as u64).max(1);
        let window = self.opts.window.max(1);
        let mut next = acked;
        let mut inflight: VecDeque<(u8, u64)> = VecDeque::new();
        let mut stalls = 0u32;
        let bad_before = self.link.stats().bad_frames;
        while acked < total {
            while inflight.len() < window && next < total {
                let end = (next + chunk).min(total);
                let msg = Message::UploadChunk(UploadChunk::new(
                    target,
                    next as u32,
                    &data[next as usize..end as usize],
                ));
                let seq = self.link.next_seq();
                let p = Packet::request(seq, msg);
                self.link
                    .send(what, &p.header, &msg)
                    .map_err(|e| wrap(acked, e))?;
                inflight.push_back((seq, end));
                report.chunks += 1;
                next = end;
            }
            let deadline = Instant::now() + self.timeout_for(window * (chunk as usize + 64));
            let mut go_back = false;
            match self.link.recv(what, deadline).map_err(|e| wrap(acked, e))? {
                None => go_back = true,
                Some(f) => match classify(&f) {
                    Got::Version(v) => {
                        return Err(DeviceError::Version {
                            device: v,
                            host: PROTOCOL_VERSION,
                        });
                    }
                    Got::Damaged => self.link.stats_mut().bad_frames += 1,
                    Got::Frame { seq, msg } => {
                        if let Some(pos) = inflight.iter().position(|(s, _)| *s == seq) {
                            let expected = inflight[pos].1;
                            inflight.drain(..=pos);
                            match msg {
                                Message::UploadAck(a) if a.target == target => {
                                    let n = a.next_offset as u64;
                                    if n > acked {
                                        acked = n.min(total);
                                        stalls = 0;
                                        progress(acked, total);
                                    }
                                    if n < expected {
                                        go_back = true;
                                    }
                                }
                                Message::Nak(nak) => {
                                    self.link.stats_mut().naks += 1;
                                    match nak.code {
                                        NakCode::BadOffset | NakCode::Crc | NakCode::Framing => {
                                            go_back = true
                                        }
                                        _ => {
                                            return Err(
                                                self.nak_error(&format!("a chunk of {what}"), nak)
                                            );
                                        }
                                    }
                                }
                                _ => {
                                    return Err(DeviceError::Protocol(format!(
                                        "unexpected answer to a chunk of {what}"
                                    )));
                                }
                            }
                        }
                    }
                },
            }
            if go_back {
                stalls += 1;
                report.recoveries += 1;
                self.link.stats_mut().retries += 1;
                if stalls > self.opts.retries {
                    let e = self.no_response(&format!("the chunks of {what}"), stalls, bad_before);
                    return Err(wrap(acked, e));
                }
                match self.request(
                    &format!("QueryUpload ({what})"),
                    Message::QueryUpload(target),
                ) {
                    Ok(Reply::UploadAck(a)) if a.target == target => {
                        acked = (a.next_offset as u64).min(total)
                    }
                    Ok(r) => return Err(unexpected("QueryUpload", r)),
                    Err(e) => return Err(wrap(acked, e)),
                }
                progress(acked, total);
                inflight.clear();
                next = acked;
            }
        }
        match self.request(
            &format!("ConfirmUpload ({what})"),
            Message::ConfirmUpload(target),
        ) {
            Ok(Reply::Ack(_)) => {}
            Ok(r) => return Err(unexpected("ConfirmUpload", r)),
            Err(DeviceError::Refused {
                code: NakCode::DigestMismatch,
                ..
            }) => {
                return Err(DeviceError::DigestMismatch {
                    what: what.to_string(),
                });
            }
            Err(e) => return Err(wrap(acked, e)),
        }
        report.wire_bytes = self.link.stats().bytes_sent - sent0;
        report.seconds = t0.elapsed().as_secs_f64();
        Ok(report)
    }

    /// Scan: run the sequence, stream rows `first_row .. first_row + row_count` (0: to the last
    /// row) of `output`, and request lost rows again until all are in. Point rows go through the
    /// head's depth-edge filter when `edge_filter` says so (`fringe3d scan` filters at 80° by
    /// default); the head filters each row with its true neighbours, so the rows of a partial
    /// scan or a re-request equal those of a whole-image scan.
    pub fn scan(
        &mut self,
        output: ScanOutput,
        first_row: u16,
        row_count: u16,
        edge_filter: EdgeFilterMode,
        progress: &mut dyn FnMut(u64, u64),
    ) -> Result<ScanOutcome, DeviceError> {
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
        };
        let mut ranges = vec![(first, rows)];
        let mut rescans = 0u32;
        loop {
            for &(f, n) in &ranges {
                self.scan_stream(output, f as u16, n as u16, edge_filter, &mut acc, progress)?;
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
            wire_bytes: self.link.stats().bytes_received - recv0,
            seconds: t0.elapsed().as_secs_f64(),
        })
    }

    /// One Scan request and its stream. Returns when the stream ended (ScanDone, or silence
    /// after which the head says it no longer scans); rows lost meanwhile are the caller's to
    /// request again.
    fn scan_stream(
        &mut self,
        output: ScanOutput,
        first: u16,
        count: u16,
        edge_filter: EdgeFilterMode,
        acc: &mut Assembly,
        progress: &mut dyn FnMut(u64, u64),
    ) -> Result<(), DeviceError> {
        let what = "Scan";
        let msg = Message::Scan(ScanRequest {
            output,
            first_row: first,
            row_count: count,
            edge_filter,
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
                    Message::ScanDone(_) => return Ok(()),
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
