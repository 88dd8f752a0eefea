//! Corner accuracy against the board's in-plane angle (issue #18): boards rendered at σ = 1 gray
//! level noise, 8 bits, turned in their plane from 0° to 45°; per view the detected corners are
//! compared with the renderer's exact projections.

use fringe3d::calib::corners::{Board, DetectOptions, Image, detect};
use fringe3d::render::Scene;
use fringe3d::render::board::{board_object, board_truth};
use fringe3d::render::rng::Rng;
use fringe3d::render::scene::{BoardLight, Pose};
use fringe3d::render::{Geometry, Overrides, SceneSpec, Slide};

struct View {
    rms: f64,
    mean: [f64; 2],
}

/// Per-view RMS and mean error vector, under the labelling (as is / half turn) that fits.
fn compare(det: &[[f64; 2]], truth: &[[f64; 2]]) -> View {
    assert_eq!(det.len(), truth.len());
    let n = det.len();
    let mut best: Option<View> = None;
    for flip in [false, true] {
        let (mut s2, mut m) = (0.0, [0.0, 0.0]);
        for k in 0..n {
            let d = det[if flip { n - 1 - k } else { k }];
            let e = [d[0] - truth[k][0], d[1] - truth[k][1]];
            s2 += e[0] * e[0] + e[1] * e[1];
            m[0] += e[0];
            m[1] += e[1];
        }
        let v = View {
            rms: (s2 / n as f64).sqrt(),
            mean: [m[0] / n as f64, m[1] / n as f64],
        };
        if best.as_ref().is_none_or(|b| v.rms < b.rms) {
            best = Some(v);
        }
    }
    best.unwrap()
}

fn scene() -> Scene {
    let mut spec = SceneSpec::builtin("checkerboard").unwrap();
    spec.apply(&Overrides {
        noise: Some(1.0),
        bits: Some(8),
        size: Some((640, 512)),
        ..Default::default()
    });
    Scene::new(spec, None).unwrap()
}

/// The scene's board at the image centre, turned by `angle` degrees in its plane (plus a small
/// tilt), rendered as the dataset writer renders board images; `edge_ss` samples per pixel side
/// at edges. Returns the image and the true corners.
fn render(
    scene: &Scene,
    angle: f64,
    tilt: [f64; 2],
    edge_ss: u32,
    stream: u64,
) -> (Image, Vec<[f64; 2]>) {
    let pose = Pose {
        center: [0.0, 0.0, 720.0],
        euler_deg: [tilt[0], tilt[1], angle],
    };
    render_at(scene, &pose, edge_ss, stream)
}

/// [`render`] of the scene's board at `pose`.
fn render_at(scene: &Scene, pose: &Pose, edge_ss: u32, stream: u64) -> (Image, Vec<[f64; 2]>) {
    let b = scene.spec.board.clone().unwrap();
    let lit = scene.spec.photometry.board_light == BoardLight::Projector;
    let mut sensor = scene.spec.camera.sensor();
    sensor.supersample = b.supersample;
    sensor.edge_supersample = edge_ss;
    let mut phot = scene.spec.photometry.photometry();
    phot.auto_with_projector = lit;
    let g = Geometry::build(&[board_object(&b, pose, None, true, b.light)]).unwrap();
    let (f, _) = scene
        .render_slides(
            &g,
            &[Slide::Uniform(if lit { 1.0 } else { 0.0 })],
            stream,
            fringe3d::render::RenderOptions {
                sensor: Some(sensor),
                photometry: Some(phot),
                ..Default::default()
            },
        )
        .unwrap();
    let t = board_truth(&b, pose, &scene.rig, "x").unwrap();
    let img = Image {
        width: f.width as usize,
        height: f.height as usize,
        data: f.images[0].iter().map(|&v| v as f32).collect(),
    };
    (img, t.corners_px)
}

