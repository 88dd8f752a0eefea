//! The projector's centre P from a flat plate at two or more parallel positions (paper §7).
//!
//! For every pair of plate positions (S, T) and every sampled camera pixel `(i, j)` seeing plate
//! S with phases `(Φ_V, Φ_H)`, the point `T^(I)` of plate T's image with the same phase pair is
//! found by intersecting the two contour lines `Φ_V^(T) = Φ_V`, `Φ_H^(T) = Φ_H` in the bilinear
//! interpolation of T's phase maps (Newton's method inside one pixel cell, walking cell to cell
//! from a global cubic prediction). `S_ij` and `T_ij` are the camera rays of the two pixels cut by
//! the plate planes (from the board poses), and the line `S_ij T_ij` passes through P. P is the
//! weighted least-squares point nearest to all lines (weights `1/λ²`, `λ = |P − S| / |T − S|`: a
//! line's error at P grows with the lever λ), with lines farther than 4 robust σ rejected (three
//! rounds).
//!
//! Uncertainty: (a) the lines: a delete-one-block jackknife over 4 × 4 blocks of the image (the
//! phase errors of neighbouring pixels are correlated, so the formal `σ²A⁻¹` is optimistic and is
//! reported only for comparison); (b) the plate poses: their covariances (from the board fits)
//! propagated through numerically differentiated re-solves. The total covariance is the sum.
//! The camera intrinsics' own uncertainty is not propagated.

use super::CalibError;
use super::lens::Lens;
use super::linalg::solve3;
use super::pose::{PlanePose, ray_dir_plane};
use crate::math::{Mat3, Vec3};
use rayon::prelude::*;

/// One plate position.
#[derive(Clone, Debug)]
pub struct PlateObservation {
    /// Name for messages (e.g. the plate's folder).
    pub name: String,
    /// The plate's pose (from its board image).
    pub pose: PlanePose,
    /// Phase-map width.
    pub width: usize,
    /// Phase-map height.
    pub height: usize,
    /// Absolute phase of the vertical fringes (phase along ξ), NaN where invalid.
    pub phase_v: Vec<f32>,
    /// Absolute phase of the horizontal fringes (phase along η), NaN where invalid.
    pub phase_h: Vec<f32>,
}

/// Options of [`estimate`].
#[derive(Clone, Copy, Debug)]
pub struct ProjectorOptions {
    /// Sample every `stride`-th pixel of plate S along both axes.
    pub stride: usize,
    /// Largest angle between two plates' normals, degrees, before they count as not parallel.
    pub max_plate_angle_deg: f64,
    /// Outlier threshold, robust standard deviations.
    pub outlier_sigmas: f64,
    /// Fewest lines a plate pair must give to be used.
    pub min_pair_lines: usize,
    /// Jackknife blocks per image axis.
    pub blocks: usize,
    /// Pixels of the phase maps' valid areas ignored at their borders (mixed pixels at plate
    /// edges).
    pub erode: usize,
    /// The plate is translated without turning (paper §7): fit one board rotation shared by all
    /// positions (with a translation each) instead of independent poses. Parallelism is checked
    /// on the independent poses first.
    pub translated: bool,
}

impl Default for ProjectorOptions {
    fn default() -> Self {
        ProjectorOptions {
            stride: 2,
            max_plate_angle_deg: 2.0,
            outlier_sigmas: 4.0,
            min_pair_lines: 200,
            blocks: 4,
            erode: 2,
            translated: true,
        }
    }
}

/// What one plate pair contributed.
#[derive(Clone, Debug, serde::Serialize)]
pub struct PairStats {
    /// Plate S (the pixels sampled).
    pub s: String,
    /// Plate T (searched).
    pub t: String,
    /// Sampled S pixels with valid phases.
    pub sampled: usize,
    /// Of those, matched in T.
    pub matched: usize,
    /// Of those, kept after outlier rejection.
    pub used: usize,
    /// RMS distance of this pair's kept lines from P, mm.
    pub rms_distance_mm: f64,
}

