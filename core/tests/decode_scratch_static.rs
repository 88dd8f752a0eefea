//! `DecodeScratch::new` is a `const fn`: a head keeps the row decoder's scratch in a `static`
//! (docs/integration.md). The scratch in a static, reused across rows and sets, gives the same
//! bits as a fresh scratch per row, for the f32 and the fixed-point backends.

use fringe3d_core::arith::{Arith, F32Accurate, Fixed};
use fringe3d_core::decode::{DecodeScratch, Decoder, RowOut, parity};
use fringe3d_core::pattern::MAX_IMAGES;
use std::sync::Mutex;

static SCRATCH: Mutex<DecodeScratch> = Mutex::new(DecodeScratch::new());
static SCRATCH_FIXED: Mutex<DecodeScratch<Fixed>> = Mutex::new(DecodeScratch::new());

/// Phase, modulation, DC and validity of every parity case, as bits; `scratch` = kept scratch.
fn decode_all<A: Arith>(scratch: Option<&Mutex<DecodeScratch<A>>>) -> Vec<u32> {
    let mut bits = Vec::new();
    for case in 0..parity::CASES {
        let set = parity::set(case).expect("parity set");
        let dec = Decoder::<A>::with_arith(&set, parity::config(case)).expect("decoder");
        let mut rows = [[0u16; parity::WIDTH]; MAX_IMAGES];
        let n = parity::samples(case, &mut rows).expect("samples");
        let views: Vec<&[u16]> = rows[..n].iter().map(|r| &r[..]).collect();
        let w = parity::WIDTH;
        let (mut p, mut m, mut a, mut q) =
            (vec![0f32; w], vec![0f32; w], vec![0f32; w], vec![0u8; w]);
        for _ in 0..2 {
            let out = RowOut {
                phase: &mut p,
                modulation: &mut m,
                dc: &mut a,
                validity: &mut q,
            };
            match scratch {
                Some(s) => dec.decode_row_with(&mut s.lock().unwrap(), &views, out),
                None => dec.decode_row(&views, out),
            }
            .expect("decode");
            bits.extend(p.iter().chain(&m).chain(&a).map(|x| x.to_bits()));
            bits.extend(q.iter().map(|&c| c as u32));
        }
    }
    bits
}

#[test]
fn a_static_scratch_gives_the_bits_of_a_fresh_one() {
    let fresh = decode_all::<F32Accurate>(None);
    assert!(
        fresh.iter().any(|&b| b != 0),
        "the cases decode to something"
    );
    assert_eq!(decode_all(Some(&SCRATCH)), fresh);
    assert_eq!(
        decode_all::<Fixed>(Some(&SCRATCH_FIXED)),
        decode_all::<Fixed>(None)
    );
}
