//! Scene files (TOML) and the built-in scenes.
//!
//! A scene names the rig (camera, projector and its pose, reference plane, depth range), the
//! pattern set, the photometry, the objects, the camera noise and bit depth, and the seed. See
//! `docs/render.md` for every key; `fringe3d render --scene NAME --print` prints a built-in scene
//! as a file to start from.

use super::camera::{CameraParams, LensModel};
use super::engine::{Photometry, Sensor};
use super::light::{Optics, ProjectorMode};
use super::math::{Mat3, Vec3, look_at};
use super::objects::{ObjectSpec, Shape};
use super::rig::{DEFAULT_AIM, Rig, default_rig};
use crate::io::pattern_file::{PatternSetFile, Preset};
use fringe3d_core::pattern::{Output, PatternSet};
use fringe3d_core::phase_function::{Axis, PhaseFunction};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// The names of the built-in scenes.
pub const BUILTIN_SCENES: [&str; 8] = [
    "sphere",
    "ballbar",
    "steps",
    "freeform",
    "plane",
    "reference",
    "checkerboard",
    "plates",
];

/// What a scene produces.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum DatasetKind {
    /// A fringe set of the objects (plus the reference plane's, decoded into the calibration).
    #[default]
    Fringe,
    /// Images of a checkerboard at many poses under uniform light (camera calibration, §7).
    Checkerboard,
    /// A flat plate at several parallel positions, each with vertical and horizontal fringe sets
    /// and a board image (projector-centre calibration, §7).
    Plates,
}

fn d_true() -> bool {
    true
}
fn d_bits16() -> u8 {
    16
}
fn d_ss() -> u32 {
    3
}
fn d_edge_ss() -> u32 {
    9
}
fn d_gamma() -> f64 {
    1.0
}
fn d_defocus() -> f64 {
    1.0
}
fn d_ambient() -> f64 {
    0.05
}
fn d_auto() -> f64 {
    0.8
}
fn d_refdist() -> f64 {
    600.0
}
fn d_ratio() -> f64 {
    8.0
}
fn d_span() -> f64 {
    0.9 * std::f64::consts::TAU
}
fn d_albedo() -> f64 {
    0.8
}

/// The camera: intrinsics (eq 4, distortion eq 3) and sensor. In a scene file the
/// [`CameraParams`] keys (`width`, `fx`, …) and the sensor's sit side by side in `[camera]`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CameraSpec {
    /// The lens and the image size.
    #[serde(flatten)]
    pub lens: CameraParams,
    /// Bits per sample: 8, 12 or 16 (default 16).
    #[serde(default = "d_bits16")]
    pub bits: u8,
    /// Gaussian noise σ, gray levels (default 0).
    #[serde(default)]
    pub noise: f64,
    /// Gaussian camera blur σ, pixels (default 0).
    #[serde(default)]
    pub blur: f64,
    /// n × n samples per pixel (default 3).
    #[serde(default = "d_ss")]
    pub supersample: u32,
    /// Samples per pixel side at edges (default 9).
    #[serde(default = "d_edge_ss")]
    pub edge_supersample: u32,
    /// Keys that belong to neither part (refused by [`SceneSpec::parse`]; `flatten` rules out
    /// serde's own `deny_unknown_fields`).
    #[serde(flatten, skip_serializing)]
    pub unknown: BTreeMap<String, toml::Value>,
}

impl CameraSpec {
    fn from_lens(lens: &CameraParams) -> CameraSpec {
        CameraSpec {
            lens: *lens,
            bits: 16,
            noise: 0.0,
            blur: 0.0,
            supersample: d_ss(),
            edge_supersample: d_edge_ss(),
            unknown: BTreeMap::new(),
        }
    }

    /// The sensor settings.
    pub fn sensor(&self) -> Sensor {
        Sensor {
            bits: self.bits,
            noise: self.noise,
            blur: self.blur,
            supersample: self.supersample,
            edge_supersample: self.edge_supersample.max(self.supersample),
        }
    }
}

