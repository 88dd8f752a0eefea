//! Full-calibration imports against a known rig: the skewed rig of `examples/scenes` (skew and
//! distortion on both devices, a projector off to the side, turned) is written BY HAND in each
//! foreign format — the stereo convention `x_p = R·x_c + T` applied here, independently of the
//! importer and the exporter — then imported; camera, projector and P must come back to 1e-9.
//! Bad inputs give one error naming the file and the key.

use fringe3d::io::import::{ForeignKind, ImportedRig};
use fringe3d::io::import::{RigFormat, RigSizes, detect, import_any_camera, import_rig};
use fringe3d::render::Scene;
use fringe3d::render::rig::Rig;
use fringe3d::render::scene::SceneSpec;
use fringe3d_core::params::CameraParams;
use std::fmt::Write as _;
use std::path::Path;

use crate::cli_support::Tmp;

fn truth() -> Rig {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples/scenes/skewed_rig.toml");
    let spec = SceneSpec::load(&p).unwrap();
    Scene::new(spec, p.parent()).unwrap().rig
}

/// The stereo pose of the rig in OpenCV's convention, computed here: with
/// `X_cam = Rr·X_proj + P`, a camera-frame point maps to `X_proj = Rrᵀ·X_cam − Rrᵀ·P`.
fn stereo_pose(rig: &Rig) -> ([[f64; 3]; 3], [f64; 3]) {
    let rr = rig.rotation;
    let mut r = [[0.0; 3]; 3];
    for (i, row) in r.iter_mut().enumerate() {
        for (j, x) in row.iter_mut().enumerate() {
            *x = rr[j][i];
        }
    }
    let p = rig.translation;
    let t = [0, 1, 2].map(|i| -(r[i][0] * p[0] + r[i][1] * p[1] + r[i][2] * p[2]));
    (r, t)
}

/// The Rodrigues vector of a rotation (axis·angle), by the textbook formula.
fn rodrigues_vector(r: &[[f64; 3]; 3]) -> [f64; 3] {
    let c = ((r[0][0] + r[1][1] + r[2][2] - 1.0) / 2.0).clamp(-1.0, 1.0);
    let th = c.acos();
    let s = th.sin();
    let f = th / (2.0 * s);
    [
        (r[2][1] - r[1][2]) * f,
        (r[0][2] - r[2][0]) * f,
        (r[1][0] - r[0][1]) * f,
    ]
}

fn k(c: &CameraParams) -> [f64; 9] {
    [c.fx, c.skew * c.fx, c.cx, 0.0, c.fy, c.cy, 0.0, 0.0, 1.0]
}

fn list(v: &[f64]) -> String {
    let p: Vec<String> = v.iter().map(|x| format!("{x:e}")).collect();
    p.join(", ")
}

fn flat(r: &[[f64; 3]; 3]) -> Vec<f64> {
    r.iter().flatten().copied().collect()
}

fn yml_mat(s: &mut String, key: &str, rows: usize, cols: usize, v: &[f64]) {
    let _ = writeln!(
        s,
        "{key}: !!opencv-matrix\n   rows: {rows}\n   cols: {cols}\n   dt: d\n   data: [ {} ]",
        list(v)
    );
}

fn xml_mat(s: &mut String, key: &str, rows: usize, cols: usize, v: &[f64]) {
    let p: Vec<String> = v.iter().map(|x| format!("{x:e}")).collect();
    let _ = writeln!(
        s,
        "<{key} type_id=\"opencv-matrix\">\n  <rows>{rows}</rows>\n  <cols>{cols}</cols>\n  <dt>d</dt>\n  <data>\n    {}</data></{key}>",
        p.join(" ")
    );
}

fn close(a: f64, b: f64, what: &str) {
    assert!(
        (a - b).abs() <= 1e-9 * a.abs().max(b.abs()).max(1.0),
        "{what}: {a} vs {b}"
    );
}

fn same_camera(a: &CameraParams, b: &CameraParams, what: &str) {
    assert_eq!((a.width, a.height), (b.width, b.height), "{what} size");
    close(a.fx, b.fx, what);
    close(a.fy, b.fy, what);
    close(a.cx, b.cx, what);
    close(a.cy, b.cy, what);
    close(a.skew, b.skew, what);
    for (x, y) in a.distortion.to_array().iter().zip(b.distortion.to_array()) {
        close(*x, y, what);
    }
}

