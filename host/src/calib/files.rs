//! The calibration steps on files, as `fringe3d calibrate` and the demo run them: images in,
//! calibration files, phase maps and reports out. Every error names the file, folder or view.

use super::camera::{CameraCalibration, CameraOptions, Rejected, View, calibrate};
pub use super::camera_files::{
    DetectedViews, load_camera, load_camera_covariance, load_image, write_camera_report,
    write_opencv_yaml,
};
use super::corners::{Board, DetectOptions, Detection, detect};
use super::lens::Lens;
use super::projector_centre::PlateObservation;
use super::reference::ReferencePose;
use super::reference_fit::{ReferenceFit, fit_reference};
use super::reference_physical::{PhysicalFit, fit_physical};
pub use super::reference_write::write_reference;
use super::{CalibError, pose};
use crate::batch::decode_image_set;
use crate::io::calibration::{Calibration, ProjectorResponse, SensorNoise};
use crate::io::image::{Pixels, read_gray};
use crate::io::image_set;
use crate::io::pattern_file::PatternSetFile;
use crate::math::Vec3;
use fringe3d_core::decode::{DecodeConfig, Decoder, PhaseCorrection};
use fringe3d_core::pattern::PatternSet;
use fringe3d_core::phase_function::Axis;
use rayon::prelude::*;
use std::path::{Path, PathBuf};

/// A progress callback: called with the number of work items just finished.
pub type Progress<'a> = &'a (dyn Fn(u64) + Sync);

pub(crate) use super::input;

/// The images named on a command line: the files themselves, or every PNG/TIFF/BMP/PGM (or NPY)
/// frame of one folder sorted by name.
pub fn image_list(args: &[PathBuf]) -> Result<Vec<PathBuf>, CalibError> {
    match args {
        [] => Err(CalibError::Input {
            what: "images".into(),
            message: "no images given".into(),
        }),
        [d] if d.is_dir() => Ok(image_set::list_folder(d)?),
        list => Ok(list.to_vec()),
    }
}

/// Detect `board` in every image (in parallel). Unreadable images and images of another size
/// are errors; images without the board are rejected views.
pub fn detect_views(
    paths: &[PathBuf],
    board: &Board,
    opts: &DetectOptions,
    progress: Progress<'_>,
) -> Result<DetectedViews, CalibError> {
    if paths.is_empty() {
        return Err(CalibError::Input {
            what: "camera calibration".into(),
            message: "no board images given".into(),
        });
    }
    let res: Vec<Result<(u32, u32, Result<Detection, String>), CalibError>> = paths
        .par_iter()
        .map(|p| {
            let img = load_image(p)?;
            let d = detect(&img, board, opts).map_err(|e| e.to_string());
            progress(1);
            Ok((img.width as u32, img.height as u32, d))
        })
        .collect();
    let mut out = DetectedViews {
        width: 0,
        height: 0,
        views: Vec::new(),
        images: Vec::new(),
        rejected: Vec::new(),
        half_turn_ambiguous: 0,
    };
    for (p, r) in paths.iter().zip(res) {
        let (w, h, d) = r?;
        if out.width == 0 {
            out.width = w;
            out.height = h;
        } else if (w, h) != (out.width, out.height) {
            return Err(input(
                p,
                format!(
                    "{w}x{h} pixels, but {} is {}x{}: all views must come from one camera",
                    paths[0].display(),
                    out.width,
                    out.height
                ),
            ));
        }
        let name = p.display().to_string();
        match d {
            Ok(d) => {
                out.half_turn_ambiguous += d.half_turn_ambiguous as usize;
                out.views.push(View {
                    name,
                    corners: d.corners,
                });
                out.images.push(p.clone());
            }
            Err(reason) => out.rejected.push(Rejected { name, reason }),
        }
    }
    Ok(out)
}

