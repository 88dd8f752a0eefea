//! Writing a reference (paper §6's Φ_R and its plane) into a calibration: the phase map and the
//! pattern set beside it, then the calibration with its `[reference]`. Shared by the captured
//! ([`super::files::calibrate_reference_files`]) and the virtual reference
//! ([`super::virtual_reference`]).

use std::io::Write;
use std::path::{Path, PathBuf};

use super::{CalibError, input};
use crate::io::atomic::AtomicFile;
use crate::io::calibration::{Calibration, ReferencePlane};
use crate::io::image::encode_tiff_f32;
use crate::io::pattern_file::PatternSetFile;

/// Write a reference: the phase map `map_name` (float TIFF, `width × height` including the
/// `margin` past the image) and `reference_patterns.toml` beside `out`, then `out`, the
/// calibration with its `[reference]` (`plane` = point, normal). Returns the calibration written
/// and the map's path. Shared by the captured and the virtual reference. Nothing is replaced
/// unless all three files could be written: each goes to a temporary file first, and the renames
/// come last.
pub fn write_reference(
    calibration: &Calibration,
    out: &Path,
    mut pattern_file: PatternSetFile,
    map_name: &str,
    (width, height, map): (u32, u32, &[f32]),
    (point, normal): ([f64; 3], [f64; 3]),
    margin: fringe3d_core::reconstruct::Margin,
) -> Result<(Calibration, PathBuf), CalibError> {
    let digest =
        crate::io::calibration::pattern_digest(&pattern_file.to_pattern_set()?).map_err(|m| {
            CalibError::Input {
                what: "the reference's pattern set".into(),
                message: m,
            }
        })?;
    let dir = out
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    std::fs::create_dir_all(dir).map_err(|e| input(dir, format!("cannot create: {e}")))?;
    let map_path = dir.join(map_name);
    pattern_file.images = None;
    let pat_name = "reference_patterns.toml";
    let pat_path = dir.join(pat_name);
    let mut cal = calibration.clone();
    cal.reference = Some(ReferencePlane {
        point,
        normal,
        phase_map: PathBuf::from(map_name),
        pattern_set: Some(PathBuf::from(pat_name)),
        pattern_digest: Some(digest),
        margin: (margin != fringe3d_core::reconstruct::Margin::ZERO).then(|| margin.to_array()),
    });
    // All three files are encoded and written to temporary files before any is renamed over
    // its target: a failure (a bad value, a full disk) leaves the old calibration and its map
    // as they were. Only the renames, in order map, patterns, calibration, come after.
    let tiff = encode_tiff_f32(&map_path, width, height, map)?;
    let patterns = pattern_file.to_text(&pat_path)?;
    let toml = cal.to_text(out)?;
    let mut staged = Vec::new();
    for (path, bytes) in [
        (&map_path, tiff.as_slice()),
        (&pat_path, patterns.as_bytes()),
        (&out.to_path_buf(), toml.as_bytes()),
    ] {
        let mut f = AtomicFile::create(path).map_err(|e| input(path, e.to_string()))?;
        f.write_all(bytes)
            .and_then(|_| f.flush())
            .map_err(|e| input(path, format!("cannot write: {e}")))?;
        staged.push(f);
    }
    for f in staged {
        let path = f.target().to_path_buf();
        f.commit().map_err(|e| input(&path, e.to_string()))?;
    }
    Ok((cal, map_path))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::rig::default_rig;
    use fringe3d_core::pattern::{Output, PatternSet};
    use fringe3d_core::phase_function::{Axis, PhaseFunction};

    /// A calibration that cannot be written (its path is a folder) leaves the old map and
    /// pattern set beside it as they were, and no temporary file behind.
    #[test]
    fn nothing_is_replaced_when_one_file_fails() {
        let dir = std::env::temp_dir().join(format!("fringe3d-refwrite-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(dir.join("calibration.toml")).unwrap();
        std::fs::write(dir.join("reference_phase.tif"), b"old map").unwrap();
        std::fs::write(dir.join("reference_patterns.toml"), b"old set").unwrap();
        let rig = default_rig().with_camera_size(16, 8);
        let cal = rig.calibration(None, None, None);
        let out = Output {
            width: 912,
            height: 1140,
            i_min: 0.0,
            i_max: 255.0,
        };
        let f = PhaseFunction::centered(Axis::Xi, 912, 5.0).unwrap();
        let set = PatternSet::paper_eight(f, 8.0, out).unwrap();
        let r = write_reference(
            &cal,
            &dir.join("calibration.toml"),
            PatternSetFile::from_pattern_set(&set, 8),
            "reference_phase.tif",
            (16, 8, &[1.0f32; 128]),
            ([0.0, 0.0, 700.0], [0.0, 0.0, -1.0]),
            fringe3d_core::reconstruct::Margin::ZERO,
        );
        assert!(r.is_err());
        assert_eq!(
            std::fs::read(dir.join("reference_phase.tif")).unwrap(),
            b"old map"
        );
        assert_eq!(
            std::fs::read(dir.join("reference_patterns.toml")).unwrap(),
            b"old set"
        );
        let left: Vec<_> = std::fs::read_dir(&dir)
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(left.len(), 3, "{left:?}");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
