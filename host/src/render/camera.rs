//! The pinhole camera / projector model of the renderer (paper §4.1, eqs 1-4), in f64.
//!
//! Conventions: OpenCV frame (x right, y down, z forward), pixel centres at integer coordinates,
//! distortion `[k1, k2, p1, p2, k3]` (the paper's `[k1, k2, k3, k4, k5]`), skew α as in eq 4:
//!
//! ```text
//! x_n = X/Z, y_n = Y/Z,  r² = x_n² + y_n²
//! x_d = x_n·(1 + k1 r² + k2 r⁴ + k3 r⁶) + 2 p1 x_n y_n + p2 (r² + 2 x_n²)
//! y_d = y_n·(1 + k1 r² + k2 r⁴ + k3 r⁶) + p1 (r² + 2 y_n²) + 2 p2 x_n y_n
//! u = fx·x_d + α·fx·y_d + cx,   v = fy·y_d + cy
//! ```
//!
//! This is the renderer's own implementation — deliberately not shared with the core's camera
//! code — so that tests comparing the two are independent.

use super::math::Vec3;
pub use fringe3d_core::params::CameraParams;

/// Largest normalized radius the forward model is used at when no turning point limits it:
/// 3 (≈ 72° off axis).
const R_CAP: f64 = 3.0;

/// The renderer's own lens math (eqs 2-4 and the inverse of eq 3) over the shared
/// [`CameraParams`] of a camera or a projector (the projector is an inverted camera whose
/// "pixels" are the DMD mirrors: ξ = u, η = v).
pub trait LensModel {
    /// Check that the parameters are finite and sensible; `what` names the device in the message.
    fn validate(&self, what: &str) -> Result<(), String>;

    /// Apply the lens distortion (eq 3) to normalized coordinates.
    fn distort(&self, x: f64, y: f64) -> (f64, f64);

    /// Distorted normalized coordinates → pixel (eq 4).
    fn to_pixel(&self, xd: f64, yd: f64) -> (f64, f64);

    /// Pixel → distorted normalized coordinates (inverse of eq 4).
    fn pixel_to_distorted(&self, u: f64, v: f64) -> (f64, f64);

    /// The normalized radius beyond which the model is not used: just inside the first radius
    /// where the radial map `r·(1 + k1 r² + k2 r⁴ + k3 r⁶)` stops increasing (the lens "folds
    /// over"), capped at 3. Points beyond it are outside the device's field.
    fn max_radius(&self) -> f64;

    /// Project normalized undistorted coordinates to a pixel; `None` beyond [`max_radius`].
    ///
    /// [`max_radius`]: LensModel::max_radius
    fn project_normalized(&self, x: f64, y: f64, r_max: f64) -> Option<(f64, f64)>;

    /// Project a point given in this device's frame (mm) to pixel coordinates. `None` if the point
    /// is not in front (z ≤ 0) or lies beyond the model's radius `r_max` (see [`max_radius`]).
    ///
    /// [`max_radius`]: LensModel::max_radius
    fn project(&self, p: Vec3, r_max: f64) -> Option<(f64, f64)>;

    /// Invert the distortion: the undistorted normalized coordinates `(x, y)` whose projection is
    /// pixel `(u, v)`, by Newton's method from `guess` (or from the distorted coordinates) until the
    /// reprojection residual is below 1e-12 px. `None` if it does not converge within `r_max`.
    fn undistort_pixel(
        &self,
        u: f64,
        v: f64,
        guess: Option<(f64, f64)>,
        r_max: f64,
    ) -> Option<(f64, f64)>;

    /// The viewing ray of pixel `(u, v)`: direction `(x, y, 1)` in the device frame.
    fn pixel_ray(&self, u: f64, v: f64, r_max: f64) -> Option<Vec3>;

    /// The same model for an image resized by `scale` (pixel centres stay at integers: a new pixel
    /// `u'` covers the old `(u' + 0.5)/scale − 0.5`).
    fn scaled(&self, width: u32, height: u32) -> CameraParams;
}

/// The radial part `1 + k1 r² + k2 r⁴ + k3 r⁶`.
#[inline]
fn radial(c: &CameraParams, r2: f64) -> f64 {
    let [k1, k2, _, _, k3] = c.distortion.to_array();
    1.0 + r2 * (k1 + r2 * (k2 + r2 * k3))
}

