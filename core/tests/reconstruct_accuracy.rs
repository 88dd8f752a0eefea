//! Accuracy of the hybrid reconstruction (paper §6, eqs 16-18) on exact synthetic phase maps,
//! against independent f64 truth: ray-cast geometry, a literal f64 evaluation of eqs 16-18, the
//! closest point of two lines, and an f64 re-implementation of the whole search.
// Integration tests are std: std f64 maths is the independent truth here.
#![allow(clippy::disallowed_methods)]

use crate::reconstruct_support as support;

use fringe3d_core::Validity;
use fringe3d_core::reconstruct::{Reconstructor, ReferenceMap};
use support::*;

/// Reconstructed rows: per pixel (u, v, point, crossing N_I) for valid pixels, and all codes.
struct Run {
    pts: Vec<(usize, usize, [f64; 3], [f64; 2])>,
    codes: Vec<u8>,
}

fn run(rig: &Rig, reference: &PhaseMap, object: &PhaseMap, rows: &[usize]) -> Run {
    let cam = rig.cam.model();
    let recon = Reconstructor::new(&cam, &rig.setup()).expect("reconstructor");
    let w = reference.width;
    let mut rp = reference.phase.clone();
    let map = ReferenceMap::prepare(&mut rp, &reference.validity, w, reference.height).unwrap();
    let mut xyz = vec![0f32; 3 * w];
    let mut val = vec![0u8; w];
    let mut cr = vec![0f32; 2 * w];
    let mut out = Run {
        pts: vec![],
        codes: vec![],
    };
    for &v in rows {
        let p = &object.phase[v * w..(v + 1) * w];
        let q = &object.validity[v * w..(v + 1) * w];
        recon
            .reconstruct_row_with_crossings(&map, v as u32, p, q, &mut xyz, &mut val, &mut cr)
            .unwrap();
        for u in 0..w {
            out.codes.push(val[u]);
            if val[u] == Validity::Valid as u8 {
                let m = [
                    xyz[3 * u] as f64,
                    xyz[3 * u + 1] as f64,
                    xyz[3 * u + 2] as f64,
                ];
                out.pts
                    .push((u, v, m, [cr[2 * u] as f64, cr[2 * u + 1] as f64]));
            }
        }
    }
    out
}

fn count(codes: &[u8], c: Validity) -> usize {
    codes.iter().filter(|&&x| x == c as u8).count()
}

/// Eqs 16-18 written out literally in f64 (C = 0, image plane z = +1).
fn eq16_18(rig: &Rig, m_i: [f64; 2], n_i: [f64; 2]) -> V3 {
    let n = rig.ref_normal;
    let o = rig.ref_point;
    let p = rig.p;
    let cm = [m_i[0], m_i[1], 1.0];
    let cn = [n_i[0], n_i[1], 1.0];
    let m_r = mul(cm, dot(o, n) / dot(cm, n)); // eq 16
    let n_r = mul(cn, dot(o, n) / dot(cn, n)); // eq 16
    let q = mul(cm, dot(p, n) / dot(cm, n)); // eq 17
    let pq = sub(q, p);
    let k = norm(pq) * norm(sub(m_r, q)) / (norm(add(pq, sub(n_r, m_r))) * norm(cm)); // eq 18
    add(q, mul(cm, k))
}

/// Closest point on line `a + λ·d` to line `b + μ·e`.
fn closest_on_first(a: V3, d: V3, b: V3, e: V3) -> V3 {
    let w = sub(a, b);
    let (aa, bb, cc, dd, ee) = (dot(d, d), dot(d, e), dot(e, e), dot(d, w), dot(e, w));
    let l = (bb * ee - cc * dd) / (aa * cc - bb * bb);
    add(a, mul(d, l))
}

fn err_um(a: V3, b: V3) -> f64 {
    norm(sub(a, b)) * 1000.0
}

