//! What the decoder reads and writes besides the images: the caller's output rows ([`RowOut`]),
//! the frame-sequential state ([`State`]), the row driver's scratch ([`DecodeScratch`]) and the
//! per-block arrays of both drivers.

use super::BLOCK;
#[cfg(doc)]
use super::decoder::Decoder;
use crate::arith::{Arith, F32Accurate};
use crate::decode_error::DecodeError;
use crate::limits::MAX_LEVELS;
#[cfg(doc)]
use crate::validity::Validity;

/// Output rows of the decoder, all the same length.
pub struct RowOut<'a> {
    /// Absolute phase of the finest level, radians (`c_K·Φ^(P)`); canonical NaN where invalid.
    pub phase: &'a mut [f32],
    /// Modulation B of the finest level, camera codes; or empty when not wanted (a head that
    /// needs only phase and validity saves 4 B per column).
    pub modulation: &'a mut [f32],
    /// DC term A (eq 10/15), camera codes; or empty when not wanted (4 B per column).
    pub dc: &'a mut [f32],
    /// [`Validity`] code per pixel.
    pub validity: &'a mut [u8],
}

impl RowOut<'_> {
    pub(super) fn len_ok(&self, n: usize) -> bool {
        self.phase.len() == n
            && (self.modulation.len() == n || self.modulation.is_empty())
            && (self.dc.len() == n || self.dc.is_empty())
            && self.validity.len() == n
    }
}

/// Borrowed per-pixel decoding state: one plane for the DC accumulator, two per level (S and C
/// accumulators) and a flag byte. All planes have the same length. The element type is the
/// backend's accumulator ([`Arith::Acc`]): f32 by default, i32 for [`crate::arith::Fixed`].
pub struct State<'a, T = f32> {
    /// DC accumulator `Σ w_n·I_n` of the DC level.
    pub dc: &'a mut [T],
    /// S accumulators, one plane per level.
    pub s: [&'a mut [T]; MAX_LEVELS],
    /// C accumulators, one plane per level.
    pub c: [&'a mut [T]; MAX_LEVELS],
    /// Bit 0: some sample was saturated.
    pub flags: &'a mut [u8],
}

/// Scratch memory of the row decoder ([`Decoder::decode_row_with`]): one block of A, the wrapped
/// phase and the modulation measure of every level (about 3.3 KiB with f32 backends). Its
/// contents never carry over from one row to the next.
pub struct DecodeScratch<A: Arith = F32Accurate>(pub(super) Block<A>);

impl<A: Arith> DecodeScratch<A> {
    /// A cleared scratch. A `const fn`, so a head can keep one in a `static`.
    pub const fn new() -> Self {
        DecodeScratch(Block::new())
    }
}

impl<A: Arith> Default for DecodeScratch<A> {
    fn default() -> Self {
        Self::new()
    }
}

/// The per-block scratch of the finishing passes: A, the wrapped phase and the modulation
/// measure of every level, for one block of [`BLOCK`] pixels.
pub(super) struct Block<A: Arith> {
    pub(super) dc: [A::Acc; BLOCK],
    pub(super) wrapped: [[A::Phase; BLOCK]; MAX_LEVELS],
    /// The modulation measure of every level (the smallest is taken in pass 2: a running minimum
    /// stored back per level becomes a masked store, which is slow on some x86 cores).
    pub(super) mag: [[A::Mag; BLOCK]; MAX_LEVELS],
    /// Ambiguous Gray-code bits per pixel (a set with a Gray-code level, [`crate::gray`]).
    pub(super) ambiguous: [u8; BLOCK],
}

impl<A: Arith> Block<A> {
    /// Zeroes everywhere (the backends' `ZERO`s equal their types' `default()`).
    pub(super) const fn new() -> Self {
        Block {
            dc: [A::ZERO; BLOCK],
            wrapped: [[A::PHASE_ZERO; BLOCK]; MAX_LEVELS],
            mag: [[A::MAG_ZERO; BLOCK]; MAX_LEVELS],
            ambiguous: [0; BLOCK],
        }
    }
}

/// The outputs of one block.
pub(super) struct BlockOut<'a> {
    pub(super) phase: &'a mut [f32; BLOCK],
    pub(super) modulation: &'a mut [f32; BLOCK],
    pub(super) dc: &'a mut [f32; BLOCK],
    pub(super) validity: &'a mut [u8; BLOCK],
}

/// The block `range` (of length [`BLOCK`]) of a row, as an array.
#[inline(always)]
pub(super) fn block<T>(
    row: &[T],
    range: core::ops::Range<usize>,
) -> Result<&[T; BLOCK], DecodeError> {
    row.get(range)
        .and_then(|r| r.try_into().ok())
        .ok_or(DecodeError::Length)
}

/// [`block`], mutable.
#[inline(always)]
pub(super) fn block_mut<T>(
    row: &mut [T],
    range: core::ops::Range<usize>,
) -> Result<&mut [T; BLOCK], DecodeError> {
    row.get_mut(range)
        .and_then(|r| r.try_into().ok())
        .ok_or(DecodeError::Length)
}

/// The block `range` of an optional output row ([`RowOut::modulation`], [`RowOut::dc`]): the
/// row's block, or `sink` when the caller passed an empty row. The values are computed either way
/// (the same work, the same bits elsewhere) and dropped in the sink.
#[inline(always)]
pub(super) fn block_or_sink<'a, T>(
    row: &'a mut [T],
    range: core::ops::Range<usize>,
    sink: &'a mut [T; BLOCK],
) -> Result<&'a mut [T; BLOCK], DecodeError> {
    if row.is_empty() {
        Ok(sink)
    } else {
        block_mut(row, range)
    }
}

/// A zeroed stack state for one block of `n ≤ BLOCK` pixels.
pub(super) fn block_state<'a, T>(
    dc: &'a mut [T; BLOCK],
    s: &'a mut [[T; BLOCK]; MAX_LEVELS],
    c: &'a mut [[T; BLOCK]; MAX_LEVELS],
    flags: &'a mut [u8],
    n: usize,
) -> State<'a, T> {
    let [s0, s1, s2, s3, s4, s5] = s;
    let [c0, c1, c2, c3, c4, c5] = c;
    State {
        dc: &mut dc[..n],
        s: [
            &mut s0[..n],
            &mut s1[..n],
            &mut s2[..n],
            &mut s3[..n],
            &mut s4[..n],
            &mut s5[..n],
        ],
        c: [
            &mut c0[..n],
            &mut c1[..n],
            &mut c2[..n],
            &mut c3[..n],
            &mut c4[..n],
            &mut c5[..n],
        ],
        flags: {
            let k = n.min(flags.len());
            &mut flags[..k]
        },
    }
}
