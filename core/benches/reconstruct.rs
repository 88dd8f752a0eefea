//! Throughput of the hybrid reconstruction (paper §6) on a 1280 × 1024 phase map, single thread.
//!
//! The scene (seeded, built with the tests' independent f64 ray caster): the default test rig,
//! a plane tilted through most of the depth range filling the image and a sphere in front of it.
//! `exact`: exact phases. `noisy`: Gaussian phase noise (σ = 0.01 rad, seeded) on both the
//! reference and the object map. Reported per frame; throughput in pixels (all pixels of the frame).

#![allow(clippy::disallowed_methods)] // std maths for the synthetic scene

#[path = "../tests/reconstruct_support.rs"]
mod support;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use fringe3d_core::reconstruct::{Reconstructor, ReferenceMap, ReferenceRing};
use std::hint::black_box;
use support::*;

/// The batch path, always inlined into the wide-ISA wrappers below (the kernel is
/// `#[inline(always)]`, so it is vectorized 8- or 16-wide inside them), as a host would dispatch
/// at run time. Same bits as the baseline build.
#[inline(always)]
fn frame_rows(
    recon: &Reconstructor,
    map: &ReferenceMap<'_>,
    phase: &[f32],
    validity: &[u8],
    xyz: &mut [f32],
    val: &mut [u8],
) {
    let w = recon.width();
    let rows = phase
        .chunks_exact(w)
        .zip(validity.chunks_exact(w))
        .zip(xyz.chunks_exact_mut(3 * w).zip(val.chunks_exact_mut(w)));
    for (v, ((p, q), (o, ov))) in rows.enumerate() {
        recon.reconstruct_row(map, v as u32, p, q, o, ov).unwrap();
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn frame_avx2(
    recon: &Reconstructor,
    map: &ReferenceMap<'_>,
    phase: &[f32],
    validity: &[u8],
    xyz: &mut [f32],
    val: &mut [u8],
) {
    frame_rows(recon, map, phase, validity, xyz, val)
}

/// AVX-512 (compilers ≥ 1.89: `cfg(fringe3d_avx512)` from `build.rs`).
#[cfg(all(target_arch = "x86_64", fringe3d_avx512))]
#[target_feature(enable = "avx512f,avx512bw,avx512dq,avx512vl")]
fn frame_avx512(
    recon: &Reconstructor,
    map: &ReferenceMap<'_>,
    phase: &[f32],
    validity: &[u8],
    xyz: &mut [f32],
    val: &mut [u8],
) {
    frame_rows(recon, map, phase, validity, xyz, val)
}

type FrameFn = unsafe fn(&Reconstructor, &ReferenceMap<'_>, &[f32], &[u8], &mut [f32], &mut [u8]);

/// The wide variants this build has and this CPU runs.
fn wide_variants() -> Vec<(&'static str, FrameFn)> {
    #[allow(unused_mut)]
    let mut v: Vec<(&'static str, FrameFn)> = Vec::new();
    #[cfg(target_arch = "x86_64")]
    if std::is_x86_feature_detected!("avx2") {
        v.push(("avx2", frame_avx2));
    }
    #[cfg(all(target_arch = "x86_64", fringe3d_avx512))]
    if std::is_x86_feature_detected!("avx512f")
        && std::is_x86_feature_detected!("avx512bw")
        && std::is_x86_feature_detected!("avx512dq")
        && std::is_x86_feature_detected!("avx512vl")
    {
        v.push(("avx512", frame_avx512));
    }
    v
}

fn bench(c: &mut Criterion) {
    for (name, noise) in [("exact", 0.0), ("noisy", 0.01)] {
        let (rig, reference, object) = bench_scene(noise);
        let cam = rig.cam.model();
        let recon = Reconstructor::new(&cam, &rig.setup()).unwrap();
        let (w, h) = (reference.width, reference.height);
        let mut prep = reference.phase.clone();
        let map = ReferenceMap::prepare(&mut prep, &reference.validity, w, h).unwrap();
        let mut xyz = vec![0f32; 3 * w * h];
        let mut val = vec![0u8; w * h];
        recon
            .reconstruct_frame(&map, &object.phase, &object.validity, &mut xyz, &mut val)
            .unwrap();
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
                    .reconstruct_frame(
                        &map,
                        black_box(&object.phase),
                        &object.validity,
                        &mut xyz,
                        &mut val,
                    )
                    .unwrap()
            })
        });
        for (isa, f) in wide_variants() {
            let mut xyz2 = vec![0f32; 3 * w * h];
            let mut val2 = vec![0u8; w * h];
            // SAFETY: `wide_variants` lists only variants whose features were detected at run time.
            unsafe {
                f(
                    &recon,
                    &map,
                    &object.phase,
                    &object.validity,
                    &mut xyz2,
                    &mut val2,
                )
            };
            let same = val == val2
                && xyz
                    .iter()
                    .zip(&xyz2)
                    .all(|(a, b)| a.to_bits() == b.to_bits());
            assert!(same, "{isa} build differs from the baseline build");
            g.bench_function(format!("frame_1280x1024_batch_{isa}"), |b| {
                // SAFETY: as above.
                b.iter(|| unsafe {
                    f(
                        &recon,
                        &map,
                        black_box(&object.phase),
                        &object.validity,
                        &mut xyz2,
                        &mut val2,
                    )
                })
            });
        }
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
                        ring.push_row(
                            &reference.phase[r * w..(r + 1) * w],
                            &reference.validity[r * w..(r + 1) * w],
                        )
                        .unwrap();
                    }
                    let s = v as usize * w;
                    recon
                        .reconstruct_row(
                            &ring,
                            v,
                            &object.phase[s..s + w],
                            &object.validity[s..s + w],
                            &mut orow,
                            &mut vrow,
                        )
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
