//! The paper's Fig. 10(c) experiment (issue #22 item 3): on a rendered scene, RMS point error
//! against unresolvable area for fixed-pitch sets of several fringe numbers and for sets adapted
//! to the object from a first scan (as `fringe3d adapt --decoded --noise` designs them). Each set is rendered, given a virtual reference (no capture),
//! scanned as `fringe3d scan` does (edge filter included) and scored against the truth on the
//! object's pixels.
//!
//! *Unresolvable* pixels are the object's interior pixels (lit, seen, their 3×3 neighbourhood on
//! the same primitive) that the scan leaves without a point or gives a point farther than
//! [`Config::gross_mm`] from the truth (a wrong fringe order, an aliased phase); the RMS is over
//! the others.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result};

use super::decoded::{self, Reference};
use super::{Adapted, Goal, Snr, adapted_file, solve, template_of};
use crate::accuracy::{Truth, load_truth};
use crate::batch::{Decoded, decode_image_set};
use crate::calib::virtual_reference::virtual_reference_files;
use crate::io::calibration::Calibration;
use crate::io::image_set;
use crate::io::pattern_file::PatternSetFile;
use crate::render::Scene;
use crate::render::dataset::{DatasetOptions, write_dataset};
use crate::render::scene::{Overrides, PatternSpec, ReferenceMode, SceneSpec};
use crate::scan::{PointCloud, ScanCalibration, filter_edges};
use fringe3d_core::decode::{DecodeConfig, Decoder};
use fringe3d_core::validity::Validity;

/// What one scene's experiment runs.
#[derive(Clone, Debug)]
pub struct Config {
    /// Level ratios of the fixed-pitch paper-8 sets (finest scale = ratio²).
    pub fixed_ratios: Vec<f64>,
    /// Level ratios of the templates adapted (each from the first scan).
    pub adapt_ratios: Vec<f64>,
    /// The design's limits.
    pub goal: Goal,
    /// The object in the first scan (min, max corners, camera frame, mm).
    pub crop: ([f64; 3], [f64; 3]),
    /// Points farther than this from the truth count as unresolved, mm.
    pub gross_mm: f64,
    /// Scene overrides (size, noise, ...).
    pub overrides: Overrides,
    /// Design with the noise known: the first scan's measured modulation over the scene's read
    /// noise gives each pixel's B/σ ([`Goal::snr`]).
    pub noise_model: bool,
}

/// One set's result on a scene.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Point {
    /// `fixed` or `adaptive`.
    pub kind: &'static str,
    /// The level ratio.
    pub ratio: f64,
    /// Finest fringes across the projector (the template's, for an adapted set).
    pub fringes: f64,
    /// RMS point error over the resolved object pixels, mm.
    pub rms_mm: f64,
    /// Unresolvable share of the object's interior pixels.
    pub unresolvable: f64,
    /// Object interior pixels scored.
    pub pixels: usize,
    /// The design's predicted RMS gain over its template (adaptive only).
    pub predicted_gain: Option<f64>,
    /// Why no set was designed at this ratio (adaptive only).
    pub refused: Option<String>,
    /// The unresolvable pixels by cause, shares of the scored pixels: a validity code's name,
    /// or `gross` for a point more than [`Config::gross_mm`] from the truth.
    pub lost: std::collections::BTreeMap<&'static str, f64>,
}

impl Point {
    /// A point of `kind` at level ratio `ratio` (a paper-8 set of base span `span`), not scored.
    fn new(kind: &'static str, ratio: f64, span: f64) -> Point {
        Point {
            kind,
            ratio,
            fringes: ratio * ratio * span / std::f64::consts::TAU,
            rms_mm: f64::NAN,
            unresolvable: f64::NAN,
            pixels: 0,
            predicted_gain: None,
            refused: None,
            lost: Default::default(),
        }
    }

    /// Scored by [`score_detail`].
    fn scored(self, s: Score) -> Point {
        let n = s.pixels.max(1) as f64;
        Point {
            rms_mm: s.rms_mm,
            unresolvable: s.unresolvable,
            pixels: s.pixels,
            lost: s.lost.into_iter().map(|(k, c)| (k, c as f64 / n)).collect(),
            ..self
        }
    }
}

/// A cloud's score on the object ([`score_detail`]).
#[derive(Clone, Debug)]
pub struct Score {
    /// RMS point error over the resolved pixels, mm.
    pub rms_mm: f64,
    /// Unresolvable share of the scored pixels.
    pub unresolvable: f64,
    /// Object interior pixels scored.
    pub pixels: usize,
    /// Unresolvable pixels by cause: a validity code's name, or `gross`.
    pub lost: std::collections::BTreeMap<&'static str, usize>,
    /// Per pixel: [`NOT_SCORED`], [`RESOLVED`] or [`UNRESOLVABLE`].
    pub status: Vec<u8>,
}

