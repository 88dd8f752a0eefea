//! Phase accuracy of noise-free renders, checked with an f64 decoder written here (independent of
//! the core's decoder) against the exact phase `c_K·Φ^(P)(ξ, η)` of the point hit through each
//! pixel centre.
//!
//! # The bound
//! The finest level is the 4-step level (shifts 0, π/2, π, 3π/2), decoded as
//! `Φ = atan2(S, C)`, `S = I₁ − I₃ = 2B sin Φ`, `C = I₂ − I₄ = 2B cos Φ`. Errors `e_n` of the samples
//! change S and C by `e₁ − e₃` and `e₂ − e₄`, so to first order
//! `|ΔΦ| ≤ (|e₁ − e₃|·|cos Φ| + |e₂ − e₄|·|sin Φ|)/(2B) ≤ √2·max|e|/B`.
//! - camera quantization (round to nearest code): `|e| ≤ ½` → `|ΔΦ| ≤ 0.7071/B` (B in codes);
//! - pattern codes (pixelated mode): the relative radiance of a DMD pixel is off by at most
//!   `q = ½/(2^bits − 1)`, the camera sample by `q·G` with `B = G/2`, and the defocus blur is an
//!   average with positive weights, so `|ΔΦ| ≤ 2√2·q` (2.2e-5 rad for 16-bit patterns);
//! - the renderer's interpolation of the blurred DMD image: < 1e-7 rad (docs/render.md).
//!
//! With one sample per pixel (no supersampling) nothing else separates the rendered phase from
//! the truth, so every valid pixel must satisfy `|ΔΦ| ≤ 0.7071/B + 2√2·q + 1e-6`.

use crate::render_common::{decode_float, decode_frames, rms_max};
use fringe3d::render::{MASK_VALID, Overrides, ProjectorMode, RenderOptions, Scene, SceneSpec};

fn plane_scene(
    mode: ProjectorMode,
    defocus: f64,
    pattern_bits: u8,
    ss: u32,
    size: (u32, u32),
) -> Scene {
    let mut s = SceneSpec::builtin("plane").unwrap();
    s.apply(&Overrides {
        size: Some(size),
        supersample: Some(ss),
        pattern_bits: Some(pattern_bits),
        defocus: Some(defocus),
        ..Default::default()
    });
    s.projector.mode = mode;
    s.camera.edge_supersample = ss;
    Scene::new(s, None).unwrap()
}

struct Stats {
    n: usize,
    rms: f64,
    max: f64,
    worst_ratio: f64,
    float_rms: f64,
    float_max: f64,
}

/// Decode and compare on valid pixels; `model` is the model-error allowance added to 0.7071/B.
fn check(scene: &Scene, model: f64) -> Stats {
    let (f, t) = scene
        .render_fringes(RenderOptions {
            keep_float: true,
            ..Default::default()
        })
        .unwrap();
    let truth = scene.true_phase(&t);
    let dec = decode_frames(&scene.patterns, &f);
    let fdec = decode_float(&scene.patterns, &f);
    let mut errs = Vec::new();
    let mut ferrs = Vec::new();
    let mut worst: f64 = 0.0;
    for p in 0..truth.len() {
        if t.mask[p] != MASK_VALID {
            continue;
        }
        let (phi, b, _) = dec[p];
        let e = phi - truth[p];
        let bound = std::f64::consts::FRAC_1_SQRT_2 / b + model;
        worst = worst.max(e.abs() / bound);
        errs.push(e);
        ferrs.push(fdec[p].0 - truth[p]);
    }
    let (rms, max) = rms_max(&errs);
    let (float_rms, float_max) = rms_max(&ferrs);
    Stats {
        n: errs.len(),
        rms,
        max,
        worst_ratio: worst,
        float_rms,
        float_max,
    }
}

