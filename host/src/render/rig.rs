//! The camera–projector rig and the default geometry every built-in scene, the demo and the
//! tests share.

use super::camera::{CameraParams, LensModel};
use super::math::{Mat3, Vec3, look_at};
use crate::io::calibration::{Calibration, ProjectorParams, ReferencePlane};
use fringe3d_core::params::Distortion;
use serde::{Deserialize, Serialize};
use std::path::PathBuf;

/// A camera and a projector, posed: the projector frame maps to the camera frame by
/// `X_cam = R·X_proj + T` (so `T` is the projector's centre P in the camera frame, paper §6).
/// All lengths in millimetres.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Rig {
    /// Camera intrinsics.
    pub camera: CameraParams,
    /// Projector intrinsics (width × height = the DMD, ξ × η).
    pub projector: CameraParams,
    /// R, row-major: projector → camera rotation.
    pub rotation: [[f64; 3]; 3],
    /// T: the projector centre in the camera frame, mm.
    pub translation: [f64; 3],
    /// A point O_R of the reference plane (paper §6), camera frame, mm.
    pub reference_point: [f64; 3],
    /// The reference plane's unit normal n_R, pointing towards the camera.
    pub reference_normal: [f64; 3],
    /// `[z_min, z_max]` of the measurement volume, mm.
    pub depth_range: [f64; 2],
    /// Lower corner of the measurement volume (x, y, z), camera frame, mm.
    pub volume_min: [f64; 3],
    /// Upper corner of the measurement volume (x, y, z), camera frame, mm.
    pub volume_max: [f64; 3],
}

/// The default camera: 1280 × 1024, f = 1550 px (field of view ≈ 495 × 396 mm at 600 mm),
/// principal point a little off centre, moderate barrel distortion, no skew.
pub fn default_camera() -> CameraParams {
    CameraParams {
        width: 1280,
        height: 1024,
        fx: 1550.0,
        fy: 1550.0,
        skew: 0.0,
        cx: 642.25,
        cy: 508.75,
        distortion: Distortion::from_array([-0.085, 0.11, 0.0004, -0.0003, 0.0]),
    }
}

/// The default projector: a 1024 × 768 DMD, f = 1250 px (≈ 490 × 370 mm at 600 mm), slight
/// pincushion distortion.
pub fn default_projector() -> CameraParams {
    CameraParams {
        width: 1024,
        height: 768,
        fx: 1250.0,
        fy: 1250.0,
        skew: 0.0,
        cx: 511.5,
        cy: 390.0,
        distortion: Distortion::from_array([0.03, -0.02, 0.0, 0.0, 0.0]),
    }
}

/// The centre of the default measurement volume, where the projector is aimed.
pub const DEFAULT_AIM: [f64; 3] = [0.0, 0.0, 600.0];

/// The default projector centre, camera frame, mm: 225 mm to the right of the camera (a
/// triangulation angle of ≈ 20.5° at 600 mm), a little up and forward.
pub const DEFAULT_PROJECTOR_CENTER: [f64; 3] = [225.0, -12.0, 6.0];

/// The default rig: [`default_camera`], [`default_projector`] at [`DEFAULT_PROJECTOR_CENTER`]
/// aimed at [`DEFAULT_AIM`]; the measurement volume 280 × 220 × 250 mm (x ∈ ±140, y ∈ ±110,
/// z ∈ [475, 725]); the reference plane z = 730 mm facing the camera (just behind the volume);
/// depth range [450, 750] mm.
pub fn default_rig() -> Rig {
    let t = Vec3::from_array(DEFAULT_PROJECTOR_CENTER);
    let r = look_at(t, Vec3::from_array(DEFAULT_AIM)).unwrap_or(Mat3::IDENTITY);
    Rig {
        camera: default_camera(),
        projector: default_projector(),
        rotation: r.0,
        translation: t.to_array(),
        reference_point: [0.0, 0.0, 730.0],
        reference_normal: [0.0, 0.0, -1.0],
        depth_range: [450.0, 750.0],
        volume_min: [-140.0, -110.0, 475.0],
        volume_max: [140.0, 110.0, 725.0],
    }
}

