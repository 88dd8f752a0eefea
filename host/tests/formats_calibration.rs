//! Calibration files and the OpenCV / Bouguet importers, checked against hand-written files and
//! hand-computed values.

use std::fs;
use std::path::{Path, PathBuf};

use fringe3d::io::calibration::{
    Calibration, CameraCovariance, CameraParams, Distortion, FormatError, ProjectorParams,
    ReferencePlane,
};
use fringe3d::io::import::{import_bouguet, import_bouguet_file, import_opencv};

fn scratch(name: &str) -> crate::cli_support::Tmp {
    crate::cli_support::Tmp::new(&format!("formats-calib-{name}"))
}

fn examples() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("..")
        .join("examples")
}

fn sample() -> Calibration {
    Calibration {
        version: 1,
        camera: CameraParams {
            width: 640,
            height: 480,
            fx: 1100.0,
            fy: 1100.5,
            skew: 0.001,
            cx: 319.5,
            cy: 239.5,
            distortion: Distortion::from_array([-0.12, 0.08, 0.0005, -0.0003, 0.0]),
        },
        projector_centre: [-200.0, 0.0, 30.0],
        reference: Some(ReferencePlane {
            point: [0.0, 0.0, 800.0],
            normal: [0.0, 0.0, -1.0],
            phase_map: PathBuf::from("reference/phase.tiff"),
            pattern_set: Some(PathBuf::from("patterns.toml")),
            pattern_digest: Some(format!("sha256:{}", "0123456789abcdef".repeat(4))),
            margin: None,
        }),
        depth_range: [650.0, 900.0],
        projector: Some(ProjectorParams {
            intrinsics: CameraParams {
                width: 1024,
                height: 768,
                fx: 1500.0,
                fy: 1500.0,
                skew: 0.0,
                cx: 511.5,
                cy: 767.5,
                distortion: Distortion::from_array([0.0; 5]),
            },
            rotation: [
                [0.9682458365518543, 0.0, 0.25],
                [0.0, 1.0, 0.0],
                [-0.25, 0.0, 0.9682458365518543],
            ],
            translation: [-200.0, 0.0, 30.0],
        }),
        projector_response: None,
        projector_defocus: None,
        camera_covariance: None,
        sensor: None,
    }
}

/// What `save` must write for `sample()`, by hand.
const SAMPLE_TOML: &str = r#"# fringe3d calibration file, format version 1 (docs/formats.md).
# Frame: the camera's (OpenCV): origin at its centre of projection, x right, y down, z forward.
# Units: millimetres for positions and depths; pixels for fx, fy, cx, cy and sizes;
# skew (alpha of eq 4) and distortion [k1, k2, p1, p2, k3] are dimensionless.
# Pixel centres are at integer coordinates: (0, 0) is the centre of the top-left pixel.
version = 1
projector_centre = [-200.0, 0.0, 30.0]  # P, mm
depth_range = [650.0, 900.0]  # [z_min, z_max], mm

[camera]
width = 640  # px
height = 480  # px
fx = 1100.0  # px
fy = 1100.5  # px
skew = 0.001  # alpha: u = fx*x + skew*fx*y + cx
cx = 319.5  # px
cy = 239.5  # px
distortion = [-0.12, 0.08, 0.0005, -0.0003, 0.0]  # [k1, k2, p1, p2, k3]

[reference]
point = [0.0, 0.0, 800.0]  # O_R, mm
normal = [0.0, 0.0, -1.0]  # n_R, unit
phase_map = "reference/phase.tiff"  # float32 TIFF, relative to this file
pattern_set = "patterns.toml"
pattern_digest = "sha256:0123456789abcdef0123456789abcdef0123456789abcdef0123456789abcdef"  # the reference's pattern set (docs/formats.md)

[projector]
rotation = [[0.9682458365518543, 0.0, 0.25], [0.0, 1.0, 0.0], [-0.25, 0.0, 0.9682458365518543]]  # R, rows: X_cam = R * X_proj + T
translation = [-200.0, 0.0, 30.0]  # T, mm

[projector.intrinsics]
width = 1024  # px
height = 768  # px
fx = 1500.0  # px
fy = 1500.0  # px
skew = 0.0  # alpha: u = fx*x + skew*fx*y + cx
cx = 511.5  # px
cy = 767.5  # px
distortion = [0.0, 0.0, 0.0, 0.0, 0.0]  # [k1, k2, p1, p2, k3]
"#;

