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
//!   until every row is in, at most [`ClientOptions::retries`] times. Every Scan request carries
//!   a fresh scan identity that the head copies into each row and its ScanDone; rows and
//!   ScanDones of any other scan (an earlier one still in flight) are dropped and counted
//!   ([`ScanOutcome::stale_rows`]), never assembled.

use std::collections::VecDeque;
use std::time::{Duration, Instant};

use fringe3d_core::decode::{DecodeConfig, PhaseCorrection};
use fringe3d_core::reconstruct::Margin;
use fringe3d_core::wire::crc::crc32c;
use fringe3d_core::wire::{
    BeginCompiled, BeginPhaseMap, BeginUpload, Calibration, Capabilities, Command,
    DecodeThresholds, DefineCorrection, DefinePatternSet, DefineThresholds, FirmwareVersion, Hello,
    LutEntry, LutTable, Message, Nak, NakCode, PHASE_MAP_BYTES_PER_PIXEL, PROTOCOL_VERSION, Packet,
    PatternSetDesc, Sequence, SetupCorrection, Status, UploadAck, UploadChunk, UploadTarget,
    ValidationStatus, WireError, check_header, frame,
};

use super::{DeviceError, Link, Transport, nak_reason};
use crate::scan::ScanCounts;

mod scan;

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
    /// The head's counts over the scan's rows (ScanDone, protocol version 11): the pixels with
    /// a valid phase and, of them, those whose point the §6 search computed (with compiled
    /// models, those the models left to it; none in a phase scan). `None` when rows were
    /// requested again (those came from another capture) or the ScanDone was lost.
    pub counts: Option<ScanCounts>,
    /// Frames of other scans (rows or ScanDones with another scan identity: an earlier scan's,
    /// still in flight) received and dropped.
    pub stale_rows: u64,
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

