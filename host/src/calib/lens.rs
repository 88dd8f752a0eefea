//! The camera model of the calibration (paper eqs 2-4) in f64, with the derivatives the
//! Levenberg–Marquardt solvers need, and its inverse (pixel → normalized ray).
//!
//! ```text
//! x = X/Z, y = Y/Z, r² = x² + y²
//! x_d = x·(1 + k1 r² + k2 r⁴ + k3 r⁶) + 2 p1 x y + p2 (r² + 2x²)
//! y_d = y·(1 + k1 r² + k2 r⁴ + k3 r⁶) + p1 (r² + 2y²) + 2 p2 x y
//! u = fx·x_d + α·fx·y_d + u0,   v = fy·y_d + v0
//! ```
//!
//! α is the paper's dimensionless skew (eq 4). OpenCV's camera matrix holds `K[0][1] = α·fx`
//! instead; Bouguet's `alpha_c` is α.

use fringe3d_core::params::CameraParams;

/// Number of intrinsic parameters: `[fx, fy, α, u0, v0, k1, k2, p1, p2, k3]`.
pub const N_INTRINSICS: usize = 10;

/// Names of the intrinsic parameters, in [`Lens::p`] order.
pub const PARAM_NAMES: [&str; N_INTRINSICS] =
    ["fx", "fy", "skew", "cx", "cy", "k1", "k2", "p1", "p2", "k3"];

/// A pinhole camera with Brown distortion.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lens {
    /// Image width, pixels.
    pub width: u32,
    /// Image height, pixels.
    pub height: u32,
    /// Intrinsics `[fx, fy, α, u0, v0, k1, k2, p1, p2, k3]` ([`CameraParams::to_vector`]).
    pub p: [f64; N_INTRINSICS],
}

/// Derivatives of one projection.
#[derive(Clone, Copy, Debug)]
pub struct ProjJac {
    /// ∂(u, v)/∂(x, y): rows u, v.
    pub d_xy: [[f64; 2]; 2],
    /// ∂(u, v)/∂(intrinsics): rows u, v.
    pub d_intr: [[f64; N_INTRINSICS]; 2],
}

impl Lens {
    /// The solver's form of a camera's parameters.
    pub fn from_model(c: &CameraParams) -> Lens {
        Lens {
            width: c.width,
            height: c.height,
            p: c.to_vector(),
        }
    }

    /// The parameters again ([`CameraParams::from_vector`]).
    pub fn to_model(&self) -> CameraParams {
        CameraParams::from_vector(self.width, self.height, self.p)
    }

