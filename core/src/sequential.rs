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
use crate::decode::hdr::MAX_EXPOSURES;
use crate::decode::{BLOCK, DecodeError, Decoder, RowOut, Sample, State};
use crate::pattern::MAX_LEVELS;

/// Flag bit: some sample of the pixel saturated (the decoder's bit 0).
const SATURATED: u8 = 1;
/// Flag bit: an earlier exposure decoded the pixel unsaturated ([`FrameDecoder::next_exposure`]).
const LOCKED: u8 = 2;

/// Decodes a set whose frames arrive one after another, in the arithmetic `A` of its decoder.
pub struct FrameDecoder<'d, 's, A: Arith = F32Accurate> {
    decoder: &'d Decoder<A>,
    width: usize,
    height: usize,
    st: State<'s, A::Acc>,
    image: usize,
    row: usize,
    /// Exposures completed before the current one ([`FrameDecoder::next_exposure`]).
    exposure: usize,
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
            exposure: 0,
        })
    }

    fn view(&mut self, y: usize) -> State<'_, A::Acc> {
        let w = self.width;
        self.view_cols(y, 0, w)
    }

    /// The state of columns `x0..x0 + w` of row `y`.
    fn view_cols(&mut self, y: usize, x0: usize, w: usize) -> State<'_, A::Acc> {
        let o = y * self.width + x0;
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
        if self.exposure == 0 {
            self.accumulate_at(image, y, 0, row)?;
        } else {
            self.accumulate_unlocked(image, y, row)?;
        }
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

    /// End an exposure and start the next, shorter one of the same set (HDR, [`crate::decode::hdr`]):
    /// once every frame of the exposure is in, each pixel whose samples did not saturate is
    /// locked (its sums stay that exposure's, and later frames pass it by), and every other
    /// pixel's sums and flags are cleared, so that the next exposure's frames accumulate into it
    /// from zero, as a decode of that exposure alone would. Frames then start again at the set's
    /// first. At most [`MAX_EXPOSURES`] exposures.
    pub fn next_exposure(&mut self) -> Result<(), DecodeError> {
        if !self.is_complete() || self.exposure + 1 >= MAX_EXPOSURES {
            return Err(DecodeError::Sequence);
        }
        let levels = self.decoder.level_count();
        let plane = self.width * self.height;
        let st = &mut self.st;
        for i in 0..plane {
            let Some(f) = st.flags.get_mut(i) else { break };
            if *f & SATURATED == 0 {
                *f |= LOCKED;
                continue;
            }
            *f = 0;
            if let Some(x) = st.dc.get_mut(i) {
                *x = A::ZERO;
            }
            for l in 0..levels {
                if let Some(x) = st.s[l].get_mut(i) {
                    *x = A::ZERO;
                }
                if let Some(x) = st.c[l].get_mut(i) {
                    *x = A::ZERO;
                }
            }
        }
        self.exposure += 1;
        self.image = 0;
        self.row = 0;
        Ok(())
    }

    /// `true` if some pixel saturated in the exposure whose frames are in: the next, shorter
    /// exposure can change it. `false`: every pixel is final (locked, or unsaturated now), so a
    /// driver may skip the remaining exposures, as the row driver stops when no decoded pixel
    /// is [`crate::Validity::Saturated`] ([`crate::decode::hdr::any_saturated`]; the decoder
    /// gives that code exactly when a sample saturated).
    pub fn saturated_left(&self) -> bool {
        let plane = self.width * self.height;
        self.st
            .flags
            .get(..plane)
            .is_some_and(|f| f.iter().any(|&f| f & SATURATED != 0))
    }

    /// Exposures begun so far minus one: 0 during the first ([`Self::next_exposure`]).
    pub fn exposure(&self) -> usize {
        self.exposure
    }

    /// [`Decoder::accumulate`] of `cols`, columns `x0..` of row `y` of image `image`: the one
    /// instance of the kernel's accumulation in a frame-sequential build (both exposure paths
    /// call it, so that a head carries one copy).
    #[inline(never)]
    fn accumulate_at<P: Sample>(
        &mut self,
        image: usize,
        y: usize,
        x0: usize,
        cols: &[P],
    ) -> Result<(), DecodeError> {
        let decoder = self.decoder;
        let mut v = self.view_cols(y, x0, cols.len());
        decoder.accumulate(image, cols, &mut v)
    }

    /// [`Decoder::accumulate`] of row `y` of image `image` into the pixels that no earlier
    /// exposure locked: blocks of [`BLOCK`] columns with no locked pixel are accumulated
    /// directly, blocks of locked pixels only are passed by, and in a mixed block the locked
    /// pixels' sums are kept aside on the stack and put back (the kernel is elementwise, so
    /// its other pixels get the bits they would get in a whole row).
    #[inline(never)]
    fn accumulate_unlocked<P: Sample>(
        &mut self,
        image: usize,
        y: usize,
        row: &[P],
    ) -> Result<(), DecodeError> {
        let decoder = self.decoder;
        let levels = decoder.level_count();
        let mut x0 = 0;
        while x0 < self.width {
            let n = BLOCK.min(self.width - x0);
            let cols = row.get(x0..x0 + n).ok_or(DecodeError::Length)?;
            let v = self.view_cols(y, x0, n);
            if v.flags.len() != n {
                return Err(DecodeError::Length);
            }
            let mut lock = [false; BLOCK];
            for (l, &f) in lock.iter_mut().zip(v.flags.iter()) {
                *l = f & LOCKED != 0;
            }
            let locked = lock[..n].iter().filter(|&&l| l).count();
            if locked == 0 {
                self.accumulate_at(image, y, x0, cols)?;
            } else if locked < n {
                // Kept aside: DC, then S and C per level, then the flags.
                let mut keep = [[A::ZERO; BLOCK]; 1 + 2 * MAX_LEVELS];
                let mut keep_flags = [0u8; BLOCK];
                let save = |k: &mut [A::Acc; BLOCK], p: &[A::Acc]| {
                    for (d, &s) in k.iter_mut().zip(p) {
                        *d = s;
                    }
                };
                save(&mut keep[0], v.dc);
                for l in 0..levels {
                    save(&mut keep[1 + 2 * l], v.s[l]);
                    save(&mut keep[2 + 2 * l], v.c[l]);
                }
                keep_flags[..n].copy_from_slice(v.flags);
                self.accumulate_at(image, y, x0, cols)?;
                let v = self.view_cols(y, x0, n);
                let restore = |p: &mut [A::Acc], k: &[A::Acc; BLOCK]| {
                    for ((d, &s), &l) in p.iter_mut().zip(k).zip(&lock) {
                        if l {
                            *d = s;
                        }
                    }
                };
                restore(v.dc, &keep[0]);
                for l in 0..levels {
                    restore(v.s[l], &keep[1 + 2 * l]);
                    restore(v.c[l], &keep[2 + 2 * l]);
                }
                for ((d, &s), &l) in v.flags.iter_mut().zip(&keep_flags).zip(&lock) {
                    if l {
                        *d = s;
                    }
                }
            }
            x0 += n;
        }
        Ok(())
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
