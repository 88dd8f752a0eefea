//! Plausibility checks of a camera's parameters as a file states them: the calibration file and
//! the OpenCV / Bouguet importers apply the same limits.

use fringe3d_core::params::CameraParams;

/// Limits of [`validate_camera`] on distortion coefficients: radial `|k| ≤ 1000`,
/// tangential `|p| ≤ 1`.
const RADIAL_LIMIT: f64 = 1000.0;
const TANGENTIAL_LIMIT: f64 = 1.0;

/// Check a camera's parameters as a file states them; every problem is reported, joined by
/// `"; "`, each naming its field: sizes > 0; `fx`, `fy` finite and > 0; `|skew| < 1`; `cx`, `cy`
/// finite and within ten image sizes of the image; distortion finite with
/// `|k1|, |k2|, |k3| ≤ 1000` and `|p1|, |p2| ≤ 1`. (The core's `CameraParams::new` then checks
/// that the model can be inverted over the image.)
pub fn validate_camera(c: &CameraParams) -> Result<(), String> {
    let mut errs = Vec::new();
    check_camera(c, "camera", &mut errs);
    if errs.is_empty() {
        Ok(())
    } else {
        Err(errs.join("; "))
    }
}

/// [`validate_camera`] for the table `name`, appending to `errs`.
pub(crate) fn check_camera(c: &CameraParams, name: &str, errs: &mut Vec<String>) {
    if c.width == 0 {
        errs.push(format!("{name}.width must be positive, got 0"));
    }
    if c.height == 0 {
        errs.push(format!("{name}.height must be positive, got 0"));
    }
    for (k, v) in [("fx", c.fx), ("fy", c.fy)] {
        if !(v.is_finite() && v > 0.0) {
            errs.push(format!("{name}.{k} must be positive, got {v}"));
        }
    }
    if !(c.skew.is_finite() && c.skew.abs() < 1.0) {
        errs.push(format!(
            "{name}.skew (alpha of eq 4, dimensionless) must satisfy |skew| < 1, got {}",
            c.skew
        ));
    }
    for (k, v, size) in [("cx", c.cx, c.width), ("cy", c.cy, c.height)] {
        let s = f64::from(size.max(1));
        if !v.is_finite() {
            errs.push(format!("{name}.{k} must be finite, got {v}"));
        } else if (v - 0.5 * s).abs() > 10.0 * s {
            errs.push(format!(
                "{name}.{k} = {v} px is implausibly far outside the image ({size} px)"
            ));
        }
    }
    let names = ["k1", "k2", "p1", "p2", "k3"];
    for (i, (&v, n)) in c.distortion.to_array().iter().zip(names).enumerate() {
        let limit = if i == 2 || i == 3 {
            TANGENTIAL_LIMIT
        } else {
            RADIAL_LIMIT
        };
        if !v.is_finite() {
            errs.push(format!(
                "{name}.distortion[{i}] ({n}) must be finite, got {v}"
            ));
        } else if v.abs() > limit {
            errs.push(format!(
                "{name}.distortion[{i}] ({n}) = {v} is not plausible (|{n}| <= {limit})"
            ));
        }
    }
}
