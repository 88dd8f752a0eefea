//! The size limits of a pattern set, shared by the set ([`crate::pattern`]), its estimators
//! ([`crate::estimator`]), the decoding arithmetic ([`crate::arith`]) and the decoder
//! ([`crate::decode`]): fixed, so every table of the `no_std` core is a fixed-size array.
//! [`crate::pattern`] re-exports them (`fringe3d_core::pattern::MAX_LEVELS`).

/// The most levels a set holds.
pub const MAX_LEVELS: usize = 6;
/// The most phase shifts one level holds.
pub const MAX_SHIFTS: usize = 16;
/// The most bits of a Gray-code level ([`crate::pattern::GrayCode`]): 2^10 = 1024 stripes, one
/// per fringe period (11 images with the complementary one).
pub const MAX_GRAY_BITS: usize = 10;
/// The most levels of a set with a Gray-code level: the code and one or two phase levels (each
/// level count is a loop of its own in the decoder's finishing pass, 3 KB of a head's flash).
pub const MAX_GRAY_LEVELS: usize = 3;
/// The most images a set holds.
pub const MAX_IMAGES: usize = 64;
/// Knots per level of a phase-error table ([`crate::decode::PhaseCorrection`]), over one period
/// of the wrapped phase.
pub const CORRECTION_KNOTS: usize = 32;
/// The unit of a phase-error table's knots: 2⁻¹³ rad (1.2e-4 rad; an i16 spans ±4 rad).
pub const CORRECTION_LSB: f64 = 1.0 / 8192.0;
