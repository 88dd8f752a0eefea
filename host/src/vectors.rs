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
//! | input | `input/images.{u8,u16}` (camera rows of every image, set order), `input/reference_phase.f32`, `input/params.bin` (pattern set, decoder thresholds, calibration, edge filter), plus the project's own `patterns.toml`, `calibration.toml`, `reference_phase.tif` |
//! | decode | `decode/wrapped_level{k}.f32`, `decode/modulation_level{k}.f32` (per level), `decode/dc.f32` (A), `decode/modulation.f32` (B of the finest level), `decode/phase.f32` (unwrapped), `decode/validity.u8` |
//! | reconstruct | `reconstruct/points.f32` (x, y, z per pixel), `reconstruct/validity.u8` |
//! | edge filter | `filter/validity.u8`, `filter/points.f32` |
//!
//! The same scene and options give the same bytes on every run and every machine: the renderer is
//! seeded, the kernels are plain IEEE arithmetic and pinned libm, every NaN is written as the
//! canonical quiet NaN `0x7fc00000`, and the manifest is written in a fixed key order.
//! `docs/golden-vectors.md` describes every file and the `params.bin` layout.

use crate::io::atomic::{AtomicDir, AtomicError};
use crate::io::calibration::FormatError;
use crate::io::image::encode_tiff_f32;
use crate::io::pattern_file::PatternSetFile;
use crate::render::scene::Overrides;
use crate::render::{RenderError, RenderOptions, Scene, decode_phase};
use crate::scan::{ScanCalibration, ScanError};
use fringe3d_core::decode::{DecodeConfig, Decoder, RowOut, Sample, level_estimator};
use fringe3d_core::filter::EdgeFilter;
use fringe3d_core::math::CANONICAL_NAN;
use fringe3d_core::pattern::{Convention, PatternSet};
use fringe3d_core::phase_function::{Axis, Profile};
use fringe3d_core::reconstruct::{Reconstructor, ReferenceRing};
use fringe3d_core::validity::Validity;
use serde_json::json;
use sha2::{Digest, Sha256};
use std::path::{Path, PathBuf};

/// Manifest format name.
pub const FORMAT: &str = "fringe3d-golden-vectors";
/// Manifest format version.
pub const VERSION: u32 = 1;
/// First 8 bytes of `input/params.bin`.
pub const PARAMS_MAGIC: [u8; 8] = *b"F3DVPAR1";
/// Last 4 bytes of `input/params.bin`.
pub const PARAMS_END: [u8; 4] = *b"END1";
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
    /// Steepest accepted surface of the depth-edge filter, degrees from facing the camera.
    pub max_angle_deg: f64,
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
    /// Validity after the depth-edge filter.
    pub filtered_validity: Vec<u8>,
    /// Points after the depth-edge filter (flagged points become canonical NaN).
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

/// The reference pipeline's inputs, resolved: what [`generate`] renders and what a test needs to
/// run other drivers (the desktop batch path) on the same data.
pub struct Inputs {
    /// The rendered scene.
    pub scene: Scene,
    /// Camera codes per image (set order), `width × height` each.
    pub images: Vec<Vec<u16>>,
    /// Significant bits of the camera codes.
    pub bits: u8,
    /// The calibration, reconstructor and prepared reference map.
    pub calibration: ScanCalibration,
    /// Decoder thresholds.
    pub decode_config: DecodeConfig,
    /// The depth-edge filter.
    pub edge_filter: EdgeFilter,
    /// Its focal length, pixels (`min(fx, fy)`).
    pub edge_focal_px: f64,
    /// Its steepest accepted surface, degrees.
    pub edge_max_angle_deg: f64,
}

