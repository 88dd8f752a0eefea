//! A reference map wider than the image (issue #17 item 3) and the fallback's clipping to the
//! map: on a surface near the camera that fills the image, every fully lit pixel whose true point
//! lies in the depth range reconstructs when the map has the margin the geometry needs; without a
//! margin, every one whose true reference crossing lies on the map still does (the search clips
//! its interval to the map instead of giving up). Truth: the analytic rig of
//! `reconstruct_support`.
// Integration tests are std: std f64 maths is the independent truth here.
#![allow(clippy::disallowed_methods)]

use crate::reconstruct_support as support;

use fringe3d_core::Validity;
use fringe3d_core::reconstruct::{
    MAX_MARGIN, Margin, ReconstructError, Reconstructor, ReferenceMap, ReferenceRing,
};
use support::*;

const W: usize = 1280;
const H: usize = 1024;

/// The reference map of `rig` over the image and margin `m`: map sample (i, j) is image pixel
/// (i − left, j − top), ray-cast against the reference plane.
fn reference_with_margin(rig: &Rig, m: Margin) -> (Vec<f32>, Vec<u8>, usize, usize) {
    let (mw, mh) = (
        W + (m.left + m.right) as usize,
        H + (m.top + m.bottom) as usize,
    );
    let plane = Surface::Plane {
        p: rig.ref_point,
        n: rig.ref_normal,
    };
    let mut phase = vec![f32::NAN; mw * mh];
    let mut validity = vec![Validity::Dark as u8; mw * mh];
    for j in 0..mh {
        for i in 0..mw {
            let (u, v) = (i as f64 - m.left as f64, j as f64 - m.top as f64);
            let d = rig.ray(u, v);
            let Some(l) = plane.hit([0.0; 3], d) else {
                continue;
            };
            if let Some(ph) = rig.phase_at(mul(d, l)) {
                phase[j * mw + i] = ph as f32;
                validity[j * mw + i] = Validity::Valid as u8;
            }
        }
    }
    (phase, validity, mw, mh)
}

/// A plane near the near end of the volume filling the whole image, with `sigma` rad of phase
/// noise.
fn near_scene(rig: &Rig, sigma: f64) -> PhaseMap {
    let s = Surface::Plane {
        p: [0.0, 0.0, rig.z_range[0] + 15.0],
        n: unit([0.04, -0.03, -1.0]),
    };
    let mut m = render(rig, &[s], Bounds::EVERYWHERE, 0..H);
    if sigma > 0.0 {
        add_phase_noise([&mut m, &mut empty()], sigma, 3);
    }
    m
}

fn empty() -> PhaseMap {
    PhaseMap {
        width: 0,
        height: 0,
        phase: vec![],
        validity: vec![],
        truth: vec![],
    }
}

/// The camera pixel of the reference crossing of point `x`: where the projector ray through `x`
/// meets the reference plane, imaged.
fn crossing_pixel(rig: &Rig, x: V3) -> Option<(f64, f64)> {
    let d = sub(x, rig.p);
    let den = dot(rig.ref_normal, d);
    let l = dot(rig.ref_normal, sub(rig.ref_point, rig.p)) / den;
    rig.cam.project(add(rig.p, mul(d, l)))
}

/// Whether the whole search segment of the pixel with ray `d` lies on lit reference: every point
/// of the ray in the depth range is lit by the projector at least 3 projector pixels inside its
/// image (a point and its reference crossing share the projector ray). Pixels at the edge of the
/// projector's light cross unlit reference on the way: a loss no map avoids, counted apart.
fn well_lit(rig: &Rig, d: V3) -> bool {
    let (w, h) = (rig.proj.width as f64, rig.proj.height as f64);
    (0..=25).all(|k| {
        let z = rig.z_range[0] + (rig.z_range[1] - rig.z_range[0]) * k as f64 / 25.0;
        let x = mul(d, z / d[2]);
        rig.proj
            .project(rig.projector_frame(x))
            .is_some_and(|(xi, eta)| xi >= 3.0 && xi <= w - 4.0 && eta >= 3.0 && eta <= h - 4.0)
    })
}

