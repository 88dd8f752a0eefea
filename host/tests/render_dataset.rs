//! Dataset folders: determinism, the manifest's hashes, the files readable by the project's own
//! readers, the CLI, scene files and bad input.

use fringe3d::io::calibration::Calibration;
use fringe3d::io::image::{Pixels, read_gray};
use fringe3d::io::npy;
use fringe3d::io::pattern_file::PatternSetFile;
use fringe3d::render::dataset::{DatasetOptions, write_dataset};
use fringe3d::render::{BUILTIN_SCENES, MASK_VALID, Overrides, RenderOptions, Scene, SceneSpec};
use sha2::{Digest, Sha256};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Command;

fn tmp(name: &str) -> PathBuf {
    let p = std::env::temp_dir().join(format!("fringe3d-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&p);
    p
}

fn files(dir: &Path) -> BTreeMap<String, Vec<u8>> {
    fn walk(base: &Path, d: &Path, out: &mut BTreeMap<String, Vec<u8>>) {
        for e in std::fs::read_dir(d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                walk(base, &p, out);
            } else {
                out.insert(
                    p.strip_prefix(base).unwrap().to_string_lossy().into_owned(),
                    std::fs::read(&p).unwrap(),
                );
            }
        }
    }
    let mut m = BTreeMap::new();
    walk(dir, dir, &mut m);
    m
}

fn small(name: &str, seed: u64, noise: f64) -> Scene {
    Scene::builtin(
        name,
        &Overrides {
            size: Some((160, 128)),
            seed: Some(seed),
            noise: Some(noise),
            bits: Some(12),
            ..Default::default()
        },
    )
    .unwrap()
}

#[test]
fn same_seed_same_bytes_and_other_seed_other_noise() {
    let (a, b, c) = (tmp("det-a"), tmp("det-b"), tmp("det-c"));
    write_dataset(&small("sphere", 5, 3.0), &a, DatasetOptions::default()).unwrap();
    // The second render runs on a single thread: bytes must not depend on the thread count.
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    pool.install(|| write_dataset(&small("sphere", 5, 3.0), &b, DatasetOptions::default()))
        .unwrap();
    write_dataset(&small("sphere", 6, 3.0), &c, DatasetOptions::default()).unwrap();
    let (fa, fb, fc) = (files(&a), files(&b), files(&c));
    assert_eq!(fa.keys().collect::<Vec<_>>(), fb.keys().collect::<Vec<_>>());
    for (k, v) in &fa {
        assert!(
            v == &fb[k],
            "{k} differs between two renders with the same seed"
        );
    }
    for i in 0..8 {
        let k = format!("img_{i:02}.png");
        assert!(fa[&k] != fc[&k], "{k}: another seed must give other noise");
    }
    for k in [
        "truth/points.npy",
        "truth/phase.tif",
        "truth/mask.png",
        "calibration.toml",
        "patterns.toml",
    ] {
        assert!(fa[k] == fc[k], "{k} must not depend on the noise seed");
    }
    // Every file is in the manifest with its SHA-256 and size.
    let m: serde_json::Value = serde_json::from_slice(&fa["manifest.json"]).unwrap();
    let listed = m["files"].as_array().unwrap();
    assert_eq!(
        listed.len() + 1,
        fa.len(),
        "every file but the manifest is listed"
    );
    for f in listed {
        let p = f["path"].as_str().unwrap();
        let bytes = &fa[p];
        let hex: String = Sha256::digest(bytes)
            .iter()
            .map(|b| format!("{b:02x}"))
            .collect();
        assert_eq!(f["sha256"].as_str().unwrap(), hex, "{p}");
        assert_eq!(f["bytes"].as_u64().unwrap(), bytes.len() as u64, "{p}");
    }
    assert_eq!(m["seed"], 5);
    for d in [a, b, c] {
        let _ = std::fs::remove_dir_all(d);
    }
}

#[test]
fn noise_has_the_requested_sigma() {
    let mut spec = SceneSpec::builtin("plane").unwrap();
    spec.apply(&Overrides {
        size: Some((320, 256)),
        noise: Some(4.0),
        ..Default::default()
    });
    let s = Scene::new(spec, None).unwrap();
    let (f, t) = s
        .render_fringes(RenderOptions {
            keep_float: true,
            ..Default::default()
        })
        .unwrap();
    let fl = f.float.as_ref().unwrap();
    let mut d = Vec::new();
    for (img, fimg) in f.images.iter().zip(fl) {
        for p in 0..img.len() {
            if t.mask[p] == MASK_VALID {
                d.push(img[p] as f64 - fimg[p]);
            }
        }
    }
    let n = d.len() as f64;
    let mean = d.iter().sum::<f64>() / n;
    let sd = (d.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / n).sqrt();
    // σ² = 4² + 1/12 (rounding).
    let expect = (16.0f64 + 1.0 / 12.0).sqrt();
    eprintln!(
        "noise: mean {mean:.4}, sd {sd:.4} (expect {expect:.4}) over {} samples",
        d.len()
    );
    assert!(mean.abs() < 0.02 && (sd / expect - 1.0).abs() < 0.01);
}

#[test]
fn dataset_files_read_back_with_the_project_readers() {
    let dir = tmp("readback");
    let scene = small("steps", 1, 0.0);
    let sum = write_dataset(&scene, &dir, DatasetOptions::default()).unwrap();
    assert_eq!(sum.images, 8);
    let cal_path = dir.join("calibration.toml");
    let cal = Calibration::load(&cal_path).unwrap();
    assert_eq!(cal.camera.width, 160);
    assert_eq!(cal.projector_centre, scene.rig.translation);
    let map = cal.reference_map_path(&cal_path).unwrap();
    let (ref_img, _) = read_gray(&map).unwrap();
    let Pixels::F32(ref_phase) = ref_img.pixels else {
        panic!("reference map must be float")
    };
    let (true_img, _) = read_gray(&dir.join("truth/reference_phase_true.tif")).unwrap();
    let Pixels::F32(ref_true) = true_img.pixels else {
        panic!()
    };
    let mut errs = Vec::new();
    for (a, b) in ref_phase.iter().zip(&ref_true) {
        if a.is_finite() && b.is_finite() {
            errs.push((a - b) as f64);
        }
    }
    let rms = (errs.iter().map(|e| e * e).sum::<f64>() / errs.len() as f64).sqrt();
    eprintln!(
        "decoded reference vs true: {} px, rms {rms:.2e} rad",
        errs.len()
    );
    // At 160 × 128 a fringe period spans ~2 camera pixels, so the 3 × 3 box average of the
    // strongly curved phase biases it by ~1e-2 rad; render_phase checks the full-size map.
    assert!(errs.len() > 15_000 && rms < 5e-2, "{rms}");
    let pf = PatternSetFile::load(&cal.reference_pattern_path(&cal_path).unwrap()).unwrap();
    assert_eq!(pf.to_pattern_set().unwrap(), scene.patterns);
    let imgs = pf.image_paths(&dir.join("patterns.toml")).unwrap();
    assert_eq!(imgs.len(), 8);
    for p in &imgs {
        let (g, info) = read_gray(p).unwrap();
        assert_eq!((g.width, g.height, g.significant_bits), (160, 128, 12));
        assert!(!info.converted_from_color);
        let Pixels::U16(v) = g.pixels else {
            panic!("12-bit images are stored in 16-bit PNGs")
        };
        assert!(v.iter().all(|&x| x <= 4095));
    }
    let (shape, pts) =
        npy::decode_f64(&std::fs::read(dir.join("truth/points.npy")).unwrap()).unwrap();
    assert_eq!(shape, vec![128, 160, 3]);
    let (mask, _) = read_gray(&dir.join("truth/mask.png")).unwrap();
    let Pixels::U8(mask) = mask.pixels else {
        panic!()
    };
    let hits = mask.iter().filter(|&&m| m & 1 == 1).count();
    let finite = pts.chunks(3).filter(|p| p[0].is_finite()).count();
    assert_eq!(hits, finite);
    let scene2 = SceneSpec::load(&dir.join("scene.toml")).unwrap();
    assert_eq!(scene2, scene.spec, "scene.toml reproduces the scene");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn calibration_datasets_have_their_files() {
    let dir = tmp("plates");
    let scene = small("plates", 0, 0.0);
    let sum = write_dataset(&scene, &dir, DatasetOptions::default()).unwrap();
    assert_eq!(sum.images, 3 * 17);
    for k in 0..3 {
        for f in ["v/img_00.png", "v/img_07.png", "h/img_07.png", "board.png"] {
            assert!(
                dir.join(format!("plate_{k:02}/{f}")).is_file(),
                "plate {k} {f}"
            );
        }
        assert!(
            dir.join(format!("truth/plate_{k:02}/phase_h.tif"))
                .is_file()
        );
    }
    let j: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.join("truth/plates.json")).unwrap()).unwrap();
    let plates = j["plates"].as_array().unwrap();
    assert_eq!(plates.len(), 3);
    // Parallel plates: same normal.
    assert_eq!(plates[0]["plane_normal"], plates[2]["plane_normal"]);
    assert!(
        Calibration::load(&dir.join("calibration.toml"))
            .unwrap()
            .reference
            .is_some()
    );
    let _ = std::fs::remove_dir_all(&dir);

    let dir = tmp("boards");
    let mut spec = SceneSpec::builtin("checkerboard").unwrap();
    spec.apply(&Overrides {
        size: Some((320, 256)),
        ..Default::default()
    });
    spec.board.as_mut().unwrap().count = 3;
    let sum = write_dataset(
        &Scene::new(spec, None).unwrap(),
        &dir,
        DatasetOptions::default(),
    )
    .unwrap();
    assert_eq!(sum.images, 3);
    let j: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.join("truth/corners.json")).unwrap()).unwrap();
    assert_eq!(j["poses"].as_array().unwrap().len(), 3);
    assert_eq!(j["poses"][0]["corners_px"].as_array().unwrap().len(), 70);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn existing_folder_is_kept_unless_overwrite() {
    let dir = tmp("overwrite");
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("keep.txt"), b"x").unwrap();
    let s = small("plane", 0, 0.0);
    let e = write_dataset(&s, &dir, DatasetOptions::default())
        .unwrap_err()
        .to_string();
    assert!(e.contains("not empty"), "{e}");
    assert!(dir.join("keep.txt").is_file());
    write_dataset(
        &s,
        &dir,
        DatasetOptions {
            overwrite: true,
            ..Default::default()
        },
    )
    .unwrap();
    assert!(!dir.join("keep.txt").exists() && dir.join("manifest.json").is_file());
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn example_scene_files_are_valid() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples/scenes");
    let mut n = 0;
    for e in std::fs::read_dir(&dir).unwrap() {
        let p = e.unwrap().path();
        if p.extension().is_some_and(|x| x == "toml") {
            let s = SceneSpec::load(&p).unwrap_or_else(|e| panic!("{e}"));
            Scene::new(s, p.parent()).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
            n += 1;
        }
    }
    assert!(
        n >= 8,
        "expected the built-in scenes and more as examples, found {n}"
    );
}