/// Detect the board in `paths` and calibrate the camera. Rejected views of both stages are in
/// the result's `rejected`.
pub fn calibrate_camera_files(
    paths: &[PathBuf],
    board: &Board,
    detect_opts: &DetectOptions,
    opts: &CameraOptions,
    progress: Progress<'_>,
) -> Result<(CameraCalibration, DetectedViews), CalibError> {
    let first = detect_views(paths, board, detect_opts, progress)?;
    // Calibrated once, the corners are refined again with the lens's distortion straightened
    // out of their windows (`DetectOptions::lens`), and the camera calibrated on them.
    let dv = match calibrate(board, &first.views, first.width, first.height, opts) {
        Ok(c) if detect_opts.lens.is_none() => {
            let again = DetectOptions {
                lens: Some(c.lens),
                ..*detect_opts
            };
            detect_views(paths, board, &again, progress)?
        }
        _ => first,
    };
    match calibrate(board, &dv.views, dv.width, dv.height, opts) {
        Ok(mut c) => {
            let mut all = dv.rejected.clone();
            all.append(&mut c.rejected);
            c.rejected = all;
            Ok((c, dv))
        }
        Err(CalibError::TooFewViews {
            usable,
            needed,
            used,
            rejected,
        }) => {
            let mut all: Vec<String> = dv
                .rejected
                .iter()
                .map(|r| format!("{}: {}", r.name, r.reason))
                .collect();
            all.extend(rejected);
            Err(CalibError::TooFewViews {
                usable,
                needed,
                used,
                rejected: all,
            })
        }
        Err(e) => Err(e),
    }
}

/// A decoded fringe set.
#[derive(Clone, Debug)]
pub struct DecodedSet {
    /// Width.
    pub width: u32,
    /// Height.
    pub height: u32,
    /// Finest absolute phase, NaN where invalid.
    pub phase: Vec<f32>,
    /// Validity codes (0 = valid; see `fringe3d_core::validity`).
    pub validity: Vec<u8>,
    /// Fraction of valid pixels.
    pub valid_fraction: f64,
    /// The phase axis of the set.
    pub axis: Axis,
    /// The images decoded.
    pub images: Vec<PathBuf>,
    /// The camera's read noise measured on them ([`crate::noise::estimate`]: the set needs a
    /// level of 4, 6, … uniform shifts), in codes of their bit depth.
    pub sensor: Option<SensorNoise>,
}

/// Decode the fringe images of the pattern set `set_path`: `images` empty → the set file's own
/// `images` list; one folder → the set file's names inside it, else every image of the folder
/// sorted by name; else the files in set order.
pub fn decode_set(set_path: &Path, images: &[PathBuf]) -> Result<DecodedSet, CalibError> {
    decode_set_with(set_path, images, None, None)
}

