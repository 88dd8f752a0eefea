//! Building the compiled reconstruction ([`fringe3d_core::reconstruct::compiled`]): one
//! rational function of the phase per pixel, fitted to the reference map's geometry and checked
//! against the exact §6 search before it is kept.
//!
//! # How a pixel is compiled
//! 1. **Its phase along its ray (f64).** The pixel's ideal coordinates `m = (x, y)` (the camera's
//!    inverse), then for [`NODES`] depths `z_j` at the Chebyshev nodes of the depth range widened
//!    by [`WIDEN`] at each end: the crossing `N_I = m + t(z_j)·e` of §6 (module docs of
//!    [`fringe3d_core::reconstruct`]: `t(z) = (z·a − h_R)/((z·a − h_R)·P_z + H·z)`), its
//!    distorted pixel, and the bilinear value of the reference map there: `Φ_j`. Where the map
//!    (the projector's light) covers only part of the range along the ray, the range is clipped
//!    to its longest covered stretch and the model marked so ([`PixelModel::is_clipped`]); phases
//!    that are not strictly monotonic in depth leave the pixel to the search.
//! 2. **The fit (f64).** With `τ = (Φ − Φ_c)·k` mapping the widened range to `[−1, 1]` (Φ_c and
//!    k rounded to f32 first, so their rounding is part of the fit) and `ŝ = (z − z_c)/σ`, the
//!    linear least-squares problem `ŝ_j = Ĉ(τ_j) − γ·τ_j·ŝ_j` (a Möbius function times a
//!    polynomial Ĉ of degree [`TERMS`], Levy's linearization) gives γ and Ĉ; rewritten about
//!    `τ = 0` they are the kernel's `s_c`, `d₁…d₄` and `γ`.
//!    The f64 function is then checked against the map's bilinear phase (what the search reads)
//!    at points half a pixel apart along the pixel's search segment (evenly in its parameter t;
//!    every cell it crosses about twice, up to [`MAX_FIT_SAMPLES`]); a miss larger than the
//!    tolerance leaves the pixel to the search (after the unwidened range is tried).
//! 3. **The check (f32, the real kernels).** For [`CHECKS`] phases evenly spread over `τ ∈ [−1,
//!    1]` the whole row is run through the exact search ([`Reconstructor::reconstruct_row`]) and
//!    through [`compiled_row`]; a pixel is kept only if at every phase both give the same code
//!    and points within the tolerance (or the search's point lies within the tolerance of an end
//!    of the depth range, where a code may flip). Otherwise it is [`PixelModel::SEARCH`].
//!    A clipped model with the far rule is also run at the [`FAR_CHECKS`] phases beyond its
//!    τ_far ([`PixelModel::far`]), where both must say `NoCrossing`.
//!
//! Two proofs walk a pixel's whole search segment (its ends as the search takes them, lengthened
//! by 10⁻⁴ of it) against tables of what the search can read (`compiled/near.rs`):
//! - A pixel whose ray the map does not cover (step 1) is [`PixelModel::NO_REFERENCE`] instead
//!   of the search when no valid sample lies within [`NEAR_PX`] of any walked point (points at
//!   most [`PATH_STEP_PX`] apart: a bilinear sample reads samples within 1 px, and a walked
//!   point stands for the path within half a step plus the rounding to a sample): no sample the
//!   f32 search takes can be valid, and it answers [`Validity::ReferenceInvalid`] whatever the
//!   phase.
//! - A clipped model gets the far rule ([`PixelModel::far_is_no_crossing`]; otherwise its τ_far
//!   is +∞ and every phase beyond its range goes to the search) when the search's sample at one
//!   end of the segment is valid and at the other invalid, wherever within a quarter pixel of
//!   the end it is taken. Its τ_far is then the least `|τ|`, at least 1, whose phases, on both
//!   sides, lie beyond every value the search can read along the segment (the corners of the
//!   valid bilinear cells within a quarter pixel of a walk half a pixel apart) by a tenth of the
//!   largest spread of those cells ([`PixelModel::far`] says why that gives `NoCrossing`).
//!
//! Step 3 checks both at its phases.
//!
//! The tolerance ([`DEFAULT_TOLERANCE_MM`], 0.1 µm) bounds the f64 function against the f64
//! geometry the search reads, checked densely (step 2). Against the f32 search itself a point
//! may differ by the tolerance plus [`F32_ALLOWANCE_ULP`] units in the last place of the
//! coordinate: at 512–1024 mm one ulp is 61 nm, and the search and the function round
//! differently, so two f32 answers cannot agree to 0.1 µm everywhere.

