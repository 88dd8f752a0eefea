//! Dataset folders: images, pattern-set file, true calibration, reference phase map, ground
//! truth and a manifest with the SHA-256 of every file. Written atomically (all or nothing) and
//! deterministically (same scene and seed → same bytes).

use super::board::{BoardTruth, board_object, board_truth, random_poses};
use super::engine::{Frames, MASK_HIT, MASK_IN_FRAME, MASK_LIT, Sensor, Truth};
use super::objects::{Geometry, Prim};
use super::scene::{BoardLight, DatasetKind, FringeAxis, ReferenceMode};
use super::{RenderError, RenderOptions, Scene, Slide, decode_phase_corrected};
use crate::io::atomic::AtomicDir;
use crate::io::image::{encode_png_u8, encode_png_u16, encode_tiff_f32};
use crate::io::npy;
use crate::io::pattern_file::PatternSetFile;
use fringe3d_core::pattern::PatternSet;
use serde::Serialize;
use serde_json::json;
use sha2::{Digest, Sha256};
use std::path::{Path, PathBuf};

/// Manifest format name.
pub const MANIFEST_FORMAT: &str = "fringe3d-render-dataset";
/// Manifest format version.
pub const MANIFEST_VERSION: u32 = 1;

/// Options of [`write_dataset`].
#[derive(Clone, Copy, Default)]
pub struct DatasetOptions<'a> {
    /// Replace an existing non-empty folder.
    pub overwrite: bool,
    /// Called with the number of image rows just rendered.
    pub progress: Option<&'a (dyn Fn(u64) + Sync)>,
}

/// What [`write_dataset`] wrote.
#[derive(Clone, Debug, Serialize)]
pub struct Summary {
    /// The dataset folder.
    pub path: PathBuf,
    /// Its kind.
    pub kind: DatasetKind,
    /// Camera images written.
    pub images: usize,
    /// Files written (besides the manifest).
    pub files: usize,
    /// Total bytes of those files.
    pub bytes: u64,
}

#[derive(Clone, Debug, Serialize)]
struct FileEntry {
    path: String,
    format: String,
    description: String,
    bytes: u64,
    sha256: String,
}

struct Out {
    dir: AtomicDir,
    files: Vec<FileEntry>,
}

fn file_err(path: &Path, m: impl std::fmt::Display) -> RenderError {
    RenderError::File {
        path: path.to_path_buf(),
        message: m.to_string(),
    }
}

fn hex(d: &[u8]) -> String {
    d.iter().map(|b| format!("{b:02x}")).collect()
}

impl Out {
    fn put(
        &mut self,
        rel: &str,
        bytes: &[u8],
        format: &str,
        description: &str,
    ) -> Result<(), RenderError> {
        let path = self.dir.join(rel);
        if let Some(p) = path.parent() {
            std::fs::create_dir_all(p).map_err(|e| file_err(p, e))?;
        }
        std::fs::write(&path, bytes).map_err(|e| file_err(&path, e))?;
        self.record(rel, bytes, format, description);
        Ok(())
    }

    fn record(&mut self, rel: &str, bytes: &[u8], format: &str, description: &str) {
        self.files.push(FileEntry {
            path: rel.into(),
            format: format.into(),
            description: description.into(),
            bytes: bytes.len() as u64,
            sha256: hex(&Sha256::digest(bytes)),
        });
    }

    /// Hash a file another writer put at `rel`.
    fn adopt(&mut self, rel: &str, format: &str, description: &str) -> Result<(), RenderError> {
        let path = self.dir.join(rel);
        let b = std::fs::read(&path).map_err(|e| file_err(&path, e))?;
        self.record(rel, &b, format, description);
        Ok(())
    }

    fn ensure_dir(&self, rel: &str) -> Result<PathBuf, RenderError> {
        let p = self.dir.join(rel);
        std::fs::create_dir_all(&p).map_err(|e| file_err(&p, e))?;
        Ok(p)
    }

