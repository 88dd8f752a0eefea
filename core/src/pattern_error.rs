//! Why a pattern set was refused ([`PatternError`]), with its coarse classes: the checks of
//! `PatternSet::validate` (in `pattern`), in the core's words.

use crate::limits::{MAX_GRAY_BITS, MAX_GRAY_LEVELS, MAX_IMAGES, MAX_LEVELS, MAX_SHIFTS};
use crate::phase_function::PhaseFunctionError;

/// Why a pattern set was refused.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PatternError {
    /// The phase function is malformed or fails its check over the projector.
    Function(PhaseFunctionError),
    /// No levels, or more than [`MAX_LEVELS`].
    LevelCount(usize),
    /// Level `0` has a shift count outside 2..=[`MAX_SHIFTS`].
    ShiftCount(usize, usize),
    /// Level has a scale coefficient that is not finite and positive.
    Scale(usize),
    /// Scale coefficients must strictly increase from level to level (coarse to fine).
    ScalesNotIncreasing(usize),
    /// A shift of a level is not finite or lies outside ±`pattern::MAX_SHIFT_MAGNITUDE`.
    Shift(usize),
    /// The shifts of a level cannot separate sin and cos (they are equal modulo π), or, for a
    /// level of 3 or more, cannot separate A, sin and cos.
    DegenerateShifts(usize),
    /// A level has exactly 2 shifts but no level of the set has 3 or more to provide the DC term
    /// A (eqs 10, 11, 15).
    NoDcLevel,
    /// The image order names level/shift pairs that are out of range, repeated or missing.
    ImageOrder,
    /// More than [`MAX_IMAGES`] images in all.
    TooManyImages(usize),
    /// Projector size is zero, or the intensity range is not `0 ≤ I_min < I_max ≤ 65535`.
    Output,
    /// The constant phase offset lies outside ±`pattern::MAX_SHIFT_MAGNITUDE` (2π).
    PhaseOffset,
    /// A Gray-code level that is not level 0, or is not followed by a phase level of the same
    /// scale (the level whose fringe order it gives).
    GrayPlacement(usize),
    /// A heterodyne set that is not 2 or 3 phase levels whose beat scale (`c₁ − c₀`, or
    /// `c₂ − 2c₁ + c₀`) is positive (`pattern::Relation::Heterodyne`).
    HeterodyneLevels,
    /// A coprime set whose first two phase levels' scale ratio `c₁/c₀` is not `b/a` of coprime
    /// integers `2 ≤ a < b ≤ MAX_COPRIME` (`pattern::Relation::Coprime`), that has a Gray code, or
    /// more than `MAX_COPRIME_LEVELS` levels.
    CoprimeLevels,
    /// A Gray-code level's bit count is outside 1..=[`MAX_GRAY_BITS`].
    GrayBits(usize),
    /// A Gray-code level but no level with 3 or more shifts: its threshold is the DC term A.
    GrayNoDc,
    /// The Gray code's periods do not cover the phase level's periods over the projector: the
    /// level spans `periods` periods (`[min, max]` of `c·Φ/2π`), the code `[lo, hi)`.
    GrayRange {
        /// Smallest `c·Φ/2π` over the projector.
        min: f32,
        /// Largest `c·Φ/2π` over the projector.
        max: f32,
        /// The code's bits.
        bits: u8,
        /// Whether the code is shifted by half a period ([`crate::gray::GrayCode::shifted`]).
        shifted: bool,
    },
}

/// Coarse classes of [`PatternError`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PatternErrorKind {
    /// The phase function is at fault.
    Function,
    /// The level structure is at fault.
    Levels,
    /// The image order is at fault.
    Order,
    /// Projector or intensity parameters are at fault.
    Output,
}

