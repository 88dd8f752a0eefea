//! Golden vectors (`fringe3d vectors`): deterministic bytes, an intact manifest, and the desktop
//! batch paths (whole-frame decode on all threads with the widest kernel, parallel reconstruction
//! over the whole reference map, the whole-cloud edge filter) reproduce every stage's digest.

use crate::common::{
    ballbar_u8_with, coprime_set, gray_inverse_set, gray_set, gray_shifted_set, heterodyne_set,
    small_u8,
};
use fringe3d::batch::{FrameOut, Isa, decode_frames};
use fringe3d::scan::{ScanCalibration, filter_edges};
use fringe3d::vectors::{self, Dtype, GoldenVectors, VectorOptions, VectorReference};
use fringe3d_core::decode::{Decoder, Sample, State};
use fringe3d_core::pattern::{MAX_LEVELS, PatternSet};
use std::path::{Path, PathBuf};

fn scratch(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("fringe3d-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}

fn sha(v: &GoldenVectors, path: &str) -> String {
    let e = v.manifest();
    let files = e["files"].as_array().expect("manifest lists files");
    let f = files
        .iter()
        .find(|f| f["path"] == path)
        .unwrap_or_else(|| panic!("{path} not in the manifest"));
    f["sha256"]
        .as_str()
        .expect("sha256 is a string")
        .to_string()
}

fn f32s(b: &[u8]) -> Vec<f32> {
    b.chunks_exact(4)
        .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
        .collect()
}

#[test]
fn vectors_are_deterministic_and_the_manifest_holds() {
    let opts = VectorOptions::default();
    let a = scratch("vectors-a");
    let b = scratch("vectors-b");
    let va = vectors::generate_into(&opts, &a, false).expect("vectors a");
    let vb = vectors::generate_into(&opts, &b, false).expect("vectors b");
    // Same options, same bytes: every file, the manifest included.
    assert_eq!(
        va.files.len(),
        21,
        "files: {:?}",
        va.files.iter().map(|f| &f.path).collect::<Vec<_>>()
    );
    let diff = vectors::compare(&va, &vb);
    assert!(diff.is_empty(), "two runs differ: {diff:?}");
    assert_eq!(
        std::fs::read(a.join("manifest.json")).unwrap(),
        std::fs::read(b.join("manifest.json")).unwrap()
    );
    assert!(vectors::check_dir(&a).unwrap().is_empty());

    // Shapes and sizes agree with the manifest's formats.
    let m = va.manifest();
    for f in m["files"].as_array().unwrap() {
        if let (Some(dt), Some(shape)) = (f["dtype"].as_str(), f["shape"].as_array()) {
            let size = match dt {
                "u8" => 1,
                "u16" => 2,
                "f32" => 4,
                other => panic!("dtype {other}"),
            };
            let n: u64 = shape.iter().map(|s| s.as_u64().unwrap()).product();
            assert_eq!(f["bytes"].as_u64().unwrap(), n * size, "{}", f["path"]);
            assert_eq!(f["order"], "C");
        }
    }
    // Every NaN is canonical, and invalid pixels are NaN, valid ones finite.
    for p in [
        "decode/phase.f32",
        "reconstruct/points.f32",
        "filter/points.f32",
        "decode/wrapped_level0.f32",
        "input/reference_phase.f32",
    ] {
        let v = f32s(&va.file(p).unwrap().bytes);
        assert!(
            v.iter().all(|x| !x.is_nan() || x.to_bits() == 0x7fc0_0000),
            "{p}: non-canonical NaN"
        );
    }
    // The map as a head stores it: a checked file whose samples are reference_phase.f32's.
    let map_file = &va.file("input/reference.f3m").unwrap().bytes;
    let rf = fringe3d_core::wire::ReferenceFile::check(map_file).expect("a valid map file");
    assert_eq!(
        &map_file[rf.samples_range()],
        &va.file("input/reference_phase.f32").unwrap().bytes[..]
    );
    let phase = f32s(&va.file("decode/phase.f32").unwrap().bytes);
    let val = &va.file("decode/validity.u8").unwrap().bytes;
    assert!(
        phase
            .iter()
            .zip(val.iter())
            .all(|(p, v)| (*v == 0) == p.is_finite())
    );
    let fval = &va.file("filter/validity.u8").unwrap().bytes;
    let valid = fval.iter().filter(|v| **v == 0).count();
    let edges = fval.iter().filter(|v| **v == 10).count();
    assert!(
        valid > 50_000 && edges > 0,
        "the scan should have many valid points ({valid}) and some depth edges ({edges})"
    );

    // A corrupted file is caught by the manifest.
    let victim = a.join("reconstruct/points.f32");
    let mut bytes = std::fs::read(&victim).unwrap();
    bytes[1000] ^= 1;
    std::fs::write(&victim, &bytes).unwrap();
    let bad = vectors::check_dir(&a).unwrap();
    assert_eq!(bad.len(), 1);
    assert_eq!(bad[0].path, "reconstruct/points.f32");
    let _ = std::fs::remove_dir_all(&a);
    let _ = std::fs::remove_dir_all(&b);
}

/// Whole-frame per-level outputs: accumulate every image over whole planes, then
/// `Decoder::finish_level` (another driver than the vectors' 64-pixel row blocks).
/// Each level's wrapped phase and modulation from whole frames (the frame-sequential path's
/// accumulation); a Gray-code level has none (empty planes), and its images are not folded.
fn levels_whole_frame<P: Sample>(
    dec: &Decoder,
    set: &PatternSet,
    frames: &[&[P]],
    n: usize,
) -> Vec<(Vec<f32>, Vec<f32>)> {
    let mut dc = vec![0.0f32; n];
    let mut s: Vec<Vec<f32>> = vec![vec![0.0; n]; MAX_LEVELS];
    let mut c: Vec<Vec<f32>> = vec![vec![0.0; n]; MAX_LEVELS];
    let mut flags = vec![0u8; n];
    let mut out = Vec::new();
    {
        let mut si = s.iter_mut();
        let mut ci = c.iter_mut();
        let s_arr: [&mut [f32]; MAX_LEVELS] =
            std::array::from_fn(|_| si.next().unwrap().as_mut_slice());
        let c_arr: [&mut [f32]; MAX_LEVELS] =
            std::array::from_fn(|_| ci.next().unwrap().as_mut_slice());
        let mut st = State {
            dc: &mut dc,
            s: s_arr,
            c: c_arr,
            flags: &mut flags,
        };
        for (i, f) in frames.iter().enumerate() {
            if set.gray().is_some() && set.image(i).is_some_and(|id| id.level == 0) {
                continue;
            }
            dec.accumulate(i, f, &mut st).expect("accumulate");
        }
        for l in 0..dec.level_count() {
            if !dec.level_has_phase(l) {
                out.push((Vec::new(), Vec::new()));
                continue;
            }
            let mut w = vec![0.0f32; n];
            let mut m = vec![0.0f32; n];
            dec.finish_level(&st, l, &mut w, &mut m)
                .expect("finish_level");
            out.push((w, m));
        }
    }
    out
}

fn check_batch(opts: &VectorOptions, name: &str) -> (ScanCalibration, Vec<f32>, Vec<u8>) {
    let dir = scratch(name);
    let v = vectors::generate_into(opts, &dir, false).expect("vectors");
    let (w, h) = (v.width, v.height);
    let n = w * h;
    // Everything the desktop needs comes from the folder, through the project's file formats.
    let set = fringe3d::io::pattern_file::PatternSetFile::load(&dir.join("input/patterns.toml"))
        .unwrap()
        .to_pattern_set()
        .unwrap();
    let cal = ScanCalibration::load(&dir.join("input/calibration.toml"), set.axis())
        .expect("calibration from the vectors");
    let bits = v.info["scene"]["camera_bits"].as_u64().unwrap() as u32;
    let mut dec = Decoder::new(
        &set,
        fringe3d_core::decode::DecodeConfig::for_bit_depth(bits),
    )
    .unwrap();
    // The phase-error table, from the folder's calibration as `fringe3d scan` makes it (a
    // projector response, a binary set's blur): the same as the set-up blob's.
    let file =
        fringe3d::io::pattern_file::PatternSetFile::load(&dir.join("input/patterns.toml")).unwrap();
    let c = &cal.calibration;
    if let Some(t) = fringe3d::calib::files::response_table_for(
        &file,
        &set,
        c.projector_response.as_ref(),
        c.projector_defocus,
    )
    .unwrap()
    {
        dec = dec.with_correction(&t).unwrap();
    }
    let img = v
        .files
        .iter()
        .find(|f| f.path.starts_with("input/images."))
        .unwrap();
    let (dtype, shape) = img.array.clone().unwrap();
    assert_eq!(shape, vec![set.image_count(), h, w]);
    let mut phase = vec![0.0f32; n];
    let mut modulation = vec![0.0f32; n];
    let mut dc = vec![0.0f32; n];
    let mut validity = vec![0u8; n];
    let out = FrameOut {
        phase: &mut phase,
        modulation: &mut modulation,
        dc: &mut dc,
        validity: &mut validity,
    };
    let levels = match dtype {
        Dtype::U8 => {
            let fr: Vec<&[u8]> = img.bytes.chunks_exact(n).collect();
            decode_frames(&dec, &fr, w, h, out, Isa::detect(), true).unwrap();
            levels_whole_frame(&dec, &set, &fr, n)
        }
        Dtype::U16 => {
            let all: Vec<u16> = img
                .bytes
                .chunks_exact(2)
                .map(|c| u16::from_le_bytes([c[0], c[1]]))
                .collect();
            let fr: Vec<&[u16]> = all.chunks_exact(n).collect();
            decode_frames(&dec, &fr, w, h, out, Isa::detect(), true).unwrap();
            levels_whole_frame(&dec, &set, &fr, n)
        }
        Dtype::F32 => panic!("images are integers"),
    };
    let mut cloud = cal
        .reconstruct(&phase, &validity, true)
        .expect("batch reconstruction");
    let unfiltered = (vectors::f32_bytes(&cloud.xyz), cloud.validity.clone());
    filter_edges(&mut cloud, &cal.edge_filter(opts.max_angle_deg).unwrap());

    let mut got: Vec<(String, Vec<u8>)> = vec![
        ("decode/phase.f32".into(), vectors::f32_bytes(&phase)),
        (
            "decode/modulation.f32".into(),
            vectors::f32_bytes(&modulation),
        ),
        ("decode/dc.f32".into(), vectors::f32_bytes(&dc)),
        ("decode/validity.u8".into(), validity.clone()),
        ("reconstruct/points.f32".into(), unfiltered.0),
        ("reconstruct/validity.u8".into(), unfiltered.1),
        ("filter/points.f32".into(), vectors::f32_bytes(&cloud.xyz)),
        ("filter/validity.u8".into(), cloud.validity.clone()),
    ];
    for (l, (wr, m)) in levels.iter().enumerate() {
        if wr.is_empty() {
            continue;
        }
        got.push((
            format!("decode/wrapped_level{l}.f32"),
            vectors::f32_bytes(wr),
        ));
        got.push((
            format!("decode/modulation_level{l}.f32"),
            vectors::f32_bytes(m),
        ));
    }
    let phase_levels = (0..dec.level_count())
        .filter(|&l| dec.level_has_phase(l))
        .count();
    assert_eq!(got.len(), 8 + 2 * phase_levels);
    let mut bad = Vec::new();
    for (path, bytes) in &got {
        if vectors::sha256_hex(bytes) != sha(&v, path) {
            bad.push(format!(
                "{path}: {}",
                vectors::first_difference(v.file(path).unwrap(), bytes)
            ));
        }
    }
    assert!(
        bad.is_empty(),
        "desktop batch outputs differ from the golden vectors:\n{}",
        bad.join("\n")
    );
    let _ = std::fs::remove_dir_all(Path::new(&dir));
    (cal, phase, validity)
}

#[test]
fn vectors_match_the_desktop_batch_paths_u16() {
    check_batch(&VectorOptions::default(), "vectors-batch16");
}

#[test]
fn vectors_match_the_desktop_batch_paths_u8() {
    check_batch(&small_u8("steps", 7), "vectors-batch8");
}

/// Issue #17 item 5: with the fitted model of the capture and with the virtual map as the
/// reference, the golden vectors (the row drivers) and the desktop's batch paths give the same
/// bits (the QEMU test checks the board on the same two).
#[test]
fn vectors_match_the_desktop_batch_paths_with_model_and_virtual_references() {
    for reference in [VectorReference::Model, VectorReference::Virtual] {
        check_batch(
            &ballbar_u8_with(reference),
            &format!("vectors-batch-{}", reference.name()),
        );
    }
}

/// Issue #17 items 3 and 5: the virtual map on the default far plane with the margin the
/// geometry needs (a map wider than the image, as a head takes it since protocol version 6):
/// the golden vectors equal the desktop's batch paths, and the margin carries points, which
/// the same map cropped to the image loses.
#[test]
fn vectors_match_the_desktop_batch_paths_with_a_map_wider_than_the_image() {
    let reference = VectorReference::VirtualMargin;
    let (cal, phase, validity) = check_batch(
        &ballbar_u8_with(reference),
        &format!("vectors-batch-{}", reference.name()),
    );
    let m = cal.recon.margin();
    assert_ne!(m, fringe3d_core::reconstruct::Margin::ZERO);
    let valid = |c: &ScanCalibration| {
        c.reconstruct(&phase, &validity, true)
            .unwrap()
            .valid_count()
    };
    let (w, h) = (cal.width(), cal.height());
    let mw = cal.recon.map_width();
    let (l, t) = (m.left as usize, m.top as usize);
    let cropped: Vec<f32> = (0..h)
        .flat_map(|y| cal.reference_phase[(t + y) * mw + l..(t + y) * mw + l + w].to_vec())
        .collect();
    let mut file = cal.calibration.clone();
    if let Some(r) = file.reference.as_mut() {
        r.margin = None;
    }
    let image_sized =
        ScanCalibration::from_parts(file, cropped, cal.recon.setup().axis, Path::new("cropped"))
            .unwrap();
    let (with, without) = (valid(&cal), valid(&image_sized));
    println!(
        "margin {:?}: {with} points, {without} with the map cropped to the image",
        m.to_array()
    );
    assert!(with > without + 100, "{with} against {without}");
}

#[test]
fn vectors_match_the_desktop_batch_paths_with_tables_and_gray_codes() {
    // A projector of gamma 2.2, blurred by 2 pixels: the folder's calibration carries the
    // response and the blur, the batch path's table is the set-up blob's.
    let gamma = VectorOptions {
        gamma: Some(2.2),
        defocus: Some(2.0),
        ..small_u8("steps", 7)
    };
    check_batch(&gamma, "vectors-batch-gamma");
    // A complementary Gray code + 4-step set, gray-level and Bayer-dithered (σ = 3).
    for (binary, defocus) in [("off", None), ("bayer", Some(3.0))] {
        let opts = VectorOptions {
            patterns: Some(gray_set(binary)),
            defocus,
            ..small_u8("sphere", 5)
        };
        check_batch(&opts, &format!("vectors-batch-gray-{binary}"));
    }
    // A two-frequency heterodyne set (the set-up blob's version 4 carries its relation).
    let opts = VectorOptions {
        patterns: Some(heterodyne_set()),
        ..small_u8("sphere", 6)
    };
    check_batch(&opts, "vectors-batch-heterodyne");
    // And a coprime pair (relation [2]).
    let opts = VectorOptions {
        patterns: Some(coprime_set()),
        ..small_u8("sphere", 8)
    };
    check_batch(&opts, "vectors-batch-coprime");
    // A Gray code with inverse patterns (Shifts::GrayInverse).
    let opts = VectorOptions {
        patterns: Some(gray_inverse_set()),
        ..small_u8("sphere", 9)
    };
    check_batch(&opts, "vectors-batch-gray-inverse");
    // A shifted Gray code (Shifts::GrayShifted).
    let opts = VectorOptions {
        patterns: Some(gray_shifted_set()),
        ..small_u8("sphere", 10)
    };
    check_batch(&opts, "vectors-batch-gray-shifted");
}

#[test]
fn vectors_cli_writes_and_verifies() {
    let dir = scratch("vectors-cli");
    let d = dir.to_str().expect("UTF-8 temp path");
    let args = [
        "fringe3d", "vectors", "--out", d, "--size", "96x80", "--scene", "sphere", "-q",
    ];
    fringe3d::cli::run(args).expect("fringe3d vectors");
    assert!(dir.join("manifest.json").exists() && dir.join("input/setup.bin").exists());
    // Writing again over a non-empty folder needs --overwrite.
    assert!(fringe3d::cli::run(args).is_err());
    let verify = [
        "fringe3d", "vectors", "--out", d, "--size", "96x80", "--scene", "sphere", "--verify", "-q",
    ];
    fringe3d::cli::run(verify).expect("an untouched folder verifies");
    // Other options give other vectors: verification fails.
    let other = [
        "fringe3d", "vectors", "--out", d, "--size", "96x80", "--scene", "sphere", "--noise", "2",
        "--verify", "-q",
    ];
    assert!(fringe3d::cli::run(other).is_err());
    // A changed byte fails too.
    let p = dir.join("decode/phase.f32");
    let mut b = std::fs::read(&p).unwrap();
    b[8] ^= 0x80;
    std::fs::write(&p, &b).unwrap();
    assert!(fringe3d::cli::run(verify).is_err());
    let _ = std::fs::remove_dir_all(&dir);
}
