//! Φ_R from a model (issue #17): the reference plane's phase map as a smooth fit to one decoded
//! capture, not the capture itself.
//!
//! A scan's error is the difference of two decoded phases (the object's and the reference's at
//! the crossing, paper §6 eqs 16-18), so a raw reference map adds its own noise to every point
//! (about √2 × the noise-limited error at equal modulation). The plane is flat and the projector
//! smooth, so the map is a smooth function of the pixel and a fit removes almost all of that
//! noise (the fitted map's error is the noise times √(parameters / pixels), a few ‰ of it).
//!
//! # The model
//! The finest absolute phase is `Φ = c_K·g(τ)` (eq 7 with the phase function of §5.1), where `g` is
//! the set's 1-D profile (linear, or monotone cubic through knots for fringes of varying width)
//! and `τ = t + a·(w − w₀)²` the bent projector coordinate. On a plane, `t` and `w` are smooth
//! functions of the camera pixel (a homography bent by the two lenses' distortion), so `τ(u, v)`
//! is smooth for every pattern family, while `Φ(u, v)` is not for a profile with knots. The fit
//! therefore works on `τ = g⁻¹(Φ / c_K)`:
//!
//! 1. `τ` per valid pixel ([`Transfer::to_tau`], exact inverse of the core's `g`);
//! 2. a tensor-product uniform cubic B-spline `τ̂(u, v)` by weighted least squares (weights
//!    `(c_K·g′(τ))²`, so that residuals are measured in radians of phase), with a small
//!    second-difference penalty that only matters where there is no data;
//! 3. outliers (unwrapping errors, specks) beyond [`OUTLIER_SIGMAS`] robust standard deviations of
//!    the finest fit are dropped and every candidate spacing is refitted; the coarsest spacing
//!    whose residual RMS is within [`SPACING_TOLERANCE`] of the finest one's is kept (chosen by
//!    measured residuals: a spacing too coarse for the map shows as a larger residual);
//! 4. the residuals are checked for structure: their RMS beyond what white noise explains
//!    (measured from differences of neighbouring pixels, [`ReferenceFit::structure_rad`]) must
//!    stay under [`MAX_STRUCTURE_OF_NOISE`] × the noise — a plate that is bent at a scale below the
//!    knot spacing, a pattern description that does not match the projected patterns, or phase
//!    errors of a non-linear projector leave such structure;
//! 5. the map is `c_K·g(τ̂)` on every pixel within one knot cell of the data, NaN elsewhere.

use fringe3d_core::pattern::PatternSet;
use fringe3d_core::phase_function::Profile;

use super::linalg::{cholesky, cholesky_solve};

/// Knot spacings tried, pixels, coarse first.
pub const SPACINGS_PX: [u32; 3] = [256, 128, 64];
/// A coarser spacing is kept while its residual RMS is within this factor of the finest one's.
pub const SPACING_TOLERANCE: f64 = 1.005;
/// The smallest noise the outlier and structure tests assume, rad: a noise-free capture (a 16-bit
/// render without noise) has σ ≈ 1e-5 rad, below what a spline of modest knot spacing represents
/// of the lens and projector (≈ 1.8e-4 rad of structure on a synthetic plane), and every pixel
/// would look like an outlier. 5e-4 rad of map error is
/// 1e-4 of a 16-pixel fringe (about a micrometre of depth); a capture that clean gains
/// nothing from the model (`--raw` keeps it exactly).
pub const NOISE_FLOOR_RAD: f64 = 5e-4;
/// Pixels off by more than this many robust standard deviations are outliers.
pub const OUTLIER_SIGMAS: f64 = 6.0;
/// Reweighting rounds of the robust start (each one least-squares fit at the finest spacing).
pub const ROBUST_ROUNDS: usize = 8;
/// Largest accepted fraction of outliers among the valid pixels.
pub const MAX_OUTLIER_FRACTION: f64 = 0.05;
/// Largest accepted structure (RMS of block means beyond the noise) as a fraction of the noise:
/// 0.5 σ of systematic error would already make scans ≥ 1.1 × noise-limited.
pub const MAX_STRUCTURE_OF_NOISE: f64 = 0.5;
/// Side of the blocks that locate the worst structure in error messages, pixels.
pub const BLOCK_PX: usize = 16;
/// Valid pixels needed per model parameter: the fitted map's noise is the capture's times
/// `√(parameters / pixels)`, so 100 keeps it at a tenth or less.
pub const MIN_PIXELS_PER_PARAMETER: usize = 100;

