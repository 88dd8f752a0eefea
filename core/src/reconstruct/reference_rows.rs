//! Where the kernel reads the reference phase map from ([`ReferenceRows`]): a ring of the last
//! rows over caller buffers for streaming ([`ReferenceRing`]) or the whole map for batch use
//! ([`ReferenceMap`]), both storing invalid samples as the canonical NaN.

use super::error::ReconstructError;
use super::reconstructor::Reconstructor;
#[cfg(doc)]
use super::setup::Band;
use crate::math::CANONICAL_NAN;
use crate::validity::Validity;

/// Where the kernel reads reference rows from: a [`ReferenceRing`] or a [`ReferenceMap`].
///
/// Rows are stored with every invalid sample replaced by the canonical NaN, so the kernel detects
/// invalid reference data by NaN propagation through the interpolation.
pub trait ReferenceRows {
    /// Map width: the image's plus its margin ([`Reconstructor::map_width`]).
    fn width(&self) -> usize;
    /// Map height: the image's plus its margin ([`Reconstructor::map_height`]).
    fn height(&self) -> usize;
    /// Rows the storage can hold at once.
    fn capacity_rows(&self) -> u32;
    /// All stored samples (NaN-encoded phase).
    fn storage(&self) -> &[f32];
    /// Where map row `r` starts in [`ReferenceRows::storage`], or `None` if it is not held.
    fn row_offset(&self, r: u32) -> Option<usize>;
    /// The stored phase of map row `r`, or `None` if it is not held.
    fn row(&self, r: u32) -> Option<&[f32]> {
        let o = self.row_offset(r)?;
        self.storage().get(o..o + self.width())
    }
}

/// Copy a reference row into storage, replacing invalid or non-finite samples by the canonical NaN,
/// and its codes into `dst_validity` (non-finite samples marked `Valid` become
/// `PhaseOutOfRange`). An empty `validity` means every sample is valid where finite; an empty
/// `dst_validity` keeps no codes (the kernel reads only the NaN-encoded phase).
fn encode_row(dst: &mut [f32], dst_validity: &mut [u8], phase: &[f32], validity: &[u8]) {
    const VALID: u8 = Validity::Valid as u8;
    if validity.is_empty() {
        for (d, &p) in dst.iter_mut().zip(phase) {
            *d = if p.is_finite() { p } else { CANONICAL_NAN };
        }
        for (dv, &p) in dst_validity.iter_mut().zip(phase) {
            *dv = if p.is_finite() {
                VALID
            } else {
                Validity::PhaseOutOfRange as u8
            };
        }
        return;
    }
    for ((d, &p), &q) in dst.iter_mut().zip(phase).zip(validity) {
        *d = if q == VALID && p.is_finite() {
            p
        } else {
            CANONICAL_NAN
        };
    }
    for ((dv, &p), &q) in dst_validity.iter_mut().zip(phase).zip(validity) {
        *dv = if q != VALID || p.is_finite() {
            q
        } else {
            Validity::PhaseOutOfRange as u8
        };
    }
}

/// A ring of reference rows over caller buffers, for streaming (push rows in order 0, 1, 2, …,
/// or from a first row on, [`ReferenceRing::start_at`], for a region of interest).
///
/// Rows are the reference map's ([`Reconstructor::map_width`] wide, numbered from the map's
/// top, [`Reconstructor::with_margin`]). Holds the last `capacity` pushed rows;
/// `capacity = phase.len() / map_width` must be at least [`Band::rows`] (checked at
/// construction). Row `r` lives in slot `r mod capacity`.
///
/// The validity plane is optional: the kernel reads only the phase (invalid samples stored as
/// NaN), so a ring built with an empty `validity` buffer keeps no codes (1 B per sample less:
/// 32 000 B for a 25-row band at 1280 wide) and [`ReferenceRing::validity_row`] is `None`.
#[derive(Debug)]
pub struct ReferenceRing<'a> {
    phase: &'a mut [f32],
    validity: &'a mut [u8],
    width: usize,
    height: usize,
    capacity: u32,
    /// The first row pushed (0, or [`ReferenceRing::start_at`]'s).
    first: u32,
    pushed: u32,
}

