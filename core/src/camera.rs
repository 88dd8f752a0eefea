//! The pinhole camera with Brown–Conrady ("Plumb Bob") lens distortion (paper §4.1, eqs 1-4),
//! forward and inverse.
//!
//! # Conventions
//! - Camera frame: OpenCV convention, x right, y down, z forward, millimetres. The paper puts the
//!   image plane at z = −1 and divides by −z (eq 2); we put it at **z = +1** and divide by +z, so
//!   the normalized coordinates of a point `(X, Y, Z)` in front of the camera are
//!   `x_n = X/Z, y_n = Y/Z` with `Z > 0`. The ray of a pixel is `(x_n, y_n, 1)`.
//! - Pixel centres are at integer coordinates: pixel `(u, v)` covers `[u − ½, u + ½) × [v − ½, v + ½)`.
//! - Distortion coefficients in OpenCV order `[k1, k2, p1, p2, k3]`, which are the paper's
//!   `[k1, k2, k3, k4, k5]` of eq 3 (radial k1, k2, k5 = our k3; tangential k3, k4 = our p1, p2).
//! - The intrinsic matrix of eq 4 includes the paper's skew α:
//!   `u = fx·x_d + α·fx·y_d + cx`, `v = fy·y_d + cy` ([`CameraParams`]).
//!
//! # Inverse
//! Undistortion (normalized distorted → normalized ideal coordinates) has no closed form. It runs
//! Newton's method on the full 2-D model (radial + tangential) for a **fixed** number of
//! iterations, [`UNDISTORT_ITERATIONS`], starting from the distorted coordinates.
//! [`CameraModel::new`] refuses a model it cannot invert over the image: it checks that the radial
//! profile `ρ(r) = r·(1 + k1 r² + k2 r⁴ + k3 r⁶)` is strictly increasing over the radii the image
//! needs, and that the fixed iteration count converges to ≤ [`UNDISTORT_TOLERANCE_PX`] (f64) at
//! every border pixel and on a 16-pixel grid of the interior, onto the monotonic branch. The f32
//! per-pixel paths are checked the same way against [`UNDISTORT_TOLERANCE_F32_PX`] (their floor is
//! f32 rounding, ~1e-4 px, not convergence).

use crate::geometry::Vec3;
pub use crate::params::{CameraParams, Distortion};

/// Newton iterations of [`CameraModel::undistort`] / [`CameraModel::undistort_f32`].
pub const UNDISTORT_ITERATIONS: usize = 8;
/// Largest accepted round-trip error `|project(undistort(p)) − p|` of the f64 inverse, pixels.
pub const UNDISTORT_TOLERANCE_PX: f64 = 1e-4;
/// Largest accepted round-trip error of the f32 inverses (measured in f64 from the f32 result),
/// pixels. f32 rounding alone is ~1e-4 px at the edge of a 1280-pixel image.
pub const UNDISTORT_TOLERANCE_F32_PX: f64 = 1e-3;
/// Column spacing of the knots of [`CameraModel::undistort_row_f32`].
pub const ROW_KNOT_STEP: usize = 32;
/// Most knots of one row: `MAX_DIMENSION / ROW_KNOT_STEP + 1`.
pub const MAX_ROW_KNOTS: usize = MAX_DIMENSION as usize / ROW_KNOT_STEP + 1;
/// `0.0, 1.0, …, (ROW_KNOT_STEP − 1) as f32`.
const KNOT_OFFSETS_F32: [f32; ROW_KNOT_STEP] = {
    let mut a = [0f32; ROW_KNOT_STEP];
    let mut j = 0;
    while j < ROW_KNOT_STEP {
        a[j] = j as f32;
        j += 1;
    }
    a
};
/// Largest image side accepted.
pub const MAX_DIMENSION: u32 = 16384;
/// Grid step (pixels) of the interior convergence check of [`CameraModel::new`].
const CHECK_GRID: u32 = 16;