/// The fitted reference map and what the fit measured.
#[derive(Clone, Debug)]
pub struct ReferenceFit {
    /// `c_K·g(τ̂)` per pixel, row-major, NaN more than one knot cell away from the data.
    pub phase: Vec<f32>,
    /// The chosen knot spacing, pixels.
    pub spacing_px: u32,
    /// Residual RMS of the inliers against the model, radians.
    pub residual_rms_rad: f64,
    /// The capture's white noise (from differences of neighbouring residuals, robust), radians.
    pub noise_rad: f64,
    /// RMS of the residuals beyond what white noise explains, radians.
    pub structure_rad: f64,
    /// Valid pixels used.
    pub used: usize,
    /// Valid pixels dropped as outliers.
    pub outliers: usize,
    /// Every spacing tried and its residual RMS (radians).
    pub candidates: Vec<(u32, f64)>,
}

/// Why a capture does not give a reference model.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum FitError {
    /// Too few valid pixels for the model.
    #[error("only {valid} valid pixels; the model needs at least {needed}")]
    TooFew {
        /// Valid pixels.
        valid: usize,
        /// Needed.
        needed: usize,
    },
    /// Too many pixels far off any smooth map.
    #[error(
        "{percent:.1} % of the valid pixels are more than {OUTLIER_SIGMAS} σ ({sigma:.2e} rad) off a smooth map (at most {max:.0} % allowed): not a flat plate under this pattern set"
    , max = MAX_OUTLIER_FRACTION * 100.0)]
    Outliers {
        /// Percentage of outliers.
        percent: f64,
        /// Robust noise, radians.
        sigma: f64,
    },
    /// The residuals show structure.
    #[error(
        "the residuals of the smooth model show structure: {structure:.2e} rad RMS beyond {sigma:.2e} rad of noise (largest near pixel ({u}, {v})); a bent or uneven plate, a pattern description that does not match the projected patterns, or a non-linear projector (`--raw` keeps the decoded map)"
    )]
    Structure {
        /// Structure, radians.
        structure: f64,
        /// Noise, radians.
        sigma: f64,
        /// Centre of the worst block.
        u: usize,
        /// Centre of the worst block.
        v: usize,
    },
    /// The normal equations are singular (data on a line, or not finite).
    #[error("the model's normal equations are singular (valid pixels on a line or not finite)")]
    Singular,
}

/// `Φ ↔ τ` for one pattern set: `Φ = c_K·g(τ)`.
#[derive(Clone, Copy, Debug)]
pub struct Transfer {
    scale: f64,
    profile: Profile,
}

impl Transfer {
    /// The finest level's transfer of `set`.
    pub fn of(set: &PatternSet) -> Transfer {
        let scale = set.levels().last().map_or(1.0, |l| l.scale());
        Transfer {
            scale,
            profile: *set.function().profile(),
        }
    }

    /// `c_K·g(τ)`.
    pub fn to_phase(&self, tau: f64) -> f64 {
        self.scale * self.profile.eval(tau)
    }

    /// `c_K·g′(τ)`, radians per projector pixel.
    pub fn slope(&self, tau: f64) -> f64 {
        let g1 = match &self.profile {
            Profile::Linear { slope, .. } => *slope,
            Profile::Knots(k) => {
                let (s, p, m) = (k.positions(), k.phases(), k.slopes());
                let n = s.len();
                if tau <= s[0] {
                    m[0]
                } else if tau >= s[n - 1] {
                    m[n - 1]
                } else {
                    let i = s
                        .partition_point(|&x| x <= tau)
                        .saturating_sub(1)
                        .min(n - 2);
                    let h = s[i + 1] - s[i];
                    hermite_dt((tau - s[i]) / h, h, p[i], p[i + 1], m[i], m[i + 1]) / h
                }
            }
        };
        self.scale * g1
    }

