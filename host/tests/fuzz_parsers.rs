//! A short seeded fuzz loop of the file parsers and the wire decoder (issue #21), on stable and
//! in the normal test run.
//!
//! Valid seeds (PNG 8/16-bit, TIFF f32/u16, BMP 8/24-bit, PGM 8/12-bit, NPY frames u8/u16, the
//! example calibration and pattern files, an NPY array, wire packets) are mutated by a seeded
//! SplitMix64: bit flips, byte overwrites, truncations, insertions, deletions, duplicated runs,
//! little- and big-endian length-field edits (with the PNG chunk CRCs and the wire frame CRC
//! recomputed, so that the mutation reaches the parser behind the checksum), and for the TOML
//! files number tokens replaced by extreme values. Every input must give `Ok` or `Err`: a panic
//! fails the test and leaves the input in the temp folder. Errors must name the file; an image
//! accepted must fit the pixel cap it was read with (the memory bound). The importers of other
//! tools' calibrations (OpenCV camera and stereo files, SLStudio, SLMaster, Bouguet's stereo
//! script) are fuzzed too.
//!
//! `FRINGE3D_FUZZ_ITERS` sets the mutated inputs per parser (default 1000); `FRINGE3D_FUZZ_SEED`
//! the seed. Each test prints its count and time (`cargo test --release -p
//! fringe3d --test suite fuzz_parsers:: -- --nocapture`).

use std::path::{Path, PathBuf};
use std::time::Instant;

use fringe3d::io::calibration::Calibration;
use fringe3d::io::image::{
    ReadLimits, decode_gray_limited, encode_png_u8, encode_png_u16, encode_tiff_f32,
    read_gray_limited, read_header,
};
use fringe3d::io::import::{
    RigSizes, import_any_camera, import_opencv, import_rig, opencv_stereo_yaml,
};
use fringe3d::io::npy;
use fringe3d::io::pattern_file::PatternSetFile;
use fringe3d_core::pattern::{Output, PatternSet};
use fringe3d_core::phase_function::Axis;
use fringe3d_core::wire::crc::crc32c;
use fringe3d_core::wire::{
    DefinePatternSet, FrameReceiver, Hello, MAX_ENCODED_FRAME, MAX_FRAME, Message, Packet,
    PatternSetDesc, parse_packet,
};

use crate::cli_support::Tmp;

/// SplitMix64: small, seeded, reproducible.
struct Rng(u64);

impl Rng {
    fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    /// Uniform in `0..n` (`n > 0`).
    fn below(&mut self, n: usize) -> usize {
        (self.next_u64() % n as u64) as usize
    }
}

fn iters() -> usize {
    std::env::var("FRINGE3D_FUZZ_ITERS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(1000)
}

fn seed(salt: u64) -> u64 {
    let base = std::env::var("FRINGE3D_FUZZ_SEED")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(0x0F3D_F022);
    base ^ salt.wrapping_mul(0x9E37_79B9_7F4A_7C15)
}

/// While alive, marks the input being parsed: if the parser panics, the input is saved and named.
struct Case<'a> {
    parser: &'a str,
    iter: usize,
    input: &'a [u8],
}
impl Drop for Case<'_> {
    fn drop(&mut self) {
        if std::thread::panicking() {
            let p = std::env::temp_dir().join(format!(
                "fringe3d-fuzz-crash-{}-{}-{}.bin",
                self.parser,
                std::process::id(),
                self.iter
            ));
            let _ = std::fs::write(&p, self.input);
            eprintln!(
                "fuzz {}: input {} made the parser panic; saved as {}",
                self.parser,
                self.iter,
                p.display()
            );
        }
    }
}

/// Values that break length and size fields.
const EDGES: [u64; 12] = [
    0,
    1,
    2,
    0x7f,
    0x80,
    0xff,
    0xffff,
    0x8000_0000,
    0xffff_ffff,
    0x1000_0000,
    0x7fff_ffff,
    0xffff_ffff_ffff_ffff,
];

