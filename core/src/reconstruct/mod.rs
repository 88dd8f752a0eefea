//! Point-cloud construction by the hybrid method of paper §6 (eqs 16-18), streaming row by row.
//!
//! # Inputs
//! - the camera model ([`CameraModel`], eqs 1-4), with the camera centre C at the origin;
//! - the projector centre P (camera frame, mm);
//! - the absolute phase map Φ_R of a reference plane, its point O_R and normal n_R;
//! - the projector axis the phase is monotonic in ([`Axis`]);
//! - the depth range `[z_min, z_max]` (camera z, mm) of the measurement volume.
//!
//! # Per pixel (paper §6)
//! For a pixel `(u, v)` with object phase Φ, let `m = (x, y)` be its ideal normalized coordinates
//! (the point M_I on the image plane z = +1 — the paper's plane is z = −1, see [`crate::camera`]).
//! 1. **Search** (§6 step 1, Fig. 7). N_I lies on the epipolar line P_I–M_I. We write it
//!    `N_I = m + t·e` with `e = (P_x − P_z·x, P_y − P_z·y)`, which points from M_I towards the
//!    epipole P_I and stays finite when P_I is at infinity (P_z = 0). The reference phase is sampled
//!    at the *distorted* pixel position of `m + t·e` by bilinear interpolation of Φ_R, and we look
//!    for `Φ_R(t) = Φ` with `t` restricted to the depth range. Along that line the phase is
//!    monotonic (§5.1), so the crossing is unique.
//! 2. **Triangulation** (eqs 16-18). With `a = n_R·(x, y, 1)`, `h_R = n_R·O_R` and
//!    `H = n_R·(O_R − P)`, eliminating M_R, N_R (eq 16) and Q (eq 17) from eq 18 gives the depth
//!    of M along the ray `(x, y, 1)` in closed form:
//!    ```text
//!    M = s·(x, y, 1),    s = h_R·(1 − P_z·t) / (a − (a·P_z + H)·t)
//!    ```
//!    (at `t = 0`, N_I = M_I and `s = h_R/a`: M = M_R.) This is algebraically identical to eqs
//!    16-18 — [`triangulate_eq16_18`] evaluates them literally in f64 for comparison — but it needs no
//!    square roots and keeps its precision in f32: every quantity is either O(1) or proportional to
//!    the offset `t`, so nothing cancels. Conversely `t(z) = (z·a − h_R) / ((z·a − h_R)·P_z + H·z)`
//!    maps the depth range to the search interval.
//!
//! # Search, with fixed iteration counts
//! *Fast path*, for every pixel independently (so a row vectorizes and rows are independent):
//! start at `t₀ = 0` (the pixel itself: the reference sample there needs no interpolation), take a
//! first step with the slope of Φ_R at the pixel (central differences, over ±8 columns along the
//! row where those samples are valid, else ±1, to keep phase noise out of the step; projected on
//! the epipolar direction through the distortion Jacobian), then [`NEWTON_EVALS`] (= 2)
//! interpolated evaluations, each followed by a Newton step (every step but the last clamped to
//! the depth interval). The Newton slope is that of the bilinear interpolant in the sampled cell
//! along the search line (the cell's gradient times the derivative of the sample offset in `t`):
//! the interpolant is linear within a cell up to its small twist term, so a step taken inside the
//! crossing's cell lands on the crossing whatever the phase noise, where a secant across cells
//! would carry the cells' slope differences (a few % with 0.01 rad of noise). A flat cell or an
//! invalid sample gives no slope, and an infinite or NaN step that is never accepted. The final,
//! unevaluated step gives the answer; it is accepted if it is below [`ACCEPT_LAST_STEP_PX`], it
//! lies in the depth interval, and every sample was valid.
//! *Stage 2*, for lanes the fast path did not settle (a far crossing on a curved or noisy phase):
//! one more evaluation and Newton step, same acceptance.
//! *Fallback*, for the remaining few (invalid reference on the way, crossing outside the depth
//! range or the image): the ends of the depth interval are sampled; a phase outside them is
//! [`Validity::OutOfDepth`]; otherwise the closest valid bracket is bisected a fixed number of times
//! ([`Reconstructor::fallback_bisections`], from the longest segment) and polished by two
//! regula-falsi steps. Every stage has a fixed count, so the work per pixel is bounded
//! (≤ 1 + 2 + 1 + 2 + bisections + 2 samples).
//!
//! Samples are taken in coordinates relative to the pixel: the distorted offset
//! `D(m + t·e) − D(m)` is computed in a difference form that stays exact to f32 rounding of the
//! offset itself (a polynomial in `t` whose per-pixel coefficients are computed once, in the
//! first pass), and the integer and fractional parts of the pixel position are split without
//! rounding, so the crossing is found to ~1e-5 px although absolute pixel coordinates carry
//! ~1e-4 px of f32 rounding.
//!
//! # Streaming
//! Reconstructing row `v` reads only reference rows `v − above ..= v + below` ([`Band`]), which
//! [`Reconstructor::new`] computes from the calibration and depth range (every search segment of
//! the image, in distorted pixel coordinates, plus the bilinear neighbour and a one-row margin).
//! They live in a [`ReferenceRing`] over caller buffers; [`ReferenceMap`] is the whole map for
//! batch use. Both present the same rows to the same kernel, so streaming and batch give the same
//! bits.
//!
//! # Memory on the head
//! For the default geometry (camera 1280 × 1024, f ≈ 1500 px, moderate barrel distortion
//! k1 = −0.12; projector centre (200, −10, 5) mm; reference plane ≈ 700 mm; volume
//! 280 × 220 × 250 mm, z ∈ [575, 825] mm) the band is 7 rows above and 9 below (17 rows, measured by
//! the `band_and_ring` test): the ring needs 17 × 1280 × (4 + 1) B = 108 800 B (87 040 B of phase,
//! 21 760 B of validity). Per row in flight: object phase 5 120 B + validity 1 280 B, output
//! 3 × 4 × 1280 = 15 360 B + 1 280 B (23 040 B). The [`Reconstructor`] is 336 B and holds no
//! per-pixel table. The row kernel's stack is ≈ 13 KiB (the row's undistortion knots 4 KiB, the
//! band's row table 2 KiB, one chunk of [`LANES`] pixels ≈ 7 KiB). Total ≈ 145 KiB of the
//! 256 KiB SRAM. The band grows with the epipolar lines' bow (lens distortion) and tilt; a
//! vertical baseline with horizontal fringes needs ≈ 170 rows (host only).
//!
//! [`Reconstructor::new`] samples the image on a 16-pixel grid in f64 (camera check and band
//! analysis, ≈ 10⁴ inverses and 10⁵ projections): fast on a desktop, seconds in soft-float f64 on
//! a Cortex-M4; run it where the calibration is made, or once at boot.
//!
//! # Speed
//! The fast path is a fixed sequence of vectorizable passes over [`LANES`] pixels (geometry and
//! the offset polynomials, two sample positions, bilinear gathers, Newton updates,
//! triangulation). The gathers' storage indices are computed in the vector passes from a formula
//! for the band's row offsets (rows `width` apart with at most one wrap: always true for
//! [`ReferenceMap`] and [`ReferenceRing`]; other [`ReferenceRows`] layouts are looked up row by
//! row, with the same loads and bits). The loads themselves go through a [`CellGather`]
//! ([`Reconstructor::reconstruct_row_gather`]): [`ScalarGather`] here, one load per sample; a
//! host may read each adjacent pair as one 64-bit element (`fringe3d::gather` does, with AVX2
//! and AVX-512), the same values and bits with half the gathered elements. The scalar
//! fallback loop is skipped for chunks that have no lane left; when at least 4 lanes of a chunk
//! need stage 2 it runs as a vector pass over the chunk, and likewise the fallback's samples at
//! the ends of the depth interval (the same operations per lane as the scalar code, so the same
//! bits whichever runs). Everything on it is
//! `#[inline(always)]`, so a host may wrap [`Reconstructor::reconstruct_row`] in a
//! `#[target_feature(enable = "avx2")]` function and get 8-wide code with the same bits (tested
//! in the benchmark).

