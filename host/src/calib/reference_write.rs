//! Writing a reference (paper §6's Φ_R and its plane) into a calibration: the phase map and the
//! pattern set beside it, then the calibration with its `[reference]`. Shared by the captured
//! ([`super::files::calibrate_reference_files`]) and the virtual reference
//! ([`super::virtual_reference`]).

use std::path::{Path, PathBuf};

use super::{CalibError, input};
use crate::io::calibration::{Calibration, ReferencePlane};
use crate::io::image::write_tiff_f32;
use crate::io::pattern_file::PatternSetFile;

/// Write a reference: the phase map `map_name` (float TIFF, `width × height` including the
/// `margin` past the image) and `reference_patterns.toml` beside `out`, then `out`, the
/// calibration with its `[reference]` (`plane` = point, normal). Returns the calibration written
/// and the map's path. Shared by the captured and the virtual reference.
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
    write_tiff_f32(&map_path, width, height, map)?;
    pattern_file.images = None;
    let pat_name = "reference_patterns.toml";
    pattern_file.save(&dir.join(pat_name))?;
    let mut cal = calibration.clone();
    cal.reference = Some(ReferencePlane {
        point,
        normal,
        phase_map: PathBuf::from(map_name),
        pattern_set: Some(PathBuf::from(pat_name)),
        pattern_digest: Some(digest),
        margin: (margin != fringe3d_core::reconstruct::Margin::ZERO).then(|| margin.to_array()),
    });
    cal.save(out)?;
    Ok((cal, map_path))
}