    fn image(
        &mut self,
        rel: &str,
        f: &Frames,
        i: usize,
        description: &str,
    ) -> Result<(), RenderError> {
        let path = self.dir.join(rel);
        let img = &f.images[i];
        let (bytes, fmt) = if f.bits == 8 {
            let v: Vec<u8> = img.iter().map(|&x| x.min(255) as u8).collect();
            (
                encode_png_u8(&path, f.width, f.height, &v)?,
                "png gray 8-bit",
            )
        } else {
            (
                encode_png_u16(&path, f.width, f.height, img, f.bits)?,
                if f.bits == 12 {
                    "png gray 16-bit container, 12 significant bits (sBIT), codes 0..4095"
                } else {
                    "png gray 16-bit"
                },
            )
        };
        self.put(rel, &bytes, fmt, description)
    }

    fn tiff(
        &mut self,
        rel: &str,
        w: u32,
        h: u32,
        data: &[f32],
        description: &str,
    ) -> Result<(), RenderError> {
        let path = self.dir.join(rel);
        let b = encode_tiff_f32(&path, w, h, data)?;
        self.put(rel, &b, "tiff gray float32 (NaN = invalid)", description)
    }
}

/// Image rows the dataset of `scene` renders (for a progress bar).
pub fn planned_rows(scene: &Scene) -> u64 {
    let h = scene.rig.camera.height as u64;
    let s = &scene.spec;
    let refs =
        u64::from(s.reference.mode == ReferenceMode::Render && s.kind != DatasetKind::Checkerboard);
    match s.kind {
        DatasetKind::Fringe => h * (1 + refs),
        DatasetKind::Checkerboard => {
            let b = s.board.as_ref();
            let n = b
                .map(|b| {
                    if b.poses.is_empty() {
                        b.count as u64
                    } else {
                        b.poses.len() as u64
                    }
                })
                .unwrap_or(0);
            h * n
        }
        DatasetKind::Plates => {
            h * (3 * s.plates.as_ref().map_or(0, |p| p.positions.len() as u64) + refs)
        }
    }
}

fn f32s(v: &[f64]) -> Vec<f32> {
    v.iter().map(|&x| x as f32).collect()
}

/// Phase where the truth says the point is lit and on the DMD, NaN elsewhere.
fn lit_phase(set: &PatternSet, truth: &Truth) -> Vec<f64> {
    let need = MASK_HIT | MASK_IN_FRAME | MASK_LIT;
    truth
        .projector
        .iter()
        .zip(&truth.mask)
        .map(|(p, &m)| {
            if m & need == need {
                set.finest_phase(p[0], p[1])
            } else {
                f64::NAN
            }
        })
        .collect()
}

fn write_truth(
    out: &mut Out,
    dir: &str,
    set: Option<&PatternSet>,
    t: &Truth,
) -> Result<(), RenderError> {
    let (w, h) = (t.width, t.height);
    let (wu, hu) = (w as usize, h as usize);
    let pts: Vec<f64> = t.points.iter().flatten().copied().collect();
    out.put(
        &format!("{dir}/points.npy"),
        &npy::encode(&[hu, wu, 3], &pts),
        "npy float64 (H, W, 3)",
        "hit point of the pixel-centre ray, camera frame, mm; NaN = no hit",
    )?;
    let nrm: Vec<f32> = t.normals.iter().flatten().map(|&x| x as f32).collect();
    out.put(
        &format!("{dir}/normals.npy"),
        &npy::encode(&[hu, wu, 3], &nrm),
        "npy float32 (H, W, 3)",
        "unit surface normal towards the camera; NaN = no hit",
    )?;
    let pr: Vec<f64> = t.projector.iter().flatten().copied().collect();
    out.put(
        &format!("{dir}/projector.npy"),
        &npy::encode(&[hu, wu, 2], &pr),
        "npy float64 (H, W, 2)",
        "exact projector coordinates (xi, eta) of the hit point, projector pixels (centres at integers); NaN = none",
    )?;
    let depth: Vec<f32> = t.points.iter().map(|p| p[2] as f32).collect();
    out.tiff(
        &format!("{dir}/depth.tif"),
        w,
        h,
        &depth,
        "z of the hit point, mm",
    )?;
    let mp = std::path::Path::new("mask.png");
    out.put(&format!("{dir}/mask.png"), &encode_png_u8(mp, w, h, &t.mask)?, "png gray 8-bit bit mask", "1 hit | 2 on the DMD | 4 lit (faces the projector, unshadowed) | 8 clean (whole pixel on one surface, away from edges); 15 = valid")?;
    out.put(
        &format!("{dir}/object_id.png"),
        &encode_png_u16(mp, w, h, &t.object_id, 16)?,
        "png gray 16-bit",
        "object id of the hit (manifest primitives); 0 = none",
    )?;
    if let Some(set) = set {
        let ph = lit_phase(set, t);
        out.tiff(
            &format!("{dir}/phase.tif"),
            w,
            h,
            &f32s(&ph),
            "true absolute phase c_K*Phi(xi, eta) of the finest level, radians; NaN where not lit",
        )?;
        out.put(
            &format!("{dir}/phase.npy"),
            &npy::encode(&[hu, wu], &ph),
            "npy float64 (H, W)",
            "true absolute phase, float64",
        )?;
    }
    Ok(())
}

