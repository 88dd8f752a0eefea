//! What the CLI and file-format tests share: a scratch folder removed on drop, and the
//! `fringe3d` binary run with arguments.
#![allow(dead_code)] // each test file uses its own subset

use fringe3d::batch::{FrameOut, Isa, decode_frames};
use fringe3d_core::decode::Decoder;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// A scratch folder `fringe3d-TAG-PID` under the system's temp dir, created empty and removed
/// when dropped.
pub struct Tmp(pub PathBuf);

impl Tmp {
    /// An empty scratch folder for `tag`.
    pub fn new(tag: &str) -> Tmp {
        let p = std::env::temp_dir().join(format!("fringe3d-{tag}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&p);
        std::fs::create_dir_all(&p).unwrap();
        Tmp(p)
    }
}

impl Drop for Tmp {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

impl std::ops::Deref for Tmp {
    type Target = std::path::Path;
    fn deref(&self) -> &std::path::Path {
        &self.0
    }
}

impl AsRef<std::path::Path> for Tmp {
    fn as_ref(&self) -> &std::path::Path {
        &self.0
    }
}

/// Run the `fringe3d` binary with `args`.
pub fn fringe3d(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_fringe3d"))
        .args(args)
        .output()
        .unwrap()
}

/// Run it and expect success; its stdout.
pub fn run(args: &[&str]) -> String {
    let out = fringe3d(args);
    assert!(
        out.status.success(),
        "{args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// `fringe3d calibrate reference -q --virtual` for the pattern set `patterns` and the
/// calibration `calibration`, written to `out` (a calibration with its virtual reference map).
pub fn virtual_reference(patterns: &Path, calibration: &Path, out: &Path) {
    virtual_reference_with(patterns, calibration, out, &[]);
}

/// [`virtual_reference`] with `extra` options (`--margin 0`, `--plane-point …`).
pub fn virtual_reference_with(patterns: &Path, calibration: &Path, out: &Path, extra: &[&str]) {
    let mut args = vec![
        "calibrate",
        "reference",
        "-q",
        "--virtual",
        "--patterns",
        s(patterns),
        "--calibration",
        s(calibration),
        "-o",
        s(out),
    ];
    args.extend_from_slice(extra);
    run(&args);
}

/// `fringe3d render -q` of `scene` (a built-in name or a scene file) at `size` ("WxH"), 8 bits
/// with σ = 1 gray level of noise, into `out`, with `extra` options (e.g. `--seed 5`).
pub fn render_noisy(scene: &str, size: &str, out: &Path, extra: &[&str]) {
    let mut args = vec![
        "render",
        "-q",
        "--scene",
        scene,
        "--size",
        size,
        "--noise",
        "1",
        "--bits",
        "8",
        "--out",
        s(out),
    ];
    args.extend_from_slice(extra);
    run(&args);
}

/// A path as the `&str` argument the binary takes.
pub fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// A `.npy` file (format 1.0) with `dict` as its header text, padded as numpy pads it; written
/// here from the format's description, not by the reader's code.
pub fn npy_file(dict: &str, data: &[u8]) -> Vec<u8> {
    let mut h = dict.to_string();
    while !(10 + h.len() + 1).is_multiple_of(64) {
        h.push(' ');
    }
    h.push('\n');
    let mut b = b"\x93NUMPY\x01\x00".to_vec();
    b.extend_from_slice(&(h.len() as u16).to_le_bytes());
    b.extend_from_slice(h.as_bytes());
    b.extend_from_slice(data);
    b
}

/// `fringe3d scan` with `args` (without the program name) the whole-frame way
/// (`cli::scan::run_whole_frame`, the reference of the streaming pass), in this process, quiet.
pub fn scan_whole_frame(args: &[String]) {
    use clap::Parser;
    use fringe3d::cli::{Cli, Command as Cmd, Global};
    let argv = std::iter::once("fringe3d".to_string()).chain(args.iter().cloned());
    let Cmd::Scan(a) = Cli::try_parse_from(argv).unwrap().command else {
        panic!("not a scan")
    };
    fringe3d::cli::scan::run_whole_frame(
        a,
        Global {
            quiet: true,
            json: false,
        },
    )
    .unwrap();
}

/// Every kernel variant of the batch decode paired with threading, for tests that hold them to
/// the same bits (a variant the CPU lacks falls back to one it has).
pub const VARIANTS: [(Isa, bool); 6] = [
    (Isa::Baseline, false),
    (Isa::Avx2, false),
    (Isa::Avx2, true),
    (Isa::Avx512, false),
    (Isa::Avx512, true),
    (Isa::Baseline, true),
];

/// The whole-frame decode of `frames` (`w × h` 8-bit images) with the kernel variant `isa`, on
/// rayon's pool when `par`: phase, modulation, DC and validity.
pub fn decode_variant(
    d: &Decoder,
    frames: &[&[u8]],
    (w, h): (usize, usize),
    (isa, par): (Isa, bool),
) -> (Vec<f32>, Vec<f32>, Vec<f32>, Vec<u8>) {
    let n = w * h;
    let (mut p, mut m, mut a, mut v) = (vec![0f32; n], vec![0f32; n], vec![0f32; n], vec![0u8; n]);
    let out = FrameOut {
        phase: &mut p,
        modulation: &mut m,
        dc: &mut a,
        validity: &mut v,
    };
    decode_frames(d, frames, w, h, out, isa, par).expect("decode");
    (p, m, a, v)
}
