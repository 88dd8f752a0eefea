//! What every full-calibration importer shares: a lens as a file states it (`Lens`), the
//! stereo pose convention `x_p = R·x_c + T` turned into fringe3d's projector pose, and the
//! finished, validated [`ImportedRig`].

use std::path::Path;

use crate::io::camera_check::check_camera;
use crate::io::error::FormatError;
use fringe3d_core::params::{CameraParams, ProjectorParams};

/// The foreign formats a full calibration (camera + projector + pose) is imported from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RigFormat {
    /// OpenCV `cv::FileStorage` stereo file (`M1 D1 M2 D2 R T` and the other spellings).
    OpenCv,
    /// SLStudio's `calibration.xml` (`Kc kc Kp kp Rp Tp`).
    SlStudio,
    /// SLMaster's `caliInfo.yml` (`M1 D1 M4 D4 Rlp Tlp`).
    SlMaster,
    /// Bouguet's stereo results script `Calib_Results_stereo.m`.
    Bouguet,
}

impl RigFormat {
    /// The name used on the command line (`--format`).
    pub fn name(self) -> &'static str {
        match self {
            RigFormat::OpenCv => "opencv",
            RigFormat::SlStudio => "slstudio",
            RigFormat::SlMaster => "slmaster",
            RigFormat::Bouguet => "bouguet",
        }
    }

    /// Every format, in the order of `--format`'s list.
    pub const ALL: [RigFormat; 4] = [
        RigFormat::OpenCv,
        RigFormat::SlStudio,
        RigFormat::SlMaster,
        RigFormat::Bouguet,
    ];

    /// The format named `s` (as [`RigFormat::name`]).
    pub fn parse(s: &str) -> Result<RigFormat, String> {
        let t = s.trim().to_ascii_lowercase();
        RigFormat::ALL
            .into_iter()
            .find(|f| f.name() == t)
            .ok_or_else(|| {
                format!(
                    "unknown calibration format `{s}`: use opencv, slstudio, slmaster or bouguet"
                )
            })
    }
}

/// Image sizes the caller knows (command-line options), for files that do not state them.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RigSizes {
    /// The camera's image size (width, height), px.
    pub camera: Option<(u32, u32)>,
    /// The projector's image (DMD) size, px.
    pub projector: Option<(u32, u32)>,
}

/// One lens as a file states it: the 3×3 matrix, the distortion vector, the size if stated,
/// with the keys they came from (for messages).
#[derive(Clone, Debug)]
pub(crate) struct Lens {
    /// What this lens is, for messages ("camera", "projector").
    pub role: &'static str,
    /// The key of the matrix, e.g. `M1`.
    pub kname: String,
    /// `[fx s cx; 0 fy cy; 0 0 1]`, row-major.
    pub k: Vec<f64>,
    /// The key of the distortion vector.
    pub dname: String,
    /// The distortion coefficients as written.
    pub d: Vec<f64>,
    /// The image size, if the file states it, and the key(s) it came from.
    pub size: Option<((u32, u32), String)>,
    /// fringe3d's exact skew α (written by the exporter), if present.
    pub skew: Option<f64>,
    /// The keys that would have held the size, for the message when none did.
    pub size_keys: &'static str,
}

/// `x_p = R·x_c + T` as a file states it (OpenCV's `stereoCalibrate` convention).
#[derive(Clone, Debug)]
pub(crate) struct StereoPose {
    /// The key of R.
    pub rname: String,
    /// R: 9 values (row-major) or a 3-value Rodrigues vector.
    pub r: Vec<f64>,
    /// The key of T.
    pub tname: String,
    /// T, 3 values (length units of the file: mm expected).
    pub t: Vec<f64>,
    /// fringe3d's exact projector centre (written by the exporter), if present.
    pub centre: Option<[f64; 3]>,
}

/// Everything a foreign full-calibration file holds, before sizes are settled.
#[derive(Clone, Debug)]
pub(crate) struct ParsedRig {
    pub format: RigFormat,
    pub camera: Lens,
    pub projector: Lens,
    pub pose: StereoPose,
    pub depth_range: Option<[f64; 2]>,
}

