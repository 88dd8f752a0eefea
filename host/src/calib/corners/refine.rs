//! Step 4 of the detection: sub-pixel refinement of a corner, as the saddle point of the
//! Gaussian-weighted samples ([`refine_saddle`]) or by fitting an X-junction model
//! ([`refine_model`]).

use super::{Image, dist};
use crate::calib::lens::Lens;
use crate::calib::{linalg, lm};

/// Pixel positions around a centre `c` with the lens's distortion straightened: `w(p) = c +
/// A⁻¹·(P(p) − P(c))`, `P` the ideal (undistorted) pixel of `p` and `A = ∂P/∂p` at `c`. Straight
/// lines of the scene are straight in `w`, and `w(p) = p + O(|p − c|²)`: near `c` a pixel's box
/// keeps its size and shape, and only the curvature that distortion gives the board's edges is
/// taken out. Fitting straight edges to curved ones pulls a corner towards the edges' centres of
/// curvature: with the default rig's barrel distortion every board came out 4·10⁻⁶ smaller than
/// it is (docs/calibration.md, "Corners and lens distortion").
struct Straighten {
    lens: Lens,
    c: [f64; 2],
    pc: [f64; 2],
    /// `A⁻¹`, row-major.
    ainv: [f64; 4],
}

impl Straighten {
    fn new(lens: &Lens, c: [f64; 2]) -> Option<Straighten> {
        let p = |u: f64, v: f64| ideal(lens, u, v);
        let pc = p(c[0], c[1])?;
        let (xp, xm) = (p(c[0] + 1.0, c[1])?, p(c[0] - 1.0, c[1])?);
        let (yp, ym) = (p(c[0], c[1] + 1.0)?, p(c[0], c[1] - 1.0)?);
        let a = [
            0.5 * (xp[0] - xm[0]),
            0.5 * (yp[0] - ym[0]),
            0.5 * (xp[1] - xm[1]),
            0.5 * (yp[1] - ym[1]),
        ];
        let det = a[0] * a[3] - a[1] * a[2];
        if !(det.abs() > 1e-9) {
            return None;
        }
        Some(Straighten {
            lens: *lens,
            c,
            pc,
            ainv: [a[3] / det, -a[1] / det, -a[2] / det, a[0] / det],
        })
    }

    fn apply(&self, p: [f64; 2]) -> Option<[f64; 2]> {
        let q = ideal(&self.lens, p[0], p[1])?;
        let (dx, dy) = (q[0] - self.pc[0], q[1] - self.pc[1]);
        let a = &self.ainv;
        Some([
            self.c[0] + a[0] * dx + a[1] * dy,
            self.c[1] + a[2] * dx + a[3] * dy,
        ])
    }

    /// The pixel `p` with `w(p) = q` (`w` is the identity to first order near `c`: a few
    /// fixed-point steps).
    fn invert(&self, q: [f64; 2]) -> Option<[f64; 2]> {
        let mut p = q;
        for _ in 0..4 {
            let w = self.apply(p)?;
            p = [p[0] + q[0] - w[0], p[1] + q[1] - w[1]];
        }
        Some(p)
    }
}

/// The ideal (undistorted) pixel of `(u, v)`: the pinhole's projection of its ray.
fn ideal(lens: &Lens, u: f64, v: f64) -> Option<[f64; 2]> {
    let (x, y) = lens.undistort(u, v)?;
    let [fx, fy, skew, cx, cy, ..] = lens.p;
    Some([fx * x + skew * fx * y + cx, fy * y + cy])
}

