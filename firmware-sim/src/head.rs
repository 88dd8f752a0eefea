//! The scan head's firmware logic: the wire protocol's command handler, uploads, the trigger
//! sequence, and scans (capture, decode, reconstruct, stream).
//!
//! `no_std`, allocation-free and panic-free on any input: the head works in the buffers it is
//! given ([`HeadMemory`]) and the fixed frame buffers of its own struct.
//!
//! # Main loop
//! A board's `main` owns a [`Head`] and calls [`Head::service`] in a loop with its serial port
//! (anything `embedded-io` `Read + ReadReady + Write`; on a board the two `heapless` UART queues of
//! [`crate::port`]). Each call handles every complete frame received so far, then advances a
//! running sequence by one entry, or runs a requested scan to its end. A scan keeps serving the
//! link between frames and rows: status requests are answered, Abort stops it, anything else is
//! refused with Nak Busy.
//!
//! # State machine (reported by Status)
//! ```text
//!            DefinePatternSet / ConfigureSequence / UploadCalibration
//!   Idle ───────────────────────────────────────────────► Idle (not validated)
//!   Idle ──BeginUpload / BeginPhaseMapUpload──► Uploading ──ConfirmUpload (digest ok)──► Idle
//!   Idle ──ValidateSequence (projection bits clear)──► Ready
//!   Ready ──Start──► Running ──Stop / last entry (once)──► Ready
//!   Ready ──Scan──► Scanning ──ScanDone / Abort──► Ready
//!   Running/Scanning ──hardware fault──► Fault ──Abort──► Idle
//! ```
//! Any change of the set, the sequence or an upload drops the validation (back to Idle). While a
//! sequence runs or a scan streams, only Hello, GetStatus, QueryUpload, ValidateSequence, Stop and
//! Abort are served.
//!
//! # What the head trusts
//! A pattern-set slot is usable when it was defined parametrically, or, after a BeginUpload into
//! it, only once ConfirmUpload found the CRC-32C of the stored bytes equal to the announced
//! digest. The reference phase map likewise. Validation and Scan refuse anything else, so no
//! partially or wrongly uploaded data is ever projected or used.

use embedded_hal::delay::DelayNs;
use embedded_hal::digital::{InputPin, OutputPin};
use embedded_io::{Read, ReadReady, Write};
use fringe3d_core::decode::{DecodeConfig, Decoder, RowOut};
use fringe3d_core::filter::EdgeFilter;
use fringe3d_core::math::CANONICAL_NAN;
use fringe3d_core::pattern::{ImageId, MAX_IMAGES, PatternSet};
use fringe3d_core::reconstruct::{Reconstructor, ReferenceRing};
use fringe3d_core::sequential::FrameDecoder as CaptureDecoder;
use fringe3d_core::validity::Validity;
use fringe3d_core::wire::crc::Crc32c;
use fringe3d_core::wire::frame;
use fringe3d_core::wire::{
    Ack, BeginPhaseMap, BeginUpload, Calibration, Capabilities, Command, EdgeFilterMode,
    FirmwareVersion, Flags, FrameDecoder, HeadErrors, HeadState, Header, Invalid, LUT_ENTRY_LEN,
    LutEntry, MAX_CHUNK, MAX_ENCODED_FRAME, MAX_FRAME, MAX_LUT_ENTRIES, MAX_ROW_DATA, Message, Nak,
    NakCode, PROTOCOL_VERSION, PatternSetDesc, ResultRow, RowKind, ScanDone, ScanOutput,
    ScanRequest, Status, UploadAck, UploadTarget, ValidationStatus, WireError, check_header,
    emit_packet, image_index,
};

use crate::hal::{BoardIo, Camera, HwError, Projector, Storage};
use crate::memory::{HeadMemory, MemoryReport};

/// Pattern-set slots the head has room for.
pub const MAX_SETS: usize = 4;

/// Validation bits that only matter to scans streaming points.
const POINTS_ONLY: u32 = ValidationStatus::NO_CALIBRATION | ValidationStatus::NO_REFERENCE;

/// Fixed parameters of a head.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct HeadConfig {
    /// Reported firmware version.
    pub firmware: FirmwareVersion,
    /// Pattern-set slots offered, `1..=MAX_SETS`.
    pub max_sets: u8,
    /// Largest upload chunk accepted, `1..=MAX_CHUNK`.
    pub max_chunk: u16,
    /// Shortest exposure the projector can show, µs.
    pub min_exposure_us: u32,
    /// Camera readout time, µs: camera-triggered entries need at least this dark time.
    pub readout_us: u32,
    /// How long to wait for the camera-ready and external trigger inputs, µs.
    pub trigger_timeout_us: u32,
    /// Polling step while waiting for an input, µs.
    pub poll_us: u32,
}

impl HeadConfig {
    /// The defaults: firmware 0.1.0, 4 slots, 4064-byte chunks, 100 µs minimum exposure, 1 ms
    /// readout, 1 s trigger timeout polled every 10 µs.
    pub const DEFAULT: HeadConfig = HeadConfig {
        firmware: FirmwareVersion {
            major: 0,
            minor: 1,
            patch: 0,
        },
        max_sets: MAX_SETS as u8,
        max_chunk: MAX_CHUNK as u16,
        min_exposure_us: 100,
        readout_us: 1_000,
        trigger_timeout_us: 1_000_000,
        poll_us: 10,
    };
}

impl Default for HeadConfig {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// Why a head could not be built.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum HeadError {
    /// A line buffer of [`HeadMemory`] is shorter than the camera or projector width needs.
    LineBuffers,
    /// The camera or projector has a zero dimension.
    Dimensions,
    /// A [`HeadConfig`] value is out of range.
    Config,
}

impl HeadError {
    /// The error's class (the enum is its own kind).
    pub const fn kind(self) -> HeadError {
        self
    }
}

impl core::fmt::Display for HeadError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            HeadError::LineBuffers => "a line buffer is shorter than the sensor or projector width",
            HeadError::Dimensions => "the camera or projector has a zero dimension",
            HeadError::Config => "a head configuration value is out of range",
        })
    }
}

/// Why [`Head::service`] stopped: the serial port failed (the board decides what to do; the head
/// keeps its state and can be serviced again).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LinkError {
    /// Reading or writing the port failed.
    Io(embedded_io::ErrorKind),
    /// A frame could not be emitted (a bug: every reply is validated before it is sent).
    Wire(WireError),
}

impl LinkError {
    /// The error's class (the enum is its own kind).
    pub const fn kind(self) -> LinkError {
        self
    }
}

impl core::fmt::Display for LinkError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            LinkError::Io(k) => write!(f, "serial port: {k:?}"),
            LinkError::Wire(e) => write!(f, "cannot emit a frame: {e}"),
        }
    }
}

/// What a [`Head::service`] call did.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Activity {
    /// Nothing: no byte arrived, nothing runs (a board may sleep until the next interrupt).
    Idle,
    /// Something was received or done.
    Busy,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Source {
    Generated,
    Uploaded { confirmed: bool },
}