#[test]
fn save_writes_the_documented_layout() {
    let d = scratch("save");
    let p = d.join("calib.toml");
    sample().save(&p).unwrap();
    assert_eq!(fs::read_to_string(&p).unwrap(), SAMPLE_TOML);
    assert_eq!(Calibration::load(&p).unwrap(), sample());
    let names: Vec<_> = fs::read_dir(&d)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(names.len(), 1, "no temporary file left: {names:?}");
}

#[test]
fn load_reads_a_hand_written_minimal_file() {
    let d = scratch("minimal");
    let p = d.join("c.toml");
    // Key order differs from what save writes; integers where floats are expected are accepted.
    fs::write(
        &p,
        "version = 1\ndepth_range = [100, 2e3]\nprojector_center = [150.0, -10.0, 0.0]\n\
         [camera]\nwidth = 8\nheight = 6\nfx = 10\nfy = 11.0\nskew = 0\ncx = 3.5\ncy = 2.5\n\
         distortion = [0.1, -0.2, 0.0, 0.0, 1e-3]\n",
    )
    .unwrap();
    let c = Calibration::load(&p).unwrap();
    assert_eq!(c.camera.fx, 10.0);
    assert_eq!(c.camera.fy, 11.0);
    assert_eq!(c.camera.distortion.to_array(), [0.1, -0.2, 0.0, 0.0, 0.001]);
    assert_eq!(c.depth_range, [100.0, 2000.0]);
    assert_eq!(c.projector_centre, [150.0, -10.0, 0.0]);
    assert_eq!(c.reference, None);
    assert_eq!(c.projector, None);
    assert_eq!(c.reference_map_path(&p), None);
}

#[test]
fn awkward_floats_round_trip_exactly() {
    let d = scratch("floats");
    let p = d.join("c.toml");
    let mut c = sample();
    c.camera.fx = 1.0 / 3.0 * 3000.0 + 1e-10;
    c.camera.cx = 0.1 + 0.2;
    c.camera.distortion =
        Distortion::from_array([1e-300, -0.0, 5e-324, 123456789.0e-15, -999.9999999999999]);
    c.depth_range = [1e-3, 1e21];
    c.save(&p).unwrap();
    let back = Calibration::load(&p).unwrap();
    assert_eq!(back, c);
    assert_eq!(back.camera.distortion.k2.to_bits(), (-0.0f64).to_bits());
}

/// `[camera_covariance]` (issue #18 item 4): round-trips exactly, and a matrix that is no
/// covariance is refused by name.
#[test]
fn a_camera_covariance_round_trips_and_is_checked() {
    let d = scratch("covariance");
    let p = d.join("c.toml");
    let mut c = sample();
    let mut m = [[0.0; 10]; 10];
    let sd = [0.05, 0.06, 1e-6, 0.1, 0.12, 2e-4, 1e-3, 1e-5, 2e-5, 0.0];
    for i in 0..10 {
        for j in 0..10 {
            let rho = if i == j {
                1.0
            } else {
                0.3 / (1.0 + (i + j) as f64)
            };
            m[i][j] = rho * sd[i] * sd[j];
        }
    }
    c.camera_covariance = Some(CameraCovariance { matrix: m });
    c.save(&p).unwrap();
    let text = fs::read_to_string(&p).unwrap();
    assert!(
        text.contains("[camera_covariance]") && text.contains("fx, fy, skew, cx, cy"),
        "{text}"
    );
    assert_eq!(Calibration::load(&p).unwrap(), c);
    for (edit, want) in [
        ((0, 1, 1.0), "not symmetric"),
        ((3, 3, -1e-4), "the variance of cx is negative"),
        ((0, 0, f64::NAN), "must be finite"),
    ] {
        let mut bad = c.clone();
        let cv = bad.camera_covariance.as_mut().unwrap();
        let ((i, j, v), _) = (edit, want);
        cv.matrix[i][j] = v;
        let e = bad.save(&d.join("bad.toml")).unwrap_err().to_string();
        assert!(e.contains(want) && e.contains("camera_covariance"), "{e}");
    }
    // An OpenCV camera file with fringe3d's `intrinsics_covariance` carries it on.
    let yml = d.join("camera.yml");
    let flat = CameraCovariance { matrix: m }.flat();
    fs::write(
        &yml,
        format!(
            "%YAML:1.0\n---\nimage_width: 640\nimage_height: 512\n\
             camera_matrix: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n   data: [ 600., 0., 320., 0., 600., 256., 0., 0., 1. ]\n\
             distortion_coefficients: !!opencv-matrix\n   rows: 5\n   cols: 1\n   dt: d\n   data: [ 0., 0., 0., 0., 0. ]\n\
             intrinsics_covariance: !!opencv-matrix\n   rows: 10\n   cols: 10\n   dt: d\n   data: [ {} ]\n",
            flat.iter().map(|x| format!("{x:?}")).collect::<Vec<_>>().join(", ")
        ),
    )
    .unwrap();
    let got = fringe3d::calib::files::load_camera_covariance(&yml).unwrap();
    assert_eq!(got, Some(CameraCovariance { matrix: m }));
    // A file without it (OpenCV's own) has none.
    let plain = examples().join("calibration").join("opencv.yml");
    assert_eq!(
        fringe3d::calib::files::load_camera_covariance(&plain).unwrap(),
        None
    );
}