/// Apply 1 to 4 random mutations to `seed`.
fn mutate(r: &mut Rng, seed: &[u8]) -> Vec<u8> {
    let mut v = seed.to_vec();
    for _ in 0..1 + r.below(4) {
        if v.is_empty() {
            v.push(r.next_u64() as u8);
            continue;
        }
        let at = r.below(v.len());
        match r.below(8) {
            0 => v[at] ^= 1 << r.below(8),
            1 => v[at] = EDGES[r.below(EDGES.len())] as u8,
            2 => v.truncate(at),
            3 => {
                let n = 1 + r.below(16);
                let bytes: Vec<u8> = (0..n).map(|_| r.next_u64() as u8).collect();
                v.splice(at..at, bytes);
            }
            4 => {
                let end = (at + 1 + r.below(64)).min(v.len());
                v.drain(at..end);
            }
            5 => {
                let end = (at + 1 + r.below(64)).min(v.len());
                let run = v[at..end].to_vec();
                v.splice(at..at, run);
            }
            _ => {
                // A length field: 2 or 4 bytes, either byte order, set to an edge value or
                // nudged by a small amount.
                let w = if r.below(2) == 0 { 2 } else { 4 };
                if at + w > v.len() {
                    continue;
                }
                let big = r.below(2) == 0;
                let old = if w == 2 {
                    let b = [v[at], v[at + 1]];
                    u64::from(if big {
                        u16::from_be_bytes(b)
                    } else {
                        u16::from_le_bytes(b)
                    })
                } else {
                    let b = [v[at], v[at + 1], v[at + 2], v[at + 3]];
                    u64::from(if big {
                        u32::from_be_bytes(b)
                    } else {
                        u32::from_le_bytes(b)
                    })
                };
                let new = if r.below(2) == 0 {
                    EDGES[r.below(EDGES.len())]
                } else {
                    old.wrapping_add(r.below(9) as u64).wrapping_sub(4)
                };
                let bytes = new.to_le_bytes();
                for i in 0..w {
                    v[at + i] = if big { bytes[w - 1 - i] } else { bytes[i] };
                }
            }
        }
    }
    v
}

/// Numbers that break numeric fields of text formats.
const EXTREME: [&str; 14] = [
    "0",
    "-1",
    "1e300",
    "-1e300",
    "nan",
    "inf",
    "-inf",
    "4294967296",
    "18446744073709551616",
    "65536",
    "16385",
    "1e-300",
    "[1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0]",
    "\"x\"",
];

/// Replace 1 or 2 number tokens of `text` by extreme values; sometimes mutate bytes as well.
fn mutate_text(r: &mut Rng, text: &str) -> Vec<u8> {
    let mut t = text.to_string();
    for _ in 0..1 + r.below(2) {
        let starts: Vec<usize> = t
            .char_indices()
            .filter(|&(i, c)| {
                (c.is_ascii_digit() || c == '-')
                    && !t[..i].ends_with(|p: char| p.is_ascii_alphanumeric() || p == '.')
            })
            .map(|(i, _)| i)
            .collect();
        if starts.is_empty() {
            break;
        }
        let s = starts[r.below(starts.len())];
        let len = t[s..]
            .find(|c: char| !(c.is_ascii_alphanumeric() || "+-.".contains(c)))
            .unwrap_or(t.len() - s);
        t.replace_range(s..s + len, EXTREME[r.below(EXTREME.len())]);
    }
    if r.below(3) == 0 {
        mutate(r, t.as_bytes())
    } else {
        t.into_bytes()
    }
}

/// Recompute the CRC of every PNG chunk that still fits (so mutations reach the decoder).
fn fix_png_crcs(v: &mut [u8]) {
    let mut at = 8;
    while at + 12 <= v.len() {
        let n = u32::from_be_bytes([v[at], v[at + 1], v[at + 2], v[at + 3]]) as usize;
        let Some(end) = (at + 8).checked_add(n).filter(|&e| e + 4 <= v.len()) else {
            return;
        };
        let c = crc32(&v[at + 4..end]);
        v[end..end + 4].copy_from_slice(&c.to_be_bytes());
        at = end + 4;
    }
}

/// CRC-32 (ISO-HDLC), as PNG chunks use it.
fn crc32(data: &[u8]) -> u32 {
    let mut c = 0xffff_ffffu32;
    for &b in data {
        c ^= u32::from(b);
        for _ in 0..8 {
            c = if c & 1 != 0 {
                (c >> 1) ^ 0xedb8_8320
            } else {
                c >> 1
            };
        }
    }
    !c
}