fn check(rig: &Rig, got: &ImportedRig, format: RigFormat) {
    let what = format.name();
    assert_eq!(got.format, format);
    same_camera(&rig.camera, &got.camera, &format!("{what} camera"));
    same_camera(
        &rig.projector,
        &got.projector.intrinsics,
        &format!("{what} projector"),
    );
    for i in 0..3 {
        for j in 0..3 {
            close(
                rig.rotation[i][j],
                got.projector.rotation[i][j],
                &format!("{what} R[{i}][{j}]"),
            );
        }
        // P to 1e-9 relative to its length.
        let p = rig.translation;
        let n = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
        let d = (got.projector_centre()[i] - p[i]).abs();
        assert!(
            d <= 1e-9 * n,
            "{what} P[{i}]: {:?} vs {p:?}",
            got.projector_centre()
        );
    }
}

fn opencv_yaml(rig: &Rig) -> String {
    let (r, t) = stereo_pose(rig);
    let (c, p) = (&rig.camera, &rig.projector);
    let mut s = format!(
        "%YAML:1.0\n---\nimage_width: {}\nimage_height: {}\nprojector_width: {}\nprojector_height: {}\n",
        c.width, c.height, p.width, p.height
    );
    yml_mat(&mut s, "M1", 3, 3, &k(c));
    yml_mat(&mut s, "D1", 1, 5, &c.distortion.to_array());
    yml_mat(&mut s, "M2", 3, 3, &k(p));
    yml_mat(&mut s, "D2", 5, 1, &p.distortion.to_array());
    yml_mat(&mut s, "R", 3, 3, &flat(&r));
    yml_mat(&mut s, "T", 3, 1, &t);
    // What stereoRectify adds: ignored.
    yml_mat(&mut s, "Q", 1, 2, &[1.0, 2.0]);
    s
}