/// The result of [`estimate`].
#[derive(Clone, Debug, serde::Serialize)]
pub struct ProjectorCentre {
    /// P, camera frame, mm.
    pub center: [f64; 3],
    /// Total standard deviation of P per axis, mm (lines + plate poses).
    pub std: [f64; 3],
    /// Total covariance of P (row-major 3 × 3), mm².
    pub covariance: [f64; 9],
    /// Standard deviation from the lines (block jackknife), mm.
    pub std_lines: [f64; 3],
    /// Formal standard deviation `σ²A⁻¹` (treats every line as independent: optimistic), mm.
    pub std_formal: [f64; 3],
    /// Standard deviation from the plate-pose uncertainties, mm.
    pub std_poses: [f64; 3],
    /// Lines used.
    pub lines: usize,
    /// Lines rejected as outliers.
    pub rejected: usize,
    /// RMS distance of the used lines from P, mm.
    pub rms_distance_mm: f64,
    /// Median distance, mm.
    pub median_distance_mm: f64,
    /// Largest distance of a used line, mm.
    pub max_distance_mm: f64,
    /// Per plate pair.
    pub pairs: Vec<PairStats>,
    /// Angle between each pair of plate normals, degrees: (plate a, plate b, angle).
    pub plate_angles_deg: Vec<(String, String, f64)>,
    /// z range of the plate points used, mm (a default for the depth range).
    pub z_range: [f64; 2],
}

#[derive(Clone, Copy, Debug)]
struct Line {
    /// Ray directions (z = 1) of the S and T pixels.
    ds: Vec3,
    dt: Vec3,
    s: Vec3,
    t: Vec3,
    pair: usize,
    block: usize,
}

fn dir(l: &Line) -> Vec3 {
    let d = l.t - l.s;
    d * (1.0 / d.norm())
}

/// Accumulate `Σ w (I − d dᵀ)` and `Σ w (I − d dᵀ) s`.
fn accumulate(a: &mut [f64; 9], b: &mut Vec3, s: Vec3, d: Vec3, w: f64) {
    for i in 0..3 {
        for j in 0..3 {
            let m = if i == j { 1.0 } else { 0.0 } - d[i] * d[j];
            a[i * 3 + j] += w * m;
            b[i] += w * m * s[j];
        }
    }
}

fn solve(a: &[f64; 9], b: Vec3) -> Option<Vec3> {
    solve3(&mat(a), b)
}

/// The row-major 3 × 3 matrix `a`.
fn mat(a: &[f64; 9]) -> Mat3 {
    Mat3([[a[0], a[1], a[2]], [a[3], a[4], a[5]], [a[6], a[7], a[8]]])
}

fn distance(p: Vec3, s: Vec3, d: Vec3) -> f64 {
    let q = p - s;
    (q - d * q.dot(d)).norm()
}

fn weight(p: Vec3, l: &Line) -> f64 {
    let lever = (p - l.s).norm() / (l.t - l.s).norm();
    1.0 / (lever * lever).max(1e-12)
}

fn intersect(lines: &[Line], keep: &[bool], weights: &[f64]) -> Option<Vec3> {
    let mut a = [0.0; 9];
    let mut b = Vec3::ZERO;
    for ((l, &k), &w) in lines.iter().zip(keep).zip(weights) {
        if k {
            accumulate(&mut a, &mut b, l.s, dir(l), w);
        }
    }
    solve(&a, b)
}

/// Validity after erosion: finite in both maps with every pixel within `r` finite too.
fn eroded_valid(p: &PlateObservation, r: usize) -> Vec<bool> {
    let (w, h) = (p.width, p.height);
    let ok: Vec<bool> = p
        .phase_v
        .iter()
        .zip(&p.phase_h)
        .map(|(a, b)| a.is_finite() && b.is_finite())
        .collect();
    if r == 0 {
        return ok;
    }
    // Separable erosion.
    let mut tmp = vec![false; w * h];
    for y in 0..h {
        for x in 0..w {
            let lo = x.saturating_sub(r);
            let hi = (x + r).min(w - 1);
            tmp[y * w + x] = x >= r && x + r < w && (lo..=hi).all(|xx| ok[y * w + xx]);
        }
    }
    let mut out = vec![false; w * h];
    for y in 0..h {
        for x in 0..w {
            let lo = y.saturating_sub(r);
            let hi = (y + r).min(h - 1);
            out[y * w + x] = y >= r && y + r < h && (lo..=hi).all(|yy| tmp[yy * w + x]);
        }
    }
    out
}