#[test]
fn continuous_plane_recovers_phase_within_quantization() {
    let s = plane_scene(ProjectorMode::Continuous, 0.0, 16, 1, (640, 512));
    let st = check(&s, 1e-6);
    eprintln!(
        "continuous, 1 spp: n = {}, rms = {:.2e}, max = {:.2e} rad, worst/bound = {:.3}; unquantized: rms {:.2e} max {:.2e}",
        st.n, st.rms, st.max, st.worst_ratio, st.float_rms, st.float_max
    );
    assert!(st.n > 200_000, "too few valid pixels: {}", st.n);
    assert!(
        st.worst_ratio <= 1.0,
        "a pixel exceeds the quantization bound ({})",
        st.worst_ratio
    );
    assert!(
        st.float_max < 1e-9,
        "unquantized render differs from the truth: {}",
        st.float_max
    );
    assert!(st.rms < 1e-4);
}

#[test]
fn defocused_dmd_plane_recovers_phase_within_quantization() {
    // σ = 1 projector pixel, 16-bit patterns: pattern-code bound 2√2·½/65535.
    let q = 2.0 * std::f64::consts::SQRT_2 * 0.5 / 65535.0;
    let s = plane_scene(ProjectorMode::Pixelated, 1.0, 16, 1, (640, 512));
    let st = check(&s, q + 1e-6);
    eprintln!(
        "pixelated σ=1, 16-bit patterns, 1 spp: n = {}, rms = {:.2e}, max = {:.2e}, worst/bound = {:.3}; unquantized: rms {:.2e} max {:.2e}",
        st.n, st.rms, st.max, st.worst_ratio, st.float_rms, st.float_max
    );
    assert!(
        st.worst_ratio <= 1.0,
        "a pixel exceeds the bound ({})",
        st.worst_ratio
    );
    assert!(
        st.float_max <= q + 1e-6,
        "model error {} above the pattern-code bound {q}",
        st.float_max
    );
    assert!(st.rms < 1e-4);
}

#[test]
fn supersampled_plane_meets_1e4_rad_rms() {
    // The default render (3 × 3 supersampling, σ = 1) at full size: the supersampling bias of the
    // curved (perspective) phase is part of the error here.
    let s = plane_scene(ProjectorMode::Pixelated, 1.0, 16, 3, (1280, 1024));
    let q = 2.0 * std::f64::consts::SQRT_2 * 0.5 / 65535.0;
    let st = check(&s, q + 1e-4);
    eprintln!(
        "pixelated σ=1, 3x3 spp, 1280x1024: n = {}, rms = {:.2e}, max = {:.2e}; unquantized: rms {:.2e} max {:.2e}",
        st.n, st.rms, st.max, st.float_rms, st.float_max
    );
    assert!(st.n > 800_000);
    assert!(st.rms < 1e-4, "rms {}", st.rms);
    assert!(
        st.float_rms < 5e-5,
        "supersampling bias rms {}",
        st.float_rms
    );
}

#[test]
fn sharp_dmd_pixelation_error_is_visible_and_bounded() {
    // σ = 0 and one sample per pixel: all four shifted images sample the same DMD pixel, so the
    // decoded phase is that of the pixel centre — a staircase. The error is then uniform over one
    // DMD pixel's phase step c_K·slope, RMS c_K·slope/√12 (0.102 rad for the default set). The
    // renderer must show this physical effect, not hide it.
    let s = plane_scene(ProjectorMode::Pixelated, 0.0, 16, 1, (640, 512));
    let st = check(&s, 1.0);
    let step = s.patterns.finest_phase(1.0, 0.0) - s.patterns.finest_phase(0.0, 0.0);
    let expect = step / 12f64.sqrt();
    eprintln!(
        "pixelated σ=0, 1 spp: rms = {:.4e} (staircase predicts {expect:.4e}), max = {:.3e} (half step {:.3e})",
        st.float_rms,
        st.float_max,
        step / 2.0
    );
    assert!(
        (st.float_rms / expect - 1.0).abs() < 0.02,
        "{} vs {expect}",
        st.float_rms
    );
    // Plus the 16-bit pattern-code bound 2√2·½/65535.
    assert!(
        st.float_max <= step / 2.0 + 2.2e-5,
        "{} vs {}",
        st.float_max,
        step / 2.0
    );
}