/// Render the scene of `opts` and set up its calibration (no decoding of the object yet).
pub fn inputs(opts: &VectorOptions) -> Result<Inputs, VectorsError> {
    let scenes = ["sphere", "ballbar", "steps", "freeform", "plane"];
    if !scenes.contains(&opts.scene.as_str()) {
        return Err(VectorsError::Options(format!(
            "scene {:?}: golden vectors use one of {}",
            opts.scene,
            scenes.join(", ")
        )));
    }
    let (w, h) = opts.size;
    if !(16..=4096).contains(&w) || !(16..=4096).contains(&h) {
        return Err(VectorsError::Options(format!(
            "size {w}x{h}: width and height must be 16 to 4096"
        )));
    }
    if !(opts.max_angle_deg > 0.0 && opts.max_angle_deg < 90.0) {
        return Err(VectorsError::Options(format!(
            "edge-filter angle {}: must be in (0, 90) degrees",
            opts.max_angle_deg
        )));
    }
    let o = Overrides {
        seed: opts.seed,
        noise: opts.noise,
        bits: opts.bits,
        size: Some(opts.size),
        ..Overrides::default()
    };
    let scene = Scene::builtin(&opts.scene, &o)?;
    let ropts = RenderOptions::default();
    let (frames, _truth) = scene.render_fringes(ropts)?;
    let (ref_frames, _) = scene.render_reference(ropts)?;
    let reference = decode_phase(&scene.patterns, &ref_frames)?;
    let cal = scene.rig.calibration(
        Some(PathBuf::from("reference_phase.tif")),
        Some(PathBuf::from("patterns.toml")),
    );
    let calibration = ScanCalibration::from_parts(
        cal,
        reference,
        scene.patterns.axis(),
        Path::new("input/calibration.toml"),
    )?;
    let edge_filter = calibration.edge_filter(opts.max_angle_deg)?;
    let c = &calibration.calibration.camera;
    let edge_focal_px = c.fx.min(c.fy);
    Ok(Inputs {
        images: frames.images,
        bits: frames.bits,
        decode_config: DecodeConfig::for_bit_depth(frames.bits as u32),
        scene,
        calibration,
        edge_filter,
        edge_focal_px,
        edge_max_angle_deg: opts.max_angle_deg,
    })
}

/// Decode whole frames with the row APIs, one row at a time (the reference driver).
pub fn decode_rows<P: Sample>(
    dec: &Decoder,
    frames: &[&[P]],
    width: usize,
    height: usize,
) -> Result<DecodeStage, VectorsError> {
    let n = width * height;
    let levels = dec.level_count();
    let mut s = DecodeStage {
        wrapped: vec![vec![0.0; n]; levels],
        modulation_level: vec![vec![0.0; n]; levels],
        dc: vec![0.0; n],
        modulation: vec![0.0; n],
        phase: vec![0.0; n],
        validity: vec![0; n],
    };
    if frames.len() != dec.image_count() || frames.iter().any(|f| f.len() != n) {
        return Err(kernel(
            "decode",
            "frame count or size differs from the pattern set and image size",
        ));
    }
    for y in 0..height {
        let r = y * width..(y + 1) * width;
        let rows: Vec<&[P]> = frames.iter().map(|f| &f[r.clone()]).collect();
        dec.decode_row(
            &rows,
            RowOut {
                phase: &mut s.phase[r.clone()],
                modulation: &mut s.modulation[r.clone()],
                dc: &mut s.dc[r.clone()],
                validity: &mut s.validity[r.clone()],
            },
        )
        .map_err(|e| kernel("decode", e))?;
        for l in 0..levels {
            dec.decode_row_level(
                &rows,
                l,
                &mut s.wrapped[l][r.clone()],
                &mut s.modulation_level[l][r.clone()],
            )
            .map_err(|e| kernel("decode (per level)", e))?;
        }
    }
    Ok(s)
}

/// Reconstruct and edge-filter whole frames row by row through a [`ReferenceRing`] of exactly
/// the band's rows (the streaming driver a head runs), with a 3-row window for the filter.
pub fn reconstruct_rows(
    recon: &Reconstructor,
    reference_phase: &[f32],
    reference_validity: &[u8],
    phase: &[f32],
    validity: &[u8],
    filter: &EdgeFilter,
) -> Result<PointStage, VectorsError> {
    let (w, h) = (recon.width(), recon.height());
    let n = w * h;
    if reference_phase.len() != n
        || reference_validity.len() != n
        || phase.len() != n
        || validity.len() != n
    {
        return Err(kernel("reconstruct", "map sizes differ from the camera"));
    }
    let band = recon.band().rows().min(h as u32) as usize;
    let mut ring_phase = vec![0.0f32; band * w];
    let mut ring_validity = vec![0u8; band * w];
    let mut ring = ReferenceRing::new(recon, &mut ring_phase, &mut ring_validity)
        .map_err(|e| kernel("reconstruct", e))?;
    let mut out = PointStage {
        points: vec![0.0; 3 * n],
        validity: vec![0; n],
        filtered_validity: vec![0; n],
        filtered_points: vec![0.0; 3 * n],
    };
    for v in 0..h {
        let (_, last) = recon.rows_needed(v as u32);
        while ring.rows_pushed() <= last {
            let r = ring.rows_pushed() as usize * w..(ring.rows_pushed() as usize + 1) * w;
            ring.push_row(&reference_phase[r.clone()], &reference_validity[r])
                .map_err(|e| kernel("reconstruct (reference ring)", e))?;
        }
        let r = v * w..(v + 1) * w;
        recon
            .reconstruct_row(
                &ring,
                v as u32,
                &phase[r.clone()],
                &validity[r.clone()],
                &mut out.points[3 * v * w..3 * (v + 1) * w],
                &mut out.validity[r],
            )
            .map_err(|e| kernel("reconstruct", e))?;
    }
    for v in 0..h {
        let row = |k: usize| {
            (
                &out.points[3 * k * w..3 * (k + 1) * w],
                &out.validity[k * w..(k + 1) * w],
            )
        };
        let above = (v > 0).then(|| row(v - 1));
        let below = (v + 1 < h).then(|| row(v + 1));
        if !filter.filter_row(
            above,
            row(v),
            below,
            &mut out.filtered_validity[v * w..(v + 1) * w],
        ) {
            return Err(kernel("edge filter", "row lengths disagree"));
        }
    }
    out.filtered_points.copy_from_slice(&out.points);
    for (i, p) in out.filtered_points.chunks_exact_mut(3).enumerate() {
        if out.filtered_validity[i] != Validity::Valid as u8 {
            p.fill(CANONICAL_NAN);
        }
    }
    Ok(out)
}

