//! The memory a head needs for the core's row pipeline (issue #23): every buffer a firmware keeps
//! in its statics to decode a camera row and reconstruct its points, per image column and in
//! total, for a given width, pattern set, sample size and reconstruction band
//! (docs/integration.md, "Buffers and their sizes"; `fringe3d budget` prints it).
//!
//! The layout is the one `firmware-sim/board-mps2` and `examples/head-minimal` keep, with the
//! choices they make as options ([`RowLayout`]); `tests/tests/qemu_firmware.rs` checks the
//! board's static RAM, as its linker laid it out, against [`RowBudget::total`] of its layout.
//!
//! | buffer | bytes per column | when |
//! |---|---|---|
//! | row `v` of each of the N images | `N·s` (`s` bytes per sample) | always |
//! | decoded phase (f32) and validity (u8) | 5 | always |
//! | modulation and DC rows (f32 each) | 8 | [`RowLayout::modulation_rows`] |
//! | reference ring: B rows of f32 phase | `4·B` per map column | points, unless [`RowLayout::map_in_place`] |
//! | the reference row on its way into the ring | 4 per map column | points, [`RowLayout::staging_row`] |
//! | points: x, y, z (f32) and codes (u8) | 13, or 39 for the edge filter's 3 rows | points |
//! | the edge filter's output codes | 1 | [`RowLayout::edge_filter`] |
//!
//! A head whose reference map lies in memory it can address (a QSPI/OSPI flash in memory-mapped
//! mode, PSRAM; [`RowLayout::map_in_place`]) reads it there through
//! [`ReferenceMap::from_prepared`](crate::reconstruct::ReferenceMap::from_prepared) and keeps no
//! ring: the map's `4·MW·MH` bytes are then in that memory, not in SRAM.
//!
//! The reference map may extend past the image (issue #17, [`crate::reconstruct::Margin`]): its
//! rows are then `left + W + right` columns wide ([`RowBudget::margin_columns`] = `left + right`),
//! and so are the ring's and the staging row's; every other buffer is `W` columns.
//!
//! plus, not per column: the decoder (a `static Option<Decoder>` built in place by
//! `HeadSetup::decoder_into`), the decoder's scratch (`DecodeScratch`, for
//! `decode_row_with`), and the set-up blob's bytes. The stack comes on top (docs/integration.md,
//! "Stack per call": measured, not derived).

use crate::decode::{DecodeScratch, Decoder};
use crate::wire::setup::MAX_SETUP_BLOB;

/// Which buffers a firmware keeps, beyond the rows every row pipeline needs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RowLayout {
    /// Reconstruct points (the reference ring and the point row); `false`: phase only.
    pub points: bool,
    /// The reference map is read where it lies, in memory-mapped storage (`ReferenceMap`): no
    /// ring and no staging row in SRAM (the example); `false`: the map streams from storage
    /// through a `ReferenceRing` of the band's rows (the board).
    pub map_in_place: bool,
    /// The edge filter: a window of 3 point rows and its output codes.
    pub edge_filter: bool,
    /// Modulation and DC rows of their own (a head that sends them; the board lets them share
    /// the point row that is free while a row decodes, and the example passes empty rows).
    pub modulation_rows: bool,
    /// A row buffer to stage the reference row before `ReferenceRing::push_row` (the board
    /// stages it in the free point row).
    pub staging_row: bool,
    /// The decoder in a `static` (the board; the example keeps it on `main`'s stack).
    pub decoder_static: bool,
    /// A `DecodeScratch` in a `static` for `decode_row_with` (the example; `decode_row` makes one
    /// on the stack).
    pub scratch_static: bool,
    /// The set-up blob in a buffer of its own (the example; the board reads it into the ring's
    /// storage before the ring is made).
    pub blob_static: bool,
}

impl RowLayout {
    /// `firmware-sim/board-mps2`'s golden-vector firmware: points and the edge filter, the
    /// modulation, DC and reference rows in the free point row, the decoder in a static, the
    /// blob in the ring's storage.
    pub const BOARD: RowLayout = RowLayout {
        points: true,
        map_in_place: false,
        edge_filter: true,
        modulation_rows: false,
        staging_row: false,
        decoder_static: true,
        scratch_static: false,
        blob_static: false,
    };

    /// `examples/head-minimal`: phase, validity and points, the reference map read in place
    /// (memory-mapped); no edge filter and no modulation or DC rows; the scratch and the blob in
    /// statics, the decoder on the stack.
    pub const MINIMAL: RowLayout = RowLayout {
        points: true,
        map_in_place: true,
        edge_filter: false,
        modulation_rows: false,
        staging_row: false,
        decoder_static: false,
        scratch_static: true,
        blob_static: true,
    };

    /// [`RowLayout::MINIMAL`] for a map streamed from storage the core cannot address: the
    /// reference ring and a row to stage each reference row in.
    pub const MINIMAL_RING: RowLayout = RowLayout {
        points: true,
        map_in_place: false,
        edge_filter: false,
        modulation_rows: false,
        staging_row: true,
        decoder_static: false,
        scratch_static: true,
        blob_static: true,
    };
}

/// One buffer of a [`RowBudget`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BudgetLine {
    /// What it holds.
    pub name: &'static str,
    /// Bytes per image column (0 for the fixed-size buffers).
    pub per_column: usize,
    /// Bytes at the budget's width.
    pub bytes: usize,
}

/// Most lines of a budget.
pub const MAX_BUDGET_LINES: usize = 10;

