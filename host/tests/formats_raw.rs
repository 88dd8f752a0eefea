//! Raw camera frames (PGM `P5`, NumPy `.npy`, headerless `.raw` with a `raw.toml`): read
//! exactly, refused with the reason when bad,
//! and a scan from them gives the bits of the same scan from PNG. The files are written here by
//! hand, from the formats' specifications, not by the readers' code.

use crate::cli_support::{Tmp, fringe3d, npy_file as npy, run, s};
use fringe3d::io::image::{GrayImage, ImageFormat, Pixels, read_gray, read_header};
use std::path::{Path, PathBuf};

/// A PGM file: `header` is everything before the raster (magic, fields, comments, the one
/// whitespace byte after maxval).
fn pgm(header: &str, raster: &[u8]) -> Vec<u8> {
    let mut b = header.as_bytes().to_vec();
    b.extend_from_slice(raster);
    b
}

fn put(dir: &Path, name: &str, bytes: &[u8]) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, bytes).unwrap();
    p
}

fn u16_be(v: &[u16]) -> Vec<u8> {
    v.iter().flat_map(|x| x.to_be_bytes()).collect()
}

fn u16_le(v: &[u16]) -> Vec<u8> {
    v.iter().flat_map(|x| x.to_le_bytes()).collect()
}

#[test]
fn pgm_frames_of_8_12_and_16_bits_are_read_exactly() {
    let t = Tmp::new("raw-pgm");
    let (w, h) = (5u32, 3u32);
    let v8: Vec<u8> = (0..15).map(|i| (i * 17) as u8).collect();
    let v12: Vec<u16> = (0..15).map(|i| (i * 273) as u16).collect(); // up to 3822 ≤ 4095
    let v16: Vec<u16> = (0..15).map(|i| (i * 4681) as u16).collect(); // up to 65534
    // A raster whose first byte is itself whitespace (10 = LF) must not be eaten by the header.
    let mut lf = v8.clone();
    lf[0] = b'\n';
    let cases: Vec<(&str, Vec<u8>, Pixels, u8)> = vec![
        ("a.pgm", pgm("P5 5 3 255\n", &v8), Pixels::U8(v8.clone()), 8),
        (
            "comments.pgm",
            pgm("P5\n# grabber 7\n5\t3 # size\n255\r", &v8),
            Pixels::U8(v8.clone()),
            8,
        ),
        ("lf.pgm", pgm("P5 5 3 255 ", &lf), Pixels::U8(lf.clone()), 8),
        (
            "twelve.pgm",
            pgm("P5\n5 3\n4095\n", &u16_be(&v12)),
            Pixels::U16(v12.clone()),
            12,
        ),
        (
            "sixteen.pgm",
            pgm("P5\n5 3\n65535\n", &u16_be(&v16)),
            Pixels::U16(v16.clone()),
            16,
        ),
    ];
    for (name, bytes, want, bits) in cases {
        let p = put(&t.0, name, &bytes);
        let (img, info) = read_gray(&p).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!(info.format, ImageFormat::Pgm, "{name}");
        assert_eq!(
            img,
            GrayImage {
                width: w,
                height: h,
                pixels: want,
                significant_bits: bits
            },
            "{name}"
        );
        let hd = read_header(&p).unwrap();
        assert_eq!((hd.format, hd.width, hd.height), (ImageFormat::Pgm, w, h));
    }
}

