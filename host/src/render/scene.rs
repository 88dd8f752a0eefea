//! Scene files (TOML) and the built-in scenes.
//!
//! A scene names the rig (camera, projector and its pose, reference plane, depth range), the
//! pattern set, the photometry, the objects, the camera noise and bit depth, and the seed. See
//! `docs/render.md` for every key; `fringe3d render --scene NAME --print` prints a built-in scene
//! as a file to start from.

use super::camera::LensModel;
use super::math::{Mat3, Vec3, look_at};
use super::objects::ObjectSpec;
use super::rig::{DEFAULT_AIM, Rig, default_rig};
use crate::io::pattern_file::PatternSetFile;
use fringe3d_core::pattern::{Output, PatternSet};
use fringe3d_core::phase_function::{Axis, PhaseFunction};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// The names of the built-in scenes.
pub const BUILTIN_SCENES: [&str; 10] = [
    "sphere",
    "ballbar",
    "cylinder",
    "steps",
    "freeform",
    "plane",
    "reference",
    "checkerboard",
    "plates",
    "boards",
];

mod builtin;
mod sections;

pub use sections::{
    BoardLight, BoardSpec, CameraSpec, DatasetKind, FringeAxis, PatternSpec, PhotometrySpec,
    PlatesSpec, Pose, ProjectorSpec, ReferenceMode, ReferenceSpec, VolumeSpec,
};

/// A complete scene description (the TOML file).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SceneSpec {
    /// Scene name.
    pub name: String,
    /// `fringe` (default), `checkerboard` or `plates`.
    #[serde(default)]
    pub kind: DatasetKind,
    /// Seed of the camera noise and random board poses.
    #[serde(default)]
    pub seed: u64,
    /// `[z_min, z_max]` of the measurement volume, mm.
    pub depth_range: [f64; 2],
    /// The measurement volume (for board poses; default the rig's).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub volume: Option<VolumeSpec>,
    /// The camera.
    pub camera: CameraSpec,
    /// The projector.
    pub projector: ProjectorSpec,
    /// The pattern set.
    #[serde(default)]
    pub patterns: PatternSpec,
    /// Photometry.
    #[serde(default)]
    pub photometry: PhotometrySpec,
    /// The reference plane.
    pub reference: ReferenceSpec,
    /// The objects.
    #[serde(default)]
    pub objects: Vec<ObjectSpec>,
    /// The checkerboard (checkerboard and plates scenes).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub board: Option<BoardSpec>,
    /// The plates (plates scenes).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub plates: Option<PlatesSpec>,
}

/// Why a scene could not be read or built.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    /// The file could not be read.
    #[error("{path}: cannot read: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The OS error.
        source: std::io::Error,
    },
    /// The file is not valid TOML or has unknown/missing keys.
    #[error("{path}: {message}")]
    Parse {
        /// The file.
        path: PathBuf,
        /// The parser's message.
        message: String,
    },
    /// A value is out of range.
    #[error("scene {scene}: {message}")]
    Invalid {
        /// Scene name (or file).
        scene: String,
        /// The problem.
        message: String,
    },
    /// No built-in scene of that name.
    #[error("no built-in scene named {0:?} (built-in: {list})", list = BUILTIN_SCENES.join(", "))]
    UnknownBuiltin(String),
}

/// Overrides from the command line (each `None` keeps the scene's value).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Overrides {
    /// Seed.
    pub seed: Option<u64>,
    /// Camera noise σ, gray levels.
    pub noise: Option<f64>,
    /// Camera bits.
    pub bits: Option<u8>,
    /// Pattern bits.
    pub pattern_bits: Option<u8>,
    /// Supersampling.
    pub supersample: Option<u32>,
    /// Projector defocus σ.
    pub defocus: Option<f64>,
    /// Camera size (same field of view).
    pub size: Option<(u32, u32)>,
    /// Relative exposure (the scene's `photometry.exposure`).
    pub exposure: Option<f64>,
}