mod gather;
mod kernel;

pub use gather::{CellGather, ScalarGather};
pub use kernel::{LANES, MAX_BAND_ROWS};

use crate::camera::CameraModel;
use crate::geometry::{Plane, Vec3};
use crate::math::CANONICAL_NAN;
use crate::phase_function::Axis;
use crate::validity::Validity;

/// Interpolated evaluations of the fast path (the first at the slope-guided step from the pixel
/// itself), each followed by a Newton step with the slope of the interpolated reference there.
pub const NEWTON_EVALS: usize = 2;
/// Fast-path acceptance: largest last (unevaluated) Newton step, pixels. Within a bilinear cell
/// the interpolant along the search line is nearly linear, so Newton lands on its crossing; a
/// last step that crosses into the next cell errs by the step times the slope's relative change
/// between the cells (a few % with 0.01 rad of phase noise): 3e-3 px keeps that near 1e-4 px
/// (≈ 0.2 µm of depth).
pub const ACCEPT_LAST_STEP_PX: f32 = 3e-3;

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

/// Why a reconstructor could not be built or run.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ReconstructError {
    /// A setup value is NaN or infinite.
    NotFinite,
    /// The depth range does not satisfy `0 < z_min < z_max`.
    DepthRange,
    /// The reference plane has a zero normal, passes (nearly) through the camera centre, or some
    /// pixel's ray does not meet it in front of the camera.
    ReferencePlane,
    /// The projector centre is at the camera centre or on the reference plane, or the projector ray
    /// of a point in the depth range runs parallel to the reference plane (eq 18 degenerates).
    ProjectorCentre,
    /// At this pixel the epipolar line is more than 45° away from the phase axis (x for
    /// [`Axis::Xi`], y for [`Axis::Eta`]): the phase would hardly change along it, or the epipole
    /// is in the image.
    AxisMismatch {
        /// Pixel column.
        u: u32,
        /// Pixel row.
        v: u32,
    },
    /// The band the geometry needs exceeds [`MAX_BAND_ROWS`].
    BandTooLarge {
        /// Rows needed.
        rows: u32,
    },
    /// The ring has fewer rows than the band needs.
    BandTooSmall {
        /// Rows needed.
        needed: u32,
        /// Rows the buffers hold.
        given: u32,
    },
    /// A buffer is shorter than its width × rows, or the phase and validity buffers disagree.
    BufferTooSmall,
    /// A row or a map has the wrong length for the image width/size.
    Length,
    /// The row index is outside the image.
    Row,
    /// A reference row needed for this row is not in the ring (not pushed yet, or overwritten).
    NotResident {
        /// The missing reference row.
        row: u32,
    },
    /// Every row of the image has already been pushed into the ring.
    Sequence,
}