#[test]
fn exact_phase_maps_reconstruct_to_truth() {
    let rig = Rig::default_rig();
    let reference = render_reference(&rig);
    let rows: Vec<usize> = (0..1024).step_by(4).collect();
    let object = render(&rig, &object(&rig), volume(&rig), rows.iter().copied());
    let r = run(&rig, &reference, &object, &rows);
    let truth_n = rows
        .iter()
        .map(|&v| {
            (0..1280)
                .filter(|&u| object.truth[v * 1280 + u].is_some())
                .count()
        })
        .sum::<usize>();
    let errs: Vec<f64> = r
        .pts
        .iter()
        .map(|&(u, v, m, _)| err_um(m, object.truth[v * 1280 + u].unwrap()))
        .collect();
    let s = stats(&errs);
    let zs: Vec<f64> = r.pts.iter().map(|p| p.2[2]).collect();
    let (zmin, zmax) = zs
        .iter()
        .fold((f64::MAX, f64::MIN), |(a, b), &z| (a.min(z), b.max(z)));
    eprintln!(
        "end-to-end: {} of {} object pixels valid, z {:.1}..{:.1} mm, error RMS {:.3} µm, max {:.3} µm; codes: no-crossing {}, out-of-depth {}, reference-invalid {}, degenerate {}",
        s.n,
        truth_n,
        zmin,
        zmax,
        s.rms,
        s.max,
        count(&r.codes, Validity::NoCrossing),
        count(&r.codes, Validity::OutOfDepth),
        count(&r.codes, Validity::ReferenceInvalid),
        count(&r.codes, Validity::Degenerate)
    );
    assert!(
        s.n as f64 > 0.995 * truth_n as f64,
        "too many object pixels lost: {} of {}",
        s.n,
        truth_n
    );
    assert!(zmax - zmin > 200.0, "the object must span the depth range");
    assert!(s.rms < 1.0, "RMS error {} µm", s.rms);
    assert!(s.max < 1.0, "max error {} µm", s.max);
}

#[test]
fn point_matches_literal_eqs_16_18_and_closest_point() {
    let rig = Rig::default_rig();
    let reference = render_reference(&rig);
    let rows: Vec<usize> = (3..1024).step_by(37).collect();
    let object = render(&rig, &object(&rig), volume(&rig), rows.iter().copied());
    let r = run(&rig, &reference, &object, &rows);
    assert!(r.pts.len() > 5000);
    let mut e_lit = vec![];
    let mut e_cp = vec![];
    for &(u, v, m, n_i) in &r.pts {
        let (x, y) = rig.cam.unproject(u as f64, v as f64);
        let lit = eq16_18(&rig, [x, y], n_i);
        e_lit.push(err_um(m, lit));
        // The core's literal f64 version agrees with the test's.
        let core_lit =
            fringe3d_core::reconstruct::triangulate_eq16_18(&rig.setup(), [x, y], n_i).unwrap();
        assert!(err_um(core_lit.to_array(), lit) < 1e-6);
        // M is where the camera ray meets the projector ray P–N_R (eq 16 for N_R).
        let cn = [n_i[0], n_i[1], 1.0];
        let n_r = mul(
            cn,
            dot(rig.ref_point, rig.ref_normal) / dot(cn, rig.ref_normal),
        );
        let cp = closest_on_first([0.0; 3], [x, y, 1.0], rig.p, sub(n_r, rig.p));
        e_cp.push(err_um(m, cp));
    }
    let (a, b) = (stats(&e_lit), stats(&e_cp));
    eprintln!(
        "vs literal eqs 16-18: RMS {:.4} µm max {:.4} µm; vs closest point: RMS {:.4} max {:.4} µm",
        a.rms, a.max, b.rms, b.max
    );
    assert!(a.max < 1.0 && b.max < 1.0);
}