/// [`decode_set`] correcting each level's phase for the projector's measured `response`
/// (unless the set file says its patterns are pre-distorted) or, for a binary set, for its
/// `defocus` ([`response_table_for`]).
pub fn decode_set_with(
    set_path: &Path,
    images: &[PathBuf],
    response: Option<&ProjectorResponse>,
    defocus: Option<f64>,
) -> Result<DecodedSet, CalibError> {
    let file = PatternSetFile::load(set_path)?;
    let set = file.to_pattern_set()?;
    let n = set.image_count();
    let (paths, what) = match images {
        [] => (
            file.image_paths(set_path).ok_or_else(|| input(set_path, format!("no images given and the pattern-set file lists none; pass the {n} images or their folder")))?,
            set_path.display().to_string(),
        ),
        [d] if d.is_dir() => match &file.images {
            Some(names) => (names.iter().map(|x| d.join(x)).collect(), format!("{} (names from {})", d.display(), set_path.display())),
            None => (image_set::list_folder(d)?, format!("folder {}", d.display())),
        },
        list => (list.to_vec(), "the images given".to_string()),
    };
    let imgs = image_set::load(&paths, n, &what)?;
    // The sensor's noise as these images show it (a level of 4, 6, … uniform shifts): the
    // decoder's floor is 12σ of it, as `scan` will use (docs/gamma.md, "Thresholds"); without
    // such a level, the bit depth's default.
    let sensor = crate::noise::estimate(&set, &imgs)
        .map(|e| SensorNoise {
            bits: imgs.bits,
            noise: f64::from(e.sigma),
        })
        .filter(|s| s.validate().is_ok());
    let config = sensor.map_or_else(
        || DecodeConfig::for_bit_depth(imgs.bits as u32),
        |s| s.decode_config(imgs.bits),
    );
    let mut dec =
        Decoder::new(&set, config).map_err(|e| input(set_path, format!("decoder: {e}")))?;
    if let Some(t) =
        response_table_for(&file, &set, response, defocus).map_err(|m| input(set_path, m))?
    {
        dec = dec
            .with_correction(&t)
            .map_err(|e| input(set_path, format!("gamma correction: {e}")))?;
    }
    let (w, h) = (imgs.width as usize, imgs.height as usize);
    let decoded = decode_image_set(&dec, &imgs).map_err(|e| {
        input(
            &paths[0],
            format!("decoding the set of {}: {e}", set_path.display()),
        )
    })?;
    let (mut phase, v) = (decoded.phase, decoded.validity);
    for (p, c) in phase.iter_mut().zip(&v) {
        if *c != 0 {
            *p = f32::NAN;
        }
    }
    let valid = phase.iter().filter(|p| p.is_finite()).count();
    Ok(DecodedSet {
        sensor,
        width: imgs.width,
        height: imgs.height,
        phase,
        validity: v,
        valid_fraction: valid as f64 / (w * h).max(1) as f64,
        axis: set.axis(),
        images: paths,
    })
}

/// The board pose in one image with a calibrated lens; errors name the image.
pub fn board_pose_file(
    path: &Path,
    lens: &Lens,
    board: &Board,
    opts: &DetectOptions,
) -> Result<(pose::PlanePose, Detection), CalibError> {
    let img = load_image(path)?;
    if (img.width as u32, img.height as u32) != (lens.width, lens.height) {
        return Err(input(
            path,
            format!(
                "{}x{} pixels, but the camera is {}x{}",
                img.width, img.height, lens.width, lens.height
            ),
        ));
    }
    let d = detect(&img, board, opts).map_err(|e| CalibError::Board {
        path: path.to_path_buf(),
        message: e.to_string(),
    })?;
    let p = pose::board_pose(lens, board, &d.corners).map_err(|e| CalibError::Board {
        path: path.to_path_buf(),
        message: e.to_string(),
    })?;
    Ok((p, d))
}

/// One plate position's files: `DIR/v/` (vertical fringes, phase along ξ), `DIR/h/` (horizontal
/// fringes, phase along η) and `DIR/board.png` (the board printed on the plate).
/// Also returns the board corners.
pub fn load_plate(
    dir: &Path,
    lens: &Lens,
    board: &Board,
    set_v: &Path,
    set_h: &Path,
    opts: &DetectOptions,
) -> Result<(PlateObservation, Vec<[f64; 2]>), CalibError> {
    if !dir.is_dir() {
        return Err(input(
            dir,
            "not a folder (a plate position is a folder with v/, h/ and board.png)",
        ));
    }
    let board_img = ["board.png", "board.tif", "board.tiff", "board.bmp"]
        .iter()
        .map(|n| dir.join(n))
        .find(|p| p.is_file())
        .ok_or_else(|| input(dir, "no board.png (the board image of this plate position)"))?;
    let (pose, det) = board_pose_file(&board_img, lens, board, opts)?;
    let v = decode_set(set_v, &[dir.join("v")])?;
    let h = decode_set(set_h, &[dir.join("h")])?;
    for (d, which) in [(&v, "v"), (&h, "h")] {
        if (d.width, d.height) != (lens.width, lens.height) {
            return Err(input(
                &dir.join(which),
                format!(
                    "images are {}x{}, the camera is {}x{}",
                    d.width, d.height, lens.width, lens.height
                ),
            ));
        }
    }
    Ok((
        PlateObservation {
            name: dir.display().to_string(),
            pose,
            width: v.width as usize,
            height: v.height as usize,
            phase_v: v.phase,
            phase_h: h.phase,
        },
        det.corners,
    ))
}