struct Run {
    xyz: Vec<f32>,
    codes: Vec<u8>,
}

fn batch(recon: &Reconstructor, map: &ReferenceMap<'_>, obj: &PhaseMap) -> Run {
    let mut xyz = vec![0f32; 3 * W * H];
    let mut codes = vec![0u8; W * H];
    recon
        .reconstruct_frame(map, &obj.phase, &obj.validity, &mut xyz, &mut codes)
        .unwrap();
    Run { xyz, codes }
}

fn err_mm(run: &Run, obj: &PhaseMap, i: usize) -> f64 {
    let t = obj.truth[i].unwrap();
    let p = &run.xyz[3 * i..3 * i + 3];
    norm(sub([p[0] as f64, p[1] as f64, p[2] as f64], t))
}

#[test]
fn a_map_with_the_needed_margin_covers_every_pixel_near_the_camera() {
    let rig = Rig::default_rig();
    let recon = Reconstructor::new(&rig.cam.model(), &rig.setup()).unwrap();
    assert_eq!(recon.with_margin(Margin::ZERO).unwrap(), recon);
    let need = recon.margin_needed();
    // This rig's projector sits to the right: near points' crossings move left.
    assert!(need.left > 20, "needed margin {need:?}");
    let wide = recon.with_margin(need).unwrap();
    assert_eq!(wide.margin(), need);
    // One analysis for the margin gives the reconstructor of the two steps, for every margin
    // (the band grows with it; the segments' reach and length do not change).
    let (cam, setup) = (rig.cam.model(), rig.setup());
    for m in [
        Margin::ZERO,
        need,
        Margin::uniform(8),
        Margin::from_array([0, 40, 3, 0]),
        Margin::uniform(MAX_MARGIN),
    ] {
        let chained = recon.with_margin(m).unwrap();
        assert_eq!(
            Reconstructor::new_with_margin(&cam, &setup, m).unwrap(),
            chained,
            "{m:?}"
        );
    }
    assert_eq!(
        Reconstructor::new_with_margin(&cam, &setup, Margin::uniform(MAX_MARGIN + 1)).err(),
        recon.with_margin(Margin::uniform(MAX_MARGIN + 1)).err()
    );
    let obj = near_scene(&rig, 0.0);

    // Without a margin (today's map).
    let (mut p0, v0, _, _) = reference_with_margin(&rig, Margin::ZERO);
    let m0 = ReferenceMap::prepare(&mut p0, &v0, W, H).unwrap();
    let r0 = batch(&recon, &m0, &obj);
    // With the margin.
    let (mut p1, v1, mw, mh) = reference_with_margin(&rig, need);
    assert_eq!((mw, mh), (wide.map_width(), wide.map_height()));
    let m1 = ReferenceMap::prepare(&mut p1, &v1, mw, mh).unwrap();
    let r1 = batch(&wide, &m1, &obj);

    let (mut inside, mut lost0, mut on_map, mut lost_on_map, mut lost1) = (0, 0, 0, 0, 0);
    let mut at_light_edge = 0;
    let mut worst = 0f64;
    for i in 0..W * H {
        let Some(t) = obj.truth[i] else { continue };
        if !(t[2] >= rig.z_range[0] && t[2] <= rig.z_range[1]) {
            continue;
        }
        if !well_lit(&rig, t) {
            at_light_edge += 1;
            continue;
        }
        inside += 1;
        let valid0 = r0.codes[i] == Validity::Valid as u8;
        lost0 += !valid0 as usize;
        // Crossing inside the unwidened map, a pixel from its edge (the bilinear cell).
        if let Some((cu, cv)) = crossing_pixel(&rig, t)
            && cu >= 1.0
            && cu <= W as f64 - 2.0
            && cv >= 1.0
            && cv <= H as f64 - 2.0
        {
            on_map += 1;
            lost_on_map += !valid0 as usize;
        }
        if r1.codes[i] == Validity::Valid as u8 {
            worst = worst.max(err_mm(&r1, &obj, i));
        } else {
            lost1 += 1;
        }
    }
    eprintln!(
        "margin {need:?}: {inside} pixels in depth ({at_light_edge} more at the edge of the \
         projector's light); no margin loses {lost0} ({lost_on_map} of \
         the {on_map} whose crossing is on the map), with the margin {lost1}; worst error \
         {:.2} µm",
        worst * 1e3
    );
    assert!(inside > W * H * 7 / 10);
    assert!(
        lost0 > 1000,
        "the scene must need the margin ({lost0} lost)"
    );
    assert_eq!(
        lost_on_map, 0,
        "no-crossing although the crossing is on the map"
    );
    assert_eq!(lost1, 0, "pixels lost with the needed margin");
    assert!(worst < 1e-3, "worst error {} µm", worst * 1e3);
    // The margin changes nothing where the search stayed on the image: the same bits.
    for i in 0..W * H {
        if r0.codes[i] == Validity::Valid as u8 {
            let b = |r: &Run| [0, 1, 2].map(|k| r.xyz[3 * i + k].to_bits());
            let (a, c) = (b(&r0), b(&r1));
            if a != c {
                // Pixels whose first step read the map's margin may differ by rounding only.
                assert!(err_mm(&r1, &obj, i) < 1e-3, "pixel {i}: {a:?} vs {c:?}");
            }
        }
    }
}

