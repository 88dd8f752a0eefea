//! The renderer's geometry helpers over the host's [`Vec3`] and [`Mat3`] (in [`crate::math`],
//! shared with the calibration; independent of the core's geometry).

pub use crate::math::{Mat3, Vec3};

/// A rotation whose z column points from `from` to `to` and whose y column points "down"
/// (towards +y of the camera frame) as far as possible: the pose of a device at `from` aimed at
/// `to`, in the OpenCV convention (x right, y down, z forward). `None` if the points coincide or
/// the direction is vertical.
pub fn look_at(from: Vec3, to: Vec3) -> Option<Mat3> {
    let z = (to - from).normalized();
    let down = Vec3::new(0.0, 1.0, 0.0);
    let x = down.cross(z);
    if !(x.norm() > 1e-9) || !z.is_finite() {
        return None;
    }
    let x = x.normalized();
    let y = z.cross(x);
    Some(Mat3::from_columns(x, y, z))
}
