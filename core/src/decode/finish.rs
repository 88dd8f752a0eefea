//! Pass 1 from accumulated planes and pass 2 of both drivers: S and C per level, the wrapped
//! phases and modulation (eqs 9, 11), the hierarchical unwrapping (eqs 12-13), the range,
//! modulation, dark and saturation tests and the outputs ([`Decoder::finish`]).

use super::BLOCK;
use super::buffers::{Block, BlockOut, RowOut, State, block, block_mut, block_or_sink};
use super::decoder::Decoder;
use crate::arith::Arith;
use crate::decode_error::DecodeError;
use crate::math::CANONICAL_NAN;
use crate::validity::Validity;

/// `finish_lanes`'s mode: eqs 12-13 from the coarsest level.
/// `core::array::from_fn` for the lanes of pass 2, always inlined, so that every build computes
/// the lanes in line: the x86-64 baseline (SSE2) build of the host's row loop left some of
/// `from_fn`'s closures out of line, one call per lane (docs/performance.md, "Decode"). The same
/// operations in the same order, so the same bits.
#[inline(always)]
fn lanes<T: Copy + Default, const N: usize>(mut f: impl FnMut(usize) -> T) -> [T; N] {
    let mut out = [T::default(); N];
    for (k, o) in out.iter_mut().enumerate() {
        *o = f(k);
    }
    out
}

const HIERARCHICAL: u8 = 0;
/// `finish_lanes`'s mode: level 0 is a Gray-code level ([`crate::gray`]).
const GRAY: u8 = 1;
/// `finish_lanes`'s mode: a heterodyne set ([`crate::pattern::Relation::Heterodyne`]).
const HETERODYNE: u8 = 2;
/// `finish_lanes`'s mode: a coprime set ([`crate::pattern::Relation::Coprime`]).
const COPRIME: u8 = 3;

impl<A: Arith> Decoder<A> {
    /// Turn a complete state into outputs (the second half of the kernel): S and C per level,
    /// wrapped phase by the backend's `atan2` ([`crate::math::atan2`] by default), modulation,
    /// hierarchical unwrapping, validity.
    ///
    /// Always inlined (as are [`Self::decode_row`] and [`Self::accumulate`]) so that a caller
    /// compiled for a wider instruction set (the host's AVX2 batch path) vectorizes the same
    /// operations wider; IEEE arithmetic without contraction gives the same bits.
    #[inline(always)]
    pub fn finish(&self, st: &State<'_, A::Acc>, out: RowOut<'_>) -> Result<(), DecodeError> {
        let flags = &st.flags[..];
        if flags.len() != st.dc.len() {
            return Err(DecodeError::Length);
        }
        self.finish_levels(st, flags, |f| f & 1 != 0, out)
    }

    /// [`Self::finish`] with the saturation test of pixel `i` given by `saturated(sat[i])`,
    /// compiled once per level count.
    #[inline(always)]
    fn finish_levels<T: Copy>(
        &self,
        st: &State<'_, A::Acc>,
        sat: &[T],
        saturated: impl Fn(T) -> bool,
        out: RowOut<'_>,
    ) -> Result<(), DecodeError> {
        let n = st.dc.len();
        if !out.len_ok(n)
            || sat.len() != n
            || (0..self.n_levels).any(|l| st.s[l].len() != n || st.c[l].len() != n)
        {
            return Err(DecodeError::Length);
        }
        if n == 0 {
            return Ok(());
        }
        let mut blk = Block::<A>::new();
        if n < BLOCK {
            // Short: padded copies of the state (the padding's results are dropped).
            let pad = |p: &[A::Acc]| {
                let mut b = [A::ZERO; BLOCK];
                b[..n].copy_from_slice(p);
                b
            };
            let mut sat_b = [sat[0]; BLOCK];
            sat_b[..n].copy_from_slice(sat);
            blk.dc = pad(st.dc);
            let (mut ph, mut mo, mut dc) = ([0.0f32; BLOCK], [0.0f32; BLOCK], [0.0f32; BLOCK]);
            let mut va = [0u8; BLOCK];
            for l in 0..self.n_levels {
                self.level_into(l, &pad(st.s[l]), &pad(st.c[l]), &mut blk, &mut mo);
            }
            self.correct_block(&mut blk);
            self.unwrap_block::<T, 1>(
                &blk,
                &sat_b,
                &saturated,
                BlockOut {
                    phase: &mut ph,
                    modulation: &mut mo,
                    dc: &mut dc,
                    validity: &mut va,
                },
            );
            // (Zips: the optional rows may be empty.)
            for (dst, src) in [
                (&mut *out.phase, &ph),
                (&mut *out.modulation, &mo),
                (&mut *out.dc, &dc),
            ] {
                dst.iter_mut().zip(src.iter()).for_each(|(d, s)| *d = *s);
            }
            out.validity.copy_from_slice(&va[..n]);
            return Ok(());
        }
        // Whole blocks, the last one overlapping (see `decode_row_with`).
        let (mut mo_sink, mut dc_sink) = ([0.0f32; BLOCK], [0.0f32; BLOCK]);
        let mut start = 0;
        loop {
            let r = start..start + BLOCK;
            blk.dc = *block(st.dc, r.clone())?;
            let mo = block_or_sink(out.modulation, r.clone(), &mut mo_sink)?;
            for l in 0..self.n_levels {
                self.level_into(
                    l,
                    block(st.s[l], r.clone())?,
                    block(st.c[l], r.clone())?,
                    &mut blk,
                    mo,
                );
            }
            self.correct_block(&mut blk);
            let o = BlockOut {
                phase: block_mut(out.phase, r.clone())?,
                modulation: mo,
                dc: block_or_sink(out.dc, r.clone(), &mut dc_sink)?,
                validity: block_mut(out.validity, r.clone())?,
            };
            self.unwrap_block::<T, 1>(&blk, block(sat, r)?, &saturated, o);
            if start + BLOCK == n {
                return Ok(());
            }
            start = if n - (start + BLOCK) >= BLOCK {
                start + BLOCK
            } else {
                n - BLOCK
            };
        }
    }

