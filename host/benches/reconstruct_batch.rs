//! Reconstruction throughput of the desktop batch path (`fringe3d::batch::reconstruct_frame`,
//! which `fringe3d scan` runs): a 1280 × 1024 phase map, single thread and all cores, the
//! baseline and AVX2 kernels and the runtime-dispatched one (AVX-512 where the CPU and the
//! compiler have it), with the x86 pair gathers of `fringe3d::gather`. The scene is the core
//! benchmark's (`core/benches/reconstruct.rs`: seeded, from the tests' f64 ray caster), `exact`
//! and `noisy` (σ = 0.01 rad phase noise). Every variant is first checked bit for bit against
//! the core's portable `reconstruct_frame`. Then the compiled reconstruction (`compiled_*`,
//! `fringe3d::compiled`, at 0.1 µm and `_1um`), each variant against its portable run; the
//! build's report and how many pixels the scan leaves to the search are printed first.
//! Run: `cargo bench -p fringe3d-bench --bench reconstruct_batch`.

#![allow(clippy::disallowed_methods)] // std maths for the synthetic scene

#[path = "../../core/tests/reconstruct_support.rs"]
mod support;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use fringe3d::batch::{
    CompiledRows, Isa, PointsOut, reconstruct_frame, reconstruct_frame_compiled,
};
use fringe3d::compiled::{DEFAULT_TOLERANCE_MM, compile};
use fringe3d_core::reconstruct::compiled::{FIELDS, PixelModel};
use fringe3d_core::reconstruct::{Reconstructor, ReferenceMap};
use fringe3d_core::validity::Validity;
use std::hint::black_box;
use support::*;