/// The static memory of a row pipeline ([`crate::budget`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RowBudget {
    /// Image width (the widest the firmware's buffers hold), pixels.
    pub width: usize,
    /// Images per set (the row buffers hold one row of each).
    pub images: usize,
    /// Bytes per camera sample: 1 (8-bit) or 2.
    pub sample_bytes: usize,
    /// Reference rows the ring holds: the reconstruction's band (`Reconstructor::band`).
    pub band_rows: usize,
    /// Columns of the reference map beyond the image, `left + right` of its margin
    /// (`Reconstructor::map_width` − width; 0 for an image-sized map): the ring and the staging
    /// row are this much wider than the image.
    pub margin_columns: usize,
    /// What is kept.
    pub layout: RowLayout,
}

impl RowBudget {
    /// The buffers, in the order of the module table (then the fixed ones); `count` of them.
    pub fn lines(&self) -> ([BudgetLine; MAX_BUDGET_LINES], usize) {
        let w = self.width;
        let l = &self.layout;
        let point_rows = if l.edge_filter { 3 } else { 1 };
        // (kept, name, bytes per column, spans the reference map's columns)
        let rows: [(bool, &'static str, usize, bool); 7] = [
            (
                true,
                "image rows (one row of each image)",
                self.images * self.sample_bytes,
                false,
            ),
            (true, "decoded phase (f32) and validity (u8)", 5, false),
            (l.modulation_rows, "modulation and DC rows (f32)", 8, false),
            (
                l.points && !l.map_in_place,
                "reference ring (band rows of f32 phase)",
                4 * self.band_rows,
                true,
            ),
            (
                l.points && !l.map_in_place && l.staging_row,
                "reference row staging (f32)",
                4,
                true,
            ),
            (
                l.points,
                "point rows (x, y, z f32 and a code)",
                13 * point_rows,
                false,
            ),
            (
                l.points && l.edge_filter,
                "edge filter output codes (u8)",
                1,
                false,
            ),
        ];
        let fixed: [(bool, &'static str, usize); 3] = [
            (
                l.decoder_static,
                "decoder (static Option<Decoder>)",
                core::mem::size_of::<Option<Decoder>>(),
            ),
            (
                l.scratch_static,
                "decode scratch (DecodeScratch)",
                core::mem::size_of::<DecodeScratch>(),
            ),
            (
                l.blob_static,
                "set-up blob (MAX_SETUP_BLOB)",
                MAX_SETUP_BLOB,
            ),
        ];
        let mut out = [BudgetLine {
            name: "",
            per_column: 0,
            bytes: 0,
        }; MAX_BUDGET_LINES];
        let mut n = 0;
        let map_w = w + self.margin_columns;
        let per = rows
            .iter()
            .map(|&(on, name, c, map)| (on, name, c, c * if map { map_w } else { w }));
        let all = per.chain(fixed.iter().map(|&(on, name, b)| (on, name, 0, b)));
        for (on, name, per_column, bytes) in all {
            if let (true, Some(slot)) = (on, out.get_mut(n)) {
                *slot = BudgetLine {
                    name,
                    per_column,
                    bytes,
                };
                n += 1;
            }
        }
        (out, n)
    }

    /// Bytes per image column over all per-column buffers (the ring's and the staging row's per
    /// column of the reference map, which has [`RowBudget::margin_columns`] more).
    pub fn per_column(&self) -> usize {
        let (lines, n) = self.lines();
        lines.iter().take(n).map(|l| l.per_column).sum()
    }

    /// Bytes of every buffer together (statics; the stack comes on top).
    pub fn total(&self) -> usize {
        let (lines, n) = self.lines();
        lines.iter().take(n).map(|l| l.bytes).sum()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_board_layout_is_the_documented_formula() {
        // docs/firmware.md: (2N + 45 + 4B)·W plus the decoder.
        let b = RowBudget {
            width: 1280,
            images: 8,
            sample_bytes: 2,
            band_rows: 25,
            margin_columns: 0,
            layout: RowLayout::BOARD,
        };
        assert_eq!(b.per_column(), 2 * 8 + 45 + 4 * 25);
        let decoder = core::mem::size_of::<Option<Decoder>>();
        assert_eq!(b.total(), (2 * 8 + 45 + 4 * 25) * 1280 + decoder);
    }

    #[test]
    fn the_minimal_layout_is_the_examples_formula() {
        // examples/head-minimal, the map in place: (2N + 4 + 1 + 4·3 + 1)·W, scratch and blob;
        // neither the band nor the map's margin costs SRAM.
        let fixed = core::mem::size_of::<DecodeScratch>() + MAX_SETUP_BLOB;
        let in_place = RowBudget {
            width: 640,
            images: 8,
            sample_bytes: 2,
            band_rows: 16,
            margin_columns: 96,
            layout: RowLayout::MINIMAL,
        };
        assert_eq!(in_place.total(), (16 + 4 + 1 + 12 + 1) * 640 + fixed);
        // Streamed through a ring: (2N + 4 + 1 + 4B + 4 + 4·3 + 1)·W.
        let b = RowBudget {
            margin_columns: 0,
            layout: RowLayout::MINIMAL_RING,
            ..in_place
        };
        let fixed = core::mem::size_of::<DecodeScratch>() + MAX_SETUP_BLOB;
        assert_eq!(b.total(), (16 + 4 + 1 + 64 + 4 + 12 + 1) * 640 + fixed);
        // A map 96 columns wider than the image widens the ring and the staging row only.
        let wide = RowBudget {
            margin_columns: 96,
            ..b
        };
        assert_eq!(wide.total(), b.total() + (4 * 16 + 4) * 96);
        assert_eq!(wide.per_column(), b.per_column());
        // Phase only: no ring and no point row.
        let phase = RowBudget {
            layout: RowLayout {
                points: false,
                ..RowLayout::MINIMAL_RING
            },
            ..b
        };
        assert_eq!(phase.per_column(), 16 + 5);
    }
}
