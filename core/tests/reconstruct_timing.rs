//! Per-frame CPU time of the reconstruction (ignored by default; run with
//! `cargo test --release -p fringe3d-core --test suite reconstruct_timing:: -- --ignored --nocapture
//! --test-threads 1`, so that the two scenes do not compete for the cores).
//!
//! Reports the thread's on-CPU time (Linux `/proc/thread-self/schedstat`) next to wall time, so
//! that a busy machine does not inflate the numbers as much as criterion's wall clock. Same scenes
//! (`exact` and `noisy`) as `benches/reconstruct.rs`. Also checks that the AVX2 build of the kernel gives the same bits.
// Integration tests are std: std f64 maths builds the scene.
#![allow(clippy::disallowed_methods)]

use crate::reconstruct_support as support;

use fringe3d_core::reconstruct::{Reconstructor, ReferenceMap};
use std::time::Instant;
use support::*;

fn cpu_ns() -> Option<u64> {
    let s = std::fs::read_to_string("/proc/thread-self/schedstat").ok()?;
    s.split_whitespace().next()?.parse().ok()
}

fn frame(
    recon: &Reconstructor,
    map: &ReferenceMap<'_>,
    phase: &[f32],
    val: &[u8],
    xyz: &mut [f32],
    out: &mut [u8],
) {
    recon.reconstruct_frame(map, phase, val, xyz, out).unwrap();
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn frame_avx2(
    recon: &Reconstructor,
    map: &ReferenceMap<'_>,
    phase: &[f32],
    val: &[u8],
    xyz: &mut [f32],
    out: &mut [u8],
) {
    let w = recon.width();
    let rows = phase
        .chunks_exact(w)
        .zip(val.chunks_exact(w))
        .zip(xyz.chunks_exact_mut(3 * w).zip(out.chunks_exact_mut(w)));
    for (v, ((p, q), (o, ov))) in rows.enumerate() {
        recon.reconstruct_row(map, v as u32, p, q, o, ov).unwrap();
    }
}

#[test]
#[ignore]
fn frame_cpu_time() {
    timing("exact", 0.0);
}

/// The benchmark's `noisy` scene: Gaussian phase noise σ = 0.01 rad on both maps.
#[test]
#[ignore]
fn frame_cpu_time_noisy() {
    timing("noisy", 0.01);
}

fn timing(name: &str, noise: f64) {
    let (rig, reference, object) = bench_scene(noise);
    let recon = Reconstructor::new(&rig.cam.model(), &rig.setup()).unwrap();
    let (w, h) = (1280, 1024);
    let mut prep = reference.phase.clone();
    let map = ReferenceMap::prepare(&mut prep, &reference.validity, w, h).unwrap();
    let mut xyz = vec![0f32; 3 * w * h];
    let mut val = vec![0u8; w * h];
    let mut xyz2 = vec![0f32; 3 * w * h];
    let mut val2 = vec![0u8; w * h];
    let n = 10;
    let mut best = [f64::MAX; 4];
    for _ in 0..n {
        let (t, c) = (Instant::now(), cpu_ns());
        frame(
            &recon,
            &map,
            &object.phase,
            &object.validity,
            &mut xyz,
            &mut val,
        );
        let (wall, cpu) = (
            t.elapsed().as_secs_f64() * 1e3,
            cpu_ns().zip(c).map(|(a, b)| (a - b) as f64 * 1e-6),
        );
        best[0] = best[0].min(wall);
        best[1] = best[1].min(cpu.unwrap_or(f64::NAN));
        #[cfg(target_arch = "x86_64")]
        if std::is_x86_feature_detected!("avx2") {
            let (t, c) = (Instant::now(), cpu_ns());
            // SAFETY: AVX2 was detected at run time.
            unsafe {
                frame_avx2(
                    &recon,
                    &map,
                    &object.phase,
                    &object.validity,
                    &mut xyz2,
                    &mut val2,
                )
            };
            let (wall, cpu) = (
                t.elapsed().as_secs_f64() * 1e3,
                cpu_ns().zip(c).map(|(a, b)| (a - b) as f64 * 1e-6),
            );
            best[2] = best[2].min(wall);
            best[3] = best[3].min(cpu.unwrap_or(f64::NAN));
        }
    }
    let mpx = |ms: f64| (w * h) as f64 / ms / 1e3;
    eprintln!(
        "{name} 1280x1024, best of {n}: baseline {:.1} ms wall / {:.1} ms CPU ({:.1} Mpx/s CPU); avx2 {:.1} ms wall / {:.1} ms CPU ({:.1} Mpx/s CPU)",
        best[0],
        best[1],
        mpx(best[1]),
        best[2],
        best[3],
        mpx(best[3])
    );
    if best[2] < f64::MAX {
        assert!(
            val == val2
                && xyz
                    .iter()
                    .zip(&xyz2)
                    .all(|(a, b)| a.to_bits() == b.to_bits())
        );
    }
}