fn prim_json(scene_objects: &[super::ObjectSpec], g: &Geometry) -> serde_json::Value {
    let v: Vec<serde_json::Value> = g
        .prims
        .iter()
        .map(|p| {
            let o = &scene_objects[p.object];
            let part = match (&o.shape, p.part) {
                (super::Shape::BallBar { .. }, 0) => "ball_a",
                (super::Shape::BallBar { .. }, 1) => "ball_b",
                (super::Shape::BallBar { .. }, _) => "bar",
                _ => "whole",
            };
            let exact = match &p.prim {
                Prim::Sphere { c, r } => json!({"sphere": {"center": c.to_array(), "radius": r}}),
                Prim::Cylinder { c0, w, r, len, caps } => json!({"cylinder": {"start": c0.to_array(), "axis": w.to_array(), "radius": r, "length": len, "caps": caps}}),
                Prim::Plane { p, n, u, v, half } => json!({"plane": {"point": p.to_array(), "normal": n.to_array(), "u": u.to_array(), "v": v.to_array(), "half_size": half.map(|(a, b)| [a, b])}}),
                Prim::Box { c, rot, half } => json!({"box": {"center": c.to_array(), "rotation": rot.0, "half_size": half.to_array()}}),
                Prim::Height(_) => json!({"height_field": "see the object's shape"}),
            };
            json!({"id": p.id, "object": p.object, "name": o.name, "part": part, "albedo": p.albedo, "geometry": exact})
        })
        .collect();
    serde_json::Value::Array(v)
}

fn pattern_file(
    out: &mut Out,
    rel: &str,
    set: &PatternSet,
    bits: u8,
    images: Option<Vec<String>>,
) -> Result<(), RenderError> {
    let mut f = PatternSetFile::from_pattern_set(set, bits);
    f.images = images.map(|v| v.into_iter().map(PathBuf::from).collect());
    f.save(&out.dir.join(rel))?;
    out.adopt(
        rel,
        "fringe3d pattern-set TOML (docs/formats.md)",
        "the projected pattern set",
    )
}

fn image_list(set: &PatternSet, prefix: &str) -> Vec<serde_json::Value> {
    set.order()
        .iter()
        .enumerate()
        .map(|(i, id)| {
            let level = &set.levels()[id.level as usize];
            let file = format!("{prefix}img_{i:02}.png");
            match level.gray() {
                // A Gray-code image: its bit (0 = most significant).
                Some(_) => json!({"file": file, "level": id.level, "gray_bit": id.shift}),
                None => json!({"file": file, "level": id.level, "shift": id.shift, "shift_rad": level.shifts()[id.shift as usize]}),
            }
        })
        .collect()
}