/// Where the reference plane's pose comes from.
#[derive(Clone, Debug)]
pub enum PlaneSource {
    /// One or more boards lying on the plane (anywhere on it, one per image).
    Board {
        /// The board images.
        images: Vec<PathBuf>,
        /// The board.
        board: Board,
        /// Thickness of the board above the reference surface, mm.
        offset_mm: f64,
    },
    /// Given point and normal (camera frame, mm).
    Given {
        /// O_R.
        point: [f64; 3],
        /// n_R.
        normal: [f64; 3],
    },
}

/// The result of [`calibrate_reference_files`].
#[derive(Clone, Debug)]
pub struct ReferenceRun {
    /// The plane.
    pub plane: ReferencePose,
    /// The calibration written.
    pub calibration: Calibration,
    /// The phase map written.
    pub map_path: PathBuf,
    /// Fraction of valid pixels in the decoded capture.
    pub valid_fraction: f64,
    /// The model fitted to the capture (its map is the one written); `None` with
    /// [`MapSource::Raw`]. Its `phase` is emptied (the map is in the file).
    pub fit: Option<ReferenceFit>,
    /// The plane fitted to the capture through the calibration's projector model (when it has
    /// one): the flatness and pose check.
    pub physical: Option<PhysicalFit>,
    /// The map's margin past the image.
    pub margin: fringe3d_core::reconstruct::Margin,
    /// With a margin: the largest shift between the capture's model and the projector model's
    /// map at the image's border, radians ([`super::reference_margin`]).
    pub seam_rad: Option<f64>,
}

/// The largest angle between the plane the fringes show (through the projector model) and the
/// pose from the board or given, degrees.
pub const MAX_POSE_ANGLE_DEG: f64 = 0.2;
/// The largest distance between them at the plane's point, mm.
pub const MAX_POSE_OFFSET_MM: f64 = 0.5;

/// How [`calibrate_reference_files`] works and what it writes.
#[derive(Clone, Debug)]
pub struct ReferenceOptions<'a> {
    /// Board detection.
    pub detect: DetectOptions,
    /// File name of the phase map written beside the calibration.
    pub map_name: &'a str,
    /// The model's map or the decoded capture.
    pub source: MapSource,
    /// With a projector model: refuse a plate that deviates from a plane by more than this, mm.
    /// `None`: measure and report only (the deviation also holds the projector model's own error
    /// where its calibration did not reach; see [`super::reference_physical::FLATNESS_MM`]).
    pub flatness_limit_mm: Option<f64>,
    /// How far the map extends past the image ([`super::reference_margin`]): `None` for what the
    /// geometry needs; anything but zero needs the calibration's projector model and
    /// [`MapSource::Model`].
    pub margin: Option<fringe3d_core::reconstruct::Margin>,
}

/// What `calibrate reference` writes as Φ_R.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum MapSource {
    /// The smooth model fitted to the decoded capture ([`fit_reference`]).
    #[default]
    Model,
    /// The decoded capture itself (noisy; the behaviour before the model).
    Raw,
}

