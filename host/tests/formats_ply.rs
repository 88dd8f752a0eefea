//! PLY and XYZ writers, checked with a small independent PLY parser written here and, when
//! python3 with `plyfile` and `numpy` is installed, with plyfile.

use std::fs;
use std::path::{Path, PathBuf};
use std::process::Command;

use fringe3d::io::ply::{
    PixelIndexType, PlyEncoding, PlyOptions, PlyPoint, PlyWriter, PointRow, XyzWriter, write_ply,
};

fn scratch(name: &str) -> crate::cli_support::Tmp {
    crate::cli_support::Tmp::new(&format!("formats-ply-{name}"))
}

fn listing(d: &Path) -> Vec<String> {
    let mut v: Vec<String> = fs::read_dir(d)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

// --- an independent PLY reader -----------------------------------------------------------------

#[derive(Debug)]
struct Ply {
    format: String,
    comments: Vec<String>,
    obj_info: Vec<String>,
    count: usize,
    props: Vec<(String, String)>, // (type, name)
    rows: Vec<Vec<f64>>,
}

fn read_ply(path: &Path) -> Ply {
    let bytes = fs::read(path).unwrap();
    let end = b"end_header\n";
    let hend = bytes
        .windows(end.len())
        .position(|w| w == end)
        .expect("end_header")
        + end.len();
    let header = std::str::from_utf8(&bytes[..hend]).unwrap();
    let mut lines = header.lines();
    assert_eq!(lines.next(), Some("ply"));
    let mut ply = Ply {
        format: String::new(),
        comments: vec![],
        obj_info: vec![],
        count: 0,
        props: vec![],
        rows: vec![],
    };
    let mut elements = 0;
    for l in lines {
        let t: Vec<&str> = l.split(' ').collect();
        match t[0] {
            "format" => ply.format = l["format ".len()..].to_string(),
            "comment" => ply.comments.push(l["comment ".len()..].to_string()),
            "obj_info" => ply.obj_info.push(l["obj_info ".len()..].to_string()),
            "element" => {
                assert_eq!(t[1], "vertex");
                assert_eq!(t.len(), 3, "exactly `element vertex N`: {l:?}");
                ply.count = t[2].parse().unwrap();
                elements += 1;
            }
            "property" => {
                assert_eq!(t.len(), 3, "{l:?}");
                ply.props.push((t[1].to_string(), t[2].to_string()));
            }
            "end_header" => {}
            other => panic!("unexpected header line {other:?}"),
        }
    }
    assert_eq!(elements, 1);
    let body = &bytes[hend..];
    if ply.format == "ascii 1.0" {
        let text = std::str::from_utf8(body).unwrap();
        for line in text.lines() {
            let tok: Vec<&str> = line.split(' ').collect();
            assert_eq!(tok.len(), ply.props.len(), "{line:?}");
            // Parse each value as its declared type, as a PLY reader must.
            let v: Vec<f64> = tok
                .iter()
                .zip(&ply.props)
                .map(|(x, (ty, _))| match ty.as_str() {
                    "float" => x.parse::<f32>().unwrap() as f64,
                    "ushort" => x.parse::<u16>().unwrap() as f64,
                    "uint" => x.parse::<u32>().unwrap() as f64,
                    "uchar" => x.parse::<u8>().unwrap() as f64,
                    t => panic!("type {t}"),
                })
                .collect();
            ply.rows.push(v);
        }
    } else {
        assert_eq!(ply.format, "binary_little_endian 1.0");
        let mut pos = 0;
        for _ in 0..ply.count {
            let mut row = Vec::new();
            for (ty, _) in &ply.props {
                let (v, n) = match ty.as_str() {
                    "float" => (
                        f32::from_le_bytes(body[pos..pos + 4].try_into().unwrap()) as f64,
                        4,
                    ),
                    "ushort" => (
                        u16::from_le_bytes(body[pos..pos + 2].try_into().unwrap()) as f64,
                        2,
                    ),
                    "uint" => (
                        u32::from_le_bytes(body[pos..pos + 4].try_into().unwrap()) as f64,
                        4,
                    ),
                    "uchar" => (body[pos] as f64, 1),
                    t => panic!("type {t}"),
                };
                row.push(v);
                pos += n;
            }
            ply.rows.push(row);
        }
        assert_eq!(pos, body.len(), "no trailing bytes");
    }
    assert_eq!(ply.rows.len(), ply.count);
    ply
}

fn names(p: &Ply) -> Vec<&str> {
    p.props.iter().map(|(_, n)| n.as_str()).collect()
}

// --- test data ---------------------------------------------------------------------------------

/// A 4 × 3 scan; pixels with (u + v) % 3 == 1 are invalid (code 6 = no crossing).
struct Scan {
    w: usize,
    h: usize,
    xyz: Vec<[f32; 3]>,
    a: Vec<f32>,
    b: Vec<f32>,
    valid: Vec<u8>,
}

fn scan() -> Scan {
    let (w, h) = (4, 3);
    let mut s = Scan {
        w,
        h,
        xyz: vec![],
        a: vec![],
        b: vec![],
        valid: vec![],
    };
    for v in 0..h {
        for u in 0..w {
            s.xyz.push([
                u as f32 * 0.1 - 0.15,
                v as f32 * -2.5e-3,
                800.0 + (u * 7 + v) as f32 / 3.0,
            ]);
            s.a.push(100.0 + u as f32 + 0.5 * v as f32);
            s.b.push(1.0 / (1 + u + v) as f32);
            s.valid.push(if (u + v) % 3 == 1 { 6 } else { 0 });
        }
    }
    s
}

fn row(s: &Scan, v: usize) -> PointRow<'_> {
    let r = v * s.w..(v + 1) * s.w;
    PointRow {
        v: v as u32,
        xyz: &s.xyz[r.clone()],
        intensity: &s.a[r.clone()],
        modulation: &s.b[r.clone()],
        validity: &s.valid[r],
    }
}