impl SceneSpec {
    /// Read a scene file.
    pub fn load(path: &Path) -> Result<SceneSpec, SceneError> {
        let text = std::fs::read_to_string(path).map_err(|source| SceneError::Io {
            path: path.to_path_buf(),
            source,
        })?;
        Self::parse(&text, path)
    }

    /// Parse scene TOML; `path` names it in errors.
    pub fn parse(text: &str, path: &Path) -> Result<SceneSpec, SceneError> {
        let parse_error = |message: String| SceneError::Parse {
            path: path.to_path_buf(),
            message,
        };
        let spec: SceneSpec =
            toml::from_str(text).map_err(|e| parse_error(e.to_string().trim_end().to_string()))?;
        let tables = [
            ("camera", &spec.camera.unknown),
            ("projector", &spec.projector.unknown),
        ];
        for (table, unknown) in tables {
            if let Some(k) = unknown.keys().next() {
                return Err(parse_error(format!("[{table}]: unknown key `{k}`")));
            }
        }
        Ok(spec)
    }

    /// The scene as TOML text (round-trips through [`SceneSpec::parse`]).
    pub fn to_toml(&self) -> Result<String, SceneError> {
        toml::to_string(self).map_err(|e| self.invalid(format!("cannot write as TOML: {e}")))
    }

    fn invalid(&self, message: impl Into<String>) -> SceneError {
        SceneError::Invalid {
            scene: self.name.clone(),
            message: message.into(),
        }
    }

    /// Apply command-line overrides.
    pub fn apply(&mut self, o: &Overrides) {
        if let Some(s) = o.seed {
            self.seed = s;
        }
        if let Some(n) = o.noise {
            self.camera.noise = n;
        }
        if let Some(b) = o.bits {
            self.camera.bits = b;
        }
        if let Some(b) = o.pattern_bits {
            self.projector.bits = b;
        }
        if let Some(s) = o.supersample {
            self.camera.supersample = s;
            self.camera.edge_supersample = self.camera.edge_supersample.max(s);
        }
        if let Some(d) = o.defocus {
            self.projector.defocus = d;
        }
        if let Some((w, h)) = o.size {
            self.camera.lens = self.camera.lens.scaled(w, h);
        }
        if let Some(e) = o.exposure {
            self.photometry.exposure = e;
        }
    }

    /// The rig this scene describes.
    pub fn rig(&self) -> Result<Rig, SceneError> {
        let t = Vec3::from_array(self.projector.center);
        let r = match (&self.projector.rotation, &self.projector.look_at) {
            (Some(_), Some(_)) => {
                return Err(self.invalid("projector: give either rotation or look_at, not both"));
            }
            (Some(r), None) => Mat3(*r),
            (None, a) => {
                let aim = Vec3::from_array(a.unwrap_or(DEFAULT_AIM));
                look_at(t, aim).ok_or_else(|| {
                    self.invalid(
                        "projector.look_at: cannot aim at its own centre or straight up/down",
                    )
                })?
            }
        };
        let n = Vec3::from_array(self.reference.normal);
        if !(n.norm() > 1e-12 && n.is_finite()) {
            return Err(self.invalid("reference.normal must be a non-zero vector"));
        }
        let mut n = n.normalized();
        let p = Vec3::from_array(self.reference.point);
        if n.dot(p) > 0.0 {
            n = -n;
        }
        let vol = self.volume.clone().unwrap_or_else(|| {
            let d = default_rig();
            VolumeSpec {
                min: d.volume_min,
                max: d.volume_max,
            }
        });
        let rig = Rig {
            camera: self.camera.lens,
            projector: self.projector.lens,
            rotation: r.0,
            translation: t.to_array(),
            reference_point: p.to_array(),
            reference_normal: n.to_array(),
            depth_range: self.depth_range,
            volume_min: vol.min,
            volume_max: vol.max,
        };
        rig.validate().map_err(|m| self.invalid(m))?;
        Ok(rig)
    }

