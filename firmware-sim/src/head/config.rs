//! The head's fixed parameters ([`HeadConfig`]) and its number of pattern-set slots.

use fringe3d_core::wire::{FirmwareVersion, MAX_CHUNK};

/// Pattern-set slots the head has room for.
pub const MAX_SETS: usize = 4;

/// Fixed parameters of a head.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct HeadConfig {
    /// Reported firmware version.
    pub firmware: FirmwareVersion,
    /// Pattern-set slots offered, `1..=MAX_SETS`.
    pub max_sets: u8,
    /// Largest upload chunk accepted, `1..=MAX_CHUNK`.
    pub max_chunk: u16,
    /// Shortest exposure the projector can show, µs.
    pub min_exposure_us: u32,
    /// Camera readout time, µs: camera-triggered entries need at least this dark time.
    pub readout_us: u32,
    /// How long to wait for the camera-ready and external trigger inputs, µs.
    pub trigger_timeout_us: u32,
    /// Polling step while waiting for an input, µs.
    pub poll_us: u32,
}

impl HeadConfig {
    /// The defaults: firmware 0.1.0, 4 slots, 4064-byte chunks, 100 µs minimum exposure, 1 ms
    /// readout, 1 s trigger timeout polled every 10 µs.
    pub const DEFAULT: HeadConfig = HeadConfig {
        firmware: FirmwareVersion {
            major: 0,
            minor: 1,
            patch: 0,
        },
        max_sets: MAX_SETS as u8,
        max_chunk: MAX_CHUNK as u16,
        min_exposure_us: 100,
        readout_us: 1_000,
        trigger_timeout_us: 1_000_000,
        poll_us: 10,
    };
}

impl Default for HeadConfig {
    fn default() -> Self {
        Self::DEFAULT
    }
}
