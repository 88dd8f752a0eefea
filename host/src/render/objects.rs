//! Analytic objects with exact geometry, and ray intersection (nearest hit).
//!
//! Every shape is intersected in closed form (planes, spheres, cylinders, boxes) and polished by
//! one Newton step on its implicit equation, or — for the free-form height field — found by
//! Lipschitz-safe ray marching and refined by safeguarded Newton/bisection until the bracket is
//! below 1e-10 mm. Hit points are therefore exact to ~1e-9 mm at the working distance.

use super::freeform::HeightField;
use super::math::{Mat3, Vec3};
use serde::{Deserialize, Serialize};

fn yes() -> bool {
    true
}

fn default_albedo() -> f64 {
    0.8
}

/// The geometry of an object (camera frame, mm, angles in degrees).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
pub enum Shape {
    /// A plane through `point` with normal `normal`; infinite, or a `size = [w, h]` rectangle
    /// centred on `point` with its `w` side along `u_axis` (projected onto the plane; default the
    /// camera's x axis, or y if x is normal to the plane).
    Plane {
        /// A point on the plane (the rectangle's centre).
        point: [f64; 3],
        /// The normal (need not be unit length).
        normal: [f64; 3],
        /// `[w, h]` of a finite rectangle, mm; absent = infinite.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        size: Option<[f64; 2]>,
        /// Direction of the rectangle's `w` side and of the texture's u axis.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        u_axis: Option<[f64; 3]>,
    },
    /// A sphere.
    Sphere {
        /// Centre.
        center: [f64; 3],
        /// Radius, mm.
        radius: f64,
    },
    /// A finite circular cylinder from `center − axis·length/2` to `center + axis·length/2`,
    /// closed by flat caps unless `caps = false`.
    Cylinder {
        /// Midpoint of the axis.
        center: [f64; 3],
        /// Axis direction (need not be unit length).
        axis: [f64; 3],
        /// Radius, mm.
        radius: f64,
        /// Length along the axis, mm.
        length: f64,
        /// Closed by flat end caps (default `true`).
        #[serde(default = "yes")]
        caps: bool,
    },
    /// A box of edge lengths `size` centred at `center`, rotated by `euler_deg` (x, then y, then
    /// z about the camera axes, degrees).
    Box {
        /// Centre.
        center: [f64; 3],
        /// Edge lengths `[sx, sy, sz]` along the box's own axes, mm.
        size: [f64; 3],
        /// Rotation, degrees.
        #[serde(default)]
        euler_deg: [f64; 3],
    },
    /// A ball bar: two spheres of `radius` at `center_a` and `center_b`, joined by a cylindrical
    /// bar of `bar_radius` (0 = no bar). Expands to 2 or 3 primitives with their own ids.
    BallBar {
        /// Centre of ball A.
        center_a: [f64; 3],
        /// Centre of ball B.
        center_b: [f64; 3],
        /// Ball radius, mm.
        radius: f64,
        /// Bar radius, mm (0: no bar).
        #[serde(default)]
        bar_radius: f64,
    },
    /// A smooth free-form surface: the height field
    /// `z_local = base + Σ a·exp(−((x−x₀)² + (y−y₀)²)/(2σ²))` over the rectangle
    /// `|x| ≤ w/2, |y| ≤ h/2` of a local frame centred at `center` and rotated by `euler_deg`.
    HeightField {
        /// Origin of the local frame.
        center: [f64; 3],
        /// Rotation of the local frame, degrees (x, y, z about camera axes).
        #[serde(default)]
        euler_deg: [f64; 3],
        /// `[w, h]` of the rectangle, mm.
        size: [f64; 2],
        /// Constant height, mm.
        #[serde(default)]
        base: f64,
        /// Gaussian bumps `[x₀, y₀, a, σ]`, mm.
        bumps: Vec<[f64; 4]>,
    },
}