    /// `g⁻¹(Φ / c_K)`: the inverse of [`Transfer::to_phase`] (exact for the linear profile, to
    /// 1e-12 projector pixels for knots; `g` is strictly increasing).
    pub fn to_tau(&self, phase: f64) -> f64 {
        let y = phase / self.scale;
        match &self.profile {
            Profile::Linear { origin, slope } => origin + y / slope,
            Profile::Knots(k) => {
                let (s, p, m) = (k.positions(), k.phases(), k.slopes());
                let n = s.len();
                if y <= p[0] {
                    return s[0] + (y - p[0]) / m[0];
                }
                if y >= p[n - 1] {
                    return s[n - 1] + (y - p[n - 1]) / m[n - 1];
                }
                let i = p.partition_point(|&x| x <= y).saturating_sub(1).min(n - 2);
                let h = s[i + 1] - s[i];
                // Safeguarded Newton on the segment's cubic in t ∈ [0, 1].
                let (mut lo, mut hi) = (0.0f64, 1.0f64);
                let mut t = ((y - p[i]) / (p[i + 1] - p[i])).clamp(0.0, 1.0);
                for _ in 0..60 {
                    let f = k.eval(s[i] + t * h) - y;
                    if f > 0.0 {
                        hi = t;
                    } else {
                        lo = t;
                    }
                    let d = hermite_dt(t, h, p[i], p[i + 1], m[i], m[i + 1]);
                    let mut next = t - f / d;
                    if !(next > lo && next < hi) {
                        next = 0.5 * (lo + hi);
                    }
                    if (next - t).abs() < 1e-15 || hi - lo < 1e-15 {
                        t = next;
                        break;
                    }
                    t = next;
                }
                s[i] + t * h
            }
        }
    }
}

/// d/dt of the cubic Hermite segment `H(t)` of [`fringe3d_core::phase_function::KnotProfile`].
fn hermite_dt(t: f64, h: f64, p0: f64, p1: f64, m0: f64, m1: f64) -> f64 {
    let t2 = t * t;
    (6.0 * t2 - 6.0 * t) * p0
        + (3.0 * t2 - 4.0 * t + 1.0) * h * m0
        + (-6.0 * t2 + 6.0 * t) * p1
        + (3.0 * t2 - 2.0 * t) * h * m1
}

/// The uniform cubic B-spline basis at `t ∈ [0, 1]`.
fn basis(t: f64) -> [f64; 4] {
    let (t2, t3) = (t * t, t * t * t);
    let s = 1.0 - t;
    [
        s * s * s / 6.0,
        (3.0 * t3 - 6.0 * t2 + 4.0) / 6.0,
        (-3.0 * t3 + 3.0 * t2 + 3.0 * t + 1.0) / 6.0,
        t3 / 6.0,
    ]
}

/// A tensor-product uniform cubic B-spline over a `width × height` image.
#[derive(Clone, Debug)]
struct Spline {
    spacing: f64,
    /// Cells along u and v.
    cells: [usize; 2],
    /// Control values, `(cells[0] + 3) × (cells[1] + 3)`, u fastest.
    coef: Vec<f64>,
}

impl Spline {
    fn new(width: usize, height: usize, spacing: u32) -> Spline {
        let s = f64::from(spacing);
        let cells = |n: usize| (((n.max(2) - 1) as f64 / s).ceil() as usize).max(1);
        let cells = [cells(width), cells(height)];
        Spline {
            spacing: s,
            cells,
            coef: vec![0.0; (cells[0] + 3) * (cells[1] + 3)],
        }
    }

    fn stride(&self) -> usize {
        self.cells[0] + 3
    }

    fn len(&self) -> usize {
        self.coef.len()
    }

    /// Cell index and local coordinate along one axis.
    fn locate(&self, x: f64, axis: usize) -> (usize, f64) {
        let q = x / self.spacing;
        let i = (q.floor().max(0.0) as usize).min(self.cells[axis] - 1);
        (i, q - i as f64)
    }

    /// The 16 control indices and weights of pixel (u, v).
    fn weights(&self, u: usize, v: usize) -> ([usize; 16], [f64; 16]) {
        let (iu, tu) = self.locate(u as f64, 0);
        let (iv, tv) = self.locate(v as f64, 1);
        let (bu, bv) = (basis(tu), basis(tv));
        let mut idx = [0; 16];
        let mut w = [0.0; 16];
        for b in 0..4 {
            for a in 0..4 {
                idx[4 * b + a] = (iv + b) * self.stride() + iu + a;
                w[4 * b + a] = bu[a] * bv[b];
            }
        }
        (idx, w)
    }

