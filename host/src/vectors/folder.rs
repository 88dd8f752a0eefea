//! A vectors folder on disk: written atomically with the project-format files and the manifest,
//! read back, checked against the manifest's digests, compared file by file.

use super::generate::generate_from;
use super::pipeline::{Inputs, inputs};
use super::{
    DecodeStage, Dtype, FORMAT, GoldenVectors, MANIFEST, PointStage, VectorFile, VectorOptions,
    VectorsError, f32_bytes, file_err, sha256_hex,
};
use crate::io::atomic::AtomicDir;
use crate::io::pattern_file::PatternSetFile;
use std::path::{Path, PathBuf};

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

/// Generate the vectors of `opts` and write them to `dir` ([`generate`](super::generate) then [`write()`]).
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
/// another driver's outputs by digest). Paths as in [`generate`](super::generate).
pub fn stage_files(d: &DecodeStage, p: Option<&PointStage>) -> Vec<(String, Vec<u8>)> {
    let mut v = Vec::new();
    for (l, (wr, m)) in d.wrapped.iter().zip(&d.modulation_level).enumerate() {
        // (A Gray-code level has no wrapped phase, and no file.)
        if wr.is_empty() {
            continue;
        }
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
