//! The sensor's read noise, estimated from a scan's own images (issue #19 item 5), so that the
//! decoder's modulation floor has the same physical meaning at every bit depth
//! ([`DecodeConfig::for_sensor`]: `B ≥ 12σ`).
//!
//! A level of an even number N ≥ 4 of uniform shifts `2πn/N` has an alternating sum
//! `e = Σ (−1)ⁿ Iₙ` in which the DC term and the fringe cancel (`Σ (−1)ⁿ sin(φ + 2πn/N) = 0`),
//! leaving `N` samples' noise: `var e = N·σ²`. Over the lit, unsaturated pixels the mean of
//! `|e|` is `√(2/π)·√N·σ` for Gaussian noise; values beyond 6 times the median (at least 6
//! codes) are left out, the few pixels where the scene moves or an edge mixes surfaces (that
//! cut removes 0.3 % of a Gaussian's |e|, a bias under 0.1 %). Not the median itself: `e` of
//! integer samples is an integer, and at σ ≈ 1 code its median is 1 or 2, 25 % off. A projector's harmonics of order `N/2` (the 2nd for a 4-step level:
//! gamma) survive the sum and bias σ upwards, which only makes the floor stricter; a
//! response-compensated projector (docs/gamma.md) removes them.

use fringe3d_core::decode::DecodeConfig;
use fringe3d_core::pattern::{Level, PatternSet};

use crate::io::image_set::{Frames, ImageSet};

/// Pixels sampled at most (evenly spaced over the frame).
const MAX_SAMPLES: usize = 262_144;

/// A noise estimate.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NoiseEstimate {
    /// Read noise σ of one sample, camera codes.
    pub sigma: f32,
    /// Pixels it was estimated from.
    pub pixels: usize,
    /// The level whose alternating sum was used.
    pub level: usize,
}

/// Estimate the read noise from the images of `set` (see the module doc). `None` if the set has
/// no level of an even number ≥ 4 of uniform shifts, or fewer than 1000 lit, unsaturated pixels.
pub fn estimate(set: &PatternSet, imgs: &ImageSet) -> Option<NoiseEstimate> {
    let (level, l) = set
        .levels()
        .iter()
        .enumerate()
        .filter(|(_, l)| {
            let n = l.len();
            l.gray().is_none() && n >= 4 && n % 2 == 0 && **l == Level::n_step(l.scale(), n)
        })
        .max_by_key(|(i, l)| (l.len(), *i))?;
    let n = l.len();
    let idx: Vec<usize> = (0..n)
        .map(|s| {
            set.order()
                .iter()
                .position(|id| id.level as usize == level && id.shift as usize == s)
        })
        .collect::<Option<_>>()?;
    let full = ((1u32 << imgs.bits.clamp(1, 16)) - 1) as f64;
    let dark = DecodeConfig::for_bit_depth(imgs.bits as u32).dark_level as f64;
    let pixels = (imgs.width as usize) * (imgs.height as usize);
    let step = pixels.div_ceil(MAX_SAMPLES).max(1);
    let sample = |i: usize, p: usize| -> f64 {
        match &imgs.frames {
            Frames::U8(f) => f[i][p] as f64,
            Frames::U16(f) => f[i][p] as f64,
        }
    };
    let mut e: Vec<f64> = (0..pixels)
        .step_by(step)
        .filter_map(|p| {
            // (One pass, no allocation per pixel: the sum, the alternating sum, the peak.)
            let (mut sum, mut alt, mut peak) = (0.0, 0.0, 0.0f64);
            for (k, &i) in idx.iter().enumerate() {
                let x = sample(i, p);
                sum += x;
                alt += if k % 2 == 0 { x } else { -x };
                peak = peak.max(x);
            }
            if sum / (n as f64) < dark || peak >= full {
                return None;
            }
            Some(alt.abs())
        })
        .collect();
    if e.len() < 1000 {
        return None;
    }
    let mid = e.len() / 2;
    let (_, median, _) = e.select_nth_unstable_by(mid, |a, b| a.total_cmp(b));
    let cut = (6.0 * *median).max(6.0);
    let kept: Vec<f64> = e.into_iter().filter(|&x| x <= cut).collect();
    let mean = kept.iter().sum::<f64>() / kept.len() as f64;
    let sigma = mean / (2.0 / std::f64::consts::PI).sqrt() / (n as f64).sqrt();
    Some(NoiseEstimate {
        sigma: sigma as f32,
        pixels: kept.len(),
        level,
    })
}
