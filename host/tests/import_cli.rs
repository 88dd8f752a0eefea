//! `fringe3d calibrate import` / `export` and `info` through the binary on a small rendered
//! dataset: export → import gives the same calibration exactly and bit-identical points; an
//! SLStudio file written here by hand from the dataset's true rig scans like the native file; the
//! imported file makes a virtual reference; bad inputs give one clear error and write nothing;
//! `calibrate projector`/`reference` name a missing input with the option that fixes it.

use fringe3d::cli::common;
use fringe3d::io::calibration::Calibration;
use fringe3d::scan::{PointCloud, ScanCalibration};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use crate::cli_support::{Tmp, fringe3d, run, s, virtual_reference_with};

/// The command fails with one error line holding every `must`.
fn fails(args: &[&str], must: &[&str]) -> String {
    let out = fringe3d(args);
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(!out.status.success(), "{args:?} succeeded");
    for m in must {
        assert!(err.contains(m), "{args:?}: `{m}` not in: {err}");
    }
    err
}

fn render(dir: &Path) {
    run(&[
        "render",
        "-q",
        "--scene",
        "sphere",
        "--size",
        "160x128",
        "--out",
        s(dir),
    ]);
}

/// The cloud of the dataset `ds` with `calibration` (the library path of `fringe3d scan`).
fn cloud(ds: &Path, calibration: &Path) -> PointCloud {
    let ls = common::load_set(&ds.join("patterns.toml")).unwrap();
    let cal = ScanCalibration::load(calibration, ls.set.axis()).unwrap();
    let imgs = common::load_images(&ls, &[], true).unwrap();
    let d = common::decode(&ls.set, &imgs, common::decode_config(&imgs)).unwrap();
    cal.reconstruct(&d.phase, &d.validity, true).unwrap()
}

/// `imported` with the native calibration's reference, saved beside it (its map resolves).
fn with_reference(ds: &Path, imported: &Path, name: &str) -> PathBuf {
    let native = Calibration::load(&ds.join("calibration.toml")).unwrap();
    let mut c = Calibration::load(imported).unwrap();
    assert!(c.reference.is_none());
    c.reference = native.reference.clone();
    let p = ds.join(name);
    c.save(&p).unwrap();
    p
}

fn xml_mat(s: &mut String, key: &str, rows: usize, cols: usize, v: &[f64]) {
    let p: Vec<String> = v.iter().map(|x| format!("{x:?}")).collect();
    let _ = writeln!(
        s,
        "<{key} type_id=\"opencv-matrix\"><rows>{rows}</rows><cols>{cols}</cols><dt>d</dt>\n<data>{}</data></{key}>",
        p.join(" ")
    );
}

/// SLStudio's calibration.xml of a calibration's rig, the convention applied here:
/// `Rp = Rᵀ`, `Tp = −Rᵀ·P` for fringe3d's `X_cam = R·X_proj + P`.
fn slstudio_xml(c: &Calibration, sizes: bool) -> String {
    let pr = c.projector.as_ref().unwrap();
    let r = pr.rotation;
    let rp: Vec<f64> = (0..9).map(|k| r[k % 3][k / 3]).collect();
    let p = c.projector_centre;
    let tp: Vec<f64> = (0..3)
        .map(|i| -(rp[3 * i] * p[0] + rp[3 * i + 1] * p[1] + rp[3 * i + 2] * p[2]))
        .collect();
    let k = |c: &fringe3d::io::calibration::CameraParams| {
        [c.fx, c.skew * c.fx, c.cx, 0.0, c.fy, c.cy, 0.0, 0.0, 1.0]
    };
    let mut s = String::from("<?xml version=\"1.0\"?>\n<opencv_storage>\n");
    xml_mat(&mut s, "Kc", 3, 3, &k(&c.camera));
    xml_mat(&mut s, "kc", 5, 1, &c.camera.distortion.to_array());
    xml_mat(&mut s, "Kp", 3, 3, &k(&pr.intrinsics));
    xml_mat(&mut s, "kp", 5, 1, &pr.intrinsics.distortion.to_array());
    xml_mat(&mut s, "Rp", 3, 3, &rp);
    xml_mat(&mut s, "Tp", 3, 1, &tp);
    let _ = writeln!(
        s,
        "<frameWidth>{}</frameWidth><frameHeight>{}</frameHeight>",
        c.camera.width, c.camera.height
    );
    if sizes {
        let _ = writeln!(
            s,
            "<screenResX>{}</screenResX><screenResY>{}</screenResY>",
            pr.intrinsics.width, pr.intrinsics.height
        );
    }
    s.push_str("</opencv_storage>\n");
    s
}

