//! The calibration file's schema: [`Calibration`] and [`ReferencePlane`], reading and writing
//! the file, and the conversions to what the reconstruction needs. Arrays are read with their
//! exact lengths (`io::exact`): a `normal` of 4 values is an error, not a normal.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Deserializer};

use crate::io::atomic::write_atomic;
use crate::io::error::{FormatError, check_toml_version, read_text, toml_message};
use crate::io::exact;
use fringe3d_core::camera::CameraModel;
use fringe3d_core::params::{CameraParams, ProjectorParams, ScanGeometry};
use fringe3d_core::phase_function::Axis;
use fringe3d_core::reconstruct::Setup;

/// The largest `projector_defocus` a calibration may state, projector pixels (the renderer's
/// bound on a projector's blur).
pub const MAX_DEFOCUS: f64 = 50.0;

/// The calibration file format version this build reads and writes.
pub const CALIBRATION_VERSION: u32 = 1;

/// Everything the reconstruction needs to turn a phase map into points, plus optional extras.
///
/// Stored as TOML ([`Calibration::load`], [`Calibration::save`]); see `docs/formats.md`.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Calibration {
    /// Format version; [`CALIBRATION_VERSION`] (= 1).
    pub version: u32,
    /// The camera's intrinsic model.
    pub camera: CameraParams,
    /// The projector's centre of projection P (paper §6), camera frame, mm. Written
    /// `projector_centre`; files with the older spelling `projector_center` still load.
    #[serde(alias = "projector_center", deserialize_with = "read_projector_centre")]
    pub projector_centre: [f64; 3],
    /// The reference plane and its absolute phase map Φ_R (paper §6), if calibrated.
    pub reference: Option<ReferencePlane>,
    /// `[z_min, z_max]`: the depth range of the measurement volume, camera frame, mm
    /// (`0 < z_min < z_max`).
    #[serde(deserialize_with = "read_depth_range")]
    pub depth_range: [f64; 2],
    /// The full projector model, when known (synthetic data); not needed to scan.
    #[serde(default, deserialize_with = "read_projector")]
    pub projector: Option<ProjectorParams>,
    /// The projector's measured response (gamma), when calibrated (`fringe3d calibrate gamma`):
    /// `scan`, `decode` and `calibrate reference` then correct the phase for it, `patterns
    /// --response` pre-distorts patterns through it.
    #[serde(default)]
    pub projector_response: Option<super::ProjectorResponse>,
    /// The projector's effective blur σ, projector pixels (its defocus and the camera's blur
    /// mapped onto it), at most [`MAX_DEFOCUS`]: the model binary pattern sets are decoded with
    /// (`response::binary::binary_correction`, docs/binary.md).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub projector_defocus: Option<f64>,
    /// The covariance of the camera's intrinsics from its calibration, when known (`calibrate
    /// camera`'s file or `calibrate projector --camera-intrinsics refine`): the later steps add
    /// the camera's uncertainty to the σ they report (docs/calibration.md, "Honest σ").
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub camera_covariance: Option<super::CameraCovariance>,
    /// The camera's read noise, when measured (`calibrate reference`, from the plane's
    /// captures): `scan` and `device upload` then put the decoder's minimum modulation at 12σ
    /// unless told otherwise (docs/gamma.md, "Thresholds").
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sensor: Option<super::SensorNoise>,
}

/// The reference plane of paper §6 and its phase map.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ReferencePlane {
    /// A point O_R on the plane, camera frame, mm.
    #[serde(deserialize_with = "read_point")]
    pub point: [f64; 3],
    /// The plane's unit normal n_R, camera frame. Either orientation is accepted (eqs 16-17 use
    /// n_R only in ratios of dot products, so its sign and exact length cancel); fringe3d writes
    /// it pointing towards the camera (`n_R · O_R < 0`).
    #[serde(deserialize_with = "read_normal")]
    pub normal: [f64; 3],
    /// The absolute phase map Φ_R(u, v) of the plane: a 32-bit float TIFF of the camera's
    /// width × height, holding the finest level's absolute phase (radians, what the decoder
    /// returns), NaN where invalid. Relative paths are relative to the calibration file's folder
    /// (see [`Calibration::reference_map_path`]).
    pub phase_map: PathBuf,
    /// The pattern-set file the reference was captured with (relative like `phase_map`); scans
    /// must use the same phase function and scales.
    pub pattern_set: Option<PathBuf>,
    /// The digest of the pattern set the reference was captured with
    /// ([`pattern_digest`](fn@super::pattern_digest)): `sha256:` and 64 lowercase hex digits.
    /// `fringe3d scan`, `reconstruct` and `device upload` refuse a scan whose set differs
    /// ([`check_pattern_set`](super::check_pattern_set)). Older files without it still load; the
    /// check then uses `pattern_set`.
    pub pattern_digest: Option<String>,
    /// How far the phase map extends past the image, `[left, top, right, bottom]` pixels
    /// ([`Margin`](fringe3d_core::reconstruct::Margin)): the map is then
    /// `(left + width + right) × (top + height + bottom)`, its sample `(i, j)` at image pixel
    /// `(i − left, j − top)`. Absent: no margin (a map of the image's size).
    #[serde(default)]
    pub margin: Option<[u32; 4]>,
}