#[test]
fn npy_frames_of_both_byte_orders_and_shapes_are_read_exactly() {
    let t = Tmp::new("raw-npy");
    let v8: Vec<u8> = (0..12).map(|i| (i * 21) as u8).collect();
    let v16: Vec<u16> = (0..12).map(|i| (i * 5000 + 7) as u16).collect();
    let f: Vec<f32> = (0..12).map(|i| i as f32 * 0.25 - 1.0).collect();
    let fb: Vec<u8> = f.iter().flat_map(|x| x.to_le_bytes()).collect();
    let cases: Vec<(&str, Vec<u8>, Pixels, u8)> = vec![
        (
            "u8.npy",
            npy(
                "{'descr': '|u1', 'fortran_order': False, 'shape': (3, 4), }",
                &v8,
            ),
            Pixels::U8(v8.clone()),
            8,
        ),
        (
            "u8x1.npy",
            npy(
                r#"{"descr": "|u1", "fortran_order": False, "shape": (3, 4, 1)}"#,
                &v8,
            ),
            Pixels::U8(v8.clone()),
            8,
        ),
        (
            "le.npy",
            npy(
                "{'descr': '<u2', 'fortran_order': False, 'shape': (3, 4), }",
                &u16_le(&v16),
            ),
            Pixels::U16(v16.clone()),
            16,
        ),
        (
            "be.npy",
            npy(
                "{'descr': '>u2', 'fortran_order': False, 'shape': (3, 4), }",
                &u16_be(&v16),
            ),
            Pixels::U16(v16.clone()),
            16,
        ),
        (
            "f32.npy",
            npy(
                "{'descr': '<f4', 'fortran_order': False, 'shape': (3, 4), }",
                &fb,
            ),
            Pixels::F32(f.clone()),
            32,
        ),
    ];
    for (name, bytes, want, bits) in cases {
        let p = put(&t.0, name, &bytes);
        let (img, info) = read_gray(&p).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!(info.format, ImageFormat::Npy, "{name}");
        assert_eq!(
            img,
            GrayImage {
                width: 4,
                height: 3,
                pixels: want,
                significant_bits: bits
            },
            "{name}"
        );
        let hd = read_header(&p).unwrap();
        assert_eq!((hd.format, hd.width, hd.height), (ImageFormat::Npy, 4, 3));
    }
}

#[test]
fn bad_raw_frames_are_refused_with_the_file_and_the_reason() {
    let t = Tmp::new("raw-bad");
    let d = |descr: &str, shape: &str| {
        format!("{{'descr': '{descr}', 'fortran_order': False, 'shape': {shape}, }}")
    };
    let cases: Vec<(&str, Vec<u8>, &str)> = vec![
        ("short.pgm", pgm("P5 4 4 255\n", &[7; 15]), "truncated"),
        (
            "long.pgm",
            pgm("P5 4 4 255\n", &[7; 17]),
            "one image per file",
        ),
        ("max1000.pgm", pgm("P5 2 2 1000\n", &[0; 8]), "maxval 1000"),
        ("max0.pgm", pgm("P5 2 2 0\n", &[0; 4]), "maxval 0"),
        (
            "over.pgm",
            pgm("P5 2 2 127\n", &[1, 2, 200, 3]),
            "exceeds maxval 127",
        ),
        ("plain.pgm", b"P2 2 2 255\n1 2 3 4\n".to_vec(), "P2"),
        ("nofield.pgm", pgm("P5 4 x 255\n", &[0; 16]), "height"),
        ("empty.pgm", pgm("P5 0 4 255\n", &[]), "empty"),
        (
            "huge.pgm",
            pgm("P5 100000 100000 255\n", &[0; 16]),
            "more than",
        ),
        (
            "bigval.pgm",
            pgm("P5 2 2 70000\n", &[0; 8]),
            "maxval is larger than 65535",
        ),
        (
            "comment.pgm",
            pgm(&format!("P5 #{}\n2 2 255\n", "x".repeat(5000)), &[0; 4]),
            "4096",
        ),
        (
            "rgb.npy",
            npy(&d("|u1", "(2, 2, 3)"), &[0; 12]),
            "not a gray frame",
        ),
        ("f8.npy", npy(&d("<f8", "(2, 2)"), &[0; 32]), "'<f8'"),
        (
            "fortran.npy",
            npy(
                "{'descr': '|u1', 'fortran_order': True, 'shape': (2, 2), }",
                &[0; 4],
            ),
            "Fortran",
        ),
        ("short.npy", npy(&d("<u2", "(2, 2)"), &[0; 7]), "need 8"),
        (
            "overflow.npy",
            npy(&d("|u1", "(99999999999999999999, 2)"), &[0; 4]),
            "bad shape",
        ),
        (
            "huge.npy",
            npy(&d("|u1", "(100000, 100000)"), &[0; 4]),
            "more than",
        ),
        (
            "hdr.npy",
            b"\x93NUMPY\x01\x00\xff\x00{'descr'".to_vec(),
            "truncated header",
        ),
        ("v9.npy", b"\x93NUMPY\x09\x00\x10\x00".to_vec(), "version 9"),
    ];
    for (name, bytes, why) in cases {
        let p = put(&t.0, name, &bytes);
        let e = read_gray(&p).expect_err(name).to_string();
        assert!(
            e.starts_with(s(&p)) && e.contains(why),
            "{name}: expected the path and \"{why}\", got: {e}"
        );
    }
    // Through the binary: one message naming the file, a non-zero exit.
    let bad = t.0.join("short.pgm");
    let out = fringe3d(&["info", s(&bad)]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && err.contains(s(&bad)) && err.contains("PGM"),
        "{err}"
    );
}

