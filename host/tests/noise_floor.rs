//! The modulation floor in physical terms (issue #19 item 5): the same sphere rendered on an
//! 8-bit camera with σ = 1 code and on a 16-bit one with the same noise relative to full scale
//! (σ = 257 codes). At 2 % of full scale the 16-bit floor admitted pixels down to B/σ ≈ 5, and
//! with them phase errors the 8-bit floor (12 codes = 12σ) refuses; `--noise auto` of `decode`
//! and `scan` estimates σ from the 16-bit images and holds B ≥ 12σ, as for 8 bits.

use fringe3d::cli::common::{NoiseArg, ThresholdArgs};
use fringe3d::io::image_set::{Frames, ImageSet};
use fringe3d::render::{MASK_VALID, Overrides, RenderOptions, Scene, SceneSpec};
use fringe3d_core::decode::{DecodeConfig, Decoder, RowOut};
use fringe3d_core::validity::Validity;

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
    let eight = count(&s8, &i8, &t8, &m8, told.config(&s8.patterns, &i8).unwrap());
    let auto = ThresholdArgs {
        noise: Some(NoiseArg::Auto),
        ..Default::default()
    };
    let cfg16 = auto.config(&s16.patterns, &i16).unwrap();
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
