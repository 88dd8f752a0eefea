//! Bouguet's stereo results script `Calib_Results_stereo.m` (the Camera Calibration Toolbox for
//! Matlab's stereo module): the left camera is the camera, the right one the projector.

use super::matlab::{matlab_assignments, matlab_numbers};
use super::rig::{Lens, ParsedRig, RigFormat, StereoPose};

/// Whether a Matlab script looks like a stereo results script.
pub(crate) fn is_bouguet_stereo(text: &str) -> bool {
    matlab_assignments(text)
        .iter()
        .any(|(n, _, _)| n == "fc_left" || n == "KK_left")
}

/// Parse `Calib_Results_stereo.m`: `fc_left`, `cc_left`, `alpha_c_left` (default 0), `kc_left`
/// (4 or 5 values) and the same with `_right`; the pose `om` (Rodrigues vector) or `R`, and `T`,
/// which the toolbox defines by `XR = R·XL + T` (`R = rodrigues(om)`; see its
/// `stereo_triangulation.m`);
/// sizes `nx`, `ny` (the left camera's) and `nx_right`, `ny_right` if present. `KK` matrices are
/// ignored: `fc`, `cc`, `alpha_c` are the toolbox's parameters (see [`super::import_bouguet`]).
pub(crate) fn parse_bouguet_stereo(text: &str) -> Result<ParsedRig, String> {
    let vars = matlab_assignments(text);
    let get = |name: &str| -> Result<Option<Vec<f64>>, String> {
        match vars.iter().rev().find(|(n, _, _)| n == name) {
            None => Ok(None),
            Some((_, line, expr)) => matlab_numbers(expr)
                .map(Some)
                .map_err(|m| format!("line {line}: `{name}`: {m}")),
        }
    };
    let need = |name: &str, len: usize| -> Result<Vec<f64>, String> {
        let v = get(name)?.ok_or_else(|| format!("no `{name} = ...;` assignment found"))?;
        if v.len() != len {
            return Err(format!("`{name}` has {} values, expected {len}", v.len()));
        }
        Ok(v)
    };
    let count = |name: &str| -> Result<Option<u32>, String> {
        match get(name)? {
            None => Ok(None),
            Some(v) => match v[..] {
                [x] if x >= 1.0 && x <= f64::from(u32::MAX) && x.fract() == 0.0 => {
                    Ok(Some(x as u32))
                }
                _ => Err(format!("`{name}` must be a positive integer, got {v:?}")),
            },
        }
    };
    let size = |w: &str, h: &str| -> Result<Option<((u32, u32), String)>, String> {
        match (count(w)?, count(h)?) {
            (Some(a), Some(b)) => Ok(Some(((a, b), format!("{w}/{h}")))),
            (None, None) => Ok(None),
            _ => Err(format!("`{w}` and `{h}` must be given together")),
        }
    };
    let lens =
        |side: &str, role: &'static str, size_keys: &'static str, sz| -> Result<Lens, String> {
            let fc = need(&format!("fc_{side}"), 2)?;
            let cc = need(&format!("cc_{side}"), 2)?;
            let alpha = match get(&format!("alpha_c_{side}"))? {
                None => 0.0,
                Some(v) if v.len() == 1 => v[0],
                Some(v) => {
                    return Err(format!(
                        "`alpha_c_{side}` must be one number, got {} values",
                        v.len()
                    ));
                }
            };
            let kname = format!("kc_{side}");
            let kc = get(&kname)?.ok_or_else(|| format!("no `{kname} = ...;` assignment found"))?;
            if !(kc.len() == 4 || kc.len() == 5) {
                return Err(format!(
                    "`{kname}` has {} values, expected 4 or 5",
                    kc.len()
                ));
            }
            Ok(Lens {
                role,
                kname: format!("fc_{side}/cc_{side}/alpha_c_{side}"),
                // KK as the toolbox builds it: [fc(1) alpha_c*fc(1) cc(1); 0 fc(2) cc(2); 0 0 1].
                k: vec![
                    fc[0],
                    alpha * fc[0],
                    cc[0],
                    0.0,
                    fc[1],
                    cc[1],
                    0.0,
                    0.0,
                    1.0,
                ],
                dname: kname,
                d: kc,
                size: sz,
                // The toolbox states α itself: exact, no division by fc.
                skew: Some(alpha),
                size_keys,
            })
        };
    let camera = lens("left", "camera", "nx/ny", size("nx", "ny")?)?;
    let projector = lens(
        "right",
        "projector",
        "nx_right/ny_right",
        size("nx_right", "ny_right")?,
    )?;
    let (rname, r) = match get("R")? {
        Some(r) => ("R", r),
        None => ("om", need("om", 3)?),
    };
    Ok(ParsedRig {
        format: RigFormat::Bouguet,
        camera,
        projector,
        pose: StereoPose {
            rname: rname.into(),
            r,
            tname: "T".into(),
            t: need("T", 3)?,
            centre: None,
        },
        depth_range: None,
    })
}