/// Why a camera model was refused.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum CameraError {
    /// A parameter is NaN or infinite.
    NotFinite,
    /// `fx` or `fy` is not positive.
    NonPositiveFocal,
    /// |skew| ≥ 0.5: not a physical sensor.
    Skew,
    /// Width or height below 2 or above [`MAX_DIMENSION`].
    Size,
    /// The radial profile `ρ(r)` stops increasing (`dρ/dr ≤ 0`) at this undistorted radius before
    /// it covers the image: the distortion cannot be inverted over the field of view.
    NotMonotonic {
        /// Normalized radius where `dρ/dr ≤ 0`.
        radius: f32,
    },
    /// The fixed-count inverse does not reach the tolerance at this pixel (or lands off the
    /// monotonic branch).
    NotConvergent {
        /// Pixel column.
        u: u32,
        /// Pixel row.
        v: u32,
        /// Round-trip error there, pixels (infinite when the iteration diverged or left the branch).
        error_px: f32,
    },
}

/// Coarse classes of [`CameraError`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CameraErrorKind {
    /// A parameter is malformed.
    InvalidParameter,
    /// The distortion model cannot be inverted over the image.
    NotInvertible,
}

impl CameraError {
    /// The coarse class of the error.
    pub fn kind(&self) -> CameraErrorKind {
        match self {
            Self::NotFinite | Self::NonPositiveFocal | Self::Skew | Self::Size => {
                CameraErrorKind::InvalidParameter
            }
            Self::NotMonotonic { .. } | Self::NotConvergent { .. } => {
                CameraErrorKind::NotInvertible
            }
        }
    }
}

impl core::fmt::Display for CameraError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::NotFinite => f.write_str("a camera parameter is NaN or infinite"),
            Self::NonPositiveFocal => f.write_str("fx and fy must be positive"),
            Self::Skew => f.write_str("|skew| must be below 0.5"),
            Self::Size => write!(f, "image width and height must be in 2..={MAX_DIMENSION}"),
            Self::NotMonotonic { radius } => write!(
                f,
                "radial distortion is not monotonic (dρ/dr ≤ 0 at normalized radius {radius}): not invertible over the image"
            ),
            Self::NotConvergent { u, v, error_px } => write!(
                f,
                "undistortion does not converge at pixel ({u}, {v}): round-trip error {error_px} px"
            ),
        }
    }
}

/// f32 copies of the parameters for the per-pixel paths.
#[derive(Clone, Copy, Debug, PartialEq)]
struct F32Params {
    fx: f32,
    fy: f32,
    sfx: f32,
    u0: f32,
    v0: f32,
    k1: f32,
    k2: f32,
    p1: f32,
    p2: f32,
    k3: f32,
}

/// What [`CameraModel::new`]'s checks of the inverse found: the costly part of building a model
/// (the inverse run over the image's border, a 16-pixel grid and every 16th row, in f64, which a
/// Cortex-M4F does in software: about 100 M instructions at 320 × 240). A desktop reads it off
/// its model ([`CameraModel::check`]) and ships it in the head set-up blob (field 10); the head
/// builds the same model from it ([`CameraModel::from_check`]) without running the inverse.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct CameraCheck {
    /// Undistorted radius up to which `ρ(r)` was verified strictly increasing.
    pub monotonic_radius: f64,
    /// Worst round-trip error of the f64 inverse, pixels.
    pub max_error_f64: f64,
    /// Worst round-trip error of the f32 inverses, pixels.
    pub max_error_f32: f64,
}

impl CameraCheck {
    /// Whether the numbers are ones the checks can give: a finite, non-negative radius, and
    /// errors within [`UNDISTORT_TOLERANCE_PX`] and [`UNDISTORT_TOLERANCE_F32_PX`].
    pub fn is_sane(&self) -> bool {
        let within = |e: f64, tol: f64| e >= 0.0 && e <= tol;
        self.monotonic_radius.is_finite()
            && self.monotonic_radius >= 0.0
            && within(self.max_error_f64, UNDISTORT_TOLERANCE_PX)
            && within(self.max_error_f32, UNDISTORT_TOLERANCE_F32_PX)
    }
}

/// A validated, invertible camera model (eqs 2-4 and their inverse).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CameraModel {
    params: CameraParams,
    f: F32Params,
    /// Radius up to which ρ(r) was verified strictly increasing.
    monotonic_radius: f64,
    max_error_f64: f64,
    max_error_f32: f64,
}

