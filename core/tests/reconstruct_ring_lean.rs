//! The lean reference ring (issue #23 item 3): without a validity plane, fed rows with codes or
//! NaN-encoded rows without, and started at a first row for a region of interest, it gives the
//! batch path's points bit for bit; misuse is refused by name.
// Integration tests are std: std f64 maths is the independent truth here.
#![allow(clippy::disallowed_methods)]

use crate::reconstruct_support as support;

use fringe3d_core::Validity;
use fringe3d_core::reconstruct::{ReconstructError, Reconstructor, ReferenceMap, ReferenceRing};
use support::*;

const W: usize = 1280;
const H: usize = 1024;

/// Points and codes of camera rows `rows` through `ring`, fed from `rp`/`rv` (codes, or none).
fn stream(
    recon: &Reconstructor,
    ring: &mut ReferenceRing<'_>,
    (rp, rv): (&[f32], Option<&[u8]>),
    (op, ov): (&[f32], &[u8]),
    rows: std::ops::Range<usize>,
) -> (Vec<u32>, Vec<u8>) {
    let (mut xyz, mut out) = (vec![0f32; 3 * W], vec![0u8; W]);
    let (mut bits, mut codes) = (Vec::new(), Vec::new());
    for v in rows {
        let (_, last) = recon.rows_needed(v as u32);
        while ring.rows_pushed() <= last {
            let r = ring.rows_pushed() as usize;
            let codes = rv.map_or(&[][..], |rv| &rv[r * W..(r + 1) * W]);
            ring.push_row(&rp[r * W..(r + 1) * W], codes).unwrap();
        }
        let s = v * W;
        recon
            .reconstruct_row(
                &*ring,
                v as u32,
                &op[s..s + W],
                &ov[s..s + W],
                &mut xyz,
                &mut out,
            )
            .unwrap();
        bits.extend(xyz.iter().map(|x| x.to_bits()));
        codes.extend_from_slice(&out);
    }
    (bits, codes)
}

#[test]
fn a_ring_without_codes_and_a_region_of_interest_give_the_batch_bits() {
    let rig = Rig::default_rig();
    let recon = Reconstructor::new(&rig.cam.model(), &rig.setup()).unwrap();
    let reference = render_reference(&rig);
    let obj = render(&rig, &object(&rig), Bounds::EVERYWHERE, 0..H);
    // Some invalid reference pixels (codes only: their phase stays finite).
    let mut rng = Rng(7);
    let rp = reference.phase.clone();
    let mut rv = reference.validity.clone();
    for q in rv.iter_mut() {
        if rng.uniform() < 0.01 {
            *q = Validity::LowModulation as u8;
        }
    }
    // The batch path, and the same map NaN-encoded (as the desktop's TIFF stores it).
    let mut prep = rp.clone();
    let m = ReferenceMap::prepare(&mut prep, &rv, W, H).unwrap();
    let (mut bxyz, mut bval) = (vec![0f32; 3 * W * H], vec![0u8; W * H]);
    recon
        .reconstruct_frame(&m, &obj.phase, &obj.validity, &mut bxyz, &mut bval)
        .unwrap();
    let batch = |rows: std::ops::Range<usize>| {
        let b: Vec<u32> = bxyz[3 * rows.start * W..3 * rows.end * W]
            .iter()
            .map(|x| x.to_bits())
            .collect();
        (b, bval[rows.start * W..rows.end * W].to_vec())
    };
    assert!(bval.iter().filter(|&&c| c == 0).count() > W * H / 4);

    let band = recon.band().rows() as usize;
    let obj = (&obj.phase[..], &obj.validity[..]);
    // No validity plane, rows pushed with their codes.
    let mut ring_p = vec![0f32; band * W];
    let mut ring = ReferenceRing::new(&recon, &mut ring_p, &mut []).unwrap();
    assert_eq!(
        stream(&recon, &mut ring, (&rp, Some(&rv)), obj, 0..H),
        batch(0..H),
        "no codes kept"
    );
    assert_eq!(ring.validity_row(H as u32 - 1), None);

    // No validity plane, NaN-encoded rows pushed without codes.
    ring.reset();
    assert_eq!(
        stream(&recon, &mut ring, (&prep, None), obj, 0..H),
        batch(0..H),
        "NaN-encoded rows without codes"
    );

    // A region of interest: camera rows 600.. only, the ring started at the first row they need.
    let v0 = 600;
    ring.reset();
    ring.start_at(recon.rows_needed(v0 as u32).0).unwrap();
    assert_eq!(
        stream(&recon, &mut ring, (&rp, Some(&rv)), obj, v0..H),
        batch(v0..H),
        "region of interest"
    );
}

#[test]
fn misuse_is_refused() {
    let rig = Rig::default_rig();
    let recon = Reconstructor::new(&rig.cam.model(), &rig.setup()).unwrap();
    let band = recon.band().rows() as usize;
    let mut ring_p = vec![0f32; band * W];
    let mut short_codes = vec![0u8; W];
    // A validity plane, when given, must cover the ring.
    assert_eq!(
        ReferenceRing::new(&recon, &mut ring_p, &mut short_codes).unwrap_err(),
        ReconstructError::BufferTooSmall
    );
    let mut ring = ReferenceRing::new(&recon, &mut ring_p, &mut []).unwrap();
    let row = vec![0.5f32; W];
    // Codes of the wrong length.
    assert_eq!(
        ring.push_row(&row, &[0u8; 3]),
        Err(ReconstructError::Length)
    );
    ring.push_row(&row, &[]).unwrap();
    // Not while rows are held, and not past the map.
    assert_eq!(ring.start_at(10), Err(ReconstructError::Sequence));
    ring.reset();
    assert_eq!(ring.start_at(H as u32 + 1), Err(ReconstructError::Sequence));
    ring.start_at(10).unwrap();
    assert_eq!(ring.rows_pushed(), 10);
    ring.push_row(&row, &[]).unwrap();
    // Rows before the start are never held.
    assert_eq!(
        fringe3d_core::reconstruct::ReferenceRows::row(&ring, 9),
        None
    );
    assert!(fringe3d_core::reconstruct::ReferenceRows::row(&ring, 10).is_some());
}
