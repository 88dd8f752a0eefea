//! The free-form surface: a height field of Gaussian bumps over a posed rectangle, intersected by
//! Lipschitz-safe ray marching and refined by safeguarded Newton/bisection.
//!
//! Along a ray `o + t·d` (local frame) the height of bump i is a 1-D Gaussian in t, because the
//! squared in-plane distance to the bump centre is a quadratic in t. The marcher uses that to drop
//! bumps that cannot matter along the ray (peak contribution < 1e-15 mm) and to bound the
//! derivative of `f(t) = z(t) − h(x(t), y(t))` along this ray: `|f'| ≤ L`. A step of `|f|/L`
//! can therefore never jump over a root; the first sign change is bracketed and refined until the
//! bracket is below 1e-10 mm (so the hit point is exact to ~1e-9 mm).

use super::math::{Mat3, Vec3};

/// A height field `z = base + Σ a·exp(−r²/(2σ²))` over `|x| ≤ w/2, |y| ≤ h/2` of a local frame.
#[derive(Clone, Debug)]
pub struct HeightField {
    c: Vec3,
    rot: Mat3,
    hw: f64,
    hh: f64,
    base: f64,
    bumps: Vec<[f64; 4]>,
    z_lo: f64,
    z_hi: f64,
}

/// Smallest marching step, mm: two roots closer than this along a ray (a grazing touch) may be
/// missed.
const STEP_MIN: f64 = 1e-3;

impl HeightField {
    /// A height field centred at `c`, local → camera rotation `rot`, `size = [w, h]`.
    pub fn new(c: Vec3, rot: Mat3, size: [f64; 2], base: f64, bumps: &[[f64; 4]]) -> Self {
        let mut hf = HeightField {
            c,
            rot,
            hw: 0.5 * size[0],
            hh: 0.5 * size[1],
            base,
            bumps: bumps.to_vec(),
            z_lo: f64::NEG_INFINITY,
            z_hi: f64::INFINITY,
        };
        // Height bounds: extremes on a grid plus the most the surface can rise between grid
        // points (global gradient bound G times the largest distance to a grid point).
        let g: f64 = bumps.iter().map(|b| b[2].abs() / b[3] * 0.606_530_66).sum();
        let n = 400usize;
        let (dx, dy) = (size[0] / n as f64, size[1] / n as f64);
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for j in 0..=n {
            for i in 0..=n {
                let (h, _, _) = hf.height(-hf.hw + i as f64 * dx, -hf.hh + j as f64 * dy);
                lo = lo.min(h);
                hi = hi.max(h);
            }
        }
        let margin = g * 0.5 * dx.hypot(dy) + 1e-9;
        let abs_lo: f64 = base + bumps.iter().map(|b| b[2].min(0.0)).sum::<f64>();
        let abs_hi: f64 = base + bumps.iter().map(|b| b[2].max(0.0)).sum::<f64>();
        hf.z_lo = (lo - margin).max(abs_lo - 1e-9);
        hf.z_hi = (hi + margin).min(abs_hi + 1e-9);
        hf
    }

    /// Height and gradient at local (x, y).
    pub fn height(&self, x: f64, y: f64) -> (f64, f64, f64) {
        let (mut h, mut hx, mut hy) = (self.base, 0.0, 0.0);
        for b in &self.bumps {
            let (dx, dy) = (x - b[0], y - b[1]);
            let s2 = b[3] * b[3];
            let g = b[2] * libm::exp(-(dx * dx + dy * dy) / (2.0 * s2));
            h += g;
            hx -= g * dx / s2;
            hy -= g * dy / s2;
        }
        (h, hx, hy)
    }

    /// The surface point over local (x, y), camera frame.
    pub fn point(&self, x: f64, y: f64) -> Vec3 {
        let (h, _, _) = self.height(x, y);
        self.c + self.rot.mul_vec(Vec3::new(x, y, h))
    }

