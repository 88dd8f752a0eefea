//! The sections of a scene file: camera, projector, pattern set, photometry, reference plane,
//! checkerboard, plates and measurement volume, with their defaults.

use super::super::camera::CameraParams;
use super::super::engine::{Photometry, Sensor};
use super::super::light::{Optics, ProjectorMode, ResponseLut};
use super::super::math::{Mat3, Vec3};
use crate::io::pattern_file::{PatternSetFile, Preset};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::PathBuf;

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

pub(super) fn d_true() -> bool {
    true
}
pub(super) fn d_bits16() -> u8 {
    16
}
pub(super) fn d_ss() -> u32 {
    3
}
pub(super) fn d_edge_ss() -> u32 {
    9
}
fn is_zero_u32(v: &u32) -> bool {
    *v == 0
}
pub(super) fn d_gamma() -> f64 {
    1.0
}
pub(super) fn d_defocus() -> f64 {
    1.0
}
pub(super) fn d_ambient() -> f64 {
    0.05
}
pub(super) fn d_auto() -> f64 {
    0.8
}
pub(super) fn d_refdist() -> f64 {
    600.0
}
pub(super) fn d_ratio() -> f64 {
    8.0
}
pub(super) fn d_span() -> f64 {
    0.9 * std::f64::consts::TAU
}
pub(super) fn d_albedo() -> f64 {
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
    /// Keys that belong to neither part (refused by [`SceneSpec::parse`](super::SceneSpec::parse); `flatten` rules out
    /// serde's own `deny_unknown_fields`).
    #[serde(flatten, skip_serializing)]
    pub unknown: BTreeMap<String, toml::Value>,
}

impl CameraSpec {
    pub(super) fn from_lens(lens: &CameraParams) -> CameraSpec {
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
    /// A measured response table instead of the gamma: relative light at equally spaced
    /// pattern values from 0 to 1, increasing from 0 to 1 (2 to 65 values; docs/render.md).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub response: Option<Vec<f64>>,
    /// Pattern bits, 8 or 16 (default 16).
    #[serde(default = "d_bits16")]
    pub bits: u8,
    /// Fringe datasets: also capture the reference plane under this many uniform gray levels
    /// (`gray/gray_NN.png`, codes as `fringe3d patterns --gray N` writes them) for
    /// `fringe3d calibrate gamma`; 0 (default): none.
    #[serde(default, skip_serializing_if = "is_zero_u32")]
    pub gray_levels: u32,
    /// Keys that belong to no part (refused by [`SceneSpec::parse`](super::SceneSpec::parse)).
    #[serde(flatten, skip_serializing)]
    pub unknown: BTreeMap<String, toml::Value>,
}

impl ProjectorSpec {
    /// The optics (a response table that [`ResponseLut::new`] refuses is left out here; the
    /// scene's check, [`super::SceneSpec`]'s validation, reports it).
    pub fn optics(&self) -> Optics {
        Optics {
            mode: self.mode,
            defocus: self.defocus,
            gamma: self.gamma,
            black_level: self.black_level,
            response: self
                .response
                .as_deref()
                .and_then(|r| ResponseLut::new(r).ok()),
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
    /// Relative exposure: the gain, given or automatic, times this (default 1; an HDR series
    /// renders the scene at several, e.g. with `fringe3d render --exposure`).
    #[serde(default = "d_one")]
    pub exposure: f64,
}

fn d_one() -> f64 {
    1.0
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
            exposure: 1.0,
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
            exposure: self.exposure,
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

pub(super) fn d_dark() -> f64 {
    0.05
}
pub(super) fn d_light() -> f64 {
    0.85
}
pub(super) fn d_margin() -> f64 {
    20.0
}
pub(super) fn d_count() -> u32 {
    15
}
pub(super) fn d_board_ss() -> u32 {
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
