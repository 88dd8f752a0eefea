//! The frame store (`frame_store::FrameStore`, issue #23 item 4): a set's frames kept as the camera
//! delivers them, N bytes a pixel for N 8-bit images, decoded row by row with the same bits as
//! the row path and as the frame-sequential accumulators (three drivers, one kernel), on noisy
//! synthetic frames of the paper's set.

use crate::common::{self, Pixel, Rng};
use fringe3d_core::decode::{DecodeConfig, DecodeError, DecodeScratch, Decoder, RowOut};
use fringe3d_core::frame_store::FrameStore;
use fringe3d_core::sequential::FrameDecoder;

#[test]
fn the_frame_store_decodes_the_row_paths_bits_in_n_bytes_a_pixel() {
    let set = common::paper_set();
    let d = Decoder::new(&set, DecodeConfig::for_bit_depth(8)).unwrap();
    let (w, h, n) = (150usize, 5usize, set.image_count());
    let mut rng = Rng(41);
    // Frames, set order: each w × h, row by row from the f64 model with noise; some pixels
    // dark or saturated so that every code path has work.
    let mut frames = vec![vec![0u8; w * h]; n];
    for v in 0..h {
        let pixels: Vec<Pixel> = (0..w)
            .map(|u| Pixel {
                a: if u % 37 == 5 {
                    3.0
                } else {
                    120.0 + 10.0 * v as f64
                },
                b: if u % 41 == 7 { 200.0 } else { 80.0 },
                phi_p: 0.03 * u as f64 + 0.2 * v as f64,
            })
            .collect();
        let imgs = common::to_u8(&common::images(&set, &pixels, 1.5, 255.0, &mut rng));
        for (f, img) in frames.iter_mut().zip(&imgs) {
            f[v * w..(v + 1) * w].copy_from_slice(img);
        }
    }
    // The store: N bytes a pixel, against the accumulators' 29 for this 3-level set.
    assert_eq!(FrameStore::<u8>::bytes_per_pixel(n), 8);
    assert_eq!(FrameDecoder::bytes_per_pixel(set.levels().len()), 29);
    let mut buf = vec![0u8; n * w * h];
    assert_eq!(
        FrameStore::new(&d, &mut buf[..n * w * h - 1], w, h).err(),
        Some(DecodeError::StateTooSmall)
    );
    let mut store = FrameStore::new(&d, &mut buf, w, h).unwrap();
    // Frame 0 row by row (a camera that streams rows), the others whole (a DMA target).
    for v in 0..h {
        store
            .push_row(0, v, &frames[0][v * w..(v + 1) * w])
            .unwrap();
    }
    assert_eq!(
        store.push_row(0, h, &frames[0][..w]),
        Err(DecodeError::Sequence)
    );
    assert_eq!(
        store.push_row(n, 0, &frames[0][..w]),
        Err(DecodeError::ImageCount)
    );
    for (i, f) in frames.iter().enumerate().skip(1) {
        store.frame_mut(i).unwrap().copy_from_slice(f);
    }
    assert!(store.frame_mut(n).is_none());

    let (seq_bits, seq_codes) = common::frame_sequential(&d, &frames, w, h);
    let mut scratch = DecodeScratch::new();
    let mut direct = DecodeScratch::new();
    for v in 0..h {
        let (mut p, mut m, mut a, mut q) =
            (vec![0f32; w], vec![0f32; w], vec![0f32; w], vec![0; w]);
        let out = RowOut {
            phase: &mut p,
            modulation: &mut m,
            dc: &mut a,
            validity: &mut q,
        };
        store.decode_row(&d, &mut scratch, v, out).unwrap();
        // The row path over the same rows.
        let rows: Vec<&[u8]> = frames.iter().map(|f| &f[v * w..(v + 1) * w]).collect();
        let (mut p2, mut m2, mut a2, mut q2) =
            (vec![0f32; w], vec![0f32; w], vec![0f32; w], vec![0; w]);
        let out = RowOut {
            phase: &mut p2,
            modulation: &mut m2,
            dc: &mut a2,
            validity: &mut q2,
        };
        d.decode_row_with(&mut direct, &rows, out).unwrap();
        let bits = |x: &[f32]| x.iter().map(|f| f.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&p), bits(&p2), "row {v}: phase");
        assert_eq!(bits(&m), bits(&m2), "row {v}: modulation");
        assert_eq!(bits(&a), bits(&a2), "row {v}: DC");
        assert_eq!(q, q2, "row {v}: validity");
        // ... and the frame-sequential accumulators.
        assert_eq!(
            bits(&p),
            seq_bits[v * w..(v + 1) * w],
            "row {v}: accumulators"
        );
        assert_eq!(
            q,
            seq_codes[v * w..(v + 1) * w],
            "row {v}: accumulators' codes"
        );
        assert!(
            q.contains(&0) && q.iter().any(|&c| c != 0),
            "row {v}: {q:?}"
        );
    }
    let out = RowOut {
        phase: &mut [0f32; 150],
        modulation: &mut [],
        dc: &mut [],
        validity: &mut [0; 150],
    };
    assert_eq!(
        store.decode_row(&d, &mut scratch, h, out),
        Err(DecodeError::Sequence)
    );
}
