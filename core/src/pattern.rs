//! Pattern sets and row-by-row pattern generation (paper §5.1-5.2, eqs 5, 7 and 14).
//!
//! A [`PatternSet`] is a phase function Φ^(P) plus a list of *levels*. Level k projects
//! `c_k·Φ^(P)` (its scale coefficient `c_k`, eq 7) at each of its phase shifts `δ_n`:
//!
//! ```text
//! I_n^k(ξ, η) = I_min + (I_max − I_min)/2 · [1 + sin(c_k·Φ^(P)(ξ, η) + δ_n + φ_off)]
//! ```
//!
//! which is eq 7 (`I_min = 0`, `δ_n = (n−1)π/2`) and eq 14 (`δ_n = 2π(n−1)/N`). The *cosine*
//! convention of other systems is the same with `φ_off = π/2`; any other constant offset goes in
//! [`PatternSet::with_phase_offset`].
//!
//! The images of a set have an order: the order in which they are projected and captured, and in
//! which decoders expect them. [`PatternSet::image`] maps an image index to its level and shift.
//! The built-in sets put the level that carries the DC term A (the one with ≥ 3 shifts) first,
//! so that a frame-sequential decoder can use A for the 2-image levels as soon as they arrive.

pub use crate::binary::Binarization;
use crate::binary::pixel_centre;
use crate::estimator::level_estimator;
pub use crate::gray::GrayCode;
use crate::limits::MAX_GRAY_LEVELS;
pub use crate::pattern_error::{PatternError, PatternErrorKind};
use crate::phase_function::{Axis, PhaseFunction, PhaseFunctionError};

// The set's size limits live in `crate::limits` (below the estimator, which this module uses to
// check a level's shifts); re-exported here, where they have always been.
pub use crate::limits::{MAX_IMAGES, MAX_LEVELS, MAX_SHIFTS};

/// Margin (radians) kept between the coarsest level's phase range and ±π by
/// [`PatternSet::validate`]: none. The range must lie strictly inside (−π, π), so a coarse level
/// may span one whole period across the projector (`PhaseFunction::centered` with span 2π gives
/// ±π·(1 − 1/n)); the decoder guards the wrap seam itself, refusing pixels whose coarse phase
/// lies within the range tolerance of it ([`crate::arith::Plan::accepted_coarse`]). Until issue
/// #20 it was 0.05 rad, which made users shrink the declared projector.
pub const COARSE_MARGIN: f64 = 0.0;

/// The largest magnitude of a phase shift or of the constant phase offset, radians: 2π. Any angle
/// has an equal one within `[−2π, 2π]`; far outside it, `c_k·Φ + δ` loses Φ's bits to δ's
/// exponent (at 1e300 every pattern comes out constant).
pub const MAX_SHIFT_MAGNITUDE: f64 = core::f64::consts::TAU;

/// Whether the fringe profile is written with sin (the paper, eq 5) or cos.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Convention {
    /// `I = A + B·sin(Φ + δ)`, as in the paper.
    Sine,
    /// `I = A + B·cos(Φ + δ)`, common in other systems; equals the sine form with δ + π/2.
    Cosine,
}

/// One level of a pattern set: a scale coefficient `c_k` and its phase shifts.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Level {
    scale: f64,
    n: usize,
    shifts: [f64; MAX_SHIFTS],
    gray: Option<GrayCode>,
}

impl Level {
    /// A level with explicit phase shifts (radians), e.g. measured shifts of another system.
    pub fn with_shifts(scale: f64, shifts: &[f64]) -> Self {
        let mut s = [0.0; MAX_SHIFTS];
        let n = shifts.len().min(MAX_SHIFTS);
        s[..n].copy_from_slice(&shifts[..n]);
        // An over-long list is kept as an invalid count so that validation reports it.
        Level {
            scale,
            n: shifts.len(),
            shifts: s,
            gray: None,
        }
    }

    /// A Gray-code level ([`crate::gray`]): `code.images()` binary images giving the fringe
    /// order of the phase level after it, whose scale must equal `scale`.
    pub fn gray_code(scale: f64, code: GrayCode) -> Self {
        Level {
            scale,
            n: code.images(),
            shifts: [0.0; MAX_SHIFTS],
            gray: Some(code),
        }
    }