/// Report one parser's figures.
fn report(parser: &str, n: usize, ok: usize, t0: Instant) {
    eprintln!(
        "fuzz {parser}: {n} inputs ({ok} accepted, {} refused) in {:.2} s",
        n - ok,
        t0.elapsed().as_secs_f64()
    );
}

/// The pixel cap the fuzzed images are read with (the memory bound under test).
const CAP: u64 = 1 << 20;

fn image_seeds() -> Vec<Vec<u8>> {
    let p = Path::new("seed");
    let (w, h) = (37u32, 23u32);
    let g8: Vec<u8> = (0..w * h).map(|i| (i * 7) as u8).collect();
    let g16: Vec<u16> = (0..w * h).map(|i| (i * 977) as u16).collect();
    let gf: Vec<f32> = (0..w * h).map(|i| i as f32 * 0.25 - 3.0).collect();
    let mut tiff16 = Vec::new();
    {
        let mut c = std::io::Cursor::new(&mut tiff16);
        let mut enc = tiff::encoder::TiffEncoder::new(&mut c).unwrap();
        enc.write_image::<tiff::encoder::colortype::Gray16>(w, h, &g16)
            .unwrap();
    }
    vec![
        encode_png_u8(p, w, h, &g8).unwrap(),
        encode_png_u16(p, w, h, &g16, 12).unwrap(),
        encode_tiff_f32(p, w, h, &gf).unwrap(),
        tiff16,
        bmp(w, h, 8),
        bmp(w, h, 24),
        [
            format!("P5\n# seed\n{w} {h}\n255\n").into_bytes(),
            g8.clone(),
        ]
        .concat(),
        [
            format!("P5 {w} {h} 4095\n").into_bytes(),
            g16.iter().flat_map(|v| (v & 4095).to_be_bytes()).collect(),
        ]
        .concat(),
        npy_frame("|u1", w, h, &g8),
        npy_frame(
            "<u2",
            w,
            h,
            &g16.iter()
                .flat_map(|v| v.to_le_bytes())
                .collect::<Vec<u8>>(),
        ),
    ]
}

/// A `.npy` camera frame of dtype `descr` holding `data`.
fn npy_frame(descr: &str, w: u32, h: u32, data: &[u8]) -> Vec<u8> {
    let dict = format!("{{'descr': '{descr}', 'fortran_order': False, 'shape': ({h}, {w}), }}");
    crate::cli_support::npy_file(&dict, data)
}

/// An uncompressed bottom-up BMP of `bpp` = 8 (gray palette) or 24 bits.
fn bmp(w: u32, h: u32, bpp: u16) -> Vec<u8> {
    let stride = (w as usize * bpp as usize).div_ceil(32) * 4;
    let palette = if bpp == 8 { 256 * 4 } else { 0 };
    let off = 54 + palette;
    let size = off + stride * h as usize;
    let mut b = Vec::with_capacity(size);
    b.extend_from_slice(b"BM");
    b.extend_from_slice(&(size as u32).to_le_bytes());
    b.extend_from_slice(&[0; 4]);
    b.extend_from_slice(&(off as u32).to_le_bytes());
    b.extend_from_slice(&40u32.to_le_bytes());
    b.extend_from_slice(&(w as i32).to_le_bytes());
    b.extend_from_slice(&(h as i32).to_le_bytes());
    b.extend_from_slice(&1u16.to_le_bytes());
    b.extend_from_slice(&bpp.to_le_bytes());
    b.extend_from_slice(&[0; 4]); // compression
    b.extend_from_slice(&((stride * h as usize) as u32).to_le_bytes());
    b.extend_from_slice(&[0; 8]);
    let colours: u32 = if bpp == 8 { 256 } else { 0 };
    b.extend_from_slice(&colours.to_le_bytes());
    b.extend_from_slice(&[0; 4]);
    if bpp == 8 {
        for i in 0..=255u8 {
            b.extend_from_slice(&[i, i, i, 0]);
        }
    }
    for y in 0..h as usize {
        let row: Vec<u8> = (0..stride).map(|x| (x * 3 + y * 5) as u8).collect();
        b.extend_from_slice(&row);
    }
    b
}