/// Render, run the reference pipeline and collect every file (nothing is written).
pub fn generate(opts: &VectorOptions) -> Result<GoldenVectors, VectorsError> {
    generate_from(&inputs(opts)?)
}

/// Run the reference pipeline on rendered inputs and collect every file (nothing is written).
pub fn generate_from(inp: &Inputs) -> Result<GoldenVectors, VectorsError> {
    let set = inp.scene.patterns;
    let cal = &inp.calibration;
    let recon = &cal.recon;
    let (w, h) = (recon.width(), recon.height());
    let dec = Decoder::new(&set, inp.decode_config).map_err(|e| kernel("decoder set-up", e))?;
    // 8-bit cameras get u8 files and the u8 kernel; deeper ones u16.
    let (sample, image_bytes, d) = if inp.bits == 8 {
        let f8: Vec<Vec<u8>> = inp
            .images
            .iter()
            .map(|f| f.iter().map(|&x| x.min(255) as u8).collect())
            .collect();
        let r: Vec<&[u8]> = f8.iter().map(|f| f.as_slice()).collect();
        let d = decode_rows(&dec, &r, w, h)?;
        (Dtype::U8, f8.concat(), d)
    } else {
        let r: Vec<&[u16]> = inp.images.iter().map(|f| f.as_slice()).collect();
        let d = decode_rows(&dec, &r, w, h)?;
        (
            Dtype::U16,
            inp.images.iter().flat_map(|f| u16_bytes(f)).collect(),
            d,
        )
    };
    let p = reconstruct_rows(
        recon,
        &cal.reference_phase,
        &cal.reference_validity,
        &d.phase,
        &d.validity,
        &inp.edge_filter,
    )?;

    let n_img = set.image_count();
    let levels = dec.level_count();
    let mut files = Vec::new();
    let mut arr =
        |path: String, dtype: Dtype, shape: Vec<usize>, description: String, bytes: Vec<u8>| {
            files.push(VectorFile {
                path,
                array: Some((dtype, shape)),
                format: "raw",
                description,
                bytes,
            });
        };
    arr(
        format!("input/images.{}", sample.name()),
        sample,
        vec![n_img, h, w],
        format!(
            "camera codes ({} significant bits) of every image of the set, in the set's image order (see pattern_set.order)",
            inp.bits
        ),
        image_bytes,
    );
    arr(
        "input/reference_phase.f32".into(),
        Dtype::F32,
        vec![h, w],
        "reference-plane absolute phase map Phi_R (radians), prepared: canonical NaN where invalid"
            .into(),
        f32_bytes(&cal.reference_phase),
    );
    for l in 0..levels {
        arr(
            format!("decode/wrapped_level{l}.f32"),
            Dtype::F32,
            vec![h, w],
            format!(
                "wrapped phase of level {l} (0 = coarsest), radians in [-pi, pi], every pixel (Decoder::decode_row_level)"
            ),
            f32_bytes(&d.wrapped[l]),
        );
        arr(
            format!("decode/modulation_level{l}.f32"),
            Dtype::F32,
            vec![h, w],
            format!(
                "modulation B of level {l}, camera codes, every pixel (Decoder::decode_row_level)"
            ),
            f32_bytes(&d.modulation_level[l]),
        );
    }
    arr(
        "decode/dc.f32".into(),
        Dtype::F32,
        vec![h, w],
        "DC term A (eq 10/15), camera codes, every pixel".into(),
        f32_bytes(&d.dc),
    );
    arr(
        "decode/modulation.f32".into(),
        Dtype::F32,
        vec![h, w],
        "modulation B of the finest level, camera codes, every pixel (Decoder::decode_row)".into(),
        f32_bytes(&d.modulation),
    );
    arr(
        "decode/phase.f32".into(),
        Dtype::F32,
        vec![h, w],
        "unwrapped absolute phase of the finest level (c_K * Phi), radians; canonical NaN where validity != 0".into(),
        f32_bytes(&d.phase),
    );
    arr(
        "decode/validity.u8".into(),
        Dtype::U8,
        vec![h, w],
        "decode validity codes (see validity_codes)".into(),
        d.validity.clone(),
    );
    arr(
        "reconstruct/points.f32".into(),
        Dtype::F32,
        vec![h, w, 3],
        "point M = (x, y, z) per pixel, camera frame, mm (paper eqs 16-18); canonical NaN where validity != 0".into(),
        f32_bytes(&p.points),
    );
    arr(
        "reconstruct/validity.u8".into(),
        Dtype::U8,
        vec![h, w],
        "reconstruction validity codes".into(),
        p.validity.clone(),
    );
    arr(
        "filter/validity.u8".into(),
        Dtype::U8,
        vec![h, w],
        "validity after the depth-edge filter (valid points at a depth discontinuity become 10 = depth-edge)".into(),
        p.filtered_validity.clone(),
    );
    arr(
        "filter/points.f32".into(),
        Dtype::F32,
        vec![h, w, 3],
        "points after the depth-edge filter: canonical NaN where the filtered validity != 0".into(),
        f32_bytes(&p.filtered_points),
    );
    let params = params_bytes(inp, &set)?;
    files.push(VectorFile {
        path: "input/params.bin".into(),
        array: None,
        format: "fringe3d params v1 (docs/golden-vectors.md)",
        description: "pattern set, decoder thresholds, camera model, reconstruction set-up and edge filter as little-endian binary, for firmware and ports".into(),
        bytes: params,
    });
    let tif = encode_tiff_f32(
        Path::new("input/reference_phase.tif"),
        w as u32,
        h as u32,
        &canonical_vec(&cal.reference_phase),
    )
    .map_err(|e| file_err(Path::new("input/reference_phase.tif"), e))?;
    files.push(VectorFile {
        path: "input/reference_phase.tif".into(),
        array: None,
        format: "tiff gray float32 (NaN = invalid)",
        description: "the reference map as the calibration file names it (same values as reference_phase.f32)".into(),
        bytes: tif,
    });
    files.sort_by(|a, b| a.path.cmp(&b.path));

    let info = manifest_info(inp, &set, &dec, sample, levels)?;
    Ok(GoldenVectors {
        width: w,
        height: h,
        files,
        info,
    })
}