    /// The generic N-step level of eq 14: shifts `2π(n−1)/N`, n = 1..N.
    pub fn n_step(scale: f64, n_steps: usize) -> Self {
        let mut s = [0.0; MAX_SHIFTS];
        for (i, v) in s.iter_mut().enumerate().take(n_steps.min(MAX_SHIFTS)) {
            *v = core::f64::consts::TAU * i as f64 / n_steps as f64;
        }
        Level {
            scale,
            n: n_steps,
            shifts: s,
            gray: None,
        }
    }

    /// The paper's 2-image level (eq 7 with n = 1, 2): shifts 0 and π/2; it needs the DC term A of
    /// another level (eq 11).
    pub fn two_step(scale: f64) -> Self {
        Self::with_shifts(scale, &[0.0, core::f64::consts::FRAC_PI_2])
    }

    /// The scale coefficient `c_k` of eq 7.
    pub fn scale(&self) -> f64 {
        self.scale
    }

    /// The phase shifts, radians (none for a Gray-code level).
    pub fn shifts(&self) -> &[f64] {
        if self.gray.is_some() {
            return &[];
        }
        &self.shifts[..self.n.min(MAX_SHIFTS)]
    }

    /// The code of a Gray-code level, `None` for a phase level.
    pub fn gray(&self) -> Option<GrayCode> {
        self.gray
    }

    /// Number of shifts (images) of the level.
    pub fn len(&self) -> usize {
        self.n
    }

    /// `true` if the level has no images.
    pub fn is_empty(&self) -> bool {
        self.n == 0
    }

    /// `true` if the level estimates its own DC term (3 or more shifts, eqs 10 and 15).
    pub fn has_dc(&self) -> bool {
        self.gray.is_none() && self.n >= 3
    }
}

/// The built-in level structures, written once here: pattern-set files (`preset = "paper8"`),
/// scene descriptions and [`PatternSet::paper_eight`] / [`PatternSet::twelve_pattern`] use them.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LevelPreset {
    /// The paper's 8 images (eq 7): levels of 2, 2 and 4 images (shifts 0, π/2 and
    /// 0, π/2, π, 3π/2), scales `1 : ratio : ratio²`.
    PaperEight,
    /// The conventional 12 images: three 4-step levels (eq 14), scales `1 : ratio : ratio²`.
    Twelve,
}

impl LevelPreset {
    /// Every preset, in the order [`LevelPreset::recognize`] tries them.
    pub const ALL: [LevelPreset; 2] = [LevelPreset::PaperEight, LevelPreset::Twelve];

    /// The levels, coarse to fine, with the scale ratio `ratio` between consecutive levels.
    pub fn levels(self, ratio: f64) -> [Level; 3] {
        match self {
            LevelPreset::PaperEight => [
                Level::two_step(1.0),
                Level::two_step(ratio),
                Level::n_step(ratio * ratio, 4),
            ],
            LevelPreset::Twelve => [
                Level::n_step(1.0, 4),
                Level::n_step(ratio, 4),
                Level::n_step(ratio * ratio, 4),
            ],
        }
    }

    /// The preset and ratio that give exactly `levels` (every scale and shift to the bit; the
    /// ratio is the middle level's scale), if any.
    pub fn recognize(levels: &[Level]) -> Option<(LevelPreset, f64)> {
        let [_, middle, _] = levels else {
            return None;
        };
        let ratio = middle.scale();
        Self::ALL
            .into_iter()
            .find(|p| levels == p.levels(ratio))
            .map(|p| (p, ratio))
    }
}

/// Which level and shift one image of a set shows.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ImageId {
    /// Level index (0 = coarsest).
    pub level: u8,
    /// Shift index within the level (0-based: the paper's n − 1).
    pub shift: u8,
}

/// The intensity range and size of generated patterns.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Output {
    /// Projector width (ξ extent), pixels.
    pub width: u32,
    /// Projector height (η extent), pixels.
    pub height: u32,
    /// Gray level of the fringe minimum (0 in eq 5).
    pub i_min: f64,
    /// Gray level of the fringe maximum, `I_max^(P)` of eq 5 (255 for 8-bit patterns).
    pub i_max: f64,
}

