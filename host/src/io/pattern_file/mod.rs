//! Pattern-set files: a documented TOML description of a fringe pattern set, mapped onto
//! [`fringe3d_core::pattern::PatternSet`].
//!
//! ```toml
//! version = 1
//! convention = "sine"        # or "cosine"
//! phase_offset = 0.0         # radians, added to every pattern
//! preset = "paper8"          # or "twelve"; or explicit [[levels]]
//! ratio = 8.0                # scale ratio between levels of a preset
//!
//! [projector]
//! width = 1024
//! height = 768
//! bit_depth = 8              # i_min = 0 and i_max = 255 by default
//!
//! [phase]
//! axis = "xi"                # vertical fringes; "eta" for horizontal ones
//! kind = "centered"          # or "linear", "knots"
//! span = 5.654866776461628   # radians across the axis (default 0.9·2π)
//! ```
//!
//! `binary = "square"` or `"bayer"` writes 1-bit patterns (docs/binary.md).
//!
//! Every field is specified in `docs/formats.md`; `examples/patterns/` has one file per feature.
//! The struct mirrors the file: optional keys stay `None` so that a file read and saved again keeps
//! its shape; defaults are applied by [`PatternSetFile::to_pattern_set`].

mod names;
pub use names::{AxisName, BinaryName, ConventionName, PhaseKind, Preset, UnwrapName};

use std::f64::consts::{PI, TAU};
use std::path::{Path, PathBuf};

use fringe3d_core::pattern::{
    Convention, GrayCode, ImageId, Level, MAX_SHIFT_MAGNITUDE, Output, PatternError, PatternSet,
};
use fringe3d_core::phase_function::{
    Axis, KnotProfile, MIN_COARSE_SPAN, PhaseFunction, PhaseFunctionError, Profile,
};

use super::atomic::write_atomic;

mod write;
use super::error::{FormatError, check_toml_version, read_text, toml_message};

/// The pattern-set file format version this build writes. It reads this and
/// [`PATTERN_FILE_VERSION_LISTED`].
pub const PATTERN_FILE_VERSION: u32 = 1;

/// The format version in which explicit `[[levels]]` without `order` are projected in the listed
/// order (each level's shifts in turn, levels as listed). In version 1 they mean the built-in
/// order (see `order` in docs/formats.md), which [`PatternSetFile::implicit_order_note`] points out
/// where it differs from the listed one.
pub const PATTERN_FILE_VERSION_LISTED: u32 = 2;

/// The default span of `kind = "centered"` (and of a file without `[phase]`): 0.9·2π radians.
pub const DEFAULT_SPAN: f64 = 0.9 * TAU;

/// The largest projector width or height accepted (the phase function is checked at every
/// projector pixel, so absurd sizes would take forever).
pub const MAX_PROJECTOR_SIZE: u32 = 16384;

/// The default ratio between the scales of consecutive levels of a preset.
pub const DEFAULT_RATIO: f64 = 8.0;

/// A pattern-set file, as read from / written to TOML.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PatternSetFile {
    /// Format version: [`PATTERN_FILE_VERSION`] (= 1) or [`PATTERN_FILE_VERSION_LISTED`] (= 2,
    /// where explicit `[[levels]]` without `order` are in the listed order).
    pub version: u32,
    /// Sine (the paper's eq 5) or cosine convention; default sine.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub convention: Option<ConventionName>,
    /// Constant phase offset added to every pattern, radians; default 0.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub phase_offset: Option<f64>,
    /// A built-in level structure; exclusive with `levels`. Without either, `paper8`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub preset: Option<Preset>,
    /// Ratio between consecutive levels' scales for a preset (scales `1 : r : r²`); default 8.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub ratio: Option<f64>,
    /// The image order as `[level, shift]` pairs (0-based), for captured data of other systems;
    /// default: the order of [`PatternSet::new`].
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        deserialize_with = "read_order"
    )]
    pub order: Option<Vec<[u32; 2]>>,
    /// The file of each image, in image order, relative to the pattern file's folder.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub images: Option<Vec<PathBuf>>,
    /// Projector size and gray levels.
    pub projector: ProjectorSection,
    /// The phase function Φ^(P); default: `kind = "centered"` along ξ.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub phase: Option<PhaseSection>,
    /// Explicit levels, coarse to fine; exclusive with `preset`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub levels: Option<Vec<LevelSection>>,
    /// How the levels give the absolute phase: `"hierarchical"` (default; eqs 12-13) or
    /// `"heterodyne"` (2 or 3 levels whose beat spans one period,
    /// `fringe3d_core::pattern::Relation::Heterodyne`) or `"coprime"` (the first two levels'
    /// scales in the ratio of coprime integers, `fringe3d_core::pattern::Relation::Coprime`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub unwrap: Option<UnwrapName>,
    /// 1-bit patterns for a DLP's binary mode: `"square"` (squared binary) or `"bayer"`
    /// (ordered dithering); default `"off"`, gray-level sinusoids
    /// (`fringe3d_core::binary::Binarization`, docs/binary.md).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub binary: Option<BinaryName>,
    /// The file this was read from, for error messages and relative paths.
    #[serde(skip)]
    source: Option<PathBuf>,
}

