//! The codes real rigs use, on rendered scans with truth (issue #20's quality bar): Gray code +
//! phase shifting, 3-frequency heterodyne and binary defocused patterns. The renderer projects a pattern-set file's images
//! onto its scenes through the projector's defocus, an 8-bit camera with σ = 1 code of read
//! noise; the core decoder's phase is compared with the exact phase of the point each pixel sees.
//!
//! - zero fringe-order errors on valid pixels (plain and complementary codes, heterodyne 21/26/32,
//!   three scenes);
//! - the phase RMS, in units of each pixel's 4-step noise prediction `√(2/N)·σ/B` (σ² = 1 +
//!   1/12 for the rounding; for a binary set times the slope `1 − Δ'` of the phase-error
//!   table, which stretches the noise where the harmonics compress the measured phase), within
//!   10 % of 1 on pixels with B/σ ≥ 14;
//! - the complementary code refuses no pixel for its code or order on a smooth surface (no
//!   boundary losses), the plain one refuses some (it cannot tell a period edge's side);
//! - binary patterns (squared binary after a Gray code, Bayer-dithered 12-image set) through a
//!   defocused projector, decoded with the table of its blur: the same bar;
//! - the CLI: `patterns`, `render` and `scan` take a Gray-code, a heterodyne and a binary set
//!   file end to end; `patterns` writes the binary set as 1-bit PNGs; `scan` refuses a binary
//!   set without `projector_defocus`, and `calibrate defocus` measures the rendered blur again
//!   (within 0.3 pixel of 3).

use crate::cli_support::Tmp;
use std::path::Path;
use std::process::Command;

use fringe3d::io::pattern_file::PatternSetFile;
use fringe3d::render::dataset::{DatasetOptions, write_dataset};
use fringe3d::render::{MASK_VALID, Overrides, RenderOptions, Scene, SceneSpec};
use fringe3d_core::decode::{DecodeConfig, Decoder, RowOut};
use fringe3d_core::validity::Validity;

/// 32 periods across a 1024-column projector (32 projector pixels per period), ordered by a
/// 6-bit Gray code (complementary or not), then a 4-step level.
fn set_file(complementary: bool) -> String {
    gray_set_file(&format!("complementary = {complementary}"))
}

/// [`set_file`]'s set with the Gray level's options `code` (e.g. `shifted = true`).
fn gray_set_file(code: &str) -> String {
    format!(
        "version = 2\n\
         [projector]\nwidth = 1024\nheight = 768\n\
         [phase]\naxis = \"xi\"\nkind = \"linear\"\norigin = 511.5\nslope = {slope}\n\
         [[levels]]\nscale = 32.0\ngray_bits = 6\n{code}\n\
         [[levels]]\nscale = 32.0\nsteps = 4\n",
        slope = std::f64::consts::TAU / 1024.0,
    )
}

/// Three 4-step levels of scales 21, 26 and 32 over the default 0.9·2π phase: 18.9, 23.4 and
/// 28.8 periods, beats of 4.5 and 5.4, their beat 0.9 periods.
const HETERODYNE: &str = "version = 2\nunwrap = \"heterodyne\"\n\
    [projector]\nwidth = 1024\nheight = 768\n\
    [[levels]]\nscale = 21.0\nsteps = 4\n\
    [[levels]]\nscale = 26.0\nsteps = 4\n\
    [[levels]]\nscale = 32.0\nsteps = 4\n";

/// Binary patterns (issue #20 item 3) for a projector defocused by [`BINARY_DEFOCUS`] pixels: the
/// classic squared-binary scheme (the complementary Gray code above, then a 1-bit 4-step level
/// of 32-pixel period), or three 4-step levels dithered (Bayer), periods 1024, 171 and 32
/// pixels. The finest period is a multiple of the dither's 8-pixel tile, so that its error
/// repeats with the phase, which the table removes (at 31.6 pixels it beats with the tile over
/// 630 pixels and no table of the phase can: docs/binary.md).
fn binary_file(kind: &str) -> String {
    match kind {
        "square" => format!("binary = \"square\"\n{}", set_file(true)),
        _ => format!(
            "version = 2\nbinary = \"bayer\"\n\
             [projector]\nwidth = 1024\nheight = 768\n\
             [phase]\naxis = \"xi\"\nkind = \"linear\"\norigin = 511.5\nslope = {slope}\n\
             [[levels]]\nscale = 1.0\nsteps = 4\n\
             [[levels]]\nscale = 6.0\nsteps = 4\n\
             [[levels]]\nscale = 32.0\nsteps = 4\n",
            slope = std::f64::consts::TAU / 1024.0,
        ),
    }
}

