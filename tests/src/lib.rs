//! End-to-end tests live in `tests/tests/`; this library holds what several of them share.
#![deny(missing_docs)]

pub mod qemu;
