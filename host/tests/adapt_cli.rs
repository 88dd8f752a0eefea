//! `fringe3d adapt` (issue #22 item 1) through the binary: a first scan of a rendered object gives
//! a set that scans it better than its template, with no reference capture; a mesh placed in
//! the rig does too; bad input gets one clear error naming the binding constraint, with nothing
//! written.

use std::path::{Path, PathBuf};

use fringe3d::accuracy::load_truth;
use fringe3d::adapt::experiment::score;
use fringe3d::cli::common;
use fringe3d::scan::{ScanCalibration, filter_edges};

use crate::cli_support::{Tmp, fringe3d, run, s, virtual_reference};

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// The flanks scene of the experiment with `patterns` as its `[patterns]` section, written to
/// `dir/name.toml`.
fn scene(dir: &Path, name: &str, patterns: &str) -> PathBuf {
    let text = std::fs::read_to_string(root().join("examples/scenes/adapt_flanks.toml")).unwrap();
    let text = text.replace(
        "[reference]",
        &format!("[patterns]\n{patterns}\n\n[reference]"),
    );
    let p = dir.join(format!("{name}.toml"));
    std::fs::write(&p, text).unwrap();
    p
}

fn render(scene: &Path, out: &Path) {
    run(&[
        "render",
        "-q",
        "--scene",
        s(scene),
        "--size",
        "640x512",
        "--out",
        s(out),
    ]);
}

/// RMS (mm) and unresolvable share on the object of `ds` scanned with `patterns` and
/// `calibration` (the library path of `fringe3d scan`).
fn scan_score(ds: &Path, patterns: &Path, calibration: &Path) -> (f64, f64) {
    let ls = common::load_set(patterns).unwrap();
    let cal = ScanCalibration::load(calibration, ls.set.axis()).unwrap();
    let imgs = common::load_images(&ls, &[ds.to_path_buf()], true).unwrap();
    let d = common::decode(&ls.set, &imgs, common::decode_config(&imgs)).unwrap();
    let mut cloud = cal.reconstruct(&d.phase, &d.validity, true).unwrap();
    filter_edges(&mut cloud, &cal.edge_filter(80.0).unwrap());
    let (rms, unresolved, n) = score(&cloud, &load_truth(ds).unwrap(), 1.0);
    assert!(n > 10_000, "{n} object pixels");
    (rms, unresolved)
}

const CROP: &str = "-250,-250,450,250,250,715";

/// RMS and unresolvable share of the scene scanned with the set `adapt` wrote into `out` (and its
/// virtual reference), and of the first scan `first` (set `set`, calibration `cal`) with a
/// virtual reference of its own.
fn adapted_and_template(
    t: &Path,
    out: &Path,
    first: &Path,
    set: &Path,
    cal: &Path,
) -> ((f64, f64), (f64, f64)) {
    let file = out.join("patterns.toml");
    let second = t.join("second");
    render(
        &scene(t, "second", &format!("file = {:?}", s(&file))),
        &second,
    );
    // The dataset's copy of the set lists its images.
    let adapted = scan_score(
        &second,
        &second.join("patterns.toml"),
        &out.join("calibration.toml"),
    );
    let tcal = t.join("template/calibration.toml");
    virtual_reference(set, cal, &tcal);
    (adapted, scan_score(first, set, &tcal))
}

