//! Pieces shared by several commands: finding a set's images, decoding a whole set, progress.

pub use crate::batch::Decoded;
use crate::batch::decode_image_set;
use crate::io::calibration::{
    Calibration, PatternCheck, ScanPatterns, SensorNoise, check_pattern_set, pattern_digest,
};
use crate::io::image_set::{self, Frames, ImageSet};
use crate::io::pattern_file::PatternSetFile;
use crate::scan::{MapDefect, ScanCalibration};
use anyhow::{Context, Result, bail};
use fringe3d_core::decode::{DecodeConfig, Decoder, PhaseCorrection};
use fringe3d_core::pattern::PatternSet;
use fringe3d_core::phase_function::Axis;
use fringe3d_core::validity::Validity;
use std::path::{Path, PathBuf};

/// Check an output *file* option before any work is done: `-` (standard output) is only for
/// point clouds, and an existing target must be a regular file (never a folder, a device, a FIFO).
pub fn file_out(p: &Path, opt: &str) -> Result<()> {
    refuse_stdout(p, opt)?;
    crate::io::atomic::check_file_target(p)?;
    Ok(())
}

/// Check an output *folder* option: `-` (standard output) is refused.
pub fn dir_out(p: &Path, opt: &str) -> Result<()> {
    refuse_stdout(p, opt)
}

fn refuse_stdout(p: &Path, opt: &str) -> Result<()> {
    if p.as_os_str() == "-" {
        bail!(
            "{opt} -: only point clouds (scan, reconstruct, device scan) can be written to standard output; for a file or folder named '-', write ./-"
        );
    }
    Ok(())
}

/// Check that an input read by library code that opens it itself is a regular file (a FIFO
/// would block the open forever, a device would never end).
pub fn input_file(p: &Path) -> Result<()> {
    crate::io::input::check_regular(p).with_context(|| format!("{}: cannot read", p.display()))
}

/// Load a calibration and its reference phase map, refusing a map no scan can use: one with an
/// infinite phase anywhere (NaN marks an invalid pixel; ±inf is never a phase) or without a
/// single finite phase (every point would be invalid: an empty cloud, not an answer).
pub fn load_calibration(path: &Path, axis: Axis) -> Result<ScanCalibration> {
    refuse_defects(ScanCalibration::load(path, axis)?, path)
}

/// [`load_calibration`] for the streaming scan: a map that can be read row by row stays in its
/// file ([`ScanCalibration::load_streamed`]).
pub fn load_calibration_streamed(path: &Path, axis: Axis) -> Result<ScanCalibration> {
    refuse_defects(ScanCalibration::load_streamed(path, axis)?, path)
}

fn refuse_defects(cal: ScanCalibration, path: &Path) -> Result<ScanCalibration> {
    let map = cal
        .calibration
        .reference_map_path(path)
        .unwrap_or_else(|| path.to_path_buf());
    match cal.reference_defect {
        None => Ok(cal),
        Some(MapDefect::Infinite { x, y, value }) => bail!(
            "{}: reference phase map: pixel ({x}, {y}) is {value} (invalid pixels are NaN; an infinite phase is no phase); re-run `fringe3d calibrate reference`",
            map.display(),
        ),
        Some(MapDefect::NoFinite) => bail!(
            "{}: reference phase map has no valid (finite) phase at all: no point could be reconstructed; re-run `fringe3d calibrate reference`",
            map.display()
        ),
    }
}

/// The peak resident memory of this process so far, bytes: `VmHWM` of `/proc/self/status`
/// (Linux; `None` elsewhere). It is the high-water mark of this program's own address space:
/// unlike `getrusage`'s `ru_maxrss`, it does not include the memory of the process that started
/// it, which Linux carries over through `fork` and `exec`.
pub fn peak_rss_bytes() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib * 1024)
}

/// Warn (unless quiet) when a cloud holds no valid point at all.
pub fn warn_if_empty(h: &Histogram, out: &str, quiet: bool) {
    if h[0] == 0 && !quiet {
        errln!(
            "warning: no pixel gave a valid point: {out} holds no points ({})",
            validity_summary(h)
        );
    }
}

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
    if let Some(note) = file.implicit_order_note() {
        errln!("note: {note}");
    }
    Ok(LoadedSet {
        path: path.to_path_buf(),
        file,
        set,
    })
}

