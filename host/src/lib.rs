//! fringe3d desktop library: file formats, rendering of synthetic scans, calibration, batch paths
//! and the device link. The `fringe3d` binary is a thin CLI over it.
#![deny(missing_docs)]