#[test]
fn every_format_reproduces_the_rig() {
    let t = Tmp::new("import-formats");
    let rig = truth();
    let (r, tv) = stereo_pose(&rig);
    let (c, p) = (&rig.camera, &rig.projector);
    let mut pad8 = p.distortion.to_array().to_vec();
    pad8.extend([0.0; 3]);

    // OpenCV YAML, M1/D1/M2/D2/R/T, sizes in the file.
    let f = t.0.join("stereo.yml");
    std::fs::write(&f, opencv_yaml(&rig)).unwrap();
    check(
        &rig,
        &import_rig(&f, None, RigSizes::default()).unwrap(),
        RigFormat::OpenCv,
    );
    // `--camera-from` takes camera 1.
    same_camera(
        &rig.camera,
        &import_any_camera(&f, None).unwrap(),
        "opencv camera-from",
    );
    // ... also of a camera-only file with the stereo names (M1, D1).
    let text = opencv_yaml(&rig);
    let g = t.0.join("camera_m1.yml");
    std::fs::write(&g, &text[..text.find("M2:").unwrap()]).unwrap();
    same_camera(
        &rig.camera,
        &import_any_camera(&g, None).unwrap(),
        "M1/D1 camera file",
    );

    // OpenCV XML, cameraMatrix1/..., an 8-coefficient D2 with zero k4..k6, sizes from options.
    let mut s = String::from("<?xml version=\"1.0\"?>\n<opencv_storage>\n");
    xml_mat(&mut s, "cameraMatrix1", 3, 3, &k(c));
    xml_mat(&mut s, "distCoeffs1", 1, 5, &c.distortion.to_array());
    xml_mat(&mut s, "cameraMatrix2", 3, 3, &k(p));
    xml_mat(&mut s, "distCoeffs2", 1, 8, &pad8);
    xml_mat(&mut s, "R", 3, 3, &flat(&r));
    xml_mat(&mut s, "T", 3, 1, &tv);
    s.push_str("</opencv_storage>\n");
    let f = t.0.join("stereo.xml");
    std::fs::write(&f, &s).unwrap();
    let sizes = RigSizes {
        camera: Some((c.width, c.height)),
        projector: Some((p.width, p.height)),
    };
    check(
        &rig,
        &import_rig(&f, None, sizes).unwrap(),
        RigFormat::OpenCv,
    );

    // OpenCV JSON with nested camera / projector maps.
    let j = serde_json::json!({
        "camera": {"camera_matrix": {"type_id": "opencv-matrix", "rows": 3, "cols": 3, "dt": "d", "data": k(c)},
                   "distortion_coefficients": c.distortion.to_array(),
                   "image_width": c.width, "image_height": c.height},
        "projector": {"camera_matrix": k(p), "distortion_coefficients": p.distortion.to_array(),
                   "image_width": p.width, "image_height": p.height},
        "R": flat(&r), "T": tv,
    });
    let f = t.0.join("stereo.json");
    std::fs::write(&f, serde_json::to_string_pretty(&j).unwrap()).unwrap();
    check(
        &rig,
        &import_rig(&f, None, RigSizes::default()).unwrap(),
        RigFormat::OpenCv,
    );

    // SLStudio calibration.xml (CalibrationData::saveXML's keys).
    let mut s = String::from("<?xml version=\"1.0\"?>\n<opencv_storage>\n");
    xml_mat(&mut s, "Kc", 3, 3, &k(c));
    xml_mat(&mut s, "kc", 5, 1, &c.distortion.to_array());
    xml_mat(&mut s, "Kp", 3, 3, &k(p));
    xml_mat(&mut s, "kp", 5, 1, &p.distortion.to_array());
    xml_mat(&mut s, "Rp", 3, 3, &flat(&r));
    xml_mat(&mut s, "Tp", 3, 1, &tv);
    let _ = write!(
        s,
        "<cam_error>0.1</cam_error>\n<proj_error>0.2</proj_error>\n<stereo_error>0.3</stereo_error>\n\
         <frameWidth>{}</frameWidth>\n<frameHeight>{}</frameHeight>\n<screenResX>{}</screenResX>\n<screenResY>{}</screenResY>\n</opencv_storage>\n",
        c.width, c.height, p.width, p.height
    );
    let f = t.0.join("calibration.xml");
    std::fs::write(&f, &s).unwrap();
    check(
        &rig,
        &import_rig(&f, None, RigSizes::default()).unwrap(),
        RigFormat::SlStudio,
    );

    // SLMaster caliInfo.yml: S = camera size, Rlp as a Rodrigues vector (older versions), the
    // projector's size from the option.
    let mut s = String::from("%YAML:1.0\n---\n");
    yml_mat(&mut s, "M1", 3, 3, &k(c));
    yml_mat(&mut s, "D1", 1, 5, &c.distortion.to_array());
    yml_mat(
        &mut s,
        "S",
        2,
        1,
        &[f64::from(c.width), f64::from(c.height)],
    );
    yml_mat(&mut s, "M4", 3, 3, &k(p));
    yml_mat(&mut s, "D4", 1, 5, &p.distortion.to_array());
    yml_mat(&mut s, "Rlp", 3, 1, &rodrigues_vector(&r));
    yml_mat(&mut s, "Tlp", 3, 1, &tv);
    let f = t.0.join("caliInfo.yml");
    std::fs::write(&f, &s).unwrap();
    let proj_only = RigSizes {
        camera: None,
        projector: Some((p.width, p.height)),
    };
    check(
        &rig,
        &import_rig(&f, None, proj_only).unwrap(),
        RigFormat::SlMaster,
    );
    // ... and with Rlp as the 3x3 matrix.
    let s3 = s.replace(
        &format!(
            "Rlp: !!opencv-matrix\n   rows: 3\n   cols: 1\n   dt: d\n   data: [ {} ]",
            list(&rodrigues_vector(&r))
        ),
        &format!(
            "Rlp: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n   data: [ {} ]",
            list(&flat(&r))
        ),
    );
    assert_ne!(s3, s);
    std::fs::write(&f, &s3).unwrap();
    check(
        &rig,
        &import_rig(&f, None, proj_only).unwrap(),
        RigFormat::SlMaster,
    );

    // Bouguet's Calib_Results_stereo.m: left = camera, right = projector, om and T.
    let vec = |v: &[f64]| {
        let p: Vec<String> = v.iter().map(|x| format!("{x:e}")).collect();
        format!("[ {} ]", p.join(" ; "))
    };
    let mut s = String::from("% Intrinsic and Extrinsic Camera Parameters\n%\n");
    for (side, cam) in [("left", c), ("right", p)] {
        let _ = writeln!(
            s,
            "%-- Focal length:\nfc_{side} = {};",
            vec(&[cam.fx, cam.fy])
        );
        let _ = writeln!(s, "cc_{side} = {};", vec(&[cam.cx, cam.cy]));
        let _ = writeln!(s, "alpha_c_{side} = {:e};", cam.skew);
        let _ = writeln!(s, "kc_{side} = {};", vec(&cam.distortion.to_array()));
        let _ = writeln!(
            s,
            "KK_{side} = [{:e} {:e} {:e}; 0 {:e} {:e}; 0 0 1];",
            cam.fx,
            cam.skew * cam.fx,
            cam.cx,
            cam.fy,
            cam.cy
        );
    }
    let _ = writeln!(s, "om = {};\nT = {};", vec(&rodrigues_vector(&r)), vec(&tv));
    let _ = writeln!(s, "nx = {};\nny = {};", c.width, c.height);
    let f = t.0.join("Calib_Results_stereo.m");
    std::fs::write(&f, &s).unwrap();
    check(
        &rig,
        &import_rig(&f, None, proj_only).unwrap(),
        RigFormat::Bouguet,
    );
    // The camera alone, as `--camera-from` reads it.
    same_camera(
        &rig.camera,
        &import_any_camera(&f, None).unwrap(),
        "bouguet camera-from",
    );
    assert_eq!(
        detect(&f, None).unwrap(),
        ForeignKind::Rig(RigFormat::Bouguet)
    );
}