impl LoadedSet {
    /// The set as a scan's side of the reference check: its digest, named by the file.
    pub fn scan_patterns(&self) -> Result<ScanPatterns> {
        let digest = pattern_digest(&self.set)
            .map_err(|m| anyhow::anyhow!("{}: {m}", self.path.display()))?;
        Ok(ScanPatterns {
            source: format!("the scan's pattern set {}", self.path.display()),
            digest,
        })
    }
}

/// Check that a scan's pattern set is the one the calibration's reference phase map was made
/// with (`[reference] pattern_digest`, else the digest of its `pattern_set` file): refuse a
/// mismatch with one error naming both sides; warn (unless quiet) when the calibration records
/// neither, since nothing can be checked. Read before any output is written.
pub fn check_reference_patterns(
    calibration: &Path,
    scan: &ScanPatterns,
    quiet: bool,
) -> Result<()> {
    let cal = Calibration::load(calibration)?;
    check_loaded_reference_patterns(&cal, calibration, scan, quiet)
}

/// [`check_reference_patterns`] with the calibration already loaded from `calibration`.
pub fn check_loaded_reference_patterns(
    cal: &Calibration,
    calibration: &Path,
    scan: &ScanPatterns,
    quiet: bool,
) -> Result<()> {
    match check_pattern_set(cal, calibration, scan)? {
        PatternCheck::Match | PatternCheck::NoReference => {}
        PatternCheck::Unchecked(m) => {
            if !quiet {
                errln!("warning: {m}");
            }
        }
    }
    Ok(())
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
            errln!("warning: {w}");
        }
    }
    Ok(imgs)
}

/// The images of an HDR scan (`--hdr`): one folder per exposure of the whole set, longest
/// exposure first, loaded and checked as [`load_images`] does each, then one [`ImageSet`] of
/// their frames in that order ([`crate::batch::decode_exposures`]). The folders must agree in
/// size and bit depth, and their mean levels must fall from one to the next (the order the
/// fusion relies on).
pub fn load_exposures(set: &LoadedSet, folders: &[PathBuf], quiet: bool) -> Result<ImageSet> {
    let max = fringe3d_core::decode::hdr::MAX_EXPOSURES;
    if !(2..=max).contains(&folders.len()) {
        bail!(
            "--hdr takes 2 to {max} folders, one per exposure, longest first; got {}",
            folders.len()
        );
    }
    if let Some(f) = folders.iter().find(|f| !f.is_dir()) {
        bail!(
            "{}: --hdr takes folders, one per exposure; this is not one",
            f.display()
        );
    }
    let mut all: Option<ImageSet> = None;
    let mut last_mean = f64::INFINITY;
    for (k, folder) in folders.iter().enumerate() {
        let imgs = load_images(set, std::slice::from_ref(folder), quiet)?;
        let mean = frames_mean(&imgs.frames);
        if mean >= last_mean {
            bail!(
                "{}: the exposures must be listed longest first, but this folder's mean level \
                 ({mean:.1}) is not below the previous folder's ({last_mean:.1})",
                folder.display()
            );
        }
        last_mean = mean;
        all = Some(match all {
            None => imgs,
            Some(mut a) => {
                if (a.width, a.height, a.bits) != (imgs.width, imgs.height, imgs.bits) {
                    bail!(
                        "{}: exposure {} is {}x{} at {} bits, but the first ({}) is {}x{} at {} bits",
                        folder.display(),
                        k + 1,
                        imgs.width,
                        imgs.height,
                        imgs.bits,
                        folders[0].display(),
                        a.width,
                        a.height,
                        a.bits
                    );
                }
                match (&mut a.frames, imgs.frames) {
                    (Frames::U8(x), Frames::U8(y)) => x.extend(y),
                    (Frames::U16(x), Frames::U16(y)) => x.extend(y),
                    _ => bail!(
                        "{}: its images are stored at another sample size than the first exposure's ({})",
                        folder.display(),
                        folders[0].display()
                    ),
                }
                a.paths.extend(imgs.paths);
                a.warnings.extend(imgs.warnings);
                a
            }
        });
    }
    all.ok_or_else(|| anyhow::anyhow!("--hdr: no folders"))
}

