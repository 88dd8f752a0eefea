//! The fringe3d scan head: its firmware logic, `no_std` and allocation-free, over `embedded-io`
//! (the serial link) and `embedded-hal` 1.0 (trigger pins, delays), with a simulated board and,
//! behind the default `std` feature, a desktop front that presents the head on a pseudo-terminal.
//!
//! - [`head`]: the command handler, uploads, trigger sequences and scans — [`Head`];
//! - [`hal`]: what the head needs from a board ([`BoardIo`]: projector, camera, stores, pins,
//!   delay);
//! - [`port`]: the `heapless` queues between the UART interrupts and the main loop;
//! - [`memory`]: the fixed working buffers and the peak-use report;
//! - [`sim`]: a simulated board ([`sim::SimBoard`]) with virtual time and a trigger timeline;
//! - `desktop` (feature `std`): the PTY front, dataset replay and in-process links for tests.
//!
//! Build for a board with `--no-default-features` (e.g. `--target thumbv7em-none-eabihf`).
#![no_std]
#![deny(unsafe_code, missing_docs)]
#![allow(clippy::neg_cmp_op_on_partial_ord)]

#[cfg(feature = "std")]
extern crate std;

pub mod hal;
pub mod head;
pub mod memory;
pub mod port;
pub mod sim;

#[cfg(feature = "std")]
pub mod desktop;

pub use hal::{BoardIo, Camera, HwError, Projector, SliceStore, Storage};
pub use head::{Activity, Head, HeadConfig, HeadError, LinkError, MAX_SETS};
pub use memory::{HeadBuffers, HeadMemory, MemoryPlan, MemoryReport};
