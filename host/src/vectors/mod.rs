//! Golden test vectors for people porting the kernels to their own MCU, DSP or FPGA
//! (`fringe3d vectors`).
//!
//! A small rendered scan (built-in scene, 320 × 240 by default) is pushed through the reference
//! pipeline — the core's *row* APIs, one row at a time, exactly as a streaming head runs them —
//! and every stage's inputs and outputs are written as raw little-endian arrays with a JSON
//! manifest of their formats and SHA-256 digests:
//!
//! | stage | files |
//! |---|---|
//! | input | `input/images.{u8,u16}` (camera rows of every image, set order), `input/reference_phase.f32`, `input/setup.bin` (the core's head set-up blob: pattern set, capture order, decoder thresholds, calibration, edge filter), plus the project's own `patterns.toml`, `calibration.toml`, `reference_phase.tif` |
//! | decode | `decode/wrapped_level{k}.f32`, `decode/modulation_level{k}.f32` (per level), `decode/dc.f32` (A), `decode/modulation.f32` (B of the finest level), `decode/phase.f32` (unwrapped), `decode/validity.u8` |
//! | reconstruct | `reconstruct/points.f32` (x, y, z per pixel), `reconstruct/validity.u8` |
//! | edge filter | `filter/validity.u8`, `filter/points.f32` |
//!
//! The same scene and options give the same bytes on every run and every machine: the renderer is
//! seeded, the kernels are plain IEEE arithmetic and pinned libm, every NaN is written as the
//! canonical quiet NaN `0x7fc00000`, and the manifest is written in a fixed key order.
//! `docs/golden-vectors.md` describes every file, `docs/setup-blob.md` the `setup.bin` layout.
//!
//! | file | what |
//! |---|---|
//! | `pipeline.rs` | the inputs (rendered scene, calibration) and the reference row drivers |
//! | `generate.rs` | running the pipeline and collecting every file |
//! | `setup.rs` | `input/setup.bin`, checked to rebuild the desktop's objects exactly |
//! | `manifest.rs` | the manifest's parameters |
//! | `folder.rs` | writing, reading back, checking and comparing a vectors folder |

mod folder;
mod generate;
mod manifest;
mod pipeline;
mod setup;

pub use folder::{
    Mismatch, check_dir, compare, first_difference, generate_into, read_dir, stage_files, write,
};
pub use generate::{generate, generate_from};
pub use pipeline::{Inputs, decode_rows, inputs, reconstruct_rows};

use crate::io::atomic::AtomicError;
use crate::io::calibration::FormatError;
use crate::io::pattern_file::PatternSetFile;
use crate::render::RenderError;
use crate::scan::ScanError;
use fringe3d_core::math::CANONICAL_NAN;
use serde_json::json;
use sha2::{Digest, Sha256};
use std::path::{Path, PathBuf};

/// Manifest format name.
pub const FORMAT: &str = "fringe3d-golden-vectors";
/// Manifest format version.
pub const VERSION: u32 = 1;
/// The manifest's file name.
pub const MANIFEST: &str = "manifest.json";

