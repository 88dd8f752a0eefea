//! Calibration (paper §7): the camera (checkerboard views → intrinsics and Brown distortion by
//! Zhang's closed form and a bundle adjustment), the projector centre P (two or more parallel plate
//! positions with vertical and horizontal fringes), and the reference plane with its phase map.
//! See `docs/calibration.md`.
//!
//! Conventions: the camera frame of OpenCV (x right, y down, z forward), pixel centres at integer
//! coordinates, millimetres, distortion `[k1, k2, p1, p2, k3]`, and the paper's dimensionless skew
//! α of eq 4 (`u = fx·x + α·fx·y + u0`; OpenCV's camera matrix holds `α·fx`).

pub mod camera;
pub mod camera_files;
pub mod corners;
pub mod dlt;
pub mod files;
pub mod lens;
pub mod linalg;
pub mod lm;
pub mod plane_projector;
pub mod pose;
pub mod projector_centre;
pub mod projector_coords;
pub mod projector_files;
pub mod projector_model;
pub mod reference;
pub mod reference_fit;
pub mod reference_margin;
pub mod reference_physical;
pub mod reference_write;
pub mod report;
pub mod uncertainty;
pub mod virtual_reference;
pub mod zhang;

use std::path::{Path, PathBuf};

/// [`CalibError::Input`] naming `what`.
pub(crate) fn input(what: &Path, message: impl Into<String>) -> CalibError {
    CalibError::Input {
        what: what.display().to_string(),
        message: message.into(),
    }
}

/// Why a calibration failed. Messages name the files (or views, plates) concerned.
#[derive(Debug, thiserror::Error)]
pub enum CalibError {
    /// Not enough usable checkerboard views.
    #[error(
        "too few usable views: {usable} (need at least {needed}, taken from different angles){}{}",
        list_used(used),
        list(rejected)
    )]
    TooFewViews {
        /// Views usable.
        usable: usize,
        /// Views needed.
        needed: usize,
        /// The usable views.
        used: Vec<String>,
        /// The views left out, with reasons.
        rejected: Vec<String>,
    },
    /// The data do not determine the solution.
    #[error("calibration is degenerate: {what}")]
    Degenerate {
        /// What could not be determined.
        what: String,
    },
    /// An input is unusable.
    #[error("{what}: {message}")]
    Input {
        /// The file, folder, plate or view.
        what: String,
        /// What is wrong.
        message: String,
    },
    /// A board was not found where one is required.
    #[error("{path}: {message}")]
    Board {
        /// The image.
        path: PathBuf,
        /// What went wrong.
        message: String,
    },
    /// Two plate positions are not parallel.
    #[error(
        "plates {a} and {b} are not parallel: their normals differ by {angle_deg:.3} degrees (limit {limit_deg} degrees; the method of paper §7 translates the plate without turning it)"
    )]
    NotParallel {
        /// One plate.
        a: String,
        /// The other.
        b: String,
        /// Angle between their normals.
        angle_deg: f64,
        /// The limit.
        limit_deg: f64,
    },
    /// The plate positions' phase maps do not overlap.
    #[error(
        "the plate positions' phase maps do not overlap enough to match points ({detail}); the plates must be lit by the same projector area and seen by the camera at every position"
    )]
    NoOverlap {
        /// Per pair: matched pixels.
        detail: String,
    },
    /// An image could not be read or written.
    #[error(transparent)]
    Image(#[from] crate::io::image::ImageError),
    /// An image set could not be loaded.
    #[error(transparent)]
    ImageSet(#[from] crate::io::image_set::ImageSetError),
    /// A calibration or pattern-set file could not be read or written.
    #[error(transparent)]
    Format(#[from] crate::io::error::FormatError),
}

fn list_used(v: &[String]) -> String {
    if v.is_empty() {
        String::new()
    } else {
        format!("; usable: {}", v.join(", "))
    }
}

fn list(v: &[String]) -> String {
    if v.is_empty() {
        String::new()
    } else {
        format!("; left out: {}", v.join("; "))
    }
}