/// Coarse classes of [`ReconstructError`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ReconstructErrorKind {
    /// The calibration or depth range cannot be used (at set-up).
    Setup,
    /// Buffers or rows do not fit the image.
    Argument,
    /// Rows were pushed or requested out of order.
    Stream,
}

impl ReconstructError {
    /// The coarse class of the error.
    pub fn kind(&self) -> ReconstructErrorKind {
        match self {
            Self::NotFinite
            | Self::DepthRange
            | Self::ReferencePlane
            | Self::ProjectorCentre
            | Self::AxisMismatch { .. }
            | Self::BandTooLarge { .. }
            | Self::BandTooSmall { .. } => ReconstructErrorKind::Setup,
            Self::BufferTooSmall | Self::Length | Self::Row => ReconstructErrorKind::Argument,
            Self::NotResident { .. } | Self::Sequence => ReconstructErrorKind::Stream,
        }
    }
}

impl core::fmt::Display for ReconstructError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::NotFinite => f.write_str("a reconstruction set-up value is NaN or infinite"),
            Self::DepthRange => f.write_str("depth range must satisfy 0 < z_min < z_max"),
            Self::ReferencePlane => f.write_str(
                "reference plane: zero normal, through the camera centre, or not in front of every pixel",
            ),
            Self::ProjectorCentre => f.write_str(
                "projector centre at the camera centre or on the reference plane, or degenerate triangulation in the depth range",
            ),
            Self::AxisMismatch { u, v } => write!(
                f,
                "at pixel ({u}, {v}) the epipolar line is more than 45 degrees from the phase axis"
            ),
            Self::BandTooLarge { rows } => {
                write!(f, "the geometry needs a band of {rows} reference rows (max {MAX_BAND_ROWS})")
            }
            Self::BandTooSmall { needed, given } => {
                write!(f, "reference ring holds {given} rows, the geometry needs {needed}")
            }
            Self::BufferTooSmall => f.write_str("buffer too small for width × rows"),
            Self::Length => f.write_str("row or map length differs from the image size"),
            Self::Row => f.write_str("row index outside the image"),
            Self::NotResident { row } => write!(f, "reference row {row} is not in the ring"),
            Self::Sequence => f.write_str("all reference rows have already been pushed"),
        }
    }
}

/// f32 constants of the per-pixel kernel.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Consts {
    pub nx: f32,
    pub ny: f32,
    pub nz: f32,
    pub h_r: f32,
    pub h: f32,
    pub px: f32,
    pub py: f32,
    pub pz: f32,
    pub z_min: f32,
    pub z_max: f32,
    pub fx: f32,
    pub fy: f32,
    pub sfx: f32,
    pub k: [f32; 5],
}

