//! The host side of the scan-head link (project issue #7): a serial port, the wire protocol's
//! framing (the core's `wire` module, the very code the head runs), requests with timeouts and
//! retries, resumable uploads and streamed scans.
//!
//! - [`transport`]: what the link runs over — a serial port or PTY ([`SerialTransport`], via
//!   `serialport` and `embedded-io-adapters`), or any `embedded-io` byte stream ([`Transport`]);
//! - [`link`]: frames on a transport: sequence numbers, emit, receive with a deadline, counters;
//! - [`client`]: the commands — [`Client::connect`], uploads, sequence, scans;
//! - [`interrupt`]: Ctrl-C during a scan aborts it on the head before the process exits;
//! - [`desc`]: desktop data in wire form: pattern sets (with the check that the head will rebuild
//!   the very same set), calibrations, trigger tables, image and phase-map bytes.
//!
//! Errors are [`DeviceError`]: every message says what failed and what to do about it.

pub mod client;
pub mod desc;
pub mod interrupt;
pub mod link;
pub mod transport;

pub use client::{Client, ClientOptions, ScanOutcome, UploadReport};
pub use link::{Link, LinkStats};
pub use transport::{SerialTransport, Transport, open_serial};

use fringe3d_core::wire::NakCode;

/// Why talking to the head failed.
#[derive(Debug, thiserror::Error)]
pub enum DeviceError {
    /// The serial port could not be opened.
    #[error(
        "cannot open {path}: {message} (is the scan head plugged in and powered? check the port name and your permissions)"
    )]
    Open {
        /// The port.
        path: String,
        /// The system's reason.
        message: String,
    },
    /// Nothing intact came back, even after retries.
    #[error(
        "no answer from the device to {what} after {attempts} attempts{noise}: is a fringe3d scan head connected, powered and set to this baud rate?"
    )]
    NoResponse {
        /// The request.
        what: String,
        /// Attempts made.
        attempts: u32,
        /// A note on damaged frames seen, if any.
        noise: String,
    },
    /// The port failed: the device was unplugged or the line closed.
    #[error("the device disconnected during {what}: {message}")]
    Disconnected {
        /// What was going on.
        what: String,
        /// The system's reason.
        message: String,
    },
    /// The device answers in another protocol version.
    #[error(
        "the device speaks protocol version {device}, this fringe3d speaks version {host}: update the head's firmware or fringe3d so that they match"
    )]
    Version {
        /// The device's version.
        device: u8,
        /// Ours.
        host: u8,
    },
    /// The device refused a request (a Nak).
    #[error("the device refused {what}: {reason}")]
    Refused {
        /// The request.
        what: String,
        /// The Nak code.
        code: NakCode,
        /// The Nak detail.
        detail: u16,
        /// In words.
        reason: String,
    },
    /// An upload stopped; the head keeps what it acknowledged.
    #[error(
        "upload of {what} stopped at byte {acked} of {total}: {cause}. Nothing unconfirmed is ever used; run the same command again to resume from byte {acked}"
    )]
    UploadInterrupted {
        /// The upload.
        what: String,
        /// Bytes the head acknowledged.
        acked: u64,
        /// Bytes in all.
        total: u64,
        /// Why.
        cause: Box<DeviceError>,
    },
    /// The head's copy failed its digest check.
    #[error(
        "the device's copy of {what} does not match what was sent (CRC-32C digest mismatch); it was discarded, nothing was used: upload it again"
    )]
    DigestMismatch {
        /// The upload.
        what: String,
    },
    /// A scan did not deliver every row, even after re-requests.
    #[error(
        "scan incomplete: {missing} of {rows} rows missing after {attempts} re-requests (line too noisy?)"
    )]
    ScanIncomplete {
        /// Rows still missing.
        missing: usize,
        /// Rows requested.
        rows: usize,
        /// Re-requests made.
        attempts: u32,
    },
    /// The command was interrupted (Ctrl-C, or the interrupt flag set).
    #[error("interrupted during {what}{note}")]
    Interrupted {
        /// What was going on.
        what: String,
        /// What became of the head's scan, if one ran.
        note: String,
    },
    /// The device broke the protocol (an answer of the wrong kind).
    #[error("protocol error: {0}")]
    Protocol(String),
    /// The data to send is not acceptable.
    #[error("{0}")]
    Input(String),
}