#[test]
fn images_png_tiff_bmp_pgm_npy() {
    let seeds = image_seeds();
    let tmp = Tmp::new("fuzz-images");
    let path = tmp.0.join("fuzzed-image");
    let lim = ReadLimits {
        max_pixels: CAP,
        size: None,
    };
    // The seeds decode, at the size they were written.
    for s in &seeds {
        let (img, _) = decode_gray_limited(s, &path, &lim).unwrap();
        assert_eq!((img.width, img.height), (37, 23));
    }
    let mut r = Rng(seed(1));
    let (n, t0) = (iters() * seeds.len(), Instant::now());
    let mut ok = 0;
    for i in 0..n {
        let mut v = mutate(&mut r, &seeds[i % seeds.len()]);
        if v.starts_with(b"\x89PNG") && r.below(4) != 0 {
            fix_png_crcs(&mut v);
        }
        let _case = Case {
            parser: "image",
            iter: i,
            input: &v,
        };
        match decode_gray_limited(&v, &path, &lim) {
            Ok((img, _)) => {
                ok += 1;
                let px = u64::from(img.width) * u64::from(img.height);
                assert!(px <= CAP, "input {i}: {px} pixels past the cap");
                assert_eq!(img.pixels.len() as u64, px, "input {i}");
            }
            Err(e) => {
                let m = e.to_string();
                assert!(m.contains("fuzzed-image"), "input {i}: no file named: {m}");
            }
        }
        // Every 8th input also through the file readers (regular-file check, header only).
        if i % 8 == 0 {
            std::fs::write(&path, &v).unwrap();
            match read_header(&path) {
                Ok(_) => {}
                Err(e) => assert!(e.to_string().contains("fuzzed-image"), "{e}"),
            }
            match read_gray_limited(&path, &lim) {
                Ok((img, _)) => {
                    assert!(u64::from(img.width) * u64::from(img.height) <= CAP)
                }
                Err(e) => assert!(e.to_string().contains("fuzzed-image"), "{e}"),
            }
        }
    }
    report("png/tiff/bmp/pgm/npy", n, ok, t0);
}

fn examples() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples")
}

/// Fuzz a text file loader: `load` must return Ok or an error naming the file.
fn fuzz_text<T, E: std::fmt::Display>(
    parser: &str,
    salt: u64,
    seeds: &[String],
    load: impl Fn(&Path) -> Result<T, E>,
) {
    fuzz_text_as(parser, "toml", salt, seeds, load);
}

/// [`fuzz_text`] with the fuzzed file named `fuzzed-PARSER.EXT` (importers look at the extension).
fn fuzz_text_as<T, E: std::fmt::Display>(
    parser: &str,
    ext: &str,
    salt: u64,
    seeds: &[String],
    load: impl Fn(&Path) -> Result<T, E>,
) {
    let tmp = Tmp::new(&format!("fuzz-{parser}"));
    let path = tmp.0.join(format!("fuzzed-{parser}.{ext}"));
    for s in seeds {
        std::fs::write(&path, s).unwrap();
        if let Err(e) = load(&path) {
            panic!("seed refused: {e}");
        }
    }
    let mut r = Rng(seed(salt));
    let (n, t0) = (iters() * seeds.len(), Instant::now());
    let mut ok = 0;
    for i in 0..n {
        let v = mutate_text(&mut r, &seeds[i % seeds.len()]);
        std::fs::write(&path, &v).unwrap();
        let _case = Case {
            parser,
            iter: i,
            input: &v,
        };
        match load(&path) {
            Ok(_) => ok += 1,
            Err(e) => {
                let m = e.to_string();
                assert!(
                    m.contains(&format!("fuzzed-{parser}.{ext}")),
                    "input {i}: no file named: {m}"
                );
            }
        }
    }
    report(parser, n, ok, t0);
}

#[test]
fn calibration_toml() {
    let seed = std::fs::read_to_string(examples().join("calibration/calib.toml")).unwrap();
    fuzz_text("calibration", 2, &[seed], Calibration::load);
}