/// The distortion of eq 3 and its Jacobian, generic over the float type.
macro_rules! distort_fns {
    ($T:ty, $name:ident, $name_jac:ident, $undist:ident) => {
        /// Eq 3: ideal normalized → distorted normalized.
        #[inline(always)]
        fn $name(k: [$T; 5], x: $T, y: $T) -> ($T, $T) {
            let [k1, k2, p1, p2, k3] = k;
            let r2 = x * x + y * y;
            let radial = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3));
            let xy = x * y;
            let dx = x * radial + (2.0 * p1 * xy + p2 * (r2 + 2.0 * x * x));
            let dy = y * radial + (p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * xy);
            (dx, dy)
        }

        /// Eq 3 and its (symmetric) Jacobian `[[j00, j01], [j01, j11]]`.
        #[inline(always)]
        fn $name_jac(k: [$T; 5], x: $T, y: $T) -> ($T, $T, $T, $T, $T) {
            let [k1, k2, p1, p2, k3] = k;
            let r2 = x * x + y * y;
            let radial = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3));
            // dR/d(r²)
            let dr = k1 + r2 * (2.0 * k2 + r2 * (3.0 * k3));
            let xy = x * y;
            let dx = x * radial + (2.0 * p1 * xy + p2 * (r2 + 2.0 * x * x));
            let dy = y * radial + (p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * xy);
            let j00 = radial + 2.0 * x * x * dr + (2.0 * p1 * y + 6.0 * p2 * x);
            let j01 = 2.0 * xy * dr + (2.0 * p1 * x + 2.0 * p2 * y);
            let j11 = radial + 2.0 * y * y * dr + (6.0 * p1 * y + 2.0 * p2 * x);
            (dx, dy, j00, j01, j11)
        }

        /// Newton's method on eq 3 for a fixed number of iterations from `(gx, gy)`.
        #[inline(always)]
        fn $undist(k: [$T; 5], xd: $T, yd: $T, gx: $T, gy: $T, iterations: usize) -> ($T, $T) {
            let mut x = gx;
            let mut y = gy;
            for _ in 0..iterations {
                let (dx, dy, j00, j01, j11) = $name_jac(k, x, y);
                let rx = dx - xd;
                let ry = dy - yd;
                let det = j00 * j11 - j01 * j01;
                x -= (j11 * rx - j01 * ry) / det;
                y -= (j00 * ry - j01 * rx) / det;
            }
            (x, y)
        }
    };
}

distort_fns!(f64, distort64, distort_jac64, newton64);
distort_fns!(f32, distort32, distort_jac32, newton32);

/// The parameters' own checks (finite, positive focal lengths, skew, size) and their f32 copy.
fn f32_params(params: &CameraParams) -> Result<F32Params, CameraError> {
    let i = params;
    let d = params.distortion;
    if !params.is_finite() {
        return Err(CameraError::NotFinite);
    }
    if !(i.fx > 0.0 && i.fy > 0.0) {
        return Err(CameraError::NonPositiveFocal);
    }
    if !(libm::fabs(i.skew) < 0.5) {
        return Err(CameraError::Skew);
    }
    if !(2..=MAX_DIMENSION).contains(&i.width) || !(2..=MAX_DIMENSION).contains(&i.height) {
        return Err(CameraError::Size);
    }
    Ok(F32Params {
        fx: i.fx as f32,
        fy: i.fy as f32,
        sfx: (i.skew * i.fx) as f32,
        u0: i.cx as f32,
        v0: i.cy as f32,
        k1: d.k1 as f32,
        k2: d.k2 as f32,
        p1: d.p1 as f32,
        p2: d.p2 as f32,
        k3: d.k3 as f32,
    })
}

impl CameraModel {
    /// Validate a model and check that it can be inverted over the whole image (see the module
    /// documentation).
    pub fn new(params: CameraParams) -> Result<Self, CameraError> {
        let mut cam = CameraModel {
            params,
            f: f32_params(&params)?,
            monotonic_radius: 0.0,
            max_error_f64: 0.0,
            max_error_f32: 0.0,
        };
        cam.monotonic_radius = cam.check_monotonic()?;
        cam.check_convergence()?;
        Ok(cam)
    }

