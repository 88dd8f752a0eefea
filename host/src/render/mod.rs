//! Synthetic fringe-projection scans with exact ground truth (`fringe3d render`).
//!
//! The renderer is the project's independent f64 truth: its camera and projector models
//! ([`camera`]), geometry ([`objects`], [`freeform`]) and light transport ([`light`], [`engine`])
//! share nothing with the core's reconstruction code, only the core's pattern generator (the
//! patterns are what a real projector would be sent) and — to produce the reference phase map a
//! real user would get — its decoder.
//!
//! Entry points:
//! - [`default_rig`]: the default camera/projector geometry shared by the built-in scenes, the
//!   demo and the tests.
//! - [`Scene`]: a resolved scene ([`SceneSpec`] from a built-in name or a TOML file) with
//!   [`Scene::render_fringes`], [`Scene::render_reference`], [`Scene::render_slides`] (any
//!   projector images: the simulated head's camera), [`Scene::true_phase`].
//! - [`dataset::write_dataset`]: a complete dataset folder with images, calibration, truth and a
//!   manifest (what the CLI writes).
//! - [`decode_phase`]: the core decoder over rendered frames (how the reference map is made).
//!
//! See `docs/render.md` for the models, formats and measured accuracy.

// `!(x > 0.0)` is used on purpose throughout: unlike `x <= 0.0` it also rejects NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod board;
pub mod camera;
pub mod dataset;
pub mod engine;
pub mod freeform;
pub mod light;
pub mod math;
pub mod objects;
pub mod rig;
pub mod rng;
pub mod scene;

pub use camera::{CameraParams, LensModel};
pub use engine::{
    Frames, MASK_CLEAN, MASK_HIT, MASK_IN_FRAME, MASK_LIT, MASK_VALID, Photometry, Sensor, Truth,
};
pub use light::{LightSet, Optics, ProjectorMode, Slide};
pub use objects::{Geometry, ObjectSpec, Shape, Texture};
pub use rig::{Rig, default_rig};
pub use scene::{BUILTIN_SCENES, DatasetKind, Overrides, SceneSpec};

use crate::batch::decode_whole;
use fringe3d_core::decode::{DecodeConfig, Decoder};
use fringe3d_core::pattern::PatternSet;
use std::path::{Path, PathBuf};