#[derive(Clone, Copy, Debug)]
struct Slot {
    desc: PatternSetDesc,
    set: PatternSet,
    source: Source,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum UploadKey {
    Patterns(BeginUpload),
    Map(BeginPhaseMap),
}

impl UploadKey {
    fn total(&self) -> u32 {
        match self {
            UploadKey::Patterns(b) => b.total_bytes,
            UploadKey::Map(m) => m.total_bytes,
        }
    }

    fn digest(&self) -> u32 {
        match self {
            UploadKey::Patterns(b) => b.digest,
            UploadKey::Map(m) => m.digest,
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Upload {
    key: UploadKey,
    next: u32,
}

#[derive(Clone, Copy, Debug)]
struct Lut {
    bytes: [u8; MAX_LUT_ENTRIES * LUT_ENTRY_LEN],
    len: usize,
    set_id: u8,
    repeat: bool,
}

impl Lut {
    fn entry(&self, i: usize) -> Option<LutEntry> {
        if i >= self.len {
            return None;
        }
        let b = self.bytes.get(i * LUT_ENTRY_LEN..(i + 1) * LUT_ENTRY_LEN)?;
        LutEntry::from_bytes(b.try_into().ok()?).ok()
    }
}

#[derive(Clone, Copy, Debug)]
struct PendingScan {
    seq: u8,
    output: ScanOutput,
    first: u16,
    count: u16,
    set: PatternSet,
    slot: u8,
    recon: Option<Reconstructor>,
    filter: Option<EdgeFilter>,
}

struct Control {
    caps: Capabilities,
    slots: [Option<Slot>; MAX_SETS],
    image_owner: Option<u8>,
    pattern_upload: Option<Upload>,
    map_upload: Option<Upload>,
    map_confirmed: bool,
    calibration: Option<Calibration>,
    lut: Option<Lut>,
    validated: bool,
    running: Option<usize>,
    scanning: bool,
    pending: Option<PendingScan>,
    abort: bool,
    fault: bool,
    errors: u32,
    rx_frames: u32,
    rx_errors: u32,
    rows_sent: u32,
    state_capacity: usize,
    flags_capacity: usize,
    ring_capacity: usize,
    report: MemoryReport,
}

impl Control {
    fn busy(&self) -> bool {
        self.scanning || self.running.is_some()
    }

    fn state(&self) -> HeadState {
        if self.scanning {
            HeadState::Scanning
        } else if self.running.is_some() {
            HeadState::Running
        } else if self.fault {
            HeadState::Fault
        } else if self.pattern_upload.is_some() || self.map_upload.is_some() {
            HeadState::Uploading
        } else if self.validated {
            HeadState::Ready
        } else {
            HeadState::Idle
        }
    }

    /// What is wrong with the configured sequence (bits of [`ValidationStatus`]).
    fn validation(&self, cfg: &HeadConfig) -> u32 {
        let mut v = 0;
        if self.busy() {
            v |= ValidationStatus::BUSY;
        }
        if self.calibration.is_none() {
            v |= ValidationStatus::NO_CALIBRATION;
        }
        if !self.map_confirmed {
            v |= ValidationStatus::NO_REFERENCE;
        }
        let Some(lut) = &self.lut else {
            return v | ValidationStatus::NO_SEQUENCE;
        };
        let slot = self.slots.get(lut.set_id as usize).and_then(|s| s.as_ref());
        let Some(slot) = slot else {
            return v | ValidationStatus::NO_PATTERN_SET;
        };
        if self.usable(lut.set_id).is_none() {
            v |= ValidationStatus::SET_NOT_CONFIRMED;
        }
        let count = slot.desc.pattern_count();
        let mut triggers = 0;
        for i in 0..lut.len {
            let Some(e) = lut.entry(i) else {
                v |= ValidationStatus::PATTERN_INDEX;
                continue;
            };
            if e.pattern as usize >= count {
                v |= ValidationStatus::PATTERN_INDEX;
            }
            if e.bit_depth != slot.desc.bit_depth {
                v |= ValidationStatus::BIT_DEPTH;
            }
            if e.exposure_us < cfg.min_exposure_us {
                v |= ValidationStatus::EXPOSURE;
            }
            if e.trigger_out {
                triggers += 1;
                if e.dark_us < cfg.readout_us {
                    v |= ValidationStatus::DARK_TIME;
                }
            }
        }
        if triggers == 0 {
            v |= ValidationStatus::TRIGGER;
        }
        v
    }

    /// The slot `id` if it may be projected: defined, and confirmed if uploaded.
    fn usable(&self, id: u8) -> Option<&Slot> {
        let s = self.slots.get(id as usize)?.as_ref()?;
        match s.source {
            Source::Generated => Some(s),
            Source::Uploaded { confirmed: true } if self.image_owner == Some(id) => Some(s),
            Source::Uploaded { .. } => None,
        }
    }

    fn confirmed(&self, t: UploadTarget) -> Option<u32> {
        match t {
            UploadTarget::PatternSet(id) => {
                let s = self.slots.get(id as usize)?.as_ref()?;
                let ok = s.source == Source::Uploaded { confirmed: true }
                    && self.image_owner == Some(id);
                ok.then(|| {
                    s.desc.pattern_count() as u32 * s.desc.width as u32 * s.desc.height as u32
                })
            }
            UploadTarget::PhaseMap => self
                .map_confirmed
                .then(|| self.caps.sensor_width as u32 * self.caps.sensor_height as u32 * 5),
        }
    }

    fn upload_mut(&mut self, t: UploadTarget) -> Option<&mut Upload> {
        match t {
            UploadTarget::PatternSet(id) => self
                .pattern_upload
                .as_mut()
                .filter(|u| matches!(u.key, UploadKey::Patterns(b) if b.set_id == id)),
            UploadTarget::PhaseMap => self.map_upload.as_mut(),
        }
    }
}

/// The transmit side: frame buffers and a counter.
struct Tx {
    scratch: [u8; MAX_FRAME],
    out: [u8; MAX_ENCODED_FRAME],
    row: [u8; MAX_ROW_DATA],
    frames: u32,
}

fn io_err<E: embedded_io::Error>(e: E) -> LinkError {
    LinkError::Io(e.kind())
}

impl Tx {
    fn send<T: Write>(
        &mut self,
        io: &mut T,
        header: &Header,
        msg: &Message<'_>,
    ) -> Result<(), LinkError> {
        let n =
            emit_packet(header, msg, &mut self.scratch, &mut self.out).map_err(LinkError::Wire)?;
        io.write_all(&self.out[..n]).map_err(io_err)?;
        self.frames = self.frames.wrapping_add(1);
        Ok(())
    }

    fn reply<T: Write>(
        &mut self,
        io: &mut T,
        seq: u8,
        msg: Message<'_>,
        more: bool,
    ) -> Result<(), LinkError> {
        let mut h = Header::for_message(&msg, seq);
        h.flags = h.flags.with(Flags::MORE_FOLLOWS, more);
        self.send(io, &h, &msg)
    }

    fn nak<T: Write>(
        &mut self,
        io: &mut T,
        seq: u8,
        command: u8,
        code: NakCode,
        detail: u16,
    ) -> Result<(), LinkError> {
        self.reply(
            io,
            seq,
            Message::Nak(Nak {
                command,
                code,
                detail,
            }),
            false,
        )
    }

    /// Stream one result row as segments of at most [`MAX_ROW_DATA`] bytes.
    #[allow(clippy::too_many_arguments)]
    fn rows<T: Write>(
        &mut self,
        io: &mut T,
        seq: u8,
        row: u16,
        kind: RowKind,
        values: &[f32],
        validity: &[u8],
        before_filter: Option<&[u8]>,
    ) -> Result<(), LinkError> {
        let k = kind.components();
        let stride = kind.stride();
        let per = MAX_ROW_DATA / stride;
        let n = validity.len();
        let mut c0 = 0;
        while c0 < n {
            let c1 = (c0 + per).min(n);
            let m = c1 - c0;
            let vals = values
                .get(c0 * k..c1 * k)
                .ok_or(LinkError::Wire(WireError::BufferTooSmall))?;
            for (j, (v, dst)) in vals.iter().zip(self.row.chunks_exact_mut(4)).enumerate() {
                // Points the edge filter flagged (valid before, DepthEdge now) go as canonical
                // NaN, like every invalid point.
                let c = c0 + j / k;
                let flagged = before_filter.is_some_and(|b| {
                    validity.get(c) == Some(&(Validity::DepthEdge as u8))
                        && b.get(c) == Some(&(Validity::Valid as u8))
                });
                let v = if flagged { CANONICAL_NAN } else { *v };
                dst.copy_from_slice(&v.to_le_bytes());
            }
            let codes = self
                .row
                .get_mut(4 * m * k..m * stride)
                .ok_or(LinkError::Wire(WireError::BufferTooSmall))?;
            codes.copy_from_slice(&validity[c0..c1]);
            let msg = Message::ResultRow(ResultRow {
                row,
                first_col: c0 as u16,
                kind,
                data: &self.row[..m * stride],
            });
            let mut h = Header::for_message(&msg, seq);
            h.flags = h.flags.with(Flags::MORE_FOLLOWS, true);
            let len =
                emit_packet(&h, &msg, &mut self.scratch, &mut self.out).map_err(LinkError::Wire)?;
            io.write_all(&self.out[..len]).map_err(io_err)?;
            self.frames = self.frames.wrapping_add(1);
            c0 = c1;
        }
        Ok(())
    }
}

/// How a scan ended.
enum ScanEnd {
    Done { rows: u16, valid: u32 },
    Aborted,
}

/// Why a scan failed.
enum ScanFail {
    Hw(HwError),
    Internal,
    Link(LinkError),
}

impl From<HwError> for ScanFail {
    fn from(e: HwError) -> Self {
        ScanFail::Hw(e)
    }
}

impl From<LinkError> for ScanFail {
    fn from(e: LinkError) -> Self {
        ScanFail::Link(e)
    }
}

/// The scan head. See the module documentation.
pub struct Head<'m, B> {
    board: B,
    mem: HeadMemory<'m>,
    cfg: HeadConfig,
    rx: FrameDecoder<[u8; MAX_ENCODED_FRAME]>,
    tx: Tx,
    ctl: Control,
}

/// CRC-32C of the first `len` bytes of `store`.
fn store_crc<S: Storage>(store: &mut S, len: u32) -> Result<u32, HwError> {
    let mut crc = Crc32c::new();
    let mut buf = [0u8; 256];
    let mut at = 0u32;
    while at < len {
        let n = ((len - at) as usize).min(buf.len());
        store.read(at, &mut buf[..n])?;
        crc.update(&buf[..n]);
        at += n as u32;
    }
    Ok(crc.finish())
}

/// Wait until the input `pin` of `board` reads high, polling every `cfg.poll_us`, at most
/// `cfg.trigger_timeout_us`.
fn wait_high<B: BoardIo, I: InputPin>(
    board: &mut B,
    pin: impl Fn(&mut B) -> &mut I,
    cfg: &HeadConfig,
) -> Result<(), HwError> {
    let step = cfg.poll_us.max(1);
    let mut waited = 0u32;
    loop {
        if pin(board).is_high().map_err(|_| HwError::Pin)? {
            return Ok(());
        }
        if waited >= cfg.trigger_timeout_us {
            return Err(HwError::Timeout);
        }
        board.delay().delay_us(step);
        waited = waited.saturating_add(step);
    }
}

fn hw_bit(e: HwError) -> u32 {
    match e {
        HwError::Timeout => HeadErrors::TRIGGER_TIMEOUT,
        HwError::Camera => HeadErrors::CAMERA,
        HwError::Projector | HwError::Pin => HeadErrors::PROJECTOR,
        HwError::Storage => HeadErrors::MEMORY,
    }
}

impl<'m, B: BoardIo> Head<'m, B> {
    /// A head driving `board` in `mem`. The line buffers must fit the camera and projector
    /// widths; the per-pixel buffers are checked per scan (a scan that does not fit is refused
    /// with Nak OutOfMemory).
    pub fn new(mut board: B, mem: HeadMemory<'m>, cfg: HeadConfig) -> Result<Self, HeadError> {
        let (w, h) = (
            board.camera().width() as usize,
            board.camera().height() as usize,
        );
        let (pw, ph) = (
            board.projector().width() as usize,
            board.projector().height() as usize,
        );
        if w < 2 || h < 2 || pw == 0 || ph == 0 {
            return Err(HeadError::Dimensions);
        }
        if !(1..=MAX_SETS as u8).contains(&cfg.max_sets)
            || !(1..=MAX_CHUNK as u16).contains(&cfg.max_chunk)
        {
            return Err(HeadError::Config);
        }
        let m = &mem;
        if m.camera_line.len() < w
            || m.projector_line.len() < pw
            || m.phase_row.len() < w
            || m.modulation_row.len() < w
            || m.dc_row.len() < w
            || m.validity_row.len() < w
            || m.xyz_rows.len() < 9 * w
            || m.point_codes.len() < 4 * w
            || m.reference_phase.len() < w
            || m.reference_validity.len() < w
        {
            return Err(HeadError::LineBuffers);
        }
        let caps = Capabilities {
            protocol_version: PROTOCOL_VERSION,
            firmware: cfg.firmware,
            sensor_width: w as u16,
            sensor_height: h as u16,
            projector_width: pw as u16,
            projector_height: ph as u16,
            free_memory: board
                .pattern_store()
                .capacity()
                .saturating_add(board.map_store().capacity()),
            max_chunk: cfg.max_chunk,
            max_sets: cfg.max_sets,
            max_lut_entries: MAX_LUT_ENTRIES as u16,
        };
        let ctl = Control {
            caps,
            slots: [None; MAX_SETS],
            image_owner: None,
            pattern_upload: None,
            map_upload: None,
            map_confirmed: false,
            calibration: None,
            lut: None,
            validated: false,
            running: None,
            scanning: false,
            pending: None,
            abort: false,
            fault: false,
            errors: 0,
            rx_frames: 0,
            rx_errors: 0,
            rows_sent: 0,
            state_capacity: mem.decode_state.len(),
            flags_capacity: mem.decode_flags.len(),
            ring_capacity: mem.ring_phase.len().min(mem.ring_validity.len()),
            report: MemoryReport::default(),
        };
        let mut head = Head {
            board,
            mem,
            cfg,
            rx: FrameDecoder::new([0; MAX_ENCODED_FRAME]),
            tx: Tx {
                scratch: [0; MAX_FRAME],
                out: [0; MAX_ENCODED_FRAME],
                row: [0; MAX_ROW_DATA],
                frames: 0,
            },
            ctl,
        };
        head.ctl.report.head_struct = core::mem::size_of::<Self>();
        Ok(head)
    }

    /// The board (to inspect simulated peripherals).
    pub fn board(&self) -> &B {
        &self.board
    }

    /// The board, mutably.
    pub fn board_mut(&mut self) -> &mut B {
        &mut self.board
    }

    /// The capabilities the head reports.
    pub fn capabilities(&self) -> Capabilities {
        self.ctl.caps
    }

    /// The status the head would report now (without clearing its error bits).
    pub fn status(&self) -> Status {
        Status {
            state: self.ctl.state(),
            errors: HeadErrors(self.ctl.errors),
            rx_frames: self.ctl.rx_frames,
            rx_errors: self.ctl.rx_errors,
            tx_frames: self.tx.frames,
            rows_sent: self.ctl.rows_sent,
        }
    }

    /// Peak use of the head's memory so far.
    pub fn memory_report(&self) -> MemoryReport {
        self.ctl.report
    }

    /// Record the sizes of the UART queues the board uses (for [`Head::memory_report`]).
    pub fn set_queue_sizes(&mut self, rx: usize, tx: usize) {
        self.ctl.report.rx_queue = rx;
        self.ctl.report.tx_queue = tx;
    }

    /// One pass of the main loop: handle every frame received so far, then run a requested scan
    /// to its end (serving the link between rows) or advance a running sequence by one entry.
    pub fn service<T: Read + ReadReady + Write>(
        &mut self,
        io: &mut T,
    ) -> Result<Activity, LinkError> {
        let Head {
            board,
            rx,
            tx,
            ctl,
            cfg,
            ..
        } = self;
        let mut busy = pump(rx, tx, ctl, cfg, io, Some(board))?;
        if let Some(scan) = self.ctl.pending.take() {
            self.run_scan(io, scan)?;
            busy = true;
        } else if let Some(i) = self.ctl.running {
            self.run_step(i);
            busy = true;
        }
        Ok(if busy { Activity::Busy } else { Activity::Idle })
    }

    fn run_step(&mut self, i: usize) {
        let Head {
            board,
            mem,
            cfg,
            ctl,
            ..
        } = self;
        let Some(lut) = ctl.lut.as_ref() else {
            ctl.running = None;
            return;
        };
        let (len, repeat) = (lut.len, lut.repeat);
        let (Some(slot), Some(e)) = (ctl.usable(lut.set_id).copied(), lut.entry(i)) else {
            ctl.running = None;
            return;
        };
        match run_entry(board, mem, cfg, &slot, e, None) {
            Ok(()) => {
                ctl.running = if i + 1 < len {
                    Some(i + 1)
                } else if repeat {
                    Some(0)
                } else {
                    None
                };
            }
            Err(e) => {
                ctl.running = None;
                ctl.fault = true;
                ctl.errors |= hw_bit(e);
            }
        }
    }

    fn run_scan<T: Read + ReadReady + Write>(
        &mut self,
        io: &mut T,
        sc: PendingScan,
    ) -> Result<(), LinkError> {
        self.ctl.scanning = true;
        let res = self.scan_inner(io, &sc);
        let Head { tx, ctl, .. } = self;
        ctl.scanning = false;
        ctl.abort = false;
        let cmd = Command::Scan as u8;
        match res {
            Ok(ScanEnd::Done { rows, valid }) => {
                ctl.validated = true;
                tx.reply(
                    io,
                    sc.seq,
                    Message::ScanDone(ScanDone { rows, valid }),
                    false,
                )
            }
            Ok(ScanEnd::Aborted) => tx.nak(io, sc.seq, cmd, NakCode::Aborted, 0),
            Err(ScanFail::Hw(e)) => {
                ctl.fault = true;
                ctl.errors |= hw_bit(e);
                tx.nak(io, sc.seq, cmd, NakCode::Internal, hw_bit(e) as u16)
            }
            Err(ScanFail::Internal) => {
                ctl.errors |= HeadErrors::INTERNAL;
                tx.nak(
                    io,
                    sc.seq,
                    cmd,
                    NakCode::Internal,
                    HeadErrors::INTERNAL as u16,
                )
            }
            Err(ScanFail::Link(e)) => Err(e),
        }
    }

    fn scan_inner<T: Read + ReadReady + Write>(
        &mut self,
        io: &mut T,
        sc: &PendingScan,
    ) -> Result<ScanEnd, ScanFail> {
        let Head {
            board,
            mem,
            cfg,
            rx,
            tx,
            ctl,
        } = self;
        let slot = *ctl.usable(sc.slot).ok_or(ScanFail::Internal)?;
        let lut = ctl.lut.ok_or(ScanFail::Internal)?;
        let w = board.camera().width() as usize;
        let h = board.camera().height() as usize;
        let bits = board.camera().bit_depth() as u32;
        let decoder = Decoder::new(&sc.set, DecodeConfig::for_bit_depth(bits))
            .map_err(|_| ScanFail::Internal)?;
        let plane = w * h;
        let state_len = CaptureDecoder::state_len(&decoder, w, h);
        let HeadMemory {
            decode_state,
            decode_flags,
            ring_phase,
            ring_validity,
            camera_line,
            projector_line,
            phase_row,
            modulation_row,
            dc_row,
            validity_row,
            xyz_rows,
            point_codes,
            reference_phase,
            reference_validity,
        } = mem;
        let state = decode_state
            .get_mut(..state_len)
            .ok_or(ScanFail::Internal)?;
        let flags = decode_flags.get_mut(..plane).ok_or(ScanFail::Internal)?;
        let mut fd =
            CaptureDecoder::new(&decoder, w, h, state, flags).map_err(|_| ScanFail::Internal)?;
        let r = &mut ctl.report;
        r.decode_state = r.decode_state.max(state_len * 4);
        r.decode_flags = r.decode_flags.max(plane);
        let points = !matches!(sc.output, ScanOutput::Phase);
        // Camera line, decoded row; projector line; three point rows with their codes, the
        // reference row, and with the edge filter its output codes.
        let lines = w * (2 + 12 + 1)
            + board.projector().width() as usize
            + if points { w * (3 * 13 + 5) } else { 0 }
            + if points && sc.filter.is_some() { w } else { 0 };
        r.lines = r.lines.max(lines);

        // Capture: the sequence once, every camera-triggered frame into the decoder.
        let mut lines_buf = Lines {
            camera: camera_line,
            projector: projector_line,
        };
        for i in 0..lut.len {
            pump::<T, B>(rx, tx, ctl, cfg, io, None)?;
            if ctl.abort {
                return Ok(ScanEnd::Aborted);
            }
            let e = lut.entry(i).ok_or(ScanFail::Internal)?;
            entry(board, &mut lines_buf, cfg, &slot, e, Some(&mut fd))?;
        }
        if !fd.is_complete() {
            return Err(ScanFail::Internal);
        }

        // Output rows: decode, reconstruct, stream.
        let mut ring = None;
        let mut recon = None;
        if let (true, Some(rc)) = (points, sc.recon.as_ref()) {
            let rows = (rc.band().rows() as usize).min(h);
            let rp = ring_phase.get_mut(..rows * w).ok_or(ScanFail::Internal)?;
            let rv = ring_validity
                .get_mut(..rows * w)
                .ok_or(ScanFail::Internal)?;
            ring = Some(ReferenceRing::new(rc, rp, rv).map_err(|_| ScanFail::Internal)?);
            recon = Some(rc);
            ctl.report.ring = ctl.report.ring.max(rows * w * 5);
        }
        let (phase_row, modulation_row, dc_row, validity_row) = (
            &mut phase_row[..w],
            &mut modulation_row[..w],
            &mut dc_row[..w],
            &mut validity_row[..w],
        );
        let (xyz_rows, point_codes) = (&mut xyz_rows[..9 * w], &mut point_codes[..4 * w]);
        let (point_codes, filtered) = point_codes.split_at_mut(3 * w);
        let (reference_phase, reference_validity) =
            (&mut reference_phase[..w], &mut reference_validity[..w]);
        let filter = sc.filter.filter(|_| recon.is_some());
        let end = sc.first.saturating_add(sc.count);
        let wanted = |r: u16| r >= sc.first && r < end;
        // With the edge filter, point row y needs rows y − 1 and y + 1 too: decode and
        // reconstruct one row beyond the range at each end (where the image has one), and emit
        // row y once row y + 1 is reconstructed. Point rows rotate through three slots.
        let (lo, hi) = match filter {
            Some(_) => (
                sc.first.saturating_sub(1),
                end.saturating_add(1).min(h as u16),
            ),
            None => (sc.first, end),
        };
        let mut valid = 0u32;
        let mut sent = 0u16;
        for y in lo..hi {
            pump::<T, B>(rx, tx, ctl, cfg, io, None)?;
            if ctl.abort {
                return Ok(ScanEnd::Aborted);
            }
            fd.finish_row(
                y as usize,
                RowOut {
                    phase: &mut *phase_row,
                    modulation: &mut *modulation_row,
                    dc: &mut *dc_row,
                    validity: &mut *validity_row,
                },
            )
            .map_err(|_| ScanFail::Internal)?;
            if wanted(y) && matches!(sc.output, ScanOutput::Phase | ScanOutput::Both) {
                tx.rows(io, sc.seq, y, RowKind::Phase, phase_row, validity_row, None)?;
            }
            let (Some(rc), Some(ring)) = (recon, ring.as_mut()) else {
                if wanted(y) {
                    valid += count_valid(validity_row);
                    sent += 1;
                    ctl.rows_sent = ctl.rows_sent.wrapping_add(1);
                }
                continue;
            };
            let (_, last) = rc.rows_needed(y as u32);
            while ring.rows_pushed() <= last {
                read_reference_row(
                    board.map_store(),
                    ring.rows_pushed(),
                    w,
                    reference_phase,
                    reference_validity,
                )?;
                ring.push_row(reference_phase, reference_validity)
                    .map_err(|_| ScanFail::Internal)?;
            }
            let k = y as usize % 3;
            rc.reconstruct_row(
                ring,
                y as u32,
                phase_row,
                validity_row,
                &mut xyz_rows[3 * w * k..3 * w * (k + 1)],
                &mut point_codes[w * k..w * (k + 1)],
            )
            .map_err(|_| ScanFail::Internal)?;
            // The point row now complete: y itself without the filter, else y − 1.
            let (done, below) = match filter {
                None => (Some(y), false),
                Some(_) => (y.checked_sub(1).filter(|&t| wanted(t)), true),
            };
            if let Some(t) = done {
                valid += emit_points(
                    tx,
                    io,
                    sc.seq,
                    t,
                    h,
                    filter,
                    below,
                    xyz_rows,
                    point_codes,
                    filtered,
                    w,
                )?;
                sent += 1;
                ctl.rows_sent = ctl.rows_sent.wrapping_add(1);
            }
        }
        // The image's last row has no row below: filter it now.
        if let (Some(_), Some(_)) = (filter, recon) {
            let t = end.saturating_sub(1);
            if end as usize == h && wanted(t) {
                valid += emit_points(
                    tx,
                    io,
                    sc.seq,
                    t,
                    h,
                    filter,
                    false,
                    xyz_rows,
                    point_codes,
                    filtered,
                    w,
                )?;
                sent += 1;
                ctl.rows_sent = ctl.rows_sent.wrapping_add(1);
            }
        }
        Ok(ScanEnd::Done { rows: sent, valid })
    }
}

fn count_valid(codes: &[u8]) -> u32 {
    codes
        .iter()
        .filter(|&&v| v == Validity::Valid as u8)
        .count() as u32
}

/// Stream point row `t` from its slot (`t % 3`) of `xyz_rows` / `codes`; with `filter`, first run
/// the depth-edge filter over it with its neighbours (rows `t ± 1`, read from their slots; the
/// row below only if `below`), exactly as the desktop's `filter_edges`: flagged points become
/// canonical NaN. Returns the number of valid points sent.
#[allow(clippy::too_many_arguments)]
fn emit_points<T: Write>(
    tx: &mut Tx,
    io: &mut T,
    seq: u8,
    t: u16,
    h: usize,
    filter: Option<EdgeFilter>,
    below: bool,
    xyz_rows: &[f32],
    codes: &[u8],
    filtered: &mut [u8],
    w: usize,
) -> Result<u32, ScanFail> {
    let slot = |r: usize| {
        let k = r % 3;
        (
            &xyz_rows[3 * w * k..3 * w * (k + 1)],
            &codes[w * k..w * (k + 1)],
        )
    };
    let t = t as usize;
    let cur = slot(t);
    let Some(f) = filter else {
        tx.rows(io, seq, t as u16, RowKind::Points, cur.0, cur.1, None)?;
        return Ok(count_valid(cur.1));
    };
    let above = (t > 0).then(|| slot(t - 1));
    let below = (below && t + 1 < h).then(|| slot(t + 1));
    if !f.filter_row(above, cur, below, filtered) {
        return Err(ScanFail::Internal);
    }
    tx.rows(
        io,
        seq,
        t as u16,
        RowKind::Points,
        cur.0,
        filtered,
        Some(cur.1),
    )?;
    Ok(count_valid(filtered))
}

/// Read row `r` of the reference phase map from `store` (phases LE, then validity codes).
fn read_reference_row<S: Storage>(
    store: &mut S,
    r: u32,
    w: usize,
    phase: &mut [f32],
    validity: &mut [u8],
) -> Result<(), HwError> {
    let row_bytes = (w * 5) as u32;
    let base = r.checked_mul(row_bytes).ok_or(HwError::Storage)?;
    let mut buf = [0u8; 256];
    let mut i = 0usize;
    while i < w {
        let n = (w - i).min(buf.len() / 4);
        let b = &mut buf[..4 * n];
        store.read(base + 4 * i as u32, b)?;
        for (dst, c) in phase[i..i + n].iter_mut().zip(b.chunks_exact(4)) {
            *dst = f32::from_le_bytes([c[0], c[1], c[2], c[3]]);
        }
        i += n;
    }
    store.read(base + 4 * w as u32, &mut validity[..w])
}

struct Lines<'a, 'b> {
    camera: &'a mut &'b mut [u16],
    projector: &'a mut &'b mut [u8],
}

fn run_entry<B: BoardIo>(
    board: &mut B,
    mem: &mut HeadMemory<'_>,
    cfg: &HeadConfig,
    slot: &Slot,
    e: LutEntry,
    capture: Option<&mut CaptureDecoder<'_, '_>>,
) -> Result<(), HwError> {
    let mut lines = Lines {
        camera: &mut mem.camera_line,
        projector: &mut mem.projector_line,
    };
    match entry(board, &mut lines, cfg, slot, e, capture) {
        Ok(()) => Ok(()),
        Err(ScanFail::Hw(e)) => Err(e),
        Err(_) => Err(HwError::Camera),
    }
}

/// Project one sequence entry: wait for the external trigger if asked, load the pattern, show it
/// (and expose the camera if asked), dark time, then read the frame into `capture` (or discard
/// it).
fn entry<B: BoardIo>(
    board: &mut B,
    lines: &mut Lines<'_, '_>,
    cfg: &HeadConfig,
    slot: &Slot,
    e: LutEntry,
    capture: Option<&mut CaptureDecoder<'_, '_>>,
) -> Result<(), ScanFail> {
    if e.wait_for_trigger {
        wait_high(board, B::external_trigger, cfg)?;
    }
    let pw = board.projector().width() as usize;
    let ph = board.projector().height();
    let line = lines.projector.get_mut(..pw).ok_or(ScanFail::Internal)?;
    let id = slot.desc.pattern_id(e.pattern).ok_or(ScanFail::Internal)?;
    let image = image_index(&slot.set, id).ok_or(ScanFail::Internal)?;
    board.projector().begin_frame(e.pattern)?;
    for y in 0..ph {
        match slot.source {
            Source::Generated => slot
                .set
                .generate_row(image, y as u32, line)
                .map_err(|_| ScanFail::Internal)?,
            Source::Uploaded { .. } => {
                let off = (e.pattern as u64 * ph as u64 + y as u64) * pw as u64;
                let off = u32::try_from(off).map_err(|_| ScanFail::Hw(HwError::Storage))?;
                board.pattern_store().read(off, line)?;
            }
        }
        board.projector().write_row(y, line)?;
    }
    board.projector().end_frame()?;
    const PIN: ScanFail = ScanFail::Hw(HwError::Pin);
    board.projector_trigger().set_high().map_err(|_| PIN)?;
    if e.trigger_out {
        board.camera_trigger().set_high().map_err(|_| PIN)?;
    }
    board.delay().delay_us(e.exposure_us);
    if e.trigger_out {
        board.camera_trigger().set_low().map_err(|_| PIN)?;
    }
    board.projector_trigger().set_low().map_err(|_| PIN)?;
    board.delay().delay_us(e.dark_us);
    if e.trigger_out {
        wait_high(board, B::camera_ready, cfg)?;
        let w = board.camera().width() as usize;
        let cam = lines.camera.get_mut(..w).ok_or(ScanFail::Internal)?;
        let mut capture = capture;
        for y in 0..board.camera().height() {
            board.camera().read_row(y, cam)?;
            if let Some(fd) = capture.as_deref_mut() {
                fd.push_row(&cam[..]).map_err(|_| ScanFail::Internal)?;
            }
        }
    }
    Ok(())
}

/// Read every byte available, feed the frame decoder and answer each complete frame. `board` is
/// `None` while a scan holds it (commands that need its stores are refused as busy).
fn pump<T: Read + ReadReady + Write, B: BoardIo>(
    rx: &mut FrameDecoder<[u8; MAX_ENCODED_FRAME]>,
    tx: &mut Tx,
    ctl: &mut Control,
    cfg: &HeadConfig,
    io: &mut T,
    mut board: Option<&mut B>,
) -> Result<bool, LinkError> {
    let mut any = false;
    let mut buf = [0u8; 256];
    while io.read_ready().map_err(io_err)? {
        let n = io.read(&mut buf).map_err(io_err)?;
        if n == 0 {
            break;
        }
        any = true;
        let mut input = &buf[..n];
        while !input.is_empty() {
            let (used, event) = rx.feed(input);
            input = &input[used..];
            match event {
                None => {}
                Some(Err(_)) => {
                    ctl.rx_errors = ctl.rx_errors.wrapping_add(1);
                    ctl.errors |= HeadErrors::LINK;
                }
                Some(Ok(f)) => {
                    ctl.rx_frames = ctl.rx_frames.wrapping_add(1);
                    handle_frame(f, tx, ctl, cfg, io, board.as_deref_mut())?;
                }
            }
        }
    }
    Ok(any)
}

/// Parse one CRC-checked frame and dispatch it; malformed requests get a Nak echoing their seq.
fn handle_frame<T: Write, B: BoardIo>(
    f: &[u8],
    tx: &mut Tx,
    ctl: &mut Control,
    cfg: &HeadConfig,
    io: &mut T,
    board: Option<&mut B>,
) -> Result<(), LinkError> {
    // The CRC passed, so the header bytes are what the host sent.
    let (seq, cmd) = (
        f.get(2).copied().unwrap_or(0),
        f.get(3).copied().unwrap_or(0),
    );
    let (header, payload) = match frame::parse(f) {
        Ok(x) => x,
        Err(e) => {
            let nak = Nak::for_error(cmd, e);
            let detail = if matches!(e, WireError::Version(_)) {
                PROTOCOL_VERSION as u16
            } else {
                nak.detail
            };
            return tx.nak(io, seq, cmd, nak.code, detail);
        }
    };
    let msg = match Message::decode(header.command, payload) {
        Ok(m) => m,
        Err(e) => {
            let nak = Nak::for_error(cmd, e);
            return tx.nak(io, seq, cmd, nak.code, nak.detail);
        }
    };
    if check_header(&header, &msg).is_err() || !msg.command().is_request() {
        return tx.nak(io, seq, cmd, NakCode::Malformed, 0);
    }
    dispatch(tx, ctl, cfg, io, board, header, msg)
}

fn dispatch<T: Write, B: BoardIo>(
    tx: &mut Tx,
    ctl: &mut Control,
    cfg: &HeadConfig,
    io: &mut T,
    board: Option<&mut B>,
    h: Header,
    msg: Message<'_>,
) -> Result<(), LinkError> {
    let seq = h.seq;
    let cmd = h.command;
    let want = !msg.command().is_write() || h.flags.contains(Flags::REPLY_WANTED);
    let ack = Message::Ack(Ack { command: cmd });
    macro_rules! nak {
        ($code:expr, $detail:expr) => {
            return tx.nak(io, seq, cmd, $code, $detail as u16)
        };
    }
    macro_rules! reply {
        ($m:expr) => {
            return if want {
                tx.reply(io, seq, $m, false)
            } else {
                Ok(())
            }
        };
    }
    // Served in every state.
    match msg {
        Message::Hello(hello) => {
            if hello.protocol_version != PROTOCOL_VERSION {
                nak!(NakCode::Version, PROTOCOL_VERSION);
            }
            reply!(Message::Capabilities(ctl.caps));
        }
        Message::GetStatus => {
            let st = Status {
                state: ctl.state(),
                errors: HeadErrors(ctl.errors),
                rx_frames: ctl.rx_frames,
                rx_errors: ctl.rx_errors,
                tx_frames: tx.frames,
                rows_sent: ctl.rows_sent,
            };
            ctl.errors = 0;
            reply!(Message::Status(st));
        }
        Message::QueryUpload(t) => {
            if let Some(u) = ctl.upload_mut(t) {
                let next_offset = u.next;
                reply!(Message::UploadAck(UploadAck {
                    target: t,
                    next_offset
                }));
            }
            match ctl.confirmed(t) {
                Some(total) => reply!(Message::UploadAck(UploadAck {
                    target: t,
                    next_offset: total
                })),
                None => nak!(NakCode::NoUpload, 0),
            }
        }
        Message::ValidateSequence => {
            let v = ctl.validation(cfg);
            if !ctl.busy() && v & !POINTS_ONLY == 0 {
                ctl.validated = true;
            }
            reply!(Message::Validation(ValidationStatus(v)));
        }
        Message::Abort => {
            if ctl.scanning {
                ctl.abort = true;
            }
            ctl.running = None;
            if ctl.fault {
                ctl.fault = false;
                ctl.validated = false;
            }
            reply!(ack);
        }
        Message::Stop => {
            if ctl.scanning {
                nak!(NakCode::Busy, 0);
            }
            ctl.running = None;
            reply!(ack);
        }
        _ => {}
    }
    if !msg.command().is_request() {
        nak!(NakCode::Malformed, 0);
    }
    let Some(board) = board.filter(|_| !ctl.busy()) else {
        nak!(NakCode::Busy, 0);
    };
    match msg {
        Message::DefinePatternSet(d) => {
            if d.set_id >= ctl.caps.max_sets {
                nak!(NakCode::NoSuchSet, 0);
            }
            if d.desc.width != ctl.caps.projector_width
                || d.desc.height != ctl.caps.projector_height
            {
                nak!(NakCode::Invalid, Invalid::Dimension);
            }
            let set = match d.desc.to_set() {
                Ok(s) => s,
                Err(why) => nak!(NakCode::Invalid, why),
            };
            let id = d.set_id;
            let same = matches!(&ctl.slots[id as usize], Some(s) if s.desc == d.desc);
            if !same {
                ctl.slots[id as usize] = Some(Slot {
                    desc: d.desc,
                    set,
                    source: Source::Generated,
                });
                if ctl.image_owner == Some(id) {
                    ctl.image_owner = None;
                }
                if matches!(ctl.pattern_upload, Some(u) if matches!(u.key, UploadKey::Patterns(b) if b.set_id == id))
                {
                    ctl.pattern_upload = None;
                }
                ctl.validated = false;
            }
            reply!(ack);
        }
        Message::BeginUpload(b) => {
            let id = b.set_id;
            let Some(slot) = ctl
                .slots
                .get(id as usize)
                .copied()
                .flatten()
                .filter(|_| id < ctl.caps.max_sets)
            else {
                nak!(NakCode::NoSuchSet, 0);
            };
            let d = &slot.desc;
            if b.image_count as usize != d.pattern_count()
                || b.width != d.width
                || b.height != d.height
            {
                nak!(NakCode::Invalid, Invalid::Dimension);
            }
            if b.bit_depth != d.bit_depth {
                nak!(NakCode::Invalid, Invalid::BitDepth);
            }
            if b.total_bytes > board.pattern_store().capacity() {
                nak!(NakCode::OutOfMemory, 0);
            }
            let key = UploadKey::Patterns(b);
            let next = match ctl.pattern_upload {
                Some(u) if u.key == key => u.next,
                _ => {
                    ctl.pattern_upload = Some(Upload { key, next: 0 });
                    if let Some(s) = ctl
                        .image_owner
                        .filter(|&o| o != id)
                        .and_then(|o| ctl.slots.get_mut(o as usize))
                        .and_then(|s| s.as_mut())
                    {
                        s.source = Source::Uploaded { confirmed: false };
                    }
                    ctl.image_owner = Some(id);
                    if let Some(s) = ctl.slots.get_mut(id as usize).and_then(|s| s.as_mut()) {
                        s.source = Source::Uploaded { confirmed: false };
                    }
                    ctl.validated = false;
                    0
                }
            };
            let target = UploadTarget::PatternSet(id);
            reply!(Message::UploadAck(UploadAck {
                target,
                next_offset: next
            }));
        }
        Message::BeginPhaseMapUpload(m) => {
            if m.width != ctl.caps.sensor_width || m.height != ctl.caps.sensor_height {
                nak!(NakCode::Invalid, Invalid::Dimension);
            }
            if m.total_bytes > board.map_store().capacity() {
                nak!(NakCode::OutOfMemory, 0);
            }
            let key = UploadKey::Map(m);
            let next = match ctl.map_upload {
                Some(u) if u.key == key => u.next,
                _ => {
                    ctl.map_upload = Some(Upload { key, next: 0 });
                    ctl.map_confirmed = false;
                    0
                }
            };
            reply!(Message::UploadAck(UploadAck {
                target: UploadTarget::PhaseMap,
                next_offset: next
            }));
        }
        Message::UploadChunk(c) => {
            if c.data.len() > ctl.caps.max_chunk as usize {
                nak!(NakCode::Invalid, Invalid::ChunkSize);
            }
            let store = match c.target {
                UploadTarget::PatternSet(_) => board.pattern_store(),
                UploadTarget::PhaseMap => board.map_store(),
            };
            let Some((next, total)) = ctl.upload_mut(c.target).map(|u| (u.next, u.key.total()))
            else {
                nak!(NakCode::NoUpload, 0);
            };
            let end = c.offset as u64 + c.data.len() as u64;
            let mut next_offset = next;
            if c.offset == next {
                if end > total as u64 {
                    nak!(NakCode::Invalid, Invalid::Offset);
                }
                if store.write(c.offset, c.data).is_err() {
                    ctl.errors |= HeadErrors::MEMORY;
                    nak!(NakCode::Internal, HeadErrors::MEMORY);
                }
                next_offset = end as u32;
                if let Some(u) = ctl.upload_mut(c.target) {
                    u.next = next_offset;
                }
            } else if end > next as u64 {
                // Not at the current offset and not a repeat of bytes already stored.
                nak!(NakCode::BadOffset, 0);
            }
            reply!(Message::UploadAck(UploadAck {
                target: c.target,
                next_offset
            }));
        }
        Message::ConfirmUpload(t) => {
            let store = match t {
                UploadTarget::PatternSet(_) => board.pattern_store(),
                UploadTarget::PhaseMap => board.map_store(),
            };
            let Some(u) = ctl.upload_mut(t).copied() else {
                if ctl.confirmed(t).is_some() {
                    reply!(ack);
                }
                nak!(NakCode::NoUpload, 0);
            };
            if u.next != u.key.total() {
                nak!(NakCode::NotReady, 0);
            }
            let crc = match store_crc(store, u.key.total()) {
                Ok(c) => c,
                Err(_) => {
                    ctl.errors |= HeadErrors::MEMORY;
                    nak!(NakCode::Internal, HeadErrors::MEMORY);
                }
            };
            if crc != u.key.digest() {
                ctl.errors |= HeadErrors::UPLOAD;
                if let Some(u) = ctl.upload_mut(t) {
                    u.next = 0;
                }
                nak!(NakCode::DigestMismatch, 0);
            }
            match t {
                UploadTarget::PatternSet(id) => {
                    ctl.pattern_upload = None;
                    if let Some(s) = ctl.slots.get_mut(id as usize).and_then(|s| s.as_mut()) {
                        s.source = Source::Uploaded { confirmed: true };
                    }
                }
                UploadTarget::PhaseMap => {
                    ctl.map_upload = None;
                    ctl.map_confirmed = true;
                }
            }
            reply!(ack);
        }
        Message::UploadCalibration(cal) => {
            if cal.camera.width != ctl.caps.sensor_width
                || cal.camera.height != ctl.caps.sensor_height
            {
                nak!(NakCode::Invalid, Invalid::Dimension);
            }
            if let Err(why) = cal.camera_model() {
                nak!(NakCode::Invalid, why);
            }
            ctl.calibration = Some(cal);
            reply!(ack);
        }
        Message::ConfigureSequence(s) => {
            if s.set_id >= ctl.caps.max_sets {
                nak!(NakCode::NoSuchSet, 0);
            }
            let src = s.entries.as_bytes();
            let mut lut = Lut {
                bytes: [0; MAX_LUT_ENTRIES * LUT_ENTRY_LEN],
                len: s.entries.len(),
                set_id: s.set_id,
                repeat: s.repeat,
            };
            match lut.bytes.get_mut(..src.len()) {
                Some(dst) => dst.copy_from_slice(src),
                None => nak!(NakCode::Invalid, Invalid::LutLength),
            }
            ctl.lut = Some(lut);
            ctl.validated = false;
            reply!(ack);
        }
        Message::Start => {
            if ctl.fault {
                nak!(NakCode::NotReady, ctl.errors);
            }
            let v = ctl.validation(cfg) & !POINTS_ONLY;
            if v != 0 {
                nak!(NakCode::SequenceInvalid, v);
            }
            ctl.validated = true;
            ctl.running = Some(0);
            reply!(ack);
        }
        Message::Scan(req) => {
            if ctl.fault {
                nak!(NakCode::NotReady, ctl.errors);
            }
            match plan_scan(ctl, cfg, seq, req) {
                Ok(p) => {
                    ctl.pending = Some(p);
                    // The stream always starts with an Ack, whatever the flags.
                    tx.reply(io, seq, ack, true)
                }
                Err((code, detail)) => nak!(code, detail),
            }
        }
        _ => nak!(NakCode::Malformed, 0),
    }
}

/// Check everything a scan needs and prepare it; on failure the Nak's code and detail.
fn plan_scan(
    ctl: &Control,
    cfg: &HeadConfig,
    seq: u8,
    req: ScanRequest,
) -> Result<PendingScan, (NakCode, u32)> {
    let points = !matches!(req.output, ScanOutput::Phase);
    let mut v = ctl.validation(cfg);
    if !points {
        v &= !POINTS_ONLY;
    }
    if v != 0 {
        return Err((NakCode::SequenceInvalid, v));
    }
    let lut = ctl
        .lut
        .ok_or((NakCode::SequenceInvalid, ValidationStatus::NO_SEQUENCE))?;
    let slot = ctl.usable(lut.set_id).ok_or((
        NakCode::SequenceInvalid,
        ValidationStatus::SET_NOT_CONFIRMED,
    ))?;
    // The capture order: the camera-triggered entries, which must show every pattern once.
    let mut order = [ImageId { level: 0, shift: 0 }; MAX_IMAGES];
    let mut n = 0;
    for i in 0..lut.len {
        let e = lut
            .entry(i)
            .ok_or((NakCode::SequenceInvalid, ValidationStatus::PATTERN_INDEX))?;
        if !e.trigger_out {
            continue;
        }
        let id = slot
            .desc
            .pattern_id(e.pattern)
            .ok_or((NakCode::SequenceInvalid, ValidationStatus::PATTERN_INDEX))?;
        *order
            .get_mut(n)
            .ok_or((NakCode::SequenceInvalid, ValidationStatus::TRIGGER))? = id;
        n += 1;
    }
    let set = slot
        .set
        .with_order(&order[..n])
        .map_err(|_| (NakCode::SequenceInvalid, ValidationStatus::TRIGGER))?;
    let (w, h) = (
        ctl.caps.sensor_width as usize,
        ctl.caps.sensor_height as usize,
    );
    let first = req.first_row;
    let count = if req.row_count == 0 {
        (h as u16).saturating_sub(first)
    } else {
        req.row_count
    };
    if first as usize >= h || first as usize + count as usize > h || count == 0 {
        return Err((NakCode::Invalid, Invalid::Dimension as u32));
    }
    let levels = set.levels().len();
    if (1 + 2 * levels) * w * h > ctl.state_capacity || w * h > ctl.flags_capacity {
        return Err((NakCode::OutOfMemory, 0));
    }
    let recon = if points {
        let cal = ctl
            .calibration
            .as_ref()
            .ok_or((NakCode::SequenceInvalid, ValidationStatus::NO_CALIBRATION))?;
        let r = cal
            .reconstructor(slot.desc.phase.axis)
            .map_err(|why| (NakCode::Invalid, why as u32))?;
        if (r.band().rows() as usize).min(h) * w > ctl.ring_capacity {
            return Err((NakCode::OutOfMemory, 0));
        }
        Some(r)
    } else {
        None
    };
    let filter = match (req.edge_filter, ctl.calibration.as_ref()) {
        (EdgeFilterMode::MaxAngle(a), Some(cal)) if points => Some(
            cal.edge_filter(a)
                .ok_or((NakCode::Invalid, Invalid::EdgeFilter as u32))?,
        ),
        _ => None,
    };
    Ok(PendingScan {
        seq,
        output: req.output,
        first,
        count,
        set,
        slot: lut.set_id,
        recon,
        filter,
    })
}
