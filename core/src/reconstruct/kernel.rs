//! The per-pixel kernel of [`super`]: search for N_I and eqs 16-18, over chunks of [`LANES`]
//! pixels in structure-of-arrays form so that the arithmetic passes vectorize. Every lane runs
//! the same IEEE operations whatever the chunk, so results do not depend on how a row is cut.
//! Its pieces: the sample offsets ([`super::offset`]), cells and Newton steps
//! ([`super::cell`]), the band's rows ([`super::refrows`]), the fallback search
//! ([`super::fallback`]) and the gathers ([`super::gather`]).

use super::cell::{Grid, accept, cell, cell_slope, clamp, interp, sample, small_int};
use super::fallback::fallback;
use super::gather::CellGather;
use super::offset::{Lane, lane_coefficients, offset};
use super::reconstructor::Reconstructor;
use super::refrows::RefRows;
use super::setup::Consts;
use super::{LANES, MAX_BAND_ROWS, NEWTON_EVALS, input_code};
use crate::camera::MAX_ROW_KNOTS as MAX_KNOTS;
use crate::math::{CANONICAL_NAN, fabs};
use crate::validity::Validity;

/// Lanes of a chunk needing stage 2 from which it runs as a vector pass (below, per lane).
const STAGE2_VECTOR_MIN: u32 = 4;

/// Eq 16-18 in closed form: depth `s` of M along `(x, y, 1)` for the crossing at `t`.
#[inline(always)]
fn depth(c: &Consts, a: f32, t: f32) -> f32 {
    c.h_r * (1.0 - c.pz * t) / (a - (a * c.pz + c.h) * t)
}

/// Reconstruct the columns `cols.0..cols.1` of one row (see [`Reconstructor::reconstruct_row`]
/// and [`Reconstructor::reconstruct_span_gather`]); the slices hold those columns only, and the
/// caller checked their lengths and that the span starts a chunk and ends one or the row (so
/// every chunk is the whole row's).
/// Always inlined, like everything it calls on the fast path, so that a caller compiled with more
/// SIMD features (a host `#[target_feature(enable = "avx2")]` wrapper) vectorizes it wider; the
/// operations, and so the bits, are the same.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub(super) fn row<G: CellGather>(
    g: G,
    r: &Reconstructor,
    rr: &RefRows<'_>,
    v: u32,
    cols: (usize, usize),
    phase: &[f32],
    validity: &[u8],
    out_xyz: &mut [f32],
    out_validity: &mut [u8],
    mut crossings: Option<&mut [f32]>,
) {
    let (lo, hi) = cols;
    let mut kx = [0f32; MAX_KNOTS];
    let mut ky = [0f32; MAX_KNOTS];
    // The knots of the span's chunks only (the first at column `lo`, a chunk boundary).
    if hi <= lo {
        return;
    }
    let j0 = lo / LANES;
    let count = ((hi - 1) / LANES + 2 - j0).min(MAX_KNOTS);
    let (kxs, kys) = (&mut kx[..count], &mut ky[..count]);
    let nk = r.camera().row_knots_span_f32(v, j0, kxs, kys);
    let knots = (&kx[..nk], &ky[..nk], j0);
    // The chunks' per-pixel coefficients, set whole by every chunk's first pass (zeroed once per
    // row, not per chunk: 1.5 KiB).
    let mut lane = Lanes::zeroed();
    let mut c0 = lo;
    while c0 < hi {
        let n = (hi - c0).min(LANES);
        let (i0, i1) = (c0 - lo, c0 - lo + n);
        let cr = crossings
            .as_deref_mut()
            .and_then(|c| c.get_mut(2 * i0..2 * i1));
        // The caller checked the lengths: these are never `None` (and compile no panic path).
        let (Some(p), Some(q), Some(xyz), Some(out_q)) = (
            phase.get(i0..i1),
            validity.get(i0..i1),
            out_xyz.get_mut(3 * i0..3 * i1),
            out_validity.get_mut(i0..i1),
        ) else {
            return;
        };
        chunk(g, &mut lane, r, rr, knots, v, c0, p, q, xyz, out_q, cr);
        c0 += n;
    }
}

