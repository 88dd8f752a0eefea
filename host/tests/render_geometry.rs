//! The ground truth is geometrically exact: checked with a pinhole + Brown camera and projector
//! model written in the test (render_common), not the renderer's.

use crate::render_common::{decode_frames, project_to_camera, project_to_projector, rms_max};
use fringe3d::render::{
    MASK_HIT, MASK_IN_FRAME, MASK_LIT, MASK_VALID, Overrides, RenderOptions, Rig, Scene,
};
use fringe3d_core::phase_function::Profile;

/// Undistort pixel (u, v) of the camera by fixed-point iteration (independent of the renderer's
/// Newton solver): the direction (x, y, 1) of its ray.
fn camera_ray(rig: &Rig, u: f64, v: f64) -> [f64; 3] {
    let c = &rig.camera;
    let yd = (v - c.cy) / c.fy;
    let xd = (u - c.cx) / c.fx - c.skew * yd;
    let [k1, k2, p1, p2, k3] = c.distortion.to_array();
    let (mut x, mut y) = (xd, yd);
    for _ in 0..500 {
        let r2 = x * x + y * y;
        let rad = 1.0 + k1 * r2 + k2 * r2 * r2 + k3 * r2 * r2 * r2;
        let dx = 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x);
        let dy = p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y;
        let (nx, ny) = ((xd - dx) / rad, (yd - dy) / rad);
        let done = (nx - x).abs() < 1e-17 && (ny - y).abs() < 1e-17;
        x = nx;
        y = ny;
        if done {
            break;
        }
    }
    [x, y, 1.0]
}

/// Intersect the camera ray `d` with the projector's surface of constant ξ (a plane for an
/// undistorted projector, a ruled cone through P with distortion) by bisection on depth.
fn triangulate(rig: &Rig, d: [f64; 3], xi: f64) -> Option<[f64; 3]> {
    let at = |z: f64| [d[0] * z, d[1] * z, z];
    let f = |z: f64| project_to_projector(rig, at(z)).0 - xi;
    let (mut lo, mut hi) = (200.0, 1200.0);
    let (flo, fhi) = (f(lo), f(hi));
    if flo.signum() == fhi.signum() {
        return None;
    }
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if f(mid).signum() == flo.signum() {
            lo = mid;
        } else {
            hi = mid;
        }
        if hi - lo < 1e-13 {
            break;
        }
    }
    Some(at(0.5 * (lo + hi)))
}

fn xi_of_phase(scene: &Scene, phase: f64) -> f64 {
    let set = &scene.patterns;
    let c = set.levels().last().unwrap().scale();
    match set.function().profile() {
        Profile::Linear { origin, slope } => origin + phase / (c * slope),
        _ => panic!("test scenes use linear phase functions"),
    }
}

