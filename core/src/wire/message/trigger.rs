//! The trigger sequence: a DLPC350-style look-up table of patterns, exposures and triggers, and
//! what the head's validation of it found.

use serde::{Deserialize, Deserializer, Serialize, Serializer};

use super::{Body, Invalid, LUT_ENTRY_LEN, MAX_LUT_ENTRIES, WireError, bit_depth_ok, check};

/// One entry of the trigger look-up table (DLPC350-style pattern LUT).
///
/// Packed on the wire as 12 bytes, little-endian:
///
/// | offset | size | field                                            |
/// |-------:|-----:|--------------------------------------------------|
/// | 0      | 2    | `pattern`                                        |
/// | 2      | 4    | `exposure_us`                                    |
/// | 6      | 4    | `dark_us`                                        |
/// | 10     | 1    | `bit_depth`                                      |
/// | 11     | 1    | bit 0 `wait_for_trigger`, bit 1 `trigger_out`, bits 2-7 reserved 0 |
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct LutEntry {
    /// Index of the pattern in the set (levels in order, shifts in order).
    pub pattern: u16,
    /// Exposure (pattern display) time, µs, `>= 1`.
    pub exposure_us: u32,
    /// Dark time after the exposure, µs.
    pub dark_us: u32,
    /// Bit depth to display, `1..=MAX_BIT_DEPTH`.
    pub bit_depth: u8,
    /// Wait for the external trigger input before this pattern.
    pub wait_for_trigger: bool,
    /// Pulse the camera trigger output with this pattern.
    pub trigger_out: bool,
}

impl LutEntry {
    /// The packed form.
    pub fn to_bytes(&self) -> [u8; LUT_ENTRY_LEN] {
        let mut b = [0u8; LUT_ENTRY_LEN];
        b[0..2].copy_from_slice(&self.pattern.to_le_bytes());
        b[2..6].copy_from_slice(&self.exposure_us.to_le_bytes());
        b[6..10].copy_from_slice(&self.dark_us.to_le_bytes());
        b[10] = self.bit_depth;
        b[11] = self.wait_for_trigger as u8 | (self.trigger_out as u8) << 1;
        b
    }

    /// Unpack and validate one entry.
    pub fn from_bytes(b: &[u8; LUT_ENTRY_LEN]) -> Result<LutEntry, WireError> {
        let e = Self::unpack(b);
        check(b[11] & !0b11 == 0, Invalid::ReservedBits)?;
        e.validate()?;
        Ok(e)
    }

    fn unpack(b: &[u8; LUT_ENTRY_LEN]) -> LutEntry {
        LutEntry {
            pattern: u16::from_le_bytes([b[0], b[1]]),
            exposure_us: u32::from_le_bytes([b[2], b[3], b[4], b[5]]),
            dark_us: u32::from_le_bytes([b[6], b[7], b[8], b[9]]),
            bit_depth: b[10],
            wait_for_trigger: b[11] & 1 != 0,
            trigger_out: b[11] & 2 != 0,
        }
    }

    /// Check the bit depth and exposure.
    pub fn validate(&self) -> Result<(), WireError> {
        check(
            bit_depth_ok(self.bit_depth) && self.exposure_us >= 1,
            Invalid::LutEntry,
        )
    }
}

/// A borrowed table of packed [`LutEntry`]s; on the wire a postcard byte string (varint length,
/// then the entries). The length is always a multiple of [`LUT_ENTRY_LEN`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LutTable<'a>(&'a [u8]);

impl<'a> LutTable<'a> {
    /// Wrap packed entries, validating every one and the count (`1..=MAX_LUT_ENTRIES`).
    pub fn new(bytes: &'a [u8]) -> Result<Self, WireError> {
        let t = LutTable::from_raw(bytes)?;
        t.validate()?;
        Ok(t)
    }

    fn from_raw(bytes: &'a [u8]) -> Result<Self, WireError> {
        check(
            bytes.len().is_multiple_of(LUT_ENTRY_LEN),
            Invalid::LutLength,
        )?;
        Ok(LutTable(bytes))
    }

    /// Pack `entries` into `out` and wrap the result.
    pub fn encode(entries: &[LutEntry], out: &'a mut [u8]) -> Result<Self, WireError> {
        let n = entries.len() * LUT_ENTRY_LEN;
        let out = out.get_mut(..n).ok_or(WireError::BufferTooSmall)?;
        for (e, dst) in entries.iter().zip(out.chunks_exact_mut(LUT_ENTRY_LEN)) {
            dst.copy_from_slice(&e.to_bytes());
        }
        LutTable::new(out)
    }

