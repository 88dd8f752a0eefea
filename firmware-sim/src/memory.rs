//! The head's working memory: fixed buffers handed over once, never grown, and a report of how
//! much of them the scans used.
//!
//! Everything per-pixel or per-line lives in caller-owned slices ([`HeadMemory`]); on a board
//! they are `static` arrays ([`HeadBuffers`] holds a complete set in one value that can be a
//! `static`), in tests and on the desktop any slices. The head's own struct adds the frame
//! buffers of the link (receive, transmit, result row): see [`MemoryReport::head_struct`].
//!
//! | buffer | length | bytes per element | for |
//! |---|---|---|---|
//! | `decode_state` | `(1 + 2L)·W·H` | 4 | the frame-sequential decoder's accumulators |
//! | `decode_flags` | `W·H` | 1 | its saturation flags |
//! | `ring_phase` | `band·MW` | 4 | the reference-row ring of the reconstruction |
//! | `ring_validity` | `band·MW` | 1 | its validity codes |
//! | `camera_line` | `W` | 2 | one camera row |
//! | `projector_line` | `PW` | 1 | one pattern row |
//! | `phase_row`, `modulation_row`, `dc_row` | `W` | 4 | one decoded row |
//! | `validity_row` | `W` | 1 | its codes |
//! | `xyz_rows` | `9·W` | 4 | three point rows (the edge filter's window) |
//! | `point_codes` | `4·W` | 1 | their codes, and the filter's output codes |
//! | `reference_phase`, `reference_validity` | `MW` | 4 + 1 | one reference row from storage |
//! | `compiled_line` | `14·W` | 4 | one row of compiled models (`11·W`), the search's points for the pixels they leave (`3·W`) |
//! | `compiled_codes` | `2·W` | 1 | the search's codes and its input mask for those pixels |
//!
//! `W × H` is the camera, `PW` the projector width, `L` the pattern set's levels and `band` the
//! reference rows a point row needs (`Reconstructor::band`). `MW` is the reference map's width:
//! `W` for an image-sized map, `left + W + right` for a map with a margin past the image
//! (issue #17; `Reconstructor::map_width`), which a head takes up to the width these buffers
//! hold (a wider map's upload is refused with Nak OutOfMemory). The map itself,
//! `MW × (top + H + bottom) × 5` bytes, lives in the board's map store (external memory), and
//! so do the compiled reconstruction's models (docs/compiled.md, since protocol version 10),
//! `W × H × 44` bytes at the store's end. A head without the two `compiled_*` buffers (empty
//! slices, or shorter than a camera row needs) refuses the models' upload with Nak OutOfMemory
//! and reconstructs with the search.

/// The head's working buffers (see the module documentation for their sizes).
pub struct HeadMemory<'a> {
    /// Decoder accumulators, `(1 + 2L)·W·H` f32.
    pub decode_state: &'a mut [f32],
    /// Decoder flags, `W·H` bytes.
    pub decode_flags: &'a mut [u8],
    /// Reference ring phases, `band·MW` f32.
    pub ring_phase: &'a mut [f32],
    /// Reference ring validity, `band·MW` bytes.
    pub ring_validity: &'a mut [u8],
    /// One camera row, `W` samples.
    pub camera_line: &'a mut [u16],
    /// One pattern row, `PW` bytes.
    pub projector_line: &'a mut [u8],
    /// Decoded phase, `W`.
    pub phase_row: &'a mut [f32],
    /// Decoded modulation, `W`.
    pub modulation_row: &'a mut [f32],
    /// Decoded DC term, `W`.
    pub dc_row: &'a mut [f32],
    /// Decoded validity, `W`.
    pub validity_row: &'a mut [u8],
    /// Three point rows, `9·W` (x, y, z interleaved, row after row).
    pub xyz_rows: &'a mut [f32],
    /// Their validity codes, then the edge filter's output codes: `4·W`.
    pub point_codes: &'a mut [u8],
    /// One reference row's phases, `MW`.
    pub reference_phase: &'a mut [f32],
    /// One reference row's validity, `MW`.
    pub reference_validity: &'a mut [u8],
    /// One row of compiled models, then the search's points for the pixels they leave:
    /// `14·W` (empty: no compiled reconstruction on this head).
    pub compiled_line: &'a mut [f32],
    /// The search's codes and its input mask for those pixels: `2·W`.
    pub compiled_codes: &'a mut [u8],
}

