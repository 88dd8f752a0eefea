//! The object as the design sees it: a map of camera-frame points on the camera's pixel grid (from
//! a first scan's cloud, or a mesh placed in the rig and rasterised), and from it one
//! [`Sample`] per object pixel: its projector coordinate along the set's axis, the gradient of
//! that coordinate in the image, and the triangulation's rate `dξ/dt` along the pixel's ray.

use fringe3d_core::phase_function::Axis;
use rayon::prelude::*;

use super::Sample;
use crate::calib::lens::Lens;
use crate::io::calibration::Calibration;
use crate::io::mesh::Mesh;
use crate::math::{Mat3, Vec3};

/// The full rig: camera lens, projector lens and pose, the set's axis and the depth range.
#[derive(Clone, Copy, Debug)]
pub struct Rig {
    camera: Lens,
    projector: Lens,
    /// `X_cam = R·X_proj + T`.
    r: Mat3,
    t: Vec3,
    axis: Axis,
    depth: [f64; 2],
    /// Curved fringes `(a, w₀)`: the design's coordinate is `t + a·(w − w₀)²` (t along the axis,
    /// w across it), the phase function's own bend.
    bend: Option<(f64, f64)>,
}

/// A camera-frame point per camera pixel (NaN where the object is not seen).
#[derive(Clone, Debug)]
pub struct PointMap {
    /// Image width.
    pub width: usize,
    /// Image height.
    pub height: usize,
    /// Row-major points, mm.
    pub points: Vec<[f64; 3]>,
    /// Row-major measured light (a first scan's modulation), NaN where unknown.
    pub light: Vec<f64>,
}

/// How the points of a cloud or mesh fared.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct Gathered {
    /// Object pixels kept (seen, lit, in the volume).
    pub kept: usize,
    /// Points or pixels outside the depth range.
    pub outside_depth: usize,
    /// Points off the camera image (or behind it).
    pub outside_image: usize,
    /// Points the projector does not light (off the DMD, behind it, or shadowed).
    pub unlit: usize,
    /// Points removed by the crop box.
    pub cropped: usize,
    /// Points that are not finite (an organized cloud's invalid pixels).
    pub invalid: usize,
}

impl Rig {
    /// The rig of a calibration holding the full projector model; `None` without `[projector]`.
    pub fn new(cal: &Calibration, axis: Axis) -> Option<Rig> {
        let p = cal.projector.as_ref()?;
        Some(Rig {
            camera: Lens::from_model(&cal.camera),
            projector: Lens::from_model(&p.intrinsics),
            r: Mat3(p.rotation),
            t: Vec3::from_array(p.translation),
            axis,
            depth: cal.depth_range,
            bend: None,
        })
    }

    /// Projector pixel of a camera-frame point, `None` behind the projector or off the DMD.
    pub fn projector_pixel(&self, x: [f64; 3]) -> Option<(f64, f64)> {
        let xp = self.r.tmul_vec(Vec3::from_array(x) - self.t).to_array();
        let (u, v) = self.projector.project_point(xp)?;
        let (w, h) = (
            f64::from(self.projector.width),
            f64::from(self.projector.height),
        );
        (u >= -0.5 && u <= w - 0.5 && v >= -0.5 && v <= h - 0.5).then_some((u, v))
    }

    /// The projector coordinate along the set's axis (bent by [`Rig::with_bend`]).
    fn along(&self, x: [f64; 3]) -> Option<f64> {
        let (u, v) = self.projector_pixel(x)?;
        let (t, w) = if self.axis == Axis::Xi {
            (u, v)
        } else {
            (v, u)
        };
        Some(match self.bend {
            Some((a, w0)) => t + a * (w - w0) * (w - w0),
            None => t,
        })
    }

    /// The same rig designing curved fringes `Φ = g(t + a·(w − w₀)²)`.
    pub fn with_bend(mut self, a: f64, w0: f64) -> Rig {
        self.bend = Some((a, w0));
        self
    }