/// Structure-of-arrays per-pixel coefficients of a chunk.
struct Lanes {
    q1: [f32; LANES],
    q2: [f32; LANES],
    a: [f32; LANES],
    b: [f32; LANES],
    u1: [f32; LANES],
    u2: [f32; LANES],
    ux: [f32; LANES],
    ue: [f32; LANES],
    v1: [f32; LANES],
    v2: [f32; LANES],
    vy: [f32; LANES],
    ve: [f32; LANES],
}

impl Lanes {
    #[inline(always)]
    fn zeroed() -> Self {
        const Z: [f32; LANES] = [0.0; LANES];
        Lanes {
            q1: Z,
            q2: Z,
            a: Z,
            b: Z,
            u1: Z,
            u2: Z,
            ux: Z,
            ue: Z,
            v1: Z,
            v2: Z,
            vy: Z,
            ve: Z,
        }
    }

    #[inline(always)]
    fn get(&self, i: usize) -> Lane {
        Lane {
            q1: self.q1[i],
            q2: self.q2[i],
            a: self.a[i],
            b: self.b[i],
            u1: self.u1[i],
            u2: self.u2[i],
            ux: self.ux[i],
            ue: self.ue[i],
            v1: self.v1[i],
            v2: self.v2[i],
            vy: self.vy[i],
            ve: self.ve[i],
        }
    }

    #[inline(always)]
    fn set(&mut self, i: usize, l: Lane) {
        self.q1[i] = l.q1;
        self.q2[i] = l.q2;
        self.a[i] = l.a;
        self.b[i] = l.b;
        self.u1[i] = l.u1;
        self.u2[i] = l.u2;
        self.ux[i] = l.ux;
        self.ue[i] = l.ue;
        self.v1[i] = l.v1;
        self.v2[i] = l.v2;
        self.vy[i] = l.vy;
        self.ve[i] = l.ve;
    }
}

/// `0.0, 1.0, …` as f32: lane offsets without an integer conversion per lane (which does not
/// vectorize for `usize`).
const LANE_F: [f32; LANES] = {
    let mut a = [0f32; LANES];
    let mut i = 0;
    while i < LANES {
        a[i] = i as f32;
        i += 1;
    }
    a
};

/// Vector pass: sample offsets and cells for parameters `t`: the storage indices `ia`, `ib` of
/// the cell's left samples in its upper and lower rows, the fractions, and the offsets' rates of
/// change ([`offset`]). Lanes whose cell is unusable (outside the image or band, or not
/// `active`) get band row and column 0 (always loadable) and a NaN fraction, so their
/// interpolated value is NaN whatever is loaded.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn pass_cells(
    c: &Consts,
    l: &Lanes,
    t: &[f32; LANES],
    u0: f32,
    v: f32,
    gr: &Grid,
    rr: &RefRows<'_>,
    active: &[bool; LANES],
    ia: &mut [u32; LANES],
    ib: &mut [u32; LANES],
    fu: &mut [f32; LANES],
    fv: &mut [f32; LANES],
    rate: (&mut [f32; LANES], &mut [f32; LANES]),
) {
    let mut kk = [0u32; LANES];
    let mut cc = [0u32; LANES];
    for i in 0..LANES {
        let ((du, dv), (ru, rv)) = offset(c, l.get(i), t[i]);
        rate.0[i] = ru;
        rate.1[i] = rv;
        let (kr, col, f_u, f_v, o) = cell(du, dv, u0 + LANE_F[i], v, gr);
        let o = o & active[i];
        kk[i] = if o { small_int(kr) } else { 0 };
        cc[i] = if o { small_int(col) } else { 0 };
        fu[i] = if o { f_u } else { CANONICAL_NAN };
        fv[i] = f_v;
    }
    // Indices clamped into the storage, so that the loads need no early exit (the clamps never
    // bind for a usable lane, whose band row and column were checked).
    let last = u32::try_from(rr.data.len().saturating_sub(2)).unwrap_or(u32::MAX);
    if let Some(a) = rr.affine {
        for i in 0..LANES {
            ia[i] = a.offset(kk[i]).wrapping_add(cc[i]).min(last);
            ib[i] = a.offset(kk[i] + 1).wrapping_add(cc[i]).min(last);
        }
    } else {
        for i in 0..LANES {
            let k = (kk[i] as usize).min(MAX_BAND_ROWS - 2);
            ia[i] = rr.offs[k].wrapping_add(cc[i]).min(last);
            ib[i] = rr.offs[k + 1].wrapping_add(cc[i]).min(last);
        }
    }
}

