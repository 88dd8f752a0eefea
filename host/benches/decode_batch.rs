//! Decode throughput of the desktop batch path: a 1280×1024 8-image u8 set, single thread and all
//! cores, the baseline and AVX2 kernels and the runtime-dispatched one (AVX-512 where the CPU and
//! the compiler have it). Seeded synthetic input.
//! Run: `cargo bench -p fringe3d-bench --bench decode_batch`.

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use fringe3d::batch::{FrameOut, Isa, decode_frames};
use fringe3d_core::decode::{DecodeConfig, Decoder};
use fringe3d_core::pattern::{Output, PatternSet};
use fringe3d_core::phase_function::Axis;
use std::hint::black_box;

const W: usize = 1280;
const H: usize = 1024;

fn bench(c: &mut Criterion) {
    let set = PatternSet::default_for(
        Axis::Xi,
        Output {
            width: 1024,
            height: 768,
            i_min: 0.0,
            i_max: 65535.0,
        },
    )
    .expect("set");
    let d = Decoder::new(&set, DecodeConfig::for_bit_depth(8)).expect("decoder");
    let mut seed = 0x9e37_79b9_7f4a_7c15u64;
    let imgs: Vec<Vec<u8>> = (0..8)
        .map(|i| {
            let mut row = vec![0u16; 1024];
            let mut img = vec![0u8; W * H];
            for y in 0..H {
                set.generate_row(i, (y * 768 / H) as u32, &mut row)
                    .expect("row");
                for x in 0..W {
                    seed ^= seed << 13;
                    seed ^= seed >> 7;
                    seed ^= seed << 17;
                    img[y * W + x] =
                        (20 + row[x * 1024 / W] as u32 * 200 / 65535 + (seed & 3) as u32).min(255)
                            as u8;
                }
            }
            img
        })
        .collect();
    let frames: Vec<&[u8]> = imgs.iter().map(|v| v.as_slice()).collect();
    let (mut p, mut m, mut a, mut v) = (
        vec![0.0f32; W * H],
        vec![0.0f32; W * H],
        vec![0.0f32; W * H],
        vec![0u8; W * H],
    );
    let mut g = c.benchmark_group("decode_batch_1280x1024_8img_u8");
    g.throughput(Throughput::Elements((W * H) as u64));
    g.sample_size(20);
    for (name, isa, par) in [
        ("baseline_1thread", Isa::Baseline, false),
        ("avx2_1thread", Isa::Avx2, false),
        ("dispatched_1thread", Isa::detect(), false),
        ("dispatched_all_cores", Isa::detect(), true),
    ] {
        g.bench_function(name, |b| {
            b.iter(|| {
                decode_frames(
                    &d,
                    &frames,
                    W,
                    H,
                    FrameOut {
                        phase: &mut p,
                        modulation: &mut m,
                        dc: &mut a,
                        validity: &mut v,
                    },
                    isa,
                    par,
                )
                .expect("decode");
                black_box(&p);
            })
        });
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
