//! The projector's defocus kernel and the 1-D tables built from it: the box ⊗ Gaussian kernel
//! `K`, the blurred window of the DMD's extent, 4-point Lagrange weights, and the exact blur of a
//! pixel staircase at sub-pixel spacing (the straight-fringe profiles and the 2-D tables of
//! [`LightSet`](super::LightSet)).

pub use crate::math::box_gauss;

/// The Gaussian blur of the indicator of `[−½, n − ½]` at `w`.
#[inline]
pub(super) fn window(w: f64, n: u32, sigma: f64) -> f64 {
    let hi = n as f64 - 0.5;
    if sigma == 0.0 {
        return if (-0.5..=hi).contains(&w) { 1.0 } else { 0.0 };
    }
    let r = 7.0 * sigma;
    if w > -0.5 + r && w < hi - r {
        return 1.0;
    }
    if w < -0.5 - r || w > hi + r {
        return 0.0;
    }
    let s = 1.0 / (sigma * std::f64::consts::SQRT_2);
    0.5 * (libm::erf((w + 0.5) * s) - libm::erf((w - hi) * s))
}

/// 4-point Lagrange weights at nodes −1, 0, 1, 2 for a fraction `f ∈ [0, 1)`.
#[inline(always)]
pub(super) fn lagrange4(f: f64) -> [f64; 4] {
    let (fm1, fm2, fp1) = (f - 1.0, f - 2.0, f + 1.0);
    [
        -f * fm1 * fm2 / 6.0,
        fp1 * fm1 * fm2 / 2.0,
        -fp1 * f * fm2 / 2.0,
        fp1 * f * fm1 / 6.0,
    ]
}

/// Kernel reach: beyond 7σ + ½ the kernel is below 1e-12.
pub(super) fn reach_of(sigma: f64) -> f64 {
    7.0 * sigma + 0.5
}

/// Kernel values `K(φ/m − k)` for each sub-pixel phase φ = 0..m and integer offsets within reach:
/// `taps[φ] = (k_lo, values)` with values for k = k_lo, k_lo + 1, ….
pub(super) fn tap_table(sigma: f64, m: usize, reach: f64) -> Vec<(i64, Vec<f64>)> {
    (0..m)
        .map(|ph| {
            let f = ph as f64 / m as f64;
            let lo = (f - reach).ceil() as i64;
            let hi = (f + reach).floor() as i64;
            (
                lo,
                (lo..=hi).map(|k| box_gauss(f - k as f64, sigma)).collect(),
            )
        })
        .collect()
}

/// Blur the staircase `v` (pixel i at position i) onto positions `t0 + q/m`, q = 0..len.
/// `t0` must be an integer.
///
/// Each output is `0 + v[i₀]·k₀ + v[i₀+1]·k₁ + …` over the taps whose pixel exists, summed in
/// that order: [`blur_columns`] adds the same products in the same order, so the two passes of
/// the 2-D tables round alike.
pub(super) fn blur_1d(
    v: &[f64],
    t0: f64,
    m: usize,
    len: usize,
    taps: &[(i64, Vec<f64>)],
) -> Vec<f64> {
    let n = v.len() as i64;
    let t0 = t0 as i64;
    (0..len)
        .map(|q| {
            let (lo, ks) = &taps[q % m];
            let first = t0 + (q / m) as i64 + lo;
            // The taps whose pixel exists, in order.
            let (d0, d1) = taps_inside(first, ks.len(), n);
            let mut acc = 0.0;
            if d0 < d1 {
                let src = &v[(first + d0 as i64) as usize..(first + d1 as i64) as usize];
                for (x, k) in src.iter().zip(&ks[d0..d1]) {
                    acc += x * k;
                }
            }
            acc
        })
        .collect()
}

/// [`blur_1d`] down the columns of `rows` (`h` rows of `nx` values): output row `q` (of `len`)
/// into `out[q·nx..]`, as f32. Whole rows at a time, so the reads are contiguous; each value is
/// the f64 sum [`blur_1d`] gives for its column, to the bit.
pub(super) fn blur_columns(
    rows: &[f64],
    nx: usize,
    t0: f64,
    m: usize,
    len: usize,
    taps: &[(i64, Vec<f64>)],
    out: &mut [f32],
) {
    let h = (rows.len() / nx.max(1)) as i64;
    let t0 = t0 as i64;
    let mut acc = vec![0f64; nx];
    for (q, dst) in out.chunks_exact_mut(nx).take(len).enumerate() {
        let (lo, ks) = &taps[q % m];
        let first = t0 + (q / m) as i64 + lo;
        acc.fill(0.0);
        let (d0, d1) = taps_inside(first, ks.len(), h);
        for (d, k) in (d0..d1).zip(&ks[d0..d1]) {
            let j = (first + d as i64) as usize;
            for (a, x) in acc.iter_mut().zip(&rows[j * nx..(j + 1) * nx]) {
                *a += x * k;
            }
        }
        for (o, a) in dst.iter_mut().zip(&acc) {
            *o = *a as f32;
        }
    }
}

/// The taps `d0..d1` of `taps` taps starting at pixel `first` whose pixel `first + d` lies in
/// `0..n` (empty, `d0 == d1`, when none does).
fn taps_inside(first: i64, taps: usize, n: i64) -> (usize, usize) {
    let d0 = (-first).clamp(0, taps as i64) as usize;
    let d1 = (n - first).clamp(d0 as i64, taps as i64) as usize;
    (d0, d1)
}
