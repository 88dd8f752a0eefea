//! The desktop side of the simulated head (feature `std`): a pseudo-terminal front so that
//! `fringe3d device` talks to it like to a USB serial device, a camera that replays a dataset's
//! images (one dataset per exposure for HDR), heap-backed stores and buffers, and an in-process
//! link for deterministic tests.
//!
//! None of this is firmware: it plays the board (interrupts, external memory, peripherals) around
//! the `no_std` [`Head`].

mod inprocess;
mod pty;
mod replay;

pub use inprocess::{Device, HeadPort, InProcess, VecSink};
pub use pty::{Pty, ServeReport, TX_STALL, serve, serve_with};
pub use replay::{Replay, ReplaySeries, wire_index};

use crate::hal::{HwError, Storage};
use crate::head::Head;
use crate::memory::{HeadMemory, MemoryPlan};
use crate::sim::{FrameSource, RowSink, SimBoard, SimWorld};

/// A [`Storage`] over a `Vec` (the head's external memory on the desktop).
#[derive(Clone, Debug, Default)]
pub struct VecStore {
    bytes: std::vec::Vec<u8>,
}

impl VecStore {
    /// `capacity` zero bytes.
    pub fn new(capacity: usize) -> Self {
        VecStore {
            bytes: std::vec![0; capacity],
        }
    }

    /// The stored bytes.
    pub fn bytes(&self) -> &[u8] {
        &self.bytes
    }

    /// The stored bytes, mutably (tests damage them).
    pub fn bytes_mut(&mut self) -> &mut [u8] {
        &mut self.bytes
    }
}

impl Storage for VecStore {
    fn capacity(&self) -> u32 {
        u32::try_from(self.bytes.len()).unwrap_or(u32::MAX)
    }

    fn write(&mut self, offset: u32, data: &[u8]) -> Result<(), HwError> {
        let s = offset as usize;
        let d = self
            .bytes
            .get_mut(s..s.checked_add(data.len()).ok_or(HwError::Storage)?)
            .ok_or(HwError::Storage)?;
        d.copy_from_slice(data);
        Ok(())
    }

    fn read(&mut self, offset: u32, out: &mut [u8]) -> Result<(), HwError> {
        let s = offset as usize;
        let d = self
            .bytes
            .get(s..s.checked_add(out.len()).ok_or(HwError::Storage)?)
            .ok_or(HwError::Storage)?;
        out.copy_from_slice(d);
        Ok(())
    }
}

/// A [`RowSink`] keeping every pattern the projector was sent (index → image bytes).
#[derive(Clone, Debug, Default)]
pub struct Recorder {
    /// Patterns by index, the last one sent of each.
    pub patterns: std::collections::BTreeMap<u16, std::vec::Vec<u8>>,
}

impl RowSink for Recorder {
    fn row(&mut self, pattern: u16, y: u16, row: &[u8]) {
        let img = self.patterns.entry(pattern).or_default();
        if y == 0 {
            img.clear();
        }
        img.extend_from_slice(row);
    }
}

/// Heap-backed working memory, sized once by a [`MemoryPlan`] (the desktop's stand-in for the
/// board's `static` buffers; `vec!` of zeros maps untouched pages lazily).
pub struct OwnedMemory {
    decode_state: std::vec::Vec<f32>,
    decode_flags: std::vec::Vec<u8>,
    ring_phase: std::vec::Vec<f32>,
    ring_validity: std::vec::Vec<u8>,
    camera_line: std::vec::Vec<u16>,
    projector_line: std::vec::Vec<u8>,
    rows_f32: [std::vec::Vec<f32>; 4],
    rows_u8: [std::vec::Vec<u8>; 2],
    point_codes: std::vec::Vec<u8>,
    xyz: std::vec::Vec<f32>,
    compiled_line: std::vec::Vec<f32>,
    compiled_codes: std::vec::Vec<u8>,
}

impl OwnedMemory {
    /// Buffers of the lengths of `plan`.
    pub fn new(plan: MemoryPlan) -> Self {
        let w = plan.line;
        OwnedMemory {
            decode_state: std::vec![0.0; plan.decode_state],
            decode_flags: std::vec![0; plan.decode_flags],
            ring_phase: std::vec![0.0; plan.ring],
            ring_validity: std::vec![0; plan.ring],
            camera_line: std::vec![0; w],
            projector_line: std::vec![0; plan.projector_line],
            rows_f32: [
                std::vec![0.0; w],
                std::vec![0.0; w],
                std::vec![0.0; w],
                std::vec![0.0; plan.map_line],
            ],
            rows_u8: [std::vec![0; w], std::vec![0; plan.map_line]],
            point_codes: std::vec![0; 4 * w],
            xyz: std::vec![0.0; 9 * w],
            compiled_line: std::vec![0.0; plan.compiled_line],
            compiled_codes: std::vec![0; plan.compiled_codes],
        }
    }

    /// The buffers as a [`HeadMemory`].
    pub fn memory(&mut self) -> HeadMemory<'_> {
        let [phase_row, modulation_row, dc_row, reference_phase] = &mut self.rows_f32;
        let [validity_row, reference_validity] = &mut self.rows_u8;
        HeadMemory {
            decode_state: &mut self.decode_state,
            decode_flags: &mut self.decode_flags,
            ring_phase: &mut self.ring_phase,
            ring_validity: &mut self.ring_validity,
            camera_line: &mut self.camera_line,
            projector_line: &mut self.projector_line,
            phase_row,
            modulation_row,
            dc_row,
            validity_row,
            xyz_rows: &mut self.xyz,
            point_codes: &mut self.point_codes,
            reference_phase,
            reference_validity,
            compiled_line: &mut self.compiled_line,
            compiled_codes: &mut self.compiled_codes,
        }
    }
}

/// A head on the simulated board with `Vec` stores.
pub type SimHead<'m, 'w, F, R> = Head<'m, SimBoard<'w, F, R, VecStore>>;

/// A simulated board in `world`: camera seeing `source`, a `projector.0 × projector.1` projector
/// passing its rows to `sink`, stores of the given sizes.
pub fn sim_board<'w, F: FrameSource, R: RowSink>(
    world: &'w SimWorld,
    source: F,
    sink: R,
    projector: (u16, u16),
    pattern_store: usize,
    map_store: usize,
) -> SimBoard<'w, F, R, VecStore> {
    SimBoard::new(
        world,
        source,
        sink,
        projector,
        VecStore::new(pattern_store),
        VecStore::new(map_store),
    )
}
