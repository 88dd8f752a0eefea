//! The ray tracer: camera rays, nearest hits, projector light, shadows, supersampling, camera
//! blur, noise, quantization — and the per-pixel ground truth.
//!
//! # Image formation
//! For a camera sample whose ray hits the surface at X (albedo ρ, unit normal n towards the
//! camera), with P the projector centre:
//!
//! ```text
//! E = ρ·ambient + lit·[ρ·cos θ + k_s·(n·h)^m]·(d_ref/|P − X|)²·L(ξ, η)   (relative radiance)
//! cos θ = n·(P − X)/|P − X|,  lit = cos θ > 0 ∧ the segment X→P is free ∧ X projects onto the DMD
//! h = (l + v)/|l + v|,  l = (P − X)/|P − X|,  v = −X/|X|   (Blinn-Phong half vector)
//! ```
//!
//! The specular lobe (strength k_s, exponent m; objects with `specular`) reflects the light of
//! the projector pixel that lights X, so it carries the same fringe phase: a highlight adds
//! light, up to clipping, not a phase error.
//!
//! (the `(d_ref/|P − X|)²` falloff can be switched off). The pixel value is the mean of `E` over
//! `n × n` sample positions `((i + ½)/n − ½, (j + ½)/n − ½)` around the pixel centre (a box pixel),
//! refined to `n_e × n_e` samples where the samples of the pixel or of its 8 neighbours disagree
//! about object, face, texture cell, shadow or DMD frame (edges). Then: `gain·E` (the gain given, or automatic — metering the diffuse light under full white, so a highlight clips as it does for a camera exposed for the part — times the relative exposure), optional
//! Gaussian camera blur (σ in camera pixels, edges replicated), plus Gaussian noise (σ in gray
//! levels, one seeded stream per image row), clipped to `[0, 2^bits − 1]` and rounded to the
//! nearest code.
//!
//! # Ground truth
//! Per pixel, from the ray through the pixel *centre*: the hit point (camera frame, mm), the exact
//! continuous projector coordinate (ξ, η) of that point (forward projector model), object id, and a
//! mask of [`MASK_HIT`], [`MASK_IN_FRAME`], [`MASK_LIT`], [`MASK_CLEAN`].

use super::camera::LensModel;
use super::light::LightSet;
use super::math::Vec3;
use super::objects::{Geometry, SHADOW_EPS};
use super::rig::Rig;
use super::rng::{Rng, derive};
use rayon::prelude::*;

/// Mask bit: the pixel-centre ray hits an object.
pub const MASK_HIT: u8 = 1;
/// Mask bit: the hit point projects onto the DMD (inside the projector frame).
pub const MASK_IN_FRAME: u8 = 2;
/// Mask bit: the hit point faces the projector and is not shadowed.
pub const MASK_LIT: u8 = 4;
/// Mask bit: every base sample of the pixel and of its 8 neighbours is on the same object face
/// and texture cell, equally lit and on the DMD, and the centre is at least `3σ + 2` projector
/// pixels inside the DMD frame: the pixel's value is free of edge effects.
pub const MASK_CLEAN: u8 = 8;
/// All mask bits: a pixel whose phase is meaningful and unbiased by edges.
pub const MASK_VALID: u8 = MASK_HIT | MASK_IN_FRAME | MASK_LIT | MASK_CLEAN;

/// Camera sensor settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sensor {
    /// Bits per sample: 8, 12 or 16.
    pub bits: u8,
    /// Gaussian read noise σ, gray levels (0 = none).
    pub noise: f64,
    /// Gaussian camera blur σ, camera pixels (0 = none).
    pub blur: f64,
    /// Supersampling: n × n samples per pixel.
    pub supersample: u32,
    /// Supersampling at edges (≥ `supersample`; equal = no refinement).
    pub edge_supersample: u32,
}