/// Render `scene` and write its dataset folder to `out` atomically. See `docs/render.md` for the
/// layout.
pub fn write_dataset(
    scene: &Scene,
    out_dir: &Path,
    opts: DatasetOptions<'_>,
) -> Result<Summary, RenderError> {
    let dir = AtomicDir::create(out_dir, opts.overwrite)?;
    let mut out = Out {
        dir,
        files: Vec::new(),
    };
    let ropts = RenderOptions {
        keep_float: false,
        progress: opts.progress,
        sensor: None,
        photometry: None,
    };
    let spec = &scene.spec;
    let rig = &scene.rig;
    let mut extra = serde_json::Map::new();
    let mut images = 0usize;
    let mut gains = Vec::new();
    let mut reference_files: Option<(String, String)> = None;

    // The reference map (fringe and plates scenes).
    let mut reference = |out: &mut Out,
                         main: Option<(&Frames, &Truth)>|
     -> Result<(), RenderError> {
        let owned;
        let (frames, truth): (&Frames, &Truth) = match (spec.reference.mode, main) {
            (ReferenceMode::Render, _) => {
                owned = scene.render_reference(ropts)?;
                (&owned.0, &owned.1)
            }
            (ReferenceMode::Images, Some((f, t))) => (f, t),
            _ => return Ok(()),
        };
        let decoded = decode_phase_corrected(
            &scene.patterns,
            frames,
            scene.true_correction(&scene.patterns)?.as_ref(),
        )?;
        let (w, h) = (frames.width, frames.height);
        out.tiff("reference_phase.tif", w, h, &decoded, "reference plane phase map decoded from its own render by the core decoder (what a user gets); NaN = invalid")?;
        let tp = lit_phase(&scene.patterns, truth);
        out.tiff(
            "truth/reference_phase_true.tif",
            w,
            h,
            &f32s(&tp),
            "exact reference plane phase c_K*Phi(xi, eta); NaN where not lit",
        )?;
        reference_files = Some(("reference_phase.tif".into(), "patterns.toml".into()));
        Ok(())
    };

    match spec.kind {
        DatasetKind::Fringe => {
            let (frames, truth) = scene.render_fringes(ropts)?;
            gains.push(frames.gain);
            let names: Vec<String> = (0..frames.images.len())
                .map(|i| format!("img_{i:02}.png"))
                .collect();
            for (i, n) in names.iter().enumerate() {
                out.image(n, &frames, i, "camera image of pattern image i (set order)")?;
            }
            images += names.len();
            pattern_file(
                &mut out,
                "patterns.toml",
                &scene.patterns,
                scene.pattern_bits,
                Some(names),
            )?;
            write_truth(&mut out, "truth", Some(&scene.patterns), &truth)?;
            reference(&mut out, Some((&frames, &truth)))?;
            let n_gray = spec.projector.gray_levels as usize;
            if n_gray > 0 {
                // Uniform gray levels on the reference plane (noise stream 2), for
                // `fringe3d calibrate gamma`.
                let full = if scene.pattern_bits == 8 { 255 } else { 65535 };
                let codes = crate::response::gray_codes(n_gray, full);
                let slides: Vec<Slide> = codes
                    .iter()
                    .map(|&c| Slide::Uniform(c as f64 / full as f64))
                    .collect();
                let (f, _) = scene.render_slides(&scene.reference_geometry(), &slides, 2, ropts)?;
                out.ensure_dir("gray")?;
                for k in 0..codes.len() {
                    out.image(
                        &format!("gray/gray_{k:02}.png"),
                        &f,
                        k,
                        "camera image of the reference plane under a uniform gray level (codes: manifest extra.gray_codes)",
                    )?;
                }
                images += codes.len();
                extra.insert("gray_codes".into(), json!(codes));
            }
            extra.insert(
                "images".into(),
                serde_json::Value::Array(image_list(&scene.patterns, "")),
            );
            extra.insert(
                "primitives".into(),
                prim_json(&spec.objects, &scene.geometry),
            );
        }
        DatasetKind::Checkerboard => {
            let b = spec
                .board
                .clone()
                .ok_or_else(|| RenderError::Decode("no board".into()))?;
            let lit = spec.photometry.board_light == BoardLight::Projector;
            let poses = if b.poses.is_empty() {
                random_poses(&b, rig, spec.seed, b.count as usize, lit)
                    .map_err(|m| scene_err(scene, m))?
            } else {
                b.poses.clone()
            };
            let sensor = board_sensor(scene, b.supersample);
            let slides = [Slide::Uniform(if lit { 1.0 } else { 0.0 })];
            let mut truths: Vec<BoardTruth> = Vec::new();
            for (k, pose) in poses.iter().enumerate() {
                let name = format!("board_{k:02}.png");
                let g = Geometry::build(&[board_object(&b, pose, None, true, b.light)])
                    .map_err(|m| scene_err(scene, m))?;
                let (f, _) = scene.render_slides(
                    &g,
                    &slides,
                    100 + k as u64,
                    RenderOptions {
                        sensor: Some(sensor),
                        photometry: Some(board_photometry(scene, lit)),
                        ..ropts
                    },
                )?;
                gains.push(f.gain);
                out.image(&name, &f, 0, "checkerboard under uniform light")?;
                images += 1;
                truths.push(board_truth(&b, pose, rig, &name).ok_or_else(|| {
                    scene_err(scene, format!("board pose {k}: a corner does not project"))
                })?);
            }
            let j = json!({"board": b, "corner_order": "row by row, x fastest (OpenCV)", "poses": truths});
            out.put("truth/corners.json", &pretty(&j)?, "json", "board poses, inner corners in mm (camera frame) and in pixels (camera model, distortion included)")?;
        }
        DatasetKind::Plates => {
            let b = spec
                .board
                .clone()
                .ok_or_else(|| RenderError::Decode("no board".into()))?;
            let plates = spec
                .plates
                .clone()
                .ok_or_else(|| RenderError::Decode("no plates".into()))?;
            let (set_v, bits) = spec.pattern_set(scene.base_dir(), Some(FringeAxis::Xi))?;
            let (set_h, _) = spec.pattern_set(scene.base_dir(), Some(FringeAxis::Eta))?;
            pattern_file(&mut out, "patterns_v.toml", &set_v, bits, None)?;
            pattern_file(&mut out, "patterns_h.toml", &set_h, bits, None)?;
            let lit = spec.photometry.board_light == BoardLight::Projector;
            let bsensor = board_sensor(scene, b.supersample);
            let mut recs = Vec::new();
            for (k, pose) in plates.positions.iter().enumerate() {
                let pd = format!("plate_{k:02}");
                out.ensure_dir(&pd)?;
                let plate = Geometry::build(&[board_object(
                    &b,
                    pose,
                    Some(plates.size),
                    false,
                    plates.albedo,
                )])
                .map_err(|m| scene_err(scene, m))?;
                for (axis, set, stream) in [
                    ("v", &set_v, 1000 + 3 * k as u64),
                    ("h", &set_h, 1001 + 3 * k as u64),
                ] {
                    let slides: Vec<Slide> = (0..set.image_count())
                        .map(|index| Slide::Pattern { set, index, bits })
                        .collect();
                    let (f, t) = scene.render_slides(&plate, &slides, stream, ropts)?;
                    gains.push(f.gain);
                    for i in 0..f.images.len() {
                        out.image(
                            &format!("{pd}/{axis}/img_{i:02}.png"),
                            &f,
                            i,
                            &format!("plate {k}, {axis} fringes, pattern image i"),
                        )?;
                    }
                    images += f.images.len();
                    let ph = lit_phase(set, &t);
                    out.tiff(
                        &format!("truth/{pd}/phase_{axis}.tif"),
                        t.width,
                        t.height,
                        &f32s(&ph),
                        "true absolute phase of this fringe set; NaN where not lit",
                    )?;
                    if axis == "v" {
                        let mp = Path::new("mask.png");
                        out.put(
                            &format!("truth/{pd}/mask.png"),
                            &encode_png_u8(mp, t.width, t.height, &t.mask)?,
                            "png gray 8-bit bit mask",
                            "as truth/mask.png of a fringe dataset",
                        )?;
                    }
                }
                let board_g =
                    Geometry::build(&[board_object(&b, pose, Some(plates.size), true, b.light)])
                        .map_err(|m| scene_err(scene, m))?;
                let slides = [Slide::Uniform(if lit { 1.0 } else { 0.0 })];
                let (f, _) = scene.render_slides(
                    &board_g,
                    &slides,
                    1002 + 3 * k as u64,
                    RenderOptions {
                        sensor: Some(bsensor),
                        photometry: Some(board_photometry(scene, lit)),
                        ..ropts
                    },
                )?;
                gains.push(f.gain);
                let bname = format!("{pd}/board.png");
                out.image(
                    &bname,
                    &f,
                    0,
                    "the plate's board pattern under uniform light (same pose)",
                )?;
                images += 1;
                let bt = board_truth(&b, pose, rig, &bname).ok_or_else(|| {
                    scene_err(scene, format!("plate {k}: a board corner does not project"))
                })?;
                recs.push(json!({"folder": pd, "pose": pose, "plane_point": pose.center, "plane_normal": bt.normal, "board": bt}));
            }
            let j = json!({"board": b, "plate_size": plates.size, "plates": recs});
            out.put(
                "truth/plates.json",
                &pretty(&j)?,
                "json",
                "plate poses and planes, board corners (mm and pixels)",
            )?;
            if spec.reference.mode == ReferenceMode::Render {
                reference(&mut out, None)?;
            }
            // The calibration names patterns.toml for the reference; the plates' V set is it.
            pattern_file(
                &mut out,
                "patterns.toml",
                &scene.patterns,
                scene.pattern_bits,
                None,
            )?;
        }
    }

    // Scene, calibration, manifest.
    let scene_toml = spec.to_toml()?;
    out.put(
        "scene.toml",
        scene_toml.as_bytes(),
        "fringe3d scene TOML (docs/render.md)",
        "the resolved scene; `fringe3d render --scene scene.toml` re-renders this dataset",
    )?;
    let (map, pat, digest) = match &reference_files {
        Some((m, p)) => {
            // The reference was decoded with (and patterns.toml describes) the scene's set.
            let d = crate::io::calibration::pattern_digest(&scene.patterns)
                .map_err(|m| RenderError::Decode(format!("reference pattern set: {m}")))?;
            (Some(PathBuf::from(m)), Some(PathBuf::from(p)), Some(d))
        }
        None => (None, None, None),
    };
    let mut cal = rig.calibration(map, pat, digest);
    scene.record_true_light(&mut cal);
    cal.save(&out.dir.join("calibration.toml"))?;
    out.adopt(
        "calibration.toml",
        "fringe3d calibration TOML (docs/formats.md)",
        "the true calibration of the rig",
    )?;

    let total: u64 = out.files.iter().map(|f| f.bytes).sum();
    let n_files = out.files.len();
    let mut files = out.files.clone();
    files.sort_by(|a, b| a.path.cmp(&b.path));
    let manifest = json!({
        "format": MANIFEST_FORMAT,
        "version": MANIFEST_VERSION,
        "generator": format!("fringe3d {}", env!("CARGO_PKG_VERSION")),
        "kind": spec.kind,
        "name": spec.name,
        "seed": spec.seed,
        "units": {"length": "mm", "angle": "rad", "pixel": "pixel centres at integer coordinates"},
        "frames": "camera frame (OpenCV: x right, y down, z forward); projector: X_cam = R*X_proj + T",
        "camera": {"bits": spec.camera.bits, "noise_sigma": spec.camera.noise, "gains": gains},
        "rig": rig,
        "scene": spec,
        "extra": extra,
        "files": files,
    });
    out.put(
        "manifest.json",
        &pretty(&manifest)?,
        "json",
        "this manifest",
    )?;
    let path = out.dir.commit()?;
    Ok(Summary {
        path,
        kind: spec.kind,
        images,
        files: n_files,
        bytes: total,
    })
}

fn pretty(v: &serde_json::Value) -> Result<Vec<u8>, RenderError> {
    let mut s =
        serde_json::to_vec_pretty(v).map_err(|e| file_err(Path::new("manifest.json"), e))?;
    s.push(b'\n');
    Ok(s)
}

fn scene_err(scene: &Scene, m: impl Into<String>) -> RenderError {
    RenderError::Scene(super::scene::SceneError::Invalid {
        scene: scene.spec.name.clone(),
        message: m.into(),
    })
}

/// Board images lit by ambient light only are exposed for the ambient light.
fn board_photometry(scene: &Scene, lit: bool) -> super::Photometry {
    let mut p = scene.spec.photometry.photometry();
    p.auto_with_projector = lit;
    p
}

fn board_sensor(scene: &Scene, ss: u32) -> Sensor {
    let mut s = scene.spec.camera.sensor();
    s.supersample = ss;
    s.edge_supersample = s.edge_supersample.max(12).max(ss);
    s
}
