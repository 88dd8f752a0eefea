//! Adaptive projection patterns (paper §5.1, Fig. 10; issue #22): a phase function whose fringe
//! width varies along the projector axis, designed for one object in one rig.
//!
//! # What is maximised, under which constraints
//!
//! A camera pixel that sees the object at distance t along its ray measures the finest phase
//! `c_K·Φ(ξ)` (eq 7) with noise σ_φ; the reconstruction (§6) turns it into t with the error
//!
//! ```text
//! σ_t = σ_φ / (c_K · s(ξ) · |dξ/dt|),    s = dΦ/dξ, the base phase's slope at the pixel's ξ,
//! ```
//!
//! `dξ/dt` the rate at which the projector column moves along the ray (the triangulation). The
//! design keeps the set's levels (their scales, hence the unwrapping's odds, which depend only on
//! the ratios and B/σ: [`crate::design`]) and redistributes the slope s over the projector's
//! columns to **minimise the object's mean squared point error** `Σ_pixels w/s(ξ)²`,
//! `w = 1/(dξ/dt)²`, subject to
//!
//! 1. **the camera** resolves the fringes: on every object pixel the finest fringe period in the
//!    image, `2π / (c_K·s(ξ)·|∇ξ|)` camera pixels (`|∇ξ|` the projector columns per camera pixel
//!    there, large on steep flanks), stays at least `min_camera_period`, and the optics pass at
//!    least `min_contrast` of the fringes' contrast there (and, with the noise known, enough of
//!    it for the B/σ the levels need). Each pixel so has a largest slope; a knot interval takes
//!    the slope all but `1 − percentile` of its pixels resolve, so that a few grazing pixels do
//!    not flatten a whole region (the rest are predicted unresolvable);
//! 2. **the projector** renders them: its finest period `2π/(c_K·s)` stays at least
//!    `min_projector_period` DMD pixels (pixelation and defocus);
//! 3. **the coarsest level stays absolute**: the base phase's span `∫s dξ` is the template's, so
//!    the coarsest level keeps its margin inside one period (eqs 12-13);
//! 4. s ≥ `floor` × the template's mean slope everywhere (the phase stays strictly monotonic,
//!    §6 step 1, where no object is seen).
//!
//! s is piecewise linear between `knots` equally spaced knots: that is exactly the derivative of
//! the pattern file's `kind = "knots"` profile, whose phases follow from the slopes by the
//! trapezoid rule (a cubic Hermite segment whose secant is the mean of its end slopes has a
//! linear derivative), so the design is what the projector shows. The objective is convex in the
//! knot slopes, the span constraint linear and the bounds boxes: the solution is found by
//! coordinate descent for a Lagrange multiplier λ of the span, and λ by bisection, with fixed
//! iteration counts. Where the span does not bind, every knot sits at its camera or projector
//! bound: the fringes are as dense as the camera allows everywhere on the object.

pub mod decoded;
pub mod experiment;
mod pattern;
mod solve;
pub mod surface;

use std::f64::consts::TAU;

pub use pattern::{adapted_file, bent_file, template_of};
pub use solve::{check, solve};

/// The refusal probability at which a pixel counts as unresolvable by the noise
/// ([`crate::design::needed_snr`]): a pixel whose finest level keeps less B/σ than that rate
/// needs is lost more often than one scan in a thousand.
pub const PIXEL_FAILURE: f64 = 1e-3;

/// One camera pixel on the object.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sample {
    /// Its projector coordinate along the set's axis (ξ, or η for horizontal fringes), pixels.
    pub along: f64,
    /// `|∇ξ|`: projector pixels along the axis per camera pixel, at that pixel.
    pub grad: f64,
    /// `1/(dξ/dt)²`, mm² per projector pixel² (the weight of its squared error).
    pub weight: f64,
    /// The projector's light on the pixel's surface relative to a surface facing it at 600 mm,
    /// `cos θ_p·(600 mm/d_p)²` (θ_p the incidence angle, d_p the distance to the projector
    /// centre): with a uniform albedo, the pixel's fringe modulation is proportional to it.
    pub bright: f64,
}

/// The noise side of a design: the modulation-to-noise ratio of the brightest object surface
/// (at the template's coarse levels, where the optics pass the whole contrast) and the ratio
/// every pixel must keep at the finest level.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Snr {
    /// B/σ of the brightest object surface (the 99th percentile of [`Sample::bright`]).
    pub brightest: f64,
    /// B/σ each pixel's finest level needs (the decoder's threshold, safe unwrapping).
    pub needed: f64,
}

