//! `fringe3d scan` end to end through the binary on a small rendered dataset: the PLY written with
//! one thread equals the one written with all threads byte for byte, and the library's kernel
//! variants (baseline, AVX2; serial, parallel) give the same bits.

use crate::cli_support::{VARIANTS, decode_variant};
use fringe3d::cli::common;
use fringe3d::io::image_set::Frames;
use fringe3d::scan::ScanCalibration;
use fringe3d_core::decode::Decoder;
use std::path::PathBuf;
use std::process::Command;

struct Tmp(PathBuf);
impl Drop for Tmp {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

fn run(args: &[&str]) {
    let out = Command::new(env!("CARGO_BIN_EXE_fringe3d"))
        .args(args)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
}

#[test]
fn single_and_multi_threaded_scans_are_identical() {
    let t = Tmp(std::env::temp_dir().join(format!("fringe3d-cli-scan-{}", std::process::id())));
    let _ = std::fs::remove_dir_all(&t.0);
    let ds = t.0.join("ds");
    let ds_s = ds.to_str().unwrap();
    run(&[
        "render", "-q", "--scene", "ballbar", "--size", "320x256", "--noise", "1", "--bits", "8",
        "--out", ds_s,
    ]);
    let set = ds.join("patterns.toml");
    let cal = ds.join("calibration.toml");
    let mut plys = Vec::new();
    for (j, extra) in [
        ("1", "--organized"),
        ("2", "--organized"),
        ("1", "--ascii"),
        ("2", "--ascii"),
    ] {
        let out = t.0.join(format!("cloud-{j}{extra}.ply"));
        run(&[
            "scan",
            "-q",
            "-j",
            j,
            extra,
            "--patterns",
            set.to_str().unwrap(),
            "--calibration",
            cal.to_str().unwrap(),
            ds_s,
            "-o",
            out.to_str().unwrap(),
        ]);
        plys.push(std::fs::read(&out).unwrap());
    }
    assert!(
        plys[0].len() > 320 * 256 * 12,
        "organized cloud holds every pixel"
    );
    assert_eq!(
        plys[0], plys[1],
        "organized PLY differs between 1 and 2 threads"
    );
    assert_eq!(
        plys[2], plys[3],
        "ASCII PLY differs between 1 and 2 threads"
    );

    // Library: every decode and reconstruction variant gives the same bits.
    let ls = common::load_set(&set).unwrap();
    let sc = ScanCalibration::load(&cal, ls.set.axis()).unwrap();
    let imgs = common::load_images(&ls, &[], true).unwrap();
    let d = Decoder::new(&ls.set, common::decode_config(&imgs)).unwrap();
    let Frames::U8(f) = &imgs.frames else {
        panic!("8-bit set expected")
    };
    let fr: Vec<&[u8]> = f.iter().map(|v| v.as_slice()).collect();
    let (w, h) = (imgs.width as usize, imgs.height as usize);
    let mut results = Vec::new();
    for variant in VARIANTS {
        let (p, _, _, v) = decode_variant(&d, &fr, (w, h), variant);
        let (isa, par) = variant;
        let cloud = sc.reconstruct_with(&p, &v, par, isa).unwrap();
        let bits: Vec<u32> = p
            .iter()
            .chain(&cloud.xyz)
            .map(|x| fringe3d_core::math::canonical(*x).to_bits())
            .collect();
        results.push((bits, cloud.validity));
    }
    assert!(results[0].1.contains(&0), "some valid points");
    for r in &results[1..] {
        assert!(
            r.0 == results[0].0 && r.1 == results[0].1,
            "variants differ"
        );
    }
}

/// `scan` takes the decoder's thresholds that `decode` has (issue #19 item 5): a stricter minimum
/// modulation flags more pixels low-modulation (the validity counts of `--json`), and values
/// outside their meaningful range are one clear error with nothing written.
#[test]
fn scan_takes_the_decode_thresholds() {
    let t = Tmp(std::env::temp_dir().join(format!("fringe3d-cli-thr-{}", std::process::id())));
    let _ = std::fs::remove_dir_all(&t.0);
    let ds = t.0.join("ds");
    let ds_s = ds.to_str().unwrap();
    run(&[
        "render", "-q", "--scene", "ballbar", "--size", "160x128", "--noise", "1", "--bits", "8",
        "--out", ds_s,
    ]);
    let (set, cal) = (ds.join("patterns.toml"), ds.join("calibration.toml"));
    let scan = |out: &str, extra: &[&str]| {
        let mut a = vec![
            "--json",
            "scan",
            "--patterns",
            set.to_str().unwrap(),
            "--calibration",
            cal.to_str().unwrap(),
            ds_s,
        ];
        let o = t.0.join(out);
        let o = o.to_str().unwrap().to_string();
        a.extend(["-o", &o]);
        a.extend(extra);
        Command::new(env!("CARGO_BIN_EXE_fringe3d"))
            .args(&a)
            .output()
            .unwrap()
    };
    let counts = |o: &std::process::Output| -> (u64, u64) {
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        (
            j["validity"]["low-modulation"].as_u64().unwrap(),
            j["validity"]["valid"].as_u64().unwrap(),
        )
    };
    let (low0, valid0) = counts(&scan("a.ply", &[]));
    let (low1, valid1) = counts(&scan("b.ply", &["--min-modulation", "60"]));
    assert!(
        low1 > low0 && valid1 < valid0,
        "{low0}/{valid0} vs {low1}/{valid1}"
    );
    for (args, msg) in [
        (["--min-modulation", "300"], "0 to 255 camera codes"),
        (["--range-tolerance", "5"], "at most π radians"),
        (["--saturation", "0"], "more than 0"),
        (["--unwrap-tolerance", "NaN"], "--unwrap-tolerance"),
    ] {
        let o = scan("bad.ply", &args);
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success() && err.contains(msg), "{args:?}: {err}");
        assert!(!t.0.join("bad.ply").exists());
    }
}
