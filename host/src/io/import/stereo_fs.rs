//! Full calibrations in `cv::FileStorage` files (YAML, XML, JSON): OpenCV stereo files, SLStudio's
//! `calibration.xml` and SLMaster's `caliInfo.yml`. All three state the projector's pose as
//! OpenCV's `stereoCalibrate` does, `x_p = R·x_c + T` (a point's coordinates in the camera frame
//! `x_c` to the projector frame `x_p`); [`super::rig`] turns that into fringe3d's pose.

use super::filestorage::{Node, matrix_values};
use super::rig::{Lens, ParsedRig, RigFormat, StereoPose};

/// What a `cv::FileStorage` document holds, judged by its keys.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) enum FsKind {
    /// A full calibration in one format.
    Rig(RigFormat),
    /// Keys of more than one full-calibration format.
    Ambiguous(Vec<RigFormat>),
    /// A camera alone (`camera_matrix`, `cameraMatrix` or `K`).
    CameraOnly,
    /// Nothing known.
    Unknown,
}

/// The OpenCV stereo spellings: camera 1 = the camera, camera 2 = the projector.
const OPENCV_SETS: [[&str; 4]; 2] = [
    ["M1", "D1", "M2", "D2"],
    [
        "cameraMatrix1",
        "distCoeffs1",
        "cameraMatrix2",
        "distCoeffs2",
    ],
];
/// Matrix and distortion keys inside a nested `camera:` / `projector:` map.
const NESTED_K: [&str; 3] = ["camera_matrix", "cameraMatrix", "K"];
const NESTED_D: [&str; 4] = ["distortion_coefficients", "distCoeffs", "dist_coeffs", "D"];

fn has(root: &Node, k: &str) -> bool {
    root.get(k).is_some()
}

fn is_map(n: Option<&Node>) -> bool {
    matches!(n, Some(Node::Map(_)))
}

/// Classify a parsed document.
pub(crate) fn classify(root: &Node) -> FsKind {
    let mut found = Vec::new();
    let nested = is_map(root.get("camera")) && is_map(root.get("projector"));
    if OPENCV_SETS
        .iter()
        .any(|s| has(root, s[0]) && has(root, s[2]))
        || nested
    {
        found.push(RigFormat::OpenCv);
    }
    if has(root, "Kc") && has(root, "Kp") {
        found.push(RigFormat::SlStudio);
    }
    if ["M4", "Rlp", "Tlp", "Rlr", "Tlr"]
        .iter()
        .any(|k| has(root, k))
    {
        found.push(RigFormat::SlMaster);
    }
    // An SLMaster two-camera file also has M1/M2: it is SLMaster's when it has no R/T.
    if found == [RigFormat::OpenCv, RigFormat::SlMaster] && !has(root, "R") && !has(root, "T") {
        found.remove(0);
    }
    match found.len() {
        1 => FsKind::Rig(found[0]),
        0 if NESTED_K.iter().any(|k| has(root, k)) => FsKind::CameraOnly,
        0 => FsKind::Unknown,
        _ => FsKind::Ambiguous(found),
    }
}

/// The values of matrix `key` under `node` (`what` prefixes the key in messages).
fn values(node: &Node, key: &str, what: &str) -> Result<Option<Vec<f64>>, String> {
    match node.get(key) {
        None => Ok(None),
        Some(n) => matrix_values(n)
            .map(Some)
            .map_err(|m| format!("{what}{key}: {m}")),
    }
}

fn need(node: &Node, key: &str, what: &str, role: &str) -> Result<Vec<f64>, String> {
    values(node, key, what)?.ok_or_else(|| format!("no {what}{key} (the {role})"))
}

/// A positive whole number stated by `key` (a scalar or a one-element matrix).
fn count(node: &Node, key: &str) -> Result<Option<u32>, String> {
    let Some(v) = values(node, key, "")? else {
        return Ok(None);
    };
    match v[..] {
        [x] if x >= 1.0 && x <= f64::from(u32::MAX) && x.fract() == 0.0 => Ok(Some(x as u32)),
        _ => Err(format!("{key} must be a positive whole number, got {v:?}")),
    }
}

/// A size stated by a pair of scalar keys, or by one `[w, h]` matrix key.
fn size(
    node: &Node,
    pairs: &[(&str, &str)],
    both: &[&str],
) -> Result<Option<((u32, u32), String)>, String> {
    for (wk, hk) in pairs {
        match (count(node, wk)?, count(node, hk)?) {
            (Some(w), Some(h)) => return Ok(Some(((w, h), format!("{wk}/{hk}")))),
            (None, None) => {}
            _ => return Err(format!("{wk} and {hk} must be given together")),
        }
    }
    for k in both {
        if let Some(v) = values(node, k, "")? {
            let ok = |x: f64| x >= 1.0 && x <= f64::from(u32::MAX) && x.fract() == 0.0;
            return match v[..] {
                [w, h] if ok(w) && ok(h) => Ok(Some(((w as u32, h as u32), k.to_string()))),
                _ => Err(format!(
                    "{k} must be two positive whole numbers [width, height], got {v:?}"
                )),
            };
        }
    }
    Ok(None)
}