/// A complete, validated description of a fringe pattern set.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PatternSet {
    function: PhaseFunction,
    levels: [Level; MAX_LEVELS],
    n_levels: usize,
    order: [ImageId; MAX_IMAGES],
    n_images: usize,
    convention: Convention,
    phase_offset: f64,
    output: Output,
    coarse_range: (f64, f64),
    relation: Relation,
    binary: Binarization,
}

pub use crate::relation::{MAX_COPRIME, MAX_COPRIME_LEVELS, Relation, coprime_ratio};

impl crate::relation::Scaled for Level {
    fn scale(&self) -> f64 {
        self.scale
    }
}

impl PatternSet {
    /// A set from a phase function, levels ordered coarse to fine, and the projector output.
    ///
    /// Images are ordered with the DC-bearing levels first (finest first among them), then the
    /// remaining levels from coarse to fine, each level's shifts in order. Use
    /// [`PatternSet::with_order`] for captured data in another order.
    pub fn new(
        function: PhaseFunction,
        levels: &[Level],
        output: Output,
    ) -> Result<Self, PatternError> {
        Self::new_with_relation(function, levels, output, Relation::Hierarchical)
    }

    /// [`PatternSet::new`] with the levels in `relation` ([`Relation::Heterodyne`]: the coarsest
    /// level need not be within one period, the beat must).
    pub fn new_with_relation(
        function: PhaseFunction,
        levels: &[Level],
        output: Output,
        relation: Relation,
    ) -> Result<Self, PatternError> {
        if levels.is_empty() || levels.len() > MAX_LEVELS {
            return Err(PatternError::LevelCount(levels.len()));
        }
        let mut lv = [Level::with_shifts(0.0, &[]); MAX_LEVELS];
        lv[..levels.len()].copy_from_slice(levels);
        let total: usize = levels.iter().map(|l| l.n).sum();
        if total > MAX_IMAGES {
            return Err(PatternError::TooManyImages(total));
        }
        let mut order = [ImageId { level: 0, shift: 0 }; MAX_IMAGES];
        let mut k = 0;
        for pass in 0..2 {
            let dc_pass = pass == 0;
            let mut idx = [0usize; MAX_LEVELS];
            let mut m = 0;
            // (`get`, `take`: `levels.len() <= MAX_LEVELS` was checked above; no panic path is
            // compiled in.)
            for (i, l) in levels.iter().enumerate() {
                if l.has_dc() != dc_pass {
                    continue;
                }
                if let Some(slot) = idx.get_mut(m) {
                    *slot = i;
                    m += 1;
                }
            }
            if let Some(used) = idx.get_mut(..m).filter(|_| dc_pass) {
                used.reverse();
            }
            for &li in idx.iter().take(m) {
                let Some(level) = levels.get(li) else {
                    continue;
                };
                for s in 0..level.n.min(MAX_SHIFTS) {
                    if k < MAX_IMAGES {
                        order[k] = ImageId {
                            level: li as u8,
                            shift: s as u8,
                        };
                        k += 1;
                    }
                }
            }
        }
        let mut set = PatternSet {
            function,
            levels: lv,
            n_levels: levels.len(),
            order,
            n_images: total,
            convention: Convention::Sine,
            phase_offset: 0.0,
            output,
            coarse_range: (0.0, 0.0),
            relation,
            binary: Binarization::Off,
        };
        set.validate()?;
        Ok(set)
    }

    /// The paper's 8-pattern, 3-level set (eq 7): level 0 and 1 with 2 images (shifts 0, π/2),
    /// level 2 with 4 (shifts 0, π/2, π, 3π/2), scale coefficients `1 : ratio : ratio²`.
    pub fn paper_eight(
        function: PhaseFunction,
        ratio: f64,
        output: Output,
    ) -> Result<Self, PatternError> {
        Self::new(function, &LevelPreset::PaperEight.levels(ratio), output)
    }