impl PatternError {
    /// A coarse classification.
    pub fn kind(&self) -> PatternErrorKind {
        match self {
            Self::Function(_) => PatternErrorKind::Function,
            Self::ImageOrder | Self::TooManyImages(_) => PatternErrorKind::Order,
            Self::Output => PatternErrorKind::Output,
            Self::PhaseOffset | Self::GrayRange { .. } => PatternErrorKind::Function,
            _ => PatternErrorKind::Levels,
        }
    }
}

impl From<PhaseFunctionError> for PatternError {
    fn from(e: PhaseFunctionError) -> Self {
        PatternError::Function(e)
    }
}

impl core::fmt::Display for PatternError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::Function(e) => write!(f, "phase function: {e}"),
            Self::LevelCount(n) => write!(
                f,
                "{n} levels given; need 1 to {MAX_LEVELS} (2 to {MAX_GRAY_LEVELS} with a Gray-code level)"
            ),
            Self::ShiftCount(l, n) => {
                write!(f, "level {l} has {n} phase shifts; need 2 to {MAX_SHIFTS}")
            }
            Self::Scale(l) => write!(
                f,
                "level {l}: scale coefficient must be finite and positive"
            ),
            Self::ScalesNotIncreasing(l) => write!(
                f,
                "level {l}: scale coefficients must strictly increase from the coarsest level to the finest"
            ),
            Self::Shift(l) => write!(
                f,
                "level {l}: a phase shift is NaN, infinite or outside [-2pi, 2pi]"
            ),
            Self::DegenerateShifts(l) => write!(
                f,
                "level {l}: the phase shifts cannot separate the unknowns (shifts equal modulo pi?)"
            ),
            Self::NoDcLevel => write!(
                f,
                "a level has 2 images but no level has 3 or more to provide the DC term A"
            ),
            Self::ImageOrder => write!(
                f,
                "the image order must name every (level, shift) pair of the set exactly once"
            ),
            Self::TooManyImages(n) => write!(f, "{n} images in all; at most {MAX_IMAGES}"),
            Self::Output => write!(
                f,
                "projector size must be non-zero and 0 <= I_min < I_max <= 65535"
            ),
            Self::PhaseOffset => write!(f, "the phase offset must lie within [-2pi, 2pi]"),
            Self::GrayPlacement(l) => write!(
                f,
                "level {l}: a Gray-code level must be level 0, followed by a phase level of the \
                 same scale"
            ),
            Self::HeterodyneLevels => write!(
                f,
                "a heterodyne set needs 2 or 3 phase levels whose beat scale (c1 - c0, or \
                 c2 - 2 c1 + c0 for 3) is positive"
            ),
            Self::CoprimeLevels => write!(
                f,
                "a coprime set needs 2 to {} phase levels (no Gray code) whose first two \
                 scales are in the ratio b/a of coprime integers 2 <= a < b <= {} (an integer \
                 ratio is a hierarchical set)",
                crate::relation::MAX_COPRIME_LEVELS,
                crate::relation::MAX_COPRIME
            ),
            Self::GrayBits(n) => write!(
                f,
                "a Gray-code level has {n} bits; need 1 to {MAX_GRAY_BITS} (an inverse code: its \
                 images and their inverses at most {MAX_SHIFTS}, so 8 bits, 7 with the \
                 complementary image)"
            ),
            Self::GrayNoDc => write!(
                f,
                "a Gray-code level needs a level with 3 or more shifts: its threshold is that \
                 level's DC term A"
            ),
            Self::GrayRange {
                min,
                max,
                bits,
                shifted,
            } => {
                let b = (1u32 << (bits.saturating_sub(1) as u32)) as f32;
                let s = if *shifted { 0.5 } else { 0.0 };
                write!(
                    f,
                    "the Gray-coded level spans periods {min:.2} to {max:.2} (c*Phi/2pi) over \
                     the projector; {bits} {}bits cover [{}, {})",
                    if *shifted { "shifted " } else { "" },
                    -b - 0.5 - s,
                    b - 0.5 - s
                )
            }
        }
    }
}
