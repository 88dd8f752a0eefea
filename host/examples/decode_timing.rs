//! Warm, in-memory decode timing of a dataset, for side-by-side comparisons with other decoders
//! that are timed the same way (`bench/compare.sh`): the images are loaded once, then
//! `cli::common::decode` (decoder set-up, output allocation, all cores, the best kernel variant)
//! runs `--repeat` times; the best time is printed in seconds.
//!
//! Run: `cargo run --release -p fringe3d --example decode_timing -- PATTERNS.toml DATASET_DIR [REPEAT]`

use anyhow::{Context, Result};
use fringe3d::cli::common;
use std::path::PathBuf;
use std::time::Instant;

fn main() -> Result<()> {
    let mut args = std::env::args().skip(1);
    let patterns = PathBuf::from(
        args.next()
            .context("usage: decode_timing PATTERNS.toml DATASET_DIR [REPEAT]")?,
    );
    let dir = PathBuf::from(
        args.next()
            .context("usage: decode_timing PATTERNS.toml DATASET_DIR [REPEAT]")?,
    );
    let repeat: usize = args
        .next()
        .map(|r| r.parse())
        .transpose()
        .context("REPEAT must be a count")?
        .unwrap_or(5);
    let set = common::load_set(&patterns)?;
    let imgs = common::load_images(&set, &[dir], true)?;
    let cfg = common::decode_config(&imgs);
    let mut best = f64::INFINITY;
    for _ in 0..repeat.max(1) {
        let t = Instant::now();
        let d = common::decode(&set.set, &imgs, cfg)?;
        best = best.min(t.elapsed().as_secs_f64());
        std::hint::black_box(&d);
    }
    println!("{best:.6}");
    Ok(())
}