/// Saddle point of `Σ_k G_σ(q − k) I(k)` near `q0` by Newton's method.
pub fn refine_saddle(img: &Image, q0: [f64; 2], sigma: f64) -> Result<[f64; 2], &'static str> {
    let r = (4.5 * sigma).ceil() as isize;
    let s2 = sigma * sigma;
    let mut q = q0;
    for _ in 0..40 {
        let (cx, cy) = (q[0].round() as isize, q[1].round() as isize);
        if cx - r < 0 || cy - r < 0 || cx + r >= img.width as isize || cy + r >= img.height as isize
        {
            return Err("too close to the image border");
        }
        let mut mean = 0.0;
        for y in cy - r..=cy + r {
            for x in cx - r..=cx + r {
                mean += img.at(x as usize, y as usize) as f64;
            }
        }
        mean /= ((2 * r + 1) * (2 * r + 1)) as f64;
        let (mut g0, mut g1, mut h00, mut h01, mut h11) = (0.0, 0.0, 0.0, 0.0, 0.0);
        for y in cy - r..=cy + r {
            let dy = q[1] - y as f64;
            for x in cx - r..=cx + r {
                let dx = q[0] - x as f64;
                let w = (-(dx * dx + dy * dy) / (2.0 * s2)).exp();
                let v = (img.at(x as usize, y as usize) as f64 - mean) * w;
                g0 -= dx * v;
                g1 -= dy * v;
                h00 += (dx * dx / s2 - 1.0) * v;
                h01 += dx * dy / s2 * v;
                h11 += (dy * dy / s2 - 1.0) * v;
            }
        }
        // Common factors 1/σ² (gradient) and 1/σ² (Hessian) cancel in the Newton step.
        let det = h00 * h11 - h01 * h01;
        if !(det < 0.0) {
            return Err("not a saddle");
        }
        let mut d = [-(h11 * g0 - h01 * g1) / det, -(-h01 * g0 + h00 * g1) / det];
        let l = (d[0] * d[0] + d[1] * d[1]).sqrt();
        if !l.is_finite() {
            return Err("singular");
        }
        if l > 0.5 {
            d = [d[0] * 0.5 / l, d[1] * 0.5 / l];
        }
        q = [q[0] + d[0], q[1] + d[1]];
        if l < 1e-6 {
            return Ok(q);
        }
    }
    Err("no convergence")
}

/// Smallest optical blur β of the corner model, pixels. The pixel's own box integration is
/// modelled exactly (see `edge`), so β only stands for blur beyond it and may be near 0.
const BETA_MIN: f64 = 0.05;

/// The blur β for the model parameter `b`: smooth, never below [`BETA_MIN`] (a bound the fit
/// would otherwise run into on images without optical blur).
#[inline]
fn blur(b: f64) -> f64 {
    (BETA_MIN * BETA_MIN + b * b).sqrt()
}

/// Below this width a box factor of `edge` is replaced by its limit (a derivative).
const W_EPS: f64 = 1e-3;

/// `[F₂, F₁, F₀, F₋₁](x)` for a Gaussian of standard deviation β: `F₀` its CDF, `F₋₁` its
/// density, `F₁ = ∫F₀`, `F₂ = ∫F₁`.
#[inline]
fn gauss_antiderivatives(x: f64, beta: f64) -> [f64; 4] {
    // Beyond 8.5 β the CDF is 0 or 1 to 1e-16 (most pixels of a window are that far from an
    // edge).
    if x > 8.5 * beta {
        return [0.5 * (x * x + beta * beta), x, 1.0, 0.0];
    }
    if x < -8.5 * beta {
        return [0.0; 4];
    }
    let (e, ex) = erf_exp(x / (std::f64::consts::SQRT_2 * beta));
    let cdf = 0.5 * (1.0 + e);
    let g = ex / (beta * (2.0 * std::f64::consts::PI).sqrt());
    let b2 = beta * beta;
    let f1 = x * cdf + b2 * g;
    let f2 = 0.5 * ((x * x + b2) * cdf + x * b2 * g);
    [f2, f1, cdf, g]
}