/// Area of a convex polygon clipped to the box [x0, x1] × [y0, y1].
fn clipped_area(poly: &[[f64; 2]], x0: f64, x1: f64, y0: f64, y1: f64) -> f64 {
    let mut p: Vec<[f64; 2]> = poly.to_vec();
    for (axis, lim, keep_below) in [(0, x0, false), (0, x1, true), (1, y0, false), (1, y1, true)] {
        let inside = |q: &[f64; 2]| {
            if keep_below {
                q[axis] <= lim
            } else {
                q[axis] >= lim
            }
        };
        let mut out = Vec::with_capacity(p.len() + 2);
        for k in 0..p.len() {
            let a = p[k];
            let b = p[(k + 1) % p.len()];
            let (ia, ib) = (inside(&a), inside(&b));
            if ia {
                out.push(a);
            }
            if ia != ib {
                let t = (lim - a[axis]) / (b[axis] - a[axis]);
                out.push([a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])]);
            }
        }
        p = out;
        if p.len() < 3 {
            return 0.0;
        }
    }
    let mut s = 0.0;
    for k in 0..p.len() {
        let (a, b) = (p[k], p[(k + 1) % p.len()]);
        s += a[0] * b[1] - a[1] * b[0];
    }
    0.5 * s.abs()
}

/// An exactly box-integrated fronto-parallel `board` (no renderer) in a 640 × 512 image: squares
/// of 27.9 px (as the renders above) centred near the image centre, turned by `angle` degrees; the
/// renders' dark/light levels, σ = 1 noise, 8-bit rounding.
fn exact(board: &Board, angle: f64, seed: u64) -> (Image, Vec<[f64; 2]>) {
    let (w, h) = (640usize, 512usize);
    let (cols, rows) = (board.cols as i64, board.rows as i64);
    let (sq, c) = (27.9, [320.3, 255.7]);
    let (s, co) = angle.to_radians().sin_cos();
    // board (squares) -> pixel
    let fwd = |x: f64, y: f64| {
        let (bx, by) = ((x - cols as f64 / 2.0) * sq, (y - rows as f64 / 2.0) * sq);
        [c[0] + co * bx - s * by, c[1] + s * bx + co * by]
    };
    let inv = |u: f64, v: f64| {
        let (dx, dy) = (u - c[0], v - c[1]);
        let (bx, by) = (co * dx + s * dy, -s * dx + co * dy);
        [bx / sq + cols as f64 / 2.0, by / sq + rows as f64 / 2.0]
    };
    let (dark, light) = (0.05 * 220.0, 0.85 * 220.0);
    let mut rng = Rng::new(seed);
    let mut data = vec![0f32; w * h];
    for y in 0..h {
        for x in 0..w {
            let (u, v) = (x as f64, y as f64);
            let poly = [
                inv(u - 0.5, v - 0.5),
                inv(u + 0.5, v - 0.5),
                inv(u + 0.5, v + 0.5),
                inv(u - 0.5, v + 0.5),
            ];
            let (mut xmin, mut xmax, mut ymin, mut ymax) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
            for p in &poly {
                xmin = xmin.min(p[0]);
                xmax = xmax.max(p[0]);
                ymin = ymin.min(p[1]);
                ymax = ymax.max(p[1]);
            }
            let a_tot = 1.0 / (sq * sq);
            let mut dark_area = 0.0;
            for j in ymin.floor() as i64..=ymax.floor() as i64 {
                for i in xmin.floor() as i64..=xmax.floor() as i64 {
                    if i < 0 || j < 0 || i >= cols || j >= rows || (i + j) % 2 != 0 {
                        continue;
                    }
                    dark_area +=
                        clipped_area(&poly, i as f64, i as f64 + 1.0, j as f64, j as f64 + 1.0);
                }
            }
            let fd = (dark_area / a_tot).clamp(0.0, 1.0);
            let val = light + (dark - light) * fd + rng.gauss();
            data[y * w + x] = val.clamp(0.0, 255.0).round() as f32;
        }
    }
    let mut t = Vec::new();
    for j in 1..rows {
        for i in 1..cols {
            t.push(fwd(i as f64, j as f64));
        }
    }
    (
        Image {
            width: w,
            height: h,
            data,
        },
        t,
    )
}