/// An f64 re-implementation of the whole method on the same (f32) input data: the pixel's ray by
/// the test's own inverse camera model, the depth interval mapped to the epipolar line by
/// intersecting projector rays with the reference plane, bilinear interpolation of Φ_R at the
/// distorted positions, 80 bisection steps, then eqs 16-18 literally.
fn reference_f64(rig: &Rig, prep: &[f32], u: usize, v: usize, phi: f64) -> Option<V3> {
    let w = rig.cam.width as usize;
    let h = rig.cam.height as usize;
    let (x, y) = rig.cam.unproject(u as f64, v as f64);
    let e = [rig.p[0] - rig.p[2] * x, rig.p[1] - rig.p[2] * y];
    let ee = e[0] * e[0] + e[1] * e[1];
    let t_of_z = |z: f64| {
        let m = [x * z, y * z, z];
        let d = sub(m, rig.p);
        let l = dot(rig.ref_normal, sub(rig.ref_point, rig.p)) / dot(rig.ref_normal, d);
        let nr = add(rig.p, mul(d, l));
        let ni = [nr[0] / nr[2] - x, nr[1] / nr[2] - y];
        (ni[0] * e[0] + ni[1] * e[1]) / ee
    };
    let (ta, tb) = (t_of_z(rig.z_range[0]), t_of_z(rig.z_range[1]));
    let f = |t: f64| -> Option<f64> {
        let (xd, yd) = rig.cam.distort(x + t * e[0], y + t * e[1]);
        let (pu, pv) = rig.cam.pixel_of_distorted(xd, yd);
        if !(pu >= 0.0 && pv >= 0.0 && pu <= (w - 1) as f64 && pv <= (h - 1) as f64) {
            return None;
        }
        let (iu, iv) = (
            (pu.floor() as usize).min(w - 2),
            (pv.floor() as usize).min(h - 2),
        );
        let (fu, fv) = (pu - iu as f64, pv - iv as f64);
        let s = |r: usize, c: usize| prep[r * w + c] as f64;
        let val = (1.0 - fv) * ((1.0 - fu) * s(iv, iu) + fu * s(iv, iu + 1))
            + fv * ((1.0 - fu) * s(iv + 1, iu) + fu * s(iv + 1, iu + 1));
        val.is_finite().then_some(val - phi)
    };
    let (mut a, mut b) = (ta, tb);
    let (mut fa, fb) = (f(a)?, f(b)?);
    if (fa < 0.0) == (fb < 0.0) {
        return None;
    }
    for _ in 0..80 {
        let m = 0.5 * (a + b);
        let fm = f(m)?;
        if (fm < 0.0) == (fa < 0.0) {
            a = m;
            fa = fm;
        } else {
            b = m;
        }
    }
    let t = 0.5 * (a + b);
    Some(eq16_18(rig, [x, y], [x + t * e[0], y + t * e[1]]))
}

#[test]
fn added_error_against_f64_reference_is_below_one_micrometre() {
    let rig = Rig::default_rig();
    let reference = render_reference(&rig);
    let rows: Vec<usize> = (1..1024).step_by(23).collect();
    let object = render(&rig, &object(&rig), volume(&rig), rows.iter().copied());
    let r = run(&rig, &reference, &object, &rows);
    let mut prep = reference.phase.clone();
    ReferenceMap::prepare(&mut prep, &reference.validity, 1280, 1024).unwrap();
    let mut errs = vec![];
    for &(u, v, m, _) in &r.pts {
        let phi = object.phase[v * 1280 + u] as f64;
        if let Some(rf) = reference_f64(&rig, &prep, u, v, phi) {
            errs.push(err_um(m, rf));
        }
    }
    let s = stats(&errs);
    eprintln!(
        "added error of the f32 kernel vs the f64 reference: n {} RMS {:.4} µm max {:.4} µm",
        s.n, s.rms, s.max
    );
    assert!(s.n as f64 > 0.99 * r.pts.len() as f64);
    assert!(s.max <= 1.0, "max added error {} µm", s.max);
}