    /// The bend that makes the fringes through the object's centre `along` circles about the
    /// projector's epipole (the image of the camera centre; lens distortion left out): a point
    /// moving along a camera ray moves along a line through it, so such fringes cross every
    /// epipolar line at right angles and lose no depth sensitivity to its slant. `(a, w₀, e_t)`:
    /// `a = 1/(2·(along − e_t))`, `w₀` the epipole's coordinate across the axis. `None` when the
    /// epipolar lines are parallel (the epipole at infinity) or `w₀` lies beyond the projector by
    /// more than its size (the core's limit on the bend centre).
    pub fn epipolar_bend(&self, along: f64) -> Option<(f64, f64, f64)> {
        let c = self.r.tmul_vec(Vec3::new(0.0, 0.0, 0.0) - self.t);
        if c.z.abs() < 1e-9 * c.norm() {
            return None;
        }
        let [fx, fy, skew, cx, cy, ..] = self.projector.p;
        let (x, y) = (c.x / c.z, c.y / c.z);
        let (eu, ev) = (fx * (x + skew * y) + cx, fy * y + cy);
        let (et, ew, across) = match self.axis {
            Axis::Xi => (eu, ev, f64::from(self.projector.height)),
            Axis::Eta => (ev, eu, f64::from(self.projector.width)),
        };
        let r = along - et;
        (r.abs() > 1.0 && ew >= -across && ew <= 2.0 * across).then(|| (0.5 / r, ew, et))
    }

    fn in_depth(&self, x: &[f64; 3]) -> bool {
        x[2] >= self.depth[0] && x[2] <= self.depth[1]
    }

    /// Camera-frame points (a first scan's cloud) on the camera grid: each to its nearest pixel,
    /// the nearest to the camera where several meet; points outside `crop` (min, max corners),
    /// the depth range, the image or the projector's light are dropped and counted.
    pub fn map_points(
        &self,
        points: &[[f64; 3]],
        light: Option<&[f64]>,
        crop: Option<([f64; 3], [f64; 3])>,
    ) -> (PointMap, Gathered) {
        let (w, h) = (self.camera.width as usize, self.camera.height as usize);
        let mut map = PointMap {
            width: w,
            height: h,
            points: vec![[f64::NAN; 3]; w * h],
            light: vec![f64::NAN; w * h],
        };
        let mut g = Gathered::default();
        for (k, p) in points.iter().enumerate() {
            if !p.iter().all(|c| c.is_finite()) {
                g.invalid += 1;
                continue;
            }
            if let Some((a, b)) = crop
                && (0..3).any(|i| p[i] < a[i] || p[i] > b[i])
            {
                g.cropped += 1;
                continue;
            }
            if !self.in_depth(p) {
                g.outside_depth += 1;
                continue;
            }
            let Some((u, v)) = self.camera.project_point(*p) else {
                g.outside_image += 1;
                continue;
            };
            let (u, v) = (u.round(), v.round());
            if !(u >= 0.0 && v >= 0.0 && u < w as f64 && v < h as f64) {
                g.outside_image += 1;
                continue;
            }
            if self.along(*p).is_none() {
                g.unlit += 1;
                continue;
            }
            let i = v as usize * w + u as usize;
            if !(map.points[i][2] <= p[2]) {
                map.points[i] = *p;
                map.light[i] = light.and_then(|l| l.get(k)).copied().unwrap_or(f64::NAN);
            }
        }
        g.kept = map.points.iter().filter(|p| p[0].is_finite()).count();
        (map, g)
    }

    /// A mesh posed in the camera frame (`X_cam = R·X + t`), rasterised on the camera grid (the
    /// nearest surface per pixel centre) and kept where the projector lights it (its own
    /// rasterisation on the DMD grid tells the shadows).
    pub fn map_mesh(&self, mesh: &Mesh, rotation: Mat3, translation: Vec3) -> (PointMap, Gathered) {
        let world: Vec<[f64; 3]> = mesh
            .vertices
            .iter()
            .map(|v| (rotation.mul_vec(Vec3::from_array(*v)) + translation).to_array())
            .collect();
        let (w, h) = (self.camera.width as usize, self.camera.height as usize);
        let cam = |x: [f64; 3]| self.camera.project_point(x).map(|(u, v)| (u, v, x[2]));
        let on_image = |x: &[f64; 3]| {
            cam(*x).is_some_and(|(u, v, _)| {
                u >= -0.5 && v >= -0.5 && u < w as f64 - 0.5 && v < h as f64 - 0.5
            })
        };
        let mut zcam = vec![f64::INFINITY; w * h];
        let mut pts = vec![[f64::NAN; 3]; w * h];
        rasterise(&world, &mesh.triangles, (w, h), cam, |i, x, z| {
            if z < zcam[i] {
                zcam[i] = z;
                pts[i] = x;
            }
        });
        let (pw, ph) = (
            self.projector.width as usize,
            self.projector.height as usize,
        );
        let proj = |x: [f64; 3]| {
            let xp = self.r.tmul_vec(Vec3::from_array(x) - self.t).to_array();
            self.projector.project_point(xp).map(|(u, v)| (u, v, xp[2]))
        };
        let mut zproj = vec![f64::INFINITY; pw * ph];
        rasterise(&world, &mesh.triangles, (pw, ph), proj, |i, _, z| {
            zproj[i] = zproj[i].min(z);
        });
        let mut g = Gathered {
            outside_image: world.iter().filter(|x| !on_image(x)).count(),
            ..Gathered::default()
        };
        for p in &mut pts {
            if !p[0].is_finite() {
                continue;
            }
            let lit = proj(*p).is_some_and(|(u, v, z)| {
                let (iu, iv) = (u.round(), v.round());
                iu >= 0.0
                    && iv >= 0.0
                    && (iu as usize) < pw
                    && (iv as usize) < ph
                    && z <= zproj[iv as usize * pw + iu as usize] + 0.5 + 0.002 * z
            });
            if !lit {
                g.unlit += 1;
                *p = [f64::NAN; 3];
            } else if !self.in_depth(p) {
                g.outside_depth += 1;
                *p = [f64::NAN; 3];
            }
        }
        g.kept = pts.iter().filter(|p| p[0].is_finite()).count();
        (
            PointMap {
                width: w,
                height: h,
                points: pts,
                light: vec![f64::NAN; w * h],
            },
            g,
        )
    }

