//! Why a reconstructor could not be built or run ([`ReconstructError`], [`ReconstructErrorKind`]).

use super::{MAX_BAND_ROWS, MAX_MARGIN};
#[cfg(doc)]
use crate::phase_function::Axis;

/// Why a reconstructor could not be built or run.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ReconstructError {
    /// A setup value is NaN or infinite.
    NotFinite,
    /// The depth range does not satisfy `0 < z_min < z_max`.
    DepthRange,
    /// The reference plane has a zero normal, passes (nearly) through the camera centre, or some
    /// pixel's ray does not meet it in front of the camera.
    ReferencePlane,
    /// The projector centre is at the camera centre or on the reference plane, or the projector ray
    /// of a point in the depth range runs parallel to the reference plane (eq 18 degenerates).
    ProjectorCentre,
    /// At this pixel the epipolar line is more than 45° away from the phase axis (x for
    /// [`Axis::Xi`], y for [`Axis::Eta`]): the phase would hardly change along it, or the epipole
    /// is in the image.
    AxisMismatch {
        /// Pixel column.
        u: u32,
        /// Pixel row.
        v: u32,
    },
    /// The band the geometry needs exceeds [`MAX_BAND_ROWS`].
    BandTooLarge {
        /// Rows needed.
        rows: u32,
    },
    /// A side of the reference map's margin exceeds [`MAX_MARGIN`].
    Margin,
    /// The ring has fewer rows than the band needs.
    BandTooSmall {
        /// Rows needed.
        needed: u32,
        /// Rows the buffers hold.
        given: u32,
    },
    /// A buffer is shorter than its width × rows, or the phase and validity buffers disagree.
    BufferTooSmall,
    /// A row or a map has the wrong length for the image width/size.
    Length,
    /// The row index is outside the image.
    Row,
    /// A reference row needed for this row is not in the ring (not pushed yet, or overwritten).
    NotResident {
        /// The missing reference row.
        row: u32,
    },
    /// Every row of the image has already been pushed into the ring.
    Sequence,
}

/// Coarse classes of [`ReconstructError`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ReconstructErrorKind {
    /// The calibration or depth range cannot be used (at set-up).
    Setup,
    /// Buffers or rows do not fit the image.
    Argument,
    /// Rows were pushed or requested out of order.
    Stream,
}

impl ReconstructError {
    /// The coarse class of the error.
    pub fn kind(&self) -> ReconstructErrorKind {
        match self {
            Self::NotFinite
            | Self::DepthRange
            | Self::ReferencePlane
            | Self::ProjectorCentre
            | Self::AxisMismatch { .. }
            | Self::BandTooLarge { .. }
            | Self::Margin
            | Self::BandTooSmall { .. } => ReconstructErrorKind::Setup,
            Self::BufferTooSmall | Self::Length | Self::Row => ReconstructErrorKind::Argument,
            Self::NotResident { .. } | Self::Sequence => ReconstructErrorKind::Stream,
        }
    }
}

impl core::fmt::Display for ReconstructError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::NotFinite => f.write_str("a reconstruction set-up value is NaN or infinite"),
            Self::DepthRange => f.write_str("depth range must satisfy 0 < z_min < z_max"),
            Self::ReferencePlane => f.write_str(
                "reference plane: zero normal, through the camera centre, or not in front of every pixel",
            ),
            Self::ProjectorCentre => f.write_str(
                "projector centre at the camera centre or on the reference plane, or degenerate triangulation in the depth range",
            ),
            Self::AxisMismatch { u, v } => write!(
                f,
                "at pixel ({u}, {v}) the epipolar line is more than 45 degrees from the phase axis"
            ),
            Self::BandTooLarge { rows } => {
                write!(f, "the geometry needs a band of {rows} reference rows (max {MAX_BAND_ROWS})")
            }
            Self::Margin => {
                write!(f, "a side of the reference map's margin exceeds {MAX_MARGIN} pixels")
            }
            Self::BandTooSmall { needed, given } => {
                write!(f, "reference ring holds {given} rows, the geometry needs {needed}")
            }
            Self::BufferTooSmall => f.write_str("buffer too small for width × rows"),
            Self::Length => f.write_str("row or map length differs from the image size"),
            Self::Row => f.write_str("row index outside the image"),
            Self::NotResident { row } => write!(f, "reference row {row} is not in the ring"),
            Self::Sequence => f.write_str("all reference rows have already been pushed"),
        }
    }
}