/// The same with Gaussian phase noise (σ = 0.01 rad, seeded) on both maps: the search must still
/// find the crossing of the (now rough) interpolated reference, as the f64 bisection does.
#[test]
fn added_error_with_phase_noise_is_below_one_micrometre() {
    let rig = Rig::default_rig();
    let mut reference = render_reference(&rig);
    let rows: Vec<usize> = (2..1024).step_by(29).collect();
    let mut object = render(&rig, &object(&rig), volume(&rig), rows.iter().copied());
    add_phase_noise([&mut reference, &mut object], 0.01, 0x0401_5eed);
    let r = run(&rig, &reference, &object, &rows);
    let mut prep = reference.phase.clone();
    ReferenceMap::prepare(&mut prep, &reference.validity, 1280, 1024).unwrap();
    let mut errs = vec![];
    for &(u, v, m, _) in &r.pts {
        let phi = object.phase[v * 1280 + u] as f64;
        if let Some(rf) = reference_f64(&rig, &prep, u, v, phi) {
            errs.push(err_um(m, rf));
        }
    }
    let s = stats(&errs);
    let truth_n = object.truth.iter().filter(|t| t.is_some()).count();
    eprintln!(
        "noisy maps: {} of {} object pixels valid; added error vs the f64 reference: n {} RMS {:.4} µm max {:.4} µm",
        r.pts.len(),
        truth_n,
        s.n,
        s.rms,
        s.max
    );
    assert!(r.pts.len() as f64 > 0.99 * truth_n as f64);
    assert!(s.n as f64 > 0.99 * r.pts.len() as f64);
    assert!(s.max <= 1.0, "max added error {} µm", s.max);
}

/// The paper claims the reference map absorbs the projector's lens distortion (§6, §9). Measure it:
/// a projector with k1 = ±0.1 (and some k2), everything else as the default rig.
#[test]
fn distorted_projector_is_absorbed_by_the_reference() {
    for (k1, k2) in [(0.1, 0.0), (-0.1, 0.0), (-0.1, 0.05)] {
        let mut rig = Rig::default_rig();
        rig.proj.k = [k1, k2, 0.0, 0.0, 0.0];
        let reference = render_reference(&rig);
        let rows: Vec<usize> = (2..1024).step_by(8).collect();
        let object = render(&rig, &object(&rig), volume(&rig), rows.iter().copied());
        let r = run(&rig, &reference, &object, &rows);
        let errs: Vec<f64> = r
            .pts
            .iter()
            .map(|&(u, v, m, _)| err_um(m, object.truth[v * 1280 + u].unwrap()))
            .collect();
        let s = stats(&errs);
        let truth_n = object.truth.iter().filter(|t| t.is_some()).count();
        eprintln!(
            "projector k1 = {k1:+}, k2 = {k2:+}: {} of {} pixels, RMS {:.3} µm, max {:.3} µm",
            s.n, truth_n, s.rms, s.max
        );
        assert!(s.n as f64 > 0.995 * truth_n as f64);
        assert!(
            s.rms < 1.0 && s.max < 5.0,
            "k1 {k1}: RMS {} max {}",
            s.rms,
            s.max
        );
    }
}

#[test]
fn horizontal_fringes_with_vertical_baseline() {
    // Axis::Eta: projector below the camera, phase along η.
    let mut rig = Rig::default_rig();
    rig.p = [8.0, 200.0, 5.0];
    rig.rot = look_at(rig.p, [0.0, 0.0, 700.0]);
    rig.eta = true;
    rig.s_c = 383.5;
    let reference = render_reference(&rig);
    let rows: Vec<usize> = (5..1024).step_by(16).collect();
    let object = render(&rig, &object(&rig), volume(&rig), rows.iter().copied());
    let r = run(&rig, &reference, &object, &rows);
    let errs: Vec<f64> = r
        .pts
        .iter()
        .map(|&(u, v, m, _)| err_um(m, object.truth[v * 1280 + u].unwrap()))
        .collect();
    let s = stats(&errs);
    let cam = rig.cam.model();
    let band = Reconstructor::new(&cam, &rig.setup()).unwrap().band();
    let truth_n = object.truth.iter().filter(|t| t.is_some()).count();
    eprintln!(
        "Eta rig: band {:?}, {} of {} pixels, RMS {:.3} µm max {:.3} µm",
        band, s.n, truth_n, s.rms, s.max
    );
    assert!(s.n as f64 > 0.995 * truth_n as f64);
    assert!(s.rms < 1.0 && s.max < 5.0);
}
