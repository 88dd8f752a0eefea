//! The modulation floor in physical terms (issue #19 item 5): the same sphere rendered on an
//! 8-bit camera with σ = 1 code and on a 16-bit one with the same noise relative to full scale
//! (σ = 257 codes). At 2 % of full scale the 16-bit floor admitted pixels down to B/σ ≈ 5, and
//! with them phase errors the 8-bit floor (12 codes = 12σ) refuses; `--noise auto` of `decode`
//! and `scan` estimates σ from the 16-bit images and holds B ≥ 12σ, as for 8 bits; and a
//! calibration that records the sensor's noise makes 12σ `scan`'s default.

use crate::cli_support::{Tmp, run, s};
use fringe3d::cli::common::{self, NoiseArg, ThresholdArgs};
use fringe3d::io::calibration::Calibration;
use fringe3d::io::image_set::{Frames, ImageSet};
use fringe3d::render::{MASK_VALID, Overrides, RenderOptions, Scene, SceneSpec};
use fringe3d::scan::{ScanCalibration, filter_edges};
use fringe3d_core::decode::{DecodeConfig, Decoder, RowOut};
use fringe3d_core::validity::Validity;
use std::path::Path;

fn render(bits: u8, noise: f64) -> (Scene, ImageSet, Vec<f64>, Vec<u8>) {
    let mut spec = SceneSpec::builtin("sphere").unwrap();
    spec.apply(&Overrides {
        size: Some((320, 256)),
        supersample: Some(1),
        bits: Some(bits),
        noise: Some(noise),
        pattern_bits: Some(16),
        seed: Some(5),
        ..Default::default()
    });
    let scene = Scene::new(spec, None).unwrap();
    let (f, t) = scene.render_fringes(RenderOptions::default()).unwrap();
    let truth = scene.true_phase(&t);
    let frames = if bits == 8 {
        Frames::U8(
            f.images
                .iter()
                .map(|i| i.iter().map(|&v| v as u8).collect())
                .collect(),
        )
    } else {
        Frames::U16(f.images.clone())
    };
    let imgs = ImageSet {
        width: f.width,
        height: f.height,
        bits,
        frames,
        paths: vec![],
        warnings: vec![],
    };
    (scene, imgs, truth, t.mask.clone())
}

/// (valid pixels, valid pixels more than 0.25 rad from the truth).
fn count(
    scene: &Scene,
    imgs: &ImageSet,
    truth: &[f64],
    mask: &[u8],
    cfg: DecodeConfig,
) -> (usize, usize) {
    let d = Decoder::new(&scene.patterns, cfg).unwrap();
    let w = imgs.width as usize;
    let (mut ph, mut mo, mut dc, mut va) =
        (vec![0f32; w], vec![0f32; w], vec![0f32; w], vec![0u8; w]);
    let (mut valid, mut off) = (0, 0);
    for y in 0..imgs.height as usize {
        let r = y * w..(y + 1) * w;
        let out = RowOut {
            phase: &mut ph,
            modulation: &mut mo,
            dc: &mut dc,
            validity: &mut va,
        };
        match &imgs.frames {
            Frames::U8(f) => {
                let rows: Vec<&[u8]> = f.iter().map(|i| &i[r.clone()]).collect();
                d.decode_row(&rows, out).unwrap();
            }
            Frames::U16(f) => {
                let rows: Vec<&[u16]> = f.iter().map(|i| &i[r.clone()]).collect();
                d.decode_row(&rows, out).unwrap();
            }
        }
        for x in 0..w {
            let p = y * w + x;
            if va[x] != Validity::Valid as u8 || mask[p] != MASK_VALID || !truth[p].is_finite() {
                continue;
            }
            valid += 1;
            off += ((ph[x] as f64 - truth[p]).abs() > 0.25) as usize;
        }
    }
    (valid, off)
}

