//! The end-to-end tests across the crates, one binary: `cargo test --release -p fringe3d-tests
//! --test suite`; one file's tests with its module name, e.g. `--test suite qemu_firmware::`.
//! One binary rather than one per file saves CI seven links of the host library, and lets the
//! single-threaded QEMU runs share the machine with the rendered scans instead of each binary
//! leaving a core idle. Scratch folders carry their file's own prefix.

mod common;
mod rendered;

mod head_compiled;
mod head_hdr;
mod head_pty;
mod qemu_c_example;
mod qemu_example;
mod qemu_firmware;
mod qemu_head_pty;
mod reference_quality;
mod scan_rendered;
mod vectors_golden;
