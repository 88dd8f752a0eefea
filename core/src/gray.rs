//! Gray-code levels (issue #20): binary stripe patterns that give the fringe order of the phase
//! level they precede, as in "Gray code + phase shifting", the most common scheme of other
//! scanners. Here with the code word defined on the phase function, so curved and variable-width
//! fringes (paper §5.1) get their Gray code too.
//!
//! # The code
//! A Gray-code level of `bits` bits and scale `c` (equal to the scale of the phase level it
//! orders) counts the fringe periods of `c·Φ^(P)`. With `u = c·Φ^(P)/2π` (periods; the phase
//! level's wrapped phase is `2π·(u − round(u))`) and `B = 2^(bits−1)`, the *half-stripe index*
//!
//! ```text
//! h = ⌊2u + 1⌋ + 2B,      0 ≤ h < 2^(bits+1)   (u ∈ [−B − ½, B − ½))
//! ```
//!
//! counts half periods, and `h >> 1 = round(u) + B` is the period (fringe order plus bias).
//! The projected word is the reflected binary code of `h`, `G(h) = h ⊕ (h >> 1)`, one image per
//! bit, most significant first: image `j` (`0 ≤ j < bits`) is bright where bit `bits − j` of
//! `G(h)` is set. Those are exactly the bits of `G(h >> 1)`, the plain Gray code of the period.
//! The *complementary* scheme adds image `bits`: bit 0 of `G(h)`, stripes half a period wide,
//! whose edges fall at the middles of the other images' stripes.
//!
//! # Shifted code
//! A *shifted* code (Wu et al., Opt. Express 27(16), 2019; SLMaster's "sinus shift Gray code")
//! moves every stripe by half a period, so that its edges fall in the middle of the fringes
//! (`φ = 0`) instead of on the phase's wraps (`φ = ±π`): the code of `h + 1` is projected, its
//! period stripe `g = ⌊u + 1⌋ + B` covers `u ∈ [g − B − 1, g − B)` and the code covers
//! `u ∈ [−B − 1, B − 1)`. It cannot be combined with the complementary image (which already
//! puts an edge at every half period).
//!
//! # Inverse patterns
//! An *inverse* code projects every image followed by its inverse (image `2j` the bit, `2j + 1`
//! its complement; [`GrayCode::inverted`]), doubling the images for the classic per-pixel
//! threshold: the bit is bright where `I₂ⱼ > I₂ⱼ₊₁`, ambiguous where `|I₂ⱼ − I₂ⱼ₊₁|` is below a
//! margin. Each pixel compares its own bright and dark response, so the threshold holds under
//! surface colour, ambient light and a projector whose black is not `I_min`, where the mean
//! intensity's `A` may not lie halfway (a projector's gamma puts `A` below the midpoint).
//!
//! # Decoding
//! Each image is thresholded against the DC term `A` of the set's DC level (the "mean intensity"
//! threshold): bright where `I > A` (an inverse code: against its inverse image, above). A bit
//! with `|I − A|` below a margin is *ambiguous*; it still takes the side of its sign. The word is converted back to binary ([`GrayCode::quarter_turns`])
//! and gives an absolute phase estimate at the centre of its stripe, which unwraps the phase
//! level's wrapped phase as any coarser level does (eqs 12-13, level ratio 1):
//!
//! - **plain** (`bits` images): the stripe is one period, so the estimate is within ±π of the
//!   truth and rounding is decided by the wrapped phase alone at the stripe edges, where the
//!   blurred code is least reliable. Pixels with an ambiguous bit, or within the range
//!   tolerance of a period edge, are refused ([`GrayCode::tolerance`]).
//! - **shifted** (`bits` images): the estimate is the centre of the shifted stripe (a wrap of
//!   the phase), within ±π of the truth, and rounding is decided by the wrapped phase at the
//!   stripe edges, now in the middle of the fringes. Per pixel it is as robust as the plain code:
//!   pixels with an ambiguous bit, or within the range tolerance of a stripe edge (`φ ≈ 0`), are
//!   refused; the lost pixels lie mid-fringe instead of at the wraps. (Published decoders of this
//!   code correct the edges from the neighbouring pixels along a row; a pixel-wise decoder cannot
//!   tell an edge pixel's side. For robust edges project the complementary image.)
//! - **complementary** (`bits + 1` images): the estimate is the centre of a half-period stripe,
//!   within ±π/2 of the truth. Near any stripe edge only one bit changes (the Gray property), so
//!   a wrong or ambiguous bit there moves the estimate by one half stripe, still within the
//!   rounding's ±π: period-edge errors cannot occur. This equals the published complementary
//!   rule (order `k₁` from `bits` images where `|φ| < π/2`, `k₂` from all of them elsewhere).
//!   Two ambiguous bits refuse the pixel.
//!
//! Everything here is integer or exact f64 arithmetic: the pattern generator, the f64 reference
//! decoder and every decoding backend share it.

