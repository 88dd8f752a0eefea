//! Issue #17's coverage bar through `fringe3d scan`: on scenes that fill the image down to the
//! near end of the depth range (a tilted plane, the freeform surface brought near the camera),
//! with a virtual reference on the default far plane and the margin the geometry needs, the scan
//! keeps ≥ 99.5 % of the interior pixels whose true point lies in the depth range, and none of
//! them is refused as "no-crossing"; so does the model fitted to a capture of the rig's own
//! reference plane, extended by the projector model (`--margin auto`). The same scans with an
//! image-sized map lose the near points whose crossing lies off the image (the margin's reason
//! to exist).

use fringe3d::cli::common;
use fringe3d::render::Scene;
use fringe3d::render::scene::Overrides;
use fringe3d::scan::{ScanCalibration, filter_edges};
use fringe3d_core::Validity;
use std::path::Path;

use crate::cli_support::{Tmp, render_noisy, run, s, virtual_reference, virtual_reference_with};

/// The default rig's scene head (camera, projector, patterns, reference) with `objects`.
fn scene_toml(objects: &str) -> String {
    let base = Scene::builtin("plane", &Overrides::default())
        .expect("builtin scene")
        .spec
        .to_toml()
        .expect("toml");
    let head = base.split("[[objects]]").next().expect("scene head");
    format!("{head}{objects}")
}

/// A plane tilted about 40° from facing the camera, towards the projector: its near corner at
/// about 465 mm (bottom left), its far one beyond the depth range (top right).
const TILTED: &str = r#"
[[objects]]
name = "near-plane"
albedo = 0.8
[objects.shape]
type = "plane"
point = [0.0, 0.0, 575.0]
normal = [0.6, -0.25, -0.76]
"#;

/// The built-in freeform surface 130 mm nearer the camera, so that it fills the image and its
/// bumps reach the near end of the depth range.
const FREEFORM_NEAR: &str = r#"
[[objects]]
name = "freeform-near"
albedo = 0.8
[objects.shape]
type = "height_field"
center = [0.0, 0.0, 530.0]
euler_deg = [190.0, -8.0, 0.0]
size = [400.0, 320.0]
base = 0.0
bumps = [[0.0, 0.0, 60.0, 45.0], [-80.0, 50.0, 35.0, 25.0], [85.0, -45.0, 40.0, 30.0], [70.0, 60.0, -25.0, 22.0], [-75.0, -55.0, 20.0, 18.0], [20.0, -70.0, 15.0, 12.0]]
"#;

/// What a scan kept of the pixels that count.
struct Coverage {
    /// Interior pixels (the renderer's mask 15: hit, on the DMD, lit, clean) whose true point's
    /// depth lies in the calibration's range.
    counted: usize,
    /// Of those, valid after the edge filter.
    valid: usize,
    /// Of those, refused as no-crossing.
    no_crossing: usize,
    /// The nearest true depth among them, mm.
    nearest: f64,
}