    /// Pass 1 of the frame-sequential path for level `l`: [`Self::polar_into`], or for a
    /// Gray-code level the estimates of the words kept in its S plane `s` (`gray`).
    #[inline(always)]
    fn level_into(
        &self,
        l: usize,
        s: &[A::Acc; BLOCK],
        c: &[A::Acc; BLOCK],
        blk: &mut Block<A>,
        modulation: &mut [f32; BLOCK],
    ) {
        if l == 0 && self.gray.is_some() {
            let words: [u16; BLOCK] = core::array::from_fn(|i| A::acc_word(s[i]));
            self.gray_estimates(&words, blk);
        } else {
            self.polar_into(l, s, c, blk, modulation);
        }
    }

    /// Pass 1 for level `l` from its S and C accumulators and the block's A: S and C (eq 11 for
    /// the 2-shift levels), the wrapped phase and the modulation measure. The coarser levels only
    /// choose fringe orders, so they take the backend's cheaper arctangent
    /// ([`Arith::polar_coarse`]); the finest level, whose phase is the output, the accurate one,
    /// and it writes B into `modulation`.
    #[inline(always)]
    pub(super) fn polar_into(
        &self,
        l: usize,
        s: &[A::Acc; BLOCK],
        c: &[A::Acc; BLOCK],
        blk: &mut Block<A>,
        modulation: &mut [f32; BLOCK],
    ) {
        if l + 1 < self.n_levels {
            self.polar_from_planes::<false>(l, s, c, blk, modulation);
        } else {
            self.polar_from_planes::<true>(l, s, c, blk, modulation);
        }
    }

    /// [`Self::polar_into`] for a coarser (`FINE = false`) or the finest level.
    #[inline(always)]
    fn polar_from_planes<const FINE: bool>(
        &self,
        l: usize,
        s: &[A::Acc; BLOCK],
        c: &[A::Acc; BLOCK],
        blk: &mut Block<A>,
        mo: &mut [f32; BLOCK],
    ) {
        let (ad, bd, fmt) = (self.a_dc[l], self.b_dc[l], &self.format);
        let Block {
            dc, wrapped, mag, ..
        } = blk;
        let (w, mag) = (&mut wrapped[l], &mut mag[l]);
        for i in 0..BLOCK {
            let (s, c) = A::level_sc(s[i], c[i], ad, bd, dc[i], fmt);
            if FINE {
                let (p, b2, b) = A::polar_fine(s, c, fmt);
                (w[i], mag[i], mo[i]) = (p, b2, b);
            } else {
                (w[i], mag[i]) = A::polar_coarse(s, c);
            }
        }
    }

