//! Checkerboard calibration images: the rendered corners sit where the camera model projects
//! them. Written through the dataset writer and read back from the files, the corners are
//! measured with a point-symmetry (saddle) estimator written here (independent of the renderer)
//! and compared with (a) `truth/corners.json` and (b) a projection of the 3-D corners by the
//! test's own camera model.
//!
//! (A plain quadratic saddle fit on a pixel-centred window was tried first: it is biased by up to
//! ~0.1 px depending on where the pixel grid falls, so it cannot check the render to 0.05 px. The
//! symmetry estimator has no such bias; what it leaves, ~0.01 px, includes the projector's
//! shading gradient across each corner, which breaks the symmetry slightly.)

use crate::render_common::{project_to_camera, rms_max};
use fringe3d::io::image::{Pixels, read_gray};
use fringe3d::render::dataset::{DatasetOptions, write_dataset};
use fringe3d::render::{Scene, SceneSpec};
use std::path::PathBuf;

fn tmp(name: &str) -> PathBuf {
    std::env::temp_dir().join(format!("fringe3d-{name}-{}", std::process::id()))
}

/// Gaussian-smoothed value of the image at integer (x, y) (σ in pixels, clamped edges).
fn smoothed(img: &[f64], w: usize, h: usize, x: i64, y: i64, sigma: f64) -> f64 {
    let r = (3.5 * sigma).ceil() as i64;
    let (mut a, mut s) = (0.0, 0.0);
    for dy in -r..=r {
        for dx in -r..=r {
            let k = (-((dx * dx + dy * dy) as f64) / (2.0 * sigma * sigma)).exp();
            let xx = (x + dx).clamp(0, w as i64 - 1) as usize;
            let yy = (y + dy).clamp(0, h as i64 - 1) as usize;
            a += k * img[yy * w + xx];
            s += k;
        }
    }
    a / s
}

/// Catmull-Rom weights for a fraction f ∈ [0, 1) at nodes −1, 0, 1, 2.
fn catmull(f: f64) -> [f64; 4] {
    let (f2, f3) = (f * f, f * f * f);
    [
        (-f3 + 2.0 * f2 - f) / 2.0,
        (3.0 * f3 - 5.0 * f2 + 2.0) / 2.0,
        (-3.0 * f3 + 4.0 * f2 + f) / 2.0,
        (f3 - f2) / 2.0,
    ]
}

/// Point-symmetry estimate: an X-junction seen through a locally affine map (and any symmetric
/// blur, including the pixel box) is point-symmetric about the corner, so the corner is the c
/// minimising Σ w(|d|)·[S(c + d) − S(c − d)]² with S a smoothed, bicubically interpolated image.
/// Unlike a quadratic fit it has no bias from where the pixel grid falls.
fn symmetric(img: &[f64], w: usize, h: usize, u: f64, v: f64) -> (f64, f64) {
    let (x0, y0) = (u.round() as i64, v.round() as i64);
    let half = 14i64;
    let side = (2 * half + 1) as usize;
    let mut patch = vec![0.0; side * side];
    for dy in -half..=half {
        for dx in -half..=half {
            patch[((dy + half) as usize) * side + (dx + half) as usize] =
                smoothed(img, w, h, x0 + dx, y0 + dy, 1.2);
        }
    }
    let s = |x: f64, y: f64| -> f64 {
        let (px, py) = (x - x0 as f64 + half as f64, y - y0 as f64 + half as f64);
        let (ix, iy) = (px.floor(), py.floor());
        let (wx, wy) = (catmull(px - ix), catmull(py - iy));
        let mut a = 0.0;
        for (j, wyj) in wy.iter().enumerate() {
            for (i, wxi) in wx.iter().enumerate() {
                let xx = (ix as i64 - 1 + i as i64).clamp(0, side as i64 - 1) as usize;
                let yy = (iy as i64 - 1 + j as i64).clamp(0, side as i64 - 1) as usize;
                a += wyj * wxi * patch[yy * side + xx];
            }
        }
        a
    };
    let mut offs = Vec::new();
    for j in 0..=10 {
        for i in -10..=10 {
            if j == 0 && i <= 0 {
                continue;
            }
            let d = (i as f64 * 0.5, j as f64 * 0.5);
            let r2 = d.0 * d.0 + d.1 * d.1;
            if r2 <= 25.0 {
                offs.push((d, (-r2 / (2.0 * 3.0 * 3.0)).exp()));
            }
        }
    }
    let (mut cu, mut cv) = (x0 as f64, y0 as f64);
    let e = 1e-4;
    for _ in 0..30 {
        let (mut a11, mut a12, mut a22, mut b1, mut b2) = (0.0, 0.0, 0.0, 0.0, 0.0);
        for &((dx, dy), wt) in &offs {
            let r = |cx: f64, cy: f64| s(cx + dx, cy + dy) - s(cx - dx, cy - dy);
            let r0 = r(cu, cv);
            let jx = (r(cu + e, cv) - r(cu - e, cv)) / (2.0 * e);
            let jy = (r(cu, cv + e) - r(cu, cv - e)) / (2.0 * e);
            a11 += wt * jx * jx;
            a12 += wt * jx * jy;
            a22 += wt * jy * jy;
            b1 -= wt * jx * r0;
            b2 -= wt * jy * r0;
        }
        let det = a11 * a22 - a12 * a12;
        let (du, dv) = ((a22 * b1 - a12 * b2) / det, (a11 * b2 - a12 * b1) / det);
        let (du, dv) = (du.clamp(-0.5, 0.5), dv.clamp(-0.5, 0.5));
        cu += du;
        cv += dv;
        if du.hypot(dv) < 1e-8 {
            break;
        }
    }
    (cu, cv)
}