impl PartialEq for PatternSetFile {
    /// Equal content; where the files came from does not matter.
    fn eq(&self, o: &Self) -> bool {
        self.version == o.version
            && self.convention == o.convention
            && self.phase_offset == o.phase_offset
            && self.preset == o.preset
            && self.ratio == o.ratio
            && self.order == o.order
            && self.images == o.images
            && self.projector == o.projector
            && self.phase == o.phase
            && self.levels == o.levels
            && self.unwrap == o.unwrap
            && self.binary == o.binary
    }
}

/// `order`: each entry exactly a `[level, shift]` pair (an entry of 3 indices is refused).
fn read_order<'de, D: serde::Deserializer<'de>>(d: D) -> Result<Option<Vec<[u32; 2]>>, D::Error> {
    struct Entry([u32; 2]);
    impl<'de> serde::Deserialize<'de> for Entry {
        fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
            super::exact::entry(d, "order").map(Entry)
        }
    }
    let v = <Option<Vec<Entry>> as serde::Deserialize>::deserialize(d)?;
    Ok(v.map(|v| v.into_iter().map(|e| e.0).collect()))
}

/// `[projector]`: pattern size and gray levels.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ProjectorSection {
    /// Projector width (ξ extent), pixels.
    pub width: u32,
    /// Projector height (η extent), pixels.
    pub height: u32,
    /// Gray level of the fringe minimum; default 0.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub i_min: Option<f64>,
    /// Gray level of the fringe maximum `I_max^(P)` (eq 5); default `2^bit_depth − 1`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub i_max: Option<f64>,
    /// Bits per pattern pixel, 8 or 16; default 8.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub bit_depth: Option<u8>,
    /// `true`: the images were written through the inverse of the projector's measured response
    /// (`fringe3d patterns --response`), so the light is already sinusoidal and decoding applies
    /// no gamma correction. Default false.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub response_compensated: Option<bool>,
}

/// `[phase]`: the phase function `Φ(ξ, η) = g(t + curvature·(w − bend_center)²)`.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PhaseSection {
    /// The axis along which Φ increases; default `xi`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub axis: Option<AxisName>,
    /// The profile `g`; default `centered`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub kind: Option<PhaseKind>,
    /// `linear`: position (pixels along the axis) where Φ = 0; default the axis middle `(n−1)/2`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub origin: Option<f64>,
    /// `linear`: radians per pixel, positive (required).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub slope: Option<f64>,
    /// `centered`: radians across the axis; default 0.9·2π.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub span: Option<f64>,
    /// `knots`: knot positions, pixels along the axis, increasing (required).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub positions: Option<Vec<f64>>,
    /// `knots`: Φ's slope at each knot, radians per pixel, positive (required).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub slopes: Option<Vec<f64>>,
    /// `knots`: Φ at each knot, radians, increasing. Without it, phases follow from the slopes by
    /// the trapezoid rule, starting at `phase0`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub phases: Option<Vec<f64>>,
    /// `knots` without `phases`: Φ at the first knot; default: the value that centres Φ across
    /// the axis (`g(0) = −g(n−1)`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub phase0: Option<f64>,
    /// Bend `a` of curved fringes, 1/pixel; default 0 (straight).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub curvature: Option<f64>,
    /// Line `w₀` (pixels along the other axis) about which fringes bend; default its middle when
    /// `curvature ≠ 0`, else 0.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub bend_center: Option<f64>,
}

