//! x86-64 implementations of the reconstruction kernel's [`CellGather`]: each pair of adjacent
//! reference samples is read as one 64-bit element (`vpgatherdq`), half the gathered elements of
//! the portable [`ScalarGather`].
//!
//! Data movement only: the kernel receives the same values, so the reconstruction gives the same
//! bits whichever gather it runs with (the tests below compare the samples, `host/tests/cli_scan.rs`
//! and the `reconstruct_batch` benchmark whole reconstructions). A value of
//! [`Avx2Pairs`] or [`Avx512Pairs`] is a token that the CPU has the instructions: it exists only
//! through [`Avx2Pairs::detect`] / [`Avx512Pairs::detect`].

use fringe3d_core::reconstruct::{CellGather, LANES, ScalarGather};

/// The largest sample index a 32-bit signed gather index reaches; longer storage falls back to
/// [`ScalarGather`].
#[cfg(target_arch = "x86_64")]
const MAX_INDEX: usize = i32::MAX as usize;

/// AVX2 pair gathers (`_mm256_i32gather_epi64`, four pairs per instruction).
#[derive(Clone, Copy, Debug)]
pub struct Avx2Pairs(());

impl Avx2Pairs {
    /// The token, if this CPU has AVX2.
    pub fn detect() -> Option<Self> {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            return Some(Avx2Pairs(()));
        }
        None
    }
}

impl CellGather for Avx2Pairs {
    #[inline(always)]
    fn gather(self, data: &[f32], ia: &[u32; LANES], ib: &[u32; LANES], q: [&mut [f32; LANES]; 4]) {
        #[cfg(target_arch = "x86_64")]
        if data.len() >= 2 && data.len() - 2 <= MAX_INDEX {
            // SAFETY: the token exists only if the CPU has AVX2 (`detect`); the indices are
            // clamped below, so every 8-byte read lies inside `data`.
            unsafe { x86::pairs_avx2(data, ia, ib, q) };
            return;
        }
        ScalarGather.gather(data, ia, ib, q);
    }
}

/// AVX-512 pair gathers (`_mm512_i32gather_epi64`, eight pairs per instruction). Exists when the
/// compiler has the AVX-512 intrinsics (1.89 or newer, `cfg(fringe3d_avx512)`).
#[derive(Clone, Copy, Debug)]
pub struct Avx512Pairs(());

impl Avx512Pairs {
    /// The token, if this CPU has AVX-512F and AVX-512DQ and this build has the AVX-512 kernels.
    pub fn detect() -> Option<Self> {
        #[cfg(all(target_arch = "x86_64", fringe3d_avx512))]
        if std::arch::is_x86_feature_detected!("avx512f")
            && std::arch::is_x86_feature_detected!("avx512dq")
        {
            return Some(Avx512Pairs(()));
        }
        None
    }
}

impl CellGather for Avx512Pairs {
    #[inline(always)]
    fn gather(self, data: &[f32], ia: &[u32; LANES], ib: &[u32; LANES], q: [&mut [f32; LANES]; 4]) {
        #[cfg(all(target_arch = "x86_64", fringe3d_avx512))]
        if data.len() >= 2 && data.len() - 2 <= MAX_INDEX {
            // SAFETY: the token exists only if the CPU has AVX-512F/DQ (`detect`); the indices
            // are clamped below, so every 8-byte read lies inside `data`.
            unsafe { x86::pairs_avx512(data, ia, ib, q) };
            return;
        }
        ScalarGather.gather(data, ia, ib, q);
    }
}

#[cfg(target_arch = "x86_64")]
mod x86 {
    use super::LANES;
    use std::arch::x86_64::*;

    const _: () = assert!(LANES.is_multiple_of(8));

    /// [`super::Avx2Pairs`]: for each 8 lanes, four gathers of 4 pairs, then even/odd split.
    ///
    /// # Safety
    /// The CPU has AVX2; `2 ≤ data.len()` and `data.len() − 2 ≤ i32::MAX`.
    #[target_feature(enable = "avx2")]
    #[inline]
    pub(super) unsafe fn pairs_avx2(
        data: &[f32],
        ia: &[u32; LANES],
        ib: &[u32; LANES],
        q: [&mut [f32; LANES]; 4],
    ) {
        let [qa, qb, qc, qd] = q;
        let last = _mm256_set1_epi32((data.len() - 2) as i32);
        let base = data.as_ptr() as *const i64;
        // Split 8 pairs (two vectors of 4) into the 8 first and the 8 second samples.
        let split = |lo: __m256i, hi: __m256i| {
            let (lo, hi) = (_mm256_castsi256_ps(lo), _mm256_castsi256_ps(hi));
            // Per 128-bit half: [lo0 lo2 hi0 hi2] (firsts) and [lo1 lo3 hi1 hi3] (seconds); the
            // 64-bit permute puts the halves in lane order.
            let first = _mm256_shuffle_ps::<0b10_00_10_00>(lo, hi);
            let second = _mm256_shuffle_ps::<0b11_01_11_01>(lo, hi);
            let fix = |v: __m256| {
                _mm256_castpd_ps(_mm256_permute4x64_pd::<0b11_01_10_00>(_mm256_castps_pd(v)))
            };
            (fix(first), fix(second))
        };
        for j in (0..LANES).step_by(8) {
            // SAFETY (all pointer reads and writes below): `j + 8 ≤ LANES`, the arrays' length;
            // the clamped indices are ≤ data.len() − 2 and non-negative as i32, so each gathered
            // 8 bytes are samples `i` and `i + 1` of `data`.
            unsafe {
                let xa = _mm256_min_epu32(
                    _mm256_loadu_si256(ia.as_ptr().add(j) as *const __m256i),
                    last,
                );
                let xb = _mm256_min_epu32(
                    _mm256_loadu_si256(ib.as_ptr().add(j) as *const __m256i),
                    last,
                );
                let ga0 = _mm256_i32gather_epi64::<4>(base, _mm256_castsi256_si128(xa));
                let ga1 = _mm256_i32gather_epi64::<4>(base, _mm256_extracti128_si256::<1>(xa));
                let gb0 = _mm256_i32gather_epi64::<4>(base, _mm256_castsi256_si128(xb));
                let gb1 = _mm256_i32gather_epi64::<4>(base, _mm256_extracti128_si256::<1>(xb));
                let (a, b) = split(ga0, ga1);
                let (c, d) = split(gb0, gb1);
                _mm256_storeu_ps(qa.as_mut_ptr().add(j), a);
                _mm256_storeu_ps(qb.as_mut_ptr().add(j), b);
                _mm256_storeu_ps(qc.as_mut_ptr().add(j), c);
                _mm256_storeu_ps(qd.as_mut_ptr().add(j), d);
            }
        }
    }

