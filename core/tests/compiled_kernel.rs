//! The compiled reconstruction's kernel (`reconstruct::compiled`), the model's encoding and the
//! settle of a row, against their f64 and pixel-by-pixel references.

use fringe3d_core::Validity;
use fringe3d_core::math::CANONICAL_NAN;
use fringe3d_core::reconstruct::compiled::*;

fn model() -> PixelModel {
    PixelModel {
        ray: [0.1, -0.05],
        phase_centre: 100.0,
        phase_scale: 0.02,
        depth_centre: 700.0,
        pole: 0.1,
        slope: [120.0, 2.0, -0.5, 0.01],
        far: f32::INFINITY,
    }
}

#[test]
fn bytes_round_trip_and_bad_models_are_search() {
    let m = model();
    let mut b = [0u8; PixelModel::BYTES];
    m.emit(&mut b).unwrap();
    assert_eq!(PixelModel::parse(&b), Some(m));
    assert_eq!(PixelModel::parse(&b[..PixelModel::BYTES - 1]), None);
    // A zero scale: no reference, whatever the other numbers; a NaN anywhere else: the
    // search.
    let bits = |m: PixelModel| m.to_array().map(f32::to_bits);
    for zero in [0.0, -0.0] {
        let mut z = m;
        z.phase_scale = zero;
        z.emit(&mut b).unwrap();
        let back = PixelModel::parse(&b).unwrap();
        assert_eq!(bits(back), bits(PixelModel::NO_REFERENCE));
        assert!(back.is_no_reference() && !back.is_compiled());
    }
    assert!(!PixelModel::SEARCH.is_no_reference());
    // A negative s_c is not usable, clipped or not.
    let mut neg = m;
    neg.depth_centre = -neg.depth_centre;
    neg.emit(&mut b).unwrap();
    assert!(!PixelModel::parse(&b).unwrap().is_compiled());
    neg.phase_scale = -neg.phase_scale;
    neg.emit(&mut b).unwrap();
    assert!(!PixelModel::parse(&b).unwrap().is_compiled());
    // τ_far: +∞, or at least 1 on a clipped model; anything else is not usable.
    let mut clip = m;
    clip.phase_scale = -clip.phase_scale;
    for (far, clipped, usable) in [
        (f32::INFINITY, false, true),
        (f32::INFINITY, true, true),
        (1.0, true, true),
        (1.3, true, true),
        (1.3, false, false),
        (0.99, true, false),
        (f32::NEG_INFINITY, true, false),
        (f32::NAN, true, false),
    ] {
        let mut x = if clipped { clip } else { m };
        x.far = far;
        x.emit(&mut b).unwrap();
        let back = PixelModel::parse(&b).unwrap();
        assert_eq!(back.is_compiled(), usable, "τ_far {far}, clipped {clipped}");
        if usable {
            assert_eq!(bits(back), bits(x));
            assert_eq!(back.far_is_no_crossing(), far < f32::INFINITY);
        }
    }
    let mut n = m;
    n.phase_centre = f32::NAN;
    n.emit(&mut b).unwrap();
    assert_eq!(
        bits(PixelModel::parse(&b).unwrap()),
        bits(PixelModel::SEARCH)
    );
    let mut n = m;
    n.slope[2] = f32::INFINITY;
    n.emit(&mut b).unwrap();
    assert!(!PixelModel::parse(&b).unwrap().is_compiled());
}

#[test]
fn kernel_follows_the_f64_reference_and_the_codes() {
    let m = model();
    let mut clip = m;
    clip.phase_scale = -m.phase_scale;
    let list = [m, m, m, PixelModel::SEARCH, m, m, clip, clip];
    let mut models = [0f32; 8 * FIELDS];
    for (u, x) in list.iter().enumerate() {
        x.store(&mut models, u).unwrap();
    }
    assert_eq!(PixelModel::load(&models, 6), Some(clip));
    assert_eq!(PixelModel::load(&models, 8), None);
    // The bytes of a row, parsed back.
    let mut bytes = [0u8; 32 * FIELDS];
    for (b, v) in bytes.chunks_exact_mut(4).zip(&models) {
        b.copy_from_slice(&v.to_le_bytes());
    }
    let mut back = [0f32; 8 * FIELDS];
    PixelModel::parse_row(&bytes, &mut back).unwrap();
    assert!(
        models
            .iter()
            .zip(&back)
            .all(|(a, b)| a.to_bits() == b.to_bits())
    );
    assert_eq!(PixelModel::parse_row(&bytes[1..], &mut back), None);
    let phase = [100.0, 140.0, 160.0, 100.0, 100.0, f32::NAN, 140.0, 160.0];
    let q = [0, 0, 0, 0, 1, 0, 0, 0];
    let mut xyz = [0f32; 24];
    let mut out = [0u8; 8];
    let n = compiled_row(&models, 500.0, 900.0, &phase, &q, &mut xyz, &mut out).unwrap();
    assert_eq!(n, 2);
    let s = m.depth_f64(140.0).unwrap();
    assert!((xyz[5] as f64 - s).abs() < 1e-4, "{} {}", xyz[5], s);
    assert_eq!(xyz[0..3], [70.0, -35.0, 700.0]);
    // τ = 1.2: outside the range; clipped, the same phase goes to the search.
    assert_eq!(out[2], Validity::OutOfDepth as u8);
    assert_eq!(out[7], LEFT_TO_SEARCH);
    assert_eq!(xyz[18..21], xyz[3..6], "a clipped model inside its range");
    assert_eq!(out[3], LEFT_TO_SEARCH);
    assert!(xyz[9].is_nan());
    assert_eq!(out[4], 1);
    assert_eq!(out[5], Validity::PhaseOutOfRange as u8);
    // The search's pass and its merge.
    let mut mask = [0u8; 8];
    search_mask(&out, &q, &mut mask).unwrap();
    assert_eq!(mask, [7, 7, 7, 0, 7, 7, 7, 0]);
    let sx = [1f32; 24];
    merge_search(&sx, &[4; 8], &mut xyz, &mut out).unwrap();
    assert_eq!((out[3], out[7]), (4, 4));
    assert_eq!(xyz[9..12], [1.0; 3]);
    assert_eq!((out[0], out[2]), (0, 7));
    assert_eq!(
        compiled_row(&models, 900.0, 500.0, &phase, &q, &mut xyz, &mut out),
        Err(CompiledError::DepthRange)
    );
    assert_eq!(
        compiled_row(&models[1..], 500.0, 900.0, &phase, &q, &mut xyz, &mut out),
        Err(CompiledError::Length)
    );
}