/// A reconstructor for one calibration and depth range: validated, with its band and constants.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Reconstructor {
    cam: CameraModel,
    setup: Setup,
    band: Band,
    c: Consts,
    bisections: u32,
    max_segment_px: f32,
}

/// Sampling grid of the set-up analysis (pixels) and samples per search segment.
const SETUP_GRID: u32 = 16;
const SETUP_SEGMENT_SAMPLES: u32 = 17;

impl Reconstructor {
    /// Validate the geometry against the camera and compute the band and the per-pixel constants.
    ///
    /// Checks, on a 16-pixel grid of the image (plus its last row and column): every ray meets the
    /// reference plane in front of the camera; the depth range maps to a finite search segment
    /// (no projector ray parallel to the reference plane); the epipolar line is within 45° of the
    /// phase axis; and the band of reference rows the segments need fits [`MAX_BAND_ROWS`].
    pub fn new(camera: &CameraModel, setup: &Setup) -> Result<Self, ReconstructError> {
        let s = setup;
        if !(s.projector_centre.is_finite()
            && s.reference_point.is_finite()
            && s.reference_normal.is_finite()
            && s.z_min.is_finite()
            && s.z_max.is_finite())
        {
            return Err(ReconstructError::NotFinite);
        }
        if !(s.z_min > 0.0 && s.z_min < s.z_max) {
            return Err(ReconstructError::DepthRange);
        }
        let plane = Plane::new(s.reference_point, s.reference_normal)
            .ok_or(ReconstructError::ReferencePlane)?;
        let mut n = plane
            .normal
            .normalized()
            .ok_or(ReconstructError::ReferencePlane)?;
        let mut h_r = n.dot(plane.point);
        if h_r < 0.0 {
            n = n.scale(-1.0);
            h_r = -h_r;
        }
        if !(h_r > 1e-3 * s.z_min) {
            return Err(ReconstructError::ReferencePlane);
        }
        let p = s.projector_centre;
        let h = h_r - n.dot(p);
        if !(p.norm() > 1e-6 * s.z_max) || !(libm::fabs(h) > 1e-6 * s.z_max) {
            return Err(ReconstructError::ProjectorCentre);
        }
        let i = camera.params();
        let c = Consts {
            nx: n.x as f32,
            ny: n.y as f32,
            nz: n.z as f32,
            h_r: h_r as f32,
            h: h as f32,
            px: p.x as f32,
            py: p.y as f32,
            pz: p.z as f32,
            z_min: s.z_min as f32,
            z_max: s.z_max as f32,
            fx: i.fx as f32,
            fy: i.fy as f32,
            sfx: (i.skew * i.fx) as f32,
            k: {
                let d = camera.distortion();
                [
                    d.k1 as f32,
                    d.k2 as f32,
                    d.p1 as f32,
                    d.p2 as f32,
                    d.k3 as f32,
                ]
            },
        };
        let (band, max_segment_px) = analyse(camera, s, n, h_r, h)?;
        if band.rows() > MAX_BAND_ROWS as u32 {
            return Err(ReconstructError::BandTooLarge { rows: band.rows() });
        }
        // Bisection steps bringing the longest segment below a quarter pixel.
        let mut bisections = 0u32;
        let mut len = max_segment_px;
        while len > 0.25 && bisections < 30 {
            len *= 0.5;
            bisections += 1;
        }
        Ok(Reconstructor {
            cam: *camera,
            setup: *s,
            band,
            c,
            bisections,
            max_segment_px: max_segment_px as f32,
        })
    }

    /// The camera model.
    pub fn camera(&self) -> &CameraModel {
        &self.cam
    }

    /// The geometry this reconstructor was built for.
    pub fn setup(&self) -> &Setup {
        &self.setup
    }

    /// The band of reference rows a row needs.
    pub fn band(&self) -> Band {
        self.band
    }

    /// Image width, pixels.
    pub fn width(&self) -> usize {
        self.cam.width() as usize
    }

    /// Image height, pixels.
    pub fn height(&self) -> usize {
        self.cam.height() as usize
    }

    /// The longest search segment (depth range) over the image, distorted pixels.
    pub fn max_segment_px(&self) -> f32 {
        self.max_segment_px
    }

    /// Bisection steps of the fallback search (fixed by the longest segment).
    pub fn fallback_bisections(&self) -> u32 {
        self.bisections
    }

    /// Bytes of a ring of `rows` rows for this image width: `rows × width × (4 + 1)`.
    pub fn ring_bytes(&self, rows: u32) -> usize {
        (rows as usize)
            .saturating_mul(self.width())
            .saturating_mul(5)
    }