#[test]
fn streaming_with_a_margin_equals_batch_bit_for_bit() {
    let rig = Rig::default_rig();
    let need = Reconstructor::new(&rig.cam.model(), &rig.setup())
        .unwrap()
        .margin_needed();
    let wide = Reconstructor::new(&rig.cam.model(), &rig.setup())
        .unwrap()
        .with_margin(need)
        .unwrap();
    let obj = near_scene(&rig, 0.0);
    let (p1, v1, mw, mh) = reference_with_margin(&rig, need);
    let mut prep = p1.clone();
    let map = ReferenceMap::prepare(&mut prep, &v1, mw, mh).unwrap();
    let b = batch(&wide, &map, &obj);

    let rows = wide.band().rows() as usize;
    assert_eq!(wide.ring_bytes(rows as u32), rows * mw * 5);
    let narrow = Reconstructor::new(&rig.cam.model(), &rig.setup()).unwrap();
    eprintln!(
        "ring: {} rows × {mw} = {} B with the margin {need:?}, {} rows × {W} = {} B without",
        rows,
        wide.ring_bytes(rows as u32),
        narrow.band().rows(),
        narrow.ring_bytes(narrow.band().rows())
    );
    let mut rp = vec![0f32; rows * mw];
    let mut rv = vec![0u8; rows * mw];
    let mut ring = ReferenceRing::new(&wide, &mut rp, &mut rv).unwrap();
    let mut xyz = vec![0f32; 3 * W];
    let mut codes = vec![0u8; W];
    for v in 0..H {
        let (_, last) = wide.rows_needed(v as u32);
        while ring.rows_pushed() <= last {
            let r = ring.rows_pushed() as usize;
            ring.push_row(&p1[r * mw..(r + 1) * mw], &v1[r * mw..(r + 1) * mw])
                .unwrap();
        }
        let s = v * W..(v + 1) * W;
        wide.reconstruct_row(
            &ring,
            v as u32,
            &obj.phase[s.clone()],
            &obj.validity[s.clone()],
            &mut xyz,
            &mut codes,
        )
        .unwrap();
        assert_eq!(codes, b.codes[s.clone()], "row {v}");
        let bits = |x: &[f32]| x.iter().map(|c| c.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&xyz), bits(&b.xyz[3 * s.start..3 * s.end]), "row {v}");
    }
}