/// `true` if `m` is of a kind that answers a `req` request (its Ack or Nak naming `req`, or the
/// reply of its kind). Frames of another kind that carry the awaited `seq` — answers of an
/// earlier session still in flight — are not taken for the answer.
fn answers(req: Command, m: &Message<'_>) -> bool {
    match m {
        Message::Nak(n) => n.command == req as u8,
        Message::Ack(a) => a.command == req as u8,
        Message::Capabilities(_) => req == Command::Hello,
        Message::Status(_) => req == Command::GetStatus,
        Message::Validation(_) => req == Command::ValidateSequence,
        Message::UploadAck(_) => matches!(
            req,
            Command::BeginUpload
                | Command::BeginPhaseMapUpload
                | Command::BeginCompiledUpload
                | Command::UploadChunk
                | Command::QueryUpload
        ),
        _ => false,
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

    /// Stop waiting once `flag` is set (Ctrl-C): requests then fail with
    /// [`DeviceError::Interrupted`], and a scan first aborts itself on the head
    /// ([`super::interrupt`]).
    pub fn set_interrupt(&mut self, flag: std::sync::Arc<std::sync::atomic::AtomicBool>) {
        self.link.set_interrupt(Some(flag));
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
                    Got::Frame { seq: s, msg: m } if s != seq || !answers(msg.command(), &m) => {}
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

    /// Set (or with `None` clear) the phase-error table pattern set `set_id` is decoded with
    /// (protocol version 4).
    pub fn define_correction(
        &mut self,
        set_id: u8,
        table: Option<&PhaseCorrection>,
    ) -> Result<(), DeviceError> {
        self.expect_ack(
            "DefineCorrection",
            Message::DefineCorrection(DefineCorrection {
                set_id,
                table: table.map(SetupCorrection::from),
            }),
        )
    }

    /// Set (or with `None` clear: the camera bit depth's defaults) the decoder thresholds
    /// pattern set `set_id` is decoded with (protocol version 7).
    pub fn define_thresholds(
        &mut self,
        set_id: u8,
        config: Option<&DecodeConfig>,
    ) -> Result<(), DeviceError> {
        self.expect_ack(
            "DefineThresholds",
            Message::DefineThresholds(DefineThresholds {
                set_id,
                thresholds: config.map(|c| DecodeThresholds::from(*c)),
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

    /// Upload the reference phase map of a `width × height` camera, extending `margin` past the
    /// image (issue #17; [`Margin::ZERO`] for an image-sized map), with `data` as
    /// [`super::desc::phase_map_bytes`] lays it out, and confirm it.
    pub fn upload_phase_map(
        &mut self,
        width: u16,
        height: u16,
        margin: Margin,
        data: &[u8],
        progress: &mut dyn FnMut(u64, u64),
    ) -> Result<UploadReport, DeviceError> {
        let mut begin = BeginPhaseMap {
            width,
            height,
            margin,
            total_bytes: 0,
            digest: crc32c(data),
        };
        let (mw, mh) = (begin.map_width() as usize, begin.map_height() as usize);
        let want = mw * mh * PHASE_MAP_BYTES_PER_PIXEL;
        if data.len() != want {
            return Err(DeviceError::Input(format!(
                "phase map: {} bytes, expected {want} for a {mw}x{mh} map ({width}x{height} and \
                 the margin {:?})",
                data.len(),
                margin.to_array()
            )));
        }
        begin.total_bytes = u32::try_from(want).map_err(|_| {
            DeviceError::Input(format!("phase map: {want} bytes exceed the wire's 4 GiB"))
        })?;
        self.upload(
            "the reference phase map",
            UploadTarget::PhaseMap,
            Message::BeginPhaseMapUpload(begin),
            data,
            progress,
        )
    }

    /// Upload the compiled reconstruction's models (docs/compiled.md; protocol version 10) of a
    /// `width × height` camera compiled for depths `[z_min, z_max]` mm, `data` the rows of a
    /// `fringe3d compile` file after its header, and confirm them. The head takes them after
    /// the calibration and the reference map they were compiled from, and forgets them when
    /// either is replaced.
    pub fn upload_compiled(
        &mut self,
        width: u16,
        height: u16,
        z: (f32, f32),
        data: &[u8],
        progress: &mut dyn FnMut(u64, u64),
    ) -> Result<UploadReport, DeviceError> {
        let begin = BeginCompiled {
            width,
            height,
            z_min: z.0,
            z_max: z.1,
            total_bytes: u32::try_from(data.len()).map_err(|_| {
                DeviceError::Input(format!(
                    "compiled models: {} bytes exceed the wire's 4 GiB",
                    data.len()
                ))
            })?,
            digest: crc32c(data),
        };
        if let Err(e) = begin.validate() {
            return Err(DeviceError::Input(format!(
                "compiled models: {e} ({} bytes for a {width}x{height} camera)",
                data.len()
            )));
        }
        let r = self.upload(
            "the compiled reconstruction",
            UploadTarget::Compiled,
            Message::BeginCompiledUpload(begin),
            data,
            progress,
        );
        match r {
            // The detail names what the head lacks (ValidationStatus bits).
            Err(DeviceError::Refused {
                what,
                code: code @ NakCode::NotReady,
                detail,
                ..
            }) => {
                let v = ValidationStatus(u32::from(detail));
                let missing: Vec<&str> = [
                    (ValidationStatus::NO_CALIBRATION, "the calibration"),
                    (ValidationStatus::NO_REFERENCE, "the reference map"),
                ]
                .into_iter()
                .filter(|(bit, _)| v.has(*bit))
                .map(|(_, name)| name)
                .collect();
                Err(DeviceError::Refused {
                    what,
                    code,
                    detail,
                    reason: format!(
                        "the head takes compiled models only after the calibration and the \
                         reference map they were compiled from; it has not got {}",
                        missing.join(" nor ")
                    ),
                })
            }
            r => r,
        }
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
                        let ours = match msg {
                            Message::UploadAck(a) => a.target == target,
                            ref m => answers(Command::UploadChunk, m),
                        };
                        if let Some(pos) = inflight
                            .iter()
                            .position(|(s, _)| *s == seq)
                            .filter(|_| ours)
                        {
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
}
