//! Bouguet's Camera Calibration Toolbox for Matlab: its parameters ([`import_bouguet`]) and its
//! results script `Calib_Results.m` ([`import_bouguet_file`]).

use std::path::Path;

use super::matlab::{matlab_assignments, matlab_numbers};
use crate::io::camera_check::validate_camera;
use crate::io::error::{FormatError, read_text};
use fringe3d_core::params::CameraParams;

/// A camera model from Bouguet's Camera Calibration Toolbox for Matlab
/// (`Calib_Results.m` / `.mat` variables `fc`, `cc`, `alpha_c`, `kc`).
///
/// The toolbox's conventions (its documentation, "Description of the calibration parameters",
/// and its code) map onto ours without change:
///
/// - pixel coordinates: `[0; 0]` is the centre of the upper-left pixel and `[nx−1; ny−1]` that of
///   the lower-right one (the toolbox initialises `cc = [nx; ny]/2 − 0.5`), which is our
///   convention — **no** 1-based correction is applied. (Coordinates you read yourself with
///   Matlab's 1-based indexing are different: subtract 1 from those, not from `cc`.)
/// - `KK = [fc(1) alpha_c*fc(1) cc(1); 0 fc(2) cc(2); 0 0 1]`: `alpha_c` is exactly the α of
///   paper eq 4 (the paper's authors used this toolbox, its ref. 14).
/// - `kc = [k1; k2; p1; p2; k3]`: radial `1 + kc(1)r² + kc(2)r⁴ + kc(5)r⁶`, tangential
///   `[2kc(3)xy + kc(4)(r² + 2x²); kc(3)(r² + 2y²) + 2kc(4)xy]` — OpenCV's order.
///
/// The model is not validated here; call [`validate_camera`].
pub fn import_bouguet(
    fc: [f64; 2],
    cc: [f64; 2],
    alpha_c: f64,
    kc: [f64; 5],
    width: u32,
    height: u32,
) -> CameraParams {
    CameraParams {
        width,
        height,
        fx: fc[0],
        fy: fc[1],
        skew: alpha_c,
        cx: cc[0],
        cy: cc[1],
        distortion: kc.into(),
    }
}

/// A camera model from a Bouguet toolbox results script (`Calib_Results.m`: lines such as
/// `fc = [ 657.64 ; 658.04 ];`, `alpha_c = 0.0;`, `kc = [ ... ];`, `nx = 640;`), converted as in
/// [`import_bouguet`]. `kc` may have 4 (older toolbox versions: `k3 = 0`) or 5 elements. `nx`/`ny`,
/// if present, override `width`/`height`. Other statements (`KK = [...]`, extrinsics, uncertainties)
/// are ignored. The result is validated.
pub fn import_bouguet_file(
    path: &Path,
    width: u32,
    height: u32,
) -> Result<CameraParams, FormatError> {
    let text = read_text(path)?;
    let vars = matlab_assignments(&text);
    let get = |name: &str| -> Result<Option<Vec<f64>>, FormatError> {
        match vars.iter().rev().find(|(n, _, _)| n == name) {
            None => Ok(None),
            Some((_, line, expr)) => matlab_numbers(expr)
                .map(Some)
                .map_err(|m| FormatError::parse(path, format!("line {line}: `{name}`: {m}"))),
        }
    };
    let need = |name: &str, lens: &[usize]| -> Result<Vec<f64>, FormatError> {
        let v = get(name)?.ok_or_else(|| {
            FormatError::parse(path, format!("no `{name} = ...;` assignment found"))
        })?;
        if !lens.contains(&v.len()) {
            return Err(FormatError::invalid(
                path,
                format!(
                    "`{name}` has {} values, expected {}",
                    v.len(),
                    alternatives(lens)
                ),
            ));
        }
        if let Some(x) = v.iter().find(|x| !x.is_finite()) {
            return Err(FormatError::invalid(path, format!("`{name}` contains {x}")));
        }
        Ok(v)
    };
    let fc = need("fc", &[2])?;
    let cc = need("cc", &[2])?;
    let alpha = match get("alpha_c")? {
        None => 0.0,
        Some(v) if v.len() == 1 && v[0].is_finite() => v[0],
        Some(v) => {
            return Err(FormatError::invalid(
                path,
                format!("`alpha_c` must be one finite number, got {v:?}"),
            ));
        }
    };
    let kc = need("kc", &[4, 5])?;
    let mut k = [0.0; 5];
    k[..kc.len()].copy_from_slice(&kc);
    let size = |name: &str, default: u32| -> Result<u32, FormatError> {
        match get(name)? {
            None => Ok(default),
            Some(v)
                if v.len() == 1
                    && v[0] >= 1.0
                    && v[0] <= f64::from(u32::MAX)
                    && v[0].fract() == 0.0 =>
            {
                Ok(v[0] as u32)
            }
            Some(v) => Err(FormatError::invalid(
                path,
                format!("`{name}` must be a positive integer, got {v:?}"),
            )),
        }
    };
    let cam = import_bouguet(
        [fc[0], fc[1]],
        [cc[0], cc[1]],
        alpha,
        k,
        size("nx", width)?,
        size("ny", height)?,
    );
    validate_camera(&cam).map_err(|m| FormatError::invalid(path, m))?;
    Ok(cam)
}

fn alternatives(lens: &[usize]) -> String {
    let v: Vec<String> = lens.iter().map(|n| n.to_string()).collect();
    v.join(" or ")
}