#[test]
fn opencv_camera_files() {
    let seeds: Vec<String> = ["opencv.yml", "opencv.xml"]
        .iter()
        .map(|f| std::fs::read_to_string(examples().join("calibration").join(f)).unwrap())
        .collect();
    fuzz_text_as("opencv-camera", "yml", 7, &seeds, |p| {
        import_opencv(p, 640, 480)
    });
}

/// Seeds of every full-calibration format, from the example calibration's rig: the exporter's
/// OpenCV YAML and, by renaming its keys, SLStudio's and SLMaster's; a Bouguet stereo script.
fn stereo_seeds() -> (Vec<String>, String) {
    let cal = Calibration::load(&examples().join("calibration/calib.toml")).unwrap();
    let yml = opencv_stereo_yaml(&cal).unwrap();
    let rename = |pairs: &[(&str, &str)]| {
        let mut t = yml.clone();
        for (a, b) in pairs {
            t = t.replace(&format!("\n{a}: "), &format!("\n{b}: "));
        }
        t
    };
    let sl = rename(&[
        ("M1", "Kc"),
        ("D1", "kc"),
        ("M2", "Kp"),
        ("D2", "kp"),
        ("R", "Rp"),
        ("T", "Tp"),
    ])
    .replace("fringe3d_", "x_");
    let slm = rename(&[("M2", "M4"), ("D2", "D4"), ("R", "Rlp"), ("T", "Tlp")])
        .replace("fringe3d_", "x_");
    let c = &cal.camera;
    let p = cal.projector.as_ref().unwrap();
    let pi = &p.intrinsics;
    let d = |v: [f64; 5]| format!("[ {} ; {} ; {} ; {} ; {} ]", v[0], v[1], v[2], v[3], v[4]);
    let m = format!(
        "% stereo\nfc_left = [ {} ; {} ];\ncc_left = [ {} ; {} ];\nalpha_c_left = {};\nkc_left = {};\n\
         fc_right = [ {} ; {} ];\ncc_right = [ {} ; {} ];\nalpha_c_right = {};\nkc_right = {};\n\
         om = [ 0.0 ; -0.25268 ; 0.0 ];\nT = [ 200.0 ; 0.0 ; -30.0 ];\nnx = 640;\nny = 480;\nnx_right = 1024;\nny_right = 768;\n",
        c.fx,
        c.fy,
        c.cx,
        c.cy,
        c.skew,
        d(c.distortion.to_array()),
        pi.fx,
        pi.fy,
        pi.cx,
        pi.cy,
        pi.skew,
        d(pi.distortion.to_array()),
    );
    (vec![yml, sl, slm], m)
}

#[test]
fn stereo_calibrations() {
    let (fs_seeds, m) = stereo_seeds();
    let sizes = RigSizes {
        camera: Some((640, 480)),
        projector: Some((1024, 768)),
    };
    fuzz_text_as("stereo-fs", "yml", 8, &fs_seeds, |p| {
        import_rig(p, None, sizes)
    });
    fuzz_text_as("stereo-camera", "yml", 9, &fs_seeds[2..], |p| {
        import_any_camera(p, Some((640, 480)))
    });
    fuzz_text_as("bouguet-stereo", "m", 10, &[m], |p| {
        import_rig(p, None, sizes)
    });
}

#[test]
fn pattern_toml() {
    let seeds: Vec<String> = [
        "paper8.toml",
        "twelve.toml",
        "cosine-3step.toml",
        "variable-width.toml",
        "curved.toml",
    ]
    .iter()
    .map(|f| std::fs::read_to_string(examples().join("patterns").join(f)).unwrap())
    .collect();
    fuzz_text("pattern", 3, &seeds, |p| {
        PatternSetFile::load(p).and_then(|f| f.to_pattern_set())
    });
}

