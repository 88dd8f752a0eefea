//! Invalid inputs give invalid codes and canonical-NaN points (never made-up points); set-up
//! errors; the band and the ring; streaming equals batch bit for bit; random bad input never
//! panics.
// Integration tests are std: std f64 maths is the independent truth here.
#![allow(clippy::disallowed_methods)]

use crate::reconstruct_support as support;

use fringe3d_core::Validity;
use fringe3d_core::geometry::Vec3;
use fringe3d_core::phase_function::Axis;
use fringe3d_core::reconstruct::{
    LANES, ReconstructError, ReconstructErrorKind, Reconstructor, ReferenceMap, ReferenceRing,
    ReferenceRows,
};
use proptest::prelude::*;
use std::sync::OnceLock;
use support::*;

const W: usize = 1280;
const H: usize = 1024;
const NAN_BITS: u32 = 0x7fc0_0000;

struct Fixture {
    rig: Rig,
    recon: Reconstructor,
    reference: PhaseMap,
    map: ReferenceMap<'static>,
}

fn fixture() -> &'static Fixture {
    static F: OnceLock<Fixture> = OnceLock::new();
    F.get_or_init(|| {
        let rig = Rig::default_rig();
        let recon = Reconstructor::new(&rig.cam.model(), &rig.setup()).unwrap();
        let reference = render_reference(&rig);
        // Leaked once: the fixture lives for the whole test binary.
        let prepared: &'static mut [f32] = Box::leak(reference.phase.clone().into_boxed_slice());
        let map = ReferenceMap::prepare(prepared, &reference.validity, W, H).unwrap();
        Fixture {
            rig,
            recon,
            reference,
            map,
        }
    })
}

fn map(f: &Fixture) -> ReferenceMap<'static> {
    f.map
}

fn row_of(
    recon: &Reconstructor,
    m: &ReferenceMap<'_>,
    v: usize,
    phase: &[f32],
    val: &[u8],
) -> (Vec<f32>, Vec<u8>) {
    let mut xyz = vec![0f32; 3 * W];
    let mut out = vec![0u8; W];
    recon
        .reconstruct_row(m, v as u32, phase, val, &mut xyz, &mut out)
        .unwrap();
    (xyz, out)
}

fn assert_consistent(xyz: &[f32], codes: &[u8]) {
    for (u, &c) in codes.iter().enumerate() {
        assert!(
            Validity::from_u8(c).is_some(),
            "pixel {u}: unknown code {c}"
        );
        let p = &xyz[3 * u..3 * u + 3];
        if c == Validity::Valid as u8 {
            assert!(
                p.iter().all(|x| x.is_finite()),
                "pixel {u}: valid but not finite"
            );
        } else {
            assert!(
                p.iter().all(|x| x.to_bits() == NAN_BITS),
                "pixel {u}: invalid but not canonical NaN"
            );
        }
    }
}

/// The phase the test object gives at pixel (u, v) of the default rig, or None.
fn true_phase(rig: &Rig, surfaces: &[Surface], u: usize, v: usize) -> Option<f32> {
    let m = render(rig, surfaces, Bounds::EVERYWHERE, v..v + 1);
    let i = v * W + u;
    (m.validity[i] == 0).then_some(m.phase[i])
}