/// Vector pass: interpolate the loaded cells, then the Newton update `t_next` with the slope of
/// the interpolant there ([`cell_slope`]; `rate` from [`pass_cells`]).
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn pass_update(
    q: [&[f32; LANES]; 4],
    fu: &[f32; LANES],
    fv: &[f32; LANES],
    rate: (&[f32; LANES], &[f32; LANES]),
    phi: &[f32; LANES],
    t_cur: &[f32; LANES],
    bounds: (&[f32; LANES], &[f32; LANES], bool),
    g_cur: &mut [f32; LANES],
    t_next: &mut [f32; LANES],
) {
    let (tlo, thi, clamped) = bounds;
    for i in 0..LANES {
        let q4 = [q[0][i], q[1][i], q[2][i], q[3][i]];
        let gk = interp(q4, fu[i], fv[i], phi[i]);
        g_cur[i] = gk;
        let si = cell_slope(q4, fu[i], fv[i], rate.0[i], rate.1[i]);
        let tn = t_cur[i] - gk / si;
        t_next[i] = if clamped {
            clamp(tn, tlo[i], thi[i])
        } else {
            tn
        };
    }
}

/// A window of `LANES + 2` samples of row `row` around columns `c0 − 1 ..= c0 + LANES`, linearly
/// extrapolated one column past each image edge (so a central difference there is one-sided); NaN
/// further out or where the row is missing.
#[inline(always)]
fn window(row: &[f32], c0: usize, w: usize) -> [f32; LANES + 2] {
    let mut out = [CANONICAL_NAN; LANES + 2];
    if c0 >= 1
        && c0 + LANES < w
        && let Some(src) = row.get(c0 - 1..c0 + LANES + 1)
    {
        out.copy_from_slice(src);
        return out;
    }
    // At an image edge (window index j holds column c0 + j − 1): the columns that exist, copied
    // as one range, then the extrapolated column −1 or w where the window reaches it.
    let at = |k: usize| row.get(k).copied().unwrap_or(CANONICAL_NAN);
    copy_columns(&mut out, row, c0, 1, w);
    if c0 == 0 {
        out[0] = 2.0 * at(0) - at(1);
    }
    if w >= 2
        && let Some(o) = out.get_mut((w + 1).wrapping_sub(c0))
    {
        *o = 2.0 * at(w - 1) - at(w - 2);
    }
    out
}

/// Half-width (columns) of the central difference giving the reference phase's slope along
/// the row at the pixel, for the first step (a power of two, so the scale is exact).
const SLOPE_SPAN: usize = 8;

/// The samples of row `row` at columns `c0 − SLOPE_SPAN ..= c0 + LANES − 1 + SLOPE_SPAN`, NaN
/// outside the image or where the row is missing.
#[inline(always)]
fn window_wide(row: &[f32], c0: usize, w: usize) -> [f32; LANES + 2 * SLOPE_SPAN] {
    let mut out = [CANONICAL_NAN; LANES + 2 * SLOPE_SPAN];
    if c0 >= SLOPE_SPAN
        && c0 + LANES + SLOPE_SPAN <= w
        && let Some(src) = row.get(c0 - SLOPE_SPAN..c0 + LANES + SLOPE_SPAN)
    {
        out.copy_from_slice(src);
        return out;
    }
    // At an image edge: the columns that exist.
    copy_columns(&mut out, row, c0, SLOPE_SPAN, w);
    out
}

/// Copy into `out` (index j holds column `c0 + j − span`) the columns of `row` that exist: at
/// or right of column 0, left of the width `w` and inside `row`, as one range; the rest of `out`
/// is left as it is.
#[inline(always)]
fn copy_columns(out: &mut [f32], row: &[f32], c0: usize, span: usize, w: usize) {
    let first = c0.saturating_sub(span);
    let end = (c0 + out.len()).saturating_sub(span).min(w).min(row.len());
    if first < end {
        let j0 = first + span - c0;
        if let (Some(dst), Some(src)) = (out.get_mut(j0..j0 + (end - first)), row.get(first..end)) {
            dst.copy_from_slice(src);
        }
    }
}

