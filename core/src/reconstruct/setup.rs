//! The geometry of a scan ([`Setup`]), the band of reference rows it needs ([`Band`]), and the
//! set-up analysis that validates it against the camera on a grid of pixels, plus the f32
//! constants the per-pixel kernel takes from it.

use super::MAX_MARGIN;
use super::error::ReconstructError;
use crate::camera::{CameraCheck, CameraModel};
use crate::geometry::Vec3;
use crate::params::ScanGeometry;
use crate::phase_function::Axis;

/// The geometry of a scan: everything §6 needs besides the camera model and the reference phase.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Setup {
    /// The projector's centre of projection P, camera frame, mm.
    pub projector_centre: Vec3,
    /// A point O_R of the reference plane, camera frame, mm.
    pub reference_point: Vec3,
    /// The normal n_R of the reference plane (any non-zero length, either orientation).
    pub reference_normal: Vec3,
    /// The projector axis the phase is monotonic in (Xi: vertical fringes).
    pub axis: Axis,
    /// Near end of the measurement volume, camera z, mm.
    pub z_min: f64,
    /// Far end of the measurement volume, camera z, mm.
    pub z_max: f64,
}

/// The reference rows needed around a row: `v − above ..= v + below` (clipped to the image).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Band {
    /// Rows above (smaller v).
    pub above: u32,
    /// Rows below (larger v).
    pub below: u32,
}

impl Band {
    /// Rows of the band: `above + below + 1`, the smallest ring that works.
    pub const fn rows(&self) -> u32 {
        self.above + self.below + 1
    }
}

/// How far the reference phase map extends past the image on each side, pixels (issue #17 item 3):
/// the map is `(left + width + right) × (top + height + bottom)` samples, its sample `(i, j)` at
/// image pixel `(i − left, j − top)`. A map wider than the image keeps the epipolar search of a
/// pixel near the image border on the map when its reference crossing lies outside the image (a
/// point near the camera); [`crate::reconstruct::Reconstructor::margin_needed`] measures the
/// margin a geometry needs.
///
/// On the wire (a phase-map upload, the head set-up blob) it is four varints in this order
/// (docs/device.md, docs/setup-blob.md).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct Margin {
    /// Columns left of column 0.
    pub left: u32,
    /// Rows above row 0.
    pub top: u32,
    /// Columns right of the last column.
    pub right: u32,
    /// Rows below the last row.
    pub bottom: u32,
}

impl Margin {
    /// No margin: the map covers the image exactly.
    pub const ZERO: Margin = Margin {
        left: 0,
        top: 0,
        right: 0,
        bottom: 0,
    };

    /// The same margin on every side.
    pub const fn uniform(px: u32) -> Margin {
        Margin {
            left: px,
            top: px,
            right: px,
            bottom: px,
        }
    }

    /// The margin as `[left, top, right, bottom]`.
    pub const fn to_array(self) -> [u32; 4] {
        [self.left, self.top, self.right, self.bottom]
    }

    /// A margin from `[left, top, right, bottom]`.
    pub const fn from_array(a: [u32; 4]) -> Margin {
        Margin {
            left: a[0],
            top: a[1],
            right: a[2],
            bottom: a[3],
        }
    }
}

/// What a reconstructor's set-up found: the costly part of building one from a calibration
/// ([`CameraModel::new`]'s checks of its inverse and [`Reconstructor::new`](super::Reconstructor::new)'s
/// band analysis, both in f64 over grids of the image, which a Cortex-M4F does in software:
/// 154 M instructions at 320 × 240, 1.66 G at 1280 × 1024). A desktop reads it off its
/// reconstructor ([`Reconstructor::analysis`](super::Reconstructor::analysis)) and ships it in
/// the head set-up blob (field 10), and the head builds the same camera model and reconstructor
/// from it ([`CameraModel::from_check`], [`Reconstructor::from_analysis`](super::Reconstructor::from_analysis))
/// without either. On the wire: the camera check (three f64), three varints and an f32, then the
/// reach (four varints).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SetupAnalysis {
    /// What the camera model's checks found ([`CameraModel::check`]): the other costly part
    /// of a reconstructor's set-up (its inverse over the image).
    pub camera: CameraCheck,
    /// Reference rows above a row the reconstruction reads ([`Band::above`]), for the map's
    /// margin.
    pub above: u32,
    /// Reference rows below ([`Band::below`]).
    pub below: u32,
    /// Bisection steps of the fallback search (from the longest segment).
    pub bisections: u32,
    /// The longest search segment over the image, distorted pixels.
    pub max_segment_px: f32,
    /// How far the search segments reach past the image
    /// ([`Reconstructor::margin_needed`](super::Reconstructor::margin_needed)).
    pub reach: Margin,
}