fn three(v: Option<Vec<f64>>, key: &str) -> Result<Option<[f64; 3]>, String> {
    match v {
        None => Ok(None),
        Some(v) => match v[..] {
            [a, b, c] => Ok(Some([a, b, c])),
            _ => Err(format!("{key} has {} values, expected 3", v.len())),
        },
    }
}

/// fringe3d's own keys (written by the exporter): the exact skews, projector centre and depth
/// range, which the OpenCV matrices alone carry only up to rounding.
struct Extras {
    skew: Option<(f64, f64)>,
    centre: Option<[f64; 3]>,
    depth: Option<[f64; 2]>,
}

fn extras(root: &Node) -> Result<Extras, String> {
    let skew = match values(root, "fringe3d_skew", "")? {
        None => None,
        Some(v) => match v[..] {
            [a, b] => Some((a, b)),
            _ => return Err(format!("fringe3d_skew has {} values, expected 2", v.len())),
        },
    };
    let depth = match values(root, "fringe3d_depth_range", "")? {
        None => None,
        Some(v) => match v[..] {
            [a, b] => Some([a, b]),
            _ => {
                return Err(format!(
                    "fringe3d_depth_range has {} values, expected 2",
                    v.len()
                ));
            }
        },
    };
    let centre = three(
        values(root, "fringe3d_projector_centre", "")?,
        "fringe3d_projector_centre",
    )?;
    Ok(Extras {
        skew,
        centre,
        depth,
    })
}

const CAMERA_SIZE_KEYS: &str = "image_width/image_height, image_size, imageSize";
const PROJECTOR_SIZE_KEYS: &str = "projector_width/projector_height, projector_size, projectorSize";

/// An OpenCV stereo file: `M1 D1 M2 D2 R T`, `cameraMatrix1 distCoeffs1 cameraMatrix2
/// distCoeffs2 R T`, or nested `camera:` / `projector:` maps with `camera_matrix` and
/// `distortion_coefficients` (and `R`, `T` at the top). Camera 1 is the camera, camera 2 the
/// projector, `x_2 = R·x_1 + T` (OpenCV's `stereoCalibrate`).
pub(crate) fn parse_opencv(root: &Node) -> Result<ParsedRig, String> {
    let ex = extras(root)?;
    let (camera, projector) = if let Some(set) = OPENCV_SETS.iter().find(|s| has(root, s[0])) {
        let [k1, d1, k2, d2] = *set;
        let cam_size = size(
            root,
            &[("image_width", "image_height")],
            &["image_size", "imageSize"],
        )?;
        let proj_size = size(
            root,
            &[("projector_width", "projector_height")],
            &["projector_size", "projectorSize"],
        )?;
        (
            Lens {
                role: "camera",
                kname: k1.into(),
                k: need(root, k1, "", "camera matrix, camera 1")?,
                dname: d1.into(),
                d: need(root, d1, "", "camera's distortion, camera 1")?,
                size: cam_size,
                skew: ex.skew.map(|s| s.0),
                size_keys: CAMERA_SIZE_KEYS,
            },
            Lens {
                role: "projector",
                kname: k2.into(),
                k: need(root, k2, "", "projector matrix, camera 2")?,
                dname: d2.into(),
                d: need(root, d2, "", "projector's distortion, camera 2")?,
                size: proj_size,
                skew: ex.skew.map(|s| s.1),
                size_keys: PROJECTOR_SIZE_KEYS,
            },
        )
    } else {
        let lens = |name: &'static str, role: &'static str, skew| -> Result<Lens, String> {
            let n = root.get(name).ok_or_else(|| {
                format!("no `{name}` map and no M1/M2 or cameraMatrix1/cameraMatrix2")
            })?;
            let what = format!("{name}.");
            let k = NESTED_K
                .iter()
                .find(|k| has(n, k))
                .ok_or_else(|| format!("no {name}.camera_matrix (the {role} matrix)"))?;
            let d = NESTED_D.iter().find(|k| has(n, k)).ok_or_else(|| {
                format!("no {name}.distortion_coefficients (the {role}'s distortion)")
            })?;
            Ok(Lens {
                role,
                kname: format!("{what}{k}"),
                k: need(n, k, &what, role)?,
                dname: format!("{what}{d}"),
                d: need(n, d, &what, role)?,
                size: size(
                    n,
                    &[("image_width", "image_height")],
                    &["image_size", "imageSize"],
                )?
                .map(|(s, k)| (s, format!("{what}{k}"))),
                skew,
                size_keys: if role == "camera" {
                    "camera.image_width/image_height"
                } else {
                    "projector.image_width/image_height"
                },
            })
        };
        (
            lens("camera", "camera", ex.skew.map(|s| s.0))?,
            lens("projector", "projector", ex.skew.map(|s| s.1))?,
        )
    };
    Ok(ParsedRig {
        format: RigFormat::OpenCv,
        camera,
        projector,
        pose: StereoPose {
            rname: "R".into(),
            r: need(root, "R", "", "rotation, camera 1 to camera 2")?,
            tname: "T".into(),
            t: need(root, "T", "", "translation, camera 1 to camera 2")?,
            centre: ex.centre,
        },
        depth_range: ex.depth,
    })
}

