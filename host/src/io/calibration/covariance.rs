//! `[camera_covariance]`: the covariance of the camera's intrinsics, as `calibrate camera`
//! estimated it, so that the steps that hold the camera (`calibrate projector`, `calibrate
//! reference`) can add the camera's own uncertainty to theirs (issue #18 item 4).

/// Names of the covariance's rows and columns, in order (the calibration's `[camera]` keys;
/// `skew` is α of paper eq 4, dimensionless).
pub const COVARIANCE_ORDER: [&str; 10] =
    ["fx", "fy", "skew", "cx", "cy", "k1", "k2", "p1", "p2", "k3"];

/// The covariance of the camera's intrinsics `[fx, fy, skew, cx, cy, k1, k2, p1, p2, k3]`
/// ([`COVARIANCE_ORDER`]; pixels², pixels × 1, 1): the intrinsics block of `σ²(JᵀJ)⁻¹` of the
/// camera's bundle adjustment. Rows of parameters the calibration held (e.g. k3) are zero.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraCovariance {
    /// The 10 × 10 matrix, row by row.
    pub matrix: [[f64; 10]; 10],
}

impl CameraCovariance {
    /// The matrix as a row-major array.
    pub fn flat(&self) -> [f64; 100] {
        std::array::from_fn(|i| self.matrix[i / 10][i % 10])
    }

    /// From a row-major array.
    pub fn from_flat(c: &[f64; 100]) -> CameraCovariance {
        CameraCovariance {
            matrix: std::array::from_fn(|i| std::array::from_fn(|j| c[i * 10 + j])),
        }
    }

    /// The standard deviations (square roots of the diagonal).
    pub fn std(&self) -> [f64; 10] {
        std::array::from_fn(|i| self.matrix[i][i].max(0.0).sqrt())
    }

    /// Finite, symmetric (to 1e-9 of the diagonal's scale), a non-negative diagonal, and no
    /// correlation beyond ±1 (to 1e-6): what a covariance must be.
    pub fn validate(&self) -> Result<(), String> {
        let m = &self.matrix;
        if m.iter().flatten().any(|x| !x.is_finite()) {
            return Err("camera_covariance.matrix must be finite".into());
        }
        for i in 0..10 {
            if m[i][i] < 0.0 {
                return Err(format!(
                    "camera_covariance.matrix: the variance of {} is negative ({})",
                    COVARIANCE_ORDER[i], m[i][i]
                ));
            }
            for j in 0..i {
                let scale = (m[i][i] * m[j][j]).sqrt();
                if (m[i][j] - m[j][i]).abs() > 1e-9 * scale.max(f64::MIN_POSITIVE) {
                    return Err(format!(
                        "camera_covariance.matrix is not symmetric: ({}, {}) = {} but ({}, {}) = {}",
                        COVARIANCE_ORDER[i],
                        COVARIANCE_ORDER[j],
                        m[i][j],
                        COVARIANCE_ORDER[j],
                        COVARIANCE_ORDER[i],
                        m[j][i]
                    ));
                }
                if m[i][j].abs() > scale * (1.0 + 1e-6) {
                    return Err(format!(
                        "camera_covariance.matrix: {} and {} correlate beyond ±1",
                        COVARIANCE_ORDER[i], COVARIANCE_ORDER[j]
                    ));
                }
            }
        }
        Ok(())
    }
}