/// Decode the reference plane's fringe set, find its pose, write the phase map (float TIFF,
/// `map_name` beside `out`: the fitted model's map, or the decoded capture with
/// [`MapSource::Raw`]), a copy of the pattern-set file (`reference_patterns.toml`) and the
/// calibration `out` (the given calibration with its `[reference]` set).
pub fn calibrate_reference_files(
    calibration: &Calibration,
    out: &Path,
    patterns: &Path,
    images: &[PathBuf],
    plane: &PlaneSource,
    opts: &ReferenceOptions<'_>,
) -> Result<ReferenceRun, CalibError> {
    let (detect_opts, map_name, source) = (&opts.detect, opts.map_name, opts.source);
    super::reference_margin::check_request(calibration, source == MapSource::Model, opts.margin)
        .map_err(|m| input(images.first().map_or(out, |p| p.as_path()), m))?;
    let lens = Lens::from_model(&calibration.camera);
    // The boards' corners with the camera's distortion straightened out of their windows.
    let detect_opts = &DetectOptions {
        lens: Some(lens),
        ..*detect_opts
    };
    let pose = match plane {
        PlaneSource::Board {
            images,
            board,
            offset_mm,
        } => {
            let mut all = Vec::new();
            for image in images {
                let img = load_image(image)?;
                if (img.width as u32, img.height as u32) != (lens.width, lens.height) {
                    return Err(input(
                        image,
                        format!(
                            "{}x{} pixels, but the camera is {}x{}",
                            img.width, img.height, lens.width, lens.height
                        ),
                    ));
                }
                let d = detect(&img, board, detect_opts).map_err(|e| CalibError::Board {
                    path: image.clone(),
                    message: e.to_string(),
                })?;
                all.push(d.corners);
            }
            let plane =
                ReferencePose::from_boards(&lens, board, &all, *offset_mm).map_err(|e| {
                    CalibError::Input {
                        what: images
                            .iter()
                            .map(|p| p.display().to_string())
                            .collect::<Vec<_>>()
                            .join(", "),
                        message: format!("board pose: {e}"),
                    }
                })?;
            // The camera's own uncertainty, when the calibration records it.
            match &calibration.camera_covariance {
                Some(c) => plane.with_camera(&lens, board, &all, *offset_mm, c),
                None => plane,
            }
        }
        PlaneSource::Given { point, normal } => ReferencePose::given(
            Vec3::from_array(*point),
            Vec3::from_array(*normal),
        )
        .ok_or_else(|| CalibError::Input {
            what: "--plane-point/--plane-normal".into(),
            message:
                "the normal must be non-zero and the plane must not pass through the camera centre"
                    .into(),
        })?,
    };
    let dec = decode_set_with(
        patterns,
        images,
        calibration.projector_response.as_ref(),
        calibration.projector_defocus,
    )?;
    if (dec.width, dec.height) != (lens.width, lens.height) {
        return Err(input(
            &dec.images[0],
            format!(
                "{}x{} pixels, but the camera is {}x{}",
                dec.width, dec.height, lens.width, lens.height
            ),
        ));
    }
    if dec.valid_fraction < 0.05 {
        return Err(input(
            &dec.images[0],
            format!(
                "only {:.1} % of the reference images decode to a valid phase",
                100.0 * dec.valid_fraction
            ),
        ));
    }
    let pf = PatternSetFile::load(patterns)?;
    let set = pf.to_pattern_set()?;
    // With the full projector model: the plane from the fringes, against the pose used, and
    // the plate's flatness.
    let physical = match &calibration.projector {
        Some(proj) => {
            let f = fit_physical(
                &calibration.camera,
                proj,
                &set,
                &dec.phase,
                (dec.width as usize, dec.height as usize),
                (pose.point.to_array(), pose.normal.to_array()),
            )
            .map_err(|e| input(&dec.images[0], format!("the reference plate: {e}")))?;
            if let Some(limit) = opts.flatness_limit_mm {
                f.check_flat(limit)
                    .map_err(|e| input(&dec.images[0], format!("the reference plate: {e}")))?;
            }
            if f.angle_deg > MAX_POSE_ANGLE_DEG || f.offset_mm.abs() > MAX_POSE_OFFSET_MM {
                return Err(input(
                    &dec.images[0],
                    format!(
                        "the fringes put the reference plane {:+.3} mm and {:.3} degrees away from the pose {} (limits {MAX_POSE_OFFSET_MM} mm, {MAX_POSE_ANGLE_DEG} degrees): the plate was moved or tilted away from it, or the board does not lie on it",
                        f.offset_mm,
                        f.angle_deg,
                        match plane {
                            PlaneSource::Board { .. } => "of the board images",
                            PlaneSource::Given { .. } => "given",
                        }
                    ),
                ));
            }
            Some(f)
        }
        None => None,
    };
    let (map, fit) = match source {
        MapSource::Raw => (dec.phase, None),
        MapSource::Model => {
            let mut f = fit_reference(&set, &dec.phase, dec.width as usize, dec.height as usize)
                .map_err(|e| {
                    input(
                        &dec.images[0],
                        format!("the reference images do not give a reference model: {e}"),
                    )
                })?;
            (std::mem::take(&mut f.phase), Some(f))
        }
    };
    let plane = (pose.point.to_array(), pose.normal.to_array());
    let (map, margin, seam_rad) = super::reference_margin::capture_map(
        calibration,
        &set,
        map,
        (plane, physical.as_ref().map(|f| (f.point, f.normal))),
        fit.is_some(),
        opts.margin,
    )
    .map_err(|m| input(&dec.images[0], m))?;
    let size = (
        dec.width + margin.left + margin.right,
        dec.height + margin.top + margin.bottom,
    );
    // The sensor's noise as these captures show it: the decoder's floor for later scans.
    let measured;
    let calibration = match dec.sensor {
        Some(s) => {
            measured = Calibration {
                sensor: Some(s),
                ..calibration.clone()
            };
            &measured
        }
        None => calibration,
    };
    let (cal, map_path) = write_reference(
        calibration,
        out,
        pf,
        map_name,
        (size.0, size.1, &map),
        plane,
        margin,
    )?;
    Ok(ReferenceRun {
        plane: pose,
        calibration: cal,
        map_path,
        valid_fraction: dec.valid_fraction,
        fit,
        physical,
        margin,
        seam_rad,
    })
}

