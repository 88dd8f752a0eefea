//! The Gray-code pass of both drivers ([`crate::gray`] has the code and its decoding rules).
//!
//! Each image of the set's Gray-code level (level 0) is thresholded against the DC term A of
//! the DC level: `e = A − v` ([`Arith::dc_minus_input`]); the bit is bright where `e < 0`, and
//! ambiguous where `e` lies within the margin ([`crate::arith::Plan::gray_margin`]). A pixel's
//! bits and its count of ambiguous bits are packed in one 16-bit *word*: bits 0..=10 the code
//! word laid out as `G(h)` ([`crate::gray::GrayCode::word_bit`]), bits 12..=15 the count. The
//! row driver builds the words of a block from the images' rows once pass 1 has A; the
//! frame-sequential path folds each Gray image into the words as it arrives, kept in the Gray
//! level's S plane (a level without phase has no S or C to accumulate), and so needs the DC
//! level's images before the Gray ones ([`crate::pattern::PatternSet::new`]'s order has them so).
//! Both then turn the words into the level-0 phase estimate the unwrapping starts from: the same
//! comparisons on the same A, the same bits.
//!
//! An inverse code ([`crate::gray::GrayCode::inverted`]) thresholds each image against its
//! inverse instead: `e = I₂ⱼ − I₂ⱼ₊₁` ([`Arith::dc_minus_input`] of [`Arith::input_acc`]), bright
//! where `e > 0`, ambiguous within the margin. The row driver has both rows; the
//! frame-sequential path keeps image `2j` in the level's C plane until `2j + 1` comes (so the
//! code's images must come in pairs, [`crate::pattern::PatternSet::frame_sequential_order`]),
//! and forms the same `e`.

use super::BLOCK;
use super::buffers::{Block, block};
use super::decoder::Decoder;
use crate::arith::Arith;
use crate::decode_error::DecodeError;
use crate::sample::Sample;

/// Where the count of ambiguous bits starts in a packed word.
pub(super) const AMBIGUOUS_SHIFT: u32 = 12;

impl<A: Arith> Decoder<A> {
    /// The bit of one sample `v` against the DC term `a`: its place in the packed word (bit
    /// `word_bit` if bright) plus `1 << AMBIGUOUS_SHIFT` if ambiguous.
    #[inline(always)]
    pub(super) fn gray_bit(&self, a: A::Acc, v: A::In, word_bit: u8) -> u16 {
        let lim = &self.limits;
        let e = A::dc_minus_input(a, v, &self.format);
        // `|`, not `||`: no branch, so the row driver's loop over a block vectorizes.
        let bright = !A::dc_at_least(e, A::ZERO);
        let firm = A::dc_at_least(e, lim.gray_dark) | !A::dc_at_least(e, lim.gray_bright);
        ((bright as u16) << (word_bit & 15)) | ((!firm as u16) << AMBIGUOUS_SHIFT)
    }

    /// The bit of an inverse code's pair, `e = I₂ⱼ − I₂ⱼ₊₁` in accumulator units: bright where
    /// `e > 0`, ambiguous where `−margin < e < margin` (the margins of [`Self::gray_bit`]).
    #[inline(always)]
    pub(super) fn gray_pair_bit(&self, e: A::Acc, word_bit: u8) -> u16 {
        let lim = &self.limits;
        let bright = !A::dc_at_least(A::ZERO, e);
        let firm = A::dc_at_least(e, lim.gray_dark) | A::dc_at_least(lim.gray_bright, e);
        ((bright as u16) << (word_bit & 15)) | ((!firm as u16) << AMBIGUOUS_SHIFT)
    }