fn canonical_vec(v: &[f32]) -> Vec<f32> {
    v.iter()
        .map(|x| if x.is_nan() { CANONICAL_NAN } else { *x })
        .collect()
}

fn axis_code(a: Axis) -> u32 {
    match a {
        Axis::Xi => 0,
        Axis::Eta => 1,
    }
}

fn axis_name(a: Axis) -> &'static str {
    match a {
        Axis::Xi => "xi",
        Axis::Eta => "eta",
    }
}

/// Little-endian writer of `params.bin`.
struct Params(Vec<u8>);

impl Params {
    fn u32(&mut self, v: u32) {
        self.0.extend_from_slice(&v.to_le_bytes());
    }
    fn f32(&mut self, v: f32) {
        self.0.extend_from_slice(&v.to_le_bytes());
    }
    fn f64(&mut self, v: f64) {
        self.0.extend_from_slice(&v.to_le_bytes());
    }
    fn len(&mut self, n: usize) -> Result<(), VectorsError> {
        self.u32(
            u32::try_from(n)
                .map_err(|_| VectorsError::Options("a count does not fit params.bin".into()))?,
        );
        Ok(())
    }
}

/// The `params.bin` of a set of inputs (layout: docs/golden-vectors.md).
fn params_bytes(inp: &Inputs, set: &PatternSet) -> Result<Vec<u8>, VectorsError> {
    let recon = &inp.calibration.recon;
    let mut p = Params(Vec::new());
    p.0.extend_from_slice(&PARAMS_MAGIC);
    p.len(recon.width())?;
    p.len(recon.height())?;
    p.len(set.image_count())?;
    p.u32(inp.bits as u32);
    p.u32(if inp.bits == 8 { 1 } else { 2 });
    let c = inp.decode_config;
    for v in [
        c.dark_level,
        c.saturation_level,
        c.min_modulation,
        c.unwrap_tolerance,
        c.range_tolerance,
    ] {
        p.f32(v);
    }
    // Pattern set.
    let f = set.function();
    p.u32(axis_code(f.axis()));
    match f.profile() {
        Profile::Linear { origin, slope } => {
            p.u32(0);
            p.f64(*origin);
            p.f64(*slope);
        }
        Profile::Knots(k) => {
            p.u32(1);
            p.len(k.len())?;
            for v in k.positions().iter().chain(k.phases()).chain(k.slopes()) {
                p.f64(*v);
            }
        }
    }
    p.f64(f.curvature());
    p.f64(f.bend_center());
    p.len(set.levels().len())?;
    for l in set.levels() {
        p.f64(l.scale());
        p.len(l.shifts().len())?;
        for s in l.shifts() {
            p.f64(*s);
        }
    }
    let o = set.output();
    p.u32(o.width);
    p.u32(o.height);
    p.f64(o.i_min);
    p.f64(o.i_max);
    p.u32(match set.convention() {
        Convention::Sine => 0,
        Convention::Cosine => 1,
    });
    p.f64(set.phase_offset());
    p.len(set.order().len())?;
    for id in set.order() {
        p.u32(id.level as u32);
        p.u32(id.shift as u32);
    }
    // Camera.
    let cam = recon.camera();
    let i = cam.params();
    for v in [i.fx, i.fy, i.skew, i.cx, i.cy] {
        p.f64(v);
    }
    p.u32(i.width);
    p.u32(i.height);
    for v in cam.distortion().to_array() {
        p.f64(v);
    }
    // Reconstruction set-up.
    let s = recon.setup();
    for v in [s.projector_centre, s.reference_point, s.reference_normal] {
        p.f64(v.x);
        p.f64(v.y);
        p.f64(v.z);
    }
    p.u32(axis_code(s.axis));
    p.f64(s.z_min);
    p.f64(s.z_max);
    // Edge filter.
    p.f64(inp.edge_focal_px);
    p.f64(inp.edge_max_angle_deg);
    p.0.extend_from_slice(&PARAMS_END);
    Ok(p.0)
}