/// The projector's blur σ for the binary scans, projector pixels: a 32-pixel square wave keeps a
/// 3rd harmonic of 8 % of its fundamental (exp(−2π²·8·σ²/32²)/3), and the dither's 8-pixel tile
/// 6 % of its contrast (exp(−2π²σ²/8²)), both repeating with the phase: the decoder's table
/// removes them.
const BINARY_DEFOCUS: f64 = 3.0;

fn scene(name: &str, set: &Path) -> Scene {
    scene_with(name, set, None)
}

fn scene_with(name: &str, set: &Path, defocus: Option<f64>) -> Scene {
    let mut spec = SceneSpec::builtin(name).unwrap();
    spec.apply(&Overrides {
        defocus,
        size: Some((320, 256)),
        supersample: Some(1),
        bits: Some(8),
        noise: Some(1.0),
        pattern_bits: Some(8),
        seed: Some(11),
        exposure: None,
    });
    spec.patterns.set = Some(PatternSetFile::load(set).unwrap());
    Scene::new(spec, None).unwrap()
}

struct Score {
    /// Valid pixels (decoder) that the renderer also marks valid.
    valid: usize,
    /// Of those, more than π from the truth.
    order_errors: usize,
    /// RMS of the error over the predicted noise, pixels with B ≥ 14.
    normalized_rms: f64,
    /// Pixels refused as `CodeAmbiguous` or `UnwrapInconsistent` among the lit ones.
    edge_refusals: usize,
    /// Of those, the ones in the middle of a fringe (true wrapped phase within ±π/2).
    mid_fringe_refusals: usize,
}

fn score(scene: &Scene) -> Score {
    let (f, t) = scene.render_fringes(RenderOptions::default()).unwrap();
    let truth = scene.true_phase(&t);
    let set = &scene.patterns;
    let mut d = Decoder::new(set, DecodeConfig::for_bit_depth(8)).unwrap();
    // A binary set is decoded with the table of the projector's true blur (what a calibration's
    // `projector_defocus` gives `fringe3d scan`).
    let correction = scene.true_correction(set).unwrap();
    if let Some(c) = &correction {
        assert!(set.binarization().is_binary());
        d = d.with_correction(c).unwrap();
    }
    // The table maps the measured phase φ to θ = φ − Δ(φ): it scales the noise by its slope
    // 1 − Δ'(φ) at the pixel's phase (harmonics that compress the measured phase stretch its
    // noise back). 1 without a table.
    let fine = set.levels().len() - 1;
    let slope = |theta: f64| match &correction {
        None => 1.0,
        Some(c) => {
            let mut phi = theta;
            for _ in 0..50 {
                phi = theta + (phi - c.reference(fine, phi));
            }
            let h = 1e-3;
            (c.reference(fine, phi + h) - c.reference(fine, phi - h)) / (2.0 * h)
        }
    };
    let (w, h) = (f.width as usize, f.height as usize);
    let frames: Vec<Vec<u8>> = f
        .images
        .iter()
        .map(|i| i.iter().map(|&v| v as u8).collect())
        .collect();
    let sigma2: f64 = 1.0 + 1.0 / 12.0;
    let (mut valid, mut order_errors, mut edge_refusals, mut mid_fringe_refusals) = (0, 0, 0, 0);
    let (mut sum, mut n) = (0.0, 0usize);
    let (mut ph, mut mo, mut dc, mut va) =
        (vec![0f32; w], vec![0f32; w], vec![0f32; w], vec![0u8; w]);
    for y in 0..h {
        let rows: Vec<&[u8]> = frames.iter().map(|i| &i[y * w..(y + 1) * w]).collect();
        let out = RowOut {
            phase: &mut ph,
            modulation: &mut mo,
            dc: &mut dc,
            validity: &mut va,
        };
        d.decode_row(&rows, out).unwrap();
        for x in 0..w {
            let p = y * w + x;
            if t.mask[p] != MASK_VALID || !truth[p].is_finite() {
                continue;
            }
            if va[x] == Validity::CodeAmbiguous as u8 || va[x] == Validity::UnwrapInconsistent as u8
            {
                edge_refusals += 1;
                let tau = std::f64::consts::TAU;
                let wrapped = truth[p] - tau * (truth[p] / tau).round();
                mid_fringe_refusals += (wrapped.abs() < std::f64::consts::FRAC_PI_2) as usize;
            }
            if va[x] != Validity::Valid as u8 {
                continue;
            }
            valid += 1;
            let e = ph[x] as f64 - truth[p];
            if e.abs() > std::f64::consts::PI {
                order_errors += 1;
                continue;
            }
            let b = mo[x] as f64;
            if b >= 14.0 {
                let wrapped =
                    truth[p] - std::f64::consts::TAU * (truth[p] / std::f64::consts::TAU).round();
                let pred = (0.5 * sigma2).sqrt() / b * slope(wrapped).abs();
                sum += (e / pred).powi(2);
                n += 1;
            }
        }
    }
    assert!(n > 1000, "{n} pixels at B >= 14");
    Score {
        valid,
        order_errors,
        normalized_rms: (sum / n as f64).sqrt(),
        edge_refusals,
        mid_fringe_refusals,
    }
}

