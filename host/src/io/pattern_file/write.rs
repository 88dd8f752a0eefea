//! [`PatternSetFile::from_pattern_set`]: the file describing a set, every value explicit.

use fringe3d_core::pattern::{Convention, Level, LevelPreset, PatternSet};
use fringe3d_core::phase_function::{Axis, Profile};

use super::{
    AxisName, BinaryName, ConventionName, LevelSection, PATTERN_FILE_VERSION, PatternSetFile,
    PhaseKind, PhaseSection, Preset, ProjectorSection, UnwrapName, listed_order,
};

impl PatternSetFile {
    /// The file describing `set`, with every value explicit (projector gray levels and bit depth,
    /// phase function parameters, convention, offset). Levels are written as a preset when they are
    /// exactly one; a level's shifts as `steps` when they are exactly those of eq 14, else in
    /// radians; the order only when it differs from the default. The conversion is exact:
    /// `from_pattern_set(s, b).to_pattern_set() == s`.
    pub fn from_pattern_set(set: &PatternSet, bit_depth: u8) -> PatternSetFile {
        let o = set.output();
        let f = set.function();
        let axis = match f.axis() {
            Axis::Xi => AxisName::Xi,
            Axis::Eta => AxisName::Eta,
        };
        let mut phase = PhaseSection {
            axis: Some(axis),
            curvature: Some(f.curvature()),
            bend_center: Some(f.bend_center()),
            ..PhaseSection::default()
        };
        match f.profile() {
            Profile::Linear { origin, slope } => {
                phase.kind = Some(PhaseKind::Linear);
                phase.origin = Some(*origin);
                phase.slope = Some(*slope);
            }
            Profile::Knots(k) => {
                phase.kind = Some(PhaseKind::Knots);
                phase.positions = Some(k.positions().to_vec());
                phase.slopes = Some(k.slopes().to_vec());
                phase.phases = Some(k.phases().to_vec());
            }
        }
        let levels = set.levels();
        let (preset, ratio) = match LevelPreset::recognize(levels) {
            Some((p, r)) => (Some(Preset::from(p)), Some(r)),
            None => (None, None),
        };
        let level_sections = if preset.is_some() {
            None
        } else {
            Some(
                levels
                    .iter()
                    .map(|l| {
                        let n = l.len();
                        let gray = l.gray();
                        let is_nstep = n >= 3 && *l == Level::n_step(l.scale(), n);
                        LevelSection {
                            scale: l.scale(),
                            steps: is_nstep.then_some(n as u32),
                            shifts: (!is_nstep && gray.is_none()).then(|| l.shifts().to_vec()),
                            shifts_deg: None,
                            gray_bits: gray.map(|g| u32::from(g.bits())),
                            complementary: gray.map(|g| g.complementary()),
                            inverse: gray.filter(|g| g.inverse()).map(|_| true),
                            shifted: gray.filter(|g| g.is_shifted()).map(|_| true),
                        }
                    })
                    .collect(),
            )
        };
        // A version-1 file: without `order` its images are in the built-in order. Write the
        // order when the set's differs, and for explicit [[levels]] also when the built-in order
        // differs from the listed one (so that no reader has to know the built-in rule).
        let default_order = PatternSet::new_with_relation(*f, levels, *o, set.relation())
            .map(|d| {
                d.order() == set.order()
                    && (level_sections.is_none() || listed_order(&d).as_slice() == d.order())
            })
            .unwrap_or(false);
        let order = (!default_order).then(|| {
            set.order()
                .iter()
                .map(|id| [u32::from(id.level), u32::from(id.shift)])
                .collect()
        });
        PatternSetFile {
            version: PATTERN_FILE_VERSION,
            convention: Some(match set.convention() {
                Convention::Sine => ConventionName::Sine,
                Convention::Cosine => ConventionName::Cosine,
            }),
            phase_offset: Some(set.phase_offset()),
            preset,
            ratio,
            order,
            images: None,
            projector: ProjectorSection {
                width: o.width,
                height: o.height,
                i_min: Some(o.i_min),
                i_max: Some(o.i_max),
                bit_depth: Some(bit_depth),
                response_compensated: None,
            },
            phase: Some(phase),
            levels: level_sections,
            unwrap: UnwrapName::of(set.relation()),
            binary: set
                .binarization()
                .is_binary()
                .then(|| BinaryName::of(set.binarization())),
            source: None,
        }
    }
}
