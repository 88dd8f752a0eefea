//! The control state machine (module docs of [`super`]): pattern-set slots, uploads, the
//! trigger table, calibration, validation, and the counters Status reports.

use fringe3d_core::filter::EdgeFilter;
use fringe3d_core::pattern::PatternSet;
use fringe3d_core::reconstruct::Reconstructor;
use fringe3d_core::wire::{
    BeginCompiled, BeginPhaseMap, BeginUpload, Calibration, Capabilities, DecodeThresholds,
    Exposures, HeadErrors, HeadState, Holds, LUT_ENTRY_LEN, LutEntry, MAX_LUT_ENTRIES,
    PatternSetDesc, ScanOutput, SetupCorrection, Status, UploadTarget, ValidationStatus,
};

use super::config::{HeadConfig, MAX_SETS};
use crate::memory::{COMPILED_LINE_PER_COLUMN, HeadMemory, MemoryReport};

/// Validation bits that only matter to scans streaming points.
pub(super) const POINTS_ONLY: u32 =
    ValidationStatus::NO_CALIBRATION | ValidationStatus::NO_REFERENCE;

/// Where a slot's patterns come from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Source {
    Generated,
    Uploaded { confirmed: bool },
}

/// A pattern-set slot: its description, the core's set, its source, and the phase-error table
/// (DefineCorrection) and thresholds (DefineThresholds) it is decoded with.
#[derive(Clone, Copy, Debug)]
pub(super) struct Slot {
    pub(super) desc: PatternSetDesc,
    pub(super) set: PatternSet,
    pub(super) source: Source,
    pub(super) correction: Option<SetupCorrection>,
    pub(super) thresholds: Option<DecodeThresholds>,
}

/// What an upload is for, as announced (a repeated Begin with the same key resumes it).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum UploadKey {
    Patterns(BeginUpload),
    Map(BeginPhaseMap),
    Compiled(BeginCompiled),
}

impl UploadKey {
    pub(super) fn total(&self) -> u32 {
        match self {
            UploadKey::Patterns(b) => b.total_bytes,
            UploadKey::Map(m) => m.total_bytes,
            UploadKey::Compiled(c) => c.total_bytes,
        }
    }

    pub(super) fn digest(&self) -> u32 {
        match self {
            UploadKey::Patterns(b) => b.digest,
            UploadKey::Map(m) => m.digest,
            UploadKey::Compiled(c) => c.digest,
        }
    }
}

/// Where the compiled models of `c` lie in a map store of `capacity` bytes: at its end, after
/// the reference map (which starts at 0), or `None` if the store is too small for them.
pub(super) fn compiled_base(capacity: u32, c: &BeginCompiled) -> Option<u32> {
    capacity.checked_sub(c.total_bytes)
}

/// An upload in progress: its key and the next offset expected.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Upload {
    pub(super) key: UploadKey,
    pub(super) next: u32,
}

/// The configured trigger table (sequence entries as received).
#[derive(Clone, Copy, Debug)]
pub(super) struct Lut {
    pub(super) bytes: [u8; MAX_LUT_ENTRIES * LUT_ENTRY_LEN],
    pub(super) len: usize,
    pub(super) set_id: u8,
    pub(super) repeat: bool,
}

impl Lut {
    pub(super) fn entry(&self, i: usize) -> Option<LutEntry> {
        if i >= self.len {
            return None;
        }
        let b = self.bytes.get(i * LUT_ENTRY_LEN..(i + 1) * LUT_ENTRY_LEN)?;
        LutEntry::from_bytes(b.try_into().ok()?).ok()
    }
}

/// A scan accepted and planned, run after the frames being handled.
#[derive(Clone, Copy, Debug)]
pub(super) struct PendingScan {
    pub(super) seq: u8,
    pub(super) scan_id: u32,
    pub(super) output: ScanOutput,
    pub(super) first: u16,
    pub(super) count: u16,
    pub(super) set: PatternSet,
    pub(super) slot: u8,
    pub(super) recon: Option<Reconstructor>,
    /// The compiled models' announcement (they lie at [`compiled_base`] of the map store), with
    /// `recon`.
    pub(super) compiled: Option<BeginCompiled>,
    /// Whether a whole earlier scan found every row of those models settled: this one reads
    /// them as they are, without `PixelModel::settle_row_counted`.
    pub(super) compiled_settled: bool,
    pub(super) filter: Option<EdgeFilter>,
    /// The exposure list (HDR): the sequence runs once per exposure.
    pub(super) exposures: Exposures,
}

/// The head's state: slots, uploads, calibration, sequence, what runs, and its counters.
pub(super) struct Control {
    pub(super) caps: Capabilities,
    pub(super) slots: [Option<Slot>; MAX_SETS],
    pub(super) image_owner: Option<u8>,
    pub(super) pattern_upload: Option<Upload>,
    pub(super) map_upload: Option<Upload>,
    /// The confirmed reference map's announcement (its size and margin), if any.
    pub(super) map_confirmed: Option<BeginPhaseMap>,
    pub(super) compiled_upload: Option<Upload>,
    /// The confirmed compiled models' announcement, if any (forgotten with the calibration or
    /// the map they were compiled from).
    pub(super) compiled_confirmed: Option<BeginCompiled>,
    /// Whether a whole scan found every row of the confirmed compiled models settled
    /// (`PixelModel::settle_row_counted` changed nothing): later scans read their rows as they
    /// are. Forgotten with them and at every new upload.
    pub(super) compiled_settled: bool,
    pub(super) calibration: Option<Calibration>,
    /// The last point scan's reconstructor (for its pattern set's axis and the map's margin),
    /// kept so that the next scan of the same kind skips its set-up (the grid analysis, in
    /// software f64 on a Cortex-M4F); forgotten with the calibration.
    pub(super) recon_cache: Option<Reconstructor>,
    pub(super) lut: Option<Lut>,
    pub(super) validated: bool,
    pub(super) running: Option<usize>,
    pub(super) scanning: bool,
    pub(super) pending: Option<PendingScan>,
    pub(super) abort: bool,
    pub(super) fault: bool,
    pub(super) errors: u32,
    pub(super) rx_frames: u32,
    pub(super) rx_errors: u32,
    pub(super) rows_sent: u32,
    pub(super) state_capacity: usize,
    pub(super) flags_capacity: usize,
    pub(super) ring_capacity: usize,
    /// Samples of one reference row the head can stage (the widest map row it takes).
    pub(super) reference_capacity: usize,
    /// The widest camera row of compiled models the head can stage (0: none).
    pub(super) compiled_capacity: usize,
    pub(super) report: MemoryReport,
}

