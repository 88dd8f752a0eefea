//! Decode throughput per arithmetic backend (issue #9, docs/arithmetic.md): the paper's 3-level
//! set, u8, 1280 pixels × 256 rows of seeded synthetic fringes, single thread, row API; each
//! backend compiled for the baseline x86-64 (SSE2) and, when the CPU has it, for AVX2 (as the
//! host's batch path does). Run: `cargo bench -p fringe3d-core-bench --bench arith`.

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use fringe3d_core::arith::{Arith, F32Accurate, F32Fast, F32Micromath, Fixed};
use fringe3d_core::decode::{DecodeConfig, Decoder, RowOut};
use fringe3d_core::pattern::{Output, PatternSet};
use fringe3d_core::phase_function::Axis;
use std::hint::black_box;

const W: usize = 1280;
const H: usize = 256;

fn frames(set: &PatternSet) -> Vec<Vec<u8>> {
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

struct Out {
    phase: Vec<f32>,
    b: Vec<f32>,
    a: Vec<f32>,
    v: Vec<u8>,
}

#[inline(always)]
fn all_rows<A: Arith>(d: &Decoder<A>, imgs: &[Vec<u8>], o: &mut Out) {
    for y in 0..H {
        let rows: [&[u8]; 8] = core::array::from_fn(|i| &imgs[i][y * W..(y + 1) * W]);
        d.decode_row(
            &rows,
            RowOut {
                phase: &mut o.phase,
                modulation: &mut o.b,
                dc: &mut o.a,
                validity: &mut o.v,
            },
        )
        .expect("decode");
    }
}

fn baseline<A: Arith>(d: &Decoder<A>, imgs: &[Vec<u8>], o: &mut Out) {
    all_rows(d, imgs, o)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn avx2<A: Arith>(d: &Decoder<A>, imgs: &[Vec<u8>], o: &mut Out) {
    all_rows(d, imgs, o)
}

fn backend<A: Arith>(c: &mut Criterion, set: &PatternSet, imgs: &[Vec<u8>]) {
    let d = Decoder::<A>::with_arith(set, DecodeConfig::for_bit_depth(8)).expect("decoder");
    let mut o = Out {
        phase: vec![0.0; W],
        b: vec![0.0; W],
        a: vec![0.0; W],
        v: vec![0; W],
    };
    let mut g = c.benchmark_group("arith");
    g.throughput(Throughput::Elements((W * H) as u64));
    g.sample_size(20);
    g.bench_function(format!("{}_sse2", A::NAME), |bch| {
        bch.iter(|| {
            baseline(&d, imgs, &mut o);
            black_box(&o.phase);
        })
    });
    #[cfg(target_arch = "x86_64")]
    if std::is_x86_feature_detected!("avx2") {
        g.bench_function(format!("{}_avx2", A::NAME), |bch| {
            bch.iter(|| {
                // SAFETY: the CPU has AVX2 (checked above), the only requirement of `avx2`.
                unsafe { avx2(&d, imgs, &mut o) };
                black_box(&o.phase);
            })
        });
    }
    g.finish();
}

fn bench(c: &mut Criterion) {
    let out = Output {
        width: 1024,
        height: 768,
        i_min: 0.0,
        i_max: 65535.0,
    };
    let set = PatternSet::default_for(Axis::Xi, out).expect("default set");
    let imgs = frames(&set);
    backend::<F32Accurate>(c, &set, &imgs);
    backend::<F32Fast>(c, &set, &imgs);
    backend::<F32Micromath>(c, &set, &imgs);
    backend::<Fixed>(c, &set, &imgs);
}

criterion_group!(benches, bench);
criterion_main!(benches);
