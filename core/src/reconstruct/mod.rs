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
//! range or the map): the ends of the depth interval are sampled; a phase outside them is
//! [`Validity::OutOfDepth`]; otherwise the closest valid bracket is bisected a fixed number of times
//! ([`Reconstructor::fallback_bisections`], from the longest segment) and polished by two
//! regula-falsi steps. When an end is off the map (or on invalid reference) and the valid samples
//! do not bracket the crossing, the interval is first clipped to the map: from the valid sample
//! nearest to that end, the same number of bisections on validity find where the map ends, and
//! the last valid sample joins the candidates. Every stage has a fixed count, so the work per
//! pixel is bounded (≤ 1 + 2 + 1 + 2 + 3 × bisections + 2 samples).
//!
//! # A map wider than the image
//! A point nearer than the reference plane has its reference crossing displaced along the
//! epipolar line, and near the image border that crossing can lie outside the image. The
//! reference map may therefore extend past the image by a [`Margin`]
//! ([`Reconstructor::with_margin`]; [`Reconstructor::margin_needed`] measures how far this
//! geometry's search segments reach). The kernel reads the map in its own coordinates (image
//! pixel `(u, v)` is map sample `(u + left, v + top)`); rings, maps and
//! [`Reconstructor::rows_needed`] count map rows. A map with margin comes from a model (a fitted
//! or virtual reference), since a capture ends at the image.
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
//!
//! # Files
//! | module | holds |
//! |---|---|
//! | `setup` | [`Setup`], [`Band`], the set-up analysis and the kernel's constants |
//! | `reconstructor` | [`Reconstructor`]: validation and accessors |
//! | `row` | the row API ([`Reconstructor::reconstruct_row`] and its variants, the frame) |
//! | `error` | [`ReconstructError`], [`ReconstructErrorKind`] |
//! | `reference_rows` | [`ReferenceRows`], [`ReferenceRing`], [`ReferenceMap`] |
//! | `kernel` | the per-chunk kernel: vector passes, stage 2, triangulation |
//! | `offset`, `cell`, `fallback` | the sample offset polynomial, one cell sample and the Newton step, the bracketed fallback |
//! | `refrows` | the band's row table as the kernel indexes it |
//! | `gather` | [`CellGather`], [`ScalarGather`] |
//! | `triangulate` | [`triangulate_eq16_18`] |
//! | [`compiled`] | the compiled reconstruction: one rational function of the phase per pixel |

mod cell;
pub mod compiled;
mod error;
mod fallback;
mod gather;
mod kernel;
mod offset;
mod reconstructor;
mod reference_rows;
mod refrows;
mod row;
mod setup;
mod triangulate;

pub use error::{ReconstructError, ReconstructErrorKind};
pub use gather::{CellGather, ScalarGather};
pub use reconstructor::Reconstructor;
pub use reference_rows::{ReferenceMap, ReferenceRing, ReferenceRows};
pub use setup::{Band, Margin, Setup, SetupAnalysis};
pub use triangulate::triangulate_eq16_18;

use crate::camera::ROW_KNOT_STEP;
#[cfg(doc)]
use crate::{camera::CameraModel, phase_function::Axis, validity::Validity};

/// A pixel's input to reconstruction, as the search and the compiled row both read it: whether
/// it is to be reconstructed (code `Valid` and a finite phase) and the code it keeps otherwise
/// (its own when that is a known code, [`Validity::PhaseOutOfRange`] for an unknown code or a
/// non-finite phase marked `Valid`). Branch-free, so a loop over a row vectorizes.
#[inline(always)]
pub(crate) fn input_code(q: u8, p: f32) -> (bool, u8) {
    use crate::math::fabs;
    let valid = crate::validity::Validity::Valid as u8;
    let act = (q == valid) & (fabs(p) < f32::INFINITY);
    let keep = act | (((q as usize) < crate::validity::Validity::ALL.len()) & (q != valid));
    let code = if keep {
        q
    } else {
        crate::validity::Validity::PhaseOutOfRange as u8
    };
    (act, code)
}

/// Interpolated evaluations of the fast path (the first at the slope-guided step from the pixel
/// itself), each followed by a Newton step with the slope of the interpolated reference there.
pub const NEWTON_EVALS: usize = 2;
/// Fast-path acceptance: largest last (unevaluated) Newton step, pixels. Within a bilinear cell
/// the interpolant along the search line is nearly linear, so Newton lands on its crossing; a
/// last step that crosses into the next cell errs by the step times the slope's relative change
/// between the cells (a few % with 0.01 rad of phase noise): 3e-3 px keeps that near 1e-4 px
/// (≈ 0.2 µm of depth).
pub const ACCEPT_LAST_STEP_PX: f32 = 3e-3;

/// Pixels per chunk of the row kernel (one knot span of the camera's row inverse).
pub const LANES: usize = ROW_KNOT_STEP;
/// Largest margin of the reference map past the image on any side ([`Margin`]), pixels: bounds
/// the map's memory, and keeps the lens model within a sane distance of the image it was
/// calibrated on.
pub const MAX_MARGIN: u32 = 1024;
/// Largest band of reference rows a reconstructor accepts.
pub const MAX_BAND_ROWS: usize = 512;