/// One `[[levels]]` entry: a scale coefficient and its phase shifts (exactly one of `steps`,
/// `shifts`, `shifts_deg`), or a Gray-code level (`gray_bits`, with `complementary`).
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LevelSection {
    /// Scale coefficient `c_k` (eq 7), positive, increasing from level to level.
    pub scale: f64,
    /// N-step level of eq 14: shifts `2π(n−1)/N`, N ≥ 3.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub steps: Option<u32>,
    /// Explicit shifts, radians.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub shifts: Option<Vec<f64>>,
    /// Explicit shifts, degrees.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub shifts_deg: Option<Vec<f64>>,
    /// A Gray-code level of this many bits (1 to 10): binary stripe images giving the fringe
    /// order of the next level, which must have the same scale (`fringe3d_core::gray`). Only
    /// the first level.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub gray_bits: Option<u32>,
    /// With `gray_bits`: project the complementary half-period image too (one more image; no
    /// period-edge errors). Default true.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub complementary: Option<bool>,
    /// With `gray_bits`: follow every code image by its inverse and threshold each bit against
    /// it rather than the DC term (twice the images; `fringe3d_core::gray`). Default false.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub inverse: Option<bool>,
    /// With `gray_bits`: move the code's stripes by half a period, their edges to the middle of
    /// the fringes (the "shifted Gray code" of SLMaster and Wu et al. 2019;
    /// `fringe3d_core::gray`). Needs `complementary = false`. Default false.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub shifted: Option<bool>,
}

impl PatternSetFile {
    /// Read a pattern-set file and check it completely (it is converted once with
    /// [`PatternSetFile::to_pattern_set`]).
    pub fn load(path: &Path) -> Result<PatternSetFile, FormatError> {
        let text = read_text(path)?;
        // Version 2 differs only in the default order of explicit [[levels]].
        if check_toml_version(path, &text, PATTERN_FILE_VERSION_LISTED).is_err() {
            check_toml_version(path, &text, PATTERN_FILE_VERSION)?;
        }
        let mut f: PatternSetFile =
            toml::from_str(&text).map_err(|e| FormatError::parse(path, toml_message(&e)))?;
        f.source = Some(path.to_path_buf());
        f.to_pattern_set()?;
        Ok(f)
    }

    /// The file this was read from (`None` if built in memory).
    pub fn source(&self) -> Option<&Path> {
        self.source.as_deref()
    }

    /// Bits per pattern pixel: `projector.bit_depth`, default 8.
    pub fn bit_depth(&self) -> u8 {
        self.projector.bit_depth.unwrap_or(8)
    }

    fn err(&self, message: impl Into<String>) -> FormatError {
        let path = self
            .source
            .clone()
            .unwrap_or_else(|| PathBuf::from("<pattern set>"));
        FormatError::Invalid {
            path,
            message: message.into(),
        }
    }

    /// A core refusal of the whole set, naming the keys that decide it.
    fn set_error(&self, e: PatternError) -> FormatError {
        let keys = match e {
            PatternError::Function(PhaseFunctionError::CoarseRangeTooSmall { .. }) => format!(
                " (raise phase.span / phase.slope / the knot slopes, or the coarsest scale; \
                 the coarsest level must span at least {MIN_COARSE_SPAN} rad)"
            ),
            PatternError::Function(PhaseFunctionError::CoarseRangeExceeded { .. })
                if self.unwrap == Some(UnwrapName::Heterodyne) =>
            {
                " (unwrap = \"heterodyne\": the beat c1 - c0, or c2 - 2 c1 + c0 for 3 levels, \
                 times the phase must stay within one period: lower the beat or phase.span)"
                    .to_string()
            }
            PatternError::Function(PhaseFunctionError::CoarseRangeExceeded { .. })
                if self.unwrap == Some(UnwrapName::Coprime) =>
            {
                " (unwrap = \"coprime\": the unit u = c0/a of the scales c0 = a u, c1 = b u \
                 times the phase must stay within one period: lower the scales or phase.span)"
                    .to_string()
            }
            PatternError::Function(PhaseFunctionError::CoarseRangeExceeded { .. }) => {
                " (phase.span / phase.slope / the knots, or the coarsest scale)".to_string()
            }
            PatternError::HeterodyneLevels => {
                " ([[levels]] with unwrap = \"heterodyne\")".to_string()
            }
            PatternError::CoprimeLevels => " ([[levels]] with unwrap = \"coprime\")".to_string(),
            PatternError::GrayRange { .. } => {
                " (raise levels[0].gray_bits, or lower the scale or phase.span)".to_string()
            }
            PatternError::Function(PhaseFunctionError::BendTooLarge { .. }) => {
                " (phase.curvature: the bend must stay within the projector)".to_string()
            }
            PatternError::Function(PhaseFunctionError::BendCenter) => {
                " (phase.bend_center: within [-n, 2n] for n projector pixels across the fringes)"
                    .to_string()
            }
            _ => String::new(),
        };
        self.err(format!("pattern set: {e}{keys}"))
    }