/// `f32` per camera column of [`HeadMemory::compiled_line`]: a model's eleven numbers and a point's
/// three.
pub const COMPILED_LINE_PER_COLUMN: usize = fringe3d_core::reconstruct::compiled::FIELDS + 3;

/// Buffer lengths (elements) for a head.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MemoryPlan {
    /// `decode_state` length.
    pub decode_state: usize,
    /// `decode_flags` length.
    pub decode_flags: usize,
    /// `ring_phase` and `ring_validity` length.
    pub ring: usize,
    /// Camera line length (`W`).
    pub line: usize,
    /// Projector line length.
    pub projector_line: usize,
    /// Reference row length (`MW`: the widest map row, the camera line and the margins).
    pub map_line: usize,
    /// `compiled_line` length (`14·W`; 0 without the compiled reconstruction).
    pub compiled_line: usize,
    /// `compiled_codes` length (`2·W`; 0 without it).
    pub compiled_codes: usize,
}

impl MemoryPlan {
    /// The lengths for a `width × height` camera, a projector `projector_width` wide, pattern sets
    /// of up to `levels` levels and reference bands of up to `band_rows` rows.
    pub const fn new(
        width: usize,
        height: usize,
        projector_width: usize,
        levels: usize,
        band_rows: usize,
    ) -> Self {
        MemoryPlan {
            decode_state: (1 + 2 * levels) * width * height,
            decode_flags: width * height,
            ring: band_rows * width,
            line: width,
            projector_line: projector_width,
            map_line: width,
            compiled_line: COMPILED_LINE_PER_COLUMN * width,
            compiled_codes: 2 * width,
        }
    }

    /// The same lengths without the compiled reconstruction's row buffers (a head that
    /// reconstructs with the search only).
    pub const fn without_compiled(self) -> Self {
        MemoryPlan {
            compiled_line: 0,
            compiled_codes: 0,
            ..self
        }
    }

    /// The lengths for reference maps up to `columns` wider than the image (the left and right
    /// margins together): the ring and the reference row widen, nothing else.
    pub const fn with_margin_columns(self, columns: usize) -> Self {
        let band_rows = match self.ring.checked_div(self.line) {
            Some(rows) => rows,
            None => 0,
        };
        MemoryPlan {
            ring: band_rows * (self.line + columns),
            map_line: self.line + columns,
            ..self
        }
    }

    /// Total bytes of the buffers of this plan.
    pub const fn bytes(&self) -> usize {
        self.decode_state * 4
            + self.decode_flags
            + self.ring * 5
            + self.line * (2 + 3 * 4 + 1 + 9 * 4 + 4)
            + self.map_line * (4 + 1)
            + self.projector_line
            + self.compiled_line * 4
            + self.compiled_codes
    }
}

/// A complete set of buffers in one value, for a `static` on a board. The const parameters are
/// the lengths of [`MemoryPlan`] (`LINE9 = 9·LINE`, `LINE4 = 4·LINE`, `MAP_LINE` the widest
/// reference map row, `LINE` for image-sized maps, `CLINE = 13·LINE` and `LINE2 = 2·LINE` for
/// the compiled reconstruction, or 0 without it); compute them where the type is named, e.g.
/// `HeadBuffers<{ 7 * 64 * 48 }, { 64 * 48 }, 64, { 9 * 64 }, { 4 * 64 }, 64, { 20 * 64 }, 64,
/// { 13 * 64 }, { 2 * 64 }>`.
pub struct HeadBuffers<
    const STATE: usize,
    const PIXELS: usize,
    const LINE: usize,
    const LINE9: usize,
    const LINE4: usize,
    const PLINE: usize,
    const RING: usize,
    const MAP_LINE: usize,
    const CLINE: usize,
    const LINE2: usize,
