//! Calibrations from other tools.
//!
//! - A camera alone: OpenCV's `cv::FileStorage` files (YAML, XML, JSON; [`opencv`]) and Bouguet's
//!   Camera Calibration Toolbox for Matlab (`Calib_Results.m`; [`bouguet`]).
//! - A full camera + projector calibration ([`import_rig`]): OpenCV stereo files, SLStudio's
//!   `calibration.xml`, SLMaster's `caliInfo.yml` (`stereo_fs`) and Bouguet's
//!   `Calib_Results_stereo.m` (`bouguet_stereo`); all state the projector's pose as
//!   `x_p = R·x_c + T`, which becomes fringe3d's `X_cam = Rᵀ·X_proj + P` with `P = −Rᵀ·T`
//!   ([`rig`]).
//! - The way back: [`export_opencv_stereo`].
//!
//! Each maps onto [`CameraParams`] without pixel shifts, validates the result like a calibration
//! file's camera and names the file and the key in every error.

pub mod bouguet;
mod bouguet_stereo;
mod filestorage;
mod matlab;
pub mod opencv;
mod opencv_export;
pub mod rig;
mod stereo_fs;

use std::path::Path;

pub use bouguet::{import_bouguet, import_bouguet_file};
pub use opencv::{import_opencv, import_opencv_covariance};
pub use opencv_export::{export_opencv_stereo, opencv_stereo_yaml};
pub use rig::{ImportedRig, RigFormat, RigSizes};

use crate::io::error::{FormatError, read_text};
use filestorage::parse_filestorage;
use fringe3d_core::params::CameraParams;
use rig::ParsedRig;
use stereo_fs::FsKind;

/// What a calibration file from another tool holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ForeignKind {
    /// A full calibration (camera, projector, pose) in this format.
    Rig(RigFormat),
    /// A camera alone: an OpenCV camera file.
    OpenCvCamera,
    /// A camera alone: Bouguet's `Calib_Results.m`.
    BouguetCamera,
}

const EXPECTED: &str = "expected an OpenCV stereo file (M1 D1 M2 D2 R T, or cameraMatrix1 distCoeffs1 cameraMatrix2 distCoeffs2 R T), \
SLStudio's calibration.xml (Kc kc Kp kp Rp Tp), SLMaster's caliInfo.yml (M1 D1 M4 D4 Rlp Tlp) or Bouguet's Calib_Results_stereo.m";

fn is_matlab(path: &Path) -> bool {
    path.extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("m"))
}

/// Read and parse `path`, as `format` or, with `None`, as the format its content shows
/// (refusing a file whose keys fit several). Camera-only files give `Ok(Err(Some(kind)))`, a
/// `cv::FileStorage` file without any known key `Ok(Err(None))`.
fn parse(
    path: &Path,
    format: Option<RigFormat>,
) -> Result<Result<ParsedRig, Option<ForeignKind>>, FormatError> {
    let text = read_text(path)?;
    let bad = |m: String| FormatError::invalid(path, m);
    if is_matlab(path) || format == Some(RigFormat::Bouguet) {
        if format.is_some_and(|f| f != RigFormat::Bouguet) {
            return Err(bad(format!(
                "--format {}: a Matlab script (.m) can only be Bouguet's (--format bouguet)",
                format.map_or("", RigFormat::name)
            )));
        }
        if !bouguet_stereo::is_bouguet_stereo(&text) {
            if format.is_none() && !text.is_empty() {
                return Ok(Err(Some(ForeignKind::BouguetCamera)));
            }
            return Err(bad(
                "no `fc_left = ...;` assignment: not Bouguet's stereo results (Calib_Results_stereo.m)"
                    .into(),
            ));
        }
        return bouguet_stereo::parse_bouguet_stereo(&text)
            .map(Ok)
            .map_err(|m| FormatError::parse(path, m));
    }
    let root = parse_filestorage(&text).map_err(|m| FormatError::parse(path, m))?;
    let format = match (format, stereo_fs::classify(&root)) {
        (Some(f), _) => f,
        (None, FsKind::Rig(f)) => f,
        (None, FsKind::CameraOnly) => return Ok(Err(Some(ForeignKind::OpenCvCamera))),
        (None, FsKind::Ambiguous(v)) => {
            let names: Vec<&str> = v.iter().map(|f| f.name()).collect();
            return Err(bad(format!(
                "the keys fit several formats ({}): choose one with --format",
                names.join(", ")
            )));
        }
        (None, FsKind::Unknown) => return Ok(Err(None)),
    };
    stereo_fs::parse_as(&root, format).map(Ok).map_err(bad)
}

