//! Reconstruction throughput of the desktop batch path (`fringe3d::batch::reconstruct_frame`,
//! which `fringe3d scan` runs): a 1280 × 1024 phase map, single thread and all cores, the
//! baseline and AVX2 kernels and the runtime-dispatched one (AVX-512 where the CPU and the
//! compiler have it), with the x86 pair gathers of `fringe3d::gather`. The scene is the core
//! benchmark's (`core/benches/reconstruct.rs`: seeded, from the tests' f64 ray caster), `exact`
//! and `noisy` (σ = 0.01 rad phase noise). Every variant is first checked bit for bit against
//! the core's portable `reconstruct_frame`.
//! Run: `cargo bench -p fringe3d --bench reconstruct_batch`.

#![allow(clippy::disallowed_methods)] // std maths for the synthetic scene

#[path = "../../core/tests/reconstruct_support.rs"]
mod support;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use fringe3d::batch::{Isa, PointsOut, reconstruct_frame};
use fringe3d_core::reconstruct::{Reconstructor, ReferenceMap};
use std::hint::black_box;
use support::*;

fn bench(c: &mut Criterion) {
    for (name, noise) in [("exact", 0.0), ("noisy", 0.01)] {
        let (rig, reference, object) = bench_scene(noise);
        let cam = rig.cam.model();
        let recon = Reconstructor::new(&cam, &rig.setup()).expect("reconstructor");
        let (w, h) = (reference.width, reference.height);
        let mut prep = reference.phase.clone();
        let map = ReferenceMap::prepare(&mut prep, &reference.validity, w, h).expect("map");
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
                        },
                        isa,
                        par,
                    )
                    .expect("batch")
                })
            });
        }
        g.finish();
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
