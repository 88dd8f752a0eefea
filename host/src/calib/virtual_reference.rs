//! A virtual reference (issue #17 item 2): Φ_R of a plane computed from the full projector model,
//! for any pattern set, with no capture.
//!
//! Per sample of the map, at camera pixel centre (u, v) (the map may extend past the image by a
//! [`Margin`]: sample (i, j) is pixel (i − left, j − top)), in f64:
//!
//! 1. the ray `(x, y, 1)` of the camera lens (eqs 2-4 inverted: [`Lens::undistort`]);
//! 2. its point `X = s·(x, y, 1)` on the plane `n·(X − O) = 0`, `s = n·O / n·(x, y, 1) > 0`;
//! 3. in the projector frame `X_p = Rᵀ·(X − T)` ([`ProjectorParams`]: `X_cam = R·X_proj + T`);
//! 4. the projector pixel `(ξ, η)` of its lens (§4.2, the projector as an inverted camera);
//! 5. `Φ_R = c_K·Φ(ξ, η)`, the set's finest absolute phase there (eq 7,
//!    [`PatternSet::finest_phase`]), the quantity the decoder returns.
//!
//! NaN where the ray misses the plane, the point is behind the projector, or `(ξ, η)` falls off the
//! DMD (`[−0.5, W − 0.5] × [−0.5, H − 0.5]`), and within [`EDGE_GUARD_PX`] of such a sample (the
//! edge of the light, where decoded phases are biased). Every pixel is computed on its own with the same
//! operations, so the map is the same bits on every run and thread count.

use std::path::{Path, PathBuf};

use fringe3d_core::camera::CameraModel;
use fringe3d_core::params::{CameraParams, ProjectorParams, ScanGeometry};
use fringe3d_core::pattern::PatternSet;
use fringe3d_core::reconstruct::{Margin, Reconstructor};
use rayon::prelude::*;

use super::CalibError;
use super::lens::Lens;
use super::plane_projector::PlaneProjector;
pub use super::plane_projector::VirtualError;
use super::reference::ReferencePose;
use super::reference_write::write_reference;
use crate::io::calibration::Calibration;
use crate::io::pattern_file::PatternSetFile;
use crate::math::Vec3;

/// The virtual reference map of `set` on the plane through `point` with normal `normal` (camera
/// frame, mm), for `camera` and `projector`, extending `margin` past the image:
/// `(left + width + right) × (top + height + bottom)` phases, row-major.
pub fn virtual_reference(
    camera: &CameraParams,
    projector: &ProjectorParams,
    set: &PatternSet,
    (point, normal): ([f64; 3], [f64; 3]),
    margin: Margin,
) -> Result<Vec<f32>, VirtualError> {
    let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let nn = dot(normal, normal);
    let d = dot(normal, point);
    if !(nn > 0.0 && nn.is_finite() && d.is_finite() && d.abs() > 1e-9 * nn.sqrt()) {
        return Err(VirtualError::Plane);
    }
    let pp = PlaneProjector::new(projector)?;
    let cam = Lens::from_model(camera);
    let w = (camera.width + margin.left + margin.right) as usize;
    let h = (camera.height + margin.top + margin.bottom) as usize;
    let (l, t0) = (f64::from(margin.left), f64::from(margin.top));
    let mut map = vec![f32::NAN; w * h];
    map.par_chunks_mut(w.max(1))
        .enumerate()
        .for_each(|(j, row)| {
            for (i, out) in row.iter_mut().enumerate() {
                let (u, v) = (i as f64 - l, j as f64 - t0);
                if let Some(p) = cam
                    .undistort(u, v)
                    .and_then(|ray| pp.phase(set, ray, (normal, d)))
                {
                    *out = p as f32;
                }
            }
        });
    let map = erode_light_edge(&map, w, h, EDGE_GUARD_PX);
    if map.iter().all(|p| p.is_nan()) {
        return Err(VirtualError::Empty);
    }
    Ok(map)
}

/// Camera pixels of the virtual map dropped along the edge of the projector's light.
///
/// A camera pixel that straddles the edge of the light, or sits next to it, integrates lit and
/// dark (and the lens blur spreads the edge): its decoded phase is biased towards the edge, by
/// up to the pixel's footprint on the DMD. A captured reference carries the same bias and cancels
/// it; an exact virtual map does not, and a search that ends at the map's edge would turn such a
/// phase into a point millimetres off (measured: up to 2.5 mm at the light's edge of a 320 × 256
/// sphere scan, ~850 points, without this guard; none above the noise with it, and 2 px cost
/// 1 200 points more than 1 px). So the map keeps only samples whose neighbours within this
/// many pixels are lit too.
pub const EDGE_GUARD_PX: usize = 1;

/// `map` (w × h, NaN = unlit) with every sample that has a NaN within `r` samples (Chebyshev
/// distance) made NaN: the lit region eroded by `r`. Outside the map counts as lit (the map's
/// border is no edge of the light). Separable: rows, then columns.
fn erode_light_edge(map: &[f32], w: usize, h: usize, r: usize) -> Vec<f32> {
    let lit: Vec<bool> = map.iter().map(|p| p.is_finite()).collect();
    // Along rows: lit when every sample within ±r in the row is.
    let mut rows = vec![false; w * h];
    for v in 0..h {
        let src = &lit[v * w..(v + 1) * w];
        for u in 0..w {
            let (a, b) = (u.saturating_sub(r), (u + r).min(w - 1));
            rows[v * w + u] = src[a..=b].iter().all(|&l| l);
        }
    }
    let mut out = map.to_vec();
    for v in 0..h {
        for u in 0..w {
            let ok = (v.saturating_sub(r)..=(v + r).min(h - 1)).all(|k| rows[k * w + u]);
            if !ok {
                out[v * w + u] = f32::NAN;
            }
        }
    }
    out
}