/// Light levels and exposure.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Photometry {
    /// Ambient irradiance relative to the projector's full white at `reference_distance`,
    /// facing it.
    pub ambient: f64,
    /// Gray levels per unit relative radiance; `None` = automatic (see `auto_level`).
    pub gain: Option<f64>,
    /// Automatic exposure puts the brightest pixel under full white at this fraction of full
    /// scale (measured on a sparse grid of pixel centres).
    pub auto_level: f64,
    /// Apply the inverse-square falloff from the projector.
    pub falloff: bool,
    /// Distance (mm) at which the falloff factor is 1.
    pub reference_distance: f64,
    /// Automatic exposure assumes the projector shows full white (`true`: the gain then depends
    /// on the geometry only, so renders of different slides get the same gain) or shows nothing
    /// (`false`: ambient light only, for images without projector light).
    pub auto_with_projector: bool,
    /// The exposure, relative: the gain (given or automatic) is multiplied by it (an HDR series
    /// renders the same scene at several; 1 = as set).
    pub exposure: f64,
}

/// Everything one render needs.
pub struct Job<'a> {
    /// Camera, projector, pose.
    pub rig: &'a Rig,
    /// The objects.
    pub geometry: &'a Geometry,
    /// What the projector shows (one output image per slide).
    pub lights: &'a LightSet,
    /// Sensor settings.
    pub sensor: Sensor,
    /// Photometry.
    pub photometry: Photometry,
    /// Seed of the camera noise.
    pub seed: u64,
    /// Distinguishes the noise streams of several renders made with one seed (e.g. the scene and
    /// its reference plane).
    pub stream: u64,
    /// Keep the unquantized images (before blur, noise and quantization).
    pub keep_float: bool,
    /// Called with the number of rows just finished (from worker threads).
    pub progress: Option<&'a (dyn Fn(u64) + Sync)>,
}

/// Rendered images.
#[derive(Clone, Debug)]
pub struct Frames {
    /// Width, pixels.
    pub width: u32,
    /// Height, pixels.
    pub height: u32,
    /// Bits per sample.
    pub bits: u8,
    /// One image per slide, row-major codes.
    pub images: Vec<Vec<u16>>,
    /// The gain used, gray levels per unit relative radiance.
    pub gain: f64,
    /// `gain·E` per slide before camera blur, noise and quantization (if asked for).
    pub float: Option<Vec<Vec<f64>>>,
}

/// Per-pixel ground truth, row-major.
#[derive(Clone, Debug)]
pub struct Truth {
    /// Width, pixels.
    pub width: u32,
    /// Height, pixels.
    pub height: u32,
    /// Hit point of the pixel-centre ray, camera frame, mm (NaN: no hit).
    pub points: Vec<[f64; 3]>,
    /// Unit surface normal there, towards the camera (NaN: no hit).
    pub normals: Vec<[f64; 3]>,
    /// Exact projector coordinates (ξ, η) of the hit point (NaN: no hit or not projectable).
    pub projector: Vec<[f64; 2]>,
    /// Mask bits ([`MASK_HIT`] …).
    pub mask: Vec<u8>,
    /// Object id (0: nothing).
    pub object_id: Vec<u16>,
}

impl Truth {
    /// The absolute phase `f(ξ, η)` per pixel (e.g. `|ξ, η| set.finest_phase(ξ, η)`), NaN where
    /// the pixel has no projector coordinate.
    pub fn map_projector(&self, f: impl Fn(f64, f64) -> f64 + Sync) -> Vec<f64> {
        self.projector
            .par_iter()
            .map(|p| {
                if p[0].is_nan() {
                    f64::NAN
                } else {
                    f(p[0], p[1])
                }
            })
            .collect()
    }
}

/// Why a render failed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum EngineError {
    /// A setting is out of range.
    #[error("{0}")]
    Setting(String),
}

struct Shade {
    class: u32,
    lit: bool,
    in_frame: bool,
    /// ρ·ambient.
    base: f64,
    /// ρ·cos θ·falloff (multiplies L).
    direct: f64,
    /// The specular lobe's `k_s·(n·h)^m·falloff` (multiplies L; not metered by automatic
    /// exposure).
    glossy: f64,
    xi: f64,
    eta: f64,
}

struct Tracer<'a> {
    job: &'a Job<'a>,
    p: Vec3,
    cam_rmax: f64,
    proj_rmax: f64,
}