fn bench(c: &mut Criterion) {
    for (name, noise) in [("exact", 0.0), ("noisy", 0.01)] {
        let (rig, reference, object) = bench_scene(noise);
        let cam = rig.cam.model();
        let recon = Reconstructor::new(&cam, &rig.setup()).expect("reconstructor");
        let (w, h) = (reference.width, reference.height);
        let mut prep = reference.phase.clone();
        ReferenceMap::prepare(&mut prep, &reference.validity, w, h).expect("map");
        let map = ReferenceMap::from_prepared(&prep, w, h).expect("map");
        let (mut xyz, mut val) = (vec![0f32; 3 * w * h], vec![0u8; w * h]);
        recon
            .reconstruct_frame(&map, &object.phase, &object.validity, &mut xyz, &mut val)
            .expect("portable");
        let mut g = c.benchmark_group(format!("reconstruct_batch_{name}"));
        g.throughput(Throughput::Elements((w * h) as u64));
        g.sample_size(20);
        for (label, isa, par) in [
            ("baseline_1thread", Isa::Baseline, false),
            ("avx2_1thread", Isa::Avx2, false),
            ("dispatched_1thread", Isa::detect(), false),
            ("dispatched_all_cores", Isa::detect(), true),
        ] {
            let (mut xyz2, mut val2) = (vec![0f32; 3 * w * h], vec![0u8; w * h]);
            reconstruct_frame(
                &recon,
                &map,
                &object.phase,
                &object.validity,
                PointsOut {
                    xyz: &mut xyz2,
                    validity: &mut val2,
                    searched: None,
                },
                isa,
                par,
            )
            .expect("batch");
            let same = val == val2
                && xyz
                    .iter()
                    .zip(&xyz2)
                    .all(|(a, b)| a.to_bits() == b.to_bits());
            assert!(same, "{label} differs from the portable reconstruction");
            g.bench_function(label, |b| {
                b.iter(|| {
                    reconstruct_frame(
                        &recon,
                        &map,
                        black_box(&object.phase),
                        &object.validity,
                        PointsOut {
                            xyz: &mut xyz2,
                            validity: &mut val2,
                            searched: None,
                        },
                        isa,
                        par,
                    )
                    .expect("batch")
                })
            });
        }
        // The compiled reconstruction of the same map (`fringe3d compile`), the search for
        // the pixels it leaves; every variant the same bits as the portable one. At the default
        // tolerance (0.1 µm) and at 1 µm, where nearly every pixel the map covers compiles.
        for (tol_label, tol) in [("", DEFAULT_TOLERANCE_MM), ("_1um", 1e-3)] {
            let (file, rep) = compile(&recon, &prep, tol);
            eprintln!(
                "{name}, tolerance {} µm: compiled {} of {} pixels ({} clipped, {} of them with \
                 the far rule), {} with no reference along the ray; left to the search: {} off \
                 the map, {} fits and {} checks missing; largest difference from the search \
                 {:.3} µm",
                tol * 1e3,
                rep.compiled,
                rep.pixels,
                rep.clipped,
                rep.clipped_far,
                rep.no_reference,
                rep.off_map,
                rep.fit_failed,
                rep.check_failed,
                rep.max_difference_mm * 1e3
            );
            // What this scan leaves to the search, and why.
            let (mut left, mut beyond) = ([0usize; 3], Vec::new());
            let pixels = file.left_to_search(&object.phase, &object.validity);
            for i in pixels.expect("the scene's size") {
                let pm = file.model(i % w, i / w).expect("model");
                left[if pm.far_is_no_crossing() {
                    beyond.push(i);
                    0
                } else if pm.is_compiled() {
                    1
                } else {
                    2
                }] += 1;
            }
            eprintln!(
                "{name}, tolerance {} µm: left to the search in this scan: {} pixels ({} clipped \
                 with the far rule, just beyond their range; {} clipped without it; {} with no \
                 function)",
                tol * 1e3,
                left.iter().sum::<usize>(),
                left[0],
                left[1],
                left[2]
            );
            let rows = CompiledRows {
                models: &file.models,
                first_row: 0,
                z_min: file.z_min,
                z_max: file.z_max,
            };
            let (mut cx, mut cv) = (vec![0f32; 3 * w * h], vec![0u8; w * h]);
            let run = |isa, par, x: &mut [f32], v: &mut [u8]| {
                reconstruct_frame_compiled(
                    &recon,
                    &map,
                    Some(rows),
                    black_box(&object.phase),
                    &object.validity,
                    PointsOut {
                        xyz: x,
                        validity: v,
                        searched: None,
                    },
                    isa,
                    par,
                )
                .expect("compiled")
            };
            run(Isa::Baseline, false, &mut cx, &mut cv);
            // What the search answers those just beyond a clipped range, and the far
            // thresholds' spread.
            let mut answers = [0usize; 3];
            for &i in &beyond {
                answers[match Validity::from_u8(cv[i]) {
                    Some(Validity::Valid) => 0,
                    Some(Validity::NoCrossing) => 1,
                    _ => 2,
                }] += 1;
            }
            let mut fars: Vec<f32> = (0..h)
                .flat_map(|v| {
                    let m = &file.models[v * FIELDS * w..(v + 1) * FIELDS * w];
                    (0..w).filter_map(move |u| PixelModel::load(m, u))
                })
                .filter(|pm| pm.far_is_no_crossing())
                .map(|pm| pm.far)
                .collect();
            fars.sort_by(f32::total_cmp);
            let q = |f: f64| {
                let i = ((fars.len().max(1) - 1) as f64 * f) as usize;
                fars.get(i).copied().unwrap_or(f32::NAN)
            };
            eprintln!(
                "{name}, tolerance {} µm: of those just beyond their range the search gives {} a \
                 point, {} no-crossing, {} another code; τ_far at the 10th / 50th / 90th \
                 percentile {:.4} / {:.4} / {:.4}",
                tol * 1e3,
                answers[0],
                answers[1],
                answers[2],
                q(0.1),
                q(0.5),
                q(0.9)
            );
            for (label, isa, par) in [
                ("compiled_baseline_1thread", Isa::Baseline, false),
                ("compiled_avx2_1thread", Isa::Avx2, false),
                ("compiled_dispatched_1thread", Isa::detect(), false),
                ("compiled_dispatched_all_cores", Isa::detect(), true),
            ] {
                let (mut x2, mut v2) = (vec![0f32; 3 * w * h], vec![0u8; w * h]);
                run(isa, par, &mut x2, &mut v2);
                let same = cv == v2 && cx.iter().zip(&x2).all(|(a, b)| a.to_bits() == b.to_bits());
                assert!(
                    same,
                    "{label} differs from the portable compiled reconstruction"
                );
                g.bench_function(format!("{label}{tol_label}"), |b| {
                    b.iter(|| run(isa, par, &mut x2, &mut v2))
                });
            }
        }
        g.finish();
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