/// The projector: intrinsics, pose and optics. In a scene file the [`CameraParams`] keys of its
/// lens (`width` × `height` = the DMD, ξ × η; distortion forward: camera-frame point → DMD
/// pixel) sit beside the pose and optics keys in `[projector]`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ProjectorSpec {
    /// The lens and the DMD's size.
    #[serde(flatten)]
    pub lens: CameraParams,
    /// The projector centre P in the camera frame, mm (the translation T).
    pub center: [f64; 3],
    /// Aim the optical axis at this point (camera frame, mm), image "down" towards camera +y.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub look_at: Option<[f64; 3]>,
    /// Or give R (projector → camera, row-major) explicitly.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rotation: Option<[[f64; 3]; 3]>,
    /// `pixelated` (DMD pixels + defocus, default) or `continuous` (ideal projector).
    #[serde(default)]
    pub mode: ProjectorMode,
    /// Defocus blur σ, projector pixels (default 1).
    #[serde(default = "d_defocus")]
    pub defocus: f64,
    /// Gamma (default 1).
    #[serde(default = "d_gamma")]
    pub gamma: f64,
    /// Relative radiance of code 0 (default 0).
    #[serde(default)]
    pub black_level: f64,
    /// Pattern bits, 8 or 16 (default 16).
    #[serde(default = "d_bits16")]
    pub bits: u8,
    /// Keys that belong to no part (refused by [`SceneSpec::parse`]).
    #[serde(flatten, skip_serializing)]
    pub unknown: BTreeMap<String, toml::Value>,
}

impl ProjectorSpec {
    /// The optics.
    pub fn optics(&self) -> Optics {
        Optics {
            mode: self.mode,
            defocus: self.defocus,
            gamma: self.gamma,
            black_level: self.black_level,
        }
    }
}

/// Fringe axis of the shorthand pattern description.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum FringeAxis {
    /// Phase along ξ: vertical fringes.
    #[default]
    Xi,
    /// Phase along η: horizontal fringes.
    Eta,
}

/// The pattern set: a file, an inline pattern-set file, or the shorthand (preset + linear phase
/// function centred on the DMD, optionally bent).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PatternSpec {
    /// A pattern-set file (relative to the scene file).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub file: Option<PathBuf>,
    /// An inline pattern-set file (`[patterns.set]`, the keys of a pattern-set file).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub set: Option<PatternSetFile>,
    /// Shorthand: fringe axis.
    #[serde(default)]
    pub axis: FringeAxis,
    /// Shorthand: preset.
    #[serde(default)]
    pub preset: Preset,
    /// Shorthand: scale ratio between levels (default 8).
    #[serde(default = "d_ratio")]
    pub ratio: f64,
    /// Shorthand: coarse level's phase span across the DMD, radians (default 0.9·2π).
    #[serde(default = "d_span")]
    pub span: f64,
    /// Shorthand: fringe bending `a` of `Φ = g(t + a·(w − w₀)²)` (default 0), w₀ = DMD centre.
    #[serde(default)]
    pub curvature: f64,
}

impl Default for PatternSpec {
    fn default() -> Self {
        PatternSpec {
            file: None,
            set: None,
            axis: FringeAxis::Xi,
            preset: Preset::Paper8,
            ratio: d_ratio(),
            span: d_span(),
            curvature: 0.0,
        }
    }
}

/// Light levels and exposure.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PhotometrySpec {
    /// Ambient irradiance relative to the projector's white at `reference_distance` (default
    /// 0.05).
    #[serde(default = "d_ambient")]
    pub ambient: f64,
    /// Gray levels per unit radiance; absent = automatic exposure.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub gain: Option<f64>,
    /// Automatic exposure target: brightest pixel under full white at this fraction of full
    /// scale (default 0.8).
    #[serde(default = "d_auto")]
    pub auto_level: f64,
    /// Inverse-square falloff from the projector (default true).
    #[serde(default = "d_true")]
    pub falloff: bool,
    /// Distance of unit falloff, mm (default 600).
    #[serde(default = "d_refdist")]
    pub reference_distance: f64,
    /// Board and plate-board images: lit by the projector showing white (`projector`, default)
    /// or by ambient light only (`ambient`).
    #[serde(default)]
    pub board_light: BoardLight,
}