impl Control {
    /// The state of a new head reporting `caps`, working in `mem`: nothing defined, uploaded or
    /// running.
    pub(super) fn new(caps: Capabilities, mem: &HeadMemory<'_>) -> Control {
        Control {
            caps,
            slots: [None; MAX_SETS],
            image_owner: None,
            pattern_upload: None,
            map_upload: None,
            map_confirmed: None,
            compiled_upload: None,
            compiled_confirmed: None,
            compiled_settled: false,
            calibration: None,
            recon_cache: None,
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
            reference_capacity: mem.reference_phase.len().min(mem.reference_validity.len()),
            compiled_capacity: (mem.compiled_line.len() / COMPILED_LINE_PER_COLUMN)
                .min(mem.compiled_codes.len() / 2),
            report: MemoryReport::default(),
        }
    }

    pub(super) fn busy(&self) -> bool {
        self.scanning || self.running.is_some()
    }

    pub(super) fn state(&self) -> HeadState {
        if self.scanning {
            HeadState::Scanning
        } else if self.running.is_some() {
            HeadState::Running
        } else if self.fault {
            HeadState::Fault
        } else if self.pattern_upload.is_some()
            || self.map_upload.is_some()
            || self.compiled_upload.is_some()
        {
            HeadState::Uploading
        } else if self.validated {
            HeadState::Ready
        } else {
            HeadState::Idle
        }
    }

    /// What the head holds (bits of [`Holds`]): what Status reports.
    pub(super) fn holds(&self) -> Holds {
        let mut h = 0;
        if self.calibration.is_some() {
            h |= Holds::CALIBRATION;
        }
        if self.map_confirmed.is_some() {
            h |= Holds::REFERENCE;
        }
        if self.compiled_confirmed.is_some() {
            h |= Holds::COMPILED;
        }
        Holds(h)
    }

    /// The status the head reports: its state, counters and what it holds (`tx_frames`, kept
    /// by the sender).
    pub(super) fn status(&self, tx_frames: u32) -> Status {
        Status {
            state: self.state(),
            errors: HeadErrors(self.errors),
            rx_frames: self.rx_frames,
            rx_errors: self.rx_errors,
            tx_frames,
            rows_sent: self.rows_sent,
            holds: self.holds(),
        }
    }

    /// What is wrong with the configured sequence (bits of [`ValidationStatus`]).
    pub(super) fn validation(&self, cfg: &HeadConfig) -> u32 {
        let mut v = 0;
        if self.busy() {
            v |= ValidationStatus::BUSY;
        }
        if self.calibration.is_none() {
            v |= ValidationStatus::NO_CALIBRATION;
        }
        if self.map_confirmed.is_none() {
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
        if slot.set.binarization().is_binary() && slot.correction.is_none() {
            v |= ValidationStatus::NO_CORRECTION;
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
    pub(super) fn usable(&self, id: u8) -> Option<&Slot> {
        let s = self.slots.get(id as usize)?.as_ref()?;
        match s.source {
            Source::Generated => Some(s),
            Source::Uploaded { confirmed: true } if self.image_owner == Some(id) => Some(s),
            Source::Uploaded { .. } => None,
        }
    }

    pub(super) fn confirmed(&self, t: UploadTarget) -> Option<u32> {
        match t {
            UploadTarget::PatternSet(id) => {
                let s = self.slots.get(id as usize)?.as_ref()?;
                let ok = s.source == Source::Uploaded { confirmed: true }
                    && self.image_owner == Some(id);
                ok.then(|| {
                    s.desc.pattern_count() as u32 * s.desc.width as u32 * s.desc.height as u32
                })
            }
            UploadTarget::PhaseMap => self.map_confirmed.map(|m| m.total_bytes),
            UploadTarget::Compiled => self.compiled_confirmed.map(|c| c.total_bytes),
        }
    }

    /// Forget the compiled models, confirmed or arriving (their calibration or map changes).
    pub(super) fn drop_compiled(&mut self) {
        self.compiled_upload = None;
        self.compiled_confirmed = None;
        self.compiled_settled = false;
    }

    pub(super) fn upload_mut(&mut self, t: UploadTarget) -> Option<&mut Upload> {
        match t {
            UploadTarget::PatternSet(id) => self
                .pattern_upload
                .as_mut()
                .filter(|u| matches!(u.key, UploadKey::Patterns(b) if b.set_id == id)),
            UploadTarget::PhaseMap => self.map_upload.as_mut(),
            UploadTarget::Compiled => self.compiled_upload.as_mut(),
        }
    }
}
