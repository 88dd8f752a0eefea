//! Unit tests of the projector model's calibration: synthetic corners of known rigs.

use super::*;
use crate::render::rig::default_rig;

/// Exact synthetic corners of a rig (truth: the default rig's camera and projector) give the
/// rig back, from tilted boards and from parallel plates.
#[test]
fn recovers_the_default_rig_from_exact_corners() {
    let rig = default_rig();
    let cam = Lens::from_model(&rig.camera);
    let proj = Lens::from_model(&rig.projector);
    let r = Mat3(rig.rotation);
    let tt = Vec3::from_array(rig.translation);
    let board = Board {
        cols: 9,
        rows: 7,
        square: 30.0,
    };
    let obj = board.object_points();
    let view = |name: &str, e: [f64; 3], c: [f64; 3]| {
        let rb = Mat3::from_euler_deg(e);
        let tb = Vec3::from_array(c);
        let mut corners = Vec::new();
        let mut pj = Vec::new();
        for o in &obj {
            let x = rb.mul_vec(Vec3::new(o[0], o[1], 0.0)) + tb;
            let (u, v) = cam.project_point(x.to_array()).unwrap();
            corners.push([u, v]);
            let xp = r.tmul_vec(x - tt);
            pj.push(proj.project_point(xp.to_array()).map(|(a, b)| [a, b]));
        }
        RigView {
            name: name.into(),
            corners,
            projector: pj,
        }
    };
    let tilted = vec![
        view("a", [20.0, 0.0, 5.0], [0.0, 0.0, 700.0]),
        view("b", [-20.0, 5.0, -5.0], [10.0, 0.0, 680.0]),
        view("c", [0.0, 25.0, 0.0], [0.0, 10.0, 640.0]),
        view("d", [5.0, -25.0, 10.0], [-10.0, 0.0, 620.0]),
        view("e", [15.0, 20.0, 0.0], [-30.0, 20.0, 560.0]),
        view("f", [-15.0, -20.0, -10.0], [30.0, -20.0, 540.0]),
    ];
    let parallel = vec![
        view("p0", [8.0, -12.0, 0.0], [0.0, 0.0, 710.0]),
        view("p1", [8.0, -12.0, 0.0], [0.0, 0.0, 600.0]),
        view("p2", [8.0, -12.0, 0.0], [0.0, 0.0, 490.0]),
    ];
    // The joint problem's Jacobian (camera intrinsics free too) against central differences,
    // at a state off the solution.
    {
        let used = &tilted;
        let problem = Problem {
            obj: obj.clone(),
            views: used,
            use_proj: used.iter().map(|v| vec![true; v.projector.len()]).collect(),
            cam_free: (0..N_INTRINSICS).collect(),
            proj_free: ModelOptions::default().projector.free(),
            weight: [1.0, 2.0],
        };
        let mut rot = Vec::new();
        let mut t = Vec::new();
        for v in used.iter() {
            let p = pose::board_pose(&cam, &board, &v.corners).unwrap();
            rot.push(rodrigues(Vec3::new(1e-3, -2e-3, 5e-4)).mul_mat(&p.rotation));
            t.push(p.translation + Vec3::new(0.3, -0.2, 0.5));
        }
        let mut c2 = cam;
        c2.p[0] += 2.0;
        c2.p[5] += 0.01;
        let mut p2 = proj;
        p2.p[3] += 1.5;
        let st = State {
            cam: c2,
            proj: p2,
            q: r.transpose(),
            s: r.transpose().mul_vec(tt) * -1.0 + Vec3::new(0.2, 0.1, -0.3),
            rot,
            t,
        };
        let n = problem.n();
        let e = problem.eval(&st).unwrap();
        let m = e.r.len();
        let mut jac = vec![0.0; m * n];
        for i in 0..m {
            for k in 0..e.width {
                jac[i * n + e.cols[i * e.width + k]] += e.vals[i * e.width + k];
            }
        }
        for j in 0..n {
            let h = if j < N_INTRINSICS {
                1e-6 * cam.p[j].abs().max(1.0)
            } else {
                1e-6
            };
            let mut dp = vec![0.0; n];
            dp[j] = h;
            let rp = problem.eval(&problem.apply(&st, &dp)).unwrap().r;
            dp[j] = -h;
            let rm = problem.eval(&problem.apply(&st, &dp)).unwrap().r;
            for i in 0..m {
                let fd = (rp[i] - rm[i]) / (2.0 * h);
                let an = jac[i * n + j];
                assert!(
                    (fd - an).abs() <= 1e-4 * (1.0 + fd.abs()),
                    "row {i} column {j}: {an} vs {fd}"
                );
            }
        }
    }
    for (views, opts) in [
        (&tilted, ModelOptions::default()),
        (&parallel, ModelOptions::default()),
        (
            &tilted,
            ModelOptions {
                refine_camera: true,
                ..ModelOptions::default()
            },
        ),
    ] {
        let m = calibrate(&board, &cam, (1024, 768), views, &opts).unwrap();
        for k in 0..5 {
            assert!(
                (m.projector.p[k] - proj.p[k]).abs() < 1e-5 * proj.p[0],
                "{k}: {:?} vs {:?}",
                m.projector.p,
                proj.p
            );
        }
        assert!((m.translation - tt).norm() < 1e-5, "{:?}", m.translation);
        assert!(m.rms_projector_px < 1e-6, "{}", m.rms_projector_px);
    }
}