impl Default for PhotometrySpec {
    fn default() -> Self {
        PhotometrySpec {
            ambient: d_ambient(),
            gain: None,
            auto_level: d_auto(),
            falloff: true,
            reference_distance: d_refdist(),
            board_light: BoardLight::Projector,
        }
    }
}

impl PhotometrySpec {
    /// The engine's form.
    pub fn photometry(&self) -> Photometry {
        Photometry {
            ambient: self.ambient,
            gain: self.gain,
            auto_level: self.auto_level,
            falloff: self.falloff,
            reference_distance: self.reference_distance,
            auto_with_projector: true,
        }
    }
}

/// Illumination of board images.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum BoardLight {
    /// The projector shows white.
    #[default]
    Projector,
    /// Ambient light only.
    Ambient,
}

/// What to do about the reference plane (paper §6).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum ReferenceMode {
    /// Render the reference plane's fringe set separately and decode it into the calibration's
    /// `reference_phase.tif` (default).
    #[default]
    Render,
    /// The scene's own images are the reference set (the `reference` scene).
    Images,
    /// No reference map.
    None,
}

/// The reference plane.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ReferenceSpec {
    /// A point O_R, camera frame, mm.
    pub point: [f64; 3],
    /// Normal n_R (normalised and turned towards the camera).
    pub normal: [f64; 3],
    /// Albedo of the plane when rendered (default 0.8).
    #[serde(default = "d_albedo")]
    pub albedo: f64,
    /// `render`, `images` or `none`.
    #[serde(default)]
    pub mode: ReferenceMode,
}

/// A checkerboard (the camera calibration target).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BoardSpec {
    /// Square edge, mm.
    pub square: f64,
    /// Squares along the board's x (inner corners: cols − 1).
    pub cols: u32,
    /// Squares along the board's y (inner corners: rows − 1).
    pub rows: u32,
    /// Albedo of dark squares.
    #[serde(default = "d_dark")]
    pub dark: f64,
    /// Albedo of light squares and of the border.
    #[serde(default = "d_light")]
    pub light: f64,
    /// White border around the squares, mm.
    #[serde(default = "d_margin")]
    pub margin: f64,
    /// Number of random poses (checkerboard scenes without explicit `poses`).
    #[serde(default = "d_count")]
    pub count: u32,
    /// Explicit poses (override `count`).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub poses: Vec<Pose>,
    /// Samples per pixel side for board images (default 2; at least 12 at edges).
    #[serde(default = "d_board_ss")]
    pub supersample: u32,
}

fn d_dark() -> f64 {
    0.05
}
fn d_light() -> f64 {
    0.85
}
fn d_margin() -> f64 {
    20.0
}
fn d_count() -> u32 {
    15
}
fn d_board_ss() -> u32 {
    2
}

/// A rigid pose: the object's local frame (x right, y down, z away from the camera at zero
/// rotation) placed at `center` with rotation `euler_deg` (x, then y, then z, camera axes).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Pose {
    /// Centre, camera frame, mm.
    pub center: [f64; 3],
    /// Rotation, degrees.
    #[serde(default)]
    pub euler_deg: [f64; 3],
}

impl Pose {
    /// The rotation (local → camera).
    pub fn rotation(&self) -> Mat3 {
        Mat3::from_euler_deg(self.euler_deg)
    }

    /// A local point in the camera frame.
    pub fn apply(&self, p: Vec3) -> Vec3 {
        Vec3::from_array(self.center) + self.rotation().mul_vec(p)
    }
}

/// The flat calibration plate of paper §7.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PlatesSpec {
    /// Plate size `[w, h]`, mm.
    pub size: [f64; 2],
    /// Plate albedo in the fringe images.
    #[serde(default = "d_albedo")]
    pub albedo: f64,
    /// The plate positions (parallel: same rotation, different centres), far to near.
    pub positions: Vec<Pose>,
}