impl Rig {
    /// R as a matrix.
    pub fn rotation_matrix(&self) -> Mat3 {
        Mat3(self.rotation)
    }

    /// The projector centre P (camera frame).
    pub fn projector_centre(&self) -> Vec3 {
        Vec3::from_array(self.translation)
    }

    /// A camera-frame point in the projector frame: `Rᵀ·(X − T)`.
    #[inline]
    pub fn to_projector_frame(&self, p: Vec3) -> Vec3 {
        self.rotation_matrix().tmul_vec(p - self.projector_centre())
    }

    /// The projector pixel (ξ, η) lighting the camera-frame point `p`, by the exact forward model
    /// (no inversion needed); `None` behind the projector or beyond its lens model.
    pub fn projector_pixel(&self, p: Vec3) -> Option<(f64, f64)> {
        self.projector
            .project(self.to_projector_frame(p), self.projector.max_radius())
    }

    /// Check every parameter; the message names the field.
    pub fn validate(&self) -> Result<(), String> {
        self.camera.validate("camera")?;
        self.projector.validate("projector")?;
        let (e, det) = self.rotation_matrix().orthonormality_error();
        if !(e < 1e-9 && (det - 1.0).abs() < 1e-9) {
            return Err(format!(
                "projector rotation is not a rotation (|RᵀR − I| = {e:e}, det = {det})"
            ));
        }
        let t = self.projector_centre();
        if !(t.is_finite() && t.norm() > 1e-6) {
            return Err("projector centre must be finite and away from the camera centre".into());
        }
        let n = Vec3::from_array(self.reference_normal);
        if !((n.norm() - 1.0).abs() < 1e-9) || !Vec3::from_array(self.reference_point).is_finite() {
            return Err("reference plane: point must be finite and normal a unit vector".into());
        }
        let [z0, z1] = self.depth_range;
        if !(z0 > 0.0 && z0 < z1 && z1.is_finite()) {
            return Err(format!(
                "depth_range must satisfy 0 < z_min < z_max, got [{z0}, {z1}]"
            ));
        }
        if !(0..3).all(|i| self.volume_min[i] < self.volume_max[i]) {
            return Err("volume_min must be below volume_max in x, y and z".into());
        }
        Ok(())
    }

    /// The rig for a camera image of `width × height` (same field of view; see
    /// [`LensModel::scaled`]).
    pub fn with_camera_size(&self, width: u32, height: u32) -> Rig {
        let mut r = self.clone();
        r.camera = self.camera.scaled(width, height);
        r
    }

    /// The camera's parameters (the calibration file's form).
    pub fn camera_model(&self) -> CameraParams {
        self.camera
    }

    /// The true calibration of this rig. `reference_map` (relative to the calibration file) and
    /// `pattern_set` name the reference files when a reference was rendered, `pattern_digest` is
    /// the reference pattern set's digest
    /// ([`pattern_digest`](fn@crate::io::calibration::pattern_digest)).
    pub fn calibration(
        &self,
        reference_map: Option<PathBuf>,
        pattern_set: Option<PathBuf>,
        pattern_digest: Option<String>,
    ) -> Calibration {
        Calibration {
            version: 1,
            camera: self.camera_model(),
            projector_centre: self.translation,
            reference: reference_map.map(|phase_map| ReferencePlane {
                point: self.reference_point,
                normal: self.reference_normal,
                phase_map,
                pattern_set,
                pattern_digest,
                margin: None,
            }),
            depth_range: self.depth_range,
            projector: Some(ProjectorParams {
                intrinsics: self.projector,
                rotation: self.rotation,
                translation: self.translation,
            }),
            projector_response: None,
            projector_defocus: None,
            camera_covariance: None,
            sensor: None,
        }
    }
}