#[test]
fn no_reference_answers_reference_invalid_without_the_search() {
    // Models with every field but the scale finite (a zero scale wins) and canonical ones.
    let mut odd = model();
    odd.phase_scale = -0.0;
    let list = [
        PixelModel::NO_REFERENCE,
        odd,
        PixelModel::NO_REFERENCE,
        model(),
    ];
    let mut models = [0f32; 4 * FIELDS];
    for (u, x) in list.iter().enumerate() {
        x.store(&mut models, u).unwrap();
    }
    let phase = [100.0, 100.0, f32::NAN, 100.0];
    let q = [0, 0, 0, Validity::Dark as u8];
    let (mut xyz, mut out) = ([0f32; 12], [0u8; 4]);
    let n = compiled_row(&models, 500.0, 900.0, &phase, &q, &mut xyz, &mut out).unwrap();
    assert_eq!(n, 0, "nothing is left to the search");
    let ri = Validity::ReferenceInvalid as u8;
    assert_eq!(
        out,
        [
            ri,
            ri,
            Validity::PhaseOutOfRange as u8,
            Validity::Dark as u8
        ]
    );
    assert!(xyz.iter().all(|v| v.to_bits() == CANONICAL_NAN.to_bits()));
}

#[test]
fn far_beyond_a_clipped_range_is_no_crossing() {
    // τ = ±2.5 and ±1.2 (not beyond its τ_far of 1.25) on a clipped model; ±2.5 on an
    // unclipped one and on a clipped one without the rule (τ_far = +∞), which keeps its
    // points; 2.5 and 3.2 on a clipped one whose τ_far is 3: each pixel its own threshold.
    let mut clip = model();
    clip.phase_scale = -clip.phase_scale;
    let open = clip;
    let mut wide = clip;
    clip.far = 1.25;
    wide.far = 3.0;
    assert!(clip.far_is_no_crossing() && !open.far_is_no_crossing());
    assert!(!model().far_is_no_crossing());
    let list = [
        clip,
        clip,
        clip,
        clip,
        model(),
        model(),
        open,
        open,
        open,
        wide,
        wide,
    ];
    let mut models = [0f32; 11 * FIELDS];
    for (u, x) in list.iter().enumerate() {
        x.store(&mut models, u).unwrap();
    }
    let phase = [
        225.0, -25.0, 160.0, 40.0, 225.0, -25.0, 225.0, -25.0, 140.0, 225.0, 260.0,
    ];
    let (mut xyz, mut out) = ([0f32; 33], [0u8; 11]);
    let n = compiled_row(&models, 500.0, 900.0, &phase, &[0; 11], &mut xyz, &mut out).unwrap();
    let (nc, ood, left) = (
        Validity::NoCrossing as u8,
        Validity::OutOfDepth as u8,
        LEFT_TO_SEARCH,
    );
    assert_eq!(out, [nc, nc, left, left, ood, ood, left, left, 0, left, nc]);
    assert_eq!(n, 5);
    assert!(xyz[..24].iter().all(|v| v.is_nan()));
    assert!(xyz[27..].iter().all(|v| v.is_nan()));
    let s = open.depth_f64(140.0).unwrap();
    assert_eq!(s, model().depth_f64(140.0).unwrap());
    assert!((xyz[26] as f64 - s).abs() < 1e-4, "{} {s}", xyz[26]);
}