#[test]
fn export_import_scan_and_a_virtual_reference() {
    let t = Tmp::new("impcli-roundtrip");
    let ds = t.0.join("ds");
    render(&ds);
    let native_path = ds.join("calibration.toml");
    let native = Calibration::load(&native_path).unwrap();

    // export → import: the same calibration, exactly (bar the reference, which is not exported).
    let yml = t.0.join("out/stereo.yml");
    run(&["calibrate", "export", "-q", s(&native_path), "-o", s(&yml)]);
    let imp = t.0.join("imp/calibration.toml");
    run(&["calibrate", "import", "-q", s(&yml), "-o", s(&imp)]);
    let back = Calibration::load(&imp).unwrap();
    assert!(back.reference.is_none());
    assert_eq!(back.camera, native.camera);
    assert_eq!(back.projector, native.projector);
    assert_eq!(back.projector_centre, native.projector_centre);
    assert_eq!(back.depth_range, native.depth_range);
    // Scans with the native and the imported file (the native reference added): bit-identical.
    let a = cloud(&ds, &native_path);
    let b = cloud(&ds, &with_reference(&ds, &imp, "imported.toml"));
    assert!(a.xyz.iter().filter(|x| x.is_finite()).count() > 1000);
    assert_eq!(a.validity, b.validity);
    assert!(
        a.xyz
            .iter()
            .zip(&b.xyz)
            .all(|(x, y)| x.to_bits() == y.to_bits())
    );

    // SLStudio, written here from the true rig: P comes back to rounding, the points to well
    // under a micrometre.
    let xml = t.0.join("calibration.xml");
    std::fs::write(&xml, slstudio_xml(&native, true)).unwrap();
    let imp_sl = t.0.join("sl/calibration.toml");
    let text = run(&[
        "calibrate",
        "import",
        s(&xml),
        "--depth-range",
        "450,750",
        "-o",
        s(&imp_sl),
    ]);
    assert!(
        text.contains("slstudio") && text.contains("calibrate reference"),
        "{text}"
    );
    let sl = Calibration::load(&imp_sl).unwrap();
    assert_eq!(sl.camera, native.camera);
    let (p, q) = (sl.projector_centre, native.projector_centre);
    for i in 0..3 {
        assert!((p[i] - q[i]).abs() <= 1e-9 * 300.0, "P {p:?} vs {q:?}");
    }
    let c = cloud(&ds, &with_reference(&ds, &imp_sl, "imported_sl.toml"));
    assert_eq!(a.validity, c.validity);
    let worst = a
        .xyz
        .iter()
        .zip(&c.xyz)
        .filter(|(x, _)| x.is_finite())
        .map(|(x, y)| (x - y).abs())
        .fold(0.0f32, f32::max);
    assert!(worst <= 1e-3, "points differ by {worst} mm");

    // The imported file makes a virtual reference (it has [projector]); the plane given with
    // negative coordinates, as `--plane-point -10,5,600` (no `=`).
    let patterns = ds.join("patterns.toml");
    let virt = t.0.join("virt/calibration.toml");
    virtual_reference_with(
        &patterns,
        &imp,
        &virt,
        &["--plane-point", "-10,5,600", "--plane-normal", "-0.05,0,-1"],
    );
    let v = Calibration::load(&virt).unwrap();
    let r = v.reference.as_ref().unwrap();
    assert!(r.point[0] == -10.0 && r.normal[0] < 0.0, "{:?}", r);
    assert!(t.0.join("virt/reference_phase.tif").is_file());

    // `info` of the foreign file and of the calibrations.
    let j: serde_json::Value = serde_json::from_str(&run(&["info", "--json", s(&yml)])).unwrap();
    assert_eq!(j["format"], "opencv");
    let baseline = j["baseline_mm"].as_f64().unwrap();
    let n = (q[0] * q[0] + q[1] * q[1] + q[2] * q[2]).sqrt();
    assert!((baseline - n).abs() < 1e-9 * n);
    assert_eq!(j["projector"]["width"], 1024);
    let j: serde_json::Value = serde_json::from_str(&run(&["info", "--json", s(&xml)])).unwrap();
    assert_eq!(j["format"], "slstudio");
    let j: serde_json::Value = serde_json::from_str(&run(&["info", "--json", s(&imp)])).unwrap();
    assert_eq!(j["reference_present"], false);
    assert_eq!(j["projector_model_present"], true);
    let j: serde_json::Value = serde_json::from_str(&run(&["info", "--json", s(&virt)])).unwrap();
    assert_eq!(j["reference_present"], true);
}

