//! The camera model (paper §4.1, eqs 1-4): forward projection against an independent f64
//! implementation, the fixed-count inverse over the whole image with strong distortion, and
//! rejection of models that cannot be inverted.
// Integration tests are std: std f64 maths is the independent truth here.
#![allow(clippy::disallowed_methods)]

use crate::reconstruct_support as support;

use fringe3d_core::camera::{
    CameraCheck, CameraError, CameraErrorKind, CameraModel, CameraParams, Distortion,
    UNDISTORT_TOLERANCE_F32_PX, UNDISTORT_TOLERANCE_PX,
};
use fringe3d_core::geometry::Vec3;
use support::Pinhole;

fn strong() -> Pinhole {
    Pinhole {
        fx: 1500.0,
        fy: 1498.5,
        skew: 1.5e-3,
        u0: 645.2,
        v0: 505.9,
        width: 1280,
        height: 1024,
        k: [-0.3, 0.1, 1.2e-3, -8e-4, 0.0],
    }
}

#[test]
fn forward_matches_independent_model() {
    let p = strong();
    let cam = p.model();
    let mut worst: f64 = 0.0;
    for &pt in &[
        [10.0, -20.0, 700.0],
        [-250.0, 180.0, 600.0],
        [300.0, 240.0, 800.0],
        [0.0, 0.0, 500.0],
    ] {
        let a = cam.project(Vec3::from_array(pt)).unwrap();
        let b = p.project(pt).unwrap();
        worst = worst.max((a[0] - b.0).abs()).max((a[1] - b.1).abs());
    }
    assert!(worst < 1e-9, "{worst}");
    assert!(cam.project(Vec3::new(1.0, 1.0, -5.0)).is_none());
    assert!(cam.project(Vec3::new(f64::NAN, 1.0, 5.0)).is_none());
    // Skew (eq 4): u = fx·x_d + α·fx·y_d + u0.
    let d = cam.distorted_to_pixel([0.1, 0.2]);
    assert!((d[0] - (1500.0 * 0.1 + 1.5e-3 * 1500.0 * 0.2 + 645.2)).abs() < 1e-12);
}

/// forward∘inverse over every pixel of a 1280 × 1024 image with k1 = −0.3, k2 = 0.1 (and
/// tangential terms): ≤ 1e-4 px for the f64 inverse, and the inverse agrees with the test's own
/// (fixed-point + numerical-Newton) inverse.
#[test]
fn inverse_round_trip_full_image_strong_distortion() {
    let p = strong();
    let cam = p.model();
    let (mut worst64, mut worst_indep, mut worst32, mut worst_row): (f64, f64, f64, f64) =
        (0.0, 0.0, 0.0, 0.0);
    let mut xs = vec![0f32; 1280];
    let mut ys = vec![0f32; 1280];
    for v in 0..1024u32 {
        cam.undistort_row_f32(v, &mut xs, &mut ys);
        for u in 0..1280u32 {
            let px = [u as f64, v as f64];
            let n = cam.pixel_to_normalized(px);
            let back = p.pixel_of_normalized(n[0], n[1]);
            worst64 = worst64.max((back.0 - px[0]).hypot(back.1 - px[1]));
            let (ix, iy) = p.unproject(px[0], px[1]);
            worst_indep = worst_indep.max(((ix - n[0]).hypot(iy - n[1])) * 1500.0);
            if u % 7 == 0 {
                let n32 = cam.pixel_to_normalized_f32([u as f32, v as f32]);
                let b32 = p.pixel_of_normalized(n32[0] as f64, n32[1] as f64);
                worst32 = worst32.max((b32.0 - px[0]).hypot(b32.1 - px[1]));
            }
            let br = p.pixel_of_normalized(xs[u as usize] as f64, ys[u as usize] as f64);
            worst_row = worst_row.max((br.0 - px[0]).hypot(br.1 - px[1]));
        }
    }
    eprintln!(
        "round trip: f64 {worst64:.3e} px, vs independent inverse {worst_indep:.3e} px, f32 {worst32:.3e} px, f32 row path {worst_row:.3e} px; setup check: {:.3e} / {:.3e}",
        cam.max_undistort_error_px(),
        cam.max_undistort_error_f32_px()
    );
    assert!(worst64 <= UNDISTORT_TOLERANCE_PX);
    assert!(worst_indep <= UNDISTORT_TOLERANCE_PX);
    assert!(worst32 <= UNDISTORT_TOLERANCE_F32_PX);
    assert!(worst_row <= UNDISTORT_TOLERANCE_F32_PX);
}

fn intr() -> CameraParams {
    strong().params()
}

/// The model of `params` with distortion `d` instead.
fn model(params: CameraParams, d: Distortion) -> Result<CameraModel, CameraError> {
    CameraModel::new(CameraParams {
        distortion: d,
        ..params
    })
}

