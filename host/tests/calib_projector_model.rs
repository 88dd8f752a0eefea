//! The full projector model (issue #18 item 2) through the binary, against the renderer's truth:
//! freely posed boards and parallel plates each give the projector's intrinsics, distortion and
//! pose; the two workflows agree with each other and, for the plates, with the line method of
//! paper §7; a perturbed camera is pulled back by `--camera-intrinsics refine`; and a scan with the
//! self-made projector and a virtual reference is as accurate as with the true calibration.

use fringe3d::accuracy;
use fringe3d::calib::lens::Lens;
use fringe3d::cli::common;
use fringe3d::io::calibration::Calibration;
use fringe3d::scan::ScanCalibration;
use serde_json::Value;
use std::path::Path;

use crate::cli_support::{Tmp, render_noisy, run, s, virtual_reference};

/// `calibrate projector` on every pose folder of `ds` with `camera`; the report and the file.
fn calibrate(ds: &Path, camera: &Path, out: &Path, extra: &[&str]) -> (Value, Calibration) {
    let mut poses: Vec<String> = std::fs::read_dir(ds)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| {
            p.is_dir()
                && p.file_name()
                    .unwrap()
                    .to_str()
                    .unwrap()
                    .starts_with("plate_")
        })
        .map(|p| s(&p).to_string())
        .collect();
    poses.sort();
    let mut a: Vec<&str> = vec!["--json", "calibrate", "projector"];
    a.extend(poses.iter().map(String::as_str));
    a.extend([
        "--camera-from",
        s(camera),
        "--board",
        "9x7",
        "--square",
        "30",
        "--depth-range",
        "450,750",
        "-o",
        s(out),
    ]);
    a.extend(extra);
    let j: Value = serde_json::from_str(&run(&a)).unwrap();
    (j, Calibration::load(out).unwrap())
}

/// The projector pixel of camera-frame point `x` under a calibration's projector model.
fn pixel(c: &Calibration, x: [f64; 3]) -> Option<(f64, f64)> {
    let p = c.projector.as_ref()?;
    let q: [f64; 3] = std::array::from_fn(|k| x[k] - p.translation[k]);
    let xp: [f64; 3] =
        std::array::from_fn(|k| (0..3).map(|i| p.rotation[i][k] * q[i]).sum::<f64>());
    Lens::from_model(&p.intrinsics).project_point(xp)
}

/// RMS and largest difference of the projector pixels of the two models over a grid of the
/// default rig's measurement volume (points the true projector lights), projector pixels.
fn volume_error(est: &Calibration, truth: &Calibration) -> (f64, f64) {
    let (mut ss, mut n, mut mx) = (0.0, 0usize, 0.0f64);
    for i in 0..=14 {
        for j in 0..=11 {
            for k in 0..=5 {
                let x = [
                    -140.0 + 20.0 * i as f64,
                    -110.0 + 20.0 * j as f64,
                    475.0 + 50.0 * k as f64,
                ];
                let Some(t) = pixel(truth, x) else { continue };
                if !(0.0..1024.0).contains(&t.0) || !(0.0..768.0).contains(&t.1) {
                    continue;
                }
                let e = pixel(est, x).unwrap();
                let d = ((e.0 - t.0).powi(2) + (e.1 - t.1).powi(2)).sqrt();
                ss += d * d;
                n += 1;
                mx = mx.max(d);
            }
        }
    }
    assert!(n > 500, "{n} grid points lit");
    ((ss / n as f64).sqrt(), mx)
}

fn dist(a: [f64; 3], b: [f64; 3]) -> f64 {
    (0..3).map(|k| (a[k] - b[k]).powi(2)).sum::<f64>().sqrt()
}