/// A surface texture (albedo pattern) on a plane.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
pub enum Texture {
    /// A checkerboard of `cols × rows` squares of edge `square` mm, centred on the plane's
    /// point, the top-left square (most negative u and v) dark. Outside the squares the plane has
    /// the object's albedo.
    Checker {
        /// Square edge, mm.
        square: f64,
        /// Squares along u.
        cols: u32,
        /// Squares along v.
        rows: u32,
        /// Albedo of dark squares.
        dark: f64,
        /// Albedo of light squares.
        light: f64,
    },
}

/// An object of a scene.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ObjectSpec {
    /// A name for reports and the manifest.
    #[serde(default)]
    pub name: String,
    /// Lambertian albedo (0..1), default 0.8.
    #[serde(default = "default_albedo")]
    pub albedo: f64,
    /// The geometry.
    pub shape: Shape,
    /// An albedo pattern (planes only).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub texture: Option<Texture>,
    /// A glossy surface: a Blinn-Phong lobe on top of the Lambertian albedo.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub specular: Option<Specular>,
}

/// A Blinn-Phong specular lobe: the projector's light reflected towards the camera with the
/// relative radiance `strength·(n·h)^exponent` (h the half vector of the directions to the
/// projector and to the camera), on top of the Lambertian `albedo·cos θ`. At the mirror angle it
/// is `strength` times a white Lambertian surface facing the projector: a highlight.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Specular {
    /// Peak relative radiance (0..100).
    pub strength: f64,
    /// Sharpness of the lobe (1..10 000; larger is smaller).
    pub exponent: f64,
}

/// A primitive ready for intersection.
#[derive(Clone, Debug)]
pub(crate) enum Prim {
    Plane {
        p: Vec3,
        n: Vec3,
        u: Vec3,
        v: Vec3,
        half: Option<(f64, f64)>,
    },
    Sphere {
        c: Vec3,
        r: f64,
    },
    Cylinder {
        c0: Vec3,
        w: Vec3,
        r: f64,
        len: f64,
        caps: bool,
    },
    Box {
        c: Vec3,
        rot: Mat3,
        half: Vec3,
    },
    Height(Box<HeightField>),
}

/// One primitive of the scene with its id (1-based; 0 means "nothing") and material.
#[derive(Clone, Debug)]
pub struct Primitive {
    /// Object id written to the ground truth (1-based).
    pub id: u16,
    /// Index of the [`ObjectSpec`] it comes from.
    pub object: usize,
    /// Which part of the object (0 for simple shapes; ball bar: 0 = ball A, 1 = ball B, 2 = bar).
    pub part: u8,
    /// Albedo.
    pub albedo: f64,
    /// The specular lobe `(strength, exponent)`, if glossy.
    pub specular: Option<(f64, f64)>,
    texture: Option<Texture>,
    pub(crate) prim: Prim,
}

/// The nearest intersection of a ray.
#[derive(Clone, Copy, Debug)]
pub struct Hit {
    /// Ray parameter.
    pub t: f64,
    /// The point, camera frame.
    pub point: Vec3,
    /// Unit surface normal, oriented towards the ray's origin side.
    pub normal: Vec3,
    /// Index of the primitive in the scene.
    pub prim: usize,
    /// Albedo at the point (texture applied).
    pub albedo: f64,
    /// The primitive's specular lobe `(strength, exponent)`, if glossy.
    pub specular: Option<(f64, f64)>,
    /// A code that differs between primitives, faces and texture cells: the renderer
    /// supersamples pixels more finely where it changes.
    pub class: u32,
}

fn unit(a: [f64; 3], what: &str) -> Result<Vec3, String> {
    let v = Vec3::from_array(a);
    let n = v.norm();
    if !(n.is_finite() && n > 1e-12) {
        return Err(format!("{what} must be a finite non-zero vector"));
    }
    Ok(v * (1.0 / n))
}

fn finite(a: &[f64], what: &str) -> Result<(), String> {
    if a.iter().all(|v| v.is_finite()) {
        Ok(())
    } else {
        Err(format!("{what} must be finite"))
    }
}

fn positive(v: f64, what: &str) -> Result<(), String> {
    if v.is_finite() && v > 0.0 {
        Ok(())
    } else {
        Err(format!("{what} must be positive, got {v}"))
    }
}