fn err_of(text: &str) -> FormatError {
    let d = scratch("err");
    let p = d.join("calib.toml");
    fs::write(&p, text).unwrap();
    Calibration::load(&p).unwrap_err()
}

#[test]
fn validation_errors_name_file_and_field() {
    let bad_fx = SAMPLE_TOML.replace("fx = 1100.0", "fx = -3");
    let e = err_of(&bad_fx);
    let m = e.to_string();
    assert!(matches!(e, FormatError::Invalid { .. }));
    assert!(
        m.contains("calib.toml: camera.fx must be positive, got -3"),
        "{m}"
    );

    let m = err_of(&SAMPLE_TOML.replace(
        "depth_range = [650.0, 900.0]",
        "depth_range = [900.0, 650.0]",
    ))
    .to_string();
    assert!(m.contains("calib.toml") && m.contains("depth_range"), "{m}");

    let m = err_of(&SAMPLE_TOML.replace("normal = [0.0, 0.0, -1.0]", "normal = [0.0, 0.0, -2.0]"))
        .to_string();
    assert!(m.contains("reference.normal must be a unit vector"), "{m}");

    let m = err_of(&SAMPLE_TOML.replace(
        "translation = [-200.0, 0.0, 30.0]",
        "translation = [-200.0, 0.0, 31.0]",
    ))
    .to_string();
    assert!(
        m.contains("projector.translation") && m.contains("projector_centre"),
        "{m}"
    );

    let m = err_of(&SAMPLE_TOML.replace("[0.0, 1.0, 0.0], [-0.25", "[0.0, 1.1, 0.0], [-0.25"))
        .to_string();
    assert!(m.contains("projector.rotation is not orthonormal"), "{m}");

    let m = err_of(&SAMPLE_TOML.replace(
        "[-0.25, 0.0, 0.9682458365518543]]",
        "[0.25, 0.0, -0.9682458365518543]]",
    ))
    .to_string();
    assert!(m.contains("reflection"), "{m}");

    let m = err_of(&SAMPLE_TOML.replace(
        "projector.intrinsics]\nwidth = 1024",
        "projector.intrinsics]\nwidth = 0",
    ))
    .to_string();
    assert!(
        m.contains("projector.intrinsics.width must be positive"),
        "{m}"
    );

    let m =
        err_of(&SAMPLE_TOML.replace("distortion = [-0.12,", "distortion = [-5000.0,")).to_string();
    assert!(m.contains("camera.distortion[0] (k1)"), "{m}");

    // Reference plane through the projector centre.
    let m = err_of(&SAMPLE_TOML.replace("point = [0.0, 0.0, 800.0]", "point = [0.0, 0.0, 30.0]"))
        .to_string();
    assert!(m.contains("passes through the projector centre"), "{m}");

    // Several problems are all reported.
    let m = err_of(&bad_fx.replace("fy = 1100.5", "fy = 0.0")).to_string();
    assert!(m.contains("camera.fx") && m.contains("camera.fy"), "{m}");
}