#[test]
fn maps_of_the_wrong_size_and_huge_margins_are_refused() {
    let rig = Rig::default_rig();
    let recon = Reconstructor::new(&rig.cam.model(), &rig.setup()).unwrap();
    assert_eq!(
        recon.with_margin(Margin::uniform(MAX_MARGIN + 1)).err(),
        Some(ReconstructError::Margin)
    );
    let wide = recon.with_margin(Margin::uniform(8)).unwrap();
    // An image-sized map for a reconstructor expecting a margin.
    let mut p = vec![0f32; W * H];
    let map = ReferenceMap::prepare(&mut p, &vec![0u8; W * H], W, H).unwrap();
    let (mut xyz, mut codes) = (vec![0f32; 3 * W], vec![0u8; W]);
    let row = vec![0f32; W];
    let val = vec![0u8; W];
    assert_eq!(
        wide.reconstruct_row(&map, 0, &row, &val, &mut xyz, &mut codes),
        Err(ReconstructError::Length)
    );
    // Rows count from the map's top.
    assert_eq!(wide.rows_needed(0).0, 8 - wide.band().above.min(8));
}

#[test]
fn with_a_noisy_map_the_search_clips_to_the_map_instead_of_giving_up() {
    // A raw reference capture (0.02 rad of noise) ends at the image: a near pixel whose crossing
    // lies on the map but whose search interval runs off it must still be found, and right (the
    // fallback clips its interval to the map). Without the clip, 90 such pixels of this scene
    // were "no-crossing".
    let rig = Rig::default_rig();
    let recon = Reconstructor::new(&rig.cam.model(), &rig.setup()).unwrap();
    let obj = near_scene(&rig, 0.05);
    let (p0, v0, _, _) = reference_with_margin(&rig, Margin::ZERO);
    let mut reference = PhaseMap {
        width: W,
        height: H,
        phase: p0,
        validity: v0,
        truth: vec![],
    };
    add_phase_noise([&mut reference, &mut empty()], 0.02, 5);
    let m0 = ReferenceMap::prepare(&mut reference.phase, &reference.validity, W, H).unwrap();
    let r0 = batch(&recon, &m0, &obj);
    let (mut near_edge, mut lost, mut s2) = (0, 0, 0f64);
    let (mut all, mut all_s2) = (0, 0f64);
    let mut worst = 0f64;
    for i in 0..W * H {
        let Some(t) = obj.truth[i] else { continue };
        // 2 mm inside the depth range: 0.05 rad of noise moves points by ~0.2 mm.
        let in_depth = t[2] >= rig.z_range[0] + 2.0 && t[2] <= rig.z_range[1] - 2.0;
        if !(in_depth && well_lit(&rig, t)) {
            continue;
        }
        let valid = r0.codes[i] == Validity::Valid as u8;
        if valid {
            let e = err_mm(&r0, &obj, i);
            all += 1;
            all_s2 += e * e;
        }
        let Some((cu, cv)) = crossing_pixel(&rig, t) else {
            continue;
        };
        if !(cu >= 1.0 && cu <= W as f64 - 2.0 && cv >= 1.0 && cv <= H as f64 - 2.0) {
            continue;
        }
        // The interval runs off the map: its near end lies left of the image.
        let d = rig.ray((i % W) as f64, (i / W) as f64);
        let near_end = crossing_pixel(&rig, mul(d, rig.z_range[0]));
        if near_end.is_some_and(|(u, _)| u < 0.0) {
            near_edge += 1;
            if valid {
                let e = err_mm(&r0, &obj, i);
                s2 += e * e;
                worst = worst.max(e);
            } else {
                lost += 1;
            }
        }
    }
    let rms_edge = (s2 / (near_edge - lost).max(1) as f64).sqrt();
    let rms_all = (all_s2 / all.max(1) as f64).sqrt();
    eprintln!(
        "{near_edge} pixels whose search runs off the map: {lost} lost, error RMS {:.1} µm \
         (max {:.1}) against {:.1} µm over all {all} pixels",
        rms_edge * 1e3,
        worst * 1e3,
        rms_all * 1e3
    );
    assert!(
        near_edge > 2_000,
        "the scene must exercise the clip ({near_edge})"
    );
    assert_eq!(lost, 0);
    // Found, and right: the noise's error, as elsewhere (this band near the image's left edge
    // is 1.21× the image's RMS with or without the clip; a wrong crossing would be millimetres).
    assert!(rms_edge < 1.3 * rms_all, "{rms_edge} vs {rms_all}");
    assert!(worst < 6.0 * rms_all, "{worst} vs {rms_all}");
}
