//! The per-pixel kernel of [`super`]: search for N_I and eqs 16-18, over chunks of [`LANES`]
//! pixels in structure-of-arrays form so that the arithmetic passes vectorize. Every lane runs
//! the same IEEE operations whatever the chunk, so results do not depend on how a row is cut.

use super::{ACCEPT_LAST_STEP_PX, ACCEPT_STEP_PRODUCT_PX2, Consts, Reconstructor, SECANT_EVALS};
use crate::camera::{MAX_ROW_KNOTS as MAX_KNOTS, ROW_KNOT_STEP};
use crate::math::{CANONICAL_NAN, fabs};
use crate::validity::Validity;

/// Pixels per chunk of the row kernel (one knot span of the camera's row inverse).
pub const LANES: usize = ROW_KNOT_STEP;
/// Largest band of reference rows a reconstructor accepts.
pub const MAX_BAND_ROWS: usize = 512;

/// The band's reference rows, indexed by image row: offsets into one storage slice.
pub(crate) struct RefRows<'a> {
    data: &'a [f32],
    offs: [u32; MAX_BAND_ROWS],
    first: i64,
    last_image_row: i64,
    /// Rows set (`offs[..len]`).
    len: usize,
}

impl<'a> RefRows<'a> {
    pub(crate) fn new(data: &'a [f32], first: i64, last_image_row: i64) -> Self {
        RefRows { data, offs: [u32::MAX; MAX_BAND_ROWS], first, last_image_row, len: 0 }
    }

    pub(crate) fn set(&mut self, k: usize, offset: usize) {
        if let Some(s) = self.offs.get_mut(k) {
            *s = u32::try_from(offset).unwrap_or(u32::MAX);
            self.len = self.len.max(k + 1);
        }
    }

    /// Image row `r` (from its start to the end of storage; the caller indexes columns only
    /// below the width), or an empty slice outside the band.
    #[inline(always)]
    fn get(&self, r: i64) -> &'a [f32] {
        let k = r - self.first;
        if k >= 0 && (k as usize) < MAX_BAND_ROWS {
            let o = self.offs[k as usize];
            if o != u32::MAX {
                return self.data.get(o as usize..).unwrap_or(&[]);
            }
        }
        &[]
    }
}

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
fn cell(du: f32, dv: f32, u: f32, v: f32, gr: &Grid) -> (f32, f32, f32, f32, bool) {
    let fin = fabs(du) < 1.0e6 && fabs(dv) < 1.0e6;
    let du = if fin { du } else { 0.0 };
    let dv = if fin { dv } else { 0.0 };
    let iu = floor_small(du);
    let iv = floor_small(dv);
    let fu0 = du - iu;
    let fv0 = dv - iv;
    let col0 = u + iu;
    let row0 = v + iv;
    let eu = col0 == gr.w - 1.0;
    let ev = row0 == gr.last_row;
    let col = if eu { col0 - 1.0 } else { col0 };
    let fu = if eu { fu0 + 1.0 } else { fu0 };
    let row = if ev { row0 - 1.0 } else { row0 };
    let fv = if ev { fv0 + 1.0 } else { fv0 };
    let k = row - gr.first;
    let ok = fin & (col >= 0.0) & (col + 1.0 < gr.w) & (fu <= 1.0) & (fv <= 1.0) & (k >= 0.0) & (k + 1.0 < gr.band_len);
    (k, col, fu, fv, ok)
}

/// The integer value of an f32 holding an integer in `[0, 2²³)`, by its bits (`x + 2²³` has the
/// integer in its mantissa): no conversion instruction, so it vectorizes. Other inputs give a
/// meaningless value (callers only use it under an `ok` flag).
#[inline(always)]
fn small_int(x: f32) -> u32 {
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
    let i0 = o0 as usize + col;
    let i1 = o1 as usize + col;
    match (rr.data.get(i0..i0 + 2), rr.data.get(i1..i1 + 2)) {
        (Some(a), Some(b)) if o0 != u32::MAX && o1 != u32::MAX => [a[0], a[1], b[0], b[1]],
        _ => NAN4,
    }
}

