//! Depth error of every decoding arithmetic (issue #9, docs/arithmetic.md) on a rendered sphere
//! scan: the built-in `sphere` scene (`fringe3d render --scene sphere`) rendered noise-free at 16
//! bits and with σ = 1 code of noise at 8 bits, decoded by each backend — the scan's images *and*
//! the reference plane's, as a head computing in that arithmetic would — then reconstructed,
//! edge-filtered and scored by the same code as `fringe3d scan` / `fringe3d demo`.
//!
//! Not a timing benchmark (a libtest target among the benches, ignored by default because it
//! renders two scans):
//!
//!     cargo test --release -p fringe3d-bench --bench arith_depth -- --ignored --nocapture
#![allow(clippy::disallowed_methods)] // std f64 maths for the statistics

use fringe3d::accuracy;
use fringe3d::cli::common;
use fringe3d::io::calibration::Calibration;
use fringe3d::io::image_set::Frames;
use fringe3d::render::dataset::{DatasetOptions, write_dataset};
use fringe3d::render::scene::Overrides;
use fringe3d::render::{RenderOptions, Scene};
use fringe3d::scan::{ScanCalibration, filter_edges};
use fringe3d_core::arith::Backend;
use fringe3d_core::decode::{AnyDecoder, DecodeConfig, RowOut, Sample};
use fringe3d_core::pattern::PatternSet;
use rayon::prelude::*;
use std::path::PathBuf;

/// Whole-frame decode with one backend (rows in parallel): phase and validity.
fn decode<P: Sample + Sync>(
    d: &AnyDecoder,
    frames: &[&[P]],
    w: usize,
    h: usize,
) -> (Vec<f32>, Vec<u8>) {
    let mut phase = vec![0.0f32; w * h];
    let mut validity = vec![0u8; w * h];
    phase
        .par_chunks_mut(w)
        .zip(validity.par_chunks_mut(w))
        .enumerate()
        .for_each(|(y, (p, v))| {
            let rows: Vec<&[P]> = frames.iter().map(|f| &f[y * w..(y + 1) * w]).collect();
            let (mut m, mut a) = (vec![0.0f32; w], vec![0.0f32; w]);
            d.decode_row(
                &rows,
                RowOut {
                    phase: p,
                    modulation: &mut m,
                    dc: &mut a,
                    validity: v,
                },
            )
            .expect("decode");
        });
    (phase, validity)
}

fn any(set: &PatternSet, bits: u32, b: Backend) -> AnyDecoder {
    AnyDecoder::new(set, DecodeConfig::for_bit_depth(bits), b).expect("decoder")
}

struct TmpDir(PathBuf);
impl Drop for TmpDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

#[test]
#[ignore = "renders two scans; run explicitly (see the file's documentation)"]
fn depth_error_per_backend_on_a_rendered_sphere() {
    let conditions = [
        (
            "16-bit, noise-free",
            Overrides {
                bits: Some(16),
                ..Overrides::default()
            },
        ),
        (
            "8-bit, sigma 1",
            Overrides {
                noise: Some(1.0),
                bits: Some(8),
                seed: Some(11),
                ..Overrides::default()
            },
        ),
    ];
    for (name, o) in conditions {
        let tmp = TmpDir(
            std::env::temp_dir().join(format!("fringe3d-arith-depth-{}", std::process::id())),
        );
        let _ = std::fs::remove_dir_all(&tmp.0);
        let ds = tmp.0.join("dataset");
        let scene = Scene::builtin("sphere", &o).expect("scene");
        write_dataset(&scene, &ds, DatasetOptions::default()).expect("render");
        let ls = common::load_set(&ds.join("patterns.toml")).expect("pattern set");
        let imgs = common::load_images(&ls, &[], true).expect("images");
        let truth = accuracy::load_truth(&ds).expect("truth");
        let (rf, _) = scene
            .render_reference(RenderOptions::default())
            .expect("reference render");
        let (w, h) = (imgs.width as usize, imgs.height as usize);
        let (rw, rh) = (rf.width as usize, rf.height as usize);
        let rframes: Vec<&[u16]> = rf.images.iter().map(|v| v.as_slice()).collect();
        let mut default_valid = 0usize;
        let mut default_xyz: Vec<f32> = Vec::new();
        for b in Backend::ALL {
            let (ref_phase, _) = decode(&any(&ls.set, rf.bits as u32, b), &rframes, rw, rh);
            if b == Backend::F32Accurate {
                // The same reference map as the dataset's (decoded by the default decoder).
                let (img, _) = fringe3d::io::image::read_gray(&ds.join("reference_phase.tif"))
                    .expect("reference map");
                let fringe3d::io::image::Pixels::F32(file) = img.pixels else {
                    panic!("reference map format")
                };
                let same = file
                    .iter()
                    .zip(&ref_phase)
                    .all(|(a, b)| a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan()));
                assert!(same, "the re-decoded reference differs from the dataset's");
            }
            let cal = Calibration::load(&ds.join("calibration.toml")).expect("calibration");
            let scal = ScanCalibration::from_parts(
                cal,
                ref_phase,
                ls.set.axis(),
                &ds.join("calibration.toml"),
            )
            .expect("scan calibration");
            let d = any(&ls.set, imgs.bits as u32, b);
            let (phase, validity) = match &imgs.frames {
                Frames::U8(f) => decode(
                    &d,
                    &f.iter().map(|v| v.as_slice()).collect::<Vec<_>>(),
                    w,
                    h,
                ),
                Frames::U16(f) => decode(
                    &d,
                    &f.iter().map(|v| v.as_slice()).collect::<Vec<_>>(),
                    w,
                    h,
                ),
            };
            let mut cloud = scal
                .reconstruct(&phase, &validity, true)
                .expect("reconstruct");
            filter_edges(&mut cloud, &scal.edge_filter(80.0).expect("filter"));
            let acc = accuracy::evaluate(&cloud, &truth).expect("evaluate");
            let sp = acc.spheres.first().expect("the scene's sphere");
            if b == Backend::F32Accurate {
                default_xyz = cloud.xyz.clone();
            }
            // Point-by-point distance to the default backend's cloud: the error the arithmetic adds.
            let (mut sum2, mut n) = (0.0f64, 0usize);
            for (p, q) in cloud.xyz.chunks_exact(3).zip(default_xyz.chunks_exact(3)) {
                if p[2].is_finite() && q[2].is_finite() {
                    let d2: f64 = (0..3).map(|k| (p[k] as f64 - q[k] as f64).powi(2)).sum();
                    sum2 += d2;
                    n += 1;
                }
            }
            println!(
                "depth | {b} | {name} | RMS vs f32 {:.3} µm | interior RMS {:.3} µm | all RMS {:.3} µm | valid {} of {} | sphere diameter error {:+.3} µm, form RMS {:.3} µm",
                (sum2 / n.max(1) as f64).sqrt() * 1e3,
                acc.interior.rms * 1e3,
                acc.all.rms * 1e3,
                acc.valid_pixels,
                acc.truth_pixels,
                sp.diameter_error * 1e3,
                sp.form_rms * 1e3
            );
            assert_eq!(acc.spurious_points, 0, "{b} {name}");
            if b == Backend::F32Accurate {
                default_valid = acc.valid_pixels;
            }
            let ratio = acc.valid_pixels as f64 / default_valid as f64;
            assert!(
                (ratio - 1.0).abs() < 0.01,
                "{b} {name}: {} valid points, the default has {default_valid}",
                acc.valid_pixels
            );
        }
    }
}