/// A measurement volume box (camera frame, mm).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct VolumeSpec {
    /// Lower corner.
    pub min: [f64; 3],
    /// Upper corner.
    pub max: [f64; 3],
}

/// A complete scene description (the TOML file).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SceneSpec {
    /// Scene name.
    pub name: String,
    /// `fringe` (default), `checkerboard` or `plates`.
    #[serde(default)]
    pub kind: DatasetKind,
    /// Seed of the camera noise and random board poses.
    #[serde(default)]
    pub seed: u64,
    /// `[z_min, z_max]` of the measurement volume, mm.
    pub depth_range: [f64; 2],
    /// The measurement volume (for board poses; default the rig's).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub volume: Option<VolumeSpec>,
    /// The camera.
    pub camera: CameraSpec,
    /// The projector.
    pub projector: ProjectorSpec,
    /// The pattern set.
    #[serde(default)]
    pub patterns: PatternSpec,
    /// Photometry.
    #[serde(default)]
    pub photometry: PhotometrySpec,
    /// The reference plane.
    pub reference: ReferenceSpec,
    /// The objects.
    #[serde(default)]
    pub objects: Vec<ObjectSpec>,
    /// The checkerboard (checkerboard and plates scenes).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub board: Option<BoardSpec>,
    /// The plates (plates scenes).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub plates: Option<PlatesSpec>,
}

/// Why a scene could not be read or built.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    /// The file could not be read.
    #[error("{path}: cannot read: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The OS error.
        source: std::io::Error,
    },
    /// The file is not valid TOML or has unknown/missing keys.
    #[error("{path}: {message}")]
    Parse {
        /// The file.
        path: PathBuf,
        /// The parser's message.
        message: String,
    },
    /// A value is out of range.
    #[error("scene {scene}: {message}")]
    Invalid {
        /// Scene name (or file).
        scene: String,
        /// The problem.
        message: String,
    },
    /// No built-in scene of that name.
    #[error("no built-in scene named {0:?} (built-in: {list})", list = BUILTIN_SCENES.join(", "))]
    UnknownBuiltin(String),
}

/// Overrides from the command line (each `None` keeps the scene's value).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Overrides {
    /// Seed.
    pub seed: Option<u64>,
    /// Camera noise σ, gray levels.
    pub noise: Option<f64>,
    /// Camera bits.
    pub bits: Option<u8>,
    /// Pattern bits.
    pub pattern_bits: Option<u8>,
    /// Supersampling.
    pub supersample: Option<u32>,
    /// Projector defocus σ.
    pub defocus: Option<f64>,
    /// Camera size (same field of view).
    pub size: Option<(u32, u32)>,
}

impl SceneSpec {
    /// Read a scene file.
    pub fn load(path: &Path) -> Result<SceneSpec, SceneError> {
        let text = std::fs::read_to_string(path).map_err(|source| SceneError::Io {
            path: path.to_path_buf(),
            source,
        })?;
        Self::parse(&text, path)
    }

    /// Parse scene TOML; `path` names it in errors.
    pub fn parse(text: &str, path: &Path) -> Result<SceneSpec, SceneError> {
        let parse_error = |message: String| SceneError::Parse {
            path: path.to_path_buf(),
            message,
        };
        let spec: SceneSpec =
            toml::from_str(text).map_err(|e| parse_error(e.to_string().trim_end().to_string()))?;
        let tables = [
            ("camera", &spec.camera.unknown),
            ("projector", &spec.projector.unknown),
        ];
        for (table, unknown) in tables {
            if let Some(k) = unknown.keys().next() {
                return Err(parse_error(format!("[{table}]: unknown key `{k}`")));
            }
        }
        Ok(spec)
    }

    /// The scene as TOML text (round-trips through [`SceneSpec::parse`]).
    pub fn to_toml(&self) -> Result<String, SceneError> {
        toml::to_string(self).map_err(|e| self.invalid(format!("cannot write as TOML: {e}")))
    }