    /// Pass 2, compiled once per level count: both unwrapping steps (eqs 12-13), the range test,
    /// the validity selects and the phase, DC and validity outputs of one block. Pixel `i` is
    /// saturated if `saturated(sat[i])`.
    ///
    /// Splitting the finishing work into these two passes keeps each loop body short, with
    /// independent iterations an out-of-order core overlaps; one fused body (arctangents →
    /// unwrapping → validity, ~300 instructions per vector) ran at the latency of its chain.
    #[inline(always)]
    pub(super) fn unwrap_block<T: Copy, const N: usize>(
        &self,
        blk: &Block<A>,
        sat: &[T; BLOCK],
        saturated: impl Fn(T) -> bool,
        out: BlockOut<'_>,
    ) {
        if self.heterodyne {
            // 2 or 3 levels (`Relation::Heterodyne`).
            return match self.n_levels {
                2 => self.unwrap_levels::<2, T, N, HETERODYNE>(blk, sat, saturated, out),
                _ => self.unwrap_levels::<3, T, N, HETERODYNE>(blk, sat, saturated, out),
            };
        }
        if self.coprime != 0 {
            // 2 to 4 levels (`Relation::Coprime`, `MAX_COPRIME_LEVELS`).
            return match self.n_levels {
                2 => self.unwrap_levels::<2, T, N, COPRIME>(blk, sat, saturated, out),
                3 => self.unwrap_levels::<3, T, N, COPRIME>(blk, sat, saturated, out),
                _ => self.unwrap_levels::<4, T, N, COPRIME>(blk, sat, saturated, out),
            };
        }
        match (self.n_levels, self.gray.is_some()) {
            (1, _) => self.unwrap_levels::<1, T, N, HIERARCHICAL>(blk, sat, saturated, out),
            (2, false) => self.unwrap_levels::<2, T, N, HIERARCHICAL>(blk, sat, saturated, out),
            (3, false) => self.unwrap_levels::<3, T, N, HIERARCHICAL>(blk, sat, saturated, out),
            (4, false) => self.unwrap_levels::<4, T, N, HIERARCHICAL>(blk, sat, saturated, out),
            (5, false) => self.unwrap_levels::<5, T, N, HIERARCHICAL>(blk, sat, saturated, out),
            (_, false) => self.unwrap_levels::<6, T, N, HIERARCHICAL>(blk, sat, saturated, out),
            // A Gray-coded set has 2 or 3 levels ([`crate::limits::MAX_GRAY_LEVELS`]).
            (2, true) => self.unwrap_levels::<2, T, N, GRAY>(blk, sat, saturated, out),
            (_, true) => self.unwrap_levels::<3, T, N, GRAY>(blk, sat, saturated, out),
        }
    }

    /// [`Self::unwrap_block`] for `L` levels, pixel `j` of each of the block's `N` parts side by
    /// side ([`Self::finish_lanes`]); `MODE`: [`HIERARCHICAL`], [`GRAY`] (level 0 is a
    /// Gray-code level) or [`HETERODYNE`].
    // Indices, not iterators, over the levels: the iterator form left this loop unvectorized
    // (5× slower with AVX-512).
    #[allow(clippy::needless_range_loop)]
    #[inline(always)]
    fn unwrap_levels<const L: usize, T: Copy, const N: usize, const MODE: u8>(
        &self,
        blk: &Block<A>,
        sat: &[T; BLOCK],
        saturated: impl Fn(T) -> bool,
        out: BlockOut<'_>,
    ) {
        let fmt = &self.format;
        let (wrapped, mag, a) = (&blk.wrapped, &blk.mag, &blk.dc);
        let BlockOut {
            phase: po,
            dc: ao,
            validity: vo,
            ..
        } = out;
        const { assert!(N > 0 && BLOCK.is_multiple_of(N)) };
        for j in 0..BLOCK / N {
            let ix: [usize; N] = lanes(|k| j + k * (BLOCK / N));
            let av: [A::Acc; N] = core::array::from_fn(|k| a[ix[k]]);
            let w: [[A::Phase; L]; N] =
                core::array::from_fn(|k| core::array::from_fn(|l| wrapped[l][ix[k]]));
            let m: [[A::Mag; L]; N] =
                core::array::from_fn(|k| core::array::from_fn(|l| mag[l][ix[k]]));
            let st: [bool; N] = lanes(|k| saturated(sat[ix[k]]));
            let amb: [u8; N] = lanes(|k| blk.ambiguous[ix[k]]);
            let r = self.finish_lanes::<L, N, MODE>(&w, &m, &av, &st, &amb);
            for k in 0..N {
                (po[ix[k]], vo[ix[k]]) = r[k];
                ao[ix[k]] = A::dc_out(av[k], fmt);
            }
        }
    }