> {
    decode_state: [f32; STATE],
    decode_flags: [u8; PIXELS],
    ring_phase: [f32; RING],
    ring_validity: [u8; RING],
    camera_line: [u16; LINE],
    projector_line: [u8; PLINE],
    phase_row: [f32; LINE],
    modulation_row: [f32; LINE],
    dc_row: [f32; LINE],
    validity_row: [u8; LINE],
    xyz_rows: [f32; LINE9],
    point_codes: [u8; LINE4],
    reference_phase: [f32; MAP_LINE],
    reference_validity: [u8; MAP_LINE],
    compiled_line: [f32; CLINE],
    compiled_codes: [u8; LINE2],
}

impl<
    const STATE: usize,
    const PIXELS: usize,
    const LINE: usize,
    const LINE9: usize,
    const LINE4: usize,
    const PLINE: usize,
    const RING: usize,
    const MAP_LINE: usize,
    const CLINE: usize,
    const LINE2: usize,
> Default for HeadBuffers<STATE, PIXELS, LINE, LINE9, LINE4, PLINE, RING, MAP_LINE, CLINE, LINE2>
{
    fn default() -> Self {
        Self::new()
    }
}

impl<
    const STATE: usize,
    const PIXELS: usize,
    const LINE: usize,
    const LINE9: usize,
    const LINE4: usize,
    const PLINE: usize,
    const RING: usize,
    const MAP_LINE: usize,
    const CLINE: usize,
    const LINE2: usize,
> HeadBuffers<STATE, PIXELS, LINE, LINE9, LINE4, PLINE, RING, MAP_LINE, CLINE, LINE2>
{
    /// Zeroed buffers (a `const fn`: usable in a `static` initialiser, placed in `.bss`).
    pub const fn new() -> Self {
        HeadBuffers {
            decode_state: [0.0; STATE],
            decode_flags: [0; PIXELS],
            ring_phase: [0.0; RING],
            ring_validity: [0; RING],
            camera_line: [0; LINE],
            projector_line: [0; PLINE],
            phase_row: [0.0; LINE],
            modulation_row: [0.0; LINE],
            dc_row: [0.0; LINE],
            validity_row: [0; LINE],
            xyz_rows: [0.0; LINE9],
            point_codes: [0; LINE4],
            reference_phase: [0.0; MAP_LINE],
            reference_validity: [0; MAP_LINE],
            compiled_line: [0.0; CLINE],
            compiled_codes: [0; LINE2],
        }
    }

    /// The buffers as a [`HeadMemory`].
    pub fn memory(&mut self) -> HeadMemory<'_> {
        HeadMemory {
            decode_state: &mut self.decode_state,
            decode_flags: &mut self.decode_flags,
            ring_phase: &mut self.ring_phase,
            ring_validity: &mut self.ring_validity,
            camera_line: &mut self.camera_line,
            projector_line: &mut self.projector_line,
            phase_row: &mut self.phase_row,
            modulation_row: &mut self.modulation_row,
            dc_row: &mut self.dc_row,
            validity_row: &mut self.validity_row,
            xyz_rows: &mut self.xyz_rows,
            point_codes: &mut self.point_codes,
            reference_phase: &mut self.reference_phase,
            reference_validity: &mut self.reference_validity,
            compiled_line: &mut self.compiled_line,
            compiled_codes: &mut self.compiled_codes,
        }
    }
}

/// Peak use of the head's memory, bytes: the high-water marks of every scan since start.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct MemoryReport {
    /// Decoder accumulators used.
    pub decode_state: usize,
    /// Decoder flags used.
    pub decode_flags: usize,
    /// Reference ring used (phase and validity).
    pub ring: usize,
    /// Line buffers used (camera, projector, decoded row, point row, reference row, and the
    /// compiled reconstruction's row of models and the search's points for the pixels it
    /// leaves).
    pub lines: usize,
    /// The head struct itself: link frame buffers, pattern-set slots, trigger table, decoder
    /// and reconstructor (`size_of` the `Head`).
    pub head_struct: usize,
    /// The receive queue between the UART interrupt and the main loop, if the board reports it.
    pub rx_queue: usize,
    /// The transmit queue, if the board reports it.
    pub tx_queue: usize,
}

impl MemoryReport {
    /// Sum of all parts.
    pub const fn total(&self) -> usize {
        self.decode_state
            + self.decode_flags
            + self.ring
            + self.lines
            + self.head_struct
            + self.rx_queue
            + self.tx_queue
    }
}
