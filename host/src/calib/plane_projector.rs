//! The phase a plane shows at a camera ray through the full projector model (steps 2-5 of
//! [`super::virtual_reference`]): shared by the virtual reference and the physical check of a
//! captured one ([`super::reference_physical`]).

use fringe3d_core::params::ProjectorParams;
use fringe3d_core::pattern::PatternSet;

use super::lens::Lens;

/// Why there is no virtual reference.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum VirtualError {
    /// The plane's normal is zero or not finite, or the plane passes through the camera centre.
    #[error(
        "the plane must have a finite non-zero normal and must not pass through the camera centre"
    )]
    Plane,
    /// The projector's rotation is not a rotation.
    #[error("the projector's rotation is not a rotation (|RᵀR − I| = {0:e})")]
    Rotation(f64),
    /// No pixel sees the plane lit by the projector.
    #[error(
        "no camera pixel sees a point of the plane that the projector lights: move the plane into both fields of view"
    )]
    Empty,
}

/// The projector lighting a plane: steps 2-5 of [`super::virtual_reference`] for one camera ray.
#[derive(Clone, Copy, Debug)]
pub(crate) struct PlaneProjector {
    lens: Lens,
    r: [[f64; 3]; 3],
    t: [f64; 3],
    size: (f64, f64),
}

impl PlaneProjector {
    /// The projector of `p`, whose rotation must be one.
    pub(crate) fn new(p: &ProjectorParams) -> Result<PlaneProjector, VirtualError> {
        let r = p.rotation;
        let mut err: f64 = 0.0;
        for i in 0..3 {
            for j in 0..3 {
                let rtr: f64 = (0..3).map(|k| r[k][i] * r[k][j]).sum();
                err = err.max((rtr - if i == j { 1.0 } else { 0.0 }).abs());
            }
        }
        if !(err < 1e-6) {
            return Err(VirtualError::Rotation(err));
        }
        Ok(PlaneProjector {
            lens: Lens::from_model(&p.intrinsics),
            r,
            t: p.translation,
            size: (
                f64::from(p.intrinsics.width),
                f64::from(p.intrinsics.height),
            ),
        })
    }

    /// The finest phase of `set` on the plane `normal·X = d` along the undistorted camera ray
    /// `(x, y, 1)`; `None` where the ray misses the plane, the point is behind the projector or
    /// its pixel is off the DMD.
    pub(crate) fn phase(
        &self,
        set: &PatternSet,
        (x, y): (f64, f64),
        (normal, d): ([f64; 3], f64),
    ) -> Option<f64> {
        let s = d / (normal[0] * x + normal[1] * y + normal[2]);
        if !(s > 0.0 && s.is_finite()) {
            return None;
        }
        let (r, t) = (&self.r, self.t);
        let q = [s * x - t[0], s * y - t[1], s - t[2]];
        let xp = [
            r[0][0] * q[0] + r[1][0] * q[1] + r[2][0] * q[2],
            r[0][1] * q[0] + r[1][1] * q[1] + r[2][1] * q[2],
            r[0][2] * q[0] + r[1][2] * q[1] + r[2][2] * q[2],
        ];
        let (xi, eta) = self.lens.project_point(xp)?;
        let (pw, ph) = self.size;
        ((-0.5..=pw - 0.5).contains(&xi) && (-0.5..=ph - 0.5).contains(&eta))
            .then(|| set.finest_phase(xi, eta))
    }
}