impl Tracer<'_> {
    /// Shade the camera ray with direction `dir` (from the camera centre).
    #[inline]
    fn shade(&self, dir: Vec3) -> Option<(Shade, super::objects::Hit)> {
        let g = self.job.geometry;
        let hit = g.trace(Vec3::ZERO, dir, 1e-9, f64::INFINITY)?;
        let ph = &self.job.photometry;
        let base = hit.albedo * ph.ambient;
        let mut s = Shade {
            class: hit.class,
            lit: false,
            in_frame: false,
            base,
            direct: 0.0,
            glossy: 0.0,
            xi: f64::NAN,
            eta: f64::NAN,
        };
        if let Some((xi, eta)) = self
            .job
            .rig
            .projector
            .project(self.job.rig.to_projector_frame(hit.point), self.proj_rmax)
        {
            s.xi = xi;
            s.eta = eta;
            s.in_frame = self.job.lights.in_frame(xi, eta);
            let to_p = self.p - hit.point;
            let dist = to_p.norm();
            let l = to_p * (1.0 / dist);
            let cos = hit.normal.dot(l);
            if cos > 0.0 && !g.occluded(hit.point, l, SHADOW_EPS, dist * (1.0 - 1e-9)) {
                s.lit = true;
                let fall = if ph.falloff {
                    let r = ph.reference_distance / dist;
                    r * r
                } else {
                    1.0
                };
                s.direct = hit.albedo * cos * fall;
                if let Some((ks, m)) = hit.specular {
                    // Blinn-Phong: the half vector of the light and view directions.
                    let view = -dir.normalized();
                    let half = (l + view).normalized();
                    let nh = hit.normal.dot(half).max(0.0);
                    s.glossy = ks * nh.powf(m) * fall;
                }
            }
        }
        s.class ^= (u32::from(s.lit) << 30) | (u32::from(s.in_frame) << 31);
        Some((s, hit))
    }
}

fn check(job: &Job<'_>) -> Result<(), EngineError> {
    let s = &job.sensor;
    let e = |m: String| Err(EngineError::Setting(m));
    if ![8u8, 12, 16].contains(&s.bits) {
        return e(format!("camera bits must be 8, 12 or 16, got {}", s.bits));
    }
    if !(s.noise.is_finite() && s.noise >= 0.0) {
        return e(format!(
            "noise must be a non-negative number of gray levels, got {}",
            s.noise
        ));
    }
    if !(s.blur.is_finite() && s.blur >= 0.0 && s.blur <= 50.0) {
        return e(format!(
            "camera blur must be in [0, 50] pixels, got {}",
            s.blur
        ));
    }
    if !(1..=32).contains(&s.supersample)
        || s.edge_supersample < s.supersample
        || s.edge_supersample > 64
    {
        return e(format!(
            "supersample must be 1..32 and edge_supersample in [supersample, 64], got {} and {}",
            s.supersample, s.edge_supersample
        ));
    }
    let p = &job.photometry;
    if !(p.ambient.is_finite() && p.ambient >= 0.0) {
        return e(format!("ambient must be >= 0, got {}", p.ambient));
    }
    if p.gain.is_some_and(|g| !(g.is_finite() && g > 0.0)) {
        return e("gain must be positive".into());
    }
    if !(p.auto_level > 0.0 && p.auto_level <= 1.0) {
        return e(format!(
            "auto_level must be in (0, 1], got {}",
            p.auto_level
        ));
    }
    if !(p.exposure.is_finite() && p.exposure > 0.0 && p.exposure <= 1e3) {
        return e(format!("exposure must be in (0, 1000], got {}", p.exposure));
    }
    if !(p.reference_distance.is_finite() && p.reference_distance > 0.0) {
        return e("reference_distance must be positive".into());
    }
    Ok(())
}