/// A full calibration imported from another tool: camera, projector (intrinsics, distortion and
/// pose in fringe3d's convention `X_cam = R·X_proj + T`, `T` = the projector centre P) and, when
/// the file records it (fringe3d's own export), the depth range.
#[derive(Clone, Debug, PartialEq)]
pub struct ImportedRig {
    /// The format read.
    pub format: RigFormat,
    /// The camera (camera 1 of a stereo file).
    pub camera: CameraParams,
    /// The projector (camera 2), its pose relative to the camera.
    pub projector: ProjectorParams,
    /// The depth range, when the file has fringe3d's `fringe3d_depth_range`.
    pub depth_range: Option<[f64; 2]>,
}

impl ImportedRig {
    /// The projector centre P, camera frame, mm.
    pub fn projector_centre(&self) -> [f64; 3] {
        self.projector.translation
    }
}

/// The camera a [`Lens`] describes, `size` filling in a size the file does not state; validated
/// like a calibration file's camera, every message naming the keys.
pub(crate) fn lens_camera(lens: &Lens, size: Option<(u32, u32)>) -> Result<CameraParams, String> {
    let (width, height) = match (&lens.size, size) {
        (Some((s, _)), None) => *s,
        (Some((s, keys)), Some(g)) if *s != g => {
            return Err(format!(
                "the {} is {}x{} by {keys}, but {}x{} was given",
                lens.role, s.0, s.1, g.0, g.1
            ));
        }
        (Some((s, _)), Some(_)) => *s,
        (None, Some(g)) => g,
        (None, None) => {
            let opt = if lens.role == "projector" {
                "--projector-size WxH"
            } else {
                "--camera-size WxH"
            };
            return Err(format!(
                "the {} image size is not in the file (looked for {}): give it with {opt}",
                lens.role, lens.size_keys
            ));
        }
    };
    let kname = &lens.kname;
    let k = &lens.k;
    if k.len() != 9 {
        return Err(format!(
            "{kname} ({} matrix) has {} values, expected 9 (3x3)",
            lens.role,
            k.len()
        ));
    }
    let near = |i: usize, want: f64| (k[i] - want).abs() <= 1e-9;
    if !(near(3, 0.0) && near(6, 0.0) && near(7, 0.0) && near(8, 1.0)) {
        return Err(format!(
            "{kname} ({} matrix) must have the form [fx s cx; 0 fy cy; 0 0 1], got [{} {} {}; {} {} {}; {} {} {}]",
            lens.role, k[0], k[1], k[2], k[3], k[4], k[5], k[6], k[7], k[8]
        ));
    }
    let distortion = distortion5(&lens.d, &lens.dname)?;
    let fx = k[0];
    let skew = match lens.skew {
        // fringe3d's exact α, accepted when it agrees with K[0][1] = α·fx.
        Some(a) if !a.is_finite() || (a * fx - k[1]).abs() <= 1e-9 * fx.abs().max(1.0) => a,
        Some(a) => {
            return Err(format!(
                "the {}'s skew {a} (fringe3d_skew) disagrees with {kname}[0][1] = {} (= skew·fx)",
                lens.role, k[1]
            ));
        }
        None if fx != 0.0 => k[1] / fx,
        None => f64::NAN,
    };
    let cam = CameraParams {
        width,
        height,
        fx,
        fy: k[4],
        skew,
        cx: k[2],
        cy: k[5],
        distortion: distortion.into(),
    };
    let mut errs = Vec::new();
    check_camera(
        &cam,
        &format!("{} ({kname}, {})", lens.role, lens.dname),
        &mut errs,
    );
    if errs.is_empty() {
        Ok(cam)
    } else {
        Err(errs.join("; "))
    }
}