/// Why rendering failed.
#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    /// The scene is invalid.
    #[error(transparent)]
    Scene(#[from] scene::SceneError),
    /// The projector light could not be set up.
    #[error("projector: {0}")]
    Light(#[from] light::LightError),
    /// A render setting is out of range.
    #[error("render: {0}")]
    Engine(#[from] engine::EngineError),
    /// Decoding the rendered reference failed.
    #[error("decoding the rendered fringes: {0}")]
    Decode(String),
    /// An image could not be written.
    #[error(transparent)]
    Image(#[from] crate::io::image::ImageError),
    /// A calibration or pattern-set file could not be written.
    #[error(transparent)]
    Format(#[from] crate::io::error::FormatError),
    /// The dataset folder could not be created or committed.
    #[error(transparent)]
    Atomic(#[from] crate::io::atomic::AtomicError),
    /// Another file could not be written or read back.
    #[error("{path}: {message}")]
    File {
        /// The file.
        path: PathBuf,
        /// What went wrong.
        message: String,
    },
}

/// Options of one render call.
#[derive(Clone, Copy, Default)]
pub struct RenderOptions<'a> {
    /// Keep the unquantized images in [`Frames::float`].
    pub keep_float: bool,
    /// Called with the number of image rows just finished.
    pub progress: Option<&'a (dyn Fn(u64) + Sync)>,
    /// Use these sensor settings instead of the scene's.
    pub sensor: Option<Sensor>,
    /// Use this photometry instead of the scene's.
    pub photometry: Option<Photometry>,
}

/// A resolved scene: rig, pattern set, objects.
#[derive(Clone, Debug)]
pub struct Scene {
    /// The description it was built from.
    pub spec: SceneSpec,
    /// Camera, projector, pose, reference plane.
    pub rig: Rig,
    /// The pattern set (the scene's fringe axis).
    pub patterns: PatternSet,
    /// Bits of the projector's pattern codes (8 or 16).
    pub pattern_bits: u8,
    /// The objects.
    pub geometry: Geometry,
    base_dir: Option<PathBuf>,
}

impl Scene {
    /// Resolve a scene description; `base_dir` resolves a relative pattern file.
    pub fn new(spec: SceneSpec, base_dir: Option<&Path>) -> Result<Scene, RenderError> {
        spec.validate(base_dir)?;
        let rig = spec.rig()?;
        let (patterns, pattern_bits) = spec.pattern_set(base_dir, None)?;
        let geometry = Geometry::build(&spec.objects).map_err(|m| scene::SceneError::Invalid {
            scene: spec.name.clone(),
            message: m,
        })?;
        Ok(Scene {
            spec,
            rig,
            patterns,
            pattern_bits,
            geometry,
            base_dir: base_dir.map(Path::to_path_buf),
        })
    }

    /// A built-in scene with overrides.
    pub fn builtin(name: &str, overrides: &Overrides) -> Result<Scene, RenderError> {
        let mut s = SceneSpec::builtin(name)?;
        s.apply(overrides);
        Scene::new(s, None)
    }

    /// A scene file with overrides.
    pub fn load(path: &Path, overrides: &Overrides) -> Result<Scene, RenderError> {
        let mut s = SceneSpec::load(path)?;
        s.apply(overrides);
        Scene::new(s, path.parent())
    }

    /// The folder relative pattern files are resolved against.
    pub fn base_dir(&self) -> Option<&Path> {
        self.base_dir.as_deref()
    }

    /// The projector optics.
    pub fn optics(&self) -> Optics {
        self.spec.projector.optics()
    }

    /// The projector's true normalised response, when it is not linear (a response table, or
    /// gamma ≠ 1): what a perfect `fringe3d calibrate gamma` measures (the table, or
    /// [`crate::response::power_law`]).
    pub fn true_response(&self) -> Option<crate::io::calibration::ProjectorResponse> {
        if let Some(t) = self.optics().response {
            return Some(t.to_response());
        }
        let g = self.spec.projector.gamma;
        (g != 1.0).then(|| crate::response::power_law(g))
    }

    /// The projector's true blur σ (projector pixels) where the decoding of `set` models it: a
    /// binary set (the defocus; 0 for the continuous projector), or a gray-level one through a
    /// non-linear response on the pixelated projector; `None` otherwise.
    pub fn true_defocus(&self, set: &PatternSet) -> Option<f64> {
        let p = &self.spec.projector;
        let pixelated = p.mode != ProjectorMode::Continuous;
        if set.binarization().is_binary() {
            Some(if pixelated { p.defocus } else { 0.0 })
        } else {
            (pixelated && self.true_response().is_some()).then_some(p.defocus)
        }
    }

    /// Record the projector's true light in `cal` (its response and, where the decoding of the
    /// scene's set models it, its blur): what a perfect `calibrate gamma` and `calibrate
    /// defocus` give, from which `scan` makes [`Self::true_correction`]'s table.
    pub fn record_true_light(&self, cal: &mut crate::io::calibration::Calibration) {
        cal.projector_response = self.true_response();
        cal.projector_defocus = self.true_defocus(&self.patterns);
    }

    /// The phase-error table of `set`: for a binary set under [`Self::true_defocus`], else
    /// under [`Self::true_response`] (with the defocus on the pixelated projector; `None` for
    /// a linear projector).
    pub fn true_correction(
        &self,
        set: &PatternSet,
    ) -> Result<Option<fringe3d_core::decode::PhaseCorrection>, RenderError> {
        let sigma = self.true_defocus(set);
        if let Some(sigma) = sigma.filter(|_| set.binarization().is_binary()) {
            return crate::response::binary::binary_correction(set, sigma)
                .map(|(t, _)| Some(t))
                .map_err(RenderError::Decode);
        }
        if let (Some(r), Some(sigma)) = (self.true_response(), sigma) {
            return crate::response::binary::light_table(set, sigma, Some(&r))
                .map(|(t, _)| Some(t))
                .map_err(RenderError::Decode);
        }
        match self.true_response() {
            Some(r) => crate::response::table::phase_correction(set, &r)
                .map(|(t, _)| Some(t))
                .map_err(RenderError::Decode),
            None => Ok(None),
        }
    }

    /// Render `slides` onto `geometry` with this scene's rig, sensor and photometry: one camera
    /// image per slide. `stream` separates the noise of several renders with one seed — give every
    /// call a different one (e.g. a frame counter), or their noise repeats. The automatic exposure
    /// depends on the geometry only (it assumes full white), so separate calls get equal gains.
    pub fn render_slides(
        &self,
        geometry: &Geometry,
        slides: &[Slide<'_>],
        stream: u64,
        opts: RenderOptions<'_>,
    ) -> Result<(Frames, Truth), RenderError> {
        let lights = LightSet::new(
            self.rig.projector.width,
            self.rig.projector.height,
            slides,
            self.optics(),
        )?;
        self.render_lights(geometry, &lights, stream, opts)
    }

    /// Render with a prepared light set (reuse it across renders of the same slides).
    pub fn render_lights(
        &self,
        geometry: &Geometry,
        lights: &LightSet,
        stream: u64,
        opts: RenderOptions<'_>,
    ) -> Result<(Frames, Truth), RenderError> {
        let job = engine::Job {
            rig: &self.rig,
            geometry,
            lights,
            sensor: opts.sensor.unwrap_or_else(|| self.spec.camera.sensor()),
            photometry: opts
                .photometry
                .unwrap_or_else(|| self.spec.photometry.photometry()),
            seed: self.spec.seed,
            stream,
            keep_float: opts.keep_float,
            progress: opts.progress,
        };
        Ok(engine::render(&job)?)
    }

    /// The slides of a pattern set.
    pub fn pattern_slides<'a>(&self, set: &'a PatternSet) -> Vec<Slide<'a>> {
        (0..set.image_count())
            .map(|index| Slide::Pattern {
                set,
                index,
                bits: self.pattern_bits,
            })
            .collect()
    }

    /// The scene's fringe set on its objects.
    pub fn render_fringes(&self, opts: RenderOptions<'_>) -> Result<(Frames, Truth), RenderError> {
        let slides = self.pattern_slides(&self.patterns);
        self.render_slides(&self.geometry, &slides, 0, opts)
    }

    /// The reference plane alone (an infinite plane at the rig's reference, the scene's
    /// reference albedo).
    pub fn reference_geometry(&self) -> Geometry {
        let o = ObjectSpec {
            name: "reference".into(),
            albedo: self.spec.reference.albedo,
            shape: Shape::Plane {
                point: self.rig.reference_point,
                normal: self.rig.reference_normal,
                size: None,
                u_axis: None,
            },
            texture: None,
            specular: None,
        };
        Geometry::build(&[o]).unwrap_or_default()
    }

    /// The scene's fringe set on the reference plane (noise stream 1).
    pub fn render_reference(
        &self,
        opts: RenderOptions<'_>,
    ) -> Result<(Frames, Truth), RenderError> {
        let slides = self.pattern_slides(&self.patterns);
        self.render_slides(&self.reference_geometry(), &slides, 1, opts)
    }

    /// The true absolute phase `c_K·Φ^(P)(ξ, η)` per pixel (NaN where the pixel-centre ray misses
    /// or its point does not project); combine with the mask to restrict to lit pixels.
    pub fn true_phase(&self, truth: &Truth) -> Vec<f64> {
        let set = self.patterns;
        truth.map_projector(|xi, eta| set.finest_phase(xi, eta))
    }
}

/// Decode rendered frames with the core's decoder (thresholds for the frames' bit depth):
/// the finest absolute phase per pixel, NaN where invalid.
pub fn decode_phase(set: &PatternSet, frames: &Frames) -> Result<Vec<f32>, RenderError> {
    decode_phase_corrected(set, frames, None)
}

/// [`decode_phase`] with a phase-error table for the projector's response (what
/// `fringe3d calibrate reference` does with a calibration holding `[projector_response]`).
pub fn decode_phase_corrected(
    set: &PatternSet,
    frames: &Frames,
    correction: Option<&fringe3d_core::decode::PhaseCorrection>,
) -> Result<Vec<f32>, RenderError> {
    let mut dec = Decoder::new(set, DecodeConfig::for_bit_depth(frames.bits as u32))
        .map_err(|e| RenderError::Decode(e.to_string()))?;
    if let Some(c) = correction {
        dec = dec
            .with_correction(c)
            .map_err(|e| RenderError::Decode(format!("gamma correction: {e}")))?;
    }
    let (w, h) = (frames.width as usize, frames.height as usize);
    if frames.images.len() != set.image_count() {
        return Err(RenderError::Decode(format!(
            "{} frames for a set of {} images",
            frames.images.len(),
            set.image_count()
        )));
    }
    if frames.images.iter().any(|i| i.len() != w * h) {
        return Err(RenderError::Decode(format!(
            "frames must hold {w} x {h} samples each"
        )));
    }
    if w == 0 || h == 0 {
        return Ok(Vec::new());
    }
    let images: Vec<&[u16]> = frames.images.iter().map(|i| i.as_slice()).collect();
    let decoded =
        decode_whole(&dec, &images, w, h).map_err(|e| RenderError::Decode(e.to_string()))?;
    Ok(decoded.phase)
}