    /// Build the pattern set the file describes, applying defaults. Problems found here or by the
    /// core (e.g. a non-monotonic phase function) become [`FormatError::Invalid`] naming the file
    /// and the problem.
    pub fn to_pattern_set(&self) -> Result<PatternSet, FormatError> {
        if self.version != PATTERN_FILE_VERSION && self.version != PATTERN_FILE_VERSION_LISTED {
            return Err(self.err(format!(
                "version must be {PATTERN_FILE_VERSION} or {PATTERN_FILE_VERSION_LISTED}, got {}",
                self.version
            )));
        }
        let output = self.output()?;
        let function = self.function(&output)?;
        let levels = self.levels()?;
        let relation = self.unwrap.unwrap_or(UnwrapName::Hierarchical).core();
        let mut set = PatternSet::new_with_relation(function, &levels, output, relation)
            .map_err(|e| self.set_error(e))?;
        set = set.with_convention(match self.convention.unwrap_or(ConventionName::Sine) {
            ConventionName::Sine => Convention::Sine,
            ConventionName::Cosine => Convention::Cosine,
        });
        set = set.with_binarization(self.binary.unwrap_or(BinaryName::Off).core());
        let offset = self.phase_offset.unwrap_or(0.0);
        set = set.with_phase_offset(offset).map_err(|_| {
            self.err(format!(
                "phase_offset must be finite and within [-2pi, 2pi] = [-{MAX_SHIFT_MAGNITUDE}, \
                 {MAX_SHIFT_MAGNITUDE}] radians (any angle has an equal one there), got {offset:?}"
            ))
        })?;
        if self.order.is_none()
            && self.levels.is_some()
            && self.version == PATTERN_FILE_VERSION_LISTED
        {
            let ids = listed_order(&set);
            set = set
                .with_order(&ids)
                .map_err(|e| self.err(format!("the listed order: {e}")))?;
        }
        if let Some(order) = &self.order {
            let mut ids = Vec::with_capacity(order.len());
            for (i, &[l, s]) in order.iter().enumerate() {
                let (Ok(level), Ok(shift)) = (u8::try_from(l), u8::try_from(s)) else {
                    return Err(self.err(format!("order[{i}] = [{l}, {s}] is out of range")));
                };
                ids.push(ImageId { level, shift });
            }
            let n = set.image_count();
            set = set.with_order(&ids).map_err(|e| {
                self.err(format!(
                    "order: {e} ({} entries given, the set has {n} images)",
                    ids.len()
                ))
            })?;
        }
        if let Some(images) = &self.images {
            if images.len() != set.image_count() {
                return Err(self.err(format!(
                    "images lists {} files but the set has {} images",
                    images.len(),
                    set.image_count()
                )));
            }
            if let Some(i) = images.iter().position(|p| p.as_os_str().is_empty()) {
                return Err(self.err(format!("images[{i}] is empty")));
            }
        }
        Ok(set)
    }