#[test]
fn a_first_scan_gives_a_set_that_beats_its_template() {
    let t = Tmp::new("adapt-cloud");
    let first = t.0.join("first");
    render(&scene(&t.0, "first", "ratio = 5.657"), &first);
    let ply = t.0.join("first.ply");
    run(&[
        "scan",
        "-q",
        "--patterns",
        s(&first.join("patterns.toml")),
        "--calibration",
        s(&first.join("calibration.toml")),
        s(&first),
        "-o",
        s(&ply),
    ]);
    let out = t.0.join("adapted");
    // `fringe3d adapt` from the cloud into `out`, with `extra` flags.
    let (cal, pat) = (first.join("calibration.toml"), first.join("patterns.toml"));
    let adapt = |out: &Path, extra: &[&str]| {
        let mut a = vec![
            "adapt",
            "--calibration",
            s(&cal),
            "--patterns",
            s(&pat),
            "--cloud",
            s(&ply),
            "--crop",
            CROP,
            "-o",
            s(out),
        ];
        a.extend_from_slice(extra);
        run(&a)
    };
    let json = adapt(&out, &["--json"]);
    let v: serde_json::Value = serde_json::from_str(&json).unwrap();
    let gain = v["predicted_rms_gain"].as_f64().unwrap();
    assert!(gain > 1.5, "{json}");
    let text = std::fs::read_to_string(out.join("patterns.toml")).unwrap();
    assert!(text.contains("kind = \"knots\""), "{text}");
    // The template's image list names its captures, not the new set's.
    assert!(!text.contains("images"), "{text}");
    // The text report names the regions and what binds them.
    let report = adapt(&t.0.join("again"), &[]);
    assert!(
        report.contains("predicted RMS gain") && report.contains("bound by"),
        "{report}"
    );

    // Scan the object with the new set and the virtual reference adapt wrote: no capture; the
    // template with a virtual reference of its own.
    let ((rms, unresolved), (t_rms, t_unresolved)) = adapted_and_template(
        &t.0,
        &out,
        &first,
        &first.join("patterns.toml"),
        &first.join("calibration.toml"),
    );
    eprintln!(
        "flanks 640x512: template {:.1} µm, {:.2} % unresolved; adapted {:.1} µm, {:.2} % \
         (predicted gain x{gain:.2})",
        t_rms * 1e3,
        t_unresolved * 100.0,
        rms * 1e3,
        unresolved * 100.0
    );
    assert!(rms < 0.6 * t_rms, "{rms} vs {t_rms}");
    assert!(
        unresolved <= t_unresolved + 0.005,
        "{unresolved} vs {t_unresolved}"
    );
}

/// A binary STL of `triangles`.
fn stl(triangles: &[[[f64; 3]; 3]]) -> Vec<u8> {
    let mut b = vec![0u8; 80];
    b.extend((triangles.len() as u32).to_le_bytes());
    for t in triangles {
        b.extend([0u8; 12]);
        for v in t {
            for c in v {
                b.extend((*c as f32).to_le_bytes());
            }
        }
        b.extend([0u8; 2]);
    }
    b
}

/// A UV sphere of radius `r` about the origin, outward triangles.
fn sphere(r: f64) -> Vec<[[f64; 3]; 3]> {
    let (n, m) = (24, 48);
    let p = |i: usize, j: usize| {
        let (th, ph) = (
            std::f64::consts::PI * i as f64 / n as f64,
            std::f64::consts::TAU * j as f64 / m as f64,
        );
        [
            r * th.sin() * ph.cos(),
            r * th.sin() * ph.sin(),
            r * th.cos(),
        ]
    };
    let mut t = Vec::new();
    for i in 0..n {
        for j in 0..m {
            t.push([p(i, j), p(i + 1, j), p(i + 1, j + 1)]);
            t.push([p(i, j), p(i + 1, j + 1), p(i, j + 1)]);
        }
    }
    t
}