    /// The conventional 12-pattern set: three 4-step levels, scales `1 : ratio : ratio²`.
    pub fn twelve_pattern(
        function: PhaseFunction,
        ratio: f64,
        output: Output,
    ) -> Result<Self, PatternError> {
        Self::new(function, &LevelPreset::Twelve.levels(ratio), output)
    }

    /// The default set of fringe3d: [`PatternSet::paper_eight`] with vertical fringes, the coarse
    /// level spanning 90 % of (−π, π) across the projector width, and a level ratio of 8
    /// (so the finest level has 0.9·64 = 57.6 periods across the width).
    pub fn default_for(axis: Axis, output: Output) -> Result<Self, PatternError> {
        let size = match axis {
            Axis::Xi => output.width,
            Axis::Eta => output.height,
        };
        let f = PhaseFunction::centered(axis, size, 0.9 * core::f64::consts::TAU)?;
        Self::paper_eight(f, 8.0, output)
    }

    /// How the levels give the absolute phase.
    pub fn relation(&self) -> Relation {
        self.relation
    }

    /// Use the sine (paper) or cosine convention.
    pub fn with_convention(mut self, c: Convention) -> Self {
        self.convention = c;
        self
    }

    /// Write the phase levels as 1-bit images ([`crate::binary`]); Gray-code levels are binary
    /// already.
    pub fn with_binarization(mut self, b: Binarization) -> Self {
        self.binary = b;
        self
    }

    /// Gray-level or binary phase levels.
    pub fn binarization(&self) -> Binarization {
        self.binary
    }

    /// Add a constant phase offset (radians, within ±[`MAX_SHIFT_MAGNITUDE`] = ±2π) to every
    /// pattern.
    pub fn with_phase_offset(mut self, offset: f64) -> Result<Self, PatternError> {
        if !offset.is_finite() {
            return Err(PatternError::Function(PhaseFunctionError::NotFinite));
        }
        if !(-MAX_SHIFT_MAGNITUDE..=MAX_SHIFT_MAGNITUDE).contains(&offset) {
            return Err(PatternError::PhaseOffset);
        }
        self.phase_offset = offset;
        Ok(self)
    }

    /// Use an explicit image order (for captured data of other systems).
    pub fn with_order(mut self, order: &[ImageId]) -> Result<Self, PatternError> {
        if order.len() != self.n_images {
            return Err(PatternError::ImageOrder);
        }
        let mut seen = [[false; MAX_SHIFTS]; MAX_LEVELS];
        // (`get`, `zip`: the same checks with no panic path compiled in.)
        for id in order {
            let (l, s) = (id.level as usize, id.shift as usize);
            let shifts = self.levels().get(l).map_or(0, |lv| lv.n);
            let Some(slot) = seen.get_mut(l).and_then(|r| r.get_mut(s)) else {
                return Err(PatternError::ImageOrder);
            };
            if s >= shifts || *slot {
                return Err(PatternError::ImageOrder);
            }
            *slot = true;
        }
        for (d, s) in self.order.iter_mut().zip(order) {
            *d = *s;
        }
        Ok(self)
    }

