//! The row driver ([`Decoder::decode_row`]): block by block of [`BLOCK`] pixels, the largest
//! sample of every pixel, pass 1 straight from each level's image rows with every sum in
//! registers (the fused form for the paper's and the 12-pattern sets is in `fused`), then pass 2
//! (`finish`).

use super::BLOCK;
use super::buffers::{Block, BlockOut, DecodeScratch, RowOut, block, block_mut, block_or_sink};
use super::decoder::{
    Decoder, FUSED_LANES, FUSED_PAIRS, FUSED_QUADS, KIND_GENERIC, KIND_GRAY, KIND_PAIR,
    KIND_PAIR_UNIT, KIND_QUAD, KIND_QUAD_EXACT,
};
use crate::arith::Arith;
use crate::decode_error::DecodeError;
#[cfg(feature = "short-rows")]
use crate::limits::MAX_IMAGES;
use crate::sample::Sample;

impl<A: Arith> Decoder<A> {
    /// Decode one row: `rows[i]` is the row of image `i` (in the set's order), all of the same
    /// length as the outputs. Writes the finest absolute phase, its modulation B, the DC term A and
    /// a validity code for every pixel.
    ///
    /// Works block by block of [`BLOCK`] pixels on a [`DecodeScratch`] of its own (about 3.4 KiB
    /// of stack in f32); a caller decoding many rows saves clearing it every row by keeping one
    /// and calling [`Self::decode_row_with`]. Same bits either way.
    ///
    /// Out of line (the flash policy, docs/integration.md): one copy of the kernel per sample
    /// type, however many places call it. A caller that compiles the kernel into its own
    /// `#[target_feature]` function (the desktop's AVX2 build) calls
    /// [`Self::decode_row_lanes`], which is always inlined.
    #[inline(never)]
    pub fn decode_row<P: Sample>(&self, rows: &[&[P]], out: RowOut<'_>) -> Result<(), DecodeError> {
        self.decode_row_with(&mut DecodeScratch::new(), rows, out)
    }

    /// [`Self::decode_row`] with caller-kept scratch (e.g. one in a `static` on a head, or one
    /// per worker on the desktop).
    ///
    /// Per block: the largest sample of every pixel (saturation is tested once on it:
    /// `v ≥ t` for some sample ⇔ `max v ≥ t`); pass 1 per level, DC level first, straight from
    /// the level's image rows (`level_from_rows`); pass 2, the unwrapping and validity
    /// (`unwrap_block`). The frame-sequential path ([`Self::accumulate`] then
    /// [`Self::finish`]) computes the same values in the same order: the same bits.
    ///
    /// Out of line, as [`Self::decode_row`].
    #[inline(never)]
    pub fn decode_row_with<P: Sample>(
        &self,
        scratch: &mut DecodeScratch<A>,
        rows: &[&[P]],
        out: RowOut<'_>,
    ) -> Result<(), DecodeError> {
        self.decode_row_lanes::<P, 1>(scratch, rows, out)
    }

