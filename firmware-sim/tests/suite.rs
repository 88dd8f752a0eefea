//! The head simulator's integration tests, one binary: `cargo test --release -p fringe3d-head
//! --test suite`; one file's tests with its module name, e.g. `--test suite head_link::`. One
//! binary rather than one per file saves CI the per-binary compile of the head and the links.

mod link_support;

mod head_bin;
mod head_budget;
mod head_faults;
mod head_interrupt;
mod head_link;
mod head_stale;
mod head_stall;
mod head_stress;
