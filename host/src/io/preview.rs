//! False-colour PNG previews a person can look at: phase maps, modulation, validity.

use crate::io::atomic::write_atomic;
use std::path::Path;

/// Colour of each validity code in previews (index = code): valid pixels are coloured by value,
/// the others get these fixed colours.
pub const VALIDITY_COLOURS: [[u8; 3]; fringe3d_core::Validity::ALL.len()] = [
    [255, 255, 255], // valid
    [0, 0, 0],       // dark
    [255, 0, 255],   // saturated
    [60, 60, 60],    // low modulation
    [255, 0, 0],     // unwrap inconsistent
    [255, 128, 0],   // phase out of range
    [0, 0, 160],     // no crossing
    [0, 160, 160],   // out of depth
    [120, 0, 120],   // reference invalid
    [160, 160, 0],   // degenerate
    [255, 255, 0],   // depth edge
    [255, 96, 160],  // code ambiguous
    [200, 230, 255], // light edge
];

/// A perceptually ordered blue-cyan-green-yellow-red ramp (piecewise linear), `t ∈ [0, 1]`.
pub fn ramp(t: f32) -> [u8; 3] {
    let t = if t.is_finite() {
        t.clamp(0.0, 1.0)
    } else {
        0.0
    };
    let stops: [[f32; 3]; 5] = [
        [48.0, 18.0, 59.0],
        [40.0, 140.0, 230.0],
        [60.0, 220.0, 90.0],
        [245.0, 200.0, 40.0],
        [180.0, 20.0, 10.0],
    ];
    let x = t * 4.0;
    let i = (x as usize).min(3);
    let f = x - i as f32;
    let mut c = [0u8; 3];
    for k in 0..3 {
        c[k] = (stops[i][k] + (stops[i + 1][k] - stops[i][k]) * f).round() as u8;
    }
    c
}

/// Write an RGB8 PNG atomically.
pub fn write_rgb_png(path: &Path, width: u32, height: u32, rgb: &[u8]) -> Result<(), String> {
    if rgb.len() != width as usize * height as usize * 3 {
        return Err(format!("{}: RGB buffer size mismatch", path.display()));
    }
    write_atomic(path, |w| {
        let mut enc = png::Encoder::new(w, width, height);
        enc.set_color(png::ColorType::Rgb);
        enc.set_depth(png::BitDepth::Eight);
        let mut wr = enc.write_header().map_err(std::io::Error::other)?;
        wr.write_image_data(rgb).map_err(std::io::Error::other)?;
        wr.finish().map_err(std::io::Error::other)
    })
    .map_err(|e| e.to_string())
}

/// Colour a map: valid pixels by `values` scaled from the 1st to the 99th percentile of the valid
/// values, invalid ones by [`VALIDITY_COLOURS`].
pub fn colourize(values: &[f32], validity: &[u8]) -> Vec<u8> {
    let mut v: Vec<f32> = values
        .iter()
        .zip(validity)
        .filter(|(x, c)| **c == 0 && x.is_finite())
        .map(|(x, _)| *x)
        .collect();
    let (lo, hi) = if v.is_empty() {
        (0.0, 1.0)
    } else {
        v.sort_by(f32::total_cmp);
        let q = |p: f64| v[((v.len() - 1) as f64 * p) as usize];
        (q(0.01), q(0.99))
    };
    let span = if hi > lo { hi - lo } else { 1.0 };
    let mut out = Vec::with_capacity(values.len() * 3);
    for (x, c) in values.iter().zip(validity) {
        let rgb = if *c == 0 && x.is_finite() {
            ramp((x - lo) / span)
        } else {
            VALIDITY_COLOURS[(*c as usize).min(VALIDITY_COLOURS.len() - 1)]
        };
        out.extend_from_slice(&rgb);
    }
    out
}