    /// [`Self::decode_row_with`] computing several pixels side by side: `N` (1, 2 or 4) in the
    /// finishing pass (pass 2) and, for `N > 1`, four in the fused first pass of the paper's and
    /// the 12-pattern sets. [`Self::decode_row_with`] takes 1. The lane count only orders the
    /// work: every `N` gives the same bits. It is a scheduling choice for the core the caller is
    /// compiled for: one pixel at a time suits a scalar in-order core (Cortex-M4F: 352
    /// instructions per pixel against 460 with lanes); on x86-64 with 16-byte vectors (SSE2)
    /// four independent chains per iteration are the fastest, while the AVX2 and AVX-512 builds
    /// of a four-lane pass 2 do not vectorize (LLVM 20) and take 2-4× longer, so they take 2.
    /// The host's batch path picks per ISA.
    ///
    /// Always inlined: for a caller that compiles the kernel with its own target features.
    /// Each call site gets its own copy of the kernel (tens of KB on a Cortex-M4F): a firmware
    /// calls [`Self::decode_row_with`] instead.
    #[inline(always)]
    pub fn decode_row_lanes<P: Sample, const N: usize>(
        &self,
        scratch: &mut DecodeScratch<A>,
        rows: &[&[P]],
        out: RowOut<'_>,
    ) -> Result<(), DecodeError> {
        if rows.len() != self.n_images {
            return Err(DecodeError::ImageCount);
        }
        let w = out.phase.len();
        if !out.len_ok(w) || rows.iter().any(|r| r.len() != w) {
            return Err(DecodeError::Length);
        }
        if w == 0 {
            return Ok(());
        }
        if w < BLOCK {
            // Rows narrower than a block: padded into one (feature `short-rows`, on by default;
            // a firmware whose rows are never that narrow saves its code, about 35 KB on a
            // Cortex-M4F, and gets `ShortRow` instead).
            #[cfg(feature = "short-rows")]
            return self.decode_short_row::<P, N>(scratch, rows, out);
            #[cfg(not(feature = "short-rows"))]
            return Err(DecodeError::ShortRow);
        }
        let RowOut {
            phase,
            modulation,
            dc,
            validity,
        } = out;
        let blk = &mut scratch.0;
        let (mut mo_sink, mut dc_sink) = ([0.0f32; BLOCK], [0.0f32; BLOCK]);
        // Whole blocks only, so that every loop has the constant trip count BLOCK (no remainder
        // loops, whatever the vector width): the last block ends at the row's end and may overlap
        // the one before, whose pixels it computes again to the same bits.
        let mut start = 0;
        loop {
            let r = start..start + BLOCK;
            let out = BlockOut {
                phase: block_mut(phase, r.clone())?,
                modulation: block_or_sink(modulation, r.clone(), &mut mo_sink)?,
                dc: block_or_sink(dc, r.clone(), &mut dc_sink)?,
                validity: block_mut(validity, r.clone())?,
            };
            self.decode_block::<P, N>(blk, rows, start, out)?;
            if start + BLOCK == w {
                return Ok(());
            }
            start = if w - (start + BLOCK) >= BLOCK {
                start + BLOCK
            } else {
                w - BLOCK
            };
        }
    }

    /// A row shorter than [`BLOCK`]: copied into a padded block (the padding decodes to values
    /// that are dropped).
    #[cfg(feature = "short-rows")]
    fn decode_short_row<P: Sample, const N: usize>(
        &self,
        scratch: &mut DecodeScratch<A>,
        rows: &[&[P]],
        out: RowOut<'_>,
    ) -> Result<(), DecodeError> {
        let first = rows
            .first()
            .and_then(|r| r.first())
            .copied()
            .ok_or(DecodeError::Length)?;
        let mut padded = [[first; BLOCK]; MAX_IMAGES];
        let mut refs: [&[P]; MAX_IMAGES] = [&[]; MAX_IMAGES];
        // Element-wise copies (zip) rather than `copy_from_slice`: the caller checked the
        // lengths, and no length-mismatch panic path is compiled in.
        for ((p, r), slot) in padded.iter_mut().zip(rows).zip(refs.iter_mut()) {
            for (d, s) in p.iter_mut().zip(r.iter()) {
                *d = *s;
            }
            *slot = &p[..];
        }
        let (mut ph, mut mo, mut dc) = ([0.0f32; BLOCK], [0.0f32; BLOCK], [0.0f32; BLOCK]);
        let mut va = [0u8; BLOCK];
        let o = BlockOut {
            phase: &mut ph,
            modulation: &mut mo,
            dc: &mut dc,
            validity: &mut va,
        };
        let refs = refs.get(..rows.len()).ok_or(DecodeError::ImageCount)?;
        self.decode_block::<P, N>(&mut scratch.0, refs, 0, o)?;
        copy(out.phase, &ph);
        copy(out.modulation, &mo);
        copy(out.dc, &dc);
        copy(out.validity, &va);
        Ok(())
    }