/// The limits of a design (see the module documentation).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Goal {
    /// Least finest fringe period in the camera image, pixels.
    pub min_camera_period: f64,
    /// Least finest fringe period on the projector, pixels.
    pub min_projector_period: f64,
    /// Projector defocus, Gaussian σ in DMD pixels (its contrast transfer, with the pixel's box).
    pub projector_blur: f64,
    /// Camera blur, Gaussian σ in camera pixels (with the pixel's box).
    pub camera_blur: f64,
    /// Least share of the fringe contrast the projector's and the camera's optics must pass.
    pub min_contrast: f64,
    /// With the noise known: every pixel keeps `needed` B/σ at the finest level.
    pub snr: Option<Snr>,
    /// Least slope, as a fraction of the template's mean slope.
    pub floor: f64,
    /// Knots of the slope profile (2 to [`fringe3d_core::phase_function::MAX_KNOTS`]).
    pub knots: usize,
    /// A knot interval's bound is the slope this share of its pixels resolve (0.99: the 1 %
    /// with the lowest limits, the steepest or dimmest, may be lost).
    pub percentile: f64,
    /// Least object pixels a design is made from.
    pub min_samples: usize,
    /// The largest share of the object's pixels that may stay unresolvable at the least slope
    /// (grazing surfaces) before the design is refused as camera-bound.
    pub max_unresolvable: f64,
}

impl Default for Goal {
    fn default() -> Self {
        Goal {
            min_camera_period: 3.0,
            min_projector_period: 4.0,
            projector_blur: 1.0,
            camera_blur: 0.5,
            min_contrast: 0.5,
            snr: None,
            floor: 0.1,
            knots: fringe3d_core::phase_function::MAX_KNOTS,
            percentile: 0.99,
            min_samples: 1000,
            max_unresolvable: 0.05,
        }
    }
}

/// The set the design starts from.
#[derive(Clone, Debug, PartialEq)]
pub struct Template {
    /// Projector pixels along the axis.
    pub extent: u32,
    /// The finest level's scale `c_K`.
    pub finest: f64,
    /// The base phase's span over the projector, radians (kept).
    pub span: f64,
    /// The template's base slope at each projector column (the fixed-pitch comparison).
    pub slopes: Vec<f64>,
}

/// What binds a region's slope.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Binding {
    /// The pixels' resolution: the camera's least fringe period, the optics' contrast, the
    /// noise.
    Camera,
    /// The projector's least fringe period.
    Projector,
    /// The coarsest level's span (the phase budget is shared with other regions).
    Span,
    /// The least slope (no object there).
    Floor,
}

/// Predicted figures of one phase function on the object.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Prediction {
    /// RMS point error per radian of phase noise, mm/rad (× σ_φ gives mm; σ_φ the phase noise
    /// at the fringes' full contrast: what the optics lose at each pixel's period is counted).
    pub rms_per_rad: f64,
    /// Fraction of the object's pixels whose finest fringes the optics or the noise do not
    /// resolve (steeper than the pixel's limit).
    pub unresolvable: f64,
    /// Least finest fringe period on the object in the camera image (at the goal's percentile
    /// of each column), pixels.
    pub min_camera_period: f64,
}

/// One knot interval's prediction (columns from its knot to the column before the next).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Region {
    /// First and last projector column.
    pub columns: (u32, u32),
    /// Object pixels seen there.
    pub pixels: usize,
    /// RMS point error of the template over the design's there (> 1: the design is better).
    pub gain: f64,
    /// What binds the slope there (at the knot nearer the region's pixels' centroid).
    pub binding: Binding,
}

/// A designed phase function with its predictions.
#[derive(Clone, Debug, PartialEq)]
pub struct Adapted {
    /// Knot positions, projector pixels along the axis.
    pub positions: Vec<f64>,
    /// Base-phase slope at each knot, rad per pixel.
    pub slopes: Vec<f64>,
    /// The base phase's span, radians (the template's, or less where every knot is bound).
    pub span: f64,
    /// The template on the object.
    pub fixed: Prediction,
    /// The design on the object.
    pub adaptive: Prediction,
    /// Per knot interval with object pixels.
    pub regions: Vec<Region>,
    /// Object pixels used.
    pub samples: usize,
}

/// Why no design was made: the constraint that binds.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum AdaptError {
    /// Too few object pixels to design from.
    #[error(
        "only {found} object pixels lie in the measurement volume, lit and seen; a design needs \
         {need}: scan the object first (or place the model) inside the volume"
    )]
    TooFewSamples {
        /// Pixels found.
        found: usize,
        /// Pixels needed.
        need: usize,
    },
    /// A goal parameter is out of range.
    #[error("adapt: {0}")]
    Parameter(String),
    /// Too many object pixels resolve no fringes even at the least slope.
    #[error(
        "the camera binds: {:.1} % of the object's pixels (most at projector columns {} to {}) \
         resolve no fringes even at the least slope ({floor:.3e} rad/px): surfaces too steep for \
         --min-period, too blurred for --min-contrast or too dim for --snr; crop them away, \
         lower those limits or --floor",
        100.0 * share, columns.0, columns.1
    )]
    CameraBinds {
        /// The columns holding most of them.
        columns: (u32, u32),
        /// Their share of the object's pixels.
        share: f64,
        /// The least slope.
        floor: f64,
    },
    /// Too many object pixels are too dim for the B/σ the levels need, at any slope.
    #[error(
        "the noise binds: {:.1} % of the object's pixels (most at projector columns {} to {}) \
         are too dim to keep the B/sigma of {needed:.1} the template's levels need (the brightest \
         surface has {brightest:.1}): use smaller level ratios or more levels (`fringe3d patterns \
         --design`), a longer exposure, or crop those surfaces away",
        100.0 * share, columns.0, columns.1
    )]
    NoiseBinds {
        /// The columns holding most of them.
        columns: (u32, u32),
        /// Their share of the object's pixels.
        share: f64,
        /// The B/σ needed.
        needed: f64,
        /// The brightest surface's B/σ.
        brightest: f64,
    },
    /// The projector constraint cannot be met even at the least slope.
    #[error(
        "the projector binds: the least slope ({floor:.3e} rad/px) already gives a finest \
         period of {period:.2} projector pixels, under --min-projector-period {need}: lower \
         --floor or use a coarser finest scale"
    )]
    ProjectorBinds {
        /// The least slope.
        floor: f64,
        /// Its finest period.
        period: f64,
        /// The period asked for.
        need: f64,
    },
}

