//! Phase functions Φ(ξ, η) over the projector image plane (paper §5.1, step 1).
//!
//! A phase function must be continuous and strictly monotonic along one projector axis: the
//! point-cloud construction relies on it (paper §6, step 1). The built-in functions are
//!
//! - [`Profile::Linear`]: `g(s) = slope·(s − origin)`, the straight, fixed-width fringes of eq 6;
//! - [`Profile::Knots`]: a monotonic cubic Hermite curve through knots `(s_i, Φ_i)` with given
//!   positive slopes: fringes whose width varies continuously (paper Fig. 2(b));
//!
//! and each may be bent by a quadratic term, `Φ(ξ, η) = g(ξ + a·(η − η₀)²)` for vertical fringes
//! (ξ and η swap roles for horizontal ones): curved fringes.
//!
//! Φ here is the *base* phase `Φ^(P)` of eq 7; level k of a pattern set projects `c_k·Φ^(P)`.
//! By our convention the built-in sets choose `c_0 = 1`, so Φ^(P) itself must stay inside
//! (−π, π) over the projector: [`PhaseFunction::check`] verifies that together with monotonicity
//! and continuity. Evaluation is in f64 (pattern generation and set-up, not the per-pixel decode).

/// The projector image axis in which a phase function is monotonic.
///
/// `Xi` (ξ, projector columns) gives vertical fringes; `Eta` (η, projector rows) horizontal ones.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Axis {
    /// Monotonic along ξ (projector x, columns): vertical fringes.
    Xi,
    /// Monotonic along η (projector y, rows): horizontal fringes.
    Eta,
}

/// The most knots a [`KnotProfile`] holds (fixed so that phase functions need no allocation).
pub const MAX_KNOTS: usize = 16;

/// The least phase range (radians) the coarsest level must span over the projector
/// ([`PhaseFunction::check`]). Below it the coarsest patterns vary by less than 5 % of their gray
/// range across the whole projector: nearly constant, useless as the absolute reference of
/// eqs 12-13 (a tiny span, slope or scale coefficient gives that).
pub const MIN_COARSE_SPAN: f64 = 0.1;

/// Why a phase function or its parameters were refused.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PhaseFunctionError {
    /// A parameter is NaN or infinite.
    NotFinite,
    /// The linear slope is zero or negative: the function must increase along its axis.
    NonPositiveSlope,
    /// Fewer than 2 or more than [`MAX_KNOTS`] knots.
    KnotCount(usize),
    /// Knot positions or values do not strictly increase at this knot index.
    KnotsNotIncreasing(usize),
    /// A knot slope is not positive at this knot index.
    KnotSlope(usize),
    /// The cubic segment starting at this knot index is not monotonic (its end slopes are too
    /// steep for its secant: Fritsch–Carlson condition α² + β² ≤ 9 violated).
    SegmentNotMonotonic(usize),
    /// Sampled over the projector, Φ does not strictly increase between these two pixel positions
    /// along the axis (ξ or η, and the other coordinate).
    NotMonotonic {
        /// Position along the monotonic axis where the decrease was found.
        along: u32,
        /// Position along the other axis.
        across: u32,
    },
    /// Between two adjacent projector pixels the phase of the finest level jumps by more than
    /// π/2: the function is discontinuous or too steep for the projector to render.
    Discontinuous {
        /// Position along the monotonic axis where the jump was found.
        along: u32,
        /// Position along the other axis.
        across: u32,
    },
    /// The coarsest level's phase leaves (−π + margin, π − margin) over the projector, so it
    /// would wrap and could not serve as the absolute reference (eqs 12-13).
    CoarseRangeExceeded {
        /// Lowest phase of the coarsest level over the projector.
        min: f32,
        /// Highest phase of the coarsest level over the projector.
        max: f32,
    },
    /// The coarsest level's phase spans less than [`MIN_COARSE_SPAN`] over the projector: its
    /// patterns are nearly constant.
    CoarseRangeTooSmall {
        /// The coarsest level's phase range over the projector, radians.
        span: f32,
    },
    /// The bend centre `w₀` lies outside the projector extended by its size on either side
    /// (`−n ≤ w₀ ≤ 2n` for `n` pixels across the fringes).
    BendCenter,
    /// Curved fringes move by more than the projector's size along the fringe axis:
    /// `|a|·(w − w₀)²` exceeds it at an end line.
    BendTooLarge {
        /// The largest displacement over the projector, pixels.
        shift: f32,
        /// The projector's size along the fringe axis, pixels.
        size: u32,
    },
}