#[test]
fn parse_errors_name_file_and_problem() {
    let e = err_of(&SAMPLE_TOML.replace("fy = 1100.5", "fyy = 1100.5"));
    assert!(matches!(e, FormatError::Parse { .. }));
    let m = e.to_string();
    assert!(
        m.starts_with(&format!("{}", e.path().display())) && m.contains("fyy"),
        "{m}"
    );

    let m = err_of(&SAMPLE_TOML.replace("width = 640", "width = \"640\"")).to_string();
    assert!(m.contains("calib.toml") && m.contains("line"), "{m}");

    let e = err_of(&SAMPLE_TOML.replace("version = 1", "version = 2"));
    assert!(
        matches!(
            e,
            FormatError::Version {
                found: 2,
                supported: 1,
                ..
            }
        ),
        "{e}"
    );

    let e = err_of(&SAMPLE_TOML.replace("version = 1\n", ""));
    assert!(e.to_string().contains("missing `version = 1`"), "{e}");

    let missing = Path::new("/nonexistent/fringe3d/calib.toml");
    let e = Calibration::load(missing).unwrap_err();
    assert!(matches!(e, FormatError::Io { .. }));
    assert!(
        e.to_string()
            .starts_with("/nonexistent/fringe3d/calib.toml: cannot read"),
        "{e}"
    );
}

#[test]
fn save_refuses_invalid_data_and_writes_nothing() {
    let d = scratch("save-invalid");
    let p = d.join("c.toml");
    let mut c = sample();
    c.camera.fy = f64::NAN;
    let e = c.save(&p).unwrap_err();
    assert!(
        e.to_string()
            .contains("camera.fy must be positive, got NaN"),
        "{e}"
    );
    assert!(!p.exists());
}

#[test]
fn reference_paths_resolve_against_the_calibration_file() {
    let c = sample();
    assert_eq!(
        c.reference_map_path(Path::new("/data/rig/calib.toml")),
        Some(PathBuf::from("/data/rig/reference/phase.tiff"))
    );
    assert_eq!(
        c.reference_map_path(Path::new("calib.toml")),
        Some(PathBuf::from("reference/phase.tiff"))
    );
    assert_eq!(
        c.reference_pattern_path(Path::new("/data/rig/calib.toml")),
        Some(PathBuf::from("/data/rig/patterns.toml"))
    );
    let mut abs = c.clone();
    if let Some(r) = abs.reference.as_mut() {
        r.phase_map = PathBuf::from("/maps/phi.tiff");
    }
    assert_eq!(
        abs.reference_map_path(Path::new("/data/calib.toml")),
        Some(PathBuf::from("/maps/phi.tiff"))
    );
}

#[test]
fn example_calibration_loads() {
    let p = examples().join("calibration").join("calib.toml");
    let c = Calibration::load(&p).unwrap();
    assert_eq!(c, sample_example());
}

fn sample_example() -> Calibration {
    let mut c = sample();
    c.camera.fy = 1100.0;
    c.camera.skew = 0.0;
    if let Some(r) = c.reference.as_mut() {
        r.pattern_set = Some(PathBuf::from("../patterns/paper8.toml"));
        // The example predates the digest: it still loads.
        r.pattern_digest = None;
    }
    c
}

// --- OpenCV -----------------------------------------------------------------------------------

fn expected_opencv() -> CameraParams {
    CameraParams {
        width: 640,
        height: 480,
        fx: 1102.3456789012345,
        fy: 1101.2345678901234,
        skew: 0.0,
        cx: 321.45678901234567,
        cy: 240.34567890123456,
        distortion: Distortion::from_array([
            -0.12345678901234567,
            0.087_654_321_098_765_43,
            0.000_543_210_987_654_321,
            -0.00032109876543210987,
            -0.011111111111111111,
        ]),
    }
}

#[test]
fn opencv_yaml_and_xml_examples() {
    let dir = examples().join("calibration");
    // The size arguments are overridden by image_width / image_height in the files.
    assert_eq!(
        import_opencv(&dir.join("opencv.yml"), 1, 1).unwrap(),
        expected_opencv()
    );
    assert_eq!(
        import_opencv(&dir.join("opencv.xml"), 1, 1).unwrap(),
        expected_opencv()
    );
}

/// A file in a scratch folder of its own, removed with it.
struct ScratchFile {
    _dir: crate::cli_support::Tmp,
    path: PathBuf,
}

impl std::ops::Deref for ScratchFile {
    type Target = Path;
    fn deref(&self) -> &Path {
        &self.path
    }
}

