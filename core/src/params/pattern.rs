//! The pattern-set description: the parametric form of the core's
//! [`PatternSet`](crate::pattern::PatternSet) (paper §5, eqs 5-7 and 14) as plain data, the
//! same on disk, on the wire and in a head's blob. Checks live with their users:
//! `PatternSetDesc::validate` in [`crate::wire`] (field ranges) and `PatternSetDesc::to_set`
//! (what only the whole set can tell).

use serde::{Deserialize, Serialize};

pub use crate::pattern::Relation;

/// Most fringe levels (scale coefficients `c_k`) in a [`PatternSetDesc`]: the core's
/// [`pattern::MAX_LEVELS`](crate::pattern::MAX_LEVELS).
pub const MAX_LEVELS: usize = crate::pattern::MAX_LEVELS;
/// Most phase shifts in one level of a [`PatternSetDesc`]: the core's
/// [`pattern::MAX_SHIFTS`](crate::pattern::MAX_SHIFTS).
pub const MAX_SHIFTS: usize = crate::pattern::MAX_SHIFTS;
/// Most knots of a [`Knots`] profile: the core's
/// [`phase_function::MAX_KNOTS`](crate::phase_function::MAX_KNOTS).
pub const MAX_KNOTS: usize = crate::phase_function::MAX_KNOTS;
/// The buffer [`PatternSetDesc::phase_encoding`] always fits in, bytes: the whole encoding of a
/// description with a full knot profile and every level holding [`MAX_SHIFTS`] explicit shifts
/// (postcard: sizes as varints of up to 3 bytes, `u8` and enum tags 1 byte, `f64` 8 bytes,
/// arrays without a length), its last byte the relation, which the result then leaves out.
pub const PHASE_ENCODING_MAX: usize =
    32 + (19 + 24 * MAX_KNOTS) + 1 + MAX_LEVELS * (10 + 8 * MAX_SHIFTS) + 1;

/// The projector axis along which the phase function is monotonic.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum PatternAxis {
    /// ξ, projector columns: vertical fringes (wire value 0).
    Xi,
    /// η, projector rows: horizontal fringes (wire value 1).
    Eta,
}

/// The periodic function turning phase into intensity.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum Waveform {
    /// `I = I_min + (I_max − I_min)/2 · (1 + sin(·))`, the paper's eq 5 (wire value 0).
    Sine,
    /// `I = I_min + (I_max − I_min)/2 · (1 + cos(·))` (wire value 1).
    Cosine,
    /// The sine's square wave, 1-bit ([`Binarization::Square`](crate::binary::Binarization::Square); wire value 2).
    SquareSine,
    /// The cosine's square wave, 1-bit (wire value 3).
    SquareCosine,
    /// The sine Bayer-dithered, 1-bit ([`Binarization::Bayer`](crate::binary::Binarization::Bayer); wire value 4).
    BayerSine,
    /// The cosine Bayer-dithered, 1-bit (wire value 5).
    BayerCosine,
}

/// Knots of a monotonic cubic Hermite profile (the core's
/// [`KnotProfile`](crate::phase_function::KnotProfile)): positions `s` (projector pixels),
/// phases `phi` (radians) and slopes (radians per pixel) of the first `count` knots; the unused
/// entries are `+0.0`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Knots {
    /// Knots used, `2..=MAX_KNOTS`.
    pub count: u8,
    /// Knot positions.
    pub s: [f64; MAX_KNOTS],
    /// Knot phases.
    pub phi: [f64; MAX_KNOTS],
    /// Knot slopes.
    pub slope: [f64; MAX_KNOTS],
}

/// The 1-D profile `g(t)` of the phase function along its axis (the core's
/// [`Profile`](crate::phase_function::Profile)).
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum PhaseProfile {
    /// `g(t) = slope·(t − origin)`, `slope > 0` (wire value 0): straight fringes of fixed width.
    Linear {
        /// Position (projector pixels) where the phase is zero.
        origin: f64,
        /// Radians per projector pixel.
        slope: f64,
    },
    /// A monotonic cubic through knots (wire value 1): fringes of varying width.
    Knots(Knots),
}

/// The phase function `Φ(ξ, η) = g(t + curvature·(w − bend_center)²)`, `t` the coordinate along
/// `axis`, `w` the other one (the core's [`PhaseFunction`](crate::phase_function::PhaseFunction);
/// curvature 0: straight fringes).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct PhaseDesc {
    /// The axis along which Φ increases.
    pub axis: PatternAxis,
    /// The profile `g`.
    pub profile: PhaseProfile,
    /// Bending coefficient `a`, 1/pixel.
    pub curvature: f64,
    /// The line `w₀` about which fringes bend, pixels.
    pub bend_center: f64,
}