#[test]
fn bad_scenes_are_errors_that_name_the_problem() {
    let p = Path::new("bad.toml");
    let mut base = SceneSpec::builtin("sphere").unwrap().to_toml().unwrap();
    let e = SceneSpec::parse(&(base.clone() + "\nwobble = 3\n"), p)
        .unwrap_err()
        .to_string();
    assert!(e.contains("bad.toml") && e.contains("wobble"), "{e}");
    base = base.replace("radius = 60.0", "radius = -1.0");
    let s = SceneSpec::parse(&base, p).unwrap();
    let e = Scene::new(s, None).unwrap_err().to_string();
    assert!(e.contains("radius"), "{e}");
    let mut s = SceneSpec::builtin("plane").unwrap();
    s.camera.bits = 10;
    assert!(
        Scene::new(s, None)
            .unwrap_err()
            .to_string()
            .contains("bits")
    );
    let mut s = SceneSpec::builtin("plane").unwrap();
    s.projector.defocus = f64::NAN;
    let sc = Scene::new(s, None);
    let msg = match sc {
        Err(e) => e.to_string(),
        Ok(sc) => sc
            .render_fringes(RenderOptions::default())
            .unwrap_err()
            .to_string(),
    };
    assert!(msg.contains("defocus"), "{msg}");
    assert!(
        SceneSpec::builtin("teapot")
            .unwrap_err()
            .to_string()
            .contains("teapot")
    );
    for n in BUILTIN_SCENES {
        assert!(SceneSpec::builtin(n).is_ok());
    }
}

