//! The calibration: camera parameters and scan geometry, everything reconstruction needs besides
//! the reference phase map.

use serde::{Deserialize, Serialize};

use super::{Body, CameraParams, Invalid, ScanGeometry, WireError, check, finite64};

/// Host → head: everything reconstruction needs besides the reference phase map: the camera's
/// [`CameraParams`] and the [`ScanGeometry`] of the core's [`Setup`](crate::reconstruct::Setup),
/// in f64, so the head's reconstructor is the desktop's ([`Calibration::reconstructor`]).
/// Encoded as the two in turn (postcard is positional).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Calibration {
    /// The camera.
    pub camera: CameraParams,
    /// Projector centre, reference plane, depth range.
    pub geometry: ScanGeometry,
}

impl Calibration {
    /// Check finiteness and ranges.
    pub fn validate(&self) -> Result<(), WireError> {
        let c = &self.camera;
        let g = &self.geometry;
        // Sizes travel as varints and were u16 before the shared type: keep the same range.
        let side = 1..=u32::from(u16::MAX);
        check(
            side.contains(&c.width) && side.contains(&c.height),
            Invalid::Dimension,
        )?;
        finite64(&c.to_vector())?;
        finite64(&g.projector_centre)?;
        finite64(&g.plane_point)?;
        finite64(&g.plane_normal)?;
        finite64(&[g.depth_min, g.depth_max])?;
        check(c.fx > 0.0 && c.fy > 0.0, Invalid::Intrinsics)?;
        check(
            g.plane_normal.iter().any(|&x| x != 0.0),
            Invalid::PlaneNormal,
        )?;
        check(g.depth_min < g.depth_max, Invalid::DepthRange)
    }
}

impl Body for Calibration {
    fn validate_body(&self) -> Result<(), WireError> {
        self.validate()
    }
}