    /// [`super::Avx512Pairs`]: for each 8 lanes, two gathers of 8 pairs, then one permute each
    /// puts the first samples in the low and the second samples in the high half.
    ///
    /// # Safety
    /// The CPU has AVX-512F and AVX-512DQ; `2 ≤ data.len()` and `data.len() − 2 ≤ i32::MAX`.
    #[cfg(fringe3d_avx512)]
    #[clippy::msrv = "1.89"] // compiled only by rustc ≥ 1.89 (`fringe3d_avx512`)
    #[target_feature(enable = "avx512f,avx512dq,avx2")]
    #[inline]
    pub(super) unsafe fn pairs_avx512(
        data: &[f32],
        ia: &[u32; LANES],
        ib: &[u32; LANES],
        q: [&mut [f32; LANES]; 4],
    ) {
        let [qa, qb, qc, qd] = q;
        let last = _mm256_set1_epi32((data.len() - 2) as i32);
        let perm = _mm512_setr_epi32(0, 2, 4, 6, 8, 10, 12, 14, 1, 3, 5, 7, 9, 11, 13, 15);
        let base = data.as_ptr() as *const i64;
        for j in (0..LANES).step_by(8) {
            // SAFETY: as in `pairs_avx2`.
            unsafe {
                let xa = _mm256_min_epu32(
                    _mm256_loadu_si256(ia.as_ptr().add(j) as *const __m256i),
                    last,
                );
                let xb = _mm256_min_epu32(
                    _mm256_loadu_si256(ib.as_ptr().add(j) as *const __m256i),
                    last,
                );
                let pa = _mm512_permutexvar_ps(
                    perm,
                    _mm512_castsi512_ps(_mm512_i32gather_epi64::<4>(xa, base)),
                );
                let pb = _mm512_permutexvar_ps(
                    perm,
                    _mm512_castsi512_ps(_mm512_i32gather_epi64::<4>(xb, base)),
                );
                _mm256_storeu_ps(qa.as_mut_ptr().add(j), _mm512_castps512_ps256(pa));
                _mm256_storeu_ps(qb.as_mut_ptr().add(j), _mm512_extractf32x8_ps::<1>(pa));
                _mm256_storeu_ps(qc.as_mut_ptr().add(j), _mm512_castps512_ps256(pb));
                _mm256_storeu_ps(qd.as_mut_ptr().add(j), _mm512_extractf32x8_ps::<1>(pb));
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every sample bit pattern moved as it is (NaN payloads included), for in-range, clamped
    /// and huge indices and every short storage.
    fn check<G: CellGather>(g: G) {
        let mut seed = 0x2545_f491_4f6c_dd1du64;
        let mut next = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            seed
        };
        for len in [0usize, 1, 2, 3, 7, 64, 1000] {
            let data: Vec<f32> = (0..len).map(|_| f32::from_bits(next() as u32)).collect();
            for round in 0..50 {
                let (mut ia, mut ib) = ([0u32; LANES], [0u32; LANES]);
                for (a, b) in ia.iter_mut().zip(ib.iter_mut()) {
                    let pick = |r: u64| match r % 4 {
                        0 => u32::MAX - (r >> 8) as u32 % 3,
                        1 => len as u32 + (r >> 8) as u32 % 3,
                        _ => ((r >> 8) % (len as u64 + 1)) as u32,
                    };
                    (*a, *b) = (pick(next()), pick(next()));
                }
                let mut want = [[0f32; LANES]; 4];
                let mut got = [[1f32; LANES]; 4];
                let [w0, w1, w2, w3] = &mut want;
                ScalarGather.gather(&data, &ia, &ib, [w0, w1, w2, w3]);
                let [g0, g1, g2, g3] = &mut got;
                g.gather(&data, &ia, &ib, [g0, g1, g2, g3]);
                let bits = |q: &[[f32; LANES]; 4]| {
                    q.iter().flatten().map(|x| x.to_bits()).collect::<Vec<_>>()
                };
                assert_eq!(
                    bits(&got),
                    bits(&want),
                    "storage of {len} samples, round {round}"
                );
            }
        }
    }

    #[test]
    fn avx2_pairs_move_the_samples_of_the_scalar_gather() {
        match Avx2Pairs::detect() {
            Some(g) => check(g),
            None => eprintln!("skipped: this CPU has no AVX2"),
        }
    }

    #[test]
    fn avx512_pairs_move_the_samples_of_the_scalar_gather() {
        match Avx512Pairs::detect() {
            Some(g) => check(g),
            None => eprintln!("skipped: this CPU or compiler has no AVX-512"),
        }
    }
}