/// In-plane axes: `u` from a hint projected onto the plane, `v = n × u`.
pub(crate) fn plane_axes(n: Vec3, hint: Option<[f64; 3]>) -> Result<(Vec3, Vec3), String> {
    let try_axis = |a: Vec3| {
        let p = a - n * a.dot(n);
        (p.norm() > 1e-6).then(|| p.normalized())
    };
    let u = match hint {
        Some(h) => {
            try_axis(unit(h, "plane u_axis")?).ok_or("plane u_axis is normal to the plane")?
        }
        None => try_axis(Vec3::new(1.0, 0.0, 0.0))
            .or_else(|| try_axis(Vec3::new(0.0, 1.0, 0.0)))
            .ok_or("plane normal is degenerate")?,
    };
    Ok((u, n.cross(u)))
}

impl ObjectSpec {
    /// Check the object; the message names it.
    pub fn validate(&self, index: usize) -> Result<(), String> {
        self.primitives(index, 1).map(|_| ())
    }

    /// The primitives of this object, ids from `first_id`.
    pub fn primitives(&self, index: usize, first_id: u16) -> Result<Vec<Primitive>, String> {
        let label = if self.name.is_empty() {
            format!("object {index}")
        } else {
            format!("object {index} ({})", self.name)
        };
        let e = |m: String| format!("{label}: {m}");
        if !(self.albedo.is_finite() && (0.0..=1.0).contains(&self.albedo)) {
            return Err(e(format!("albedo must be in [0, 1], got {}", self.albedo)));
        }
        if let Some(Texture::Checker {
            square,
            cols,
            rows,
            dark,
            light,
        }) = &self.texture
        {
            positive(*square, "checker square").map_err(e)?;
            if *cols == 0 || *rows == 0 {
                return Err(e("checker needs at least one column and row".into()));
            }
            for a in [dark, light] {
                if !(a.is_finite() && (0.0..=1.0).contains(a)) {
                    return Err(e("checker albedos must be in [0, 1]".into()));
                }
            }
            if !matches!(self.shape, Shape::Plane { .. }) {
                return Err(e("textures are supported on planes only".into()));
            }
        }
        if let Some(sp) = &self.specular
            && !(sp.strength.is_finite()
                && (0.0..=100.0).contains(&sp.strength)
                && sp.exponent.is_finite()
                && (1.0..=1e4).contains(&sp.exponent))
        {
            return Err(e(format!(
                "specular strength must be in [0, 100] and exponent in [1, 10000], got {} and {}",
                sp.strength, sp.exponent
            )));
        }
        let mk = |part: u8, id: u16, prim: Prim| Primitive {
            id,
            object: index,
            part,
            albedo: self.albedo,
            specular: self.specular.map(|s| (s.strength, s.exponent)),
            texture: self.texture.clone(),
            prim,
        };
        let prims = match &self.shape {
            Shape::Plane {
                point,
                normal,
                size,
                u_axis,
            } => {
                finite(point, "plane point").map_err(e)?;
                let n = unit(*normal, "plane normal").map_err(e)?;
                let (u, v) = plane_axes(n, *u_axis).map_err(e)?;
                let half = match size {
                    Some([w, h]) => {
                        positive(*w, "plane width").map_err(e)?;
                        positive(*h, "plane height").map_err(e)?;
                        Some((0.5 * w, 0.5 * h))
                    }
                    None => None,
                };
                vec![mk(
                    0,
                    first_id,
                    Prim::Plane {
                        p: Vec3::from_array(*point),
                        n,
                        u,
                        v,
                        half,
                    },
                )]
            }
            Shape::Sphere { center, radius } => {
                finite(center, "sphere centre").map_err(e)?;
                positive(*radius, "sphere radius").map_err(e)?;
                vec![mk(
                    0,
                    first_id,
                    Prim::Sphere {
                        c: Vec3::from_array(*center),
                        r: *radius,
                    },
                )]
            }
            Shape::Cylinder {
                center,
                axis,
                radius,
                length,
                caps,
            } => {
                finite(center, "cylinder centre").map_err(e)?;
                let w = unit(*axis, "cylinder axis").map_err(e)?;
                positive(*radius, "cylinder radius").map_err(e)?;
                positive(*length, "cylinder length").map_err(e)?;
                let c0 = Vec3::from_array(*center) - w * (0.5 * length);
                vec![mk(
                    0,
                    first_id,
                    Prim::Cylinder {
                        c0,
                        w,
                        r: *radius,
                        len: *length,
                        caps: *caps,
                    },
                )]
            }
            Shape::Box {
                center,
                size,
                euler_deg,
            } => {
                finite(center, "box centre").map_err(e)?;
                finite(euler_deg, "box euler_deg").map_err(e)?;
                for s in size {
                    positive(*s, "box size").map_err(e)?;
                }
                let half = Vec3::from_array(*size) * 0.5;
                vec![mk(
                    0,
                    first_id,
                    Prim::Box {
                        c: Vec3::from_array(*center),
                        rot: Mat3::from_euler_deg(*euler_deg),
                        half,
                    },
                )]
            }
            Shape::BallBar {
                center_a,
                center_b,
                radius,
                bar_radius,
            } => {
                finite(center_a, "ball bar centre_a").map_err(e)?;
                finite(center_b, "ball bar centre_b").map_err(e)?;
                positive(*radius, "ball radius").map_err(e)?;
                let (a, b) = (Vec3::from_array(*center_a), Vec3::from_array(*center_b));
                let len = (b - a).norm();
                if !(len > 2.0 * radius) {
                    return Err(e("the balls overlap (centre distance ≤ 2·radius)".into()));
                }
                let mut v = vec![
                    mk(0, first_id, Prim::Sphere { c: a, r: *radius }),
                    mk(1, first_id + 1, Prim::Sphere { c: b, r: *radius }),
                ];
                if *bar_radius != 0.0 {
                    positive(*bar_radius, "bar radius").map_err(e)?;
                    if *bar_radius >= *radius {
                        return Err(e("bar radius must be below the ball radius".into()));
                    }
                    let w = (b - a) * (1.0 / len);
                    v.push(mk(
                        2,
                        first_id + 2,
                        Prim::Cylinder {
                            c0: a,
                            w,
                            r: *bar_radius,
                            len,
                            caps: false,
                        },
                    ));
                }
                v
            }
            Shape::HeightField {
                center,
                euler_deg,
                size,
                base,
                bumps,
            } => {
                finite(center, "height field centre").map_err(e)?;
                finite(euler_deg, "height field euler_deg").map_err(e)?;
                positive(size[0], "height field width").map_err(e)?;
                positive(size[1], "height field height").map_err(e)?;
                finite(&[*base], "height field base").map_err(e)?;
                for b in bumps {
                    finite(b, "bump").map_err(e)?;
                    positive(b[3], "bump sigma").map_err(e)?;
                }
                let hf = HeightField::new(
                    Vec3::from_array(*center),
                    Mat3::from_euler_deg(*euler_deg),
                    *size,
                    *base,
                    bumps,
                );
                vec![mk(0, first_id, Prim::Height(Box::new(hf)))]
            }
        };
        Ok(prims)
    }
}