    /// Row driver: the packed words of the block at `start` from the Gray images' rows and the
    /// block's A (pass 1 done), then their estimates ([`Self::gray_estimates`]).
    #[inline(always)]
    pub(super) fn gray_from_rows<P: Sample>(
        &self,
        rows: &[&[P]],
        start: usize,
        blk: &mut Block<A>,
    ) -> Result<(), DecodeError> {
        let li = &self.level_images[0];
        let mut words = [0u16; BLOCK];
        let inverse = self.gray.is_some_and(|g| g.inverse());
        let fmt = &self.format;
        for (j, (&k, &bit)) in li.idx.iter().zip(&self.gray_word_bit).enumerate() {
            if j >= li.n as usize {
                break;
            }
            let row = rows.get(k as usize).ok_or(DecodeError::ImageCount)?;
            let row = block(row, start..start + BLOCK)?;
            if !inverse {
                for i in 0..BLOCK {
                    words[i] += self.gray_bit(blk.dc[i], A::input(row[i]), bit);
                }
                continue;
            }
            // An inverse code: at each pair's image (even shift), against its inverse.
            let p = *self.gray_partner.get(j).ok_or(DecodeError::Sequence)? as usize;
            if p < j {
                continue;
            }
            let k_inv = *li.idx.get(p).ok_or(DecodeError::Sequence)?;
            let inv = rows.get(k_inv as usize).ok_or(DecodeError::ImageCount)?;
            let inv = block(inv, start..start + BLOCK)?;
            let (first, second) = if self.gray_image_first(j)? {
                (row, inv)
            } else {
                (inv, row)
            };
            for i in 0..BLOCK {
                let e = A::dc_minus_input(
                    A::input_acc(A::input(first[i]), fmt),
                    A::input(second[i]),
                    fmt,
                );
                words[i] += self.gray_pair_bit(e, bit);
            }
        }
        self.gray_estimates(&words, blk);
        Ok(())
    }

    /// Whether the image at position `j` of the Gray level is its pair's image (even shift)
    /// rather than the inverse.
    #[inline(always)]
    fn gray_image_first(&self, j: usize) -> Result<bool, DecodeError> {
        self.gray_even.get(j).copied().ok_or(DecodeError::Sequence)
    }

    /// Frame-sequential path: fold Gray image `j` of the level (image order) into the words
    /// kept in `plane` (the Gray level's S plane), testing against the complete DC plane `dc`;
    /// an inverse code's image is kept in `pending` (the level's C plane) until its inverse
    /// comes, which then folds the pair's bit.
    #[inline(always)]
    pub(super) fn gray_fold<P: Sample>(
        &self,
        j: usize,
        row: &[P],
        dc: &[A::Acc],
        plane: &mut [A::Acc],
        pending: &mut [A::Acc],
    ) -> Result<(), DecodeError> {
        if !self.gray_after_dc {
            return Err(DecodeError::GrayBeforeDc);
        }
        let bit = *self.gray_word_bit.get(j).ok_or(DecodeError::Sequence)?;
        if !self.gray.is_some_and(|g| g.inverse()) {
            for ((p, &a), &v) in plane.iter_mut().zip(dc).zip(row) {
                let w = A::acc_word(*p).wrapping_add(self.gray_bit(a, A::input(v), bit));
                *p = A::word_acc(w);
            }
            return Ok(());
        }
        let fmt = &self.format;
        if self.gray_image_first(j)? {
            for (q, &v) in pending.iter_mut().zip(row) {
                *q = A::input_acc(A::input(v), fmt);
            }
            return Ok(());
        }
        for ((p, &q), &v) in plane.iter_mut().zip(pending.iter()).zip(row) {
            let e = A::dc_minus_input(q, A::input(v), fmt);
            let w = A::acc_word(*p).wrapping_add(self.gray_pair_bit(e, bit));
            *p = A::word_acc(w);
        }
        Ok(())
    }

    /// The level-0 phase estimate ([`crate::gray::GrayCode::quarter_turns`]) and the count of
    /// ambiguous bits of every packed word; the level's modulation measure is left out of the
    /// minimum (set to the largest).
    #[inline(always)]
    pub(super) fn gray_estimates(&self, words: &[u16; BLOCK], blk: &mut Block<A>) {
        let Some(code) = self.gray else {
            return;
        };
        let mask = (1u16 << AMBIGUOUS_SHIFT) - 1;
        let Block {
            wrapped,
            mag,
            ambiguous,
            ..
        } = blk;
        let cells = wrapped[0]
            .iter_mut()
            .zip(mag[0].iter_mut())
            .zip(ambiguous.iter_mut());
        for (((p, m), a), &w) in cells.zip(words) {
            *p = A::quarter_turns(code.quarter_turns((w & mask) as u32));
            *m = A::MAG_MAX;
            *a = (w >> AMBIGUOUS_SHIFT) as u8;
        }
    }
}