    fn eval(&self, u: usize, v: usize) -> f64 {
        let (idx, w) = self.weights(u, v);
        idx.iter().zip(&w).map(|(&i, &w)| self.coef[i] * w).sum()
    }

    /// Weighted least squares of `tau` over its finite pixels, pixel `p` weighing
    /// `weight(p, tau[p])` (pixels of weight 0 or less are left out), with the second-difference
    /// penalty `λ·Σ(Δ²c)²` along both axes (λ a 1e-6 fraction of the mean data weight per
    /// control value): where there is data it changes nothing measurable, where there is none it
    /// continues the surface linearly.
    fn fit(
        &mut self,
        width: usize,
        tau: &[f64],
        weight: impl Fn(usize, f64) -> f64,
    ) -> Result<(), FitError> {
        let n = self.len();
        let mut a = vec![0.0; n * n];
        let mut b = vec![0.0; n];
        for (p, &t) in tau.iter().enumerate() {
            if !t.is_finite() {
                continue;
            }
            let wt = weight(p, t);
            if !(wt > 0.0) {
                continue;
            }
            let (idx, w) = self.weights(p % width, p / width);
            for k in 0..16 {
                let wk = w[k] * wt;
                b[idx[k]] += wk * t;
                let row = idx[k] * n;
                for l in 0..16 {
                    a[row + idx[l]] += wk * w[l];
                }
            }
        }
        let trace: f64 = (0..n).map(|i| a[i * n + i]).sum();
        let lambda = 1e-6 * trace / n as f64;
        let (su, sv) = (self.stride(), self.cells[1] + 3);
        let mut penalise = |i0: usize, step: usize| {
            let ids = [i0, i0 + step, i0 + 2 * step];
            let d = [1.0, -2.0, 1.0];
            for x in 0..3 {
                for y in 0..3 {
                    a[ids[x] * n + ids[y]] += lambda * d[x] * d[y];
                }
            }
        };
        for j in 0..sv {
            for i in 0..su - 2 {
                penalise(j * su + i, 1);
            }
        }
        for j in 0..sv - 2 {
            for i in 0..su {
                penalise(j * su + i, su);
            }
        }
        if !cholesky(&mut a, n) {
            return Err(FitError::Singular);
        }
        cholesky_solve(&a, n, &mut b);
        if b.iter().any(|c| !c.is_finite()) {
            return Err(FitError::Singular);
        }
        self.coef = b;
        Ok(())
    }
}

/// The residual `Φ − c_K·g(τ̂)` of pixel `p`.
fn residual(spline: &Spline, transfer: &Transfer, phase: f32, p: usize, width: usize) -> f64 {
    f64::from(phase) - transfer.to_phase(spline.eval(p % width, p / width))
}

/// Residuals `Φ − c_K·g(τ̂)` of the pixels whose `tau` is finite (NaN elsewhere), written into
/// `r` (one per pixel), and their RMS.
fn residuals(
    spline: &Spline,
    transfer: &Transfer,
    phase: &[f32],
    tau: &[f64],
    width: usize,
    r: &mut Vec<f64>,
) -> f64 {
    let mut sum = 0.0;
    let mut n = 0usize;
    r.clear();
    r.extend(phase.iter().zip(tau).enumerate().map(|(p, (&ph, &t))| {
        if t.is_finite() {
            let e = residual(spline, transfer, ph, p, width);
            sum += e * e;
            n += 1;
            e
        } else {
            f64::NAN
        }
    }));
    (sum / n.max(1) as f64).sqrt()
}

/// The RMS of [`residuals`], without writing them.
fn residual_rms(
    spline: &Spline,
    transfer: &Transfer,
    phase: &[f32],
    tau: &[f64],
    width: usize,
) -> f64 {
    let (mut sum, mut n) = (0.0, 0usize);
    for (p, (&ph, &t)) in phase.iter().zip(tau).enumerate() {
        if t.is_finite() {
            let e = residual(spline, transfer, ph, p, width);
            sum += e * e;
            n += 1;
        }
    }
    (sum / n.max(1) as f64).sqrt()
}

/// 1.4826 × the median absolute value of the finite entries (0 without any).
fn robust_sigma(r: &[f64]) -> f64 {
    robust_sigma_of(r.to_vec())
}

