//! Status, Ack and Nak: the head's state and counters, and the answers to requests.

use serde::{Deserialize, Serialize};

use super::{Body, Invalid, WireError, check};

/// The head's state machine.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum HeadState {
    /// Nothing configured or running (wire value 0).
    Idle,
    /// An upload is open (1).
    Uploading,
    /// A validated sequence is ready to start (2).
    Ready,
    /// The sequence is projecting (3).
    Running,
    /// A scan is capturing and streaming (4).
    Scanning,
    /// A fault stopped the head; see the error flags (5).
    Fault,
}

/// A bit-field of faults the head has seen since the last status read.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct HeadErrors(pub u32);

impl HeadErrors {
    /// Frames were dropped on the link (COBS, CRC, overflow).
    pub const LINK: u32 = 1 << 0;
    /// An upload failed its digest.
    pub const UPLOAD: u32 = 1 << 1;
    /// A trigger input did not arrive in time.
    pub const TRIGGER_TIMEOUT: u32 = 1 << 2;
    /// Camera fault.
    pub const CAMERA: u32 = 1 << 3;
    /// Projector fault.
    pub const PROJECTOR: u32 = 1 << 4;
    /// Result rows were dropped because the link was too slow.
    pub const OVERRUN: u32 = 1 << 5;
    /// Out of memory.
    pub const MEMORY: u32 = 1 << 6;
    /// Internal error.
    pub const INTERNAL: u32 = 1 << 7;
    /// All defined bits.
    pub const ALL: u32 = 0xFF;

    /// Check that no reserved bit is set.
    pub fn validate(&self) -> Result<(), WireError> {
        check(self.0 & !Self::ALL == 0, Invalid::ReservedBits)
    }
}

/// A bit-field: what the head holds, each confirmed (protocol version 10). A point scan needs
/// the calibration and the reference map; with the compiled models too, it reconstructs the
/// pixels that have one without the search (docs/compiled.md).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct Holds(pub u32);

impl Holds {
    /// A calibration (UploadCalibration).
    pub const CALIBRATION: u32 = 1 << 0;
    /// A confirmed reference phase map.
    pub const REFERENCE: u32 = 1 << 1;
    /// Confirmed compiled models of that calibration and map.
    pub const COMPILED: u32 = 1 << 2;
    /// All defined bits.
    pub const ALL: u32 = 0x7;

    /// `true` if bit(s) `bit` are all set.
    pub const fn has(self, bit: u32) -> bool {
        self.0 & bit == bit
    }

    /// Check that no reserved bit is set.
    pub fn validate(&self) -> Result<(), WireError> {
        check(self.0 & !Self::ALL == 0, Invalid::ReservedBits)
    }
}

/// Head → host: state and counters.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Status {
    /// State machine state.
    pub state: HeadState,
    /// Faults seen.
    pub errors: HeadErrors,
    /// Frames received intact.
    pub rx_frames: u32,
    /// Frames received damaged.
    pub rx_errors: u32,
    /// Frames sent.
    pub tx_frames: u32,
    /// Result rows sent.
    pub rows_sent: u32,
    /// What the head holds ([`Holds`] bits; protocol version 10).
    pub holds: Holds,
}

/// Head → host: the request with the header's `seq` succeeded.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Ack {
    /// The command acknowledged.
    pub command: u8,
}

/// Why a request failed. The wire value is the position in this list (shown in brackets).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum NakCode {
    /// \[0] The frame's CRC was wrong.
    Crc,
    /// \[1] The frame was malformed (COBS, length, truncated).
    Framing,
    /// \[2] Unsupported protocol version.
    Version,
    /// \[3] Unknown command id.
    UnknownCommand,
    /// \[4] The payload did not decode, or flags contradict the command.
    Malformed,
    /// \[5] A field is out of range; `detail` is the [`Invalid`] code.
    Invalid,
    /// \[6] The head is busy (a sequence or scan runs).
    Busy,
    /// \[7] The request is not allowed in the current state.
    NotReady,
    /// \[8] No such pattern set (or not confirmed).
    NoSuchSet,
    /// \[9] The uploaded data does not match the announced digest.
    DigestMismatch,
    /// \[10] Not enough memory.
    OutOfMemory,
    /// \[11] The chunk does not start at the expected offset; `detail` is unused, query the
    /// offset with QueryUpload.
    BadOffset,
    /// \[12] No upload is open for the target.
    NoUpload,
    /// \[13] The sequence is invalid (Validate tells why).
    SequenceInvalid,
    /// \[14] Aborted by the host.
    Aborted,
    /// \[15] Internal error.
    Internal,
}

/// Head → host: the request with the header's `seq` failed. Sent with
/// [`Flags::ERROR`](crate::wire::Flags::ERROR).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Nak {
    /// The command refused (0 if unknown).
    pub command: u8,
    /// Why.
    pub code: NakCode,
    /// Code-specific detail (e.g. the [`Invalid`] code), else 0.
    pub detail: u16,
}

impl Nak {
    /// The Nak answering a request that failed to parse with `err`.
    pub const fn for_error(command: u8, err: WireError) -> Nak {
        let (code, detail) = match err {
            WireError::Crc => (NakCode::Crc, 0),
            WireError::Cobs | WireError::Truncated | WireError::Overflow | WireError::Length => {
                (NakCode::Framing, 0)
            }
            WireError::Version(_) => (NakCode::Version, 0),
            WireError::UnknownCommand(_) => (NakCode::UnknownCommand, 0),
            WireError::Invalid(why) => (NakCode::Invalid, why as u16),
            WireError::BufferTooSmall | WireError::PayloadTooLarge => (NakCode::Internal, 0),
            WireError::ReservedFlags
            | WireError::FlagMismatch
            | WireError::CommandMismatch
            | WireError::Payload
            | WireError::TrailingBytes => (NakCode::Malformed, 0),
        };
        Nak {
            command,
            code,
            detail,
        }
    }
}

impl Body for Status {
    fn validate_body(&self) -> Result<(), WireError> {
        self.errors.validate()?;
        self.holds.validate()
    }
}

impl Body for Ack {}

impl Body for Nak {}
