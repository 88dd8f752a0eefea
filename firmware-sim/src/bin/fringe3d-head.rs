//! `fringe3d-head`: the simulated scan head on a pseudo-terminal.
//!
//! ```text
//! fringe3d-head DATASET[@US]... [--link PATH] [--readout-us N] [--pattern-store-mib N]
//!               [--tx-stall-s S] [--max-margin PX]
//! ```
//!
//! DATASET is a dataset folder (or its `patterns.toml`): the pattern-set file lists the camera
//! image of every pattern, which the simulated camera replays whatever the head projects. For
//! HDR scans (`fringe3d device scan --exposures-us`) give one dataset per exposure, each as
//! `DIR@US` (the exposure it was captured at, µs): an exposure replays the dataset whose
//! exposure is nearest (`ReplaySeries`). The
//! head prints `PTY /dev/pts/N`; use that path as `fringe3d device --port`. `--link PATH` also
//! makes a symlink to it. `--tx-stall-s S` (default 10): when the host stops reading for S
//! seconds while the head sends (a scan nobody reads), the head ends the scan (it leaves
//! Scanning). `--max-margin PX` (default 256, at most 1024): the widest margin past the image, on
//! any side, of a reference map the head takes (issue #17): its map store and reference buffers
//! are sized for it, and a wider map's upload is refused with Nak OutOfMemory. The map store
//! also holds the camera's compiled models (44 bytes a pixel, `device upload --compiled`,
//! docs/compiled.md). Stop with Ctrl-C.

use std::io::Write as _;
use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::atomic::AtomicBool;

use fringe3d_core::pattern::MAX_LEVELS;
use fringe3d_core::reconstruct::{MAX_BAND_ROWS, MAX_MARGIN};
use fringe3d_head::desktop::{
    OwnedMemory, Pty, Replay, ReplaySeries, TX_STALL, serve_with, sim_board,
};
use fringe3d_head::port::QUEUE_LEN;
use fringe3d_head::sim::{FrameSource, NoSink, SimWorld, split_exposure};
use fringe3d_head::{Head, HeadConfig, MemoryPlan};

fn usage() -> ExitCode {
    eprintln!(
        "usage: fringe3d-head DATASET[@US]... [--link PATH] [--readout-us N] [--pattern-store-mib N] [--tx-stall-s S] [--max-margin PX]"
    );
    eprintln!(
        "  DATASET: a dataset folder (its patterns.toml lists the camera images) or a pattern-set file;"
    );
    eprintln!(
        "  several, each DATASET@US (its exposure, µs), for HDR scans: an exposure replays the nearest"
    );
    ExitCode::from(2)
}

