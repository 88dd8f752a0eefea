//! Golden digests of the parity workload ([`fringe3d_core::decode::parity`]) for every backend:
//! the bits x86-64 computes, which the Cortex-M builds reproduce (`arith_qemu.rs`, and the table
//! in docs/arithmetic.md). A change here is a change of some backend's results: update the
//! constants only on purpose, and say so in docs/arithmetic.md.

use fringe3d_core::arith::Backend;
use fringe3d_core::decode::parity;

/// `backend → digest per case` (cases: [`parity::CASE_NAMES`]).
const GOLDEN: [(&str, [u64; parity::CASES]); 4] = [
    (
        "f32",
        [
            0x284ca7e3234232fc,
            0xd78d13a835725a5b,
            0xa88e87c14166b239,
            0xc72cb6842c925c37,
            0x4713ae2e46213551,
            0x7ad77ba821506716,
            0x220b67594415c768,
        ],
    ),
    (
        "f32-fast",
        [
            0xbb549402bc8dd97d,
            0x5722b9910192e760,
            0x35294c698affbc4a,
            0x3d576938e792a289,
            0xa85a07187c927aab,
            0x52a4bdad447e05f0,
            0x5f0b98e40c1063e1,
        ],
    ),
    (
        "f32-micromath",
        [
            0xa6404b2c96c8b455,
            0x448db36a41be827b,
            0x53a42920faed9f8a,
            0x4e24ff59a6ef4c4d,
            0xff06000959f93034,
            0xde23090b5043d385,
            0x5faf28e6a4c2e521,
        ],
    ),
    (
        "fixed",
        [
            0x9c0a7182af9da10c,
            0x62065a3c85a004cb,
            0x6e89d400f6f0c146,
            0x57acd6561fb75752,
            0x93e63ad5c6faffa2,
            0x7984bee121143aa8,
            0xb449f7e6828db9c9,
        ],
    ),
];

#[test]
fn parity_digests_are_the_golden_ones() {
    if std::env::var_os("FRINGE3D_PRINT_DIGESTS").is_some() {
        for b in Backend::ALL {
            let d: Vec<String> = (0..parity::CASES)
                .map(|c| format!("0x{:016x}", parity::digest(b, c).unwrap()))
                .collect();
            println!("    (\"{}\", [{}]),", b.name(), d.join(", "));
        }
    }
    for (b, (name, want)) in Backend::ALL.into_iter().zip(GOLDEN) {
        assert_eq!(b.name(), name);
        for (case, w) in want.iter().enumerate() {
            let got = parity::digest(b, case).unwrap();
            assert_eq!(
                got,
                *w,
                "{b}, case {case} ({}): 0x{got:016x}",
                parity::CASE_NAMES[case]
            );
        }
    }
}

#[test]
fn the_workload_exercises_every_validity_code_it_should() {
    // Valid and invalid pixels in every case, so that the digests cover both paths.
    use fringe3d_core::decode::AnyDecoder;
    use fringe3d_core::decode::RowOut;
    use fringe3d_core::pattern::MAX_IMAGES;
    for case in 0..parity::CASES {
        let set = parity::set(case).unwrap();
        let d = AnyDecoder::new(&set, parity::config(case), Backend::Fixed).unwrap();
        let mut rows = [[0u16; parity::WIDTH]; MAX_IMAGES];
        let n = parity::samples(case, &mut rows).unwrap();
        let refs: Vec<&[u16]> = rows[..n].iter().map(|r| &r[..]).collect();
        let (mut p, mut m, mut a, mut v) = (
            [0.0f32; parity::WIDTH],
            [0.0f32; parity::WIDTH],
            [0.0f32; parity::WIDTH],
            [0u8; parity::WIDTH],
        );
        d.decode_row(
            &refs,
            RowOut {
                phase: &mut p,
                modulation: &mut m,
                dc: &mut a,
                validity: &mut v,
            },
        )
        .unwrap();
        let valid = v.iter().filter(|x| **x == 0).count();
        assert!(
            valid > parity::WIDTH / 2 && valid < parity::WIDTH,
            "case {case}: {valid} valid"
        );
    }
}

/// The HDR case ([`fringe3d_core::hdr_parity`]): both drivers agree (else the digest is an
/// error) and the bits are those x86-64 recorded, per backend; `arith_qemu.rs` holds the
/// Cortex-M builds to them.
#[test]
fn hdr_digests_are_the_golden_ones() {
    use fringe3d_core::hdr_parity;
    const GOLDEN_HDR: [(&str, u64); 4] = [
        ("f32", 0x670a7b7f0646be56),
        ("f32-fast", 0xb5fa95a30257737e),
        ("f32-micromath", 0xb9914700b619d9b9),
        ("fixed", 0xce7c7ba505d69628),
    ];
    for (b, (name, want)) in Backend::ALL.into_iter().zip(GOLDEN_HDR) {
        assert_eq!(b.name(), name);
        let got = hdr_parity::digest(b).unwrap();
        assert_eq!(got, want, "{b}: 0x{got:016x}");
    }
}
