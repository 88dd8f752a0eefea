#![doc = include_str!("../README.md")]
#![no_std]
#![deny(unsafe_code, missing_docs)]
// `!(x >= t)` is deliberate throughout: a NaN must fail every acceptance test.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod arith;
pub mod binary;
pub mod budget;
pub mod camera;
pub mod decode;
pub mod decode_config;
pub mod decode_error;
pub mod digest;
pub mod estimator;
pub mod filter;
pub mod frame_store;
pub mod geometry;
pub mod gray;
pub mod hdr_parity;
pub mod limits;
pub mod math;
pub mod params;
pub mod pattern;
pub mod pattern_error;
pub mod phase_function;
pub mod qnum;
pub mod reconstruct;
pub mod relation;
pub mod sample;
pub mod sequential;
pub mod unwrap;
pub mod validity;
pub mod wire;

pub use validity::Validity;