/// [`Score::status`]: not an interior pixel of the object.
pub const NOT_SCORED: u8 = 0;
/// [`Score::status`]: a point within the gross limit.
pub const RESOLVED: u8 = 1;
/// [`Score::status`]: no point, or one beyond the gross limit.
pub const UNRESOLVABLE: u8 = 2;

/// The score of a cloud on the object (every primitive but the one named `background`): RMS,
/// unresolvable share, pixels scored ([`score_detail`]).
pub fn score(cloud: &PointCloud, truth: &Truth, gross_mm: f64) -> (f64, f64, usize) {
    let s = score_detail(cloud, truth, gross_mm);
    (s.rms_mm, s.unresolvable, s.pixels)
}

/// The score of a cloud on the object's interior pixels (lit, seen, the 3×3 neighbourhood on
/// one primitive): a pixel without a point, or with one more than `gross_mm` from the truth, is
/// unresolvable; the RMS is over the others.
pub fn score_detail(cloud: &PointCloud, truth: &Truth, gross_mm: f64) -> Score {
    let mut lost = std::collections::BTreeMap::new();
    let mut status = vec![NOT_SCORED; truth.width * truth.height];
    let (w, h) = (truth.width, truth.height);
    let background: Vec<u16> = truth
        .primitives
        .iter()
        .filter(|p| p.1 == "background")
        .map(|p| p.0)
        .collect();
    let (mut n, mut ok, mut sq) = (0usize, 0usize, 0.0f64);
    for y in 1..h.saturating_sub(1) {
        for x in 1..w.saturating_sub(1) {
            let i = y * w + x;
            let id = truth.object_id[i];
            if id == 0 || background.contains(&id) {
                continue;
            }
            let interior = (0..3).all(|dy| {
                (0..3).all(|dx| {
                    let j = (y + dy - 1) * w + x + dx - 1;
                    truth.object_id[j] == id && truth.points[3 * j].is_finite()
                })
            });
            if !interior {
                continue;
            }
            n += 1;
            status[i] = UNRESOLVABLE;
            if cloud.validity[i] != 0 {
                let name = Validity::from_u8(cloud.validity[i]).map_or("unknown", |v| v.name());
                *lost.entry(name).or_insert(0) += 1;
                continue;
            }
            let d2: f64 = (0..3)
                .map(|k| (f64::from(cloud.xyz[3 * i + k]) - truth.points[3 * i + k]).powi(2))
                .sum();
            if d2 <= gross_mm * gross_mm {
                status[i] = RESOLVED;
                ok += 1;
                sq += d2;
            } else {
                *lost.entry("gross").or_insert(0) += 1;
            }
        }
    }
    let rms = if ok > 0 {
        (sq / ok as f64).sqrt()
    } else {
        f64::NAN
    };
    Score {
        rms_mm: rms,
        unresolvable: 1.0 - ok as f64 / n.max(1) as f64,
        pixels: n,
        lost,
        status,
    }
}

/// Render `spec` with `patterns` into `dir`, give it a virtual reference, scan it: the cloud and
/// the decode.
pub fn render_scan(
    spec: &SceneSpec,
    patterns: PatternSpec,
    dir: &Path,
) -> Result<(PointCloud, Decoded)> {
    let mut spec = spec.clone();
    spec.patterns = patterns;
    spec.reference.mode = ReferenceMode::None;
    let scene = Scene::new(spec, None)?;
    write_dataset(
        &scene,
        dir,
        DatasetOptions {
            overwrite: true,
            progress: None,
        },
    )?;
    let cal_path = dir.join("calibration.toml");
    let cal = Calibration::load(&cal_path)?;
    let virt = dir.join("virtual/calibration.toml");
    virtual_reference_files(
        &cal,
        &cal_path,
        &virt,
        &dir.join("patterns.toml"),
        None,
        None,
        "reference_phase.tif",
    )?;
    // What `fringe3d scan` does with the dataset's own image list and default thresholds.
    let set_path = dir.join("patterns.toml");
    let file = PatternSetFile::load(&set_path)?;
    let set = file.to_pattern_set()?;
    let sc = ScanCalibration::load(&virt, set.axis())?;
    let paths = file
        .image_paths(&set_path)
        .context("the dataset's pattern file lists no images")?;
    let imgs = image_set::load(&paths, set.image_count(), "the rendered images")?;
    let decoder = Decoder::new(&set, DecodeConfig::for_bit_depth(u32::from(imgs.bits)))
        .map_err(|e| anyhow::anyhow!("decoder: {e}"))?;
    let d = decode_image_set(&decoder, &imgs).map_err(|e| anyhow::anyhow!("decode: {e}"))?;
    let mut cloud = sc.reconstruct(&d.phase, &d.validity, true)?;
    filter_edges(&mut cloud, &sc.edge_filter(80.0)?);
    Ok((cloud, d))
}

