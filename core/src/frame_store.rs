//! Frames kept as the camera delivers them, then decoded row by row: the frame-sequential state
//! at the frames' own size (issue #23 item 4).
//!
//! A camera delivers whole frames one after another. [`crate::sequential::FrameDecoder`] folds
//! each into per-pixel accumulators as it arrives: `4·(1 + 2L) + 1` bytes a pixel, 29 for the
//! paper's 3-level set, more than the 8 frames of an 8-bit camera take themselves (8 bytes a
//! pixel). A [`FrameStore`] keeps the frames instead, in a caller buffer (a head's external RAM:
//! 10.5 MB for eight 8-bit 1280 × 1024 frames, where the accumulators need 38 MB), and decodes
//! row `v` by handing row `v` of every frame to [`Decoder::decode_row_with`]: the row path
//! itself, so its bits are the row path's by construction, for every set the row path decodes
//! (Gray code, heterodyne and coprime sets included).
//!
//! [`FrameStore::bytes_per_pixel`] = `N·s` for `N` images of `s` bytes a sample: the smaller
//! state whenever `N·s < 4·(1 + 2L) + 1`. What it gives up against the accumulators: the decode
//! runs after the last frame, not folded in as the frames arrive (the same instructions, later),
//! and several exposures (HDR) keep the accumulators, which fuse each exposure as it ends.

use crate::decode::{DecodeError, DecodeScratch, Decoder, RowOut, Sample};
use crate::pattern::MAX_IMAGES;

/// A set's frames in one caller buffer, image after image, each `width × height` samples in
/// row order (the set's image order, [`crate::pattern::PatternSet::order`]).
pub struct FrameStore<'a, P: Sample> {
    frames: &'a mut [P],
    width: usize,
    height: usize,
    images: usize,
}

impl<'a, P: Sample> FrameStore<'a, P> {
    /// Bytes of state per pixel: the frames themselves, `images × size_of::<P>()`.
    pub const fn bytes_per_pixel(images: usize) -> usize {
        images * core::mem::size_of::<P>()
    }

    /// A store for `decoder`'s set of `width × height` frames over `frames` (at least
    /// `image_count × width × height` samples; [`DecodeError::StateTooSmall`] if shorter,
    /// [`DecodeError::Length`] for a zero or overflowing size).
    pub fn new(
        decoder: &Decoder,
        frames: &'a mut [P],
        width: usize,
        height: usize,
    ) -> Result<Self, DecodeError> {
        let images = decoder.image_count();
        let n = width
            .checked_mul(height)
            .and_then(|p| p.checked_mul(images))
            .filter(|&n| n > 0)
            .ok_or(DecodeError::Length)?;
        if frames.len() < n {
            return Err(DecodeError::StateTooSmall);
        }
        Ok(FrameStore {
            frames,
            width,
            height,
            images,
        })
    }

    /// Frame `image` (in the set's order), to fill as the camera delivers it (a DMA target), or
    /// `None` past the set.
    pub fn frame_mut(&mut self, image: usize) -> Option<&mut [P]> {
        let n = self.width * self.height;
        self.frames
            .get_mut(image.checked_mul(n)?..(image + 1).checked_mul(n)?)
    }

    /// Store row `v` of frame `image` (a camera that delivers a frame row by row).
    pub fn push_row(&mut self, image: usize, v: usize, row: &[P]) -> Result<(), DecodeError> {
        let w = self.width;
        if row.len() != w {
            return Err(DecodeError::Length);
        }
        if v >= self.height {
            return Err(DecodeError::Sequence);
        }
        let dst = self
            .frame_mut(image)
            .and_then(|f| f.get_mut(v * w..(v + 1) * w))
            .ok_or(DecodeError::ImageCount)?;
        dst.iter_mut().zip(row).for_each(|(d, s)| *d = *s);
        Ok(())
    }

    /// Decode row `v` of the stored frames into `out` ([`Decoder::decode_row_with`] over row
    /// `v` of every frame: the row path's bits). `decoder` must be the store's.
    pub fn decode_row(
        &self,
        decoder: &Decoder,
        scratch: &mut DecodeScratch,
        v: usize,
        out: RowOut<'_>,
    ) -> Result<(), DecodeError> {
        if v >= self.height {
            return Err(DecodeError::Sequence);
        }
        if decoder.image_count() != self.images {
            return Err(DecodeError::ImageCount);
        }
        let (w, n) = (self.width, self.width * self.height);
        let mut rows: [&[P]; MAX_IMAGES] = [&[]; MAX_IMAGES];
        for (i, r) in rows.iter_mut().enumerate().take(self.images) {
            let at = i * n + v * w;
            *r = self.frames.get(at..at + w).ok_or(DecodeError::Length)?;
        }
        let rows = rows.get(..self.images).ok_or(DecodeError::ImageCount)?;
        decoder.decode_row_with(scratch, rows, out)
    }
}
