//! fringe3d desktop library: file formats, rendering of synthetic scans, calibration, batch paths
//! and the device link. The `fringe3d` binary is a thin CLI over it ([`cli::run`]).
#![deny(missing_docs)]

pub mod accuracy;
pub mod batch;
pub mod calib;
pub mod cli;
pub mod device;
pub mod io;
pub mod render;
pub mod scan;
pub mod vectors;
