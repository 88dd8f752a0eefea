//! The §6 search for the pixels a compiled row leaves ([`LEFT_TO_SEARCH`]): their input codes
//! ([`search_mask`]), the runs of the search's chunks that hold them ([`next_search_span`]),
//! and their results taken into the row ([`merge_search`]); [`Reconstructor::search_left`]
//! runs the three over a row, the one loop of the desktop, the head and the C ABI.
//!
//! The simple form, and the reference the golden vectors are made with: the whole row through
//! [`search_mask`], [`Reconstructor::reconstruct_row`] and [`merge_search`]. Searching only the
//! runs of chunks that hold a left pixel gives the same bits (a chunk's results do not depend
//! on the others), without the cost of the rest of the row.

use super::{CompiledError, LEFT_TO_SEARCH};
use crate::reconstruct::LANES;
use crate::reconstruct::{CellGather, ReconstructError, Reconstructor, ReferenceRows};
use crate::validity::Validity;

/// The scratch rows of [`Reconstructor::search_left`], each the image's width long (`xyz`
/// three values a pixel): the search's input codes, points and codes.
pub struct SearchScratch<'a> {
    /// The search's input codes ([`search_mask`]).
    pub mask: &'a mut [u8],
    /// The search's points.
    pub xyz: &'a mut [f32],
    /// The search's codes.
    pub codes: &'a mut [u8],
}

impl Reconstructor {
    /// The search for the pixels [`compiled_row`](super::compiled_row) left in row `v`
    /// (`out_validity[u] == LEFT_TO_SEARCH`), its results into `out_xyz` and `out_validity`:
    /// for each run of chunks that holds one ([`next_search_span`]), [`search_mask`],
    /// [`Reconstructor::reconstruct_span_gather`] and [`merge_search`] over the run's columns.
    /// The bits of the whole row searched (the module's simple form). `phase_row`,
    /// `validity_row` and the outputs are the whole row's; the reference rows as for
    /// [`Reconstructor::reconstruct_row`]. Always inlined (a host compiles it in its own SIMD
    /// function); [`Reconstructor::search_left`] is the out-of-line one.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    pub fn search_left_gather<R: ReferenceRows + ?Sized, G: CellGather>(
        &self,
        gather: G,
        reference: &R,
        v: u32,
        phase_row: &[f32],
        validity_row: &[u8],
        out_xyz: &mut [f32],
        out_validity: &mut [u8],
        scratch: SearchScratch<'_>,
    ) -> Result<(), ReconstructError> {
        let (p, q, o, oq) = (phase_row, validity_row, out_xyz, out_validity);
        let span = Inlined(self, gather, reference, v);
        search_spans(self.width(), p, q, o, oq, scratch, span)
    }

    /// [`Reconstructor::search_left_gather`] with the scalar gather, out of line (the flash
    /// policy of [`Reconstructor::reconstruct_row`]).
    #[allow(clippy::too_many_arguments)]
    #[inline(never)]
    pub fn search_left<R: ReferenceRows + ?Sized>(
        &self,
        reference: &R,
        v: u32,
        phase_row: &[f32],
        validity_row: &[u8],
        out_xyz: &mut [f32],
        out_validity: &mut [u8],
        scratch: SearchScratch<'_>,
    ) -> Result<(), ReconstructError> {
        // Through the out-of-line span (which `reconstruct_row` is too): one copy of the
        // kernel in a firmware, whichever path a scan takes.
        let (p, q, o, oq) = (phase_row, validity_row, out_xyz, out_validity);
        search_spans(
            self.width(),
            p,
            q,
            o,
            oq,
            scratch,
            OutOfLine(self, reference, v),
        )
    }
}

/// The search over one span of a row: (first column, phases, input codes, points, codes).
/// A trait with an always-inlined method rather than a closure: a closure may be compiled out
/// of line, outside a host's `#[target_feature]` function, and so without its vectors.
trait SpanSearch {
    fn span(
        &self,
        c0: usize,
        p: &[f32],
        q: &[u8],
        xyz: &mut [f32],
        codes: &mut [u8],
    ) -> Result<(), ReconstructError>;
}

/// [`Reconstructor::reconstruct_span_gather`], inlined.
struct Inlined<'a, G, R: ?Sized>(&'a Reconstructor, G, &'a R, u32);

impl<G: CellGather, R: ReferenceRows + ?Sized> SpanSearch for Inlined<'_, G, R> {
    #[inline(always)]
    fn span(&self, c0: usize, p: &[f32], q: &[u8], x: &mut [f32], c: &mut [u8]) -> SpanResult {
        let Inlined(r, g, reference, v) = *self;
        r.reconstruct_span_gather(g, reference, v, c0, p, q, x, c)
    }
}

/// [`Reconstructor::reconstruct_span`], out of line.
struct OutOfLine<'a, R: ?Sized>(&'a Reconstructor, &'a R, u32);

impl<R: ReferenceRows + ?Sized> SpanSearch for OutOfLine<'_, R> {
    #[inline(always)]
    fn span(&self, c0: usize, p: &[f32], q: &[u8], x: &mut [f32], c: &mut [u8]) -> SpanResult {
        let OutOfLine(r, reference, v) = *self;
        r.reconstruct_span(reference, v, c0, p, q, x, c)
    }
}

