//! [`Calibration::validate`]: every check of a calibration's content, each problem naming its
//! field.

use super::schema::{CALIBRATION_VERSION, Calibration};
use crate::io::camera_check::check_camera;
use crate::math::Vec3;

fn v3(a: &[f64; 3]) -> Vec3 {
    Vec3::from_array(*a)
}

fn finite3(a: &[f64; 3]) -> bool {
    v3(a).is_finite()
}

fn fmt3(v: &[f64; 3]) -> String {
    format!("[{}, {}, {}]", v[0], v[1], v[2])
}

impl Calibration {
    /// Check everything; every problem is reported, joined by `"; "`, each naming its field:
    ///
    /// - `version` is 1; all numbers finite;
    /// - the camera (and projector intrinsics), as in
    ///   [`validate_camera`](crate::io::camera_check::validate_camera);
    /// - `projector_centre` is not the camera centre (no baseline otherwise);
    /// - `0 < depth_range[0] < depth_range[1]`;
    /// - reference: `| |n_R| − 1 | ≤ 1e-3`; the plane passes neither through the camera centre nor
    ///   through the projector centre; `phase_map` is not empty; `pattern_digest`, when given, is
    ///   `sha256:` and 64 lowercase hex digits;
    /// - projector: `rotation` orthonormal (`|RRᵀ − I| ≤ 1e-6` element-wise) with determinant +1;
    ///   `translation` equals `projector_centre` (within 1e-6 mm + 1e-9 relative).
    pub fn validate(&self) -> Result<(), String> {
        let mut errs = Vec::new();
        if self.version != CALIBRATION_VERSION {
            errs.push(format!(
                "version must be {CALIBRATION_VERSION}, got {}",
                self.version
            ));
        }
        check_camera(&self.camera, "camera", &mut errs);
        let p = &self.projector_centre;
        if !finite3(p) {
            errs.push(format!("projector_centre must be finite, got {}", fmt3(p)));
        } else if v3(p).norm() <= 1e-9 {
            errs.push(
                "projector_centre coincides with the camera centre: there is no baseline".into(),
            );
        }
        let [z0, z1] = self.depth_range;
        if !(z0.is_finite() && z1.is_finite() && z0 > 0.0 && z0 < z1) {
            errs.push(format!(
                "depth_range must satisfy 0 < z_min < z_max (mm), got [{z0}, {z1}]"
            ));
        }
        if let Some(r) = &self.projector_response
            && let Err(m) = r.validate()
        {
            errs.push(m);
        }
        if let Some(c) = &self.camera_covariance
            && let Err(m) = c.validate()
        {
            errs.push(m);
        }
        if let Some(s) = &self.sensor
            && let Err(m) = s.validate()
        {
            errs.push(m);
        }
        if let Some(d) = self.projector_defocus
            && !(d.is_finite() && (0.0..=super::MAX_DEFOCUS).contains(&d))
        {
            errs.push(format!(
                "projector_defocus must be in [0, {}] projector pixels, got {d}",
                super::MAX_DEFOCUS
            ));
        }
        if let Some(r) = &self.reference {
            let n = &r.normal;
            if !finite3(&r.point) {
                errs.push(format!(
                    "reference.point must be finite, got {}",
                    fmt3(&r.point)
                ));
            }
            if !finite3(n) {
                errs.push(format!("reference.normal must be finite, got {}", fmt3(n)));
            } else if (v3(n).norm() - 1.0).abs() > 1e-3 {
                errs.push(format!(
                    "reference.normal must be a unit vector, got {} (length {})",
                    fmt3(n),
                    v3(n).norm()
                ));
            } else if finite3(&r.point) {
                let d_cam = v3(n).dot(v3(&r.point)) / v3(n).norm();
                if d_cam.abs() <= 1e-6 {
                    errs.push("reference plane passes through the camera centre".into());
                }
                if finite3(p) {
                    let d = [p[0] - r.point[0], p[1] - r.point[1], p[2] - r.point[2]];
                    if (v3(n).dot(v3(&d)) / v3(n).norm()).abs() <= 1e-6 {
                        errs.push("reference plane passes through the projector centre".into());
                    }
                }
            }
            if r.phase_map.as_os_str().is_empty() {
                errs.push("reference.phase_map must name a file".into());
            }
            if r.pattern_set
                .as_ref()
                .is_some_and(|s| s.as_os_str().is_empty())
            {
                errs.push("reference.pattern_set, when given, must name a file".into());
            }
            if let Some(m) = r.margin
                && m.iter()
                    .any(|&x| x > fringe3d_core::reconstruct::MAX_MARGIN)
            {
                errs.push(format!(
                    "reference.margin: each side at most {} pixels, got {m:?}",
                    fringe3d_core::reconstruct::MAX_MARGIN
                ));
            }
            if let Some(d) = &r.pattern_digest
                && !super::pattern_digest::is_digest(d)
            {
                errs.push(format!(
                    "reference.pattern_digest must be \"sha256:\" and 64 lowercase hex digits, got \"{d}\""
                ));
            }
        }
        if let Some(pr) = &self.projector {
            check_camera(&pr.intrinsics, "projector.intrinsics", &mut errs);
            let r = &pr.rotation;
            if !r.iter().all(finite3) {
                errs.push("projector.rotation must be finite".into());
            } else {
                let mut worst: f64 = 0.0;
                for i in 0..3 {
                    for j in 0..3 {
                        let e = if i == j { 1.0 } else { 0.0 };
                        worst = worst.max((v3(&r[i]).dot(v3(&r[j])) - e).abs());
                    }
                }
                let det = r[0][0] * (r[1][1] * r[2][2] - r[1][2] * r[2][1])
                    - r[0][1] * (r[1][0] * r[2][2] - r[1][2] * r[2][0])
                    + r[0][2] * (r[1][0] * r[2][1] - r[1][1] * r[2][0]);
                if worst > 1e-6 {
                    errs.push(format!(
                        "projector.rotation is not orthonormal (|R·Rᵀ − I| up to {worst:e})"
                    ));
                } else if det < 0.0 {
                    errs.push(
                        "projector.rotation is a reflection (determinant −1), not a rotation"
                            .into(),
                    );
                }
            }
            let t = &pr.translation;
            if !finite3(t) {
                errs.push(format!(
                    "projector.translation must be finite, got {}",
                    fmt3(t)
                ));
            } else if finite3(p) {
                let d = [t[0] - p[0], t[1] - p[1], t[2] - p[2]];
                if v3(&d).norm() > 1e-6 + 1e-9 * v3(p).norm() {
                    errs.push(format!(
                        "projector.translation {} differs from projector_centre {} (both are the projector centre, mm)",
                        fmt3(t),
                        fmt3(p)
                    ));
                }
            }
        }
        if errs.is_empty() {
            Ok(())
        } else {
            Err(errs.join("; "))
        }
    }
}