    /// Nearest hit in `(t_min, t_max)`: (t, unit normal in the camera frame, local +z side).
    pub fn intersect(&self, o: Vec3, d: Vec3, t_min: f64, t_max: f64) -> Option<(f64, Vec3)> {
        let ol = self.rot.tmul_vec(o - self.c);
        let dl = self.rot.tmul_vec(d);
        // Clip to the bounding box.
        let (oa, da) = (ol.to_array(), dl.to_array());
        let lo = [-self.hw, -self.hh, self.z_lo];
        let hi = [self.hw, self.hh, self.z_hi];
        let (mut ta, mut tb) = (t_min, t_max);
        for i in 0..3 {
            if da[i] == 0.0 {
                if oa[i] < lo[i] || oa[i] > hi[i] {
                    return None;
                }
                continue;
            }
            let (mut t0, mut t1) = ((lo[i] - oa[i]) / da[i], (hi[i] - oa[i]) / da[i]);
            if t0 > t1 {
                std::mem::swap(&mut t0, &mut t1);
            }
            ta = ta.max(t0);
            tb = tb.min(t1);
        }
        if !(ta <= tb) {
            return None;
        }
        // Along the ray, bump i contributes a_i·exp(−(A t² + B_i t + C_i)/(2σ_i²)).
        let a = dl.x * dl.x + dl.y * dl.y;
        let mut active: Vec<[f64; 5]> = Vec::with_capacity(self.bumps.len());
        let mut lip = dl.z.abs();
        for b in &self.bumps {
            let (px, py) = (ol.x - b[0], ol.y - b[1]);
            let bb = 2.0 * (px * dl.x + py * dl.y);
            let cc = px * px + py * py;
            let s2 = 2.0 * b[3] * b[3];
            // Minimum squared distance over all t (a ≥ 0).
            let min_q = if a > 0.0 {
                (cc - bb * bb / (4.0 * a)).max(0.0)
            } else {
                cc
            };
            let peak = b[2].abs() * libm::exp(-min_q / s2);
            if peak < 1e-15 {
                continue;
            }
            // |d/dt of a·exp(−q/s2)| ≤ peak · sqrt(a)/σ · e^{−1/2}.
            lip += peak * a.sqrt() / b[3] * 0.606_530_66;
            active.push([bb, cc, s2, b[2], 0.0]);
        }
        let f = |t: f64| -> f64 {
            let mut h = self.base;
            for b in &active {
                h += b[3] * libm::exp(-((a * t + b[0]) * t + b[1]) / b[2]);
            }
            ol.z + t * dl.z - h
        };
        let f_df = |t: f64| -> (f64, f64) {
            let (mut h, mut dh) = (self.base, 0.0);
            for b in &active {
                let q = (a * t + b[0]) * t + b[1];
                let g = b[3] * libm::exp(-q / b[2]);
                h += g;
                dh -= g * (2.0 * a * t + b[0]) / b[2];
            }
            (ol.z + t * dl.z - h, dl.z - dh)
        };
        let lip = lip * (1.0 + 1e-9) + 1e-12;
        let mut t = ta;
        let mut ft = f(t);
        if ft == 0.0 {
            return (t > t_min).then(|| (t, self.normal_at(ol + dl * t)));
        }
        let s0 = ft > 0.0;
        let mut bracket = None;
        // Relaxed Lipschitz marching: try 1.5× the secant prediction of the root; keep the step
        // only if it brackets a root or provably skips none (|f_a| + |f_b| ≥ L·Δ: a root inside
        // would need the function to fall to 0 and come back, which takes more than L·Δ);
        // otherwise take the safe step |f|/L.
        let mut prev: Option<(f64, f64)> = None;
        for _ in 0..200_000 {
            if t >= tb {
                break;
            }
            let safe = (ft.abs() / lip).max(STEP_MIN);
            let mut step = safe;
            if let Some((tp, fp)) = prev {
                let slope = (ft - fp) / (t - tp);
                step = if slope != 0.0 && (-ft / slope) > 0.0 {
                    // Heading for a root: aim past it.
                    step.max((1.5 * -ft / slope).min(50.0 * safe))
                } else {
                    // Moving away from the surface: |f| grows, longer steps verify.
                    2.5 * safe
                };
            }
            let mut tn = (t + step).min(tb);
            let mut fnx = f(tn);
            if (fnx > 0.0) == s0
                && fnx != 0.0
                && step > safe
                && ft.abs() + fnx.abs() < lip * (tn - t)
            {
                tn = (t + safe).min(tb);
                fnx = f(tn);
            }
            if (fnx > 0.0) != s0 || fnx == 0.0 {
                bracket = Some((t, ft, tn, fnx));
                break;
            }
            prev = Some((t, ft));
            t = tn;
            ft = fnx;
        }
        let (mut lo_t, mut lo_f, mut hi_t, _) = bracket?;
        // Safeguarded Newton inside the bracket.
        let mut x = 0.5 * (lo_t + hi_t);
        let mut result = None;
        for _ in 0..200 {
            let (fx, dfx) = f_df(x);
            if fx == 0.0 {
                result = Some(x);
                break;
            }
            if (fx > 0.0) == (lo_f > 0.0) {
                lo_t = x;
                lo_f = fx;
            } else {
                hi_t = x;
            }
            let step = if dfx != 0.0 { fx / dfx } else { f64::INFINITY };
            let xn = x - step;
            let (l, h) = if lo_t < hi_t {
                (lo_t, hi_t)
            } else {
                (hi_t, lo_t)
            };
            if step.abs() < 1e-11 && xn >= l && xn <= h {
                result = Some(xn);
                break;
            }
            if h - l < 1e-10 {
                result = Some(0.5 * (l + h));
                break;
            }
            x = if xn > l && xn < h { xn } else { 0.5 * (l + h) };
        }
        let t = result.unwrap_or(0.5 * (lo_t + hi_t));
        if !(t > t_min && t < t_max) {
            return None;
        }
        let p = ol + dl * t;
        if p.x.abs() > self.hw || p.y.abs() > self.hh {
            return None;
        }
        Some((t, self.normal_at(p)))
    }

    /// Unit normal (camera frame) at local point `p` (towards local +z).
    fn normal_at(&self, p: Vec3) -> Vec3 {
        let (_, hx, hy) = self.height(p.x, p.y);
        self.rot.mul_vec(Vec3::new(-hx, -hy, 1.0).normalized())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hit_is_on_the_surface() {
        let hf = HeightField::new(
            Vec3::new(0.0, 0.0, 600.0),
            Mat3::from_euler_deg([180.0, 0.0, 0.0]),
            [200.0, 160.0],
            0.0,
            &[
                [0.0, 0.0, 40.0, 30.0],
                [50.0, 20.0, -20.0, 20.0],
                [-60.0, -30.0, 25.0, 15.0],
            ],
        );
        let mut n = 0;
        for i in 0..50 {
            for j in 0..50 {
                let d = Vec3::new(-0.15 + 0.006 * i as f64, -0.12 + 0.005 * j as f64, 1.0);
                if let Some((t, _)) = hf.intersect(Vec3::ZERO, d, 1e-6, 1e9) {
                    let p = d * t;
                    let l = hf.rot.tmul_vec(p - hf.c);
                    let (h, _, _) = hf.height(l.x, l.y);
                    assert!((l.z - h).abs() < 1e-9, "{} vs {}", l.z, h);
                    n += 1;
                }
            }
        }
        assert!(n > 1000);
    }
}