#[test]
fn sixteen_bit_images_get_the_eight_bit_floor_in_physical_terms() {
    // A noisy camera: σ = 4 codes of 8 bits, 1028 of 16.
    let (s8, i8, t8, m8) = render(8, 4.0);
    let (s16, i16, t16, m16) = render(16, 1028.0);
    let est = fringe3d::noise::estimate(&s16.patterns, &i16).unwrap();
    assert!(
        (est.sigma / 1028.0 - 1.0).abs() < 0.05,
        "estimated σ {}",
        est.sigma
    );
    // 8 bits: σ² = 16 + 1/12 for the rounding.
    let est8 = fringe3d::noise::estimate(&s8.patterns, &i8).unwrap();
    assert!(
        (est8.sigma / 4.01 - 1.0).abs() < 0.05,
        "8-bit σ {}",
        est8.sigma
    );

    // 8 bits told its noise; 16 bits estimating it (`--noise auto`).
    let told = ThresholdArgs {
        noise: Some(NoiseArg::Codes(4.0)),
        ..Default::default()
    };
    let eight = count(
        &s8,
        &i8,
        &t8,
        &m8,
        told.config(&s8.patterns, &i8, None).unwrap(),
    );
    let auto = ThresholdArgs {
        noise: Some(NoiseArg::Auto),
        ..Default::default()
    };
    let cfg16 = auto.config(&s16.patterns, &i16, None).unwrap();
    assert_eq!(cfg16.min_modulation, 12.0 * est.sigma);
    let new = count(&s16, &i16, &t16, &m16, cfg16);
    let old = count(&s16, &i16, &t16, &m16, DecodeConfig::for_bit_depth(16));
    eprintln!("valid, > 0.25 rad off: 8-bit {eight:?}, 16-bit now {new:?}, at 2 % FS {old:?}");
    // The old floor (B/σ ≥ 1.3 here) admits pixels a quarter radian off; B ≥ 12σ none.
    assert!(old.1 > 10, "the old floor's outliers: {old:?}");
    assert_eq!(new.1, 0, "16-bit outliers {new:?}");
    assert_eq!(eight.1, 0, "8-bit outliers {eight:?}");
    let ratio = new.0 as f64 / eight.0 as f64;
    assert!(
        (ratio - 1.0).abs() < 0.03,
        "coverage 16-bit {new:?} vs 8-bit {eight:?}"
    );
    // The rule's anchor: 8-bit images at σ = 1 code keep their 12-code floor.
    assert_eq!(
        DecodeConfig::for_sensor(8, 1.0),
        DecodeConfig::for_bit_depth(8)
    );
}

/// Pixels with a valid point, and those more than 1 mm from the renderer's truth, of `ds`
/// scanned with `calibration` as `fringe3d scan` scans (its thresholds: the calibration's
/// `[sensor]` noise unless `args` say otherwise; edge filter on).
fn scan_counts(ds: &Path, calibration: &Path, args: &ThresholdArgs) -> (usize, usize) {
    let ls = common::load_set(&ds.join("patterns.toml")).unwrap();
    let cal = ScanCalibration::load(calibration, ls.set.axis()).unwrap();
    let imgs = common::load_images(&ls, &[], true).unwrap();
    let cfg = args
        .config(&ls.set, &imgs, cal.calibration.sensor.as_ref())
        .unwrap();
    let d = common::decode(&ls.set, &imgs, cfg).unwrap();
    let mut cloud = cal.reconstruct(&d.phase, &d.validity, true).unwrap();
    filter_edges(&mut cloud, &cal.edge_filter(80.0).unwrap());
    let truth = fringe3d::accuracy::load_truth(ds).unwrap();
    let (mut valid, mut off) = (0, 0);
    for i in 0..cloud.validity.len() {
        if cloud.validity[i] != Validity::Valid as u8 {
            continue;
        }
        valid += 1;
        let e: f64 = (0..3)
            .map(|k| (cloud.xyz[3 * i + k] as f64 - truth.points[3 * i + k]).powi(2))
            .sum::<f64>()
            .sqrt();
        // A NaN point counts as off.
        off += usize::from(e.is_nan() || e > 1.0);
    }
    (valid, off)
}