use crate::limits::MAX_GRAY_BITS;

/// A Gray-code level's code: its bit count, whether the complementary image is projected, and
/// whether every image is followed by its inverse.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct GrayCode {
    bits: u8,
    complementary: bool,
    inverse: bool,
    shifted: bool,
}

impl GrayCode {
    /// A code of `bits` bits (`1..=`[`MAX_GRAY_BITS`], checked by the pattern set), with the
    /// complementary half-period image or without.
    pub const fn new(bits: u8, complementary: bool) -> Self {
        GrayCode {
            bits,
            complementary,
            inverse: false,
            shifted: false,
        }
    }

    /// A plain code of `bits` bits with its stripes moved by half a period (the module docs'
    /// "Shifted code").
    pub const fn shifted(bits: u8) -> Self {
        GrayCode {
            bits,
            complementary: false,
            inverse: false,
            shifted: true,
        }
    }

    /// Whether the stripes are moved by half a period ([`Self::shifted`]).
    pub const fn is_shifted(&self) -> bool {
        self.shifted
    }

    /// The same code with every image followed by its inverse (the per-pixel threshold of the
    /// module docs' "Inverse patterns").
    pub const fn inverted(self) -> Self {
        GrayCode {
            inverse: true,
            ..self
        }
    }

    /// Whether every image is followed by its inverse.
    pub const fn inverse(&self) -> bool {
        self.inverse
    }

    /// Whether image `j` of the level is the inverse of image `j − 1` (an inverse code's odd
    /// images).
    pub const fn is_inverse_image(&self, j: usize) -> bool {
        self.inverse && j % 2 == 1
    }

    /// The code image (bit position among the `bits` + complementary ones) image `j` shows.
    const fn code_image(&self, j: usize) -> usize {
        if self.inverse { j / 2 } else { j }
    }

    /// Bits of the period code (images without the complementary one).
    pub const fn bits(&self) -> u8 {
        self.bits
    }

    /// Whether the complementary half-period image is projected.
    pub const fn complementary(&self) -> bool {
        self.complementary
    }

    /// Images of the level: `bits`, plus one if complementary; twice that if inverse.
    pub const fn images(&self) -> usize {
        (self.bits as usize + self.complementary as usize) * (1 + self.inverse as usize)
    }

    /// Whether `bits` is in `1..=MAX_GRAY_BITS` and the images fit a level
    /// ([`crate::limits::MAX_SHIFTS`]: an inverse code has at most 8 bits, 7 if complementary).
    pub const fn is_valid(&self) -> bool {
        self.bits >= 1
            && self.bits as usize <= MAX_GRAY_BITS
            && self.images() <= crate::limits::MAX_SHIFTS
            && !(self.shifted && self.complementary)
    }

    /// `B = 2^(bits−1)`, the period code of `u = 0`.
    pub const fn bias(&self) -> i64 {
        1i64 << (self.bits.saturating_sub(1) as u32)
    }

    /// The range of `u = c·Φ/2π` (periods) the code covers: `[−B − ½, B − ½)`; shifted
    /// `[−B − 1, B − 1)`.
    pub fn period_range(&self) -> (f64, f64) {
        let b = self.bias() as f64;
        let s = if self.shifted { 0.5 } else { 0.0 };
        (-b - 0.5 - s, b - 0.5 - s)
    }

    /// The half-stripe index whose code word is projected at `u` periods: `h = ⌊2u + 1⌋ + 2B`,
    /// plus one for a shifted code (not clamped: outside [`Self::period_range`] it leaves
    /// `0..2^(bits+1)`).
    pub fn half_stripe(&self, u: f64) -> i64 {
        libm::floor(2.0 * u + 1.0) as i64 + 2 * self.bias() + self.shifted as i64
    }

    /// Whether image `j` of the level (0 = most significant bit; an inverse code's odd images
    /// the complements) is bright at half stripe `h`.
    pub fn bright(&self, j: usize, h: i64) -> bool {
        let word = h ^ (h >> 1);
        let bit = self.bits as i64 - self.code_image(j) as i64;
        let set = (0..=self.bits as i64).contains(&bit) && (word >> bit) & 1 == 1;
        set != self.is_inverse_image(j)
    }

    /// The bit of the code word image `j` sets (`bits − j`; an inverse code's pair `2j, 2j + 1`
    /// sets one): the word is laid out as `G(h)`.
    pub const fn word_bit(&self, j: usize) -> u32 {
        (self.bits as u32).wrapping_sub(self.code_image(j) as u32)
    }

