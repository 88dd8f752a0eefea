//! `fringe3d calibrate reference --virtual` through the binary on a small rendered dataset: the map
//! equals the renderer's exact map of the plane, the scan with it is as accurate as with the
//! captured map, and misuse gets one clear error with nothing written.

use fringe3d::accuracy;
use fringe3d::calib::files::read_phase_map;
use fringe3d::cli::common;
use fringe3d::scan::ScanCalibration;
use std::path::Path;

use crate::cli_support::{Tmp, fringe3d, run, s, virtual_reference, virtual_reference_with};

/// Interior RMS error of the scan of `ds` with `calibration` (the library path of `fringe3d scan`),
/// mm, and the interior points compared. The CLI's `scan` is exercised on the same files too.
fn scan_rms(ds: &Path, calibration: &Path, out: &Path) -> (f64, usize) {
    run(&[
        "scan",
        "-q",
        "--patterns",
        s(&ds.join("patterns.toml")),
        "--calibration",
        s(calibration),
        s(ds),
        "-o",
        s(out),
    ]);
    let ls = common::load_set(&ds.join("patterns.toml")).expect("pattern set");
    let cal = ScanCalibration::load(calibration, ls.set.axis()).expect("calibration");
    let imgs = common::load_images(&ls, &[], true).expect("images");
    let d = common::decode(&ls.set, &imgs, common::decode_config(&imgs)).expect("decode");
    let cloud = cal
        .reconstruct(&d.phase, &d.validity, true)
        .expect("reconstruct");
    let truth = accuracy::load_truth(ds).expect("truth");
    let acc = accuracy::evaluate(&cloud, &truth).expect("evaluate");
    (acc.interior.rms, acc.interior.count)
}

#[test]
fn a_virtual_reference_through_the_cli() {
    let t = Tmp::new("virtual");
    let ds = t.0.join("ds");
    run(&[
        "render",
        "-q",
        "--scene",
        "sphere",
        "--size",
        "320x256",
        "--noise",
        "1",
        "--bits",
        "8",
        "--out",
        s(&ds),
    ]);
    let cal = ds.join("calibration.toml");
    let virt = t.0.join("virtual/calibration.toml");
    virtual_reference(&ds.join("patterns.toml"), &cal, &virt);
    // The same without a margin (an image-sized map, as a head takes).
    let virt0 = t.0.join("virtual0/calibration.toml");
    virtual_reference_with(&ds.join("patterns.toml"), &cal, &virt0, &["--margin", "0"]);
    let margin = fringe3d::io::calibration::Calibration::load(&virt)
        .unwrap()
        .reference
        .unwrap()
        .margin;
    assert!(
        margin.is_some_and(|m| m.iter().any(|&x| x > 0)),
        "{margin:?}"
    );
    // The default plane is at the far end of the depth range: a different plane from the
    // dataset's, so compare the scans, and the map on the dataset's own plane with the truth.
    let (rms_virtual, n_virtual) = scan_rms(&ds, &virt, &t.0.join("virtual.ply"));
    let (rms_virtual0, n_virtual0) = scan_rms(&ds, &virt0, &t.0.join("virtual0.ply"));
    let (rms_captured, n_captured) = scan_rms(&ds, &cal, &t.0.join("captured.ply"));
    eprintln!(
        "sphere 320x256: virtual reference (margin {margin:?}) {:.2} µm ({n_virtual} points), \
         without a margin {:.2} µm ({n_virtual0} points), captured {:.2} µm ({n_captured} points)",
        rms_virtual * 1e3,
        rms_virtual0 * 1e3,
        rms_captured * 1e3
    );
    // Accuracy as good. On the far plane, near points have their crossing off the image: the
    // map's margin keeps them (issue #17 item 3): more points than without it, and nearly the
    // captured plane's (that plane lies inside the volume).
    assert!(rms_virtual <= 1.02 * rms_captured);
    assert!(
        n_virtual as f64 >= 0.98 * n_captured as f64,
        "{n_virtual} vs {n_captured}"
    );
    assert!(
        n_virtual as f64 > 1.01 * n_virtual0 as f64,
        "{n_virtual} vs {n_virtual0}"
    );

    let c = fringe3d::io::calibration::Calibration::load(&cal).unwrap();
    let r = c.reference.as_ref().unwrap();
    let same = t.0.join("same/calibration.toml");
    let point = format!("{},{},{}", r.point[0], r.point[1], r.point[2]);
    let normal = format!("{},{},{}", r.normal[0], r.normal[1], r.normal[2]);
    virtual_reference_with(
        &ds.join("patterns.toml"),
        &cal,
        &same,
        &[
            "--margin",
            "0",
            "--plane-point",
            &point,
            "--plane-normal",
            &normal,
        ],
    );
    let (rms_same, n_same) = scan_rms(&ds, &same, &t.0.join("same.ply"));
    eprintln!(
        "on the dataset's plane: virtual reference {:.2} µm ({n_same} points)",
        rms_same * 1e3
    );
    assert!(rms_same <= 1.02 * rms_captured);
    // The virtual map leaves out a pixel along the edge of the projector's light (where decoded
    // phases are biased and only a captured map, biased alike, cancels it): ~1 % of this small
    // image's points.
    assert!(n_same as f64 >= 0.985 * n_captured as f64);
    let exact = read_phase_map(&ds.join("truth/reference_phase_true.tif"))
        .unwrap()
        .2;
    let map = read_phase_map(&t.0.join("same/reference_phase.tif"))
        .unwrap()
        .2;
    let (mut s2, mut n) = (0.0, 0usize);
    for (a, b) in exact.iter().zip(&map) {
        if a.is_finite() && b.is_finite() {
            s2 += (f64::from(*a) - f64::from(*b)).powi(2);
            n += 1;
        }
    }
    assert!(n > 60_000, "{n} pixels compared");
    assert!((s2 / n as f64).sqrt() <= 1e-4);
}

#[test]
fn misuse_of_virtual_is_one_clear_error_and_nothing_written() {
    let t = Tmp::new("virtual-bad");
    let ds = t.0.join("ds");
    run(&[
        "render",
        "-q",
        "--scene",
        "plane",
        "--size",
        "160x128",
        "--out",
        s(&ds),
    ]);
    let cal = ds.join("calibration.toml");
    let patterns = ds.join("patterns.toml");
    // A calibration without the full projector model.
    let text = std::fs::read_to_string(&cal).unwrap();
    let cut = text
        .find("[projector")
        .expect("the rendered calibration has [projector]");
    let no_projector = t.0.join("no_projector.toml");
    std::fs::write(&no_projector, &text[..cut]).unwrap();
    let out_dir = t.0.join("out");
    let out = out_dir.join("calibration.toml");
    let cases: [(Vec<&str>, &str); 3] = [
        (
            vec!["--calibration", s(&no_projector)],
            "no [projector] section",
        ),
        (vec!["--calibration", s(&cal), s(&ds)], "give no images"),
        (
            vec!["--calibration", s(&cal), "--plane-point", "0,0,600"],
            "both --plane-point and --plane-normal",
        ),
    ];
    for (extra, want) in cases {
        let mut args = vec![
            "calibrate",
            "reference",
            "--virtual",
            "--patterns",
            s(&patterns),
            "-o",
            s(&out),
        ];
        args.extend(extra);
        let o = fringe3d(&args);
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success(), "{args:?} succeeded");
        assert!(err.contains(want), "{args:?}: {err}");
        assert!(!out_dir.exists(), "{args:?} wrote {}", out_dir.display());
    }
}