#[test]
fn invalid_input_phase_keeps_or_gets_an_invalid_code() {
    let f = fixture();
    let m = map(f);
    let v = 500;
    let obj = render(&f.rig, &object(&f.rig), volume(&f.rig), v..v + 1);
    let mut phase = obj.phase[v * W..(v + 1) * W].to_vec();
    let mut val = obj.validity[v * W..(v + 1) * W].to_vec();
    let valid_us: Vec<usize> = (0..W).filter(|&u| val[u] == 0).collect();
    assert!(valid_us.len() > 200);
    let (a, b, c, d) = (valid_us[10], valid_us[50], valid_us[90], valid_us[130]);
    phase[a] = f32::NAN; // NaN marked valid
    phase[b] = f32::INFINITY; // infinite marked valid
    val[c] = Validity::Saturated as u8; // upstream code: kept
    val[d] = 200; // not a code
    let (xyz, out) = row_of(&f.recon, &m, v, &phase, &val);
    assert_consistent(&xyz, &out);
    assert_eq!(out[a], Validity::PhaseOutOfRange as u8);
    assert_eq!(out[b], Validity::PhaseOutOfRange as u8);
    assert_eq!(out[c], Validity::Saturated as u8);
    assert_eq!(out[d], Validity::PhaseOutOfRange as u8);
    assert_eq!(out[valid_us[20]], Validity::Valid as u8);
    // Dark pixels of the input stay Dark.
    let dark = (0..W)
        .find(|&u| obj.validity[v * W + u] == Validity::Dark as u8)
        .unwrap();
    assert_eq!(out[dark], Validity::Dark as u8);
}

#[test]
fn out_of_depth_range_is_flagged() {
    let f = fixture();
    let m = map(f);
    // A wall at z ≈ 900 mm (beyond z_max = 825) and one at ≈ 520 mm (before z_min = 575).
    for (z, name) in [(900.0, "far"), (520.0, "near")] {
        let wall = [Surface::Plane {
            p: [0.0, 0.0, z],
            n: [0.0, 0.0, -1.0],
        }];
        let v = 512;
        let obj = render(&f.rig, &wall, Bounds::EVERYWHERE, v..v + 1);
        let (xyz, out) = row_of(
            &f.recon,
            &m,
            v,
            &obj.phase[v * W..(v + 1) * W],
            &obj.validity[v * W..(v + 1) * W],
        );
        assert_consistent(&xyz, &out);
        let lit = (0..W).filter(|&u| obj.validity[v * W + u] == 0).count();
        let ood = out
            .iter()
            .filter(|&&c| c == Validity::OutOfDepth as u8)
            .count();
        let valid = out.iter().filter(|&&c| c == 0).count();
        eprintln!("{name} wall: {lit} lit pixels, {ood} out-of-depth, {valid} valid");
        assert_eq!(
            valid, 0,
            "{name}: no point may be made up outside the depth range"
        );
        // The rest: segments leaving the image near its edges (phase not found on the valid part).
        let other = out
            .iter()
            .filter(|&&c| c == Validity::NoCrossing as u8 || c == Validity::ReferenceInvalid as u8)
            .count();
        assert_eq!(ood + other, lit, "{name}");
        assert!(ood as f64 > 0.8 * lit as f64, "{name}: {ood} of {lit}");
    }
}