/// The rendered frames rewritten as PGM and as NPY scan to the PNG scan's bytes: the readers are
/// exact and the rest of the pipeline cannot tell the formats apart.
#[test]
fn a_scan_from_pgm_or_npy_frames_gives_the_png_scans_bits() {
    let t = Tmp::new("raw-scan");
    let ds = t.0.join("ds");
    run(&[
        "render",
        "-q",
        "--scene",
        "ballbar",
        "--size",
        "320x256",
        "--noise",
        "1",
        "--bits",
        "8",
        "--out",
        s(&ds),
    ]);
    let set = ds.join("patterns.toml");
    let cal = ds.join("calibration.toml");
    let scan = |frames: &[PathBuf], out: &Path| {
        let mut a: Vec<&str> = vec![
            "scan",
            "-q",
            "--patterns",
            s(&set),
            "--calibration",
            s(&cal),
            "-o",
            s(out),
        ];
        a.extend(frames.iter().map(|p| s(p)));
        run(&a);
        std::fs::read(out).unwrap()
    };
    let mut table: toml::Table = std::fs::read_to_string(&set).unwrap().parse().unwrap();
    let names: Vec<String> = table
        .remove("images")
        .and_then(|v| v.as_array().cloned())
        .expect("the rendered pattern file lists its images")
        .iter()
        .filter_map(|v| v.as_str().map(String::from))
        .collect();
    assert_eq!(names.len(), 8, "{names:?}");
    let png: Vec<PathBuf> = names.iter().map(|n| ds.join(n)).collect();
    let (pgm_dir, npy_dir, raw_dir) = (t.0.join("pgm"), t.0.join("npy"), t.0.join("raw"));
    for d in [&pgm_dir, &npy_dir, &raw_dir] {
        std::fs::create_dir_all(d).unwrap();
    }
    let (mut pgms, mut npys, mut raws) = (Vec::new(), Vec::new(), Vec::new());
    for (i, p) in png.iter().enumerate() {
        let (img, _) = read_gray(p).unwrap();
        let Pixels::U8(v) = &img.pixels else {
            panic!("8-bit render expected")
        };
        let (w, h) = (img.width, img.height);
        pgms.push(put(
            &pgm_dir,
            &format!("f{i}.pgm"),
            &pgm(&format!("P5 {w} {h} 255\n"), v),
        ));
        let dict = format!("{{'descr': '|u1', 'fortran_order': False, 'shape': ({h}, {w}), }}");
        npys.push(put(&npy_dir, &format!("f{i}.npy"), &npy(&dict, v)));
        raws.push(put(&raw_dir, &format!("f{i}.raw"), v));
        put(
            &raw_dir,
            "raw.toml",
            format!("width = {w}\nheight = {h}\nbits = 8\n").as_bytes(),
        );
    }
    let from_png = scan(&png, &t.0.join("png.ply"));
    assert!(from_png.len() > 10_000, "the scan found points");
    // (assert!, not assert_eq!: a difference would print megabytes)
    assert!(
        scan(&pgms, &t.0.join("pgm.ply")) == from_png,
        "PGM scan differs"
    );
    assert!(
        scan(&npys, &t.0.join("npy.ply")) == from_png,
        "NPY scan differs"
    );
    assert!(
        scan(&raws, &t.0.join("raw.ply")) == from_png,
        "headerless raw scan differs"
    );
    // A folder of NPY frames is read as one (sorted by name: f0..f7 are in set order) when the
    // pattern file names no images.
    let bare = t.0.join("patterns.toml");
    std::fs::write(&bare, toml::to_string(&table).unwrap()).unwrap();
    let out = t.0.join("npy-folder.ply");
    run(&[
        "scan",
        "-q",
        "--patterns",
        s(&bare),
        "--calibration",
        s(&cal),
        "-o",
        s(&out),
        s(&npy_dir),
    ]);
    // Same vertices; the header's comment names the other pattern file.
    let vertices = |b: &[u8]| {
        let at = b.windows(11).position(|w| w == b"end_header\n").unwrap();
        b[at..].to_vec()
    };
    assert!(
        vertices(&std::fs::read(&out).unwrap()) == vertices(&from_png),
        "NPY folder scan differs"
    );
}