/// Solve `a t² + 2 b t + c = 0` stably; roots ascending.
#[inline]
fn quadratic(a: f64, b: f64, c: f64) -> Option<(f64, f64)> {
    let disc = b * b - a * c;
    if !(disc >= 0.0) || a == 0.0 {
        return None;
    }
    let q = -(b + b.signum() * disc.sqrt());
    if q == 0.0 {
        return Some((0.0, 0.0));
    }
    let (t1, t2) = (q / a, c / q);
    Some(if t1 < t2 { (t1, t2) } else { (t2, t1) })
}

impl Primitive {
    /// The nearest intersection with `t ∈ (t_min, t_max)`: (t, outward normal, class).
    pub(crate) fn intersect(
        &self,
        o: Vec3,
        d: Vec3,
        t_min: f64,
        t_max: f64,
    ) -> Option<(f64, Vec3, u32)> {
        let inside = |t: f64| t > t_min && t < t_max;
        match &self.prim {
            Prim::Plane { p, n, u, v, half } => {
                let den = d.dot(*n);
                if den == 0.0 {
                    return None;
                }
                let t = (*p - o).dot(*n) / den;
                if !inside(t) {
                    return None;
                }
                if let Some((hw, hh)) = half {
                    let q = o + d * t - *p;
                    if q.dot(*u).abs() > *hw || q.dot(*v).abs() > *hh {
                        return None;
                    }
                }
                Some((t, *n, 0))
            }
            Prim::Sphere { c, r } => {
                let oc = o - *c;
                let (a, b, cc) = (d.dot(d), oc.dot(d), oc.dot(oc) - r * r);
                let (t1, t2) = quadratic(a, b, cc)?;
                let t0 = if inside(t1) {
                    t1
                } else if inside(t2) {
                    t2
                } else {
                    return None;
                };
                // One Newton step on |o + t d − c|² − r².
                let q = oc + d * t0;
                let t = t0 - (q.dot(q) - r * r) / (2.0 * d.dot(q));
                let t = if (t - t0).abs() < 1e-6 * (1.0 + t0.abs()) {
                    t
                } else {
                    t0
                };
                let nrm = (o + d * t - *c) * (1.0 / r);
                Some((t, nrm, 0))
            }
            Prim::Cylinder {
                c0,
                w,
                r,
                len,
                caps,
            } => {
                let mut best: Option<(f64, Vec3, u32)> = None;
                let oc = o - *c0;
                let dp = d - *w * d.dot(*w);
                let op = oc - *w * oc.dot(*w);
                if let Some((t1, t2)) = quadratic(dp.dot(dp), op.dot(dp), op.dot(op) - r * r) {
                    for t0 in [t1, t2] {
                        if !inside(t0) {
                            continue;
                        }
                        let q = op + dp * t0;
                        let t = t0 - (q.dot(q) - r * r) / (2.0 * dp.dot(q));
                        let t = if (t - t0).abs() < 1e-6 * (1.0 + t0.abs()) {
                            t
                        } else {
                            t0
                        };
                        let s = (oc + d * t).dot(*w);
                        if (0.0..=*len).contains(&s) {
                            let q = op + dp * t;
                            best = Some((t, q * (1.0 / r), 0));
                            break;
                        }
                    }
                }
                if *caps {
                    let den = d.dot(*w);
                    if den != 0.0 {
                        for (k, s) in [(1u32, 0.0), (2u32, *len)] {
                            let t = (s - oc.dot(*w)) / den;
                            if inside(t) && best.is_none_or(|b| t < b.0) {
                                let q = oc + d * t - *w * s;
                                if q.dot(q) <= r * r {
                                    let nrm = if k == 1 { -*w } else { *w };
                                    best = Some((t, nrm, k));
                                }
                            }
                        }
                    }
                }
                best
            }
            Prim::Box { c, rot, half } => {
                let ol = rot.tmul_vec(o - *c);
                let dl = rot.tmul_vec(d);
                let (oa, da, ha) = (ol.to_array(), dl.to_array(), half.to_array());
                let (mut t_in, mut t_out) = (f64::NEG_INFINITY, f64::INFINITY);
                let (mut ax_in, mut ax_out) = (0usize, 0usize);
                for i in 0..3 {
                    if da[i] == 0.0 {
                        if oa[i].abs() > ha[i] {
                            return None;
                        }
                        continue;
                    }
                    let (mut ta, mut tb) = ((-ha[i] - oa[i]) / da[i], (ha[i] - oa[i]) / da[i]);
                    if ta > tb {
                        std::mem::swap(&mut ta, &mut tb);
                    }
                    if ta > t_in {
                        t_in = ta;
                        ax_in = i;
                    }
                    if tb < t_out {
                        t_out = tb;
                        ax_out = i;
                    }
                }
                if t_in > t_out {
                    return None;
                }
                let (t, ax, enter) = if inside(t_in) {
                    (t_in, ax_in, true)
                } else if inside(t_out) {
                    (t_out, ax_out, false)
                } else {
                    return None;
                };
                let mut nl = [0.0; 3];
                // Entering through a face: normal opposes the ray; leaving: along it.
                nl[ax] = if enter {
                    -da[ax].signum()
                } else {
                    da[ax].signum()
                };
                let face = (ax as u32) * 2 + u32::from(nl[ax] > 0.0);
                Some((t, rot.mul_vec(Vec3::from_array(nl)), face))
            }
            Prim::Height(h) => h.intersect(o, d, t_min, t_max).map(|(t, n)| (t, n, 0)),
        }
    }

