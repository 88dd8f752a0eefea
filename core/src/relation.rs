//! How the levels of a pattern set give the absolute phase ([`Relation`], issue #20): the
//! paper's hierarchical unwrapping (eqs 12-13), multi-frequency heterodyne, or number-theoretic
//! (coprime-period) unwrapping. Re-exported by [`crate::pattern`], where it has always been
//! named, with the start scale of a set's levels ([`Relation::start_scale`]).

/// How the levels of a set give the absolute phase. On the wire (the last field of a
/// [`PatternSetDesc`](crate::params::pattern::PatternSetDesc), protocol version 4, set-up blob
/// version 4) a varint: `[0]` hierarchical, `[1]` heterodyne, `[2]` coprime.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum Relation {
    /// Eqs 12-13: the coarsest level is absolute (within one period over the projector) and each
    /// level unwraps the next (or a Gray-code level gives the first phase level's order).
    #[default]
    Hierarchical,
    /// Multi-frequency heterodyne (issue #20), 2 or 3 phase levels none of which need be within
    /// one period: the *beat* of levels a < b, `wrap(φ_b − φ_a)`, is the phase of scale
    /// `c_b − c_a`; with 3 levels the beat of the two beats, scale `c₂ − 2c₁ + c₀`, must be
    /// within one period over the projector (the set's coarse range). From it the chain unwraps
    /// (eqs 12-13, each step's residual checked): 2 levels `beat → φ₀ → φ₁`; 3 levels
    /// `beat of beats → beat₀₁ → φ₁ → φ₂`. Periods 21/26/32 across the projector beat to 5, 6
    /// and 1: non-integer scale ratios are the point.
    Heterodyne,
    /// Number-theoretic (coprime-period) unwrapping (issue #20): the first two phase levels'
    /// scales are `c₀ = a·u`, `c₁ = b·u` with `2 ≤ a < b` coprime integers (`b ≤`
    /// [`MAX_COPRIME`]), and `u·Φ` is within one period over the projector (the set's coarse
    /// range), while neither level nor their beat (`b − a` periods of `u`) need be. Of the
    /// orders `k₀` that put `φ₀ + 2πk₀` in range, the one whose prediction of level 1,
    /// `(b/a)(φ₀ + 2πk₀)`, lands within `π/a` of `φ₁` (at most one can: the candidates' residuals
    /// are `2π/a` apart, `a` and `b` being coprime) is the fringe order; none, or two, flag
    /// the pixel. That is the noise margin of the classic lookup-table method
    /// (`|b·δφ₀ − a·δφ₁| < π`). Further levels, up to [`MAX_COPRIME_LEVELS`] in all, unwrap
    /// hierarchically (eqs 12-13).
    Coprime,
}

/// Most levels of a coprime set ([`Relation::Coprime`]): the pair and two finer ones (each
/// level count is a kernel of its own in a head's flash).
pub const MAX_COPRIME_LEVELS: usize = 4;

/// Largest integer `b` of a coprime set's scale ratio `c₁/c₀ = b/a` ([`Relation::Coprime`]).
pub const MAX_COPRIME: u32 = 64;

/// The coprime integers `(a, b)`, `a < b ≤ MAX_COPRIME`, with `b/a = c1/c0` to within 1e-9
/// relative, if any (the smallest `a`, so coprime).
pub fn coprime_ratio(c0: f64, c1: f64) -> Option<(u32, u32)> {
    let r = c1 / c0;
    if !(r.is_finite() && r > 1.0) {
        return None;
    }
    (1..MAX_COPRIME).find_map(|a| {
        let b = libm::round(r * a as f64);
        let close = libm::fabs(b - r * a as f64) <= 1e-9 * r * a as f64;
        (close && b <= MAX_COPRIME as f64 && b > a as f64).then_some((a, b as u32))
    })
}

/// A level's scale coefficient `c_k` (eq 7): what [`Relation::start_scale`] reads of a set's
/// levels (the pattern set's `Level` implements it).
pub trait Scaled {
    /// The scale coefficient.
    fn scale(&self) -> f64;
}

impl Relation {
    /// The scale of the absolute phase the decoder starts from: the coarsest level's, a
    /// heterodyne set's beat's, a coprime set's unit `u` (`None` if the levels cannot give one:
    /// a wrong count, beats not increasing, no coprime ratio).
    pub fn start_scale<L: Scaled>(self, levels: &[L]) -> Option<f64> {
        let c = |i: usize| levels.get(i).map(Scaled::scale);
        match (self, levels.len()) {
            (Relation::Hierarchical, _) => c(0),
            (Relation::Heterodyne, 2) => Some(c(1)? - c(0)?),
            (Relation::Heterodyne, 3) => Some((c(2)? - c(1)?) - (c(1)? - c(0)?)),
            (Relation::Heterodyne, _) => None,
            (Relation::Coprime, 2..=MAX_COPRIME_LEVELS) => {
                // a = 1 is an integer ratio: hierarchical, with its own unwrapping check.
                let (a, _) = coprime_ratio(c(0)?, c(1)?).filter(|(a, _)| *a >= 2)?;
                Some(c(0)? / a as f64)
            }
            (Relation::Coprime, _) => None,
        }
    }
}
