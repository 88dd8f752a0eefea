//! The 6-byte frame header.
//!
//! | offset | size | field                                   |
//! |-------:|-----:|-----------------------------------------|
//! | 0      | 1    | protocol version, [`PROTOCOL_VERSION`]  |
//! | 1      | 1    | flags, [`Flags`]                        |
//! | 2      | 1    | sequence number                         |
//! | 3      | 1    | command id, [`Command`](super::Command) |
//! | 4      | 2    | payload length, u16 little-endian       |

use super::{MAX_PAYLOAD, WireError};

/// The protocol version this module speaks; frames of any other version are rejected.
///
/// Version 11 ends ScanDone with two counts over the scan's rows: the pixels decoded and those
/// whose point the §6 search computed (of a compiled scan, those its models left to the
/// search: the fallback rate), which a version-10 host would not read.
/// Version 10 gives each compiled model an eleventh number, its own far threshold τ_far (44
/// bytes a pixel instead of 40): a version-9 head would take the models' rows for the wrong
/// layout; and Status ends with what the head holds ([`Holds`](super::Holds): calibration,
/// reference map, compiled models).
/// Version 9 adds BeginCompiledUpload and the upload target `[2]` (issue #24 item 1): a head of
/// version 9 takes the compiled reconstruction's models and reconstructs the pixels that have
/// one without the search.
/// Version 8 adds the exposure list to Scan ([`Exposures`](super::Exposures), issue #19 item 4):
/// a head of version 8 captures the sequence once per exposure and fuses them per pixel (HDR).
/// Version 7 adds DefineThresholds: a head of version 7 decodes a set with the host's thresholds
/// (the minimum modulation in the sensor's noise, the saturation level), not only with its camera
/// bit depth's defaults.
/// Version 6 adds the reference map's margin past the image (issue #17) to BeginPhaseMapUpload:
/// a head of version 6 reconstructs with a map wider than the image, which a version-5 head would
/// take for a map of the wrong size; and the shifted Gray code (`Shifts` value 4, issue #20).
/// Version 5 adds the validity code 12, `light-edge` (the edge filter flags a point beside a
/// pixel without light): a head of version 5 sends it in ResultRow, which a version-4 host
/// would refuse row by row.
/// Version 4 ends the pattern-set description with the levels' relation (hierarchical,
/// multi-frequency heterodyne or coprime) and adds DefineCorrection, the decoder's phase-error table for
/// the projector's response or a binary set's blur.
/// Version 3 adds a scan identity (`scan_id`, u32) to Scan, ResultRow and ScanDone, so that rows
/// of an earlier scan still in flight are told apart. Version 2 carries the pattern-set description and the calibration as f64 (the values the
/// core's set-up consumes, so the head computes exactly what the desktop computes), describes
/// knot profiles and curved fringes, and adds the edge-filter mode to Scan. Version 1 carried
/// f32 and linear phase functions only.
pub const PROTOCOL_VERSION: u8 = 11;

/// Length of the header in bytes.
pub const HEADER_LEN: usize = 6;

/// The header's flag byte.
///
/// | bit | flag                          |
/// |----:|-------------------------------|
/// | 0   | [`Flags::WRITE`]              |
/// | 1   | [`Flags::REPLY_WANTED`]       |
/// | 2   | [`Flags::ERROR`]              |
/// | 3   | [`Flags::MORE_FOLLOWS`]       |
/// | 4-7 | reserved, must be 0           |
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct Flags(u8);

impl Flags {
    /// No flag set.
    pub const NONE: Flags = Flags(0);
    /// The request changes the head's state (DLPC350's R/W bit). Must equal
    /// [`Command::is_write`](super::Command::is_write) of the frame's command; 0 on replies.
    pub const WRITE: Flags = Flags(1 << 0);
    /// On a write request: the sender wants its reply (Ack, UploadAck...). Without it the head
    /// answers only failures. Read requests are always answered.
    pub const REPLY_WANTED: Flags = Flags(1 << 1);
    /// The frame reports a failure: set exactly on [`Nak`](super::Message::Nak) frames.
    pub const ERROR: Flags = Flags(1 << 2);
    /// More frames of the same answer follow (a Scan's Ack and result rows; all but its final
    /// ScanDone). Advisory: the parser does not enforce it.
    pub const MORE_FOLLOWS: Flags = Flags(1 << 3);
    /// All defined bits.
    pub const ALL: Flags = Flags(0x0F);