mod file;
mod map_view;
mod near;
mod ray;
mod rows;

pub use file::{
    CompiledFile, FileError, HEADER, MAGIC, MAX_FILE_BYTES, source_digest, source_digest_of_files,
};
pub use rows::ModelFile;

use fringe3d_core::reconstruct::compiled::{
    FIELDS, LEFT_TO_SEARCH, PixelModel, TERMS, compiled_row,
};
use fringe3d_core::reconstruct::{Reconstructor, ReferenceMap};
use fringe3d_core::validity::Validity;
use map_view::MapView;
use near::Near;
use ray::Ray;
use rayon::prelude::*;

/// Depths a pixel's function is fitted to.
pub const NODES: usize = 16;
/// Phases a pixel is checked at against the search.
pub const CHECKS: usize = 33;
/// Phases beyond a clipped model's τ_far (as multiples of it, in τ; [`PixelModel::far`]) it is
/// also checked at: the search must give `NoCrossing` there, as the kernel does.
pub const FAR_CHECKS: [f64; 4] = [-3.0, -1.01, 1.01, 3.0];
/// The fitted depth range is the calibration's widened by this fraction of it at each end, so
/// that the function covers the search's whole range whatever its rounding.
pub const WIDEN: f64 = 0.005;
/// How far a clipped range's end is pulled in from the map's edge, as a fraction of the depth
/// range.
pub const CLIP_INSET: f64 = 0.002;
/// Units in the last place of a coordinate that the check allows on top of the tolerance: the
/// search in f32 lands within about 2 ulp of its f64 crossing, the function within 1–2 (one
/// ulp is 61 nm at 512–1024 mm), so two f32 answers to the same question differ by up to 4.
pub const F32_ALLOWANCE_ULP: f64 = 4.0;
/// Most depths a pixel's fit is checked at (half-pixel steps along its search segment).
pub const MAX_FIT_SAMPLES: usize = 4096;
/// Samples of [`fit_range`]'s dense check computed together (see there).
const FIT_CHUNK: usize = 32;
/// The reach (Chebyshev distance, pixels) of the no-reference proof: whether the search can
/// read a valid value near a walked point of a search segment is taken from every map sample
/// this near it (module documentation). A bilinear sample reads samples within 1 px, a walked point
/// stands for the path within half a [`PATH_STEP_PX`], and rounding it to a sample moves it by
/// half a pixel; one more for the f32 search's rounding and the path's bend between walked
/// points.
pub const NEAR_PX: usize = 4;
/// Largest distance between walked points of a search segment in the no-reference proof, pixels.
pub const PATH_STEP_PX: f64 = 2.0;
/// Default tolerance on each coordinate of a point, mm (0.1 µm).
pub const DEFAULT_TOLERANCE_MM: f64 = 1e-4;

/// Why a pixel was left to the search.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Reason {
    /// Compiled.
    Compiled,
    /// The map covers less than 1 % of its ray's depth range.
    OffMap,
    /// Its phase is not strictly monotonic in depth along the ray.
    NotMonotonic,
    /// The fit's system is singular.
    Singular,
    /// The function missed the search by more than the tolerance at a checked phase.
    Check,
}

