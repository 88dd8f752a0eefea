//! The compiled reconstruction on the head (issue #24 item 1, protocol version 10): the models of
//! `fringe3d compile` go over the link after the calibration and the reference map they were
//! compiled from (`Client::upload_compiled`, what `fringe3d device upload --compiled` sends),
//! the head reads them row by row from its map store and reconstructs the pixels that have one
//! without the search. Its points equal, bit for bit, those of the desktop's `scan --compiled`
//! path (`ScanCalibration::with_compiled`), which differ from the search's (so the head cannot
//! pass by ignoring the models). The head refuses the models before their map, and forgets them
//! when the map is replaced: it then scans with the search, bit for bit the desktop's. After a
//! new calibration it scans with that one, not with the reconstructor it kept from the last
//! scan. Status says at each step what the head holds (calibration, map, models), and ScanDone
//! how many decoded pixels the search computed (protocol version 11): those the models left, as
//! the desktop's kernel leaves them, and every one without the models.

use std::path::Path;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

use fringe3d::compiled::CompiledFile;
use fringe3d::device::{Client, DeviceError, ScanOutcome, open_serial};
use fringe3d::scan::{ScanCalibration, ScanCounts, filter_edges};
use fringe3d_core::math::canonical;
use fringe3d_core::reconstruct::compiled::FIELDS;
use fringe3d_core::wire::{EdgeFilterMode, Holds, NakCode, ScanOutput, ValidationStatus};

use crate::head_pty::{
    CAM, Cmd, assert_desktop_bits, dataset, fresh_root, head_case, head_case_with, opts, scan_both,
    spawn_head_series, virtual_reference,
};

/// ScanDone's counts as the host reports them: `decoded` and `searched` pixels, or none when rows
/// were requested again (from another capture).
fn assert_counts(out: &ScanOutcome, decoded: usize, searched: usize) {
    let want = ScanCounts { decoded, searched };
    match out.rescans {
        0 => assert_eq!(out.counts, Some(want), "the head's ScanDone counts"),
        _ => assert_eq!(out.counts, None, "counts after rows requested again"),
    }
}

