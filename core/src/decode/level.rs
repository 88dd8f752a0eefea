//! One level's wrapped phase and modulation, for diagnostics, golden vectors and noise studies
//! ([`Decoder::finish_level`], [`Decoder::decode_row_level`]).

use super::BLOCK;
use super::buffers::{State, block_state};
use super::decoder::Decoder;
use crate::arith::Arith;
use crate::decode_error::DecodeError;
use crate::limits::MAX_LEVELS;
use crate::sample::Sample;

impl<A: Arith> Decoder<A> {
    /// Wrapped phase φ^(k) ∈ [−π, π] (eqs 9, 11) and modulation B of one level from a complete
    /// state, for diagnostics, golden vectors and noise studies. Same operations as [`Self::finish`]
    /// (with the phase-error table, if any, [`Self::with_correction`]).
    pub fn finish_level(
        &self,
        st: &State<'_, A::Acc>,
        level: usize,
        wrapped: &mut [f32],
        modulation: &mut [f32],
    ) -> Result<(), DecodeError> {
        let n = st.dc.len();
        // A Gray-code level has no wrapped phase.
        if level >= self.n_levels || (level == 0 && self.gray.is_some()) {
            return Err(DecodeError::Sequence);
        }
        if wrapped.len() != n
            || modulation.len() != n
            || st.s[level].len() != n
            || st.c[level].len() != n
        {
            return Err(DecodeError::Length);
        }
        let (ad, bd, fmt) = (self.a_dc[level], self.b_dc[level], &self.format);
        for i in 0..n {
            let (s, c) = A::level_sc(st.s[level][i], st.c[level][i], ad, bd, st.dc[i], fmt);
            let (w, _, b) = A::polar_fine(s, c, fmt);
            wrapped[i] = A::phase_out(self.correct_one(level, w));
            modulation[i] = b;
        }
        Ok(())
    }

    /// Row API for one level: wrapped phase and modulation of `level` from the rows of every image
    /// (set order). See [`Self::finish_level`].
    pub fn decode_row_level<P: Sample>(
        &self,
        rows: &[&[P]],
        level: usize,
        wrapped: &mut [f32],
        modulation: &mut [f32],
    ) -> Result<(), DecodeError> {
        if rows.len() != self.n_images {
            return Err(DecodeError::ImageCount);
        }
        let w = wrapped.len();
        if modulation.len() != w || rows.iter().any(|r| r.len() != w) {
            return Err(DecodeError::Length);
        }
        let mut start = 0;
        while start < w {
            let end = if w - start > BLOCK { start + BLOCK } else { w };
            let n = end - start;
            let mut st_dc = [A::ZERO; BLOCK];
            let mut st_s = [[A::ZERO; BLOCK]; MAX_LEVELS];
            let mut st_c = [[A::ZERO; BLOCK]; MAX_LEVELS];
            let mut flags = [0u8; BLOCK];
            let mut st = block_state(&mut st_dc, &mut st_s, &mut st_c, &mut flags, n);
            for (i, r) in rows.iter().enumerate() {
                // (The Gray images give no level's wrapped phase.)
                let gray_image =
                    self.gray.is_some() && self.images.get(i).is_some_and(|c| c.level == 0);
                if !gray_image {
                    self.accumulate(i, &r[start..end], &mut st)?;
                }
            }
            self.finish_level(
                &st,
                level,
                &mut wrapped[start..end],
                &mut modulation[start..end],
            )?;
            start = end;
        }
        Ok(())
    }
}