/// What a build did.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct Report {
    /// Pixels.
    pub pixels: usize,
    /// Pixels with a function.
    pub compiled: usize,
    /// Compiled pixels whose range is clipped to the part of the depth range the map covers.
    pub clipped: usize,
    /// Clipped pixels for which the build showed that a phase far beyond the range (beyond their
    /// τ_far, [`PixelModel::far`]) gets the search's `NoCrossing`, and which answer it without
    /// the search.
    pub clipped_far: usize,
    /// Clipped pixels whose far rule the build proved but the search contradicted at a
    /// [`FAR_CHECKS`] phase: the rule is dropped (the model stays). Not zero means a proof's
    /// assumption does not hold: report it.
    pub far_rule_dropped: usize,
    /// Pixels whose whole search segment lies away from the map: they answer
    /// [`Validity::ReferenceInvalid`] without the search ([`PixelModel::NO_REFERENCE`]).
    pub no_reference: usize,
    /// Pixels left to the search because the map covers (almost) none of their depth range but
    /// is near their segment somewhere (or because their proof of no reference failed its
    /// check).
    pub off_map: usize,
    /// ... because their phase is not monotonic in depth (or the fit's system is singular).
    pub not_monotonic: usize,
    /// ... because the fit itself missed the tolerance at or between its nodes.
    pub fit_failed: usize,
    /// ... because the function missed the search at a checked phase.
    pub check_failed: usize,
    /// Kept pixels that differ from the search by more than the tolerance itself somewhere (but
    /// within it plus the f32 allowance).
    pub beyond_tolerance: usize,
    /// Kept clipped pixels where the search found no crossing at some checked phase inside the
    /// range (it gives up near the map's end) and the function's point matched the f64 crossing:
    /// there the compiled reconstruction gives a point the search does not.
    pub answered: usize,
    /// Largest difference, any coordinate, between the function and the search over the kept
    /// pixels' checked phases, mm.
    pub max_difference_mm: f64,
    /// Largest difference of the f64 function from its f64 nodes over the kept pixels, mm (the
    /// fit alone, without f32 rounding).
    pub max_fit_error_mm: f64,
    /// The tolerance the build used, mm.
    pub tolerance_mm: f64,
    /// Checked phases per pixel over its range (a clipped pixel with the far rule is also checked
    /// at the [`FAR_CHECKS`] phases, a pixel with no reference at all of them).
    pub checks: usize,
}

impl Report {
    /// Pixels left to the search, as a fraction of all.
    pub fn search_fraction(&self) -> f64 {
        let left = self.pixels - self.compiled - self.no_reference;
        left as f64 / self.pixels.max(1) as f64
    }
}

/// Compile every pixel of a reconstruction (rows in parallel) from its reconstructor and its
/// prepared reference map (`map_width × map_height`, invalid samples NaN, as
/// [`ReferenceMap::prepare`] leaves them; a scan's `ScanCalibration` holds both).
/// `tolerance_mm`: the largest difference from the search's geometry a kept pixel may have on any
/// coordinate.
pub fn compile(
    recon: &Reconstructor,
    reference_phase: &[f32],
    tolerance_mm: f64,
) -> (CompiledFile, Report) {
    let (w, h) = (recon.width(), recon.height());
    let (mw, mh) = (recon.map_width(), recon.map_height());
    let near = Near::new(reference_phase, mw, mh);
    let m = recon.margin();
    let cal = &Source {
        recon,
        map: MapView::new(reference_phase, mw, mh, m.left, m.top),
        near: &near,
    };
    // A prepared map (the scan's own): never fails for a loaded calibration; a map too small
    // to interpolate compiles nothing.
    let map = ReferenceMap::from_prepared(reference_phase, mw, mh)
        .ok()
        .filter(|_| mw >= 2 && mh >= 2 && w > 0);
    let mut models = vec![0f32; FIELDS * w * h];
    let rows: Vec<RowStats> = models
        .par_chunks_mut(FIELDS * w.max(1))
        .enumerate()
        .map(|(v, out)| {
            let mut st = RowStats::default();
            let mut row = vec![PixelModel::SEARCH; w];
            let mut fits = vec![f64::NAN; w];
            fit_row(cal, v, &mut row, &mut fits, tolerance_mm, &mut st);
            match &map {
                Some(map) => check_row(cal, map, v, &mut row, tolerance_mm, &mut st),
                // Never for a prepared map of the reconstructor's size; but no model is kept
                // unchecked.
                None => {
                    st.check_failed += row.iter().filter(|m| m.is_compiled()).count();
                    st.off_map += row.iter().filter(|m| m.is_no_reference()).count();
                    row.fill(PixelModel::SEARCH);
                }
            }
            // The fit's error over the pixels kept.
            for (m, f) in row.iter().zip(&fits) {
                if m.is_compiled() {
                    st.max_fit = st.max_fit.max(*f);
                }
            }
            for (u, m) in row.iter().enumerate() {
                let _ = m.store(out, u);
            }
            st
        })
        .collect();
    let mut rep = Report {
        pixels: w * h,
        tolerance_mm,
        checks: CHECKS,
        ..Report::default()
    };
    for st in rows {
        rep.off_map += st.off_map;
        rep.no_reference += st.no_reference;
        rep.far_rule_dropped += st.far_rule_dropped;
        rep.not_monotonic += st.not_monotonic;
        rep.check_failed += st.check_failed;
        rep.fit_failed += st.fit_failed;
        rep.beyond_tolerance += st.beyond_tolerance;
        rep.answered += st.answered;
        rep.max_difference_mm = rep.max_difference_mm.max(st.max_difference);
        rep.max_fit_error_mm = rep.max_fit_error_mm.max(st.max_fit);
    }
    let s = recon.setup();
    let file = CompiledFile {
        width: w as u32,
        height: h as u32,
        z_min: s.z_min as f32,
        z_max: s.z_max as f32,
        tolerance_mm: tolerance_mm as f32,
        source_digest: [0; 32],
        models,
    };
    rep.compiled = file.compiled_count();
    rep.clipped = file.clipped_count();
    rep.clipped_far = file.count(|m| m.far_is_no_crossing());
    (file, rep)
}