/// A straight edge integrated over a unit box pixel, then blurred by a Gaussian β, at signed
/// distance `a` from the edge whose unit normal is `(−sin φ, cos φ)` = `(−sn, cs)`: the step
/// convolved with the projection of the pixel box onto the normal (two boxes of widths |sin φ| and
/// |cos φ|) and the Gaussian, in closed form by finite differences of `F₂`. Returns
/// `[E, ∂E/∂a, ∂E/∂φ at fixed a, ∂E/∂β]` with `E ∈ [−1, 1]`.
///
/// Unlike an erf profile this is exact for any edge direction: a box-integrated edge along a
/// pixel axis is a linear ramp one pixel wide, and an erf fitted to its samples lands off by up to
/// ~0.05 px depending on where the edge falls within the pixel — the same error along the whole
/// edge, so it does not average out (issue #18: corners biased on boards near axis alignment).
#[inline]
fn edge(a: f64, sn: f64, cs: f64, beta: f64) -> [f64; 4] {
    let (w1, w2) = (sn.abs(), cs.abs());
    // Per box factor: shifts and weights of the difference quotient (w ≥ W_EPS) or of its limit,
    // a derivative (one point, one F level lower).
    let factor = |w: f64| -> ([f64; 2], [f64; 2], usize, usize) {
        if w >= W_EPS {
            ([0.5 * w, -0.5 * w], [1.0 / w, -1.0 / w], 2, 0)
        } else {
            ([0.0, 0.0], [1.0, 0.0], 1, 1)
        }
    };
    let (sh1, wt1, n1, o1) = factor(w1);
    let (sh2, wt2, n2, o2) = factor(w2);
    let mut f = [[0.0; 4]; 4];
    for i in 0..n1 {
        for j in 0..n2 {
            f[i * 2 + j] = gauss_antiderivatives(a + sh1[i] + sh2[j], beta);
        }
    }
    // P⁽ᵐ⁾ = Σ wt1·wt2·F_{2−m−o1−o2}; index into [F₂, F₁, F₀, F₋₁] = m + o1 + o2.
    let p = |m: usize| -> f64 {
        let mut s = 0.0;
        for i in 0..n1 {
            for j in 0..n2 {
                s += wt1[i] * wt2[j] * f[i * 2 + j][m + o1 + o2];
            }
        }
        s
    };
    let (p0, p1, p2) = (p(0), p(1), p(2));
    // ∂P/∂w for a difference-quotient factor: [mean of the one-level-lower F at ±w/2 − P]/w.
    let mut dw1 = 0.0;
    if n1 == 2 {
        let mut s = 0.0;
        for i in 0..2 {
            for j in 0..n2 {
                s += 0.5 * wt2[j] * f[i * 2 + j][1 + o2];
            }
        }
        dw1 = (s - p0) / w1;
    }
    let mut dw2 = 0.0;
    if n2 == 2 {
        let mut s = 0.0;
        for i in 0..n1 {
            for j in 0..2 {
                s += 0.5 * wt1[i] * f[i * 2 + j][1 + o1];
            }
        }
        dw2 = (s - p0) / w2;
    }
    // w1 = |sin φ|, w2 = |cos φ|.
    let dphi = dw1 * sn.signum() * cs - dw2 * cs.signum() * sn;
    [2.0 * p0 - 1.0, 2.0 * p1, 2.0 * dphi, 2.0 * beta * p2]
}

/// Hessian of `Σ_k G_σ(q − k) I(k)` at `q` (up to a positive factor).
pub(super) fn saddle_hessian(img: &Image, q: [f64; 2], sigma: f64) -> Option<[f64; 3]> {
    let r = (4.5 * sigma).ceil() as isize;
    let s2 = sigma * sigma;
    let (cx, cy) = (q[0].round() as isize, q[1].round() as isize);
    if cx - r < 0 || cy - r < 0 || cx + r >= img.width as isize || cy + r >= img.height as isize {
        return None;
    }
    let (mut h00, mut h01, mut h11) = (0.0, 0.0, 0.0);
    for y in cy - r..=cy + r {
        let dy = q[1] - y as f64;
        for x in cx - r..=cx + r {
            let dx = q[0] - x as f64;
            let w = (-(dx * dx + dy * dy) / (2.0 * s2)).exp();
            let v = img.at(x as usize, y as usize) as f64 * w;
            h00 += (dx * dx / s2 - 1.0) * v;
            h01 += dx * dy / s2 * v;
            h11 += (dy * dy / s2 - 1.0) * v;
        }
    }
    Some([h00, h01, h11])
}