fn main() -> ExitCode {
    let mut args = std::env::args().skip(1);
    let mut datasets: Vec<(PathBuf, Option<u32>)> = Vec::new();
    let mut link: Option<PathBuf> = None;
    let mut readout_us: u32 = 1_000;
    let mut store_mib: usize = 64;
    let mut stall = TX_STALL;
    let mut max_margin: usize = 256;
    while let Some(a) = args.next() {
        match a.as_str() {
            "--link" => link = args.next().map(PathBuf::from),
            "--readout-us" => match args.next().and_then(|v| v.parse().ok()) {
                Some(v) => readout_us = v,
                None => return usage(),
            },
            "--max-margin" => match args
                .next()
                .and_then(|v| v.parse().ok())
                .filter(|&m| m <= MAX_MARGIN as usize)
            {
                Some(v) => max_margin = v,
                None => return usage(),
            },
            "--pattern-store-mib" => match args.next().and_then(|v| v.parse().ok()) {
                Some(v) => store_mib = v,
                None => return usage(),
            },
            "--tx-stall-s" => match args
                .next()
                .and_then(|v| v.parse::<f64>().ok())
                .filter(|s| *s > 0.0 && *s <= 86_400.0)
                .and_then(|s| std::time::Duration::try_from_secs_f64(s).ok())
            {
                Some(v) => stall = v,
                None => return usage(),
            },
            "-h" | "--help" => {
                usage();
                return ExitCode::SUCCESS;
            }
            s if !s.starts_with('-') => match split_exposure(s) {
                Ok((dir, us)) => datasets.push((PathBuf::from(dir), us)),
                Err(why) => {
                    eprintln!("fringe3d-head: {s}: {why}");
                    return usage();
                }
            },
            _ => return usage(),
        }
    }
    let dataset = match datasets.as_slice() {
        [] => return usage(),
        [(d, _), ..] => d.clone(),
    };
    if datasets.len() > 1 && datasets.iter().any(|d| d.1.is_none()) {
        eprintln!(
            "fringe3d-head: with several datasets, give each its exposure as DATASET@US (µs)"
        );
        return ExitCode::from(2);
    }
    let mut takes = Vec::new();
    for (dir, us) in &datasets {
        let patterns = if dir.is_dir() {
            dir.join("patterns.toml")
        } else {
            dir.clone()
        };
        match Replay::load(&patterns) {
            // One dataset replays for every exposure: its own is not needed.
            Ok(r) => takes.push((us.unwrap_or(1), r)),
            Err(e) => {
                eprintln!("fringe3d-head: {e}");
                return ExitCode::FAILURE;
            }
        }
    }
    let replay = match ReplaySeries::new(takes) {
        Ok(r) => r,
        Err(e) => {
            eprintln!("fringe3d-head: {e}");
            return ExitCode::FAILURE;
        }
    };
    let o = *replay.first().set.output();
    let (Ok(pw), Ok(ph)) = (u16::try_from(o.width), u16::try_from(o.height)) else {
        eprintln!("fringe3d-head: projector larger than 65535 pixels");
        return ExitCode::FAILURE;
    };
    let (w, h) = (replay.width() as usize, replay.height() as usize);
    let world = SimWorld::new(readout_us as u64 * 1_000);
    let plan = MemoryPlan::new(w, h, pw as usize, MAX_LEVELS, MAX_BAND_ROWS.min(h))
        .with_margin_columns(2 * max_margin);
    let mut mem = OwnedMemory::new(plan);
    // The reference map with its margin, then the compiled models (44 bytes a pixel).
    let map_store = (w + 2 * max_margin) * (h + 2 * max_margin) * 5
        + w * h * fringe3d_core::wire::COMPILED_BYTES_PER_PIXEL;
    let board = sim_board(&world, replay, NoSink, (pw, ph), store_mib << 20, map_store);
    let cfg = HeadConfig {
        readout_us,
        ..HeadConfig::DEFAULT
    };
    let mut head = match Head::new(board, mem.memory(), cfg) {
        Ok(h) => h,
        Err(e) => {
            eprintln!("fringe3d-head: {e}");
            return ExitCode::FAILURE;
        }
    };
    head.set_queue_sizes(QUEUE_LEN, QUEUE_LEN);
    let pty = match Pty::open() {
        Ok(p) => p,
        Err(e) => {
            eprintln!("fringe3d-head: cannot open a pseudo-terminal: {e}");
            return ExitCode::FAILURE;
        }
    };
    if let Some(l) = &link {
        let _ = std::fs::remove_file(l);
        if let Err(e) = std::os::unix::fs::symlink(pty.path(), l) {
            eprintln!(
                "fringe3d-head: cannot link {} to {}: {e}",
                l.display(),
                pty.path()
            );
            return ExitCode::FAILURE;
        }
    }
    let more = match datasets.len() {
        1 => String::new(),
        n => format!(" and {} more (one per exposure)", n - 1),
    };
    println!(
        "fringe3d-head: {}{more} — camera {w}x{h}, projector {pw}x{ph}",
        dataset.display()
    );
    println!("PTY {}", pty.path());
    let _ = std::io::stdout().flush();
    let stop = AtomicBool::new(false);
    let mut rows_seen = 0;
    serve_with(&mut head, &pty, &stop, stall, |head| {
        let st = head.status();
        if st.rows_sent != rows_seen && st.state != fringe3d_core::wire::HeadState::Scanning {
            rows_seen = st.rows_sent;
            let m = head.memory_report();
            eprintln!(
                "fringe3d-head: {} rows sent; peak memory: decoder {} B + flags {} B, reference ring {} B, lines {} B, head {} B, UART queues {} B: {} B in all",
                st.rows_sent,
                m.decode_state,
                m.decode_flags,
                m.ring,
                m.lines,
                m.head_struct,
                m.rx_queue + m.tx_queue,
                m.total()
            );
        }
    });
    ExitCode::SUCCESS
}
