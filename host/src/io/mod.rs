//! File formats: images, pattern-set and calibration files, point clouds.

pub mod atomic;
pub mod calibration;
pub mod image;
pub mod image_set;
pub mod input;
pub mod pattern_file;
pub mod ply;
pub mod preview;