    /// Decode the block of pixels `start..start + BLOCK` of every row.
    ///
    /// The largest sample of every pixel first (saturation is tested once on it: `v ≥ t` for
    /// some sample ⇔ `max v ≥ t`); pass 1 per level, DC level first, straight from the level's
    /// image rows ([`Self::level_from_rows`]); pass 2, the unwrapping and validity
    /// ([`Self::unwrap_block`]).
    #[inline(always)]
    fn decode_block<P: Sample, const N: usize>(
        &self,
        blk: &mut Block<A>,
        rows: &[&[P]],
        start: usize,
        out: BlockOut<'_>,
    ) -> Result<(), DecodeError> {
        let peak = match rows.len() {
            8 => peak_of::<P, 8>(rows, start)?,
            12 => peak_of::<P, 12>(rows, start)?,
            _ => {
                let r = start..start + BLOCK;
                let mut peak: [P; BLOCK] = *block(rows.first().copied().unwrap_or(&[]), r.clone())?;
                for row in rows.iter().skip(1) {
                    let row = block(row, r.clone())?;
                    for (p, v) in peak.iter_mut().zip(row) {
                        *p = v.max_of(*p);
                    }
                }
                peak
            }
        };
        match self.fused {
            FUSED_PAIRS if N == 1 => {
                self.fused_rows::<P, KIND_PAIR_UNIT, 1>(rows, start, blk, out.modulation)?
            }
            FUSED_QUADS if N == 1 => {
                self.fused_rows::<P, KIND_QUAD_EXACT, 1>(rows, start, blk, out.modulation)?
            }
            FUSED_PAIRS => {
                self.fused_rows::<P, KIND_PAIR_UNIT, FUSED_LANES>(rows, start, blk, out.modulation)?
            }
            FUSED_QUADS => self.fused_rows::<P, KIND_QUAD_EXACT, FUSED_LANES>(
                rows,
                start,
                blk,
                out.modulation,
            )?,
            _ => {
                blk.dc = [A::ZERO; BLOCK];
                for &l in self.level_order.iter().take(self.n_levels) {
                    let li = self.level_images.get(l as usize);
                    if li.is_some_and(|li| li.kind != KIND_GRAY) {
                        self.level_from_rows(l as usize, rows, start, blk, out.modulation)?;
                    }
                }
                if self.gray.is_some() {
                    self.gray_from_rows(rows, start, blk)?;
                }
            }
        }
        self.correct_block(blk);
        let sat = self.limits.saturation;
        self.unwrap_block::<P, N>(blk, &peak, |p| A::saturated(A::input(p), sat), out);
        Ok(())
    }

