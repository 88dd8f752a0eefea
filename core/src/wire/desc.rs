//! The wire's descriptions and the core's types, mapped both ways: one code path for the host
//! (which describes its pattern set and calibration) and the head (which rebuilds them).
//!
//! Since protocol version 2 every number the core's set-up consumes travels as the f64 the core
//! holds, so the mapping is exact both ways:
//!
//! - [`PatternSetDesc::from_set`] then [`PatternSetDesc::to_set`] gives back the desktop's
//!   [`PatternSet`] bit for bit (images in the core's default order; the capture order is the
//!   trigger sequence's business). Linear and knot profiles, curved fringes, `I_min`, sine or
//!   cosine, any phase offset and explicit shifts are all carried. Shifts that equal
//!   `TAU * i as f64 / n as f64` bit for bit go as `Uniform { n, count }`, others as `Explicit`.
//! - [`Calibration::from_core`] takes the very [`CameraParams`] and [`Setup`] the
//!   desktop builds its [`Reconstructor`] from; [`Calibration::reconstructor`] builds the same
//!   reconstructor on the head, and [`Calibration::edge_filter`] the same edge filter as the
//!   desktop's (`EdgeFilter::new(min(fx, fy), angle)`).
//!
//! Wire pattern indices count levels in order and shifts in order within a level
//! ([`PatternSetDesc::pattern_id`]); the core's image order (DC level first) is another
//! numbering ([`image_index`]).

use core::f64::consts::TAU;

use super::message::{
    Calibration, CameraParams, Knots, Level, MAX_BIT_DEPTH, MAX_KNOTS, MAX_LEVELS, MAX_SHIFTS,
    PatternAxis, PatternSetDesc, PhaseDesc, PhaseProfile, Shifts, Waveform,
};
use super::{Invalid, WireError};
use crate::camera;
use crate::filter::EdgeFilter;
use crate::params::ScanGeometry;
use crate::pattern::{self, Binarization, Convention, ImageId, Output, PatternError, PatternSet};
use crate::phase_function::{Axis, KnotProfile, PhaseFunction, Profile};
use crate::reconstruct::{Margin, ReconstructError, Reconstructor, Setup, SetupAnalysis};

/// Why a desktop value has no wire description.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum DescError {
    /// The projector's bit depth is outside `1..=MAX_BIT_DEPTH` (the value given).
    BitDepth(u32),
    /// A width or height exceeds 65535 pixels.
    Size,
    /// The description breaks a wire rule (e.g. `I_max` above `2^bits − 1`).
    Invalid(Invalid),
}

impl core::fmt::Display for DescError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            DescError::BitDepth(b) => write!(
                f,
                "the head projects 1- to {MAX_BIT_DEPTH}-bit patterns, this set is {b}-bit"
            ),
            DescError::Size => f.write_str("a width or height exceeds 65535 pixels"),
            DescError::Invalid(why) => write!(f, "invalid wire description: {}", why.name()),
        }
    }
}

impl core::error::Error for DescError {}

fn invalid_of(e: WireError) -> Invalid {
    match e {
        WireError::Invalid(why) => why,
        _ => Invalid::PhaseFunction,
    }
}

impl From<Axis> for PatternAxis {
    fn from(a: Axis) -> Self {
        match a {
            Axis::Xi => PatternAxis::Xi,
            Axis::Eta => PatternAxis::Eta,
        }
    }
}

impl From<PatternAxis> for Axis {
    fn from(a: PatternAxis) -> Self {
        match a {
            PatternAxis::Xi => Axis::Xi,
            PatternAxis::Eta => Axis::Eta,
        }
    }
}

/// The `i`-th of `n` uniform shifts, exactly as the core's `Level::n_step` computes it.
fn uniform_shift(i: usize, n: usize) -> f64 {
    TAU * i as f64 / n as f64
}

/// Uniform `2π·i/n` shifts when they are exactly that (bit for bit), else explicit.
fn shifts_of(s: &[f64]) -> Shifts {
    let count = s.len().min(MAX_SHIFTS);
    for n in count.max(1)..=MAX_SHIFTS {
        if s.iter()
            .enumerate()
            .all(|(i, v)| v.to_bits() == uniform_shift(i, n).to_bits())
        {
            return Shifts::Uniform {
                n: n as u8,
                count: count as u8,
            };
        }
    }
    let mut radians = [0.0f64; MAX_SHIFTS];
    radians[..count].copy_from_slice(&s[..count]);
    Shifts::Explicit {
        count: count as u8,
        radians,
    }
}