    /// Apply the distortion to normalized coordinates.
    #[inline]
    pub fn distort(&self, x: f64, y: f64) -> (f64, f64) {
        let [_, _, _, _, _, k1, k2, p1, p2, k3] = self.p;
        let r2 = x * x + y * y;
        let rad = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3));
        (
            x * rad + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x),
            y * rad + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y,
        )
    }

    /// Normalized undistorted coordinates → pixel.
    #[inline]
    pub fn project(&self, x: f64, y: f64) -> (f64, f64) {
        let (xd, yd) = self.distort(x, y);
        let [fx, fy, a, u0, v0, ..] = self.p;
        (fx * (xd + a * yd) + u0, fy * yd + v0)
    }

    /// Project a camera-frame point (`None` behind the camera).
    pub fn project_point(&self, p: [f64; 3]) -> Option<(f64, f64)> {
        (p[2] > 0.0).then(|| self.project(p[0] / p[2], p[1] / p[2]))
    }

    /// [`Lens::project`] with its derivatives.
    pub fn project_jac(&self, x: f64, y: f64) -> ((f64, f64), ProjJac) {
        let [fx, fy, a, _, _, k1, k2, p1, p2, k3] = self.p;
        let r2 = x * x + y * y;
        let rad = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3));
        let drad = k1 + r2 * (2.0 * k2 + 3.0 * k3 * r2); // d rad / d r²
        let xd = x * rad + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x);
        let yd = y * rad + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y;
        let dxd_dx = rad + 2.0 * x * x * drad + 2.0 * p1 * y + 6.0 * p2 * x;
        let dxd_dy = 2.0 * x * y * drad + 2.0 * p1 * x + 2.0 * p2 * y;
        let dyd_dx = 2.0 * x * y * drad + 2.0 * p1 * x + 2.0 * p2 * y;
        let dyd_dy = rad + 2.0 * y * y * drad + 6.0 * p1 * y + 2.0 * p2 * x;
        let u = fx * (xd + a * yd) + self.p[3];
        let v = fy * yd + self.p[4];
        let d_xy = [
            [fx * (dxd_dx + a * dyd_dx), fx * (dxd_dy + a * dyd_dy)],
            [fy * dyd_dx, fy * dyd_dy],
        ];
        // ∂(xd, yd)/∂(k1, k2, p1, p2, k3).
        let r4 = r2 * r2;
        let dk = [
            (x * r2, y * r2),
            (x * r4, y * r4),
            (2.0 * x * y, r2 + 2.0 * y * y),
            (r2 + 2.0 * x * x, 2.0 * x * y),
            (x * r4 * r2, y * r4 * r2),
        ];
        let mut d_intr = [[0.0; N_INTRINSICS]; 2];
        d_intr[0][0] = xd + a * yd;
        d_intr[0][2] = fx * yd;
        d_intr[0][3] = 1.0;
        d_intr[1][1] = yd;
        d_intr[1][4] = 1.0;
        for (i, (dx, dy)) in dk.iter().enumerate() {
            d_intr[0][5 + i] = fx * (dx + a * dy);
            d_intr[1][5 + i] = fy * dy;
        }
        ((u, v), ProjJac { d_xy, d_intr })
    }

    /// Pixel → distorted normalized coordinates (inverse of eq 4).
    #[inline]
    pub fn unpixel(&self, u: f64, v: f64) -> (f64, f64) {
        let [fx, fy, a, u0, v0, ..] = self.p;
        let yd = (v - v0) / fy;
        ((u - u0) / fx - a * yd, yd)
    }

    /// Pixel → normalized undistorted coordinates `(x, y)` (the ray `(x, y, 1)`), by Newton's
    /// method on the distortion until the reprojection error is below 1e-10 px. `None` if it does
    /// not converge (a pixel beyond the lens model's monotonic range).
    pub fn undistort(&self, u: f64, v: f64) -> Option<(f64, f64)> {
        let (xd, yd) = self.unpixel(u, v);
        let (mut x, mut y) = (xd, yd);
        let [fx, fy, ..] = self.p;
        let scale = fx.max(fy);
        for _ in 0..50 {
            let ((pu, pv), j) = self.project_jac(x, y);
            let (eu, ev) = (pu - u, pv - v);
            if (eu * eu + ev * ev).sqrt() < 1e-10 {
                return Some((x, y));
            }
            let [[a, b], [c, d]] = j.d_xy;
            let det = a * d - b * c;
            if !(det.abs() > 1e-12 * scale * scale) {
                return None;
            }
            x -= (d * eu - b * ev) / det;
            y -= (-c * eu + a * ev) / det;
            if !(x.is_finite() && y.is_finite()) || x * x + y * y > 100.0 {
                return None;
            }
        }
        let (pu, pv) = self.project(x, y);
        (((pu - u).powi(2) + (pv - v).powi(2)).sqrt() < 1e-7).then_some((x, y))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lens() -> Lens {
        Lens {
            width: 1280,
            height: 1024,
            p: [
                1550.0, 1545.0, 0.001, 642.25, 508.75, -0.085, 0.11, 0.0004, -0.0003, -0.02,
            ],
        }
    }

    #[test]
    fn jacobian_matches_finite_differences() {
        let l = lens();
        let (x, y) = (0.31, -0.22);
        let (_, j) = l.project_jac(x, y);
        let h = 1e-7;
        let (u1, v1) = l.project(x + h, y);
        let (u0, v0) = l.project(x - h, y);
        assert!(((u1 - u0) / (2.0 * h) - j.d_xy[0][0]).abs() < 1e-4);
        assert!(((v1 - v0) / (2.0 * h) - j.d_xy[1][0]).abs() < 1e-4);
        let (u1, v1) = l.project(x, y + h);
        let (u0, v0) = l.project(x, y - h);
        assert!(((u1 - u0) / (2.0 * h) - j.d_xy[0][1]).abs() < 1e-4);
        assert!(((v1 - v0) / (2.0 * h) - j.d_xy[1][1]).abs() < 1e-4);
        for k in 0..N_INTRINSICS {
            let mut a = l;
            let mut b = l;
            let hk = 1e-6 * l.p[k].abs().max(1e-3);
            a.p[k] += hk;
            b.p[k] -= hk;
            let (ua, va) = a.project(x, y);
            let (ub, vb) = b.project(x, y);
            assert!(
                ((ua - ub) / (2.0 * hk) - j.d_intr[0][k]).abs()
                    < 1e-4 * (1.0 + j.d_intr[0][k].abs()),
                "u/{k}"
            );
            assert!(
                ((va - vb) / (2.0 * hk) - j.d_intr[1][k]).abs()
                    < 1e-4 * (1.0 + j.d_intr[1][k].abs()),
                "v/{k}"
            );
        }
    }

    #[test]
    fn undistort_inverts_project() {
        let l = lens();
        for (u, v) in [
            (0.0, 0.0),
            (1279.0, 1023.0),
            (640.0, 512.0),
            (17.5, 1000.25),
        ] {
            let (x, y) = l.undistort(u, v).unwrap();
            let (pu, pv) = l.project(x, y);
            assert!((pu - u).abs() < 1e-9 && (pv - v).abs() < 1e-9);
        }
    }
}