#[test]
fn compiled_models_reconstruct_on_the_head_bit_identical_to_the_desktop() {
    let root = fresh_root("compiled");
    let dir = dataset(&root);
    let s = |p: &Path| p.to_str().unwrap().to_string();
    let (patterns, cal) = (dir.join("patterns.toml"), dir.join("calibration.toml"));
    let f3c = dir.join("reconstruction.f3c");
    // A model of the reference (a captured map's noise compiles nothing), then its models at
    // 1 µm: at 320 x 256 the map's bilinear cells are too coarse for most pixels at 0.1 µm
    // (docs/compiled.md, "How close to the search").
    let run = |args: &[&str]| fringe3d::cli::run(args.iter().copied()).unwrap();
    virtual_reference(&dir, "auto", &cal);
    run(&[
        "fringe3d",
        "--quiet",
        "compile",
        "-p",
        &s(&patterns),
        "-c",
        &s(&cal),
        "--tolerance",
        "1",
        "-o",
        &s(&f3c),
    ]);
    let case = head_case(&dir);
    let file = CompiledFile::read(&f3c, CAM.0, CAM.1).unwrap();
    let pixels = (CAM.0 * CAM.1) as usize;
    assert!(
        file.compiled_count() > pixels / 2,
        "{} of {pixels} pixels compiled",
        file.compiled_count()
    );
    // The desktop's compiled scan, as `fringe3d scan --compiled` computes it.
    let sc = ScanCalibration::load(&cal, case.set.axis())
        .unwrap()
        .with_compiled(&f3c)
        .unwrap();
    let mut compiled = sc
        .reconstruct(&case.dec.phase, &case.dec.validity, true)
        .unwrap();
    filter_edges(&mut compiled, &sc.edge_filter(80.0).unwrap());
    let bits = |v: &[f32]| {
        v.iter()
            .map(|x| canonical(*x).to_bits())
            .collect::<Vec<_>>()
    };
    let (a, b) = (bits(&compiled.xyz), bits(&case.cloud.xyz));
    let differ = a.chunks(3).zip(b.chunks(3)).filter(|(p, q)| p != q).count();
    assert!(
        differ > compiled.valid_count() / 10,
        "the compiled points differ from the search's at {differ} pixels of {} valid: too few \
         to tell whether the head used the models",
        compiled.valid_count()
    );
    let data: Vec<u8> = file
        .models
        .iter()
        .flat_map(|v| canonical(*v).to_le_bytes())
        .collect();
    let g = &case.wcal.geometry;
    let z = (g.depth_min as f32, g.depth_max as f32);
    let (w, h) = (CAM.0 as u16, CAM.1 as u16);

    let stop = Arc::new(AtomicBool::new(false));
    let (paths, cmd, head) = spawn_head_series(vec![(10_000, dir.clone())], stop.clone());
    let port = paths.recv().unwrap();
    let mut c = Client::connect(open_serial(&port, 921_600).unwrap(), opts()).unwrap();
    // What the head holds, as Status reports it (protocol version 10), step by step.
    let holds = |c: &mut Client<_>| c.status().unwrap().holds;
    assert_eq!(holds(&mut c), Holds(0));
    c.define_pattern_set(0, &case.desc).unwrap();
    c.define_correction(0, case.table.as_ref()).unwrap();
    c.upload_calibration(&case.wcal).unwrap();
    assert_eq!(holds(&mut c), Holds(Holds::CALIBRATION));
    // Before their map: refused, naming what is missing.
    match c.upload_compiled(w, h, z, &data, &mut |_, _| {}) {
        Err(DeviceError::Refused {
            code,
            detail,
            reason,
            ..
        }) => {
            assert_eq!(code, NakCode::NotReady);
            assert_eq!(u32::from(detail), ValidationStatus::NO_REFERENCE);
            assert!(reason.ends_with("not got the reference map"), "{reason}");
        }
        r => panic!("models before their map: {:?}", r.map(|_| ())),
    }
    c.upload_phase_map(w, h, case.margin, &case.map, &mut |_, _| {})
        .unwrap();
    let held = Holds(Holds::CALIBRATION | Holds::REFERENCE);
    assert_eq!(holds(&mut c), held);
    // Another depth range than the calibration's: refused.
    match c.upload_compiled(w, h, (z.0, z.1 + 1.0), &data, &mut |_, _| {}) {
        Err(DeviceError::Refused { code, .. }) => assert_eq!(code, NakCode::Invalid),
        r => panic!("models of another depth range: {:?}", r.map(|_| ())),
    }
    assert_eq!(holds(&mut c), held, "refused models are not held");
    let r = c.upload_compiled(w, h, z, &data, &mut |_, _| {}).unwrap();
    assert_eq!(r.total, data.len() as u64);
    assert_eq!(holds(&mut c), Holds(Holds::ALL));
    c.configure_sequence(0, false, &case.seq).unwrap();
    assert_eq!(c.validate().unwrap(), ValidationStatus::OK);
    // What the desktop's kernel leaves to the search in this scan (the fallback rate).
    let decoded = case.dec.validity.iter().filter(|&&q| q == 0).count();
    let left = file
        .left_to_search(&case.dec.phase, &case.dec.validity)
        .unwrap()
        .len();
    assert!(
        left < decoded / 2,
        "{left} of {decoded} pixels left to the search"
    );
    let out = scan_both(&mut c);
    assert_desktop_bits(&out, &case.dec, &compiled);
    assert_counts(&out, decoded, left);
    // The first scan found every row settled: the second reads them as they are, the same bits.
    let out = scan_both(&mut c);
    assert_desktop_bits(&out, &case.dec, &compiled);
    assert_counts(&out, decoded, left);
    // Rows 100..137 with the edge filter: the head reconstructs rows 99 and 137 too, but counts
    // the rows it streams only.
    let (first, rows) = (100usize, 37usize);
    let part = c
        .scan(
            ScanOutput::Points,
            first as u16,
            rows as u16,
            EdgeFilterMode::MaxAngle(80.0),
            &mut |_, _| {},
        )
        .unwrap();
    let wu = CAM.0 as usize;
    let span = first * wu..(first + rows) * wu;
    let part_decoded = case.dec.validity[span.clone()].iter().filter(|&&q| q == 0);
    let in_span = |i: &&usize| span.contains(*i);
    let part_left = file
        .left_to_search(&case.dec.phase, &case.dec.validity)
        .unwrap();
    let part_left = part_left.iter().filter(in_span).count();
    assert!(
        part_left > 0,
        "no pixel of rows {first}.. left to the search"
    );
    assert_counts(&part, part_decoded.count(), part_left);
    // Models a foreign host might send: pixels left to the search given a neighbour's finite
    // numbers with a NaN d₂ (usable in nothing but their scale: `PixelModel::from_array` makes
    // them the search's again). The head must settle them at every scan, not only the first.
    let (wu, mut data2, mut unsettled) = (w as usize, file.models.clone(), 0);
    for v in 0..h as usize {
        let row = &mut data2[v * FIELDS * wu..(v + 1) * FIELDS * wu];
        for u in 0..wu - 1 {
            let (k, k_next) = (row[3 * wu + u], row[3 * wu + u + 1]);
            if k.is_nan() && k_next.is_finite() && k_next != 0.0 && unsettled < 200 {
                for f in 0..FIELDS {
                    row[f * wu + u] = row[f * wu + u + 1];
                }
                row[7 * wu + u] = f32::NAN;
                unsettled += 1;
            }
        }
    }
    assert!(unsettled >= 20, "{unsettled} models to settle");
    let data2: Vec<u8> = data2.iter().flat_map(|v| v.to_le_bytes()).collect();
    c.upload_compiled(w, h, z, &data2, &mut |_, _| {}).unwrap();
    for _ in 0..3 {
        assert_desktop_bits(&scan_both(&mut c), &case.dec, &compiled);
    }
    c.upload_compiled(w, h, z, &data, &mut |_, _| {}).unwrap();
    // The map again: the models were compiled from the map it replaces, so the head forgets
    // them and scans with the search.
    c.upload_phase_map(w, h, case.margin, &case.map, &mut |_, _| {})
        .unwrap();
    assert_eq!(holds(&mut c), held, "the models went with their map");
    let out = scan_both(&mut c);
    assert_desktop_bits(&out, &case.dec, &case.cloud);
    assert_counts(&out, decoded, decoded);
    // The head keeps the last scan's reconstructor: a scan after a new calibration must not
    // use it. The projector 1 mm to the side moves every point.
    let moved = dir.join("calibration_moved.toml");
    let text = std::fs::read_to_string(&cal).unwrap();
    assert_eq!(text.matches("[225.0, -12.0, 6.0]").count(), 2, "{text}");
    std::fs::write(
        &moved,
        text.replace("[225.0, -12.0, 6.0]", "[226.0, -12.0, 6.0]"),
    )
    .unwrap();
    let case2 = head_case_with(&dir, &moved);
    let differ = bits(&case2.cloud.xyz)
        .chunks(3)
        .zip(bits(&case.cloud.xyz).chunks(3))
        .filter(|(p, q)| p != q)
        .count();
    assert!(
        differ > case.cloud.valid_count() / 2,
        "{differ} points moved"
    );
    c.upload_calibration(&case2.wcal).unwrap();
    assert_desktop_bits(&scan_both(&mut c), &case2.dec, &case2.cloud);
    drop(c);
    stop.store(true, Ordering::SeqCst);
    cmd.send(Cmd::Exit).unwrap();
    let report = head.join().unwrap();
    // The scan with the models staged a row of them and the search's buffers.
    assert!(
        report.lines >= CAM.0 as usize * (4 * 14 + 2),
        "line buffers used: {} bytes",
        report.lines
    );
    let _ = std::fs::remove_dir_all(&root);
}
