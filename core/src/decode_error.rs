//! Why a decoder could not be built or run ([`DecodeError`]). Below the decoding arithmetic
//! ([`crate::arith`], whose backends may refuse a set) and the decoder ([`crate::decode`], which
//! re-exports it as `fringe3d_core::decode::DecodeError`).

/// Why a decoder could not be built or run.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DecodeError {
    /// The pattern set's shifts cannot be decoded at this level.
    Degenerate(u8),
    /// A threshold is NaN, negative, or the unwrap tolerance exceeds π.
    Config,
    /// The number of image rows differs from the set's image count.
    ImageCount,
    /// Input or output rows differ in length.
    Length,
    /// The state buffer given to the frame-sequential decoder is too small.
    StateTooSmall,
    /// A frame or row was pushed out of order, or the set was already complete.
    Sequence,
    /// The frame-sequential decoder of a Gray-coded set whose image order has a Gray-code image
    /// before the last image of the DC level: it thresholds each Gray image against A as it
    /// arrives ([`crate::gray`]). The row decoder takes any order.
    GrayBeforeDc,
    /// A row narrower than [`crate::decode::BLOCK`] pixels, in a build of the core without its
    /// `short-rows` feature (which decodes such rows through a padded block).
    ShortRow,
}

impl DecodeError {
    /// The error itself (all variants are argument errors; the enum is its own kind).
    pub fn kind(&self) -> DecodeError {
        *self
    }
}

impl core::fmt::Display for DecodeError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::Degenerate(l) => write!(f, "level {l}: shifts cannot be decoded"),
            Self::Config => f.write_str(
                "decode thresholds must be finite and non-negative, unwrap tolerance <= pi",
            ),
            Self::ImageCount => f.write_str("number of image rows differs from the pattern set"),
            Self::Length => f.write_str("input and output rows differ in length"),
            Self::StateTooSmall => f.write_str("state buffer too small for this frame size"),
            Self::Sequence => f.write_str("frame or row pushed out of order"),
            Self::GrayBeforeDc => f.write_str(
                "frame-sequential decoding needs the DC level's images before the Gray-code images",
            ),
            Self::ShortRow => f.write_str(
                "a row narrower than 64 pixels: this build of the core has no `short-rows` feature",
            ),
        }
    }
}
