//! HDR scans (issue #19 item 4) on a rendered glossy sphere (`examples/scenes/specular.toml`):
//! the renderer's Blinn-Phong highlight clips at the exposure metered for the diffuse light.
//!
//! - The quality bar: the highlight saturates at least 5 % of the sphere's pixels at the long
//!   exposure; the unclipped case is the same scene through an ideal sensor that does not clip (a
//!   16-bit container at the 8-bit camera's gain and noise stream, decoded with the 8-bit
//!   thresholds). With a second exposure at a quarter of the light, at least 99 % of the
//!   sphere's pixels that the unclipped sensor resolves get a point within 1 mm, at its RMS
//!   within 10 %; with a third, four times longer, first, the same, and the dim flank (the
//!   projector's grazing light, which no exposure of the first two resolves) shrinks.
//! - `scan --hdr` through the binary: the streaming pass writes the whole-frame path's file byte
//!   for byte; the exposures out of order, a single folder, or folders of other sizes are
//!   refused with one line naming the folder, and nothing is written.

use std::path::{Path, PathBuf};

use fringe3d::accuracy::load_truth;
use fringe3d::adapt::experiment::{RESOLVED, Score, score_detail};
use fringe3d::cli::common;
use fringe3d::scan::{ScanCalibration, filter_edges};
use fringe3d_core::decode::DecodeConfig;

use crate::cli_support::{Tmp, fringe3d, run, s, scan_whole_frame};

fn scene() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples/scenes/specular.toml")
}

fn render(out: &Path, size: &str, extra: &[&str]) {
    let scene = scene();
    let scene_arg = s(&scene);
    let mut a = vec![
        "render",
        "-q",
        "--scene",
        scene_arg,
        "--size",
        size,
        "--out",
        s(out),
    ];
    a.extend_from_slice(extra);
    run(&a);
}

/// The score on the sphere of the scan of `folders` (one, or an HDR series) with `cfg`, through
/// the library path of `fringe3d scan` (the calibration of `cal_ds`, the edge filter).
fn scan_score(
    cal_ds: &Path,
    folders: &[PathBuf],
    truth: &Path,
    cfg: Option<DecodeConfig>,
) -> Score {
    let ls = common::load_set(&cal_ds.join("patterns.toml")).unwrap();
    let cal = ScanCalibration::load(&cal_ds.join("calibration.toml"), ls.set.axis()).unwrap();
    let imgs = match folders {
        [one] => common::load_images(&ls, std::slice::from_ref(one), true).unwrap(),
        many => common::load_exposures(&ls, many, true).unwrap(),
    };
    let cfg = cfg.unwrap_or_else(|| common::decode_config(&imgs));
    let d = common::decode(&ls.set, &imgs, cfg).unwrap();
    let mut cloud = cal.reconstruct(&d.phase, &d.validity, true).unwrap();
    filter_edges(&mut cloud, &cal.edge_filter(80.0).unwrap());
    score_detail(&cloud, &load_truth(truth).unwrap(), 1.0)
}