/// What `path` holds: a full calibration (and its format) or a camera alone. Errors name the file.
pub fn detect(path: &Path, format: Option<RigFormat>) -> Result<ForeignKind, FormatError> {
    match parse(path, format)? {
        Ok(r) => Ok(ForeignKind::Rig(r.format)),
        Err(Some(k)) => Ok(k),
        Err(None) => Err(unknown(path)),
    }
}

/// Import a full camera + projector calibration from `path`, as `format` or (`None`) the format
/// its content shows. Sizes the file does not state come from `sizes` (else an error that names
/// the option giving them). The camera, the projector intrinsics and the pose are validated;
/// every error names the file and the key.
pub fn import_rig(
    path: &Path,
    format: Option<RigFormat>,
    sizes: RigSizes,
) -> Result<ImportedRig, FormatError> {
    match parse(path, format)? {
        Ok(r) => r.finish(path, sizes),
        Err(Some(k)) => Err(FormatError::invalid(path, camera_only_message(k))),
        Err(None) => Err(unknown(path)),
    }
}

fn unknown(path: &Path) -> FormatError {
    FormatError::invalid(path, format!("no calibration keys found: {EXPECTED}"))
}

fn camera_only_message(k: ForeignKind) -> String {
    let what = match k {
        ForeignKind::BouguetCamera => "Bouguet's single-camera results (fc, cc, kc)",
        _ => "an OpenCV camera file (camera_matrix, distortion_coefficients)",
    };
    format!(
        "{what}: a camera alone, no projector; use it with `fringe3d calibrate projector --camera-from`, or import a full calibration ({EXPECTED})"
    )
}

/// [`import_rig`] for a look at the file (`fringe3d info`): sizes the file does not state are
/// stood in for by twice the principal point; also returns whether the camera's and the
/// projector's sizes were stated.
pub fn inspect_rig(path: &Path) -> Result<(ImportedRig, [bool; 2]), FormatError> {
    match parse(path, None)? {
        Ok(r) => {
            let (sizes, stated) = r.stand_in_sizes();
            Ok((r.finish(path, sizes)?, stated))
        }
        Err(Some(k)) => Err(FormatError::invalid(path, camera_only_message(k))),
        Err(None) => Err(unknown(path)),
    }
}

/// The camera of any camera file other tools write: an OpenCV camera file, Bouguet's
/// `Calib_Results.m`, or camera 1 of a full calibration (OpenCV stereo, SLStudio, SLMaster,
/// Bouguet stereo). `size` fills in a size the file does not state (and, for camera-only files,
/// is the default their `image_width`/`nx` override, as [`import_opencv`] and
/// [`import_bouguet_file`] do).
pub fn import_any_camera(
    path: &Path,
    size: Option<(u32, u32)>,
) -> Result<CameraParams, FormatError> {
    let (w, h) = size.unwrap_or((0, 0));
    match parse(path, None)? {
        Ok(r) => r.camera(path, size),
        Err(Some(ForeignKind::BouguetCamera)) => import_bouguet_file(path, w.max(1), h.max(1)),
        Err(_) => import_opencv(path, w.max(1), h.max(1)),
    }
}