impl PhaseFunctionError {
    /// A coarse classification of the error, for callers that branch on it.
    pub fn kind(&self) -> PhaseFunctionErrorKind {
        match self {
            Self::NotFinite
            | Self::NonPositiveSlope
            | Self::KnotCount(_)
            | Self::KnotsNotIncreasing(_)
            | Self::KnotSlope(_)
            | Self::SegmentNotMonotonic(_) => PhaseFunctionErrorKind::InvalidParameter,
            Self::NotMonotonic { .. } => PhaseFunctionErrorKind::NotMonotonic,
            Self::Discontinuous { .. } => PhaseFunctionErrorKind::Discontinuous,
            Self::CoarseRangeExceeded { .. } | Self::CoarseRangeTooSmall { .. } => {
                PhaseFunctionErrorKind::Range
            }
            Self::BendCenter | Self::BendTooLarge { .. } => {
                PhaseFunctionErrorKind::InvalidParameter
            }
        }
    }
}

/// Coarse classes of [`PhaseFunctionError`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PhaseFunctionErrorKind {
    /// A parameter is malformed.
    InvalidParameter,
    /// The function is not strictly monotonic along its axis.
    NotMonotonic,
    /// The function jumps between adjacent pixels.
    Discontinuous,
    /// The coarse level would wrap.
    Range,
}

impl core::fmt::Display for PhaseFunctionError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::NotFinite => write!(f, "a phase-function parameter is NaN or infinite"),
            Self::NonPositiveSlope => write!(f, "the linear phase slope must be positive"),
            Self::KnotCount(n) => write!(f, "{n} knots given; need 2 to {MAX_KNOTS}"),
            Self::KnotsNotIncreasing(i) => {
                write!(f, "knot {i}: positions and phases must strictly increase")
            }
            Self::KnotSlope(i) => write!(f, "knot {i}: slope must be positive"),
            Self::SegmentNotMonotonic(i) => write!(
                f,
                "segment after knot {i} is not monotonic: its end slopes are too steep for its secant \
                 (need (m0/d)^2 + (m1/d)^2 <= 9)"
            ),
            Self::NotMonotonic { along, across } => write!(
                f,
                "phase does not increase at projector position {along} along the fringe axis (line {across})"
            ),
            Self::Discontinuous { along, across } => write!(
                f,
                "finest-level phase jumps by more than pi/2 between adjacent projector pixels at {along} \
                 (line {across}): discontinuous or too fine to project"
            ),
            Self::CoarseRangeExceeded { min, max } => write!(
                f,
                "coarsest level spans [{min:.4}, {max:.4}] rad; it must stay strictly inside (-pi, pi): at most one period across the projector"
            ),
            Self::CoarseRangeTooSmall { span } => write!(
                f,
                "coarsest level spans only {span:.3e} rad across the projector; it needs at least \
                 {MIN_COARSE_SPAN} rad, else its patterns are nearly constant"
            ),
            Self::BendCenter => write!(
                f,
                "bend centre must lie within [-n, 2n] for n projector pixels across the fringes"
            ),
            Self::BendTooLarge { shift, size } => write!(
                f,
                "curvature moves the fringes by {shift:.4e} pixels; at most the projector's {size} \
                 pixels along the fringe axis"
            ),
        }
    }
}

/// A monotonic cubic Hermite curve through knots, extended linearly beyond the end knots.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct KnotProfile {
    n: usize,
    s: [f64; MAX_KNOTS],
    phi: [f64; MAX_KNOTS],
    slope: [f64; MAX_KNOTS],
}