/// A cubic polynomial map (Φ_V, Φ_H) → (u, v) fitted over a plate's valid pixels: the starting
/// cell of the contour intersection.
struct Predictor {
    mean: [f64; 2],
    scale: [f64; 2],
    cu: [f64; 10],
    cv: [f64; 10],
}

fn terms(a: f64, b: f64) -> [f64; 10] {
    [
        1.0,
        a,
        b,
        a * a,
        a * b,
        b * b,
        a * a * a,
        a * a * b,
        a * b * b,
        b * b * b,
    ]
}

impl Predictor {
    fn fit(p: &PlateObservation, valid: &[bool]) -> Option<Predictor> {
        let w = p.width;
        let idx: Vec<usize> = (0..valid.len())
            .filter(|&i| valid[i] && (i % w).is_multiple_of(4) && (i / w).is_multiple_of(4))
            .collect();
        if idx.len() < 30 {
            return None;
        }
        let n = idx.len() as f64;
        let mean = [
            idx.iter().map(|&i| p.phase_v[i] as f64).sum::<f64>() / n,
            idx.iter().map(|&i| p.phase_h[i] as f64).sum::<f64>() / n,
        ];
        let sd = |m: f64, f: &dyn Fn(usize) -> f64| {
            (idx.iter().map(|&i| (f(i) - m).powi(2)).sum::<f64>() / n)
                .sqrt()
                .max(1e-9)
        };
        let scale = [
            sd(mean[0], &|i| p.phase_v[i] as f64),
            sd(mean[1], &|i| p.phase_h[i] as f64),
        ];
        let mut ata = vec![0.0; 100];
        let mut bu = [0.0; 10];
        let mut bv = [0.0; 10];
        for &i in &idx {
            let t = terms(
                (p.phase_v[i] as f64 - mean[0]) / scale[0],
                (p.phase_h[i] as f64 - mean[1]) / scale[1],
            );
            let (u, v) = ((i % w) as f64, (i / w) as f64);
            for r in 0..10 {
                bu[r] += t[r] * u;
                bv[r] += t[r] * v;
                for c in 0..10 {
                    ata[r * 10 + c] += t[r] * t[c];
                }
            }
        }
        let mut l = ata;
        if !super::linalg::cholesky(&mut l, 10) {
            return None;
        }
        super::linalg::cholesky_solve(&l, 10, &mut bu);
        super::linalg::cholesky_solve(&l, 10, &mut bv);
        Some(Predictor {
            mean,
            scale,
            cu: bu,
            cv: bv,
        })
    }

    fn predict(&self, pv: f64, ph: f64) -> (f64, f64) {
        let t = terms(
            (pv - self.mean[0]) / self.scale[0],
            (ph - self.mean[1]) / self.scale[1],
        );
        (
            t.iter().zip(&self.cu).map(|(a, b)| a * b).sum(),
            t.iter().zip(&self.cv).map(|(a, b)| a * b).sum(),
        )
    }
}