impl LensModel for CameraParams {
    /// Check that the parameters are finite and sensible; `what` names the device in the message.
    fn validate(&self, what: &str) -> Result<(), String> {
        let all = [self.fx, self.fy, self.skew, self.cx, self.cy];
        if self.width == 0 || self.height == 0 {
            return Err(format!("{what}: width and height must be positive"));
        }
        if self.width > 32768 || self.height > 32768 {
            return Err(format!(
                "{what}: {}x{} is larger than 32768x32768",
                self.width, self.height
            ));
        }
        if !all
            .iter()
            .chain(self.distortion.to_array().iter())
            .all(|v| v.is_finite())
        {
            return Err(format!("{what}: intrinsics contain NaN or infinity"));
        }
        if !(self.fx > 0.0 && self.fy > 0.0) {
            return Err(format!("{what}: focal lengths must be positive"));
        }
        if self.max_radius() < 0.05 {
            return Err(format!(
                "{what}: radial distortion folds over within 3 degrees of the axis"
            ));
        }
        Ok(())
    }

    /// Apply the lens distortion (eq 3) to normalized coordinates.
    #[inline]
    fn distort(&self, x: f64, y: f64) -> (f64, f64) {
        let [_, _, p1, p2, _] = self.distortion.to_array();
        let r2 = x * x + y * y;
        let rad = radial(self, r2);
        let xy = x * y;
        (
            x * rad + 2.0 * p1 * xy + p2 * (r2 + 2.0 * x * x),
            y * rad + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * xy,
        )
    }

    /// Distorted normalized coordinates → pixel (eq 4).
    #[inline]
    fn to_pixel(&self, xd: f64, yd: f64) -> (f64, f64) {
        (
            self.fx * xd + self.skew * self.fx * yd + self.cx,
            self.fy * yd + self.cy,
        )
    }

    /// Pixel → distorted normalized coordinates (inverse of eq 4).
    #[inline]
    fn pixel_to_distorted(&self, u: f64, v: f64) -> (f64, f64) {
        let yd = (v - self.cy) / self.fy;
        ((u - self.cx) / self.fx - self.skew * yd, yd)
    }

    /// The normalized radius beyond which the model is not used: just inside the first radius
    /// where the radial map `r·(1 + k1 r² + k2 r⁴ + k3 r⁶)` stops increasing (the lens "folds
    /// over"), capped at 3. Points beyond it are outside the device's field.
    fn max_radius(&self) -> f64 {
        let [k1, k2, _, _, k3] = self.distortion.to_array();
        let deriv = |r: f64| {
            let r2 = r * r;
            1.0 + r2 * (3.0 * k1 + r2 * (5.0 * k2 + r2 * 7.0 * k3))
        };
        let n = 3000;
        let mut prev = 0.0;
        for i in 1..=n {
            let r = R_CAP * i as f64 / n as f64;
            if deriv(r) <= 0.05 {
                return prev;
            }
            prev = r;
        }
        R_CAP
    }

    /// Project normalized undistorted coordinates to a pixel; `None` beyond [`max_radius`].
    ///
    /// [`max_radius`]: LensModel::max_radius
    #[inline]
    fn project_normalized(&self, x: f64, y: f64, r_max: f64) -> Option<(f64, f64)> {
        if !(x * x + y * y <= r_max * r_max) {
            return None;
        }
        let (xd, yd) = self.distort(x, y);
        Some(self.to_pixel(xd, yd))
    }

    /// Project a point given in this device's frame (mm) to pixel coordinates. `None` if the point
    /// is not in front (z ≤ 0) or lies beyond the model's radius `r_max` (see [`max_radius`]).
    ///
    /// [`max_radius`]: LensModel::max_radius
    #[inline]
    fn project(&self, p: Vec3, r_max: f64) -> Option<(f64, f64)> {
        if !(p.z > 0.0) {
            return None;
        }
        self.project_normalized(p.x / p.z, p.y / p.z, r_max)
    }