/// The phase shifts of one level.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum Shifts {
    /// The first `count` of `n` equally spaced shifts `2π·i/n` (evaluated in f64 as
    /// `TAU * i as f64 / n as f64`), `i = 0..count` (eq 14; the paper's eq 7 levels 0 and 1 are
    /// `{ n: 4, count: 2 }`). `1 <= count <= n <= MAX_SHIFTS`.
    Uniform {
        /// Number of equal steps in 2π.
        n: u8,
        /// How many of them are projected.
        count: u8,
    },
    /// Explicit shifts in radians: the first `count` entries, `1..=MAX_SHIFTS`; the rest must be
    /// `+0.0`.
    Explicit {
        /// Number of shifts used.
        count: u8,
        /// The shifts, radians.
        radians: [f64; MAX_SHIFTS],
    },
    /// Not a phase level: a Gray-code level of `bits` binary images (`1..=MAX_GRAY_BITS`), plus
    /// the complementary half-period one if `complementary` ([`crate::gray`]; wire value 2). Only
    /// level 0, followed by a phase level of the same scale.
    Gray {
        /// Bits of the period code.
        bits: u8,
        /// Whether the complementary image is projected.
        complementary: bool,
    },
    /// [`Shifts::Gray`] with every image followed by its inverse, each bit thresholded against
    /// its inverse ([`crate::gray::GrayCode::inverted`]; wire value 3): `2·(bits +
    /// complementary)` images, at most `MAX_SHIFTS`.
    GrayInverse {
        /// Bits of the period code.
        bits: u8,
        /// Whether the complementary image (and its inverse) is projected.
        complementary: bool,
    },
    /// A Gray-code level whose stripes are moved by half a period, edges in the middle of the
    /// fringes ([`crate::gray::GrayCode::shifted`]; wire value 4): `bits` images, twice that
    /// with every image followed by its inverse.
    GrayShifted {
        /// Bits of the period code.
        bits: u8,
        /// Whether every image is followed by its inverse.
        inverse: bool,
    },
}

impl Shifts {
    /// Number of patterns (shifts) of the level.
    pub const fn count(&self) -> usize {
        match *self {
            Shifts::Uniform { count, .. } | Shifts::Explicit { count, .. } => count as usize,
            Shifts::Gray {
                bits,
                complementary,
            } => bits as usize + complementary as usize,
            Shifts::GrayInverse {
                bits,
                complementary,
            } => 2 * (bits as usize + complementary as usize),
            Shifts::GrayShifted { bits, inverse } => bits as usize * (1 + inverse as usize),
        }
    }
}

/// One level of a pattern set: a scale coefficient `c_k` and its shifts.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Level {
    /// Scale coefficient `c_k` (eq 7), finite and `> 0`.
    pub scale: f64,
    /// The level's phase shifts.
    pub shifts: Shifts,
}

impl Level {
    /// The filler for unused level slots: scale `+0.0`, `Uniform { n: 0, count: 0 }`.
    pub const UNUSED: Level = Level {
        scale: 0.0,
        shifts: Shifts::Uniform { n: 0, count: 0 },
    };

    /// Whether the slot is [`Level::UNUSED`] to the bit.
    pub fn is_unused(&self) -> bool {
        self.scale.to_bits() == 0 && matches!(self.shifts, Shifts::Uniform { n: 0, count: 0 })
    }
}

/// A parametric pattern set the head generates row by row: the core's
/// [`PatternSet`](crate::pattern::PatternSet) (eq 7 generalised) with every parameter as the
/// core holds it (f64), so the head's set is the desktop's bit for bit
/// (`PatternSetDesc::from_set`, `PatternSetDesc::to_set` in [`crate::wire`]). Pattern `(k, n)` has intensity
/// `I_min + (I_max − I_min)/2 · (1 + wave(c_k · Φ(ξ, η) + shift_{k,n} + phase_offset))`, quantised
/// to `bit_depth` bits; wire pattern indices count levels in order, shifts in order within a
/// level.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct PatternSetDesc {
    /// Projector width, pixels, `>= 1`.
    pub width: u16,
    /// Projector height, pixels, `>= 1`.
    pub height: u16,
    /// Bits per pattern pixel, `1..=MAX_BIT_DEPTH`.
    pub bit_depth: u8,
    /// Gray level of the fringe minimum, `0 <= I_min < I_max`.
    pub i_min: f64,
    /// Peak intensity `I_max`, `<= 2^bit_depth - 1`.
    pub i_max: f64,
    /// Sine or cosine modulation.
    pub waveform: Waveform,
    /// Constant phase added to every pattern, radians.
    pub phase_offset: f64,
    /// The phase function Φ.
    pub phase: PhaseDesc,
    /// Levels used, `1..=MAX_LEVELS`.
    pub level_count: u8,
    /// The levels, coarse to fine; slots from `level_count` on must be [`Level::UNUSED`].
    pub levels: [Level; MAX_LEVELS],
    /// How the levels give the absolute phase (protocol version 4; earlier versions had no such
    /// field and meant [`Relation::Hierarchical`]).
    pub relation: Relation,
}

impl PatternSetDesc {
    /// The used levels (empty if `level_count` is out of range).
    pub fn used_levels(&self) -> &[Level] {
        self.levels.get(..self.level_count as usize).unwrap_or(&[])
    }