fn pattern_invalid(e: PatternError) -> Invalid {
    match e {
        PatternError::Function(_) => Invalid::PhaseFunction,
        PatternError::LevelCount(_) | PatternError::TooManyImages(_) | PatternError::ImageOrder => {
            Invalid::LevelCount
        }
        PatternError::Scale(_) | PatternError::ScalesNotIncreasing(_) => Invalid::Scale,
        PatternError::ShiftCount(..)
        | PatternError::Shift(_)
        | PatternError::DegenerateShifts(_)
        | PatternError::NoDcLevel
        | PatternError::PhaseOffset
        | PatternError::GrayPlacement(_)
        | PatternError::GrayBits(_)
        | PatternError::GrayNoDc => Invalid::Shifts,
        PatternError::HeterodyneLevels | PatternError::CoprimeLevels => Invalid::LevelCount,
        PatternError::GrayRange { .. } => Invalid::PhaseFunction,
        PatternError::Output => Invalid::Intensity,
    }
}

impl PatternSetDesc {
    /// The description of `set` for a projector of `bit_depth` bits: every parameter as the core
    /// holds it, so [`PatternSetDesc::to_set`] gives `set` back bit for bit (in the core's
    /// default image order).
    pub fn from_set(set: &PatternSet, bit_depth: u32) -> Result<Self, DescError> {
        Self::from_set_up_to(set, bit_depth, MAX_BIT_DEPTH)
    }

    /// [`PatternSetDesc::from_set`] for projectors of up to `max_bits` bits (the set-up blob's
    /// 16).
    pub(crate) fn from_set_up_to(
        set: &PatternSet,
        bit_depth: u32,
        max_bits: u8,
    ) -> Result<Self, DescError> {
        if !(1..=max_bits as u32).contains(&bit_depth) {
            return Err(DescError::BitDepth(bit_depth));
        }
        let f = set.function();
        let profile = match f.profile() {
            Profile::Linear { origin, slope } => PhaseProfile::Linear {
                origin: *origin,
                slope: *slope,
            },
            Profile::Knots(k) => {
                let n = k.len().min(MAX_KNOTS);
                let mut w = Knots {
                    count: n as u8,
                    s: [0.0; MAX_KNOTS],
                    phi: [0.0; MAX_KNOTS],
                    slope: [0.0; MAX_KNOTS],
                };
                w.s[..n].copy_from_slice(&k.positions()[..n]);
                w.phi[..n].copy_from_slice(&k.phases()[..n]);
                w.slope[..n].copy_from_slice(&k.slopes()[..n]);
                PhaseProfile::Knots(w)
            }
        };
        let levels = set.levels();
        let mut wl = [Level::UNUSED; MAX_LEVELS];
        for (dst, l) in wl.iter_mut().zip(levels) {
            *dst = Level {
                scale: l.scale(),
                shifts: match l.gray() {
                    Some(g) if g.is_shifted() => Shifts::GrayShifted {
                        bits: g.bits(),
                        inverse: g.inverse(),
                    },
                    Some(g) if g.inverse() => Shifts::GrayInverse {
                        bits: g.bits(),
                        complementary: g.complementary(),
                    },
                    Some(g) => Shifts::Gray {
                        bits: g.bits(),
                        complementary: g.complementary(),
                    },
                    None => shifts_of(l.shifts()),
                },
            };
        }
        let o = set.output();
        let d = PatternSetDesc {
            width: u16::try_from(o.width).map_err(|_| DescError::Size)?,
            height: u16::try_from(o.height).map_err(|_| DescError::Size)?,
            bit_depth: bit_depth as u8,
            i_min: o.i_min,
            i_max: o.i_max,
            waveform: match (set.convention(), set.binarization()) {
                (Convention::Sine, Binarization::Off) => Waveform::Sine,
                (Convention::Cosine, Binarization::Off) => Waveform::Cosine,
                (Convention::Sine, Binarization::Square) => Waveform::SquareSine,
                (Convention::Cosine, Binarization::Square) => Waveform::SquareCosine,
                (Convention::Sine, Binarization::Bayer) => Waveform::BayerSine,
                (Convention::Cosine, Binarization::Bayer) => Waveform::BayerCosine,
            },
            phase_offset: set.phase_offset(),
            phase: PhaseDesc {
                axis: f.axis().into(),
                profile,
                curvature: f.curvature(),
                bend_center: f.bend_center(),
            },
            level_count: levels.len().min(MAX_LEVELS) as u8,
            levels: wl,
            relation: set.relation(),
        };
        d.validate_up_to(max_bits)
            .map_err(|e| DescError::Invalid(invalid_of(e)))?;
        Ok(d)
    }