fn write_unorganized(path: &Path, enc: PlyEncoding) -> u64 {
    let s = scan();
    let opts = PlyOptions {
        encoding: enc,
        comments: vec!["scan 7\nsecond line".into()],
        ..Default::default()
    };
    let mut w = PlyWriter::create(path, opts).unwrap();
    // Rows out of order are fine for an unorganized cloud.
    for v in [2, 0, 1] {
        w.write_row(&row(&s, v)).unwrap();
    }
    w.finish().unwrap()
}

fn check_unorganized(p: &Ply) {
    let s = scan();
    assert_eq!(
        names(p),
        ["x", "y", "z", "intensity", "modulation", "u", "v"]
    );
    assert_eq!(p.props[5].0, "ushort");
    assert!(
        p.comments.iter().any(|c| c == "scan 7 second line"),
        "{:?}",
        p.comments
    );
    assert!(p.comments[0].contains("millimetres"));
    assert!(p.obj_info.is_empty());
    let mut expect = Vec::new();
    for v in [2, 0, 1] {
        for u in 0..s.w {
            let i = v * s.w + u;
            if s.valid[i] == 0 {
                let x = s.xyz[i];
                expect.push(vec![
                    x[0] as f64,
                    x[1] as f64,
                    x[2] as f64,
                    s.a[i] as f64,
                    s.b[i] as f64,
                    u as f64,
                    v as f64,
                ]);
            }
        }
    }
    assert_eq!(p.count, 8);
    assert_eq!(p.rows, expect);
}

#[test]
fn unorganized_binary() {
    let d = scratch("unorg-bin");
    let path = d.join("cloud.ply");
    assert_eq!(write_unorganized(&path, PlyEncoding::BinaryLittleEndian), 8);
    let p = read_ply(&path);
    assert_eq!(p.format, "binary_little_endian 1.0");
    check_unorganized(&p);
    assert_eq!(
        listing(&d),
        ["cloud.ply"],
        "no scratch or temporary file left"
    );
}