    /// Pass 2 of `N` pixels of `L` levels, every step written for the `N` side by side (each
    /// pixel's operations are the same whatever `N`): both unwrapping steps (eqs 12-13) from the
    /// wrapped phases `w` (coarsest first), the range test, the smallest modulation measure of
    /// `m`, the dark test on `a` and the validity code (`saturated` given). Returns the phase
    /// output and the code of each pixel.
    ///
    /// `MODE` [`GRAY`]: level 0 is a Gray-code level, `w[k][0]` its estimate and `ambiguous` the
    /// count of ambiguous bits. Its step to level 1 (ratio 1) is held to the code's tolerance,
    /// and the range test applies to the phase that step gives (the estimate itself is always in
    /// range). [`HETERODYNE`]: the beats and the chain ([`Self::heterodyne_lanes`]).
    /// [`COPRIME`]: level 0's order from the candidates ([`Self::coprime_lanes`]), then the
    /// chain as [`HIERARCHICAL`].
    #[allow(clippy::needless_range_loop)]
    #[inline(always)]
    fn finish_lanes<const L: usize, const N: usize, const MODE: u8>(
        &self,
        w: &[[A::Phase; L]; N],
        m: &[[A::Mag; L]; N],
        a: &[A::Acc; N],
        saturated: &[bool; N],
        ambiguous: &[u8; N],
    ) -> [(f32, u8); N] {
        let lim = &self.limits;
        const { assert!(MODE != GRAY || L <= crate::limits::MAX_GRAY_LEVELS) };
        const { assert!(MODE != HETERODYNE || L == 2 || L == 3) };
        const { assert!(MODE != COPRIME || (L >= 2 && L <= crate::relation::MAX_COPRIME_LEVELS)) };
        let gray = MODE == GRAY;
        // The step to level 1 is held to the code's tolerance (a Gray code's, or a coprime
        // set's `π/a`) rather than the unwrapping tolerance.
        let coded = gray || MODE == COPRIME;
        let mut phi: [A::Phase; N] = lanes(|k| w[k][0]);
        let mut out_of_range: [bool; N] =
            lanes(|k| !gray && !A::in_range(phi[k], lim.coarse_lo, lim.coarse_hi));
        let mut inconsistent = [false; N];
        if MODE == HETERODYNE {
            (phi, out_of_range, inconsistent) = self.heterodyne_lanes(w);
        }
        if MODE == COPRIME {
            (phi, out_of_range, inconsistent) = self.coprime_lanes(w);
        }
        for l in 1..L {
            if MODE == HETERODYNE {
                break;
            }
            let st: [(A::Phase, A::Phase); N] =
                lanes(|k| A::unwrap(phi[k], self.ratio[l], w[k][l]));
            let tolerance = if coded && l == 1 {
                lim.gray_tolerance
            } else {
                lim.unwrap_tolerance
            };
            for k in 0..N {
                inconsistent[k] |= !A::consistent(st[k].1, tolerance);
                phi[k] = st[k].0;
                if gray && l == 1 {
                    out_of_range[k] = !A::in_range(phi[k], lim.coarse_lo, lim.coarse_hi);
                }
            }
        }
        let max_ambiguous = self.gray.map_or(u8::MAX, |g| g.max_ambiguous());
        let code_ambiguous: [bool; N] = lanes(|k| gray && ambiguous[k] >= max_ambiguous);
        let mut bm = [A::MAG_MAX; N];
        for l in 0..L {
            for k in 0..N {
                bm[k] = A::min_mag(m[k][l], bm[k]);
            }
        }
        // Priority (highest last): unwrap inconsistent, out of range, low modulation, dark,
        // saturated. Masks, not branches or a chain of selects (which LLVM may fold into
        // branches), so the loop vectorizes.
        let pick = |cond: bool, code: Validity, v: u32| {
            let m = (cond as u32).wrapping_neg();
            (v & !m) | (code as u32 & m)
        };
        lanes(|k| {
            let mut v = Validity::Valid as u32;
            v = pick(inconsistent[k], Validity::UnwrapInconsistent, v);
            v = pick(out_of_range[k], Validity::PhaseOutOfRange, v);
            // (An ambiguous code explains an inconsistent or out-of-range phase.)
            v = pick(code_ambiguous[k], Validity::CodeAmbiguous, v);
            v = pick(
                !A::mag_at_least(bm[k], lim.min_modulation),
                Validity::LowModulation,
                v,
            );
            v = pick(!A::dc_at_least(a[k], lim.dark), Validity::Dark, v);
            v = pick(saturated[k], Validity::Saturated, v);
            (
                if v == 0 {
                    A::phase_out(phi[k])
                } else {
                    CANONICAL_NAN
                },
                v as u8,
            )
        })
    }

