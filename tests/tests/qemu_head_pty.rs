//! The scan head's firmware on an emulated Cortex-M4F, reached by the host through QEMU's
//! `-serial pty` with the same `fringe3d device` commands as the simulated head.
//!
//! Builds `fringe3d-board-mps2-head` (firmware-sim/board-mps2/src/bin/head.rs: `fringe3d-head`'s
//! `Head` on the CMSDK UART0 of QEMU's `mps2-an386`, its camera reading the frames of a rendered
//! scene from a file on the host through semihosting), starts QEMU with `-serial pty`, reads the
//! PTY QEMU announces, then runs `fringe3d device info`, `fringe3d device upload` (pattern images
//! into the head's PSRAM store, calibration, reference phase map: the virtual map of the rig's
//! projector on the default far plane, wider than the image by the margin the geometry needs,
//! issue #17) and `fringe3d device scan`
//! (points to a PLY, phase to a float TIFF) against it, and an HDR scan (`--exposures-us`: the
//! camera reads a frames file per exposure, the scene rendered 4× brighter and as metered). The
//! scans must be bit-identical (canonical
//! NaN) to what the desktop computes from the same images — the decode and reconstruction of
//! `fringe3d scan` (`cli::common::decode`, `ScanCalibration::reconstruct`) — and the PLY, organized
//! (one vertex per pixel with its validity code), must hold exactly the desktop's points and codes.
//!
//! A second test does the same with the compiled reconstruction (`fringe3d compile`, `device
//! upload --compiled`) on a smaller camera.
//!
//! Skips with a notice when `qemu-system-arm` or the `thumbv7em-none-eabihf` target is missing,
//! unless `FRINGE3D_REQUIRE_QEMU` is set (`.ci/run` sets it): then it fails.

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::{Arc, Mutex, mpsc};
use std::time::{Duration, Instant};

use fringe3d::cli::common;
use fringe3d::io::image::{Pixels, read_gray};
use fringe3d::render::dataset::{DatasetOptions, write_dataset};
use fringe3d::render::{Overrides, SceneSpec};
use fringe3d::scan::{PointCloud, ScanCalibration};
use fringe3d_core::math::canonical;
use fringe3d_head::desktop::Replay;
use fringe3d_head::sim::{FrameSource, Shot};
use fringe3d_tests::qemu::{build_firmware, skip_without_tools};

const BIN: &str = "fringe3d-board-mps2-head";
/// The camera: small, because QEMU moves PTY input into the emulated UART one byte per
/// main-loop round (about 20 KB/s, a system call or two a byte), and the reference map (5 bytes
/// per pixel) goes that way.
const CAM: (u32, u32) = (160, 120);
/// The camera of the compiled reconstruction's test: smaller again, for its models are 44 bytes
/// a pixel (845 KB at 160 × 120 took 46 s through the emulated UART).
const CAM_COMPILED: (u32, u32) = (96, 72);
/// The projector of the pattern set (its 8 images are uploaded through the emulated UART).
const PROJ: (u32, u32) = (128, 96);

/// QEMU running the head; killed when dropped, on every path out of the test.
struct Qemu {
    child: Child,
    console: Arc<Mutex<String>>,
}

