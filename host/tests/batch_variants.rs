//! The batch decode's kernel variants (portable, AVX2, AVX-512; one thread and rayon's pool)
//! give the same bits (`fringe3d::batch`); a variant the CPU lacks falls back and says so.

use crate::cli_support::{VARIANTS, decode_variant};
use fringe3d::batch::Isa;
use fringe3d_core::decode::DecodeConfig;
use fringe3d_core::decode::Decoder;
use fringe3d_core::pattern::{Output, PatternSet};
use fringe3d_core::phase_function::Axis;

#[test]
fn every_variant_gives_the_same_bits() {
    let (w, h) = (333, 50);
    let set = PatternSet::default_for(
        Axis::Xi,
        Output {
            width: 640,
            height: 480,
            i_min: 0.0,
            i_max: 255.0,
        },
    )
    .unwrap();
    let d = Decoder::new(&set, DecodeConfig::for_bit_depth(8)).unwrap();
    let mut seed = 99u64;
    let imgs: Vec<Vec<u8>> = (0..8)
        .map(|i| {
            let mut row = vec![0u8; 640];
            (0..w * h)
                .map(|p| {
                    if p % w == 0 {
                        set.generate_row(i, ((p / w) % 480) as u32, &mut row)
                            .unwrap();
                    }
                    seed = seed
                        .wrapping_mul(6364136223846793005)
                        .wrapping_add(1442695040888963407);
                    (row[(p % w) * 640 / w] as u32 * 3 / 4 + 10 + (seed >> 60) as u32).min(255)
                        as u8
                })
                .collect()
        })
        .collect();
    let frames: Vec<&[u8]> = imgs.iter().map(|v| v.as_slice()).collect();
    let mut results = Vec::new();
    for variant in VARIANTS {
        let (p, m, a, v) = decode_variant(&d, &frames, (w, h), variant);
        let bits: Vec<u32> = p
            .iter()
            .chain(&m)
            .chain(&a)
            .map(|x| fringe3d_core::math::canonical(*x).to_bits())
            .collect();
        results.push((bits, v));
    }
    for isa in [Isa::Avx2, Isa::Avx512] {
        if !isa.available() {
            eprintln!(
                "note: no {isa:?} on this CPU or in this build; that variant fell back to {:?}",
                isa.effective()
            );
        }
    }
    for r in &results[1..] {
        assert!(r.0 == results[0].0 && r.1 == results[0].1);
    }
    assert!(results[0].1.contains(&0));
}