/// Why golden vectors could not be made, written or checked.
#[derive(Debug, thiserror::Error)]
pub enum VectorsError {
    /// Rendering the scene failed.
    #[error(transparent)]
    Render(#[from] RenderError),
    /// The calibration could not be set up.
    #[error(transparent)]
    Scan(#[from] ScanError),
    /// A calibration or pattern-set file could not be written.
    #[error(transparent)]
    Format(#[from] FormatError),
    /// The output folder could not be created or committed.
    #[error(transparent)]
    Atomic(#[from] AtomicError),
    /// A core kernel refused its input.
    #[error("{stage}: {message}")]
    Kernel {
        /// The pipeline stage.
        stage: &'static str,
        /// The core's error.
        message: String,
    },
    /// A file could not be read or written.
    #[error("{}: {message}", path.display())]
    File {
        /// The file.
        path: PathBuf,
        /// What went wrong.
        message: String,
    },
    /// An option is out of range.
    #[error("{0}")]
    Options(String),
}

fn kernel(stage: &'static str, e: impl std::fmt::Display) -> VectorsError {
    VectorsError::Kernel {
        stage,
        message: e.to_string(),
    }
}

fn file_err(path: &Path, e: impl std::fmt::Display) -> VectorsError {
    VectorsError::File {
        path: path.to_path_buf(),
        message: e.to_string(),
    }
}

/// What to render and how to scan it.
#[derive(Clone, Debug, PartialEq)]
pub struct VectorOptions {
    /// Built-in scene (sphere, ballbar, steps, freeform, plane).
    pub scene: String,
    /// Camera size (same field of view as the default 1280 × 1024 rig).
    pub size: (u32, u32),
    /// Camera bit depth (8, 12 or 16); `None`: the scene's (16).
    pub bits: Option<u8>,
    /// Camera noise σ, gray levels; `None`: the scene's.
    pub noise: Option<f64>,
    /// Noise seed; `None`: the scene's.
    pub seed: Option<u64>,
    /// Steepest accepted surface of the edge filter, degrees from facing the camera.
    pub max_angle_deg: f64,
    /// The projector's gamma (`None`: the scene's, linear). With a gamma the decoder (and the
    /// head, through the set-up blob) applies the response's phase-error table.
    pub gamma: Option<f64>,
    /// The pattern set (`None`: the scene's, the paper's 8 images). The mps2 board's golden
    /// binary holds one row of at most 8 images.
    pub patterns: Option<PatternSetFile>,
    /// The projector's defocus σ, projector pixels (`None`: the scene's, 1). A binary set is
    /// decoded with the table of this blur (docs/binary.md), which the set-up blob carries.
    pub defocus: Option<f64>,
    /// The reference map the scan uses (issue #17): the decoded capture of the plane, the
    /// model fitted to it, or the virtual map of the rig's projector (image-sized), or the
    /// virtual map on the default far plane with the margin past the image the geometry needs.
    pub reference: VectorReference,
    /// Also compile the reconstruction (`fringe3d compile`) to this tolerance, mm, and write its
    /// models (`input/compiled.f3c`) and the compiled scan's points (`compiled/`),
    /// docs/compiled.md. A smaller camera needs a larger tolerance for its pixels to compile
    /// (the map's bilinear bends grow with the pixel size).
    pub compiled: Option<f64>,
}

/// Which reference phase map the golden vectors' scan uses (`fringe3d vectors --reference`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum)]
pub enum VectorReference {
    /// The decoded render of the reference plane (`calibrate reference --raw`).
    #[default]
    Captured,
    /// The smooth model fitted to that capture (`calibrate reference`, docs/reference-model.md).
    Model,
    /// The map computed from the rig's projector model on the same plane, no capture
    /// (`calibrate reference --virtual --margin 0`).
    Virtual,
    /// The map computed from the rig's projector model on the default plane, perpendicular to
    /// the camera's axis at the far end of the depth range, extending past the image by the
    /// margin the geometry needs (`calibrate reference --virtual`, its defaults): a map wider
    /// than the image, as a head takes it since protocol version 6.
    VirtualMargin,
}

impl VectorReference {
    /// The option's value.
    pub fn name(self) -> &'static str {
        match self {
            VectorReference::Captured => "captured",
            VectorReference::Model => "model",
            VectorReference::Virtual => "virtual",
            VectorReference::VirtualMargin => "virtual-margin",
        }
    }
}

impl Default for VectorOptions {
    fn default() -> Self {
        VectorOptions {
            scene: "ballbar".into(),
            size: (320, 240),
            bits: None,
            noise: None,
            seed: None,
            max_angle_deg: 80.0,
            gamma: None,
            patterns: None,
            defocus: None,
            reference: VectorReference::Captured,
            compiled: None,
        }
    }
}

/// Element type of a raw array file.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Dtype {
    /// Unsigned byte.
    U8,
    /// Unsigned 16-bit integer, little-endian.
    U16,
    /// IEEE 754 binary32, little-endian.
    F32,
}

impl Dtype {
    /// The manifest's name of the type (`"u8"`, `"u16"`, `"f32"`).
    pub fn name(self) -> &'static str {
        match self {
            Dtype::U8 => "u8",
            Dtype::U16 => "u16",
            Dtype::F32 => "f32",
        }
    }

    /// Bytes per element.
    pub fn size(self) -> usize {
        match self {
            Dtype::U8 => 1,
            Dtype::U16 => 2,
            Dtype::F32 => 4,
        }
    }
}

/// One file of the vectors, in memory.
#[derive(Clone, Debug, PartialEq)]
pub struct VectorFile {
    /// Path relative to the vectors folder, `/`-separated.
    pub path: String,
    /// Element type and shape for raw arrays (C order, little-endian); `None` for other files.
    pub array: Option<(Dtype, Vec<usize>)>,
    /// Format of a non-array file.
    pub format: &'static str,
    /// What it holds.
    pub description: String,
    /// The bytes.
    pub bytes: Vec<u8>,
}

impl VectorFile {
    /// SHA-256 of the bytes, lowercase hex.
    pub fn sha256(&self) -> String {
        sha256_hex(&self.bytes)
    }