impl Qemu {
    /// Start the head on `frames`; returns it and the PTY QEMU connected UART0 to.
    /// QEMU running `elf` whose camera reads the frames files `frames` (`PATH` or `PATH@US`).
    fn start(elf: &Path, frames: &[String]) -> (Qemu, String) {
        let mut child = Command::new("qemu-system-arm")
            .args([
                "-M",
                "mps2-an386",
                "-cpu",
                "cortex-m4",
                "-nographic",
                "-monitor",
                "none",
                "-serial",
                "pty",
            ])
            .arg("-semihosting-config")
            .arg(format!(
                "enable=on,target=native,arg={BIN}{}",
                frames
                    .iter()
                    .map(|f| format!(",arg={f}"))
                    .collect::<String>()
            ))
            .arg("-kernel")
            .arg(elf)
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .expect("start qemu-system-arm");
        let console = Arc::new(Mutex::new(String::new()));
        let (tx, rx) = mpsc::channel();
        // QEMU announces the PTY on stdout ("char device redirected to /dev/pts/N (label
        // serial0)"); the firmware's semihosting console goes to stderr. Read both.
        let pipes: [Box<dyn std::io::Read + Send>; 2] = [
            Box::new(child.stdout.take().expect("piped stdout")),
            Box::new(child.stderr.take().expect("piped stderr")),
        ];
        for pipe in pipes {
            let (console, tx) = (console.clone(), tx.clone());
            std::thread::spawn(move || {
                for line in BufReader::new(pipe).lines().map_while(Result::ok) {
                    if let Some(at) = line.find("char device redirected to ") {
                        let rest = &line[at + "char device redirected to ".len()..];
                        let path = rest.split_whitespace().next().unwrap_or("").to_string();
                        let _ = tx.send(path);
                    }
                    let mut c = console.lock().unwrap();
                    c.push_str(&line);
                    c.push('\n');
                }
            });
        }
        let mut qemu = Qemu { child, console };
        let port = match rx.recv_timeout(Duration::from_secs(60)) {
            Ok(p) if p.starts_with("/dev/") => p,
            other => panic!(
                "QEMU announced no PTY within 60 s ({other:?}); output:\n{}",
                qemu.console()
            ),
        };
        // The firmware prints its start-up line once it serves the link.
        let t0 = Instant::now();
        while !qemu.console().contains("serving the head on UART0") {
            if let Ok(Some(s)) = qemu.child.try_wait() {
                panic!("QEMU exited ({s}):\n{}", qemu.console());
            }
            assert!(
                t0.elapsed() < Duration::from_secs(60),
                "the firmware did not start within 60 s:\n{}",
                qemu.console()
            );
            std::thread::sleep(Duration::from_millis(50));
        }
        (qemu, port)
    }

    fn console(&self) -> String {
        self.console.lock().unwrap().clone()
    }

    /// The console once it holds `n` copies of `line` (or after 10 s, whatever it holds): the
    /// head prints its report of a scan after sending the scan's last answer, so the host can be
    /// done before the line reaches the console's reader.
    fn console_with(&self, line: &str, n: usize) -> String {
        let until = Instant::now() + Duration::from_secs(10);
        loop {
            let c = self.console();
            if c.matches(line).count() >= n || Instant::now() > until {
                return c;
            }
            std::thread::sleep(Duration::from_millis(20));
        }
    }
}