/// The sub-pixel point of `plate` where the bilinearly interpolated phase maps equal
/// `(pv, ph)`: the intersection of the two contour lines, found cell by cell from `guess`.
pub fn invert_bilinear(
    plate: &PlateObservation,
    valid: &[bool],
    pv: f64,
    ph: f64,
    guess: (f64, f64),
) -> Option<(f64, f64)> {
    let (w, h) = (plate.width as isize, plate.height as isize);
    if !(guess.0.is_finite() && guess.1.is_finite()) {
        return None;
    }
    let (mut cx, mut cy) = (
        guess.0.floor().clamp(-1e6, 1e6) as isize,
        guess.1.floor().clamp(-1e6, 1e6) as isize,
    );
    let mut visited = 0;
    while visited < 24 {
        visited += 1;
        if cx < 0 || cy < 0 || cx + 1 >= w || cy + 1 >= h {
            return None;
        }
        let i00 = (cy * w + cx) as usize;
        let (i10, i01, i11) = (i00 + 1, i00 + w as usize, i00 + w as usize + 1);
        if !(valid[i00] && valid[i10] && valid[i01] && valid[i11]) {
            return None;
        }
        let g = |m: &[f32]| {
            let (v00, v10, v01, v11) = (m[i00] as f64, m[i10] as f64, m[i01] as f64, m[i11] as f64);
            [v00, v10 - v00, v01 - v00, v11 - v10 - v01 + v00]
        };
        let a = g(&plate.phase_v);
        let b = g(&plate.phase_h);
        let (mut s, mut t) = (0.5, 0.5);
        let mut ok = false;
        for _ in 0..12 {
            let f = a[0] + a[1] * s + a[2] * t + a[3] * s * t - pv;
            let k = b[0] + b[1] * s + b[2] * t + b[3] * s * t - ph;
            let (j11, j12, j21, j22) = (
                a[1] + a[3] * t,
                a[2] + a[3] * s,
                b[1] + b[3] * t,
                b[2] + b[3] * s,
            );
            let det = j11 * j22 - j12 * j21;
            if !(det.abs() > 1e-18) {
                break;
            }
            let ds = (j22 * f - j12 * k) / det;
            let dt = (-j21 * f + j11 * k) / det;
            s -= ds;
            t -= dt;
            if !(s.is_finite() && t.is_finite()) {
                break;
            }
            if ds.abs() < 1e-10 && dt.abs() < 1e-10 {
                ok = true;
                break;
            }
        }
        if !ok {
            return None;
        }
        let eps = 1e-9;
        if (-eps..=1.0 + eps).contains(&s) && (-eps..=1.0 + eps).contains(&t) {
            return Some((cx as f64 + s, cy as f64 + t));
        }
        let step = |x: f64| {
            if x < 0.0 {
                (x.floor() as isize).max(-4)
            } else if x > 1.0 {
                (x.floor() as isize).min(4)
            } else {
                0
            }
        };
        cx += step(s);
        cy += step(t);
    }
    None
}

/// The angles between the plates' normals (each pair once), and an error if one exceeds
/// `max_deg` or two positions are less than 5 mm apart.
pub fn check_parallel(
    plates: &[PlateObservation],
    max_deg: f64,
) -> Result<Vec<(String, String, f64)>, CalibError> {
    let mut angles = Vec::new();
    for a in 0..plates.len() {
        for b in a + 1..plates.len() {
            let c = plates[a]
                .pose
                .normal()
                .dot(plates[b].pose.normal())
                .clamp(-1.0, 1.0);
            let ang = c.acos().to_degrees();
            angles.push((plates[a].name.clone(), plates[b].name.clone(), ang));
            if ang > max_deg {
                return Err(CalibError::NotParallel {
                    a: plates[a].name.clone(),
                    b: plates[b].name.clone(),
                    angle_deg: ang,
                    limit_deg: max_deg,
                });
            }
            let gap = plates[a]
                .pose
                .normal()
                .dot(plates[b].pose.point() - plates[a].pose.point())
                .abs();
            if gap < 5.0 {
                return Err(CalibError::Input {
                    what: format!("plates {} and {}", plates[a].name, plates[b].name),
                    message: format!(
                        "the two positions are only {gap:.1} mm apart; move the plate by at least a few centimetres"
                    ),
                });
            }
        }
    }
    Ok(angles)
}