fn opencv_file(name: &str, text: &str) -> ScratchFile {
    // One directory per file: tests run in parallel and `scratch` empties its directory.
    let d = scratch(&format!("opencv-{}", name.replace('.', "-")));
    let p = d.join(name);
    fs::write(&p, text).unwrap();
    ScratchFile { _dir: d, path: p }
}

#[test]
fn opencv_skew_four_coefficients_and_size_arguments() {
    // OpenCV 2.x style without `---`, skew K[0][1] = alpha * fx, 4 coefficients as a row.
    let p = opencv_file(
        "cam.yaml",
        "%YAML:1.0\ncamera_matrix: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n   \
         data: [ 1000., 2., 320., 0., 1000., 240., 0., 0., 1. ]\n\
         distortion_coefficients: !!opencv-matrix\n   rows: 1\n   cols: 4\n   dt: f\n   data: [ 0.1, -0.2, 0.001, 0.002 ]\n",
    );
    let c = import_opencv(&p, 800, 600).unwrap();
    assert_eq!((c.width, c.height), (800, 600));
    assert_eq!(c.skew, 0.002);
    assert_eq!(c.distortion.to_array(), [0.1, -0.2, 0.001, 0.002, 0.0]);
    assert_eq!((c.fx, c.fy, c.cx, c.cy), (1000.0, 1000.0, 320.0, 240.0));
}

#[test]
fn opencv_json_and_alias_keys() {
    let p = opencv_file(
        "cam.json",
        r#"{ "image_width": 1280, "image_height": 1024,
             "cameraMatrix": { "type_id": "opencv-matrix", "rows": 3, "cols": 3, "dt": "d",
                               "data": [ 1500.0, 0.0, 639.5, 0.0, 1501.0, 511.5, 0.0, 0.0, 1.0 ] },
             "distCoeffs": { "type_id": "opencv-matrix", "rows": 1, "cols": 5, "dt": "d",
                             "data": [ 0.01, 0.02, 0.0, 0.0, 0.03 ] } }"#,
    );
    let c = import_opencv(&p, 1, 1).unwrap();
    assert_eq!((c.width, c.height, c.fy, c.cy), (1280, 1024, 1501.0, 511.5));
    assert_eq!(c.distortion.to_array(), [0.01, 0.02, 0.0, 0.0, 0.03]);
}

fn yaml_with_dist(n: usize, data: &str) -> String {
    format!(
        "%YAML:1.0\n---\ncamera_matrix: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n   \
         data: [ 1000., 0., 320., 0., 1000., 240., 0., 0., 1. ]\n\
         distortion_coefficients: !!opencv-matrix\n   rows: {n}\n   cols: 1\n   dt: d\n   data: [ {data} ]\n"
    )
}

#[test]
fn opencv_extra_coefficients_must_be_zero() {
    let ok = opencv_file(
        "eight.yml",
        &yaml_with_dist(8, "0.1, 0.2, 0.0, 0.0, 0.3, 0., 0., 0."),
    );
    assert_eq!(
        import_opencv(&ok, 640, 480).unwrap().distortion.to_array(),
        [0.1, 0.2, 0.0, 0.0, 0.3]
    );
    let fourteen = vec!["0."; 14].join(", ");
    let ok = opencv_file("fourteen.yml", &yaml_with_dist(14, &fourteen));
    assert!(import_opencv(&ok, 640, 480).is_ok());

    let bad = opencv_file(
        "rational.yml",
        &yaml_with_dist(8, "0.1, 0.2, 0.0, 0.0, 0.3, 0.05, 0., 0."),
    );
    let e = import_opencv(&bad, 640, 480).unwrap_err();
    let m = e.to_string();
    assert!(m.contains("rational.yml") && m.contains("k4 = 0.05"), "{m}");

    let e = import_opencv(
        &opencv_file("six.yml", &yaml_with_dist(6, "0, 0, 0, 0, 0, 0")),
        640,
        480,
    )
    .unwrap_err();
    assert!(e.to_string().contains("6 values"), "{e}");
}