    /// Albedo and texture class at a point of this primitive.
    fn material(&self, p: Vec3) -> (f64, u32) {
        match (&self.texture, &self.prim) {
            (
                Some(Texture::Checker {
                    square,
                    cols,
                    rows,
                    dark,
                    light,
                }),
                Prim::Plane { p: p0, u, v, .. },
            ) => {
                let q = p - *p0;
                let (x, y) = (q.dot(*u), q.dot(*v));
                let w = *cols as f64 * square;
                let h = *rows as f64 * square;
                let (fx, fy) = ((x + 0.5 * w) / square, (y + 0.5 * h) / square);
                if fx < 0.0 || fy < 0.0 || fx >= *cols as f64 || fy >= *rows as f64 {
                    return (self.albedo, 0);
                }
                let parity = (fx.floor() as i64 + fy.floor() as i64) & 1;
                if parity == 0 { (*dark, 1) } else { (*light, 2) }
            }
            _ => (self.albedo, 0),
        }
    }
}

/// The objects of a scene, ready for ray casting.
#[derive(Clone, Debug, Default)]
pub struct Geometry {
    /// The primitives; `Hit::prim` indexes this.
    pub prims: Vec<Primitive>,
}

/// Smallest ray parameter accepted for secondary (shadow) rays starting on a surface, mm along a
/// unit direction.
pub const SHADOW_EPS: f64 = 1e-5;

