//! The named values of a pattern-set file: the enums its keys take (`unwrap`, `binary`,
//! `convention`, `preset`, `axis`, `kind`), spelled as docs/formats.md gives them.

use fringe3d_core::binary::Binarization;
use fringe3d_core::pattern::{Level, LevelPreset};

/// `unwrap = "hierarchical" | "heterodyne" | "coprime"`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum UnwrapName {
    /// Eqs 12-13 from the coarsest level (or a Gray-code level).
    Hierarchical,
    /// Multi-frequency heterodyne: the beat of the levels is the coarse phase.
    Heterodyne,
    /// Number-theoretic: the first two levels' scales are in the ratio of coprime integers.
    Coprime,
}

impl UnwrapName {
    /// The core's relation.
    pub fn core(self) -> fringe3d_core::pattern::Relation {
        use fringe3d_core::pattern::Relation;
        match self {
            UnwrapName::Hierarchical => Relation::Hierarchical,
            UnwrapName::Heterodyne => Relation::Heterodyne,
            UnwrapName::Coprime => Relation::Coprime,
        }
    }

    /// The file's name of a relation (`None` for the default, hierarchical).
    pub fn of(r: fringe3d_core::pattern::Relation) -> Option<UnwrapName> {
        use fringe3d_core::pattern::Relation;
        match r {
            Relation::Hierarchical => None,
            Relation::Heterodyne => Some(UnwrapName::Heterodyne),
            Relation::Coprime => Some(UnwrapName::Coprime),
        }
    }
}

/// `binary = "off" | "square" | "bayer"`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum BinaryName {
    /// Gray-level sinusoids (eq 5).
    Off,
    /// Squared binary: the sinusoid's sign.
    Square,
    /// The sinusoid dithered with the 8 × 8 Bayer matrix.
    Bayer,
}

impl BinaryName {
    /// The core's binarization.
    pub fn core(self) -> Binarization {
        match self {
            BinaryName::Off => Binarization::Off,
            BinaryName::Square => Binarization::Square,
            BinaryName::Bayer => Binarization::Bayer,
        }
    }

    /// The name as the file writes it.
    pub fn name(self) -> &'static str {
        match self {
            BinaryName::Off => "off",
            BinaryName::Square => "square",
            BinaryName::Bayer => "bayer",
        }
    }

    /// The file's name for the core's binarization.
    pub fn of(b: Binarization) -> Self {
        match b {
            Binarization::Off => BinaryName::Off,
            Binarization::Square => BinaryName::Square,
            Binarization::Bayer => BinaryName::Bayer,
        }
    }
}

/// `convention = "sine" | "cosine"`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ConventionName {
    /// `I = A + B·sin(Φ + δ)` (the paper).
    Sine,
    /// `I = A + B·cos(Φ + δ)`.
    Cosine,
}

/// `preset = "paper8" | "twelve"`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum Preset {
    /// The paper's 8 images (eq 7): levels of 2, 2 and 4 images, scales `1 : r : r²`.
    #[default]
    #[serde(rename = "paper8")]
    Paper8,
    /// The conventional 12 images: three 4-step levels, scales `1 : r : r²`.
    #[serde(rename = "twelve")]
    Twelve,
}

impl Preset {
    /// The core's preset.
    pub fn core(self) -> LevelPreset {
        match self {
            Preset::Paper8 => LevelPreset::PaperEight,
            Preset::Twelve => LevelPreset::Twelve,
        }
    }

    /// The levels, coarse to fine, with the scale ratio `ratio` ([`LevelPreset::levels`]).
    pub fn levels(self, ratio: f64) -> [Level; 3] {
        self.core().levels(ratio)
    }
}

impl From<LevelPreset> for Preset {
    fn from(p: LevelPreset) -> Self {
        match p {
            LevelPreset::PaperEight => Preset::Paper8,
            LevelPreset::Twelve => Preset::Twelve,
        }
    }
}

/// `axis = "xi" | "eta"`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum AxisName {
    /// Φ increases along ξ (projector columns): vertical fringes.
    Xi,
    /// Φ increases along η (projector rows): horizontal fringes.
    Eta,
}

/// `kind = "linear" | "centered" | "knots"`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum PhaseKind {
    /// `g(s) = slope·(s − origin)` (eq 6).
    Linear,
    /// Linear, spanning `span` radians across the axis, zero at its middle.
    Centered,
    /// A monotonic cubic through knots: variable fringe width.
    Knots,
}