impl KnotProfile {
    /// Knots at positions `s` (projector pixels, strictly increasing) with phases `phi` (radians,
    /// strictly increasing) and slopes `slope` (radians per pixel, positive). All three slices must
    /// have the same length, 2 to [`MAX_KNOTS`].
    ///
    /// Each segment must satisfy the Fritsch–Carlson condition so that the cubic is monotonic.
    pub fn new(s: &[f64], phi: &[f64], slope: &[f64]) -> Result<Self, PhaseFunctionError> {
        let n = s.len();
        if !(2..=MAX_KNOTS).contains(&n) || phi.len() != n || slope.len() != n {
            return Err(PhaseFunctionError::KnotCount(
                n.max(phi.len()).max(slope.len()),
            ));
        }
        let mut k = KnotProfile {
            n,
            s: [0.0; MAX_KNOTS],
            phi: [0.0; MAX_KNOTS],
            slope: [0.0; MAX_KNOTS],
        };
        for i in 0..n {
            if !(s[i].is_finite() && phi[i].is_finite() && slope[i].is_finite()) {
                return Err(PhaseFunctionError::NotFinite);
            }
            if slope[i] <= 0.0 {
                return Err(PhaseFunctionError::KnotSlope(i));
            }
            if i > 0 && (s[i] <= s[i - 1] || phi[i] <= phi[i - 1]) {
                return Err(PhaseFunctionError::KnotsNotIncreasing(i));
            }
            k.s[i] = s[i];
            k.phi[i] = phi[i];
            k.slope[i] = slope[i];
        }
        for i in 0..n - 1 {
            let d = (phi[i + 1] - phi[i]) / (s[i + 1] - s[i]);
            let a = slope[i] / d;
            let b = slope[i + 1] / d;
            if a * a + b * b > 9.0 {
                return Err(PhaseFunctionError::SegmentNotMonotonic(i));
            }
        }
        Ok(k)
    }

    /// Knots chosen so the fringe *width* varies: the local slope (rad/px) is given at each knot
    /// position and the knot phases follow by the trapezoid rule, starting at `phi0` at `s[0]`.
    ///
    /// This is the usual way to design a variable-width pattern (narrow fringes where the surface
    /// faces the projector, wide ones where it turns away, paper Fig. 2).
    pub fn from_slopes(s: &[f64], slope: &[f64], phi0: f64) -> Result<Self, PhaseFunctionError> {
        let n = s.len();
        if !(2..=MAX_KNOTS).contains(&n) || slope.len() != n {
            return Err(PhaseFunctionError::KnotCount(n.max(slope.len())));
        }
        let mut phi = [0.0f64; MAX_KNOTS];
        phi[0] = phi0;
        for i in 1..n {
            phi[i] = phi[i - 1] + 0.5 * (slope[i] + slope[i - 1]) * (s[i] - s[i - 1]);
        }
        Self::new(s, &phi[..n], slope)
    }

    /// Number of knots.
    pub fn len(&self) -> usize {
        self.n
    }

    /// `false` always: a profile has at least 2 knots.
    pub fn is_empty(&self) -> bool {
        false
    }

    /// Knot positions.
    pub fn positions(&self) -> &[f64] {
        &self.s[..self.n]
    }

    /// Knot phases.
    pub fn phases(&self) -> &[f64] {
        &self.phi[..self.n]
    }

    /// Knot slopes.
    pub fn slopes(&self) -> &[f64] {
        &self.slope[..self.n]
    }

    /// Evaluate at `x` (cubic Hermite inside, linear extension outside).
    pub fn eval(&self, x: f64) -> f64 {
        // A profile has 2 to MAX_KNOTS knots; the clamp only tells the compiler (no panic path).
        let n = self.n.clamp(1, MAX_KNOTS);
        if x <= self.s[0] {
            return self.phi[0] + self.slope[0] * (x - self.s[0]);
        }
        if x >= self.s[n - 1] {
            return self.phi[n - 1] + self.slope[n - 1] * (x - self.s[n - 1]);
        }
        // Fixed-length scan: n ≤ MAX_KNOTS.
        let mut i = 0;
        for j in 0..n - 1 {
            if x >= self.s[j] {
                i = j;
            }
        }
        let h = self.s[i + 1] - self.s[i];
        let t = (x - self.s[i]) / h;
        let t2 = t * t;
        let t3 = t2 * t;
        let h00 = 2.0 * t3 - 3.0 * t2 + 1.0;
        let h10 = t3 - 2.0 * t2 + t;
        let h01 = -2.0 * t3 + 3.0 * t2;
        let h11 = t3 - t2;
        h00 * self.phi[i]
            + h10 * h * self.slope[i]
            + h01 * self.phi[i + 1]
            + h11 * h * self.slope[i + 1]
    }
}

