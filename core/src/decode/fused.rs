//! Pass 1 of the row driver for the two common three-level structures (the paper's 8-pattern
//! set and the 12-pattern set): every level in one loop, written out for one pixel at a time and
//! for [`FUSED_LANES`] pixels side by side.

use super::BLOCK;
use super::buffers::Block;
use super::decoder::{Decoder, KIND_PAIR_UNIT};
#[cfg(doc)]
use super::decoder::{FUSED_LANES, KIND_QUAD_EXACT};
use crate::arith::Arith;
use crate::decode_error::DecodeError;
use crate::sample::Sample;

impl<A: Arith> Decoder<A> {
    /// Pass 1 of the row driver for the sets of [`Decoder::fused`]: every level in one loop over
    /// the block. The finest level is the DC level of four images ([`KIND_QUAD_EXACT`]); the
    /// coarser levels, two of them, are all of kind `K` ([`KIND_PAIR_UNIT`]: the paper's
    /// 8-pattern set, or [`KIND_QUAD_EXACT`]: the 12-pattern set).
    ///
    /// Each pixel's operations are those of [`Self::level_rows_exact`] for each level, in the
    /// same order: the same bits. What changes is the order: each iteration takes pixel `j` of
    /// each of the block's [`FUSED_LANES`] parts, and the arctangents of the three levels of
    /// those pixels are written step by step side by side ([`Arith::polar_levels3_lanes`]).
    /// An arctangent is a long dependency chain (division, polynomial, folding); one loop per
    /// level ran at the latency of one chain, twelve independent chains keep the core busy.
    #[inline(always)]
    pub(super) fn fused_rows<P: Sample, const K: u8, const NL: usize>(
        &self,
        rows: &[&[P]],
        start: usize,
        blk: &mut Block<A>,
        mo: &mut [f32; BLOCK],
    ) -> Result<(), DecodeError> {
        let range = start..start + BLOCK;
        let fmt = &self.format;
        // Levels: the finest (the DC level, level 2 of the three), then the two coarser ones.
        let lv = [2, 0, 1];
        let mut r = [[&[] as &[P]; 4]; 3];
        let mut k = [(A::COEF_ZERO, A::COEF_ZERO, A::COEF_ZERO); 3];
        for (slot, (kslot, &l)) in r.iter_mut().zip(k.iter_mut().zip(&lv)) {
            let li = self.level_images.get(l).ok_or(DecodeError::Sequence)?;
            for (j, row) in slot.iter_mut().enumerate() {
                let img = li.idx[j % li.n.max(1) as usize] as usize;
                *row = rows
                    .get(img)
                    .ok_or(DecodeError::ImageCount)?
                    .get(range.clone())
                    .ok_or(DecodeError::Length)?;
            }
            let coef = |j: usize| {
                self.images
                    .get(li.idx[j] as usize)
                    .ok_or(DecodeError::Sequence)
            };
            *kslot = (coef(0)?.a, coef(1)?.b, coef(0)?.w);
        }
        let rb = |l: usize, j: usize| -> Result<&[P; BLOCK], DecodeError> {
            r[l][j].try_into().map_err(|_| DecodeError::Length)
        };
        let f = [rb(0, 0)?, rb(0, 1)?, rb(0, 2)?, rb(0, 3)?];
        let c1 = [rb(1, 0)?, rb(1, 1)?, rb(1, 2)?, rb(1, 3)?];
        let c2 = [rb(2, 0)?, rb(2, 1)?, rb(2, 2)?, rb(2, 3)?];
        let Block {
            dc, wrapped, mag, ..
        } = blk;
        let [w0, w1, w2, ..] = wrapped;
        let [m0, m1, m2, ..] = mag;
        let (wf, mf) = (w2, m2);
        let ((kaf, kbf, kwf), k1, k2) = (k[0], k[1], k[2]);
        // S and C of a coarser level (not the DC level: a pair's coefficients are ±1, a quad's
        // regrouped with its positive ½).
        #[inline(always)]
        fn coarse<A: Arith, P: Sample, const K: u8>(
            r: &[&[P; BLOCK]; 4],
            i: usize,
            a: A::Acc,
            (ka, kb, _): (A::Coef, A::Coef, A::Coef),
        ) -> (A::Acc, A::Acc) {
            let (v0, v1) = (A::input(r[0][i]), A::input(r[1][i]));
            if K == KIND_PAIR_UNIT {
                (A::in_minus_acc(v0, a), A::in_minus_acc(v1, a))
            } else {
                let (v2, v3) = (A::input(r[2][i]), A::input(r[3][i]));
                (
                    A::regrouped_product(ka, A::in_sub(v0, v2)),
                    A::regrouped_product(kb, A::in_sub(v1, v3)),
                )
            }
        }
        if NL == 1 {
            // One pixel at a time (a scalar core): the levels' polar calls one after the other.
            // Written out rather than through a closure shared with the lanes below: the closure
            // cost the Cortex-M4F 33 instructions per pixel (385 against 352).
            for i in 0..BLOCK {
                let (v0, v1, v2, v3) = (
                    A::input(f[0][i]),
                    A::input(f[1][i]),
                    A::input(f[2][i]),
                    A::input(f[3][i]),
                );
                let a = A::regrouped_product(kwf, A::in_add(A::in_add(A::in_add(v0, v1), v2), v3));
                dc[i] = a;
                let (s, c) = (
                    A::regrouped_product(kaf, A::in_sub(v0, v2)),
                    A::regrouped_product(kbf, A::in_sub(v1, v3)),
                );
                (wf[i], mf[i], mo[i]) = A::polar_fine(s, c, fmt);
                let (s, c) = coarse::<A, P, K>(&c1, i, a, k1);
                (w0[i], m0[i]) = A::polar_coarse(s, c);
                let (s, c) = coarse::<A, P, K>(&c2, i, a, k2);
                (w1[i], m1[i]) = A::polar_coarse(s, c);
            }
            return Ok(());
        }
        for j in 0..BLOCK / NL {
            let ix: [usize; NL] = core::array::from_fn(|k| j + k * (BLOCK / NL));
            let (mut ff, mut g, mut h) = (
                [(A::ZERO, A::ZERO); NL],
                [(A::ZERO, A::ZERO); NL],
                [(A::ZERO, A::ZERO); NL],
            );
            for k in 0..NL {
                let i = ix[k];
                let (v0, v1, v2, v3) = (
                    A::input(f[0][i]),
                    A::input(f[1][i]),
                    A::input(f[2][i]),
                    A::input(f[3][i]),
                );
                let a = A::regrouped_product(kwf, A::in_add(A::in_add(A::in_add(v0, v1), v2), v3));
                dc[i] = a;
                ff[k] = (
                    A::regrouped_product(kaf, A::in_sub(v0, v2)),
                    A::regrouped_product(kbf, A::in_sub(v1, v3)),
                );
                g[k] = coarse::<A, P, K>(&c1, i, a, k1);
                h[k] = coarse::<A, P, K>(&c2, i, a, k2);
            }
            let r = A::polar_levels3_lanes(ff, g, h, fmt);
            for k in 0..NL {
                let i = ix[k];
                let (pf, p1, p2) = r[k];
                (wf[i], mf[i], mo[i]) = pf;
                (w0[i], m0[i]) = p1;
                (w1[i], m1[i]) = p2;
            }
        }
        Ok(())
    }
}
