//! Calibration files: the camera model, the projector centre and the reference plane the
//! reconstruction needs (paper §6), in a documented TOML file. The schema and reading are in
//! `schema`, the checks in `validate`, the writer in `toml_writer`; the importers for OpenCV
//! `cv::FileStorage` files and Bouguet's toolbox live in [`crate::io::import`] (which builds on
//! this module); the core's parameter types the file embeds are re-exported here.
//!
//! # Conventions
//! - Frame: the camera's, as in OpenCV — origin at the centre of projection, x right, y down,
//!   z forward (into the scene). Every position is in millimetres.
//! - Pixels: `(0, 0)` is the *centre* of the top-left pixel; pixel centres are at integers.
//! - Projection (paper eqs 2-4): `x = X/Z, y = Y/Z`, Brown distortion with `[k1, k2, p1, p2, k3]`
//!   (the paper's `k1, k2, k3, k4, k5`: `k1, k2, k3` radial of r², r⁴, r⁶; `p1, p2` tangential),
//!   then `u = fx·x_d + α·fx·y_d + cx`, `v = fy·y_d + cy` with the dimensionless skew α of eq 4.
//!   (The paper writes the image plane at z = −1; with the OpenCV frame it is at z = +1 and the
//!   formulas are the usual ones.)
//!
//! The file format is specified field by field in `docs/formats.md`.

mod covariance;
mod pattern_digest;
mod response;
mod schema;
mod sensor;
mod toml_writer;
mod validate;

pub use super::camera_check::validate_camera;
pub use super::error::FormatError;
pub use covariance::{COVARIANCE_ORDER, CameraCovariance};
pub use fringe3d_core::params::{CameraParams, Distortion, ProjectorParams, ScanGeometry};
pub use pattern_digest::{
    DIGEST_PREFIX, PatternCheck, PatternSetError, ReferenceDigest, ScanPatterns, check_pattern_set,
    is_digest, pattern_digest, pattern_file_digest,
};
pub use response::ProjectorResponse;
pub use schema::{CALIBRATION_VERSION, Calibration, MAX_DEFOCUS, ReferencePlane};
pub use sensor::SensorNoise;