#[test]
fn opencv_malformed_files_are_refused_clearly() {
    let bad_k = yaml_with_dist(5, "0, 0, 0, 0, 0").replace("0., 0., 1. ]", "0., 0.5, 1. ]");
    let e = import_opencv(&opencv_file("k.yml", &bad_k), 640, 480).unwrap_err();
    assert!(e.to_string().contains("[fx s cx; 0 fy cy; 0 0 1]"), "{e}");

    let mismatch = yaml_with_dist(5, "0, 0, 0, 0");
    let e = import_opencv(&opencv_file("m.yml", &mismatch), 640, 480).unwrap_err();
    assert!(
        e.to_string().contains("rows x cols = 5 x 1 but data has 4"),
        "{e}"
    );

    let no_dist = "%YAML:1.0\ncamera_matrix: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n   data: [ 1,0,1,0,1,1,0,0,1 ]\n";
    let e = import_opencv(&opencv_file("nd.yml", no_dist), 640, 480).unwrap_err();
    assert!(
        e.to_string().contains("nd.yml: no distortion coefficients"),
        "{e}"
    );

    let nan = yaml_with_dist(5, ".Nan, 0, 0, 0, 0");
    let e = import_opencv(&opencv_file("nan.yml", &nan), 640, 480).unwrap_err();
    assert!(e.to_string().contains(".Nan"), "{e}");

    let unclosed = "%YAML:1.0\ncamera_matrix: !!opencv-matrix\n   rows: 3\n   data: [ 1, 2,\n";
    let e = import_opencv(&opencv_file("u.yml", unclosed), 640, 480).unwrap_err();
    assert!(
        matches!(e, FormatError::Parse { .. }) && e.to_string().contains("line 4"),
        "{e}"
    );

    let xml = "<?xml version=\"1.0\"?>\n<opencv_storage>\n<camera_matrix type_id=\"opencv-matrix\"><rows>3</rows></opencv_storage>\n";
    let e = import_opencv(&opencv_file("x.xml", xml), 640, 480).unwrap_err();
    assert!(e.to_string().contains("does not match"), "{e}");

    let neg_f =
        yaml_with_dist(5, "0, 0, 0, 0, 0").replace("[ 1000., 0., 320.", "[ -1000., 0., 320.");
    let e = import_opencv(&opencv_file("f.yml", &neg_f), 640, 480).unwrap_err();
    assert!(e.to_string().contains("camera.fx must be positive"), "{e}");
}

// --- Bouguet ----------------------------------------------------------------------------------

#[test]
fn bouguet_values_map_without_pixel_shift() {
    // The toolbox's pixel origin is the centre of the upper-left pixel, like ours: cc is kept.
    let c = import_bouguet(
        [657.6, 658.0],
        [303.2, 242.6],
        0.001,
        [-0.25, 0.13, -0.0002, 0.00004, 0.01],
        640,
        480,
    );
    assert_eq!(
        c,
        CameraParams {
            width: 640,
            height: 480,
            fx: 657.6,
            fy: 658.0,
            skew: 0.001,
            cx: 303.2,
            cy: 242.6,
            distortion: Distortion::from_array([-0.25, 0.13, -0.0002, 0.00004, 0.01]),
        }
    );
}

#[test]
fn bouguet_results_file() {
    let c = import_bouguet_file(
        &examples().join("calibration").join("Calib_Results.m"),
        1,
        1,
    )
    .unwrap();
    assert_eq!(
        c,
        CameraParams {
            width: 640,
            height: 480,
            fx: 1102.3456789012345,
            fy: 1101.2345678901234,
            skew: 0.0,
            cx: 321.45678901234567,
            cy: 240.34567890123456,
            distortion: Distortion::from_array([
                -0.123456789012346,
                0.087654321098765,
                0.000543210987654,
                -0.000321098765432,
                0.0
            ]),
        }
    );
}