#[test]
fn non_invertible_models_are_rejected() {
    // Barrel so strong that ρ(r) = r(1 + k1 r²) turns over inside the field of view
    // (dρ/dr = 0 at r = 1/√(3·0.9) ≈ 0.61 < the corner's radius).
    let e = model(intr(), Distortion::from_array([-0.9, 0.0, 0.0, 0.0, 0.0])).unwrap_err();
    assert_eq!(e.kind(), CameraErrorKind::NotInvertible, "{e}");
    assert!(matches!(e, CameraError::NotMonotonic { .. }));
    // A k2 that folds the profile back.
    let e = model(intr(), Distortion::from_array([0.2, -1.5, 0.0, 0.0, 0.0])).unwrap_err();
    assert_eq!(e.kind(), CameraErrorKind::NotInvertible, "{e}");
    // Monotonic in the field of view but Newton from the distorted point does not reach 1e-4 px
    // in the fixed count near the turning point, or lands off the branch: refused too.
    let e = model(intr(), Distortion::from_array([-0.56, 0.0, 0.0, 0.0, 0.0]));
    if let Err(e) = e {
        assert_eq!(e.kind(), CameraErrorKind::NotInvertible, "{e}");
    }
    // Strong but invertible: accepted.
    assert!(model(intr(), Distortion::from_array([-0.3, 0.1, 0.0, 0.0, 0.0])).is_ok());
    assert!(model(intr(), Distortion::from_array([0.3, 0.2, 0.0, 0.0, 0.05])).is_ok());
}

#[test]
fn bad_parameters_are_rejected() {
    let d = Distortion::NONE;
    let mut i = intr();
    i.fx = f64::NAN;
    assert_eq!(model(i, d).unwrap_err(), CameraError::NotFinite);
    let mut i = intr();
    i.fy = -1.0;
    assert_eq!(model(i, d).unwrap_err(), CameraError::NonPositiveFocal);
    let mut i = intr();
    i.width = 1;
    assert_eq!(model(i, d).unwrap_err(), CameraError::Size);
    let mut i = intr();
    i.skew = 0.7;
    assert_eq!(model(i, d).unwrap_err(), CameraError::Skew);
    assert_eq!(
        model(
            intr(),
            Distortion::from_array([f64::INFINITY, 0.0, 0.0, 0.0, 0.0])
        )
        .unwrap_err()
        .kind(),
        CameraErrorKind::InvalidParameter
    );
    // Display is implemented for every variant used above.
    assert!(!format!("{}", CameraError::NotMonotonic { radius: 0.5 }).is_empty());
}

#[test]
fn nan_input_gives_nan_not_panic() {
    let cam = strong().model();
    let n = cam.pixel_to_normalized([f64::NAN, 3.0]);
    assert!(n[0].is_nan() || n[1].is_nan());
    let n = cam.pixel_to_normalized_f32([f32::INFINITY, 3.0]);
    assert!(!n[0].is_finite() || !n[1].is_finite());
    let mut xs = [0f32; 3];
    let mut ys = [0f32; 2];
    cam.undistort_row_f32(5000, &mut xs, &mut ys); // shorter buffer and off-image row: no panic
}

/// A model built from a shipped check (`CameraModel::from_check`, the head set-up blob's field
/// 10) is the model `new` checked, bit for bit; checks no model gives are refused, and the
/// parameters' own checks still run.
#[test]
fn a_shipped_check_rebuilds_the_model_without_the_inverse() {
    let m = CameraModel::new(intr()).expect("the strong model inverts");
    let c = m.check();
    assert!(c.is_sane(), "{c:?}");
    assert!(c.monotonic_radius > 0.0 && c.max_error_f32 > 0.0, "{c:?}");
    assert_eq!(CameraModel::from_check(intr(), &c), Ok(m));
    let bad = |c: CameraCheck| CameraModel::from_check(intr(), &c).map(|_| ());
    assert!(matches!(
        bad(CameraCheck {
            monotonic_radius: f64::NAN,
            ..c
        }),
        Err(CameraError::NotMonotonic { .. })
    ));
    for e in [-1.0, 2.0 * UNDISTORT_TOLERANCE_PX, f64::INFINITY] {
        assert!(matches!(
            bad(CameraCheck {
                max_error_f64: e,
                ..c
            }),
            Err(CameraError::NotConvergent { .. })
        ));
    }
    assert!(matches!(
        bad(CameraCheck {
            max_error_f32: 2.0 * UNDISTORT_TOLERANCE_F32_PX,
            ..c
        }),
        Err(CameraError::NotConvergent { .. })
    ));
    let no_focal = CameraParams { fx: 0.0, ..intr() };
    assert_eq!(
        CameraModel::from_check(no_focal, &c),
        Err(CameraError::NonPositiveFocal)
    );
}