/// `[k1, k2, p1, p2, k3]` from 4, 5, 8, 12 or 14 coefficients (OpenCV's lengths); beyond the
/// fifth all must be zero, as fringe3d's model has only these five.
pub(crate) fn distortion5(d: &[f64], name: &str) -> Result<[f64; 5], String> {
    if ![4, 5, 8, 12, 14].contains(&d.len()) {
        return Err(format!(
            "{name} has {} values; OpenCV writes 4, 5, 8, 12 or 14",
            d.len()
        ));
    }
    const EXTRA: [&str; 9] = ["k4", "k5", "k6", "s1", "s2", "s3", "s4", "tau_x", "tau_y"];
    for (i, &v) in d.iter().enumerate().skip(5) {
        if v != 0.0 {
            return Err(format!(
                "{name} has {} values and {} = {v} is not zero: fringe3d's model has only [k1, k2, p1, p2, k3]; \
                 calibrate without the rational, thin-prism and tilted models",
                d.len(),
                EXTRA[i - 5]
            ));
        }
    }
    if let Some(v) = d.iter().find(|v| !v.is_finite()) {
        return Err(format!("{name} contains {v}"));
    }
    let mut out = [0.0; 5];
    for (o, v) in out.iter_mut().zip(d) {
        *o = *v;
    }
    Ok(out)
}

