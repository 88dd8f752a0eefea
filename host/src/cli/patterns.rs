//! `fringe3d patterns`: write the projector patterns of a pattern-set file as PNG.

use super::{Global, common};
use crate::io::atomic::AtomicDir;
use crate::io::image::{write_png_u8, write_png_u16};
use anyhow::Result;
use std::path::PathBuf;

/// Arguments of `fringe3d patterns`.
#[derive(clap::Args, Debug)]
#[command(
    after_help = "Example:\n  fringe3d patterns --patterns examples/patterns/paper8.toml --out patterns/\n\n\
Writes pattern_00.png ... (one per image, in projection order, 8- or 16-bit by the file's\n\
projector.bit_depth unless --bits is given) and patterns.toml: the set with its image list."
)]
pub struct PatternsArgs {
    /// The pattern-set file (TOML, see docs/formats.md).
    #[arg(long, short = 'p')]
    pub patterns: PathBuf,
    /// Output folder (must not exist or be empty, unless --overwrite).
    #[arg(long, short = 'o')]
    pub out: PathBuf,
    /// Bits per pattern pixel: 8 or 16 (default: the file's projector.bit_depth).
    #[arg(long, value_parser = clap::builder::PossibleValuesParser::new(["8", "16"]))]
    pub bits: Option<String>,
    /// Replace the output folder if it exists.
    #[arg(long)]
    pub overwrite: bool,
}

/// Run `fringe3d patterns`.
pub fn run(a: PatternsArgs, g: Global) -> Result<()> {
    common::dir_out(&a.out, "--out")?;
    let ls = common::load_set(&a.patterns)?;
    let set = &ls.set;
    let bits: u8 = match a.bits.as_deref() {
        Some("16") => 16,
        Some(_) => 8,
        None => ls.file.bit_depth(),
    };
    let o = *set.output();
    if bits == 8 && o.i_max > 255.0 {
        anyhow::bail!(
            "{}: projector.i_max = {} does not fit 8-bit patterns; use --bits 16",
            a.patterns.display(),
            o.i_max
        );
    }
    let dir = AtomicDir::create(&a.out, a.overwrite)?;
    let (w, h) = (o.width as usize, o.height as usize);
    let pb = common::progress(set.image_count() as u64, "patterns", g.quiet);
    let mut names = Vec::new();
    for i in 0..set.image_count() {
        let name = format!("pattern_{i:02}.png");
        let path = dir.join(&name);
        if bits == 8 {
            let mut img = vec![0u8; w * h];
            for (y, row) in img.chunks_exact_mut(w).enumerate() {
                set.generate_row(i, y as u32, row)
                    .map_err(|e| anyhow::anyhow!("{e}"))?;
            }
            write_png_u8(&path, o.width, o.height, &img)?;
        } else {
            let mut img = vec![0u16; w * h];
            for (y, row) in img.chunks_exact_mut(w).enumerate() {
                set.generate_row(i, y as u32, row)
                    .map_err(|e| anyhow::anyhow!("{e}"))?;
            }
            write_png_u16(&path, o.width, o.height, &img, 16)?;
        }
        names.push(PathBuf::from(name));
        pb.inc(1);
    }
    pb.finish_and_clear();
    let mut f = ls.file.clone();
    f.images = Some(names.clone());
    f.save(&dir.join("patterns.toml"))?;
    let out = dir.commit()?;
    if g.json {
        outln!(
            "{}",
            serde_json::json!({"command": "patterns", "out": out, "images": names, "bits": bits, "width": o.width, "height": o.height})
        );
    } else if !g.quiet {
        outln!(
            "wrote {} {}-bit patterns ({}x{}) and patterns.toml to {}",
            names.len(),
            bits,
            o.width,
            o.height,
            out.display()
        );
    }
    Ok(())
}