#[test]
fn unorganized_with_the_count_announced_is_the_same_file() {
    // The writer that knows the vertex count up front (no scratch file) must write exactly the
    // bytes of the one that counts while writing; a wrong count is refused and leaves nothing.
    let d = scratch("unorg-count");
    for enc in [PlyEncoding::BinaryLittleEndian, PlyEncoding::Ascii] {
        let a = d.join("a.ply");
        let b = d.join("b.ply");
        let n = write_unorganized(&a, enc);
        let s = scan();
        let opts = PlyOptions {
            encoding: enc,
            comments: vec!["scan 7\nsecond line".into()],
            ..Default::default()
        };
        let mut w = PlyWriter::create_with_count(&b, n, opts.clone()).unwrap();
        for v in [2, 0, 1] {
            w.write_row(&row(&s, v)).unwrap();
        }
        assert_eq!(w.finish().unwrap(), n);
        assert_eq!(fs::read(&a).unwrap(), fs::read(&b).unwrap(), "{enc:?}");
        check_unorganized(&read_ply(&b));
        let c = d.join("c.ply");
        let mut w = PlyWriter::create_with_count(&c, n + 1, opts).unwrap();
        for v in [2, 0, 1] {
            w.write_row(&row(&s, v)).unwrap();
        }
        let e = w.finish().unwrap_err();
        assert!(
            e.to_string().contains("c.ply") && e.to_string().contains("announced"),
            "{e}"
        );
        assert!(!c.exists());
        fs::remove_file(&a).unwrap();
        fs::remove_file(&b).unwrap();
    }
    assert!(listing(&d).is_empty(), "left: {:?}", listing(&d));
}

#[test]
fn unorganized_ascii() {
    let d = scratch("unorg-ascii");
    let path = d.join("cloud.ply");
    write_unorganized(&path, PlyEncoding::Ascii);
    let p = read_ply(&path);
    assert_eq!(p.format, "ascii 1.0");
    check_unorganized(&p);
    // Exact text of the first vertex, by hand: row 2, u = 0 is valid.
    let text = fs::read_to_string(&path).unwrap();
    let body = text.split("end_header\n").nth(1).unwrap();
    let z = 800.0f32 + 2.0 / 3.0;
    assert_eq!(
        body.lines().next().unwrap(),
        format!("-0.15 -0.005 {z} 101 0.33333334 0 2")
    );
}

#[test]
fn exact_binary_header() {
    let d = scratch("header");
    let path = d.join("h.ply");
    let pts = [PlyPoint {
        xyz: [1.0, 2.0, 3.0],
        intensity: 4.0,
        modulation: 5.0,
        u: 70000,
        v: 6,
    }];
    let opts = PlyOptions {
        pixel_type: PixelIndexType::UInt,
        modulation: false,
        ..Default::default()
    };
    assert_eq!(write_ply(&path, &pts, opts).unwrap(), 1);
    let mut want = b"ply\nformat binary_little_endian 1.0\n\
comment fringe3d point cloud: camera frame (x right, y down, z forward), millimetres\n\
element vertex 1\nproperty float x\nproperty float y\nproperty float z\nproperty float intensity\n\
property uint u\nproperty uint v\nend_header\n"
        .to_vec();
    for f in [1.0f32, 2.0, 3.0, 4.0] {
        want.extend_from_slice(&f.to_le_bytes());
    }
    want.extend_from_slice(&70000u32.to_le_bytes());
    want.extend_from_slice(&6u32.to_le_bytes());
    assert_eq!(fs::read(&path).unwrap(), want);
}