    /// Pass 1 of the row driver for level `l`: its S and C straight from its images' rows
    /// (the block at `start`), then as [`Self::polar_into`]. For the DC level also A, into the
    /// block.
    ///
    /// The sums are those of [`Self::accumulate`] bit for bit: the same products added in the same
    /// (image) order from +0, where a zero coefficient adds ±0, which leaves a sum that is never
    /// −0 unchanged (the accumulate path skips those products).
    #[inline(always)]
    fn level_from_rows<P: Sample>(
        &self,
        l: usize,
        rows: &[&[P]],
        start: usize,
        blk: &mut Block<A>,
        modulation: &mut [f32; BLOCK],
    ) -> Result<(), DecodeError> {
        let li = self.level_images.get(l).ok_or(DecodeError::Sequence)?;
        let is_dc = self.dc_level == Some(l as u8);
        let fine = l + 1 == self.n_levels;
        let range = start..start + BLOCK;
        let row_of = |k: u8| {
            rows.get(k as usize)
                .ok_or(DecodeError::ImageCount)
                .and_then(|row| block(row, range.clone()))
        };
        macro_rules! fixed_n {
            ($n:literal, $k:expr) => {{
                let mut r: [&[P; BLOCK]; $n] = [row_of(li.idx[0])?; $n];
                for (slot, &k) in r.iter_mut().zip(&li.idx[..$n]) {
                    *slot = row_of(k)?;
                }
                match (is_dc, fine) {
                    (false, false) => {
                        self.level_rows::<P, $n, $k, false, false>(l, &r, blk, modulation)
                    }
                    (false, true) => {
                        self.level_rows::<P, $n, $k, false, true>(l, &r, blk, modulation)
                    }
                    (true, false) => {
                        self.level_rows::<P, $n, $k, true, false>(l, &r, blk, modulation)
                    }
                    (true, true) => {
                        self.level_rows::<P, $n, $k, true, true>(l, &r, blk, modulation)
                    }
                }
            }};
        }
        match (li.n, li.kind) {
            (2, KIND_PAIR_UNIT) => fixed_n!(2, KIND_PAIR_UNIT),
            (2, KIND_PAIR) => fixed_n!(2, KIND_PAIR),
            (2, _) => fixed_n!(2, KIND_GENERIC),
            (3, _) => fixed_n!(3, KIND_GENERIC),
            (4, KIND_QUAD_EXACT) => fixed_n!(4, KIND_QUAD_EXACT),
            (4, KIND_QUAD) => fixed_n!(4, KIND_QUAD),
            (4, _) => fixed_n!(4, KIND_GENERIC),
            _ => {
                // Any other number of images: fold them one by one into S and C planes (and A),
                // in image order from +0, then the same polar pass as the frame-sequential path.
                let mut sp = [A::ZERO; BLOCK];
                let mut cp = [A::ZERO; BLOCK];
                for &k in li.idx.iter().take(li.n as usize) {
                    let coef = self.images.get(k as usize).ok_or(DecodeError::Sequence)?;
                    let row = row_of(k)?;
                    for i in 0..BLOCK {
                        let v = A::input(row[i]);
                        sp[i] = A::mac(sp[i], coef.a, v);
                        cp[i] = A::mac(cp[i], coef.b, v);
                        if is_dc {
                            blk.dc[i] = A::mac(blk.dc[i], coef.w, v);
                        }
                    }
                }
                self.polar_into(l, &sp, &cp, blk, modulation);
            }
        }
        Ok(())
    }

    /// [`Self::level_from_rows`] for a level of `N` images: one loop over the block, every sum
    /// in registers.
    #[inline(always)]
    fn level_rows<P: Sample, const N: usize, const KIND: u8, const DC: bool, const FINE: bool>(
        &self,
        l: usize,
        rows: &[&[P; BLOCK]; N],
        blk: &mut Block<A>,
        mo: &mut [f32; BLOCK],
    ) {
        let (mut ka, mut kb, mut kw) = ([A::COEF_ZERO; N], [A::COEF_ZERO; N], [A::COEF_ZERO; N]);
        for j in 0..N {
            let k = self.level_images[l].idx[j] as usize;
            if let Some(c) = self.images.get(k) {
                (ka[j], kb[j], kw[j]) = (c.a, c.b, c.w);
            }
        }
        let (ad, bd, fmt) = (self.a_dc[l], self.b_dc[l], &self.format);
        if KIND == KIND_PAIR_UNIT || KIND == KIND_QUAD_EXACT {
            return self.level_rows_exact::<P, N, KIND, DC, FINE>(
                l,
                rows,
                (ka[0], kb[1 % N], kw[0]),
                blk,
                mo,
            );
        }
        let Block {
            dc, wrapped, mag, ..
        } = blk;
        let (w, mag) = (&mut wrapped[l], &mut mag[l]);
        for i in 0..BLOCK {
            let (mut s, mut c, mut a) = (A::ZERO, A::ZERO, A::ZERO);
            for j in 0..N {
                let v = A::input(rows[j][i]);
                // The kinds' zero products are skipped (known at compile time).
                let (sj, cj) = if KIND == KIND_GENERIC {
                    (true, true)
                } else {
                    (j % 2 == 0, j % 2 == 1)
                };
                if sj {
                    s = A::mac(s, ka[j], v);
                }
                if cj {
                    c = A::mac(c, kb[j], v);
                }
                if DC {
                    a = A::mac(a, kw[j], v);
                }
            }
            if DC {
                dc[i] = a;
            } else {
                a = dc[i];
            }
            let (s, c) = if KIND == KIND_QUAD {
                (s, c)
            } else {
                A::level_sc(s, c, ad, bd, a, fmt)
            };
            if FINE {
                let (p, b2, b) = A::polar_fine(s, c, fmt);
                (w[i], mag[i], mo[i]) = (p, b2, b);
            } else {
                (w[i], mag[i]) = A::polar_coarse(s, c);
            }
        }
    }

