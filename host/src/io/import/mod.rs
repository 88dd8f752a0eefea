//! Camera models from other tools: OpenCV's `cv::FileStorage` files (YAML, XML, JSON; [`opencv`])
//! and Bouguet's Camera Calibration Toolbox for Matlab (`Calib_Results.m`; [`bouguet`]), each with
//! the small reader of its format. Both map onto [`CameraParams`](fringe3d_core::params::CameraParams)
//! without pixel shifts and validate the result like a calibration file's camera.

pub mod bouguet;
mod filestorage;
mod matlab;
pub mod opencv;

pub use bouguet::{import_bouguet, import_bouguet_file};
pub use opencv::import_opencv;