    /// Reference rows `first..=last` that row `v` reads (clipped to the image).
    pub fn rows_needed(&self, v: u32) -> (u32, u32) {
        let h = self.cam.height();
        (
            v.saturating_sub(self.band.above),
            (v.saturating_add(self.band.below)).min(h - 1),
        )
    }

    /// Reconstruct row `v` (paper §6): for each pixel `u`, the point M (x, y, z in mm, camera
    /// frame) into `out_xyz[3u..3u+3]` and its [`Validity`] code into `out_validity[u]`.
    ///
    /// `phase_row` and `validity_row` are the decoder's output for row `v` (absolute phase,
    /// increasing with ξ or η). A pixel whose input code is not `Valid` keeps its code (unknown
    /// codes and non-finite phases marked `Valid` become [`Validity::PhaseOutOfRange`]); a pixel
    /// whose phase is not found gets [`Validity::NoCrossing`], [`Validity::OutOfDepth`],
    /// [`Validity::ReferenceInvalid`] or [`Validity::Degenerate`]. Every invalid pixel's point is
    /// the canonical NaN. `reference` must hold the rows [`Reconstructor::rows_needed`] returns.
    ///
    /// Always inlined with its kernel: a host may call it from a `#[target_feature(enable =
    /// "avx2")]` function to get 8-wide vectors; the results are the same bits (no FMA is enabled
    /// or contracted).
    #[inline(always)]
    pub fn reconstruct_row<R: ReferenceRows + ?Sized>(
        &self,
        reference: &R,
        v: u32,
        phase_row: &[f32],
        validity_row: &[u8],
        out_xyz: &mut [f32],
        out_validity: &mut [u8],
    ) -> Result<(), ReconstructError> {
        let (p, q) = (phase_row, validity_row);
        self.reconstruct_row_gather(ScalarGather, reference, v, p, q, out_xyz, out_validity)
    }

    /// [`Reconstructor::reconstruct_row`] with the reference samples fetched by `gather` (a
    /// host's wider gather, e.g. AVX-512 pairs): the same bits as [`ScalarGather`], which
    /// `reconstruct_row` uses.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    pub fn reconstruct_row_gather<R: ReferenceRows + ?Sized, G: CellGather>(
        &self,
        gather: G,
        reference: &R,
        v: u32,
        phase_row: &[f32],
        validity_row: &[u8],
        out_xyz: &mut [f32],
        out_validity: &mut [u8],
    ) -> Result<(), ReconstructError> {
        self.row_impl(
            gather,
            reference,
            v,
            phase_row,
            validity_row,
            out_xyz,
            out_validity,
            None,
        )
    }

    /// [`Reconstructor::reconstruct_row`], also writing each pixel's crossing N_I as ideal
    /// normalized coordinates `(x, y)` into `crossings[2u..2u+2]` (canonical NaN where there is
    /// none). For diagnostics and tests; the points are the same bits.
    #[allow(clippy::too_many_arguments)]
    pub fn reconstruct_row_with_crossings<R: ReferenceRows + ?Sized>(
        &self,
        reference: &R,
        v: u32,
        phase_row: &[f32],
        validity_row: &[u8],
        out_xyz: &mut [f32],
        out_validity: &mut [u8],
        crossings: &mut [f32],
    ) -> Result<(), ReconstructError> {
        if crossings.len() != 2 * self.width() {
            return Err(ReconstructError::Length);
        }
        self.row_impl(
            ScalarGather,
            reference,
            v,
            phase_row,
            validity_row,
            out_xyz,
            out_validity,
            Some(crossings),
        )
    }

    /// Whole-frame batch: [`Reconstructor::reconstruct_row`] for every row, with the whole
    /// reference map. Same bits as streaming. `phase`/`validity` are `width × height` row-major,
    /// `out_xyz` is `3 × width × height`, `out_validity` `width × height`.
    pub fn reconstruct_frame(
        &self,
        reference: &ReferenceMap<'_>,
        phase: &[f32],
        validity: &[u8],
        out_xyz: &mut [f32],
        out_validity: &mut [u8],
    ) -> Result<(), ReconstructError> {
        let w = self.width();
        let n = w * self.height();
        if phase.len() != n
            || validity.len() != n
            || out_xyz.len() != 3 * n
            || out_validity.len() != n
        {
            return Err(ReconstructError::Length);
        }
        let rows = phase.chunks_exact(w).zip(validity.chunks_exact(w)).zip(
            out_xyz
                .chunks_exact_mut(3 * w)
                .zip(out_validity.chunks_exact_mut(w)),
        );
        for (v, ((p, q), (o, ov))) in rows.enumerate() {
            self.reconstruct_row(reference, v as u32, p, q, o, ov)?;
        }
        Ok(())
    }

    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn row_impl<R: ReferenceRows + ?Sized, G: CellGather>(
        &self,
        gather: G,
        reference: &R,
        v: u32,
        phase_row: &[f32],
        validity_row: &[u8],
        out_xyz: &mut [f32],
        out_validity: &mut [u8],
        crossings: Option<&mut [f32]>,
    ) -> Result<(), ReconstructError> {
        let w = self.width();
        if v >= self.cam.height() {
            return Err(ReconstructError::Row);
        }
        if phase_row.len() != w
            || validity_row.len() != w
            || out_xyz.len() != 3 * w
            || out_validity.len() != w
        {
            return Err(ReconstructError::Length);
        }
        if reference.width() != w || reference.height() != self.height() {
            return Err(ReconstructError::Length);
        }
        if reference.capacity_rows() < self.band.rows().min(self.cam.height()) {
            return Err(ReconstructError::BandTooSmall {
                needed: self.band.rows(),
                given: reference.capacity_rows(),
            });
        }
        let (first, last) = self.rows_needed(v);
        let data = reference.storage();
        let mut table = kernel::RefRows::new(data, first as i64, self.cam.height() as i64 - 1);
        for r in first..=last {
            let off = reference
                .row_offset(r)
                .ok_or(ReconstructError::NotResident { row: r })?;
            if data.get(off..off + w).is_none() {
                return Err(ReconstructError::BufferTooSmall);
            }
            table.set((r - first) as usize, off);
        }
        table.finish(w);
        kernel::row(
            gather,
            self,
            &table,
            v,
            phase_row,
            validity_row,
            out_xyz,
            out_validity,
            crossings,
        );
        Ok(())
    }

    pub(crate) fn consts(&self) -> &Consts {
        &self.c
    }

    pub(crate) fn bisection_count(&self) -> u32 {
        self.bisections
    }
}