    fn invalid(&self, message: impl Into<String>) -> SceneError {
        SceneError::Invalid {
            scene: self.name.clone(),
            message: message.into(),
        }
    }

    /// Apply command-line overrides.
    pub fn apply(&mut self, o: &Overrides) {
        if let Some(s) = o.seed {
            self.seed = s;
        }
        if let Some(n) = o.noise {
            self.camera.noise = n;
        }
        if let Some(b) = o.bits {
            self.camera.bits = b;
        }
        if let Some(b) = o.pattern_bits {
            self.projector.bits = b;
        }
        if let Some(s) = o.supersample {
            self.camera.supersample = s;
            self.camera.edge_supersample = self.camera.edge_supersample.max(s);
        }
        if let Some(d) = o.defocus {
            self.projector.defocus = d;
        }
        if let Some((w, h)) = o.size {
            self.camera.lens = self.camera.lens.scaled(w, h);
        }
    }

    /// The rig this scene describes.
    pub fn rig(&self) -> Result<Rig, SceneError> {
        let t = Vec3::from_array(self.projector.center);
        let r = match (&self.projector.rotation, &self.projector.look_at) {
            (Some(_), Some(_)) => {
                return Err(self.invalid("projector: give either rotation or look_at, not both"));
            }
            (Some(r), None) => Mat3(*r),
            (None, a) => {
                let aim = Vec3::from_array(a.unwrap_or(DEFAULT_AIM));
                look_at(t, aim).ok_or_else(|| {
                    self.invalid(
                        "projector.look_at: cannot aim at its own centre or straight up/down",
                    )
                })?
            }
        };
        let n = Vec3::from_array(self.reference.normal);
        if !(n.norm() > 1e-12 && n.is_finite()) {
            return Err(self.invalid("reference.normal must be a non-zero vector"));
        }
        let mut n = n.normalized();
        let p = Vec3::from_array(self.reference.point);
        if n.dot(p) > 0.0 {
            n = -n;
        }
        let vol = self.volume.clone().unwrap_or_else(|| {
            let d = default_rig();
            VolumeSpec {
                min: d.volume_min,
                max: d.volume_max,
            }
        });
        let rig = Rig {
            camera: self.camera.lens,
            projector: self.projector.lens,
            rotation: r.0,
            translation: t.to_array(),
            reference_point: p.to_array(),
            reference_normal: n.to_array(),
            depth_range: self.depth_range,
            volume_min: vol.min,
            volume_max: vol.max,
        };
        rig.validate().map_err(|m| self.invalid(m))?;
        Ok(rig)
    }