    /// Re-check everything: level structure, shifts, order, the phase function over the projector.
    pub fn validate(&mut self) -> Result<(), PatternError> {
        let o = self.output;
        if o.width == 0
            || o.height == 0
            || !(o.i_min.is_finite() && o.i_max.is_finite())
            || o.i_min < 0.0
            || o.i_max > 65535.0
            || o.i_min >= o.i_max
        {
            return Err(PatternError::Output);
        }
        let mut any_two = false;
        let mut any_dc = false;
        let gray = self.levels[0].gray;
        for (i, l) in self.levels[..self.n_levels].iter().enumerate() {
            if let Some(code) = l.gray {
                if i != 0 || self.n_levels < 2 {
                    return Err(PatternError::GrayPlacement(i));
                }
                if self.n_levels > MAX_GRAY_LEVELS {
                    return Err(PatternError::LevelCount(self.n_levels));
                }
                if !code.is_valid() {
                    return Err(PatternError::GrayBits(code.bits() as usize));
                }
                if !(l.scale.is_finite() && l.scale > 0.0) {
                    return Err(PatternError::Scale(i));
                }
                continue;
            }
            if l.n < 2 || l.n > MAX_SHIFTS {
                return Err(PatternError::ShiftCount(i, l.n));
            }
            if !(l.scale.is_finite() && l.scale > 0.0) {
                return Err(PatternError::Scale(i));
            }
            // The phase level after a Gray-code level has its scale (ratio 1, to the bit).
            // (`get`: i − 1 < n_levels ≤ MAX_LEVELS; no panic path is compiled in.)
            let prev = i
                .checked_sub(1)
                .and_then(|p| self.levels.get(p))
                .map(|p| p.scale);
            if let Some(prev) = prev {
                if gray.is_some() && i == 1 {
                    if l.scale.to_bits() != prev.to_bits() {
                        return Err(PatternError::GrayPlacement(0));
                    }
                } else if l.scale <= prev {
                    return Err(PatternError::ScalesNotIncreasing(i));
                }
            }
            let bound = -MAX_SHIFT_MAGNITUDE..=MAX_SHIFT_MAGNITUDE;
            if l.shifts().iter().any(|s| !bound.contains(s)) {
                return Err(PatternError::Shift(i));
            }
            if level_estimator(l.shifts(), 0.0).is_none() {
                return Err(PatternError::DegenerateShifts(i));
            }
            any_two |= l.n == 2;
            any_dc |= l.has_dc();
        }
        if gray.is_some() && !any_dc {
            return Err(PatternError::GrayNoDc);
        }
        if any_two && !any_dc {
            return Err(PatternError::NoDcLevel);
        }
        // `n_levels` is in 1..=MAX_LEVELS here (checked above); `get` keeps a panic path out.
        let scale = |i: usize| self.levels.get(i).map_or(0.0, |l| l.scale);
        let (mut c_min, c_max) = (scale(0), scale(self.n_levels.wrapping_sub(1)));
        if self.relation == Relation::Heterodyne {
            let levels = self.levels.get(..self.n_levels).unwrap_or(&[]);
            let beat = self.relation.start_scale(levels);
            let Some(beat) = beat.filter(|b| *b > 0.0 && gray.is_none()) else {
                return Err(PatternError::HeterodyneLevels);
            };
            c_min = beat;
        }
        if self.relation == Relation::Coprime {
            let levels = self.levels.get(..self.n_levels).unwrap_or(&[]);
            let unit = self.relation.start_scale(levels);
            let Some(unit) = unit.filter(|_| gray.is_none()) else {
                return Err(PatternError::CoprimeLevels);
            };
            c_min = unit;
        }
        let Some(code) = gray else {
            self.coarse_range =
                self.function
                    .check(o.width, o.height, c_min, c_max, COARSE_MARGIN)?;
            return Ok(());
        };
        // A Gray-coded set: the function is checked with the coarse scale divided by
        // 2·B + 1 (so its range test is the code's [−B − ½, B + ½) periods, loosely), then the
        // range of c·Φ/2π is held to the code's exact [−B − ½, B − ½).
        // A phase level of less than 0.1·(2B + 1) rad fails that range's span test: checked
        // again at its own scale (within one period, which every code covers).
        let mut shrink = (2 * code.bias() + 1) as f64;
        let f = &self.function;
        let (lo, hi) = match f.check(o.width, o.height, c_min / shrink, c_max, COARSE_MARGIN) {
            Err(PhaseFunctionError::CoarseRangeTooSmall { .. }) => {
                shrink = 1.0;
                f.check(o.width, o.height, c_min, c_max, COARSE_MARGIN)?
            }
            Err(PhaseFunctionError::CoarseRangeExceeded { min, max }) => {
                let periods = |x: f32| (x as f64 * shrink / core::f64::consts::TAU) as f32;
                return Err(PatternError::GrayRange {
                    min: periods(min),
                    max: periods(max),
                    bits: code.bits(),
                    shifted: code.is_shifted(),
                });
            }
            r => r?,
        };
        let (lo, hi) = (lo * shrink, hi * shrink);
        let tau = core::f64::consts::TAU;
        let (u_lo, u_hi) = code.period_range();
        if !(lo / tau >= u_lo && hi / tau < u_hi) {
            return Err(PatternError::GrayRange {
                min: (lo / tau) as f32,
                max: (hi / tau) as f32,
                bits: code.bits(),
                shifted: code.is_shifted(),
            });
        }
        self.coarse_range = (lo, hi);
        Ok(())
    }