#[test]
fn rendered_corners_sit_where_the_camera_projects_them() {
    let mut spec = SceneSpec::builtin("checkerboard").unwrap();
    spec.board.as_mut().unwrap().count = 4;
    spec.seed = 7;
    let scene = Scene::new(spec, None).unwrap();
    let dir = tmp("corners");
    let _ = std::fs::remove_dir_all(&dir);
    let sum = write_dataset(&scene, &dir, DatasetOptions::default()).unwrap();
    assert_eq!(sum.images, 4);
    let j: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.join("truth/corners.json")).unwrap()).unwrap();
    let poses = j["poses"].as_array().unwrap();
    assert_eq!(poses.len(), 4);
    let (mut e_truth, mut e_model, mut model_vs_file) = (Vec::new(), Vec::new(), 0.0f64);
    for p in poses {
        let (img, info) = read_gray(&dir.join(p["image"].as_str().unwrap())).unwrap();
        assert!(!info.converted_from_color);
        let (w, h) = (img.width as usize, img.height as usize);
        let v: Vec<f64> = match img.pixels {
            Pixels::U16(v) => v.iter().map(|&x| x as f64).collect(),
            Pixels::U8(v) => v.iter().map(|&x| x as f64).collect(),
            Pixels::F32(_) => panic!("board images are integer"),
        };
        let px = p["corners_px"].as_array().unwrap();
        let mm = p["corners_mm"].as_array().unwrap();
        for (c, m) in px.iter().zip(mm) {
            let (u, vv) = (c[0].as_f64().unwrap(), c[1].as_f64().unwrap());
            let x = [
                m[0].as_f64().unwrap(),
                m[1].as_f64().unwrap(),
                m[2].as_f64().unwrap(),
            ];
            let (mu, mv) = project_to_camera(&scene.rig, x);
            model_vs_file = model_vs_file.max((mu - u).hypot(mv - vv));
            // Start from the nearest pixel: the estimate does not see the true sub-pixel position.
            let (su, sv) = symmetric(&v, w, h, u.round(), vv.round());
            e_truth.push((su - u).hypot(sv - vv));
            e_model.push((su - mu).hypot(sv - mv));
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
    let (rms, max) = rms_max(&e_truth);
    let (rms_m, max_m) = rms_max(&e_model);
    eprintln!(
        "{} corners: measured vs truth rms {rms:.4} px, max {max:.4} px; vs test camera model rms {rms_m:.4} max {max_m:.4}; model vs file {model_vs_file:.1e} px",
        e_truth.len()
    );
    assert_eq!(e_truth.len(), 4 * 70);
    assert!(
        model_vs_file < 1e-9,
        "corners.json disagrees with the camera model by {model_vs_file} px"
    );
    assert!(rms <= 0.02 && max <= 0.05, "rms {rms}, max {max}");
}
