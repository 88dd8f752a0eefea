//! Test support: a seeded RNG, Gaussian noise, synthetic fringe images from the model of eq 8/14
//! evaluated in f64 (independent of the core's decoder), and the crate's f64 reference decoder
//! ([`fringe3d_core::decode::reference`]) in the tests' form.
#![allow(dead_code, clippy::disallowed_methods)] // std f64 maths is the independent truth here

use fringe3d_core::decode::reference;
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

/// The f64 reference decoder of the crate ([`fringe3d_core::decode::reference`], eqs 8-15 as
/// written) for one pixel: (finest absolute phase, per-level wrapped phase, A). Panics on a set
/// the reference does not cover (every level of ≥ 3 shifts uniform, 2-image levels at 0 and π/2).
pub fn reference_decode(set: &PatternSet, samples: &[f64]) -> (f64, Vec<f64>, f64) {
    let r = reference::decode_pixel(set, samples).expect("a set the reference decoder covers");
    (r.phase, r.wrapped[..set.levels().len()].to_vec(), r.dc)
}

/// Wrap to (−π, π].
pub fn wrap(x: f64) -> f64 {
    let t = std::f64::consts::TAU;
    x - t * (x / t).round()
}

/// Every row of `frames` (each `w × h`, set order) through the frame-sequential decoder: the
/// phase bits and validity codes, row after row.
pub fn frame_sequential<P: fringe3d_core::sample::Sample>(
    d: &fringe3d_core::decode::Decoder,
    frames: &[Vec<P>],
    w: usize,
    h: usize,
) -> (Vec<u32>, Vec<u8>) {
    use fringe3d_core::decode::RowOut;
    use fringe3d_core::sequential::FrameDecoder;
    let mut state = vec![0.0f32; FrameDecoder::state_len(d, w, h)];
    let mut flags = vec![0u8; w * h];
    let mut fd = FrameDecoder::new(d, w, h, &mut state, &mut flags).unwrap();
    for f in frames {
        fd.push_frame(f).unwrap();
    }
    let (mut ph, mut mo, mut dc, mut va) =
        (vec![0f32; w], vec![0f32; w], vec![0f32; w], vec![0; w]);
    let (mut bits, mut codes) = (Vec::new(), Vec::new());
    for y in 0..h {
        let out = RowOut {
            phase: &mut ph,
            modulation: &mut mo,
            dc: &mut dc,
            validity: &mut va,
        };
        fd.finish_row(y, out).unwrap();
        bits.extend(ph.iter().map(|p| p.to_bits()));
        codes.extend_from_slice(&va);
    }
    (bits, codes)
}

/// The default set (the paper's 8 images, vertical fringes) of an 8-bit 640 × 480 projector.
pub fn paper_set() -> PatternSet {
    let out = fringe3d_core::pattern::Output {
        width: 640,
        height: 480,
        i_min: 0.0,
        i_max: 255.0,
    };
    PatternSet::default_for(fringe3d_core::phase_function::Axis::Xi, out).unwrap()
}
