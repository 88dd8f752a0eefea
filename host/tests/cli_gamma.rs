//! Projector gamma through the binary, as a user meets it: a rendered rig whose projector has a
//! gamma of 2.2, its gray captures (`[projector] gray_levels`), `fringe3d calibrate gamma`, then
//! `scan`/`decode` with the measured response, and `patterns --gray` / `--response`. Truth: the
//! renderer's points, and the same rig with a linear projector.

use fringe3d::accuracy;
use fringe3d::cli::common;
use fringe3d::io::calibration::Calibration;
use fringe3d::io::image::{Pixels, read_gray};
use fringe3d::render::{Overrides, SceneSpec};
use fringe3d::scan::ScanCalibration;
use std::path::{Path, PathBuf};

use crate::cli_support::{Tmp, fringe3d, run, s};

/// Render the tilted plane (640 × 512, 8-bit camera, σ = 1, 8-bit patterns) with `gamma`.
fn render(dir: &Path, name: &str, gamma: f64, gray: u32) -> PathBuf {
    let mut spec = SceneSpec::builtin("plane").unwrap();
    spec.apply(&Overrides {
        size: Some((640, 512)),
        bits: Some(8),
        noise: Some(1.0),
        pattern_bits: Some(8),
        ..Default::default()
    });
    spec.projector.gamma = gamma;
    spec.projector.black_level = if gamma == 1.0 { 0.0 } else { 0.02 };
    spec.projector.gray_levels = gray;
    let scene = dir.join(format!("{name}.toml"));
    std::fs::write(&scene, spec.to_toml().unwrap()).unwrap();
    let out = dir.join(name);
    run(&["render", "-q", "--scene", s(&scene), "--out", s(&out)]);
    out
}

/// Interior RMS error (mm) and interior point count of `fringe3d scan` of `ds` with
/// `calibration`, computed by the library path the command runs (gamma table included).
fn scan_accuracy(ds: &Path, calibration: &Path) -> (f64, usize) {
    let out = ds.join("cloud.ply");
    run(&[
        "scan",
        "-q",
        "-p",
        s(&ds.join("patterns.toml")),
        "-c",
        s(calibration),
        s(ds),
        "-o",
        s(&out),
    ]);
    let ls = common::load_set(&ds.join("patterns.toml")).unwrap();
    let cal = ScanCalibration::load(calibration, ls.set.axis()).unwrap();
    let imgs = common::load_images(&ls, &[], true).unwrap();
    let corr = common::response_correction(&cal.calibration, calibration, &ls).unwrap();
    let d = common::decode_corrected(&ls.set, &imgs, common::decode_config(&imgs), corr.as_ref())
        .unwrap();
    let cloud = cal.reconstruct(&d.phase, &d.validity, true).unwrap();
    let acc = accuracy::evaluate(&cloud, &accuracy::load_truth(ds).unwrap()).unwrap();
    (acc.interior.rms, acc.interior.count)
}

#[test]
fn measured_gamma_makes_scans_as_good_as_a_linear_projector() {
    let tmp = Tmp::new("cli-gamma");
    let lin = render(&tmp.0, "linear", 1.0, 0);
    let gam = render(&tmp.0, "gamma", 2.2, 17);
    assert!(gam.join("gray/gray_16.png").is_file());

    // A user's calibration before `calibrate gamma`: the true rig without the response.
    let mut cal = Calibration::load(&gam.join("calibration.toml")).unwrap();
    assert!(
        cal.projector_response.is_some(),
        "the true calibration records the response"
    );
    cal.projector_response = None;
    let before = gam.join("before.toml");
    cal.save(&before).unwrap();
    let measured = gam.join("measured.toml");
    let json = run(&[
        "--json",
        "calibrate",
        "gamma",
        "-c",
        s(&before),
        s(&gam.join("gray")),
        "-p",
        s(&gam.join("patterns.toml")),
        "-o",
        s(&measured),
    ]);
    let v: serde_json::Value = serde_json::from_str(&json).unwrap();
    let g = v["gamma"].as_f64().unwrap();
    assert!((g - 2.2).abs() < 0.05, "measured gamma {g}");
    let levels = v["phase_error"].as_array().unwrap();
    assert!(levels[0]["rms_rad"].as_f64().unwrap() > 0.1, "{json}");
    assert!(
        Calibration::load(&before)
            .unwrap()
            .projector_response
            .is_none(),
        "-o leaves -c alone"
    );

    let (lin_rms, lin_n) = scan_accuracy(&lin, &lin.join("calibration.toml"));
    let (raw_rms, raw_n) = scan_accuracy(&gam, &before);
    let (rms, n) = scan_accuracy(&gam, &measured);
    eprintln!(
        "linear {lin_rms:.4} mm ({lin_n}), uncorrected {raw_rms:.4} ({raw_n}), measured gamma {rms:.4} ({n})"
    );
    assert!(rms <= 1.15 * lin_rms, "{rms} mm vs linear {lin_rms}");
    assert!(
        n as f64 >= 0.995 * lin_n as f64,
        "{n} points vs linear {lin_n}"
    );
    assert!(
        raw_n as f64 <= 0.9 * lin_n as f64 || raw_rms > 1.3 * lin_rms,
        "uncorrected: {raw_rms} mm, {raw_n} points"
    );

    // `decode -c` applies the same table; without -c it does not.
    let patterns = gam.join("patterns.toml");
    for (flag, dir) in [(true, "dec_c"), (false, "dec")] {
        let out = gam.join(dir);
        let mut args = vec!["decode", "-q", "-p", s(&patterns), s(&gam), "-o", s(&out)];
        if flag {
            args.extend(["-c", s(&measured)]);
        }
        run(&args);
    }
    let valid = |d: &str| -> usize {
        let (img, _) = read_gray(&gam.join(d).join("validity.png")).unwrap();
        match img.pixels {
            Pixels::U8(v) => v.iter().filter(|&&c| c == 0).count(),
            _ => panic!("8-bit validity"),
        }
    };
    assert!(
        valid("dec_c") > valid("dec"),
        "decode -c must recover pixels"
    );

    // Without gray captures: γ from the scan's own fringe images (`--fringes`), and the scan
    // with it as good as with the gray levels' response.
    let from_fringes = gam.join("fringes.toml");
    let json = run(&[
        "--json",
        "calibrate",
        "gamma",
        "--fringes",
        "-c",
        s(&before),
        "-p",
        s(&patterns),
        s(&gam),
        "-o",
        s(&from_fringes),
    ]);
    let v: serde_json::Value = serde_json::from_str(&json).unwrap();
    let g = v["gamma"].as_f64().unwrap();
    assert!((g - 2.2).abs() < 0.05, "gamma from the fringes {g}");
    assert_eq!(v["from"], "fringes");
    let (f_rms, f_n) = scan_accuracy(&gam, &from_fringes);
    eprintln!("gamma {g:.4} from the fringes: {f_rms:.4} mm ({f_n})");
    assert!(f_rms <= 1.15 * lin_rms, "{f_rms} mm vs linear {lin_rms}");
    assert!(f_n as f64 >= 0.995 * lin_n as f64);
    // The gray captures are not fringes of the set: refused, naming them.
    let e = fringe3d(&[
        "calibrate",
        "gamma",
        "--fringes",
        "-c",
        s(&before),
        "-p",
        s(&patterns),
        s(&gam.join("gray")),
        "-o",
        s(&gam.join("bad.toml")),
    ]);
    assert!(!e.status.success());
    let err = String::from_utf8_lossy(&e.stderr);
    assert!(err.contains("gray"), "{err}");
    assert!(!gam.join("bad.toml").exists(), "nothing written");
}