    /// The pattern set for fringe axis `axis` (`None`: the scene's own). `base_dir` resolves a
    /// relative pattern file. Also returns the pattern bits.
    pub fn pattern_set(
        &self,
        base_dir: Option<&Path>,
        axis: Option<FringeAxis>,
    ) -> Result<(PatternSet, u8), SceneError> {
        let bits = self.projector.bits;
        if bits != 8 && bits != 16 {
            return Err(self.invalid(format!("projector.bits must be 8 or 16, got {bits}")));
        }
        let p = &self.patterns;
        let file = match (&p.file, &p.set) {
            (Some(_), Some(_)) => {
                return Err(self.invalid("patterns: give either file or set, not both"));
            }
            (Some(f), None) => {
                let path = match base_dir {
                    Some(b) if f.is_relative() => b.join(f),
                    _ => f.clone(),
                };
                Some(
                    PatternSetFile::load(&path)
                        .map_err(|e| self.invalid(format!("patterns.file: {e}")))?,
                )
            }
            (None, Some(s)) => Some(s.clone()),
            (None, None) => None,
        };
        if let Some(mut f) = file {
            if axis.is_some() {
                return Err(self.invalid(
                    "plates scenes need the shorthand pattern description (they use both axes)",
                ));
            }
            let old = f.bit_depth();
            if old != bits {
                let s = ((1u32 << bits) - 1) as f64 / ((1u32 << old.min(16)) - 1) as f64;
                f.projector.i_min = f.projector.i_min.map(|v| v * s);
                f.projector.i_max = f.projector.i_max.map(|v| v * s);
                f.projector.bit_depth = Some(bits);
            }
            let set = f
                .to_pattern_set()
                .map_err(|e| self.invalid(format!("patterns: {e}")))?;
            if set.output().width != self.projector.lens.width
                || set.output().height != self.projector.lens.height
            {
                return Err(self.invalid(format!(
                    "patterns are for a {}x{} projector, the scene's is {}x{}",
                    set.output().width,
                    set.output().height,
                    self.projector.lens.width,
                    self.projector.lens.height
                )));
            }
            return Ok((set, bits));
        }
        let axis = match axis.unwrap_or(p.axis) {
            FringeAxis::Xi => Axis::Xi,
            FringeAxis::Eta => Axis::Eta,
        };
        let out = Output {
            width: self.projector.lens.width,
            height: self.projector.lens.height,
            i_min: 0.0,
            i_max: ((1u32 << bits) - 1) as f64,
        };
        let size = if axis == Axis::Xi {
            out.width
        } else {
            out.height
        };
        let other = if axis == Axis::Xi {
            out.height
        } else {
            out.width
        };
        let e = |m: &dyn std::fmt::Display| self.invalid(format!("patterns: {m}"));
        let mut f = PhaseFunction::centered(axis, size, p.span).map_err(|x| e(&x))?;
        if p.curvature != 0.0 {
            f = f
                .curved(p.curvature, 0.5 * (other as f64 - 1.0))
                .map_err(|x| e(&x))?;
        }
        let r = p.ratio;
        let levels = p.preset.levels(r);
        let set = PatternSet::new(f, &levels, out).map_err(|x| e(&x))?;
        Ok((set, bits))
    }

    /// Check everything that can be checked without rendering.
    pub fn validate(&self, base_dir: Option<&Path>) -> Result<(), SceneError> {
        self.rig()?;
        if self.kind != DatasetKind::Checkerboard {
            self.pattern_set(base_dir, None)?;
        }
        let s = self.camera.sensor();
        if self.camera.lens.width as u64 * self.camera.lens.height as u64 > 64_000_000 {
            return Err(self.invalid("camera images larger than 64 megapixels are not supported"));
        }
        if ![8u8, 12, 16].contains(&s.bits) {
            return Err(self.invalid(format!("camera.bits must be 8, 12 or 16, got {}", s.bits)));
        }
        if !(1..=32).contains(&s.supersample) || s.edge_supersample > 64 {
            return Err(
                self.invalid("camera.supersample must be 1..32 and edge_supersample at most 64")
            );
        }
        if !(s.noise.is_finite() && s.noise >= 0.0) {
            return Err(self.invalid(format!("camera.noise must be >= 0, got {}", s.noise)));
        }
        if !(self.reference.albedo.is_finite() && (0.0..=1.0).contains(&self.reference.albedo)) {
            return Err(self.invalid("reference.albedo must be in [0, 1]"));
        }
        for (i, o) in self.objects.iter().enumerate() {
            o.validate(i).map_err(|m| self.invalid(m))?;
        }
        match self.kind {
            DatasetKind::Fringe => {
                if self.objects.is_empty() {
                    return Err(self.invalid("a fringe scene needs at least one object"));
                }
            }
            DatasetKind::Checkerboard => {
                let b = self
                    .board
                    .as_ref()
                    .ok_or_else(|| self.invalid("a checkerboard scene needs [board]"))?;
                self.check_board(b)?;
            }
            DatasetKind::Plates => {
                let p = self
                    .plates
                    .as_ref()
                    .ok_or_else(|| self.invalid("a plates scene needs [plates]"))?;
                if p.positions.len() < 2 {
                    return Err(
                        self.invalid("plates: at least two positions are needed (paper §7)")
                    );
                }
                if !(p.size[0] > 0.0 && p.size[1] > 0.0) {
                    return Err(self.invalid("plates.size must be positive"));
                }
                let b = self.board.as_ref().ok_or_else(|| {
                    self.invalid("a plates scene needs [board] (printed on the plate)")
                })?;
                self.check_board(b)?;
                if self.patterns.file.is_some() || self.patterns.set.is_some() {
                    return Err(self.invalid(
                        "plates scenes need the shorthand pattern description (they use both axes)",
                    ));
                }
            }
        }
        if self.photometry.board_light == BoardLight::Ambient
            && self.photometry.ambient <= 0.0
            && self.kind != DatasetKind::Fringe
        {
            return Err(self.invalid("board_light = \"ambient\" needs photometry.ambient > 0"));
        }
        Ok(())
    }