#[test]
fn organized_binary_and_ascii() {
    for enc in [PlyEncoding::BinaryLittleEndian, PlyEncoding::Ascii] {
        let d = scratch("org");
        let path = d.join("grid.ply");
        let s = scan();
        let mut w = PlyWriter::create_organized(
            &path,
            s.w as u32,
            s.h as u32,
            PlyOptions {
                encoding: enc,
                ..Default::default()
            },
        )
        .unwrap();
        for v in 0..s.h {
            w.write_row(&row(&s, v)).unwrap();
        }
        assert_eq!(w.finish().unwrap(), 12);
        let p = read_ply(&path);
        assert_eq!(
            names(&p),
            [
                "x",
                "y",
                "z",
                "intensity",
                "modulation",
                "u",
                "v",
                "validity"
            ]
        );
        assert_eq!(p.props[7].0, "uchar");
        assert_eq!(p.obj_info, ["num_cols 4", "num_rows 3"]);
        assert!(
            p.comments.iter().any(|c| c.starts_with("organized 4 x 3")),
            "{:?}",
            p.comments
        );
        assert_eq!(p.count, 12);
        for (i, r) in p.rows.iter().enumerate() {
            let (u, v) = (i % s.w, i / s.w);
            assert_eq!((r[5], r[6], r[7]), (u as f64, v as f64, s.valid[i] as f64));
            assert_eq!((r[3], r[4]), (s.a[i] as f64, s.b[i] as f64));
            if s.valid[i] == 0 {
                assert_eq!(
                    &r[..3],
                    &[s.xyz[i][0] as f64, s.xyz[i][1] as f64, s.xyz[i][2] as f64]
                );
            } else {
                assert!(r[0].is_nan() && r[1].is_nan() && r[2].is_nan(), "{r:?}");
            }
        }
        assert_eq!(listing(&d), ["grid.ply"]);
    }
}

#[test]
fn misuse_is_an_error_and_leaves_nothing() {
    let d = scratch("misuse");
    let path = d.join("grid.ply");
    let s = scan();
    let mut w = PlyWriter::create_organized(&path, 4, 3, PlyOptions::default()).unwrap();
    let e = w.write_row(&row(&s, 1)).unwrap_err();
    assert!(
        e.to_string()
            .contains("grid.ply: organized cloud: got row 1, expected row 0"),
        "{e}"
    );
    w.write_row(&row(&s, 0)).unwrap();
    let short = PointRow {
        v: 1,
        xyz: &s.xyz[..3],
        intensity: &s.a[..3],
        modulation: &s.b[..3],
        validity: &s.valid[..3],
    };
    assert!(
        w.write_row(&short)
            .unwrap_err()
            .to_string()
            .contains("3 pixels, the cloud is 4 wide")
    );
    let ragged = PointRow {
        v: 1,
        xyz: &s.xyz[..4],
        intensity: &s.a[..2],
        modulation: &s.b[..4],
        validity: &s.valid[..4],
    };
    assert!(
        w.write_row(&ragged)
            .unwrap_err()
            .to_string()
            .contains("intensity has 2 values")
    );
    assert!(w.write_points(&[PlyPoint::default()]).is_err());
    let e = w.finish().unwrap_err();
    assert!(e.to_string().contains("1 of 3 rows written"), "{e}");
    assert_eq!(
        listing(&d),
        Vec::<String>::new(),
        "nothing at the target, no temporary files"
    );

    // ushort overflow in an unorganized cloud.
    let mut w = PlyWriter::create(&d.join("u.ply"), PlyOptions::default()).unwrap();
    let e = w
        .write_points(&[PlyPoint {
            u: 65536,
            ..Default::default()
        }])
        .unwrap_err();
    assert!(e.to_string().contains("does not fit ushort"), "{e}");
    drop(w);
    assert_eq!(listing(&d), Vec::<String>::new());
}

