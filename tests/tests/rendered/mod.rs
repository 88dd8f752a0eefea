//! The rendered-scan harness shared by the end-to-end tests (`crate::rendered`): render a scene,
//! write it as a dataset, scan it through the library path of `fringe3d scan`, and compare the
//! points with the renderer's truth; the per-pixel noise prediction the quality bars use.
// Each test file uses a part of it.
#![allow(dead_code)]
// `!(x <= t)` rejects NaN angles on purpose.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use fringe3d::accuracy::{self, Accuracy};
use fringe3d::cli::common;
use fringe3d::render::camera::LensModel;
use fringe3d::render::dataset::{DatasetOptions, write_dataset};
use fringe3d::render::scene::Overrides;
use fringe3d::render::{Scene, SceneSpec};
use fringe3d::scan::{PointCloud, ScanCalibration, filter_edges};
use std::path::{Path, PathBuf};

pub struct Tmp(pub PathBuf);
impl Tmp {
    pub fn new(name: &str) -> Tmp {
        let p = std::env::temp_dir().join(format!("fringe3d-e2e-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&p);
        Tmp(p)
    }
}
impl Drop for Tmp {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// Three blocks tilted by 15-25° at the near, middle and far end of the 280×220×250 mm volume
/// (z from 475 to 725 mm), on the default rig, with a background plane.
pub fn volume_scene(o: &Overrides) -> Scene {
    let blocks = r#"
[[objects]]
name = "near"
albedo = 0.8
[objects.shape]
type = "box"
center = [-85.0, 0.0, 505.0]
size = [75.0, 190.0, 20.0]
euler_deg = [15.0, -20.0, 0.0]
[[objects]]
name = "middle"
albedo = 0.8
[objects.shape]
type = "box"
center = [5.0, 0.0, 610.0]
size = [80.0, 200.0, 20.0]
euler_deg = [-10.0, 25.0, 0.0]
[[objects]]
name = "far"
albedo = 0.8
[objects.shape]
type = "box"
center = [110.0, 0.0, 700.0]
size = [90.0, 210.0, 20.0]
euler_deg = [20.0, 15.0, 0.0]
"#;
    scene_with_objects("volume", o, blocks)
}

/// A scene `name` on the default rig (the built-in object scenes' camera, projector, patterns
/// and reference, with `o`) holding `objects` (TOML `[[objects]]` tables).
pub fn scene_with_objects(name: &str, o: &Overrides, objects: &str) -> Scene {
    let base = Scene::builtin("sphere", o)
        .expect("builtin scene")
        .spec
        .to_toml()
        .expect("toml");
    let head = base
        .split("[[objects]]")
        .next()
        .expect("scene head")
        .replace("name = \"sphere\"", &format!("name = \"{name}\""));
    let spec = SceneSpec::parse(
        &format!("{head}{objects}"),
        Path::new(&format!("{name}.toml")),
    )
    .expect("scene parses");
    Scene::new(spec, None).expect("scene is valid")
}

pub struct Scanned {
    /// The points after the edge filter (as `fringe3d scan` writes them).
    pub cloud: PointCloud,
    /// The same before the edge filter.
    pub unfiltered: PointCloud,
    pub modulation: Vec<f32>,
    pub acc: Accuracy,
    pub dataset: PathBuf,
    pub set: fringe3d_core::pattern::PatternSet,
}

pub fn scan(scene: &Scene, dir: &Path) -> Scanned {
    scan_with(scene, dir, Reference::Raw)
}

/// The reference map a scan uses.
#[derive(Clone, Copy, PartialEq)]
pub enum Reference {
    /// The dataset's decoded capture of the plane.
    Raw,
    /// The smooth model fitted to that capture (`fringe3d calibrate reference` without `--raw`).
    Model,
    /// Computed from the calibration's full projector model on the same plane, no capture
    /// (`fringe3d calibrate reference --virtual`).
    Virtual,
}

pub fn scan_with(scene: &Scene, dir: &Path, reference: Reference) -> Scanned {
    let ds = dir.join("dataset");
    write_dataset(scene, &ds, DatasetOptions::default()).expect("render");
    scan_dataset(scene, ds, reference)
}

/// [`scan_with`] on the dataset `ds` of `scene`, already rendered (its `reference_phase.tif` the
/// decoded capture of the plane, which the model and virtual references replace).
pub fn scan_dataset(scene: &Scene, ds: PathBuf, reference: Reference) -> Scanned {
    if reference == Reference::Model {
        let path = ds.join("reference_phase.tif");
        let (w, h, raw) = fringe3d::calib::files::read_phase_map(&path).expect("reference map");
        let fit = fringe3d::calib::reference_fit::fit_reference(
            &scene.patterns,
            &raw,
            w as usize,
            h as usize,
        )
        .expect("reference model");
        eprintln!(
            "reference model: knots every {} px, residual {:.3e} rad, noise {:.3e} rad, structure {:.3e} rad, {} outliers",
            fit.spacing_px, fit.residual_rms_rad, fit.noise_rad, fit.structure_rad, fit.outliers
        );
        fringe3d::io::image::write_tiff_f32(&path, w, h, &fit.phase).expect("write the model");
    }
    if reference == Reference::Virtual {
        let c = fringe3d::io::calibration::Calibration::load(&ds.join("calibration.toml"))
            .expect("calibration");
        let r = c.reference.as_ref().expect("reference plane");
        let map = fringe3d::calib::virtual_reference::virtual_reference(
            &c.camera,
            c.projector
                .as_ref()
                .expect("the rendered calibration holds the projector"),
            &scene.patterns,
            (r.point, r.normal),
            fringe3d_core::reconstruct::Margin::ZERO,
        )
        .expect("virtual reference");
        let path = ds.join("reference_phase.tif");
        fringe3d::io::image::write_tiff_f32(&path, c.camera.width, c.camera.height, &map)
            .expect("write the virtual map");
    }
    let ls = common::load_set(&ds.join("patterns.toml")).expect("pattern set");
    let cal =
        ScanCalibration::load(&ds.join("calibration.toml"), ls.set.axis()).expect("calibration");
    let imgs = common::load_images(&ls, &[], true).expect("images");
    let d = common::decode(&ls.set, &imgs, common::decode_config(&imgs)).expect("decode");
    let mut cloud = cal
        .reconstruct(&d.phase, &d.validity, true)
        .expect("reconstruct");
    let unfiltered = cloud.clone();
    filter_edges(&mut cloud, &cal.edge_filter(80.0).expect("filter"));
    let truth = accuracy::load_truth(&ds).expect("truth");
    let acc = accuracy::evaluate(&cloud, &truth).expect("evaluate");
    Scanned {
        cloud,
        unfiltered,
        modulation: d.modulation,
        acc,
        dataset: ds,
        set: ls.set,
    }
}

/// Per-pixel truth and the angle between the surface normal and the viewing ray (degrees), the
/// normal from central differences of the true points (NaN near holes and borders).
pub fn truth_and_angles(ds: &Path, w: usize, h: usize) -> (Vec<f64>, Vec<f64>) {
    let p = fringe3d::io::npy::decode_f64(&std::fs::read(ds.join("truth/points.npy")).unwrap())
        .unwrap()
        .1;
    let at = |x: usize, y: usize| {
        [
            p[3 * (y * w + x)],
            p[3 * (y * w + x) + 1],
            p[3 * (y * w + x) + 2],
        ]
    };
    let mut ang = vec![f64::NAN; w * h];
    for y in 1..h - 1 {
        for x in 1..w - 1 {
            let (a, b, c, d, m) = (
                at(x + 1, y),
                at(x - 1, y),
                at(x, y + 1),
                at(x, y - 1),
                at(x, y),
            );
            let du = [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
            let dv = [c[0] - d[0], c[1] - d[1], c[2] - d[2]];
            let n = [
                du[1] * dv[2] - du[2] * dv[1],
                du[2] * dv[0] - du[0] * dv[2],
                du[0] * dv[1] - du[1] * dv[0],
            ];
            let (ln, lm) = (
                (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt(),
                (m[0] * m[0] + m[1] * m[1] + m[2] * m[2]).sqrt(),
            );
            let c = ((n[0] * m[0] + n[1] * m[1] + n[2] * m[2]) / (ln * lm)).abs();
            ang[y * w + x] = c.clamp(0.0, 1.0).acos().to_degrees();
        }
    }
    (p, ang)
}

/// Interior pixels (3×3 sees one primitive) viewed within `max_deg` of the normal: their errors.
pub fn errors_within(s: &Scanned, max_deg: f64) -> (Vec<f64>, Vec<usize>) {
    errors_in(s, &s.cloud, max_deg)
}

/// [`errors_within`] of `cloud` (the scan's, or its points before the edge filter).
pub fn errors_in(s: &Scanned, cloud: &PointCloud, max_deg: f64) -> (Vec<f64>, Vec<usize>) {
    let (truth, ang) = truth_and_angles(&s.dataset, cloud.width, cloud.height);
    let ids = {
        let (img, _) =
            fringe3d::io::image::read_gray(&s.dataset.join("truth/object_id.png")).unwrap();
        match img.pixels {
            fringe3d::io::image::Pixels::U16(v) => v,
            _ => panic!("object ids"),
        }
    };
    let (w, h) = (cloud.width, cloud.height);
    let mut e = Vec::new();
    let mut idx = Vec::new();
    for y in 1..h - 1 {
        for x in 1..w - 1 {
            let i = y * w + x;
            if cloud.validity[i] != 0 || !(ang[i] <= max_deg) {
                continue;
            }
            if !(0..9).all(|k| ids[(y + k / 3 - 1) * w + x + k % 3 - 1] == ids[i]) {
                continue;
            }
            let (p, t) = (&cloud.xyz[3 * i..3 * i + 3], &truth[3 * i..3 * i + 3]);
            e.push(
                ((p[0] as f64 - t[0]).powi(2)
                    + (p[1] as f64 - t[1]).powi(2)
                    + (p[2] as f64 - t[2]).powi(2))
                .sqrt(),
            );
            idx.push(i);
        }
    }
    (e, idx)
}

pub fn rms(v: &[f64]) -> f64 {
    (v.iter().map(|x| x * x).sum::<f64>() / v.len().max(1) as f64).sqrt()
}

/// Measured RMS error and the noise-limited prediction of a scan with intensity noise `noise`
/// (gray levels of the images' bit depth). Per pixel: σ_s = σ_Φ / |dΦ/ds|, with
/// σ_Φ = √(2/N)·σ_I/B for the N-step finest level (B measured by the decoder,
/// σ_I² = noise² + 1/12 with quantization) and dΦ/ds the change of the projected finest phase per
/// mm along the camera ray, from the true projector model. The prediction counts the scan's own
/// noise only, as with an exact reference map.
pub fn measured_and_predicted(scene: &Scene, s: &Scanned, noise: f64) -> (f64, f64, usize) {
    let (e, idx) = errors_within(s, 45.0);
    let sigma = predicted_sigmas(scene, s, &idx, noise);
    let (mut pred2, mut n) = (0.0, 0usize);
    for p in sigma.into_iter().flatten() {
        pred2 += p * p;
        n += 1;
    }
    (rms(&e), (pred2 / n as f64).sqrt(), e.len())
}

/// The noise-limited σ of the points of pixels `idx` ([`measured_and_predicted`]), mm; `None`
/// where the true point is off the projector.
pub fn predicted_sigmas(scene: &Scene, s: &Scanned, idx: &[usize], noise: f64) -> Vec<Option<f64>> {
    let (truth, _) = truth_and_angles(&s.dataset, s.cloud.width, s.cloud.height);
    let rig = &scene.rig;
    // `Rig::projector_pixel` with the lens model's radius found once, not per call.
    let r_max = rig.projector.max_radius();
    let projector_pixel = |p| rig.projector.project(rig.to_projector_frame(p), r_max);
    let sigma_i = (noise * noise + 1.0 / 12.0).sqrt();
    let n_fine = s.set.levels().last().map_or(4, |l| l.shifts().len()) as f64;
    idx.iter()
        .map(|&i| {
            let p = [truth[3 * i], truth[3 * i + 1], truth[3 * i + 2]];
            let l = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
            let d = 0.01; // mm along the ray
            let q = [
                p[0] * (1.0 + d / l),
                p[1] * (1.0 + d / l),
                p[2] * (1.0 + d / l),
            ];
            let v3 = |a: [f64; 3]| fringe3d::render::math::Vec3::new(a[0], a[1], a[2]);
            let (a, b) = (projector_pixel(v3(p))?, projector_pixel(v3(q))?);
            let dphi = (s.set.finest_phase(b.0, b.1) - s.set.finest_phase(a.0, a.1)).abs() / d;
            let sigma_phi = (2.0 / n_fine).sqrt() * sigma_i / s.modulation[i] as f64;
            Some(sigma_phi / dphi)
        })
        .collect()
}

/// The renderer's truth mask (`truth/mask.png`: 1 hit, 2 on the DMD, 4 lit, 8 clean).
pub fn truth_mask(ds: &Path) -> Vec<u8> {
    let (img, _) = fringe3d::io::image::read_gray(&ds.join("truth/mask.png")).unwrap();
    match img.pixels {
        fringe3d::io::image::Pixels::U8(v) => v,
        _ => panic!("the truth mask is 8-bit"),
    }
}

/// The volume scene under a variable-width (knots) or curved pattern set.
pub fn volume_scene_with(o: &Overrides, family: &str) -> Scene {
    with_family(volume_scene(o), family)
}

/// `base` under another pattern set: `"linear"` (the paper's eight images over 0.85 × 2π, as
/// the built-in scenes), `"knots"` (fringes of varying width, §5.1), `"curved"` (curved
/// fringes, §5.1) or `"phase-cue-48"` (12 steps × 4 levels, one period across at the coarsest).
pub fn with_family(base: Scene, family: &str) -> Scene {
    use fringe3d_core::pattern::{Level, PatternSet};
    use fringe3d_core::phase_function::{Axis, KnotProfile, PhaseFunction, Profile};
    if family == "linear" {
        return base;
    }
    let out = *base.patterns.output();
    let n = f64::from(out.width);
    let f = match family {
        "knots" => {
            let unit = 0.85 * std::f64::consts::TAU / n;
            let k = KnotProfile::from_slopes(
                &[0.0, 0.3 * (n - 1.0), 0.65 * (n - 1.0), n - 1.0],
                &[0.7 * unit, 1.3 * unit, 1.1 * unit, 0.8 * unit],
                -0.43 * std::f64::consts::TAU,
            )
            .expect("knots");
            PhaseFunction::with_profile(Axis::Xi, Profile::Knots(k)).expect("knot function")
        }
        // One whole period across the projector (the "phase cue").
        "phase-cue-48" => PhaseFunction::centered(Axis::Xi, out.width, std::f64::consts::TAU)
            .expect("linear function"),
        _ => PhaseFunction::centered(Axis::Xi, out.width, 0.85 * std::f64::consts::TAU)
            .and_then(|f| f.curved(1.5e-4, 0.5 * (f64::from(out.height) - 1.0)))
            .expect("curved function"),
    };
    let set = if family == "phase-cue-48" {
        // 12 steps × 4 levels, scales 1 : 4 : 16 : 64.
        let levels: Vec<Level> = [1.0, 4.0, 16.0, 64.0]
            .iter()
            .map(|&c| Level::n_step(c, 12))
            .collect();
        PatternSet::new(f, &levels, out).expect("a 48-image set")
    } else {
        PatternSet::paper_eight(f, 8.0, out).expect("pattern set")
    };
    let mut spec = base.spec.clone();
    spec.patterns = fringe3d::render::scene::PatternSpec {
        set: Some(
            fringe3d::io::pattern_file::PatternSetFile::from_pattern_set(&set, base.pattern_bits),
        ),
        ..Default::default()
    };
    Scene::new(spec, None).expect("scene with the set")
}