fn hex32(v: f32) -> String {
    format!("0x{:08x}", v.to_bits())
}

fn manifest_info(
    inp: &Inputs,
    set: &PatternSet,
    dec: &Decoder,
    sample: Dtype,
    levels: usize,
) -> Result<serde_json::Map<String, serde_json::Value>, VectorsError> {
    let recon = &inp.calibration.recon;
    let (w, h) = (recon.width(), recon.height());
    let spec = &inp.scene.spec;
    let f = set.function();
    let profile = match f.profile() {
        Profile::Linear { origin, slope } => {
            json!({"kind": "linear", "origin": origin, "slope": slope})
        }
        Profile::Knots(k) => {
            json!({"kind": "knots", "positions": k.positions(), "phases": k.phases(), "slopes": k.slopes()})
        }
    };
    let mut estimators = Vec::new();
    for (k, l) in set.levels().iter().enumerate() {
        let e = level_estimator(l.shifts(), set.effective_offset())
            .ok_or_else(|| kernel("decoder set-up", format!("level {k}: degenerate shifts")))?;
        let n = e.n;
        estimators.push(json!({
            "level": k,
            "a": e.a[..n].iter().map(|v| hex32(*v)).collect::<Vec<_>>(),
            "b": e.b[..n].iter().map(|v| hex32(*v)).collect::<Vec<_>>(),
            "w": e.w[..n].iter().map(|v| hex32(*v)).collect::<Vec<_>>(),
            "a_dc": hex32(e.a_dc),
            "b_dc": hex32(e.b_dc),
        }));
    }
    let c = inp.decode_config;
    let cam = recon.camera();
    let i = cam.params();
    let s = recon.setup();
    let band = recon.band();
    let v3 = |v: fringe3d_core::geometry::Vec3| json!([v.x, v.y, v.z]);
    let mut m = serde_json::Map::new();
    m.insert("format".into(), json!(FORMAT));
    m.insert("version".into(), json!(VERSION));
    m.insert(
        "generator".into(),
        json!(format!("fringe3d {}", env!("CARGO_PKG_VERSION"))),
    );
    m.insert(
        "conventions".into(),
        json!({
            "byte_order": "little-endian",
            "array_order": "C (row-major): the last index of `shape` varies fastest; images are [image, row, column], points [row, column, xyz]",
            "nan": "every NaN in every f32 file is the canonical quiet NaN 0x7fc00000; compare bits after mapping any NaN to it",
            "units": "phase radians, intensities camera codes, lengths mm (camera frame, OpenCV axes: x right, y down, z forward), pixel centres at integers",
            "hex_floats": "values written as 0x........ are the IEEE 754 binary32 bit patterns",
        }),
    );
    m.insert(
        "scene".into(),
        json!({"name": spec.name, "width": w, "height": h, "camera_bits": inp.bits, "noise_sigma": spec.camera.noise, "seed": spec.seed,
               "regenerate": format!("fringe3d vectors --out DIR --scene {} --size {w}x{h} --bits {} --noise {} --seed {} --max-angle {}",
                                     spec.name, inp.bits, spec.camera.noise, spec.seed, inp.edge_max_angle_deg)}),
    );
    m.insert("sample_dtype".into(), json!(sample.name()));
    m.insert(
        "decode_config".into(),
        json!({"dark_level": hex32(c.dark_level), "saturation_level": hex32(c.saturation_level), "min_modulation": hex32(c.min_modulation),
               "unwrap_tolerance": hex32(c.unwrap_tolerance), "range_tolerance": hex32(c.range_tolerance),
               "values": [c.dark_level, c.saturation_level, c.min_modulation, c.unwrap_tolerance, c.range_tolerance]}),
    );
    m.insert(
        "pattern_set".into(),
        json!({
            "axis": axis_name(f.axis()),
            "profile": profile,
            "curvature": f.curvature(),
            "bend_center": f.bend_center(),
            "levels": set.levels().iter().map(|l| json!({"scale": l.scale(), "shifts": l.shifts()})).collect::<Vec<_>>(),
            "output": {"width": set.output().width, "height": set.output().height, "i_min": set.output().i_min, "i_max": set.output().i_max},
            "convention": match set.convention() { Convention::Sine => "sine", Convention::Cosine => "cosine" },
            "phase_offset": set.phase_offset(),
            "effective_offset": set.effective_offset(),
            "order": set.order().iter().map(|id| json!([id.level, id.shift])).collect::<Vec<_>>(),
            "coarse_range": [set.coarse_range().0, set.coarse_range().1],
            "estimators": estimators,
            "images": dec.image_count(),
            "levels_count": levels,
        }),
    );
    m.insert(
        "calibration".into(),
        json!({
            "camera": {"fx": i.fx, "fy": i.fy, "skew": i.skew, "u0": i.cx, "v0": i.cy, "width": i.width, "height": i.height,
                       "distortion_k1_k2_p1_p2_k3": cam.distortion().to_array()},
            "projector_centre": v3(s.projector_centre),
            "reference_point": v3(s.reference_point),
            "reference_normal": v3(s.reference_normal),
            "axis": axis_name(s.axis),
            "depth_range": [s.z_min, s.z_max],
        }),
    );
    m.insert(
        "reconstruction".into(),
        json!({"band": {"above": band.above, "below": band.below, "rows": band.rows()},
               "ring_bytes": recon.ring_bytes(band.rows()),
               "max_segment_px": recon.max_segment_px(),
               "fallback_bisections": recon.fallback_bisections()}),
    );
    m.insert(
        "edge_filter".into(),
        json!({"focal_px": inp.edge_focal_px, "max_angle_deg": inp.edge_max_angle_deg}),
    );
    m.insert(
        "validity_codes".into(),
        json!(
            Validity::ALL
                .iter()
                .map(|v| json!([*v as u8, v.name()]))
                .collect::<Vec<_>>()
        ),
    );
    m.insert(
        "pipeline".into(),
        json!([
            "decode: for every row y, Decoder::new(pattern_set, decode_config).decode_row(rows y of every image) -> phase, modulation, dc, validity; decode_row_level(rows, k) -> wrapped_level{k}, modulation_level{k}",
            "reconstruct: Reconstructor::new(camera, setup); a ReferenceRing of band.rows reference rows (pushed in order, invalid samples as canonical NaN); reconstruct_row(ring, v, phase row, validity row) -> points, validity",
            "edge filter: EdgeFilter::new(focal_px, max_angle_deg).filter_row(row above, row, row below) on the reconstructed points and codes -> filter/validity; points whose filtered code != 0 become canonical NaN",
        ]),
    );
    Ok(m)
}

