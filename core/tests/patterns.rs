//! Pattern generation against eq 7/14 evaluated independently in f64, and the checks that
//! refuse bad phase functions and set structures.
// Tests use std f64 maths as the independent truth; the ban on it is for the core library.
#![allow(clippy::disallowed_methods)]

use fringe3d_core::pattern::{Convention, Level, Output, PatternError, PatternSet};
use fringe3d_core::phase_function::{
    Axis, KnotProfile, PhaseFunction, PhaseFunctionErrorKind, Profile,
};
use std::f64::consts::{FRAC_PI_2, PI, TAU};

fn out(max: f64) -> Output {
    Output {
        width: 320,
        height: 200,
        i_min: 0.0,
        i_max: max,
    }
}

#[test]
fn paper_set_rows_follow_eq_7() {
    let set = PatternSet::default_for(Axis::Xi, out(255.0)).unwrap();
    assert_eq!(set.image_count(), 8);
    // Independent statement of eq 7: Φ^(P) = 0.9·2π/320·(ξ − 159.5), c = 1, 8, 64.
    let c = [1.0, 8.0, 64.0];
    let mut row = vec![0u8; 320];
    let mut row16 = vec![0u16; 320];
    let set16 = PatternSet::default_for(Axis::Xi, out(65535.0)).unwrap();
    for i in 0..8 {
        let id = set.image(i).unwrap();
        let n = id.shift as f64; // paper's n − 1
        set.generate_row(i, 17, &mut row).unwrap();
        set16.generate_row(i, 17, &mut row16).unwrap();
        for (xi, (&v, &v16)) in row.iter().zip(&row16).enumerate() {
            let phi = 0.9 * TAU / 320.0 * (xi as f64 - 159.5);
            let s = 1.0 + (c[id.level as usize] * phi + n * FRAC_PI_2).sin();
            assert!(
                (v as f64 - 127.5 * s).abs() <= 0.5 + 1e-9,
                "image {i} ξ {xi}"
            );
            assert!(
                (v16 as f64 - 32767.5 * s).abs() <= 0.5 + 1e-6,
                "16-bit image {i} ξ {xi}"
            );
        }
    }
    // The DC level (4 images) comes first, then levels 0 and 1.
    let levels: Vec<u8> = set.order().iter().map(|i| i.level).collect();
    assert_eq!(levels, [2, 2, 2, 2, 0, 0, 1, 1]);
}

#[test]
fn horizontal_curved_and_cosine_patterns() {
    let f = PhaseFunction::centered(Axis::Eta, 200, 5.0)
        .unwrap()
        .curved(1e-4, 160.0)
        .unwrap();
    let set = PatternSet::twelve_pattern(f, 4.0, out(255.0))
        .unwrap()
        .with_convention(Convention::Cosine);
    let mut row = vec![0u8; 320];
    for eta in [0u32, 99, 199] {
        set.generate_row(5, eta, &mut row).unwrap();
        let id = set.image(5).unwrap();
        let lv = &set.levels()[id.level as usize];
        for (xi, &v) in row.iter().enumerate() {
            let t = eta as f64 + 1e-4 * (xi as f64 - 160.0).powi(2);
            let phi = 5.0 / 200.0 * (t - 99.5);
            let want = 127.5 * (1.0 + (lv.scale() * phi + lv.shifts()[id.shift as usize]).cos());
            assert!((v as f64 - want).abs() <= 0.5 + 1e-9);
        }
    }
}

#[test]
fn variable_width_knots_are_monotonic_and_continuous() {
    let k = KnotProfile::from_slopes(
        &[0.0, 100.0, 220.0, 319.0],
        &[0.01, 0.02, 0.016, 0.008],
        -2.4,
    )
    .unwrap();
    let f = PhaseFunction::with_profile(Axis::Xi, Profile::Knots(k)).unwrap();
    let set = PatternSet::paper_eight(f, 6.0, out(255.0)).unwrap();
    let mut prev = f64::NEG_INFINITY;
    for i in 0..3200 {
        let x = i as f64 * 0.1;
        let p = f.eval(x, 0.0);
        assert!(p > prev);
        assert!(p - prev < 0.01 || i == 0);
        prev = p;
    }
    // knots are interpolated exactly
    for (s, phi) in k.positions().iter().zip(k.phases()) {
        assert!((f.eval(*s, 5.0) - phi).abs() < 1e-12);
    }
    assert_eq!(set.image_count(), 8);
}

