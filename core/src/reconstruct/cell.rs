//! One sample of the reference phase along a pixel's search line and the pieces of the Newton
//! step (paper §6 step 1): the bilinear cell of a sample offset, its loads and interpolation, the
//! interpolant's slope along the line, and the acceptance of a step.

use super::ACCEPT_LAST_STEP_PX;
use super::offset::{Lane, offset};
use super::refrows::RefRows;
use super::setup::Consts;
use crate::math::CANONICAL_NAN;

/// `floor(x)` for `|x| < 2²²`, in f32 arithmetic only (round to nearest by the 1.5·2²³ trick,
/// then step down if it rounded up), so that it vectorizes.
#[inline(always)]
fn floor_small(x: f32) -> f32 {
    const MAGIC: f32 = 12_582_912.0;
    let r = (x + MAGIC) - MAGIC;
    if r > x { r - 1.0 } else { r }
}

/// The bilinear cell of the sample at pixel offset `(du, dv)` from pixel `(u, v)`: band row index
/// `k` (of the cell's upper row) and column `col` (integers held in f32), fractions `(fu, fv)`, and
/// whether the cell lies in the image and the band. The integer and fractional parts are split
/// exactly. On the last column/row a sample exactly on it is read from the cell to its left/above.
/// Branch-free f32 arithmetic, so a loop over lanes vectorizes.
#[inline(always)]
pub(super) fn cell(du: f32, dv: f32, u: f32, v: f32, gr: &Grid) -> (f32, f32, f32, f32, bool) {
    // NaN, infinite or huge offsets fail the range tests below (floor_small is only exact below
    // 2²², but such offsets land far outside the image or band anyway).
    let iu = floor_small(du);
    let iv = floor_small(dv);
    // The cell's column and row, at most the last but one (a sample on the last column or row
    // is read from the cell before it, with fraction 1; further out the fraction exceeds 1).
    // Integers in f32 add and subtract exactly, so `fu = du − (col − u)` is `du − iu` (exact), or
    // `(du − iu) + 1` rounded once on the last column.
    let col0 = u + iu;
    let row0 = v + iv;
    let col = if col0 < gr.w - 2.0 { col0 } else { gr.w - 2.0 };
    let row = if row0 < gr.last_row - 1.0 {
        row0
    } else {
        gr.last_row - 1.0
    };
    let fu = du - (col - u);
    let fv = dv - (row - v);
    let k = row - gr.first;
    let ok = (col >= 0.0) & (fu <= 1.0) & (fv <= 1.0) & (k >= 0.0) & (k + 1.0 < gr.band_len);
    (k, col, fu, fv, ok)
}

/// The integer value of an f32 holding an integer in `[0, 2²³)`, by its bits (`x + 2²³` has the
/// integer in its mantissa): no conversion instruction, so it vectorizes. Other inputs give a
/// meaningless value (callers only use it under an `ok` flag).
#[inline(always)]
pub(super) fn small_int(x: f32) -> u32 {
    (x + 8_388_608.0).to_bits().wrapping_sub(0x4B00_0000)
}

/// The four samples of a cell (`ok` from [`cell`]); NaN where unavailable. Invalid reference
/// samples are NaN already.
#[inline(always)]
fn load(rr: &RefRows<'_>, k: u32, col: u32, ok: bool) -> [f32; 4] {
    const NAN4: [f32; 4] = [CANONICAL_NAN; 4];
    if !ok {
        return NAN4;
    }
    let (k, col) = (k as usize, col as usize);
    let (Some(&o0), Some(&o1)) = (rr.offs.get(k), rr.offs.get(k + 1)) else {
        return NAN4;
    };
    let i0 = (o0 as usize).saturating_add(col);
    let i1 = (o1 as usize).saturating_add(col);
    let pair = |i: usize| rr.data.get(i..).and_then(|r| r.get(..2));
    match (pair(i0), pair(i1)) {
        (Some(a), Some(b)) if o0 != u32::MAX && o1 != u32::MAX => [a[0], a[1], b[0], b[1]],
        _ => NAN4,
    }
}

/// Bilinear interpolation of a cell at `(fu, fv)`, minus `phi` (differences first, so the result
/// near the crossing keeps the precision of the small terms).
#[inline(always)]
pub(super) fn interp(q: [f32; 4], fu: f32, fv: f32, phi: f32) -> f32 {
    let [a, b, c1, d] = q;
    let dab = b - a;
    (a - phi) + fu * dab + fv * ((c1 - a) + fu * ((d - c1) - dab))
}