/// The f64 crossing of §6 for camera pixel `(u, v)` and phase `phase`: the depth, mm, where the
/// bilinear reference phase along the pixel's search segment equals it (60 bisections over the
/// longest stretch of the depth range the map covers along the ray), `None` where the ends of
/// that stretch do not bracket it. What the compiled function is fitted to, and a yardstick for
/// the f32 search (`reference_phase` as for [`compile`]).
pub fn crossing_depth_f64(
    recon: &Reconstructor,
    reference_phase: &[f32],
    u: usize,
    v: usize,
    phase: f64,
) -> Option<f64> {
    let near = Near::new(&[], 0, 0);
    let (mw, mh) = (recon.map_width(), recon.map_height());
    let m = recon.margin();
    let cal = Source {
        recon,
        map: MapView::new(reference_phase, mw, mh, m.left, m.top),
        near: &near,
    };
    if reference_phase.len() != mw * mh || u >= recon.width() || v >= recon.height() {
        return None;
    }
    let s = recon.setup();
    let ray = Ray::new(&cal, u, v);
    let (a, b) = ray.valid_run(s.z_min, s.z_max, 0.0)?;
    ray.depth_of(phase, a, b)
}

/// What a build reads: the reconstructor and its prepared map, and what the search can read near
/// each map sample ([`Near`]).
struct Source<'a> {
    recon: &'a Reconstructor,
    map: MapView<'a>,
    near: &'a Near,
}

#[derive(Default)]
struct RowStats {
    no_reference: usize,
    far_rule_dropped: usize,
    off_map: usize,
    not_monotonic: usize,
    check_failed: usize,
    beyond_tolerance: usize,
    answered: usize,
    fit_failed: usize,
    max_difference: f64,
    max_fit: f64,
}

/// Steps 1 and 2 for row `v` (module documentation); each kept pixel's fit error into `fits`.
fn fit_row(
    cal: &Source<'_>,
    v: usize,
    row: &mut [PixelModel],
    fits: &mut [f64],
    tol: f64,
    st: &mut RowStats,
) {
    // The kernel's own f32 rays (the search's, bit for bit), so that points differ only in depth.
    let w = row.len();
    let (mut xs, mut ys) = (vec![0f32; w], vec![0f32; w]);
    cal.recon
        .camera()
        .undistort_row_f32(v as u32, &mut xs, &mut ys);
    for (u, (m, f)) in row.iter_mut().zip(fits.iter_mut()).enumerate() {
        match fit_pixel(cal, u, v, tol) {
            // The fit itself, checked densely, must be within the tolerance (NaN is not).
            Ok((_, fit)) if !(fit <= tol) => st.fit_failed += 1,
            Ok((mut model, fit)) => {
                // A clipped model's τ_far where the far rule holds (+∞ otherwise).
                if model.is_clipped() {
                    model.far = Ray::new(cal, u, v)
                        .far_threshold(&model)
                        .unwrap_or(f32::INFINITY);
                }
                model.ray = [xs[u], ys[u]];
                *m = model;
                *f = fit;
            }
            Err(Reason::OffMap) if Ray::new(cal, u, v).away_from_map() => {
                *m = PixelModel::NO_REFERENCE;
            }
            Err(Reason::OffMap) => st.off_map += 1,
            Err(_) => st.not_monotonic += 1,
        }
    }
}