#[test]
fn bad_functions_are_refused() {
    // slope so high that level 0 wraps
    let f = PhaseFunction::centered(Axis::Xi, 320, 1.1 * TAU).unwrap();
    let e = PatternSet::paper_eight(f, 8.0, out(255.0)).unwrap_err();
    assert!(
        matches!(e, PatternError::Function(x) if x.kind() == PhaseFunctionErrorKind::Range),
        "{e}"
    );
    // finest level too fine for the projector: fewer than 4 pixels per period
    let f = PhaseFunction::centered(Axis::Xi, 320, 0.9 * TAU).unwrap();
    let e = PatternSet::paper_eight(f, 12.0, out(255.0)).unwrap_err();
    assert!(
        matches!(e, PatternError::Function(x) if x.kind() == PhaseFunctionErrorKind::Discontinuous),
        "{e}"
    );
    // non-monotonic: a knot segment whose slopes overshoot (Fritsch-Carlson)
    assert!(KnotProfile::new(&[0.0, 10.0, 20.0], &[0.0, 0.1, 0.2], &[0.01, 0.2, 0.01]).is_err());
    // decreasing knots, zero slope
    assert!(KnotProfile::new(&[0.0, 10.0], &[0.0, -1.0], &[0.1, 0.1]).is_err());
    assert!(PhaseFunction::linear(Axis::Xi, 0.0, 0.0).is_err());
    // curvature so strong that the fringe bends back: still monotonic in ξ by construction, but
    // the coarse range overflows on the outer rows
    let f = PhaseFunction::centered(Axis::Xi, 320, 5.0)
        .unwrap()
        .curved(0.05, 100.0)
        .unwrap();
    assert!(PatternSet::paper_eight(f, 4.0, out(255.0)).is_err());
    // NaN parameters
    assert!(PhaseFunction::linear(Axis::Xi, f64::NAN, 1.0).is_err());
}

#[test]
fn bad_level_structures_are_refused() {
    let f = PhaseFunction::centered(Axis::Xi, 320, 5.0).unwrap();
    let o = out(255.0);
    assert!(matches!(
        PatternSet::new(f, &[Level::two_step(1.0), Level::two_step(4.0)], o),
        Err(PatternError::NoDcLevel)
    ));
    assert!(matches!(
        PatternSet::new(f, &[Level::n_step(4.0, 4), Level::n_step(1.0, 4)], o),
        Err(PatternError::ScalesNotIncreasing(1))
    ));
    assert!(matches!(
        PatternSet::new(f, &[Level::with_shifts(1.0, &[0.0])], o),
        Err(PatternError::ShiftCount(0, 1))
    ));
    assert!(matches!(
        PatternSet::new(f, &[Level::with_shifts(1.0, &[0.0, PI, TAU])], o),
        Err(PatternError::DegenerateShifts(0))
    ));
    assert!(matches!(
        PatternSet::new(
            f,
            &[
                Level::n_step(1.0, 4),
                Level::with_shifts(2.0, &[0.3, 0.3 + PI])
            ],
            o
        ),
        Err(PatternError::DegenerateShifts(1))
    ));
    assert!(matches!(
        PatternSet::new(f, &[], o),
        Err(PatternError::LevelCount(0))
    ));
    assert!(PatternSet::new(f, &[Level::n_step(1.0, 4)], Output { i_max: 300.0, ..o }).is_ok());
    let set = PatternSet::new(f, &[Level::n_step(1.0, 4)], Output { i_max: 300.0, ..o }).unwrap();
    assert!(
        set.generate_row(0, 0, &mut [0u8; 320]).is_err(),
        "I_max beyond u8"
    );
    assert!(
        set.generate_row(0, 200, &mut [0u16; 320]).is_err(),
        "row out of range"
    );
    assert!(
        set.generate_row(4, 0, &mut [0u16; 320]).is_err(),
        "image out of range"
    );
    assert!(
        set.generate_row(0, 0, &mut [0u16; 319]).is_err(),
        "wrong length"
    );
}