/// The rotation matrix of a Rodrigues vector (axis × angle, radians).
pub(crate) fn rodrigues(om: [f64; 3]) -> [[f64; 3]; 3] {
    let th = (om[0] * om[0] + om[1] * om[1] + om[2] * om[2]).sqrt();
    if th < 1e-300 {
        return [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    }
    let (x, y, z) = (om[0] / th, om[1] / th, om[2] / th);
    let (s, c) = th.sin_cos();
    let v = 1.0 - c;
    [
        [c + x * x * v, x * y * v - z * s, x * z * v + y * s],
        [y * x * v + z * s, c + y * y * v, y * z * v - x * s],
        [z * x * v - y * s, z * y * v + x * s, c + z * z * v],
    ]
}

/// The projector pose in fringe3d's convention from a stereo pose `x_p = R·x_c + T`:
/// `X_cam = Rᵀ·X_proj − Rᵀ·T`, so fringe3d's rotation is `Rᵀ` and the projector centre
/// `P = −Rᵀ·T`. R must be a rotation (`|R·Rᵀ − I| ≤ 1e-6`, determinant +1).
pub(crate) fn pose_to_fringe3d(pose: &StereoPose) -> Result<([[f64; 3]; 3], [f64; 3]), String> {
    let (rname, tname) = (&pose.rname, &pose.tname);
    if let Some(v) = pose.r.iter().chain(&pose.t).find(|v| !v.is_finite()) {
        return Err(format!("{rname}/{tname} contain {v}"));
    }
    let r = match pose.r.len() {
        9 => [
            [pose.r[0], pose.r[1], pose.r[2]],
            [pose.r[3], pose.r[4], pose.r[5]],
            [pose.r[6], pose.r[7], pose.r[8]],
        ],
        3 => rodrigues([pose.r[0], pose.r[1], pose.r[2]]),
        n => {
            return Err(format!(
                "{rname} has {n} values, expected 9 (a 3x3 rotation) or 3 (a Rodrigues vector)"
            ));
        }
    };
    if pose.t.len() != 3 {
        return Err(format!(
            "{tname} has {} values, expected 3 (a translation)",
            pose.t.len()
        ));
    }
    let mut worst: f64 = 0.0;
    for i in 0..3 {
        for j in 0..3 {
            let dot: f64 = (0..3).map(|k| r[i][k] * r[j][k]).sum();
            worst = worst.max((dot - if i == j { 1.0 } else { 0.0 }).abs());
        }
    }
    if worst > 1e-6 {
        return Err(format!(
            "{rname} is not a rotation (|R·Rᵀ − I| up to {worst:e})"
        ));
    }
    let det = r[0][0] * (r[1][1] * r[2][2] - r[1][2] * r[2][1])
        - r[0][1] * (r[1][0] * r[2][2] - r[1][2] * r[2][0])
        + r[0][2] * (r[1][0] * r[2][1] - r[1][1] * r[2][0]);
    if det < 0.0 {
        return Err(format!(
            "{rname} is a reflection (determinant −1), not a rotation"
        ));
    }
    let rt = [
        [r[0][0], r[1][0], r[2][0]],
        [r[0][1], r[1][1], r[2][1]],
        [r[0][2], r[1][2], r[2][2]],
    ];
    let t = [pose.t[0], pose.t[1], pose.t[2]];
    let p = [
        -(rt[0][0] * t[0] + rt[0][1] * t[1] + rt[0][2] * t[2]),
        -(rt[1][0] * t[0] + rt[1][1] * t[1] + rt[1][2] * t[2]),
        -(rt[2][0] * t[0] + rt[2][1] * t[1] + rt[2][2] * t[2]),
    ];
    let centre = match pose.centre {
        None => p,
        Some(c) => {
            let d = ((c[0] - p[0]).powi(2) + (c[1] - p[1]).powi(2) + (c[2] - p[2]).powi(2)).sqrt();
            let scale = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
            if !(d <= 1e-9 * scale.max(1.0)) {
                return Err(format!(
                    "fringe3d_projector_centre [{}, {}, {}] disagrees with −{rname}ᵀ·{tname} = [{}, {}, {}]",
                    c[0], c[1], c[2], p[0], p[1], p[2]
                ));
            }
            c
        }
    };
    if (centre[0] * centre[0] + centre[1] * centre[1] + centre[2] * centre[2]).sqrt() <= 1e-9 {
        return Err(format!(
            "{tname} puts the projector centre at the camera centre: there is no baseline"
        ));
    }
    Ok((rt, centre))
}

impl ParsedRig {
    /// The camera alone (camera 1), `size` filling in a size the file lacks.
    pub(crate) fn camera(
        &self,
        path: &Path,
        size: Option<(u32, u32)>,
    ) -> Result<CameraParams, FormatError> {
        lens_camera(&self.camera, size).map_err(|m| FormatError::invalid(path, m))
    }

    /// The full rig, validated; errors name `path` and the keys.
    pub(crate) fn finish(&self, path: &Path, sizes: RigSizes) -> Result<ImportedRig, FormatError> {
        let bad = |m: String| FormatError::invalid(path, m);
        let camera = lens_camera(&self.camera, sizes.camera).map_err(bad)?;
        let intrinsics = lens_camera(&self.projector, sizes.projector).map_err(bad)?;
        let (rotation, translation) = pose_to_fringe3d(&self.pose).map_err(bad)?;
        if let Some([z0, z1]) = self.depth_range
            && !(z0.is_finite() && z1.is_finite() && z0 > 0.0 && z0 < z1)
        {
            return Err(bad(format!(
                "fringe3d_depth_range must satisfy 0 < z_min < z_max (mm), got [{z0}, {z1}]"
            )));
        }
        Ok(ImportedRig {
            format: self.format,
            camera,
            projector: ProjectorParams {
                intrinsics,
                rotation,
                translation,
            },
            depth_range: self.depth_range,
        })
    }
}

impl ParsedRig {
    /// Sizes for a look at the file (`fringe3d info`): the file's, else a stand-in of twice the
    /// principal point; also whether each size was stated.
    pub(crate) fn stand_in_sizes(&self) -> (RigSizes, [bool; 2]) {
        let guess = |l: &Lens| -> Option<(u32, u32)> {
            if l.size.is_some() || l.k.len() != 9 {
                return None;
            }
            let g = |c: f64| {
                if c.is_finite() && c > 0.0 && c < 1e9 {
                    (2.0 * c + 1.0).ceil() as u32
                } else {
                    1
                }
            };
            Some((g(l.k[2]), g(l.k[5])))
        };
        (
            RigSizes {
                camera: guess(&self.camera),
                projector: guess(&self.projector),
            },
            [self.camera.size.is_some(), self.projector.size.is_some()],
        )
    }
}