/// The calibration records the sensor's noise (`calibrate reference`, from the plane's
/// captures) and `scan` decodes with 12σ of it by default: on a 16-bit camera with σ = 1028
/// codes (4 of 8 bits) the 2 %-of-full-scale floor lets through points a fringe order off,
/// which the calibrated floor refuses, as `--noise` does. The same thresholds go to a head
/// (`device upload`, DefineThresholds; `tests/tests/head_pty.rs`).
#[test]
fn the_calibrated_sensor_noise_sets_the_scan_floor() {
    let t = Tmp::new("noise-floor-cal");
    let ds = t.0.join("sphere");
    let plane = t.0.join("plane");
    let common_args = [
        "--size",
        "320x256",
        "--noise",
        "1028",
        "--bits",
        "16",
        "--supersample",
        "1",
    ];
    let mut a = vec![
        "render",
        "-q",
        "--scene",
        "sphere",
        "--seed",
        "5",
        "--out",
        s(&ds),
    ];
    a.extend_from_slice(&common_args);
    run(&a);
    let mut a = vec![
        "render",
        "-q",
        "--scene",
        "reference",
        "--seed",
        "6",
        "--out",
        s(&plane),
    ];
    a.extend_from_slice(&common_args);
    run(&a);
    let truth_cal = Calibration::load(&ds.join("calibration.toml")).unwrap();
    let r = truth_cal.reference.as_ref().unwrap();
    let join = |v: [f64; 3]| format!("{},{},{}", v[0], v[1], v[2]);
    let (point, normal) = (join(r.point), join(r.normal));
    let measured = t.0.join("cal/calibration.toml");
    let out = run(&[
        "--json",
        "calibrate",
        "reference",
        "--patterns",
        s(&plane.join("patterns.toml")),
        "--calibration",
        s(&ds.join("calibration.toml")),
        &format!("--plane-point={point}"),
        &format!("--plane-normal={normal}"),
        "-o",
        s(&measured),
        s(&plane),
    ]);
    let j: serde_json::Value = serde_json::from_str(&out).unwrap();
    let cal = Calibration::load(&measured).unwrap();
    let sensor = cal.sensor.expect("calibrate reference records [sensor]");
    assert_eq!(sensor.bits, 16);
    assert!(
        (sensor.noise / 1028.0 - 1.0).abs() < 0.05,
        "measured σ {}",
        sensor.noise
    );
    assert_eq!(
        j["sensor"]["min_modulation"].as_f64().unwrap() as f32,
        12.0 * sensor.noise as f32
    );
    // The same calibration without its [sensor] section: the bit depth's defaults.
    let bare = t.0.join("cal/bare.toml");
    Calibration {
        sensor: None,
        ..cal.clone()
    }
    .save(&bare)
    .unwrap();
    let defaults = ThresholdArgs::default();
    let with_sensor = scan_counts(&ds, &measured, &defaults);
    let without = scan_counts(&ds, &bare, &defaults);
    let told = scan_counts(
        &ds,
        &bare,
        &ThresholdArgs {
            noise: Some(NoiseArg::Codes(sensor.noise as f32)),
            ..Default::default()
        },
    );
    eprintln!(
        "16-bit sphere, σ = 1028 codes (measured {:.1}): valid points, > 1 mm off: with [sensor] \
         {with_sensor:?}, without {without:?}, told --noise {told:?}",
        sensor.noise
    );
    assert!(without.1 >= 10, "the 2 % floor's outliers: {without:?}");
    assert!(
        with_sensor.1 * 10 <= without.1,
        "{with_sensor:?} vs {without:?}"
    );
    assert_eq!(with_sensor, told, "[sensor] is --noise σ");
    // `fringe3d scan` itself: the calibration's noise is its default.
    let ply = t.0.join("cloud.ply");
    let scan = |cal: &Path| -> u64 {
        let out = run(&[
            "--json",
            "scan",
            "-p",
            s(&ds.join("patterns.toml")),
            "-c",
            s(cal),
            s(&ds),
            "-o",
            s(&ply),
        ]);
        let j: serde_json::Value = serde_json::from_str(&out).unwrap();
        j["points"].as_u64().unwrap()
    };
    assert_eq!(scan(&measured), with_sensor.0 as u64);
    assert_eq!(scan(&bare), without.0 as u64);
    // `fringe3d decode -c` decodes with the same floor: its validity is `scan`'s decode's.
    let decoded = |cal: &Path| -> Vec<u8> {
        let out = t.0.join("decoded");
        run(&[
            "decode",
            "-q",
            "-p",
            s(&ds.join("patterns.toml")),
            "-c",
            s(cal),
            s(&ds),
            "-o",
            s(&out),
            "--overwrite",
        ]);
        let (img, _) = fringe3d::io::image::read_gray(&out.join("validity.png")).unwrap();
        match img.pixels {
            fringe3d::io::image::Pixels::U8(v) => v,
            _ => panic!("validity.png is 8-bit"),
        }
    };
    let scan_validity = |cal: &Path| {
        let ls = common::load_set(&ds.join("patterns.toml")).unwrap();
        let c = Calibration::load(cal).unwrap();
        let imgs = common::load_images(&ls, &[], true).unwrap();
        let cfg = defaults.config(&ls.set, &imgs, c.sensor.as_ref()).unwrap();
        common::decode(&ls.set, &imgs, cfg).unwrap().validity
    };
    let with = decoded(&measured);
    assert_eq!(with, scan_validity(&measured));
    assert_ne!(with, decoded(&bare), "[sensor] changes what decode refuses");
}