    fn output(&self) -> Result<Output, FormatError> {
        let p = &self.projector;
        let bits = self.bit_depth();
        if bits != 8 && bits != 16 {
            return Err(self.err(format!("projector.bit_depth must be 8 or 16, got {bits}")));
        }
        let top = if bits == 8 { 255.0 } else { 65535.0 };
        let i_min = p.i_min.unwrap_or(0.0);
        let i_max = p.i_max.unwrap_or(top);
        if p.width == 0
            || p.height == 0
            || p.width > MAX_PROJECTOR_SIZE
            || p.height > MAX_PROJECTOR_SIZE
        {
            return Err(self.err(format!(
                "projector size must be 1 to {MAX_PROJECTOR_SIZE} pixels each way, got {} x {}",
                p.width, p.height
            )));
        }
        if !(i_min.is_finite()
            && i_max.is_finite()
            && 0.0 <= i_min
            && i_min < i_max
            && i_max <= top)
        {
            return Err(self.err(format!(
                "projector gray levels must satisfy 0 <= i_min < i_max <= {top} ({bits}-bit), got i_min = {i_min}, i_max = {i_max}"
            )));
        }
        Ok(Output {
            width: p.width,
            height: p.height,
            i_min,
            i_max,
        })
    }

    fn function(&self, o: &Output) -> Result<PhaseFunction, FormatError> {
        let default = PhaseSection::default();
        let ph = self.phase.as_ref().unwrap_or(&default);
        let axis = match ph.axis.unwrap_or(AxisName::Xi) {
            AxisName::Xi => Axis::Xi,
            AxisName::Eta => Axis::Eta,
        };
        let (size, other) = match axis {
            Axis::Xi => (o.width, o.height),
            Axis::Eta => (o.height, o.width),
        };
        let kind = ph.kind.unwrap_or(PhaseKind::Centered);
        let kind_name = match kind {
            PhaseKind::Linear => "linear",
            PhaseKind::Centered => "centered",
            PhaseKind::Knots => "knots",
        };
        let allowed: &[&str] = match kind {
            PhaseKind::Linear => &["origin", "slope"],
            PhaseKind::Centered => &["span"],
            PhaseKind::Knots => &["positions", "slopes", "phases", "phase0"],
        };
        let present = [
            ("origin", ph.origin.is_some()),
            ("slope", ph.slope.is_some()),
            ("span", ph.span.is_some()),
            ("positions", ph.positions.is_some()),
            ("slopes", ph.slopes.is_some()),
            ("phases", ph.phases.is_some()),
            ("phase0", ph.phase0.is_some()),
        ];
        for (k, set) in present {
            if set && !allowed.contains(&k) {
                let dflt = if ph.kind.is_none() {
                    " (the default)"
                } else {
                    ""
                };
                return Err(self.err(format!(
                    "phase.{k} is not used by kind = \"{kind_name}\"{dflt}"
                )));
            }
        }
        let fe = |e: fringe3d_core::phase_function::PhaseFunctionError| {
            self.err(format!("phase function: {e}"))
        };
        let f = match kind {
            PhaseKind::Linear => {
                let slope = ph.slope.ok_or_else(|| {
                    self.err("phase.slope (radians per pixel) is required for kind = \"linear\"")
                })?;
                let origin = ph.origin.unwrap_or(0.5 * (f64::from(size) - 1.0));
                PhaseFunction::linear(axis, origin, slope).map_err(fe)?
            }
            PhaseKind::Centered => {
                PhaseFunction::centered(axis, size, ph.span.unwrap_or(DEFAULT_SPAN)).map_err(fe)?
            }
            PhaseKind::Knots => {
                let pos = ph
                    .positions
                    .as_ref()
                    .ok_or_else(|| self.err("phase.positions is required for kind = \"knots\""))?;
                let slopes = ph
                    .slopes
                    .as_ref()
                    .ok_or_else(|| self.err("phase.slopes is required for kind = \"knots\""))?;
                if slopes.len() != pos.len() {
                    return Err(self.err(format!(
                        "phase.slopes has {} values but phase.positions has {}",
                        slopes.len(),
                        pos.len()
                    )));
                }
                let profile = match &ph.phases {
                    Some(phi) => {
                        if ph.phase0.is_some() {
                            return Err(
                                self.err("phase.phase0 and phase.phases exclude each other")
                            );
                        }
                        if phi.len() != pos.len() {
                            return Err(self.err(format!(
                                "phase.phases has {} values but phase.positions has {}",
                                phi.len(),
                                pos.len()
                            )));
                        }
                        KnotProfile::new(pos, phi, slopes).map_err(fe)?
                    }
                    None => {
                        let phi0 = match ph.phase0 {
                            Some(p) => p,
                            None => {
                                // Centre Φ across the axis: g(0) + g(n − 1) = 0. The profile is
                                // shifted by a constant when phi0 changes, so one probe suffices.
                                let probe =
                                    KnotProfile::from_slopes(pos, slopes, 0.0).map_err(fe)?;
                                -0.5 * (probe.eval(0.0) + probe.eval(f64::from(size) - 1.0))
                            }
                        };
                        KnotProfile::from_slopes(pos, slopes, phi0).map_err(fe)?
                    }
                };
                PhaseFunction::with_profile(axis, Profile::Knots(profile)).map_err(fe)?
            }
        };
        let curvature = ph.curvature.unwrap_or(0.0);
        let center = ph.bend_center.unwrap_or(if curvature != 0.0 {
            0.5 * (f64::from(other) - 1.0)
        } else {
            0.0
        });
        f.curved(curvature, center).map_err(fe)
    }

