//! Messages: the payloads of frames, one struct per command, postcard-encoded.
//!
//! The header's command byte says which body follows; the payload is the postcard encoding of that
//! body alone (no enum tag). Every body has a `validate` step that [`Message::decode`] and
//! [`Message::encode`] both run, so nothing invalid is sent or accepted.
//!
//! The command table below is the one place that lists the commands: [`Command`] (ids, names,
//! request / write classification) and [`Message`] (variants, encode, decode, validate) are
//! generated from it (`table.rs`). The bodies live in files named for what they carry.

use serde::{Deserialize, Serialize};

use super::{Invalid, MAX_PAYLOAD, WireError};
pub use crate::params::pattern::{
    Knots, Level, MAX_KNOTS, MAX_LEVELS, MAX_SHIFTS, PatternAxis, PatternSetDesc, PhaseDesc,
    PhaseProfile, Relation, Shifts, Waveform,
};
pub use crate::params::{CameraParams, ScanGeometry};

#[macro_use]
mod table;

mod calibration;
mod correction;
mod hello;
mod pattern;
mod scan;
mod status;
mod thresholds;
mod trigger;
mod upload;

pub use calibration::Calibration;
pub use correction::{DefineCorrection, SetupCorrection};
pub use hello::{Capabilities, FirmwareVersion, Hello};
pub use pattern::DefinePatternSet;
pub use scan::{
    EdgeFilterMode, Exposures, MAX_EXPOSURE_US, ResultRow, RowKind, ScanDone, ScanOutput,
    ScanRequest,
};
pub use status::{Ack, HeadErrors, HeadState, Holds, Nak, NakCode, Status};
pub use thresholds::{DecodeThresholds, DefineThresholds};
pub use trigger::{LutEntry, LutTable, Sequence, ValidationStatus};
pub use upload::{
    BeginCompiled, BeginPhaseMap, BeginUpload, COMPILED_BYTES_PER_PIXEL, UploadAck, UploadChunk,
    UploadTarget,
};

/// Most data bytes in one [`UploadChunk`]; a multiple of 4 so phase-map chunks can hold whole f32s.
pub const MAX_CHUNK: usize = 4064;
/// Most data bytes in one [`ResultRow`].
pub const MAX_ROW_DATA: usize = 4064;
/// Length of one packed [`LutEntry`].
pub const LUT_ENTRY_LEN: usize = 12;
/// Most entries in a trigger sequence ([`Sequence`]).
pub const MAX_LUT_ENTRIES: usize = 256;
/// Highest pattern bit depth (one byte per pixel).
pub const MAX_BIT_DEPTH: u8 = 8;
/// Bytes per pixel of the reference phase map: f32 phase plus one validity byte.
pub const PHASE_MAP_BYTES_PER_PIXEL: usize = 5;

// ---------------------------------------------------------------------------------------------
// The command table (layout of each line: `table.rs`; the protocol table: `wire/mod.rs`).