/// Bilinear interpolation of a cell at `(fu, fv)`, minus `phi` (differences first, so the result
/// near the crossing keeps the precision of the small terms).
#[inline(always)]
fn interp(q: [f32; 4], fu: f32, fv: f32, phi: f32) -> f32 {
    let [a, b, c1, d] = q;
    let dab = b - a;
    (a - phi) + fu * dab + fv * ((c1 - a) + fu * ((d - c1) - dab))
}

/// Geometry of the band for [`cell`] (integers held in f32).
#[derive(Clone, Copy)]
struct Grid {
    w: f32,
    last_row: f32,
    first: f32,
    band_len: f32,
}

/// One full sample (scalar): offset → cell → loads → interpolation.
#[inline(always)]
fn sample(c: &Consts, rr: &RefRows<'_>, gr: &Grid, l: Lane, u: f32, v: f32, t: f32, phi: f32) -> f32 {
    let (du, dv) = offset(c, l, t);
    let (k, col, fu, fv, ok) = cell(du, dv, u, v, gr);
    interp(load(rr, small_int(k), small_int(col), ok), fu, fv, phi)
}

/// Per-pixel quantities of one lane.
#[derive(Clone, Copy)]
struct Lane {
    x: f32,
    y: f32,
    r2: f32,
    rad: f32,
    ex: f32,
    ey: f32,
}

/// Pixel offset `A·(D(m + t·e) − D(m))` of the sample at parameter `t` (eqs 3-4 in difference
/// form: every term is proportional to the offset `δ = t·e`, so it keeps f32 precision relative
/// to the offset, not to the absolute pixel position).
#[inline(always)]
fn offset(c: &Consts, l: Lane, t: f32) -> (f32, f32) {
    let [k1, k2, p1, p2, k3] = c.k;
    let dx = t * l.ex;
    let dy = t * l.ey;
    let (x, y, r2) = (l.x, l.y, l.r2);
    let y1 = y + dy;
    // q = |m + δ|² − |m|²
    let q = 2.0 * (x * dx + y * dy) + (dx * dx + dy * dy);
    let r2b = r2 + q;
    let drad = q * (k1 + k2 * (r2b + r2) + k3 * (r2b * r2b + r2b * r2 + r2 * r2));
    let rad1 = l.rad + drad;
    let dxy = x * dy + dx * y1; // Δ(x·y)
    let ddx = dx * rad1 + x * drad + (2.0 * p1 * dxy + p2 * (q + 2.0 * dx * (2.0 * x + dx)));
    let ddy = dy * rad1 + y * drad + (p1 * (q + 2.0 * dy * (2.0 * y + dy)) + 2.0 * p2 * dxy);
    (c.fx * ddx + c.sfx * ddy, c.fy * ddy)
}

#[inline(always)]
fn clamp(t: f32, lo: f32, hi: f32) -> f32 {
    if t < lo {
        lo
    } else if t > hi {
        hi
    } else {
        t
    }
}

/// The slope for the next step: the secant slope of `(t0, g0)`, `(t1, g1)` when the two points
/// are at least [`MIN_SECANT_PX`] apart (`dp2` = squared pixels per unit t) and it is finite and
/// non-zero; otherwise the previous slope `s`. Points closer than that differ by f32 noise, and
/// their secant would be noise.
#[inline(always)]
fn slope(s: f32, t0: f32, g0: f32, t1: f32, g1: f32, dp2: f32) -> f32 {
    let dt = t1 - t0;
    let sec = (g1 - g0) / dt;
    let ok = (dt * dt * dp2 >= MIN_SECANT_PX * MIN_SECANT_PX) & (fabs(sec) < f32::INFINITY) & (sec != 0.0);
    if ok { sec } else { s }
}

#[doc(hidden)]
pub static REASONS: [core::sync::atomic::AtomicUsize; 5] = [const { core::sync::atomic::AtomicUsize::new(0) }; 5];
#[doc(hidden)]
pub static FALLBACKS: core::sync::atomic::AtomicUsize = core::sync::atomic::AtomicUsize::new(0);

/// Smallest separation (pixels) of two samples whose secant slope is trusted.
const MIN_SECANT_PX: f32 = 1e-4;

/// Eq 16-18 in closed form: depth `s` of M along `(x, y, 1)` for the crossing at `t`.
#[inline(always)]
fn depth(c: &Consts, a: f32, t: f32) -> f32 {
    c.h_r * (1.0 - c.pz * t) / (a - (a * c.pz + c.h) * t)
}