#[test]
fn phase_beyond_reference_and_invalid_reference() {
    let f = fixture();
    let v = 400;
    let obj = render(&f.rig, &object(&f.rig), volume(&f.rig), v..v + 1);
    let val = obj.validity[v * W..(v + 1) * W].to_vec();
    let u = (0..W).filter(|&u| val[u] == 0).nth(100).unwrap();
    // A phase no reference pixel has → out of depth (both ends of the segment valid, same side).
    let mut phase = obj.phase[v * W..(v + 1) * W].to_vec();
    phase[u] = 1.0e4;
    let m = map(f);
    let (_, out) = row_of(&f.recon, &m, v, &phase, &val);
    assert_eq!(out[u], Validity::OutOfDepth as u8);

    // Reference invalid in a block of columns around the true crossing, with valid reference on
    // both sides: the crossing is bracketed across the gap → ReferenceInvalid.
    let phase = obj.phase[v * W..(v + 1) * W].to_vec();
    let mut xyz = vec![0f32; 3 * W];
    let mut out = vec![0u8; W];
    let mut cr = vec![0f32; 2 * W];
    f.recon
        .reconstruct_row_with_crossings(&m, v as u32, &phase, &val, &mut xyz, &mut out, &mut cr)
        .unwrap();
    assert_eq!(out[u], 0);
    let (nu, _) = f
        .rig
        .cam
        .pixel_of_normalized(cr[2 * u] as f64, cr[2 * u + 1] as f64);
    let mut rp = f.reference.phase.clone();
    let mut rv = f.reference.validity.clone();
    for r in 0..H {
        for c in (nu as usize).saturating_sub(4)..(nu as usize + 5).min(W) {
            rv[r * W + c] = Validity::LowModulation as u8;
        }
    }
    let m2 = ReferenceMap::prepare(&mut rp, &rv, W, H).unwrap();
    let (xyz, out) = row_of(&f.recon, &m2, v, &phase, &val);
    assert_consistent(&xyz, &out);
    assert_eq!(
        out[u],
        Validity::ReferenceInvalid as u8,
        "gap around the crossing"
    );

    // Reference invalid from the crossing to the end of the segment: the phase is not found on the
    // valid part → NoCrossing.
    let mut rp = f.reference.phase.clone();
    let mut rv = f.reference.validity.clone();
    let seg_dir_right = cr[2 * u] as f64 > f.rig.cam.unproject(u as f64, v as f64).0;
    for r in 0..H {
        let cols: Box<dyn Iterator<Item = usize>> = if seg_dir_right {
            Box::new((nu as usize).saturating_sub(3)..W)
        } else {
            Box::new(0..(nu as usize + 4).min(W))
        };
        for c in cols {
            rv[r * W + c] = Validity::Dark as u8;
        }
    }
    let m3 = ReferenceMap::prepare(&mut rp, &rv, W, H).unwrap();
    let (xyz, out) = row_of(&f.recon, &m3, v, &phase, &val);
    assert_consistent(&xyz, &out);
    assert_eq!(
        out[u],
        Validity::NoCrossing as u8,
        "crossing in the invalid tail"
    );

    // Reference invalid everywhere → ReferenceInvalid or NoCrossing for every lit pixel, no point.
    let mut rp = f.reference.phase.clone();
    let rv = vec![Validity::Dark as u8; W * H];
    let m4 = ReferenceMap::prepare(&mut rp, &rv, W, H).unwrap();
    let (xyz, out) = row_of(&f.recon, &m4, v, &phase, &val);
    assert_consistent(&xyz, &out);
    for c in 0..W {
        if val[c] == 0 {
            assert_eq!(out[c], Validity::ReferenceInvalid as u8);
        }
    }
}

#[test]
fn setup_errors() {
    let rig = Rig::default_rig();
    let cam = rig.cam.model();
    let base = rig.setup();
    let err = |s: fringe3d_core::reconstruct::Setup| Reconstructor::new(&cam, &s).unwrap_err();
    let mut s = base;
    s.z_min = 900.0;
    assert_eq!(err(s), ReconstructError::DepthRange);
    let mut s = base;
    s.reference_normal = Vec3::ZERO;
    assert_eq!(err(s), ReconstructError::ReferencePlane);
    let mut s = base;
    s.reference_point = Vec3::new(0.0, 0.0, 0.0); // plane through the camera centre
    assert_eq!(err(s), ReconstructError::ReferencePlane);
    let mut s = base;
    s.projector_centre = Vec3::ZERO;
    assert_eq!(err(s), ReconstructError::ProjectorCentre);
    let mut s = base;
    s.axis = Axis::Eta; // horizontal baseline with horizontal fringes
    assert!(matches!(err(s), ReconstructError::AxisMismatch { .. }));
    let mut s = base;
    s.z_max = f64::NAN;
    assert_eq!(err(s), ReconstructError::NotFinite);
    let mut s = base;
    s.reference_normal = Vec3::new(1.0, 0.0, 0.0); // plane containing the optical axis
    assert!(Reconstructor::new(&cam, &s).is_err());
    for e in [
        ReconstructError::DepthRange,
        ReconstructError::AxisMismatch { u: 1, v: 2 },
    ] {
        assert_eq!(e.kind(), ReconstructErrorKind::Setup);
        assert!(!e.to_string().is_empty());
    }
}