/// One pixel's model and its largest f64 fit error (mm, step 3): over the depth range widened by
/// [`WIDEN`] where that fits within `tol`, else over the range itself (a map whose margin ends
/// where the search's segments end), else, when the map does not cover the range, over the
/// longest part of it the map covers along the ray, clipped.
fn fit_pixel(cal: &Source<'_>, u: usize, v: usize, tol: f64) -> Result<(PixelModel, f64), Reason> {
    let ray = Ray::new(cal, u, v);
    let s = cal.recon.setup();
    let mut last = Err(Reason::OffMap);
    for widen in [WIDEN, 0.0] {
        let d = widen * (s.z_max - s.z_min);
        // The widened attempt is dropped unless it fits within `tol`: its check may stop at the
        // first error above it. The range's own attempt is checked to the end: a sample off the
        // map farther on sends the pixel to the clipped attempt below instead.
        let give_up = if widen > 0.0 { tol } else { f64::INFINITY };
        last = fit_range(&ray, s.z_min - d, s.z_max + d, false, give_up);
        if matches!(last, Ok((_, fit)) if fit <= tol) {
            return last;
        }
    }
    if !matches!(last, Err(Reason::OffMap)) {
        return last;
    }
    // An end at the map's edge is pulled in by CLIP_INSET: the search needs its samples'
    // neighbours there.
    let (lo, hi) = ray
        .valid_run(s.z_min, s.z_max, CLIP_INSET)
        .ok_or(Reason::OffMap)?;
    fit_range(&ray, lo, hi, true, f64::INFINITY)
}