impl DeviceError {
    /// `true` for errors worth retrying the whole command for (line trouble, not refusals).
    pub fn is_transient(&self) -> bool {
        matches!(
            self,
            DeviceError::NoResponse { .. }
                | DeviceError::Disconnected { .. }
                | DeviceError::UploadInterrupted { .. }
                | DeviceError::ScanIncomplete { .. }
        )
    }
}

/// A Nak in words.
pub fn nak_reason(code: NakCode, detail: u16) -> String {
    use fringe3d_core::wire::{Invalid, ValidationStatus};
    match code {
        NakCode::Crc => "the frame arrived damaged (CRC)".into(),
        NakCode::Framing => "the frame arrived damaged (framing)".into(),
        NakCode::Version => {
            format!("unsupported protocol version (the device speaks version {detail})")
        }
        NakCode::UnknownCommand => "unknown command (older firmware?)".into(),
        NakCode::Malformed => "malformed request".into(),
        NakCode::Invalid => match Invalid::from_u8(detail as u8) {
            Some(why) => format!("a field is out of range ({})", why.name()),
            None => format!("a field is out of range (code {detail})"),
        },
        NakCode::Busy => "the device is busy: a sequence runs or a scan streams (`fringe3d device \
             abort` ends either; `fringe3d device stop` ends a running sequence only)"
            .into(),
        NakCode::NotReady => {
            "not allowed in the device's current state (a fault? send abort)".into()
        }
        NakCode::NoSuchSet => "no such pattern set on the device (define it first)".into(),
        NakCode::DigestMismatch => "the uploaded data does not match its digest".into(),
        NakCode::OutOfMemory => "the device has not enough memory for this".into(),
        NakCode::BadOffset => "chunk at the wrong offset".into(),
        NakCode::NoUpload => "no upload is open for this target".into(),
        NakCode::SequenceInvalid => {
            let v = ValidationStatus(detail as u32);
            let mut why = Vec::new();
            for (bit, name) in [
                (
                    ValidationStatus::NO_SEQUENCE,
                    "no trigger sequence configured",
                ),
                (
                    ValidationStatus::NO_PATTERN_SET,
                    "the sequence's pattern set is not defined",
                ),
                (
                    ValidationStatus::SET_NOT_CONFIRMED,
                    "the pattern set's upload is not confirmed",
                ),
                (
                    ValidationStatus::PATTERN_INDEX,
                    "a pattern index is beyond the set",
                ),
                (ValidationStatus::EXPOSURE, "an exposure is too short"),
                (
                    ValidationStatus::DARK_TIME,
                    "a dark time is shorter than the camera readout",
                ),
                (
                    ValidationStatus::BIT_DEPTH,
                    "an entry's bit depth differs from the set's",
                ),
                (
                    ValidationStatus::TRIGGER,
                    "the camera-triggered entries do not capture every pattern once",
                ),
                (ValidationStatus::NO_CALIBRATION, "no calibration uploaded"),
                (
                    ValidationStatus::NO_REFERENCE,
                    "no confirmed reference phase map",
                ),
                (ValidationStatus::BUSY, "the device is busy"),
                (
                    ValidationStatus::CAPTURE_ORDER,
                    "a Gray-code pattern is captured before the last image of the DC level \
                     (the head decodes frame by frame: capture the phase level first)",
                ),
                (
                    ValidationStatus::NO_CORRECTION,
                    "a binary pattern set has no phase-error table (upload it with a \
                     calibration that records projector_defocus)",
                ),
            ] {
                if v.has(bit) {
                    why.push(name);
                }
            }
            if why.is_empty() {
                "the sequence is invalid".into()
            } else {
                format!("the sequence is not ready: {}", why.join(", "))
            }
        }
        NakCode::Aborted => "aborted".into(),
        NakCode::Internal => format!("internal error on the device (error bits {detail:#x})"),
    }
}