    /// The core phase function described.
    pub fn phase_function(&self) -> Result<PhaseFunction, Invalid> {
        let p = &self.phase;
        let axis = p.axis.into();
        let f = match &p.profile {
            PhaseProfile::Linear { origin, slope } => PhaseFunction::linear(axis, *origin, *slope),
            PhaseProfile::Knots(k) => {
                let n = (k.count as usize).min(MAX_KNOTS);
                let kp = KnotProfile::new(&k.s[..n], &k.phi[..n], &k.slope[..n])
                    .map_err(|_| Invalid::PhaseFunction)?;
                PhaseFunction::with_profile(axis, Profile::Knots(kp))
            }
        };
        f.and_then(|f| f.curved(p.curvature, p.bend_center))
            .map_err(|_| Invalid::PhaseFunction)
    }

    /// The core set described, images in the core's default order: the whole check of
    /// [`PatternSet::new`] over the projector (monotonic, continuous, coarse range, shifts).
    /// Errors are the wire's [`Invalid`] codes (a Nak's detail).
    pub fn to_set(&self) -> Result<PatternSet, Invalid> {
        self.build_set_up_to(MAX_BIT_DEPTH, None)
    }

    /// [`PatternSetDesc::to_set`] for projectors of up to `max_bits` bits (the set-up blob's 16),
    /// images in `order` if given ([`PatternSet::with_order`]; [`Invalid::LevelCount`] if it is
    /// not a permutation of the set's images).
    pub(crate) fn build_set_up_to(
        &self,
        max_bits: u8,
        order: Option<&[ImageId]>,
    ) -> Result<PatternSet, Invalid> {
        self.validate_up_to(max_bits).map_err(invalid_of)?;
        let function = self.phase_function()?;
        let n = self.level_count as usize;
        let mut levels = [pattern::Level::with_shifts(0.0, &[]); MAX_LEVELS];
        for (dst, l) in levels.iter_mut().zip(self.used_levels()) {
            *dst = match l.shifts {
                Shifts::Uniform { n, count } => {
                    let mut s = [0.0f64; MAX_SHIFTS];
                    let count = (count as usize).min(MAX_SHIFTS);
                    for (i, v) in s.iter_mut().enumerate().take(count) {
                        *v = uniform_shift(i, n as usize);
                    }
                    pattern::Level::with_shifts(l.scale, &s[..count])
                }
                Shifts::Explicit { count, radians } => {
                    let count = (count as usize).min(MAX_SHIFTS);
                    pattern::Level::with_shifts(l.scale, &radians[..count])
                }
                Shifts::Gray {
                    bits,
                    complementary,
                } => {
                    pattern::Level::gray_code(l.scale, pattern::GrayCode::new(bits, complementary))
                }
                Shifts::GrayInverse {
                    bits,
                    complementary,
                } => pattern::Level::gray_code(
                    l.scale,
                    pattern::GrayCode::new(bits, complementary).inverted(),
                ),
                Shifts::GrayShifted { bits, inverse } => {
                    let code = pattern::GrayCode::shifted(bits);
                    pattern::Level::gray_code(l.scale, if inverse { code.inverted() } else { code })
                }
            };
        }
        let output = Output {
            width: self.width as u32,
            height: self.height as u32,
            i_min: self.i_min,
            i_max: self.i_max,
        };
        let (convention, binary) = match self.waveform {
            Waveform::Sine => (Convention::Sine, Binarization::Off),
            Waveform::Cosine => (Convention::Cosine, Binarization::Off),
            Waveform::SquareSine => (Convention::Sine, Binarization::Square),
            Waveform::SquareCosine => (Convention::Cosine, Binarization::Square),
            Waveform::BayerSine => (Convention::Sine, Binarization::Bayer),
            Waveform::BayerCosine => (Convention::Cosine, Binarization::Bayer),
        };
        // Each `with_*` moves the whole set (1.4 KB of a head's set-up stack): call them only
        // when they change it, and change the set inside the result rather than moving it out
        // (the order is applied here too, for the same reason).
        // `n` > MAX_LEVELS is refused by `validate_up_to` before; `get` keeps a panic path out
        // of a head's set-up all the same (the core's constructor refuses an empty set).
        let used = levels.get(..n).unwrap_or(&[]);
        let mut built = PatternSet::new_with_relation(function, used, output, self.relation);
        if let Ok(set) = &mut built {
            if set.convention() != convention {
                *set = set.with_convention(convention);
            }
            if set.binarization() != binary {
                *set = set.with_binarization(binary);
            }
            if set.phase_offset().to_bits() != self.phase_offset.to_bits() {
                *set = set
                    .with_phase_offset(self.phase_offset)
                    .map_err(pattern_invalid)?;
            }
            if let Some(order) = order.filter(|o| set.order() != *o) {
                *set = set.with_order(order).map_err(pattern_invalid)?;
            }
        }
        built.map_err(pattern_invalid)
    }