    /// The phase function Φ^(P).
    pub fn function(&self) -> &PhaseFunction {
        &self.function
    }

    /// The axis in which the phase is monotonic.
    pub fn axis(&self) -> Axis {
        self.function.axis()
    }

    /// The levels, coarse to fine.
    pub fn levels(&self) -> &[Level] {
        // `get`: `n_levels <= MAX_LEVELS` always; no panic path is compiled in.
        self.levels.get(..self.n_levels).unwrap_or(&[])
    }

    /// Number of images in the set.
    pub fn image_count(&self) -> usize {
        self.n_images
    }

    /// Level and shift of image `i` (in projection/capture order), or `None` past the end.
    pub fn image(&self, i: usize) -> Option<ImageId> {
        // (`get`: `n_images <= MAX_IMAGES`; no panic path is compiled in.)
        self.order.get(i).copied().filter(|_| i < self.n_images)
    }

    /// The image order.
    pub fn order(&self) -> &[ImageId] {
        self.order.get(..self.n_images).unwrap_or(&[])
    }

    /// The sine/cosine convention.
    pub fn convention(&self) -> Convention {
        self.convention
    }

    /// The constant phase offset, radians.
    pub fn phase_offset(&self) -> f64 {
        self.phase_offset
    }

    /// The total phase added to every shift: the offset, plus π/2 for the cosine convention.
    pub fn effective_offset(&self) -> f64 {
        match self.convention {
            Convention::Sine => self.phase_offset,
            Convention::Cosine => self.phase_offset + core::f64::consts::FRAC_PI_2,
        }
    }

    /// Projector size and intensity range.
    pub fn output(&self) -> &Output {
        &self.output
    }

    /// The coarsest level's phase range over the projector (radians), found by the check. For a
    /// Gray-coded set, the range of `c₀·Φ` (many periods).
    pub fn coarse_range(&self) -> (f64, f64) {
        self.coarse_range
    }

    /// The absolute phase of the finest level at projector pixel (ξ, η): `c_K·Φ^(P)(ξ, η)`, the
    /// quantity decoders return.
    pub fn finest_phase(&self, xi: f64, eta: f64) -> f64 {
        self.levels[self.n_levels - 1].scale * self.function.eval(xi, eta)
    }

    /// Whether a frame-sequential decoder can take the images in the set's order: always,
    /// except with a Gray-code image before the last image of the DC level (the level with the
    /// most shifts, ≥ 3, the finest on a tie), whose A thresholds the Gray images as they come
    /// ([`crate::gray`]). An inverse code needs no A: each image is kept until its inverse comes,
    /// which must be the next image of the code (image `2j` right before `2j + 1` among the
    /// code's images; other levels' images may come between).
    pub fn frame_sequential_order(&self) -> bool {
        let Some(code) = self.gray() else {
            return true;
        };
        if code.inverse() {
            let mut shifts = self
                .order()
                .iter()
                .filter(|id| id.level == 0)
                .map(|id| id.shift);
            while let Some(s) = shifts.next() {
                if s % 2 != 0 || shifts.next() != Some(s + 1) {
                    return false;
                }
            }
            return true;
        }
        let levels = self.levels();
        let mut dc = None;
        for (i, l) in levels.iter().enumerate() {
            let best = dc.and_then(|d: usize| levels.get(d)).map(|d| d.len());
            if l.has_dc() && best.is_none_or(|b| l.len() >= b) {
                dc = Some(i);
            }
        }
        let order = self.order();
        let last_dc = order.iter().rposition(|id| Some(id.level as usize) == dc);
        let first_gray = order.iter().position(|id| id.level == 0);
        matches!((first_gray, last_dc), (Some(g), Some(a)) if a < g)
    }