/// Reconstruct one row (see [`Reconstructor::reconstruct_row`]); lengths are checked by the caller.
#[allow(clippy::too_many_arguments)]
pub(crate) fn row(
    r: &Reconstructor,
    rr: &RefRows<'_>,
    v: u32,
    phase: &[f32],
    validity: &[u8],
    out_xyz: &mut [f32],
    out_validity: &mut [u8],
    mut crossings: Option<&mut [f32]>,
) {
    let w = r.width();
    let mut kx = [0f32; MAX_KNOTS];
    let mut ky = [0f32; MAX_KNOTS];
    let nk = r.camera().row_knots_f32(v, &mut kx, &mut ky);
    let knots = (&kx[..nk], &ky[..nk]);
    let mut c0 = 0;
    while c0 < w {
        let n = (w - c0).min(LANES);
        let cr = crossings.as_deref_mut().and_then(|c| c.get_mut(2 * c0..2 * (c0 + n)));
        chunk(
            r,
            rr,
            knots,
            v,
            c0,
            &phase[c0..c0 + n],
            &validity[c0..c0 + n],
            &mut out_xyz[3 * c0..3 * (c0 + n)],
            &mut out_validity[c0..c0 + n],
            cr,
        );
        c0 += n;
    }
}

/// A window of `LANES + 2` samples of row `row` around columns `c0 − 1 ..= c0 + LANES`, linearly
/// extrapolated one column past each image edge (so a central difference there is one-sided); NaN
/// further out or where the row is missing.
#[inline(always)]
fn window(row: &[f32], c0: usize, w: usize) -> [f32; LANES + 2] {
    let mut out = [CANONICAL_NAN; LANES + 2];
    if c0 >= 1 && c0 + LANES + 1 <= w {
        if let Some(src) = row.get(c0 - 1..c0 + LANES + 1) {
            out.copy_from_slice(src);
            return out;
        }
    }
    let at = |k: usize| row.get(k).copied().unwrap_or(CANONICAL_NAN);
    for (j, o) in out.iter_mut().enumerate() {
        let col = c0 + j; // image column + 1
        *o = if col == 0 {
            2.0 * at(0) - at(1)
        } else if col - 1 < w {
            at(col - 1)
        } else if col - 1 == w && w >= 2 {
            2.0 * at(w - 1) - at(w - 2)
        } else {
            CANONICAL_NAN
        };
    }
    out
}