    /// The pattern set for fringe axis `axis` (`None`: the scene's own). `base_dir` resolves a
    /// relative pattern file. Also returns the pattern bits.
    pub fn pattern_set(
        &self,
        base_dir: Option<&Path>,
        axis: Option<FringeAxis>,
    ) -> Result<(PatternSet, u8), SceneError> {
        let bits = self.projector.bits;
        if bits != 8 && bits != 16 {
            return Err(self.invalid(format!("projector.bits must be 8 or 16, got {bits}")));
        }
        let p = &self.patterns;
        let file = match (&p.file, &p.set) {
            (Some(_), Some(_)) => {
                return Err(self.invalid("patterns: give either file or set, not both"));
            }
            (Some(f), None) => {
                let path = match base_dir {
                    Some(b) if f.is_relative() => b.join(f),
                    _ => f.clone(),
                };
                Some(
                    PatternSetFile::load(&path)
                        .map_err(|e| self.invalid(format!("patterns.file: {e}")))?,
                )
            }
            (None, Some(s)) => Some(s.clone()),
            (None, None) => None,
        };
        if let Some(mut f) = file {
            if axis.is_some() {
                return Err(self.invalid(
                    "plates scenes need the shorthand pattern description (they use both axes)",
                ));
            }
            let old = f.bit_depth();
            if old != bits {
                let s = ((1u32 << bits) - 1) as f64 / ((1u32 << old.min(16)) - 1) as f64;
                f.projector.i_min = f.projector.i_min.map(|v| v * s);
                f.projector.i_max = f.projector.i_max.map(|v| v * s);
                f.projector.bit_depth = Some(bits);
            }
            let set = f
                .to_pattern_set()
                .map_err(|e| self.invalid(format!("patterns: {e}")))?;
            if set.output().width != self.projector.lens.width
                || set.output().height != self.projector.lens.height
            {
                return Err(self.invalid(format!(
                    "patterns are for a {}x{} projector, the scene's is {}x{}",
                    set.output().width,
                    set.output().height,
                    self.projector.lens.width,
                    self.projector.lens.height
                )));
            }
            return Ok((set, bits));
        }
        let axis = match axis.unwrap_or(p.axis) {
            FringeAxis::Xi => Axis::Xi,
            FringeAxis::Eta => Axis::Eta,
        };
        let out = Output {
            width: self.projector.lens.width,
            height: self.projector.lens.height,
            i_min: 0.0,
            i_max: ((1u32 << bits) - 1) as f64,
        };
        let size = if axis == Axis::Xi {
            out.width
        } else {
            out.height
        };
        let other = if axis == Axis::Xi {
            out.height
        } else {
            out.width
        };
        let e = |m: &dyn std::fmt::Display| self.invalid(format!("patterns: {m}"));
        let mut f = PhaseFunction::centered(axis, size, p.span).map_err(|x| e(&x))?;
        if p.curvature != 0.0 {
            f = f
                .curved(p.curvature, 0.5 * (other as f64 - 1.0))
                .map_err(|x| e(&x))?;
        }
        let r = p.ratio;
        let levels = p.preset.levels(r);
        let set = PatternSet::new(f, &levels, out).map_err(|x| e(&x))?;
        Ok((set, bits))
    }