    /// Level and shift of wire pattern index `p` (levels in order, shifts in order).
    pub fn pattern_id(&self, p: u16) -> Option<ImageId> {
        let mut first = 0usize;
        for (k, l) in self.used_levels().iter().enumerate() {
            let n = l.shifts.count();
            if (p as usize) < first + n {
                return Some(ImageId {
                    level: k as u8,
                    shift: (p as usize - first) as u8,
                });
            }
            first += n;
        }
        None
    }

    /// The wire pattern index of level `id.level`, shift `id.shift`.
    pub fn pattern_index(&self, id: ImageId) -> Option<u16> {
        let levels = self.used_levels();
        let l = levels.get(id.level as usize)?;
        if id.shift as usize >= l.shifts.count() {
            return None;
        }
        let first: usize = levels[..id.level as usize]
            .iter()
            .map(|l| l.shifts.count())
            .sum();
        u16::try_from(first + id.shift as usize).ok()
    }
}

/// The core image index (in `set`'s order) showing level `id.level`, shift `id.shift`.
pub fn image_index(set: &PatternSet, id: ImageId) -> Option<usize> {
    set.order().iter().position(|o| *o == id)
}

impl Calibration {
    /// The wire form of the inputs of a desktop reconstruction: the camera model's parameters
    /// and the set-up, exactly as given (the set-up's axis is the pattern set's business and is
    /// not carried).
    pub fn from_core(camera: &CameraParams, setup: &Setup) -> Result<Self, DescError> {
        if camera.width > u32::from(u16::MAX) || camera.height > u32::from(u16::MAX) {
            return Err(DescError::Size);
        }
        let c = Calibration {
            camera: *camera,
            geometry: ScanGeometry::from_setup(setup),
        };
        c.validate()
            .map_err(|e| DescError::Invalid(invalid_of(e)))?;
        Ok(c)
    }

    /// The core camera model (its construction checks run: [`Invalid::Intrinsics`] if refused).
    pub fn camera_model(&self) -> Result<camera::CameraModel, Invalid> {
        camera::CameraModel::new(self.camera).map_err(|_| Invalid::Intrinsics)
    }

    /// The core set-up for phases monotonic along `axis`.
    pub fn setup(&self, axis: PatternAxis) -> Setup {
        self.geometry.setup(axis.into())
    }

    /// The core reconstructor (band and tables) for phases monotonic along `axis`.
    pub fn reconstructor(&self, axis: PatternAxis) -> Result<Reconstructor, Invalid> {
        self.reconstructor_with_margin(axis, Margin::ZERO)
    }

    /// The core reconstructor for a reference map with margin `margin` past the image
    /// ([`Reconstructor::new_with_margin`]; [`Invalid::Margin`] for a side above
    /// [`MAX_MARGIN`](crate::reconstruct::MAX_MARGIN)).
    pub fn reconstructor_with_margin(
        &self,
        axis: PatternAxis,
        margin: Margin,
    ) -> Result<Reconstructor, Invalid> {
        let cam = self.camera_model()?;
        Reconstructor::new_with_margin(&cam, &self.setup(axis), margin).map_err(reconstruct_invalid)
    }

    /// [`Self::reconstructor_with_margin`] from its set-up analysis `a`, found before
    /// ([`camera::CameraModel::from_check`], [`Reconstructor::from_analysis`]: no analysis
    /// here).
    pub fn reconstructor_from_analysis(
        &self,
        axis: PatternAxis,
        margin: Margin,
        a: &SetupAnalysis,
    ) -> Result<Reconstructor, Invalid> {
        let cam = camera::CameraModel::from_check(self.camera, &a.camera)
            .map_err(|_| Invalid::Intrinsics)?;
        Reconstructor::from_analysis(&cam, &self.setup(axis), margin, a)
            .map_err(reconstruct_invalid)
    }

    /// The edge filter the desktop uses for this camera: focal length `min(fx, fy)`,
    /// surfaces up to `max_angle_deg` from facing the camera. `None` for an angle outside
    /// `(0, 90)`.
    pub fn edge_filter(&self, max_angle_deg: f64) -> Option<EdgeFilter> {
        let (fx, fy) = (self.camera.fx, self.camera.fy);
        EdgeFilter::new(if fy < fx { fy } else { fx }, max_angle_deg)
    }
}

/// The wire's code for a reconstructor the core refused.
fn reconstruct_invalid(e: ReconstructError) -> Invalid {
    match e {
        ReconstructError::DepthRange => Invalid::DepthRange,
        ReconstructError::ReferencePlane => Invalid::PlaneNormal,
        ReconstructError::Margin => Invalid::Margin,
        _ => Invalid::Intrinsics,
    }
}