/// Walk the image on a grid: check the geometry and measure the band and the longest segment.
fn analyse(
    cam: &CameraModel,
    s: &Setup,
    n: Vec3,
    h_r: f64,
    h: f64,
) -> Result<(Band, f64), ReconstructError> {
    let w = cam.width();
    let hgt = cam.height();
    let p = s.projector_centre;
    let (wf, hf) = ((w - 1) as f64, (hgt - 1) as f64);
    let mut above: i64 = 1;
    let mut below: i64 = 1;
    let mut max_len: f64 = 0.0;
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
                if !(q[0] >= 0.0 && q[0] <= wf && q[1] >= 0.0 && q[1] <= hf) {
                    continue; // outside the image: never sampled
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
    // One row of margin for the grid sub-sampling.
    let above = (above + 1).min(hgt as i64) as u32;
    let below = (below + 1).min(hgt as i64) as u32;
    Ok((Band { above, below }, max_len))
}

/// Where the kernel reads reference rows from: a [`ReferenceRing`] or a [`ReferenceMap`].
///
/// Rows are stored with every invalid sample replaced by the canonical NaN, so the kernel detects
/// invalid reference data by NaN propagation through the interpolation.
pub trait ReferenceRows {
    /// Image width.
    fn width(&self) -> usize;
    /// Image height.
    fn height(&self) -> usize;
    /// Rows the storage can hold at once.
    fn capacity_rows(&self) -> u32;
    /// All stored samples (NaN-encoded phase).
    fn storage(&self) -> &[f32];
    /// Where image row `r` starts in [`ReferenceRows::storage`], or `None` if it is not held.
    fn row_offset(&self, r: u32) -> Option<usize>;
    /// The stored phase of image row `r`, or `None` if it is not held.
    fn row(&self, r: u32) -> Option<&[f32]> {
        let o = self.row_offset(r)?;
        self.storage().get(o..o + self.width())
    }
}

/// Copy a reference row into storage, replacing invalid or non-finite samples by the canonical NaN.
fn encode_row(dst: &mut [f32], dst_validity: &mut [u8], phase: &[f32], validity: &[u8]) {
    for (((d, dv), &p), &q) in dst
        .iter_mut()
        .zip(dst_validity.iter_mut())
        .zip(phase)
        .zip(validity)
    {
        let ok = q == Validity::Valid as u8 && p.is_finite();
        *d = if ok { p } else { CANONICAL_NAN };
        *dv = if ok || q != Validity::Valid as u8 {
            q
        } else {
            Validity::PhaseOutOfRange as u8
        };
    }
}

/// A ring of reference rows over caller buffers, for streaming (push rows in order 0, 1, 2, …).
///
/// Holds the last `capacity` pushed rows; `capacity = phase.len() / width` must be at least
/// [`Band::rows`] (checked at construction). Row `r` lives in slot `r mod capacity`.
#[derive(Debug)]
pub struct ReferenceRing<'a> {
    phase: &'a mut [f32],
    validity: &'a mut [u8],
    width: usize,
    height: usize,
    capacity: u32,
    pushed: u32,
}