    /// Total number of patterns in the set.
    pub fn pattern_count(&self) -> usize {
        self.used_levels().iter().map(|l| l.shifts.count()).sum()
    }

    /// The description with the fields that do not change the decoded phase set to fixed
    /// values: `bit_depth` 8, `i_min` 0, `i_max` 255. The phase of eqs 8-14 is a ratio of
    /// intensity differences, so the gray levels `I_min`, `I_max` of eq 5 and the quantisation
    /// cancel; the projector size, waveform, phase offset, phase function (axis, profile,
    /// bending) and every level's scale `c_k` and shifts are kept. Two sets with equal
    /// canonical descriptions give the same absolute phase for the same scene.
    pub fn phase_canonical(&self) -> PatternSetDesc {
        PatternSetDesc {
            bit_depth: 8,
            i_min: 0.0,
            i_max: 255.0,
            ..*self
        }
    }

    /// The postcard (wire) encoding of [`PatternSetDesc::phase_canonical`] in `buf`, without
    /// its last field: the bytes a digest of "the pattern set that determines the phase" is
    /// taken over (a reference phase map and a scan are comparable only when these bytes agree).
    /// `None` if `buf` is shorter than the encoding ([`PHASE_ENCODING_MAX`] always suffices).
    ///
    /// The last field, the [`Relation`], is how the levels are unwrapped, not which phase they
    /// encode: a valid pixel's absolute phase is `c_K·Φ` whichever way it was reached. Leaving it
    /// out keeps every digest what it was before protocol version 4 carried it. Postcard writes
    /// it as one varint byte (both variants are below 128), so it is the encoding's last byte.
    pub fn phase_encoding<'a>(&self, buf: &'a mut [u8]) -> Option<&'a [u8]> {
        let canonical = PatternSetDesc {
            relation: Relation::Hierarchical,
            ..self.phase_canonical()
        };
        let all = postcard::to_slice(&canonical, buf).ok()?;
        let (relation, fields) = all.split_last()?;
        (*relation == 0).then_some(fields)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn full() -> PatternSetDesc {
        let explicit = Level {
            scale: 1.5,
            shifts: Shifts::Explicit {
                count: MAX_SHIFTS as u8,
                radians: [0.25; MAX_SHIFTS],
            },
        };
        PatternSetDesc {
            width: u16::MAX,
            height: u16::MAX,
            bit_depth: 16,
            i_min: 3.0,
            i_max: 65000.0,
            waveform: Waveform::Cosine,
            phase_offset: 0.5,
            phase: PhaseDesc {
                axis: PatternAxis::Eta,
                profile: PhaseProfile::Knots(Knots {
                    count: MAX_KNOTS as u8,
                    s: [1.0; MAX_KNOTS],
                    phi: [2.0; MAX_KNOTS],
                    slope: [3.0; MAX_KNOTS],
                }),
                curvature: 1e-4,
                bend_center: 100.0,
            },
            level_count: MAX_LEVELS as u8,
            levels: [explicit; MAX_LEVELS],
            relation: Relation::Heterodyne,
        }
    }

    #[test]
    fn the_largest_description_fits_exactly() {
        let mut buf = [0u8; PHASE_ENCODING_MAX + 8];
        let n = full().phase_encoding(&mut buf).map(|b| b.len());
        assert_eq!(n, Some(PHASE_ENCODING_MAX - 1));
        let mut short = [0u8; PHASE_ENCODING_MAX - 1];
        assert!(full().phase_encoding(&mut short).is_none());
    }

    #[test]
    fn gray_levels_do_not_count_but_phase_parameters_do() {
        let a = full();
        let enc = |d: &PatternSetDesc| {
            let mut buf = [0u8; PHASE_ENCODING_MAX];
            let n = d.phase_encoding(&mut buf).map(|b| b.len()).unwrap_or(0);
            (n, buf)
        };
        let mut b = a;
        b.bit_depth = 8;
        b.i_min = 0.0;
        b.i_max = 200.0;
        assert_eq!(enc(&a), enc(&b));
        let mut c = a;
        c.levels[1].scale = 1.25;
        assert_ne!(enc(&a), enc(&c));
        let mut d = a;
        d.width -= 1;
        assert_ne!(enc(&a), enc(&d));
        let mut e = a;
        e.waveform = Waveform::Sine;
        assert_ne!(enc(&a), enc(&e));
        // The relation is how the phase is unwrapped, not which: left out (and the encoding is
        // the whole description's but its last byte, which the wire has).
        let mut f = a;
        f.relation = Relation::Hierarchical;
        assert_eq!(enc(&a), enc(&f));
        let mut wire = [0u8; PHASE_ENCODING_MAX];
        let (n, digest_bytes) = enc(&f);
        let whole = postcard::to_slice(&f.phase_canonical(), &mut wire).map(|w| &*w);
        assert_eq!(
            whole.ok().and_then(|w| w.split_last()),
            Some((&0, &digest_bytes[..n]))
        );
    }
}