    fn check_board(&self, b: &BoardSpec) -> Result<(), SceneError> {
        if !(b.square > 0.0 && b.cols >= 2 && b.rows >= 2 && b.margin >= 0.0) {
            return Err(self.invalid("board: need square > 0, at least 2 × 2 squares, margin >= 0"));
        }
        if !(1..=32).contains(&b.supersample) {
            return Err(self.invalid("board.supersample must be 1..32"));
        }
        if b.poses.is_empty() && b.count == 0 && self.kind == DatasetKind::Checkerboard {
            return Err(self.invalid("board: count must be positive"));
        }
        Ok(())
    }

    /// A built-in scene by name (see [`BUILTIN_SCENES`]).
    pub fn builtin(name: &str) -> Result<SceneSpec, SceneError> {
        builtin(name).ok_or_else(|| SceneError::UnknownBuiltin(name.to_string()))
    }
}

/// The scene of `default_rig()` with no objects.
fn base(name: &str) -> SceneSpec {
    let rig = default_rig();
    let p = &rig.projector;
    SceneSpec {
        name: name.into(),
        kind: DatasetKind::Fringe,
        seed: 0,
        depth_range: rig.depth_range,
        volume: None,
        camera: CameraSpec::from_lens(&rig.camera),
        projector: ProjectorSpec {
            lens: *p,
            center: rig.translation,
            look_at: Some(DEFAULT_AIM),
            rotation: None,
            mode: ProjectorMode::Pixelated,
            defocus: d_defocus(),
            gamma: 1.0,
            black_level: 0.0,
            bits: 16,
            unknown: BTreeMap::new(),
        },
        patterns: PatternSpec::default(),
        photometry: PhotometrySpec::default(),
        reference: ReferenceSpec {
            point: rig.reference_point,
            normal: rig.reference_normal,
            albedo: d_albedo(),
            mode: ReferenceMode::Render,
        },
        objects: Vec::new(),
        board: None,
        plates: None,
    }
}

fn obj(name: &str, albedo: f64, shape: Shape) -> ObjectSpec {
    ObjectSpec {
        name: name.into(),
        albedo,
        shape,
        texture: None,
    }
}

fn background() -> ObjectSpec {
    obj(
        "background",
        0.6,
        Shape::Plane {
            point: [0.0, 0.0, 725.0],
            normal: [0.0, 0.0, -1.0],
            size: None,
            u_axis: None,
        },
    )
}

