//! Scanning: the scan request, the result rows streamed back and the end-of-scan summary.

use serde::{Deserialize, Serialize};

use super::{Body, Invalid, MAX_ROW_DATA, WireError, check, finite64};
use crate::Validity;
use crate::decode::hdr::MAX_EXPOSURES;

/// The longest exposure a scan may ask for, µs (60 s; `device upload --exposure-us` has the same
/// bound).
pub const MAX_EXPOSURE_US: u32 = 60_000_000;

/// The exposures of an HDR scan (protocol version 8, issue #19 item 4): the sequence runs once
/// per exposure, longest first, each camera-triggered entry exposed for that time, and the head
/// keeps for each pixel the decode of the longest exposure in which none of its samples
/// saturated ([`crate::decode::hdr`], [`crate::sequential::FrameDecoder::next_exposure`]).
///
/// Wire: `count u8, 4 × exposure_us u32` (unused slots 0). `count` 0 runs the sequence once with
/// its own entries' exposures (a plain scan); 1 runs it once with every camera-triggered entry
/// exposed for `exposure_us[0]`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct Exposures {
    /// Exposures in use, `0..=MAX_EXPOSURES`.
    pub count: u8,
    /// The exposures, µs, strictly decreasing, each `1..=MAX_EXPOSURE_US`; unused slots 0.
    pub exposure_us: [u32; MAX_EXPOSURES],
}

impl Exposures {
    /// No list: the sequence's own exposures, one pass.
    pub const NONE: Exposures = Exposures {
        count: 0,
        exposure_us: [0; MAX_EXPOSURES],
    };

    /// The list `us` (longest first), if it is one: at most [`MAX_EXPOSURES`] values, each
    /// `1..=MAX_EXPOSURE_US`, strictly decreasing.
    pub fn new(us: &[u32]) -> Result<Exposures, WireError> {
        let mut e = Exposures::NONE;
        check(us.len() <= MAX_EXPOSURES, Invalid::Exposures)?;
        e.count = us.len() as u8;
        e.exposure_us[..us.len()].copy_from_slice(us);
        e.validate()?;
        Ok(e)
    }

    /// The exposures in use, longest first.
    pub fn as_slice(&self) -> &[u32] {
        let n = (self.count as usize).min(MAX_EXPOSURES);
        &self.exposure_us[..n]
    }

    /// The number of passes of the sequence a scan makes: `count`, at least 1.
    pub fn passes(&self) -> usize {
        self.as_slice().len().max(1)
    }

    /// The exposure of pass `pass` (`None`: the entries' own).
    pub fn of_pass(&self, pass: usize) -> Option<u32> {
        self.as_slice().get(pass).copied()
    }

    /// Check the rules of [`Exposures::new`] and that unused slots are 0.
    pub fn validate(&self) -> Result<(), WireError> {
        let n = self.count as usize;
        check(n <= MAX_EXPOSURES, Invalid::Exposures)?;
        let (used, unused) = self.exposure_us.split_at(n);
        check(unused.iter().all(|&u| u == 0), Invalid::UnusedSlot)?;
        check(
            used.iter().all(|&u| (1..=MAX_EXPOSURE_US).contains(&u))
                && used.windows(2).all(|p| p[0] > p[1]),
            Invalid::Exposures,
        )
    }
}

/// What a scan streams back.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum ScanOutput {
    /// Absolute phase rows (wire value 0).
    Phase,
    /// Point rows (wire value 1).
    Points,
    /// Both, phase row first (wire value 2).
    Both,
}

/// Whether a point scan runs the edge filter ([`EdgeFilter`](crate::filter::EdgeFilter),
/// as `fringe3d scan` does by default).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum EdgeFilterMode {
    /// No filter (wire value 0).
    Off,
    /// Flag points steeper than this many degrees from facing the camera, `0 < angle < 90`
    /// (wire value 1, then the f64).
    MaxAngle(f64),
}

/// Host → head: run the configured sequence, decode, stream rows.
///
/// `scan_id` names the scan: the head copies it into every [`ResultRow`] and the [`ScanDone`] it
/// streams in answer, so a host can tell this scan's rows from rows of an earlier scan still in
/// flight (adapter or driver buffers, a host killed mid-scan). The host picks it; it should not
/// repeat between scans (protocol version 3).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ScanRequest {
    /// The scan's identity, echoed in its rows and its ScanDone.
    pub scan_id: u32,
    /// What to stream.
    pub output: ScanOutput,
    /// First camera row to stream.
    pub first_row: u16,
    /// Number of rows (0 = to the last row).
    pub row_count: u16,
    /// The edge filter of point rows (ignored for phase rows).
    pub edge_filter: EdgeFilterMode,
    /// The exposure list of an HDR scan ([`Exposures::NONE`]: the sequence's own, one pass).
    pub exposures: Exposures,
}

impl ScanRequest {
    /// Check the filter angle and the exposure list.
    pub fn validate(&self) -> Result<(), WireError> {
        match self.edge_filter {
            EdgeFilterMode::Off => {}
            EdgeFilterMode::MaxAngle(a) => {
                finite64(&[a])?;
                check(a > 0.0 && a < 90.0, Invalid::EdgeFilter)?;
            }
        }
        self.exposures.validate()
    }
}