/// Fit a pixel's model over depths `[z_lo, z_hi]` (steps 1 and 2). The dense check stops once
/// the fit error exceeds `give_up_above` (that error is returned; a caller that drops the model
/// then passes its tolerance, one that must know whether the segment leaves the map +∞).
fn fit_range(
    ray: &Ray<'_>,
    z_lo: f64,
    z_hi: f64,
    clipped: bool,
    give_up_above: f64,
) -> Result<(PixelModel, f64), Reason> {
    let (zc, sig) = (0.5 * (z_lo + z_hi), 0.5 * (z_hi - z_lo));
    // Chebyshev nodes in depth (increasing), and the ends.
    let mut zs = [0f64; NODES + 2];
    zs[0] = z_lo;
    zs[NODES + 1] = z_hi;
    for (j, z) in zs[1..=NODES].iter_mut().enumerate() {
        let c = (core::f64::consts::PI * (j as f64 + 0.5) / NODES as f64).cos();
        *z = zc - sig * c;
    }
    let mut ph = [0f64; NODES + 2];
    for (p_, z) in ph.iter_mut().zip(&zs) {
        *p_ = ray.phase_at(*z).ok_or(Reason::OffMap)?;
    }
    // The phases must be strictly monotonic in depth.
    let up = ph[NODES + 1] > ph[0];
    if !ph.windows(2).all(|q| (q[1] > q[0]) == up && q[1] != q[0]) {
        return Err(Reason::NotMonotonic);
    }
    let phase_centre = (0.5 * (ph[0] + ph[NODES + 1])) as f32;
    let k = (2.0 / (ph[NODES + 1] - ph[0]).abs()) as f32;
    let tau = |phi: f64| (phi - phase_centre as f64) * k as f64;
    let pts: Vec<(f64, f64)> = zs
        .iter()
        .zip(&ph)
        .map(|(z, phi)| (tau(*phi), (z - zc) / sig))
        .collect();
    let (c, gamma) = fit_levy(&pts).ok_or(Reason::Singular)?;
    // About τ = 0: s_c = z_c + σ·ĉ₀, d₁ = σ(ĉ₁ − ĉ₀γ), d_k = σ·ĉ_k.
    let mut slope = [0f32; TERMS];
    for (j, d) in slope.iter_mut().enumerate() {
        let cj = if j == 0 {
            c[1] - c[0] * gamma
        } else {
            c[j + 1]
        };
        *d = (sig * cj) as f32;
    }
    let model = PixelModel {
        ray: [ray.x as f32, ray.y as f32],
        phase_centre,
        phase_scale: if clipped { -k } else { k },
        depth_centre: (zc + sig * c[0]) as f32,
        pole: gamma as f32,
        slope,
        far: f32::INFINITY,
    };
    // The fit's own error (f64 evaluation of the f32 model against the map's bilinear phase,
    // which the search reads), at points half a pixel apart along the search's segment: evenly
    // spaced in its parameter t, which is nearly linear in image position (depth is not), so
    // that every cell the segment crosses is sampled about twice (the bilinear phase bends at
    // cell edges, where a smooth function departs from it most). A NaN error fails.
    let (t_lo, t_hi) = (ray.t_at(z_lo), ray.t_at(z_hi));
    let ends = [t_lo, t_hi].map(|t| ray.pixel_at_t(t));
    let len = ((ends[1][0] - ends[0][0]).powi(2) + (ends[1][1] - ends[0][1]).powi(2)).sqrt();
    let m = if len.is_finite() {
        ((2.0 * len).ceil() as usize).clamp(64, MAX_FIT_SAMPLES)
    } else {
        MAX_FIT_SAMPLES
    };
    // In chunks of three passes, so that the arithmetic of many samples overlaps: the points
    // along the segment (depth and image position: no branch, so the compiler vectorizes it),
    // the map's phase at each up to the first off the map, the model's error at each. The
    // outcome is the sample-by-sample one: a NaN error before the first sample off the map is a
    // NaN fit.
    let mut fit = 0f64;
    let (mut zs, mut px, mut py) = ([0f64; FIT_CHUNK], [0f64; FIT_CHUNK], [0f64; FIT_CHUNK]);
    let (mut phis, mut errs) = ([0f64; FIT_CHUNK], [0f64; FIT_CHUNK]);
    let mut j0 = 0;
    while j0 <= m {
        let n = (m + 1 - j0).min(FIT_CHUNK);
        for k in 0..n {
            let t = t_lo + (t_hi - t_lo) * (j0 + k) as f64 / m as f64;
            zs[k] = ray.depth_at_t(t);
            [px[k], py[k]] = ray.pixel_at_t(t);
        }
        let mut read = n;
        for k in 0..n {
            match ray.cal.map.phase([px[k], py[k]]) {
                Some(phi) => phis[k] = phi,
                None => {
                    read = k;
                    break;
                }
            }
        }
        for k in 0..read {
            errs[k] = (model.depth_f64_unbounded(phis[k]) - zs[k]).abs();
        }
        if errs[..read].iter().any(|e| e.is_nan()) {
            return Ok((model, f64::NAN));
        }
        fit = errs[..read].iter().fold(fit, |a, &e| a.max(e));
        if fit > give_up_above {
            return Ok((model, fit));
        }
        if read < n {
            return Err(Reason::OffMap);
        }
        j0 += n;
    }
    Ok((model, fit))
}

/// Levy's linearized least squares for `ŝ(1 + γτ) = Ĉ(τ)`, `Ĉ` of degree [`TERMS`]: returns
/// `(ĉ₀…ĉ_TERMS, γ)`, `None` for a singular system.
fn fit_levy(pts: &[(f64, f64)]) -> Option<([f64; TERMS + 1], f64)> {
    const N: usize = TERMS + 2;
    let mut ata = [[0f64; N]; N];
    let mut atb = [0f64; N];
    for &(t, s) in pts {
        let mut row = [0f64; N];
        let mut tk = 1.0;
        for r in row.iter_mut().take(TERMS + 1) {
            *r = tk;
            tk *= t;
        }
        row[N - 1] = -t * s;
        for i in 0..N {
            atb[i] += row[i] * s;
            for j in 0..N {
                ata[i][j] += row[i] * row[j];
            }
        }
    }
    let x = solve(ata, atb)?;
    let mut c = [0f64; TERMS + 1];
    c.copy_from_slice(&x[..TERMS + 1]);
    Some((c, x[N - 1]))
}