fn builtin(name: &str) -> Option<SceneSpec> {
    let mut s = base(name);
    match name {
        "plane" => {
            let n = Mat3::from_euler_deg([12.0, -18.0, 0.0]).mul_vec(Vec3::new(0.0, 0.0, -1.0));
            s.objects.push(obj(
                "plane",
                0.8,
                Shape::Plane {
                    point: [0.0, 0.0, 600.0],
                    normal: n.to_array(),
                    size: None,
                    u_axis: None,
                },
            ));
        }
        "sphere" => {
            s.objects.push(obj(
                "sphere",
                0.8,
                Shape::Sphere {
                    center: [10.0, -5.0, 590.0],
                    radius: 60.0,
                },
            ));
            s.objects.push(background());
        }
        "ballbar" => {
            s.objects.push(obj(
                "ballbar",
                0.8,
                Shape::BallBar {
                    center_a: [-95.0, -40.0, 620.0],
                    center_b: [95.0, 35.0, 570.0],
                    radius: 20.0,
                    bar_radius: 6.0,
                },
            ));
            s.objects.push(background());
        }
        "steps" => {
            // A base plate with five blocks of increasing height separated by 10 mm gaps, the
            // whole assembly tilted about the volume centre.
            let pose = Pose {
                center: [0.0, 0.0, 650.0],
                euler_deg: [6.0, -10.0, 4.0],
            };
            let place = |c: [f64; 3]| pose.apply(Vec3::new(c[0], c[1], c[2] - 650.0)).to_array();
            s.objects.push(obj(
                "base",
                0.75,
                Shape::Box {
                    center: place([0.0, 0.0, 705.0]),
                    size: [300.0, 230.0, 20.0],
                    euler_deg: pose.euler_deg,
                },
            ));
            let heights = [15.0, 35.0, 60.0, 90.0, 125.0];
            for (i, hgt) in heights.iter().enumerate() {
                let x = -110.0 + 55.0 * i as f64;
                let c = [x, 0.0, 695.0 - 0.5 * hgt];
                s.objects.push(obj(
                    &format!("step{}", i + 1),
                    0.8,
                    Shape::Box {
                        center: place(c),
                        size: [45.0, 170.0, *hgt],
                        euler_deg: pose.euler_deg,
                    },
                ));
            }
        }
        "freeform" => {
            s.objects.push(obj(
                "freeform",
                0.8,
                Shape::HeightField {
                    center: [0.0, 0.0, 660.0],
                    euler_deg: [190.0, -8.0, 0.0],
                    size: [270.0, 210.0],
                    base: 0.0,
                    bumps: vec![
                        [0.0, 0.0, 60.0, 45.0],
                        [-80.0, 50.0, 35.0, 25.0],
                        [85.0, -45.0, 40.0, 30.0],
                        [70.0, 60.0, -25.0, 22.0],
                        [-75.0, -55.0, 20.0, 18.0],
                        [20.0, -70.0, 15.0, 12.0],
                    ],
                },
            ));
        }
        "reference" => {
            s.objects.push(obj(
                "reference",
                d_albedo(),
                Shape::Plane {
                    point: s.reference.point,
                    normal: s.reference.normal,
                    size: None,
                    u_axis: None,
                },
            ));
            s.reference.mode = ReferenceMode::Images;
        }
        "checkerboard" => {
            s.kind = DatasetKind::Checkerboard;
            s.reference.mode = ReferenceMode::None;
            s.seed = 1;
            s.board = Some(BoardSpec {
                square: 25.0,
                cols: 11,
                rows: 8,
                dark: d_dark(),
                light: d_light(),
                margin: d_margin(),
                count: d_count(),
                poses: Vec::new(),
                supersample: d_board_ss(),
            });
        }
        "plates" => {
            s.kind = DatasetKind::Plates;
            s.board = Some(BoardSpec {
                square: 30.0,
                cols: 9,
                rows: 7,
                dark: d_dark(),
                light: d_light(),
                margin: d_margin(),
                count: 0,
                poses: Vec::new(),
                supersample: d_board_ss(),
            });
            let e = [8.0, -12.0, 0.0];
            s.plates = Some(PlatesSpec {
                size: [420.0, 340.0],
                albedo: 0.8,
                positions: vec![
                    Pose {
                        center: [0.0, 0.0, 710.0],
                        euler_deg: e,
                    },
                    Pose {
                        center: [0.0, 0.0, 600.0],
                        euler_deg: e,
                    },
                    Pose {
                        center: [0.0, 0.0, 490.0],
                        euler_deg: e,
                    },
                ],
            });
        }
        _ => return None,
    }
    Some(s)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn builtins_validate_and_roundtrip() {
        for n in BUILTIN_SCENES {
            let s = SceneSpec::builtin(n).unwrap();
            s.validate(None).unwrap_or_else(|e| panic!("{n}: {e}"));
            let t = s.to_toml().unwrap();
            let back = SceneSpec::parse(&t, Path::new("x.toml")).unwrap();
            assert_eq!(back, s, "{n}");
        }
    }
}