/// The quality bar of issue #18 on one calibration, against the truth; returns P's error, mm.
/// `camera_held`: the camera is the true one, so the projector pixels of camera-frame points are
/// comparable over the volume (a refined camera moves the frame itself by its small errors).
fn check(name: &str, j: &Value, c: &Calibration, truth: &Calibration, camera_held: bool) -> f64 {
    let (p, t) = (c.projector.unwrap(), truth.projector.unwrap());
    let m = &j["model"]["projector"];
    let std = |k: &str| m[k]["std"].as_f64().unwrap();
    let (pi, ti) = (p.intrinsics, t.intrinsics);
    let rel = |a: f64, b: f64| (a - b) / b;
    let rms = j["model"]["rms_projector_px"].as_f64().unwrap();
    let p_err = dist(c.projector_centre, truth.projector_centre);
    let (vr, vm) = volume_error(c, truth);
    println!(
        "{name}: fx {:+.4} %, fy {:+.4} % (σ {:.4} %), cx {:+.3}, cy {:+.3} px; reprojection RMS {rms:.4} px; P {p_err:.4} mm off; over the volume {vr:.4} px RMS, {vm:.4} px max",
        100.0 * rel(pi.fx, ti.fx),
        100.0 * rel(pi.fy, ti.fy),
        100.0 * std("fx") / ti.fx,
        pi.cx - ti.cx,
        pi.cy - ti.cy
    );
    assert_eq!(
        c.projector_centre, p.translation,
        "{name}: P is the projector's centre"
    );
    assert!(
        rel(pi.fx, ti.fx).abs() <= 5e-4 && rel(pi.fy, ti.fy).abs() <= 5e-4,
        "{name}: focal lengths {} {}",
        pi.fx,
        pi.fy
    );
    assert!(rms <= 0.05, "{name}: reprojection RMS {rms} px");
    assert!(p_err <= 0.05, "{name}: P {:?}", c.projector_centre);
    assert!(
        !camera_held || (vr <= 0.05 && vm <= 0.25),
        "{name}: {vr} px RMS, {vm} px max"
    );
    // The stated σ covers the error.
    for (k, e) in [
        ("fx", pi.fx - ti.fx),
        ("fy", pi.fy - ti.fy),
        ("cx", pi.cx - ti.cx),
        ("cy", pi.cy - ti.cy),
    ] {
        assert!(
            e.abs() <= 5.0 * std(k),
            "{name}: {k} error {e} vs σ {}",
            std(k)
        );
    }
    let ps: Vec<f64> = j["projector_centre_std"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect();
    for (k, sk) in ps.iter().enumerate() {
        let e = c.projector_centre[k] - truth.projector_centre[k];
        assert!(
            e.abs() <= 5.0 * sk + 1e-4,
            "{name}: P[{k}] error {e} vs σ {sk}"
        );
    }
    p_err
}

/// Interior RMS of a scan of `ds` with `calibration`, mm.
fn scan_rms(ds: &Path, calibration: &Path) -> f64 {
    let ls = common::load_set(&ds.join("patterns.toml")).unwrap();
    let cal = ScanCalibration::load(calibration, ls.set.axis()).unwrap();
    let imgs = common::load_images(&ls, &[], true).unwrap();
    let d = common::decode(&ls.set, &imgs, common::decode_config(&imgs)).unwrap();
    let cloud = cal.reconstruct(&d.phase, &d.validity, true).unwrap();
    let acc = accuracy::evaluate(&cloud, &accuracy::load_truth(ds).unwrap()).unwrap();
    acc.interior.rms
}

#[test]
fn the_full_projector_from_boards_and_from_plates() {
    let t = Tmp::new("projector-model");
    let (boards, plates) = (t.0.join("boards"), t.0.join("plates"));
    render_noisy("boards", "640x512", &boards, &[]);
    render_noisy("plates", "640x512", &plates, &[]);
    let truth = Calibration::load(&boards.join("calibration.toml")).unwrap();
    let true_cam = boards.join("calibration.toml");

    // Freely posed boards, the true camera held.
    let out_b = t.0.join("b/calibration.toml");
    let (jb, cb) = calibrate(&boards, &true_cam, &out_b, &[]);
    let eb = check("boards", &jb, &cb, &truth, true);
    assert!(jb["line_method"].is_null(), "tilted boards: no line method");
    assert!(
        jb["line_method_skipped"]
            .as_str()
            .unwrap()
            .contains("not parallel"),
        "{}",
        jb["line_method_skipped"]
    );

    // Parallel plates: the same model, and the line method agrees with it.
    let out_p = t.0.join("p/calibration.toml");
    let (jp, cp) = calibrate(&plates, &plates.join("calibration.toml"), &out_p, &[]);
    let ep = check("plates", &jp, &cp, &truth, true);
    let agree = &jp["line_method_agreement"];
    let (d, sd) = (
        agree["difference_mm"].as_f64().unwrap(),
        agree["combined_std_mm"].as_f64().unwrap(),
    );
    println!(
        "line method vs model: {d:.4} mm ({:.2} σ); P errors {eb:.4} / {ep:.4} mm",
        d / sd
    );
    assert!(d <= 4.0 * sd + 1e-3 && d <= 0.05, "{d} mm vs σ {sd}");
    // The two workflows agree with each other.
    assert!(dist(cb.projector_centre, cp.projector_centre) <= 0.05);
    let (a, b) = (
        cb.projector.unwrap().intrinsics,
        cp.projector.unwrap().intrinsics,
    );
    assert!(((a.fx - b.fx) / b.fx).abs() <= 5e-4 && ((a.fy - b.fy) / b.fy).abs() <= 5e-4);

    // A camera 0.3 % off in focal length and 3 px off in its principal point: held, it biases
    // the projector; refined with the projector (the boards are tilted), it comes back.
    let mut bad = truth.clone();
    bad.camera.fx *= 1.003;
    bad.camera.fy *= 1.003;
    bad.camera.cx += 3.0;
    bad.projector = None;
    bad.reference = None;
    let bad_path = t.0.join("bad_camera.toml");
    bad.save(&bad_path).unwrap();
    let (jr, cr) = calibrate(
        &boards,
        &bad_path,
        &t.0.join("r/calibration.toml"),
        &["--camera-intrinsics", "refine"],
    );
    let cam_err = (cr.camera.fx - truth.camera.fx) / truth.camera.fx;
    println!(
        "refined camera: fx {:+.4} %, cx {:+.3} px",
        100.0 * cam_err,
        cr.camera.cx - truth.camera.cx
    );
    assert!(cam_err.abs() <= 3e-4, "camera fx {}", cr.camera.fx);
    assert!(
        (cr.camera.cx - truth.camera.cx).abs() <= 0.5,
        "camera cx {}",
        cr.camera.cx
    );
    check("boards, camera refined", &jr, &cr, &truth, false);

    // End to end: the self-made projector gives a virtual reference; a sphere scanned with it
    // is as accurate as with the true calibration (true camera and captured reference).
    let sphere = t.0.join("sphere");
    render_noisy("sphere", "640x512", &sphere, &[]);
    let virt = t.0.join("v/calibration.toml");
    virtual_reference(&sphere.join("patterns.toml"), &out_b, &virt);
    let (r_true, r_self) = (
        scan_rms(&sphere, &sphere.join("calibration.toml")),
        scan_rms(&sphere, &virt),
    );
    println!(
        "sphere interior RMS: true calibration {:.2} µm, self-made projector + virtual reference {:.2} µm ({:.3}×)",
        1e3 * r_true,
        1e3 * r_self,
        r_self / r_true
    );
    assert!(r_self <= 1.15 * r_true, "{r_self} vs {r_true} mm");
}