    /// The model [`CameraModel::new`] makes of `params`, from what its checks found
    /// ([`CameraModel::check`], computed on a desktop) instead of running them again: the
    /// parameters' own checks are made, the inverse is not run. A check that is not
    /// [sane](CameraCheck::is_sane) is refused ([`CameraError::NotMonotonic`] for its radius,
    /// [`CameraError::NotConvergent`] at pixel (0, 0) for its errors); a sane one of other
    /// parameters is not detected here (the set-up blob's CRC and its maker vouch for it).
    pub fn from_check(params: CameraParams, c: &CameraCheck) -> Result<Self, CameraError> {
        let f = f32_params(&params)?;
        if !c.is_sane() {
            if !(c.monotonic_radius.is_finite() && c.monotonic_radius >= 0.0) {
                let radius = c.monotonic_radius as f32;
                return Err(CameraError::NotMonotonic { radius });
            }
            let worst = if c.max_error_f64 > c.max_error_f32 || c.max_error_f64.is_nan() {
                c.max_error_f64
            } else {
                c.max_error_f32
            };
            let error_px = worst as f32;
            return Err(CameraError::NotConvergent {
                u: 0,
                v: 0,
                error_px,
            });
        }
        Ok(CameraModel {
            params,
            f,
            monotonic_radius: c.monotonic_radius,
            max_error_f64: c.max_error_f64,
            max_error_f32: c.max_error_f32,
        })
    }

    /// What this model's checks found: what [`CameraModel::from_check`] takes to make it again,
    /// bit for bit.
    pub fn check(&self) -> CameraCheck {
        CameraCheck {
            monotonic_radius: self.monotonic_radius,
            max_error_f64: self.max_error_f64,
            max_error_f32: self.max_error_f32,
        }
    }

    /// Scan `ρ(r) = r·R(r²)` from 0 until it exceeds the largest distorted radius of the image
    /// (plus 5 % and a bound on the tangential terms); `dρ/dr` must stay positive on the way.
    /// Returns the radius reached.
    fn check_monotonic(&self) -> Result<f64, CameraError> {
        let w = (self.params.width - 1) as f64;
        let h = (self.params.height - 1) as f64;
        // The image rectangle is convex and the norm convex: the largest distorted radius is at a
        // corner.
        let mut rd_max: f64 = 0.0;
        for (u, v) in [(0.0, 0.0), (w, 0.0), (0.0, h), (w, h)] {
            let [x, y] = self.pixel_to_distorted([u, v]);
            rd_max = rd_max.max(libm::sqrt(x * x + y * y));
        }
        let Distortion { k1, k2, p1, p2, k3 } = self.params.distortion;
        let tang = 3.0 * (libm::fabs(p1) + libm::fabs(p2));
        let step = rd_max / 1024.0 + 1e-9;
        let mut r = 0.0;
        for _ in 0..(1024 * 16) {
            let r2 = r * r;
            let slope = 1.0 + r2 * (3.0 * k1 + r2 * (5.0 * k2 + r2 * (7.0 * k3)));
            if !(slope > 0.0) {
                return Err(CameraError::NotMonotonic { radius: r as f32 });
            }
            let rho = r * (1.0 + r2 * (k1 + r2 * (k2 + r2 * k3)));
            if rho >= 1.05 * rd_max + tang * r2 + 1e-6 {
                return Ok(r);
            }
            r += step;
        }
        Err(CameraError::NotMonotonic { radius: r as f32 })
    }

