//! `fringe3d patterns`: write the projector patterns of a pattern-set file as PNG.

use super::{Global, common};
use crate::io::atomic::AtomicDir;
use crate::io::calibration::Calibration;
use crate::io::image::{write_png_u1, write_png_u8, write_png_u16};
use anyhow::Result;
use std::path::PathBuf;

/// Arguments of `fringe3d patterns`.
#[derive(clap::Args, Debug)]
#[command(
    after_help = "Example:\n  fringe3d patterns --patterns examples/patterns/paper8.toml --out patterns/\n\n\
Writes pattern_00.png ... (one per image, in projection order, 8- or 16-bit by the file's\n\
projector.bit_depth unless --bits is given; 1-bit for a set with `binary = ...`) and\n\
patterns.toml: the set with its image list.\n\
Projector gamma (docs/gamma.md): `--gray 17` writes uniform gray images to measure it with\n\
`calibrate gamma`; `--response calibration.toml` then writes the set pre-distorted through it."
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
    /// Pre-distort: write every code through the inverse of this calibration's measured
    /// projector response (`calibrate gamma`), so the projected light is sinusoidal. The written
    /// patterns.toml says so (`response_compensated`), and decoding then applies no correction.
    #[arg(long, value_name = "CALIBRATION")]
    pub response: Option<PathBuf>,
    /// Instead of the set's patterns, write N uniform gray images (codes evenly spaced from 0 to
    /// full scale: gray_00.png …) for `calibrate gamma`.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(5..=256), conflicts_with = "response")]
    pub gray: Option<u32>,
    /// Design the levels for this modulation-to-noise ratio B/σ of the dimmest surface (issue
    /// #22 item 4, docs/formats.md "Level design"): keep the file's projector, phase function,
    /// convention and finest scale, and choose the fewest N-step levels whose unwrapping refuses
    /// at most --failure-target of the pixels; prints the predicted rates and writes the
    /// designed set (gray-level and hierarchical: the file's Gray code, binarization, relation
    /// and image order are not kept).
    #[arg(long, value_name = "B_OVER_SIGMA", conflicts_with = "gray")]
    pub design: Option<f64>,
    /// With --design: shifts per level (3 to 16).
    #[arg(long, default_value_t = 4, requires = "design")]
    pub steps: usize,
    /// With --design: the largest rate of pixels the unwrapping may refuse (all steps).
    #[arg(long, default_value_t = 1e-6, requires = "design")]
    pub failure_target: f64,
}

/// The set `--design` makes of `ls` (see [`PatternsArgs::design`]), with its prediction printed.
fn designed(ls: common::LoadedSet, a: &PatternsArgs, g: Global) -> Result<common::LoadedSet> {
    use crate::design::{DesignGoal, design_levels};
    use fringe3d_core::pattern::{Level, PatternSet};
    let set = &ls.set;
    let finest = set.levels().last().map_or(1.0, |l| l.scale());
    let start = set.relation().start_scale(set.levels()).unwrap_or(1.0);
    let (lo, hi) = set.coarse_range();
    // Φ's range over the projector, and the coarsest scale that spans 0.9 of a period over it.
    let span = (hi - lo) / start;
    let cfg = fringe3d_core::decode::DecodeConfig::for_bit_depth(8);
    let goal = DesignGoal {
        snr: a.design.unwrap_or(0.0),
        steps: a.steps,
        finest,
        coarsest_max: 0.9 * std::f64::consts::TAU / span,
        failure_target: a.failure_target,
        tolerance: cfg.unwrap_tolerance as f64,
    };
    let d = design_levels(&goal).map_err(|e| anyhow::anyhow!("{}: {e}", ls.path.display()))?;
    let levels: Vec<Level> = d
        .scales
        .iter()
        .map(|&c| Level::n_step(c, a.steps))
        .collect();
    let new = PatternSet::new(*set.function(), &levels, *set.output())
        .and_then(|s| {
            s.with_convention(set.convention())
                .with_phase_offset(set.phase_offset())
        })
        .map_err(|e| anyhow::anyhow!("{}: the designed set: {e}", ls.path.display()))?;
    let file = crate::io::pattern_file::PatternSetFile::from_pattern_set(&new, ls.file.bit_depth());
    if g.json {
        outln!(
            "{}",
            serde_json::json!({"command": "patterns --design", "snr": goal.snr, "steps": a.steps,
                "scales": d.scales, "phase_noise_rad": d.phase_noise,
                "step_refused": d.step_refused, "step_wrong_order": d.step_wrong,
                "refused": d.refused(), "wrong_order": d.wrong(), "target": a.failure_target})
        );
    } else if !g.quiet {
        outln!(
            "level design for B/sigma = {}: {} levels of {} steps, scales {:?} (phase noise {:.4} rad per level)",
            goal.snr,
            d.scales.len(),
            a.steps,
            d.scales,
            d.phase_noise
        );
        for (k, (r, w)) in d.step_refused.iter().zip(&d.step_wrong).enumerate() {
            outln!(
                "  step {k} -> {}: ratio {:.3}, refused {r:.2e}, wrong order {w:.2e} of the pixels",
                k + 1,
                d.scales[k + 1] / d.scales[k]
            );
        }
        outln!(
            "  predicted: {:.2e} refused (target {:.0e}), {:.2e} with a wrong fringe order",
            d.refused(),
            a.failure_target,
            d.wrong()
        );
    }
    Ok(common::LoadedSet {
        path: ls.path,
        file,
        set: new,
    })
}