/// Per-view figures of a sweep, printed; then the quality bar of issue #18: every view's RMS
/// ≤ 0.01 px, the worst within 1.5× the median, and no view-wide bias (|mean error| ≤ 0.3 × the
/// median RMS).
fn check(label: &str, views: &[(f64, View)]) {
    for (a, v) in views {
        eprintln!(
            "{label} angle {a:5.2}°: rms {:.4} px, mean error ({:+.4}, {:+.4}) px",
            v.rms, v.mean[0], v.mean[1]
        );
    }
    let mut r: Vec<f64> = views.iter().map(|(_, v)| v.rms).collect();
    r.sort_by(f64::total_cmp);
    let median = r[r.len() / 2];
    let worst = r[r.len() - 1];
    eprintln!(
        "{label}: median rms {median:.4} px, worst {worst:.4} px ({:.2}x)",
        worst / median
    );
    for (a, v) in views {
        assert!(v.rms <= 0.01, "{label} {a}°: rms {} px > 0.01", v.rms);
        assert!(
            v.rms <= 1.5 * median,
            "{label} {a}°: rms {} px > 1.5 x the median {median}",
            v.rms
        );
        let m = v.mean[0].hypot(v.mean[1]);
        assert!(
            m <= 0.3 * median,
            "{label} {a}°: mean error {m} px (median rms {median})"
        );
    }
}

fn board() -> Board {
    let b = scene().spec.board.unwrap();
    Board::new(b.cols, b.rows, b.square).unwrap()
}

/// The renderer, as it renders calibration boards (12 × 12 samples per pixel at edges), boards
/// turned from 1° to 44° in their plane. Closer to 0° or 45° the renderer's own regular sample
/// lattice sets the error: an edge along a lattice direction has its position quantized to 1/12 px
/// over lengths ~1/(12·tan Δ) px, comparable to the refinement window (at 0.5°: 0.0045 px with 12
/// samples, 0.0027 px with 64; exactly at 0° 0.029 px with 12, 0.004 px with 64; run the
/// `experiment` below with `SWEEP=render64`). The exact images below cover 0° and 45°.
#[test]
fn rendered_corners_are_flat_across_board_angles() {
    let sc = scene();
    let board = board();
    let mut views = Vec::new();
    for (k, a) in [1.0, 2.0, 3.0, 8.0, 22.5, 37.0, 43.0, 44.0]
        .into_iter()
        .enumerate()
    {
        let (img, truth) = render(&sc, a, [0.0, 0.0], 12, 100 + k as u64);
        let d = detect(&img, &board, &DetectOptions::default()).unwrap();
        views.push((a, compare(&d.corners, &truth)));
    }
    check("rendered", &views);
}

/// Exactly box-integrated boards (each pixel the exact area average of the squares over it, by
/// polygon clipping: no sample lattice), so the sweep includes 0° and 45° themselves.
#[test]
fn exact_corners_are_flat_across_board_angles() {
    let board = board();
    let mut views = Vec::new();
    for (k, a) in [0.0, 0.25, 0.5, 1.0, 3.0, 22.5, 44.0, 44.75, 45.0]
        .into_iter()
        .enumerate()
    {
        let (img, truth) = exact(&board, a, 500 + k as u64);
        let d = detect(&img, &board, &DetectOptions::default()).unwrap();
        views.push((a, compare(&d.corners, &truth)));
    }
    check("exact", &views);
}

fn angles() -> Vec<f64> {
    let mut a: Vec<f64> = (0..=6).map(|k| k as f64 * 0.5).collect();
    a.extend([5.0, 8.0, 12.0, 17.0, 22.5, 28.0, 33.0, 38.0]);
    a.extend((0..=6).map(|k| 42.0 + k as f64 * 0.5));
    a
}

/// The full sweep with timing, one image source per run (`SWEEP=render12|render64|tilt12|exact`):
/// `SWEEP=exact cargo test --release -p fringe3d --test suite corners_angle_sweep:: -- --ignored
/// --nocapture`.
#[test]
#[ignore]
fn experiment() {
    let sc = scene();
    let board = board();
    let mode = std::env::var("SWEEP").unwrap_or_else(|_| "render12".into());
    for (k, a) in angles().into_iter().enumerate() {
        let (img, truth) = match mode.as_str() {
            "render12" => render(&sc, a, [0.0, 0.0], 12, 100 + k as u64),
            "render64" => render(&sc, a, [0.0, 0.0], 64, 100 + k as u64),
            "tilt12" => render(&sc, a, [6.0, -5.0], 12, 100 + k as u64),
            _ => exact(&board, a, 100 + k as u64),
        };
        let t0 = std::time::Instant::now();
        let d = detect(&img, &board, &DetectOptions::default()).unwrap();
        let v = compare(&d.corners, &truth);
        eprintln!(
            "{mode} angle {a:5.1}: rms {:.4} px  mean ({:+.4}, {:+.4})  detect {:.0} ms",
            v.rms,
            v.mean[0],
            v.mean[1],
            t0.elapsed().as_secs_f64() * 1e3
        );
    }
}

