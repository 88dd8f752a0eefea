//! The pixel offset of a sample along the search line (lens distortion, eqs 3-4, in difference
//! form): per-pixel coefficients computed once ([`lane_coefficients`]), then a polynomial in the
//! line parameter `t` that keeps f32 precision relative to the offset ([`offset`]).

use super::setup::Consts;

/// Per-pixel coefficients of one lane: the sample offset as a polynomial in `t` (see [`offset`]).
#[derive(Clone, Copy)]
pub(super) struct Lane {
    pub(super) q1: f32,
    pub(super) q2: f32,
    pub(super) a: f32,
    pub(super) b: f32,
    pub(super) u1: f32,
    pub(super) u2: f32,
    pub(super) ux: f32,
    pub(super) ue: f32,
    pub(super) v1: f32,
    pub(super) v2: f32,
    pub(super) vy: f32,
    pub(super) ve: f32,
}

/// The per-pixel coefficients of [`offset`] for ideal coordinates `(x, y)` and epipolar direction
/// `(ex, ey)`, and the pixel offset per unit `t` at `t = 0` (the Jacobian of eqs 3-4 applied to
/// `e`).
#[inline(always)]
pub(super) fn lane_coefficients(c: &Consts, x: f32, y: f32, ex: f32, ey: f32) -> (Lane, f32, f32) {
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
pub(super) fn offset(c: &Consts, l: Lane, t: f32) -> ((f32, f32), (f32, f32)) {
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
}