#[test]
fn a_mesh_in_the_rig_and_each_bad_input() {
    let t = Tmp::new("adapt-bad");
    let ds = t.0.join("ds");
    render(&scene(&t.0, "ds", "ratio = 8.0"), &ds);
    let cal = ds.join("calibration.toml");
    let pat = ds.join("patterns.toml");
    let ball = t.0.join("ball.stl");
    std::fs::write(&ball, stl(&sphere(70.0))).unwrap();
    // A ball placed in the volume: a design, predicted better than the template.
    let out = t.0.join("mesh");
    let json = run(&[
        "adapt",
        "--json",
        "-c",
        s(&cal),
        "-p",
        s(&pat),
        "--mesh",
        s(&ball),
        "--pose",
        "0,0,620,0,0,0",
        "-o",
        s(&out),
    ]);
    let v: serde_json::Value = serde_json::from_str(&json).unwrap();
    assert!(v["pixels"].as_u64().unwrap() > 20_000, "{json}");
    assert!(v["predicted_rms_gain"].as_f64().unwrap() > 1.2, "{json}");
    assert!(out.join("calibration.toml").is_file());

    let fails = |args: &[&str], needles: &[&str]| {
        let o = t.0.join("out");
        let mut a = args.to_vec();
        a.extend(["-o", s(&o)]);
        let r = fringe3d(&a);
        let err = String::from_utf8_lossy(&r.stderr);
        assert!(!r.status.success(), "{args:?} succeeded");
        assert!(!err.contains("panicked"), "{err}");
        for n in needles {
            assert!(err.contains(n), "{args:?}: {err:?} lacks {n:?}");
        }
        assert_eq!(err.trim().lines().count(), 1, "one line: {err}");
        assert!(!o.exists(), "{args:?} wrote {}", o.display());
    };
    let base = ["adapt", "-c", s(&cal), "-p", s(&pat)];
    let with = |extra: &[&'static str]| [&base[..], extra].concat();
    let ball_s: &'static str = Box::leak(s(&ball).to_string().into_boxed_str());
    // The mesh outside the volume: nothing of it is seen in the depth range.
    fails(
        &with(&["--mesh", ball_s, "--pose", "0,0,2000,0,0,0"]),
        &[
            "ball.stl",
            "only 0 object pixels",
            "outside the depth range",
        ],
    );
    // A first scan of too few points.
    let few = t.0.join("few.ply");
    let mut ply = String::from(
        "ply\nformat ascii 1.0\nelement vertex 50\nproperty float x\nproperty float y\nproperty float z\nend_header\n",
    );
    for i in 0..50 {
        ply += &format!("{} 0 620\n", i as f64 * 0.3);
    }
    std::fs::write(&few, ply).unwrap();
    let few_s: &'static str = Box::leak(s(&few).to_string().into_boxed_str());
    fails(
        &with(&["--cloud", few_s]),
        &["few.ply", "a design needs 1000"],
    );
    // Constraints that cannot be met, and flags out of range: each named.
    for (flag, value, needles) in [
        (
            "--min-projector-period",
            "500",
            &["the projector binds", "--min-projector-period"][..],
        ),
        ("--min-period", "400", &["the camera binds", "--min-period"]),
        ("--knots", "40", &["--knots: 2 to 16, got 40"]),
        (
            "--min-projector-period",
            "2",
            &["--min-projector-period: at least 4"],
        ),
        (
            "--snr",
            "3",
            &["the unwrapping binds", "patterns --design 3"],
        ),
    ] {
        fails(
            &with(&["--mesh", ball_s, "--pose", "0,0,620,0,0,0", flag, value]),
            needles,
        );
    }
    // No projector model: nothing maps the object onto the projector.
    let mut c = fringe3d::io::calibration::Calibration::load(&cal).unwrap();
    c.projector = None;
    let bare = ds.join("bare.toml");
    c.save(&bare).unwrap();
    let bare_s: &'static str = Box::leak(s(&bare).to_string().into_boxed_str());
    fails(
        &[
            "adapt",
            "-c",
            bare_s,
            "-p",
            s(&pat),
            "--mesh",
            ball_s,
            "--pose",
            "0,0,620,0,0,0",
        ],
        &[
            "bare.toml",
            "no [projector] section",
            "calibrate projector",
            "--decoded",
        ],
    );
    // A mesh that is not one.
    let junk = t.0.join("junk.stl");
    std::fs::write(&junk, b"not a mesh at all").unwrap();
    let junk_s: &'static str = Box::leak(s(&junk).to_string().into_boxed_str());
    fails(
        &with(&["--mesh", junk_s, "--pose", "0,0,620,0,0,0"]),
        &["junk.stl", "neither a PLY nor an STL"],
    );
}

#[test]
fn a_decoded_first_scan_needs_no_projector_model() {
    let t = Tmp::new("adapt-decoded");
    let first = t.0.join("first");
    render(&scene(&t.0, "first", "ratio = 5.657"), &first);
    let (cal, pat) = (first.join("calibration.toml"), first.join("patterns.toml"));
    let dec = t.0.join("decoded");
    run(&[
        "decode",
        "-q",
        "--patterns",
        s(&pat),
        s(&first),
        "--out",
        s(&dec),
    ]);
    // The paper's calibration: camera, projector centre, reference; no projector model.
    let mut c = fringe3d::io::calibration::Calibration::load(&cal).unwrap();
    c.projector = None;
    let bare = first.join("bare.toml");
    c.save(&bare).unwrap();
    let args = |cal: &Path, out: &Path| -> Vec<String> {
        [
            "adapt",
            "--json",
            "-c",
            s(cal),
            "-p",
            s(&pat),
            "--decoded",
            s(&dec),
            "--first-patterns",
            s(&pat),
            "--crop",
            CROP,
            "-o",
            s(out),
        ]
        .map(String::from)
        .to_vec()
    };
    let run_s = |a: Vec<String>| {
        let a: Vec<&str> = a.iter().map(String::as_str).collect();
        serde_json::from_str::<serde_json::Value>(&run(&a)).unwrap()
    };
    // Without a projector model: the set, and the capture to make instead of a reference.
    let out = t.0.join("bare-out");
    let v = run_s(args(&bare, &out));
    assert!(out.join("patterns.toml").is_file());
    assert!(!out.join("calibration.toml").exists());
    let capture = v["capture"].as_str().unwrap();
    assert!(capture.contains("calibrate reference"), "{capture}");
    // The same design as from the projector model's view of the scan's cloud (a second
    // method: geometry from the projector model against the decoded phase and the reference):
    // the predicted gains agree, and so do the knots where the object is.
    let full = t.0.join("full-out");
    let d = run_s(args(&cal, &full));
    assert!(full.join("calibration.toml").is_file());
    let ply = t.0.join("first.ply");
    run(&[
        "scan",
        "-q",
        "-p",
        s(&pat),
        "-c",
        s(&cal),
        s(&first),
        "-o",
        s(&ply),
    ]);
    let viacloud = t.0.join("cloud-out");
    let e = run_s(
        [
            "adapt",
            "--json",
            "-c",
            s(&cal),
            "-p",
            s(&pat),
            "--cloud",
            s(&ply),
            "--crop",
            CROP,
            "-o",
            s(&viacloud),
        ]
        .map(String::from)
        .to_vec(),
    );
    let (gd, ge) = (
        d["predicted_rms_gain"].as_f64().unwrap(),
        e["predicted_rms_gain"].as_f64().unwrap(),
    );
    eprintln!("predicted gain: decoded x{gd:.3}, cloud x{ge:.3}");
    assert!((gd / ge - 1.0).abs() < 0.05, "{gd} vs {ge}");
    let ks = |v: &serde_json::Value| -> Vec<f64> {
        v["slopes"]
            .as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_f64().unwrap())
            .collect()
    };
    let (kd, ke) = (ks(&d), ks(&e));
    let top = ke.iter().cloned().fold(0.0, f64::max);
    for (a, b) in kd.iter().zip(&ke) {
        assert!((a - b).abs() < 0.1 * top, "{kd:?} vs {ke:?}");
    }
    // With the read noise, both paths use the measured modulation (the cloud carries it as a
    // property): the same design again.
    let noisy = |src: &[&str], out: &Path| {
        let mut a: Vec<String> = ["adapt", "--json", "-c", s(&cal), "-p", s(&pat)]
            .map(String::from)
            .to_vec();
        a.extend(src.iter().map(|x| x.to_string()));
        a.extend(["--noise", "1.04", "--crop", CROP, "-o", s(out)].map(String::from));
        run_s(a)
    };
    let dn = noisy(
        &["--decoded", s(&dec), "--first-patterns", s(&pat)],
        &t.0.join("dn"),
    );
    let en = noisy(&["--cloud", s(&ply)], &t.0.join("en"));
    let (gd, ge) = (
        dn["predicted_rms_gain"].as_f64().unwrap(),
        en["predicted_rms_gain"].as_f64().unwrap(),
    );
    eprintln!("with the noise: decoded x{gd:.3}, cloud x{ge:.3}");
    assert!((gd / ge - 1.0).abs() < 0.05, "{gd} vs {ge}");
    // Its scan, with the virtual reference of the full calibration.
    let ((rms, _), (t_rms, _)) = adapted_and_template(&t.0, &full, &first, &pat, &cal);
    assert!(rms < 0.6 * t_rms, "{rms} vs {t_rms}");
    // A decode folder of another set is refused.
    let other = t.0.join("other.toml");
    std::fs::write(
        &other,
        std::fs::read_to_string(&pat)
            .unwrap()
            .replace("ratio = 5.657", "ratio = 6.0"),
    )
    .unwrap();
    let r = fringe3d(&[
        "adapt",
        "-c",
        s(&bare),
        "-p",
        s(&pat),
        "--decoded",
        s(&dec),
        "--first-patterns",
        s(&other),
        "-o",
        s(&t.0.join("never")),
    ]);
    let err = String::from_utf8_lossy(&r.stderr);
    assert!(!r.status.success() && err.contains("decoded with"), "{err}");
    assert!(!t.0.join("never").exists());
    // A template along the other axis than the first scan's: its ξ would be the wrong one.
    let h = root().join("examples/patterns/horizontal.toml");
    let r = fringe3d(&[
        "adapt",
        "-c",
        s(&bare),
        "-p",
        s(&h),
        "--decoded",
        s(&dec),
        "--first-patterns",
        s(&pat),
        "-o",
        s(&t.0.join("never")),
    ]);
    let err = String::from_utf8_lossy(&r.stderr);
    assert!(
        !r.status.success() && err.contains("must share the fringe axis"),
        "{err}"
    );
    assert!(!t.0.join("never").exists());
}
