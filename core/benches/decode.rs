//! Decode throughput: a 1280×1024 8-image set (the paper's 3-level set, u8), single thread,
//! row API. Seeded synthetic input. Run: `cargo bench -p fringe3d-core --bench decode`.

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use fringe3d_core::decode::{DecodeConfig, Decoder, RowOut};
use fringe3d_core::pattern::{Output, PatternSet};
use fringe3d_core::phase_function::Axis;
use std::hint::black_box;

const W: usize = 1280;
const H: usize = 1024;

fn frames(set: &PatternSet) -> Vec<Vec<u8>> {
    // Camera sees the projector 1:1 (scaled), plus a seeded dither so that no row repeats.
    let mut seed = 0x1234_5678_9abc_def0u64;
    (0..set.image_count())
        .map(|i| {
            let mut img = vec![0u8; W * H];
            let mut row = vec![0u16; 1024];
            for y in 0..H {
                set.generate_row(i, (y * 768 / H) as u32, &mut row)
                    .unwrap_or(());
                for x in 0..W {
                    seed ^= seed << 13;
                    seed ^= seed >> 7;
                    seed ^= seed << 17;
                    let v = 20 + (row[x * 1024 / W] as u32 * 200 / 65535) + (seed & 3) as u32;
                    img[y * W + x] = v.min(255) as u8;
                }
            }
            img
        })
        .collect()
}

fn bench(c: &mut Criterion) {
    let out = Output {
        width: 1024,
        height: 768,
        i_min: 0.0,
        i_max: 65535.0,
    };
    let set = PatternSet::default_for(Axis::Xi, out).expect("default set");
    let dec = Decoder::new(&set, DecodeConfig::for_bit_depth(8)).expect("decoder");
    let imgs = frames(&set);
    let mut phase = vec![0.0f32; W];
    let mut b = vec![0.0f32; W];
    let mut a = vec![0.0f32; W];
    let mut v = vec![0u8; W];
    let mut g = c.benchmark_group("decode");
    g.throughput(Throughput::Elements((W * H) as u64));
    g.sample_size(20);
    g.bench_function("row_api_u8_1280x1024_8img", |bch| {
        bch.iter(|| {
            for y in 0..H {
                let rows: [&[u8]; 8] = core::array::from_fn(|i| &imgs[i][y * W..(y + 1) * W]);
                dec.decode_row(
                    &rows,
                    RowOut {
                        phase: &mut phase,
                        modulation: &mut b,
                        dc: &mut a,
                        validity: &mut v,
                    },
                )
                .expect("decode");
            }
            black_box(&phase);
        })
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
