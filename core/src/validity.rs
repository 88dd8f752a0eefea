//! Per-pixel validity codes, shared by decoding and reconstruction.
//!
//! Every output pixel carries one of these codes next to its value. A pixel whose code is not
//! [`Validity::Valid`] has a value that must not be used; the code says why. Codes are stored as
//! one `u8` per pixel (`Validity as u8`) so that rows of them can live in caller buffers and on the
//! wire.

/// Why a pixel does or does not carry a usable value.
///
/// The numeric values are part of the wire format and of the golden vectors: never renumber.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[repr(u8)]
pub enum Validity {
    /// The value is usable.
    Valid = 0,
    /// The DC term A is below the dark threshold: no light reaches the pixel (shadow, black
    /// surface, outside the projector frame).
    Dark = 1,
    /// At least one input sample is at or above the saturation level: the sinusoid is clipped and
    /// the phase would be biased.
    Saturated = 2,
    /// The modulation B of some level is below the threshold: the phase is dominated by noise.
    LowModulation = 3,
    /// Hierarchical unwrapping (eqs 12-13) found the scaled coarser phase too far from any
    /// 2π-multiple offset of the finer wrapped phase: the fringe order is unreliable.
    UnwrapInconsistent = 4,
    /// The coarsest level's phase lies outside the range the pattern set can produce.
    PhaseOutOfRange = 5,
    /// Reconstruction: the pixel's phase is not found on the reference phase map along its
    /// epipolar line (paper §6, step 1).
    NoCrossing = 6,
    /// Reconstruction: the point lies outside the configured depth range of the measurement volume.
    OutOfDepth = 7,
    /// Reconstruction: the reference phase map is invalid where it would be read.
    ReferenceInvalid = 8,
    /// Reconstruction: the geometry is degenerate for this pixel (ray parallel to the reference
    /// plane, or the triangle of eq 18 collapses).
    Degenerate = 9,
    /// Edge filter: the point's depth jumps to a neighbour's by more than a surface of the
    /// configured steepest slope explains — a pixel straddling a depth discontinuity ("flying
    /// pixel"), whose phase mixes two surfaces ([`crate::filter`]).
    DepthEdge = 10,
    /// Gray code (issue #20): more bits of the pixel's code word lie within the threshold
    /// margin of the DC term than the scheme tolerates (one for the plain code, two for the
    /// complementary one, [`crate::gray`]): the stripe, so the fringe order, is unknown.
    CodeAmbiguous = 11,
    /// Edge filter: a 4-neighbour receives no usable light ([`Validity::Dark`],
    /// [`Validity::Saturated`] or [`Validity::LowModulation`]), so the pixel straddles the edge
    /// of the light (the projector's frame, a shadow, a black or clipped patch): its phase is the
    /// lit part's, biased towards it by up to half a pixel's change of phase ([`crate::filter`]).
    LightEdge = 12,
}

impl Validity {
    /// All codes, in numeric order.
    pub const ALL: [Validity; 13] = [
        Validity::Valid,
        Validity::Dark,
        Validity::Saturated,
        Validity::LowModulation,
        Validity::UnwrapInconsistent,
        Validity::PhaseOutOfRange,
        Validity::NoCrossing,
        Validity::OutOfDepth,
        Validity::ReferenceInvalid,
        Validity::Degenerate,
        Validity::DepthEdge,
        Validity::CodeAmbiguous,
        Validity::LightEdge,
    ];

    /// The code of a stored byte, or `None` for a byte that is no code.
    pub const fn from_u8(b: u8) -> Option<Validity> {
        if (b as usize) < Self::ALL.len() {
            Some(Self::ALL[b as usize])
        } else {
            None
        }
    }

    /// `true` for [`Validity::Valid`].
    pub const fn is_valid(self) -> bool {
        matches!(self, Validity::Valid)
    }

    /// A short lowercase name, for reports and file metadata.
    pub const fn name(self) -> &'static str {
        match self {
            Validity::Valid => "valid",
            Validity::Dark => "dark",
            Validity::Saturated => "saturated",
            Validity::LowModulation => "low-modulation",
            Validity::UnwrapInconsistent => "unwrap-inconsistent",
            Validity::PhaseOutOfRange => "phase-out-of-range",
            Validity::NoCrossing => "no-crossing",
            Validity::OutOfDepth => "out-of-depth",
            Validity::ReferenceInvalid => "reference-invalid",
            Validity::Degenerate => "degenerate",
            Validity::DepthEdge => "depth-edge",
            Validity::CodeAmbiguous => "code-ambiguous",
            Validity::LightEdge => "light-edge",
        }
    }
}