    /// One [`Sample`] per object pixel of `map` ([`grid_samples`]), its projector coordinate and
    /// `dξ/dt` from the projector model, its light measured (`map.light`) or else modelled
    /// ([`projector_light`]).
    pub fn samples(&self, map: &PointMap) -> Vec<Sample> {
        let along: Vec<f64> = map
            .points
            .par_iter()
            .map(|p| {
                if p[0].is_finite() {
                    self.along(*p).unwrap_or(f64::NAN)
                } else {
                    f64::NAN
                }
            })
            .collect();
        let measured = map.light.iter().any(|l| l.is_finite());
        grid_samples(map, &along, self.camera.p[0], |i, x, normal| {
            let n = Vec3::from_array(x).norm();
            let step = |t: f64| self.along((Vec3::from_array(x) * (1.0 + t / n)).to_array());
            let rate = step(0.5)? - step(-0.5)?;
            // A measured light is in the camera's codes, a modelled one relative: never mixed
            // (a pixel of a measured map without a value is left out).
            let light = match map.light[i] {
                l if l.is_finite() => l.max(0.0),
                _ if measured => return None,
                _ => projector_light(self.t, x, normal),
            };
            Some((rate, light))
        })
    }
}

/// The light a projector at `centre` puts on a surface at `x` with normal `normal` (any
/// orientation; turned towards the camera at the origin), relative to a surface facing it at
/// 600 mm: `cos θ_p·(600/d_p)²`, 0 when it faces away.
pub fn projector_light(centre: Vec3, x: [f64; 3], normal: Vec3) -> f64 {
    let to_proj = centre - Vec3::from_array(x);
    let d = to_proj.norm();
    let cos = normal.try_normalized().map_or(0.0, |n| {
        let n = if n.dot(Vec3::from_array(x)) > 0.0 {
            n * -1.0
        } else {
            n
        };
        n.dot(to_proj) / d
    });
    cos.max(0.0) * (600.0 / d).powi(2)
}

