//! Pieces shared by several commands: finding a set's images, decoding a whole set, progress.

pub use crate::batch::Decoded;
use crate::batch::decode_image_set;
use crate::io::image_set::{self, ImageSet};
use crate::io::pattern_file::PatternSetFile;
use anyhow::{Context, Result, bail};
use fringe3d_core::decode::{DecodeConfig, Decoder};
use fringe3d_core::pattern::PatternSet;
use fringe3d_core::validity::Validity;
use std::path::{Path, PathBuf};

/// A loaded pattern-set file and its validated set.
pub struct LoadedSet {
    /// The file.
    pub path: PathBuf,
    /// Its content.
    pub file: PatternSetFile,
    /// The validated set.
    pub set: PatternSet,
}

/// Load and validate a pattern-set file.
pub fn load_set(path: &Path) -> Result<LoadedSet> {
    let file = PatternSetFile::load(path)?;
    let set = file.to_pattern_set()?;
    Ok(LoadedSet {
        path: path.to_path_buf(),
        file,
        set,
    })
}

/// The image files of a scan: an explicit ordered list, or one folder (the pattern file's
/// `images` names inside it if it lists them, else every image of the folder sorted by name),
/// or with no arguments the pattern file's own `images` list.
pub fn resolve_images(set: &LoadedSet, args: &[PathBuf]) -> Result<(Vec<PathBuf>, String)> {
    let n = set.set.image_count();
    match args {
        [] => match set.file.image_paths(&set.path) {
            Some(v) => Ok((v, format!("{} (its `images` list)", set.path.display()))),
            None => bail!(
                "{}: no images given, and the pattern-set file lists none (`images = [...]`); pass the {n} image files in order, or a folder",
                set.path.display()
            ),
        },
        [dir] if dir.is_dir() => match &set.file.images {
            Some(names) => Ok((
                names.iter().map(|n| dir.join(n)).collect(),
                format!("{} (names from {})", dir.display(), set.path.display()),
            )),
            None => Ok((
                image_set::list_folder(dir)?,
                format!("folder {}", dir.display()),
            )),
        },
        list => Ok((
            list.to_vec(),
            format!("{} (images from the command line)", set.path.display()),
        )),
    }
}

/// Load the images of a scan and check them against the set.
pub fn load_images(set: &LoadedSet, args: &[PathBuf], quiet: bool) -> Result<ImageSet> {
    let (paths, what) = resolve_images(set, args)?;
    let imgs = image_set::load(&paths, set.set.image_count(), &what)?;
    if !quiet {
        for w in &imgs.warnings {
            eprintln!("warning: {w}");
        }
    }
    Ok(imgs)
}

impl Decoded {
    /// Pixel count per validity code.
    pub fn histogram(&self) -> Histogram {
        histogram(&self.validity)
    }
}

/// Number of validity codes.
pub const CODES: usize = Validity::ALL.len();

/// Pixel count per validity code.
pub type Histogram = [usize; CODES];

/// Count pixels per validity code (unknown bytes count as the last code).
pub fn histogram(v: &[u8]) -> Histogram {
    let mut h = [0usize; CODES];
    for x in v {
        h[(*x as usize).min(CODES - 1)] += 1;
    }
    h
}

/// Decoder thresholds for an image set: the defaults of its bit depth.
pub fn decode_config(imgs: &ImageSet) -> DecodeConfig {
    DecodeConfig::for_bit_depth(imgs.bits as u32)
}

/// Decode a loaded set on all threads of rayon's pool with the best kernel variant.
pub fn decode(set: &PatternSet, imgs: &ImageSet, cfg: DecodeConfig) -> Result<Decoded> {
    let d = Decoder::new(set, cfg).map_err(|e| anyhow::anyhow!("decoder: {e}"))?;
    decode_image_set(&d, imgs)
        .map_err(|e| anyhow::anyhow!("decode: {e}"))
        .context("decoding the image set")
}

/// A one-line text summary of validity counts.
pub fn validity_summary(h: &Histogram) -> String {
    let total: usize = h.iter().sum();
    let mut s = format!(
        "{} of {} pixels valid ({:.1} %)",
        h[0],
        total,
        100.0 * h[0] as f64 / total.max(1) as f64
    );
    for (i, c) in h.iter().enumerate().skip(1) {
        if *c > 0 {
            s.push_str(&format!(", {} {}", c, Validity::ALL[i].name()));
        }
    }
    s
}

/// Validity counts as a JSON object.
pub fn validity_json(h: &Histogram) -> serde_json::Value {
    let mut m = serde_json::Map::new();
    for (i, c) in h.iter().enumerate() {
        m.insert(Validity::ALL[i].name().to_string(), serde_json::json!(c));
    }
    serde_json::Value::Object(m)
}

/// A progress bar that shows only when not quiet and the work takes a while.
pub fn progress(len: u64, msg: &str, quiet: bool) -> indicatif::ProgressBar {
    if quiet {
        return indicatif::ProgressBar::hidden();
    }
    let pb = indicatif::ProgressBar::new(len);
    pb.set_style(
        indicatif::ProgressStyle::with_template("{msg:>12} [{bar:30}] {pos}/{len} ({elapsed})")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar())
            .progress_chars("=> "),
    );
    pb.set_message(msg.to_string());
    // Draw only after a second: quick runs print no bar at all.
    pb.enable_steady_tick(std::time::Duration::from_millis(1000));
    pb
}