/// SLStudio's `calibration.xml` (`CalibrationData::saveXML`): `Kc`, `kc` (camera), `Kp`, `kp`
/// (projector), `Rp`, `Tp` from `cv::stereoCalibrate(Q, qc, qp, Kc, kc, Kp, kp, …, Rp, Tp, …)`,
/// so `x_p = Rp·x_c + Tp`; sizes `frameWidth`/`frameHeight` and `screenResX`/`screenResY`.
pub(crate) fn parse_slstudio(root: &Node) -> Result<ParsedRig, String> {
    Ok(ParsedRig {
        format: RigFormat::SlStudio,
        camera: Lens {
            role: "camera",
            kname: "Kc".into(),
            k: need(root, "Kc", "", "camera matrix")?,
            dname: "kc".into(),
            d: need(root, "kc", "", "camera's distortion")?,
            size: size(root, &[("frameWidth", "frameHeight")], &[])?,
            skew: None,
            size_keys: "frameWidth/frameHeight",
        },
        projector: Lens {
            role: "projector",
            kname: "Kp".into(),
            k: need(root, "Kp", "", "projector matrix")?,
            dname: "kp".into(),
            d: need(root, "kp", "", "projector's distortion")?,
            size: size(root, &[("screenResX", "screenResY")], &[])?,
            skew: None,
            size_keys: "screenResX/screenResY",
        },
        pose: StereoPose {
            rname: "Rp".into(),
            r: need(root, "Rp", "", "rotation, camera to projector")?,
            tname: "Tp".into(),
            t: need(root, "Tp", "", "translation, camera to projector")?,
            centre: None,
        },
        depth_range: None,
    })
}

/// SLMaster's `caliInfo.yml` (`slmaster::cameras::CaliInfo`): the left camera `M1`, `D1`, its
/// size `S` = [width, height], the projector `M4`, `D4` and `Rlp`, `Tlp` from
/// `cv::solvePnPRansac(camPoints, projectorPixelPoints, M4, D4, Rlp, Tlp)` — points in the left
/// camera's frame to the projector's, `x_p = Rlp·x_c + Tlp`; `Rlp` may be a 3x3 matrix or (older
/// versions) the 3x1 Rodrigues vector. The projector's size is not in the file.
pub(crate) fn parse_slmaster(root: &Node) -> Result<ParsedRig, String> {
    if !has(root, "M4") && (has(root, "Rlr") || has(root, "M2")) {
        return Err(
            "an SLMaster two-camera calibration (M2, Rlr, Tlr): it holds no projector (M4, D4, Rlp, Tlp)"
                .into(),
        );
    }
    Ok(ParsedRig {
        format: RigFormat::SlMaster,
        camera: Lens {
            role: "camera",
            kname: "M1".into(),
            k: need(root, "M1", "", "left camera matrix")?,
            dname: "D1".into(),
            d: need(root, "D1", "", "left camera's distortion")?,
            size: size(root, &[], &["S"])?,
            skew: None,
            size_keys: "S",
        },
        projector: Lens {
            role: "projector",
            kname: "M4".into(),
            k: need(root, "M4", "", "projector matrix")?,
            dname: "D4".into(),
            d: need(root, "D4", "", "projector's distortion")?,
            size: None,
            skew: None,
            size_keys: "nothing: SLMaster does not store it",
        },
        pose: StereoPose {
            rname: "Rlp".into(),
            r: need(root, "Rlp", "", "rotation, left camera to projector")?,
            tname: "Tlp".into(),
            t: need(root, "Tlp", "", "translation, left camera to projector")?,
            centre: None,
        },
        depth_range: None,
    })
}

/// Parse `root` as `format`.
pub(crate) fn parse_as(root: &Node, format: RigFormat) -> Result<ParsedRig, String> {
    match format {
        RigFormat::OpenCv => parse_opencv(root),
        RigFormat::SlStudio => parse_slstudio(root),
        RigFormat::SlMaster => parse_slmaster(root),
        RigFormat::Bouguet => Err(
            "Bouguet's results are a Matlab script (Calib_Results_stereo.m), not a FileStorage file"
                .into(),
        ),
    }
}