    /// [`Self::level_rows`] for the regrouped kinds [`KIND_PAIR_UNIT`] and [`KIND_QUAD_EXACT`]
    /// (`k` = a₀, b₁, w₀): the same bits with fewer operations.
    #[inline(always)]
    fn level_rows_exact<
        P: Sample,
        const N: usize,
        const KIND: u8,
        const DC: bool,
        const FINE: bool,
    >(
        &self,
        l: usize,
        rows: &[&[P; BLOCK]; N],
        (ka, kb, kw): (A::Coef, A::Coef, A::Coef),
        blk: &mut Block<A>,
        mo: &mut [f32; BLOCK],
    ) {
        let fmt = &self.format;
        let Block {
            dc, wrapped, mag, ..
        } = blk;
        let (w, mag) = (&mut wrapped[l], &mut mag[l]);
        let (r0, r1, r2, r3) = (rows[0], rows[1 % N], rows[2 % N], rows[3 % N]);
        for i in 0..BLOCK {
            let (v0, v1) = (A::input(r0[i]), A::input(r1[i]));
            let (s, c) = if KIND == KIND_PAIR_UNIT {
                // S = 1·I₀ − 1·A, C = 1·I₁ − 1·A (not the DC level: its coefficients are zero).
                (A::in_minus_acc(v0, dc[i]), A::in_minus_acc(v1, dc[i]))
            } else {
                let (v2, v3) = (A::input(r2[i]), A::input(r3[i]));
                // k = 0.25, 0.5, 0.5 (`level_kind`): positive.
                if DC {
                    dc[i] =
                        A::regrouped_product(kw, A::in_add(A::in_add(A::in_add(v0, v1), v2), v3));
                }
                (
                    A::regrouped_product(ka, A::in_sub(v0, v2)),
                    A::regrouped_product(kb, A::in_sub(v1, v3)),
                )
            };
            if FINE {
                let (p, b2, b) = A::polar_fine(s, c, fmt);
                (w[i], mag[i], mo[i]) = (p, b2, b);
            } else {
                (w[i], mag[i]) = A::polar_coarse(s, c);
            }
        }
    }
}

/// The largest sample of every pixel of the block at `start` of `N` image rows (the common set
/// sizes, 8 and 12): every row read side by side, the running maximum in registers. A fold row
/// by row stores and reloads the running maximum once per row. The maximum of integers does not
/// depend on the order: the bits of the fold.
#[inline(always)]
fn peak_of<P: Sample, const N: usize>(
    rows: &[&[P]],
    start: usize,
) -> Result<[P; BLOCK], DecodeError> {
    let r = start..start + BLOCK;
    let first = block(rows.first().copied().unwrap_or(&[]), r.clone())?;
    let mut b: [&[P; BLOCK]; N] = [first; N];
    if rows.len() != N {
        return Err(DecodeError::ImageCount);
    }
    for (slot, row) in b.iter_mut().zip(rows) {
        *slot = block(row, r.clone())?;
    }
    let mut peak = *first;
    for (i, p) in peak.iter_mut().enumerate() {
        let mut m = b[0][i];
        for row in &b[1..] {
            m = row[i].max_of(m);
        }
        *p = m;
    }
    Ok(peak)
}

/// `dst[i] = src[i]` for every `i` of both (the short-row path's lengths are checked before).
#[cfg(feature = "short-rows")]
fn copy<T: Copy>(dst: &mut [T], src: &[T]) {
    for (d, s) in dst.iter_mut().zip(src) {
        *d = *s;
    }
}