/// The library path of `fringe3d scan` (decode, reconstruct, the edge filter at 80°) on `ds` with
/// `calibration`, against the renderer's truth; the CLI's own count of points must agree.
fn coverage(ds: &Path, calibration: &Path, out: &Path) -> Coverage {
    let json = run(&[
        "scan",
        "-q",
        "--json",
        "--patterns",
        s(&ds.join("patterns.toml")),
        "--calibration",
        s(calibration),
        s(ds),
        "-o",
        s(out),
    ]);
    let cli_points =
        serde_json::from_str::<serde_json::Value>(&json).expect("scan --json")["points"]
            .as_u64()
            .expect("points");
    let ls = common::load_set(&ds.join("patterns.toml")).expect("pattern set");
    let cal = ScanCalibration::load(calibration, ls.set.axis()).expect("calibration");
    let imgs = common::load_images(&ls, &[], true).expect("images");
    // `scan`'s thresholds: 12σ of the calibration's measured noise, when it has one.
    let cfg = common::ThresholdArgs::default()
        .config(&ls.set, &imgs, cal.calibration.sensor.as_ref())
        .expect("thresholds");
    let d = common::decode(&ls.set, &imgs, cfg).expect("decode");
    let mut cloud = cal
        .reconstruct(&d.phase, &d.validity, true)
        .expect("reconstruct");
    filter_edges(&mut cloud, &cal.edge_filter(80.0).expect("filter"));
    assert_eq!(cloud.valid_count() as u64, cli_points, "CLI and library");
    let truth = fringe3d::io::npy::decode_f64(&std::fs::read(ds.join("truth/points.npy")).unwrap())
        .unwrap()
        .1;
    let (mask, _) = fringe3d::io::image::read_gray(&ds.join("truth/mask.png")).unwrap();
    let fringe3d::io::image::Pixels::U8(mask) = mask.pixels else {
        panic!("8-bit mask")
    };
    let [z0, z1] = fringe3d::io::calibration::Calibration::load(calibration)
        .unwrap()
        .depth_range;
    let mut c = Coverage {
        counted: 0,
        valid: 0,
        no_crossing: 0,
        nearest: f64::INFINITY,
    };
    for (i, m) in mask.iter().enumerate() {
        let z = truth[3 * i + 2];
        if *m != 15 || !(z0..=z1).contains(&z) {
            continue;
        }
        c.counted += 1;
        c.nearest = c.nearest.min(z);
        c.valid += usize::from(cloud.validity[i] == Validity::Valid as u8);
        c.no_crossing += usize::from(cloud.validity[i] == Validity::NoCrossing as u8);
    }
    c
}

#[test]
fn near_scenes_keep_their_interior_with_a_virtual_reference() {
    for (name, objects) in [("tilted-plane", TILTED), ("freeform-near", FREEFORM_NEAR)] {
        let t = Tmp::new(&format!("near-{name}"));
        let scene = t.0.join("scene.toml");
        std::fs::write(&scene, scene_toml(objects)).unwrap();
        let ds = t.0.join("ds");
        render_noisy(s(&scene), "640x512", &ds, &[]);
        let cal = ds.join("calibration.toml");
        let patterns = ds.join("patterns.toml");
        let wide = t.0.join("wide/calibration.toml");
        virtual_reference(&patterns, &cal, &wide);
        let narrow = t.0.join("narrow/calibration.toml");
        virtual_reference_with(&patterns, &cal, &narrow, &["--margin", "0"]);
        // A captured plane (the rig's reference plane, rendered on its own) with the fitted
        // model extended by the projector model (`--margin auto`; the rendered calibration
        // holds the true projector).
        let refds = t.0.join("refds");
        render_noisy("reference", "640x512", &refds, &["--seed", "5"]);
        let r = fringe3d::io::calibration::Calibration::load(&cal)
            .unwrap()
            .reference
            .unwrap();
        let captured = t.0.join("captured/calibration.toml");
        let fmt = |x: [f64; 3]| format!("{},{},{}", x[0], x[1], x[2]);
        run(&[
            "calibrate",
            "reference",
            "-q",
            s(&refds),
            "--patterns",
            s(&patterns),
            "--calibration",
            s(&cal),
            "--plane-point",
            &fmt(r.point),
            "--plane-normal",
            &fmt(r.normal),
            "--margin",
            "auto",
            "-o",
            s(&captured),
        ]);
        let margin = fringe3d::io::calibration::Calibration::load(&wide)
            .unwrap()
            .reference
            .unwrap()
            .margin;
        let w = coverage(&ds, &wide, &t.0.join("wide.ply"));
        let n = coverage(&ds, &narrow, &t.0.join("narrow.ply"));
        let c = coverage(&ds, &captured, &t.0.join("captured.ply"));
        let pc = |c: &Coverage| 100.0 * c.valid as f64 / c.counted as f64;
        eprintln!(
            "{name}: {} interior pixels in the depth range (nearest at {:.1} mm); margin \
             {margin:?}: {:.3} % kept, {} no-crossing; image-sized map: {:.3} % kept, {} \
             no-crossing",
            w.counted,
            w.nearest,
            pc(&w),
            w.no_crossing,
            pc(&n),
            n.no_crossing
        );
        let cm = fringe3d::io::calibration::Calibration::load(&captured)
            .unwrap()
            .reference
            .unwrap()
            .margin;
        eprintln!(
            "{name}: captured plane's model, margin {cm:?} by the projector model: {:.3} % kept, {} no-crossing",
            pc(&c),
            c.no_crossing
        );
        assert!(pc(&c) >= 99.5, "{name}: captured, {:.3} % kept", pc(&c));
        assert_eq!(c.no_crossing, 0, "{name}: captured, no-crossing in range");
        // The scene reaches the near end of the range and fills most of the image.
        assert!(w.counted > 200_000, "{name}: {} pixels", w.counted);
        assert!(w.nearest < 480.0, "{name}: nearest {} mm", w.nearest);
        assert!(pc(&w) >= 99.5, "{name}: {:.3} % kept", pc(&w));
        assert_eq!(w.no_crossing, 0, "{name}: no-crossing in the depth range");
        // Without the margin the near points go: the scene does test it.
        assert!(
            n.valid + 1000 < w.valid,
            "{name}: {} without the margin, {} with it",
            n.valid,
            w.valid
        );
    }
}

