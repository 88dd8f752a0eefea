#![doc = include_str!("../README.md")]
#![no_std]
#![deny(unsafe_code, missing_docs)]

pub mod camera;
pub mod decode;
pub mod geometry;
pub mod math;
pub mod pattern;
pub mod phase_function;
pub mod reconstruct;
pub mod sequential;
pub mod unwrap;
pub mod validity;
pub mod wire;

pub use validity::Validity;