    /// The code of the set's Gray-code level (level 0), if it has one.
    pub fn gray(&self) -> Option<GrayCode> {
        self.levels[0].gray
    }

    /// Intensity (real-valued gray level, before quantization) of image `image` at (ξ, η). A
    /// Gray-code image is `I_max` where its bit is set, else `I_min` ([`crate::gray`]); so is
    /// a binary set's image, decided at the centre of the pixel containing (ξ, η)
    /// ([`crate::binary`]).
    pub fn intensity(&self, image: usize, xi: f64, eta: f64) -> Option<f64> {
        let id = self.image(image)?;
        let level = &self.levels[id.level as usize];
        let o = &self.output;
        if let Some(code) = level.gray {
            let u = level.scale * self.function.eval(xi, eta) / core::f64::consts::TAU;
            let h = code.half_stripe(u);
            return Some(if code.bright(id.shift as usize, h) {
                o.i_max
            } else {
                o.i_min
            });
        }
        let delta = level.shifts[id.shift as usize] + self.effective_offset();
        if self.binary.is_binary() {
            let (i, j) = (pixel_centre(xi), pixel_centre(eta));
            let arg = level.scale * self.function.eval(i, j) + delta;
            let bright = self.binary.bright(arg, i, j) == Some(true);
            return Some(if bright { o.i_max } else { o.i_min });
        }
        let arg = level.scale * self.function.eval(xi, eta) + delta;
        Some(o.i_min + 0.5 * (o.i_max - o.i_min) * (1.0 + libm::sin(arg)))
    }

    /// Write row `eta` of image `image` into `out` (one value per projector column, `out.len()`
    /// must equal the projector width), quantized to the nearest gray level (ties away from zero).
    ///
    /// Generic over the output sample type: `u8` for 8-bit projectors, `u16` for 16-bit ones.
    /// Returns an error if the image or row index is out of range or `out` has the wrong length.
    pub fn generate_row<T: PatternSample>(
        &self,
        image: usize,
        eta: u32,
        out: &mut [T],
    ) -> Result<(), RowError> {
        if image >= self.n_images {
            return Err(RowError::Image);
        }
        if eta >= self.output.height {
            return Err(RowError::Row);
        }
        if out.len() != self.output.width as usize {
            return Err(RowError::Length);
        }
        if self.output.i_max > T::MAX {
            return Err(RowError::Depth);
        }
        for (xi, o) in out.iter_mut().enumerate() {
            let v = self.intensity(image, xi as f64, eta as f64).unwrap_or(0.0);
            *o = T::quantize(v);
        }
        Ok(())
    }
}

/// Why a pattern row could not be generated.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RowError {
    /// Image index past the end of the set.
    Image,
    /// Row index past the projector height.
    Row,
    /// Output buffer length differs from the projector width.
    Length,
    /// `I_max` exceeds what the sample type holds.
    Depth,
}

impl RowError {
    /// The error itself (all variants are argument errors).
    pub fn kind(&self) -> RowError {
        *self
    }
}

impl core::fmt::Display for RowError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            RowError::Image => "image index out of range",
            RowError::Row => "row index out of range",
            RowError::Length => "row buffer length differs from the projector width",
            RowError::Depth => "I_max does not fit the sample type",
        })
    }
}

/// A pattern pixel type: `u8` or `u16`.
pub trait PatternSample: Copy {
    /// Largest value.
    const MAX: f64;
    /// Round a gray level to the nearest code (ties away from zero), clamped to the type's range.
    fn quantize(v: f64) -> Self;
}

impl PatternSample for u8 {
    const MAX: f64 = 255.0;
    fn quantize(v: f64) -> Self {
        let r = libm::round(v);
        if r >= 255.0 {
            255
        } else if r > 0.0 {
            r as u8
        } else {
            0
        }
    }
}

impl PatternSample for u16 {
    const MAX: f64 = 65535.0;
    fn quantize(v: f64) -> Self {
        let r = libm::round(v);
        if r >= 65535.0 {
            65535
        } else if r > 0.0 {
            r as u16
        } else {
            0
        }
    }
}

#[cfg(test)]
mod tests;