#[test]
fn explicit_image_order_is_checked() {
    use fringe3d_core::pattern::ImageId;
    let f = PhaseFunction::centered(Axis::Xi, 320, 5.0).unwrap();
    let set = PatternSet::paper_eight(f, 4.0, out(255.0)).unwrap();
    let paper_order: Vec<ImageId> = [
        (0, 0),
        (0, 1),
        (1, 0),
        (1, 1),
        (2, 0),
        (2, 1),
        (2, 2),
        (2, 3),
    ]
    .iter()
    .map(|&(l, s)| ImageId { level: l, shift: s })
    .collect();
    let s2 = set.with_order(&paper_order).unwrap();
    assert_eq!(s2.image(0), Some(ImageId { level: 0, shift: 0 }));
    let mut dup = paper_order.clone();
    dup[1] = dup[0];
    assert!(set.with_order(&dup).is_err());
    assert!(set.with_order(&paper_order[..7]).is_err());
}

#[test]
fn binary_sets_write_the_sign_or_the_dither_of_eq_7() {
    use fringe3d_core::binary::{BAYER, Binarization};
    let gray = PatternSet::default_for(Axis::Xi, out(255.0)).unwrap();
    let (mut g, mut b) = (vec![0u8; 320], vec![0u8; 320]);
    // Squared binary: 255 where eq 7's sinusoid is above its mean, 0 below (independent f64).
    let sq = gray.with_binarization(Binarization::Square);
    let c = [1.0, 8.0, 64.0];
    for i in 0..8 {
        let id = sq.image(i).unwrap();
        sq.generate_row(i, 17, &mut b).unwrap();
        for (xi, &v) in b.iter().enumerate() {
            let phi = 0.9 * TAU / 320.0 * (xi as f64 - 159.5);
            let s = (c[id.level as usize] * phi + id.shift as f64 * FRAC_PI_2).sin();
            assert!(v == 0 || v == 255, "image {i} ξ {xi}: {v}");
            if s.abs() > 1e-9 {
                assert_eq!(v == 255, s > 0.0, "image {i} ξ {xi}");
            }
        }
    }
    // Bayer: each pixel against its threshold (M + ½)/64 of the 8 × 8 matrix; over a tile of the
    // coarse level the bright fraction follows the gray level.
    let by = gray.with_binarization(Binarization::Bayer);
    for i in 0..8 {
        let mut tile_on = [0u32; 40];
        let mut tile_gray = [0.0f64; 40];
        for y in 16..24u32 {
            gray.generate_row(i, y, &mut g).unwrap();
            by.generate_row(i, y, &mut b).unwrap();
            for xi in 0..320 {
                let id = by.image(i).unwrap();
                let phi = 0.9 * TAU / 320.0 * (xi as f64 - 159.5);
                let s =
                    0.5 * (1.0 + (c[id.level as usize] * phi + id.shift as f64 * FRAC_PI_2).sin());
                let t = (BAYER[y as usize % 8][xi % 8] as f64 + 0.5) / 64.0;
                assert_eq!(b[xi] == 255, s > t, "image {i} ({xi}, {y})");
                tile_on[xi / 8] += u32::from(b[xi] == 255);
                tile_gray[xi / 8] += g[xi] as f64 / 255.0;
            }
        }
        if by.image(i).unwrap().level == 0 {
            for (on, gr) in tile_on.iter().zip(&tile_gray) {
                // (±3: the 1/64 steps, and the gray level's slope across the tile, which the
                // matrix's arrangement samples unevenly.)
                assert!(
                    (*on as f64 - gr).abs() <= 3.0,
                    "image {i}: {on} of 64 vs {gr}"
                );
            }
        }
    }
    assert_eq!(gray.binarization(), Binarization::Off);
}