type SpanResult = Result<(), ReconstructError>;

/// The loop of [`Reconstructor::search_left_gather`]: for each run of chunks that holds a
/// pixel left to the search, its input codes, `span` (the search over those columns) and the
/// merge.
#[inline(always)]
fn search_spans<S: SpanSearch>(
    w: usize,
    phase_row: &[f32],
    validity_row: &[u8],
    out_xyz: &mut [f32],
    out_validity: &mut [u8],
    scratch: SearchScratch<'_>,
    span: S,
) -> Result<(), ReconstructError> {
    let SearchScratch { mask, xyz, codes } = scratch;
    if [phase_row.len(), validity_row.len(), out_validity.len()] != [w; 3]
        || [mask.len(), codes.len()] != [w; 2]
        || out_xyz.len() != 3 * w
        || xyz.len() != 3 * w
    {
        return Err(ReconstructError::Length);
    }
    let mut from = 0;
    while let Some((a, b)) = next_search_span(out_validity, from) {
        let spans = (
            mask.get_mut(a..b),
            xyz.get_mut(3 * a..3 * b),
            codes.get_mut(a..b),
            out_xyz.get_mut(3 * a..3 * b),
            out_validity.get_mut(a..b),
            phase_row.get(a..b),
            validity_row.get(a..b),
        );
        let (Some(m), Some(sx), Some(sq), Some(o), Some(oq), Some(p), Some(q)) = spans else {
            return Err(ReconstructError::Length);
        };
        search_mask(oq, q, m).map_err(|_| ReconstructError::Length)?;
        span.span(a, p, m, sx, sq)?;
        merge_search(sx, sq, o, oq).map_err(|_| ReconstructError::Length)?;
        from = b;
    }
    Ok(())
}

/// The input codes for the search pass over the pixels [`compiled_row`](super::compiled_row) left
/// (`compiled_codes[u] == LEFT_TO_SEARCH`): their input code `validity_row[u]`, and
/// [`Validity::OutOfDepth`] (a code the search keeps, and skips) for every other pixel; into
/// `out` (all three of length `w`).
pub fn search_mask(
    compiled_codes: &[u8],
    validity_row: &[u8],
    out: &mut [u8],
) -> Result<(), CompiledError> {
    if validity_row.len() != compiled_codes.len() || out.len() != compiled_codes.len() {
        return Err(CompiledError::Length);
    }
    for ((o, &q), &c) in out.iter_mut().zip(validity_row).zip(compiled_codes) {
        *o = if c == LEFT_TO_SEARCH {
            q
        } else {
            Validity::OutOfDepth as u8
        };
    }
    Ok(())
}

/// The next run of the search's chunks ([`LANES`] pixels, from column 0) that hold a pixel
/// [`compiled_row`](super::compiled_row) left to the search (`compiled_codes[u] == LEFT_TO_SEARCH`), at or after
/// column `from`: its columns `(start, end)`, for
/// [`Reconstructor::reconstruct_span_gather`]
/// (a chunk boundary or the row's end at both ends), or `None` when no chunk from `from` on
/// holds one (or `from` is past the row). `from` is rounded down to a chunk. A row's runs, each searched with
/// [`search_mask`] and taken with [`merge_search`] over its columns, give the bits of the whole
/// row searched once; the chunks between them are not run.
pub fn next_search_span(compiled_codes: &[u8], from: usize) -> Option<(usize, usize)> {
    let w = compiled_codes.len();
    let holds = |c: usize| {
        compiled_codes
            .get(c..(c + LANES).min(w))
            .is_some_and(|s| s.contains(&LEFT_TO_SEARCH))
    };
    if from >= w {
        return None;
    }
    let mut start = from - from % LANES;
    while start < w && !holds(start) {
        start += LANES;
    }
    if start >= w {
        return None;
    }
    let mut end = start + LANES;
    while end < w && holds(end) {
        end += LANES;
    }
    Some((start, end.min(w)))
}

/// Take the search's results (a row run with [`search_mask`]'s codes) for the pixels
/// [`compiled_row`](super::compiled_row) left to it into the compiled row's outputs.
pub fn merge_search(
    search_xyz: &[f32],
    search_validity: &[u8],
    out_xyz: &mut [f32],
    out_validity: &mut [u8],
) -> Result<(), CompiledError> {
    let w = out_validity.len();
    if search_xyz.len() != 3 * w || search_validity.len() != w || out_xyz.len() != 3 * w {
        return Err(CompiledError::Length);
    }
    let src = search_xyz.chunks_exact(3).zip(search_validity);
    let dst = out_xyz.chunks_exact_mut(3).zip(out_validity.iter_mut());
    for ((si, &sq), (o, oq)) in src.zip(dst) {
        if *oq == LEFT_TO_SEARCH {
            o.iter_mut().zip(si).for_each(|(d, s)| *d = *s);
            *oq = sq;
        }
    }
    Ok(())
}