impl ReferencePlane {
    /// The phase map's margin past the image (zero when absent).
    pub fn margin(&self) -> fringe3d_core::reconstruct::Margin {
        fringe3d_core::reconstruct::Margin::from_array(self.margin.unwrap_or([0; 4]))
    }
}

impl Calibration {
    /// Read and validate a calibration file (TOML, version 1).
    pub fn load(path: &Path) -> Result<Calibration, FormatError> {
        let text = read_text(path)?;
        check_toml_version(path, &text, CALIBRATION_VERSION)?;
        let c: Calibration =
            toml::from_str(&text).map_err(|e| FormatError::parse(path, toml_message(&e)))?;
        c.validate().map_err(|m| FormatError::invalid(path, m))?;
        Ok(c)
    }

    /// Validate, then write the file atomically as commented TOML (the layout of
    /// `docs/formats.md`, with a header naming frames and units). Floats are written in their
    /// shortest exact form, so `load(save(c)) == c`.
    pub fn save(&self, path: &Path) -> Result<(), FormatError> {
        let text = self.to_text(path)?;
        write_atomic(path, |w| w.write_all(text.as_bytes()))?;
        Ok(())
    }

    /// What [`Calibration::save`] writes to `path`, checked.
    pub fn to_text(&self, path: &Path) -> Result<String, FormatError> {
        self.validate().map_err(|m| FormatError::invalid(path, m))?;
        self.to_toml().map_err(|m| FormatError::invalid(path, m))
    }

    /// The scan geometry of paper §6 (projector centre, reference plane, depth range); `None`
    /// without a `[reference]` section.
    pub fn geometry(&self) -> Option<ScanGeometry> {
        let r = self.reference.as_ref()?;
        Some(ScanGeometry {
            projector_centre: self.projector_centre,
            plane_point: r.point,
            plane_normal: r.normal,
            depth_min: self.depth_range[0],
            depth_max: self.depth_range[1],
        })
    }

    /// The core's checked camera model and the reconstruction set-up for phases monotonic along
    /// `axis`: the one conversion `fringe3d scan`, `reconstruct` and the head's upload share.
    pub fn core_setup(&self, axis: Axis) -> Result<(CameraModel, Setup), String> {
        let camera = CameraModel::new(self.camera).map_err(|e| format!("camera model: {e}"))?;
        let geometry = self
            .geometry()
            .ok_or("no [reference] section: a scan needs the reference plane and its phase map")?;
        Ok((camera, geometry.setup(axis)))
    }

    /// The reference phase map's path: `reference.phase_map` resolved against the folder of
    /// `calibration_file` (unchanged if absolute). `None` without a reference.
    pub fn reference_map_path(&self, calibration_file: &Path) -> Option<PathBuf> {
        self.reference
            .as_ref()
            .map(|r| resolve(calibration_file, &r.phase_map))
    }

    /// The reference's pattern-set path, resolved like [`Calibration::reference_map_path`].
    pub fn reference_pattern_path(&self, calibration_file: &Path) -> Option<PathBuf> {
        self.reference
            .as_ref()
            .and_then(|r| r.pattern_set.as_ref())
            .map(|p| resolve(calibration_file, p))
    }
}

fn resolve(file: &Path, rel: &Path) -> PathBuf {
    if rel.is_absolute() {
        rel.to_path_buf()
    } else {
        file.parent()
            .map(|d| d.join(rel))
            .unwrap_or_else(|| rel.to_path_buf())
    }
}

// --- reading: the core's parameter types with exact array lengths --------------------------

/// `[projector]` as written: the fields of [`ProjectorParams`], arrays read exactly.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ProjectorTable {
    intrinsics: CameraParams,
    #[serde(deserialize_with = "read_rotation")]
    rotation: [[f64; 3]; 3],
    #[serde(deserialize_with = "read_translation")]
    translation: [f64; 3],
}

fn read_projector<'de, D: Deserializer<'de>>(d: D) -> Result<Option<ProjectorParams>, D::Error> {
    let p = Option::<ProjectorTable>::deserialize(d)?;
    Ok(p.map(|p| ProjectorParams {
        intrinsics: p.intrinsics,
        rotation: p.rotation,
        translation: p.translation,
    }))
}

fn read_projector_centre<'de, D: Deserializer<'de>>(d: D) -> Result<[f64; 3], D::Error> {
    exact::array(d, "projector_centre")
}

fn read_depth_range<'de, D: Deserializer<'de>>(d: D) -> Result<[f64; 2], D::Error> {
    exact::array(d, "depth_range")
}

fn read_point<'de, D: Deserializer<'de>>(d: D) -> Result<[f64; 3], D::Error> {
    exact::array(d, "point")
}

fn read_normal<'de, D: Deserializer<'de>>(d: D) -> Result<[f64; 3], D::Error> {
    exact::array(d, "normal")
}

fn read_rotation<'de, D: Deserializer<'de>>(d: D) -> Result<[[f64; 3]; 3], D::Error> {
    exact::rows(d, "rotation")
}

fn read_translation<'de, D: Deserializer<'de>>(d: D) -> Result<[f64; 3], D::Error> {
    exact::array(d, "translation")
}