    /// Run both inverses over the border and a grid of the interior, and the row inverse over
    /// a subset of rows; record the worst errors.
    fn check_convergence(&mut self) -> Result<(), CameraError> {
        let w = self.params.width;
        let h = self.params.height;
        let mut worst64: f64 = 0.0;
        let mut worst32: f64 = 0.0;
        let mut check = |cam: &Self, u: u32, v: u32| -> Result<(), CameraError> {
            let p = [u as f64, v as f64];
            let fail = |e: f64| CameraError::NotConvergent {
                u,
                v,
                error_px: e as f32,
            };
            let n = cam.pixel_to_normalized(p);
            let e64 = cam.round_trip_error(n, p);
            if !(e64 <= UNDISTORT_TOLERANCE_PX) {
                return Err(fail(e64));
            }
            let n32 = cam.pixel_to_normalized_f32([u as f32, v as f32]);
            let e32 = cam.round_trip_error([n32[0] as f64, n32[1] as f64], p);
            if !(e32 <= UNDISTORT_TOLERANCE_F32_PX) {
                return Err(fail(e32));
            }
            worst64 = worst64.max(e64);
            worst32 = worst32.max(e32);
            Ok(())
        };
        for u in 0..w {
            check(self, u, 0)?;
            check(self, u, h - 1)?;
        }
        for v in 1..h - 1 {
            check(self, 0, v)?;
            check(self, w - 1, v)?;
        }
        let mut v = CHECK_GRID;
        while v < h - 1 {
            let mut u = CHECK_GRID;
            while u < w - 1 {
                check(self, u, v)?;
                u += CHECK_GRID;
            }
            v += CHECK_GRID;
        }
        // The row inverse (knots + one Newton step): first, last and every 16th row, all columns.
        let mut kx = [0f32; MAX_ROW_KNOTS];
        let mut ky = [0f32; MAX_ROW_KNOTS];
        let mut xs = [0f32; ROW_KNOT_STEP];
        let mut ys = [0f32; ROW_KNOT_STEP];
        let mut v = 0;
        loop {
            let nk = self.row_knots_f32(v, &mut kx, &mut ky);
            let knot = |j: usize| {
                let j = j.min(nk.saturating_sub(1));
                [kx[j], ky[j]]
            };
            let mut c0 = 0usize;
            while c0 < w as usize {
                let n = (w as usize - c0).min(ROW_KNOT_STEP);
                let j = c0 / ROW_KNOT_STEP;
                self.undistort_span_from_knots_f32(v, c0, knot(j), knot(j + 1), &mut xs, &mut ys);
                for k in 0..n {
                    let p = [(c0 + k) as f64, v as f64];
                    let e = self.round_trip_error([xs[k] as f64, ys[k] as f64], p);
                    if !(e <= UNDISTORT_TOLERANCE_F32_PX) {
                        return Err(CameraError::NotConvergent {
                            u: (c0 + k) as u32,
                            v,
                            error_px: e as f32,
                        });
                    }
                    worst32 = worst32.max(e);
                }
                c0 += n;
            }
            if v == h - 1 {
                break;
            }
            v = (v + CHECK_GRID).min(h - 1);
        }
        self.max_error_f64 = worst64;
        self.max_error_f32 = worst32;
        Ok(())
    }

    /// `|normalized_to_pixel(n) − p|`, or infinity if `n` is not finite or lies off the verified
    /// monotonic branch of the radial profile.
    fn round_trip_error(&self, n: [f64; 2], p: [f64; 2]) -> f64 {
        let r = libm::sqrt(n[0] * n[0] + n[1] * n[1]);
        if !(r <= self.monotonic_radius) {
            return f64::INFINITY;
        }
        let q = self.normalized_to_pixel(n);
        let du = q[0] - p[0];
        let dv = q[1] - p[1];
        let e = libm::sqrt(du * du + dv * dv);
        if e.is_finite() { e } else { f64::INFINITY }
    }

    /// The parameters the model was built from.
    pub fn params(&self) -> &CameraParams {
        &self.params
    }

    /// The distortion coefficients.
    pub fn distortion(&self) -> &Distortion {
        &self.params.distortion
    }

    /// Image width, pixels.
    pub fn width(&self) -> u32 {
        self.params.width
    }

    /// Image height, pixels.
    pub fn height(&self) -> u32 {
        self.params.height
    }

    /// Worst round-trip error of the f64 inverse found by the construction check, pixels.
    pub fn max_undistort_error_px(&self) -> f64 {
        self.max_error_f64
    }

    /// Worst round-trip error of the f32 inverses found by the construction check, pixels.
    pub fn max_undistort_error_f32_px(&self) -> f64 {
        self.max_error_f32
    }

    /// The normalized radius up to which the radial profile was verified strictly increasing.
    pub fn monotonic_radius(&self) -> f64 {
        self.monotonic_radius
    }

