//! The size limits of a pattern set, shared by the set ([`crate::pattern`]), its estimators
//! ([`crate::estimator`]), the decoding arithmetic ([`crate::arith`]) and the decoder
//! ([`crate::decode`]): fixed, so every table of the `no_std` core is a fixed-size array.
//! [`crate::pattern`] re-exports them (`fringe3d_core::pattern::MAX_LEVELS`).

/// The most levels a set holds.
pub const MAX_LEVELS: usize = 6;
/// The most phase shifts one level holds.
pub const MAX_SHIFTS: usize = 16;
/// The most images a set holds.
pub const MAX_IMAGES: usize = 32;