/// Write `v` (made from `inp`) into the folder `dir` atomically (replacing it if `overwrite`),
/// with the pattern set and calibration in the project's own file formats
/// (`input/patterns.toml`, `input/calibration.toml`, also listed in the manifest) and the
/// manifest. Returns the folder.
pub fn write(
    v: &GoldenVectors,
    inp: &Inputs,
    dir: &Path,
    overwrite: bool,
) -> Result<PathBuf, VectorsError> {
    let out = AtomicDir::create(dir, overwrite)?;
    for f in &v.files {
        let p = out.join(&f.path);
        if let Some(parent) = p.parent() {
            std::fs::create_dir_all(parent).map_err(|e| file_err(parent, e))?;
        }
        std::fs::write(&p, &f.bytes).map_err(|e| file_err(&p, e))?;
    }
    // The project's own formats, for `fringe3d scan` and `fringe3d info`.
    PatternSetFile::from_pattern_set(&inp.scene.patterns, inp.scene.pattern_bits)
        .save(&out.join("input/patterns.toml"))?;
    inp.calibration
        .calibration
        .save(&out.join("input/calibration.toml"))?;
    let mut info = v.clone();
    for (rel, fmt, what) in [
        (
            "input/patterns.toml",
            "fringe3d pattern-set TOML (docs/formats.md)",
            "the pattern set in the project's file format",
        ),
        (
            "input/calibration.toml",
            "fringe3d calibration TOML (docs/formats.md)",
            "the calibration in the project's file format (names reference_phase.tif and patterns.toml)",
        ),
    ] {
        let p = out.join(rel);
        let bytes = std::fs::read(&p).map_err(|e| file_err(&p, e))?;
        info.files.push(VectorFile {
            path: rel.into(),
            array: None,
            format: fmt,
            description: what.into(),
            bytes,
        });
    }
    info.files.sort_by(|a, b| a.path.cmp(&b.path));
    let m = info.manifest_bytes()?;
    let mp = out.join(MANIFEST);
    std::fs::write(&mp, &m).map_err(|e| file_err(&mp, e))?;
    Ok(out.commit()?)
}

