//! The row API of a [`Reconstructor`] (paper §6, row by row): argument checks, the band's row
//! table, then the kernel ([`super::kernel`]) for one row; a whole frame row by row.

use super::LANES;
use super::error::ReconstructError;
use super::gather::{CellGather, ScalarGather};
use super::kernel;
use super::reconstructor::Reconstructor;
use super::reference_rows::{ReferenceMap, ReferenceRows};
use super::refrows::RefRows;
#[cfg(doc)]
use crate::validity::Validity;

impl Reconstructor {
    /// Reconstruct row `v` (paper §6): for each pixel `u`, the point M (x, y, z in mm, camera
    /// frame) into `out_xyz[3u..3u+3]` and its [`Validity`] code into `out_validity[u]`.
    ///
    /// `phase_row` and `validity_row` are the decoder's output for row `v` (absolute phase,
    /// increasing with ξ or η). A pixel whose input code is not `Valid` keeps its code (unknown
    /// codes and non-finite phases marked `Valid` become [`Validity::PhaseOutOfRange`]); a pixel
    /// whose phase is not found gets [`Validity::NoCrossing`], [`Validity::OutOfDepth`],
    /// [`Validity::ReferenceInvalid`] or [`Validity::Degenerate`]. Every invalid pixel's point is
    /// the canonical NaN. `reference` is the [`Reconstructor::map_width`] ×
    /// [`Reconstructor::map_height`] map (the image plus the margin of
    /// [`Reconstructor::with_margin`]) and must hold the rows [`Reconstructor::rows_needed`]
    /// returns.
    ///
    /// Out of line (the flash policy, docs/integration.md): one copy of the kernel per
    /// reference-row source type, however many places call it (this is
    /// [`Reconstructor::reconstruct_span`] over the whole row). A host that wants the kernel
    /// compiled inside its own `#[target_feature(enable = "avx2")]` function (8-wide vectors,
    /// the same bits: no FMA is enabled or contracted) calls
    /// [`Reconstructor::reconstruct_row_gather`], which is always inlined.
    #[inline]
    pub fn reconstruct_row<R: ReferenceRows + ?Sized>(
        &self,
        reference: &R,
        v: u32,
        phase_row: &[f32],
        validity_row: &[u8],
        out_xyz: &mut [f32],
        out_validity: &mut [u8],
    ) -> Result<(), ReconstructError> {
        // The whole row as one span: the out-of-line kernel that
        // `Reconstructor::search_left` calls too (one copy in a firmware).
        let (p, q) = (phase_row, validity_row);
        self.reconstruct_span(reference, v, 0, p, q, out_xyz, out_validity)
    }

    /// [`Reconstructor::reconstruct_row`] with the reference samples fetched by `gather` (a
    /// host's wider gather, e.g. AVX-512 pairs): the same bits as [`ScalarGather`], which
    /// `reconstruct_row` uses. Always inlined, with its kernel: each call site gets its own copy
    /// (a firmware calls [`Reconstructor::reconstruct_row`]).
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    pub fn reconstruct_row_gather<R: ReferenceRows + ?Sized, G: CellGather>(
        &self,
        gather: G,
        reference: &R,
        v: u32,
        phase_row: &[f32],
        validity_row: &[u8],
        out_xyz: &mut [f32],
        out_validity: &mut [u8],
    ) -> Result<(), ReconstructError> {
        self.row_impl(
            gather,
            reference,
            v,
            phase_row,
            validity_row,
            out_xyz,
            out_validity,
            0,
            None,
        )
    }