commands! {
    /// [`Hello`] → [`Capabilities`].
    Hello = 0x01 => read(Hello), "Host greeting.";
    /// [`DefinePatternSet`] → Ack.
    DefinePatternSet = 0x10 => write(DefinePatternSet), "Define a parametric pattern set.";
    /// [`BeginUpload`] → [`UploadAck`].
    BeginUpload = 0x11 => write(BeginUpload), "Start a pattern-image upload.";
    /// [`UploadChunk`] → [`UploadAck`].
    UploadChunk = 0x12 => write(UploadChunk<'a>), "One upload chunk.";
    /// [`UploadTarget`] → [`UploadAck`] (where to resume).
    QueryUpload = 0x13 => read(UploadTarget), "Ask where an upload stands.";
    /// [`UploadTarget`] → Ack, or Nak [`NakCode::DigestMismatch`].
    ConfirmUpload = 0x14 => write(UploadTarget),
        "Ask the head to check an upload's digest and adopt it (the \"ConfirmSet\" of issue #7).";
    /// [`DefineCorrection`] → Ack.
    DefineCorrection = 0x15 => write(DefineCorrection),
        "Set or clear a pattern set's phase-error table (protocol version 4).";
    /// [`DefineThresholds`] → Ack.
    DefineThresholds = 0x16 => write(DefineThresholds),
        "Set or clear a pattern set's decoder thresholds (protocol version 7).";
    /// [`Calibration`] → Ack.
    UploadCalibration = 0x18 => write(Calibration), "Upload the calibration.";
    /// [`BeginPhaseMap`] → [`UploadAck`].
    BeginPhaseMapUpload = 0x19 => write(BeginPhaseMap), "Start the reference phase map upload.";
    /// [`BeginCompiled`] → [`UploadAck`].
    BeginCompiledUpload = 0x1A => write(BeginCompiled),
        "Start the compiled reconstruction's upload (protocol version 9).";
    /// [`Sequence`] → Ack.
    ConfigureSequence = 0x20 => write(Sequence<'a>), "Configure the trigger sequence.";
    /// (empty) → [`ValidationStatus`].
    ValidateSequence = 0x21 => read(), "Validate the configured sequence.";
    /// (empty) → Ack. Starts the configured sequence.
    Start = 0x22 => write(), "Start the sequence.";
    /// (empty) → Ack. Stops it.
    Stop = 0x23 => write(), "Stop the sequence.";
    /// [`ScanRequest`] → Ack, then [`ResultRow`]s, then [`ScanDone`].
    Scan = 0x30 => write(ScanRequest), "Scan.";
    /// (empty) → Ack. Aborts whatever runs.
    Abort = 0x31 => write(), "Abort whatever runs.";
    /// (empty) → [`Status`].
    GetStatus = 0x32 => read(), "Ask for the status.";
    /// [`Capabilities`].
    Capabilities = 0x80 => reply(Capabilities), "Head capabilities.";
    /// [`Ack`].
    Ack = 0x81 => reply(Ack), "Success.";
    /// [`Nak`] (header flag ERROR set).
    Nak = 0x82 => reply(Nak), "Failure.";
    /// [`UploadAck`].
    UploadAck = 0x83 => reply(UploadAck), "Upload progress.";
    /// [`ValidationStatus`].
    Validation = 0x84 => reply(ValidationStatus), "Result of ValidateSequence.";
    /// [`Status`].
    Status = 0x85 => reply(Status), "Status.";
    /// [`ResultRow`].
    ResultRow = 0x86 => reply(ResultRow<'a>), "A result row segment.";
    /// [`ScanDone`].
    ScanDone = 0x87 => reply(ScanDone), "End of a scan.";
}

impl TryFrom<u8> for Command {
    type Error = WireError;
    fn try_from(id: u8) -> Result<Self, WireError> {
        Command::from_u8(id).ok_or(WireError::UnknownCommand(id))
    }
}

// ---------------------------------------------------------------------------------------------
// What every body file shares: its validation step and the field checks.

/// A message body: its field checks, run by [`Message::validate`] (and so on every encode and
/// decode). Bodies without rules keep the default.
trait Body {
    /// Check every field.
    fn validate_body(&self) -> Result<(), WireError> {
        Ok(())
    }
}

/// `Ok` if `ok`, else the rule `why`.
fn check(ok: bool, why: Invalid) -> Result<(), WireError> {
    if ok {
        Ok(())
    } else {
        Err(WireError::Invalid(why))
    }
}

/// Every value is finite, else [`Invalid::NotFinite`].
fn finite64(xs: &[f64]) -> Result<(), WireError> {
    check(xs.iter().all(|x| x.is_finite()), Invalid::NotFinite)
}

/// A pattern bit depth the head projects: `1..=MAX_BIT_DEPTH`.
fn bit_depth_ok(b: u8) -> bool {
    (1..=MAX_BIT_DEPTH).contains(&b)
}

fn ser<T: Serialize>(value: &T, out: &mut [u8]) -> Result<usize, WireError> {
    match postcard::to_slice(value, out) {
        Ok(used) => Ok(used.len()),
        Err(postcard::Error::SerializeBufferFull) => Err(WireError::BufferTooSmall),
        Err(_) => Err(WireError::Payload),
    }
}

fn de<'a, T: Deserialize<'a>>(payload: &'a [u8]) -> Result<T, WireError> {
    match postcard::take_from_bytes(payload) {
        Ok((v, [])) => Ok(v),
        Ok(_) => Err(WireError::TrailingBytes),
        Err(_) => Err(WireError::Payload),
    }
}

fn empty(payload: &[u8]) -> Result<(), WireError> {
    if payload.is_empty() {
        Ok(())
    } else {
        Err(WireError::TrailingBytes)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_table_is_in_id_order_and_names_round_trip() {
        let ids: [u8; Command::ALL.len()] = core::array::from_fn(|i| Command::ALL[i] as u8);
        assert!(ids.windows(2).all(|w| w[0] < w[1]), "{ids:02x?}");
        for c in Command::ALL {
            assert_eq!(Command::from_u8(c as u8), Some(c));
            assert_eq!(
                Command::ALL.iter().filter(|d| d.name() == c.name()).count(),
                1
            );
            assert!(!c.is_write() || c.is_request(), "{}", c.name());
        }
        assert_eq!(Command::UploadChunk.name(), "UploadChunk");
        assert_eq!(Command::ScanDone.name(), "ScanDone");
    }
}