impl<'a> ReferenceRing<'a> {
    /// A ring for `recon`'s reference map over `phase` (f32 per sample) and `validity` (u8 per
    /// sample, or empty to keep no codes). Its capacity is `phase.len() / map_width` rows; fewer
    /// than the band needs is [`ReconstructError::BandTooSmall`]; a non-empty `validity` buffer
    /// shorter than the rows used is [`ReconstructError::BufferTooSmall`].
    pub fn new(
        recon: &Reconstructor,
        phase: &'a mut [f32],
        validity: &'a mut [u8],
    ) -> Result<Self, ReconstructError> {
        let width = recon.map_width();
        let height = recon.map_height();
        // `checked_div`: a reconstructor's map is never 0 wide, and no panic path is compiled in.
        let capacity = phase.len().checked_div(width).unwrap_or(0).min(height) as u32;
        let needed = recon.band().rows().min(height as u32);
        if capacity < needed {
            return Err(ReconstructError::BandTooSmall {
                needed,
                given: capacity,
            });
        }
        if !validity.is_empty() && validity.len() < capacity as usize * width {
            return Err(ReconstructError::BufferTooSmall);
        }
        Ok(ReferenceRing {
            phase,
            validity,
            width,
            height,
            capacity,
            first: 0,
            pushed: 0,
        })
    }

    /// Start an empty ring at map row `row` instead of 0, for a region of interest: the next
    /// [`ReferenceRing::push_row`] is row `row`, and rows before it are never held. For camera
    /// rows from `v0` on, start at `recon.rows_needed(v0).0`. A ring that holds rows must be
    /// [`ReferenceRing::reset`] first ([`ReconstructError::Sequence`]); a row past the map is
    /// [`ReconstructError::Sequence`] too.
    pub fn start_at(&mut self, row: u32) -> Result<(), ReconstructError> {
        if self.pushed != self.first || row as usize > self.height {
            return Err(ReconstructError::Sequence);
        }
        self.first = row;
        self.pushed = row;
        Ok(())
    }

    /// Push the next reference row (row index [`ReferenceRing::rows_pushed`]) and its validity
    /// codes, or an empty `validity_row` when every finite sample is valid (a reference map
    /// stored with NaN where invalid, as the desktop's TIFF is).
    pub fn push_row(
        &mut self,
        phase_row: &[f32],
        validity_row: &[u8],
    ) -> Result<(), ReconstructError> {
        if phase_row.len() != self.width
            || !(validity_row.is_empty() || validity_row.len() == self.width)
        {
            return Err(ReconstructError::Length);
        }
        if self.pushed as usize >= self.height {
            return Err(ReconstructError::Sequence);
        }
        let Some(slot) = self.pushed.checked_rem(self.capacity) else {
            return Err(ReconstructError::BufferTooSmall);
        };
        let slot = slot as usize * self.width;
        let keeps_codes = !self.validity.is_empty();
        let (Some(d), Some(dv)) = (
            self.phase.get_mut(slot..slot + self.width),
            if keeps_codes {
                self.validity.get_mut(slot..slot + self.width)
            } else {
                Some(&mut [][..])
            },
        ) else {
            return Err(ReconstructError::BufferTooSmall);
        };
        encode_row(d, dv, phase_row, validity_row);
        self.pushed += 1;
        Ok(())
    }

    /// Rows pushed so far (= the index of the next row).
    pub fn rows_pushed(&self) -> u32 {
        self.pushed
    }

    /// Forget all rows (start a new reference, from row 0).
    pub fn reset(&mut self) {
        self.first = 0;
        self.pushed = 0;
    }

    /// The stored validity codes of map row `r`, if held (`None` for a ring without codes).
    pub fn validity_row(&self, r: u32) -> Option<&[u8]> {
        let slot = self.slot(r)?;
        self.validity.get(slot..slot + self.width)
    }

    fn slot(&self, r: u32) -> Option<usize> {
        if r >= self.first && r < self.pushed && self.pushed - r <= self.capacity {
            Some((r % self.capacity) as usize * self.width)
        } else {
            None
        }
    }
}

