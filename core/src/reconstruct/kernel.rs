//! The per-pixel kernel of [`super`]: search for N_I and eqs 16-18, over chunks of [`LANES`]
//! pixels in structure-of-arrays form so that the arithmetic passes vectorize. Every lane runs
//! the same IEEE operations whatever the chunk, so results do not depend on how a row is cut.

use super::gather::CellGather;
use super::{ACCEPT_LAST_STEP_PX, Consts, NEWTON_EVALS, Reconstructor};
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
    /// The offsets as a formula, when they follow one (always for [`super::ReferenceMap`] and
    /// [`super::ReferenceRing`]): the sample indices are then computed in the vector passes.
    affine: Option<Affine>,
}

/// Band row offsets `base + k·stride`, minus `wrap` from band row `split` on (a ring's wrap).
#[derive(Clone, Copy)]
struct Affine {
    base: u32,
    stride: u32,
    split: u32,
    wrap: u32,
}

impl Affine {
    #[inline(always)]
    fn offset(&self, k: u32) -> u32 {
        let o = self.base.wrapping_add(k.wrapping_mul(self.stride));
        if k >= self.split {
            o.wrapping_sub(self.wrap)
        } else {
            o
        }
    }
}

impl<'a> RefRows<'a> {
    pub(crate) fn new(data: &'a [f32], first: i64, last_image_row: i64) -> Self {
        RefRows {
            data,
            offs: [u32::MAX; MAX_BAND_ROWS],
            first,
            last_image_row,
            len: 0,
            affine: None,
        }
    }

    pub(crate) fn set(&mut self, k: usize, offset: usize) {
        if let Some(s) = self.offs.get_mut(k) {
            *s = u32::try_from(offset).unwrap_or(u32::MAX);
            self.len = self.len.max(k + 1);
        }
    }