/// A pixel's point does not depend on its neighbours: stage 2 and the fallback's end samples run
/// as vector passes over a chunk when enough of its pixels need them, else per pixel, with the
/// same operations. Rows of a noisy scene (where a third of the pixels need stage 2) are
/// reconstructed whole, then with one valid pixel per chunk at a time (every stage per pixel);
/// every point and code must be the same bits.
#[test]
fn every_pixel_reconstructs_as_it_does_alone() {
    let f = fixture();
    let rows = [150usize, 333, 512, 700, 901];
    let mut reference = f.reference.clone();
    let (surfaces, bounds) = bench_surfaces(&f.rig);
    let mut obj = render(&f.rig, &surfaces, bounds, rows.iter().copied());
    add_phase_noise([&mut reference, &mut obj], 0.01, 7);
    let mut prep = reference.phase.clone();
    let m = ReferenceMap::prepare(&mut prep, &reference.validity, W, H).unwrap();
    let mut checked = 0;
    for &v in &rows {
        let (p, val) = (
            &obj.phase[v * W..(v + 1) * W],
            &obj.validity[v * W..(v + 1) * W],
        );
        let (xyz, codes) = row_of(&f.recon, &m, v, p, val);
        for j in 0..LANES {
            // Only columns j, j + LANES, … keep their input code: one pixel per chunk.
            let alone: Vec<u8> = (0..W)
                .map(|u| {
                    if u % LANES == j {
                        val[u]
                    } else {
                        Validity::Dark as u8
                    }
                })
                .collect();
            let (xyz1, codes1) = row_of(&f.recon, &m, v, p, &alone);
            for u in (j..W).step_by(LANES) {
                let bits = |x: &[f32]| {
                    x[3 * u..3 * u + 3]
                        .iter()
                        .map(|c| c.to_bits())
                        .collect::<Vec<_>>()
                };
                assert_eq!(
                    (codes1[u], bits(&xyz1)),
                    (codes[u], bits(&xyz)),
                    "row {v}, column {u}"
                );
                checked += (codes[u] == Validity::Valid as u8) as usize;
            }
        }
    }
    assert!(checked > 3000, "only {checked} valid points compared");
}