/// Render one image per slide of `job.lights`, with the ground truth.
pub fn render(job: &Job<'_>) -> Result<(Frames, Truth), EngineError> {
    check(job)?;
    job.rig.validate().map_err(EngineError::Setting)?;
    let cam = &job.rig.camera;
    let (w, h) = (cam.width as usize, cam.height as usize);
    let n_img = job.lights.len();
    let tr = Tracer {
        job,
        p: job.rig.projector_centre(),
        cam_rmax: cam.max_radius(),
        proj_rmax: job.rig.projector.max_radius(),
    };
    let full = ((1u32 << job.sensor.bits) - 1) as f64;
    let gain = job.photometry.exposure
        * match job.photometry.gain {
            Some(g) => g,
            None => auto_gain(&tr, full),
        };
    let n = job.sensor.supersample as usize;
    let ne = job.sensor.edge_supersample as usize;
    let offsets =
        |k: usize| -> Vec<f64> { (0..k).map(|i| (i as f64 + 0.5) / k as f64 - 0.5).collect() };
    let (off, off_e) = (offsets(n), offsets(ne));
    let sigma = job.lights.sigma();
    let clean_margin = 3.0 * sigma + 2.0;

    struct Row {
        vals: Vec<f64>,
        points: Vec<[f64; 3]>,
        normals: Vec<[f64; 3]>,
        proj: Vec<[f64; 2]>,
        mask: Vec<u8>,
        ids: Vec<u16>,
        /// Per pixel: the class shared by all base samples, or [`MIXED`].
        class: Vec<u64>,
        /// Per pixel: the pixel-centre ray's direction (x/z, y/z), to warm-start refinement.
        centre: Vec<Option<(f64, f64)>>,
    }
    const MIXED: u64 = u64::MAX;
    type Guess = Option<(f64, f64)>;
    let undistort = |u: f64, v: f64, guess: Option<(f64, f64)>| {
        cam.undistort_pixel(u, v, guess, tr.cam_rmax)
            .or_else(|| cam.undistort_pixel(u, v, None, tr.cam_rmax))
    };
    let add = |sh: &Option<(Shade, super::objects::Hit)>,
               acc: &mut [f64],
               tmp: &mut [f64]|
     -> Option<u32> {
        let (s, _) = sh.as_ref()?;
        if s.lit && s.in_frame {
            job.lights.eval(s.xi, s.eta, tmp);
            for (a, t) in acc.iter_mut().zip(tmp.iter()) {
                *a += s.base + (s.direct + s.glossy) * t;
            }
        } else {
            for a in acc.iter_mut() {
                *a += s.base;
            }
        }
        Some(s.class)
    };

    // Pass 1: n × n samples per pixel, the truth, and whether the pixel is uniform.
    let mut rows: Vec<Row> = (0..h)
        .into_par_iter()
        .map(|y| {
            let mut row = Row {
                vals: vec![0.0; n_img * w],
                points: vec![[f64::NAN; 3]; w],
                normals: vec![[f64::NAN; 3]; w],
                proj: vec![[f64::NAN; 2]; w],
                mask: vec![0; w],
                ids: vec![0; w],
                class: vec![MIXED; w],
                centre: vec![None; w],
            };
            let mut tmp = vec![0.0; n_img];
            let mut acc = vec![0.0; n_img];
            // Directions of the base samples, one sample row at a time, each warm-started by linear
            // extrapolation from the two previous samples of its row (uniform steps of 1/n px).
            let nn = n * n;
            let mut dirs: Vec<Option<Vec3>> = vec![None; w * nn];
            for (iy, &oy) in off.iter().enumerate() {
                let v = y as f64 + oy;
                let (mut p2, mut p1): (Guess, Guess) = (None, None);
                for x in 0..w {
                    for (ix, &ox) in off.iter().enumerate() {
                        let guess = match (p2, p1) {
                            (Some(a), Some(b)) => Some((2.0 * b.0 - a.0, 2.0 * b.1 - a.1)),
                            (_, b) => b,
                        };
                        let r = undistort(x as f64 + ox, v, guess);
                        p2 = p1;
                        p1 = r;
                        dirs[x * nn + iy * n + ix] = r.map(|(a, b)| Vec3::new(a, b, 1.0));
                    }
                }
            }
            // With odd n the middle sample is the pixel centre: its shading is the truth.
            let centre_idx = (n % 2 == 1).then_some((n / 2) * n + n / 2);
            for x in 0..w {
                acc.fill(0.0);
                let mut first = None;
                let mut same = true;
                let mut centre = None;
                for (k, d) in dirs[x * nn..(x + 1) * nn].iter().enumerate() {
                    let sh = d.and_then(|d| tr.shade(d));
                    let class = add(&sh, &mut acc, &mut tmp).map_or(MIXED - 1, u64::from);
                    match first {
                        None => first = Some(class),
                        Some(c) => same &= c == class,
                    }
                    if Some(k) == centre_idx {
                        centre = sh;
                    }
                }
                if centre_idx.is_none() {
                    centre = undistort(x as f64, y as f64, None)
                        .and_then(|(a, b)| tr.shade(Vec3::new(a, b, 1.0)));
                }
                for (i, a) in acc.iter().enumerate() {
                    row.vals[i * w + x] = *a / nn as f64 * gain;
                }
                row.class[x] = if same { first.unwrap_or(MIXED) } else { MIXED };
                // Truth from the pixel centre.
                let mut m = 0u8;
                if let Some((s, hit)) = centre {
                    m |= MASK_HIT;
                    row.points[x] = hit.point.to_array();
                    row.normals[x] = hit.normal.to_array();
                    row.ids[x] = job.geometry.prims[hit.prim].id;
                    row.centre[x] = Some((hit.point.x / hit.point.z, hit.point.y / hit.point.z));
                    if !s.xi.is_nan() {
                        row.proj[x] = [s.xi, s.eta];
                        if s.in_frame
                            && s.lit
                            && job.lights.frame_margin(s.xi, s.eta) >= clean_margin
                        {
                            // Candidate for CLEAN; confirmed in pass 2.
                            m |= MASK_CLEAN;
                        }
                    }
                    if s.in_frame {
                        m |= MASK_IN_FRAME;
                    }
                    if s.lit {
                        m |= MASK_LIT;
                    }
                }
                row.mask[x] = m;
            }
            if let Some(p) = job.progress {
                p(1);
            }
            row
        })
        .collect();

    // Pass 2: a pixel whose samples, or whose 8 neighbours' samples, are not all of one class
    // (object, face, texture cell, shadow, DMD frame) sits at an edge: resample it with
    // n_e × n_e samples. Looking at the neighbours catches edges that pass between a pixel's
    // outermost samples and its border. Only uniform pixels with uniform neighbours are CLEAN.
    let classes: Vec<u64> = rows.iter().flat_map(|r| r.class.iter().copied()).collect();
    let uniform = |x: usize, y: usize| -> bool {
        let c = classes[y * w + x];
        if c == MIXED {
            return false;
        }
        let (x0, x1, y0, y1) = (
            x.saturating_sub(1),
            (x + 1).min(w - 1),
            y.saturating_sub(1),
            (y + 1).min(h - 1),
        );
        (y0..=y1).all(|yy| (x0..=x1).all(|xx| classes[yy * w + xx] == c))
    };
    rows.par_iter_mut().enumerate().for_each(|(y, row)| {
        let mut tmp = vec![0.0; n_img];
        let mut acc = vec![0.0; n_img];
        for x in 0..w {
            let uni = uniform(x, y);
            if !uni {
                row.mask[x] &= !MASK_CLEAN;
            }
            if uni || ne <= n {
                continue;
            }
            acc.fill(0.0);
            let mut g = row.centre[x];
            for &oy in &off_e {
                for &ox in &off_e {
                    let r = undistort(x as f64 + ox, y as f64 + oy, g);
                    g = r.or(g);
                    let sh = r.and_then(|(a, b)| tr.shade(Vec3::new(a, b, 1.0)));
                    add(&sh, &mut acc, &mut tmp);
                }
            }
            let k = (ne * ne) as f64;
            for (i, a) in acc.iter().enumerate() {
                row.vals[i * w + x] = *a / k * gain;
            }
        }
    });

    // Assemble.
    let mut float: Vec<Vec<f64>> = (0..n_img).map(|_| vec![0.0; w * h]).collect();
    let mut truth = Truth {
        width: w as u32,
        height: h as u32,
        points: Vec::with_capacity(w * h),
        normals: Vec::with_capacity(w * h),
        projector: Vec::with_capacity(w * h),
        mask: Vec::with_capacity(w * h),
        object_id: Vec::with_capacity(w * h),
    };
    for (y, r) in rows.into_iter().enumerate() {
        for (i, img) in float.iter_mut().enumerate() {
            img[y * w..(y + 1) * w].copy_from_slice(&r.vals[i * w..(i + 1) * w]);
        }
        truth.points.extend(r.points);
        truth.normals.extend(r.normals);
        truth.projector.extend(r.proj);
        truth.mask.extend(r.mask);
        truth.object_id.extend(r.ids);
    }
    let kept = job.keep_float.then(|| float.clone());
    if job.sensor.blur > 0.0 {
        float
            .par_iter_mut()
            .for_each(|img| gaussian_blur(img, w, h, job.sensor.blur));
    }
    let noise = job.sensor.noise;
    let images: Vec<Vec<u16>> = float
        .par_iter()
        .enumerate()
        .map(|(i, img)| {
            let mut out = vec![0u16; w * h];
            out.par_chunks_mut(w)
                .zip(img.par_chunks(w))
                .enumerate()
                .for_each(|(y, (o, src))| {
                    let mut rng = (noise > 0.0)
                        .then(|| Rng::new(derive(&[job.seed, job.stream, i as u64, y as u64])));
                    for (o, &v) in o.iter_mut().zip(src) {
                        let v = match rng.as_mut() {
                            Some(r) => v + noise * r.gauss(),
                            None => v,
                        };
                        *o = v.clamp(0.0, full).round() as u16;
                    }
                });
            out
        })
        .collect();
    Ok((
        Frames {
            width: w as u32,
            height: h as u32,
            bits: job.sensor.bits,
            images,
            gain,
            float: kept,
        },
        truth,
    ))
}