    /// After every row is set: find the affine form of the offsets (rows `stride` samples apart,
    /// with at most one wrap), if they have one and the storage is indexable in u32.
    pub(crate) fn finish(&mut self, stride: usize) {
        self.affine = None;
        let (Ok(stride), Ok(_)) = (u32::try_from(stride), u32::try_from(self.data.len())) else {
            return;
        };
        let offs = &self.offs[..self.len.min(MAX_BAND_ROWS)];
        let Some(&base) = offs.first() else {
            return;
        };
        let split = offs
            .windows(2)
            .position(|w| w[1] < w[0])
            .map_or(u32::MAX, |p| p as u32 + 1);
        let wrap = match offs.get(split as usize) {
            Some(&o) => base
                .wrapping_add(split.wrapping_mul(stride))
                .wrapping_sub(o),
            None => 0,
        };
        let a = Affine {
            base,
            stride,
            split,
            wrap,
        };
        if offs
            .iter()
            .enumerate()
            .all(|(k, &o)| o != u32::MAX && a.offset(k as u32) == o)
        {
            self.affine = Some(a);
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

/// One full sample (scalar): offset → cell → loads → interpolation, and the Newton slope there
/// ([`cell_slope`]).
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn sample(
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

/// Per-pixel coefficients of one lane: the sample offset as a polynomial in `t` (see [`offset`]).
#[derive(Clone, Copy)]
struct Lane {
    q1: f32,
    q2: f32,
    a: f32,
    b: f32,
    u1: f32,
    u2: f32,
    ux: f32,
    ue: f32,
    v1: f32,
    v2: f32,
    vy: f32,
    ve: f32,
}

/// The per-pixel coefficients of [`offset`] for ideal coordinates `(x, y)` and epipolar direction
/// `(ex, ey)`, and the pixel offset per unit `t` at `t = 0` (the Jacobian of eqs 3-4 applied to
/// `e`).
#[inline(always)]
fn lane_coefficients(c: &Consts, x: f32, y: f32, ex: f32, ey: f32) -> (Lane, f32, f32) {
    let [k1, k2, p1, p2, k3] = c.k;
    let r2 = x * x + y * y;
    let rad = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3));
    let q1 = 2.0 * (x * ex + y * ey);
    let q2 = ex * ex + ey * ey;
    let a = k1 + r2 * (2.0 * k2 + r2 * (3.0 * k3));
    let b = k2 + 3.0 * k3 * r2;
    let pxy1 = x * ey + y * ex;
    let pxy2 = ex * ey;
    let tx1 = 2.0 * p1 * pxy1 + p2 * (q1 + 4.0 * x * ex);
    let tx2 = 2.0 * p1 * pxy2 + p2 * (q2 + 2.0 * ex * ex);
    let ty1 = p1 * (q1 + 4.0 * y * ey) + 2.0 * p2 * pxy1;
    let ty2 = p1 * (q2 + 2.0 * ey * ey) + 2.0 * p2 * pxy2;
    let cx1 = ex * rad + tx1;
    let cy1 = ey * rad + ty1;
    let l = Lane {
        q1,
        q2,
        a,
        b,
        u1: c.fx * cx1 + c.sfx * cy1,
        u2: c.fx * tx2 + c.sfx * ty2,
        ux: c.fx * x + c.sfx * y,
        ue: c.fx * ex + c.sfx * ey,
        v1: c.fy * cy1,
        v2: c.fy * ty2,
        vy: c.fy * y,
        ve: c.fy * ey,
    };
    let qa = q1 * a;
    (l, l.u1 + qa * l.ux, l.v1 + qa * l.vy)
}

/// Pixel offset `A·(D(m + t·e) − D(m))` of the sample at parameter `t` (eqs 3-4 in difference
/// form, as a polynomial in `t` with per-pixel coefficients, so every term is proportional to the
/// offset and keeps f32 precision relative to it, not to the absolute pixel position). With
/// `q = |m + t·e|² − |m|² = t·(q1 + t·q2)`, the radial factor changes by
/// `Δρ = q·(a + q·(b + k3·q))` and the distorted point by `t·e·ρ + Δρ·(m + t·e)` plus the
/// tangential change `t·(T1 + t·T2)`; `A` (eq 4) is folded into the coefficients.
///
/// Returns the offset `(du, dv)` and its derivative in `t` `(ru, rv)` (pixels per unit `t` along
/// the search line, the rate of the Newton slope, [`cell_slope`]); they share `q` and `Δρ`.
#[inline(always)]
fn offset(c: &Consts, l: Lane, t: f32) -> ((f32, f32), (f32, f32)) {
    let q = t * (l.q1 + t * l.q2);
    let drad = q * (l.a + q * (l.b + c.k[4] * q));
    let du = t * (l.u1 + t * l.u2) + drad * (l.ux + t * l.ue);
    let dv = t * (l.v1 + t * l.v2) + drad * (l.vy + t * l.ve);
    let dq = l.q1 + 2.0 * t * l.q2;
    let ddrad = (l.a + q * (2.0 * l.b + 3.0 * c.k[4] * q)) * dq;
    let ru = (l.u1 + 2.0 * t * l.u2) + ddrad * (l.ux + t * l.ue) + drad * l.ue;
    let rv = (l.v1 + 2.0 * t * l.v2) + ddrad * (l.vy + t * l.ve) + drad * l.ve;
    ((du, dv), (ru, rv))
}

/// The slope in `t` of the bilinear interpolant of cell `q` at `(fu, fv)` for the sample moving
/// at `(ru, rv)` pixels per unit `t`: the Newton slope. No fallback: where it is zero or not
/// finite (a flat cell, a NaN sample) the step it gives is infinite or NaN, which no acceptance
/// passes (a first step is clamped to the depth interval and evaluated again).
#[inline(always)]
fn cell_slope(q: [f32; 4], fu: f32, fv: f32, ru: f32, rv: f32) -> f32 {
    let [a, b, c1, d] = q;
    let dab = b - a;
    let twist = (d - c1) - dab;
    let gu = dab + fv * twist;
    let gv = (c1 - a) + fu * twist;
    gu * ru + gv * rv
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

/// Acceptance of the Newton answer `tn` reached by the step from `tc` (in t; `dp2` squared
/// pixels per unit t): the step is below [`ACCEPT_LAST_STEP_PX`] and `tn` lies in the depth
/// interval `[lo, hi]`. The step is `g(tc)` (sampled) over the interpolant's slope at `tc`, so
/// it is exact to the crossing within `tc`'s cell (up to the small twist term); where the
/// crossing lies in the next cell, `tn` errs by the step times the slope's relative change
/// between the two cells.
#[inline(always)]
fn accept(tn: f32, tc: f32, dp2: f32, lo: f32, hi: f32) -> bool {
    let s1 = tn - tc;
    (s1 * s1 * dp2 <= ACCEPT_LAST_STEP_PX * ACCEPT_LAST_STEP_PX) & (tn >= lo) & (tn <= hi)
}

/// Lanes of a chunk needing stage 2 from which it runs as a vector pass (below, per lane).
const STAGE2_VECTOR_MIN: u32 = 4;

/// Eq 16-18 in closed form: depth `s` of M along `(x, y, 1)` for the crossing at `t`.
#[inline(always)]
fn depth(c: &Consts, a: f32, t: f32) -> f32 {
    c.h_r * (1.0 - c.pz * t) / (a - (a * c.pz + c.h) * t)
}

/// Reconstruct one row (see [`Reconstructor::reconstruct_row`]); lengths are checked by the caller.
/// Always inlined, like everything it calls on the fast path, so that a caller compiled with more
/// SIMD features (a host `#[target_feature(enable = "avx2")]` wrapper) vectorizes it wider; the
/// operations, and so the bits, are the same.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub(crate) fn row<G: CellGather>(
    g: G,
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
    // The chunks' per-pixel coefficients, set whole by every chunk's first pass (zeroed once per
    // row, not per chunk: 1.5 KiB).
    let mut lane = Lanes::zeroed();
    let mut c0 = 0;
    while c0 < w {
        let n = (w - c0).min(LANES);
        let cr = crossings
            .as_deref_mut()
            .and_then(|c| c.get_mut(2 * c0..2 * (c0 + n)));
        chunk(
            g,
            &mut lane,
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
    knots: (&[f32], &[f32]),
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
    let (ka, kb) = (
        ka.unwrap_or([CANONICAL_NAN; 2]),
        knot(kn + 1).or(ka).unwrap_or([CANONICAL_NAN; 2]),
    );
    r.camera()
        .undistort_span_from_knots_f32(v, c0, ka, kb, &mut x, &mut y);

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
        let act = (q == Validity::Valid as u8) & (fabs(p) < f32::INFINITY);
        let keep = act | (((q as usize) < Validity::ALL.len()) & (q != Validity::Valid as u8));
        *a_ = act;
        *p_ = if act { p } else { 0.0 };
        *c_ = if keep {
            q
        } else {
            Validity::PhaseOutOfRange as u8
        };
    }

    // Pass 1 (vector): per-pixel geometry, the sample at the pixel itself, the slope there, and
    // the first step.
    let rv = window(rr.get(vi as i64), c0, wu);
    let rw = window_wide(rr.get(vi as i64), c0, wu);
    let up = if vi == 0 {
        [CANONICAL_NAN; LANES + 2]
    } else {
        window(rr.get(vi as i64 - 1), c0, wu)
    };
    let dn = if vi as i64 == rr.last_image_row {
        [CANONICAL_NAN; LANES + 2]
    } else {
        window(rr.get(vi as i64 + 1), c0, wu)
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
            let gv = if vi as i64 == rr.last_image_row {
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
        u0,
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
        u0,
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
            u0,
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
                u0,
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
        let ui = u0 + LANE_F[i];
        let eval = |tt: f32| sample(&c, rr, &gr, l, ui, vf, tt, phi[i]).0;
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

/// The bracketed search over `[tlo, thi]` for a pixel the fast path did not settle.
///
/// `ends` are the samples at `tlo` and `thi`, `known` other samples `(t, g)` already taken (NaN g
/// where unusable). Returns the crossing `t`, or the reason there is none.
fn fallback<F: Fn(f32) -> f32>(
    eval: F,
    tlo: f32,
    thi: f32,
    ends: (f32, f32),
    known: &[(f32, f32)],
    bisections: u32,
) -> Result<f32, Validity> {
    let (glo, ghi) = ends;
    let (mut ta, mut ga, mut tb, mut gb);
    if glo.is_finite() && ghi.is_finite() {
        if (glo < 0.0) == (ghi < 0.0) {
            return Err(Validity::OutOfDepth);
        }
        (ta, ga, tb, gb) = (tlo, glo, thi, ghi);
    } else {
        // With a monotonic phase, the valid samples below the phase lie on one side of those at or
        // above it: the innermost pair brackets the crossing.
        let mut cands = [(0f32, CANONICAL_NAN); 8];
        cands[0] = (tlo, glo);
        cands[1] = (thi, ghi);
        for (dst, src) in cands[2..].iter_mut().zip(known) {
            *dst = *src;
        }
        let (mut neg_lo, mut neg_hi) = ((f32::INFINITY, 0f32), (f32::NEG_INFINITY, 0f32));
        let (mut pos_lo, mut pos_hi) = ((f32::INFINITY, 0f32), (f32::NEG_INFINITY, 0f32));
        let mut any = false;
        for &(tc, gc) in &cands {
            if !gc.is_finite() || !(tlo..=thi).contains(&tc) {
                continue;
            }
            any = true;
            let (lo, hi) = if gc < 0.0 {
                (&mut neg_lo, &mut neg_hi)
            } else {
                (&mut pos_lo, &mut pos_hi)
            };
            if tc < lo.0 {
                *lo = (tc, gc);
            }
            if tc > hi.0 {
                *hi = (tc, gc);
            }
        }
        let have = neg_lo.0.is_finite() && pos_lo.0.is_finite();
        if !have {
            return Err(if any {
                Validity::NoCrossing
            } else {
                Validity::ReferenceInvalid
            });
        }
        if neg_hi.0 < pos_lo.0 {
            (ta, ga, tb, gb) = (neg_hi.0, neg_hi.1, pos_lo.0, pos_lo.1);
        } else if pos_hi.0 < neg_lo.0 {
            (ta, ga, tb, gb) = (neg_lo.0, neg_lo.1, pos_hi.0, pos_hi.1);
        } else {
            return Err(Validity::NoCrossing); // not monotonic along the segment
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
    if tm.is_finite() {
        Ok(tm)
    } else {
        Err(Validity::NoCrossing)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The Brown model in f64, written out independently: the pixel offset of `m + t·e` from `m`.
    fn brown_offset(c: &Consts, (x, y): (f64, f64), (ex, ey): (f64, f64), t: f64) -> (f64, f64) {
        let [k1, k2, p1, p2, k3] = c.k.map(f64::from);
        let d = |x: f64, y: f64| {
            let r2 = x * x + y * y;
            let rad = 1.0 + k1 * r2 + k2 * r2 * r2 + k3 * r2 * r2 * r2;
            let xd = x * rad + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x);
            let yd = y * rad + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y;
            (
                f64::from(c.fx) * xd + f64::from(c.sfx) * yd,
                f64::from(c.fy) * yd,
            )
        };
        let (u0, v0) = d(x, y);
        let (u1, v1) = d(x + t * ex, y + t * ey);
        (u1 - u0, v1 - v0)
    }

    fn consts() -> Consts {
        Consts {
            nx: 0.0,
            ny: 0.0,
            nz: 1.0,
            h_r: 700.0,
            h: 700.0,
            px: 200.0,
            py: -10.0,
            pz: 5.0,
            z_min: 575.0,
            z_max: 825.0,
            fx: 1500.0,
            fy: 1498.0,
            sfx: 0.8,
            k: [-0.12, 0.05, 1e-3, -8e-4, 0.01],
        }
    }

    #[test]
    fn offset_rate_is_the_derivative_of_the_distortion() {
        let c = consts();
        let mut worst = 0f64;
        for &(x, y) in &[(0.0, 0.0), (0.4, -0.3), (-0.42, 0.35), (0.1, 0.33)] {
            for &(ex, ey) in &[(0.3, -0.01), (0.28, 0.05), (0.02, 0.3)] {
                let (l, _, _) = lane_coefficients(&c, x as f32, y as f32, ex as f32, ey as f32);
                for i in -8..=8 {
                    let t = 0.02 * f64::from(i);
                    let (_, (ru, rv)) = offset(&c, l, t as f32);
                    let h = 1e-6;
                    let (a, b) = (
                        brown_offset(&c, (x, y), (ex, ey), t + h),
                        brown_offset(&c, (x, y), (ex, ey), t - h),
                    );
                    let (wu, wv) = ((a.0 - b.0) / (2.0 * h), (a.1 - b.1) / (2.0 * h));
                    let scale = libm::hypot(wu, wv);
                    worst = worst.max(libm::hypot(f64::from(ru) - wu, f64::from(rv) - wv) / scale);
                }
            }
        }
        // f32 coefficients: a few ulp of the rate, not a wrong term (a missing one is ≥ 1e-3).
        assert!(worst < 2e-5, "relative error of the offset rate {worst:e}");
    }

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