impl ReferenceRows for ReferenceRing<'_> {
    fn width(&self) -> usize {
        self.width
    }
    fn height(&self) -> usize {
        self.height
    }
    fn capacity_rows(&self) -> u32 {
        self.capacity
    }
    fn storage(&self) -> &[f32] {
        self.phase
    }
    fn row_offset(&self, r: u32) -> Option<usize> {
        self.slot(r)
    }
}

/// The whole reference phase map, for the batch path.
#[derive(Clone, Copy, Debug)]
pub struct ReferenceMap<'a> {
    phase: &'a [f32],
    width: usize,
    height: usize,
}

impl<'a> ReferenceMap<'a> {
    /// Prepare a `width × height` map in place: every sample whose validity is not `Valid` or whose
    /// phase is not finite becomes the canonical NaN (the encoding [`ReferenceRing::push_row`]
    /// applies), so the kernel sees the same values as when streaming.
    pub fn prepare(
        phase: &'a mut [f32],
        validity: &[u8],
        width: usize,
        height: usize,
    ) -> Result<Self, ReconstructError> {
        let n = width.checked_mul(height).ok_or(ReconstructError::Length)?;
        if width == 0 || phase.len() != n || validity.len() != n {
            return Err(ReconstructError::Length);
        }
        for (p, &q) in phase.iter_mut().zip(validity) {
            if !(q == Validity::Valid as u8 && p.is_finite()) {
                *p = CANONICAL_NAN;
            }
        }
        Ok(ReferenceMap {
            phase,
            width,
            height,
        })
    }

    /// A view of a `width × height` map prepared before (by [`ReferenceMap::prepare`]: every
    /// sample finite or the canonical NaN), without copying or changing it, so one prepared map
    /// can serve any number of reconstructions at once. `Err(Length)` if the sizes disagree,
    /// `Err(NotFinite)` if a sample is neither finite nor the canonical NaN (not prepared).
    pub fn from_prepared(
        phase: &'a [f32],
        width: usize,
        height: usize,
    ) -> Result<Self, ReconstructError> {
        let n = width.checked_mul(height).ok_or(ReconstructError::Length)?;
        if width == 0 || phase.len() != n {
            return Err(ReconstructError::Length);
        }
        if phase
            .iter()
            .any(|p| !p.is_finite() && p.to_bits() != CANONICAL_NAN.to_bits())
        {
            return Err(ReconstructError::NotFinite);
        }
        Ok(ReferenceMap {
            phase,
            width,
            height,
        })
    }

    /// The prepared phase samples.
    pub fn phase(&self) -> &[f32] {
        self.phase
    }
}

impl ReferenceRows for ReferenceMap<'_> {
    fn width(&self) -> usize {
        self.width
    }
    fn height(&self) -> usize {
        self.height
    }
    fn capacity_rows(&self) -> u32 {
        self.height as u32
    }
    fn storage(&self) -> &[f32] {
        self.phase
    }
    fn row_offset(&self, r: u32) -> Option<usize> {
        if (r as usize) < self.height {
            Some(r as usize * self.width)
        } else {
            None
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_prepared_map_is_viewed_without_a_copy() {
        let mut phase = [1.0, f32::NAN, -f32::NAN, f32::INFINITY, 2.5, -0.0];
        let validity = [0, 0, 0, 0, Validity::ReferenceInvalid as u8, 0];
        let prepared: [u32; 6] = {
            let m = ReferenceMap::prepare(&mut phase, &validity, 3, 2).unwrap();
            core::array::from_fn(|i| m.phase()[i].to_bits())
        };
        let view = ReferenceMap::from_prepared(&phase, 3, 2).unwrap();
        assert!(core::ptr::eq(view.phase(), &phase[..]));
        assert!(view.phase().iter().map(|p| p.to_bits()).eq(prepared));
        assert_eq!(
            ReferenceMap::from_prepared(&phase, 2, 2).err(),
            Some(ReconstructError::Length)
        );
        let unprepared = [1.0, -f32::NAN, 2.0, 3.0];
        assert_eq!(
            ReferenceMap::from_prepared(&unprepared, 2, 2).err(),
            Some(ReconstructError::NotFinite)
        );
        let infinite = [1.0, f32::INFINITY, 2.0, 3.0];
        assert!(ReferenceMap::from_prepared(&infinite, 2, 2).is_err());
    }
}
