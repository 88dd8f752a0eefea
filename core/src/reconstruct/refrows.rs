//! The band of reference rows one image row reads, as the kernel indexes it ([`RefRows`]):
//! offsets into one storage slice per image row, and their affine form when they have one (always
//! for [`super::ReferenceMap`] and [`super::ReferenceRing`]), so that the vector passes compute
//! sample indices from a formula.

use super::MAX_BAND_ROWS;

/// The band's reference rows, indexed by image row: offsets into one storage slice.
pub(super) struct RefRows<'a> {
    pub(super) data: &'a [f32],
    pub(super) offs: [u32; MAX_BAND_ROWS],
    pub(super) first: i64,
    pub(super) last_row: i64,
    /// Rows set (`offs[..len]`).
    pub(super) len: usize,
    /// The offsets as a formula, when they follow one (always for [`super::ReferenceMap`] and
    /// [`super::ReferenceRing`]): the sample indices are then computed in the vector passes.
    pub(super) affine: Option<Affine>,
}

/// Band row offsets `base + k·stride`, minus `wrap` from band row `split` on (a ring's wrap).
#[derive(Clone, Copy)]
pub(super) struct Affine {
    pub(super) base: u32,
    pub(super) stride: u32,
    pub(super) split: u32,
    pub(super) wrap: u32,
}

impl Affine {
    #[inline(always)]
    pub(super) fn offset(&self, k: u32) -> u32 {
        let o = self.base.wrapping_add(k.wrapping_mul(self.stride));
        if k >= self.split {
            o.wrapping_sub(self.wrap)
        } else {
            o
        }
    }
}

impl<'a> RefRows<'a> {
    pub(super) fn new(data: &'a [f32], first: i64, last_row: i64) -> Self {
        RefRows {
            data,
            offs: [u32::MAX; MAX_BAND_ROWS],
            first,
            last_row,
            len: 0,
            affine: None,
        }
    }

    pub(super) fn set(&mut self, k: usize, offset: usize) {
        if let Some(s) = self.offs.get_mut(k) {
            *s = u32::try_from(offset).unwrap_or(u32::MAX);
            self.len = self.len.max(k + 1);
        }
    }

    /// After every row is set: find the affine form of the offsets (rows `stride` samples apart,
    /// with at most one wrap), if they have one and the storage is indexable in u32.
    pub(super) fn finish(&mut self, stride: usize) {
        self.affine = None;
        let (Ok(stride), Ok(_)) = (u32::try_from(stride), u32::try_from(self.data.len())) else {
            return;
        };
        let offs = &self.offs[..self.len.min(MAX_BAND_ROWS)];
        let Some(&base) = offs.first() else {
            return;
        };
        let split = offs
            .windows(2)
            .position(|w| w[1] < w[0])
            .map_or(u32::MAX, |p| p as u32 + 1);
        let wrap = match offs.get(split as usize) {
            Some(&o) => base
                .wrapping_add(split.wrapping_mul(stride))
                .wrapping_sub(o),
            None => 0,
        };
        let a = Affine {
            base,
            stride,
            split,
            wrap,
        };
        if offs
            .iter()
            .enumerate()
            .all(|(k, &o)| o != u32::MAX && a.offset(k as u32) == o)
        {
            self.affine = Some(a);
        }
    }

    /// Map row `r` (from its start to the end of storage; the caller indexes columns only
    /// below the width), or an empty slice outside the band.
    #[inline(always)]
    pub(super) fn get(&self, r: i64) -> &'a [f32] {
        let k = r - self.first;
        if k >= 0 && (k as usize) < MAX_BAND_ROWS {
            let o = self.offs[k as usize];
            if o != u32::MAX {
                return self.data.get(o as usize..).unwrap_or(&[]);
            }
        }
        &[]
    }
}