    /// [`Reconstructor::reconstruct_row_gather`] for the columns `c0 .. c0 + phase.len()` of
    /// row `v` only: the slices hold those columns (`out_xyz` three values a pixel), and the
    /// points and codes are the bits the whole row gives there. For a caller that needs a few
    /// pixels of a row (the ones a compiled row leaves to the search): the row's other chunks
    /// cost nothing. A span that is not empty must start at a multiple of [`LANES`] and end at
    /// one or at the row's end ([`ReconstructError::Length`] otherwise), so that its chunks are
    /// the row's.
    /// Always inlined, like `reconstruct_row_gather`; [`Reconstructor::reconstruct_span`] is
    /// the out-of-line one.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    pub fn reconstruct_span_gather<R: ReferenceRows + ?Sized, G: CellGather>(
        &self,
        gather: G,
        reference: &R,
        v: u32,
        c0: usize,
        phase: &[f32],
        validity: &[u8],
        out_xyz: &mut [f32],
        out_validity: &mut [u8],
    ) -> Result<(), ReconstructError> {
        self.row_impl(
            gather,
            reference,
            v,
            phase,
            validity,
            out_xyz,
            out_validity,
            c0,
            None,
        )
    }

    /// [`Reconstructor::reconstruct_span_gather`] with the scalar gather, out of line (the
    /// flash policy of [`Reconstructor::reconstruct_row`]).
    #[allow(clippy::too_many_arguments)]
    #[inline(never)]
    pub fn reconstruct_span<R: ReferenceRows + ?Sized>(
        &self,
        reference: &R,
        v: u32,
        c0: usize,
        phase: &[f32],
        validity: &[u8],
        out_xyz: &mut [f32],
        out_validity: &mut [u8],
    ) -> Result<(), ReconstructError> {
        let (p, q, o, oq) = (phase, validity, out_xyz, out_validity);
        self.reconstruct_span_gather(ScalarGather, reference, v, c0, p, q, o, oq)
    }

    /// [`Reconstructor::reconstruct_row`], also writing each pixel's crossing N_I as ideal
    /// normalized coordinates `(x, y)` into `crossings[2u..2u+2]` (canonical NaN where there is
    /// none). For diagnostics and tests; the points are the same bits.
    #[allow(clippy::too_many_arguments)]
    pub fn reconstruct_row_with_crossings<R: ReferenceRows + ?Sized>(
        &self,
        reference: &R,
        v: u32,
        phase_row: &[f32],
        validity_row: &[u8],
        out_xyz: &mut [f32],
        out_validity: &mut [u8],
        crossings: &mut [f32],
    ) -> Result<(), ReconstructError> {
        if crossings.len() != 2 * self.width() {
            return Err(ReconstructError::Length);
        }
        self.row_impl(
            ScalarGather,
            reference,
            v,
            phase_row,
            validity_row,
            out_xyz,
            out_validity,
            0,
            Some(crossings),
        )
    }

    /// Whole-frame batch: [`Reconstructor::reconstruct_row`] for every row, with the whole
    /// reference map (with its margin). Same bits as streaming. `phase`/`validity` are `width × height` row-major,
    /// `out_xyz` is `3 × width × height`, `out_validity` `width × height`.
    pub fn reconstruct_frame(
        &self,
        reference: &ReferenceMap<'_>,
        phase: &[f32],
        validity: &[u8],
        out_xyz: &mut [f32],
        out_validity: &mut [u8],
    ) -> Result<(), ReconstructError> {
        let w = self.width();
        let n = w * self.height();
        if phase.len() != n
            || validity.len() != n
            || out_xyz.len() != 3 * n
            || out_validity.len() != n
        {
            return Err(ReconstructError::Length);
        }
        let rows = phase.chunks_exact(w).zip(validity.chunks_exact(w)).zip(
            out_xyz
                .chunks_exact_mut(3 * w)
                .zip(out_validity.chunks_exact_mut(w)),
        );
        for (v, ((p, q), (o, ov))) in rows.enumerate() {
            self.reconstruct_row(reference, v as u32, p, q, o, ov)?;
        }
        Ok(())
    }

    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn row_impl<R: ReferenceRows + ?Sized, G: CellGather>(
        &self,
        gather: G,
        reference: &R,
        v: u32,
        phase_row: &[f32],
        validity_row: &[u8],
        out_xyz: &mut [f32],
        out_validity: &mut [u8],
        c0: usize,
        crossings: Option<&mut [f32]>,
    ) -> Result<(), ReconstructError> {
        let w = self.width();
        if v >= self.cam.height() {
            return Err(ReconstructError::Row);
        }
        let n = phase_row.len();
        let end = c0.checked_add(n).ok_or(ReconstructError::Length)?;
        if end > w
            || (n > 0 && (!c0.is_multiple_of(LANES) || (!end.is_multiple_of(LANES) && end != w)))
            || validity_row.len() != n
            || out_xyz.len() != 3 * n
            || out_validity.len() != n
        {
            return Err(ReconstructError::Length);
        }
        let (mw, mh) = (self.map_width(), self.map_height());
        if reference.width() != mw || reference.height() != mh {
            return Err(ReconstructError::Length);
        }
        if reference.capacity_rows() < self.band.rows().min(mh as u32) {
            return Err(ReconstructError::BandTooSmall {
                needed: self.band.rows(),
                given: reference.capacity_rows(),
            });
        }
        let (first, last) = self.rows_needed(v);
        let data = reference.storage();
        let mut table = RefRows::new(data, first as i64, mh as i64 - 1);
        for r in first..=last {
            let off = reference
                .row_offset(r)
                .ok_or(ReconstructError::NotResident { row: r })?;
            if data.get(off..off + mw).is_none() {
                return Err(ReconstructError::BufferTooSmall);
            }
            table.set((r - first) as usize, off);
        }
        table.finish(mw);
        kernel::row(
            gather,
            self,
            &table,
            v,
            (c0, end),
            phase_row,
            validity_row,
            out_xyz,
            out_validity,
            crossings,
        );
        Ok(())
    }
}