/// Geometry of the band for [`cell`] (integers held in f32).
#[derive(Clone, Copy)]
pub(super) struct Grid {
    pub(super) w: f32,
    pub(super) last_row: f32,
    pub(super) first: f32,
    pub(super) band_len: f32,
}

/// One full sample (scalar): offset → cell → loads → interpolation, and the Newton slope there
/// ([`cell_slope`]).
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub(super) fn sample(
    c: &Consts,
    rr: &RefRows<'_>,
    gr: &Grid,
    l: Lane,
    u: f32,
    v: f32,
    t: f32,
    phi: f32,
) -> (f32, f32) {
    let ((du, dv), (ru, rv)) = offset(c, l, t);
    let (k, col, fu, fv, ok) = cell(du, dv, u, v, gr);
    let q = load(rr, small_int(k), small_int(col), ok);
    (interp(q, fu, fv, phi), cell_slope(q, fu, fv, ru, rv))
}

/// The slope in `t` of the bilinear interpolant of cell `q` at `(fu, fv)` for the sample moving
/// at `(ru, rv)` pixels per unit `t`: the Newton slope. No fallback: where it is zero or not
/// finite (a flat cell, a NaN sample) the step it gives is infinite or NaN, which no acceptance
/// passes (a first step is clamped to the depth interval and evaluated again).
#[inline(always)]
pub(super) fn cell_slope(q: [f32; 4], fu: f32, fv: f32, ru: f32, rv: f32) -> f32 {
    let [a, b, c1, d] = q;
    let dab = b - a;
    let twist = (d - c1) - dab;
    let gu = dab + fv * twist;
    let gv = (c1 - a) + fu * twist;
    gu * ru + gv * rv
}

#[inline(always)]
pub(super) fn clamp(t: f32, lo: f32, hi: f32) -> f32 {
    if t < lo {
        lo
    } else if t > hi {
        hi
    } else {
        t
    }
}

/// Acceptance of the Newton answer `tn` reached by the step from `tc` (in t; `dp2` squared
/// pixels per unit t): the step is below [`ACCEPT_LAST_STEP_PX`] and `tn` lies in the depth
/// interval `[lo, hi]`. The step is `g(tc)` (sampled) over the interpolant's slope at `tc`, so
/// it is exact to the crossing within `tc`'s cell (up to the small twist term); where the
/// crossing lies in the next cell, `tn` errs by the step times the slope's relative change
/// between the two cells.
#[inline(always)]
pub(super) fn accept(tn: f32, tc: f32, dp2: f32, lo: f32, hi: f32) -> bool {
    let s1 = tn - tc;
    (s1 * s1 * dp2 <= ACCEPT_LAST_STEP_PX * ACCEPT_LAST_STEP_PX) & (tn >= lo) & (tn <= hi)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cell_slope_is_the_derivative_of_the_interpolant() {
        let mut seed = 0x1234_5678_9abc_def0u64;
        let mut next = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        for _ in 0..1000 {
            let q = [0.0, 0.0, 0.0, 0.0].map(|_: f64| 50.0 + 2.0 * next() - 1.0);
            let (fu, fv) = (next(), next());
            let (ru, rv) = (200.0 * next() - 100.0, 200.0 * next() - 100.0);
            // The bilinear interpolant, written as the usual weighted sum, differentiated
            // numerically along (ru, rv).
            let bil = |u: f64, v: f64| {
                q[0] * (1.0 - u) * (1.0 - v)
                    + q[1] * u * (1.0 - v)
                    + q[2] * (1.0 - u) * v
                    + q[3] * u * v
            };
            let h = 1e-7;
            let want = (bil(fu + ru * h, fv + rv * h) - bil(fu - ru * h, fv - rv * h)) / (2.0 * h);
            let got = cell_slope(
                q.map(|v| v as f32),
                fu as f32,
                fv as f32,
                ru as f32,
                rv as f32,
            );
            let tol = 1e-5 * (ru.abs() + rv.abs()) * 4.0;
            assert!(
                (f64::from(got) - want).abs() <= tol,
                "slope {got} vs {want}"
            );
        }
        // A flat cell or a NaN sample has no slope, and the step it gives is never accepted, however
        // small the sample's distance from the phase.
        let (tc, g, dp2) = (0.5f32, 1e-6f32, 100.0f32);
        for q in [[1.0; 4], [1.0, f32::NAN, 1.0, 1.0]] {
            let sl = cell_slope(q, 0.3, 0.6, 10.0, 1.0);
            assert!(sl == 0.0 || sl.is_nan(), "slope {sl}");
            assert!(!accept(tc - g / sl, tc, dp2, -1.0, 1.0));
        }
    }
}