    fn k64(&self) -> [f64; 5] {
        let d = self.params.distortion;
        [d.k1, d.k2, d.p1, d.p2, d.k3]
    }

    fn k32(&self) -> [f32; 5] {
        let f = self.f;
        [f.k1, f.k2, f.p1, f.p2, f.k3]
    }

    // ----- f64 -----

    /// Eq 3: ideal normalized coordinates → distorted normalized coordinates.
    #[inline]
    pub fn distort(&self, n: [f64; 2]) -> [f64; 2] {
        let (x, y) = distort64(self.k64(), n[0], n[1]);
        [x, y]
    }

    /// Eq 4: distorted normalized coordinates → pixel coordinates.
    #[inline]
    pub fn distorted_to_pixel(&self, d: [f64; 2]) -> [f64; 2] {
        let i = &self.params;
        [
            i.fx * d[0] + i.skew * i.fx * d[1] + i.cx,
            i.fy * d[1] + i.cy,
        ]
    }

    /// Inverse of eq 4: pixel coordinates → distorted normalized coordinates.
    pub fn pixel_to_distorted(&self, p: [f64; 2]) -> [f64; 2] {
        let i = &self.params;
        let yd = (p[1] - i.cy) / i.fy;
        let xd = (p[0] - i.cx - i.skew * i.fx * yd) / i.fx;
        [xd, yd]
    }

    /// Eqs 3-4: ideal normalized coordinates → pixel coordinates.
    #[inline]
    pub fn normalized_to_pixel(&self, n: [f64; 2]) -> [f64; 2] {
        self.distorted_to_pixel(self.distort(n))
    }

    /// Eqs 2-4: a camera-frame point → pixel coordinates; `None` unless the point is in front of
    /// the camera (z > 0; the paper's eq 2 divides by −z for its image plane at z = −1, we divide
    /// by +z for ours at z = +1). The result may lie outside the image.
    pub fn project(&self, p: Vec3) -> Option<[f64; 2]> {
        if !(p.z > 0.0) || !p.is_finite() {
            return None;
        }
        Some(self.normalized_to_pixel([p.x / p.z, p.y / p.z]))
    }

    /// Inverse of eq 3: distorted → ideal normalized coordinates, by [`UNDISTORT_ITERATIONS`]
    /// Newton steps from `d`. Converged to ≤ [`UNDISTORT_TOLERANCE_PX`] over the image (checked at
    /// construction); outside the image no guarantee. NaN in, NaN out.
    pub fn undistort(&self, d: [f64; 2]) -> [f64; 2] {
        let (x, y) = newton64(self.k64(), d[0], d[1], d[0], d[1], UNDISTORT_ITERATIONS);
        [x, y]
    }

    /// Pixel coordinates → ideal normalized coordinates (inverse of eqs 3-4).
    pub fn pixel_to_normalized(&self, p: [f64; 2]) -> [f64; 2] {
        self.undistort(self.pixel_to_distorted(p))
    }

    /// The ray of a pixel, `(x_n, y_n, 1)`: the direction `CM_I` of §6 with the camera centre C at
    /// the origin (image plane z = +1).
    pub fn pixel_to_ray(&self, p: [f64; 2]) -> Vec3 {
        let [x, y] = self.pixel_to_normalized(p);
        Vec3::new(x, y, 1.0)
    }

    // ----- f32 -----

    /// Eq 3 in f32.
    #[inline]
    pub fn distort_f32(&self, n: [f32; 2]) -> [f32; 2] {
        let (x, y) = distort32(self.k32(), n[0], n[1]);
        [x, y]
    }

    /// Eq 3 and its Jacobian in f32: `(x_d, y_d, ∂x_d/∂x, ∂x_d/∂y = ∂y_d/∂x, ∂y_d/∂y)`.
    #[inline]
    pub fn distort_jacobian_f32(&self, n: [f32; 2]) -> (f32, f32, f32, f32, f32) {
        distort_jac32(self.k32(), n[0], n[1])
    }

    /// Eq 4 in f32.
    #[inline]
    pub fn distorted_to_pixel_f32(&self, d: [f32; 2]) -> [f32; 2] {
        let f = &self.f;
        [f.fx * d[0] + f.sfx * d[1] + f.u0, f.fy * d[1] + f.v0]
    }