    fn levels(&self) -> Result<Vec<Level>, FormatError> {
        match (&self.preset, &self.levels) {
            (Some(_), Some(_)) => Err(self.err("give either preset or [[levels]], not both")),
            (None, Some(levels)) => {
                if self.ratio.is_some() {
                    return Err(
                        self.err("ratio applies to a preset only; [[levels]] give each scale")
                    );
                }
                let mut out = Vec::with_capacity(levels.len());
                for (i, l) in levels.iter().enumerate() {
                    let given = [
                        l.steps.is_some(),
                        l.shifts.is_some(),
                        l.shifts_deg.is_some(),
                        l.gray_bits.is_some(),
                    ];
                    if given.iter().filter(|&&g| g).count() != 1 {
                        return Err(self.err(format!(
                            "levels[{i}]: give exactly one of steps, shifts, shifts_deg or gray_bits"
                        )));
                    }
                    if (l.complementary.is_some() || l.inverse.is_some() || l.shifted.is_some())
                        && l.gray_bits.is_none()
                    {
                        return Err(self.err(format!(
                            "levels[{i}]: complementary, inverse and shifted apply to a Gray-code \
                             level (gray_bits) only"
                        )));
                    }
                    let level = if let Some(bits) = l.gray_bits {
                        let max = fringe3d_core::limits::MAX_GRAY_BITS as u32;
                        if !(1..=max).contains(&bits) {
                            return Err(self.err(format!(
                                "levels[{i}]: gray_bits = {bits}; a Gray-code level has 1 to {max} bits"
                            )));
                        }
                        if i != 0 {
                            return Err(self.err(format!(
                                "levels[{i}]: a Gray-code level (gray_bits) must be the first level"
                            )));
                        }
                        let mut code = if l.shifted == Some(true) {
                            if l.complementary == Some(true) {
                                return Err(self.err(format!(
                                    "levels[{i}]: shifted = true needs complementary = false (the \
                                     complementary image already puts an edge at every half \
                                     period)"
                                )));
                            }
                            GrayCode::shifted(bits as u8)
                        } else {
                            GrayCode::new(bits as u8, l.complementary.unwrap_or(true))
                        };
                        if l.inverse == Some(true) {
                            code = code.inverted();
                            if !code.is_valid() {
                                return Err(self.err(format!(
                                    "levels[{i}]: gray_bits = {bits} with inverse = true is {} \
                                     images; a level holds at most {} (8 bits, 7 with the \
                                     complementary image)",
                                    code.images(),
                                    fringe3d_core::pattern::MAX_SHIFTS
                                )));
                            }
                        }
                        Level::gray_code(l.scale, code)
                    } else if let Some(n) = l.steps {
                        if !(3..=fringe3d_core::pattern::MAX_SHIFTS as u32).contains(&n) {
                            return Err(self.err(format!(
                                "levels[{i}]: steps = {n}; an N-step level (eq 14) needs 3 to {} steps \
                                 (for the paper's 2-image level use shifts_deg = [0, 90])",
                                fringe3d_core::pattern::MAX_SHIFTS
                            )));
                        }
                        Level::n_step(l.scale, n as usize)
                    } else if let Some(s) = &l.shifts {
                        let bound = -MAX_SHIFT_MAGNITUDE..=MAX_SHIFT_MAGNITUDE;
                        if let Some((j, v)) =
                            s.iter().enumerate().find(|(_, v)| !bound.contains(*v))
                        {
                            return Err(self.err(format!(
                                "levels[{i}].shifts[{j}] must be finite and within [-2pi, 2pi] = \
                                 [-{MAX_SHIFT_MAGNITUDE}, {MAX_SHIFT_MAGNITUDE}] radians, got {v:?}"
                            )));
                        }
                        Level::with_shifts(l.scale, s)
                    } else {
                        let deg = l.shifts_deg.as_deref().unwrap_or(&[]);
                        if let Some((j, v)) = deg
                            .iter()
                            .enumerate()
                            .find(|(_, v)| !(-360.0..=360.0).contains(*v))
                        {
                            return Err(self.err(format!(
                                "levels[{i}].shifts_deg[{j}] must be finite and within [-360, 360] \
                                 degrees, got {v:?}"
                            )));
                        }
                        let rad: Vec<f64> = deg.iter().map(|d| d * PI / 180.0).collect();
                        Level::with_shifts(l.scale, &rad)
                    };
                    out.push(level);
                }
                Ok(out)
            }
            (preset, None) => {
                let r = self.ratio.unwrap_or(DEFAULT_RATIO);
                if !(r.is_finite() && r > 1.0) {
                    return Err(self.err(format!("ratio must be greater than 1, got {r}")));
                }
                Ok(preset.unwrap_or(Preset::Paper8).levels(r).to_vec())
            }
        }
    }

