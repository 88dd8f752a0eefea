//! The simulated head on a real pseudo-terminal, driven by the host's `fringe3d device` code:
//! upload a rendered dataset's pattern set (8 × 1024 × 768, curved fringes), its calibration
//! (the renderer's, arbitrary f64 values) and reference map, scan, and compare the streamed
//! phases and points bit for bit with what the desktop computes from the same images
//! (`batch::decode_frames` through `cli::common::decode`, then
//! `scan::ScanCalibration::reconstruct` and the edge filter, the path of `fringe3d scan`).
//! `fringe3d device scan --out` writes an organized PLY equal, vertex for vertex, to the one
//! `fringe3d scan --organized` writes from the images. A scan interrupted mid-stream (the
//! client's interrupt flag, as Ctrl-C sets it) is aborted on the head: it stops streaming and
//! the next scan works. The CLI's start / stop / abort drive the trigger sequence. Then the cable
//! is pulled mid-upload: a clear error, and the upload resumes on the new port.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, mpsc};
use std::time::{Duration, Instant};

use fringe3d::batch::Decoded;
use fringe3d::cli::common;
use fringe3d::device::client::ScanOutcome;
use fringe3d::device::desc::{
    capture_sequence, fidelity, pattern_bytes, pattern_desc, phase_map_bytes, render_pattern,
    wire_calibration,
};
use fringe3d::device::{Client, ClientOptions, DeviceError, open_serial};
use fringe3d::io::calibration::Calibration;
use fringe3d::render::dataset::{DatasetOptions, write_dataset};
use fringe3d::render::{Overrides, SceneSpec};
use fringe3d::scan::{PointCloud, ScanCalibration, filter_edges};
use fringe3d_core::math::canonical;
use fringe3d_core::phase_function::Profile;
use fringe3d_core::reconstruct::Margin;
use fringe3d_core::validity::Validity;
use fringe3d_core::wire::{EdgeFilterMode, HeadState, ScanOutput, ValidationStatus};
use fringe3d_head::desktop::{OwnedMemory, Pty, Replay, ReplaySeries, serve, sim_board};
use fringe3d_head::port::QUEUE_LEN;
use fringe3d_head::sim::{FrameSource, NoSink, SimWorld};
use fringe3d_head::{Head, HeadConfig, MemoryPlan, MemoryReport};

pub(crate) const CAM: (u32, u32) = (320, 256);

/// A small rendered sphere scene under the curved fringes of examples/patterns/curved.toml
/// (parameters and derived slope not f32-exact).
pub(crate) fn dataset(root: &Path) -> PathBuf {
    dataset_with(
        root,
        "version = 1\npreset = \"paper8\"\nratio = 8.0\n[projector]\nwidth = 1024\nheight = 768\nbit_depth = 8\n\
         [phase]\naxis = \"xi\"\nkind = \"centered\"\nspan = 5.2\ncurvature = 0.0002\nbend_center = 383.5\n",
    )
}

/// An empty scratch folder `fringe3d-head-pty[-TAG]-PID` under the temp dir.
pub(crate) fn fresh_root(tag: &str) -> PathBuf {
    let name = if tag.is_empty() {
        format!("fringe3d-head-pty-{}", std::process::id())
    } else {
        format!("fringe3d-head-pty-{tag}-{}", std::process::id())
    };
    let root = std::env::temp_dir().join(name);
    let _ = std::fs::remove_dir_all(&root);
    std::fs::create_dir_all(&root).unwrap();
    root
}

/// The sphere scene rendered under the pattern-set file `set`.
fn dataset_with(root: &Path, set: &str) -> PathBuf {
    dataset_defocused(root, set, None)
}