#[test]
fn bad_imports_are_one_clear_error_and_nothing_written() {
    let t = Tmp::new("impcli-bad");
    let ds = t.0.join("ds");
    run(&[
        "render",
        "-q",
        "--scene",
        "plane",
        "--size",
        "96x80",
        "--out",
        s(&ds),
    ]);
    let native = Calibration::load(&ds.join("calibration.toml")).unwrap();
    let out_dir = t.0.join("out");
    let out = out_dir.join("calibration.toml");
    let o = s(&out);
    let good = slstudio_xml(&native, true);
    let write = |name: &str, text: &str| -> PathBuf {
        let p = t.0.join(name);
        std::fs::write(&p, text).unwrap();
        p
    };
    // Positive control.
    let f = write("good.xml", &good);
    run(&[
        "calibrate",
        "import",
        "-q",
        s(&f),
        "--depth-range",
        "450,750",
        "-o",
        s(&t.0.join("ok.toml")),
    ]);

    let no_tp = write(
        "no_tp.xml",
        &good.replace("<Tp ", "<Tq ").replace("</Tp>", "</Tq>"),
    );
    fails(
        &[
            "calibrate",
            "import",
            s(&no_tp),
            "--depth-range",
            "450,750",
            "-o",
            o,
        ],
        &["no_tp.xml", "no Tp"],
    );
    let no_size = write("no_size.xml", &slstudio_xml(&native, false));
    fails(
        &[
            "calibrate",
            "import",
            s(&no_size),
            "--depth-range",
            "450,750",
            "-o",
            o,
        ],
        &["no_size.xml", "screenResX", "--projector-size"],
    );
    fails(
        &["calibrate", "import", s(&f), "-o", o],
        &["good.xml", "--depth-range"],
    );
    let out_fmt = fails(
        &["calibrate", "import", s(&f), "--format", "zemax", "-o", o],
        &["unknown calibration format", "zemax"],
    );
    assert!(out_fmt.contains("--format"), "{out_fmt}");
    fails(
        &[
            "calibrate",
            "import",
            s(&f),
            "--format",
            "slmaster",
            "--depth-range",
            "450,750",
            "-o",
            o,
        ],
        &["good.xml", "no M1"],
    );
    fails(
        &[
            "calibrate",
            "import",
            s(&ds.join("calibration.toml")),
            "-o",
            o,
        ],
        &["a fringe3d calibration already"],
    );
    // Export of a calibration without [projector].
    let text = std::fs::read_to_string(ds.join("calibration.toml")).unwrap();
    let cut = text.find("[projector").unwrap();
    let bare = write("bare.toml", &text[..cut]);
    fails(
        &[
            "calibrate",
            "export",
            s(&bare),
            "-o",
            s(&out_dir.join("stereo.yml")),
        ],
        &["bare.toml", "[projector]"],
    );
    assert!(!out_dir.exists(), "something was written");
}

#[test]
fn missing_calibration_inputs_are_named_with_the_option_that_fixes_them() {
    let t = Tmp::new("impcli-inputs");
    let plates: Vec<PathBuf> = (0..2).map(|k| t.0.join(format!("plate_{k:02}"))).collect();
    for p in &plates {
        std::fs::create_dir_all(p.join("h")).unwrap();
    }
    let cam = t.0.join("camera.yml");
    let base = |extra: &[&str]| -> Vec<String> {
        let mut a: Vec<String> = ["calibrate", "projector", s(&plates[0]), s(&plates[1])]
            .iter()
            .map(|x| x.to_string())
            .collect();
        a.extend(["--camera-from", s(&cam), "--board", "9x7", "--square", "30"].map(String::from));
        a.extend(extra.iter().map(|x| x.to_string()));
        a
    };
    let refs = |v: &[String]| -> Vec<String> { v.to_vec() };
    let call = |v: Vec<String>, must: &[&str]| {
        let r: Vec<&str> = v.iter().map(String::as_str).collect();
        fails(&r, must)
    };
    call(refs(&base(&[])), &["patterns_v.toml", "--patterns-v"]);
    std::fs::write(t.0.join("patterns_v.toml"), "").unwrap();
    call(refs(&base(&[])), &["patterns_h.toml", "--patterns-h"]);
    std::fs::write(t.0.join("patterns_h.toml"), "").unwrap();
    call(
        refs(&base(&[])),
        &["plate_00", "no v/ folder", "--patterns-v"],
    );
    call(
        refs(&base(&["--patterns-v", s(&t.0.join("nope.toml"))])),
        &["--patterns-v", "nope.toml", "no such pattern-set file"],
    );
    fails(
        &[
            "calibrate",
            "reference",
            "--virtual",
            "--patterns",
            s(&t.0.join("missing.toml")),
            "--calibration",
            s(&cam),
        ],
        &["--patterns", "missing.toml"],
    );
    assert!(!t.0.join("calibration.toml").exists());
}