/// The kind of a [`ResultRow`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum RowKind {
    /// One f32 per column: the absolute phase (wire value 0).
    Phase,
    /// Three f32 per column: x, y, z in mm, camera frame (wire value 1).
    Points,
}

impl RowKind {
    /// f32 values per column.
    pub const fn components(self) -> usize {
        match self {
            RowKind::Phase => 1,
            RowKind::Points => 3,
        }
    }

    /// Data bytes per column: the f32s and one validity byte.
    pub const fn stride(self) -> usize {
        4 * self.components() + 1
    }
}

/// Head → host: a segment of one result row, columns `first_col ..`.
///
/// `data` holds `n` columns: first `n · components` little-endian f32s (points interleaved
/// x, y, z), then `n` [`Validity`] bytes. A row wider than [`MAX_ROW_DATA`] allows is sent as
/// several segments with increasing `first_col`. Like every frame answering a Scan except the
/// final [`ScanDone`], row frames carry [`Flags::MORE_FOLLOWS`](crate::wire::Flags::MORE_FOLLOWS).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct ResultRow<'a> {
    /// The [`ScanRequest::scan_id`] of the scan the row belongs to.
    pub scan_id: u32,
    /// Camera row.
    pub row: u16,
    /// Column of the segment's first value.
    pub first_col: u16,
    /// Phase or points.
    pub kind: RowKind,
    /// Values then validity bytes, `n · kind.stride()` bytes, `1..=MAX_ROW_DATA`.
    pub data: &'a [u8],
}

impl<'a> ResultRow<'a> {
    /// Lay out `values` (`n · kind.components()` f32s) and `validity` (`n` codes) into `out` as a
    /// row segment's `data`; returns the data slice.
    pub fn write_data<'o>(
        kind: RowKind,
        values: &[f32],
        validity: &[Validity],
        out: &'o mut [u8],
    ) -> Result<&'o [u8], WireError> {
        let n = validity.len();
        check(values.len() == n * kind.components(), Invalid::RowData)?;
        let vbytes = values.len() * 4;
        let out = out
            .get_mut(..n * kind.stride())
            .ok_or(WireError::BufferTooSmall)?;
        let (vals, codes) = out.split_at_mut(vbytes);
        for (x, dst) in values.iter().zip(vals.chunks_exact_mut(4)) {
            dst.copy_from_slice(&x.to_le_bytes());
        }
        for (v, dst) in validity.iter().zip(codes.iter_mut()) {
            *dst = *v as u8;
        }
        Ok(out)
    }

    /// Number of columns in the segment.
    pub const fn columns(&self) -> usize {
        self.data.len() / self.kind.stride()
    }

    /// Component `comp` of column `i` (relative to `first_col`).
    pub fn value(&self, i: usize, comp: usize) -> Option<f32> {
        let k = self.kind.components();
        if comp >= k || i >= self.columns() {
            return None;
        }
        let at = (i * k + comp) * 4;
        let b = self.data.get(at..at + 4)?;
        Some(f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
    }

    /// Validity of column `i` (relative to `first_col`).
    pub fn validity(&self, i: usize) -> Option<Validity> {
        let n = self.columns();
        if i >= n {
            return None;
        }
        let b = *self.data.get(n * 4 * self.kind.components() + i)?;
        Validity::from_u8(b)
    }

    /// Check the length and the validity codes.
    pub fn validate(&self) -> Result<(), WireError> {
        let stride = self.kind.stride();
        let len = self.data.len();
        check(
            (1..=MAX_ROW_DATA).contains(&len) && len.is_multiple_of(stride),
            Invalid::RowData,
        )?;
        let n = len / stride;
        check(
            self.first_col as usize + n <= u16::MAX as usize + 1,
            Invalid::RowData,
        )?;
        let codes = &self.data[n * 4 * self.kind.components()..];
        check(
            codes.iter().all(|&b| Validity::from_u8(b).is_some()),
            Invalid::ValidityCode,
        )
    }
}

/// Head → host: the scan finished (after its last [`ResultRow`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct ScanDone {
    /// The [`ScanRequest::scan_id`] of the scan that finished.
    pub scan_id: u32,
    /// Rows streamed.
    pub rows: u16,
    /// Valid pixels (phase) or points over the rows streamed.
    pub valid: u32,
    /// Pixels with a valid phase over the rows streamed (not the edge filter's extra rows):
    /// the reconstruction's input (version 11).
    pub decoded: u32,
    /// Of them, the pixels whose point the §6 search computed (version 11): every one without
    /// compiled models, those the models left to the search with them (docs/compiled.md); 0
    /// in a phase scan. A compiled scan's fallback rate is `searched / decoded`.
    pub searched: u32,
}

impl Body for ScanRequest {
    fn validate_body(&self) -> Result<(), WireError> {
        self.validate()
    }
}

impl Body for ResultRow<'_> {
    fn validate_body(&self) -> Result<(), WireError> {
        self.validate()
    }
}

impl ScanDone {
    /// Check the counts: neither the valid phases or points nor the pixels searched exceed
    /// the pixels decoded.
    pub fn validate(&self) -> Result<(), WireError> {
        check(
            self.valid <= self.decoded && self.searched <= self.decoded,
            Invalid::Counts,
        )
    }
}

impl Body for ScanDone {
    fn validate_body(&self) -> Result<(), WireError> {
        self.validate()
    }
}
