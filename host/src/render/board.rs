//! Checkerboards: the board object, its inner corners, and random poses in the volume.

use super::camera::LensModel;
use super::math::Vec3;
use super::objects::{ObjectSpec, Shape, Texture};
use super::rig::Rig;
use super::rng::{Rng, derive};
use super::scene::{BoardSpec, Pose};
use serde::Serialize;

/// The board as a plane object (with its border) at `pose`; `size` overrides the plate size
/// (plates carry a board on a larger plate).
pub fn board_object(
    b: &BoardSpec,
    pose: &Pose,
    size: Option<[f64; 2]>,
    textured: bool,
    albedo: f64,
) -> ObjectSpec {
    let r = pose.rotation();
    let size = size.unwrap_or([
        b.cols as f64 * b.square + 2.0 * b.margin,
        b.rows as f64 * b.square + 2.0 * b.margin,
    ]);
    ObjectSpec {
        name: if textured {
            "board".into()
        } else {
            "plate".into()
        },
        albedo,
        shape: Shape::Plane {
            point: pose.center,
            normal: r.column(2).to_array(),
            size: Some(size),
            u_axis: Some(r.column(0).to_array()),
        },
        texture: textured.then_some(Texture::Checker {
            square: b.square,
            cols: b.cols,
            rows: b.rows,
            dark: b.dark,
            light: b.light,
        }),
        specular: None,
    }
}

/// Inner corners in the board frame (mm, z = 0), row by row (x fastest), as in OpenCV.
pub fn local_corners(b: &BoardSpec) -> Vec<[f64; 2]> {
    let (w, h) = (b.cols as f64 * b.square, b.rows as f64 * b.square);
    let mut v = Vec::new();
    for j in 1..b.rows {
        for i in 1..b.cols {
            v.push([i as f64 * b.square - 0.5 * w, j as f64 * b.square - 0.5 * h]);
        }
    }
    v
}

/// The inner corners of a board at `pose`, camera frame.
pub fn corners(b: &BoardSpec, pose: &Pose) -> Vec<Vec3> {
    local_corners(b)
        .iter()
        .map(|c| pose.apply(Vec3::new(c[0], c[1], 0.0)))
        .collect()
}

/// Ground truth of one board image.
#[derive(Clone, Debug, Serialize)]
pub struct BoardTruth {
    /// Image file.
    pub image: String,
    /// The pose.
    pub pose: Pose,
    /// Rotation board → camera (row-major).
    pub rotation: [[f64; 3]; 3],
    /// The board plane's unit normal, towards the camera.
    pub normal: [f64; 3],
    /// Inner corners, camera frame, mm.
    pub corners_mm: Vec<[f64; 3]>,
    /// Inner corners projected by the camera model (distortion included), pixels.
    pub corners_px: Vec<[f64; 2]>,
}

/// Truth for a board at `pose`; `None` if a corner does not project.
pub fn board_truth(b: &BoardSpec, pose: &Pose, rig: &Rig, image: &str) -> Option<BoardTruth> {
    let cs = corners(b, pose);
    let rm = rig.camera.max_radius();
    let px: Option<Vec<[f64; 2]>> = cs
        .iter()
        .map(|p| rig.camera.project(*p, rm).map(|(u, v)| [u, v]))
        .collect();
    let r = pose.rotation();
    let mut n = r.column(2);
    if n.dot(Vec3::from_array(pose.center)) > 0.0 {
        n = -n;
    }
    Some(BoardTruth {
        image: image.into(),
        pose: *pose,
        rotation: r.0,
        normal: n.to_array(),
        corners_mm: cs.iter().map(|p| p.to_array()).collect(),
        corners_px: px?,
    })
}

/// `true` if the whole board at `pose` is seen well: its outline and corners inside the image by
/// `margin_px`, tilted less than 60° from the camera, and — if `lit` — every corner on the DMD
/// and facing the projector.
pub fn pose_ok(b: &BoardSpec, pose: &Pose, rig: &Rig, margin_px: f64, lit: bool) -> bool {
    let (w, h) = (
        b.cols as f64 * b.square + 2.0 * b.margin,
        b.rows as f64 * b.square + 2.0 * b.margin,
    );
    let mut pts = corners(b, pose);
    for (sx, sy) in [(-0.5, -0.5), (0.5, -0.5), (0.5, 0.5), (-0.5, 0.5)] {
        pts.push(pose.apply(Vec3::new(sx * w, sy * h, 0.0)));
    }
    let rm = rig.camera.max_radius();
    let cam = &rig.camera;
    let inside = pts.iter().all(|p| {
        cam.project(*p, rm).is_some_and(|(u, v)| {
            u >= margin_px
                && v >= margin_px
                && u <= cam.width as f64 - 1.0 - margin_px
                && v <= cam.height as f64 - 1.0 - margin_px
        })
    });
    if !inside {
        return false;
    }
    let c = Vec3::from_array(pose.center);
    let n = pose.rotation().column(2);
    let cos_view = n.dot(c).abs() / c.norm();
    if cos_view < 0.5 {
        return false;
    }
    if lit {
        let p = rig.projector_centre();
        let ok = corners(b, pose).iter().all(|x| {
            let facing = n.dot(p - *x).signum() == n.dot(-*x).signum();
            facing
                && rig.projector_pixel(*x).is_some_and(|(xi, eta)| {
                    xi >= 0.0
                        && eta >= 0.0
                        && xi <= rig.projector.width as f64 - 1.0
                        && eta <= rig.projector.height as f64 - 1.0
                })
        });
        if !ok {
            return false;
        }
    }
    true
}

/// `count` random well-seen poses, deterministic in `seed`.
pub fn random_poses(
    b: &BoardSpec,
    rig: &Rig,
    seed: u64,
    count: usize,
    lit: bool,
) -> Result<Vec<Pose>, String> {
    let mut rng = Rng::new(derive(&[seed, 0xB0A7D]));
    let (lo, hi) = (rig.volume_min, rig.volume_max);
    let zmid = 0.5 * (lo[2] + hi[2]);
    let mut out = Vec::with_capacity(count);
    let mut tries = 0;
    while out.len() < count {
        tries += 1;
        if tries > 200_000 {
            return Err(format!(
                "found only {} of {count} board poses that show the whole board; use a smaller board or fewer poses",
                out.len()
            ));
        }
        let mut u = |a: f64, b: f64| a + (b - a) * rng.uniform();
        let z = u(lo[2] + 30.0, hi[2] - 20.0);
        // Spread over the field at that depth.
        let s = z / zmid;
        let pose = Pose {
            center: [
                u(0.35 * lo[0] * s, 0.35 * hi[0] * s),
                u(0.35 * lo[1] * s, 0.35 * hi[1] * s),
                z,
            ],
            euler_deg: [u(-30.0, 30.0), u(-30.0, 30.0), u(-15.0, 15.0)],
        };
        if pose_ok(b, &pose, rig, 12.0, lit) {
            out.push(pose);
        }
    }
    Ok(out)
}
