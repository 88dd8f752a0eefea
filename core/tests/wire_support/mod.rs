//! Test support shared by the wire tests.

use fringe3d_core::wire::crc::crc32c;

pub mod setup_blobs;

/// A decoded frame with a correct CRC around arbitrary header bytes and payload.
pub fn raw_frame(version: u8, flags: u8, seq: u8, command: u8, payload: &[u8]) -> Vec<u8> {
    let mut f = vec![version, flags, seq, command];
    f.extend((payload.len() as u16).to_le_bytes());
    f.extend(payload);
    let c = crc32c(&f);
    f.extend(c.to_le_bytes());
    f
}
