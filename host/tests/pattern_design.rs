//! Level design (`fringe3d patterns --design`, issue #22 item 4): the predicted unwrapping
//! rates against the core decoder on simulated pixels of known phase (a second method: the
//! decoder's own arithmetic and validity codes, Gaussian read noise), and the designed set at
//! B/σ = 14 with no unwrapping failure.

use crate::cli_support::{Tmp, run, s};
use fringe3d::design::{DesignGoal, design_levels, step_rates};
use fringe3d::io::pattern_file::PatternSetFile;
use fringe3d::render::rng::Rng;
use fringe3d_core::decode::{DecodeConfig, Decoder, RowOut};
use fringe3d_core::pattern::{Level, Output, PatternSet};
use fringe3d_core::phase_function::{Axis, PhaseFunction};
use fringe3d_core::validity::Validity;
use std::f64::consts::{PI, TAU};

/// Decode `n` pixels of `set` at modulation over noise `snr` (16-bit samples: A = 30000,
/// σ = 400 codes, so that quantization is negligible), their true Φ uniform in ±Φ_max/2 of
/// the coarse range. Returns (refused as inconsistent, valid with a wrong order, pixels).
fn simulate(set: &PatternSet, snr: f64, n: usize, seed: u64) -> (usize, usize, usize) {
    let sigma = 400.0;
    let (a, b) = (30000.0, snr * sigma);
    let cfg = DecodeConfig {
        min_modulation: 0.0,
        ..DecodeConfig::for_bit_depth(16)
    };
    let d = Decoder::new(set, cfg).unwrap();
    let mut rng = Rng::new(seed);
    let c0 = set.levels()[0].scale();
    let finest = set.levels().last().unwrap().scale();
    let (lo, hi) = set.coarse_range();
    let phi: Vec<f64> = (0..n)
        .map(|_| (0.25 * (lo + hi) + 0.5 * (hi - lo) * (rng.uniform() - 0.5)) / c0)
        .collect();
    let images: Vec<Vec<u16>> = (0..set.image_count())
        .map(|i| {
            let id = set.image(i).unwrap();
            let l = &set.levels()[id.level as usize];
            let delta = l.shifts()[id.shift as usize];
            phi.iter()
                .map(|p| {
                    let v = a + b * (l.scale() * p + delta).sin() + sigma * rng.gauss();
                    v.round().clamp(0.0, 65535.0) as u16
                })
                .collect()
        })
        .collect();
    let rows: Vec<&[u16]> = images.iter().map(|r| &r[..]).collect();
    let (mut ph, mut mo, mut dc, mut va) =
        (vec![0f32; n], vec![0f32; n], vec![0f32; n], vec![0; n]);
    d.decode_row(
        &rows,
        RowOut {
            phase: &mut ph,
            modulation: &mut mo,
            dc: &mut dc,
            validity: &mut va,
        },
    )
    .unwrap();
    let refused = va
        .iter()
        .filter(|&&v| v == Validity::UnwrapInconsistent as u8)
        .count();
    let wrong = (0..n)
        .filter(|&i| va[i] == Validity::Valid as u8 && (ph[i] as f64 - finest * phi[i]).abs() > PI)
        .count();
    (refused, wrong, n)
}

fn two_levels(r: f64) -> PatternSet {
    let f = PhaseFunction::centered(Axis::Xi, 1024, 0.9 * TAU).unwrap();
    let out = Output {
        width: 1024,
        height: 768,
        i_min: 0.0,
        i_max: 255.0,
    };
    PatternSet::new(f, &[Level::n_step(1.0, 4), Level::n_step(r, 4)], out).unwrap()
}

#[test]
fn the_predicted_rates_are_the_decoders() {
    // B/σ = 4, ratio 8: about 10 % refused and 4 % of wrong orders, measurable on 40 000 pixels.
    let (snr, r) = (4.0, 8.0);
    let (p_out, p_wrong) = step_rates(r, snr, 4, 2.0 * PI / 3.0);
    let (refused, wrong, n) = simulate(&two_levels(r), snr, 40_000, 3);
    let (got_refused, got_wrong) = (refused as f64 / n as f64, wrong as f64 / n as f64);
    eprintln!(
        "refused {got_refused:.4} (predicted {p_out:.4}), wrong {got_wrong:.4} (predicted {p_wrong:.4})"
    );
    assert!(((got_refused / p_out) - 1.0).abs() < 0.05);
    assert!(((got_wrong / p_wrong) - 1.0).abs() < 0.2);
}

#[test]
fn the_designed_set_at_b_over_sigma_14_unwraps_every_pixel() {
    let t = Tmp::new("design");
    let out = t.0.join("designed");
    let stdout = run(&[
        "--json",
        "patterns",
        "-p",
        "../examples/patterns/twelve.toml",
        "--design",
        "14",
        "-o",
        s(&out),
    ]);
    let j: serde_json::Value = serde_json::from_str(stdout.lines().next().unwrap()).unwrap();
    assert!(j["refused"].as_f64().unwrap() <= 1e-6, "{j}");
    let file = PatternSetFile::load(&out.join("patterns.toml")).unwrap();
    let set = file.to_pattern_set().unwrap();
    let scales: Vec<f64> = set.levels().iter().map(|l| l.scale()).collect();
    assert_eq!(j["scales"], serde_json::json!(scales));
    assert_eq!(
        *scales.last().unwrap(),
        64.0,
        "the file's finest scale is kept"
    );
    assert_eq!(set.image_count(), 4 * scales.len());
    for seed in 1..=3 {
        let (refused, wrong, n) = simulate(&set, 14.0, 50_000, seed);
        assert_eq!((refused, wrong), (0, 0), "of {n}");
    }
    // The same goal through the library gives as many levels; a hopeless one names the noise.
    let g = DesignGoal {
        snr: 14.0,
        steps: 4,
        finest: 64.0,
        coarsest_max: scales[0],
        failure_target: 1e-6,
        tolerance: 2.0 * PI / 3.0,
    };
    assert_eq!(design_levels(&g).unwrap().scales.len(), scales.len());
    let o = crate::cli_support::fringe3d(&[
        "patterns",
        "-p",
        "../examples/patterns/twelve.toml",
        "--design",
        "0.8",
        "-o",
        s(&t.0.join("none")),
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        !o.status.success() && err.contains("the unwrapping noise binds"),
        "{err}"
    );
    assert!(!t.0.join("none").exists());
}