#[test]
fn band_and_ring() {
    let f = fixture();
    let band = f.recon.band();
    let need = band.rows() as usize;
    eprintln!(
        "default rig: band {band:?} ({} rows), ring {} B, longest segment {:.1} px, fallback bisections {}",
        need,
        f.recon.ring_bytes(band.rows()),
        f.recon.max_segment_px(),
        f.recon.fallback_bisections()
    );
    eprintln!(
        "size_of::<Reconstructor>() = {} B",
        std::mem::size_of::<Reconstructor>()
    );
    assert!(band.above >= 1 && band.below >= 1 && need < 64);
    // Too small a ring is a set-up error.
    let mut p = vec![0f32; (need - 1) * W];
    let mut q = vec![0u8; (need - 1) * W];
    assert!(matches!(
        ReferenceRing::new(&f.recon, &mut p, &mut q),
        Err(ReconstructError::BandTooSmall { .. })
    ));
    let mut p = vec![0f32; need * W];
    let mut q = vec![0u8; need * W - 1];
    assert_eq!(
        ReferenceRing::new(&f.recon, &mut p, &mut q).unwrap_err(),
        ReconstructError::BufferTooSmall
    );
    // Rows not yet pushed → NotResident; pushing past the image → Sequence.
    let mut q = vec![0u8; need * W];
    let mut ring = ReferenceRing::new(&f.recon, &mut p, &mut q).unwrap();
    let zeros = vec![0f32; W];
    let val0 = vec![0u8; W];
    let mut xyz = vec![0f32; 3 * W];
    let mut out = vec![0u8; W];
    assert!(matches!(
        f.recon
            .reconstruct_row(&ring, 10, &zeros, &val0, &mut xyz, &mut out),
        Err(ReconstructError::NotResident { .. })
    ));
    for r in 0..H {
        ring.push_row(
            &f.reference.phase[r * W..(r + 1) * W],
            &f.reference.validity[r * W..(r + 1) * W],
        )
        .unwrap();
    }
    assert_eq!(
        ring.push_row(&zeros, &val0).unwrap_err(),
        ReconstructError::Sequence
    );
    // Old rows are gone, recent rows are held with their validity.
    assert!(ring.row(0).is_none());
    assert!(ring.row(H as u32 - 1).is_some());
    assert_eq!(
        ring.validity_row(H as u32 - 1).unwrap(),
        &f.reference.validity[(H - 1) * W..]
    );
    assert_eq!(
        f.recon
            .reconstruct_row(&ring, 3, &zeros, &val0, &mut xyz, &mut out)
            .unwrap_err(),
        ReconstructError::NotResident { row: 0 }
    );
    // Wrong lengths.
    assert_eq!(
        f.recon
            .reconstruct_row(&ring, H as u32 - 1, &zeros[1..], &val0, &mut xyz, &mut out)
            .unwrap_err(),
        ReconstructError::Length
    );
    assert_eq!(
        f.recon
            .reconstruct_row(&ring, H as u32, &zeros, &val0, &mut xyz, &mut out)
            .unwrap_err(),
        ReconstructError::Row
    );
}