/// [`robust_sigma`] of values the caller no longer needs (sorted in place: no copy).
fn robust_sigma_of(mut a: Vec<f64>) -> f64 {
    a.retain(|x| x.is_finite());
    if a.is_empty() {
        return 0.0;
    }
    for x in &mut a {
        *x = x.abs();
    }
    let mid = a.len() / 2;
    let (_, m, _) = a.select_nth_unstable_by(mid, f64::total_cmp);
    1.4826 * *m
}

/// The white part of the residuals' noise: 1.4826 × the median absolute difference of
/// horizontal neighbours, over √2 (smooth errors cancel in the differences).
fn white_sigma(r: &[f64], width: usize) -> f64 {
    let d: Vec<f64> = (0..r.len().saturating_sub(1))
        .filter(|&p| (p + 1) % width != 0)
        .map(|p| r[p + 1] - r[p])
        .collect();
    robust_sigma_of(d) / std::f64::consts::SQRT_2
}

/// Structure of the residuals: `sqrt(max(0, mean(r²) − mean((r[u+1] − r[u])²)/2))`. White noise
/// contributes equally to both terms (differences of neighbours double its variance), anything
/// smoother than a pixel or two (a bent plate, a wrong pattern description, harmonics of a
/// non-linear projector) only to the first. Also the centre of the [`BLOCK_PX`]-block with the
/// largest `|mean|·√n`, to point at it.
fn structure(r: &[f64], width: usize, height: usize) -> (f64, (usize, usize)) {
    let (mut s2, mut n) = (0.0, 0usize);
    let (mut d2, mut nd) = (0.0, 0usize);
    for (p, &e) in r.iter().enumerate() {
        if e.is_finite() {
            s2 += e * e;
            n += 1;
            if (p + 1) % width != 0 && r[p + 1].is_finite() {
                let d = r[p + 1] - e;
                d2 += d * d;
                nd += 1;
            }
        }
    }
    let structure = if n == 0 || nd == 0 {
        0.0
    } else {
        (s2 / n as f64 - 0.5 * d2 / nd as f64).max(0.0).sqrt()
    };
    let (bw, bh) = (width.div_ceil(BLOCK_PX), height.div_ceil(BLOCK_PX));
    let mut sum = vec![0.0; bw * bh];
    let mut cnt = vec![0usize; bw * bh];
    for (p, &e) in r.iter().enumerate() {
        if e.is_finite() {
            let b = (p / width / BLOCK_PX) * bw + (p % width) / BLOCK_PX;
            sum[b] += e;
            cnt[b] += 1;
        }
    }
    let (mut worst, mut at) = (-1.0, (0, 0));
    for b in 0..bw * bh {
        if cnt[b] == 0 {
            continue;
        }
        let z = (sum[b] / cnt[b] as f64).abs() * (cnt[b] as f64).sqrt();
        if z > worst {
            worst = z;
            at = (
                (b % bw) * BLOCK_PX + BLOCK_PX / 2,
                (b / bw) * BLOCK_PX + BLOCK_PX / 2,
            );
        }
    }
    (structure, at)
}

