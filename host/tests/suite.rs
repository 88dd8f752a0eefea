//! The host's integration tests, one binary: `cargo test --release -p fringe3d --test suite`; one
//! file's tests with its module name, e.g. `--test suite cli_scan::`. One binary rather than one
//! per file saves CI the per-binary compile and link. Tests of different files now run side by
//! side in one process: their scratch folders carry the file's own prefix or a tag of its own.

mod cli_support;
mod render_common;

mod adapt_cli;
mod adapt_quality;
mod batch_variants;
mod calib_bad_input;
mod calib_end_to_end;
mod calib_projector_model;
mod calib_sigma;
mod cli_budget;
mod cli_errors;
mod cli_gamma;
mod cli_scan;
mod compiled_cli;
mod corners_angle_sweep;
mod device_errors;
mod formats_atomic;
mod formats_calibration;
mod formats_pattern;
mod formats_pattern_order;
mod formats_ply;
mod formats_raw;
mod fuzz_parsers;
mod gamma_compensation;
mod hardening_bounds;
mod hardening_cli;
mod hardening_input;
mod hardening_output;
mod hdr_scan;
mod import_cli;
mod import_formats;
mod noise_floor;
mod pattern_design;
mod reference_consistency;
mod reference_fit;
mod reference_near_coverage;
mod reference_physical;
mod reference_virtual_cli;
mod render_checkerboard;
mod render_dataset;
mod render_geometry;
mod render_phase;
mod render_timing;
mod scan_codes;
mod scan_stream;