/// The default plane of a virtual reference: perpendicular to the camera's axis at the far end of
/// the depth range (`z = depth_max`, normal towards the camera), so that the whole measurement
/// volume lies on one side of it and the projector's footprint on it is the largest.
pub fn default_plane(depth_range: [f64; 2]) -> ([f64; 3], [f64; 3]) {
    ([0.0, 0.0, depth_range[1]], [0.0, 0.0, -1.0])
}

/// The margin a reference map needs past the image for `calibration`'s camera, projector centre
/// and depth range with the reference on `plane`, for phases along the axis of `set`
/// ([`Reconstructor::margin_needed`]). `Err` with the reconstruction's reason when the geometry
/// cannot be reconstructed at all.
pub fn margin_needed(
    calibration: &Calibration,
    set: &PatternSet,
    plane: ([f64; 3], [f64; 3]),
) -> Result<Margin, String> {
    let cam = CameraModel::new(calibration.camera).map_err(|e| format!("camera: {e:?}"))?;
    let g = ScanGeometry {
        projector_centre: calibration.projector_centre,
        plane_point: plane.0,
        plane_normal: plane.1,
        depth_min: calibration.depth_range[0],
        depth_max: calibration.depth_range[1],
    };
    let r = Reconstructor::new(&cam, &g.setup(set.axis())).map_err(|e| e.to_string())?;
    Ok(r.margin_needed())
}

/// What [`virtual_reference_files`] wrote.
#[derive(Clone, Debug)]
pub struct VirtualRun {
    /// The calibration written.
    pub calibration: Calibration,
    /// The phase map written.
    pub map_path: PathBuf,
    /// The plane (point, normal towards the camera), camera frame, mm.
    pub plane: ([f64; 3], [f64; 3]),
    /// Fraction of the image's pixels with a phase (the plane lit by the DMD there).
    pub valid_fraction: f64,
    /// The map's margin past the image.
    pub margin: Margin,
}

/// `fringe3d calibrate reference --virtual`: compute the map of the pattern set in `patterns` on
/// `plane` (default [`default_plane`]) from `calibration`'s camera and `[projector]`, extending
/// `margin` past the image (`None`: the margin the geometry needs, [`margin_needed`]), and
/// write it with [`write_reference`] (map and `reference_patterns.toml` beside `out`, then
/// `out`).
pub fn virtual_reference_files(
    calibration: &Calibration,
    calibration_path: &Path,
    out: &Path,
    patterns: &Path,
    plane: Option<([f64; 3], [f64; 3])>,
    margin: Option<Margin>,
    map_name: &str,
) -> Result<VirtualRun, CalibError> {
    let err = |what: &Path, message: String| CalibError::Input {
        what: what.display().to_string(),
        message,
    };
    let projector = calibration.projector.as_ref().ok_or_else(|| {
        err(
            calibration_path,
            "no [projector] section (the full projector model: intrinsics, distortion, pose): a virtual reference needs it; capture the plane instead".into(),
        )
    })?;
    let pf = PatternSetFile::load(patterns)?;
    let set = pf.to_pattern_set()?;
    let (pw, ph) = (set.output().width, set.output().height);
    let lens = &projector.intrinsics;
    if (pw, ph) != (lens.width, lens.height) {
        return Err(err(
            patterns,
            format!(
                "patterns of {pw}x{ph}, but the calibration's projector is {}x{} ({})",
                lens.width,
                lens.height,
                calibration_path.display()
            ),
        ));
    }
    let (point, normal) = plane.unwrap_or_else(|| default_plane(calibration.depth_range));
    let pose = ReferencePose::given(Vec3::from_array(point), Vec3::from_array(normal)).ok_or_else(
        || {
            err(
                calibration_path,
                format!("virtual reference: {}", VirtualError::Plane),
            )
        },
    )?;
    let plane = (pose.point.to_array(), pose.normal.to_array());
    let margin = match margin {
        Some(m) => m,
        None => margin_needed(calibration, &set, plane).map_err(|m| {
            err(
                calibration_path,
                format!("virtual reference: the scan geometry with this plane: {m}"),
            )
        })?,
    };
    if margin
        .to_array()
        .iter()
        .any(|&m| m > fringe3d_core::reconstruct::MAX_MARGIN)
    {
        return Err(err(
            calibration_path,
            format!(
                "virtual reference: a margin of at most {} pixels per side, got {:?}",
                fringe3d_core::reconstruct::MAX_MARGIN,
                margin.to_array()
            ),
        ));
    }
    let map = virtual_reference(&calibration.camera, projector, &set, plane, margin)
        .map_err(|e| err(calibration_path, format!("virtual reference: {e}")))?;
    let (w, h) = (calibration.camera.width, calibration.camera.height);
    let (mw, mh) = (
        w + margin.left + margin.right,
        h + margin.top + margin.bottom,
    );
    // The lit fraction of the image itself (the margin aside).
    let valid = map
        .chunks(mw as usize)
        .skip(margin.top as usize)
        .take(h as usize)
        .map(|r| {
            r[margin.left as usize..(margin.left + w) as usize]
                .iter()
                .filter(|p| p.is_finite())
                .count()
        })
        .sum::<usize>();
    let (cal, map_path) = write_reference(
        calibration,
        out,
        pf,
        map_name,
        (mw, mh, &map),
        plane,
        margin,
    )?;
    Ok(VirtualRun {
        calibration: cal,
        map_path,
        plane,
        valid_fraction: valid as f64 / (w as usize * h as usize).max(1) as f64,
        margin,
    })
}