/// The scene's score, held to the bar: a real scene decoded, no order error, the phase noise
/// within 10 % of the prediction.
fn meets_the_bar(scene: &Scene, what: &str) -> Score {
    let s = score(scene);
    eprintln!(
        "{what}: {} valid, {} edge refusals, RMS {:.3}",
        s.valid, s.edge_refusals, s.normalized_rms
    );
    assert!(s.valid > 10_000, "{what}: {} valid", s.valid);
    assert_eq!(s.order_errors, 0, "{what}: fringe-order errors");
    assert!(
        (s.normalized_rms - 1.0).abs() <= 0.10,
        "{what}: phase RMS {:.3} x the prediction",
        s.normalized_rms
    );
    s
}

#[test]
fn gray_code_scans_meet_the_quality_bar() {
    let t = Tmp::new("gray-bar");
    for comp in [false, true] {
        let f = t.0.join(format!("gray-{comp}.toml"));
        std::fs::write(&f, set_file(comp)).unwrap();
        let mut refusals = 0;
        for name in ["plane", "sphere", "steps"] {
            let what = format!("{name}, complementary {comp}");
            let s = meets_the_bar(&scene(name, &f), &what);
            if comp && name != "steps" {
                // Smooth surfaces: no pixel lost at a stripe or period edge.
                assert_eq!(s.edge_refusals, 0, "{what}: edge refusals");
            }
            refusals += s.edge_refusals;
        }
        if !comp {
            assert!(refusals > 0, "the plain code refused no edge pixel");
        }
    }
}

/// The shifted Gray code (stripes moved by half a period, SLMaster's and Wu et al.'s layout):
/// the bar, with its edge pixels refused in the middle of the fringes, where its stripe edges
/// lie, instead of at the wraps as for the plain code.
#[test]
fn shifted_gray_code_scans_meet_the_quality_bar() {
    let t = Tmp::new("gray-shift");
    let (mut mid, mut all, mut plain_mid, mut plain_all) = (0, 0, 0, 0);
    for (code, what) in [
        ("complementary = false\nshifted = true", "shifted"),
        (
            "complementary = false\nshifted = true\ninverse = true",
            "shifted, inverse",
        ),
        ("complementary = false", "plain"),
    ] {
        let f = t.0.join(format!("{}.toml", what.replace(", ", "-")));
        std::fs::write(&f, gray_set_file(code)).unwrap();
        for name in ["plane", "sphere", "steps"] {
            let s = meets_the_bar(&scene(name, &f), &format!("{name}, {what}"));
            if what == "plain" {
                (plain_mid, plain_all) = (
                    plain_mid + s.mid_fringe_refusals,
                    plain_all + s.edge_refusals,
                );
            } else {
                (mid, all) = (mid + s.mid_fringe_refusals, all + s.edge_refusals);
            }
        }
    }
    eprintln!("edge refusals mid-fringe: shifted {mid} of {all}, plain {plain_mid} of {plain_all}");
    assert!(
        all > 0 && mid * 10 >= all * 9,
        "shifted: {mid} of {all} mid-fringe"
    );
    assert!(
        plain_all > 0 && plain_mid * 10 <= plain_all,
        "plain: {plain_mid} of {plain_all}"
    );
}