/// The mean sample of every frame.
fn frames_mean(f: &Frames) -> f64 {
    fn mean<T: Copy + Into<f64>>(v: &[Vec<T>]) -> f64 {
        let n: usize = v.iter().map(Vec::len).sum();
        let s: f64 = v.iter().flat_map(|x| x.iter()).map(|&x| x.into()).sum();
        s / n.max(1) as f64
    }
    match f {
        Frames::U8(v) => mean(v),
        Frames::U16(v) => mean(v),
    }
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

/// `--noise`: the sensor's read noise in camera codes, or `auto`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum NoiseArg {
    /// Estimated from the images ([`crate::noise::estimate`]).
    Auto,
    /// σ of one sample, camera codes.
    Codes(f32),
}

impl std::str::FromStr for NoiseArg {
    type Err = String;
    fn from_str(s: &str) -> std::result::Result<Self, String> {
        if s == "auto" {
            return Ok(NoiseArg::Auto);
        }
        match s.parse::<f32>() {
            Ok(x) if x.is_finite() && x > 0.0 => Ok(NoiseArg::Codes(x)),
            _ => Err(format!(
                "expected `auto` or a noise sigma in camera codes (> 0), got `{s}`"
            )),
        }
    }
}

/// The decoder's thresholds a user may set (`decode` and `scan`); each absent one keeps the
/// bit depth's default ([`DecodeConfig::for_bit_depth`]); `--noise` sets the modulation floor to
/// `12σ` ([`DecodeConfig::for_sensor`]).
#[derive(clap::Args, Debug, Clone, Default)]
pub struct ThresholdArgs {
    /// Minimum modulation B, camera codes (default: 2 % of full scale, at least 12 codes for
    /// 8-bit images; see --noise for 12σ).
    #[arg(long, value_name = "CODES")]
    pub min_modulation: Option<f32>,
    /// The camera's read noise σ, camera codes, or `auto` to estimate it from the images (a
    /// level of 4, 6, … uniform shifts); the minimum modulation is then 12σ, the 8-bit floor's
    /// rule (12 codes at σ = 1). Without it, 12σ of the noise the calibration's `[sensor]`
    /// records (`calibrate reference` measures it), which a head set up by `device upload` also
    /// decodes with; without that, the bit depth's default (for deeper images 2 % of full scale).
    #[arg(long, value_name = "CODES|auto")]
    pub noise: Option<NoiseArg>,
    /// Saturation level, camera codes (default: full scale of the images' bit depth).
    #[arg(long, value_name = "CODES")]
    pub saturation: Option<f32>,
    /// Dark level: pixels whose DC term is below it are dark, camera codes (default: 2 % of
    /// full scale).
    #[arg(long, value_name = "CODES")]
    pub dark_level: Option<f32>,
    /// Largest accepted unwrapping residual, radians (default: 2π/3).
    #[arg(long, value_name = "RAD")]
    pub unwrap_tolerance: Option<f32>,
    /// How far the coarsest phase may lie outside the set's range, radians (default: 0.15).
    #[arg(long, value_name = "RAD")]
    pub range_tolerance: Option<f32>,
}

impl ThresholdArgs {
    /// The bit depth's defaults with the given thresholds applied; each checked against its
    /// meaningful range (codes within the images' full scale, radians within (0, π]). The
    /// modulation floor: `--min-modulation`, else 12σ of `--noise` (estimated from the images of
    /// `set` for `auto`), else 12σ of the calibration's `[sensor]` noise, else the bit depth's.
    pub fn config(
        &self,
        set: &PatternSet,
        imgs: &ImageSet,
        sensor: Option<&SensorNoise>,
    ) -> Result<DecodeConfig> {
        let estimate = || match crate::noise::estimate(set, imgs) {
            Some(e) => Ok(e.sigma),
            None => anyhow::bail!(
                "--noise auto: the pattern set has no level of 4, 6, ... uniform shifts to \
                 estimate the noise from, or too few lit, unsaturated pixels; give --noise \
                 CODES or --min-modulation"
            ),
        };
        self.config_for(imgs.bits, sensor, estimate)
    }

    /// [`Self::config`] for a camera of `bits` bits whose images are not at hand (a head's, set
    /// by `device upload`): `--noise auto` is refused.
    pub fn config_for_camera(
        &self,
        bits: u8,
        sensor: Option<&SensorNoise>,
    ) -> Result<DecodeConfig> {
        self.config_for(bits, sensor, || {
            anyhow::bail!(
                "--noise auto needs the images; for a head give --noise CODES (or calibrate the \
                 reference, which records the sensor's noise)"
            )
        })
    }