/// [`dataset_with`] through a projector blurred by `defocus` pixels (its calibration records
/// the blur as `projector_defocus`).
fn dataset_defocused(root: &Path, set: &str, defocus: Option<f64>) -> PathBuf {
    let dir = root.join("sphere");
    let set_file = root.join("set.toml");
    std::fs::write(&set_file, set).unwrap();
    let mut spec = SceneSpec::builtin("sphere").unwrap();
    spec.apply(&Overrides {
        size: Some(CAM),
        supersample: Some(1),
        pattern_bits: Some(8),
        defocus,
        ..Default::default()
    });
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

/// `true` if some number of the calibration the head uses is not an f32 (so that carrying f32
/// would lose it).
fn has_non_f32_values(c: &Calibration) -> bool {
    let r = c.reference.as_ref().unwrap();
    let cam = &c.camera;
    let mut all = vec![cam.fx, cam.fy, cam.cx, cam.cy, cam.skew];
    all.extend(cam.distortion.to_array());
    all.extend(c.projector_centre);
    all.extend(c.depth_range);
    all.extend(r.point);
    all.extend(r.normal);
    all.iter().filter(|&&v| (v as f32) as f64 != v).count() >= 3
}

pub(crate) enum Cmd {
    Replug,
    Exit,
}

/// The head in its own thread (its simulated board is single-threaded), serving one PTY per
/// "plug-in"; sends each PTY path, and at exit the memory report.
fn spawn_head(
    dataset: PathBuf,
    stop: Arc<AtomicBool>,
) -> (
    mpsc::Receiver<String>,
    mpsc::Sender<Cmd>,
    std::thread::JoinHandle<MemoryReport>,
) {
    spawn_head_series(vec![(10_000, dataset)], stop)
}

/// [`spawn_head`] whose camera replays one dataset per exposure (µs; `ReplaySeries`).
pub(crate) fn spawn_head_series(
    takes: Vec<(u32, PathBuf)>,
    stop: Arc<AtomicBool>,
) -> (
    mpsc::Receiver<String>,
    mpsc::Sender<Cmd>,
    std::thread::JoinHandle<MemoryReport>,
) {
    let (path_tx, path_rx) = mpsc::channel();
    let (cmd_tx, cmd_rx) = mpsc::channel();
    let h = std::thread::spawn(move || {
        let takes = takes
            .iter()
            .map(|(us, d)| (*us, Replay::load_dir(d).unwrap()))
            .collect();
        let replay = ReplaySeries::new(takes).unwrap();
        let o = *replay.first().set.output();
        let (w, h) = (replay.width() as usize, replay.height() as usize);
        let world = SimWorld::new(1_000_000);
        // Reference maps up to 256 px past the image on each side (issue #17).
        let m = 256;
        let plan = MemoryPlan::new(w, h, o.width as usize, 3, h).with_margin_columns(2 * m);
        let mut mem = OwnedMemory::new(plan);
        let board = sim_board(
            &world,
            replay,
            NoSink,
            (o.width as u16, o.height as u16),
            8 << 20,
            (w + 2 * m) * (h + 2 * m) * 5 + w * h * fringe3d_core::wire::COMPILED_BYTES_PER_PIXEL,
        );
        let mut head = Head::new(board, mem.memory(), HeadConfig::DEFAULT).unwrap();
        head.set_queue_sizes(QUEUE_LEN, QUEUE_LEN);
        loop {
            let pty = Pty::open().unwrap();
            path_tx.send(pty.path().to_string()).unwrap();
            serve(&mut head, &pty, &stop, |_| {});
            drop(pty); // the cable is out
            match cmd_rx.recv() {
                Ok(Cmd::Replug) => stop.store(false, Ordering::SeqCst),
                _ => break,
            }
        }
        head.memory_report()
    });
    (path_rx, cmd_tx, h)
}

pub(crate) fn opts() -> ClientOptions {
    ClientOptions {
        timeout: Duration::from_millis(1500),
        retries: 6,
        window: 4,
        scan_timeout: Duration::from_secs(60),
    }
}

/// A head's scan (phase and points) equals the desktop's decode and filtered cloud, bit for bit.
pub(crate) fn assert_desktop_bits(out: &ScanOutcome, dec: &Decoded, cloud: &PointCloud) {
    assert!(
        bits(out.phase.as_ref().unwrap()) == bits(&dec.phase),
        "phases differ from the desktop's"
    );
    assert!(
        out.phase_validity.as_ref().unwrap() == &dec.validity,
        "phase validity differs"
    );
    assert!(
        bits(out.xyz.as_ref().unwrap()) == bits(&cloud.xyz),
        "points differ from the desktop's"
    );
    assert!(
        out.point_validity.as_ref().unwrap() == &cloud.validity,
        "point validity differs"
    );
}

fn bits(v: &[f32]) -> Vec<u32> {
    v.iter().map(|x| canonical(*x).to_bits()).collect()
}

/// A binary little-endian PLY: its header, and per vertex the bytes of each named property.
struct Ply {
    header: String,
    count: usize,
    props: Vec<(String, usize, usize)>,
    stride: usize,
    body: Vec<u8>,
}

impl Ply {
    fn read(path: &Path) -> Ply {
        let bytes = std::fs::read(path).unwrap();
        let end = bytes
            .windows(11)
            .position(|w| w == b"end_header\n")
            .expect("PLY header")
            + 11;
        let header = std::str::from_utf8(&bytes[..end]).unwrap().to_string();
        assert!(
            header.contains("format binary_little_endian 1.0"),
            "{header}"
        );
        let (mut count, mut props, mut at) = (0usize, Vec::new(), 0usize);
        for line in header.lines() {
            match line.split_whitespace().collect::<Vec<_>>().as_slice() {
                ["element", "vertex", n] => count = n.parse().unwrap(),
                ["property", ty, name] => {
                    let size = match *ty {
                        "uchar" => 1,
                        "ushort" => 2,
                        "uint" | "float" => 4,
                        _ => panic!("PLY property type {ty}"),
                    };
                    props.push((name.to_string(), at, size));
                    at += size;
                }
                _ => {}
            }
        }
        assert_eq!(bytes.len(), end + count * at, "PLY body size");
        Ply {
            header,
            count,
            props,
            stride: at,
            body: bytes[end..].to_vec(),
        }
    }

    /// The bytes of property `name` of every vertex, concatenated.
    fn column(&self, name: &str) -> Vec<u8> {
        let &(_, at, size) = self
            .props
            .iter()
            .find(|p| p.0 == name)
            .unwrap_or_else(|| panic!("no property {name}: {}", self.header));
        self.body
            .chunks_exact(self.stride)
            .flat_map(|v| v[at..at + size].to_vec())
            .collect()
    }
}

#[test]
fn full_scan_through_a_pty_is_bit_identical_to_the_desktop_and_survives_an_unplug() {
    let root = fresh_root("");
    let t0 = Instant::now();
    let dir = dataset(&root);
    eprintln!("dataset rendered in {:.1} s", t0.elapsed().as_secs_f64());

    // The desktop's answer, `fringe3d scan`'s path: decode, reconstruct, edge filter (80°).
    let patterns = dir.join("patterns.toml");
    let calib = dir.join("calibration.toml");
    let ls = common::load_set(&patterns).unwrap();
    assert!(ls.set.function().curvature() != 0.0);
    assert!(
        matches!(ls.set.function().profile(), Profile::Linear { slope, .. } if (*slope as f32) as f64 != *slope)
    );
    assert!(has_non_f32_values(&Calibration::load(&calib).unwrap()));
    let imgs = common::load_images(&ls, &[], true).unwrap();
    let dec = common::decode(&ls.set, &imgs, common::decode_config(&imgs)).unwrap();
    let sc = ScanCalibration::load(&calib, ls.set.axis()).unwrap();
    let raw = sc.reconstruct(&dec.phase, &dec.validity, true).unwrap();
    let mut cloud = raw.clone();
    filter_edges(&mut cloud, &sc.edge_filter(80.0).unwrap());
    assert!(
        cloud.valid_count() > (CAM.0 * CAM.1 / 4) as usize,
        "a real scene: {} valid points",
        cloud.valid_count()
    );
    let edges = cloud
        .validity
        .iter()
        .filter(|&&v| v == Validity::DepthEdge as u8)
        .count();
    assert!(
        edges > 50,
        "the filter flags the silhouette: {edges} points"
    );

    // What the host sends.
    let set = &ls.set;
    let desc = pattern_desc(set, ls.file.bit_depth()).unwrap();
    let fid = fidelity(set, &desc, imgs.bits as u32);
    assert!(fid.patterns && fid.decoder, "{fid:?}");
    let data = pattern_bytes(set, &desc, |i| render_pattern(set, i)).unwrap();
    assert_eq!(data.len(), 8 * 1024 * 768);
    let cal = Calibration::load(&calib).unwrap();
    let wcal = wire_calibration(&cal).unwrap();
    let map = phase_map_bytes(&sc.reference_phase, sc.width());

    let stop = Arc::new(AtomicBool::new(false));
    let (paths, cmd, head) = spawn_head(dir.clone(), stop.clone());
    let port = paths.recv().unwrap();

    // The CLI's info command on the port.
    fringe3d::cli::run(["fringe3d", "--quiet", "device", "info", "--port", &port]).unwrap();

    let mut c = Client::connect(open_serial(&port, 921_600).unwrap(), opts()).unwrap();
    assert_eq!(
        (
            c.capabilities().sensor_width,
            c.capabilities().sensor_height
        ),
        (CAM.0 as u16, CAM.1 as u16)
    );
    c.define_pattern_set(0, &desc).unwrap();
    let up = c.upload_patterns(0, &desc, &data, &mut |_, _| {}).unwrap();
    eprintln!(
        "PTY upload of 8 x 1024 x 768 patterns: {} data bytes, {} on the wire, {:.3} s ({:.1} MB/s)",
        up.total,
        up.wire_bytes,
        up.seconds,
        up.wire_bytes as f64 / up.seconds / 1e6
    );
    c.upload_calibration(&wcal).unwrap();
    c.upload_phase_map(
        CAM.0 as u16,
        CAM.1 as u16,
        Margin::ZERO,
        &map,
        &mut |_, _| {},
    )
    .unwrap();
    c.configure_sequence(
        0,
        false,
        &capture_sequence(set, &desc, 10_000, 2_000).unwrap(),
    )
    .unwrap();
    assert_eq!(c.validate().unwrap(), ValidationStatus::OK);

    let out = c
        .scan(
            ScanOutput::Both,
            0,
            0,
            EdgeFilterMode::MaxAngle(80.0),
            &mut |_, _| {},
        )
        .unwrap();
    eprintln!(
        "PTY scan of {}x{} phase + points: {} bytes received in {:.3} s",
        CAM.0, CAM.1, out.wire_bytes, out.seconds
    );
    assert_eq!(out.rescans, 0);
    assert_desktop_bits(&out, &dec, &cloud);
    // A band of rows: filtered with their true neighbours, as in the whole cloud; and the last
    // rows (no row below). Unfiltered points equal the desktop's unfiltered cloud.
    let w = CAM.0 as usize;
    for (first, n) in [(60u16, 9u16), (CAM.1 as u16 - 5, 5)] {
        let part = c
            .scan(
                ScanOutput::Points,
                first,
                n,
                EdgeFilterMode::MaxAngle(80.0),
                &mut |_, _| {},
            )
            .unwrap();
        let r = first as usize * w..(first + n) as usize * w;
        assert!(bits(part.xyz.as_ref().unwrap()) == bits(&cloud.xyz[3 * r.start..3 * r.end]));
        assert!(part.point_validity.as_ref().unwrap()[..] == cloud.validity[r]);
    }
    let unf = c
        .scan(
            ScanOutput::Points,
            0,
            0,
            EdgeFilterMode::Off,
            &mut |_, _| {},
        )
        .unwrap();
    assert!(
        bits(unf.xyz.as_ref().unwrap()) == bits(&raw.xyz),
        "unfiltered points differ"
    );
    assert!(unf.point_validity.as_ref().unwrap() == &raw.validity);

    // The CLI scan writes the cloud.
    drop(c);
    let ply = root.join("cloud.ply");
    fringe3d::cli::run([
        "fringe3d",
        "--quiet",
        "device",
        "scan",
        "--port",
        &port,
        "--out",
        ply.to_str().unwrap(),
    ])
    .unwrap();
    assert!(std::fs::metadata(&ply).unwrap().len() > 12 * cloud.valid_count() as u64);
    // Organized, with validity codes, and equal vertex for vertex to what `fringe3d scan
    // --organized` writes from the images (the head streams no intensity or modulation).
    let batch = root.join("batch.ply");
    fringe3d::cli::run([
        "fringe3d",
        "--quiet",
        "scan",
        "-p",
        patterns.to_str().unwrap(),
        "-c",
        calib.to_str().unwrap(),
        "--organized",
        "-o",
        batch.to_str().unwrap(),
    ])
    .unwrap();
    let (dev, bat) = (Ply::read(&ply), Ply::read(&batch));
    assert_eq!(dev.count, w * CAM.1 as usize, "one vertex per pixel");
    assert!(
        dev.header.contains(&format!("obj_info num_cols {w}"))
            && dev.header.contains("property uchar validity"),
        "{}",
        dev.header
    );
    assert_eq!(bat.count, dev.count);
    for name in ["x", "y", "z", "u", "v", "validity"] {
        assert!(
            dev.column(name) == bat.column(name),
            "PLY property {name} differs"
        );
    }
    assert_eq!(dev.column("validity"), cloud.validity);

    // Ctrl-C mid-scan (the interrupt flag the CLI's signal handler sets): the client aborts the
    // head's scan, which stops streaming; the head is not left scanning.
    let mut c = Client::connect(open_serial(&port, 921_600).unwrap(), opts()).unwrap();
    let flag = Arc::new(AtomicBool::new(false));
    c.set_interrupt(flag.clone());
    let rows_before = c.status().unwrap().rows_sent;
    let f = flag.clone();
    let e = c
        .scan(
            ScanOutput::Both,
            0,
            0,
            EdgeFilterMode::MaxAngle(80.0),
            &mut |done, _| {
                if done >= 8 {
                    f.store(true, Ordering::SeqCst);
                }
            },
        )
        .unwrap_err();
    let m = e.to_string();
    assert!(
        matches!(e, DeviceError::Interrupted { .. }) && m.contains("the head's scan was aborted"),
        "{m}"
    );
    flag.store(false, Ordering::SeqCst);
    drop(c);
    let mut c = Client::connect(open_serial(&port, 921_600).unwrap(), opts()).unwrap();
    // The head handles the abort in its own loop: on a loaded machine the first status may
    // still say Scanning. It must stop within a few seconds, not be left scanning.
    let t0 = std::time::Instant::now();
    let mut st = c.status().unwrap();
    while st.state == HeadState::Scanning && t0.elapsed() < std::time::Duration::from_secs(5) {
        std::thread::sleep(std::time::Duration::from_millis(20));
        st = c.status().unwrap();
    }
    assert_ne!(st.state, HeadState::Scanning, "still scanning after 5 s");
    assert!(
        st.rows_sent - rows_before < CAM.1,
        "the head stopped streaming: {} of {} rows sent",
        st.rows_sent - rows_before,
        CAM.1
    );
    let again = c
        .scan(
            ScanOutput::Points,
            0,
            0,
            EdgeFilterMode::MaxAngle(80.0),
            &mut |_, _| {},
        )
        .unwrap();
    assert!(bits(again.xyz.as_ref().unwrap()) == bits(&cloud.xyz));
    drop(c);

    // The trigger sequence from the CLI: once (back to ready by itself), then repeating until
    // stop; abort clears it too.
    let cli =
        |what: &str| fringe3d::cli::run(["fringe3d", "--quiet", "device", what, "--port", &port]);
    let status = || {
        let mut c = Client::connect(open_serial(&port, 921_600).unwrap(), opts()).unwrap();
        c.status().unwrap()
    };
    let rows0 = status().rows_sent;
    cli("start").unwrap();
    let deadline = Instant::now() + Duration::from_secs(20);
    while status().state != HeadState::Ready {
        assert!(Instant::now() < deadline, "a single run ends by itself");
    }
    let seq = capture_sequence(set, &desc, 10_000, 2_000).unwrap();
    let mut c = Client::connect(open_serial(&port, 921_600).unwrap(), opts()).unwrap();
    c.configure_sequence(0, true, &seq).unwrap();
    assert_eq!(c.validate().unwrap(), ValidationStatus::OK);
    drop(c);
    cli("start").unwrap();
    std::thread::sleep(Duration::from_millis(300));
    assert_eq!(
        status().state,
        HeadState::Running,
        "a repeating sequence runs until stopped"
    );
    cli("stop").unwrap();
    assert_eq!(status().state, HeadState::Ready);
    cli("start").unwrap();
    assert_eq!(status().state, HeadState::Running);
    cli("abort").unwrap();
    let st = status();
    assert_eq!(
        (st.state, st.rows_sent),
        (HeadState::Ready, rows0),
        "nothing streamed"
    );
    let mut c = Client::connect(open_serial(&port, 921_600).unwrap(), opts()).unwrap();
    c.configure_sequence(0, false, &seq).unwrap();
    drop(c);

    // Pull the cable a third of the way into an upload of other data.
    let mut c = Client::connect(open_serial(&port, 921_600).unwrap(), opts()).unwrap();
    let mut other = data.clone();
    other[0] ^= 1;
    let s2 = stop.clone();
    let third = other.len() as u64 / 3;
    let err = c
        .upload_patterns(0, &desc, &other, &mut |done, _| {
            if done >= third {
                s2.store(true, Ordering::SeqCst);
            }
        })
        .unwrap_err();
    let msg = err.to_string();
    eprintln!("unplugged: {msg}");
    let DeviceError::UploadInterrupted { acked, .. } = &err else {
        panic!("{msg}")
    };
    let acked = *acked;
    assert!(acked >= third && acked < other.len() as u64, "{msg}");
    assert!(
        msg.contains("disconnected") || msg.contains("no answer"),
        "{msg}"
    );
    drop(c);

    // Plugged in again (a new port): the set is unusable until the resumed upload is confirmed.
    cmd.send(Cmd::Replug).unwrap();
    let port = paths.recv().unwrap();
    let mut c = Client::connect(open_serial(&port, 921_600).unwrap(), opts()).unwrap();
    assert!(
        c.validate()
            .unwrap()
            .has(ValidationStatus::SET_NOT_CONFIRMED)
    );
    let r = c.upload_patterns(0, &desc, &other, &mut |_, _| {}).unwrap();
    assert!(r.resumed_from >= acked, "{r:?}");
    assert!(
        r.wire_bytes < other.len() as u64 - acked + 200_000,
        "resumed, not restarted: {r:?}"
    );
    assert_eq!(c.validate().unwrap(), ValidationStatus::OK);
    drop(c);
    stop.store(true, Ordering::SeqCst);
    cmd.send(Cmd::Exit).unwrap();
    let m = head.join().unwrap();
    eprintln!("head peak memory: {m:?}, total {} B", m.total());
    assert_eq!(m.decode_state, 7 * (CAM.0 * CAM.1) as usize * 4);
    let _ = std::fs::remove_dir_all(&root);
}

/// Throughput over an unthrottled PTY at full size (1280 × 1024 camera): the upload of the
/// 8 × 1024 × 768 set and the stream of the point cloud. Slow-ish (renders a full-size dataset),
/// so run on demand: `cargo test -p fringe3d-tests --test suite -- --ignored --nocapture head_pty::`.
#[test]
#[ignore]
fn pty_throughput_full_size() {
    let root = fresh_root("full");
    let set_file = root.join("set.toml");
    std::fs::write(
        &set_file,
        "version = 1\npreset = \"paper8\"\nratio = 8.0\n[projector]\nwidth = 1024\nheight = 768\nbit_depth = 8\n\
         [phase]\naxis = \"xi\"\nkind = \"linear\"\norigin = 511.5\nslope = 0.00390625\n",
    )
    .unwrap();
    let mut spec = SceneSpec::builtin("sphere").unwrap();
    spec.apply(&Overrides {
        supersample: Some(1),
        pattern_bits: Some(8),
        ..Default::default()
    });
    spec.patterns.set = Some(fringe3d::io::pattern_file::PatternSetFile::load(&set_file).unwrap());
    let scene = fringe3d::render::Scene::new(spec, None).unwrap();
    let dir = root.join("sphere");
    write_dataset(
        &scene,
        &dir,
        DatasetOptions {
            overwrite: true,
            progress: None,
        },
    )
    .unwrap();
    let calib = dir.join("calibration.toml");
    let ls = common::load_set(&dir.join("patterns.toml")).unwrap();
    let set = &ls.set;
    let desc = pattern_desc(set, 8).unwrap();
    let data = pattern_bytes(set, &desc, |i| render_pattern(set, i)).unwrap();
    let sc = ScanCalibration::load(&calib, set.axis()).unwrap();
    let map = phase_map_bytes(&sc.reference_phase, sc.width());
    let wcal = wire_calibration(&Calibration::load(&calib).unwrap()).unwrap();

    let stop = Arc::new(AtomicBool::new(false));
    let (paths, cmd, head) = spawn_head(dir.clone(), stop.clone());
    let port = paths.recv().unwrap();
    let mut c = Client::connect(open_serial(&port, 921_600).unwrap(), opts()).unwrap();
    c.define_pattern_set(0, &desc).unwrap();
    let up = c.upload_patterns(0, &desc, &data, &mut |_, _| {}).unwrap();
    println!(
        "PTY upload 8x1024x768: {} wire bytes in {:.3} s = {:.1} MB/s ({:.0}x the 921600-baud line rate)",
        up.wire_bytes,
        up.seconds,
        up.wire_bytes as f64 / up.seconds / 1e6,
        (up.wire_bytes as f64 / 92_160.0) / up.seconds
    );
    c.upload_calibration(&wcal).unwrap();
    let m = c
        .upload_phase_map(
            sc.width() as u16,
            sc.height() as u16,
            Margin::ZERO,
            &map,
            &mut |_, _| {},
        )
        .unwrap();
    println!(
        "PTY upload of the 1280x1024 reference map: {} bytes in {:.3} s",
        m.wire_bytes, m.seconds
    );
    c.configure_sequence(
        0,
        false,
        &capture_sequence(set, &desc, 10_000, 2_000).unwrap(),
    )
    .unwrap();
    for output in [ScanOutput::Points, ScanOutput::Phase] {
        let out = c
            .scan(output, 0, 0, EdgeFilterMode::MaxAngle(80.0), &mut |_, _| {})
            .unwrap();
        println!(
            "PTY scan {output:?} 1280x1024: {} bytes received in {:.3} s (capture, decode, reconstruct and stream) = {:.1} MB/s",
            out.wire_bytes,
            out.seconds,
            out.wire_bytes as f64 / out.seconds / 1e6
        );
    }
    drop(c);
    stop.store(true, Ordering::SeqCst);
    cmd.send(Cmd::Exit).unwrap();
    let m = head.join().unwrap();
    println!(
        "head peak memory at 1280x1024: {m:?}, total {} B",
        m.total()
    );
    let _ = std::fs::remove_dir_all(&root);
}

/// Gray code + phase shifting on the head (issue #20): a complementary 5-bit code ordering the
/// 20 periods of a 4-step level, curved fringes, listed Gray first (a `version = 2` file, the
/// order the desktop decodes the images in). The host captures it in the built-in order (the
/// head decodes frame by frame, thresholding each Gray image against the complete A); the
/// head's phases and points equal the desktop's bit for bit.
#[test]
fn a_gray_coded_set_scans_on_the_head_bit_identical_to_the_desktop() {
    let root = fresh_root("gray");
    let dir = dataset_with(
        &root,
        "version = 2\n[projector]\nwidth = 1024\nheight = 768\nbit_depth = 8\n\
         [phase]\naxis = \"xi\"\nkind = \"centered\"\nspan = 6.0\ncurvature = 0.0002\nbend_center = 383.5\n\
         [[levels]]\nscale = 20.0\ngray_bits = 5\n[[levels]]\nscale = 20.0\nsteps = 4\n",
    );
    let case = head_case(&dir);
    let (set, desc, seq) = (&case.set, &case.desc, &case.seq);
    assert!(
        set.gray().is_some() && set.image(0).unwrap().level == 0,
        "Gray first"
    );
    let data = pattern_bytes(set, desc, |i| render_pattern(set, i)).unwrap();
    assert_eq!(data.len(), 10 * 1024 * 768);
    let first = desc.pattern_id(seq[0].pattern).unwrap();
    assert_eq!(first.level, 1, "captured DC level first");
    on_head(&dir, &case, Some(&data), true, |c, v| {
        assert_eq!(v, ValidationStatus::OK);
        // Captured in the listed order (Gray first), the head refuses the scan and says why.
        let listed: Vec<_> = set
            .order()
            .iter()
            .map(|&id| fringe3d_core::wire::LutEntry {
                pattern: desc.pattern_index(id).unwrap(),
                ..seq[0]
            })
            .collect();
        c.configure_sequence(0, false, &listed).unwrap();
        let e = c
            .scan(ScanOutput::Phase, 0, 0, EdgeFilterMode::Off, &mut |_, _| {})
            .unwrap_err()
            .to_string();
        assert!(e.contains("a Gray-code pattern is captured before"), "{e}");
        c.configure_sequence(0, false, seq).unwrap();
        assert_eq!(c.validate().unwrap(), ValidationStatus::OK);
        assert_desktop_bits(&scan_both(c), &case.dec, &case.cloud);
    });
    let _ = std::fs::remove_dir_all(&root);
}

/// The desktop's decode (with the calibration's phase-error table, as `fringe3d scan` decodes)
/// and filtered cloud of a dataset, the table, and what a head is sent: the set's description
/// (12 images of 1024 × 768 exceed the simulated head's 8 MiB pattern store: it renders them
/// itself, which `fidelity` shows exact), the trigger sequence, the wire calibration and the
/// reference map.
pub(crate) struct HeadCase {
    pub(crate) set: fringe3d_core::pattern::PatternSet,
    pub(crate) dec: Decoded,
    pub(crate) cloud: PointCloud,
    pub(crate) table: Option<fringe3d_core::decode::PhaseCorrection>,
    pub(crate) desc: fringe3d_core::wire::PatternSetDesc,
    pub(crate) seq: Vec<fringe3d_core::wire::LutEntry>,
    pub(crate) wcal: fringe3d_core::wire::Calibration,
    pub(crate) map: Vec<u8>,
    pub(crate) margin: Margin,
}

pub(crate) fn head_case(dir: &Path) -> HeadCase {
    head_case_with(dir, &dir.join("calibration.toml"))
}

/// [`head_case`] with the calibration file `calib`.
pub(crate) fn head_case_with(dir: &Path, calib: &Path) -> HeadCase {
    let patterns = dir.join("patterns.toml");
    let ls = common::load_set(&patterns).unwrap();
    let set = &ls.set;
    let cal = Calibration::load(calib).unwrap();
    let table = common::response_correction(&cal, calib, &ls).unwrap();
    let imgs = common::load_images(&ls, &[], true).unwrap();
    let dec =
        common::decode_corrected(set, &imgs, common::decode_config(&imgs), table.as_ref()).unwrap();
    let sc = ScanCalibration::load(calib, set.axis()).unwrap();
    let mut cloud = sc.reconstruct(&dec.phase, &dec.validity, true).unwrap();
    filter_edges(&mut cloud, &sc.edge_filter(80.0).unwrap());
    assert!(cloud.valid_count() > (CAM.0 * CAM.1 / 4) as usize);
    let desc = pattern_desc(set, ls.file.bit_depth()).unwrap();
    let fid = fidelity(set, &desc, 8);
    assert!(
        fid.patterns && fid.decoder,
        "the head rebuilds the set exactly"
    );
    HeadCase {
        seq: capture_sequence(set, &desc, 10_000, 2_000).unwrap(),
        wcal: wire_calibration(&cal).unwrap(),
        map: phase_map_bytes(&sc.reference_phase, sc.recon.map_width()),
        margin: sc.recon.margin(),
        set: *set,
        dec,
        cloud,
        table,
        desc,
    }
}

/// Define `case` on a fresh head (its table too if `send_table`), upload its images if given (else the head
/// renders them), its calibration and map, configure its sequence; `f` then drives the client,
/// given the validation.
fn on_head(
    dir: &Path,
    case: &HeadCase,
    images: Option<&[u8]>,
    send_table: bool,
    f: impl FnOnce(&mut Client<fringe3d::device::SerialTransport>, ValidationStatus),
) {
    on_head_series(
        vec![(10_000, dir.to_path_buf())],
        case,
        images,
        send_table,
        f,
    )
}

/// [`on_head`] with a camera that replays one dataset per exposure (µs).
pub(crate) fn on_head_series(
    takes: Vec<(u32, PathBuf)>,
    case: &HeadCase,
    images: Option<&[u8]>,
    send_table: bool,
    f: impl FnOnce(&mut Client<fringe3d::device::SerialTransport>, ValidationStatus),
) {
    let stop = Arc::new(AtomicBool::new(false));
    let (paths, cmd, head) = spawn_head_series(takes, stop.clone());
    let port = paths.recv().unwrap();
    let mut c = Client::connect(open_serial(&port, 921_600).unwrap(), opts()).unwrap();
    c.define_pattern_set(0, &case.desc).unwrap();
    if send_table {
        c.define_correction(0, case.table.as_ref()).unwrap();
    }
    if let Some(data) = images {
        c.upload_patterns(0, &case.desc, data, &mut |_, _| {})
            .unwrap();
    }
    c.upload_calibration(&case.wcal).unwrap();
    c.upload_phase_map(
        CAM.0 as u16,
        CAM.1 as u16,
        case.margin,
        &case.map,
        &mut |_, _| {},
    )
    .unwrap();
    c.configure_sequence(0, false, &case.seq).unwrap();
    let v = c.validate().unwrap();
    f(&mut c, v);
    drop(c);
    stop.store(true, Ordering::SeqCst);
    cmd.send(Cmd::Exit).unwrap();
    head.join().unwrap();
}

pub(crate) fn scan_both(c: &mut Client<fringe3d::device::SerialTransport>) -> ScanOutcome {
    c.scan(
        ScanOutput::Both,
        0,
        0,
        EdgeFilterMode::MaxAngle(80.0),
        &mut |_, _| {},
    )
    .unwrap()
}

/// A shifted Gray code on the head (issue #20, protocol version 6: `Shifts::GrayShifted`): the
/// head renders the set itself from its description, captures it DC level first and decodes it
/// bit for bit as the desktop.
#[test]
fn a_shifted_gray_code_scans_on_the_head_bit_identical_to_the_desktop() {
    let root = fresh_root("gray-shifted");
    let dir = dataset_with(
        &root,
        "version = 2\n[projector]\nwidth = 1024\nheight = 768\nbit_depth = 8\n\
         [phase]\naxis = \"xi\"\nkind = \"centered\"\nspan = 6.0\n\
         [[levels]]\nscale = 20.0\ngray_bits = 5\ncomplementary = false\nshifted = true\n\
         [[levels]]\nscale = 20.0\nsteps = 4\n",
    );
    let case = head_case(&dir);
    assert!(case.set.gray().is_some_and(|g| g.is_shifted()));
    assert!(matches!(
        case.desc.levels[0].shifts,
        fringe3d_core::wire::Shifts::GrayShifted {
            bits: 5,
            inverse: false
        }
    ));
    on_head(&dir, &case, None, true, |c, v| {
        assert_eq!(v, ValidationStatus::OK);
        assert_desktop_bits(&scan_both(c), &case.dec, &case.cloud);
    });
    let _ = std::fs::remove_dir_all(&root);
}

/// `fringe3d calibrate reference --virtual` for the dataset `dir` with `--margin margin`, into
/// the calibration file `out`.
pub(crate) fn virtual_reference(dir: &Path, margin: &str, out: &Path) {
    let s = |p: &Path| p.to_str().unwrap().to_string();
    let (patterns, cal) = (dir.join("patterns.toml"), dir.join("calibration.toml"));
    let args = [
        "fringe3d",
        "--quiet",
        "calibrate",
        "reference",
        "--virtual",
        "-p",
        &s(&patterns),
        "-c",
        &s(&cal),
        "--margin",
        margin,
        "-o",
        &s(out),
    ];
    fringe3d::cli::run(args).unwrap();
}

/// A reference map wider than the image on the head (issue #17 item 3, protocol version 6):
/// the virtual map of the rig's projector on the default plane at the far end of the depth
/// range, with the margin the geometry needs (`calibrate reference --virtual`'s defaults). The
/// head's phases and points equal the desktop's bit for bit, and the margin carries points that
/// the same reference without it (`--margin 0`) loses.
#[test]
fn a_reference_map_wider_than_the_image_scans_on_the_head_bit_identical_to_the_desktop() {
    let root = fresh_root("margin");
    let dir = dataset(&root);
    let cal = dir.join("calibration.toml");
    let image_sized = root.join("image-sized/calibration.toml");
    virtual_reference(&dir, "0", &image_sized);
    virtual_reference(&dir, "auto", &cal);
    let case = head_case(&dir);
    assert_ne!(case.margin, Margin::ZERO);
    let narrow = head_case_with(&dir, &image_sized);
    let (with, without) = (case.cloud.valid_count(), narrow.cloud.valid_count());
    assert!(
        with > without + 100,
        "margin {:?}: {with} points against {without}",
        case.margin.to_array()
    );
    on_head(&dir, &case, None, true, |c, v| {
        assert_eq!(v, ValidationStatus::OK);
        assert_desktop_bits(&scan_both(c), &case.dec, &case.cloud);
    });
    let _ = std::fs::remove_dir_all(&root);
}

/// Multi-frequency heterodyne on the head (issue #20, protocol version 4): periods of about
/// 54, 44 and 36 pixels across the projector, no level within one period, unwrapped from the
/// beats; the head's phases and points equal the desktop's bit for bit.
#[test]
fn a_heterodyne_set_scans_on_the_head_bit_identical_to_the_desktop() {
    let root = fresh_root("het");
    let dir = dataset_with(
        &root,
        "version = 2\nunwrap = \"heterodyne\"\n[projector]\nwidth = 1024\nheight = 768\nbit_depth = 8\n\
         [[levels]]\nscale = 21.0\nsteps = 4\n[[levels]]\nscale = 26.0\nsteps = 4\n\
         [[levels]]\nscale = 32.0\nsteps = 4\n",
    );
    let case = head_case(&dir);
    assert_eq!(
        case.desc.relation,
        fringe3d_core::wire::Relation::Heterodyne
    );
    assert!(case.table.is_none());
    on_head(&dir, &case, None, true, |c, v| {
        assert_eq!(v, ValidationStatus::OK);
        assert_desktop_bits(&scan_both(c), &case.dec, &case.cloud);
    });
    let _ = std::fs::remove_dir_all(&root);
}

/// Binary (Bayer-dithered) patterns through a projector blurred by 3 pixels, on the head
/// (issue #20 item 3, protocol version 4): without its phase-error table the head refuses the
/// sequence and says why; with the table of the calibration's `projector_defocus`
/// (DefineCorrection) its phases and points equal the desktop's bit for bit, and clearing the
/// table refuses again.
#[test]
fn a_binary_set_scans_on_the_head_with_its_table_bit_identical_to_the_desktop() {
    let root = fresh_root("bin");
    let dir = dataset_defocused(
        &root,
        &format!(
            "version = 2\nbinary = \"bayer\"\n[projector]\nwidth = 1024\nheight = 768\nbit_depth = 8\n\
             [phase]\naxis = \"xi\"\nkind = \"linear\"\norigin = 511.5\nslope = {}\n\
             [[levels]]\nscale = 1.0\nsteps = 4\n[[levels]]\nscale = 6.0\nsteps = 4\n\
             [[levels]]\nscale = 32.0\nsteps = 4\n",
            std::f64::consts::TAU / 1024.0
        ),
        Some(3.0),
    );
    let case = head_case(&dir);
    assert!(
        case.table.is_some(),
        "a binary set is decoded with its table"
    );
    on_head(&dir, &case, None, false, |c, v| {
        assert!(v.has(ValidationStatus::NO_CORRECTION), "{v:?}");
        let e = c
            .scan(ScanOutput::Phase, 0, 0, EdgeFilterMode::Off, &mut |_, _| {})
            .unwrap_err()
            .to_string();
        assert!(e.contains("no phase-error table"), "{e}");
        c.define_correction(0, case.table.as_ref()).unwrap();
        assert_eq!(c.validate().unwrap(), ValidationStatus::OK);
        assert_desktop_bits(&scan_both(c), &case.dec, &case.cloud);
        // A table for another level count is refused; clearing it refuses the scan again.
        let mut wrong = case.table.unwrap();
        wrong.levels = 2;
        let e = c
            .define_correction(0, Some(&wrong))
            .unwrap_err()
            .to_string();
        assert!(e.contains("correction"), "{e}");
        c.define_correction(0, None).unwrap();
        assert!(c.validate().unwrap().has(ValidationStatus::NO_CORRECTION));
    });
    let _ = std::fs::remove_dir_all(&root);
}

/// An inverse Gray code on the head (issue #20 item 1): a 5-bit code's images each followed by
/// its inverse, thresholded pair by pair. Captured code first, in the listed order (the mean
/// threshold would need the DC level first), the head's frame-sequential decode equals the
/// desktop's bit for bit.
#[test]
fn an_inverse_gray_set_scans_code_first_on_the_head_bit_identical_to_the_desktop() {
    let root = fresh_root("inv");
    let dir = dataset_with(
        &root,
        "version = 2\n[projector]\nwidth = 1024\nheight = 768\nbit_depth = 8\n\
         [phase]\naxis = \"xi\"\nkind = \"centered\"\nspan = 6.0\n\
         [[levels]]\nscale = 20.0\ngray_bits = 5\ncomplementary = false\ninverse = true\n\
         [[levels]]\nscale = 20.0\nsteps = 4\n",
    );
    let case = head_case(&dir);
    let (set, desc, seq) = (&case.set, &case.desc, &case.seq);
    assert!(set.gray().is_some_and(|g| g.inverse()) && set.image_count() == 14);
    assert!(
        set.frame_sequential_order(),
        "listed, code first, is frame-sequential"
    );
    on_head(&dir, &case, None, true, |c, v| {
        assert_eq!(v, ValidationStatus::OK);
        let listed: Vec<_> = set
            .order()
            .iter()
            .map(|&id| fringe3d_core::wire::LutEntry {
                pattern: desc.pattern_index(id).unwrap(),
                ..seq[0]
            })
            .collect();
        assert_eq!(desc.pattern_id(listed[0].pattern).unwrap().level, 0);
        c.configure_sequence(0, false, &listed).unwrap();
        assert_eq!(c.validate().unwrap(), ValidationStatus::OK);
        assert_desktop_bits(&scan_both(c), &case.dec, &case.cloud);
    });
    let _ = std::fs::remove_dir_all(&root);
}

/// The host's decoder thresholds on the head (issue #19 item 5, protocol version 7:
/// DefineThresholds): with a floor of 12σ for σ = 4 codes and a lower saturation level, the
/// head's phases and points equal the desktop `scan`'s with the same thresholds bit for bit (and
/// differ from its defaults'); cleared, the head decodes with its camera's defaults again. A set
/// slot without a set is refused.
#[test]
fn the_hosts_thresholds_decode_on_the_head_bit_identical_to_the_desktop() {
    let root = fresh_root("thresholds");
    let dir = dataset(&root);
    let case = head_case(&dir);
    let args = fringe3d::cli::common::ThresholdArgs {
        noise: Some(fringe3d::cli::common::NoiseArg::Codes(4.0)),
        saturation: Some(240.0),
        ..Default::default()
    };
    let cfg = args.config_for_camera(8, None).unwrap();
    assert_eq!((cfg.min_modulation, cfg.saturation_level), (48.0, 240.0));
    // The desktop with these thresholds (`fringe3d scan --noise 4 --saturation 240`).
    let calib = dir.join("calibration.toml");
    let ls = common::load_set(&dir.join("patterns.toml")).unwrap();
    let imgs = common::load_images(&ls, &[], true).unwrap();
    let dec = common::decode_corrected(&ls.set, &imgs, cfg, case.table.as_ref()).unwrap();
    let sc = ScanCalibration::load(&calib, ls.set.axis()).unwrap();
    let mut cloud = sc.reconstruct(&dec.phase, &dec.validity, true).unwrap();
    filter_edges(&mut cloud, &sc.edge_filter(80.0).unwrap());
    let refused = |v: &[u8]| v.iter().filter(|&&c| c != 0).count();
    assert!(
        refused(&dec.validity) > refused(&case.dec.validity),
        "the thresholds refuse more pixels than the defaults"
    );
    on_head(&dir, &case, None, true, |c, v| {
        assert_eq!(v, ValidationStatus::OK);
        c.define_thresholds(0, Some(&cfg)).unwrap();
        assert_desktop_bits(&scan_both(c), &dec, &cloud);
        c.define_thresholds(0, None).unwrap();
        assert_desktop_bits(&scan_both(c), &case.dec, &case.cloud);
        let e = c.define_thresholds(3, Some(&cfg)).unwrap_err().to_string();
        assert!(e.to_lowercase().contains("set"), "{e}");
    });
    let _ = std::fs::remove_dir_all(&root);
}
