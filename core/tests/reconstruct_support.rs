//! Test support for the camera and reconstruction tests (included with `#[path]`; compiled on its
//! own it has no tests). Everything here is an independent f64 implementation: a pinhole camera
//! with Brown distortion (eqs 1-4) whose inverse uses a different algorithm from the core's
//! (fixed-point iteration, then Newton with a numerical Jacobian), a posed pinhole projector with a
//! linear phase Φ = c·(ξ − ξ_c), analytic surfaces, and ray casting.
#![allow(dead_code)]
// std f64 maths is the independent truth in tests.
#![allow(clippy::disallowed_methods)]

use fringe3d_core::Validity;

pub type V3 = [f64; 3];

pub fn add(a: V3, b: V3) -> V3 {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}
pub fn sub(a: V3, b: V3) -> V3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
pub fn mul(a: V3, s: f64) -> V3 {
    [a[0] * s, a[1] * s, a[2] * s]
}
pub fn dot(a: V3, b: V3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
pub fn cross(a: V3, b: V3) -> V3 {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}
pub fn norm(a: V3) -> f64 {
    dot(a, a).sqrt()
}
pub fn unit(a: V3) -> V3 {
    mul(a, 1.0 / norm(a))
}

/// SplitMix64.
pub struct Rng(pub u64);
impl Rng {
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    pub fn uniform(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// A pinhole with Brown distortion `[k1, k2, p1, p2, k3]` and the paper's skew α (eq 4).
#[derive(Clone, Copy, Debug)]
pub struct Pinhole {
    pub fx: f64,
    pub fy: f64,
    pub skew: f64,
    pub u0: f64,
    pub v0: f64,
    pub width: u32,
    pub height: u32,
    pub k: [f64; 5],
}

impl Pinhole {
    /// Eq 3 (written out term by term as in the paper, with k3↔p1, k4↔p2, k5↔k3).
    pub fn distort(&self, x: f64, y: f64) -> (f64, f64) {
        let [k1, k2, p1, p2, k3] = self.k;
        let r2 = x * x + y * y;
        let radial = 1.0 + k1 * r2 + k2 * r2 * r2 + k3 * r2 * r2 * r2;
        let xd = radial * x + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x);
        let yd = radial * y + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y;
        (xd, yd)
    }

    /// Eq 4.
    pub fn pixel_of_distorted(&self, xd: f64, yd: f64) -> (f64, f64) {
        (
            self.fx * xd + self.skew * self.fx * yd + self.u0,
            self.fy * yd + self.v0,
        )
    }

    /// Eqs 2-4 for a point in this device's frame (z forward).
    pub fn project(&self, p: V3) -> Option<(f64, f64)> {
        if p[2] <= 0.0 {
            return None;
        }
        let (xd, yd) = self.distort(p[0] / p[2], p[1] / p[2]);
        Some(self.pixel_of_distorted(xd, yd))
    }

    /// Inverse of eqs 3-4: fixed-point iteration `x = (x_d − tangential(x)) / radial(x)` (60
    /// times) polished by Newton steps with a central-difference Jacobian.
    pub fn unproject(&self, u: f64, v: f64) -> (f64, f64) {
        let yd = (v - self.v0) / self.fy;
        let xd = (u - self.u0 - self.skew * self.fx * yd) / self.fx;
        let [k1, k2, p1, p2, k3] = self.k;
        let (mut x, mut y) = (xd, yd);
        for _ in 0..60 {
            let r2 = x * x + y * y;
            let radial = 1.0 + k1 * r2 + k2 * r2 * r2 + k3 * r2 * r2 * r2;
            let tx = 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x);
            let ty = p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y;
            x = (xd - tx) / radial;
            y = (yd - ty) / radial;
        }
        for _ in 0..3 {
            let h = 1e-6;
            let (fx0, fy0) = self.distort(x, y);
            let (ax, ay) = self.distort(x + h, y);
            let (bx, by) = self.distort(x - h, y);
            let (cx, cy) = self.distort(x, y + h);
            let (dx, dy) = self.distort(x, y - h);
            let j00 = (ax - bx) / (2.0 * h);
            let j10 = (ay - by) / (2.0 * h);
            let j01 = (cx - dx) / (2.0 * h);
            let j11 = (cy - dy) / (2.0 * h);
            let rx = fx0 - xd;
            let ry = fy0 - yd;
            let det = j00 * j11 - j01 * j10;
            x -= (j11 * rx - j01 * ry) / det;
            y -= (j00 * ry - j10 * rx) / det;
        }
        (x, y)
    }

    pub fn params(&self) -> fringe3d_core::params::CameraParams {
        fringe3d_core::params::CameraParams {
            width: self.width,
            height: self.height,
            fx: self.fx,
            fy: self.fy,
            cx: self.u0,
            cy: self.v0,
            skew: self.skew,
            distortion: fringe3d_core::params::Distortion::from_array(self.k),
        }
    }

    pub fn model(&self) -> fringe3d_core::camera::CameraModel {
        fringe3d_core::camera::CameraModel::new(self.params()).expect("camera model")
    }
}

/// Camera + posed projector with a linear phase along ξ (or η).
#[derive(Clone, Copy, Debug)]
pub struct Rig {
    pub cam: Pinhole,
    pub proj: Pinhole,
    /// Projector → camera rotation (columns: projector axes in the camera frame).
    pub rot: [[f64; 3]; 3],
    /// Projector centre P in the camera frame.
    pub p: V3,
    /// Phase per projector pixel.
    pub c: f64,
    /// Projector coordinate of zero phase.
    pub s_c: f64,
    /// Phase along η instead of ξ.
    pub eta: bool,
    /// Reference plane point and normal.
    pub ref_point: V3,
    pub ref_normal: V3,
    pub z_range: [f64; 2],
}

/// Rotation whose z column points from `from` to `to`, x column ⟂ camera y.
pub fn look_at(from: V3, to: V3) -> [[f64; 3]; 3] {
    let z = unit(sub(to, from));
    let x = unit(cross([0.0, 1.0, 0.0], z));
    let y = cross(z, x);
    [[x[0], y[0], z[0]], [x[1], y[1], z[1]], [x[2], y[2], z[2]]]
}

impl Rig {
    /// The test rig: camera 1280 × 1024, f = 1500 px, moderate distortion and a little skew;
    /// projector 1024 × 768 at P = (200, −10, 5) mm aimed at (0, 0, 700); 16-pixel fringes;
    /// reference plane through (0, 0, 700) slightly tilted; depth range [575, 825] mm (the
    /// 280 × 220 × 250 mm volume).
    pub fn default_rig() -> Rig {
        let cam = Pinhole {
            fx: 1500.0,
            fy: 1500.8,
            skew: 2e-4,
            u0: 641.3,
            v0: 509.7,
            width: 1280,
            height: 1024,
            k: [-0.12, 0.08, 3e-4, -2e-4, 0.0],
        };
        let proj = Pinhole {
            fx: 1300.0,
            fy: 1300.0,
            skew: 0.0,
            u0: 511.5,
            v0: 383.5,
            width: 1024,
            height: 768,
            k: [0.0; 5],
        };
        let p = [200.0, -10.0, 5.0];
        Rig {
            cam,
            proj,
            rot: look_at(p, [0.0, 0.0, 700.0]),
            p,
            c: std::f64::consts::TAU / 16.0,
            s_c: 511.5,
            eta: false,
            ref_point: [0.0, 0.0, 700.0],
            ref_normal: unit([0.02, -0.03, -1.0]),
            z_range: [575.0, 825.0],
        }
    }

    pub fn projector_frame(&self, x: V3) -> V3 {
        let d = sub(x, self.p);
        let r = &self.rot;
        [
            r[0][0] * d[0] + r[1][0] * d[1] + r[2][0] * d[2],
            r[0][1] * d[0] + r[1][1] * d[1] + r[2][1] * d[2],
            r[0][2] * d[0] + r[1][2] * d[1] + r[2][2] * d[2],
        ]
    }

    /// The phase the projector casts on camera-frame point `x`, if it lights it.
    pub fn phase_at(&self, x: V3) -> Option<f64> {
        let (xi, eta) = self.proj.project(self.projector_frame(x))?;
        let (w, h) = ((self.proj.width - 1) as f64, (self.proj.height - 1) as f64);
        if !(xi >= 0.0 && xi <= w && eta >= 0.0 && eta <= h) {
            return None;
        }
        Some(if self.eta {
            self.c * (eta - self.s_c)
        } else {
            self.c * (xi - self.s_c)
        })
    }

    /// Camera ray of pixel `(u, v)`: `(x_n, y_n, 1)`.
    pub fn ray(&self, u: f64, v: f64) -> V3 {
        let (x, y) = self.cam.unproject(u, v);
        [x, y, 1.0]
    }

    pub fn setup(&self) -> fringe3d_core::reconstruct::Setup {
        use fringe3d_core::geometry::Vec3;
        fringe3d_core::reconstruct::Setup {
            projector_centre: Vec3::from_array(self.p),
            reference_point: Vec3::from_array(self.ref_point),
            reference_normal: Vec3::from_array(self.ref_normal),
            axis: if self.eta {
                fringe3d_core::phase_function::Axis::Eta
            } else {
                fringe3d_core::phase_function::Axis::Xi
            },
            z_min: self.z_range[0],
            z_max: self.z_range[1],
        }
    }
}

/// Analytic surfaces.
#[derive(Clone, Copy, Debug)]
pub enum Surface {
    Plane { p: V3, n: V3 },
    Sphere { c: V3, r: f64 },
}

impl Surface {
    /// Ray parameter of the nearest hit of `o + λ·d`, λ > 0.
    pub fn hit(&self, o: V3, d: V3) -> Option<f64> {
        match *self {
            Surface::Plane { p, n } => {
                let den = dot(n, d);
                if den.abs() < 1e-15 {
                    return None;
                }
                let l = dot(n, sub(p, o)) / den;
                (l > 0.0).then_some(l)
            }
            Surface::Sphere { c, r } => {
                let oc = sub(o, c);
                let a = dot(d, d);
                let b = dot(oc, d);
                let cc = dot(oc, oc) - r * r;
                let disc = b * b - a * cc;
                if disc < 0.0 {
                    return None;
                }
                let l = (-b - disc.sqrt()) / a;
                (l > 0.0).then_some(l)
            }
        }
    }
}

/// Axis-aligned box limiting where surfaces count.
#[derive(Clone, Copy, Debug)]
pub struct Bounds {
    pub min: V3,
    pub max: V3,
}

impl Bounds {
    pub const EVERYWHERE: Bounds = Bounds {
        min: [-1e9; 3],
        max: [1e9; 3],
    };
    pub fn contains(&self, x: V3) -> bool {
        (0..3).all(|i| x[i] >= self.min[i] && x[i] <= self.max[i])
    }
}

/// A rendered phase map: f32 phase (canonical NaN where invalid), validity, and the true point of
/// every valid pixel.
#[derive(Clone)]
pub struct PhaseMap {
    pub width: usize,
    pub height: usize,
    pub phase: Vec<f32>,
    pub validity: Vec<u8>,
    pub truth: Vec<Option<V3>>,
}

/// Ray-cast `rows` of the camera image against `surfaces` (nearest hit inside `bounds`); other rows
/// are left invalid (Dark).
pub fn render(
    rig: &Rig,
    surfaces: &[Surface],
    bounds: Bounds,
    rows: impl Iterator<Item = usize>,
) -> PhaseMap {
    let w = rig.cam.width as usize;
    let h = rig.cam.height as usize;
    let mut m = PhaseMap {
        width: w,
        height: h,
        phase: vec![f32::from_bits(0x7fc0_0000); w * h],
        validity: vec![Validity::Dark as u8; w * h],
        truth: vec![None; w * h],
    };
    for v in rows {
        for u in 0..w {
            let d = rig.ray(u as f64, v as f64);
            let mut best: Option<f64> = None;
            for s in surfaces {
                if let Some(l) = s.hit([0.0; 3], d) {
                    let x = mul(d, l);
                    if bounds.contains(x) && best.is_none_or(|b| l < b) {
                        best = Some(l);
                    }
                }
            }
            let Some(l) = best else { continue };
            let x = mul(d, l);
            if let Some(ph) = rig.phase_at(x) {
                let i = v * w + u;
                m.phase[i] = ph as f32;
                m.validity[i] = Validity::Valid as u8;
                m.truth[i] = Some(x);
            }
        }
    }
    m
}

/// The reference phase map of `rig` (all rows).
pub fn render_reference(rig: &Rig) -> PhaseMap {
    let s = Surface::Plane {
        p: rig.ref_point,
        n: rig.ref_normal,
    };
    render(rig, &[s], Bounds::EVERYWHERE, 0..rig.cam.height as usize)
}

/// The measurement volume of the default rig.
pub fn volume(rig: &Rig) -> Bounds {
    Bounds {
        min: [-140.0, -110.0, rig.z_range[0]],
        max: [140.0, 110.0, rig.z_range[1]],
    }
}

/// The test object: a plane tilted through the whole depth range and a sphere in front of it.
pub fn object(rig: &Rig) -> Vec<Surface> {
    let _ = rig;
    vec![
        Surface::Sphere {
            c: [-35.0, 25.0, 640.0],
            r: 55.0,
        },
        // z = 700 + 0.55·x + 0.3·y: spans ≈ 590 … 810 mm over the volume.
        Surface::Plane {
            p: [0.0, 0.0, 700.0],
            n: unit([0.55, 0.3, -1.0]),
        },
    ]
}

/// Summary of errors.
#[derive(Debug, Default, Clone, Copy)]
pub struct Stats {
    pub n: usize,
    pub rms: f64,
    pub max: f64,
}

pub fn stats(errs: &[f64]) -> Stats {
    let n = errs.len();
    if n == 0 {
        return Stats::default();
    }
    let rms = (errs.iter().map(|e| e * e).sum::<f64>() / n as f64).sqrt();
    let max = errs.iter().cloned().fold(0.0, f64::max);
    Stats { n, rms, max }
}

impl Pinhole {
    /// Pixel of ideal normalized coordinates.
    pub fn pixel_of_normalized(&self, x: f64, y: f64) -> (f64, f64) {
        let (xd, yd) = self.distort(x, y);
        self.pixel_of_distorted(xd, yd)
    }
}

/// Add seeded Gaussian phase noise of `sigma` radians to the finite phases of `maps`, in order
/// (Box-Muller on [`Rng`]).
pub fn add_phase_noise(maps: [&mut PhaseMap; 2], sigma: f64, seed: u64) {
    let mut rng = Rng(seed);
    let mut gauss = || {
        let (a, b) = (rng.uniform().max(1e-300), rng.uniform());
        (-2.0 * a.ln()).sqrt() * (std::f64::consts::TAU * b).cos()
    };
    for m in maps {
        for p in m.phase.iter_mut() {
            if p.is_finite() {
                *p = (*p as f64 + sigma * gauss()) as f32;
            }
        }
    }
}

/// The reconstruction benchmark's scene (`benches/reconstruct.rs`, `tests/reconstruct_timing.rs`):
/// the default rig's reference map, and a plane tilted through most of the depth range with a
/// sphere in front of it, over the whole image; with `noise > 0`, that much phase noise (radians,
/// seeded) on both maps.
pub fn bench_scene(noise: f64) -> (Rig, PhaseMap, PhaseMap) {
    let rig = Rig::default_rig();
    let mut reference = render_reference(&rig);
    let (surfaces, bounds) = bench_surfaces(&rig);
    let mut object = render(&rig, &surfaces, bounds, 0..rig.cam.height as usize);
    if noise > 0.0 {
        add_phase_noise([&mut reference, &mut object], noise, 0x5eed_0004);
    }
    (rig, reference, object)
}

/// The benchmark scene's object ([`bench_scene`]): a plane tilted through most of the depth
/// range and a sphere in front of it, within the rig's depth range.
pub fn bench_surfaces(rig: &Rig) -> (Vec<Surface>, Bounds) {
    let surfaces = vec![
        Surface::Sphere {
            c: [-35.0, 25.0, 640.0],
            r: 55.0,
        },
        Surface::Plane {
            p: [0.0, 0.0, 700.0],
            n: unit([0.25, 0.15, -1.0]),
        },
    ];
    (
        surfaces,
        Bounds {
            min: [-1e9, -1e9, rig.z_range[0]],
            max: [1e9, 1e9, rig.z_range[1]],
        },
    )
}
