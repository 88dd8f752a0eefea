//! Calibration files: the camera model, the projector centre and the reference plane the
//! reconstruction needs (paper §6), in a documented TOML file; importers for OpenCV
//! `cv::FileStorage` files (YAML, XML, JSON) and for Bouguet's Camera Calibration Toolbox for
//! Matlab (`Calib_Results.m`).
//!
//! # Conventions
//! - Frame: the camera's, as in OpenCV — origin at the centre of projection, x right, y down,
//!   z forward (into the scene). Every position is in millimetres.
//! - Pixels: `(0, 0)` is the *centre* of the top-left pixel; pixel centres are at integers.
//! - Projection (paper eqs 2-4): `x = X/Z, y = Y/Z`, Brown distortion with `[k1, k2, p1, p2, k3]`
//!   (the paper's `k1, k2, k3, k4, k5`: `k1, k2, k3` radial of r², r⁴, r⁶; `p1, p2` tangential),
//!   then `u = fx·x_d + α·fx·y_d + cx`, `v = fy·y_d + cy` with the dimensionless skew α of eq 4.
//!   (The paper writes the image plane at z = −1; with the OpenCV frame it is at z = +1 and the
//!   formulas are the usual ones.)
//!
//! The file format is specified field by field in `docs/formats.md`.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use super::atomic::{AtomicError, write_atomic};
use fringe3d_core::camera::CameraModel;
pub use fringe3d_core::params::{CameraParams, Distortion, ProjectorParams, ScanGeometry};
use fringe3d_core::phase_function::Axis;
use fringe3d_core::reconstruct::Setup;

/// The calibration file format version this build reads and writes.
pub const CALIBRATION_VERSION: u32 = 1;

/// Why a file could not be read, parsed, validated or written. Every message starts with the path
/// of the file, then says what is wrong, e.g. `calib.toml: camera.fx must be positive, got -3`.
#[derive(Debug, thiserror::Error)]
pub enum FormatError {
    /// The file could not be read (or another I/O operation failed).
    #[error("{}: {action}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// What was being done.
        action: &'static str,
        /// The underlying error.
        #[source]
        source: std::io::Error,
    },
    /// The file is not well-formed (syntax, wrong type of a value, missing or unknown key).
    #[error("{}: {message}", path.display())]
    Parse {
        /// The file.
        path: PathBuf,
        /// What is wrong, with a line number where known.
        message: String,
    },
    /// The file is well-formed but its content is not acceptable (a negative focal length, a
    /// non-monotonic phase function, ...), or data handed to a writer is inconsistent.
    #[error("{}: {message}", path.display())]
    Invalid {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// The file declares a format version this build does not read.
    #[error("{}: format version {found} is not supported (this build reads version {supported})", path.display())]
    Version {
        /// The file.
        path: PathBuf,
        /// The version in the file.
        found: i64,
        /// The version this build reads.
        supported: u32,
    },
    /// Writing the file atomically failed (the message names the file).
    #[error(transparent)]
    Write(#[from] AtomicError),
}

impl FormatError {
    /// The file the error is about.
    pub fn path(&self) -> &Path {
        match self {
            FormatError::Io { path, .. }
            | FormatError::Parse { path, .. }
            | FormatError::Invalid { path, .. }
            | FormatError::Version { path, .. } => path,
            FormatError::Write(e) => e.path(),
        }
    }

    pub(crate) fn parse(path: &Path, message: impl Into<String>) -> FormatError {
        FormatError::Parse {
            path: path.to_path_buf(),
            message: message.into(),
        }
    }

    pub(crate) fn invalid(path: &Path, message: impl Into<String>) -> FormatError {
        FormatError::Invalid {
            path: path.to_path_buf(),
            message: message.into(),
        }
    }

    pub(crate) fn io(path: &Path, action: &'static str, source: std::io::Error) -> FormatError {
        FormatError::Io {
            path: path.to_path_buf(),
            action,
            source,
        }
    }
}

/// Read a whole text file.
pub(crate) fn read_text(path: &Path) -> Result<String, FormatError> {
    let bytes = super::input::read_limited(path, super::input::MAX_TEXT_BYTES)
        .map_err(|e| FormatError::io(path, "cannot read", e))?;
    let mut text = String::from_utf8(bytes)
        .map_err(|e| FormatError::parse(path, format!("not UTF-8 text: {e}")))?;
    if text.starts_with('\u{feff}') {
        text.remove(0);
    }
    Ok(text)
}

/// Check the `version` key of a TOML document before it is deserialized, so that a file of a
/// newer version gets a version error rather than a confusing missing-key error.
pub(crate) fn check_toml_version(
    path: &Path,
    text: &str,
    supported: u32,
) -> Result<(), FormatError> {
    #[derive(serde::Deserialize)]
    struct Head {
        version: Option<toml::Value>,
    }
    let head: Head =
        toml::from_str(text).map_err(|e| FormatError::parse(path, toml_message(&e)))?;
    match head.version {
        None => Err(FormatError::parse(
            path,
            format!("missing `version = {supported}` at the top of the file"),
        )),
        Some(toml::Value::Integer(v)) if v == i64::from(supported) => Ok(()),
        Some(toml::Value::Integer(v)) => Err(FormatError::Version {
            path: path.to_path_buf(),
            found: v,
            supported,
        }),
        Some(other) => Err(FormatError::parse(
            path,
            format!("`version` must be the integer {supported}, got {other}"),
        )),
    }
}

/// A TOML error as one readable message (the crate's own text carries line, column and a snippet).
pub(crate) fn toml_message(e: &toml::de::Error) -> String {
    e.to_string().trim_end().to_string()
}

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
    #[serde(alias = "projector_center")]
    pub projector_centre: [f64; 3],
    /// The reference plane and its absolute phase map Φ_R (paper §6), if calibrated.
    pub reference: Option<ReferencePlane>,
    /// `[z_min, z_max]`: the depth range of the measurement volume, camera frame, mm
    /// (`0 < z_min < z_max`).
    pub depth_range: [f64; 2],
    /// The full projector model, when known (synthetic data); not needed to scan.
    pub projector: Option<ProjectorParams>,
}