#[allow(clippy::too_many_arguments)]
#[inline(never)]
fn chunk(
    r: &Reconstructor,
    rr: &RefRows<'_>,
    knots: (&[f32], &[f32]),
    v: u32,
    c0: usize,
    phase: &[f32],
    validity: &[u8],
    out_xyz: &mut [f32],
    out_validity: &mut [u8],
    crossings: Option<&mut [f32]>,
) {
    const E: usize = SECANT_EVALS;
    let c = *r.consts();
    let n = phase.len().min(LANES);
    let wu = r.width();
    let gr = Grid {
        w: wu as f32,
        last_row: rr.last_image_row as f32,
        first: rr.first as f32,
        band_len: rr.len as f32,
    };
    let vi = v as i32;
    let vf = v as f32;
    let u0 = c0 as f32;

    let mut x = [0f32; LANES];
    let mut y = [0f32; LANES];
    let kn = c0 / LANES;
    let knot = |j: usize| match (knots.0.get(j), knots.1.get(j)) {
        (Some(&a), Some(&b)) => Some([a, b]),
        _ => None,
    };
    let ka = knot(kn);
    let (ka, kb) = (ka.unwrap_or([CANONICAL_NAN; 2]), knot(kn + 1).or(ka).unwrap_or([CANONICAL_NAN; 2]));
    r.camera().undistort_span_from_knots_f32(v, c0, ka, kb, &mut x, &mut y);

    // Input validity (scalar: codes).
    let mut phi = [0f32; LANES];
    let mut active = [false; LANES];
    let mut code = [Validity::PhaseOutOfRange as u8; LANES];
    for i in 0..n {
        let q = validity[i];
        let p = phase[i];
        if q == Validity::Valid as u8 && p.is_finite() {
            active[i] = true;
            phi[i] = p;
            code[i] = Validity::Valid as u8;
        } else if let Some(vq) = Validity::from_u8(q) {
            if !vq.is_valid() {
                code[i] = q;
            }
        }
    }

    // Pass 1 (vector): per-pixel geometry, the sample at the pixel itself, the slope there, and
    // the first step.
    let rv = window(rr.get(vi as i64), c0, wu);
    let up = if vi == 0 { [CANONICAL_NAN; LANES + 2] } else { window(rr.get(vi as i64 - 1), c0, wu) };
    let dn = if vi as i64 == rr.last_image_row { [CANONICAL_NAN; LANES + 2] } else { window(rr.get(vi as i64 + 1), c0, wu) };
    let mut a = [0f32; LANES];
    let mut lane = [Lane { x: 0.0, y: 0.0, r2: 0.0, rad: 0.0, ex: 0.0, ey: 0.0 }; LANES];
    let mut tlo = [0f32; LANES];
    let mut thi = [0f32; LANES];
    let mut dp2 = [0f32; LANES];
    let mut sl = [0f32; LANES];
    let mut t = [[0f32; LANES]; E + 2];
    let mut g = [[0f32; LANES]; E + 1];
    {
        let [k1, k2, p1, p2, k3] = c.k;
        for i in 0..LANES {
            let (xi, yi) = (x[i], y[i]);
            let ai = c.nx * xi + c.ny * yi + c.nz;
            a[i] = ai;
            let exi = c.px - c.pz * xi;
            let eyi = c.py - c.pz * yi;
            let na = c.z_min * ai - c.h_r;
            let ta = na / (na * c.pz + c.h * c.z_min);
            let nb = c.z_max * ai - c.h_r;
            let tb = nb / (nb * c.pz + c.h * c.z_max);
            let lo = if ta < tb { ta } else { tb };
            let hi = if ta < tb { tb } else { ta };
            tlo[i] = lo;
            thi[i] = hi;
            let rr2 = xi * xi + yi * yi;
            let radial = 1.0 + rr2 * (k1 + rr2 * (k2 + rr2 * k3));
            lane[i] = Lane { x: xi, y: yi, r2: rr2, rad: radial, ex: exi, ey: eyi };
            // Jacobian of eq 3 at m applied to e, then eq 4: pixels per unit t.
            let dr = k1 + rr2 * (2.0 * k2 + rr2 * (3.0 * k3));
            let xy = xi * yi;
            let j00 = radial + 2.0 * xi * xi * dr + (2.0 * p1 * yi + 6.0 * p2 * xi);
            let j01 = 2.0 * xy * dr + (2.0 * p1 * xi + 2.0 * p2 * yi);
            let j11 = radial + 2.0 * yi * yi * dr + (6.0 * p1 * yi + 2.0 * p2 * xi);
            let jx = j00 * exi + j01 * eyi;
            let jy = j01 * exi + j11 * eyi;
            let dpu = c.fx * jx + c.sfx * jy;
            let dpv = c.fy * jy;
            dp2[i] = dpu * dpu + dpv * dpv;
            // Reference at the pixel (t = 0) and its gradient (central differences).
            let g0 = rv[i + 1] - phi[i];
            let gu = (rv[i + 2] - rv[i]) * 0.5;
            let gv = (dn[i + 1] - up[i + 1]) * 0.5;
            let gv = if vi == 0 { dn[i + 1] - rv[i + 1] } else { gv };
            let gv = if vi as i64 == rr.last_image_row { rv[i + 1] - up[i + 1] } else { gv };
            let s0 = gu * dpu + gv * dpv;
            g[0][i] = g0;
            sl[i] = s0;
            t[1][i] = clamp(-g0 / s0, lo, hi);
        }
    }

    // Fast path: E interpolated evaluations, secant steps in between.
    let mut kk = [0u32; LANES];
    let mut cc = [0u32; LANES];
    let mut fu = [0f32; LANES];
    let mut fv = [0f32; LANES];
    let mut okc = [false; LANES];
    let mut qa = [0f32; LANES];
    let mut qb = [0f32; LANES];
    let mut qc = [0f32; LANES];
    let mut qd = [0f32; LANES];
    for k in 1..=E {
        for i in 0..LANES {
            let (du, dv) = offset(&c, lane[i], t[k][i]);
            let (kr, col, f_u, f_v, ok) = cell(du, dv, u0 + i as f32, vf, &gr);
            kk[i] = small_int(kr);
            cc[i] = small_int(col);
            fu[i] = f_u;
            fv[i] = f_v;
            okc[i] = ok & active[i];
        }
        for i in 0..LANES {
            let [a_, b_, c_, d_] = load(rr, kk[i], cc[i], okc[i]);
            qa[i] = a_;
            qb[i] = b_;
            qc[i] = c_;
            qd[i] = d_;
        }
        for i in 0..LANES {
            let gk = interp([qa[i], qb[i], qc[i], qd[i]], fu[i], fv[i], phi[i]);
            g[k][i] = gk;
            let si = slope(sl[i], t[k - 1][i], g[k - 1][i], t[k][i], gk, dp2[i]);
            sl[i] = si;
            let tn = t[k][i] - gk / si;
            t[k + 1][i] = if k < E { clamp(tn, tlo[i], thi[i]) } else { tn };
        }
    }

    // Acceptance (vector).
    let mut tfin = [0f32; LANES];
    let mut ok = [false; LANES];
    {
        let la = ACCEPT_LAST_STEP_PX * ACCEPT_LAST_STEP_PX;
        let lb = ACCEPT_STEP_PRODUCT_PX2;
        for i in 0..LANES {
            let s1 = t[E + 1][i] - t[E][i];
            let s2 = t[E][i] - t[E - 1][i];
            let tf = t[E + 1][i];
            ok[i] = (s1 * s1 * dp2[i] <= la) & (fabs(s1 * s2) * dp2[i] <= lb) & (tf >= tlo[i]) & (tf <= thi[i]);
            tfin[i] = tf;
        }
    }

    // Fallback (scalar, rare).
    let bis = r.bisection_count();
    for i in 0..n {
        if !active[i] || ok[i] {
            continue;
        }
        let l = lane[i];
        let ui = u0 + i as f32;
        let eval = |tt: f32| sample(&c, rr, &gr, l, ui, vf, tt, phi[i]);
        // Stage 2: one more secant step from the last two points (slow convergence, far crossing).
        let (tp, gp, tc) = (t[E][i], g[E][i], t[E + 1][i]);
        if tc >= tlo[i] && tc <= thi[i] && gp.is_finite() {
            let gc = eval(tc);
            let sc = slope(sl[i], tp, gp, tc, gc, dp2[i]);
            let tn = tc - gc / sc;
            let (s1, s2) = (tn - tc, tc - tp);
            if (s1 * s1 * dp2[i] <= ACCEPT_LAST_STEP_PX * ACCEPT_LAST_STEP_PX)
                & (fabs(s1 * s2) * dp2[i] <= ACCEPT_STEP_PRODUCT_PX2)
                & (tn >= tlo[i])
                & (tn <= thi[i])
            {
                tfin[i] = tn;
                ok[i] = true;
                continue;
            }
        }
        FALLBACKS.fetch_add(1, core::sync::atomic::Ordering::Relaxed);
        let mut known = [(0f32, CANONICAL_NAN); E + 1];
        known[0] = if 0.0 >= tlo[i] && 0.0 <= thi[i] { (0.0, g[0][i]) } else { (0.0, CANONICAL_NAN) };
        for k in 1..=E {
            known[k] = (t[k][i], g[k][i]);
        }
        match fallback(eval, tlo[i], thi[i], &known, bis) {
            Ok(tt) => {
                tfin[i] = tt;
                ok[i] = true;
            }
            Err(code_) => {
                code[i] = code_ as u8;
            }
        }
    }

    // Triangulation (vector): eqs 16-18 in closed form, and the output.
    let mut xyz = [[0f32; 3]; LANES];
    let mut good = [false; LANES];
    for i in 0..LANES {
        let si = depth(&c, a[i], tfin[i]);
        let fine = ok[i] & active[i];
        let degenerate = !(fabs(si) < f32::INFINITY) | !(a[i] > 0.0);
        let inside = (si >= c.z_min) & (si <= c.z_max);
        let gd = fine & !degenerate & inside;
        good[i] = gd;
        code[i] = if !fine {
            code[i]
        } else if degenerate {
            Validity::Degenerate as u8
        } else if !inside {
            Validity::OutOfDepth as u8
        } else {
            Validity::Valid as u8
        };
        xyz[i] = if gd { [si * x[i], si * y[i], si] } else { [CANONICAL_NAN; 3] };
    }
    for (o, p) in out_xyz.chunks_exact_mut(3).zip(&xyz[..n]) {
        o.copy_from_slice(p);
    }
    out_validity[..n].copy_from_slice(&code[..n]);
    if let Some(cx) = crossings {
        for (i, o) in cx.chunks_exact_mut(2).enumerate().take(n) {
            if good[i] {
                o[0] = x[i] + tfin[i] * lane[i].ex;
                o[1] = y[i] + tfin[i] * lane[i].ey;
            } else {
                o[0] = CANONICAL_NAN;
                o[1] = CANONICAL_NAN;
            }
        }
    }
}