/// The set `cfg` designs at level ratio `ratio` from the first scan in `first_dir` (its cloud
/// and decode), as `fringe3d adapt --decoded` does: samples from its phase and the virtual
/// reference it was scanned with, each pixel's light its measured modulation; with
/// [`Config::noise_model`], the scene's read noise (and the 8-bit codes' quantization) turns
/// that into B/σ ([`Goal::snr`]).
pub fn design_for(
    spec: &SceneSpec,
    first_dir: &Path,
    (first, d): (&PointCloud, &Decoded),
    ratio: f64,
    cfg: &Config,
) -> Result<(PatternSetFile, Adapted)> {
    let mut tspec = spec.clone();
    tspec.patterns = fixed_spec(ratio);
    let (tset, bits) = tspec.pattern_set(None, None)?;
    let first_set = PatternSetFile::load(&first_dir.join("patterns.toml"))?.to_pattern_set()?;
    let vcal_path = first_dir.join("virtual/calibration.toml");
    let vcal = Calibration::load(&vcal_path)?;
    let map_path = vcal
        .reference_map_path(&vcal_path)
        .context("the first scan's calibration has no reference")?;
    let (rw, rh, raw) = crate::calib::files::read_phase_map(&map_path)?;
    let reference = Reference {
        calibration: &vcal,
        map: (&raw, rw as usize, rh as usize),
    };
    let (samples, _) = decoded::samples(
        &reference,
        &first_set,
        first,
        &d.phase,
        &d.modulation,
        Some(cfg.crop),
    );
    let template = template_of(&tset).map_err(anyhow::Error::msg)?;
    let snr = cfg.noise_model.then(|| {
        let mut b: Vec<f64> = samples.iter().map(|s| s.bright).collect();
        b.sort_by(f64::total_cmp);
        let sigma = (spec.camera.noise * spec.camera.noise + 1.0 / 12.0).sqrt();
        Snr {
            brightest: b
                .get(((b.len().max(1) - 1) as f64 * 0.99) as usize)
                .copied()
                .unwrap_or(0.0)
                / sigma,
            needed: crate::design::needed_snr(&tset, crate::adapt::PIXEL_FAILURE),
        }
    });
    let goal = Goal {
        projector_blur: spec.projector.defocus,
        camera_blur: spec.camera.blur,
        snr,
        ..cfg.goal
    };
    let design = solve(&samples, &template, &goal)?;
    let file = adapted_file(
        &PatternSetFile::from_pattern_set(&tset, bits),
        tset.axis(),
        &design,
    );
    Ok((file, design))
}

fn fixed_spec(ratio: f64) -> PatternSpec {
    PatternSpec {
        ratio,
        ..PatternSpec::default()
    }
}

/// Run the experiment on the scene file `scene` in `work` (a folder of scratch datasets).
pub fn run_scene(scene: &Path, cfg: &Config, work: &Path) -> Result<Vec<Point>> {
    let mut spec = SceneSpec::load(scene)?;
    spec.apply(&cfg.overrides);
    let span = PatternSpec::default().span;
    let mut points = Vec::new();
    let mut first: Option<((PointCloud, Decoded), PathBuf)> = None;
    let mut ratios = cfg.fixed_ratios.clone();
    ratios.sort_by(f64::total_cmp);
    for &r in &ratios {
        let dir = work.join(format!("fixed_{r:.3}"));
        let (cloud, d) = render_scan(&spec, fixed_spec(r), &dir)
            .with_context(|| format!("{}: the fixed set of ratio {r}", scene.display()))?;
        let truth = load_truth(&dir)?;
        points.push(Point::new("fixed", r, span).scored(score_detail(
            &cloud,
            &truth,
            cfg.gross_mm,
        )));
        // The first scan: the coarsest fixed set (the most robust).
        if first.is_none() {
            first = Some(((cloud, d), dir));
        }
    }
    let (first, first_dir) = first.context("no fixed-pitch set to make the first scan with")?;
    for &r in &cfg.adapt_ratios {
        // A ratio the object's light cannot support is refused by the design: recorded, skipped.
        let (file, design) = match design_for(&spec, &first_dir, (&first.0, &first.1), r, cfg) {
            Ok(d) => d,
            Err(e) => {
                points.push(Point {
                    refused: Some(format!("{e:#}")),
                    ..Point::new("adaptive", r, span)
                });
                continue;
            }
        };
        let dir = work.join(format!("adaptive_{r:.3}"));
        let patterns = PatternSpec {
            set: Some(file),
            ..PatternSpec::default()
        };
        let (cloud, _) = render_scan(&spec, patterns, &dir)
            .with_context(|| format!("{}: the set adapted at ratio {r}", scene.display()))?;
        let truth = load_truth(&dir)?;
        points.push(
            Point {
                predicted_gain: Some(design.fixed.rms_per_rad / design.adaptive.rms_per_rad),
                ..Point::new("adaptive", r, span)
            }
            .scored(score_detail(&cloud, &truth, cfg.gross_mm)),
        );
    }
    Ok(points)
}