    /// Inverse of eq 4 in f32.
    #[inline]
    pub fn pixel_to_distorted_f32(&self, p: [f32; 2]) -> [f32; 2] {
        let f = &self.f;
        let yd = (p[1] - f.v0) / f.fy;
        let xd = (p[0] - f.u0 - f.sfx * yd) / f.fx;
        [xd, yd]
    }

    /// Eqs 3-4 in f32.
    #[inline]
    pub fn normalized_to_pixel_f32(&self, n: [f32; 2]) -> [f32; 2] {
        self.distorted_to_pixel_f32(self.distort_f32(n))
    }

    /// Inverse of eq 3 in f32 ([`UNDISTORT_ITERATIONS`] Newton steps from `d`).
    #[inline]
    pub fn undistort_f32(&self, d: [f32; 2]) -> [f32; 2] {
        let (x, y) = newton32(self.k32(), d[0], d[1], d[0], d[1], UNDISTORT_ITERATIONS);
        [x, y]
    }

    /// Pixel → ideal normalized coordinates in f32.
    #[inline]
    pub fn pixel_to_normalized_f32(&self, p: [f32; 2]) -> [f32; 2] {
        self.undistort_f32(self.pixel_to_distorted_f32(p))
    }

    /// The knots of row `v` for [`CameraModel::undistort_span_from_knots_f32`]: the ideal normalized
    /// coordinates of columns `0, S, 2S, …` (`S` = [`ROW_KNOT_STEP`]) and of the last column, by
    /// [`UNDISTORT_ITERATIONS`] Newton steps each (iterations outermost, so the loop over knots
    /// vectorizes). Returns the number of knots written (≤ [`MAX_ROW_KNOTS`] and ≤ the buffers).
    #[inline(always)]
    pub fn row_knots_f32(&self, v: u32, xs: &mut [f32], ys: &mut [f32]) -> usize {
        self.row_knots_span_f32(v, 0, xs, ys)
    }

    /// The knots `j0, j0 + 1, …` of [`CameraModel::row_knots_f32`] (columns `j0·S, …`), the
    /// same bits (each knot is computed alone), for a caller that needs a few chunks of a row.
    /// Returns the number written: up to the buffers' length, [`MAX_ROW_KNOTS`] and the row's
    /// last knot.
    #[inline(always)]
    pub fn row_knots_span_f32(&self, v: u32, j0: usize, xs: &mut [f32], ys: &mut [f32]) -> usize {
        let w = self.params.width as usize;
        let nk = (w.div_ceil(ROW_KNOT_STEP) + 1)
            .saturating_sub(j0)
            .min(xs.len())
            .min(ys.len())
            .min(MAX_ROW_KNOTS);
        let f = self.f;
        let vf = v as f32;
        let yd = (vf - f.v0) / f.fy;
        let xoff = f.u0 + f.sfx * yd;
        let mut xd = [0f32; MAX_ROW_KNOTS];
        for (j, d) in xd.iter_mut().enumerate().take(nk) {
            let col = ((j0 + j) * ROW_KNOT_STEP).min(w - 1);
            *d = (col as f32 - xoff) / f.fx;
        }
        let (xs, ys, xd) = (&mut xs[..nk], &mut ys[..nk], &xd[..nk]);
        xs.copy_from_slice(xd);
        for y in ys.iter_mut() {
            *y = yd;
        }
        let k = self.k32();
        for _ in 0..UNDISTORT_ITERATIONS {
            for ((x, y), &d) in xs.iter_mut().zip(ys.iter_mut()).zip(xd) {
                let (nx, ny) = newton32(k, d, yd, *x, *y, 1);
                *x = nx;
                *y = ny;
            }
        }
        nk
    }