#[test]
fn cli_renders_and_reports() {
    let exe = env!("CARGO_BIN_EXE_fringe3d");
    let out = Command::new(exe)
        .args(["render", "--help"])
        .output()
        .unwrap();
    let help = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success() && help.contains("Examples") && help.contains("--defocus"),
        "{help}"
    );
    let out = Command::new(exe)
        .args(["render", "--scene", "teapot", "--out", "x"])
        .output()
        .unwrap();
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("teapot"));
    let out = Command::new(exe)
        .args(["render", "--scene", "/nonexistent/s.toml", "--out", "x"])
        .output()
        .unwrap();
    assert!(
        !out.status.success()
            && String::from_utf8_lossy(&out.stderr).contains("/nonexistent/s.toml")
    );
    let out = Command::new(exe)
        .args(["render", "--scene", "ballbar", "--print"])
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(SceneSpec::parse(&text, Path::new("p.toml")).is_ok());
    let dir = tmp("cli");
    let out = Command::new(exe)
        .args([
            "--json",
            "render",
            "--scene",
            "ballbar",
            "--size",
            "128x96",
            "--supersample",
            "1",
            "--bits",
            "8",
            "--pattern-bits",
            "8",
        ])
        .arg("--out")
        .arg(&dir)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let j: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(j["images"], 8);
    let (g, _) = read_gray(&dir.join("img_00.png")).unwrap();
    assert!(matches!(g.pixels, Pixels::U8(_)) && g.width == 128);
    let _ = std::fs::remove_dir_all(&dir);
}
