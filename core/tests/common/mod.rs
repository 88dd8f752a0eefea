//! Test support: a seeded RNG, Gaussian noise, and synthetic fringe images from the model of
//! eq 8/14 evaluated in f64 (independent of the core's decoder).
#![allow(dead_code, clippy::disallowed_methods)] // std f64 maths is the independent truth here

use fringe3d_core::pattern::PatternSet;

/// SplitMix64: small, seeded, reproducible.
pub struct Rng(pub u64);

impl Rng {
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    /// Uniform in [0, 1).
    pub fn uniform(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }
    /// Standard normal (Box-Muller).
    pub fn normal(&mut self) -> f64 {
        let u1 = self.uniform().max(1e-300);
        let u2 = self.uniform();
        (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
    }
}

/// One synthetic pixel: DC term, modulation per level, base phase Φ^(P).
#[derive(Clone, Copy, Debug)]
pub struct Pixel {
    pub a: f64,
    pub b: f64,
    pub phi_p: f64,
}

/// Intensity of image `i` of `set` at a pixel (eq 8/14, with the set's shifts, offset, convention).
pub fn intensity(set: &PatternSet, i: usize, px: &Pixel) -> f64 {
    let id = set.image(i).unwrap();
    let level = &set.levels()[id.level as usize];
    let delta = level.shifts()[id.shift as usize] + set.effective_offset();
    px.a + px.b * (level.scale() * px.phi_p + delta).sin()
}

/// Images (set order) for a row of pixels, with Gaussian noise of `sigma` codes, quantized to
/// the nearest code and clipped to `[0, max]`.
pub fn images(
    set: &PatternSet,
    pixels: &[Pixel],
    sigma: f64,
    max: f64,
    rng: &mut Rng,
) -> Vec<Vec<u16>> {
    (0..set.image_count())
        .map(|i| {
            pixels
                .iter()
                .map(|p| {
                    let v = intensity(set, i, p) + sigma * rng.normal();
                    v.round().clamp(0.0, max) as u16
                })
                .collect()
        })
        .collect()
}

pub fn to_u8(imgs: &[Vec<u16>]) -> Vec<Vec<u8>> {
    imgs.iter()
        .map(|r| r.iter().map(|&v| v.min(255) as u8).collect())
        .collect()
}

/// Independent f64 reference decoder for sets whose DC level has uniform N-step shifts and whose
/// 2-image levels have shifts 0 and π/2 (the paper's sets): eqs 9-13 written out literally.
/// Returns (finest absolute phase, per-level wrapped phase, A).
pub fn reference_decode(set: &PatternSet, samples: &[f64]) -> (f64, Vec<f64>, f64) {
    let levels = set.levels();
    let off = set.effective_offset();
    let mut per_level: Vec<Vec<f64>> = vec![Vec::new(); levels.len()];
    for (i, &v) in samples.iter().enumerate() {
        let id = set.image(i).unwrap();
        per_level[id.level as usize].push(v);
    }
    // eq 15: A from the DC level (most shifts, finest on ties)
    let dc = (0..levels.len())
        .filter(|&l| levels[l].len() >= 3)
        .max_by_key(|&l| (levels[l].len(), l))
        .unwrap();
    let a = per_level[dc].iter().sum::<f64>() / per_level[dc].len() as f64;
    let mut wrapped = Vec::new();
    for (l, lv) in levels.iter().enumerate() {
        let v = &per_level[l];
        let (s, c) = if lv.len() >= 3 {
            // generic N-step (eq 14), least squares for uniform shifts
            let n = lv.len() as f64;
            let mut s = 0.0;
            let mut c = 0.0;
            for (k, d) in lv.shifts().iter().enumerate() {
                s += v[k] * (d + off).cos() * 2.0 / n;
                c += v[k] * (d + off).sin() * 2.0 / n;
            }
            (s, c)
        } else {
            // eq 11 generalised to the offset: I1 − A = B sin(Φ + o), I2 − A = B cos(Φ + o)
            let (y, x) = (v[0] - a, v[1] - a);
            let ph = y.atan2(x) - off;
            (ph.sin(), ph.cos())
        };
        wrapped.push(s.atan2(c));
    }
    // eqs 12-13
    let mut phi = wrapped[0];
    for l in 1..levels.len() {
        let ratio = levels[l].scale() / levels[l - 1].scale();
        let pred = ratio * phi;
        let n = ((pred - wrapped[l]) / std::f64::consts::TAU).round();
        phi = wrapped[l] + std::f64::consts::TAU * n;
    }
    (phi, wrapped, a)
}

/// Wrap to (−π, π].
pub fn wrap(x: f64) -> f64 {
    let t = std::f64::consts::TAU;
    x - t * (x / t).round()
}