/// Run `fringe3d patterns`.
pub fn run(a: PatternsArgs, g: Global) -> Result<()> {
    common::dir_out(&a.out, "--out")?;
    let mut ls = common::load_set(&a.patterns)?;
    if a.design.is_some() {
        ls = designed(ls, &a, g)?;
    }
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
    let binary = set.binarization().is_binary() && a.gray.is_none();
    if binary && a.response.is_some() {
        anyhow::bail!(
            "{}: the set is binary (binary = \"{}\"): its two codes need no response compensation; drop --response",
            a.patterns.display(),
            crate::io::pattern_file::BinaryName::of(set.binarization()).name()
        );
    }
    let response = match &a.response {
        Some(p) => {
            let cal = Calibration::load(p)?;
            Some(cal.projector_response.ok_or_else(|| {
                anyhow::anyhow!(
                    "{}: no [projector_response]: run `fringe3d calibrate gamma` first",
                    p.display()
                )
            })?)
        }
        None => None,
    };
    let full = if bits == 8 { 255.0 } else { 65535.0 };
    // A code through the inverse response (identity without one).
    let through = |c: f64| match &response {
        Some(r) => (r.inverse(c / full) * full).round(),
        None => c,
    };
    let dir = AtomicDir::create(&a.out, a.overwrite)?;
    let (w, h) = (o.width as usize, o.height as usize);
    if let Some(n) = a.gray {
        let codes = crate::response::gray_codes(n as usize, full as u32);
        let mut names = Vec::new();
        for (k, &c) in codes.iter().enumerate() {
            let name = format!("gray_{k:02}.png");
            if bits == 8 {
                write_png_u8(&dir.join(&name), o.width, o.height, &vec![c as u8; w * h])?;
            } else {
                write_png_u16(
                    &dir.join(&name),
                    o.width,
                    o.height,
                    &vec![c as u16; w * h],
                    16,
                )?;
            }
            names.push(name);
        }
        let out = dir.commit()?;
        if g.json {
            outln!(
                "{}",
                serde_json::json!({"command": "patterns", "out": out, "gray": names, "codes": codes, "bits": bits})
            );
        } else if !g.quiet {
            outln!(
                "wrote {n} uniform {bits}-bit gray images (codes {}) to {}: capture each on the reference plane, then `fringe3d calibrate gamma`",
                codes
                    .iter()
                    .map(|c| c.to_string())
                    .collect::<Vec<_>>()
                    .join(", "),
                out.display()
            );
        }
        return Ok(());
    }
    let pb = common::progress(set.image_count() as u64, "patterns", g.quiet);
    let mut names = Vec::new();
    for i in 0..set.image_count() {
        let name = format!("pattern_{i:02}.png");
        let path = dir.join(&name);
        if binary {
            // 1-bit: every code is I_min or I_max ([`fringe3d_core::binary`]).
            let mut img = vec![0u16; w * h];
            for (y, row) in img.chunks_exact_mut(w).enumerate() {
                set.generate_row(i, y as u32, row)
                    .map_err(|e| anyhow::anyhow!("{e}"))?;
            }
            let mid = 0.5 * (o.i_min + o.i_max);
            let on: Vec<u8> = img.iter().map(|&c| u8::from(c as f64 > mid)).collect();
            write_png_u1(&path, o.width, o.height, &on)?;
        } else if bits == 8 {
            let mut img = vec![0u8; w * h];
            for (y, row) in img.chunks_exact_mut(w).enumerate() {
                set.generate_row(i, y as u32, row)
                    .map_err(|e| anyhow::anyhow!("{e}"))?;
            }
            if response.is_some() {
                img.iter_mut().for_each(|c| *c = through(*c as f64) as u8);
            }
            write_png_u8(&path, o.width, o.height, &img)?;
        } else {
            let mut img = vec![0u16; w * h];
            for (y, row) in img.chunks_exact_mut(w).enumerate() {
                set.generate_row(i, y as u32, row)
                    .map_err(|e| anyhow::anyhow!("{e}"))?;
            }
            if response.is_some() {
                img.iter_mut().for_each(|c| *c = through(*c as f64) as u16);
            }
            write_png_u16(&path, o.width, o.height, &img, 16)?;
        }
        names.push(PathBuf::from(name));
        pb.inc(1);
    }
    pb.finish_and_clear();
    let mut f = ls.file.clone();
    f.images = Some(names.clone());
    if response.is_some() {
        f.projector.response_compensated = Some(true);
    }
    f.save(&dir.join("patterns.toml"))?;
    let out = dir.commit()?;
    if g.json {
        outln!(
            "{}",
            serde_json::json!({"command": "patterns", "out": out, "images": names, "bits": if binary { 1 } else { bits }, "width": o.width, "height": o.height})
        );
    } else if !g.quiet {
        outln!(
            "wrote {} {}-bit patterns ({}x{}) and patterns.toml to {}",
            names.len(),
            if binary { 1 } else { bits },
            o.width,
            o.height,
            out.display()
        );
    }
    Ok(())
}