/// Gaussian elimination with partial pivoting.
fn solve<const N: usize>(mut a: [[f64; N]; N], mut b: [f64; N]) -> Option<[f64; N]> {
    for col in 0..N {
        let piv = (col..N).max_by(|&i, &j| a[i][col].abs().total_cmp(&a[j][col].abs()))?;
        if !(a[piv][col].abs() > 1e-300) {
            return None;
        }
        a.swap(col, piv);
        b.swap(col, piv);
        for r in col + 1..N {
            let f = a[r][col] / a[col][col];
            for k in col..N {
                a[r][k] -= f * a[col][k];
            }
            b[r] -= f * b[col];
        }
    }
    let mut x = [0f64; N];
    for r in (0..N).rev() {
        let mut acc = b[r];
        for k in r + 1..N {
            acc -= a[r][k] * x[k];
        }
        x[r] = acc / a[r][r];
    }
    x.iter().all(|v| v.is_finite()).then_some(x)
}

/// The spacing of f32 values at `|x|` (one unit in the last place), as f64.
pub fn ulp(x: f32) -> f64 {
    let a = x.abs();
    if !a.is_finite() {
        return 0.0;
    }
    (f32::from_bits(a.to_bits() + 1) - a) as f64
}

/// Step 3 for row `v`: run the search and the function at [`CHECKS`] phases per pixel; a pixel
/// that misses anywhere becomes [`PixelModel::SEARCH`]. Where the search finds no crossing
/// inside a clipped range (it gives up near the map's end), the function's point is checked
/// against the f64 crossing instead ([`Ray::depth_of`]) and counted in `answered`.
fn check_row(
    cal: &Source<'_>,
    map: &ReferenceMap<'_>,
    v: usize,
    row: &mut [PixelModel],
    tol: f64,
    st: &mut RowStats,
) {
    let recon = &cal.recon;
    let w = row.len();
    let s = recon.setup();
    let (z_min, z_max) = (s.z_min as f32, s.z_max as f32);
    let mut phase = vec![0f32; w];
    let mut q = vec![0u8; w];
    let (mut ex, mut eq) = (vec![0f32; 3 * w], vec![0u8; w]);
    let ref_invalid = Validity::ReferenceInvalid as u8;
    let (mut cx, mut cq) = (vec![0f32; 3 * w], vec![0u8; w]);
    let mut worst = vec![0f64; w];
    let mut fail = vec![false; w];
    // A far check missed: the rule goes (the model stays).
    let mut far_fail = vec![false; w];
    let mut within = vec![true; w];
    let mut answered = vec![false; w];
    let valid = Validity::Valid as u8;
    let mut soa = vec![0f32; FIELDS * w];
    for (u, m) in row.iter().enumerate() {
        let _ = m.store(&mut soa, u);
    }
    // CHECKS phases over the range, then FAR_CHECKS beyond each τ_far (clipped models with the
    // far rule only).
    let taus = (0..CHECKS)
        .map(|k| (-1.0 + 2.0 * k as f64 / (CHECKS - 1) as f64, false))
        .chain(FAR_CHECKS.map(|f| (f, true)));
    for (tau, beyond) in taus {
        for ((p, qq), m) in phase.iter_mut().zip(q.iter_mut()).zip(row.iter()) {
            if m.is_compiled() && (!beyond || m.far_is_no_crossing()) {
                let t = if beyond { tau * m.far as f64 } else { tau };
                *p = (m.phase_centre as f64 + t / (m.phase_scale as f64).abs()) as f32;
                *qq = valid;
            } else if m.is_no_reference() {
                // Any phase: the search must find no reference (phases of a map's usual span).
                *p = (100.0 * tau) as f32;
                *qq = valid;
            } else {
                *p = f32::NAN;
                *qq = Validity::OutOfDepth as u8;
            }
        }
        let exact = recon.reconstruct_row(map, v as u32, &phase, &q, &mut ex, &mut eq);
        let comp = compiled_row(&soa, z_min, z_max, &phase, &q, &mut cx, &mut cq);
        if exact.is_err() || comp.is_err() {
            fail.iter_mut().for_each(|f| *f = true);
            break;
        }
        for u in 0..w {
            if row[u].is_no_reference() {
                let nan = |x: &[f32]| x.iter().all(|v| v.is_nan());
                fail[u] |= !(eq[u] == ref_invalid
                    && cq[u] == ref_invalid
                    && nan(&ex[3 * u..3 * u + 3])
                    && nan(&cx[3 * u..3 * u + 3]));
                continue;
            }
            if beyond {
                if row[u].far_is_no_crossing() {
                    let nc = Validity::NoCrossing as u8;
                    far_fail[u] |= !(eq[u] == nc && cq[u] == nc);
                }
                continue;
            }
            // Beyond a clipped range by rounding, the search answers, as in a scan.
            if !row[u].is_compiled() || cq[u] == LEFT_TO_SEARCH {
                continue;
            }
            let c = &cx[3 * u..3 * u + 3];
            let mut e = [ex[3 * u], ex[3 * u + 1], ex[3 * u + 2]];
            let mut code = eq[u];
            let lost =
                code == Validity::NoCrossing as u8 || code == Validity::ReferenceInvalid as u8;
            if row[u].is_clipped() && lost && cq[u] == valid {
                // The f64 crossing, bracketed by the map's stretch along the ray, stands in for
                // the search's.
                let m = &row[u];
                let ray = Ray::new(cal, u, v);
                let z = ray
                    .valid_run(s.z_min, s.z_max, 0.0)
                    .and_then(|(a, b)| ray.depth_of(phase[u] as f64, a, b));
                if let Some(z) = z {
                    e = [
                        (z * m.ray[0] as f64) as f32,
                        (z * m.ray[1] as f64) as f32,
                        z as f32,
                    ];
                    code = valid;
                    answered[u] = true;
                }
            }
            if code == valid && cq[u] == valid {
                let mut d = 0f64;
                for i in 0..3 {
                    let di = (e[i] as f64 - c[i] as f64).abs();
                    d = d.max(di);
                    fail[u] |= !(di <= tol + F32_ALLOWANCE_ULP * ulp(e[i]));
                }
                worst[u] = worst[u].max(d);
                within[u] &= d <= tol;
            } else if code != cq[u] {
                // Codes may differ only at an end of the depth range, between a point and no
                // point (out of depth, or no crossing where the search meets the range's end).
                let none =
                    |c: u8| c == Validity::OutOfDepth as u8 || c == Validity::NoCrossing as u8;
                let ok = if code == valid || cq[u] == valid {
                    let z = if code == valid { e[2] } else { c[2] } as f64;
                    let allow = tol + F32_ALLOWANCE_ULP * ulp(z as f32);
                    let near =
                        (z - z_min as f64).abs() <= allow || (z - z_max as f64).abs() <= allow;
                    near && (none(code) || none(cq[u]))
                } else {
                    none(code) && none(cq[u])
                };
                fail[u] |= !ok;
            }
        }
    }
    for u in 0..w {
        if row[u].is_no_reference() {
            if fail[u] {
                row[u] = PixelModel::SEARCH;
                st.off_map += 1;
            } else {
                st.no_reference += 1;
            }
            continue;
        }
        if !row[u].is_compiled() {
            continue;
        }
        if fail[u] {
            row[u] = PixelModel::SEARCH;
            st.check_failed += 1;
        } else {
            if far_fail[u] {
                row[u].far = f32::INFINITY;
                st.far_rule_dropped += 1;
            }
            st.max_difference = st.max_difference.max(worst[u]);
            st.beyond_tolerance += usize::from(!within[u]);
            st.answered += usize::from(answered[u]);
        }
    }
}
