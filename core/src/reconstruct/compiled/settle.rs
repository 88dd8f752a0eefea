//! Settling a row of models read from bytes ([`PixelModel::parse_row`],
//! [`PixelModel::settle_row`]): every model that is not usable becomes [`PixelModel::SEARCH`],
//! every model with no reference [`PixelModel::NO_REFERENCE`], as [`PixelModel::from_array`]
//! reads one model, so that a reader's points are the desktop's whatever bits it was given.

use super::{FIELDS, PixelModel, TERMS};

/// Pixels [`PixelModel::settle_row_counted`] checks at a time, field by field.
pub const SETTLE_CHUNK: usize = 32;

/// The exponent bits of an f32: all set for an infinity or a NaN, the numbers that are not
/// finite.
const F32_EXPONENT: u32 = 0x7f80_0000;
/// The lowest bit of [`F32_EXPONENT`].
const F32_EXPONENT_LSB: u32 = 0x0080_0000;

/// Where a model's scale `±k`, its `s_c` and its τ_far lie among its fields
/// ([`PixelModel::to_array`]'s order).
const SCALE: usize = 3;
const DEPTH_CENTRE: usize = 4;
const FAR: usize = 6 + TERMS;

impl PixelModel {
    /// Read one row of models from its bytes (`FIELDS × w` little-endian f32, field by field:
    /// how a head takes a row from its flash or its link) into `row` (`FIELDS × w` values),
    /// then make every model that is not usable [`PixelModel::SEARCH`] (and every
    /// [`PixelModel::NO_REFERENCE`] canonical), as [`PixelModel::from_array`]. `None` when the
    /// lengths differ.
    pub fn parse_row(bytes: &[u8], row: &mut [f32]) -> Option<()> {
        PixelModel::read_row(bytes, row)?;
        PixelModel::settle_row(row)
    }

    /// The first step of [`PixelModel::parse_row`] alone: the row's values from their bytes, as
    /// they are (for a reader that knows its rows settled, or settles them itself). `None` when
    /// the lengths differ.
    pub fn read_row(bytes: &[u8], row: &mut [f32]) -> Option<()> {
        if bytes.len() != 4 * row.len() || !row.len().is_multiple_of(FIELDS) {
            return None;
        }
        for (v, c) in row.iter_mut().zip(bytes.chunks_exact(4)) {
            *v = f32::from_le_bytes([c[0], c[1], c[2], c[3]]);
        }
        Some(())
    }

    /// Make every model of a row stored field by field ([`PixelModel::store`]) that is not
    /// usable [`PixelModel::SEARCH`] (and every [`PixelModel::NO_REFERENCE`] canonical), as
    /// [`PixelModel::from_array`]: the second step of [`PixelModel::parse_row`], for a head that
    /// reads a row's values in pieces. `None` when the row is not a whole number of models.
    pub fn settle_row(row: &mut [f32]) -> Option<()> {
        PixelModel::settle_row_counted(row).map(|_| ())
    }

    /// [`PixelModel::settle_row`], counting the models whose bits it changed: 0 for a row
    /// already settled (as `fringe3d` writes and uploads them). A head that finds every row of
    /// its models settled once may skip the settle at its later scans.
    ///
    /// The rule is [`PixelModel::from_array`]'s, pixel by pixel (the reference:
    /// [`PixelModel::settle_row_by_pixel`]). It runs field by field over chunks of
    /// [`SETTLE_CHUNK`] pixels, each field's values read where they lie side by side and their
    /// finiteness tested on their bits; only the few models that are not usable are read whole
    /// and rewritten. Pixel by pixel, with the row's width known only at run time, the settle
    /// cost a Cortex-M4F more than the kernel (docs/compiled.md, "Speed").
    pub fn settle_row_counted(row: &mut [f32]) -> Option<usize> {
        if !row.len().is_multiple_of(FIELDS) {
            return None;
        }
        let w = row.len() / FIELDS;
        let mut changed = 0;
        let mut u0 = 0;
        while u0 < w {
            let n = (w - u0).min(SETTLE_CHUNK);
            let mut bad = [false; SETTLE_CHUNK];
            {
                let field = |k: usize| row.get(k * w + u0..k * w + u0 + n);
                // An exponent field all ones (∞, NaN) plus its lowest bit carries into bit 31;
                // any other stays below it.
                let mut carry = [0u32; SETTLE_CHUNK];
                for k in 0..6 + TERMS {
                    for (c, v) in carry.iter_mut().zip(field(k)?) {
                        *c |= (v.to_bits() & F32_EXPONENT) + F32_EXPONENT_LSB;
                    }
                }
                let (ks, s_cs, fars) = (field(SCALE)?, field(DEPTH_CENTRE)?, field(FAR)?);
                let lanes = carry.iter().zip(ks).zip(s_cs).zip(fars);
                for (b, (((c, k), s_c), far)) in bad.iter_mut().zip(lanes) {
                    *b = !PixelModel::usable(*c >> 31 == 0, *k, *s_c, *far);
                }
            }
            for (j, _) in bad.iter().enumerate().take(n).filter(|(_, b)| **b) {
                changed += usize::from(PixelModel::settle_one(row, w, u0 + j)?);
            }
            u0 += n;
        }
        Some(changed)
    }

    /// [`PixelModel::settle_row_counted`] pixel by pixel, as [`PixelModel::from_array`] reads
    /// each model: the reference the field-by-field settle is checked against.
    pub fn settle_row_by_pixel(row: &mut [f32]) -> Option<usize> {
        if !row.len().is_multiple_of(FIELDS) {
            return None;
        }
        let w = row.len() / FIELDS;
        let mut changed = 0;
        for u in 0..w {
            if !PixelModel::load(row, u)?.is_compiled() {
                changed += usize::from(PixelModel::settle_one(row, w, u)?);
            }
        }
        Some(changed)
    }

    /// Rewrite the model of pixel `u` (of a row `w` wide) as [`PixelModel::from_array`] reads
    /// it; whether its bits changed.
    fn settle_one(row: &mut [f32], w: usize, u: usize) -> Option<bool> {
        let m = PixelModel::load(row, u)?;
        let before = (0..FIELDS).map(|k| row.get(k * w + u).map(|v| v.to_bits()));
        let after = m.to_array().map(f32::to_bits);
        let same = before.zip(after).all(|(b, a)| b == Some(a));
        m.store(row, u)?;
        Some(!same)
    }
}
