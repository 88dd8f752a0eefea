//! File formats: images, pattern-set and calibration files (and camera models of other tools),
//! point clouds, `.npy` arrays; the error they share ([`error::FormatError`]).

pub mod atomic;
pub mod calibration;
pub mod camera_check;
pub mod error;
pub(crate) mod exact;
pub mod image;
pub mod image_set;
pub mod import;
pub mod input;
pub mod map_file;
pub mod mesh;
pub mod npy;
pub mod pattern_file;
pub mod ply;
pub mod preview;