/// Streaming through the smallest ring gives the same bits as the batch path (NaNs canonical).
#[test]
fn streaming_equals_batch_bit_for_bit() {
    let f = fixture();
    let mut surfaces = object(&f.rig);
    surfaces.push(Surface::Plane {
        p: [0.0, 0.0, 900.0],
        n: [0.0, 0.0, -1.0],
    }); // out-of-depth background
    let obj = render(&f.rig, &surfaces, Bounds::EVERYWHERE, 0..H);
    // Some invalid reference and object pixels, and noise, from a seeded RNG.
    let mut rng = Rng(42);
    let mut rp = f.reference.phase.clone();
    let mut rv = f.reference.validity.clone();
    let mut op = obj.phase.clone();
    let mut ov = obj.validity.clone();
    for i in 0..W * H {
        if rng.uniform() < 0.002 {
            rv[i] = Validity::LowModulation as u8;
        }
        if rng.uniform() < 0.002 {
            ov[i] = Validity::Saturated as u8;
        }
        if op[i].is_finite() {
            op[i] += (0.02 * (rng.uniform() - 0.5)) as f32;
        }
    }
    let mut batch_xyz = vec![0f32; 3 * W * H];
    let mut batch_val = vec![0u8; W * H];
    let mut prep = rp.clone();
    let m = ReferenceMap::prepare(&mut prep, &rv, W, H).unwrap();
    f.recon
        .reconstruct_frame(&m, &op, &ov, &mut batch_xyz, &mut batch_val)
        .unwrap();

    let rows = f.recon.band().rows() as usize;
    let mut ring_p = vec![0f32; rows * W];
    let mut ring_v = vec![0u8; rows * W];
    let mut ring = ReferenceRing::new(&f.recon, &mut ring_p, &mut ring_v).unwrap();
    let mut xyz = vec![0f32; 3 * W];
    let mut out = vec![0u8; W];
    let mut differ = 0usize;
    for v in 0..H as u32 {
        let (_, last) = f.recon.rows_needed(v);
        while ring.rows_pushed() <= last {
            let r = ring.rows_pushed() as usize;
            ring.push_row(&rp[r * W..(r + 1) * W], &rv[r * W..(r + 1) * W])
                .unwrap();
        }
        let s = v as usize * W;
        f.recon
            .reconstruct_row(&ring, v, &op[s..s + W], &ov[s..s + W], &mut xyz, &mut out)
            .unwrap();
        for u in 0..W {
            if out[u] != batch_val[s + u] {
                differ += 1;
            }
            for k in 0..3 {
                if xyz[3 * u + k].to_bits() != batch_xyz[3 * (s + u) + k].to_bits() {
                    differ += 1;
                }
            }
        }
        assert_consistent(&xyz, &out);
    }
    // A reference store of another layout (rows in reverse order: the kernel cannot compute the
    // row offsets by formula and looks them up), and a ring with spare rows (another wrap point).
    let reversed = Reversed {
        data: prep.iter().rev().copied().collect(),
    }
    .fix();
    let mut ring_p2 = vec![0f32; (rows + 5) * W];
    let mut ring_v2 = vec![0u8; (rows + 5) * W];
    let mut ring2 = ReferenceRing::new(&f.recon, &mut ring_p2, &mut ring_v2).unwrap();
    for v in 0..H as u32 {
        let (_, last) = f.recon.rows_needed(v);
        while ring2.rows_pushed() <= last {
            let r = ring2.rows_pushed() as usize;
            ring2
                .push_row(&rp[r * W..(r + 1) * W], &rv[r * W..(r + 1) * W])
                .unwrap();
        }
        let s = v as usize * W;
        for k in 0..2 {
            if k == 0 {
                f.recon
                    .reconstruct_row(
                        &reversed,
                        v,
                        &op[s..s + W],
                        &ov[s..s + W],
                        &mut xyz,
                        &mut out,
                    )
                    .unwrap();
            } else {
                f.recon
                    .reconstruct_row(&ring2, v, &op[s..s + W], &ov[s..s + W], &mut xyz, &mut out)
                    .unwrap();
            }
            for u in 0..W {
                if out[u] != batch_val[s + u] {
                    differ += 1;
                }
                for c in 0..3 {
                    if xyz[3 * u + c].to_bits() != batch_xyz[3 * (s + u) + c].to_bits() {
                        differ += 1;
                    }
                }
            }
        }
    }
    let counts: Vec<usize> = (0..10)
        .map(|c| batch_val.iter().filter(|&&x| x == c).count())
        .collect();
    eprintln!(
        "streaming (two rings) and a reversed row store vs batch: {differ} differing values; codes {counts:?}"
    );
    assert_eq!(differ, 0);
    assert!(counts[0] > 100_000 && counts[Validity::OutOfDepth as usize] > 10_000);
    rp.clear();
}

/// A whole reference map stored bottom row first, each row reversed (the samples of a row are
/// read through [`ReferenceRows::row_offset`], so the row is stored left to right at its offset:
/// reversing the whole buffer reverses the rows' order and their contents, so rows are re-reversed
/// by taking each row's samples back in order).
struct Reversed {
    data: Vec<f32>,
}

impl Reversed {
    fn fix(mut self) -> Self {
        for row in self.data.chunks_exact_mut(W) {
            row.reverse();
        }
        self
    }
}

impl ReferenceRows for Reversed {
    fn width(&self) -> usize {
        W
    }
    fn height(&self) -> usize {
        H
    }
    fn capacity_rows(&self) -> u32 {
        H as u32
    }
    fn storage(&self) -> &[f32] {
        &self.data
    }
    fn row_offset(&self, r: u32) -> Option<usize> {
        ((r as usize) < H).then(|| (H - 1 - r as usize) * W)
    }
}