/// The complementary code with inverse patterns (26 images): every bit against its own inverse.
#[test]
fn inverse_gray_code_scans_meet_the_quality_bar() {
    let t = Tmp::new("gray-inv");
    let f = t.0.join("gray-inverse.toml");
    let text = set_file(true).replace(
        "complementary = true\n",
        "complementary = true\ninverse = true\n",
    );
    assert!(text.contains("inverse = true"));
    std::fs::write(&f, text).unwrap();
    for name in ["plane", "sphere", "steps"] {
        let what = format!("{name}, inverse");
        let s = meets_the_bar(&scene(name, &f), &what);
        if name != "steps" {
            assert_eq!(s.edge_refusals, 0, "{what}: edge refusals");
        }
    }
}

#[test]
fn heterodyne_scans_meet_the_quality_bar() {
    let t = Tmp::new("gray-het");
    let f = t.0.join("heterodyne.toml");
    std::fs::write(&f, HETERODYNE).unwrap();
    for name in ["plane", "sphere", "steps"] {
        meets_the_bar(&scene(name, &f), &format!("heterodyne, {name}"));
    }
}

/// Number-theoretic unwrapping (`examples/patterns/coprime.toml`): scales 5 and 7 (coprime, no
/// level nor their beat within one period), then 35: the same bar.
#[test]
fn coprime_scans_meet_the_quality_bar() {
    let f = std::path::Path::new("../examples/patterns/coprime.toml");
    for name in ["plane", "sphere", "steps"] {
        meets_the_bar(&scene(name, f), &format!("coprime, {name}"));
    }
}

#[test]
fn binary_defocused_scans_meet_the_quality_bar() {
    let t = Tmp::new("binary-bar");
    for kind in ["square", "bayer"] {
        let f = t.0.join(format!("binary-{kind}.toml"));
        std::fs::write(&f, binary_file(kind)).unwrap();
        for name in ["plane", "sphere", "steps"] {
            let scene = scene_with(name, &f, Some(BINARY_DEFOCUS));
            meets_the_bar(&scene, &format!("binary {kind}, {name}"));
        }
    }
}