    /// The beats and the unwrapping chain of a heterodyne set of `L` (2 or 3) levels, for `N`
    /// pixels: the absolute phase, out of range, inconsistent.
    ///
    /// The beat of wrapped phases `a` (coarser) and `b` is `wrap(φ_b − φ_a)`, the residual of
    /// the unwrapping step `unwrap(φ_b, 1, φ_a)` (the `φ_a + 2πn` nearest `φ_b`). With 2 levels
    /// the beat is the start; with 3 the beat of the beats `wrap(β₁₂ − β₀₁)`. The range test
    /// applies to the start, and every step of the chain (`ratio[0..L]`: to β₀₁ or φ₀, then to
    /// the levels) is held to the unwrapping tolerance: a beat that disagrees with a finer phase
    /// is flagged, never followed.
    #[allow(clippy::needless_range_loop)]
    #[inline(always)]
    fn heterodyne_lanes<const L: usize, const N: usize>(
        &self,
        w: &[[A::Phase; L]; N],
    ) -> ([A::Phase; N], [bool; N], [bool; N]) {
        let lim = &self.limits;
        let one = A::ratio(1.0, &self.format);
        let beat = |a: A::Phase, b: A::Phase| A::unwrap(b, one, a).1;
        let start: [A::Phase; N] = lanes(|k| {
            let b01 = beat(w[k][0], w[k][1 % L]);
            if L == 2 {
                b01
            } else {
                beat(b01, beat(w[k][1 % L], w[k][2 % L]))
            }
        });
        let out_of_range = lanes(|k| !A::in_range(start[k], lim.coarse_lo, lim.coarse_hi));
        let mut phi = start;
        let mut inconsistent = [false; N];
        for step in 0..L {
            for k in 0..N {
                // The targets: 2 levels φ₀, φ₁; 3 levels β₀₁, φ₁, φ₂.
                let target = if L == 2 {
                    w[k][step]
                } else if step == 0 {
                    beat(w[k][0], w[k][1 % L])
                } else {
                    w[k][step]
                };
                let (p, r) = A::unwrap(phi[k], self.ratio[step], target);
                inconsistent[k] |= !A::consistent(r, lim.unwrap_tolerance);
                phi[k] = p;
            }
        }
        (phi, out_of_range, inconsistent)
    }

    /// Level 0's absolute phase of a coprime set ([`crate::pattern::Relation::Coprime`],
    /// `c₀ = a·u`, `c₁ = b·u`), for `N` pixels: the phase, out of range, inconsistent.
    ///
    /// Each candidate `φ₀ + 2πk` (`|k| ≤ a/2 + 1`, [`Arith::add_turns`]: no rounding, so a
    /// wrapped phase of exactly ±π gives every order once) in the accepted range of
    /// `c₀·Φ` predicts level 1 (`unwrap(·, b/a, φ₁)`); it is the order if that residual is within
    /// `π/a` (the limits' code tolerance). The candidates' residuals lie `2π/a` apart, so at most
    /// one qualifies unless the noise is at the margin: none or two make the pixel inconsistent,
    /// none in range out of range. The number of candidates is the set's, the same for every
    /// pixel: no data-dependent loop.
    #[allow(clippy::needless_range_loop)]
    #[inline(always)]
    fn coprime_lanes<const L: usize, const N: usize>(
        &self,
        w: &[[A::Phase; L]; N],
    ) -> ([A::Phase; N], [bool; N], [bool; N]) {
        let lim = &self.limits;
        let reach = (self.coprime / 2) as i32 + 1;
        let mut phi = [A::PHASE_ZERO; N];
        let mut hits = [0u8; N];
        let mut in_range = [false; N];
        for k in -reach..=reach {
            for j in 0..N {
                let cand = A::add_turns(w[j][0], k);
                let inside = A::in_range(cand, lim.coarse_lo, lim.coarse_hi);
                let (_, r) = A::unwrap(cand, self.ratio[1 % L], w[j][1 % L]);
                let hit = inside & A::consistent(r, lim.gray_tolerance);
                in_range[j] |= inside;
                hits[j] += hit as u8;
                phi[j] = if hit { cand } else { phi[j] };
            }
        }
        (phi, lanes(|j| !in_range[j]), lanes(|j| hits[j] != 1))
    }
}