    /// Check everything that can be checked without rendering.
    pub fn validate(&self, base_dir: Option<&Path>) -> Result<(), SceneError> {
        self.rig()?;
        if self.kind != DatasetKind::Checkerboard {
            self.pattern_set(base_dir, None)?;
        }
        let s = self.camera.sensor();
        if self.camera.lens.width as u64 * self.camera.lens.height as u64 > 64_000_000 {
            return Err(self.invalid("camera images larger than 64 megapixels are not supported"));
        }
        if ![8u8, 12, 16].contains(&s.bits) {
            return Err(self.invalid(format!("camera.bits must be 8, 12 or 16, got {}", s.bits)));
        }
        if !(1..=32).contains(&s.supersample) || s.edge_supersample > 64 {
            return Err(
                self.invalid("camera.supersample must be 1..32 and edge_supersample at most 64")
            );
        }
        if !(s.noise.is_finite() && s.noise >= 0.0) {
            return Err(self.invalid(format!("camera.noise must be >= 0, got {}", s.noise)));
        }
        let g = self.projector.gray_levels;
        if g != 0 && !(5..=256).contains(&g) {
            return Err(self.invalid(format!(
                "projector.gray_levels must be 0 (none) or 5..256, got {g}"
            )));
        }
        if !(self.reference.albedo.is_finite() && (0.0..=1.0).contains(&self.reference.albedo)) {
            return Err(self.invalid("reference.albedo must be in [0, 1]"));
        }
        if let Some(r) = &self.projector.response {
            super::light::ResponseLut::new(r)
                .map_err(|e| self.invalid(format!("projector.{e}")))?;
            if self.projector.gamma != 1.0 {
                return Err(self.invalid("projector: give a gamma or a response table, not both"));
            }
        }
        for (i, o) in self.objects.iter().enumerate() {
            o.validate(i).map_err(|m| self.invalid(m))?;
        }
        match self.kind {
            DatasetKind::Fringe => {
                if self.objects.is_empty() {
                    return Err(self.invalid("a fringe scene needs at least one object"));
                }
            }
            DatasetKind::Checkerboard => {
                let b = self
                    .board
                    .as_ref()
                    .ok_or_else(|| self.invalid("a checkerboard scene needs [board]"))?;
                self.check_board(b)?;
            }
            DatasetKind::Plates => {
                let p = self
                    .plates
                    .as_ref()
                    .ok_or_else(|| self.invalid("a plates scene needs [plates]"))?;
                if p.positions.len() < 2 {
                    return Err(
                        self.invalid("plates: at least two positions are needed (paper §7)")
                    );
                }
                if !(p.size[0] > 0.0 && p.size[1] > 0.0) {
                    return Err(self.invalid("plates.size must be positive"));
                }
                let b = self.board.as_ref().ok_or_else(|| {
                    self.invalid("a plates scene needs [board] (printed on the plate)")
                })?;
                self.check_board(b)?;
                if self.patterns.file.is_some() || self.patterns.set.is_some() {
                    return Err(self.invalid(
                        "plates scenes need the shorthand pattern description (they use both axes)",
                    ));
                }
            }
        }
        if self.photometry.board_light == BoardLight::Ambient
            && self.photometry.ambient <= 0.0
            && self.kind != DatasetKind::Fringe
        {
            return Err(self.invalid("board_light = \"ambient\" needs photometry.ambient > 0"));
        }
        Ok(())
    }

    fn check_board(&self, b: &BoardSpec) -> Result<(), SceneError> {
        if !(b.square > 0.0 && b.cols >= 2 && b.rows >= 2 && b.margin >= 0.0) {
            return Err(self.invalid("board: need square > 0, at least 2 × 2 squares, margin >= 0"));
        }
        if !(1..=32).contains(&b.supersample) {
            return Err(self.invalid("board.supersample must be 1..32"));
        }
        if b.poses.is_empty() && b.count == 0 && self.kind == DatasetKind::Checkerboard {
            return Err(self.invalid("board: count must be positive"));
        }
        Ok(())
    }

    /// A built-in scene by name (see [`BUILTIN_SCENES`]).
    pub fn builtin(name: &str) -> Result<SceneSpec, SceneError> {
        builtin::builtin(name).ok_or_else(|| SceneError::UnknownBuiltin(name.to_string()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn builtins_validate_and_roundtrip() {
        for n in BUILTIN_SCENES {
            let s = SceneSpec::builtin(n).unwrap();
            s.validate(None).unwrap_or_else(|e| panic!("{n}: {e}"));
            let t = s.to_toml().unwrap();
            let back = SceneSpec::parse(&t, Path::new("x.toml")).unwrap();
            assert_eq!(back, s, "{n}");
        }
    }
}