/// The 1-D profile `g(s)` of a phase function along its monotonic axis.
// Knots are stored inline (no allocation); the size difference is the point.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Profile {
    /// `g(s) = slope·(s − origin)`: straight fringes of fixed width (eq 6, with the origin moved to
    /// `origin` so that the phase is centred and f32 keeps its precision).
    Linear {
        /// Position (projector pixels) where the phase is zero.
        origin: f64,
        /// Phase per projector pixel (radians/pixel), positive.
        slope: f64,
    },
    /// A monotonic cubic through knots: fringes of continuously varying width.
    Knots(KnotProfile),
}

impl Profile {
    /// Evaluate `g(s)`.
    pub fn eval(&self, s: f64) -> f64 {
        match self {
            Profile::Linear { origin, slope } => slope * (s - origin),
            Profile::Knots(k) => k.eval(s),
        }
    }
}

/// A phase function `Φ(ξ, η) = g(t + a·(w − w₀)²)`, with `t` the coordinate along `axis` and `w`
/// the other one (paper §5.1). With `a = 0` the fringes are straight.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PhaseFunction {
    axis: Axis,
    profile: Profile,
    curvature: f64,
    bend_center: f64,
}

impl PhaseFunction {
    /// Straight fringes of fixed width (eq 6): `Φ = slope·(t − origin)`.
    pub fn linear(axis: Axis, origin: f64, slope: f64) -> Result<Self, PhaseFunctionError> {
        if !(origin.is_finite() && slope.is_finite()) {
            return Err(PhaseFunctionError::NotFinite);
        }
        if slope <= 0.0 {
            return Err(PhaseFunctionError::NonPositiveSlope);
        }
        Ok(Self {
            axis,
            profile: Profile::Linear { origin, slope },
            curvature: 0.0,
            bend_center: 0.0,
        })
    }

    /// The linear function that spans `(−span/2, span/2)` radians across a projector `size`
    /// pixels long along `axis`, centred at its middle pixel: the usual coarse-level choice
    /// (e.g. `span = 0.9·2π` leaves a 5 % margin on each side of (−π, π)).
    pub fn centered(axis: Axis, size: u32, span: f64) -> Result<Self, PhaseFunctionError> {
        let size = size as f64;
        Self::linear(axis, 0.5 * (size - 1.0), span / size)
    }

    /// A function with any profile.
    pub fn with_profile(axis: Axis, profile: Profile) -> Result<Self, PhaseFunctionError> {
        if let Profile::Linear { origin, slope } = profile {
            return Self::linear(axis, origin, slope);
        }
        Ok(Self {
            axis,
            profile,
            curvature: 0.0,
            bend_center: 0.0,
        })
    }

    /// Bend the fringes: `Φ = g(t + a·(w − w₀)²)` with `a = curvature` (1/pixel) and
    /// `w₀ = center` (pixels along the other axis).
    pub fn curved(mut self, curvature: f64, center: f64) -> Result<Self, PhaseFunctionError> {
        if !(curvature.is_finite() && center.is_finite()) {
            return Err(PhaseFunctionError::NotFinite);
        }
        self.curvature = curvature;
        self.bend_center = center;
        Ok(self)
    }

    /// The axis along which Φ increases.
    pub fn axis(&self) -> Axis {
        self.axis
    }

    /// The 1-D profile.
    pub fn profile(&self) -> &Profile {
        &self.profile
    }

    /// The bending coefficient `a` (0 for straight fringes).
    pub fn curvature(&self) -> f64 {
        self.curvature
    }

    /// The line `w₀` about which fringes bend.
    pub fn bend_center(&self) -> f64 {
        self.bend_center
    }