/// One [`Sample`] per pixel of `map` with a finite projector coordinate in `along` whose
/// neighbours give its image gradient and normal, by central differences over ±4, ±2 or ±1
/// pixels (the widest on one surface: a neighbour k pixels away lies within 20·k pixel
/// footprints, `fx` the camera's focal length in pixels); pixels with no such pair along both
/// image axes (isolated, or at a depth edge) are left out. `per_pixel(index, point, normal)`
/// gives the pixel's `dξ/dt` (per mm) and light ([`Sample::bright`]), `None` to leave it out.
pub fn grid_samples(
    map: &PointMap,
    along: &[f64],
    fx: f64,
    per_pixel: impl Fn(usize, [f64; 3], Vec3) -> Option<(f64, f64)> + Sync,
) -> Vec<Sample> {
    let (w, h) = (map.width, map.height);
    let per_pixel = &per_pixel;
    (0..h)
        .into_par_iter()
        .flat_map_iter(|v| {
            let map = &map.points;
            (0..w).filter_map(move |u| {
                let i = v * w + u;
                let x = map[i];
                if !along[i].is_finite() || !x[0].is_finite() {
                    return None;
                }
                let reach = 20.0 * x[2] / fx;
                let near = |j: usize, k: usize| {
                    let y = map[j];
                    along[j].is_finite()
                        && (Vec3::from_array(y) - Vec3::from_array(x)).norm() <= reach * k as f64
                };
                // Central differences over ±K pixels (a first scan's point noise shrinks by the
                // baseline), K = 4, 2 or 1: the widest whose ends are on the same surface.
                let pair = |step: &dyn Fn(usize) -> (Option<usize>, Option<usize>)| {
                    [4usize, 2, 1].into_iter().find_map(|k| {
                        let (lo, hi) = step(k);
                        match (lo.filter(|&j| near(j, k)), hi.filter(|&j| near(j, k))) {
                            (Some(a), Some(b)) => Some((a, b, 0.5 / k as f64)),
                            _ => None,
                        }
                    })
                };
                let hu = pair(&|k| {
                    (
                        u.checked_sub(k).map(|u| v * w + u),
                        (u + k < w).then(|| i + k),
                    )
                })?;
                let hv = pair(&|k| {
                    (
                        v.checked_sub(k).map(|v| v * w + u),
                        (v + k < h).then(|| i + k * w),
                    )
                })?;
                let gu = hu.2 * (along[hu.1] - along[hu.0]);
                let gv = hv.2 * (along[hv.1] - along[hv.0]);
                let sub = |a: usize, b: usize| Vec3::from_array(map[a]) - Vec3::from_array(map[b]);
                let normal = sub(hu.1, hu.0).cross(sub(hv.1, hv.0));
                let (rate, bright) = per_pixel(i, x, normal)?;
                (rate.is_finite() && rate.abs() > 1e-9 && bright.is_finite()).then(|| Sample {
                    along: along[i],
                    grad: gu.hypot(gv),
                    weight: 1.0 / (rate * rate),
                    bright,
                })
            })
        })
        .collect()
}

/// Rasterise triangles of `world` points onto a `(w, h)` pixel grid through `project` (a point →
/// pixel and depth): `write(index, point, depth)` at every pixel centre inside a projected
/// triangle, the point and its depth interpolated perspective-correctly (image barycentrics
/// weighted by 1/depth: exact for a pinhole, and within the lens distortion's change across a
/// triangle otherwise).
fn rasterise(
    world: &[[f64; 3]],
    triangles: &[[u32; 3]],
    (w, h): (usize, usize),
    project: impl Fn([f64; 3]) -> Option<(f64, f64, f64)>,
    mut write: impl FnMut(usize, [f64; 3], f64),
) {
    for t in triangles {
        let x = t.map(|i| world[i as usize]);
        let (Some(a), Some(b), Some(c)) = (project(x[0]), project(x[1]), project(x[2])) else {
            continue;
        };
        let area = (b.0 - a.0) * (c.1 - a.1) - (c.0 - a.0) * (b.1 - a.1);
        if !(area.abs() > 1e-12) {
            continue;
        }
        let u0 = a.0.min(b.0).min(c.0).ceil().max(0.0);
        let u1 = a.0.max(b.0).max(c.0).floor().min(w as f64 - 1.0);
        let v0 = a.1.min(b.1).min(c.1).ceil().max(0.0);
        let v1 = a.1.max(b.1).max(c.1).floor().min(h as f64 - 1.0);
        if !(u0 <= u1 && v0 <= v1) {
            continue;
        }
        for v in v0 as usize..=v1 as usize {
            for u in u0 as usize..=u1 as usize {
                let (pu, pv) = (u as f64, v as f64);
                let l1 = ((c.0 - b.0) * (pv - b.1) - (pu - b.0) * (c.1 - b.1)) / area;
                let l2 = ((a.0 - c.0) * (pv - c.1) - (pu - c.0) * (a.1 - c.1)) / area;
                let l3 = 1.0 - l1 - l2;
                let e = -1e-9;
                if l1 < e || l2 < e || l3 < e {
                    continue;
                }
                let (q1, q2, q3) = (l1 / a.2, l2 / b.2, l3 / c.2);
                let sum = q1 + q2 + q3;
                if !(sum > 0.0) {
                    continue;
                }
                let p = [0, 1, 2].map(|k| (q1 * x[0][k] + q2 * x[1][k] + q3 * x[2][k]) / sum);
                write(v * w + u, p, 1.0 / sum);
            }
        }
    }
}