/// The two edge directions (angles of the lines, radians) of an X-junction from its Hessian: the
/// asymptotes of the saddle's quadratic form.
pub(super) fn edge_angles(h: [f64; 3]) -> Option<(f64, f64)> {
    let [a, b, c] = h;
    let tr = 0.5 * (a + c);
    let disc = (0.25 * (a - c) * (a - c) + b * b).sqrt();
    let (la, lb) = (tr + disc, tr - disc);
    if !(la > 0.0 && lb < 0.0) {
        return None;
    }
    // Eigenvector of la.
    let th = 0.5 * (2.0 * b).atan2(a - c);
    let (ea, eb) = ([th.cos(), th.sin()], [-th.sin(), th.cos()]);
    let k = (-lb / la).sqrt();
    let t1 = [k * ea[0] + eb[0], k * ea[1] + eb[1]];
    let t2 = [-k * ea[0] + eb[0], -k * ea[1] + eb[1]];
    Some((t1[1].atan2(t1[0]), t2[1].atan2(t2[0])))
}

/// Sub-pixel corner by fitting an X-junction model to the pixels within `radius` of `q0`:
///
/// `I(p) ≈ c0 + c1·dx + c2·dy + (c3 + c4·dx + c5·dy)·E(n1·d)·E(n2·d)`, `d = p − q`,
///
/// with `E` a straight edge integrated over the box pixel and blurred by a Gaussian β (`edge`),
/// `n_i` the normals of the two edges through q. The linear terms absorb the illumination
/// gradient across the corner (additive ambient and multiplicative projector light), which
/// otherwise shifts a saddle-point estimate by ~σ²·|∇L|/L.
/// The remaining model error (the pixel integral of the product `E₁·E₂` taken as the product of
/// the integrals, exact for edges along the pixel axes) is point-symmetric about q and confined to
/// the pixels at the corner.
/// Levenberg–Marquardt over the 11 parameters; the window is re-centred once on the result.
///
/// With the camera's `lens` known, the pixels' positions are first straightened (the lens's
/// distortion taken out around the window's centre, to second order), so that the board's edges,
/// which distortion curves, are straight as the model has them; the corner is mapped back.
pub fn refine_model(
    img: &Image,
    q0: [f64; 2],
    radius: f64,
    angles: (f64, f64),
    lens: Option<&Lens>,
) -> Result<[f64; 2], &'static str> {
    let taper = 3.0f64.min(0.5 * radius);
    // Pixels within `radius` of `c` with a cosine taper over the outer `taper` pixels (so that
    // the estimate does not jump when a rim pixel enters or leaves the window).
    let window = |c: [f64; 2],
                  warp: Option<&Straighten>|
     -> Result<Vec<(f64, f64, f64, f64)>, &'static str> {
        let r = radius.ceil() as isize;
        let (cx, cy) = (c[0].round() as isize, c[1].round() as isize);
        if cx - r < 0 || cy - r < 0 || cx + r >= img.width as isize || cy + r >= img.height as isize
        {
            return Err("too close to the image border");
        }
        let mut px = Vec::with_capacity(((2 * r + 1) * (2 * r + 1)) as usize);
        for y in cy - r..=cy + r {
            for x in cx - r..=cx + r {
                let (dx, dy) = (x as f64 - c[0], y as f64 - c[1]);
                let d = (dx * dx + dy * dy).sqrt();
                if d < radius {
                    let t = ((d - (radius - taper)) / taper).max(0.0);
                    let w = if t > 0.0 {
                        0.5 * (1.0 + (std::f64::consts::PI * t).cos())
                    } else {
                        1.0
                    };
                    let at = match warp {
                        Some(s) => s
                            .apply([x as f64, y as f64])
                            .ok_or("outside the lens model")?,
                        None => [x as f64, y as f64],
                    };
                    px.push((
                        at[0],
                        at[1],
                        img.at(x as usize, y as usize) as f64,
                        w.sqrt(),
                    ));
                }
            }
        }
        Ok(px)
    };
    // Model pieces for the nonlinear parameters (qx, qy, φ1, φ2, b), β = √(β_min² + b²).
    let piece = |x: &[f64], p: &(f64, f64, f64, f64)| {
        let (dx, dy) = (p.0 - x[0], p.1 - x[1]);
        let (s1, c1) = x[2].sin_cos();
        let (s2, c2) = x[3].sin_cos();
        let a1 = -s1 * dx + c1 * dy;
        let a2 = -s2 * dx + c2 * dy;
        let beta = blur(x[4]);
        let e1 = edge(a1, s1, c1, beta);
        let e2 = edge(a2, s2, c2, beta);
        (dx, dy, e1, e2, [c1, s1], [c2, s2])
    };
    let mut q = q0;
    let mut state: Option<Vec<f64>> = None;
    for _pass in 0..2 {
        // The model's coordinates: the pixels' own, or straightened about the window's centre
        // (the identity there, so `q` and the previous solution carry over).
        let warp = lens.and_then(|l| Straighten::new(l, q));
        let px = window(q, warp.as_ref())?;
        let lo = px.iter().map(|p| p.2).fold(f64::INFINITY, f64::min);
        let hi = px.iter().map(|p| p.2).fold(f64::NEG_INFINITY, f64::max);
        let span = hi - lo;
        if !(span > 0.0) {
            return Err("flat window");
        }
        let mid = 0.5 * (hi + lo);
        let px: Vec<(f64, f64, f64, f64)> = px
            .into_iter()
            .map(|p| (p.0, p.1, (p.2 - mid) / span, p.3))
            .collect();
        // Linear coefficients for a nonlinear guess (first pass).
        let linear = |x: &[f64]| -> Option<[f64; 6]> {
            let mut ata = [0.0; 36];
            let mut atb = [0.0; 6];
            for p in &px {
                let (dx, dy, e1, e2, ..) = piece(x, p);
                let s = e1[0] * e2[0];
                let row = [1.0, dx, dy, s, s * dx, s * dy].map(|v| v * p.3);
                for i in 0..6 {
                    atb[i] += row[i] * p.2 * p.3;
                    for j in 0..6 {
                        ata[i * 6 + j] += row[i] * row[j];
                    }
                }
            }
            if !linalg::cholesky(&mut ata, 6) {
                return None;
            }
            linalg::cholesky_solve(&ata, 6, &mut atb);
            Some(atb)
        };
        let x0 = match state.take() {
            // Re-centred window: the previous solution, its linear part re-solved for the new
            // normalisation.
            Some(mut x) => {
                let l = linear(&x).ok_or("degenerate window")?;
                x.truncate(5);
                x.extend(l);
                x
            }
            None => {
                let b0 = (0.5f64 * 0.5 - BETA_MIN * BETA_MIN).sqrt();
                let mut x = vec![q[0], q[1], angles.0, angles.1, b0];
                x.extend(linear(&x).ok_or("degenerate window")?);
                x
            }
        };
        let eval = |x: &Vec<f64>, _j: bool| -> Option<lm::Eval> {
            if !(x[4].abs() < 20.0) {
                return None;
            }
            let mut e = lm::Eval {
                width: 11,
                ..Default::default()
            };
            e.r.reserve(px.len());
            e.vals.reserve(11 * px.len());
            e.cols.reserve(11 * px.len());
            for p in &px {
                let (dx, dy, e1, e2, t1, t2) = piece(x, p);
                let sw = p.3;
                let s = e1[0] * e2[0];
                let lin = x[8] + x[9] * dx + x[10] * dy;
                e.r.push(sw * (x[5] + x[6] * dx + x[7] * dy + lin * s - p.2));
                let (s1, c1) = (t1[1], t1[0]);
                let (s2, c2) = (t2[1], t2[0]);
                let (g1, g2) = (e1[1] * e2[0], e1[0] * e2[1]);
                // ∂S/∂q = −(g1 n1 + g2 n2), n = (−sin φ, cos φ), g_i = ∂S/∂a_i.
                let dsq = [-(g1 * -s1 + g2 * -s2), -(g1 * c1 + g2 * c2)];
                // ∂a/∂φ = −(cos φ·dx + sin φ·dy); plus the box widths' dependence on φ.
                let ds1 = g1 * -(c1 * dx + s1 * dy) + e1[2] * e2[0];
                let ds2 = g2 * -(c2 * dx + s2 * dy) + e1[0] * e2[2];
                // ∂S/∂β · ∂β/∂b.
                let dsb = (e1[3] * e2[0] + e1[0] * e2[3]) * x[4] / blur(x[4]);
                e.vals.extend(
                    [
                        -x[6] - x[9] * s + lin * dsq[0],
                        -x[7] - x[10] * s + lin * dsq[1],
                        lin * ds1,
                        lin * ds2,
                        lin * dsb,
                        1.0,
                        dx,
                        dy,
                        s,
                        s * dx,
                        s * dy,
                    ]
                    .map(|v| v * sw),
                );
                e.cols.extend(0..11);
            }
            Some(e)
        };
        let apply =
            |x: &Vec<f64>, d: &[f64]| x.iter().zip(d).map(|(a, b)| a + b).collect::<Vec<f64>>();
        let sol = lm::solve(
            x0,
            11,
            eval,
            apply,
            lm::Options {
                max_iterations: 100,
                cost_tolerance: 1e-12,
                step_tolerance: 1e-9,
            },
        )
        .ok_or("model fit failed")?;
        let x = sol.state;
        let nq = match &warp {
            Some(w) => w.invert([x[0], x[1]]).ok_or("outside the lens model")?,
            None => [x[0], x[1]],
        };
        if !(nq[0].is_finite() && nq[1].is_finite()) || dist(nq, q0) > 0.5 * radius {
            return Err("model fit wandered off");
        }
        if x[8].abs() < 0.1 {
            return Err("no contrast at the corner");
        }
        q = nq;
        // The next window is straightened about `q`, where its coordinates are the pixels'.
        let mut x = x;
        (x[0], x[1]) = (q[0], q[1]);
        state = Some(x);
    }
    Ok(q)
}