/// The bracketed search over `[tlo, thi]` for a pixel the fast path did not settle.
///
/// `known` are samples `(t, g)` already taken (NaN g where unusable). Returns the crossing `t`, or
/// the reason there is none.
fn fallback<F: Fn(f32) -> f32>(
    eval: F,
    tlo: f32,
    thi: f32,
    known: &[(f32, f32)],
    bisections: u32,
) -> Result<f32, Validity> {
    let glo = eval(tlo);
    let ghi = eval(thi);
    let (mut ta, mut ga, mut tb, mut gb);
    if glo.is_finite() && ghi.is_finite() {
        if (glo < 0.0) == (ghi < 0.0) {
            return Err(Validity::OutOfDepth);
        }
        (ta, ga, tb, gb) = (tlo, glo, thi, ghi);
    } else {
        // The closest pair of valid samples of opposite sign brackets the crossing.
        let mut cands = [(0f32, CANONICAL_NAN); 8];
        cands[0] = (tlo, glo);
        cands[1] = (thi, ghi);
        for (dst, src) in cands[2..].iter_mut().zip(known) {
            *dst = *src;
        }
        let mut best: Option<(f32, f32, f32, f32)> = None;
        let mut any = false;
        for &(t0, g0) in &cands {
            if !g0.is_finite() || !(t0 >= tlo && t0 <= thi) {
                continue;
            }
            any = true;
            if g0 >= 0.0 {
                continue;
            }
            for &(t1, g1) in &cands {
                if !(g1 >= 0.0) || !(t1 >= tlo && t1 <= thi) {
                    continue;
                }
                let better = match best {
                    None => true,
                    Some((bt0, _, bt1, _)) => fabs(t1 - t0) < fabs(bt1 - bt0),
                };
                if better {
                    best = Some((t0, g0, t1, g1));
                }
            }
        }
        match best {
            Some(b) => (ta, ga, tb, gb) = b,
            None => return Err(if any { Validity::NoCrossing } else { Validity::ReferenceInvalid }),
        }
    }
    // Orient so that ga < 0 ≤ gb.
    if ga >= 0.0 {
        core::mem::swap(&mut ta, &mut tb);
        core::mem::swap(&mut ga, &mut gb);
    }
    if !(ga < 0.0 && gb >= 0.0) {
        return Err(Validity::NoCrossing);
    }
    for _ in 0..bisections {
        let tm = 0.5 * (ta + tb);
        let gm = eval(tm);
        if !gm.is_finite() {
            return Err(Validity::ReferenceInvalid);
        }
        if gm < 0.0 {
            (ta, ga) = (tm, gm);
        } else {
            (tb, gb) = (tm, gm);
        }
    }
    let mut tm = ta;
    for _ in 0..2 {
        tm = ta - ga * (tb - ta) / (gb - ga);
        let gm = eval(tm);
        if !gm.is_finite() {
            return Err(Validity::ReferenceInvalid);
        }
        if gm < 0.0 {
            (ta, ga) = (tm, gm);
        } else {
            (tb, gb) = (tm, gm);
        }
    }
    if tm.is_finite() { Ok(tm) } else { Err(Validity::NoCrossing) }
}