#[test]
fn bouguet_file_variants_and_errors() {
    let d = scratch("bouguet");
    let p = d.join("Calib_Results.m");
    // Old toolbox: 4 distortion values; no nx/ny (taken from the arguments); skew set.
    fs::write(&p, "fc = [ 500 ; 501 ];\ncc = [ 319.5 ; 239.5 ];\nalpha_c = 0.002;\nkc = [ 0.1 ; 0.2 ; 0.003 ; 0.004 ];\n").unwrap();
    let c = import_bouguet_file(&p, 640, 480).unwrap();
    assert_eq!(c.distortion.to_array(), [0.1, 0.2, 0.003, 0.004, 0.0]);
    assert_eq!((c.width, c.height, c.skew, c.fy), (640, 480, 0.002, 501.0));

    fs::write(&p, "cc = [ 319.5 ; 239.5 ];\nkc = [ 0 ; 0 ; 0 ; 0 ; 0 ];\n").unwrap();
    let e = import_bouguet_file(&p, 640, 480).unwrap_err();
    assert!(
        e.to_string()
            .contains("Calib_Results.m: no `fc = ...;` assignment found"),
        "{e}"
    );

    fs::write(
        &p,
        "fc = [ 500 ; 501 ; 3 ];\ncc = [ 1 ; 2 ];\nkc = [ 0 ; 0 ; 0 ; 0 ; 0 ];\n",
    )
    .unwrap();
    let e = import_bouguet_file(&p, 640, 480).unwrap_err();
    assert!(
        e.to_string().contains("`fc` has 3 values, expected 2"),
        "{e}"
    );

    fs::write(
        &p,
        "fc = [ 500 ; NaN ];\ncc = [ 1 ; 2 ];\nkc = [ 0 ; 0 ; 0 ; 0 ; 0 ];\n",
    )
    .unwrap();
    assert!(
        import_bouguet_file(&p, 640, 480)
            .unwrap_err()
            .to_string()
            .contains("NaN")
    );
}

/// A parse error whose message names `key` and the count found; it must not quote the whole line
/// back (a million values would make a megabyte message).
/// Each call writes its own folder (`name`): tests run in parallel.
fn length_error(name: &str, text: &str, key: &str, expected: &str) {
    let d = scratch(name);
    let p = d.join("calib.toml");
    fs::write(&p, text).unwrap();
    let e = Calibration::load(&p).unwrap_err();
    assert!(matches!(e, FormatError::Parse { .. }), "{e}");
    let m = e.to_string();
    assert!(m.contains("calib.toml"), "{m}");
    assert!(m.contains(&format!("`{key}`")), "{m}");
    assert!(m.contains(expected), "{m}");
    assert!(m.len() < 2500, "{} bytes", m.len());
}

#[test]
fn distortion_of_six_values_is_refused() {
    length_error(
        "length-1",
        &SAMPLE_TOML.replace(
            "distortion = [-0.12, 0.08, 0.0005, -0.0003, 0.0]",
            "distortion = [-0.12, 0.08, 0.0005, -0.0003, 0.0, 0.0]",
        ),
        "distortion",
        "must have exactly 5 values, got 6",
    );
}

#[test]
fn distortion_of_two_million_values_is_refused() {
    let mut long = String::from("distortion = [-0.12, 0.08, 0.0005, -0.0003, 0.0");
    for _ in 0..(2_000_000 - 5) {
        long.push_str(", 0.0");
    }
    long.push(']');
    length_error(
        "length-2",
        &SAMPLE_TOML.replace("distortion = [-0.12, 0.08, 0.0005, -0.0003, 0.0]", &long),
        "distortion",
        "must have exactly 5 values, got 2000000",
    );
}

#[test]
fn projector_intrinsics_distortion_of_six_values_is_refused() {
    length_error(
        "length-3",
        &SAMPLE_TOML.replace(
            "distortion = [0.0, 0.0, 0.0, 0.0, 0.0]",
            "distortion = [0.0, 0.0, 0.0, 0.0, 0.0, 0.0]",
        ),
        "distortion",
        "must have exactly 5 values, got 6",
    );
}

#[test]
fn projector_centre_of_four_values_is_refused() {
    length_error(
        "length-4",
        &SAMPLE_TOML.replace(
            "projector_centre = [-200.0, 0.0, 30.0]",
            "projector_centre = [-200.0, 0.0, 30.0, 1.0]",
        ),
        "projector_centre",
        "must have exactly 3 values, got 4",
    );
}

#[test]
fn normal_of_four_values_is_refused() {
    length_error(
        "length-5",
        &SAMPLE_TOML.replace(
            "normal = [0.0, 0.0, -1.0]",
            "normal = [0.0, 0.0, -1.0, 0.0]",
        ),
        "normal",
        "must have exactly 3 values, got 4",
    );
}

#[test]
fn point_and_translation_of_four_values_are_refused() {
    length_error(
        "length-6",
        &SAMPLE_TOML.replace(
            "point = [0.0, 0.0, 800.0]",
            "point = [0.0, 0.0, 800.0, 1.0]",
        ),
        "point",
        "must have exactly 3 values, got 4",
    );
    length_error(
        "length-7",
        &SAMPLE_TOML.replace(
            "translation = [-200.0, 0.0, 30.0]",
            "translation = [-200.0, 0.0, 30.0, 0.0]",
        ),
        "translation",
        "must have exactly 3 values, got 4",
    );
}