    /// Invert the distortion: the undistorted normalized coordinates `(x, y)` whose projection is
    /// pixel `(u, v)`, by Newton's method from `guess` (or from the distorted coordinates) until the
    /// reprojection residual is below 1e-12 px. `None` if it does not converge within `r_max`.
    fn undistort_pixel(
        &self,
        u: f64,
        v: f64,
        guess: Option<(f64, f64)>,
        r_max: f64,
    ) -> Option<(f64, f64)> {
        let (xd, yd) = self.pixel_to_distorted(u, v);
        let [k1, k2, p1, p2, k3] = self.distortion.to_array();
        if k1 == 0.0 && k2 == 0.0 && k3 == 0.0 && p1 == 0.0 && p2 == 0.0 {
            return Some((xd, yd));
        }
        let (mut x, mut y) = guess.unwrap_or((xd, yd));
        // Squared residual in pixels: the distorted error mapped through A (eq 4).
        let px2 = |ex: f64, ey: f64| {
            let du = self.fx * (ex + self.skew * ey);
            let dv = self.fy * ey;
            du * du + dv * dv
        };
        let mut best = (f64::INFINITY, x, y);
        for _ in 0..60 {
            let r2 = x * x + y * y;
            if !(r2 <= r_max * r_max * 1.0001) {
                // Restart from the distorted point once if a poor guess wandered off.
                return None;
            }
            let (fx_, fy_) = self.distort(x, y);
            let (ex, ey) = (fx_ - xd, fy_ - yd);
            let res = px2(ex, ey);
            if res < best.0 {
                best = (res, x, y);
            }
            if res < 1e-24 {
                return Some((x, y));
            }
            let rad = radial(self, r2);
            let drad = k1 + r2 * (2.0 * k2 + r2 * 3.0 * k3);
            let j11 = rad + 2.0 * x * x * drad + 2.0 * p1 * y + 6.0 * p2 * x;
            let j12 = 2.0 * x * y * drad + 2.0 * p1 * x + 2.0 * p2 * y;
            let j21 = 2.0 * x * y * drad + 2.0 * p1 * x + 2.0 * p2 * y;
            let j22 = rad + 2.0 * y * y * drad + 6.0 * p1 * y + 2.0 * p2 * x;
            let det = j11 * j22 - j12 * j21;
            if !(det.abs() > 1e-12) {
                return None;
            }
            x -= (j22 * ex - j12 * ey) / det;
            y -= (-j21 * ex + j11 * ey) / det;
        }
        // f64 rounding can keep the residual a hair above 1e-12 px at the rim of wide lenses;
        // accept what is within 1e-9 px (still far below every effect being modelled).
        (best.0 < 1e-18).then_some((best.1, best.2))
    }

    /// The viewing ray of pixel `(u, v)`: direction `(x, y, 1)` in the device frame.
    fn pixel_ray(&self, u: f64, v: f64, r_max: f64) -> Option<Vec3> {
        self.undistort_pixel(u, v, None, r_max)
            .map(|(x, y)| Vec3::new(x, y, 1.0))
    }

    /// The same model for an image resized by `scale` (pixel centres stay at integers: a new pixel
    /// `u'` covers the old `(u' + 0.5)/scale − 0.5`).
    fn scaled(&self, width: u32, height: u32) -> CameraParams {
        let sx = width as f64 / self.width as f64;
        let sy = height as f64 / self.height as f64;
        CameraParams {
            width,
            height,
            fx: self.fx * sx,
            fy: self.fy * sy,
            // α·fx·y_d scales with fx, so α stays.
            skew: self.skew * 1.0,
            cx: (self.cx + 0.5) * sx - 0.5,
            cy: (self.cy + 0.5) * sy - 0.5,
            distortion: self.distortion,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn nasty() -> CameraParams {
        CameraParams {
            width: 1280,
            height: 1024,
            fx: 1550.0,
            fy: 1545.0,
            skew: 0.002,
            cx: 641.3,
            cy: 509.8,
            distortion: [-0.2, 0.15, 0.001, -0.0015, -0.05].into(),
        }
    }

    #[test]
    fn undistort_inverts_distort_to_1e12_px() {
        let c = nasty();
        let rm = c.max_radius();
        for &(u, v) in &[
            (0.0, 0.0),
            (1279.0, 1023.0),
            (640.0, 512.0),
            (100.5, 900.25),
            (1279.0, 0.0),
        ] {
            let (x, y) = c.undistort_pixel(u, v, None, rm).unwrap();
            let (uu, vv) = c.project_normalized(x, y, rm).unwrap();
            assert!(
                (uu - u).abs() < 1e-10 && (vv - v).abs() < 1e-10,
                "{u} {v} -> {uu} {vv}"
            );
        }
    }

    #[test]
    fn scaled_keeps_rays() {
        let c = nasty();
        let s = c.scaled(640, 512);
        let rm = c.max_radius();
        // New pixel 10 covers old pixels 20.5 (its centre).
        let a = c.pixel_ray(20.5, 40.5, rm).unwrap();
        let b = s.pixel_ray(10.0, 20.0, rm).unwrap();
        assert!((a - b).norm() < 1e-12);
    }
}
