//! Throughput of the hybrid reconstruction (paper §6) on a 1280 × 1024 phase map, single thread.
//!
//! The scene (seeded, built with the tests' independent f64 ray caster): the default test rig,
//! a plane tilted through most of the depth range filling the image and a sphere in front of it.
//! `exact`: exact phases. `noisy`: Gaussian phase noise (σ = 0.01 rad, seeded) on both the
//! reference and the object map. Reported per frame; throughput in pixels (all pixels of the frame).

#[path = "../tests/reconstruct_support.rs"]
#[allow(dead_code)]
mod support;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use fringe3d_core::reconstruct::{ReferenceMap, ReferenceRing, Reconstructor};
use std::hint::black_box;
use support::*;

fn scene(noise: f64) -> (Rig, PhaseMap, PhaseMap) {
    let rig = Rig::default_rig();
    let mut reference = render_reference(&rig);
    let surfaces = vec![
        Surface::Sphere { c: [-35.0, 25.0, 640.0], r: 55.0 },
        Surface::Plane { p: [0.0, 0.0, 700.0], n: unit([0.25, 0.15, -1.0]) },
    ];
    let bounds = Bounds { min: [-1e9, -1e9, rig.z_range[0]], max: [1e9, 1e9, rig.z_range[1]] };
    let mut object = render(&rig, &surfaces, bounds, 0..rig.cam.height as usize);
    if noise > 0.0 {
        let mut rng = Rng(0x5eed_0004);
        let mut gauss = || {
            let (a, b) = (rng.uniform().max(1e-300), rng.uniform());
            (-2.0 * a.ln()).sqrt() * (std::f64::consts::TAU * b).cos()
        };
        for m in [&mut reference, &mut object] {
            for p in m.phase.iter_mut() {
                if p.is_finite() {
                    *p = (*p as f64 + noise * gauss()) as f32;
                }
            }
        }
    }
    (rig, reference, object)
}

fn bench(c: &mut Criterion) {
    for (name, noise) in [("exact", 0.0), ("noisy", 0.01)] {
        let (rig, reference, object) = scene(noise);
        let cam = rig.cam.model();
        let recon = Reconstructor::new(&cam, &rig.setup()).unwrap();
        let (w, h) = (reference.width, reference.height);
        let mut prep = reference.phase.clone();
        let map = ReferenceMap::prepare(&mut prep, &reference.validity, w, h).unwrap();
        let mut xyz = vec![0f32; 3 * w * h];
        let mut val = vec![0u8; w * h];
        recon.reconstruct_frame(&map, &object.phase, &object.validity, &mut xyz, &mut val).unwrap();
        let valid = val.iter().filter(|&&v| v == 0).count();
        let input_valid = object.validity.iter().filter(|&&v| v == 0).count();
        eprintln!(
            "{name}: band {:?}, {} of {} pixels have a phase, {} reconstructed",
            recon.band(),
            input_valid,
            w * h,
            valid
        );
        let mut g = c.benchmark_group(format!("reconstruct_{name}"));
        g.throughput(Throughput::Elements((w * h) as u64));
        g.sample_size(20);
        g.bench_function("frame_1280x1024_batch", |b| {
            b.iter(|| {
                recon
                    .reconstruct_frame(&map, black_box(&object.phase), &object.validity, &mut xyz, &mut val)
                    .unwrap()
            })
        });
        let rows = recon.band().rows() as usize;
        let mut ring_phase = vec![0f32; rows * w];
        let mut ring_val = vec![0u8; rows * w];
        let mut orow = vec![0f32; 3 * w];
        let mut vrow = vec![0u8; w];
        g.bench_function("frame_1280x1024_streaming", |b| {
            b.iter(|| {
                let mut ring = ReferenceRing::new(&recon, &mut ring_phase, &mut ring_val).unwrap();
                for v in 0..h as u32 {
                    let (_, last) = recon.rows_needed(v);
                    while ring.rows_pushed() <= last {
                        let r = ring.rows_pushed() as usize;
                        ring.push_row(&reference.phase[r * w..(r + 1) * w], &reference.validity[r * w..(r + 1) * w])
                            .unwrap();
                    }
                    let s = v as usize * w;
                    recon
                        .reconstruct_row(&ring, v, &object.phase[s..s + w], &object.validity[s..s + w], &mut orow, &mut vrow)
                        .unwrap();
                }
                black_box(&orow);
            })
        });
        g.finish();
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