    /// The phase estimate of a decoded word (laid out as `G(h)`, [`Self::word_bit`]; a plain
    /// code's bit 0 is 0) in quarter turns `n`, the estimate being `n·π/2` radians of `c·Φ`:
    /// the centre of the half stripe, `2(h − 2B) − 1`, for the complementary code; the centre of
    /// the period, `4(g − B)` with `g = h >> 1`, for the plain one, `4(g − B) − 2` for the
    /// shifted one (its stripes start half a period lower).
    pub const fn quarter_turns(&self, word: u32) -> i32 {
        // Gray to binary: prefix XOR from the top (a word of ≤ 11 bits, [`MAX_GRAY_BITS`] + 1).
        let mut h = word;
        h ^= h >> 1;
        h ^= h >> 2;
        h ^= h >> 4;
        h ^= h >> 8;
        let b = self.bias() as i32;
        if self.complementary {
            2 * (h as i32 - 2 * b) - 1
        } else {
            4 * ((h >> 1) as i32 - b) - 2 * self.shifted as i32
        }
    }

    /// Ambiguous bits that refuse a pixel: one for the plain code, two for the complementary.
    pub const fn max_ambiguous(&self) -> u8 {
        if self.complementary { 2 } else { 1 }
    }

    /// The largest accepted residual (radians) between the code's estimate and the unwrapped
    /// phase: `3π/4` for the complementary code (the estimate is within `π/2`, one wrong bit
    /// adds the edge distance); `π − range_tolerance` for the plain one (its estimate is only
    /// within `π`: pixels within the phase noise allowance of a period edge are refused; the
    /// shifted one's likewise).
    pub fn tolerance(&self, range_tolerance: f64) -> f64 {
        if self.complementary {
            0.75 * core::f64::consts::PI
        } else {
            core::f64::consts::PI - range_tolerance
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_half_stripe_decodes_to_its_centre() {
        for bits in 1..=MAX_GRAY_BITS as u8 {
            for comp in [false, true] {
                let g = GrayCode::new(bits, comp);
                let (lo, hi) = g.period_range();
                // Sample u at the middle of every half stripe of the range.
                let mut u = lo + 0.25;
                while u < hi {
                    let h = g.half_stripe(u);
                    let mut word = 0u32;
                    for j in 0..g.images() {
                        if g.bright(j, h) {
                            word |= 1 << g.word_bit(j);
                        }
                    }
                    let est = g.quarter_turns(word) as f64 / 4.0; // periods
                    let limit = if comp { 0.25 } else { 0.5 };
                    assert!(
                        (est - u).abs() <= limit,
                        "bits {bits} {comp} u {u} est {est}"
                    );
                    u += 0.5;
                }
            }
        }
    }

    #[test]
    fn a_shifted_stripe_decodes_to_its_centre_half_a_period_off_the_plain_one() {
        for bits in 1..=MAX_GRAY_BITS as u8 {
            for inverse in [false, true] {
                let mut g = GrayCode::shifted(bits);
                if inverse {
                    g = g.inverted();
                }
                let plain = GrayCode::new(bits, false);
                let (lo, hi) = g.period_range();
                assert_eq!(
                    (lo, hi),
                    (plain.period_range().0 - 0.5, plain.period_range().1 - 0.5)
                );
                let mut u = lo + 0.05;
                while u < hi {
                    let h = g.half_stripe(u);
                    let mut word = 0u32;
                    for j in 0..g.images() {
                        if g.bright(j, h) != g.is_inverse_image(j) {
                            word |= 1 << g.word_bit(j);
                        }
                    }
                    let est = g.quarter_turns(word) as f64 / 4.0;
                    // The stripe [k, k + 1) of integer k decodes to its centre k + ½.
                    assert_eq!(est, libm::floor(u) + 0.5, "bits {bits} u {u}");
                    // The plain code's word here is the one half a period on.
                    assert_eq!(h, plain.half_stripe(u + 0.5));
                    u += 0.1;
                }
            }
        }
        assert!(GrayCode::shifted(4).is_valid() && GrayCode::shifted(4).inverted().is_valid());
        let both = GrayCode {
            complementary: true,
            ..GrayCode::shifted(4)
        };
        assert!(!both.is_valid(), "shifted and complementary");
    }

    #[test]
    fn neighbouring_half_stripes_differ_in_one_image() {
        let g = GrayCode::new(6, true);
        for h in 0..(1i64 << 7) - 1 {
            let diff = (0..g.images())
                .filter(|&j| g.bright(j, h) != g.bright(j, h + 1))
                .count();
            assert_eq!(diff, 1, "h {h}");
        }
    }
}
