//! Decode and reconstruction of one rendered 1280 × 1024 scan of the paper's 8-image set on ONE
//! core, band by band as `fringe3d scan` runs them (`host/src/scan/stream.rs`: each band's rows
//! decoded, then reconstructed, in buffers that stay in the cache), against the two steps one
//! after the other over whole frames (`decode_frames`, then `reconstruct_frame_compiled`). The
//! measure of issue #24's "decode + reconstruct ≤ 10 ms on one core (AVX2), ≤ 6 ms (AVX-512)".
//!
//! The scene is real data made by the binary's commands (run in this process), not a synthetic
//! phase map: `fringe3d render --scene sphere --size 1280x1024 --noise 1 --bits 8` (seeded), its
//! virtual reference (`calibrate reference --virtual`) and its compiled reconstruction
//! (`fringe3d compile --tolerance 1`), in a temporary folder (the set-up takes a minute or two).
//! Every variant is first checked bit for bit against the whole-frame path with the portable
//! kernels; how many pixels the compiled scan leaves to the search is printed. The compiled models in memory
//! (`ScanCalibration::with_compiled`, a process that scans again and again) and read band by
//! band from their file (`compiled_1um_file`: what `fringe3d scan --compiled` does, so that its
//! memory stays a band's).
//! Run: `cargo bench -p fringe3d-bench --bench scan_bands`.

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use fringe3d::batch::{
    FrameOut, Isa, PointsOut, decode_frames, decode_rows, reconstruct_frame_compiled,
};
use fringe3d::cli::common;
use fringe3d::io::image_set::Frames;
use fringe3d::scan::ScanCalibration;
use fringe3d_core::decode::Decoder;
use fringe3d_core::reconstruct::ReferenceMap;
use std::path::Path;

/// Rows per band: `fringe3d scan`'s own for a 1280-pixel-wide camera (about 32 768 pixels).
const BAND_ROWS: usize = 25;

/// Run the binary's command line with `args`, in this process (`fringe3d::cli::run`, all the
/// `fringe3d` binary does); panics with its error when it fails.
fn run(args: &[&str]) {
    let argv = std::iter::once("fringe3d").chain(args.iter().copied());
    if let Err(e) = fringe3d::cli::run(argv) {
        panic!("fringe3d {args:?}: {e:#}");
    }
}

/// One scan's buffers (the whole frame's; the band path uses the first band's worth).
struct Buffers {
    phase: Vec<f32>,
    modulation: Vec<f32>,
    dc: Vec<f32>,
    decoded: Vec<u8>,
    xyz: Vec<f32>,
    codes: Vec<u8>,
    models: Vec<f32>,
}

impl Buffers {
    fn new(n: usize) -> Self {
        Buffers {
            phase: vec![0.0; n],
            modulation: vec![0.0; n],
            dc: vec![0.0; n],
            decoded: vec![0; n],
            xyz: vec![0.0; 3 * n],
            codes: vec![0; n],
            models: Vec::new(),
        }
    }
}

/// Decode the band of rows from `y0` (at most `BAND_ROWS`) into the first rows of `s`; its
/// pixels.
fn decode_band(
    d: &Decoder,
    frames: &[&[u8]],
    w: usize,
    h: usize,
    y0: usize,
    s: &mut Buffers,
    isa: Isa,
) -> usize {
    let n = (BAND_ROWS.min(h - y0)) * w;
    decode_rows(
        d,
        frames,
        w,
        y0,
        FrameOut {
            phase: &mut s.phase[..n],
            modulation: &mut s.modulation[..n],
            dc: &mut s.dc[..n],
            validity: &mut s.decoded[..n],
        },
        isa,
    )
    .expect("decode");
    n
}

/// Decode and reconstruct band after band, each band's intermediate rows in the first
/// `BAND_ROWS` rows of `s` (the reconstruction as the streaming scan runs it,
/// [`ScanCalibration::reconstruct_rows`]: with `cal`'s compiled models, in memory or read from
/// their file); the points and codes of the whole frame into `xyz` and `codes`.
#[allow(clippy::too_many_arguments)]
fn by_bands(
    cal: &ScanCalibration,
    map: &ReferenceMap<'_>,
    d: &Decoder,
    frames: &[&[u8]],
    s: &mut Buffers,
    xyz: &mut [f32],
    codes: &mut [u8],
    isa: Isa,
) {
    let (w, h) = (cal.width(), cal.height());
    for y0 in (0..h).step_by(BAND_ROWS) {
        let n = decode_band(d, frames, w, h, y0, s, isa);
        let r = y0 * w..y0 * w + n;
        let points = PointsOut {
            xyz: &mut xyz[3 * r.start..3 * r.end],
            validity: &mut codes[r],
            searched: None,
        };
        let (phase, decoded) = (&s.phase[..n], &s.decoded[..n]);
        cal.reconstruct_rows(map, y0, phase, decoded, points, &mut s.models, isa)
            .expect("reconstruct");
    }
}