/// One error, naming the file and the key; `None` if it was accepted.
fn error(dir: &Path, name: &str, text: &str, sizes: RigSizes) -> String {
    let f = dir.join(name);
    std::fs::write(&f, text).unwrap();
    let e = import_rig(&f, None, sizes).expect_err(name).to_string();
    assert!(e.contains(name), "no file named: {e}");
    e
}

#[test]
fn bad_inputs_name_the_file_and_the_key() {
    let t = Tmp::new("import-bad");
    let rig = truth();
    let good = opencv_yaml(&rig);
    let none = RigSizes::default();
    // Positive control.
    let f = t.0.join("good.yml");
    std::fs::write(&f, &good).unwrap();
    assert!(import_rig(&f, None, none).is_ok());

    // A missing key.
    let cut = good.find("T: !!opencv-matrix").unwrap();
    let no_t = format!("{}{}", &good[..cut], &good[cut..].replacen("T:", "Tx:", 1));
    let e = error(&t.0, "no_t.yml", &no_t, none);
    assert!(e.contains("no T"), "{e}");
    // A wrong shape.
    let short_r = good.replace(
        "   rows: 3\n   cols: 3\n   dt: d\n   data: [ ",
        "   data: [ 0.5, ",
    );
    let e = error(&t.0, "short.yml", &short_r, none);
    assert!(e.contains("M1") && e.contains("10 values"), "{e}");
    // A rotation that is no rotation.
    let (r, _) = stereo_pose(&rig);
    let bad_r = good.replace(
        &list(&flat(&r)),
        &list(&[1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, -1.0]),
    );
    assert_ne!(bad_r, good);
    let e = error(&t.0, "reflect.yml", &bad_r, none);
    assert!(e.contains("R is a reflection"), "{e}");
    // A non-zero k4 (the rational model).
    let d2 = list(&rig.projector.distortion.to_array());
    let k4 = good.replace(
        &format!("D2: !!opencv-matrix\n   rows: 5\n   cols: 1\n   dt: d\n   data: [ {d2} ]"),
        &format!("D2: !!opencv-matrix\n   rows: 8\n   cols: 1\n   dt: d\n   data: [ {d2}, 0.01, 0.0, 0.0 ]"),
    );
    assert_ne!(k4, good);
    let e = error(&t.0, "k4.yml", &k4, none);
    assert!(e.contains("D2") && e.contains("k4 = 0.01"), "{e}");
    // The projector's size neither in the file nor given.
    let no_size = good
        .replace("projector_width", "pw")
        .replace("projector_height", "ph");
    let e = error(&t.0, "nosize.yml", &no_size, none);
    assert!(
        e.contains("projector image size") && e.contains("--projector-size"),
        "{e}"
    );
    // No known keys; the keys of two formats; a camera-only file.
    let e = error(&t.0, "other.yml", "%YAML:1.0\n---\nfoo: 1\n", none);
    assert!(e.contains("no calibration keys"), "{e}");
    let both = format!("{good}Kc: [1, 0, 0, 0, 1, 0, 0, 0, 1]\nKp: [1, 0, 0, 0, 1, 0, 0, 0, 1]\n");
    let e = error(&t.0, "both.yml", &both, none);
    assert!(
        e.contains("opencv, slstudio") && e.contains("--format"),
        "{e}"
    );
    let cam = "%YAML:1.0\n---\ncamera_matrix: [ 775., 0., 320.6, 0., 775., 254.1, 0., 0., 1. ]\ndistortion_coefficients: [0, 0, 0, 0, 0]\n";
    let e = error(&t.0, "camera.yml", cam, none);
    assert!(
        e.contains("no projector") && e.contains("--camera-from"),
        "{e}"
    );
    // SLMaster's two-camera file holds no projector.
    let bino = "%YAML:1.0\n---\nM1: [1, 0, 0, 0, 1, 0, 0, 0, 1]\nD1: [0, 0, 0, 0, 0]\nM2: [1, 0, 0, 0, 1, 0, 0, 0, 1]\nD2: [0, 0, 0, 0, 0]\nRlr: [1, 0, 0, 0, 1, 0, 0, 0, 1]\nTlr: [-100, 0, 0]\n";
    let e = error(&t.0, "bino.yml", bino, none);
    assert!(e.contains("two-camera") && e.contains("M4"), "{e}");
    // A forced format whose keys are absent.
    let f = t.0.join("forced.yml");
    std::fs::write(&f, &good).unwrap();
    let e = import_rig(&f, Some(RigFormat::SlStudio), none)
        .unwrap_err()
        .to_string();
    assert!(e.contains("forced.yml") && e.contains("no Kc"), "{e}");
    assert!(
        RigFormat::parse("zemax")
            .unwrap_err()
            .contains("unknown calibration format")
    );
}