#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn chunk<G: CellGather>(
    g: G,
    lane: &mut Lanes,
    r: &Reconstructor,
    rr: &RefRows<'_>,
    knots: (&[f32], &[f32], usize),
    v: u32,
    c0: usize,
    phase: &[f32],
    validity: &[u8],
    out_xyz: &mut [f32],
    out_validity: &mut [u8],
    crossings: Option<&mut [f32]>,
) {
    let c = *r.consts();
    let n = phase.len().min(LANES);
    // The reference is read in map coordinates: image pixel (u, v) is map sample
    // (u + left, v + top) ([`super::Margin`]; without a margin, the same numbers).
    let m = r.margin();
    let wu = r.map_width();
    let gr = Grid {
        w: wu as f32,
        last_row: rr.last_row as f32,
        first: rr.first as f32,
        band_len: rr.len as f32,
    };
    let vi = (v + m.top) as i32;
    let vf = vi as f32;
    let cm = c0 + m.left as usize;
    let um = cm as f32;

    // Input validity: a pixel is active when marked Valid with a finite phase; other known codes
    // are kept, anything else becomes PhaseOutOfRange.
    let mut phi = [0f32; LANES];
    let mut active = [false; LANES];
    let mut code = [Validity::PhaseOutOfRange as u8; LANES];
    for ((((p_, a_), c_), &q), &p) in phi
        .iter_mut()
        .zip(&mut active)
        .zip(&mut code)
        .zip(validity)
        .zip(phase)
    {
        let (act, code_in) = input_code(q, p);
        *a_ = act;
        *p_ = if act { p } else { 0.0 };
        *c_ = code_in;
    }

    // A chunk with no pixel to search (masked by a compiled row, or all invalid) keeps its codes:
    // the passes below would give every lane a NaN point and its input code anyway.
    if !active.iter().any(|a| *a) {
        for o in out_xyz.iter_mut().take(3 * n) {
            *o = CANONICAL_NAN;
        }
        out_validity[..n].copy_from_slice(&code[..n]);
        if let Some(cx) = crossings {
            for o in cx.iter_mut().take(2 * n) {
                *o = CANONICAL_NAN;
            }
        }
        return;
    }

    let mut x = [0f32; LANES];
    let mut y = [0f32; LANES];
    let kn = c0 / LANES - knots.2;
    let knot = |j: usize| match (knots.0.get(j), knots.1.get(j)) {
        (Some(&a), Some(&b)) => Some([a, b]),
        _ => None,
    };
    let ka = knot(kn);
    let (ka, kb) = (
        ka.unwrap_or([CANONICAL_NAN; 2]),
        knot(kn + 1).or(ka).unwrap_or([CANONICAL_NAN; 2]),
    );
    r.camera()
        .undistort_span_from_knots_f32(v, c0, ka, kb, &mut x, &mut y);

    // Pass 1 (vector): per-pixel geometry, the sample at the pixel itself, the slope there, and
    // the first step.
    let rv = window(rr.get(vi as i64), cm, wu);
    let rw = window_wide(rr.get(vi as i64), cm, wu);
    let up = if vi == 0 {
        [CANONICAL_NAN; LANES + 2]
    } else {
        window(rr.get(vi as i64 - 1), cm, wu)
    };
    let dn = if vi as i64 == rr.last_row {
        [CANONICAL_NAN; LANES + 2]
    } else {
        window(rr.get(vi as i64 + 1), cm, wu)
    };
    let mut a = [0f32; LANES];
    let mut ex = [0f32; LANES];
    let mut ey = [0f32; LANES];
    let mut tlo = [0f32; LANES];
    let mut thi = [0f32; LANES];
    let mut dp2 = [0f32; LANES];
    let mut t1 = [0f32; LANES];
    let mut g0 = [0f32; LANES];
    {
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
            ex[i] = exi;
            ey[i] = eyi;
            // The offset polynomial, and its derivative at the pixel: pixels per unit t.
            let (l, dpu, dpv) = lane_coefficients(&c, xi, yi, exi, eyi);
            lane.set(i, l);
            dp2[i] = dpu * dpu + dpv * dpv;
            // Reference at the pixel (t = 0) and its gradient (central differences).
            let g0_ = rv[i + 1] - phi[i];
            // Along the row over ±SLOPE_SPAN columns where those samples exist (less noise in
            // the first step), else over ±1.
            let gw = (rw[i + 2 * SLOPE_SPAN] - rw[i]) * (0.5 / SLOPE_SPAN as f32);
            let gu = if fabs(gw) < f32::INFINITY {
                gw
            } else {
                (rv[i + 2] - rv[i]) * 0.5
            };
            let gv = (dn[i + 1] - up[i + 1]) * 0.5;
            let gv = if vi == 0 { dn[i + 1] - rv[i + 1] } else { gv };
            let gv = if vi as i64 == rr.last_row {
                rv[i + 1] - up[i + 1]
            } else {
                gv
            };
            let s0 = gu * dpu + gv * dpv;
            g0[i] = g0_;
            t1[i] = clamp(-g0_ / s0, lo, hi);
        }
    }

    // Fast path: two interpolated evaluations, each followed by a Newton step (NEWTON_EVALS = 2;
    // distinct arrays per step so that the passes vectorize).
    const _: () = assert!(NEWTON_EVALS == 2);
    let mut ia = [0u32; LANES];
    let mut ib = [0u32; LANES];
    let mut ru = [0f32; LANES];
    let mut rv = [0f32; LANES];
    let mut fu = [0f32; LANES];
    let mut fv = [0f32; LANES];
    let mut qa = [0f32; LANES];
    let mut qb = [0f32; LANES];
    let mut qc = [0f32; LANES];
    let mut qd = [0f32; LANES];
    let mut g1 = [0f32; LANES];
    let mut g2 = [0f32; LANES];
    let mut t2 = [0f32; LANES];
    let mut t3 = [0f32; LANES];
    pass_cells(
        &c,
        lane,
        &t1,
        um,
        vf,
        &gr,
        rr,
        &active,
        &mut ia,
        &mut ib,
        &mut fu,
        &mut fv,
        (&mut ru, &mut rv),
    );
    g.gather(rr.data, &ia, &ib, [&mut qa, &mut qb, &mut qc, &mut qd]);
    pass_update(
        [&qa, &qb, &qc, &qd],
        &fu,
        &fv,
        (&ru, &rv),
        &phi,
        &t1,
        (&tlo, &thi, true),
        &mut g1,
        &mut t2,
    );
    pass_cells(
        &c,
        lane,
        &t2,
        um,
        vf,
        &gr,
        rr,
        &active,
        &mut ia,
        &mut ib,
        &mut fu,
        &mut fv,
        (&mut ru, &mut rv),
    );
    g.gather(rr.data, &ia, &ib, [&mut qa, &mut qb, &mut qc, &mut qd]);
    pass_update(
        [&qa, &qb, &qc, &qd],
        &fu,
        &fv,
        (&ru, &rv),
        &phi,
        &t2,
        (&tlo, &thi, false),
        &mut g2,
        &mut t3,
    );

    // Acceptance (vector).
    let mut tfin = [0f32; LANES];
    let mut ok = [false; LANES];
    for i in 0..LANES {
        ok[i] = accept(t3[i], t2[i], dp2[i], tlo[i], thi[i]);
        tfin[i] = t3[i];
    }

    // Stage 2, for lanes the fast path did not settle whose last point is usable (slow
    // convergence, far crossing): one more evaluation and Newton step. A vector pass over the
    // chunk when enough lanes need it, else per lane in the scalar loop below: the same operations
    // either way, so the same bits.
    let mut st2 = [false; LANES];
    let mut n2 = 0u32;
    for i in 0..LANES {
        let s2 = active[i]
            & !ok[i]
            & (t3[i] >= tlo[i])
            & (t3[i] <= thi[i])
            & (fabs(g2[i]) < f32::INFINITY);
        st2[i] = s2;
        n2 += s2 as u32;
    }
    let vector2 = n2 >= STAGE2_VECTOR_MIN;
    if vector2 {
        let mut g3 = [0f32; LANES];
        let mut t4 = [0f32; LANES];
        pass_cells(
            &c,
            lane,
            &t3,
            um,
            vf,
            &gr,
            rr,
            &st2,
            &mut ia,
            &mut ib,
            &mut fu,
            &mut fv,
            (&mut ru, &mut rv),
        );
        g.gather(rr.data, &ia, &ib, [&mut qa, &mut qb, &mut qc, &mut qd]);
        pass_update(
            [&qa, &qb, &qc, &qd],
            &fu,
            &fv,
            (&ru, &rv),
            &phi,
            &t3,
            (&tlo, &thi, false),
            &mut g3,
            &mut t4,
        );
        for i in 0..LANES {
            let acc = st2[i] & accept(t4[i], t3[i], dp2[i], tlo[i], thi[i]);
            tfin[i] = if acc { t4[i] } else { tfin[i] };
            ok[i] |= acc;
        }
    }

    // Fallback (scalar, rare): skipped when no lane needs it. Its first two evaluations, at the
    // ends of the depth interval, run as two vector passes when enough lanes need them (same
    // operations, same bits).
    let mut fb = [false; LANES];
    let mut nf = 0u32;
    for i in 0..LANES {
        fb[i] = active[i] & !ok[i];
        nf += fb[i] as u32;
    }
    let need = nf > 0;
    let vector_ends = nf >= STAGE2_VECTOR_MIN;
    let mut g_lo = [0f32; LANES];
    let mut g_hi = [0f32; LANES];
    if vector_ends {
        for (tt, gg) in [(&tlo, &mut g_lo), (&thi, &mut g_hi)] {
            pass_cells(
                &c,
                lane,
                tt,
                um,
                vf,
                &gr,
                rr,
                &fb,
                &mut ia,
                &mut ib,
                &mut fu,
                &mut fv,
                (&mut ru, &mut rv),
            );
            g.gather(rr.data, &ia, &ib, [&mut qa, &mut qb, &mut qc, &mut qd]);
            for i in 0..LANES {
                gg[i] = interp([qa[i], qb[i], qc[i], qd[i]], fu[i], fv[i], phi[i]);
            }
        }
    }
    let bis = r.bisection_count();
    for i in 0..if need { n } else { 0 } {
        if !active[i] || ok[i] {
            continue;
        }
        let l = lane.get(i);
        let ui = um + LANE_F[i];
        let phi_i = phi[i];
        let eval = |tt: f32| sample(&c, rr, &gr, l, ui, vf, tt, phi_i).0;
        if !vector2 && st2[i] {
            let tc = t3[i];
            let (gc, sc) = sample(&c, rr, &gr, l, ui, vf, tc, phi[i]);
            let tn = tc - gc / sc;
            if accept(tn, tc, dp2[i], tlo[i], thi[i]) {
                tfin[i] = tn;
                ok[i] = true;
                continue;
            }
        }
        let at_pixel = if (tlo[i]..=thi[i]).contains(&0.0) {
            g0[i]
        } else {
            CANONICAL_NAN
        };
        let known = [
            (0.0, at_pixel),
            (t1[i], g1[i]),
            (t2[i], g2[i]),
            (t3[i], CANONICAL_NAN),
        ];
        let ends = if vector_ends {
            (g_lo[i], g_hi[i])
        } else {
            (eval(tlo[i]), eval(thi[i]))
        };
        match fallback(eval, tlo[i], thi[i], ends, &known, bis) {
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
        xyz[i] = if gd {
            [si * x[i], si * y[i], si]
        } else {
            [CANONICAL_NAN; 3]
        };
    }
    for (o, p) in out_xyz.chunks_exact_mut(3).zip(&xyz[..n]) {
        o.copy_from_slice(p);
    }
    out_validity[..n].copy_from_slice(&code[..n]);
    if let Some(cx) = crossings {
        for (i, o) in cx.chunks_exact_mut(2).enumerate().take(n) {
            if good[i] {
                o[0] = x[i] + tfin[i] * ex[i];
                o[1] = y[i] + tfin[i] * ey[i];
            } else {
                o[0] = CANONICAL_NAN;
                o[1] = CANONICAL_NAN;
            }
        }
    }
}