#[test]
fn patterns_write_gray_levels_and_predistorted_sets() {
    let tmp = Tmp::new("cli-gamma-patterns");
    let set = tmp.0.join("set.toml");
    std::fs::write(&set, "version = 1\n[projector]\nwidth = 256\nheight = 8\n").unwrap();
    let gray = tmp.0.join("gray");
    run(&[
        "patterns",
        "-q",
        "-p",
        s(&set),
        "--gray",
        "5",
        "-o",
        s(&gray),
    ]);
    for (k, code) in [0u8, 64, 128, 191, 255].iter().enumerate() {
        let (img, _) = read_gray(&gray.join(format!("gray_{k:02}.png"))).unwrap();
        let Pixels::U8(v) = img.pixels else { panic!() };
        assert!(v.iter().all(|c| c == code), "gray_{k:02}: {:?}", &v[..4]);
    }
    // A calibration with a response r(x) = x²: codes through its inverse, √x.
    let tmp_ds = tmp.0.join("cal.toml");
    let mut cal = Calibration::load(
        &Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples/calibration/calib.toml"),
    )
    .unwrap();
    cal.reference = None;
    cal.projector_response = Some(fringe3d::response::power_law(2.0));
    cal.save(&tmp_ds).unwrap();
    let plain = tmp.0.join("plain");
    let pre = tmp.0.join("pre");
    run(&["patterns", "-q", "-p", s(&set), "-o", s(&plain)]);
    run(&[
        "patterns",
        "-q",
        "-p",
        s(&set),
        "--response",
        s(&tmp_ds),
        "-o",
        s(&pre),
    ]);
    let (a, _) = read_gray(&plain.join("pattern_07.png")).unwrap();
    let (b, _) = read_gray(&pre.join("pattern_07.png")).unwrap();
    let (Pixels::U8(a), Pixels::U8(b)) = (a.pixels, b.pixels) else {
        panic!()
    };
    for (x, y) in a.iter().zip(&b) {
        let want = ((*x as f64 / 255.0).sqrt() * 255.0).round();
        assert!(
            (*y as f64 - want).abs() <= 1.0,
            "code {x} -> {y}, want {want}"
        );
    }
    let text = std::fs::read_to_string(pre.join("patterns.toml")).unwrap();
    assert!(text.contains("response_compensated = true"), "{text}");
    // A head cannot render pre-distorted patterns itself: `device upload` refuses them before
    // touching the port. The response's table does travel (DefineCorrection, protocol 4): a
    // calibration with a response is not refused for it (this one has no reference, which is
    // what stops the upload, before the port too).
    let port = tmp.0.join("no-such-port");
    let out = fringe3d(&[
        "device",
        "upload",
        "--port",
        s(&port),
        "-p",
        s(&pre.join("patterns.toml")),
    ]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && err.contains("--images"), "{err}");
    let out = fringe3d(&[
        "device",
        "upload",
        "--port",
        s(&port),
        "-p",
        s(&set),
        "-c",
        s(&tmp_ds),
    ]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && !err.contains("projector_response") && err.contains("[reference]"),
        "{err}"
    );
    // A calibration without a response is refused, naming it.
    let out = fringe3d(&[
        "patterns",
        "-p",
        s(&set),
        "--response",
        s(&set),
        "-o",
        s(&tmp.0.join("x")),
    ]);
    assert!(!out.status.success());
    assert!(!tmp.0.join("x").exists(), "nothing written");
}