/// Generate the vectors of `opts` and write them to `dir` ([`generate`] then [`write()`]).
/// Returns the vectors as written (the project-format files included).
pub fn generate_into(
    opts: &VectorOptions,
    dir: &Path,
    overwrite: bool,
) -> Result<GoldenVectors, VectorsError> {
    let inp = inputs(opts)?;
    let v = generate_from(&inp)?;
    let out = write(&v, &inp, dir, overwrite)?;
    read_dir(&out)
}

/// One difference between a folder and its manifest, or between two sets of vectors.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Mismatch {
    /// The file.
    pub path: String,
    /// What differs.
    pub what: String,
}

/// Read a vectors folder back: its manifest's entries with the bytes found on disk. Fails on a
/// missing manifest or file; digests are not checked here (see [`check_dir`]).
pub fn read_dir(dir: &Path) -> Result<GoldenVectors, VectorsError> {
    let mp = dir.join(MANIFEST);
    let text = crate::io::input::read_text_limited(&mp, crate::io::input::MAX_TEXT_BYTES)
        .map_err(|e| file_err(&mp, e))?;
    let m: serde_json::Value = serde_json::from_str(&text).map_err(|e| file_err(&mp, e))?;
    let obj = m
        .as_object()
        .ok_or_else(|| file_err(&mp, "not a JSON object"))?;
    if obj.get("format").and_then(|f| f.as_str()) != Some(FORMAT) {
        return Err(file_err(&mp, format!("not a {FORMAT} manifest")));
    }
    let files = obj
        .get("files")
        .and_then(|f| f.as_array())
        .ok_or_else(|| file_err(&mp, "no files list"))?;
    let mut out = Vec::new();
    for f in files {
        let path = f
            .get("path")
            .and_then(|p| p.as_str())
            .ok_or_else(|| file_err(&mp, "a file entry has no path"))?;
        let full = dir.join(path);
        let bytes = crate::io::input::read_limited(&full, crate::io::input::MAX_IMAGE_BYTES)
            .map_err(|e| file_err(&full, e))?;
        let array = match (
            f.get("dtype").and_then(|d| d.as_str()),
            f.get("shape").and_then(|s| s.as_array()),
        ) {
            (Some(d), Some(s)) => {
                let dt = match d {
                    "u8" => Dtype::U8,
                    "u16" => Dtype::U16,
                    "f32" => Dtype::F32,
                    other => return Err(file_err(&mp, format!("{path}: unknown dtype {other:?}"))),
                };
                Some((
                    dt,
                    s.iter().map(|x| x.as_u64().unwrap_or(0) as usize).collect(),
                ))
            }
            _ => None,
        };
        let description = f
            .get("description")
            .and_then(|d| d.as_str())
            .unwrap_or("")
            .to_string();
        out.push(VectorFile {
            path: path.into(),
            array,
            format: "raw",
            description,
            bytes,
        });
    }
    let mut info = obj.clone();
    info.remove("files");
    let dim = |k: &str| {
        obj.get("scene")
            .and_then(|s| s.get(k))
            .and_then(|v| v.as_u64())
            .unwrap_or(0) as usize
    };
    Ok(GoldenVectors {
        width: dim("width"),
        height: dim("height"),
        files: out,
        info,
    })
}