#[test]
fn fourth_rotation_row_is_refused() {
    length_error(
        "length-8",
        &SAMPLE_TOML.replace(
            "[-0.25, 0.0, 0.9682458365518543]]",
            "[-0.25, 0.0, 0.9682458365518543], [0.0, 0.0, 0.0]]",
        ),
        "rotation",
        "must have exactly 3 rows, got 4",
    );
}

#[test]
fn rotation_row_of_four_values_is_refused() {
    length_error(
        "length-9",
        &SAMPLE_TOML.replace("[0.0, 1.0, 0.0], [-0.25", "[0.0, 1.0, 0.0, 0.0], [-0.25"),
        "rotation",
        "must have exactly 3 values per row, got 4",
    );
}

#[test]
fn depth_range_of_three_values_is_refused() {
    length_error(
        "length-10",
        &SAMPLE_TOML.replace(
            "depth_range = [650.0, 900.0]",
            "depth_range = [650.0, 900.0, 1000.0]",
        ),
        "depth_range",
        "must have exactly 2 values, got 3",
    );
}

#[test]
fn short_arrays_are_refused_naming_the_key() {
    length_error(
        "length-11",
        &SAMPLE_TOML.replace("depth_range = [650.0, 900.0]", "depth_range = [650.0]"),
        "depth_range",
        "must have exactly 2 values, got 1",
    );
    length_error(
        "length-12",
        &SAMPLE_TOML.replace(
            "distortion = [-0.12, 0.08, 0.0005, -0.0003, 0.0]",
            "distortion = [-0.12, 0.08, 0.0005, -0.0003]",
        ),
        "distortion",
        "must have exactly 5 values, got 4",
    );
}

#[test]
fn a_margin_round_trips_and_is_bounded() {
    let d = scratch("margin");
    let p = d.join("calib.toml");
    let mut c = sample();
    c.reference.as_mut().unwrap().margin = Some([12, 3, 0, 7]);
    c.save(&p).unwrap();
    let text = fs::read_to_string(&p).unwrap();
    assert!(text.contains("margin = [12, 3, 0, 7]"), "{text}");
    assert_eq!(Calibration::load(&p).unwrap(), c);
    let big = text.replace("margin = [12, 3, 0, 7]", "margin = [12, 3, 5000, 7]");
    fs::write(&p, big).unwrap();
    let e = Calibration::load(&p).unwrap_err().to_string();
    assert!(
        e.contains("reference.margin") && e.contains("calib.toml"),
        "{e}"
    );
}

// --- [projector_response] ---------------------------------------------------------------------

#[test]
fn projector_response_round_trips_and_bad_tables_are_refused() {
    use fringe3d::io::calibration::ProjectorResponse;
    let dir = scratch("response");
    let path = dir.join("cal.toml");
    let mut c = sample();
    let levels: Vec<f64> = (0..=8).map(|k| k as f64 / 8.0).collect();
    c.projector_response = Some(ProjectorResponse {
        response: levels.iter().map(|x: &f64| x.powf(2.2)).collect(),
        levels,
        gamma: 2.2,
    });
    c.save(&path).unwrap();
    let text = std::fs::read_to_string(&path).unwrap();
    assert!(text.contains("[projector_response]"), "{text}");
    assert_eq!(Calibration::load(&path).unwrap(), c);
    for (bad, what) in [
        ("response = [0.0, 0.5, 0.4, 1.0]", "must increase"),
        ("response = [0.0, 0.5, 0.9]", "same length"),
        ("response = [0.1, 0.5, 0.7, 1.0]", "from 0 to 1"),
    ] {
        let t = format!(
            "{}\n[projector_response]\ngamma = 2.0\nlevels = [0.0, 0.3, 0.6, 1.0]\n{bad}\n",
            std::fs::read_to_string(&path)
                .unwrap()
                .split("\n[projector_response]")
                .next()
                .unwrap()
        );
        let p = dir.join("bad.toml");
        std::fs::write(&p, t).unwrap();
        let e = Calibration::load(&p).unwrap_err().to_string();
        assert!(e.contains(what) && e.contains("bad.toml"), "{bad}: {e}");
    }
}