/// Gain that puts the brightest pixel centre (of a grid of about 160 × 128) under full white at
/// `auto_level` of full scale.
fn auto_gain(tr: &Tracer<'_>, full: f64) -> f64 {
    let cam = &tr.job.rig.camera;
    let step = ((cam.width / 160).max(1)) as usize;
    let ys: Vec<u32> = (0..cam.height).step_by(step).collect();
    let max = ys
        .par_iter()
        .map(|&y| {
            let mut m: f64 = 0.0;
            for x in (0..cam.width).step_by(step) {
                if let Some(d) = cam.pixel_ray(x as f64, y as f64, tr.cam_rmax)
                    && let Some((s, _)) = tr.shade(d)
                {
                    let l = if s.lit && s.in_frame && tr.job.photometry.auto_with_projector {
                        1.0
                    } else {
                        0.0
                    };
                    m = m.max(s.base + s.direct * l);
                }
            }
            m
        })
        .reduce(|| 0.0, f64::max);
    let level = tr.job.photometry.auto_level * full;
    if max > 0.0 { level / max } else { level }
}

/// In-place separable Gaussian blur with replicated edges.
pub fn gaussian_blur(img: &mut [f64], w: usize, h: usize, sigma: f64) {
    let r = (4.0 * sigma).ceil() as isize;
    let k: Vec<f64> = (-r..=r)
        .map(|i| libm::exp(-0.5 * (i as f64 / sigma).powi(2)))
        .collect();
    let sum: f64 = k.iter().sum();
    let k: Vec<f64> = k.iter().map(|v| v / sum).collect();
    let mut tmp = vec![0.0; w * h];
    tmp.par_chunks_mut(w).enumerate().for_each(|(y, out)| {
        let src = &img[y * w..(y + 1) * w];
        for (x, o) in out.iter_mut().enumerate() {
            let mut a = 0.0;
            for (j, kv) in k.iter().enumerate() {
                let xx = (x as isize + j as isize - r).clamp(0, w as isize - 1) as usize;
                a += kv * src[xx];
            }
            *o = a;
        }
    });
    img.par_chunks_mut(w).enumerate().for_each(|(y, out)| {
        for (x, o) in out.iter_mut().enumerate() {
            let mut a = 0.0;
            for (j, kv) in k.iter().enumerate() {
                let yy = (y as isize + j as isize - r).clamp(0, h as isize - 1) as usize;
                a += kv * tmp[yy * w + x];
            }
            *o = a;
        }
    });
}
