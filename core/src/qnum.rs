//! The fixed-point numbers of the [`crate::arith::Fixed`] backend: two's-complement (or unsigned)
//! integers with a binary point, named by their integer and fraction bits (`I8F24`: signed, 8
//! integer bits including the sign, 24 fraction bits; the value is `bits / 2^24`).
//!
//! Only what the backend needs, each operation an explicit integer one so that its bits are the
//! same on every target and in debug and release builds: conversions from and to the raw bits,
//! comparisons (those of the bits), wrapping `+` and `−`, rounding to an integer half to even,
//! the absolute value, the level ratio from an f64 and its product with a phase.
//!
//! | type | bits | range | step | holds |
//! |---|---|---|---|---|
//! | [`I0F32`] | i32 | [−½, ½) | 2⁻³² | CORDIC angles, turns |
//! | [`I8F24`] | i32 | [−128, 128) | 2⁻²⁴ | phases, turns |
//! | [`U8F24`] | u32 | [0, 256) | 2⁻²⁴ | tolerances, turns |
//! | [`I16F16`] | i32 | [−32 768, 32 768) | 2⁻¹⁶ | level ratios `c_k / c_{k−1}` |

macro_rules! qnum {
    ($(#[$doc:meta])* pub struct $name:ident($bits:ty), $frac:literal fraction bits;) => {
        $(#[$doc])*
        #[derive(Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash)]
        #[repr(transparent)]
        pub struct $name($bits);

        impl $name {
            /// Zero.
            pub const ZERO: Self = Self(0);
            /// The number of fraction bits.
            pub const FRAC_BITS: u32 = $frac;

            /// The number whose raw bits are `bits` (value `bits / 2^FRAC_BITS`).
            #[inline(always)]
            pub const fn from_bits(bits: $bits) -> Self {
                Self(bits)
            }

            /// The raw bits.
            #[inline(always)]
            pub const fn to_bits(self) -> $bits {
                self.0
            }
        }
    };
}

qnum! {
    /// Turns with 32 fraction bits, [−½, ½): the angles of [`crate::arith::cordic_atan2`].
    pub struct I0F32(i32), 32 fraction bits;
}
qnum! {
    /// Turns with 24 fraction bits, [−128, 128): the phases of the fixed-point backend.
    pub struct I8F24(i32), 24 fraction bits;
}
qnum! {
    /// Unsigned turns with 24 fraction bits, [0, 256): the unwrapping tolerances.
    pub struct U8F24(u32), 24 fraction bits;
}
qnum! {
    /// 16 integer and 16 fraction bits: the level ratios `c_k / c_{k−1}`.
    pub struct I16F16(i32), 16 fraction bits;
}

impl I8F24 {
    /// `self + rhs`, wrapping at the format's range.
    #[inline(always)]
    pub const fn wrapping_add(self, rhs: Self) -> Self {
        Self(self.0.wrapping_add(rhs.0))
    }

    /// `self − rhs`, wrapping at the format's range.
    #[inline(always)]
    pub const fn wrapping_sub(self, rhs: Self) -> Self {
        Self(self.0.wrapping_sub(rhs.0))
    }

    /// The nearest integer, ties to the even one (127.5 wraps to −128).
    #[inline(always)]
    pub const fn wrapping_round_ties_even(self) -> Self {
        const HALF: i32 = 1 << 23;
        let floor = self.0 >> 24;
        let frac = self.0 & 0x00ff_ffff;
        let up = frac > HALF || (frac == HALF && floor & 1 == 1);
        Self(floor.wrapping_add(up as i32).wrapping_shl(24))
    }

    /// `|self|`, exact (the magnitude of −128 is 128, which [`U8F24`] holds).
    #[inline(always)]
    pub const fn unsigned_abs(self) -> U8F24 {
        U8F24(self.0.unsigned_abs())
    }
}

impl I16F16 {
    /// `r` rounded to the nearest multiple of 2⁻¹⁶, ties to even, wrapping at the format's range
    /// (the low 32 bits of the exact rounded integer `r·2¹⁶`); 0 for NaN and ±∞.
    pub fn wrapping_from_f64(r: f64) -> Self {
        // ×2¹⁶ is exact (or overflows to ∞); `rint` rounds half to even; `fmod` by 2³² is exact
        // and keeps the sign, so the i64 holds the integer's residue, whose low 32 bits wrap.
        let x = libm::rint(r * 65_536.0);
        if !(libm::fabs(x) < f64::INFINITY) {
            return Self::ZERO;
        }
        Self(libm::fmod(x, 4_294_967_296.0) as i64 as i32)
    }

    /// `self·phase`: the exact 64-bit product (40 fraction bits) truncated towards −∞ to 24,
    /// wrapping at [`I8F24`]'s range.
    #[inline(always)]
    pub const fn mul_phase(self, phase: I8F24) -> I8F24 {
        I8F24(((self.0 as i64 * phase.0 as i64) >> 16) as i32)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn q24(x: f64) -> I8F24 {
        I8F24::from_bits((x * 16_777_216.0) as i32)
    }

    #[test]
    fn rounding_to_an_integer_is_half_to_even_and_wraps() {
        for (x, want) in [
            (0.5, 0.0),
            (1.5, 2.0),
            (2.5, 2.0),
            (-0.5, 0.0),
            (-1.5, -2.0),
            (-2.5, -2.0),
            (2.4999, 2.0),
            (2.5001, 3.0),
            (-2.5001, -3.0),
            (-128.0, -128.0),
        ] {
            assert_eq!(q24(x).wrapping_round_ties_even(), q24(want), "{x}");
        }
        // 127.5 rounds to 128, which wraps to −128.
        assert_eq!(q24(127.5).wrapping_round_ties_even(), q24(-128.0));
    }

    #[test]
    fn ratios_round_half_to_even_and_wrap() {
        let r = |x: f64| I16F16::wrapping_from_f64(x).to_bits();
        assert_eq!(r(1.0), 65_536);
        assert_eq!(r(0.5 / 65_536.0), 0);
        assert_eq!(r(1.5 / 65_536.0), 2);
        assert_eq!(r(-1.5 / 65_536.0), -2);
        assert_eq!(r(-2.5 / 65_536.0), -2);
        assert_eq!(r(36.5), 36 * 65_536 + 32_768);
        // 32 768 is out of range: the low 32 bits of 2³¹.
        assert_eq!(r(32_768.0), i32::MIN);
        assert_eq!(r(65_536.0 + 1.0), 65_536);
        assert_eq!(r(-65_536.0 - 1.0), -65_536);
        assert_eq!(r(1e300), 0); // a multiple of 2³²
        assert_eq!(r(f64::NAN), 0);
        assert_eq!(r(f64::INFINITY), 0);
    }

    #[test]
    fn the_ratio_product_truncates_towards_minus_infinity() {
        let ratio = I16F16::from_bits(3 << 15); // 1.5
        assert_eq!(ratio.mul_phase(q24(2.0)), q24(3.0));
        // 1.5 × 2⁻²⁴ = 1.5 steps: 1 step; −1.5 steps: −2.
        assert_eq!(ratio.mul_phase(I8F24::from_bits(1)).to_bits(), 1);
        assert_eq!(ratio.mul_phase(I8F24::from_bits(-1)).to_bits(), -2);
        // The f64 reference: floor(r·p·2²⁴) for values far from the range's ends.
        let mut s = 0x2545_f491_4f6c_dd1d_u64;
        for _ in 0..10_000 {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            let (r, p) = ((s as i32) >> 9, (s >> 32) as i32 >> 10);
            let exact = r as f64 / 65_536.0 * (p as f64 / 16_777_216.0);
            let got = I16F16::from_bits(r)
                .mul_phase(I8F24::from_bits(p))
                .to_bits();
            assert_eq!(got as f64, libm::floor(exact * 16_777_216.0), "{r} {p}");
        }
    }

    #[test]
    fn the_absolute_value_holds_the_most_negative_phase() {
        assert_eq!(I8F24::from_bits(i32::MIN).unsigned_abs().to_bits(), 1 << 31);
        assert_eq!(q24(-1.25).unsigned_abs(), U8F24::from_bits(5 << 22));
        assert!(U8F24::from_bits(1) > U8F24::ZERO && I8F24::from_bits(-1) < I8F24::ZERO);
    }
}