/// The reference plane of paper §6 and its phase map.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ReferencePlane {
    /// A point O_R on the plane, camera frame, mm.
    pub point: [f64; 3],
    /// The plane's unit normal n_R, camera frame. Either orientation is accepted (eqs 16-17 use
    /// n_R only in ratios of dot products, so its sign and exact length cancel); fringe3d writes
    /// it pointing towards the camera (`n_R · O_R < 0`).
    pub normal: [f64; 3],
    /// The absolute phase map Φ_R(u, v) of the plane: a 32-bit float TIFF of the camera's
    /// width × height, holding the finest level's absolute phase (radians, what the decoder
    /// returns), NaN where invalid. Relative paths are relative to the calibration file's folder
    /// (see [`Calibration::reference_map_path`]).
    pub phase_map: PathBuf,
    /// The pattern-set file the reference was captured with (relative like `phase_map`); scans
    /// must use the same phase function and scales.
    pub pattern_set: Option<PathBuf>,
}

fn finite3(v: &[f64; 3]) -> bool {
    v.iter().all(|x| x.is_finite())
}

fn dot(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn norm(a: &[f64; 3]) -> f64 {
    dot(a, a).sqrt()
}

fn fmt3(v: &[f64; 3]) -> String {
    format!("[{}, {}, {}]", v[0], v[1], v[2])
}

/// Limits of [`validate_camera`] on distortion coefficients: radial `|k| ≤ 1000`,
/// tangential `|p| ≤ 1`.
const RADIAL_LIMIT: f64 = 1000.0;
const TANGENTIAL_LIMIT: f64 = 1.0;

/// Check a camera's parameters as a file states them; every problem is reported, joined by
/// `"; "`, each naming its field: sizes > 0; `fx`, `fy` finite and > 0; `|skew| < 1`; `cx`, `cy`
/// finite and within ten image sizes of the image; distortion finite with
/// `|k1|, |k2|, |k3| ≤ 1000` and `|p1|, |p2| ≤ 1`. (The core's `CameraParams::new` then checks
/// that the model can be inverted over the image.)
pub fn validate_camera(c: &CameraParams) -> Result<(), String> {
    let mut errs = Vec::new();
    check_camera(c, "camera", &mut errs);
    if errs.is_empty() {
        Ok(())
    } else {
        Err(errs.join("; "))
    }
}

/// [`validate_camera`] for the table `name`, appending to `errs`.
fn check_camera(c: &CameraParams, name: &str, errs: &mut Vec<String>) {
    if c.width == 0 {
        errs.push(format!("{name}.width must be positive, got 0"));
    }
    if c.height == 0 {
        errs.push(format!("{name}.height must be positive, got 0"));
    }
    for (k, v) in [("fx", c.fx), ("fy", c.fy)] {
        if !(v.is_finite() && v > 0.0) {
            errs.push(format!("{name}.{k} must be positive, got {v}"));
        }
    }
    if !(c.skew.is_finite() && c.skew.abs() < 1.0) {
        errs.push(format!(
            "{name}.skew (alpha of eq 4, dimensionless) must satisfy |skew| < 1, got {}",
            c.skew
        ));
    }
    for (k, v, size) in [("cx", c.cx, c.width), ("cy", c.cy, c.height)] {
        let s = f64::from(size.max(1));
        if !v.is_finite() {
            errs.push(format!("{name}.{k} must be finite, got {v}"));
        } else if (v - 0.5 * s).abs() > 10.0 * s {
            errs.push(format!(
                "{name}.{k} = {v} px is implausibly far outside the image ({size} px)"
            ));
        }
    }
    let names = ["k1", "k2", "p1", "p2", "k3"];
    for (i, (&v, n)) in c.distortion.to_array().iter().zip(names).enumerate() {
        let limit = if i == 2 || i == 3 {
            TANGENTIAL_LIMIT
        } else {
            RADIAL_LIMIT
        };
        if !v.is_finite() {
            errs.push(format!(
                "{name}.distortion[{i}] ({n}) must be finite, got {v}"
            ));
        } else if v.abs() > limit {
            errs.push(format!(
                "{name}.distortion[{i}] ({n}) = {v} is not plausible (|{n}| <= {limit})"
            ));
        }
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
        self.validate().map_err(|m| FormatError::invalid(path, m))?;
        let text = self.to_toml().map_err(|m| FormatError::invalid(path, m))?;
        write_atomic(path, |w| w.write_all(text.as_bytes()))?;
        Ok(())
    }

    /// Check everything; every problem is reported, joined by `"; "`, each naming its field:
    ///
    /// - `version` is 1; all numbers finite;
    /// - the camera (and projector intrinsics), as in [`validate_camera`];
    /// - `projector_centre` is not the camera centre (no baseline otherwise);
    /// - `0 < depth_range[0] < depth_range[1]`;
    /// - reference: `| |n_R| − 1 | ≤ 1e-3`; the plane passes neither through the camera centre nor
    ///   through the projector centre; `phase_map` is not empty;
    /// - projector: `rotation` orthonormal (`|RRᵀ − I| ≤ 1e-6` element-wise) with determinant +1;
    ///   `translation` equals `projector_centre` (within 1e-6 mm + 1e-9 relative).
    pub fn validate(&self) -> Result<(), String> {
        let mut errs = Vec::new();
        if self.version != CALIBRATION_VERSION {
            errs.push(format!(
                "version must be {CALIBRATION_VERSION}, got {}",
                self.version
            ));
        }
        check_camera(&self.camera, "camera", &mut errs);
        let p = &self.projector_centre;
        if !finite3(p) {
            errs.push(format!("projector_centre must be finite, got {}", fmt3(p)));
        } else if norm(p) <= 1e-9 {
            errs.push(
                "projector_centre coincides with the camera centre: there is no baseline".into(),
            );
        }
        let [z0, z1] = self.depth_range;
        if !(z0.is_finite() && z1.is_finite() && z0 > 0.0 && z0 < z1) {
            errs.push(format!(
                "depth_range must satisfy 0 < z_min < z_max (mm), got [{z0}, {z1}]"
            ));
        }
        if let Some(r) = &self.reference {
            let n = &r.normal;
            if !finite3(&r.point) {
                errs.push(format!(
                    "reference.point must be finite, got {}",
                    fmt3(&r.point)
                ));
            }
            if !finite3(n) {
                errs.push(format!("reference.normal must be finite, got {}", fmt3(n)));
            } else if (norm(n) - 1.0).abs() > 1e-3 {
                errs.push(format!(
                    "reference.normal must be a unit vector, got {} (length {})",
                    fmt3(n),
                    norm(n)
                ));
            } else if finite3(&r.point) {
                let d_cam = dot(n, &r.point) / norm(n);
                if d_cam.abs() <= 1e-6 {
                    errs.push("reference plane passes through the camera centre".into());
                }
                if finite3(p) {
                    let d = [p[0] - r.point[0], p[1] - r.point[1], p[2] - r.point[2]];
                    if (dot(n, &d) / norm(n)).abs() <= 1e-6 {
                        errs.push("reference plane passes through the projector centre".into());
                    }
                }
            }
            if r.phase_map.as_os_str().is_empty() {
                errs.push("reference.phase_map must name a file".into());
            }
            if r.pattern_set
                .as_ref()
                .is_some_and(|s| s.as_os_str().is_empty())
            {
                errs.push("reference.pattern_set, when given, must name a file".into());
            }
        }
        if let Some(pr) = &self.projector {
            check_camera(&pr.intrinsics, "projector.intrinsics", &mut errs);
            let r = &pr.rotation;
            if !r.iter().all(finite3) {
                errs.push("projector.rotation must be finite".into());
            } else {
                let mut worst: f64 = 0.0;
                for i in 0..3 {
                    for j in 0..3 {
                        let e = if i == j { 1.0 } else { 0.0 };
                        worst = worst.max((dot(&r[i], &r[j]) - e).abs());
                    }
                }
                let det = r[0][0] * (r[1][1] * r[2][2] - r[1][2] * r[2][1])
                    - r[0][1] * (r[1][0] * r[2][2] - r[1][2] * r[2][0])
                    + r[0][2] * (r[1][0] * r[2][1] - r[1][1] * r[2][0]);
                if worst > 1e-6 {
                    errs.push(format!(
                        "projector.rotation is not orthonormal (|R·Rᵀ − I| up to {worst:e})"
                    ));
                } else if det < 0.0 {
                    errs.push(
                        "projector.rotation is a reflection (determinant −1), not a rotation"
                            .into(),
                    );
                }
            }
            let t = &pr.translation;
            if !finite3(t) {
                errs.push(format!(
                    "projector.translation must be finite, got {}",
                    fmt3(t)
                ));
            } else if finite3(p) {
                let d = [t[0] - p[0], t[1] - p[1], t[2] - p[2]];
                if norm(&d) > 1e-6 + 1e-9 * norm(p) {
                    errs.push(format!(
                        "projector.translation {} differs from projector_centre {} (both are the projector centre, mm)",
                        fmt3(t),
                        fmt3(p)
                    ));
                }
            }
        }
        if errs.is_empty() {
            Ok(())
        } else {
            Err(errs.join("; "))
        }
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

    /// The TOML text [`Calibration::save`] writes.
    fn to_toml(&self) -> Result<String, String> {
        let mut s = String::new();
        s.push_str(
            "# fringe3d calibration file, format version 1 (docs/formats.md).\n\
             # Frame: the camera's (OpenCV): origin at its centre of projection, x right, y down, z forward.\n\
             # Units: millimetres for positions and depths; pixels for fx, fy, cx, cy and sizes;\n\
             # skew (alpha of eq 4) and distortion [k1, k2, p1, p2, k3] are dimensionless.\n\
             # Pixel centres are at integer coordinates: (0, 0) is the centre of the top-left pixel.\n",
        );
        let _ = writeln!(s, "version = {}", self.version);
        let _ = writeln!(
            s,
            "projector_centre = {}  # P, mm",
            arr(&self.projector_centre)
        );
        let _ = writeln!(
            s,
            "depth_range = {}  # [z_min, z_max], mm",
            arr(&self.depth_range)
        );
        s.push('\n');
        camera_toml(&mut s, "camera", &self.camera);
        if let Some(r) = &self.reference {
            s.push_str("\n[reference]\n");
            let _ = writeln!(s, "point = {}  # O_R, mm", arr(&r.point));
            let _ = writeln!(s, "normal = {}  # n_R, unit", arr(&r.normal));
            let _ = writeln!(
                s,
                "phase_map = {}  # float32 TIFF, relative to this file",
                toml_str(&r.phase_map)?
            );
            if let Some(p) = &r.pattern_set {
                let _ = writeln!(s, "pattern_set = {}", toml_str(p)?);
            }
        }
        if let Some(p) = &self.projector {
            s.push_str("\n[projector]\n");
            let _ = writeln!(
                s,
                "rotation = [{}, {}, {}]  # R, rows: X_cam = R * X_proj + T",
                arr(&p.rotation[0]),
                arr(&p.rotation[1]),
                arr(&p.rotation[2])
            );
            let _ = writeln!(s, "translation = {}  # T, mm", arr(&p.translation));
            s.push('\n');
            camera_toml(&mut s, "projector.intrinsics", &p.intrinsics);
        }
        Ok(s)
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

/// A float in TOML: Rust's shortest round-trip form (`{:?}` always has a `.` or an exponent).
fn num(v: f64) -> String {
    format!("{v:?}")
}

fn arr(v: &[f64]) -> String {
    let parts: Vec<String> = v.iter().map(|&x| num(x)).collect();
    format!("[{}]", parts.join(", "))
}

fn toml_str(p: &Path) -> Result<String, String> {
    let s = p
        .to_str()
        .ok_or_else(|| format!("path {} is not valid UTF-8", p.display()))?;
    Ok(toml::Value::String(s.to_string()).to_string())
}

fn camera_toml(s: &mut String, table: &str, c: &CameraParams) {
    let _ = writeln!(s, "[{table}]");
    let _ = writeln!(s, "width = {}  # px", c.width);
    let _ = writeln!(s, "height = {}  # px", c.height);
    let _ = writeln!(s, "fx = {}  # px", num(c.fx));
    let _ = writeln!(s, "fy = {}  # px", num(c.fy));
    let _ = writeln!(
        s,
        "skew = {}  # alpha: u = fx*x + skew*fx*y + cx",
        num(c.skew)
    );
    let _ = writeln!(s, "cx = {}  # px", num(c.cx));
    let _ = writeln!(s, "cy = {}  # px", num(c.cy));
    let _ = writeln!(
        s,
        "distortion = {}  # [k1, k2, p1, p2, k3]",
        arr(&c.distortion.to_array())
    );
}

// ---------------------------------------------------------------------------------------------
// Importers
// ---------------------------------------------------------------------------------------------

/// A camera model from Bouguet's Camera Calibration Toolbox for Matlab
/// (`Calib_Results.m` / `.mat` variables `fc`, `cc`, `alpha_c`, `kc`).
///
/// The toolbox's conventions (its documentation, "Description of the calibration parameters",
/// and its code) map onto ours without change:
///
/// - pixel coordinates: `[0; 0]` is the centre of the upper-left pixel and `[nx−1; ny−1]` that of
///   the lower-right one (the toolbox initialises `cc = [nx; ny]/2 − 0.5`), which is our
///   convention — **no** 1-based correction is applied. (Coordinates you read yourself with
///   Matlab's 1-based indexing are different: subtract 1 from those, not from `cc`.)
/// - `KK = [fc(1) alpha_c*fc(1) cc(1); 0 fc(2) cc(2); 0 0 1]`: `alpha_c` is exactly the α of
///   paper eq 4 (the paper's authors used this toolbox, its ref. 14).
/// - `kc = [k1; k2; p1; p2; k3]`: radial `1 + kc(1)r² + kc(2)r⁴ + kc(5)r⁶`, tangential
///   `[2kc(3)xy + kc(4)(r² + 2x²); kc(3)(r² + 2y²) + 2kc(4)xy]` — OpenCV's order.
///
/// The model is not validated here; call [`validate_camera`].
pub fn import_bouguet(
    fc: [f64; 2],
    cc: [f64; 2],
    alpha_c: f64,
    kc: [f64; 5],
    width: u32,
    height: u32,
) -> CameraParams {
    CameraParams {
        width,
        height,
        fx: fc[0],
        fy: fc[1],
        skew: alpha_c,
        cx: cc[0],
        cy: cc[1],
        distortion: kc.into(),
    }
}

/// A camera model from a Bouguet toolbox results script (`Calib_Results.m`: lines such as
/// `fc = [ 657.64 ; 658.04 ];`, `alpha_c = 0.0;`, `kc = [ ... ];`, `nx = 640;`), converted as in
/// [`import_bouguet`]. `kc` may have 4 (older toolbox versions: `k3 = 0`) or 5 elements. `nx`/`ny`,
/// if present, override `width`/`height`. Other statements (`KK = [...]`, extrinsics, uncertainties)
/// are ignored. The result is validated.
pub fn import_bouguet_file(
    path: &Path,
    width: u32,
    height: u32,
) -> Result<CameraParams, FormatError> {
    let text = read_text(path)?;
    let vars = matlab_assignments(&text);
    let get = |name: &str| -> Result<Option<Vec<f64>>, FormatError> {
        match vars.iter().rev().find(|(n, _, _)| n == name) {
            None => Ok(None),
            Some((_, line, expr)) => matlab_numbers(expr)
                .map(Some)
                .map_err(|m| FormatError::parse(path, format!("line {line}: `{name}`: {m}"))),
        }
    };
    let need = |name: &str, lens: &[usize]| -> Result<Vec<f64>, FormatError> {
        let v = get(name)?.ok_or_else(|| {
            FormatError::parse(path, format!("no `{name} = ...;` assignment found"))
        })?;
        if !lens.contains(&v.len()) {
            return Err(FormatError::invalid(
                path,
                format!(
                    "`{name}` has {} values, expected {}",
                    v.len(),
                    alternatives(lens)
                ),
            ));
        }
        if let Some(x) = v.iter().find(|x| !x.is_finite()) {
            return Err(FormatError::invalid(path, format!("`{name}` contains {x}")));
        }
        Ok(v)
    };
    let fc = need("fc", &[2])?;
    let cc = need("cc", &[2])?;
    let alpha = match get("alpha_c")? {
        None => 0.0,
        Some(v) if v.len() == 1 && v[0].is_finite() => v[0],
        Some(v) => {
            return Err(FormatError::invalid(
                path,
                format!("`alpha_c` must be one finite number, got {v:?}"),
            ));
        }
    };
    let kc = need("kc", &[4, 5])?;
    let mut k = [0.0; 5];
    k[..kc.len()].copy_from_slice(&kc);
    let size = |name: &str, default: u32| -> Result<u32, FormatError> {
        match get(name)? {
            None => Ok(default),
            Some(v)
                if v.len() == 1
                    && v[0] >= 1.0
                    && v[0] <= f64::from(u32::MAX)
                    && v[0].fract() == 0.0 =>
            {
                Ok(v[0] as u32)
            }
            Some(v) => Err(FormatError::invalid(
                path,
                format!("`{name}` must be a positive integer, got {v:?}"),
            )),
        }
    };
    let cam = import_bouguet(
        [fc[0], fc[1]],
        [cc[0], cc[1]],
        alpha,
        k,
        size("nx", width)?,
        size("ny", height)?,
    );
    validate_camera(&cam).map_err(|m| FormatError::invalid(path, m))?;
    Ok(cam)
}

fn alternatives(lens: &[usize]) -> String {
    let v: Vec<String> = lens.iter().map(|n| n.to_string()).collect();
    v.join(" or ")
}

/// `name = expression;` statements of a Matlab script: (name, 1-based line, expression text).
/// Comments (`%` to end of line) are removed; `;` inside brackets does not end a statement.
fn matlab_assignments(text: &str) -> Vec<(String, usize, String)> {
    // Strip comments line by line (a `%` inside a quoted string is not expected in these files).
    let mut chars: Vec<(char, usize)> = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let code = line.split('%').next().unwrap_or("");
        chars.extend(code.chars().map(|c| (c, i + 1)));
        chars.push(('\n', i + 1));
    }
    let mut out = Vec::new();
    let mut i = 0;
    let n = chars.len();
    while i < n {
        // Statement start: skip separators.
        while i < n && (chars[i].0.is_whitespace() || chars[i].0 == ';' || chars[i].0 == ',') {
            i += 1;
        }
        let start = i;
        let line = chars.get(i).map_or(0, |c| c.1);
        // Read to the end of the statement: `;`, `,` or newline at bracket depth 0.
        let mut depth = 0i32;
        while i < n {
            let c = chars[i].0;
            match c {
                '[' | '(' | '{' => depth += 1,
                ']' | ')' | '}' => depth -= 1,
                ';' | ',' | '\n' if depth <= 0 => break,
                _ => {}
            }
            i += 1;
        }
        let stmt: String = chars[start..i].iter().map(|c| c.0).collect();
        if let Some((lhs, rhs)) = stmt.split_once('=') {
            let name = lhs.trim();
            let is_ident = !name.is_empty()
                && name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_')
                && !name.starts_with(|c: char| c.is_ascii_digit());
            if is_ident && !rhs.starts_with('=') {
                out.push((name.to_string(), line, rhs.trim().to_string()));
            }
        }
    }
    out
}

/// The numbers of a Matlab literal: `3.5`, `[ 1 ; 2 ]`, `[1, 2 3]` (row/column structure ignored).
fn matlab_numbers(expr: &str) -> Result<Vec<f64>, String> {
    let e = expr.trim();
    let inner = if let Some(rest) = e.strip_prefix('[') {
        rest.strip_suffix(']')
            .ok_or_else(|| format!("unbalanced brackets in `{e}`"))?
    } else {
        e
    };
    let mut v = Vec::new();
    for tok in inner
        .split(|c: char| c.is_whitespace() || c == ';' || c == ',')
        .filter(|t| !t.is_empty())
    {
        let x = match tok.to_ascii_lowercase().as_str() {
            "nan" => f64::NAN,
            "inf" => f64::INFINITY,
            "-inf" => f64::NEG_INFINITY,
            _ => tok
                .parse::<f64>()
                .map_err(|_| format!("`{tok}` is not a number (expressions are not evaluated)"))?,
        };
        v.push(x);
    }
    Ok(v)
}

/// A camera model from an OpenCV `cv::FileStorage` file — YAML (`%YAML:1.0`, `!!opencv-matrix`
/// maps of `rows`/`cols`/`dt`/`data`), XML (`<opencv_storage>`, `type_id="opencv-matrix"`) or
/// JSON — as written by OpenCV's calibration sample and `calibrateCamera` users.
///
/// Keys (first found wins): the camera matrix `camera_matrix` (or `cameraMatrix`, `K`), the
/// distortion `distortion_coefficients` (or `dist_coeffs`, `distCoeffs`, `D`). The camera matrix
/// must be `[fx s cx; 0 fy cy; 0 0 1]`; `skew = s / fx`. Distortion may have 4 (`k3 = 0`), 5, 8, 12
/// or 14 coefficients; beyond the fifth (`k4 k5 k6 s1 s2 s3 s4 τx τy`) all must be zero, as
/// fringe3d's model has only `[k1, k2, p1, p2, k3]`. `image_width`/`image_height`, if present,
/// override `width`/`height`. OpenCV's pixel convention is ours. The result is validated.
pub fn import_opencv(path: &Path, width: u32, height: u32) -> Result<CameraParams, FormatError> {
    let text = read_text(path)?;
    let root = parse_filestorage(&text).map_err(|m| FormatError::parse(path, m))?;
    opencv_camera(&root, width, height).map_err(|m| FormatError::invalid(path, m))
}

fn opencv_camera(root: &Node, width: u32, height: u32) -> Result<CameraParams, String> {
    let find = |names: &[&'static str]| names.iter().find_map(|&n| root.get(n).map(|v| (n, v)));
    let (kname, k) = find(&["camera_matrix", "cameraMatrix", "K"])
        .ok_or("no camera matrix (looked for camera_matrix, cameraMatrix, K)")?;
    let k = matrix_values(k).map_err(|m| format!("{kname}: {m}"))?;
    if k.len() != 9 {
        return Err(format!("{kname} has {} values, expected 9 (3x3)", k.len()));
    }
    let zero_ok = |i: usize, want: f64| (k[i] - want).abs() <= 1e-9;
    if !(zero_ok(3, 0.0) && zero_ok(6, 0.0) && zero_ok(7, 0.0) && zero_ok(8, 1.0)) {
        return Err(format!(
            "{kname} must have the form [fx s cx; 0 fy cy; 0 0 1], got [{} {} {}; {} {} {}; {} {} {}]",
            k[0], k[1], k[2], k[3], k[4], k[5], k[6], k[7], k[8]
        ));
    }
    let (dname, d) = find(&["distortion_coefficients", "dist_coeffs", "distCoeffs", "D"])
        .ok_or("no distortion coefficients (looked for distortion_coefficients, dist_coeffs, distCoeffs, D)")?;
    let d = matrix_values(d).map_err(|m| format!("{dname}: {m}"))?;
    if ![4, 5, 8, 12, 14].contains(&d.len()) {
        return Err(format!(
            "{dname} has {} values; OpenCV writes 4, 5, 8, 12 or 14",
            d.len()
        ));
    }
    const EXTRA: [&str; 9] = ["k4", "k5", "k6", "s1", "s2", "s3", "s4", "tau_x", "tau_y"];
    for (i, &v) in d.iter().enumerate().skip(5) {
        if v != 0.0 {
            return Err(format!(
                "{dname} has {} values and {} = {v} is not zero: fringe3d's model has only [k1, k2, p1, p2, k3]; \
                 calibrate without the rational, thin-prism and tilted models",
                d.len(),
                EXTRA[i - 5]
            ));
        }
    }
    let mut dist = [0.0; 5];
    for (o, v) in dist.iter_mut().zip(&d) {
        *o = *v;
    }
    let size = |name: &str, default: u32| -> Result<u32, String> {
        match root.get(name) {
            None => Ok(default),
            Some(Node::Scalar(s)) => s
                .trim()
                .parse::<u32>()
                .ok()
                .filter(|&v| v > 0)
                .ok_or_else(|| format!("{name} must be a positive integer, got `{s}`")),
            Some(_) => Err(format!("{name} must be a positive integer")),
        }
    };
    let fx = k[0];
    let cam = CameraParams {
        width: size("image_width", width)?,
        height: size("image_height", height)?,
        fx,
        fy: k[4],
        skew: if fx != 0.0 { k[1] / fx } else { f64::NAN },
        cx: k[2],
        cy: k[5],
        distortion: dist.into(),
    };
    validate_camera(&cam)?;
    Ok(cam)
}

/// A parsed `cv::FileStorage` value.
#[derive(Clone, Debug, PartialEq)]
enum Node {
    Scalar(String),
    Seq(Vec<Node>),
    Map(Vec<(String, Node)>),
}

impl Node {
    fn get(&self, key: &str) -> Option<&Node> {
        match self {
            Node::Map(m) => m.iter().find(|(k, _)| k == key).map(|(_, v)| v),
            _ => None,
        }
    }
}

fn parse_number(s: &str) -> Result<f64, String> {
    let t = s.trim();
    let v: f64 = t.parse().map_err(|_| format!("`{t}` is not a number"))?;
    if !v.is_finite() {
        return Err(format!("`{t}` is not finite"));
    }
    Ok(v)
}

/// Values of an OpenCV matrix node (`rows`/`cols`/`data` map), or of a plain list of numbers.
fn matrix_values(n: &Node) -> Result<Vec<f64>, String> {
    let flat = |d: &Node| -> Result<Vec<f64>, String> {
        match d {
            Node::Scalar(s) => s.split_whitespace().map(parse_number).collect(),
            Node::Seq(items) => items
                .iter()
                .map(|i| match i {
                    Node::Scalar(s) => parse_number(s),
                    _ => Err("nested lists are not numbers".to_string()),
                })
                .collect(),
            Node::Map(_) => Err("expected numbers, found a map".to_string()),
        }
    };
    match n {
        Node::Map(_) => {
            let data = n.get("data").ok_or("matrix has no `data`")?;
            let v = flat(data)?;
            let dim = |k: &str| -> Result<Option<usize>, String> {
                match n.get(k) {
                    None => Ok(None),
                    Some(Node::Scalar(s)) => s
                        .trim()
                        .parse::<usize>()
                        .map(Some)
                        .map_err(|_| format!("`{k}` is not a count: `{s}`")),
                    Some(_) => Err(format!("`{k}` is not a count")),
                }
            };
            if let (Some(r), Some(c)) = (dim("rows")?, dim("cols")?)
                && r * c != v.len()
            {
                return Err(format!(
                    "rows x cols = {r} x {c} but data has {} values",
                    v.len()
                ));
            }
            Ok(v)
        }
        other => flat(other),
    }
}

/// Parse an OpenCV FileStorage document (YAML, XML or JSON, detected from its first character).
fn parse_filestorage(text: &str) -> Result<Node, String> {
    let t = text.trim_start();
    if t.starts_with('<') {
        parse_xml(t)
    } else if t.starts_with('{') {
        let v: serde_json::Value = serde_json::from_str(t).map_err(|e| format!("JSON: {e}"))?;
        Ok(json_node(&v))
    } else {
        parse_yaml(text)
    }
}

fn json_node(v: &serde_json::Value) -> Node {
    use serde_json::Value;
    match v {
        Value::Object(m) => Node::Map(m.iter().map(|(k, v)| (k.clone(), json_node(v))).collect()),
        Value::Array(a) => Node::Seq(a.iter().map(json_node).collect()),
        Value::String(s) => Node::Scalar(s.clone()),
        other => Node::Scalar(other.to_string()),
    }
}

// --- a small, tolerant YAML reader for what cv::FileStorage writes --------------------------

struct YLine {
    no: usize,
    indent: usize,
    text: String,
}

/// Remove a `#` comment (one at the start or after whitespace, outside quotes).
fn strip_yaml_comment(line: &str) -> &str {
    let mut quote = None;
    let mut prev_space = true;
    for (i, c) in line.char_indices() {
        match quote {
            Some(q) if c == q => quote = None,
            Some(_) => {}
            None if c == '"' || c == '\'' => quote = Some(c),
            None if c == '#' && prev_space => return &line[..i],
            None => {}
        }
        prev_space = c.is_whitespace();
    }
    line
}

fn parse_yaml(text: &str) -> Result<Node, String> {
    let mut lines = Vec::new();
    for (i, raw) in text.lines().enumerate() {
        let l = strip_yaml_comment(raw.trim_end_matches('\r')).trim_end();
        let body = l.trim_start_matches([' ', '\t']);
        if body.is_empty() || (body.starts_with('%') && l.len() == body.len()) {
            continue;
        }
        if body == "---" || body.starts_with("--- ") || body == "..." {
            // Document markers; `--- !!tag` keeps nothing useful either.
            continue;
        }
        lines.push(YLine {
            no: i + 1,
            indent: l.len() - body.len(),
            text: body.to_string(),
        });
    }
    if lines.is_empty() {
        return Err("empty file".into());
    }
    let mut i = 0;
    let node = yaml_block(&mut lines, &mut i)?;
    if i < lines.len() {
        return Err(format!("line {}: unexpected indentation", lines[i].no));
    }
    Ok(node)
}

fn is_seq_item(t: &str) -> bool {
    t == "-" || t.starts_with("- ")
}

fn yaml_block(lines: &mut [YLine], i: &mut usize) -> Result<Node, String> {
    if is_seq_item(&lines[*i].text) {
        yaml_seq(lines, i)
    } else {
        yaml_map(lines, i)
    }
}

/// Split `key: value` at the first `:` followed by a space or the end, outside quotes.
fn split_key(t: &str) -> Option<(String, &str)> {
    let mut quote = None;
    let b = t.as_bytes();
    for (i, c) in t.char_indices() {
        match quote {
            Some(q) if c == q => quote = None,
            Some(_) => {}
            None if c == '"' || c == '\'' => quote = Some(c),
            None if c == ':' && (i + 1 == b.len() || b[i + 1] == b' ' || b[i + 1] == b'\t') => {
                return Some((unquote(&t[..i]), t[i + 1..].trim()));
            }
            None => {}
        }
    }
    None
}

fn unquote(s: &str) -> String {
    let s = s.trim();
    for q in ['"', '\''] {
        if s.len() >= 2 && s.starts_with(q) && s.ends_with(q) {
            return s[1..s.len() - 1].to_string();
        }
    }
    s.to_string()
}

/// Drop a leading tag such as `!!opencv-matrix` or `!<tag:yaml.org,2002:opencv-matrix>`.
fn strip_tag(v: &str) -> &str {
    if v.starts_with('!') {
        match v.find(char::is_whitespace) {
            Some(p) => v[p..].trim_start(),
            None => "",
        }
    } else {
        v
    }
}

/// A value on the rest of a line: a flow collection (joined with the following lines until its
/// brackets balance) or a scalar. Advances `i` past the lines used.
fn yaml_inline(lines: &[YLine], i: &mut usize, first: &str) -> Result<Node, String> {
    let no = lines[*i].no;
    *i += 1;
    if first.starts_with('[') || first.starts_with('{') {
        let mut text = first.to_string();
        while !flow_balanced(&text) {
            let Some(l) = lines.get(*i) else {
                return Err(format!("line {no}: unclosed `{}`", &first[..1]));
            };
            text.push(' ');
            text.push_str(&l.text);
            *i += 1;
        }
        let mut p = FlowParser {
            s: text.as_bytes(),
            pos: 0,
        };
        let n = p.value().map_err(|m| format!("line {no}: {m}"))?;
        p.skip_ws();
        if p.pos != p.s.len() {
            return Err(format!(
                "line {no}: unexpected text after the closing bracket"
            ));
        }
        Ok(n)
    } else {
        Ok(Node::Scalar(unquote(first)))
    }
}

fn flow_balanced(t: &str) -> bool {
    let mut depth = 0i32;
    let mut quote = None;
    for c in t.chars() {
        match quote {
            Some(q) if c == q => quote = None,
            Some(_) => {}
            None => match c {
                '"' | '\'' => quote = Some(c),
                '[' | '{' => depth += 1,
                ']' | '}' => depth -= 1,
                _ => {}
            },
        }
    }
    depth <= 0
}

fn yaml_map(lines: &mut [YLine], i: &mut usize) -> Result<Node, String> {
    let ind = lines[*i].indent;
    let mut map = Vec::new();
    while *i < lines.len() && lines[*i].indent >= ind {
        let (no, indent) = (lines[*i].no, lines[*i].indent);
        if indent > ind {
            return Err(format!("line {no}: unexpected indentation"));
        }
        let text = lines[*i].text.clone();
        if is_seq_item(&text) {
            return Err(format!(
                "line {no}: list item where a `key: value` was expected"
            ));
        }
        let (key, rest) =
            split_key(&text).ok_or_else(|| format!("line {no}: expected `key: value`"))?;
        let rest = strip_tag(rest);
        let value = if rest.is_empty() {
            *i += 1;
            match lines.get(*i) {
                Some(l) if l.indent > ind || (l.indent == ind && is_seq_item(&l.text)) => {
                    yaml_block(lines, i)?
                }
                _ => Node::Scalar(String::new()),
            }
        } else {
            yaml_inline(lines, i, rest)?
        };
        map.push((key, value));
    }
    Ok(Node::Map(map))
}

fn yaml_seq(lines: &mut [YLine], i: &mut usize) -> Result<Node, String> {
    let ind = lines[*i].indent;
    let mut seq = Vec::new();
    while *i < lines.len() && lines[*i].indent == ind && is_seq_item(&lines[*i].text) {
        let text = lines[*i].text.clone();
        let item = text[1..].trim_start();
        let item = strip_tag(item);
        if item.is_empty() {
            *i += 1;
            match lines.get(*i) {
                Some(l) if l.indent > ind => seq.push(yaml_block(lines, i)?),
                _ => seq.push(Node::Scalar(String::new())),
            }
        } else if !item.starts_with('[') && !item.starts_with('{') && split_key(item).is_some() {
            // Compact nested map `- key: value`: re-read this line as a map at the item's column.
            let offset = text.len() - item.len();
            lines[*i].indent = ind + offset;
            lines[*i].text = item.to_string();
            seq.push(yaml_map(lines, i)?);
        } else {
            seq.push(yaml_inline(lines, i, item)?);
        }
    }
    Ok(Node::Seq(seq))
}

struct FlowParser<'a> {
    s: &'a [u8],
    pos: usize,
}

impl FlowParser<'_> {
    fn skip_ws(&mut self) {
        while self.pos < self.s.len() && (self.s[self.pos] as char).is_whitespace() {
            self.pos += 1;
        }
    }

    fn value(&mut self) -> Result<Node, String> {
        self.skip_ws();
        match self.s.get(self.pos) {
            Some(b'[') => {
                self.pos += 1;
                let mut items = Vec::new();
                loop {
                    self.skip_ws();
                    if self.s.get(self.pos) == Some(&b']') {
                        self.pos += 1;
                        return Ok(Node::Seq(items));
                    }
                    items.push(self.value()?);
                    self.skip_ws();
                    match self.s.get(self.pos) {
                        Some(b',') => self.pos += 1,
                        Some(b']') => {}
                        _ => return Err("expected `,` or `]` in a list".into()),
                    }
                }
            }
            Some(b'{') => {
                self.pos += 1;
                let mut map = Vec::new();
                loop {
                    self.skip_ws();
                    if self.s.get(self.pos) == Some(&b'}') {
                        self.pos += 1;
                        return Ok(Node::Map(map));
                    }
                    let key = self.scalar(b":")?;
                    if self.s.get(self.pos) != Some(&b':') {
                        return Err("expected `key: value` in a `{ }` map".into());
                    }
                    self.pos += 1;
                    let v = self.value()?;
                    map.push((key, v));
                    self.skip_ws();
                    match self.s.get(self.pos) {
                        Some(b',') => self.pos += 1,
                        Some(b'}') => {}
                        _ => return Err("expected `,` or `}` in a map".into()),
                    }
                }
            }
            Some(_) => Ok(Node::Scalar(self.scalar(b"")?)),
            None => Err("missing value".into()),
        }
    }

    /// A plain or quoted scalar, ending before `,`, `]`, `}` or any of `extra`.
    fn scalar(&mut self, extra: &[u8]) -> Result<String, String> {
        self.skip_ws();
        if let Some(&q) = self.s.get(self.pos).filter(|&&c| c == b'"' || c == b'\'') {
            let start = self.pos + 1;
            let end = self.s[start..]
                .iter()
                .position(|&c| c == q)
                .ok_or("unclosed quote")?
                + start;
            self.pos = end + 1;
            return Ok(String::from_utf8_lossy(&self.s[start..end]).into_owned());
        }
        let start = self.pos;
        while self.pos < self.s.len() {
            let c = self.s[self.pos];
            if c == b',' || c == b']' || c == b'}' || extra.contains(&c) {
                break;
            }
            self.pos += 1;
        }
        Ok(String::from_utf8_lossy(&self.s[start..self.pos])
            .trim()
            .to_string())
    }
}

// --- a small XML reader for what cv::FileStorage writes -------------------------------------

struct XmlElem {
    name: String,
    children: Vec<XmlElem>,
    text: String,
}

fn parse_xml(text: &str) -> Result<Node, String> {
    let b = text.as_bytes();
    let mut pos = 0;
    let line_of = |p: usize| text[..p.min(text.len())].matches('\n').count() + 1;
    // Stack of open elements; a synthetic document root at the bottom.
    let mut stack = vec![XmlElem {
        name: String::new(),
        children: Vec::new(),
        text: String::new(),
    }];
    while pos < b.len() {
        if b[pos] != b'<' {
            let end = text[pos..].find('<').map_or(b.len(), |e| pos + e);
            if let Some(top) = stack.last_mut() {
                top.text.push_str(&xml_unescape(&text[pos..end]));
            }
            pos = end;
            continue;
        }
        let rest = &text[pos..];
        let skip_to = |pat: &str| rest.find(pat).map(|e| pos + e + pat.len());
        if rest.starts_with("<?") {
            pos = skip_to("?>").ok_or_else(|| format!("line {}: unclosed `<?`", line_of(pos)))?;
        } else if rest.starts_with("<!--") {
            pos =
                skip_to("-->").ok_or_else(|| format!("line {}: unclosed comment", line_of(pos)))?;
        } else if rest.starts_with("<!") {
            pos = skip_to(">").ok_or_else(|| format!("line {}: unclosed `<!`", line_of(pos)))?;
        } else {
            let end = skip_to(">").ok_or_else(|| format!("line {}: unclosed tag", line_of(pos)))?;
            let inner = &text[pos + 1..end - 1];
            if let Some(name) = inner.strip_prefix('/') {
                let name = name.trim();
                let done = stack.pop().filter(|_| !stack.is_empty()).ok_or_else(|| {
                    format!(
                        "line {}: closing tag </{name}> without an open element",
                        line_of(pos)
                    )
                })?;
                if done.name != name {
                    return Err(format!(
                        "line {}: closing tag </{name}> does not match <{}>",
                        line_of(pos),
                        done.name
                    ));
                }
                if let Some(parent) = stack.last_mut() {
                    parent.children.push(done);
                }
            } else {
                let self_closing = inner.ends_with('/');
                let inner = inner.trim_end_matches('/');
                let name = inner.split_whitespace().next().unwrap_or("").to_string();
                if name.is_empty() {
                    return Err(format!("line {}: empty tag", line_of(pos)));
                }
                let e = XmlElem {
                    name,
                    children: Vec::new(),
                    text: String::new(),
                };
                if self_closing {
                    if let Some(parent) = stack.last_mut() {
                        parent.children.push(e);
                    }
                } else {
                    stack.push(e);
                }
            }
            pos = end;
        }
    }
    if stack.len() != 1 {
        let open = stack.last().map(|e| e.name.clone()).unwrap_or_default();
        return Err(format!("unclosed element <{open}>"));
    }
    let doc = stack.pop().ok_or("empty document")?;
    let root = doc
        .children
        .into_iter()
        .find(|e| e.name == "opencv_storage")
        .ok_or("no <opencv_storage> element")?;
    Ok(xml_node(root))
}

fn xml_node(e: XmlElem) -> Node {
    if e.children.is_empty() {
        Node::Scalar(e.text.trim().to_string())
    } else if e.children.iter().all(|c| c.name == "_") {
        Node::Seq(e.children.into_iter().map(xml_node).collect())
    } else {
        Node::Map(
            e.children
                .into_iter()
                .map(|c| (c.name.clone(), xml_node(c)))
                .collect(),
        )
    }
}

fn xml_unescape(s: &str) -> String {
    s.replace("&lt;", "<")
        .replace("&gt;", ">")
        .replace("&quot;", "\"")
        .replace("&apos;", "'")
        .replace("&amp;", "&")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn yaml_reader_handles_filestorage_shapes() {
        let t = "%YAML:1.0\n---\na: 3\nm: !!opencv-matrix\n   rows: 1\n   cols: 3\n   dt: d\n   data: [ 1., 2.,\n       3. ]\n\
                 s:\n  - 1\n  - { x: 2 }\n  - k: 4\n    j: 5\n";
        let n = parse_yaml(t).unwrap();
        assert_eq!(n.get("a"), Some(&Node::Scalar("3".into())));
        assert_eq!(
            matrix_values(n.get("m").unwrap()).unwrap(),
            vec![1.0, 2.0, 3.0]
        );
        let Some(Node::Seq(s)) = n.get("s") else {
            panic!("seq")
        };
        assert_eq!(s.len(), 3);
        assert_eq!(s[2].get("j"), Some(&Node::Scalar("5".into())));
    }

    #[test]
    fn matlab_statements() {
        let v = matlab_assignments("fc = [ 1 ; 2 ]; % c\nKK = [fc(1) 0;0 1];\nnx = 3;\n");
        let names: Vec<&str> = v.iter().map(|x| x.0.as_str()).collect();
        assert_eq!(names, ["fc", "KK", "nx"]);
        assert_eq!(matlab_numbers(&v[0].2).unwrap(), vec![1.0, 2.0]);
        assert!(matlab_numbers(&v[1].2).is_err());
    }
}