impl Drop for Qemu {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// A small rendered sphere scene: the default rig with a `PROJ`-sized projector (same field of
/// view), its pattern set with exact binary parameters.
/// The sphere scene, exposed `exposure` times the metered light, in `root/name`.
fn dataset(root: &Path, name: &str, cam: (u32, u32), exposure: f64) -> PathBuf {
    let dir = root.join(name);
    let set_file = root.join("set.toml");
    std::fs::write(
        &set_file,
        format!(
            "version = 1\npreset = \"paper8\"\nratio = 8.0\n[projector]\nwidth = {}\nheight = {}\nbit_depth = 8\n\
             [phase]\naxis = \"xi\"\nkind = \"linear\"\norigin = {}\nslope = {}\n",
            PROJ.0,
            PROJ.1,
            (PROJ.0 as f64 - 1.0) / 2.0,
            // 2⁻⁷ rad per pixel: the finest of the 3 levels (×64) moves 0.5 rad per pixel.
            1.0 / 128.0
        ),
    )
    .unwrap();
    let mut spec = SceneSpec::builtin("sphere").unwrap();
    spec.apply(&Overrides {
        size: Some(cam),
        supersample: Some(1),
        pattern_bits: Some(8),
        exposure: Some(exposure),
        ..Default::default()
    });
    // The rig's projector with a coarser DMD over the same field of view.
    let p = &mut spec.projector.lens;
    let s = PROJ.0 as f64 / p.width as f64;
    assert_eq!(PROJ.1 as f64 / p.height as f64, s, "same aspect ratio");
    (p.width, p.height) = PROJ;
    (p.fx, p.fy) = (p.fx * s, p.fy * s);
    (p.cx, p.cy) = ((p.cx + 0.5) * s - 0.5, (p.cy + 0.5) * s - 0.5);
    spec.patterns.set = Some(fringe3d::io::pattern_file::PatternSetFile::load(&set_file).unwrap());
    let scene = fringe3d::render::Scene::new(spec, None).unwrap();
    write_dataset(
        &scene,
        &dir,
        DatasetOptions {
            overwrite: true,
            progress: None,
        },
    )
    .unwrap();
    dir
}

/// The head's camera frames (layout: firmware-sim/board-mps2/src/bin/head.rs): the dataset's
/// images by wire pattern index, as the simulated head's replay camera delivers them.
fn write_frames(dataset: &Path, out: &Path) {
    let replay = Replay::load_dir(dataset).unwrap();
    let (w, h, bits) = (replay.width(), replay.height(), replay.bit_depth());
    let o = *replay.set.output();
    let count = replay.set.image_count() as u16;
    let sb: u8 = if bits <= 8 { 1 } else { 2 };
    let mut f = Vec::with_capacity(16 + count as usize * w as usize * h as usize * sb as usize);
    f.extend_from_slice(b"F3DC");
    for v in [w, h] {
        f.extend_from_slice(&v.to_le_bytes());
    }
    f.extend_from_slice(&[bits, sb]);
    for v in [count, o.width as u16, o.height as u16] {
        f.extend_from_slice(&v.to_le_bytes());
    }
    let mut row = vec![0u16; w as usize];
    for p in 0..count {
        for y in 0..h {
            replay.row(Shot::new(Some(p), 0), y, &mut row).unwrap();
            for s in &row {
                if sb == 1 {
                    f.push(*s as u8);
                } else {
                    f.extend_from_slice(&s.to_le_bytes());
                }
            }
        }
    }
    std::fs::write(out, f).unwrap();
}

/// The vertices of a binary little-endian PLY: (u, v, [x, y, z], validity).
fn read_ply(path: &Path) -> Vec<(u32, u32, [f32; 3], u8)> {
    let bytes = std::fs::read(path).unwrap();
    let end = bytes
        .windows(11)
        .position(|w| w == b"end_header\n")
        .expect("PLY header")
        + 11;
    let header = std::str::from_utf8(&bytes[..end]).unwrap();
    assert!(
        header.contains("format binary_little_endian 1.0"),
        "{header}"
    );
    let mut count = 0usize;
    let mut props: Vec<(String, usize)> = Vec::new();
    for line in header.lines() {
        let t: Vec<&str> = line.split_whitespace().collect();
        match t.as_slice() {
            ["element", "vertex", n] => count = n.parse().unwrap(),
            ["property", ty, name] => {
                let size = match *ty {
                    "char" | "uchar" | "int8" | "uint8" => 1,
                    "short" | "ushort" | "int16" | "uint16" => 2,
                    "int" | "uint" | "float" | "int32" | "uint32" | "float32" => 4,
                    "double" | "float64" => 8,
                    _ => panic!("PLY property type {ty}"),
                };
                props.push((format!("{ty} {name}"), size));
            }
            _ => {}
        }
    }
    let stride: usize = props.iter().map(|p| p.1).sum();
    assert_eq!(bytes.len(), end + count * stride, "PLY body size");
    let offset = |want: &str| {
        let mut at = 0;
        for (p, s) in &props {
            if p.ends_with(&format!(" {want}")) {
                return (at, p.clone());
            }
            at += s;
        }
        panic!("PLY has no property {want}: {header}")
    };
    let f32_at = |b: &[u8], o: usize| f32::from_le_bytes(b[o..o + 4].try_into().unwrap());
    let idx_at = |b: &[u8], (o, ty): &(usize, String)| {
        if ty.starts_with("ushort") || ty.starts_with("uint16") {
            u16::from_le_bytes(b[*o..*o + 2].try_into().unwrap()) as u32
        } else {
            u32::from_le_bytes(b[*o..*o + 4].try_into().unwrap())
        }
    };
    let (x, y, z) = (offset("x").0, offset("y").0, offset("z").0);
    let (u, v) = (offset("u"), offset("v"));
    let (q, ty) = offset("validity");
    assert!(ty.starts_with("uchar"), "{ty}");
    bytes[end..]
        .chunks_exact(stride)
        .map(|b| {
            (
                idx_at(b, &u),
                idx_at(b, &v),
                [f32_at(b, x), f32_at(b, y), f32_at(b, z)],
                b[q],
            )
        })
        .collect()
}

/// The organized PLY at `path` (a vertex per pixel, row-major, with its validity code) holds
/// exactly the desktop's points and codes `desk`, bit for bit.
fn assert_ply_is(path: &Path, desk: &PointCloud, what: &str) {
    let w = desk.width;
    let pts = read_ply(path);
    assert_eq!(
        pts.len(),
        w * desk.height,
        "{what}: organized, one vertex per pixel"
    );
    assert_eq!(
        pts.iter().filter(|p| p.3 == 0).count(),
        desk.valid_count(),
        "{what} valid points: emulated head vs desktop"
    );
    for (i, (u, v, xyz, code)) in pts.iter().enumerate() {
        assert_eq!(
            (*u as usize, *v as usize),
            (i % w, i / w),
            "{what}: vertex {i}"
        );
        assert_eq!(*code, desk.validity[i], "{what}: validity at ({u}, {v})");
        if *code == 0 {
            assert_eq!(
                bits(xyz),
                bits(&desk.xyz[3 * i..3 * i + 3]),
                "{what}: point at ({u}, {v})"
            );
        } else {
            assert!(xyz.iter().all(|c| c.is_nan()), "{what}: ({u}, {v}) not NaN");
        }
    }
}

fn bits(v: &[f32]) -> Vec<u32> {
    v.iter().map(|x| canonical(*x).to_bits()).collect()
}

/// `fringe3d ARGS…` in this process, timed.
fn fringe3d(args: &[&str]) -> f64 {
    let t0 = Instant::now();
    let mut all = vec!["fringe3d", "--quiet"];
    all.extend_from_slice(args);
    if let Err(e) = fringe3d::cli::run(all.clone()) {
        panic!("`{}` failed: {e:#}", all.join(" "));
    }
    t0.elapsed().as_secs_f64()
}

#[test]
fn emulated_head_through_qemu_serial_pty_scans_bit_identically_to_the_desktop() {
    if skip_without_tools("qemu_head_pty") {
        return;
    }
    let root = std::env::temp_dir().join(format!("fringe3d-qemu-head-pty-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&root);
    std::fs::create_dir_all(&root).unwrap();
    let dir = dataset(&root, "sphere", CAM, 1.0);
    // The same scene four times as bright (HDR's long exposure: the sphere's lit side clips).
    let bright = dataset(&root, "bright", CAM, 4.0);
    let patterns = dir.join("patterns.toml");
    let calib = dir.join("calibration.toml");
    // The reference the head gets: `calibrate reference --virtual` with its defaults (the far
    // plane, the margin the geometry needs past the image), written into the calibration.
    let (p, c) = (patterns.to_str().unwrap(), calib.to_str().unwrap());
    fringe3d(&["calibrate", "reference", "--virtual", "-p", p, "-c", c]);

    // The desktop's answer, from the images: the decode and reconstruction of `fringe3d scan`.
    let ls = common::load_set(&patterns).unwrap();
    let imgs = common::load_images(&ls, &[], true).unwrap();
    let dec = common::decode(&ls.set, &imgs, common::decode_config(&imgs)).unwrap();
    let sc = ScanCalibration::load(&calib, ls.set.axis()).unwrap();
    let margin = sc.recon.margin();
    assert_ne!(
        margin,
        fringe3d_core::reconstruct::Margin::ZERO,
        "a map wider than the image"
    );
    let cloud = sc.reconstruct(&dec.phase, &dec.validity, true).unwrap();
    let (w, h) = (CAM.0 as usize, CAM.1 as usize);
    assert_eq!((cloud.width, cloud.height), (w, h));
    assert!(
        cloud.valid_count() > w * h / 4,
        "a real scene: {} valid points",
        cloud.valid_count()
    );

    let frames = root.join("frames.bin");
    write_frames(&dir, &frames);
    let t0 = Instant::now();
    let elf = build_firmware(BIN);
    eprintln!("firmware built in {:.1} s", t0.elapsed().as_secs_f64());
    let frames_bright = root.join("frames_bright.bin");
    write_frames(&bright, &frames_bright);
    let at = |f: &Path, us: u32| format!("{}@{us}", f.display());
    let (qemu, port) = Qemu::start(&elf, &[at(&frames_bright, 40_000), at(&frames, 10_000)]);
    eprintln!("emulated head on {port}");

    // The same commands as for the simulated head. The emulated UART takes PTY input slowly,
    // so answers get more time than on a real line (`--timeout-ms`).
    let port_args = ["--port", port.as_str(), "--timeout-ms", "5000"];
    fringe3d(&[&["device", "info"][..], &port_args[..]].concat());
    let t_up = fringe3d(
        &[
            &["device", "upload"][..],
            &port_args[..],
            &[
                "--patterns",
                patterns.to_str().unwrap(),
                "--calibration",
                calib.to_str().unwrap(),
            ][..],
        ]
        .concat(),
    );
    // A scan as `fringe3d scan` does it by default (edge filter at 80°), with the phase;
    // then one without the filter.
    let ply = root.join("head.ply");
    let tif = root.join("head_phase.tif");
    let t_scan = fringe3d(
        &[
            &["device", "scan"][..],
            &port_args[..],
            &[
                "--max-angle",
                "80",
                "--out",
                ply.to_str().unwrap(),
                "--phase-out",
                tif.to_str().unwrap(),
            ][..],
        ]
        .concat(),
    );
    let ply_raw = root.join("head_unfiltered.ply");
    fringe3d(
        &[
            &["device", "scan"][..],
            &port_args[..],
            &["--no-edge-filter", "--out", ply_raw.to_str().unwrap()][..],
        ]
        .concat(),
    );
    // HDR (protocol version 8): the bright capture, then the sequence's own exposure where it
    // clipped, fused on the head as its frames arrive.
    let tif_hdr = root.join("head_hdr_phase.tif");
    let t_hdr = fringe3d(
        &[
            &["device", "scan"][..],
            &port_args[..],
            &[
                "--exposures-us",
                "40000,10000",
                "--output",
                "phase",
                "--phase-out",
                tif_hdr.to_str().unwrap(),
            ][..],
        ]
        .concat(),
    );
    fringe3d(&[&["device", "info"][..], &port_args[..]].concat());
    let console = qemu.console_with(&format!("scan: {h} rows sent"), 3);
    drop(qemu);
    eprintln!(
        "upload of {} pattern bytes, calibration and {} map bytes (margin {:?}): {t_up:.1} s; scan of {w}x{h} (phase and filtered points): {t_scan:.1} s",
        8 * PROJ.0 * PROJ.1,
        sc.recon.map_width() * sc.recon.map_height() * 5,
        margin.to_array()
    );
    eprintln!("firmware console:\n{console}");

    // Phase: the TIFF holds the streamed phase rows.
    let (img, _) = read_gray(&tif).unwrap();
    assert_eq!((img.width as usize, img.height as usize), (w, h));
    let Pixels::F32(phase) = img.pixels else {
        panic!("the phase TIFF is not f32")
    };
    let same_phase = bits(&phase)
        .iter()
        .zip(bits(&dec.phase))
        .filter(|(a, b)| **a == *b)
        .count();
    assert_eq!(
        same_phase,
        w * h,
        "phases differ from the desktop's at {} of {} pixels",
        w * h - same_phase,
        w * h
    );

    // HDR: the desktop's `scan --hdr bright sphere` decode, bit for bit; the bright capture
    // alone clips where the fused one does not.
    let hdr_imgs = common::load_exposures(&ls, &[bright.clone(), dir.clone()], true).unwrap();
    let hdr = common::decode(&ls.set, &hdr_imgs, common::decode_config(&hdr_imgs)).unwrap();
    let bright_imgs = common::load_images(&ls, std::slice::from_ref(&bright), true).unwrap();
    let bright_dec =
        common::decode(&ls.set, &bright_imgs, common::decode_config(&bright_imgs)).unwrap();
    let saturated = |v: &[u8]| v.iter().filter(|&&c| c == 2).count();
    eprintln!(
        "HDR scan (2 exposures) {t_hdr:.1} s: {} pixels saturated in the bright capture, {} fused",
        saturated(&bright_dec.validity),
        saturated(&hdr.validity)
    );
    assert!(saturated(&bright_dec.validity) > saturated(&hdr.validity) + 100);
    let (img, _) = read_gray(&tif_hdr).unwrap();
    let Pixels::F32(hdr_phase) = img.pixels else {
        panic!("the HDR phase TIFF is not f32")
    };
    assert!(
        bits(&hdr_phase) == bits(&hdr.phase),
        "HDR phases differ from the desktop's"
    );

    // Points: each PLY is organized (a vertex per pixel, row-major, with its validity code) and
    // holds exactly the desktop's points and codes, bit for bit.
    let mut filtered = cloud.clone();
    fringe3d::scan::filter_edges(&mut filtered, &sc.edge_filter(80.0).unwrap());
    assert!(
        filtered.valid_count() < cloud.valid_count(),
        "the edge filter flags some points of the sphere's rim"
    );
    assert_ply_is(&ply, &filtered, "edge-filtered");
    assert_ply_is(&ply_raw, &cloud, "unfiltered");

    // The firmware's own report: it ran the three scans in its SRAM budget.
    assert!(
        console.matches(&format!("scan: {h} rows sent")).count() == 3,
        "{console}"
    );
    let _ = std::fs::remove_dir_all(&root);
}

/// The compiled reconstruction (protocol version 10) on the emulated head: `fringe3d compile`'s
/// models, uploaded after the calibration and map they were compiled from (`device upload
/// --compiled`); the head reads them row by row from its map store and leaves the pixels
/// without one to the search. Its edge-filtered scan must be the desktop's `scan --compiled`,
/// bit for bit. A camera of its own, smaller than the other test's, for the models take the
/// emulated UART's byte-at-a-time path (44 bytes a pixel).
#[test]
fn compiled_models_reconstruct_on_the_emulated_head_bit_identically() {
    if skip_without_tools("qemu_head_pty compiled") {
        return;
    }
    let root = std::env::temp_dir().join(format!(
        "fringe3d-qemu-head-compiled-{}",
        std::process::id()
    ));
    let _ = std::fs::remove_dir_all(&root);
    std::fs::create_dir_all(&root).unwrap();
    let dir = dataset(&root, "sphere", CAM_COMPILED, 1.0);
    let patterns = dir.join("patterns.toml");
    let calib = dir.join("calibration.toml");
    let (p, c) = (patterns.to_str().unwrap(), calib.to_str().unwrap());
    fringe3d(&["calibrate", "reference", "--virtual", "-p", p, "-c", c]);
    // At 30 µm: the bilinear cells of a 96 × 72 map bend too much for a smooth function at the
    // 0.1 µm of a full-size camera (docs/compiled.md, "How close to the search"). What is
    // checked here is the head's bits, not the models' accuracy.
    let f3c = root.join("reconstruction.f3c");
    let f = f3c.to_str().unwrap();
    fringe3d(&["compile", "-p", p, "-c", c, "--tolerance", "30", "-o", f]);

    // The desktop's answer: `fringe3d scan --compiled` (edge filter at 80°), and the search's.
    let ls = common::load_set(&patterns).unwrap();
    let imgs = common::load_images(&ls, &[], true).unwrap();
    let dec = common::decode(&ls.set, &imgs, common::decode_config(&imgs)).unwrap();
    let sc = ScanCalibration::load(&calib, ls.set.axis()).unwrap();
    let mut search = sc.reconstruct(&dec.phase, &dec.validity, true).unwrap();
    fringe3d::scan::filter_edges(&mut search, &sc.edge_filter(80.0).unwrap());
    let scc = sc.with_compiled(&f3c).unwrap();
    let mut compiled = scc.reconstruct(&dec.phase, &dec.validity, true).unwrap();
    fringe3d::scan::filter_edges(&mut compiled, &scc.edge_filter(80.0).unwrap());
    let (w, h) = (CAM_COMPILED.0 as usize, CAM_COMPILED.1 as usize);
    let models = scc.compiled_file().map_or(0, |f| f.compiled_count());
    let differ = bits(&compiled.xyz)
        .chunks(3)
        .zip(bits(&search.xyz).chunks(3))
        .filter(|(a, b)| a != b)
        .count();
    assert!(
        models > w * h / 2 && differ > compiled.valid_count() / 10,
        "too few compiled points to tell whether the head used them: {models} models, \
         {differ} of {} points differ from the search's",
        compiled.valid_count()
    );

    let frames = root.join("frames.bin");
    write_frames(&dir, &frames);
    let elf = build_firmware(BIN);
    let (qemu, port) = Qemu::start(&elf, &[format!("{}@10000", frames.display())]);
    let port_args = ["--port", port.as_str(), "--timeout-ms", "5000"];
    let t_up = fringe3d(
        &[
            &["device", "upload"][..],
            &port_args[..],
            &["--patterns", p, "--calibration", c, "--compiled", f][..],
        ]
        .concat(),
    );
    let ply = root.join("head_compiled.ply");
    let t_scan = fringe3d(
        &[
            &["device", "scan"][..],
            &port_args[..],
            &["--max-angle", "80", "--out", ply.to_str().unwrap()][..],
        ]
        .concat(),
    );
    // ScanDone's counts (protocol version 11): the pixels decoded, and those the models left
    // to the search, as the desktop's kernel leaves them.
    let decoded = dec.validity.iter().filter(|&&q| q == 0).count();
    let file = scc.compiled_file().expect("models");
    let left = file
        .left_to_search(&dec.phase, &dec.validity)
        .unwrap()
        .len();
    let serial = fringe3d::device::open_serial(&port, 921_600).unwrap();
    let opts = fringe3d::device::ClientOptions {
        timeout: Duration::from_millis(5000),
        ..Default::default()
    };
    let mut client = fringe3d::device::Client::connect(serial, opts).unwrap();
    let out = client
        .scan(
            fringe3d_core::wire::ScanOutput::Points,
            0,
            0,
            fringe3d_core::wire::EdgeFilterMode::MaxAngle(80.0),
            &mut |_, _| {},
        )
        .unwrap();
    drop(client);
    let want = fringe3d::scan::ScanCounts {
        decoded,
        searched: left,
    };
    match out.rescans {
        0 => assert_eq!(
            out.counts,
            Some(want),
            "the emulated head's ScanDone counts"
        ),
        n => assert_eq!(out.counts, None, "counts after {n} re-requests"),
    }
    assert!(
        left < decoded,
        "{left} of {decoded} pixels left to the search"
    );
    let console = qemu.console_with(&format!("scan: {h} rows sent"), 2);
    drop(qemu);
    eprintln!(
        "compiled: {models} of {} pixels have a model, {differ} points differ from the search's, \
         {left} of {decoded} decoded pixels left to the search; upload of patterns, calibration, \
         map and models {t_up:.1} s, scan {t_scan:.1} s",
        w * h
    );
    assert_ply_is(&ply, &compiled, "compiled");
    assert!(
        console.matches(&format!("scan: {h} rows sent")).count() == 2,
        "{console}"
    );
    let _ = std::fs::remove_dir_all(&root);
}

/// Not a check: writes the emulated head's frames file for a dataset folder, for running the head
/// by hand (docs/firmware.md): `FRINGE3D_DATASET=scan FRINGE3D_FRAMES=scan/frames.bin cargo test
/// -p fringe3d-tests --test suite -- --ignored qemu_head_pty::frames_file`.
#[test]
#[ignore]
fn frames_file() {
    let (Some(dataset), Some(out)) = (
        std::env::var_os("FRINGE3D_DATASET"),
        std::env::var_os("FRINGE3D_FRAMES"),
    ) else {
        eprintln!(
            "set FRINGE3D_DATASET (a dataset folder) and FRINGE3D_FRAMES (the file to write)"
        );
        return;
    };
    write_frames(Path::new(&dataset), Path::new(&out));
    eprintln!(
        "wrote {} for {}",
        Path::new(&out).display(),
        Path::new(&dataset).display()
    );
}