/// The finest fringe period in the camera, pixels, for slope `s` at a pixel of gradient `grad`.
pub fn camera_period(finest: f64, s: f64, grad: f64) -> f64 {
    TAU / (finest * s * grad)
}

/// The slope at column `c` of the piecewise-linear profile through `(positions, slopes)`.
pub fn slope_at(positions: &[f64], slopes: &[f64], c: f64) -> f64 {
    let n = positions.len();
    if c <= positions[0] {
        return slopes[0];
    }
    if c >= positions[n - 1] {
        return slopes[n - 1];
    }
    let k = positions.partition_point(|&p| p <= c).clamp(1, n - 1);
    let (x0, x1) = (positions[k - 1], positions[k]);
    let f = (c - x0) / (x1 - x0);
    slopes[k - 1] * (1.0 - f) + slopes[k] * f
}

/// The share of a sinusoid's contrast that a Gaussian blur of σ and a box of one pixel pass at
/// period `p` (pixels): `exp(−2π²σ²/p²)·sinc(1/p)`.
pub fn contrast(p: f64, sigma: f64) -> f64 {
    let x = std::f64::consts::PI / p;
    (-2.0 * x * x * sigma * sigma).exp() * if x > 0.0 { x.sin() / x } else { 1.0 }
}

/// The share of the fringes' contrast the projector's and the camera's optics pass at base slope
/// `s` on a pixel of gradient `grad` (projector pixels per camera pixel): the finest period is
/// `p = 2π/(c_K·s)` on the DMD and `p/grad` in the image, each blurred with its pixel's box
/// ([`contrast`]). The phase noise grows as it falls (σ_φ ∝ 1/B).
pub fn optics_contrast(finest: f64, s: f64, grad: f64, g: &Goal) -> f64 {
    let p = TAU / (finest * s);
    contrast(p, g.projector_blur) * contrast(p / grad, g.camera_blur)
}

/// `d ln C/dp` of [`contrast`] at period `p`: `4π²σ²/p³ − (π/p²)·(cot x − 1/x)`, `x = π/p`.
fn log_contrast_per_period(p: f64, sigma: f64) -> f64 {
    let x = std::f64::consts::PI / p;
    let pi = std::f64::consts::PI;
    4.0 * pi * pi * sigma * sigma / (p * p * p) - (pi / (p * p)) * (x.cos() / x.sin() - 1.0 / x)
}

/// `d ln(optics_contrast)/ds` at slope `s` ([`optics_contrast`]; `dp/ds = −p/s`): negative, the
/// contrast falls as the fringes get denser.
pub fn log_contrast_rate(finest: f64, s: f64, grad: f64, g: &Goal) -> f64 {
    let p = TAU / (finest * s);
    let d = log_contrast_per_period(p, g.projector_blur)
        + log_contrast_per_period(p / grad, g.camera_blur) / grad;
    -d * p / s
}

/// One pixel's squared point error per squared radian of full-contrast phase noise,
/// `w/(c_K·s·C)²`: the triangulation's `w = 1/(dξ/dt)²`, the slope, and the contrast the optics
/// leave at that slope ([`optics_contrast`]).
pub fn point_variance(s: &Sample, slope: f64, finest: f64, g: &Goal) -> f64 {
    let c = optics_contrast(finest, slope, s.grad, g);
    s.weight / (finest * slope * c).powi(2)
}

/// Predicted figures of the slope profile `slope(column)` on `samples` whose largest resolvable
/// slopes are `limits`, with the optics of `g`.
pub fn predict(
    samples: &[Sample],
    limits: &[f64],
    finest: f64,
    percentile_period: f64,
    g: &Goal,
    slope: impl Fn(f64) -> f64,
) -> Prediction {
    let (mut sum, mut lost) = (0.0, 0usize);
    for (s, &limit) in samples.iter().zip(limits) {
        let k = slope(s.along);
        sum += point_variance(s, k, finest, g);
        if k > limit * (1.0 + 1e-9) {
            lost += 1;
        }
    }
    let n = samples.len().max(1) as f64;
    Prediction {
        rms_per_rad: (sum / n).sqrt(),
        unresolvable: lost as f64 / n,
        min_camera_period: percentile_period,
    }
}