    fn entry(&self) -> serde_json::Value {
        let mut m = serde_json::Map::new();
        m.insert("path".into(), json!(self.path));
        match &self.array {
            Some((d, shape)) => {
                m.insert("format".into(), json!("raw"));
                m.insert("dtype".into(), json!(d.name()));
                m.insert("shape".into(), json!(shape));
                m.insert("order".into(), json!("C"));
                m.insert("byte_order".into(), json!("little"));
            }
            None => {
                m.insert("format".into(), json!(self.format));
            }
        }
        m.insert("bytes".into(), json!(self.bytes.len()));
        m.insert("sha256".into(), json!(self.sha256()));
        m.insert("description".into(), json!(self.description));
        serde_json::Value::Object(m)
    }
}

/// SHA-256 of `bytes`, lowercase hex.
pub fn sha256_hex(bytes: &[u8]) -> String {
    Sha256::digest(bytes)
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect()
}

/// f32 values as little-endian bytes, every NaN replaced by the canonical NaN `0x7fc00000`.
pub fn f32_bytes(v: &[f32]) -> Vec<u8> {
    let mut out = Vec::with_capacity(4 * v.len());
    for x in v {
        let x = if x.is_nan() { CANONICAL_NAN } else { *x };
        out.extend_from_slice(&x.to_le_bytes());
    }
    out
}

/// u16 values as little-endian bytes.
pub fn u16_bytes(v: &[u16]) -> Vec<u8> {
    v.iter().flat_map(|x| x.to_le_bytes()).collect()
}

/// Outputs of the decode stage, whole frames (`width × height`, row-major).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct DecodeStage {
    /// Wrapped phase φ^(k) ∈ [−π, π] per level (coarse to fine).
    pub wrapped: Vec<Vec<f32>>,
    /// Modulation B per level.
    pub modulation_level: Vec<Vec<f32>>,
    /// DC term A.
    pub dc: Vec<f32>,
    /// Modulation B of the finest level (the row API's output).
    pub modulation: Vec<f32>,
    /// Absolute (unwrapped) phase of the finest level, canonical NaN where invalid.
    pub phase: Vec<f32>,
    /// Validity codes.
    pub validity: Vec<u8>,
}

/// Outputs of reconstruction and of the edge filter.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PointStage {
    /// Points, `3 × width × height` (x, y, z per pixel, mm), canonical NaN where invalid.
    pub points: Vec<f32>,
    /// Validity codes of the points.
    pub validity: Vec<u8>,
    /// Validity after the edge filter.
    pub filtered_validity: Vec<u8>,
    /// Points after the edge filter (flagged points become canonical NaN).
    pub filtered_points: Vec<f32>,
}

/// A complete set of golden vectors, in memory.
#[derive(Clone, Debug)]
pub struct GoldenVectors {
    /// Image width.
    pub width: usize,
    /// Image height.
    pub height: usize,
    /// The files, sorted by path (the manifest is not among them).
    pub files: Vec<VectorFile>,
    /// Everything the manifest says besides the file list.
    pub info: serde_json::Map<String, serde_json::Value>,
}

impl GoldenVectors {
    /// The file at `path` (relative, `/`-separated).
    pub fn file(&self, path: &str) -> Option<&VectorFile> {
        self.files.iter().find(|f| f.path == path)
    }

    /// The manifest: formats, parameters and SHA-256 of every file.
    pub fn manifest(&self) -> serde_json::Value {
        let mut m = self.info.clone();
        m.insert(
            "files".into(),
            serde_json::Value::Array(self.files.iter().map(VectorFile::entry).collect()),
        );
        serde_json::Value::Object(m)
    }

    /// The manifest as the bytes written to `manifest.json` (pretty JSON and a final newline).
    pub fn manifest_bytes(&self) -> Result<Vec<u8>, VectorsError> {
        let mut b = serde_json::to_vec_pretty(&self.manifest())
            .map_err(|e| file_err(Path::new(MANIFEST), e))?;
        b.push(b'\n');
        Ok(b)
    }
}
