//! Frame-sequential decoding: accumulate frames as a camera delivers them.
//!
//! Real cameras deliver whole frames one after another, not one row of every image. A
//! [`FrameDecoder`] folds each frame, row by row, into a compact per-pixel state held in caller
//! buffers, and produces outputs row by row once the last frame is in. It runs exactly the kernel
//! of the row API ([`Decoder::accumulate`] then [`Decoder::finish`]) on the same per-pixel values
//! in the same order, so its results are bit-identical to [`Decoder::decode_row`].
//!
//! # Memory
//! The state is `1 + 2·L` f32 planes (the DC accumulator, then S and C per level) plus one flag
//! byte per pixel: [`FrameDecoder::bytes_per_pixel`] = `4·(1 + 2L) + 1`, i.e. **29 bytes per
//! pixel** for the paper's 3-level set (38 MB for a 1280×1024 sensor, in external RAM on a head).
//! Frames arrive in the set's order ([`crate::pattern::PatternSet::order`]). Because the 2-image
//! levels subtract the DC term A only in the final step (their S and C are linear in the samples
//! and in A), the DC level need not come first: nothing is buffered besides the state.
//!
//! The decoder's arithmetic ([`crate::arith`]) sets the element type of the state: f32 for the
//! default and the other f32 backends, i32 for [`crate::arith::Fixed`]; both are 4 bytes, so the
//! memory figures hold for every backend.

use crate::arith::{Arith, F32Accurate};
use crate::decode::{DecodeError, Decoder, RowOut, Sample, State};
use crate::pattern::MAX_LEVELS;

/// Decodes a set whose frames arrive one after another, in the arithmetic `A` of its decoder.
pub struct FrameDecoder<'d, 's, A: Arith = F32Accurate> {
    decoder: &'d Decoder<A>,
    width: usize,
    height: usize,
    st: State<'s, A::Acc>,
    image: usize,
    row: usize,
}

fn sub<T>(s: &mut [T], from: usize, len: usize) -> &mut [T] {
    match s.get_mut(from..from + len) {
        Some(x) => x,
        None => &mut [],
    }
}

impl FrameDecoder<'_, '_> {
    /// Bytes of state per pixel for a set of `levels` levels (every backend: 4-byte accumulators).
    pub const fn bytes_per_pixel(levels: usize) -> usize {
        4 * (1 + 2 * levels) + 1
    }
}

impl<'d, 's, A: Arith> FrameDecoder<'d, 's, A> {
    /// Number of accumulator values (f32 by default, [`Arith::Acc`]) the state buffer needs for a
    /// `width × height` frame.
    pub fn state_len(decoder: &Decoder<A>, width: usize, height: usize) -> usize {
        (1 + 2 * decoder.level_count()) * width * height
    }

    /// Start a set. `state` must hold at least [`FrameDecoder::state_len`] accumulator values
    /// (f32 by default) and `flags` at least `width·height` bytes; both are zeroed here.
    pub fn new(
        decoder: &'d Decoder<A>,
        width: usize,
        height: usize,
        state: &'s mut [A::Acc],
        flags: &'s mut [u8],
    ) -> Result<Self, DecodeError> {
        let plane = width
            .checked_mul(height)
            .ok_or(DecodeError::StateTooSmall)?;
        let levels = decoder.level_count();
        if !decoder.frame_sequential_order() {
            return Err(DecodeError::GrayBeforeDc);
        }
        if state.len() < (1 + 2 * levels) * plane || flags.len() < plane || levels > MAX_LEVELS {
            return Err(DecodeError::StateTooSmall);
        }
        state.fill(A::ZERO);
        let flags = &mut flags[..plane];
        flags.fill(0);
        let (dc, mut rest) = state.split_at_mut(plane);
        let mut s: [&'s mut [A::Acc]; MAX_LEVELS] = Default::default();
        let mut c: [&'s mut [A::Acc]; MAX_LEVELS] = Default::default();
        for l in 0..levels {
            let (a, r) = rest.split_at_mut(plane);
            let (b, r) = r.split_at_mut(plane);
            s[l] = a;
            c[l] = b;
            rest = r;
        }
        Ok(FrameDecoder {
            decoder,
            width,
            height,
            st: State { dc, s, c, flags },
            image: 0,
            row: 0,
        })
    }

    fn view(&mut self, y: usize) -> State<'_, A::Acc> {
        let (o, w) = (y * self.width, self.width);
        let [s0, s1, s2, s3, s4, s5] = &mut self.st.s;
        let [c0, c1, c2, c3, c4, c5] = &mut self.st.c;
        State {
            dc: sub(self.st.dc, o, w),
            s: [
                sub(s0, o, w),
                sub(s1, o, w),
                sub(s2, o, w),
                sub(s3, o, w),
                sub(s4, o, w),
                sub(s5, o, w),
            ],
            c: [
                sub(c0, o, w),
                sub(c1, o, w),
                sub(c2, o, w),
                sub(c3, o, w),
                sub(c4, o, w),
                sub(c5, o, w),
            ],
            flags: match self.st.flags.get_mut(o..o + w) {
                Some(x) => x,
                None => &mut [],
            },
        }
    }

    /// Push the next row of the current frame (rows top to bottom, frames in the set's order).
    pub fn push_row<P: Sample>(&mut self, row: &[P]) -> Result<(), DecodeError> {
        if self.image >= self.decoder.image_count() {
            return Err(DecodeError::Sequence);
        }
        if row.len() != self.width {
            return Err(DecodeError::Length);
        }
        let (image, y) = (self.image, self.row);
        let decoder = self.decoder;
        let mut v = self.view(y);
        decoder.accumulate(image, row, &mut v)?;
        self.row += 1;
        if self.row == self.height {
            self.row = 0;
            self.image += 1;
        }
        Ok(())
    }

    /// Push a whole frame (`width·height` samples, row-major).
    pub fn push_frame<P: Sample>(&mut self, frame: &[P]) -> Result<(), DecodeError> {
        if frame.len() != self.width * self.height || self.row != 0 {
            return Err(DecodeError::Length);
        }
        for r in frame.chunks_exact(self.width) {
            self.push_row(r)?;
        }
        Ok(())
    }

    /// Index of the next frame expected (equals the image count once complete).
    pub fn frames_done(&self) -> usize {
        self.image
    }

    /// `true` once every frame of the set is in.
    pub fn is_complete(&self) -> bool {
        self.image == self.decoder.image_count()
    }

    /// Write the outputs of row `y` (any order, any number of times) once the set is complete.
    pub fn finish_row(&mut self, y: usize, out: RowOut<'_>) -> Result<(), DecodeError> {
        if !self.is_complete() || y >= self.height {
            return Err(DecodeError::Sequence);
        }
        let decoder = self.decoder;
        let v = self.view(y);
        decoder.finish(&v, out)
    }
}