/// Check every file of a vectors folder against the SHA-256 and size its manifest records.
/// Returns the mismatches (empty: the folder is intact).
pub fn check_dir(dir: &Path) -> Result<Vec<Mismatch>, VectorsError> {
    let mp = dir.join(MANIFEST);
    let text = crate::io::input::read_text_limited(&mp, crate::io::input::MAX_TEXT_BYTES)
        .map_err(|e| file_err(&mp, e))?;
    let m: serde_json::Value = serde_json::from_str(&text).map_err(|e| file_err(&mp, e))?;
    let files = m
        .get("files")
        .and_then(|f| f.as_array())
        .ok_or_else(|| file_err(&mp, "no files list"))?;
    let mut bad = Vec::new();
    for f in files {
        let path = f
            .get("path")
            .and_then(|p| p.as_str())
            .unwrap_or("")
            .to_string();
        let want = f
            .get("sha256")
            .and_then(|p| p.as_str())
            .unwrap_or("")
            .to_string();
        match crate::io::input::read_limited(&dir.join(&path), crate::io::input::MAX_IMAGE_BYTES) {
            Ok(b) => {
                let got = sha256_hex(&b);
                if got != want {
                    bad.push(Mismatch {
                        path,
                        what: format!("sha256 {got}, manifest says {want}"),
                    });
                }
            }
            Err(e) => bad.push(Mismatch {
                path,
                what: format!("cannot read: {e}"),
            }),
        }
    }
    Ok(bad)
}

/// Compare two sets of vectors file by file (paths, bytes); for raw arrays the first differing
/// element is named.
pub fn compare(expected: &GoldenVectors, got: &GoldenVectors) -> Vec<Mismatch> {
    let mut bad = Vec::new();
    for e in &expected.files {
        match got.file(&e.path) {
            None => bad.push(Mismatch {
                path: e.path.clone(),
                what: "missing".into(),
            }),
            Some(g) if g.bytes != e.bytes => bad.push(Mismatch {
                path: e.path.clone(),
                what: first_difference(e, &g.bytes),
            }),
            Some(_) => {}
        }
    }
    for g in &got.files {
        if expected.file(&g.path).is_none() {
            bad.push(Mismatch {
                path: g.path.clone(),
                what: "not expected".into(),
            });
        }
    }
    bad
}

/// Describe where `got` first differs from the file `e` (element index for raw arrays).
pub fn first_difference(e: &VectorFile, got: &[u8]) -> String {
    if got.len() != e.bytes.len() {
        return format!("{} bytes, expected {}", got.len(), e.bytes.len());
    }
    let Some(i) = e.bytes.iter().zip(got).position(|(a, b)| a != b) else {
        return "identical".into();
    };
    let count = e.bytes.iter().zip(got).filter(|(a, b)| a != b).count();
    match &e.array {
        Some((d, shape)) => {
            let k = i / d.size();
            let mut idx = Vec::new();
            let mut r = k;
            for s in shape.iter().rev() {
                idx.push(r % s.max(&1));
                r /= s.max(&1);
            }
            idx.reverse();
            let at = |b: &[u8]| -> String {
                let s = d.size();
                match (d, b.get(s * k..s * k + s)) {
                    (Dtype::U8, Some(x)) => format!("{}", x[0]),
                    (Dtype::U16, Some(x)) => format!("{}", u16::from_le_bytes([x[0], x[1]])),
                    (Dtype::F32, Some(x)) => {
                        let v = f32::from_le_bytes([x[0], x[1], x[2], x[3]]);
                        format!("{v:e} (0x{:08x})", v.to_bits())
                    }
                    (_, None) => "(truncated)".into(),
                }
            };
            format!(
                "{count} bytes differ; first at element {idx:?}: expected {}, got {}",
                at(&e.bytes),
                at(got)
            )
        }
        None => format!("{count} bytes differ; first at byte {i}"),
    }
}

/// The raw array files of a decode and point stage, as they appear in the vectors (for comparing
/// another driver's outputs by digest). Paths as in [`generate`].
pub fn stage_files(d: &DecodeStage, p: Option<&PointStage>) -> Vec<(String, Vec<u8>)> {
    let mut v = Vec::new();
    for (l, (wr, m)) in d.wrapped.iter().zip(&d.modulation_level).enumerate() {
        v.push((format!("decode/wrapped_level{l}.f32"), f32_bytes(wr)));
        v.push((format!("decode/modulation_level{l}.f32"), f32_bytes(m)));
    }
    v.push(("decode/dc.f32".into(), f32_bytes(&d.dc)));
    v.push(("decode/modulation.f32".into(), f32_bytes(&d.modulation)));
    v.push(("decode/phase.f32".into(), f32_bytes(&d.phase)));
    v.push(("decode/validity.u8".into(), d.validity.clone()));
    if let Some(p) = p {
        v.push(("reconstruct/points.f32".into(), f32_bytes(&p.points)));
        v.push(("reconstruct/validity.u8".into(), p.validity.clone()));
        v.push(("filter/validity.u8".into(), p.filtered_validity.clone()));
        v.push(("filter/points.f32".into(), f32_bytes(&p.filtered_points)));
    }
    v
}