    /// Ideal normalized coordinates of the [`ROW_KNOT_STEP`] pixels `(c0 + k, v)` of one row, for
    /// the per-pixel path, from the knots `ka` (column `c0`, rounded down to a multiple of
    /// [`ROW_KNOT_STEP`]) and `kb` (column `min(c0 + ROW_KNOT_STEP, width − 1)`) of
    /// [`CameraModel::row_knots_f32`]: linear interpolation between them as the start, then one
    /// Newton step per pixel (a fixed-width loop that vectorizes). Checked at construction on the
    /// first, last and every 16th row; columns past the image are extrapolated, without guarantee.
    #[inline(always)]
    pub fn undistort_span_from_knots_f32(
        &self,
        v: u32,
        c0: usize,
        ka: [f32; 2],
        kb: [f32; 2],
        xs: &mut [f32; ROW_KNOT_STEP],
        ys: &mut [f32; ROW_KNOT_STEP],
    ) {
        let w = self.params.width as usize;
        let c_a = c0 - c0 % ROW_KNOT_STEP;
        let c_b = (c_a + ROW_KNOT_STEP).min(w.saturating_sub(1)).max(c_a);
        let span = if c_b > c_a {
            1.0 / (c_b - c_a) as f32
        } else {
            0.0
        };
        let k = self.k32();
        let f = self.f;
        let yd = (v as f32 - f.v0) / f.fy;
        let xoff = f.u0 + f.sfx * yd;
        let caf = c_a as f32;
        for j in 0..ROW_KNOT_STEP {
            // `j as f32` from a table and `c_a + j` as a sum of exact f32 integers: no per-lane
            // integer conversion (which does not vectorize for usize); same values.
            let jf = KNOT_OFFSETS_F32[j];
            let wgt = jf * span;
            let gx = ka[0] + wgt * (kb[0] - ka[0]);
            let gy = ka[1] + wgt * (kb[1] - ka[1]);
            let xd = ((caf + jf) - xoff) / f.fx;
            let (x, y) = newton32(k, xd, yd, gx, gy, 1);
            xs[j] = x;
            ys[j] = y;
        }
    }

    /// Ideal normalized coordinates of every pixel of row `v` (see
    /// [`CameraModel::undistort_span_from_knots_f32`]); writes `min(xs.len(), ys.len(), width)`
    /// pixels.
    pub fn undistort_row_f32(&self, v: u32, xs: &mut [f32], ys: &mut [f32]) {
        let n = xs.len().min(ys.len()).min(self.params.width as usize);
        let mut kx = [0f32; MAX_ROW_KNOTS];
        let mut ky = [0f32; MAX_ROW_KNOTS];
        let nk = self.row_knots_f32(v, &mut kx, &mut ky);
        let knot = |j: usize| {
            let j = j.min(nk.saturating_sub(1));
            [kx[j], ky[j]]
        };
        let mut bx = [0f32; ROW_KNOT_STEP];
        let mut by = [0f32; ROW_KNOT_STEP];
        let mut c0 = 0;
        while c0 < n {
            let m = (n - c0).min(ROW_KNOT_STEP);
            let j = c0 / ROW_KNOT_STEP;
            self.undistort_span_from_knots_f32(v, c0, knot(j), knot(j + 1), &mut bx, &mut by);
            xs[c0..c0 + m].copy_from_slice(&bx[..m]);
            ys[c0..c0 + m].copy_from_slice(&by[..m]);
            c0 += m;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn params(k: [f64; 5]) -> CameraParams {
        CameraParams {
            width: 1280,
            height: 1024,
            fx: 1500.0,
            fy: 1502.0,
            cx: 641.5,
            cy: 509.25,
            skew: 0.001,
            distortion: Distortion::from_array(k),
        }
    }

    #[test]
    fn strong_barrel_is_accepted_and_round_trips() {
        let cam = CameraModel::new(params([-0.3, 0.1, 1e-3, -5e-4, 0.0])).unwrap();
        assert!(cam.max_undistort_error_px() <= 1e-4);
        let p = cam.normalized_to_pixel(cam.pixel_to_normalized([0.0, 0.0]));
        assert!((p[0]).abs() < 1e-4 && (p[1]).abs() < 1e-4);
    }

    #[test]
    fn fold_over_is_rejected() {
        let e = CameraModel::new(params([-1.2, 0.0, 0.0, 0.0, 0.0])).unwrap_err();
        assert_eq!(e.kind(), CameraErrorKind::NotInvertible);
    }
}