#[test]
fn npy_arrays() {
    let d: Vec<f64> = (0..4 * 5 * 3).map(|i| i as f64 * 0.5 - 7.0).collect();
    let seeds = [npy::encode(&[4, 5, 3], &d), npy::encode(&[60], &d)];
    let mut r = Rng(seed(4));
    let (n, t0) = (iters() * seeds.len(), Instant::now());
    let mut ok = 0;
    for i in 0..n {
        let mut v = mutate(&mut r, &seeds[i % seeds.len()]);
        // Edit the shape text too: numbers of any size.
        let key = b"'shape': (";
        if r.below(3) == 0
            && let Some(p) = v.windows(key.len()).position(|w| w == key)
        {
            let at = p + key.len();
            let big = [
                "0",
                "99999999999",
                "18446744073709551615",
                "4294967296, 4294967296",
            ];
            let b = big[r.below(big.len())];
            v.splice(at..at, b.bytes().chain(*b", "));
        }
        let _case = Case {
            parser: "npy",
            iter: i,
            input: &v,
        };
        // decode_f64 works on bytes; its caller names the file (accuracy::load_truth).
        if let Ok((shape, data)) = npy::decode_f64(&v) {
            ok += 1;
            assert_eq!(shape.iter().product::<usize>(), data.len(), "input {i}");
            assert!(data.len() * 8 <= v.len(), "input {i}: more data than bytes");
        }
    }
    report("npy", n, ok, t0);
}

/// Valid wire frames (decoded, CRC included) and their line bytes.
fn wire_seeds() -> Vec<Vec<u8>> {
    let out = Output {
        width: 1024,
        height: 768,
        i_min: 0.0,
        i_max: 255.0,
    };
    let set = PatternSet::default_for(Axis::Xi, out).unwrap();
    let desc = PatternSetDesc::from_set(&set, 8).unwrap();
    let messages = [
        Message::Hello(Hello {
            protocol_version: 1,
        }),
        Message::DefinePatternSet(DefinePatternSet { set_id: 0, desc }),
    ];
    messages
        .iter()
        .enumerate()
        .map(|(i, m)| {
            let mut scratch = vec![0u8; MAX_FRAME];
            let mut line = vec![0u8; MAX_ENCODED_FRAME];
            let n = Packet::request(i as u8 + 1, *m)
                .emit(&mut scratch, &mut line)
                .unwrap();
            line.truncate(n);
            line
        })
        .collect()
}

#[test]
fn wire_decoder() {
    let seeds = wire_seeds();
    let mut r = Rng(seed(5));
    let (n, t0) = (iters() * 8 * seeds.len(), Instant::now());
    let (mut frames, mut ok) = (0, 0);
    let mut rx = FrameReceiver::new([0u8; MAX_ENCODED_FRAME]);
    // The seeds go through.
    for s in &seeds {
        let (_, ev) = rx.feed(s);
        assert!(parse_packet(ev.unwrap().unwrap()).is_ok());
    }
    for i in 0..n {
        let s = &seeds[i % seeds.len()];
        let line = mutate(&mut r, s);
        let _case = Case {
            parser: "wire-line",
            iter: i,
            input: &line,
        };
        // Line bytes through the stream decoder, in random pieces.
        let mut rest: &[u8] = &line;
        while !rest.is_empty() {
            let piece = &rest[..(1 + r.below(64)).min(rest.len())];
            let (used, ev) = rx.feed(piece);
            rest = &rest[used..];
            if let Some(Ok(f)) = ev {
                frames += 1;
                ok += usize::from(parse_packet(f).is_ok());
            }
        }
        // The decoded frame mutated behind a valid CRC: reaches the header and body parsers.
        let mut rx2 = FrameReceiver::new([0u8; MAX_ENCODED_FRAME]);
        let (_, ev) = rx2.feed(s);
        let mut frame = ev.unwrap().unwrap().to_vec();
        frame.truncate(frame.len() - 4);
        let mut frame = mutate(&mut r, &frame);
        let crc = crc32c(&frame);
        frame.extend_from_slice(&crc.to_le_bytes());
        let _case = Case {
            parser: "wire-frame",
            iter: i,
            input: &frame,
        };
        ok += usize::from(parse_packet(&frame).is_ok());
    }
    // Resynchronised: a clean frame after all that garbage decodes.
    rx.feed(&[0]);
    let (_, ev) = rx.feed(&seeds[0]);
    assert!(parse_packet(ev.unwrap().unwrap()).is_ok());
    eprintln!("fuzz wire: {frames} line frames passed COBS+CRC");
    report("wire (line + CRC-valid frame)", 2 * n, ok, t0);
}