#[test]
fn patterns_render_and_scan_take_gray_code_heterodyne_and_binary_sets() {
    let t = Tmp::new("gray-cli");
    let het = t.0.join("heterodyne.toml");
    std::fs::write(&het, HETERODYNE).unwrap();
    scan_cli(&t, &het, "het", 12, None);
    let cop = std::path::Path::new("../examples/patterns/coprime.toml");
    scan_cli(&t, cop, "coprime", 12, None);
    let f = t.0.join("gray.toml");
    std::fs::write(&f, set_file(true)).unwrap();
    scan_cli(&t, &f, "gray", 11, None);
    // A binary set: 1-bit PNGs, and its dataset's calibration carries the projector's blur,
    // which `scan` decodes it with.
    let f = t.0.join("binary.toml");
    std::fs::write(&f, binary_file("square")).unwrap();
    scan_cli(&t, &f, "binary", 11, Some(BINARY_DEFOCUS));
    let png = std::fs::read(t.0.join("pat-binary").join("pattern_10.png")).unwrap();
    assert_eq!(
        png[24], 1,
        "the binary set's PNGs are 1-bit (IHDR bit depth)"
    );
    let cal = std::fs::read_to_string(t.0.join("ds-binary").join("calibration.toml")).unwrap();
    assert!(cal.contains("projector_defocus = 3.0"), "{cal}");
    // Without it, `scan` says what is missing.
    let bare = t.0.join("ds-binary").join("bare.toml");
    let stripped: String = cal
        .lines()
        .filter(|l| !l.starts_with("projector_defocus"))
        .map(|l| format!("{l}\n"))
        .collect();
    std::fs::write(&bare, stripped).unwrap();
    let o = Command::new(env!("CARGO_BIN_EXE_fringe3d"))
        .args(["scan", "-q", "--patterns"])
        .arg(t.0.join("ds-binary").join("patterns.toml"))
        .arg("--calibration")
        .arg(&bare)
        .arg(t.0.join("ds-binary"))
        .arg("-o")
        .arg(t.0.join("bare.ply"))
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        !o.status.success() && err.contains("projector_defocus"),
        "{err}"
    );
    assert!(!t.0.join("bare.ply").exists());
    // `device upload` takes the set with the calibration (the table goes with it), and without
    // one says what it needs, before touching the port.
    for cal in [None, Some(&bare)] {
        let mut cmd = Command::new(env!("CARGO_BIN_EXE_fringe3d"));
        cmd.args(["device", "upload", "--port"])
            .arg(t.0.join("no-such-port"))
            .arg("-p")
            .arg(t.0.join("ds-binary").join("patterns.toml"));
        if let Some(c) = cal {
            cmd.arg("-c").arg(c);
        }
        let o = cmd.output().unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(
            !o.status.success()
                && err.contains("projector_defocus")
                && !err.contains("no-such-port"),
            "{err}"
        );
    }
    // `calibrate defocus` measures it from the scan itself: the rendered blur, found again.
    let est = t.0.join("estimated.toml");
    let o = Command::new(env!("CARGO_BIN_EXE_fringe3d"))
        .args(["--json", "calibrate", "defocus", "-c"])
        .arg(&bare)
        .arg("-p")
        .arg(t.0.join("ds-binary").join("patterns.toml"))
        .arg(t.0.join("ds-binary"))
        .arg("-o")
        .arg(&est)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let sigma = j["projector_defocus"].as_f64().unwrap();
    eprintln!("calibrate defocus: {}", j["fit"]);
    assert!(
        (sigma - BINARY_DEFOCUS).abs() < 0.3,
        "{sigma} vs {BINARY_DEFOCUS}"
    );
    let text = std::fs::read_to_string(&est).unwrap();
    assert!(text.contains("projector_defocus = "), "{text}");
}

/// `patterns` writes `images` PNGs of set file `f`; a rendered dataset of it scans.
fn scan_cli(t: &Tmp, f: &Path, tag: &str, images: usize, defocus: Option<f64>) {
    let f = f.to_path_buf();
    let bin = env!("CARGO_BIN_EXE_fringe3d");
    let pat = t.0.join(format!("pat-{tag}"));
    let o = Command::new(bin)
        .args(["patterns", "--patterns"])
        .arg(&f)
        .arg("-o")
        .arg(&pat)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let pngs = std::fs::read_dir(&pat)
        .unwrap()
        .filter(|e| {
            e.as_ref()
                .unwrap()
                .path()
                .extension()
                .is_some_and(|x| x == "png")
        })
        .count();
    assert_eq!(pngs, images);
    // A rendered dataset scans.
    let ds = t.0.join(format!("ds-{tag}"));
    write_dataset(
        &scene_with("sphere", &f, defocus),
        &ds,
        DatasetOptions {
            overwrite: true,
            progress: None,
        },
    )
    .unwrap();
    let ply = t.0.join(format!("out-{tag}.ply"));
    let o = Command::new(bin)
        .args(["scan", "-q", "--patterns"])
        .arg(ds.join("patterns.toml"))
        .arg("--calibration")
        .arg(ds.join("calibration.toml"))
        .arg(&ds)
        .arg("-o")
        .arg(&ply)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let head = std::fs::read(&ply).unwrap();
    let text = String::from_utf8_lossy(&head[..head.len().min(400)]).into_owned();
    let count: usize = text
        .lines()
        .find_map(|l| l.strip_prefix("element vertex "))
        .and_then(|v| v.trim().parse().ok())
        .unwrap();
    assert!(count > 20_000, "{tag}: {count} points");
}