impl<'a> ReferenceRing<'a> {
    /// A ring for `recon`'s image over `phase` (f32 per sample) and `validity` (u8 per sample).
    /// Its capacity is `phase.len() / width` rows; fewer than the band needs is
    /// [`ReconstructError::BandTooSmall`]; a `validity` buffer shorter than the rows used is
    /// [`ReconstructError::BufferTooSmall`].
    pub fn new(
        recon: &Reconstructor,
        phase: &'a mut [f32],
        validity: &'a mut [u8],
    ) -> Result<Self, ReconstructError> {
        let width = recon.width();
        let height = recon.height();
        let capacity = (phase.len() / width).min(height) as u32;
        let needed = recon.band().rows().min(height as u32);
        if capacity < needed {
            return Err(ReconstructError::BandTooSmall {
                needed,
                given: capacity,
            });
        }
        if validity.len() < capacity as usize * width {
            return Err(ReconstructError::BufferTooSmall);
        }
        Ok(ReferenceRing {
            phase,
            validity,
            width,
            height,
            capacity,
            pushed: 0,
        })
    }

    /// Push the next reference row (row index [`ReferenceRing::rows_pushed`]).
    pub fn push_row(
        &mut self,
        phase_row: &[f32],
        validity_row: &[u8],
    ) -> Result<(), ReconstructError> {
        if phase_row.len() != self.width || validity_row.len() != self.width {
            return Err(ReconstructError::Length);
        }
        if self.pushed as usize >= self.height {
            return Err(ReconstructError::Sequence);
        }
        let slot = (self.pushed % self.capacity) as usize * self.width;
        let (Some(d), Some(dv)) = (
            self.phase.get_mut(slot..slot + self.width),
            self.validity.get_mut(slot..slot + self.width),
        ) else {
            return Err(ReconstructError::BufferTooSmall);
        };
        encode_row(d, dv, phase_row, validity_row);
        self.pushed += 1;
        Ok(())
    }

    /// Rows pushed so far (= the index of the next row).
    pub fn rows_pushed(&self) -> u32 {
        self.pushed
    }

    /// Forget all rows (start a new reference).
    pub fn reset(&mut self) {
        self.pushed = 0;
    }

    /// The stored validity codes of image row `r`, if held.
    pub fn validity_row(&self, r: u32) -> Option<&[u8]> {
        let slot = self.slot(r)?;
        self.validity.get(slot..slot + self.width)
    }

    fn slot(&self, r: u32) -> Option<usize> {
        if r < self.pushed && self.pushed - r <= self.capacity {
            Some((r % self.capacity) as usize * self.width)
        } else {
            None
        }
    }
}

impl ReferenceRows for ReferenceRing<'_> {
    fn width(&self) -> usize {
        self.width
    }
    fn height(&self) -> usize {
        self.height
    }
    fn capacity_rows(&self) -> u32 {
        self.capacity
    }
    fn storage(&self) -> &[f32] {
        self.phase
    }
    fn row_offset(&self, r: u32) -> Option<usize> {
        self.slot(r)
    }
}

/// The whole reference phase map, for the batch path.
#[derive(Clone, Copy, Debug)]
pub struct ReferenceMap<'a> {
    phase: &'a [f32],
    width: usize,
    height: usize,
}

impl<'a> ReferenceMap<'a> {
    /// Prepare a `width × height` map in place: every sample whose validity is not `Valid` or whose
    /// phase is not finite becomes the canonical NaN (the encoding [`ReferenceRing::push_row`]
    /// applies), so the kernel sees the same values as when streaming.
    pub fn prepare(
        phase: &'a mut [f32],
        validity: &[u8],
        width: usize,
        height: usize,
    ) -> Result<Self, ReconstructError> {
        let n = width.checked_mul(height).ok_or(ReconstructError::Length)?;
        if width == 0 || phase.len() != n || validity.len() != n {
            return Err(ReconstructError::Length);
        }
        for (p, &q) in phase.iter_mut().zip(validity) {
            if !(q == Validity::Valid as u8 && p.is_finite()) {
                *p = CANONICAL_NAN;
            }
        }
        Ok(ReferenceMap {
            phase,
            width,
            height,
        })
    }