#[test]
fn a_second_exposure_recovers_the_highlight_at_the_unclipped_accuracy() {
    let t = Tmp::new("hdr-quality");
    let (long, short, ideal) = (t.0.join("long"), t.0.join("short"), t.0.join("ideal"));
    render(&long, "640x512", &[]);
    render(&short, "640x512", &["--exposure", "0.25", "--seed", "7"]);
    // The ideal sensor: 16-bit full scale, the same gain (automatic exposure meters the same
    // light at 65535/255 times the level), the same noise stream.
    let same_gain = (255.0f64 / 65535.0).to_string();
    render(
        &ideal,
        "640x512",
        &["--bits", "16", "--exposure", &same_gain],
    );
    let eight = DecodeConfig::for_bit_depth(8);
    let unclipped = DecodeConfig {
        saturation_level: 65535.0,
        ..eight
    };

    let single = scan_score(&long, std::slice::from_ref(&long), &long, None);
    let fused = scan_score(&long, &[long.clone(), short.clone()], &long, None);
    let reference = scan_score(&long, std::slice::from_ref(&ideal), &long, Some(unclipped));
    let bright = t.0.join("bright");
    render(&bright, "640x512", &["--exposure", "4", "--seed", "11"]);
    let three = scan_score(
        &long,
        &[bright.clone(), long.clone(), short.clone()],
        &long,
        None,
    );
    println!(
        "three exposures (4, 1, 0.25): {:.2} % unresolvable, RMS {:.1} µm, lost {:?}",
        100.0 * three.unresolvable,
        1e3 * three.rms_mm,
        three.lost
    );
    let share = |s: &Score, what: &str| *s.lost.get(what).unwrap_or(&0) as f64 / s.pixels as f64;
    let saturated = share(&single, "saturated");
    println!(
        "sphere, {} px: long exposure alone {:.2} % unresolvable ({:.2} % saturated), RMS {:.1} µm; \
         two exposures {:.2} %, RMS {:.1} µm; unclipped {:.2} %, RMS {:.1} µm; lost {:?}",
        single.pixels,
        100.0 * single.unresolvable,
        100.0 * saturated,
        1e3 * single.rms_mm,
        100.0 * fused.unresolvable,
        1e3 * fused.rms_mm,
        100.0 * reference.unresolvable,
        1e3 * reference.rms_mm,
        fused.lost
    );
    assert!(single.pixels > 10_000, "{} sphere pixels", single.pixels);
    assert!(
        saturated >= 0.05,
        "the highlight clips {:.2} %",
        100.0 * saturated
    );
    assert_eq!(share(&fused, "saturated"), 0.0);
    // Coverage: of the sphere's pixels the unclipped sensor resolves at this exposure, the share
    // the HDR series resolves (what clipping took and HDR must give back).
    let coverage = |s: &Score| {
        let both = (s.status.iter().zip(&reference.status))
            .filter(|&(&a, &b)| a == RESOLVED && b == RESOLVED)
            .count();
        let base = reference.status.iter().filter(|&&b| b == RESOLVED).count();
        both as f64 / base as f64
    };
    println!(
        "coverage of the unclipped sensor's points: long alone {:.2} %, two exposures {:.2} %, \
         three {:.2} %",
        100.0 * coverage(&single),
        100.0 * coverage(&fused),
        100.0 * coverage(&three)
    );
    assert!(coverage(&single) < 0.85, "{}", coverage(&single));
    assert!(
        coverage(&fused) >= 0.99,
        "HDR covers {:.2} %",
        100.0 * coverage(&fused)
    );
    assert!(coverage(&three) >= 0.99, "{}", coverage(&three));
    // A longer first exposure also lifts the dim flank (the projector's grazing light).
    assert!(three.unresolvable < fused.unresolvable);
    assert!(
        fused.rms_mm <= 1.10 * reference.rms_mm,
        "HDR {:.1} µm against {:.1} µm unclipped",
        1e3 * fused.rms_mm,
        1e3 * reference.rms_mm
    );
}

/// `scan` arguments for the set and calibration of `ds`, output `out`.
fn scan_args<'a>(ds: &'a Path, out: &'a Path, images: &[&'a Path]) -> Vec<String> {
    let mut a = vec![
        "scan".to_string(),
        "-q".into(),
        "-p".into(),
        s(&ds.join("patterns.toml")).to_string(),
        "-c".into(),
        s(&ds.join("calibration.toml")).to_string(),
        "--hdr".into(),
        "-o".into(),
        s(out).to_string(),
    ];
    a.extend(images.iter().map(|p| s(p).to_string()));
    a
}

#[test]
fn scan_hdr_streams_the_whole_frame_file_and_refuses_bad_series() {
    let t = Tmp::new("hdr-cli");
    let (long, short) = (t.0.join("long"), t.0.join("short"));
    render(&long, "320x256", &[]);
    render(&short, "320x256", &["--exposure", "0.25", "--seed", "7"]);
    let streamed = t.0.join("streamed.ply");
    let args = scan_args(&long, &streamed, &[&long, &short]);
    let argv: Vec<&str> = args.iter().map(String::as_str).collect();
    run(&argv);
    let whole = t.0.join("whole.ply");
    scan_whole_frame(&scan_args(&long, &whole, &[&long, &short]));
    let (x, y) = (
        std::fs::read(&streamed).unwrap(),
        std::fs::read(&whole).unwrap(),
    );
    assert!(
        x == y,
        "the streamed HDR file differs from the whole-frame one"
    );

    // Refusals: one line naming the folder, non-zero exit, no file.
    let other = t.0.join("other");
    render(&other, "160x128", &["--exposure", "0.25"]);
    let out = t.0.join("refused.ply");
    let cases: [(&[&Path], &str, &str); 3] = [
        (&[&short, &long], "longest first", s(&long)),
        (&[&long], "2 to 4 folders", "--hdr"),
        (&[&long, &other], "160x128", s(&other)),
    ];
    for (folders, what, names) in cases {
        let args = scan_args(&long, &out, folders);
        let argv: Vec<&str> = args.iter().map(String::as_str).collect();
        let o = fringe3d(&argv);
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success(), "{folders:?} accepted");
        assert!(
            err.contains(what) && err.contains(names),
            "{folders:?}: {err}"
        );
        assert_eq!(err.trim().lines().count(), 1, "{err}");
        assert!(!out.exists(), "{folders:?} wrote a file");
    }
}