/// Decode the whole frame, then reconstruct it.
fn by_frames(
    cal: &ScanCalibration,
    map: &ReferenceMap<'_>,
    compiled: bool,
    d: &Decoder,
    frames: &[&[u8]],
    s: &mut Buffers,
    isa: Isa,
) {
    let (w, h) = (cal.width(), cal.height());
    let rows = if compiled { cal.compiled_rows() } else { None };
    decode_frames(
        d,
        frames,
        w,
        h,
        FrameOut {
            phase: &mut s.phase,
            modulation: &mut s.modulation,
            dc: &mut s.dc,
            validity: &mut s.decoded,
        },
        isa,
        false,
    )
    .expect("decode");
    reconstruct_frame_compiled(
        &cal.recon,
        map,
        rows,
        &s.phase,
        &s.decoded,
        PointsOut {
            xyz: &mut s.xyz,
            validity: &mut s.codes,
            searched: None,
        },
        isa,
        false,
    )
    .expect("reconstruct");
}

fn bench(c: &mut Criterion) {
    let dir = std::env::temp_dir().join(format!("fringe3d-bench-scan-{}", std::process::id()));
    let p = |name: &str| dir.join(name).to_string_lossy().into_owned();
    run(&[
        "render",
        "-q",
        "--scene",
        "sphere",
        "--size",
        "1280x1024",
        "--noise",
        "1",
        "--bits",
        "8",
        "--out",
        &p("set"),
    ]);
    run(&[
        "calibrate",
        "reference",
        "-q",
        "--virtual",
        "--patterns",
        &p("set/patterns.toml"),
        "--calibration",
        &p("set/calibration.toml"),
        "-o",
        &p("virtual/calibration.toml"),
    ]);
    run(&[
        "compile",
        "-q",
        "--tolerance",
        "1",
        "-p",
        &p("set/patterns.toml"),
        "-c",
        &p("virtual/calibration.toml"),
        "-o",
        &p("virtual/r.f3c"),
    ]);
    let ls = common::load_set(Path::new(&p("set/patterns.toml"))).expect("pattern set");
    let load = || {
        ScanCalibration::load(Path::new(&p("virtual/calibration.toml")), ls.set.axis())
            .expect("calibration")
    };
    let f3c = p("virtual/r.f3c");
    let cal = load()
        .with_compiled(Path::new(&f3c))
        .expect("compiled file");
    let streamed = load()
        .with_compiled_streamed(Path::new(&f3c))
        .expect("compiled file");
    let search = load();
    let imgs = common::load_images(&ls, &[dir.join("set")], true).expect("images");
    let Frames::U8(f) = &imgs.frames else {
        panic!("8-bit images expected")
    };
    let frames: Vec<&[u8]> = f.iter().map(|v| v.as_slice()).collect();
    let d = Decoder::new(&ls.set, common::decode_config(&imgs)).expect("decoder");
    let (w, h) = (cal.width(), cal.height());
    let map = ReferenceMap::from_prepared(
        &cal.reference_phase,
        cal.recon.map_width(),
        cal.recon.map_height(),
    )
    .expect("map");

    let mut g = c.benchmark_group("scan_bands_sphere_1280x1024");
    g.throughput(Throughput::Elements((w * h) as u64));
    g.sample_size(20);
    // The decode alone, band by band: what the reconstruction adds to it.
    {
        let mut s = Buffers::new(w * h);
        g.bench_function("decode_only_dispatched_1thread_bands", |b| {
            b.iter(|| {
                for y0 in (0..h).step_by(BAND_ROWS) {
                    decode_band(&d, &frames, w, h, y0, &mut s, Isa::detect());
                }
            })
        });
    }
    for (tag, c) in [
        ("search", &search),
        ("compiled_1um", &cal),
        ("compiled_1um_file", &streamed),
    ] {
        let compiled = tag != "search";
        // The truth: whole frames, portable kernels, the models in memory.
        let mut truth = Buffers::new(w * h);
        by_frames(&cal, &map, compiled, &d, &frames, &mut truth, Isa::Baseline);
        if tag == "compiled_1um" {
            let file = cal.compiled_file().expect("models");
            let left = file.left_to_search(&truth.phase, &truth.decoded);
            eprintln!(
                "compiled at 1 µm: {} of {} pixels left to the search in this scan",
                left.expect("the scan's size").len(),
                w * h
            );
        }
        // The file's variant runs as `fringe3d scan` dispatches it; the others also with AVX2
        // (the same kernel on an AVX2 machine, not on an AVX-512 one).
        let isas: &[(&str, Isa)] = match tag {
            "compiled_1um_file" => &[("dispatched", Isa::detect())],
            _ => &[("avx2", Isa::Avx2), ("dispatched", Isa::detect())],
        };
        for &(label, isa) in isas {
            let mut s = Buffers::new(w * h);
            let (mut xyz, mut codes) = (vec![0f32; 3 * w * h], vec![0u8; w * h]);
            by_bands(c, &map, &d, &frames, &mut s, &mut xyz, &mut codes, isa);
            let same = codes == truth.codes
                && xyz
                    .iter()
                    .zip(&truth.xyz)
                    .all(|(a, b)| a.to_bits() == b.to_bits());
            assert!(same, "{tag} {label}: the bands differ from the whole frame");
            g.bench_function(format!("{tag}_{label}_1thread_bands"), |b| {
                b.iter(|| by_bands(c, &map, &d, &frames, &mut s, &mut xyz, &mut codes, isa))
            });
            if tag != "compiled_1um_file" {
                g.bench_function(format!("{tag}_{label}_1thread_frames"), |b| {
                    b.iter(|| by_frames(&cal, &map, compiled, &d, &frames, &mut s, isa))
                });
            }
        }
    }
    g.finish();
    let _ = std::fs::remove_dir_all(&dir);
}

criterion_group!(benches, bench);
criterion_main!(benches);