/// Estimate P from two or more plate positions seen by the calibrated `lens`.
///
/// `shared_covariance`: when the plate poses come from a joint fit with one rotation
/// ([`super::pose::translated_board_poses`]), its covariance of `(δω, δt_1, …, δt_n)`; `None` when
/// each plate's pose (and covariance) is its own.
pub fn estimate(
    lens: &Lens,
    plates: &[PlateObservation],
    opts: &ProjectorOptions,
    shared_covariance: Option<&[f64]>,
) -> Result<ProjectorCentre, CalibError> {
    if plates.len() < 2 {
        return Err(CalibError::Input {
            what: "projector calibration".into(),
            message: format!(
                "{} plate position(s) given; at least two are needed (paper §7)",
                plates.len()
            ),
        });
    }
    for p in plates {
        if p.width != lens.width as usize
            || p.height != lens.height as usize
            || p.phase_v.len() != p.width * p.height
            || p.phase_h.len() != p.width * p.height
        {
            return Err(CalibError::Input {
                what: p.name.clone(),
                message: format!(
                    "phase maps are {}x{}, the calibrated camera is {}x{}",
                    p.width, p.height, lens.width, lens.height
                ),
            });
        }
    }
    let angles = check_parallel(plates, opts.max_plate_angle_deg)?;
    let valid: Vec<Vec<bool>> = plates.iter().map(|p| eroded_valid(p, opts.erode)).collect();
    let preds: Vec<Option<Predictor>> = plates
        .iter()
        .zip(&valid)
        .map(|(p, v)| Predictor::fit(p, v))
        .collect();
    for (p, pr) in plates.iter().zip(&preds) {
        if pr.is_none() {
            return Err(CalibError::Input {
                what: p.name.clone(),
                message: "too few pixels with valid vertical and horizontal phases".into(),
            });
        }
    }
    let (w, h) = (plates[0].width, plates[0].height);
    let nb = opts.blocks.max(1);
    let stride = opts.stride.max(1);
    let mut lines: Vec<Line> = Vec::new();
    let mut pairs = Vec::new();
    let mut pair_of: Vec<(usize, usize)> = Vec::new();
    for a in 0..plates.len() {
        for b in a + 1..plates.len() {
            let (ps, pt) = (&plates[a], &plates[b]);
            let (ns, os) = (ps.pose.normal(), ps.pose.point());
            let (nt, ot) = (pt.pose.normal(), pt.pose.point());
            let pred = preds[b].as_ref().expect("checked");
            let pix: Vec<(usize, usize)> = (0..h)
                .step_by(stride)
                .flat_map(|y| (0..w).step_by(stride).map(move |x| (x, y)))
                .filter(|&(x, y)| valid[a][y * w + x])
                .collect();
            let sampled = pix.len();
            let pair = pairs.len();
            let found: Vec<Line> = pix
                .par_iter()
                .filter_map(|&(x, y)| {
                    let i = y * w + x;
                    let (pv, ph) = (ps.phase_v[i] as f64, ps.phase_h[i] as f64);
                    let g = pred.predict(pv, ph);
                    let (tu, tv) = invert_bilinear(pt, &valid[b], pv, ph, g)?;
                    let (sx, sy) = lens.undistort(x as f64, y as f64)?;
                    let (tx, ty) = lens.undistort(tu, tv)?;
                    let ds = Vec3::new(sx, sy, 1.0);
                    let dt = Vec3::new(tx, ty, 1.0);
                    let s = ray_dir_plane(ds, os, ns)?;
                    let t = ray_dir_plane(dt, ot, nt)?;
                    ((t - s).norm() > 1e-6).then_some(Line {
                        ds,
                        dt,
                        s,
                        t,
                        pair,
                        block: (y * nb / h) * nb + x * nb / w,
                    })
                })
                .collect();
            let matched = found.len();
            pairs.push(PairStats {
                s: ps.name.clone(),
                t: pt.name.clone(),
                sampled,
                matched,
                used: 0,
                rms_distance_mm: f64::NAN,
            });
            pair_of.push((a, b));
            if matched >= opts.min_pair_lines {
                lines.extend(found);
            }
        }
    }
    if lines.len() < opts.min_pair_lines.max(10) {
        let detail: Vec<String> = pairs
            .iter()
            .map(|p| {
                format!(
                    "{} -> {}: {} of {} pixels matched",
                    p.s, p.t, p.matched, p.sampled
                )
            })
            .collect();
        return Err(CalibError::NoOverlap {
            detail: detail.join("; "),
        });
    }
    // Robust weighted intersection.
    let n = lines.len();
    let mut keep = vec![true; n];
    let mut weights = vec![1.0; n];
    let mut p = intersect(&lines, &keep, &weights).ok_or_else(|| CalibError::Degenerate {
        what: "the plate lines are all parallel".into(),
    })?;
    for _round in 0..3 {
        weights = lines.iter().map(|l| weight(p, l)).collect();
        p = intersect(&lines, &keep, &weights).ok_or_else(|| CalibError::Degenerate {
            what: "the plate lines are all parallel".into(),
        })?;
        // Normalised residuals r·√w.
        let r: Vec<f64> = lines
            .iter()
            .zip(&weights)
            .map(|(l, w)| distance(p, l.s, dir(l)) * w.sqrt())
            .collect();
        let mut kr: Vec<f64> = r
            .iter()
            .zip(&keep)
            .filter(|(_, k)| **k)
            .map(|(x, _)| *x)
            .collect();
        kr.sort_by(f64::total_cmp);
        let med = kr[kr.len() / 2];
        let thr = opts.outlier_sigmas * 1.4826 * med;
        for (k, ri) in keep.iter_mut().zip(&r) {
            *k = *ri <= thr.max(1e-12);
        }
        p = intersect(&lines, &keep, &weights).ok_or_else(|| CalibError::Degenerate {
            what: "the plate lines are all parallel".into(),
        })?;
    }
    weights = lines.iter().map(|l| weight(p, l)).collect();
    p = intersect(&lines, &keep, &weights).ok_or_else(|| CalibError::Degenerate {
        what: "the plate lines are all parallel".into(),
    })?;
    let used = keep.iter().filter(|k| **k).count();
    if used < 10 {
        return Err(CalibError::Degenerate {
            what: "too few consistent plate lines".into(),
        });
    }
    // Statistics.
    let dists: Vec<f64> = lines.iter().map(|l| distance(p, l.s, dir(l))).collect();
    let mut kd: Vec<f64> = dists
        .iter()
        .zip(&keep)
        .filter(|(_, k)| **k)
        .map(|(d, _)| *d)
        .collect();
    let rms = (kd.iter().map(|d| d * d).sum::<f64>() / kd.len() as f64).sqrt();
    kd.sort_by(f64::total_cmp);
    let median = kd[kd.len() / 2];
    let maxd = kd[kd.len() - 1];
    for (pi, ps) in pairs.iter_mut().enumerate() {
        let d: Vec<f64> = lines
            .iter()
            .zip(&keep)
            .zip(&dists)
            .filter(|((l, k), _)| **k && l.pair == pi)
            .map(|(_, d)| *d)
            .collect();
        ps.used = d.len();
        if !d.is_empty() {
            ps.rms_distance_mm = (d.iter().map(|x| x * x).sum::<f64>() / d.len() as f64).sqrt();
        }
    }
    // Formal covariance.
    let mut a = [0.0; 9];
    let mut bsum = Vec3::ZERO;
    let mut wss = 0.0;
    for (((l, &k), &wt), d) in lines.iter().zip(&keep).zip(&weights).zip(&dists) {
        if k {
            accumulate(&mut a, &mut bsum, l.s, dir(l), wt);
            wss += wt * d * d;
        }
    }
    let s2 = wss / (used as f64 - 3.0);
    let inv_a = mat(&a).inverse();
    let std_formal = inv_a
        .map(|m| [0, 1, 2].map(|i| (s2 * m[i][i]).max(0.0).sqrt()))
        .unwrap_or([f64::NAN; 3]);
    // Block jackknife.
    let nbl = nb * nb;
    let mut ab = vec![[0.0; 9]; nbl];
    let mut bb = vec![Vec3::ZERO; nbl];
    for ((l, &k), &wt) in lines.iter().zip(&keep).zip(&weights) {
        if k {
            accumulate(&mut ab[l.block], &mut bb[l.block], l.s, dir(l), wt);
        }
    }
    let mut reps = Vec::new();
    for j in 0..nbl {
        if ab[j].iter().all(|x| *x == 0.0) {
            continue;
        }
        let am: [f64; 9] = std::array::from_fn(|i| a[i] - ab[j][i]);
        let bm = Vec3::from_array(std::array::from_fn(|i| bsum[i] - bb[j][i]));
        if let Some(pj) = solve(&am, bm) {
            reps.push(pj);
        }
    }
    let g = reps.len() as f64;
    let mut cov_lines = [0.0; 9];
    if reps.len() >= 2 {
        let mean = Vec3::from_array(std::array::from_fn(|i| {
            reps.iter().map(|r| r[i]).sum::<f64>() / g
        }));
        for r in &reps {
            let d = *r - mean;
            for i in 0..3 {
                for j in 0..3 {
                    cov_lines[i * 3 + j] += (g - 1.0) / g * d[i] * d[j];
                }
            }
        }
    }
    // Plate poses, propagated: P re-solved with every pose parameter moved by ± its σ.
    let resolve = |poses: &[PlanePose]| -> Option<Vec3> {
        let planes: Vec<(Vec3, Vec3)> = poses.iter().map(|p| (p.normal(), p.point())).collect();
        let mut a = [0.0; 9];
        let mut b = Vec3::ZERO;
        for ((l, &k), &wt) in lines.iter().zip(&keep).zip(&weights) {
            if !k {
                continue;
            }
            let (sa, ta) = pair_of[l.pair];
            let s = ray_dir_plane(l.ds, planes[sa].1, planes[sa].0)?;
            let t = ray_dir_plane(l.dt, planes[ta].1, planes[ta].0)?;
            let d = t - s;
            accumulate(&mut a, &mut b, s, d * (1.0 / d.norm()), wt);
        }
        solve(&a, b)
    };
    let base: Vec<PlanePose> = plates.iter().map(|p| p.pose.clone()).collect();
    // Parameters: per plate (δω_k, δt_k), or (δω shared, δt_1, …, δt_n) for translated plates.
    let (np, cov_params): (usize, Vec<f64>) = match shared_covariance {
        Some(c) => (3 + 3 * plates.len(), c.to_vec()),
        None => {
            let np = 6 * plates.len();
            let mut c = vec![0.0; np * np];
            for (k, pl) in plates.iter().enumerate() {
                for i in 0..6 {
                    for j in 0..6 {
                        c[(6 * k + i) * np + 6 * k + j] = pl.pose.covariance[i * 6 + j];
                    }
                }
            }
            (np, c)
        }
    };
    if cov_params.len() != np * np {
        return Err(CalibError::Degenerate {
            what: "plate pose covariance of the wrong size".into(),
        });
    }
    let moved = |param: usize, h: f64| -> Vec<PlanePose> {
        let mut out = base.clone();
        let mut d = [0.0; 6];
        if shared_covariance.is_some() {
            if param < 3 {
                d[param] = h;
                for o in out.iter_mut() {
                    *o = o.perturbed(&d);
                }
            } else {
                let k = (param - 3) / 3;
                d[3 + (param - 3) % 3] = h;
                out[k] = out[k].perturbed(&d);
            }
        } else {
            let k = param / 6;
            d[param % 6] = h;
            out[k] = out[k].perturbed(&d);
        }
        out
    };
    let mut jac = vec![[0.0; 3]; np];
    for (q, jq) in jac.iter_mut().enumerate() {
        let sdq = cov_params[q * np + q].max(0.0).sqrt();
        let is_rot = if shared_covariance.is_some() {
            q < 3
        } else {
            q % 6 < 3
        };
        let hk = if sdq > 0.0 {
            sdq
        } else if is_rot {
            1e-5
        } else {
            1e-3
        };
        if let (Some(a1), Some(a2)) = (resolve(&moved(q, hk)), resolve(&moved(q, -hk))) {
            for i in 0..3 {
                jq[i] = (a1[i] - a2[i]) / (2.0 * hk);
            }
        }
    }
    let mut cov_pose = [0.0; 9];
    for i in 0..3 {
        for j in 0..3 {
            let mut s = 0.0;
            for k in 0..np {
                for l in 0..np {
                    s += jac[k][i] * cov_params[k * np + l] * jac[l][j];
                }
            }
            cov_pose[i * 3 + j] = s;
        }
    }
    let cov: [f64; 9] = std::array::from_fn(|i| cov_lines[i] + cov_pose[i]);
    let sd = |c: &[f64; 9]| [0, 1, 2].map(|i| c[i * 3 + i].max(0.0).sqrt());
    let zs: Vec<f64> = lines
        .iter()
        .zip(&keep)
        .filter(|(_, k)| **k)
        .flat_map(|(l, _)| [l.s[2], l.t[2]])
        .collect();
    let z_range = [
        zs.iter().cloned().fold(f64::INFINITY, f64::min),
        zs.iter().cloned().fold(f64::NEG_INFINITY, f64::max),
    ];
    Ok(ProjectorCentre {
        center: p.to_array(),
        std: sd(&cov),
        covariance: cov,
        std_lines: sd(&cov_lines),
        std_formal,
        std_poses: sd(&cov_pose),
        lines: used,
        rejected: n - used,
        rms_distance_mm: rms,
        median_distance_mm: median,
        max_distance_mm: maxd,
        pairs,
        plate_angles_deg: angles,
        z_range,
    })
}