    /// A note for a version-1 file with explicit `[[levels]]` and no `order` whose images are
    /// therefore taken in the built-in order, when that differs from the listed order (the one a
    /// reader of the file would assume). `None` otherwise.
    pub fn implicit_order_note(&self) -> Option<String> {
        if self.version != PATTERN_FILE_VERSION || self.order.is_some() || self.levels.is_none() {
            return None;
        }
        let set = self.to_pattern_set().ok()?;
        let listed = listed_order(&set);
        if set.order() == listed.as_slice() {
            return None;
        }
        let show = |ids: &[ImageId]| {
            ids.iter()
                .map(|i| format!("[{}, {}]", i.level, i.shift))
                .collect::<Vec<_>>()
                .join(", ")
        };
        let name = self
            .source
            .as_deref()
            .map_or_else(|| "<pattern set>".to_string(), |p| p.display().to_string());
        Some(format!(
            "{name}: version 1 with [[levels]] and no `order`: the images are taken in the built-in order [{}], not in the listed order [{}]; write `order = [...]` to say which, or `version = {PATTERN_FILE_VERSION_LISTED}` for the listed order (docs/formats.md)",
            show(set.order()),
            show(&listed)
        ))
    }

    /// Check the file ([`PatternSetFile::to_pattern_set`]), then write it atomically as TOML with
    /// a header comment. Floats are written exactly, so `load(save(f)) == f`.
    pub fn save(&self, path: &Path) -> Result<(), FormatError> {
        let text = self.to_text(path)?;
        write_atomic(path, |w| w.write_all(text.as_bytes()))?;
        Ok(())
    }

    /// What [`PatternSetFile::save`] writes to `path`, checked.
    pub fn to_text(&self, path: &Path) -> Result<String, FormatError> {
        let mut named = self.clone();
        named.source = Some(path.to_path_buf());
        named.to_pattern_set()?;
        let body = toml::to_string(&named)
            .map_err(|e| FormatError::invalid(path, format!("cannot write as TOML: {e}")))?;
        Ok(format!(
            "# fringe3d pattern set, format version {PATTERN_FILE_VERSION} (docs/formats.md).\n\
             # Angles in radians, positions in projector pixels (pixel centres at integers).\n{body}"
        ))
    }

    /// The image files (`images`), resolved against the folder of `file` (absolute paths are kept).
    /// `None` if the file lists no images.
    pub fn image_paths(&self, file: &Path) -> Option<Vec<PathBuf>> {
        let dir = file.parent().unwrap_or(Path::new(""));
        self.images.as_ref().map(|v| {
            v.iter()
                .map(|p| {
                    if p.is_absolute() {
                        p.clone()
                    } else {
                        dir.join(p)
                    }
                })
                .collect()
        })
    }
}

/// The listed order of a set's images: each level's shifts in turn, levels coarse to fine.
pub fn listed_order(set: &PatternSet) -> Vec<ImageId> {
    set.levels()
        .iter()
        .enumerate()
        .flat_map(|(l, lv)| {
            (0..lv.len()).map(move |s| ImageId {
                level: l as u8,
                shift: s as u8,
            })
        })
        .collect()
}