/// Lens distortion curves a board's edges; fitting straight edges pulled every corner towards
/// the edges' centres of curvature, and the boards came out 3–4·10⁻⁶ smaller than they are
/// (with a focal length 1.5·10⁻⁵ long: plates and the reference plane 10–15 µm too far). With the
/// camera's lens the refinement straightens the edges first (`DetectOptions::lens`): noise-free
/// boards in the image's corners, where the default rig's barrel distortion curves the most,
/// against the renderer's exact corners.
#[test]
fn the_lens_straightens_the_edges_it_curves() {
    let mut spec = SceneSpec::builtin("checkerboard").unwrap();
    spec.apply(&Overrides {
        noise: Some(0.0),
        bits: Some(16),
        size: Some((640, 512)),
        ..Default::default()
    });
    let sc = Scene::new(spec, None).unwrap();
    let lens = fringe3d::calib::lens::Lens::from_model(&sc.rig.camera);
    let b = sc.spec.board.clone().unwrap();
    let board = Board {
        cols: b.cols,
        rows: b.rows,
        square: b.square,
    };
    // The board's scale against the truth (least squares about the truth's centroid), −1.
    let scale = |det: &[[f64; 2]], truth: &[[f64; 2]]| {
        let n = truth.len() as f64;
        let c = [
            truth.iter().map(|t| t[0]).sum::<f64>() / n,
            truth.iter().map(|t| t[1]).sum::<f64>() / n,
        ];
        let (mut num, mut den) = (0.0, 0.0);
        for (d, t) in det.iter().zip(truth) {
            let r = [t[0] - c[0], t[1] - c[1]];
            num += (d[0] - t[0]) * r[0] + (d[1] - t[1]) * r[1];
            den += r[0] * r[0] + r[1] * r[1];
        }
        num / den
    };
    let (mut plain, mut straight) = (Vec::new(), Vec::new());
    for (k, (x, y, e)) in [
        (-70.0, -50.0, [10.0, -8.0, 5.0]),
        (70.0, -50.0, [-8.0, -10.0, 12.0]),
        (-70.0, 50.0, [12.0, 10.0, -7.0]),
        (70.0, 50.0, [-10.0, 8.0, 20.0]),
    ]
    .into_iter()
    .enumerate()
    {
        let pose = Pose {
            center: [x, y, 720.0],
            euler_deg: e,
        };
        let (img, truth) = render_at(&sc, &pose, 16, 40 + k as u64);
        for (opts, out) in [
            (DetectOptions::default(), &mut plain),
            (
                DetectOptions {
                    lens: Some(lens),
                    ..DetectOptions::default()
                },
                &mut straight,
            ),
        ] {
            let d = detect(&img, &board, &opts).unwrap();
            // The labelling that fits (a symmetric board may come out turned by half a turn).
            let n = truth.len();
            let flipped: Vec<[f64; 2]> = (0..n).map(|i| d.corners[n - 1 - i]).collect();
            let near = |c: &[[f64; 2]]| compare(c, &truth).rms;
            let det = if near(&flipped) < near(&d.corners) {
                flipped
            } else {
                d.corners
            };
            out.push(scale(&det, &truth));
        }
    }
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
    eprintln!(
        "board scale − 1: straight edges {:?} (mean {:.2e}); straightened {:?} (mean {:.2e})",
        plain.iter().map(|x| format!("{x:.2e}")).collect::<Vec<_>>(),
        mean(&plain),
        straight
            .iter()
            .map(|x| format!("{x:.2e}"))
            .collect::<Vec<_>>(),
        mean(&straight)
    );
    assert!(
        mean(&plain) < -3e-6,
        "the curvature's pull: {:.2e}",
        mean(&plain)
    );
    assert!(
        mean(&straight).abs() < 1.5e-6 && mean(&straight).abs() < mean(&plain).abs() / 3.0,
        "straightened: {:.2e}",
        mean(&straight)
    );
}