/// Most bisection steps of the fallback search.
pub(super) const MAX_BISECTIONS: u32 = 30;

impl SetupAnalysis {
    /// Whether every number is one an analysis can give: the band within
    /// [`MAX_BAND_ROWS`](super::MAX_BAND_ROWS), at most 30 bisections, a finite, non-negative
    /// segment length, a reach within [`MAX_MARGIN`] on every side.
    pub fn is_sane(&self) -> bool {
        if !self.camera.is_sane() {
            return false;
        }
        let rows = self
            .above
            .checked_add(self.below)
            .and_then(|r| r.checked_add(1));
        rows.is_some_and(|r| r <= super::MAX_BAND_ROWS as u32)
            && self.bisections <= MAX_BISECTIONS
            && self.max_segment_px.is_finite()
            && self.max_segment_px >= 0.0
            && self.reach.to_array().iter().all(|&m| m <= MAX_MARGIN)
    }
}

/// What the band analysis measures: the band of reference rows, the longest search segment
/// (distorted pixels), and how far the segments reach past the image.
pub(super) struct Analysis {
    pub(super) band: Band,
    pub(super) max_len: f64,
    pub(super) reach: Margin,
}

/// f32 constants of the per-pixel kernel.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Consts {
    pub(super) nx: f32,
    pub(super) ny: f32,
    pub(super) nz: f32,
    pub(super) h_r: f32,
    pub(super) h: f32,
    pub(super) px: f32,
    pub(super) py: f32,
    pub(super) pz: f32,
    pub(super) z_min: f32,
    pub(super) z_max: f32,
    pub(super) fx: f32,
    pub(super) fy: f32,
    pub(super) sfx: f32,
    pub(super) k: [f32; 5],
}

/// Sampling grid of the set-up analysis (pixels) and samples per search segment.
const SETUP_GRID: u32 = 16;
const SETUP_SEGMENT_SAMPLES: u32 = 17;