impl Geometry {
    /// Build from object specs; ids are assigned consecutively from 1 (a ball bar takes 2 or 3).
    pub fn build(objects: &[ObjectSpec]) -> Result<Geometry, String> {
        let mut prims = Vec::new();
        let mut next: u32 = 1;
        for (i, o) in objects.iter().enumerate() {
            if next > u16::MAX as u32 - 3 {
                return Err("too many objects (ids must fit 16 bits)".into());
            }
            let p = o.primitives(i, next as u16)?;
            next += p.len() as u32;
            prims.extend(p);
        }
        Ok(Geometry { prims })
    }

    /// The nearest hit of the ray `o + t·d`, `t ∈ (t_min, t_max)`.
    pub fn trace(&self, o: Vec3, d: Vec3, t_min: f64, t_max: f64) -> Option<Hit> {
        let mut best: Option<(f64, Vec3, u32, usize)> = None;
        let mut limit = t_max;
        for (i, p) in self.prims.iter().enumerate() {
            if let Some((t, n, c)) = p.intersect(o, d, t_min, limit) {
                limit = t;
                best = Some((t, n, c, i));
            }
        }
        let (t, n, face, i) = best?;
        let point = o + d * t;
        let n = if n.dot(d) > 0.0 { -n } else { n };
        let (albedo, tex) = self.prims[i].material(point);
        let class = ((i as u32 + 1) << 8) | (face << 2) | tex;
        Some(Hit {
            t,
            point,
            normal: n,
            prim: i,
            albedo,
            specular: self.prims[i].specular,
            class,
        })
    }

    /// `true` if anything lies on the ray `o + t·d`, `t ∈ (t_min, t_max)`.
    pub fn occluded(&self, o: Vec3, d: Vec3, t_min: f64, t_max: f64) -> bool {
        self.prims
            .iter()
            .any(|p| p.intersect(o, d, t_min, t_max).is_some())
    }
}
