//! `fringe3d vectors`: write (or verify) the golden test vectors of a small rendered scan.

use super::Global;
use crate::vectors::{self, VectorOptions};
use anyhow::{Context, Result, bail};
use std::path::PathBuf;

/// Arguments of `fringe3d vectors`.
#[derive(clap::Args, Debug)]
#[command(
    after_help = "Examples:\n  fringe3d vectors --out golden            # ballbar scene, 320x240, 16-bit camera\n  \
fringe3d vectors --out golden --verify   # regenerate in memory and compare with golden/\n  \
fringe3d vectors --out golden8 --bits 8 --scene steps\n\n\
Writes DIR/input (camera rows, reference map, setup.bin, calibration and pattern set),\n\
DIR/decode, DIR/reconstruct, DIR/filter (raw little-endian arrays) and DIR/manifest.json\n\
(dtype, shape, order and SHA-256 of every file). Same options, same bytes. See docs/golden-vectors.md."
)]
pub struct VectorsArgs {
    /// Output folder (written atomically).
    #[arg(long, short = 'o')]
    pub out: PathBuf,
    /// Built-in scene: sphere, ballbar, steps, freeform or plane.
    #[arg(long, default_value = "ballbar")]
    pub scene: String,
    /// Camera image size (same field of view as the 1280x1024 rig).
    #[arg(long, default_value = "320x240")]
    pub size: String,
    /// Camera bit depth (8 gives u8 image files, 12 and 16 give u16).
    #[arg(long, value_parser = ["8", "12", "16"])]
    pub bits: Option<String>,
    /// Camera noise σ, gray levels (default: the scene's).
    #[arg(long)]
    pub noise: Option<f64>,
    /// Noise seed (default: the scene's).
    #[arg(long)]
    pub seed: Option<u64>,
    /// Steepest surface the edge filter accepts, degrees from facing the camera.
    #[arg(long, default_value_t = 80.0)]
    pub max_angle: f64,
    /// The projector's gamma (default: linear): the decoder, and the head through the set-up
    /// blob, then apply the response's phase-error table (docs/gamma.md).
    #[arg(long)]
    pub gamma: Option<f64>,
    /// A pattern-set file instead of the scene's paper set (at most 8 images for the mps2
    /// board's golden binary): Gray-coded and binary sets too (docs/golden-vectors.md).
    #[arg(long, short = 'p')]
    pub patterns: Option<PathBuf>,
    /// The projector's defocus σ, projector pixels (default: the scene's, 1); a binary set is
    /// decoded with the table of this blur (docs/binary.md).
    #[arg(long)]
    pub defocus: Option<f64>,
    /// The reference map of the scan: the decoded capture of the plane, the model fitted to it
    /// (`calibrate reference`), or the virtual map of the rig's projector (docs/reference-model.md).
    #[arg(long, value_enum, default_value = "captured")]
    pub reference: crate::vectors::VectorReference,
    /// Also compile the reconstruction to this tolerance, µm (`fringe3d compile`; 0.1 if no
    /// value is given): its models as `input/compiled.f3c` and the compiled scan as
    /// `compiled/points.f32`, `compiled/validity.u8` (docs/compiled.md; a head runs them row by
    /// row). Use a reference model (`--reference virtual`...): a captured map compiles nothing;
    /// at 320 × 240 a few µm compile most pixels.
    #[arg(long, value_name = "UM", num_args = 0..=1, default_missing_value = "0.1")]
    pub compiled: Option<f64>,
    /// Replace an existing, non-empty output folder.
    #[arg(long)]
    pub overwrite: bool,
    /// Do not write: regenerate in memory and check DIR's files against the new vectors and
    /// against DIR's own manifest (exit status 1 on any difference).
    #[arg(long)]
    pub verify: bool,
}

fn parse_size(s: &str) -> Result<(u32, u32)> {
    let (w, h) = s
        .split_once('x')
        .with_context(|| format!("--size {s:?}: expected WxH, e.g. 320x240"))?;
    Ok((
        w.parse()
            .with_context(|| format!("--size {s:?}: bad width"))?,
        h.parse()
            .with_context(|| format!("--size {s:?}: bad height"))?,
    ))
}

/// Run `fringe3d vectors`.
pub fn run(a: VectorsArgs, g: Global) -> Result<()> {
    super::common::dir_out(&a.out, "--out")?;
    let opts = VectorOptions {
        scene: a.scene.clone(),
        size: parse_size(&a.size)?,
        bits: a
            .bits
            .as_deref()
            .map(str::parse)
            .transpose()
            .context("--bits")?,
        noise: a.noise,
        seed: a.seed,
        max_angle_deg: a.max_angle,
        gamma: a.gamma,
        patterns: a
            .patterns
            .as_deref()
            .map(crate::io::pattern_file::PatternSetFile::load)
            .transpose()?,
        defocus: a.defocus,
        reference: a.reference,
        compiled: match a.compiled {
            Some(um) if um.is_finite() && um > 0.0 && um <= 1000.0 => Some(um * 1e-3),
            Some(um) => bail!("--compiled: the tolerance must be in (0, 1000] µm, got {um}"),
            None => None,
        },
    };
    let say = |s: String| {
        if !g.quiet && !g.json {
            outln!("{s}");
        }
    };
    if a.verify {
        let bad_disk = vectors::check_dir(&a.out)?;
        let on_disk = vectors::read_dir(&a.out)?;
        let fresh = vectors::generate(&opts)?;
        let mut bad = bad_disk;
        for f in &fresh.files {
            match on_disk.file(&f.path) {
                None => bad.push(vectors::Mismatch {
                    path: f.path.clone(),
                    what: "missing from the folder".into(),
                }),
                Some(d) if d.bytes != f.bytes => bad.push(vectors::Mismatch {
                    path: f.path.clone(),
                    what: vectors::first_difference(f, &d.bytes),
                }),
                Some(_) => {}
            }
        }
        if g.json {
            let list: Vec<_> = bad
                .iter()
                .map(|m| serde_json::json!({"path": m.path, "what": m.what}))
                .collect();
            outln!(
                "{}",
                serde_json::json!({"command": "vectors", "verify": a.out, "files": fresh.files.len(), "mismatches": list})
            );
        }
        if bad.is_empty() {
            say(format!(
                "{}: all {} files match the regenerated vectors and the manifest",
                a.out.display(),
                fresh.files.len()
            ));
            return Ok(());
        }
        for m in &bad {
            errln!("{}: {}", m.path, m.what);
        }
        bail!("{}: {} file(s) differ", a.out.display(), bad.len());
    }
    let v = vectors::generate_into(&opts, &a.out, a.overwrite)?;
    let bytes: usize = v.files.iter().map(|f| f.bytes.len()).sum();
    if g.json {
        outln!(
            "{}",
            serde_json::json!({"command": "vectors", "out": a.out, "files": v.files.len(), "bytes": bytes, "width": v.width, "height": v.height})
        );
    } else {
        say(format!(
            "wrote {} files ({:.1} MB) of golden vectors for a {}x{} scan to {} (manifest.json lists formats and SHA-256)",
            v.files.len(),
            bytes as f64 / 1e6,
            v.width,
            v.height,
            a.out.display()
        ));
    }
    Ok(())
}
