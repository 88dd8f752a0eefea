//! The core's integration tests, one binary: `cargo test --release -p fringe3d-core --test suite`;
//! one file's tests with its module name, e.g. `--test suite decode_parity::`. One binary rather
//! than one per file: each file's binary compiled the generic kernels again and linked on its own,
//! which took two of CI's cold minutes. The files stay as they were, one subject each.

mod common;
mod reconstruct_support;
mod wire_support;

mod arith_accuracy;
mod arith_default_bits;
mod arith_parity;
mod arith_qemu;
mod camera_model;
mod compiled_kernel;
mod decode_accuracy;
mod decode_coprime;
mod decode_correction;
mod decode_gray;
mod decode_gray_inverse;
mod decode_heterodyne;
mod decode_long_sets;
mod decode_optional_outputs;
mod decode_parity;
mod decode_scratch_static;
mod decode_single_period;
mod filter_edges;
mod frame_store;
mod hdr_fusion;
mod patterns;
mod reconstruct_accuracy;
mod reconstruct_margin;
mod reconstruct_ring_lean;
mod reconstruct_span;
mod reconstruct_timing;
mod reconstruct_validity;
mod wire_codec;
mod wire_frame_errors;
mod wire_props;
mod wire_setup;
mod wire_stream;
mod wire_validation;
mod wire_vectors;
