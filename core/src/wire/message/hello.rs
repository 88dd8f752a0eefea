//! Hello and Capabilities: the greeting and what a head is and can do.

use serde::{Deserialize, Serialize};

#[cfg(doc)]
use super::UploadChunk;
use super::{Body, Invalid, MAX_CHUNK, MAX_LUT_ENTRIES, WireError, check};

/// Host → head greeting.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Hello {
    /// The protocol version the host speaks ([`PROTOCOL_VERSION`](crate::wire::PROTOCOL_VERSION)).
    pub protocol_version: u8,
}

/// A firmware version triple.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct FirmwareVersion {
    /// Major version.
    pub major: u8,
    /// Minor version.
    pub minor: u8,
    /// Patch level.
    pub patch: u8,
}

/// Head → host: what the head is and can do (reply to [`Hello`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Capabilities {
    /// The protocol version the head speaks.
    pub protocol_version: u8,
    /// The firmware's version.
    pub firmware: FirmwareVersion,
    /// Camera sensor width in pixels.
    pub sensor_width: u16,
    /// Camera sensor height in pixels.
    pub sensor_height: u16,
    /// Projector width in pixels.
    pub projector_width: u16,
    /// Projector height in pixels.
    pub projector_height: u16,
    /// Free memory for pattern images and maps, bytes.
    pub free_memory: u32,
    /// Largest [`UploadChunk`] data the head accepts, `1..=MAX_CHUNK`.
    pub max_chunk: u16,
    /// Number of pattern-set slots (`set_id < max_sets`).
    pub max_sets: u8,
    /// Largest trigger sequence, `1..=MAX_LUT_ENTRIES`.
    pub max_lut_entries: u16,
}

impl Capabilities {
    /// Check the fields' ranges.
    pub fn validate(&self) -> Result<(), WireError> {
        check(
            (1..=MAX_CHUNK).contains(&(self.max_chunk as usize)),
            Invalid::ChunkSize,
        )?;
        check(
            (1..=MAX_LUT_ENTRIES).contains(&(self.max_lut_entries as usize)),
            Invalid::LutLength,
        )
    }
}

impl Body for Hello {}

impl Body for Capabilities {
    fn validate_body(&self) -> Result<(), WireError> {
        self.validate()
    }
}