    /// The packed bytes.
    pub const fn as_bytes(&self) -> &'a [u8] {
        self.0
    }

    /// Number of entries.
    pub const fn len(&self) -> usize {
        self.0.len() / LUT_ENTRY_LEN
    }

    /// `true` if there are no entries.
    pub const fn is_empty(&self) -> bool {
        self.0.len() < LUT_ENTRY_LEN
    }

    /// Entry `i`.
    pub fn get(&self, i: usize) -> Option<LutEntry> {
        let start = i.checked_mul(LUT_ENTRY_LEN)?;
        let b = self.0.get(start..start.checked_add(LUT_ENTRY_LEN)?)?;
        b.try_into().ok().map(LutEntry::unpack)
    }

    /// The entries in order.
    pub fn iter(&self) -> impl Iterator<Item = LutEntry> + 'a {
        self.0
            .chunks_exact(LUT_ENTRY_LEN)
            .filter_map(|c| c.try_into().ok().map(LutEntry::unpack))
    }

    /// Check the count and every entry.
    pub fn validate(&self) -> Result<(), WireError> {
        check(
            (1..=MAX_LUT_ENTRIES).contains(&self.len()),
            Invalid::LutLength,
        )?;
        for c in self.0.chunks_exact(LUT_ENTRY_LEN) {
            let b: &[u8; LUT_ENTRY_LEN] = c
                .try_into()
                .map_err(|_| WireError::Invalid(Invalid::LutLength))?;
            LutEntry::from_bytes(b)?;
        }
        Ok(())
    }
}

impl Serialize for LutTable<'_> {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_bytes(self.0)
    }
}

impl<'de: 'a, 'a> Deserialize<'de> for LutTable<'a> {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let bytes = <&'de [u8]>::deserialize(d)?;
        LutTable::from_raw(bytes)
            .map_err(|_| serde::de::Error::invalid_length(bytes.len(), &"a multiple of 12 bytes"))
    }
}

/// Host → head: the trigger sequence over pattern set `set_id`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Sequence<'a> {
    /// The pattern set the entries index.
    pub set_id: u8,
    /// Repeat the sequence until Stop (otherwise run it once per Start).
    pub repeat: bool,
    /// The entries, `1..=MAX_LUT_ENTRIES`.
    #[serde(borrow)]
    pub entries: LutTable<'a>,
}

/// A bit-field: what the head's Validate found wrong with the configured sequence (0 = valid).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct ValidationStatus(pub u32);

impl ValidationStatus {
    /// Nothing wrong.
    pub const OK: ValidationStatus = ValidationStatus(0);
    /// No sequence configured.
    pub const NO_SEQUENCE: u32 = 1 << 0;
    /// The sequence's pattern set is not defined.
    pub const NO_PATTERN_SET: u32 = 1 << 1;
    /// The pattern set's upload digest has not been confirmed.
    pub const SET_NOT_CONFIRMED: u32 = 1 << 2;
    /// An entry's pattern index is beyond the set.
    pub const PATTERN_INDEX: u32 = 1 << 3;
    /// An exposure is shorter than the hardware allows for its bit depth.
    pub const EXPOSURE: u32 = 1 << 4;
    /// A dark time is shorter than the camera readout.
    pub const DARK_TIME: u32 = 1 << 5;
    /// An entry's bit depth differs from the set's.
    pub const BIT_DEPTH: u32 = 1 << 6;
    /// Trigger settings are inconsistent (e.g. no entry triggers the camera).
    pub const TRIGGER: u32 = 1 << 7;
    /// No calibration uploaded.
    pub const NO_CALIBRATION: u32 = 1 << 8;
    /// No confirmed reference phase map.
    pub const NO_REFERENCE: u32 = 1 << 9;
    /// A sequence or scan is running.
    pub const BUSY: u32 = 1 << 10;
    /// The capture order cannot be decoded frame by frame: a Gray-code image before the last
    /// image of the DC level (`DecodeError::GrayBeforeDc`, issue #20).
    pub const CAPTURE_ORDER: u32 = 1 << 11;
    /// A binary set (waveform 2-5) has no phase-error table ([`super::DefineCorrection`]):
    /// decoded uncorrected, its square waves' error would be measured as shape (protocol 4).
    pub const NO_CORRECTION: u32 = 1 << 12;
    /// All defined bits.
    pub const ALL: u32 = (1 << 13) - 1;

    /// `true` if no bit is set.
    pub const fn is_ok(self) -> bool {
        self.0 == 0
    }

    /// `true` if bit(s) `bit` are all set.
    pub const fn has(self, bit: u32) -> bool {
        self.0 & bit == bit
    }

    /// Check that no reserved bit is set.
    pub fn validate(&self) -> Result<(), WireError> {
        check(self.0 & !Self::ALL == 0, Invalid::ReservedBits)
    }
}

impl Body for Sequence<'_> {
    fn validate_body(&self) -> Result<(), WireError> {
        self.entries.validate()
    }
}

impl Body for ValidationStatus {
    fn validate_body(&self) -> Result<(), WireError> {
        self.validate()
    }
}
