//! The camera sample types the decoder reads ([`Sample`]): `u8`, or `u16` for 12- and 16-bit
//! sensors. Used by the decoding arithmetic ([`crate::arith`]) and the decoder
//! ([`crate::decode`], which re-exports it as `fringe3d_core::decode::Sample`).

/// A camera sample type the decoder reads: `u8` or `u16` (12- or 16-bit sensors).
pub trait Sample: Copy {
    /// Largest code of the type.
    const MAX: f32;
    /// The value as f32 (exact: every u16 is representable).
    fn to_f32(self) -> f32;
    /// The value as i32 (the fixed-point backend's input).
    #[inline(always)]
    fn to_i32(self) -> i32 {
        self.to_f32() as i32
    }
    /// The larger of two samples (the row decoder tracks the largest sample of each pixel to test
    /// saturation once, instead of once per image).
    #[inline(always)]
    fn max_of(self, other: Self) -> Self {
        if self.to_f32() > other.to_f32() {
            self
        } else {
            other
        }
    }
}

impl Sample for u8 {
    #[inline(always)]
    fn max_of(self, other: Self) -> Self {
        if self > other { self } else { other }
    }
    const MAX: f32 = 255.0;
    #[inline(always)]
    fn to_f32(self) -> f32 {
        self as f32
    }
    #[inline(always)]
    fn to_i32(self) -> i32 {
        self as i32
    }
}

impl Sample for u16 {
    #[inline(always)]
    fn max_of(self, other: Self) -> Self {
        if self > other { self } else { other }
    }
    const MAX: f32 = 65535.0;
    #[inline(always)]
    fn to_f32(self) -> f32 {
        self as f32
    }
    #[inline(always)]
    fn to_i32(self) -> i32 {
        self as i32
    }
}