fn dist(a: [f64; 3], b: [f64; 3]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

#[test]
fn truth_points_lie_on_pixel_rays_and_projector_coordinates_are_exact() {
    for name in ["sphere", "ballbar", "steps", "freeform"] {
        let scene = Scene::builtin(
            name,
            &Overrides {
                size: Some((320, 256)),
                supersample: Some(1),
                ..Default::default()
            },
        )
        .unwrap();
        let (_, t) = scene.render_fringes(RenderOptions::default()).unwrap();
        let w = t.width as usize;
        let (mut n_hit, mut n_lit) = (0, 0);
        let (mut worst_cam, mut worst_proj): (f64, f64) = (0.0, 0.0);
        for p in 0..t.mask.len() {
            if t.mask[p] & MASK_HIT == 0 {
                continue;
            }
            n_hit += 1;
            let (u, v) = project_to_camera(&scene.rig, t.points[p]);
            worst_cam = worst_cam.max((u - (p % w) as f64).hypot(v - (p / w) as f64));
            if t.mask[p] & (MASK_IN_FRAME | MASK_LIT) == MASK_IN_FRAME | MASK_LIT {
                n_lit += 1;
                let (xi, eta) = project_to_projector(&scene.rig, t.points[p]);
                worst_proj =
                    worst_proj.max((xi - t.projector[p][0]).hypot(eta - t.projector[p][1]));
            }
        }
        eprintln!(
            "{name}: {n_hit} hits, {n_lit} lit; worst reprojection camera {worst_cam:.1e} px, projector {worst_proj:.1e} px"
        );
        assert!(n_lit > 10_000, "{name}: too few lit pixels");
        assert!(
            worst_cam < 1e-8,
            "{name}: truth point off its pixel ray by {worst_cam} px"
        );
        assert!(
            worst_proj < 1e-8,
            "{name}: projector coordinate off by {worst_proj} px"
        );
    }
}

#[test]
fn triangulating_the_true_phase_returns_the_true_point() {
    let scene = Scene::builtin(
        "steps",
        &Overrides {
            size: Some((640, 512)),
            supersample: Some(1),
            ..Default::default()
        },
    )
    .unwrap();
    let (_, t) = scene.render_fringes(RenderOptions::default()).unwrap();
    let phase = scene.true_phase(&t);
    let w = t.width as usize;
    let mut errs = Vec::new();
    for p in (0..t.mask.len()).step_by(7) {
        if t.mask[p] != MASK_VALID {
            continue;
        }
        let d = camera_ray(&scene.rig, (p % w) as f64, (p / w) as f64);
        let x = triangulate(&scene.rig, d, xi_of_phase(&scene, phase[p]))
            .expect("ray crosses the fringe surface");
        errs.push(dist(x, t.points[p]));
    }
    let (rms, max) = rms_max(&errs);
    eprintln!(
        "true phase → point: n = {}, rms {rms:.2e} mm, max {max:.2e} mm",
        errs.len()
    );
    assert!(errs.len() > 5_000);
    assert!(max < 1e-6, "max error {max} mm");
}

#[test]
fn triangulating_the_rendered_phase_is_micrometre_accurate() {
    // The default render (1280 × 1024, 3 × 3 supersampling, σ = 1, 16-bit), noise-free, decoded
    // in f64 and triangulated with the exact projector model: the error is what the rendered
    // images themselves carry (phase error × depth sensitivity).
    let mut total = Vec::new();
    for name in ["steps", "plane"] {
        let scene = Scene::builtin(name, &Overrides::default()).unwrap();
        let (f, t) = scene.render_fringes(RenderOptions::default()).unwrap();
        let dec = decode_frames(&scene.patterns, &f);
        let w = t.width as usize;
        let mut errs = Vec::new();
        for p in (0..t.mask.len()).step_by(5) {
            if t.mask[p] != MASK_VALID {
                continue;
            }
            let d = camera_ray(&scene.rig, (p % w) as f64, (p / w) as f64);
            if let Some(x) = triangulate(&scene.rig, d, xi_of_phase(&scene, dec[p].0)) {
                errs.push(dist(x, t.points[p]));
            }
        }
        let (rms, max) = rms_max(&errs);
        eprintln!(
            "{name}: rendered phase → point: n = {}, rms {:.3} µm, max {:.3} µm",
            errs.len(),
            rms * 1e3,
            max * 1e3
        );
        assert!(rms < 2e-3, "{name}: rms {rms} mm");
        total.extend(errs);
    }
    let (rms, _) = rms_max(&total);
    assert!(rms < 2e-3);
}

#[test]
fn default_rig_covers_the_measurement_volume() {
    let rig = fringe3d::render::default_rig();
    let (lo, hi) = (rig.volume_min, rig.volume_max);
    assert_eq!(
        [hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]],
        [280.0, 220.0, 250.0]
    );
    let (cw, ch) = (rig.camera.width as f64, rig.camera.height as f64);
    let (pw, ph) = (rig.projector.width as f64, rig.projector.height as f64);
    let (mut cam_margin, mut proj_margin) = (f64::INFINITY, f64::INFINITY);
    for i in 0..=4 {
        for j in 0..=4 {
            for k in 0..=4 {
                let p = [
                    lo[0] + (hi[0] - lo[0]) * i as f64 / 4.0,
                    lo[1] + (hi[1] - lo[1]) * j as f64 / 4.0,
                    lo[2] + (hi[2] - lo[2]) * k as f64 / 4.0,
                ];
                let (u, v) = project_to_camera(&rig, p);
                cam_margin = cam_margin.min(u.min(v).min(cw - 1.0 - u).min(ch - 1.0 - v));
                let (xi, eta) = project_to_projector(&rig, p);
                proj_margin = proj_margin.min(xi.min(eta).min(pw - 1.0 - xi).min(ph - 1.0 - eta));
            }
        }
    }
    // Triangulation angle at the volume centre.
    let c = [0.0, 0.0, 600.0];
    let t = rig.translation;
    let (a, b) = (c, [c[0] - t[0], c[1] - t[1], c[2] - t[2]]);
    let cos = (a[0] * b[0] + a[1] * b[1] + a[2] * b[2]) / (dist(a, [0.0; 3]) * dist(b, [0.0; 3]));
    let angle = cos.acos().to_degrees();
    eprintln!(
        "volume inside the image by {cam_margin:.0} px, inside the DMD by {proj_margin:.0} px; triangulation angle {angle:.1}°"
    );
    assert!(cam_margin > 20.0 && proj_margin > 10.0);
    assert!((18.0..23.0).contains(&angle));
    assert!(rig.reference_point[2] > hi[2] && rig.reference_point[2] < rig.depth_range[1]);
    assert!(rig.depth_range[0] < lo[2]);
}