#[test]
fn kernel_matches_the_f64_reference_over_long_rows() {
    // Several chunks and a tail: every pixel within a few ulp of the f64 reference.
    const W: usize = 200;
    let w = W;
    let mut models = [0f32; W * FIELDS];
    let mut phase = [0f32; W];
    for (u, p) in phase.iter_mut().enumerate() {
        let mut m = model();
        m.pole = 0.001 * u as f32;
        m.store(&mut models, u).unwrap();
        *p = 60.0 + 0.4 * u as f32;
    }
    let q = [0u8; W];
    let (mut xyz, mut out) = ([0f32; 3 * W], [0u8; W]);
    compiled_row(&models, 500.0, 900.0, &phase, &q, &mut xyz, &mut out).unwrap();
    for u in 0..w {
        let m = PixelModel::load(&models, u).unwrap();
        match m.depth_f64(phase[u] as f64) {
            Some(s) if (500.0..=900.0).contains(&s) => {
                assert_eq!(out[u], 0, "pixel {u}");
                assert!((xyz[3 * u + 2] as f64 - s).abs() < 2e-4, "pixel {u}");
            }
            _ => assert_eq!(out[u], Validity::OutOfDepth as u8, "pixel {u}"),
        }
    }
}

#[test]
fn settle_counts_the_models_it_changes() {
    // A settled row: nothing to change, however often; a model with a NaN slope and one with a
    // zero scale among finite numbers: two changed, then none.
    const W: usize = 70;
    let mut row = [0f32; W * FIELDS];
    for u in 0..W {
        let m = match u % 3 {
            0 => model(),
            1 => PixelModel::SEARCH,
            _ => PixelModel::NO_REFERENCE,
        };
        m.store(&mut row, u).unwrap();
    }
    let settled = row;
    assert_eq!(PixelModel::settle_row_counted(&mut row), Some(0));
    row[8 * W + 3] = f32::NAN;
    row[3 * W + 6] = 0.0;
    // A non-canonical NaN in a model left to the search.
    row[W + 1] = f32::from_bits(0x7fc0_1234);
    assert_eq!(PixelModel::settle_row_counted(&mut row), Some(3));
    assert_eq!(PixelModel::settle_row_counted(&mut row), Some(0));
    // Pixels 3 and 6 became the search's and no reference's; pixel 1 canonical again.
    assert!(PixelModel::load(&row, 3).is_some_and(|m| !m.is_compiled() && !m.is_no_reference()));
    assert!(PixelModel::load(&row, 6).is_some_and(|m| m.is_no_reference()));
    let same =
        |u: usize| (0..FIELDS).all(|k| row[k * W + u].to_bits() == settled[k * W + u].to_bits());
    assert!(same(1) && same(0) && same(2));
    assert_eq!(
        PixelModel::settle_row_counted(&mut row[..FIELDS * W - 1]),
        None
    );
}

#[test]
fn field_by_field_settles_as_pixel_by_pixel() {
    // Models of every kind with up to three fields replaced by a special value (NaN of either
    // sign and any payload, ±∞, ±0, a negative number, values below 1 for τ_far), in rows
    // narrower and wider than a chunk: the same bits and the same count as the reference.
    let specials = [
        f32::NAN,
        -f32::NAN,
        f32::from_bits(0x7fa0_0001),
        f32::INFINITY,
        f32::NEG_INFINITY,
        0.0,
        -0.0,
        -3.5,
        0.5,
        1.0,
        f32::MAX,
        f32::MIN_POSITIVE,
    ];
    // Knuth's MMIX LCG, its high bits folded in.
    let mut state = 7u64;
    let mut next = || {
        state = state
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        state ^ (state >> 29)
    };
    let mut changed = 0;
    for w in [
        1,
        7,
        SETTLE_CHUNK,
        SETTLE_CHUNK + 1,
        3 * SETTLE_CHUNK - 5,
        200,
    ] {
        for _ in 0..40 {
            let mut buf = [0f32; FIELDS * 200];
            let row = &mut buf[..FIELDS * w];
            for u in 0..w {
                let r = next();
                let mut m = model();
                if r & 256 != 0 {
                    m.phase_scale = -m.phase_scale;
                    m.far = if r & 512 != 0 { 1.3 } else { f32::INFINITY };
                }
                m.store(row, u).unwrap();
                for _ in 0..(r >> 10) % 4 {
                    let s = next();
                    let f = (s % FIELDS as u64) as usize;
                    row[f * w + u] = specials[(s >> 16) as usize % specials.len()];
                }
            }
            let (mut a, mut b) = (buf, buf);
            let (a, b) = (&mut a[..FIELDS * w], &mut b[..FIELDS * w]);
            let n = PixelModel::settle_row_counted(a);
            assert_eq!(n, PixelModel::settle_row_by_pixel(b), "width {w}");
            let same =
                |x: &[f32], y: &[f32]| x.iter().zip(y).all(|(p, q)| p.to_bits() == q.to_bits());
            assert!(same(a, b), "width {w}");
            changed += n.unwrap();
        }
    }
    // The rows did hold models to settle.
    assert!(changed > 500, "{changed}");
    let mut odd = [0f32; FIELDS + 1];
    assert_eq!(PixelModel::settle_row_counted(&mut odd), None);
    assert_eq!(PixelModel::settle_row_by_pixel(&mut odd), None);
}