    /// A view of a `width × height` map prepared before (by [`ReferenceMap::prepare`]: every
    /// sample finite or the canonical NaN), without copying or changing it, so one prepared map
    /// can serve any number of reconstructions at once. `Err(Length)` if the sizes disagree,
    /// `Err(NotFinite)` if a sample is neither finite nor the canonical NaN (not prepared).
    pub fn from_prepared(
        phase: &'a [f32],
        width: usize,
        height: usize,
    ) -> Result<Self, ReconstructError> {
        let n = width.checked_mul(height).ok_or(ReconstructError::Length)?;
        if width == 0 || phase.len() != n {
            return Err(ReconstructError::Length);
        }
        if phase
            .iter()
            .any(|p| !p.is_finite() && p.to_bits() != CANONICAL_NAN.to_bits())
        {
            return Err(ReconstructError::NotFinite);
        }
        Ok(ReferenceMap {
            phase,
            width,
            height,
        })
    }

    /// The prepared phase samples.
    pub fn phase(&self) -> &[f32] {
        self.phase
    }
}

impl ReferenceRows for ReferenceMap<'_> {
    fn width(&self) -> usize {
        self.width
    }
    fn height(&self) -> usize {
        self.height
    }
    fn capacity_rows(&self) -> u32 {
        self.height as u32
    }
    fn storage(&self) -> &[f32] {
        self.phase
    }
    fn row_offset(&self, r: u32) -> Option<usize> {
        if (r as usize) < self.height {
            Some(r as usize * self.width)
        } else {
            None
        }
    }
}

/// Eqs 16-18 evaluated literally in f64, for reference and host use: the point M for the pixel
/// whose ideal normalized coordinates are `m_i` (M_I) and the crossing `n_i` (N_I).
///
/// `M_R = C + (CO_R·n / CM_I·n)·CM_I` and `N_R` likewise (eq 16), `Q = C + (CP·n / CM_I·n)·CM_I`
/// (eq 17), `M = Q + |PQ||QM_R| / (|PQ + M_R N_R| |CM_I|) · CM_I` (eq 18), with C = 0 and
/// `CM_I = (x, y, 1)`. The magnitudes of eq 18 are right for every point in front of the plane
/// through P parallel to the reference plane. `None` when a denominator vanishes.
pub fn triangulate_eq16_18(setup: &Setup, m_i: [f64; 2], n_i: [f64; 2]) -> Option<Vec3> {
    let n = setup.reference_normal;
    let cm = Vec3::new(m_i[0], m_i[1], 1.0);
    let cn = Vec3::new(n_i[0], n_i[1], 1.0);
    let dm = cm.dot(n);
    let dn = cn.dot(n);
    if dm == 0.0 || dn == 0.0 {
        return None;
    }
    let m_r = cm.scale(setup.reference_point.dot(n) / dm);
    let n_r = cn.scale(setup.reference_point.dot(n) / dn);
    let p = setup.projector_centre;
    let q = cm.scale(p.dot(n) / dm);
    let pq = q.sub(p);
    let den = pq.add(n_r.sub(m_r)).norm() * cm.norm();
    if !(den > 0.0) {
        return None;
    }
    let m = q.add(cm.scale(pq.norm() * m_r.sub(q).norm() / den));
    if m.is_finite() { Some(m) } else { None }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_prepared_map_is_viewed_without_a_copy() {
        let mut phase = [1.0, f32::NAN, -f32::NAN, f32::INFINITY, 2.5, -0.0];
        let validity = [0, 0, 0, 0, Validity::ReferenceInvalid as u8, 0];
        let prepared: [u32; 6] = {
            let m = ReferenceMap::prepare(&mut phase, &validity, 3, 2).unwrap();
            core::array::from_fn(|i| m.phase()[i].to_bits())
        };
        let view = ReferenceMap::from_prepared(&phase, 3, 2).unwrap();
        assert!(core::ptr::eq(view.phase(), &phase[..]));
        assert!(view.phase().iter().map(|p| p.to_bits()).eq(prepared));
        assert_eq!(
            ReferenceMap::from_prepared(&phase, 2, 2).err(),
            Some(ReconstructError::Length)
        );
        let unprepared = [1.0, -f32::NAN, 2.0, 3.0];
        assert_eq!(
            ReferenceMap::from_prepared(&unprepared, 2, 2).err(),
            Some(ReconstructError::NotFinite)
        );
        let infinite = [1.0, f32::INFINITY, 2.0, 3.0];
        assert!(ReferenceMap::from_prepared(&infinite, 2, 2).is_err());
    }
}