/// Read a float phase map (TIFF).
pub fn read_phase_map(path: &Path) -> Result<(u32, u32, Vec<f32>), CalibError> {
    let (g, _) = read_gray(path)?;
    match g.pixels {
        Pixels::F32(v) => Ok((g.width, g.height, v)),
        _ => Err(input(path, "not a 32-bit float image")),
    }
}

/// Why a binary set cannot be decoded with a calibration that has no `projector_defocus`.
pub const BINARY_NEEDS_DEFOCUS: &str = "the pattern set is binary: decoding it needs the \
     projector's effective blur, `projector_defocus = SIGMA` (projector pixels) in the \
     calibration (docs/binary.md)";

/// The decoder's phase-error table for `set`: for a binary set, its model under the projector's
/// `defocus` (required: [`binary_correction`](crate::response::binary::binary_correction); two
/// codes need no response correction); otherwise under the measured `response`, and with the
/// projector's `defocus` when the calibration states it
/// ([`light_table`](crate::response::binary::light_table)): `None` without a response, for a
/// linear one, or when the set file's patterns were written pre-distorted
/// (`[projector] response_compensated = true`), whose light needs no correction.
pub fn response_table_for(
    file: &PatternSetFile,
    set: &PatternSet,
    response: Option<&ProjectorResponse>,
    defocus: Option<f64>,
) -> Result<Option<PhaseCorrection>, String> {
    if set.binarization().is_binary() {
        let Some(sigma) = defocus else {
            return Err(BINARY_NEEDS_DEFOCUS.into());
        };
        return Ok(Some(
            crate::response::binary::binary_correction(set, sigma)?.0,
        ));
    }
    match (response, defocus) {
        (Some(r), _) if r.is_linear() || file.projector.response_compensated == Some(true) => {
            Ok(None)
        }
        // With the projector's blur known, the table models it too: it attenuates the
        // harmonics the response makes (docs/gamma.md).
        (Some(r), Some(sigma)) => Ok(Some(
            crate::response::binary::light_table(set, sigma, Some(r))?.0,
        )),
        (Some(r), None) => Ok(Some(crate::response::table::phase_correction(set, r)?.0)),
        (None, _) => Ok(None),
    }
}