/// `[sensor]` round-trips through the calibration file, scales with the bit depth as the same
/// noise relative to full scale, and a bad value is refused with an error naming the file and
/// the section.
#[test]
fn a_sensor_section_round_trips_and_bad_values_are_refused() {
    use fringe3d::io::calibration::SensorNoise;
    let t = Tmp::new("noise-floor-sensor");
    std::fs::create_dir_all(&t.0).unwrap();
    let example = Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples/calibration/calib.toml");
    let mut c = Calibration::load(&example).unwrap();
    assert_eq!(c.sensor, None, "the example has no [sensor]");
    let sensor = SensorNoise {
        bits: 16,
        noise: 257.0,
    };
    c.sensor = Some(sensor);
    let p = t.0.join("c.toml");
    c.save(&p).unwrap();
    let text = std::fs::read_to_string(&p).unwrap();
    assert!(
        text.contains("[sensor]") && text.contains("noise = 257.0"),
        "{text}"
    );
    assert_eq!(Calibration::load(&p).unwrap(), c);
    // σ = 257 codes of 16 bits is 1 code of 8 bits (257 · 255 / 65535): the 12-code floor.
    assert_eq!(sensor.sigma_at(8), 1.0);
    assert_eq!(sensor.decode_config(8), DecodeConfig::for_bit_depth(8));
    assert_eq!(sensor.decode_config(16).min_modulation, 12.0 * 257.0);
    for (edit, want) in [
        ("bits = 17", "bits must be 1 to 16"),
        ("noise = 0.0", "noise must be more than 0"),
        ("noise = 70000.0", "below full scale"),
        ("noise = nan", "noise must be more than 0"),
        ("gain = 2.0", "unknown field"),
    ] {
        let key = edit.split(' ').next().unwrap();
        let bad_text = match key {
            "gain" => text.replace("[sensor]", &format!("[sensor]\n{edit}")),
            _ => text
                .lines()
                .map(|l| {
                    if l.starts_with(&format!("{key} =")) {
                        edit
                    } else {
                        l
                    }
                })
                .collect::<Vec<_>>()
                .join("\n"),
        };
        let bad = t.0.join("bad.toml");
        std::fs::write(&bad, bad_text).unwrap();
        let e = Calibration::load(&bad).unwrap_err().to_string();
        assert!(e.contains(want) && e.contains("bad.toml"), "{edit}: {e}");
        if key != "gain" {
            assert!(e.contains("[sensor]"), "{edit}: {e}");
        }
    }
}