#[test]
fn reference_map_decoded_by_the_core_matches_the_truth() {
    // What the dataset writes as reference_phase.tif: the default rig's reference plane, rendered
    // at full size and decoded by the core's (f32) decoder.
    let s = Scene::builtin("sphere", &Overrides::default()).unwrap();
    let (f, t) = s.render_reference(RenderOptions::default()).unwrap();
    let dec = fringe3d::render::decode_phase(&s.patterns, &f).unwrap();
    let truth = s.true_phase(&t);
    let mut errs = Vec::new();
    for p in 0..truth.len() {
        if t.mask[p] == MASK_VALID && dec[p].is_finite() {
            errs.push(dec[p] as f64 - truth[p]);
        }
    }
    let (rms, max) = rms_max(&errs);
    eprintln!(
        "reference map (core decoder): n = {}, rms {rms:.2e}, max {max:.2e} rad",
        errs.len()
    );
    assert!(errs.len() > 1_000_000);
    assert!(rms < 1e-4, "{rms}");
}

#[test]
fn supersampling_bias_on_curved_surfaces_follows_the_second_moment() {
    // Truth is the phase at the pixel centre; the n × n average of B·e^{iφ} over the pixel, with
    // φ = φ₀ + g·x + ½xᵀHx and B = B₀(1 + a·x), has the argument φ₀ + ½s²·tr H + s²·a·g to first
    // order (s² = (n² − 1)/(12n²), the samples' second moment per axis). Measured on the
    // unquantized sphere images against that prediction (derivatives by central differences of
    // the true phase and of ln B).
    let s = Scene::builtin("sphere", &Overrides::default()).unwrap();
    let (f, t) = s
        .render_fringes(RenderOptions {
            keep_float: true,
            ..Default::default()
        })
        .unwrap();
    let truth = s.true_phase(&t);
    let fdec = decode_float(&s.patterns, &f);
    let w = t.width as usize;
    let s2 = (9.0 - 1.0) / (12.0 * 9.0);
    let (mut meas, mut resid, mut curv) = (Vec::new(), Vec::new(), Vec::new());
    for p in w + 1..truth.len() - w - 1 {
        let obj = t.object_id[p];
        let nb = [p - 1, p + 1, p - w, p + w];
        if t.mask[p] != MASK_VALID
            || obj != 1
            || nb
                .iter()
                .any(|&q| t.mask[q] != MASK_VALID || t.object_id[q] != obj)
        {
            continue;
        }
        let lap = truth[p - 1] + truth[p + 1] + truth[p - w] + truth[p + w] - 4.0 * truth[p];
        let g = (
            0.5 * (truth[p + 1] - truth[p - 1]),
            0.5 * (truth[p + w] - truth[p - w]),
        );
        let lb = |q: usize| fdec[q].1.ln();
        let a = (0.5 * (lb(p + 1) - lb(p - 1)), 0.5 * (lb(p + w) - lb(p - w)));
        let e = fdec[p].0 - truth[p];
        meas.push(e);
        resid.push(e - s2 * (0.5 * lap + a.0 * g.0 + a.1 * g.1));
        curv.push(lap);
    }
    let (rms, max) = rms_max(&meas);
    let (rrms, _) = rms_max(&resid);
    let (lrms, lmax) = rms_max(&curv);
    eprintln!(
        "sphere, 3x3 spp: bias rms {rms:.2e}, max {max:.2e} rad over {} px; after subtracting ½s²∇²φ + s²·a·g: rms {rrms:.2e}; ∇²φ rms {lrms:.2e}, max {lmax:.2e} rad/px²",
        meas.len()
    );
    assert!(meas.len() > 30_000);
    assert!(
        rrms < 0.2 * rms,
        "the second-moment model should explain most of the bias"
    );
}