#[test]
fn a_margin_on_a_capture_without_the_projector_model_is_refused() {
    let t = Tmp::new("margin-bad");
    let ds = t.0.join("ds");
    render_noisy("reference", "320x256", &ds, &[]);
    let cal = ds.join("calibration.toml");
    let text = std::fs::read_to_string(&cal).unwrap();
    let cut = text
        .find("[projector")
        .expect("the rendered calibration has [projector]");
    let no_projector = t.0.join("no_projector.toml");
    std::fs::write(&no_projector, &text[..cut]).unwrap();
    let r = fringe3d::io::calibration::Calibration::load(&cal)
        .unwrap()
        .reference
        .unwrap();
    let fmt = |x: [f64; 3]| format!("{},{},{}", x[0], x[1], x[2]);
    let (point, normal) = (fmt(r.point), fmt(r.normal));
    let out_dir = t.0.join("out");
    let out = out_dir.join("calibration.toml");
    let patterns = ds.join("patterns.toml");
    for (calibration, extra) in [
        (&no_projector, vec!["--margin", "auto"]),
        (&no_projector, vec!["--margin", "20"]),
        (&cal, vec!["--margin", "auto", "--raw"]),
    ] {
        let mut args = vec![
            "calibrate",
            "reference",
            s(&ds),
            "--patterns",
            s(&patterns),
            "--calibration",
            s(calibration),
            "--plane-point",
            &point,
            "--plane-normal",
            &normal,
            "-o",
            s(&out),
        ];
        args.extend(extra);
        let o = crate::cli_support::fringe3d(&args);
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success(), "{args:?} succeeded");
        assert!(
            err.contains("--margin extends the model fitted to the capture")
                && err.contains(s(calibration)),
            "{args:?}: {err}"
        );
        assert_eq!(err.trim().lines().count(), 1, "{err}");
        assert!(!out_dir.exists(), "{args:?} wrote {}", out_dir.display());
    }
    // `--margin 0` is the default's image-sized map, with or without the model.
    run(&[
        "calibrate",
        "reference",
        "-q",
        s(&ds),
        "--patterns",
        s(&ds.join("patterns.toml")),
        "--calibration",
        s(&no_projector),
        "--plane-point",
        &point,
        "--plane-normal",
        &normal,
        "--margin",
        "0",
        "-o",
        s(&out),
    ]);
    let written = fringe3d::io::calibration::Calibration::load(&out).unwrap();
    assert_eq!(written.reference.unwrap().margin, None);
}