    /// The raw byte.
    pub const fn bits(self) -> u8 {
        self.0
    }

    /// Flags from a byte, or `None` if a reserved bit is set.
    pub const fn from_bits(bits: u8) -> Option<Flags> {
        if bits & !Self::ALL.0 == 0 {
            Some(Flags(bits))
        } else {
            None
        }
    }

    /// `true` if every flag of `other` is set in `self`.
    pub const fn contains(self, other: Flags) -> bool {
        self.0 & other.0 == other.0
    }

    /// The union of both sets.
    pub const fn union(self, other: Flags) -> Flags {
        Flags(self.0 | other.0)
    }

    /// `self` without the flags of `other`.
    pub const fn difference(self, other: Flags) -> Flags {
        Flags(self.0 & !other.0)
    }

    /// `self` with the flags of `other` set or cleared according to `on`.
    pub const fn with(self, other: Flags, on: bool) -> Flags {
        if on {
            self.union(other)
        } else {
            self.difference(other)
        }
    }
}

impl core::ops::BitOr for Flags {
    type Output = Flags;
    fn bitor(self, rhs: Flags) -> Flags {
        self.union(rhs)
    }
}

impl core::ops::BitOrAssign for Flags {
    fn bitor_assign(&mut self, rhs: Flags) {
        *self = self.union(rhs);
    }
}

/// A parsed frame header (the version byte is implicit: always [`PROTOCOL_VERSION`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Header {
    /// Flag bits.
    pub flags: Flags,
    /// Rolling sequence number chosen by the requester and echoed in every reply to the request.
    pub seq: u8,
    /// Command id (see [`Command`](super::Command)); kept raw so an unknown command can still be
    /// answered with a Nak echoing `seq`.
    pub command: u8,
    /// Payload length in bytes, at most [`MAX_PAYLOAD`]. Filled in by the emitters.
    pub payload_len: u16,
}

impl Header {
    /// Parse the first [`HEADER_LEN`] bytes of `bytes`.
    ///
    /// Checks the version ([`WireError::Version`]), the reserved flag bits
    /// ([`WireError::ReservedFlags`]) and `payload_len <= MAX_PAYLOAD` ([`WireError::Length`]).
    /// Does not check the command id.
    pub fn parse(bytes: &[u8]) -> Result<Header, WireError> {
        let h: &[u8; HEADER_LEN] = bytes
            .get(..HEADER_LEN)
            .and_then(|s| s.try_into().ok())
            .ok_or(WireError::Truncated)?;
        if h[0] != PROTOCOL_VERSION {
            return Err(WireError::Version(h[0]));
        }
        let flags = Flags::from_bits(h[1]).ok_or(WireError::ReservedFlags)?;
        let payload_len = u16::from_le_bytes([h[4], h[5]]);
        if payload_len as usize > MAX_PAYLOAD {
            return Err(WireError::Length);
        }
        Ok(Header {
            flags,
            seq: h[2],
            command: h[3],
            payload_len,
        })
    }

    /// Write the header into the first [`HEADER_LEN`] bytes of `out`; returns [`HEADER_LEN`].
    ///
    /// Fails with [`WireError::BufferTooSmall`], or [`WireError::Length`] if
    /// `payload_len > MAX_PAYLOAD`.
    pub fn emit(&self, out: &mut [u8]) -> Result<usize, WireError> {
        if self.payload_len as usize > MAX_PAYLOAD {
            return Err(WireError::Length);
        }
        let h = out.get_mut(..HEADER_LEN).ok_or(WireError::BufferTooSmall)?;
        let len = self.payload_len.to_le_bytes();
        h.copy_from_slice(&[
            PROTOCOL_VERSION,
            self.flags.bits(),
            self.seq,
            self.command,
            len[0],
            len[1],
        ]);
        Ok(HEADER_LEN)
    }
}
