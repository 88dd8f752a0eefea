//! The trigger sequence: one table entry at a time (external trigger, pattern load, projector and
//! camera triggers, exposure, dark time, frame readout), and the stepping of a running sequence.

use embedded_hal::delay::DelayNs;
use embedded_hal::digital::{InputPin, OutputPin};
use fringe3d_core::sequential::FrameDecoder as CaptureDecoder;
use fringe3d_core::wire::{LutEntry, image_index};

use super::config::HeadConfig;
use super::control::{Control, Slot, Source};
use super::error::{ScanFail, hw_bit};
use crate::hal::{BoardIo, Camera, HwError, Projector, Storage};
use crate::memory::HeadMemory;

/// Run entry `i` of the running sequence, then point the sequence at its next entry (the first
/// again if it repeats; none after the last); a hardware fault stops it in Fault.
pub(super) fn step<B: BoardIo>(
    board: &mut B,
    mem: &mut HeadMemory<'_>,
    cfg: &HeadConfig,
    ctl: &mut Control,
    i: usize,
) {
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

/// The line buffers an entry projects and reads through.
pub(super) struct Lines<'a, 'b> {
    pub(super) camera: &'a mut &'b mut [u16],
    pub(super) projector: &'a mut &'b mut [u8],
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
pub(super) fn entry<B: BoardIo>(
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