    fn config_for(
        &self,
        bits: u8,
        sensor: Option<&SensorNoise>,
        estimate: impl FnOnce() -> Result<f32>,
    ) -> Result<DecodeConfig> {
        let mut cfg = DecodeConfig::for_bit_depth(u32::from(bits));
        match (self.noise, sensor) {
            (Some(NoiseArg::Codes(s)), _) => cfg = DecodeConfig::for_sensor(u32::from(bits), s),
            (Some(NoiseArg::Auto), _) => {
                cfg = DecodeConfig::for_sensor(u32::from(bits), estimate()?)
            }
            (None, Some(s)) => cfg = s.decode_config(bits),
            (None, None) => {}
        }
        let full = ((1u64 << bits.clamp(1, 16)) - 1) as f32;
        let codes = |v: Option<f32>, name: &str, lo_open: bool| -> Result<Option<f32>> {
            match v {
                Some(x) if x.is_finite() && (x > 0.0 || (!lo_open && x == 0.0)) && x <= full => {
                    Ok(Some(x))
                }
                Some(x) => anyhow::bail!(
                    "--{name} {x}: expected {} to {full} camera codes ({bits}-bit images)",
                    if lo_open { "more than 0" } else { "0" },
                ),
                None => Ok(None),
            }
        };
        let rad = |v: Option<f32>, name: &str| -> Result<Option<f32>> {
            match v {
                Some(x) if x.is_finite() && x > 0.0 && x <= std::f32::consts::PI => Ok(Some(x)),
                Some(x) => {
                    anyhow::bail!("--{name} {x}: expected more than 0 and at most π radians")
                }
                None => Ok(None),
            }
        };
        if let Some(x) = codes(self.min_modulation, "min-modulation", false)? {
            cfg.min_modulation = x;
        }
        if let Some(x) = codes(self.saturation, "saturation", true)? {
            cfg.saturation_level = x;
        }
        if let Some(x) = codes(self.dark_level, "dark-level", false)? {
            cfg.dark_level = x;
        }
        if let Some(x) = rad(self.unwrap_tolerance, "unwrap-tolerance")? {
            cfg.unwrap_tolerance = x;
        }
        if let Some(x) = rad(self.range_tolerance, "range-tolerance")? {
            cfg.range_tolerance = x;
        }
        Ok(cfg)
    }
}

/// Decode a loaded set on all threads of rayon's pool with the best kernel variant.
pub fn decode(set: &PatternSet, imgs: &ImageSet, cfg: DecodeConfig) -> Result<Decoded> {
    decode_corrected(set, imgs, cfg, None)
}

/// [`decode`] with a phase-error table for the projector's response ([`response_correction`]).
pub fn decode_corrected(
    set: &PatternSet,
    imgs: &ImageSet,
    cfg: DecodeConfig,
    correction: Option<&PhaseCorrection>,
) -> Result<Decoded> {
    let mut d = Decoder::new(set, cfg).map_err(|e| anyhow::anyhow!("decoder: {e}"))?;
    if let Some(c) = correction {
        d = d
            .with_correction(c)
            .map_err(|e| anyhow::anyhow!("gamma correction: {e}"))?;
    }
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

/// Save `cal`, updated by a calibration step, to `out` (default: the file it was read from,
/// `calibration`); returns where it went.
pub fn save_calibration(
    cal: &Calibration,
    out: Option<&Path>,
    calibration: &Path,
) -> Result<PathBuf> {
    let out = out.unwrap_or(calibration).to_path_buf();
    cal.save(&out)
        .with_context(|| format!("{}: cannot write the calibration", out.display()))?;
    Ok(out)
}

/// The phase-error table a decode of `ls` needs for the projector response recorded in the
/// calibration `cal` (read from `cal_path`; `[projector_response]`, docs/gamma.md); `None`
/// without one, or when the set's patterns were written pre-distorted.
pub fn response_correction(
    cal: &Calibration,
    cal_path: &Path,
    ls: &LoadedSet,
) -> Result<Option<PhaseCorrection>> {
    crate::calib::files::response_table_for(
        &ls.file,
        &ls.set,
        cal.projector_response.as_ref(),
        cal.projector_defocus,
    )
    .map_err(|m| anyhow::anyhow!("{}: {}: {m}", cal_path.display(), ls.path.display()))
}