/// `(erf(x), exp(−x²))` (Abramowitz & Stegun 7.1.26, |error| ≤ 1.5e-7).
#[inline]
fn erf_exp(x: f64) -> (f64, f64) {
    let e = (-x * x).exp();
    let a = x.abs();
    let t = 1.0 / (1.0 + 0.327_591_1 * a);
    let poly = t
        * (0.254_829_592
            + t * (-0.284_496_736
                + t * (1.421_413_741 + t * (-1.453_152_027 + t * 1.061_405_429))));
    let v = 1.0 - poly * e;
    (if x < 0.0 { -v } else { v }, e)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `edge` against a brute-force pixel integral of an erf edge (300 × 300 midpoint samples
    /// of the box), and its derivatives against central differences.
    #[test]
    fn edge_is_the_box_integral_of_a_blurred_step() {
        let n = 300;
        for &beta in &[0.25, 0.6] {
            for &phi in &[0.0, 4e-4, 0.3, std::f64::consts::FRAC_PI_4, 1.2, -0.7, 2.5] {
                let (sn, cs) = f64::sin_cos(phi);
                for &a in &[-1.2, -0.3, 0.0, 0.2, 0.9] {
                    let mut sum = 0.0;
                    for i in 0..n {
                        for j in 0..n {
                            let t = (i as f64 + 0.5) / n as f64 - 0.5;
                            let s = (j as f64 + 0.5) / n as f64 - 0.5;
                            let x = a + (-sn * t + cs * s);
                            sum += erf_exp(x / (std::f64::consts::SQRT_2 * beta)).0;
                        }
                    }
                    let want = sum / (n * n) as f64;
                    let e = edge(a, sn, cs, beta);
                    assert!(
                        (e[0] - want).abs() < 2e-5,
                        "a {a} φ {phi} β {beta}: {} vs {want}",
                        e[0]
                    );
                    let h = 1e-5;
                    let da =
                        (edge(a + h, sn, cs, beta)[0] - edge(a - h, sn, cs, beta)[0]) / (2.0 * h);
                    let (sp, cp) = f64::sin_cos(phi + h);
                    let (sm, cm) = f64::sin_cos(phi - h);
                    let dphi = (edge(a, sp, cp, beta)[0] - edge(a, sm, cm, beta)[0]) / (2.0 * h);
                    let db =
                        (edge(a, sn, cs, beta + h)[0] - edge(a, sn, cs, beta - h)[0]) / (2.0 * h);
                    for (k, fd) in [(1, da), (2, dphi), (3, db)] {
                        assert!(
                            (e[k] - fd).abs() < 1e-4 * (1.0 + fd.abs()),
                            "a {a} φ {phi} β {beta}: derivative {k} {} vs {fd}",
                            e[k]
                        );
                    }
                }
            }
        }
    }
}