    /// Φ at projector pixel (ξ, η), in radians.
    #[inline]
    pub fn eval(&self, xi: f64, eta: f64) -> f64 {
        let (t, w) = match self.axis {
            Axis::Xi => (xi, eta),
            Axis::Eta => (eta, xi),
        };
        let dw = w - self.bend_center;
        self.profile.eval(t + self.curvature * dw * dw)
    }

    /// Check the function over a projector of `width × height` pixels for a pattern set whose
    /// coarsest and finest scale coefficients are `c_min` and `c_max` (eq 7):
    ///
    /// - strictly increasing along the axis between every pair of adjacent pixels;
    /// - continuous: the finest level's phase (`c_max·Φ`) changes by at most π/2 between adjacent
    ///   pixels along the axis (at least 4 projector pixels per fringe period), so the projected
    ///   fringes are resolvable;
    /// - the coarsest level's phase (`c_min·Φ`) stays inside `(−π + margin, π − margin)` and spans
    ///   at least [`MIN_COARSE_SPAN`];
    /// - the bend stays within the projector: the centre `w₀` within `[−n, 2n]` (`n` pixels across
    ///   the fringes) and the displacement `|a|·(w − w₀)²` at most the size along the axis.
    ///
    /// Every pixel is visited (the projector grid is small: a megapixel takes a few ms); for
    /// straight fringes one line, which every other line equals. Returns the coarsest level's
    /// phase range on success.
    pub fn check(
        &self,
        width: u32,
        height: u32,
        c_min: f64,
        c_max: f64,
        margin: f64,
    ) -> Result<(f64, f64), PhaseFunctionError> {
        let (n_along, n_across) = match self.axis {
            Axis::Xi => (width, height),
            Axis::Eta => (height, width),
        };
        let across_size = f64::from(n_across);
        let w0 = self.bend_center;
        if !(w0 >= -across_size && w0 <= 2.0 * across_size) {
            return Err(PhaseFunctionError::BendCenter);
        }
        // The displacement a·(w − w₀)² is largest in magnitude at an end line (w₀ may lie outside).
        let (d0, d1) = (w0, across_size - 1.0 - w0);
        let d2 = if d0 * d0 > d1 * d1 { d0 * d0 } else { d1 * d1 };
        let a = if self.curvature < 0.0 {
            -self.curvature
        } else {
            self.curvature
        };
        let shift = a * d2;
        if !(shift <= f64::from(n_along)) {
            return Err(PhaseFunctionError::BendTooLarge {
                shift: shift as f32,
                size: n_along,
            });
        }
        // Straight fringes (no curvature): every line across is the same function of the
        // coordinate along, so the first line decides (same values, same first error).
        let n_across = if self.curvature == 0.0 {
            n_across.min(1)
        } else {
            n_across
        };
        let mut lo = f64::INFINITY;
        let mut hi = f64::NEG_INFINITY;
        for across in 0..n_across {
            let mut prev = f64::NAN;
            for along in 0..n_along {
                let (xi, eta) = match self.axis {
                    Axis::Xi => (along as f64, across as f64),
                    Axis::Eta => (across as f64, along as f64),
                };
                let p = self.eval(xi, eta);
                if !p.is_finite() {
                    return Err(PhaseFunctionError::NotFinite);
                }
                if along > 0 {
                    let d = p - prev;
                    if d <= 0.0 {
                        return Err(PhaseFunctionError::NotMonotonic { along, across });
                    }
                    if d * c_max > core::f64::consts::FRAC_PI_2 {
                        return Err(PhaseFunctionError::Discontinuous { along, across });
                    }
                }
                prev = p;
                lo = if p < lo { p } else { lo };
                hi = if p > hi { p } else { hi };
            }
        }
        let (lo, hi) = (lo * c_min, hi * c_min);
        let limit = core::f64::consts::PI - margin;
        if !(lo > -limit && hi < limit) {
            return Err(PhaseFunctionError::CoarseRangeExceeded {
                min: lo as f32,
                max: hi as f32,
            });
        }
        if !(hi - lo >= MIN_COARSE_SPAN) {
            return Err(PhaseFunctionError::CoarseRangeTooSmall {
                span: (hi - lo) as f32,
            });
        }
        Ok((lo, hi))
    }
}