/// Fit the reference model to a decoded capture of the plane: `phase` is the finest absolute
/// phase of `set`, row-major `width × height`, non-finite where invalid.
pub fn fit_reference(
    set: &PatternSet,
    phase: &[f32],
    width: usize,
    height: usize,
) -> Result<ReferenceFit, FitError> {
    let transfer = Transfer::of(set);
    let n = width * height;
    // τ per pixel, NaN where the capture is invalid (and, below, where it is an outlier): with
    // the residuals, what the fit keeps per pixel (16 bytes) besides the capture. A pixel's
    // weight `(c_K·g′(τ))²` is computed from its τ when needed.
    let mut tau = vec![f64::NAN; n];
    let mut valid = 0usize;
    for p in 0..n.min(phase.len()) {
        if phase[p].is_finite() {
            let t = transfer.to_tau(f64::from(phase[p]));
            let s = transfer.slope(t);
            if t.is_finite() && s > 0.0 {
                tau[p] = t;
                valid += 1;
            }
        }
    }
    let base = |t: f64| {
        let s = transfer.slope(t);
        s * s
    };
    let spacings: Vec<u32> = SPACINGS_PX
        .iter()
        .copied()
        .filter(|&s| (s as usize) < width.max(height) || s == SPACINGS_PX[SPACINGS_PX.len() - 1])
        .collect();
    let finest = spacings[spacings.len() - 1];
    let needed = MIN_PIXELS_PER_PARAMETER * Spline::new(width, height, finest).len();
    if valid < needed {
        return Err(FitError::TooFew { valid, needed });
    }
    // Outliers from the finest fit, made robust first when the residuals say it was pulled:
    // a least-squares fit follows a large fraction of outliers, so while the residuals' spread
    // is well above the white noise between neighbours, iterate reweighted least squares towards
    // the least-absolute-deviation fit (weights `1 / max(|r|, σ_white)`).
    let mut spline = Spline::new(width, height, finest);
    spline.fit(width, &tau, |_, t| base(t))?;
    let mut r = Vec::with_capacity(n);
    residuals(&spline, &transfer, phase, &tau, width, &mut r);
    for _ in 0..ROBUST_ROUNDS {
        let white = white_sigma(&r, width);
        if !(robust_sigma(&r) > 1.5 * white) || !(white > 0.0) {
            break;
        }
        spline.fit(width, &tau, |p, t| base(t) * white / r[p].abs().max(white))?;
        residuals(&spline, &transfer, phase, &tau, width, &mut r);
    }
    let sigma0 = robust_sigma(&r);
    let mut outliers = 0usize;
    for (t, e) in tau.iter_mut().zip(&r) {
        if t.is_finite() && !(e.abs() <= OUTLIER_SIGMAS * sigma0.max(NOISE_FLOOR_RAD)) {
            *t = f64::NAN;
            outliers += 1;
        }
    }
    if outliers as f64 > MAX_OUTLIER_FRACTION * valid as f64 {
        return Err(FitError::Outliers {
            percent: 100.0 * outliers as f64 / valid as f64,
            sigma: sigma0.max(NOISE_FLOOR_RAD),
        });
    }
    // Every spacing on the inliers; keep the coarsest within the tolerance of the finest.
    let mut fits = Vec::new();
    for &s in &spacings {
        let mut sp = Spline::new(width, height, s);
        sp.fit(width, &tau, |_, t| base(t))?;
        let rms = residual_rms(&sp, &transfer, phase, &tau, width);
        fits.push((s, sp, rms));
    }
    let best_rms = fits.last().map_or(0.0, |f| f.2);
    let pick = fits
        .iter()
        .position(|f| f.2 <= SPACING_TOLERANCE * best_rms)
        .unwrap_or(fits.len() - 1);
    let candidates = fits.iter().map(|f| (f.0, f.2)).collect();
    let (spacing_px, spline, residual_rms_rad) = fits.swap_remove(pick);
    residuals(&spline, &transfer, phase, &tau, width, &mut r);
    let noise_rad = white_sigma(&r, width);
    let (structure_rad, (u, v)) = structure(&r, width, height);
    if structure_rad > MAX_STRUCTURE_OF_NOISE * noise_rad.max(NOISE_FLOOR_RAD) {
        return Err(FitError::Structure {
            structure: structure_rad,
            sigma: noise_rad.max(NOISE_FLOOR_RAD),
            u,
            v,
        });
    }
    // The map, on every pixel within one knot cell of a cell holding data.
    let (cu, cv) = (spline.cells[0], spline.cells[1]);
    let mut has = vec![false; cu * cv];
    for (p, &t) in tau.iter().enumerate() {
        if t.is_finite() {
            let (iu, _) = spline.locate((p % width) as f64, 0);
            let (iv, _) = spline.locate((p / width) as f64, 1);
            has[iv * cu + iu] = true;
        }
    }
    let near = |iu: usize, iv: usize| {
        (iv.saturating_sub(1)..(iv + 2).min(cv))
            .any(|j| (iu.saturating_sub(1)..(iu + 2).min(cu)).any(|i| has[j * cu + i]))
    };
    let phase_out = (0..n)
        .map(|p| {
            let (u, v) = (p % width, p / width);
            let (iu, _) = spline.locate(u as f64, 0);
            let (iv, _) = spline.locate(v as f64, 1);
            if near(iu, iv) {
                transfer.to_phase(spline.eval(u, v)) as f32
            } else {
                f32::NAN
            }
        })
        .collect();
    Ok(ReferenceFit {
        phase: phase_out,
        spacing_px,
        residual_rms_rad,
        noise_rad,
        structure_rad,
        used: valid - outliers,
        outliers,
        candidates,
    })
}