fn bad_f32() -> impl Strategy<Value = f32> {
    prop_oneof![
        Just(f32::NAN),
        Just(f32::INFINITY),
        Just(f32::NEG_INFINITY),
        Just(f32::MAX),
        Just(-f32::MAX),
        Just(f32::MIN_POSITIVE),
        Just(0.0f32),
        -1.0e6f32..1.0e6f32,
        -300.0f32..300.0f32,
        any::<u32>().prop_map(f32::from_bits),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 24, ..ProptestConfig::default() })]

    /// Random phases, validity bytes and reference corruption never panic, and every output is
    /// consistent (valid ⇔ finite point, invalid ⇔ canonical NaN, codes known).
    #[test]
    fn random_bad_input_never_panics(
        row in 0u32..1024,
        phases in proptest::collection::vec(bad_f32(), 64),
        codes in proptest::collection::vec(any::<u8>(), 64),
        corrupt in proptest::collection::vec((0usize..W * 40, bad_f32(), any::<u8>()), 0..400),
    ) {
        let f = fixture();
        let (first, last) = f.recon.rows_needed(row);
        let mut rp = f.reference.phase.clone();
        let mut rv = f.reference.validity.clone();
        for (i, p, q) in corrupt {
            let i = (first as usize * W + i).min(W * H - 1);
            rp[i] = p;
            rv[i] = q;
        }
        let m = ReferenceMap::prepare(&mut rp, &rv, W, H).unwrap();
        let phase: Vec<f32> = (0..W).map(|u| phases[u % 64]).collect();
        let val: Vec<u8> = (0..W).map(|u| if u % 3 == 0 { 0 } else { codes[u % 64] }).collect();
        let mut xyz = vec![0f32; 3 * W];
        let mut out = vec![0u8; W];
        f.recon.reconstruct_row(&m, row, &phase, &val, &mut xyz, &mut out).unwrap();
        assert_consistent(&xyz, &out);
        prop_assert!(last >= first);
        // Also through a ring with garbage rows.
        let rows = f.recon.band().rows() as usize;
        let mut ring_p = vec![0f32; rows * W];
        let mut ring_v = vec![0u8; rows * W];
        let mut ring = ReferenceRing::new(&f.recon, &mut ring_p, &mut ring_v).unwrap();
        for r in 0..=last as usize {
            ring.push_row(&rp[r * W..(r + 1) * W], &rv[r * W..(r + 1) * W]).unwrap();
        }
        f.recon.reconstruct_row(&ring, row, &phase, &val, &mut xyz, &mut out).unwrap();
        assert_consistent(&xyz, &out);
    }
}

#[test]
fn truth_helper_sanity() {
    let f = fixture();
    let p = true_phase(&f.rig, &object(&f.rig), 640, 512);
    assert!(p.is_some());
    assert_eq!(f.recon.width(), W);
    assert!(map(f).row(0).is_some());
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 32, ..ProptestConfig::default() })]

    /// Random (mostly absurd) geometries are refused or accepted, never a panic; an accepted one
    /// reconstructs a row without panicking.
    #[test]
    fn random_setups_never_panic(
        p in proptest::array::uniform3(bad_f32()),
        o in proptest::array::uniform3(bad_f32()),
        n in proptest::array::uniform3(bad_f32()),
        z in (bad_f32(), bad_f32()),
        eta in any::<bool>(),
    ) {
        let f = fixture();
        let v3 = |a: [f32; 3]| Vec3::new(a[0] as f64, a[1] as f64, a[2] as f64);
        let s = fringe3d_core::reconstruct::Setup {
            projector_centre: v3(p),
            reference_point: v3(o),
            reference_normal: v3(n),
            axis: if eta { Axis::Eta } else { Axis::Xi },
            z_min: z.0 as f64,
            z_max: z.1 as f64,
        };
        if let Ok(r) = Reconstructor::new(&f.rig.cam.model(), &s) {
            let m = map(f);
            let phase = vec![1.0f32; W];
            let val = vec![0u8; W];
            let mut xyz = vec![0f32; 3 * W];
            let mut out = vec![0u8; W];
            r.reconstruct_row(&m, 17, &phase, &val, &mut xyz, &mut out).unwrap();
            assert_consistent(&xyz, &out);
        }
    }
}