/// Headerless `.raw` frames: the size, bit depth and byte order come from the folder's
/// `raw.toml`; 8-, 12- (both byte orders) and 16-bit frames are read exactly, a folder lists
/// them, and every inconsistency is refused naming the frame and the reason.
#[test]
fn headerless_raw_frames_are_read_by_their_descriptor_and_refused_when_inconsistent() {
    let t = Tmp::new("raw-headerless");
    let (w, h) = (5u32, 3u32);
    let v8: Vec<u8> = (0..15).map(|i| (i * 17) as u8).collect();
    let v12: Vec<u16> = (0..15).map(|i| (i * 273) as u16).collect(); // up to 3822 ≤ 4095
    let v16: Vec<u16> = (0..15).map(|i| (i * 4681) as u16).collect();
    let case = |name: &str, desc: &str, bytes: &[u8]| -> PathBuf {
        let dir = t.0.join(name);
        std::fs::create_dir_all(&dir).unwrap();
        put(&dir, "raw.toml", desc.as_bytes());
        put(&dir, "frame.raw", bytes)
    };
    let size = format!("width = {w}\nheight = {h}\n");
    let good: Vec<(PathBuf, Pixels, u8)> = vec![
        (
            case("u8", &format!("{size}bits = 8\n"), &v8),
            Pixels::U8(v8.clone()),
            8,
        ),
        (
            case("u12le", &format!("{size}bits = 12\n"), &u16_le(&v12)),
            Pixels::U16(v12.clone()),
            12,
        ),
        (
            case(
                "u12be",
                &format!("{size}bits = 12\nbyte_order = \"big\"\n"),
                &u16_be(&v12),
            ),
            Pixels::U16(v12.clone()),
            12,
        ),
        (
            case("u16", &format!("{size}bits = 16\n"), &u16_le(&v16)),
            Pixels::U16(v16.clone()),
            16,
        ),
    ];
    for (p, pixels, bits) in good {
        let hd = read_header(&p).unwrap();
        assert_eq!((hd.format, hd.width, hd.height), (ImageFormat::Raw, w, h));
        let (img, info): (GrayImage, _) = read_gray(&p).unwrap();
        assert_eq!(info.format, ImageFormat::Raw);
        assert_eq!((img.width, img.height, img.significant_bits), (w, h, bits));
        assert_eq!(img.pixels, pixels, "{}", p.display());
        let listed = fringe3d::io::image_set::list_folder(p.parent().unwrap()).unwrap();
        assert_eq!(listed, vec![p.clone()], "a folder lists its .raw frames");
    }
    let refused = |name: &str, desc: Option<&str>, bytes: &[u8], why: &str| {
        let dir = t.0.join(name);
        std::fs::create_dir_all(&dir).unwrap();
        if let Some(d) = desc {
            put(&dir, "raw.toml", d.as_bytes());
        }
        let p = put(&dir, "frame.raw", bytes);
        let e = read_gray(&p).unwrap_err().to_string();
        assert!(e.contains(&p.display().to_string()), "{name}: {e}");
        assert!(e.contains(why), "{name}: {e}");
        // Through the binary: one error line, a non-zero exit.
        let out = fringe3d(&["info", s(&p)]);
        assert!(!out.status.success(), "{name}");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains(why), "{name}: {err}");
    };
    refused("nodesc", None, &v8, "raw.toml");
    refused(
        "short",
        Some(&format!("{size}bits = 8\n")),
        &v8[..14],
        "15 bytes",
    );
    refused("long", Some(&format!("{size}bits = 12\n")), &v8, "30 bytes");
    refused(
        "over",
        Some(&format!("{size}bits = 10\n")),
        &u16_le(&v12),
        "above 1023",
    );
    refused(
        "order",
        Some(&format!("{size}bits = 12\nbyte_order = \"middle\"\n")),
        &u16_le(&v12),
        "byte_order",
    );
    refused("bits", Some(&format!("{size}bits = 17\n")), &v8, "bits");
    refused(
        "key",
        Some(&format!("{size}bits = 8\nstride = 6\n")),
        &v8,
        "stride",
    );
    refused(
        "huge",
        Some("width = 100000\nheight = 100000\nbits = 8\n"),
        &v8,
        "100000x100000",
    );
}
