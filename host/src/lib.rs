//! fringe3d desktop library: file formats, rendering of synthetic scans, calibration, batch paths
//! and the device link. The `fringe3d` binary is a thin CLI over it ([`cli::run`]).
#![deny(missing_docs)]
// `!(x >= t)` is deliberate throughout: a NaN must fail every acceptance test.
#![allow(clippy::neg_cmp_op_on_partial_ord, clippy::nonminimal_bool)]
// Numeric code (solvers, 3×3 and 4×4 systems) reads best with explicit indices and tuple types.
#![allow(clippy::needless_range_loop, clippy::type_complexity)]

pub mod accuracy;
pub mod adapt;
pub mod batch;
pub mod calib;
pub mod cli;
pub mod compiled;
pub mod design;
pub mod device;
pub mod gather;
pub mod io;
pub mod math;
pub mod noise;
pub mod render;
pub mod response;
pub mod scan;
pub mod vectors;
