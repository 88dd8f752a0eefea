//! Decode throughput, 1280×1024 u8 frames, single thread, row API, seeded synthetic input: the
//! paper's 8-image 3-level set; Gray code + phase shifting (a complementary 5-bit code and a
//! 4-step level, 10 images) and 3-frequency heterodyne (21/26/32, 12 images) of issue #20, whose
//! bar is a Gray set within 1.5× of the paper's per pixel. Run:
//! `cargo bench -p fringe3d-core-bench --bench decode`.

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use fringe3d_core::decode::{DecodeConfig, Decoder, RowOut};
use fringe3d_core::pattern::{GrayCode, Level, Output, PatternSet, Relation};
use fringe3d_core::phase_function::{Axis, PhaseFunction};
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
    let f = PhaseFunction::centered(Axis::Xi, 1024, 0.9 * std::f64::consts::TAU).expect("phase");
    let paper = PatternSet::default_for(Axis::Xi, out).expect("default set");
    let gray = PatternSet::new(
        f,
        &[
            Level::gray_code(20.0, GrayCode::new(5, true)),
            Level::n_step(20.0, 4),
        ],
        out,
    )
    .expect("gray set");
    let het = PatternSet::new_with_relation(
        f,
        &[21.0, 26.0, 32.0].map(|c| Level::n_step(c, 4)),
        out,
        Relation::Heterodyne,
    )
    .expect("heterodyne set");
    let mut g = c.benchmark_group("decode");
    g.throughput(Throughput::Elements((W * H) as u64));
    g.sample_size(20);
    for (name, set) in [
        ("row_api_u8_1280x1024_8img", paper),
        ("row_api_u8_1280x1024_gray5c_4step_10img", gray),
        ("row_api_u8_1280x1024_heterodyne_12img", het),
    ] {
        let dec = Decoder::new(&set, DecodeConfig::for_bit_depth(8)).expect("decoder");
        let imgs = frames(&set);
        let mut phase = vec![0.0f32; W];
        let mut b = vec![0.0f32; W];
        let mut a = vec![0.0f32; W];
        let mut v = vec![0u8; W];
        g.bench_function(name, |bch| {
            bch.iter(|| {
                for y in 0..H {
                    let mut rows: [&[u8]; 12] = [&[]; 12];
                    for (r, i) in rows.iter_mut().zip(&imgs) {
                        *r = &i[y * W..(y + 1) * W];
                    }
                    dec.decode_row(
                        &rows[..imgs.len()],
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
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