/// Walk the image on a grid: check the geometry and measure the band (over a reference map with
/// margin `m`), the longest segment and the segments' reach past the image.
pub(super) fn analyse(
    cam: &CameraModel,
    s: &Setup,
    n: Vec3,
    h_r: f64,
    h: f64,
    m: Margin,
) -> Result<Analysis, ReconstructError> {
    let w = cam.width();
    let hgt = cam.height();
    let p = s.projector_centre;
    let (wf, hf) = ((w - 1) as f64, (hgt - 1) as f64);
    // The map's extent in image pixel coordinates.
    let (u_lo, v_lo) = (-(m.left as f64), -(m.top as f64));
    let (u_hi, v_hi) = (wf + m.right as f64, hf + m.bottom as f64);
    let mut above: i64 = 1;
    let mut below: i64 = 1;
    let mut max_len: f64 = 0.0;
    // Farthest sample positions past each side of the image (pixels, ≥ 0).
    let mut reach = [0f64; 4];
    let grid =
        |len: u32| (0..=len.div_ceil(SETUP_GRID)).map(move |k| (k * SETUP_GRID).min(len - 1));
    for v in grid(hgt) {
        for u in grid(w) {
            let [x, y] = cam.pixel_to_normalized([u as f64, v as f64]);
            let a = n.x * x + n.y * y + n.z;
            if !(a > 1e-9) || !(h_r / a < 1e12) {
                return Err(ReconstructError::ReferencePlane);
            }
            let ex = p.x - p.z * x;
            let ey = p.y - p.z * y;
            let (along, across) = match s.axis {
                Axis::Xi => (ex, ey),
                Axis::Eta => (ey, ex),
            };
            if !(libm::fabs(along) > libm::fabs(across)) {
                return Err(ReconstructError::AxisMismatch { u, v });
            }
            let mut ts = [0.0f64; 2];
            for (k, z) in [s.z_min, s.z_max].into_iter().enumerate() {
                let num = z * a - h_r;
                let den = num * p.z + h * z;
                let t = num / den;
                // N_R must be in front of the camera: n·(N_I, 1) has the sign of h_R.
                let nn = n.x * (x + t * ex) + n.y * (y + t * ey) + n.z;
                if !(libm::fabs(den) > 1e-9 * (libm::fabs(num * p.z) + libm::fabs(h * z)))
                    || !t.is_finite()
                    || !(nn > 0.0)
                {
                    return Err(ReconstructError::ProjectorCentre);
                }
                ts[k] = t;
            }
            let mut prev: Option<[f64; 2]> = None;
            let mut len = 0.0;
            for k in 0..SETUP_SEGMENT_SAMPLES {
                let f = k as f64 / (SETUP_SEGMENT_SAMPLES - 1) as f64;
                let t = ts[0] + f * (ts[1] - ts[0]);
                let q = cam.normalized_to_pixel([x + t * ex, y + t * ey]);
                if let Some(pr) = prev {
                    let (du, dv) = (q[0] - pr[0], q[1] - pr[1]);
                    len += libm::sqrt(du * du + dv * dv);
                }
                prev = Some(q);
                if q[0].is_finite() && q[1].is_finite() {
                    reach[0] = reach[0].max(-q[0]);
                    reach[1] = reach[1].max(-q[1]);
                    reach[2] = reach[2].max(q[0] - wf);
                    reach[3] = reach[3].max(q[1] - hf);
                }
                if !(q[0] >= u_lo && q[0] <= u_hi && q[1] >= v_lo && q[1] <= v_hi) {
                    continue; // outside the map: never sampled
                }
                let r0 = libm::floor(q[1]) as i64;
                above = above.max(v as i64 - r0);
                below = below.max(r0 + 1 - v as i64);
            }
            if !len.is_finite() {
                return Err(ReconstructError::ProjectorCentre);
            }
            max_len = max_len.max(len);
        }
    }
    // One row of margin for the grid sub-sampling; no more rows than the map has.
    let map_h = hgt as i64 + m.top as i64 + m.bottom as i64;
    let above = (above + 1).min(map_h) as u32;
    let below = (below + 1).min(map_h) as u32;
    // The reach, plus the bilinear neighbour and two pixels for the grid sub-sampling, capped.
    let side = |r: f64| {
        let px = libm::ceil(r) + 3.0;
        if px > 3.0 {
            (px.min(MAX_MARGIN as f64)) as u32
        } else {
            0
        }
    };
    Ok(Analysis {
        band: Band { above, below },
        max_len,
        reach: Margin {
            left: side(reach[0]),
            top: side(reach[1]),
            right: side(reach[2]),
            bottom: side(reach[3]),
        },
    })
}

/// The conversions between the parameter vocabulary's geometry and the reconstruction's set-up
/// (here, so that `params` stays below `reconstruct`).
impl ScanGeometry {
    /// The reconstruction's set-up for phases monotonic along `axis` (the reconstructor checks
    /// it).
    pub fn setup(&self, axis: Axis) -> Setup {
        Setup {
            projector_centre: Vec3::from_array(self.projector_centre),
            reference_point: Vec3::from_array(self.plane_point),
            reference_normal: Vec3::from_array(self.plane_normal),
            axis,
            z_min: self.depth_min,
            z_max: self.depth_max,
        }
    }

    /// The geometry of a set-up (its axis aside).
    pub fn from_setup(s: &Setup) -> Self {
        ScanGeometry {
            projector_centre: s.projector_centre.to_array(),
            plane_point: s.reference_point.to_array(),
            plane_normal: s.reference_normal.to_array(),
            depth_min: s.z_min,
            depth_max: s.z_max,
        }
    }
}