#[test]
fn xyz_writer() {
    let d = scratch("xyz");
    let path = d.join("c.xyz");
    let s = scan();
    let mut w = XyzWriter::create(&path).unwrap();
    w.write_row(&row(&s, 0)).unwrap();
    w.write_point([1.5, -2.0, 1e-3]).unwrap();
    assert_eq!(w.finish().unwrap(), 4);
    let text = fs::read_to_string(&path).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    assert!(text.ends_with('\n'));
    assert_eq!(lines.len(), 4);
    assert_eq!(lines[3], "1.5 -2 0.001");
    // Valid pixels of row 0 are u = 0, 2, 3; each value parses back to the same f32 bits.
    for (line, u) in lines[..3].iter().zip([0usize, 2, 3]) {
        let v: Vec<f32> = line.split(' ').map(|x| x.parse().unwrap()).collect();
        let want = s.xyz[u];
        assert_eq!(
            v.iter().map(|x| x.to_bits()).collect::<Vec<_>>(),
            want.iter().map(|x| x.to_bits()).collect::<Vec<_>>(),
            "{line}"
        );
    }
}

// --- cross-check with plyfile ------------------------------------------------------------------

const PY: &str = r#"
import json, sys, math
from plyfile import PlyData
out = {}
for path in sys.argv[1:]:
    d = PlyData.read(path)
    v = d['vertex']
    names = [p.name for p in v.properties]
    rows = [[None if (isinstance(x, float) and math.isnan(x)) else x for x in (float(r[n]) for n in names)] for r in v.data]
    out[path] = {"names": names, "rows": rows, "obj_info": list(d.obj_info), "text": bool(d.text)}
print(json.dumps(out))
"#;

#[test]
fn plyfile_reads_our_files() {
    let have = Command::new("python3")
        .args(["-c", "import plyfile, numpy"])
        .output();
    if !have.is_ok_and(|o| o.status.success()) {
        eprintln!(
            "NOTICE: python3 with plyfile and numpy not available; skipping the plyfile cross-check"
        );
        return;
    }
    let d = scratch("plyfile");
    let s = scan();
    let paths: Vec<PathBuf> = ["ub.ply", "ua.ply", "ob.ply", "oa.ply"]
        .iter()
        .map(|n| d.join(n))
        .collect();
    write_unorganized(&paths[0], PlyEncoding::BinaryLittleEndian);
    write_unorganized(&paths[1], PlyEncoding::Ascii);
    for (p, enc) in [
        (&paths[2], PlyEncoding::BinaryLittleEndian),
        (&paths[3], PlyEncoding::Ascii),
    ] {
        let mut w = PlyWriter::create_organized(
            p,
            4,
            3,
            PlyOptions {
                encoding: enc,
                ..Default::default()
            },
        )
        .unwrap();
        for v in 0..3 {
            w.write_row(&row(&s, v)).unwrap();
        }
        w.finish().unwrap();
    }
    let out = Command::new("python3")
        .arg("-c")
        .arg(PY)
        .args(&paths)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "plyfile failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let j: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    for (k, p) in paths.iter().enumerate() {
        let ours = read_ply(p);
        let theirs = &j[p.to_str().unwrap()];
        let tn: Vec<&str> = theirs["names"]
            .as_array()
            .unwrap()
            .iter()
            .map(|n| n.as_str().unwrap())
            .collect();
        assert_eq!(tn, names(&ours));
        assert_eq!(theirs["text"].as_bool().unwrap(), k % 2 == 1);
        let rows = theirs["rows"].as_array().unwrap();
        assert_eq!(rows.len(), ours.count);
        for (r, o) in rows.iter().zip(&ours.rows) {
            for (x, y) in r.as_array().unwrap().iter().zip(o) {
                match x.as_f64() {
                    Some(x) => assert_eq!(x, *y, "{p:?}"),
                    None => assert!(y.is_nan(), "{p:?}"),
                }
            }
        }
        if k >= 2 {
            let info: Vec<&str> = theirs["obj_info"]
                .as_array()
                .unwrap()
                .iter()
                .map(|n| n.as_str().unwrap())
                .collect();
            assert_eq!(info, ["num_cols 4", "num_rows 3"]);
        }
    }
}
