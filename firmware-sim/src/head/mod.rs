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
//! refused with Nak Busy. A port error while the scan sends (on the desktop board: the host
//! stopped reading for the port's stall limit, `desktop::TX_STALL`) ends the scan too, so a scan
//! nobody reads does not keep the head busy for good.
//!
//! # State machine (reported by Status)
//! ```text
//!            DefinePatternSet / ConfigureSequence / UploadCalibration
//!   Idle ───────────────────────────────────────────────► Idle (not validated)
//!   Idle ──BeginUpload / BeginPhaseMapUpload / BeginCompiledUpload──► Uploading
//!        ──ConfirmUpload (digest ok)──► Idle
//!   Idle ──ValidateSequence (projection bits clear)──► Ready
//!   Ready ──Start──► Running ──Stop / last entry (once)──► Ready
//!   Ready ──Scan──► Scanning ──ScanDone / Abort──► Ready
//!   Scanning ──port failure (a board's stalled transmitter: nobody reads)──► as before the Scan
//!   Running/Scanning ──hardware fault──► Fault ──Abort──► Idle
//! ```
//! Any change of the set, the sequence or an upload drops the validation (back to Idle). While a
//! sequence runs or a scan streams, only Hello, GetStatus, QueryUpload, ValidateSequence, Stop and
//! Abort are served.
//!
//! # What the head trusts
//! A pattern-set slot is usable when it was defined parametrically, or, after a BeginUpload into
//! it, only once ConfirmUpload found the CRC-32C of the stored bytes equal to the announced
//! digest. The reference phase map likewise, and the compiled reconstruction's models
//! (since protocol version 10, docs/compiled.md), which it takes only after the calibration and a
//! confirmed map of their size and depth range and forgets when either is replaced: they were
//! compiled from them. Validation and Scan refuse anything else, so no partially or wrongly
//! uploaded data is ever projected or used.
//!
//! # Files
//! `config` (the head's parameters), `error`, `control` (the state machine's data and
//! validation), `transmit` (frames out), `dispatch` (frames in, one handler per request),
//! `plan` (a Scan request checked and prepared), `sequence` (one trigger-table entry on the
//! board), `scan` (capture, decode, reconstruct, stream). This file holds [`Head`] and its main
//! loop.

mod config;
mod control;
mod dispatch;
mod error;
mod plan;
mod scan;
mod sequence;
mod transmit;

use embedded_io::{Read, ReadReady, Write};
use fringe3d_core::wire::{
    Capabilities, FrameReceiver, MAX_CHUNK, MAX_ENCODED_FRAME, MAX_LUT_ENTRIES, PROTOCOL_VERSION,
    Status,
};

use crate::hal::{BoardIo, Camera, Projector, Storage};
use crate::memory::{HeadMemory, MemoryReport};

pub use config::{HeadConfig, MAX_SETS};
pub use error::{HeadError, LinkError};

use control::Control;
use dispatch::Link;
use transmit::Tx;

/// What a [`Head::service`] call did.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Activity {
    /// Nothing: no byte arrived, nothing runs (a board may sleep until the next interrupt).
    Idle,
    /// Something was received or done.
    Busy,
}

/// The scan head. See the module documentation.
pub struct Head<'m, B> {
    board: B,
    mem: HeadMemory<'m>,
    cfg: HeadConfig,
    rx: FrameReceiver<[u8; MAX_ENCODED_FRAME]>,
    tx: Tx,
    ctl: Control,
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
        let ctl = Control::new(caps, &mem);
        let mut head = Head {
            board,
            mem,
            cfg,
            rx: FrameReceiver::new([0; MAX_ENCODED_FRAME]),
            tx: Tx::new(),
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
        self.ctl.status(self.tx.frames)
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
            mem,
            cfg,
            rx,
            tx,
            ctl,
        } = self;
        let mut link = Link { rx, tx, ctl, cfg };
        let mut busy = link.pump(io, Some(&mut *board))?;
        if let Some(sc) = link.ctl.pending.take() {
            scan::run(board, mem, &mut link, io, sc)?;
            busy = true;
        } else if let Some(i) = link.ctl.running {
            sequence::step(board, mem, cfg, link.ctl, i);
            busy = true;
        }
        Ok(if busy { Activity::Busy } else { Activity::Idle })
    }
}
