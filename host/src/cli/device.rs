//! `fringe3d device`: talk to a scan head over a serial port — `info`, `upload`, `scan`, and
//! the trigger-sequence controls `start`, `stop`, `abort`.

use super::cloud_out::{self, CloudFormat, CloudOut};
use super::{Global, common, parse};
use crate::device::desc::{
    capture_sequence, fidelity, pattern_bytes, pattern_desc, phase_map_bytes, render_pattern,
    wire_calibration,
};
use crate::device::{
    Client, ClientOptions, DeviceError, SerialTransport, interrupt, nak_reason, open_serial,
};
use crate::io::calibration::Calibration;
use crate::io::image::{Pixels, ReadLimits, read_gray_limited, write_tiff_f32};
use crate::io::ply::{PlyOptions, PointRow};
use crate::scan::CompiledModels;
use anyhow::{Context, Result, bail};
use fringe3d_core::wire::{
    EdgeFilterMode, Exposures, NakCode, PROTOCOL_VERSION, ScanOutput, ValidationStatus,
};
use std::path::PathBuf;
use std::time::Duration;

/// Arguments of `fringe3d device`.
#[derive(clap::Args, Debug)]
#[command(
    after_help = "Examples:\n  fringe3d device info --port /dev/ttyUSB0\n  \
fringe3d device upload --port /dev/ttyUSB0 --patterns scan/patterns.toml --calibration scan/calibration.toml\n  \
fringe3d device scan --port /dev/ttyUSB0 --out cloud.ply\n  \
fringe3d device start --port /dev/ttyUSB0   (project the sequence; stop / abort end it)\n\n\
The simulated head `fringe3d-head DATASET` prints the PTY path to use as --port. See docs/device.md."
)]
pub struct DeviceArgs {
    /// What to do.
    #[command(subcommand)]
    pub command: DeviceCommand,
}

/// The `device` subcommands.
#[derive(clap::Subcommand, Debug)]
pub enum DeviceCommand {
    /// Show what the head is and its state.
    Info(PortArgs),
    /// Define a pattern set on the head, upload its images (or let the head render them), the
    /// calibration and reference phase map, and the trigger sequence that captures the set.
    Upload(UploadArgs),
    /// Scan: the head projects, captures, decodes, reconstructs and streams the rows back.
    Scan(ScanArgs),
    /// Start the configured trigger sequence: the head projects it (and triggers the camera as
    /// configured) once, or until `stop` if it was uploaded with `--repeat`. Nothing is streamed.
    Start(PortArgs),
    /// Stop a running sequence after its current entry (refused while a scan streams: use
    /// `abort`).
    Stop(PortArgs),
    /// Abort whatever runs (a sequence or a scan) and clear a fault; the head returns to ready
    /// (or idle after a fault).
    Abort(PortArgs),
}

/// The serial port and link options.
#[derive(clap::Args, Debug, Clone)]
pub struct PortArgs {
    /// Serial port (e.g. /dev/ttyUSB0, or the PTY `fringe3d-head` prints).
    #[arg(long)]
    pub port: String,
    /// Baud rate, 50 to 20000000.
    #[arg(long, default_value_t = 921_600, value_parser = parse::baud)]
    pub baud: u32,
    /// Time allowed for an answer beyond its transmission time, milliseconds (1 to 3600000).
    #[arg(long, default_value_t = 500, value_parser = parse::timeout_ms)]
    pub timeout_ms: u64,
    /// Times a request is repeated on silence or line damage before giving up (0 to 100).
    #[arg(long, default_value_t = 8, value_parser = parse::retries)]
    pub retries: u32,
}

/// Arguments of `fringe3d device upload`.
#[derive(clap::Args, Debug)]
pub struct UploadArgs {
    /// Port options.
    #[command(flatten)]
    pub port: PortArgs,
    /// The pattern-set file.
    #[arg(long, short = 'p')]
    pub patterns: PathBuf,
    /// Pattern-set slot on the head.
    #[arg(long, default_value_t = 0)]
    pub set_id: u8,
    /// Upload these pattern images (a folder written by `fringe3d patterns`) instead of
    /// rendering them from the pattern-set file.
    #[arg(long, conflicts_with = "parametric")]
    pub images: Option<PathBuf>,
    /// Upload no images: the head renders the patterns itself (refused unless its rendering is
    /// bit-identical to `fringe3d patterns`).
    #[arg(long)]
    pub parametric: bool,
    /// Calibration file: its camera, projector centre, reference plane and depth range, and the
    /// reference phase map it names, go to the head (needed for point scans). Its reference must
    /// have been made with this pattern set (refused otherwise, before the port is opened).
    #[arg(long, short = 'c')]
    pub calibration: Option<PathBuf>,
    /// The compiled reconstruction of that calibration and map (`fringe3d compile`; checked
    /// against them as `scan --compiled` does): the head reconstructs the pixels that have a
    /// model without the search (docs/compiled.md).
    #[arg(long, requires = "calibration", value_name = "FILE.f3c")]
    pub compiled: Option<PathBuf>,
    /// Exposure per pattern, µs (1 to 60000000).
    #[arg(long, default_value_t = 10_000, value_parser = parse::exposure_us)]
    pub exposure_us: u32,
    /// Dark time after each pattern (covers the camera readout), µs (0 to 60000000).
    #[arg(long, default_value_t = 2_000, value_parser = parse::dark_us)]
    pub dark_us: u32,
    /// Configure the sequence to repeat until `fringe3d device stop` (for `device start`; a scan
    /// always runs it once).
    #[arg(long)]
    pub repeat: bool,
    /// The decoder's thresholds the head scans with (DefineThresholds), as `scan` takes them;
    /// `--noise` takes codes only (the images are the head's). Without any, and without a
    /// `[sensor]` noise in the calibration, the head uses its camera bit depth's defaults.
    #[command(flatten)]
    pub thresholds: common::ThresholdArgs,
    /// The head camera's bit depth (8 to 16), for the thresholds' defaults; needed with
    /// thresholds when the calibration records no `[sensor]` noise (whose bit depth it is).
    #[arg(long, value_name = "BITS", value_parser = clap::value_parser!(u8).range(8..=16))]
    pub camera_bits: Option<u8>,
}

/// What a scan streams.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum OutputKind {
    /// Points (x, y, z in mm, camera frame).
    Points,
    /// Absolute phase.
    Phase,
    /// Both.
    Both,
}

/// Arguments of `fringe3d device scan`.
#[derive(clap::Args, Debug)]
pub struct ScanArgs {
    /// Port options.
    #[command(flatten)]
    pub port: PortArgs,
    /// What to stream.
    #[arg(long, value_enum, default_value_t = OutputKind::Points)]
    pub output: OutputKind,
    /// Point cloud file, or - for standard output (the summary then goes to standard error).
    /// PLY: organized, one vertex per camera pixel of the scanned rows (x, y, z, u, v and the
    /// validity code; x y z NaN where invalid), as `fringe3d scan --organized` writes it; .xyz:
    /// plain "x y z" text of the valid points.
    #[arg(long, short = 'o')]
    pub out: Option<PathBuf>,
    /// Cloud format (default: by the extension of --out, which must then be .ply or .xyz; PLY for -).
    #[arg(long, value_enum)]
    pub format: Option<CloudFormat>,
    /// Phase map file (32-bit float TIFF, NaN where invalid).
    #[arg(long)]
    pub phase_out: Option<PathBuf>,
    /// First camera row.
    #[arg(long, default_value_t = 0)]
    pub first_row: u16,
    /// Rows (0: to the last row).
    #[arg(long, default_value_t = 0)]
    pub rows: u16,
    /// Silence tolerated while the head captures, seconds (more than 0, at most 86400).
    #[arg(long, default_value_t = 30.0, value_parser = parse::scan_timeout_s)]
    pub scan_timeout_s: f64,
    /// Keep points at depth discontinuities ("flying pixels" that mix two surfaces) and at the
    /// edge of the light; by default the head filters them as `fringe3d scan` does.
    #[arg(long)]
    pub no_edge_filter: bool,
    /// Steepest accepted surface for the edge filter, degrees from facing the camera.
    #[arg(long, default_value_t = 80.0)]
    pub max_angle: f64,
    /// HDR: capture the whole set at each of these exposures (µs, 1 to 4 comma-separated,
    /// longest first) and keep, per pixel, the decode of the longest exposure in which it did
    /// not saturate, as `fringe3d scan --hdr` does (docs/hdr.md). The head stops early when no
    /// pixel is left saturated. One value sets the exposure of a plain scan; without the
    /// option the sequence's own exposures (`device upload --exposure-us`) are used.
    #[arg(long, value_name = "US,US,...", value_parser = parse::exposures_us)]
    pub exposures_us: Option<fringe3d_core::wire::Exposures>,
}

/// Open the port and say Hello (`scan_timeout`: the scan's answer timeout, s).
fn connect(p: &PortArgs, scan_timeout: Option<f64>) -> Result<Client<SerialTransport>> {
    let io = open_serial(&p.port, p.baud)?;
    let mut opts = ClientOptions {
        timeout: Duration::from_millis(p.timeout_ms),
        retries: p.retries,
        ..Default::default()
    };
    if let Some(s) = scan_timeout {
        // Checked at parse time (`parse::scan_timeout_s`); `try_` all the same: never a panic.
        opts.scan_timeout = Duration::try_from_secs_f64(s)
            .map_err(|e| anyhow::anyhow!("--scan-timeout-s {s}: {e}"))?;
    }
    Client::connect(io, opts).with_context(|| format!("connecting to the scan head on {}", p.port))
}

mod status;

use status::{Control, control, info};

/// Run `fringe3d device`.
pub fn run(a: DeviceArgs, g: Global) -> Result<()> {
    match a.command {
        DeviceCommand::Info(p) => info(p, g),
        DeviceCommand::Upload(u) => upload(u, g),
        DeviceCommand::Scan(s) => scan(s, g),
        DeviceCommand::Start(p) => control(p, Control::Start, g),
        DeviceCommand::Stop(p) => control(p, Control::Stop, g),
        DeviceCommand::Abort(p) => control(p, Control::Abort, g),
    }
}

fn bar(len: u64, msg: &str, quiet: bool) -> (indicatif::ProgressBar, impl FnMut(u64, u64)) {
    let pb = common::progress(len, msg, quiet);
    let pb2 = pb.clone();
    (pb, move |done: u64, total: u64| {
        pb2.set_length(total);
        pb2.set_position(done);
    })
}

/// The thresholds `device upload` sends: those `scan` would use with the calibration's
/// `[sensor]` noise and the given options, for the head camera's bit depth; `None` (the head's
/// own defaults) when nothing sets them.
fn head_thresholds(
    a: &UploadArgs,
    cal: Option<&Calibration>,
) -> Result<Option<fringe3d_core::decode::DecodeConfig>> {
    let t = &a.thresholds;
    let given = t.noise.is_some()
        || t.min_modulation.is_some()
        || t.saturation.is_some()
        || t.dark_level.is_some()
        || t.unwrap_tolerance.is_some()
        || t.range_tolerance.is_some();
    let sensor = cal.and_then(|c| c.sensor.as_ref());
    if !given && sensor.is_none() {
        return Ok(None);
    }
    let Some(bits) = a.camera_bits.or(sensor.map(|s| s.bits)) else {
        bail!(
            "decoder thresholds for the head: give --camera-bits (the head camera's bit depth), \
             or a calibration whose reference recorded the sensor's noise ([sensor])"
        );
    };
    t.config_for_camera(bits, sensor).map(Some)
}

fn upload(a: UploadArgs, g: Global) -> Result<()> {
    let ls = common::load_set(&a.patterns)?;
    // The head's reference and pattern set must match, as for `fringe3d scan`; checked before
    // anything else (and before the line is touched).
    // The phase-error table of the projector's light (its response, a binary set's blur;
    // docs/gamma.md, docs/binary.md), which the head decodes with (DefineCorrection).
    // The calibration file, read once (the table here, the wire calibration below).
    let cal_file = a
        .calibration
        .as_deref()
        .map(Calibration::load)
        .transpose()?;
    let correction = match (&a.calibration, &cal_file) {
        (Some(path), Some(cal)) => {
            common::check_reference_patterns(path, &ls.scan_patterns()?, g.quiet)?;
            common::response_correction(cal, path, &ls)?
        }
        _ if ls.set.binarization().is_binary() => bail!(
            "{}: a binary pattern set is decoded with the phase-error table of the projector's \
             blur: give --calibration with the calibration that records projector_defocus \
             (`fringe3d calibrate defocus`, docs/binary.md)",
            a.patterns.display()
        ),
        _ => None,
    };
    if ls.file.projector.response_compensated == Some(true) && a.images.is_none() {
        bail!(
            "{}: its patterns are pre-distorted through a projector response \
             (response_compensated = true), which the head's own rendering cannot reproduce: \
             upload the written images with --images DIR",
            a.patterns.display()
        );
    }
    let set = &ls.set;
    let desc = pattern_desc(set, ls.file.bit_depth())
        .map_err(|m| anyhow::anyhow!("{}: {m}", a.patterns.display()))?;
    let fid = fidelity(set, &desc, 8);
    // Everything that can fail locally is read before the line is touched.
    let images = if a.parametric {
        if !fid.patterns {
            bail!(
                "{}: the head's own rendering of this set would differ from `fringe3d patterns` (a bug: its wire description does not rebuild it); upload the images instead (omit --parametric)",
                a.patterns.display()
            );
        }
        None
    } else {
        let data = match &a.images {
            Some(dir) => {
                let files = crate::io::image_set::list_folder(dir)?;
                if files.len() != set.image_count() {
                    bail!(
                        "{}: {} images, the pattern set has {}",
                        dir.display(),
                        files.len(),
                        set.image_count()
                    );
                }
                pattern_bytes(set, &desc, |i| {
                    let lim = ReadLimits::sized(desc.width as u32, desc.height as u32);
                    let (img, _) = read_gray_limited(&files[i], &lim).map_err(|e| e.to_string())?;
                    match img.pixels {
                        Pixels::U8(v)
                            if (img.width, img.height)
                                == (desc.width as u32, desc.height as u32) =>
                        {
                            Ok(v)
                        }
                        _ => Err(format!(
                            "{}: must be an 8-bit {}x{} image",
                            files[i].display(),
                            desc.width,
                            desc.height
                        )),
                    }
                })
            }
            None => pattern_bytes(set, &desc, |i| render_pattern(set, i)),
        }
        .map_err(|m| anyhow::anyhow!("pattern images: {m}"))?;
        Some(data)
    };
    let calib = match (&a.calibration, &cal_file) {
        (Some(path), Some(cal)) => {
            let axis = set.axis();
            let sc = common::load_calibration(path, axis)
                .with_context(|| format!("{}: preparing the reconstruction", path.display()))?;
            let w =
                wire_calibration(cal).map_err(|m| anyhow::anyhow!("{}: {m}", path.display()))?;
            // The map's rows are its own width: the image's and its margin past the image.
            let map = phase_map_bytes(&sc.reference_phase, sc.recon.map_width());
            let (width, height, margin) = (sc.width(), sc.height(), sc.recon.margin());
            let compiled = match &a.compiled {
                Some(p) => {
                    let s = sc.recon.setup();
                    let z = (s.z_min as f32, s.z_max as f32);
                    let models = match sc.with_compiled(p)?.compiled {
                        Some(CompiledModels::Whole(f)) => f.models,
                        _ => Vec::new(),
                    };
                    let bytes: Vec<u8> = models
                        .iter()
                        .flat_map(|v| fringe3d_core::math::canonical(*v).to_le_bytes())
                        .collect();
                    Some((p.clone(), z, bytes))
                }
                None => None,
            };
            Some((path.clone(), w, map, width, height, margin, compiled))
        }
        _ => None,
    };

    let thresholds = head_thresholds(&a, cal_file.as_ref())?;

    let mut c = connect(&a.port, None)?;
    let caps = *c.capabilities();
    if (caps.projector_width, caps.projector_height) != (desc.width, desc.height) {
        bail!(
            "the head's projector is {}x{}, the pattern set {}x{}",
            caps.projector_width,
            caps.projector_height,
            desc.width,
            desc.height
        );
    }
    c.define_pattern_set(a.set_id, &desc)?;
    // Always sent: a table left from an earlier upload of the same set must not stay.
    c.define_correction(a.set_id, correction.as_ref())?;
    // Always sent too: thresholds left from an earlier upload must not stay.
    c.define_thresholds(a.set_id, thresholds.as_ref())?;
    let mut summary = serde_json::json!({"command": "device upload", "port": a.port.port, "set_id": a.set_id,
        "patterns_exact": fid.patterns, "decoder_exact": fid.decoder,
        "phase_correction": correction.is_some(),
        "thresholds": thresholds.map(|t| serde_json::json!({"dark_level": t.dark_level,
            "saturation_level": t.saturation_level, "min_modulation": t.min_modulation,
            "unwrap_tolerance": t.unwrap_tolerance, "range_tolerance": t.range_tolerance}))});
    if let Some(t) = &thresholds
        && !g.quiet
        && !g.json
    {
        outln!(
            "decoder thresholds sent: minimum modulation {} codes, saturation {} codes, dark {} \
             codes",
            t.min_modulation,
            t.saturation_level,
            t.dark_level
        );
    }
    if correction.is_some() && !g.quiet && !g.json {
        outln!(
            "phase-error table of the projector's light sent: the head decodes with it, as the \
             desktop does"
        );
    }
    if let Some(data) = &images {
        let (pb, mut cb) = bar(data.len() as u64, "patterns", g.quiet);
        let r = c.upload_patterns(a.set_id, &desc, data, &mut cb);
        pb.finish_and_clear();
        let r = r?;
        summary["patterns_upload"] = serde_json::json!({"bytes": r.total, "resumed_from": r.resumed_from, "wire_bytes": r.wire_bytes, "recoveries": r.recoveries, "seconds": r.seconds});
        if !g.quiet && !g.json {
            let resumed = if r.resumed_from > 0 {
                format!(" (resumed at byte {})", r.resumed_from)
            } else {
                String::new()
            };
            outln!(
                "uploaded {} pattern images, {} bytes{} in {:.2} s; digest confirmed",
                desc.pattern_count(),
                r.total,
                resumed,
                r.seconds
            );
        }
    } else if !g.quiet && !g.json {
        outln!(
            "pattern set {} defined; the head renders its {} patterns itself",
            a.set_id,
            desc.pattern_count()
        );
    }
    if let Some((_, w, map, mw, mh, margin, compiled)) = &calib {
        if (caps.sensor_width as usize, caps.sensor_height as usize) != (*mw, *mh) {
            bail!(
                "the head's camera is {}x{}, the calibration's {}x{}",
                caps.sensor_width,
                caps.sensor_height,
                mw,
                mh
            );
        }
        c.upload_calibration(w)?;
        let (pb, mut cb) = bar(map.len() as u64, "phase map", g.quiet);
        let r = c.upload_phase_map(*mw as u16, *mh as u16, *margin, map, &mut cb);
        pb.finish_and_clear();
        let r = match r {
            Err(crate::device::DeviceError::Refused {
                code: fringe3d_core::wire::NakCode::OutOfMemory,
                ..
            }) if *margin != fringe3d_core::reconstruct::Margin::ZERO => bail!(
                "the head has not enough memory for the reference map of {}: {} bytes, \
                 {:?} px past the image (left, top, right, bottom); make the head's reference \
                 with a smaller `calibrate reference --margin` (0: image-sized)",
                calib
                    .as_ref()
                    .map_or(String::new(), |c| c.0.display().to_string()),
                map.len(),
                margin.to_array()
            ),
            r => r?,
        };
        summary["phase_map_upload"] = serde_json::json!({"bytes": r.total, "resumed_from": r.resumed_from, "wire_bytes": r.wire_bytes, "seconds": r.seconds, "margin": margin.to_array()});
        if !g.quiet && !g.json {
            let past = if *margin == fringe3d_core::reconstruct::Margin::ZERO {
                String::new()
            } else {
                let [l, t, r, b] = margin.to_array();
                format!(", {l}/{t}/{r}/{b} px past the image (left/top/right/bottom)")
            };
            outln!(
                "uploaded the calibration and the reference phase map ({} bytes{past}) in {:.2} s; digest confirmed",
                r.total,
                r.seconds
            );
        }
        if let Some((path, z, bytes)) = compiled {
            let (pb, mut cb) = bar(bytes.len() as u64, "compiled", g.quiet);
            let r = c.upload_compiled(*mw as u16, *mh as u16, *z, bytes, &mut cb);
            pb.finish_and_clear();
            let r = match r {
                Err(crate::device::DeviceError::Refused {
                    code: NakCode::OutOfMemory,
                    ..
                }) => bail!(
                    "the head has no room for the compiled reconstruction {} ({} bytes, a row of \
                     {} bytes): upload without --compiled, and it reconstructs with the search",
                    path.display(),
                    bytes.len(),
                    bytes.len() / (*mh).max(1)
                ),
                r => r?,
            };
            summary["compiled_upload"] = serde_json::json!({"bytes": r.total, "resumed_from": r.resumed_from, "wire_bytes": r.wire_bytes, "seconds": r.seconds});
            if !g.quiet && !g.json {
                outln!(
                    "uploaded the compiled reconstruction ({} bytes) in {:.2} s; digest confirmed",
                    r.total,
                    r.seconds
                );
            }
        }
    }
    if !fid.decoder && !g.quiet {
        errln!(
            "warning: the head's decoder for this set differs from the desktop's (a bug: its wire description does not rebuild the set): phases may differ in the last bits"
        );
    }
    let lut = capture_sequence(set, &desc, a.exposure_us, a.dark_us)
        .map_err(|m| anyhow::anyhow!("{m}"))?;
    c.configure_sequence(a.set_id, a.repeat, &lut)?;
    let v = c.validate()?;
    summary["validation"] = serde_json::json!(v.0);
    let blocking = v.0 & !(ValidationStatus::NO_CALIBRATION | ValidationStatus::NO_REFERENCE);
    if g.json {
        outln!("{summary}");
    } else if !g.quiet {
        if v.is_ok() {
            outln!(
                "trigger sequence of {} entries configured and valid: ready to scan",
                lut.len()
            );
        } else {
            outln!(
                "trigger sequence of {} entries configured: {}",
                lut.len(),
                nak_reason(NakCode::SequenceInvalid, v.0 as u16)
            );
        }
    }
    if blocking != 0 {
        bail!(
            "the head refused the sequence: {}",
            nak_reason(NakCode::SequenceInvalid, v.0 as u16)
        );
    }
    Ok(())
}

fn scan(a: ScanArgs, g: Global) -> Result<()> {
    if a.out.is_none() && a.phase_out.is_none() {
        bail!("nothing to write: give --out FILE.ply (points) and/or --phase-out FILE.tif (phase)");
    }
    let cloud = a
        .out
        .as_deref()
        .map(|p| CloudOut::resolve(p, a.format, "--out"))
        .transpose()?;
    if let Some(p) = &a.phase_out {
        common::file_out(p, "--phase-out")?;
    }
    let output = match (a.output, a.out.is_some(), a.phase_out.is_some()) {
        (OutputKind::Points, _, true) | (OutputKind::Both, _, _) => ScanOutput::Both,
        (OutputKind::Phase, true, _) => ScanOutput::Both,
        (OutputKind::Phase, _, _) => ScanOutput::Phase,
        (OutputKind::Points, _, _) => ScanOutput::Points,
    };
    let edge_filter = if a.no_edge_filter {
        EdgeFilterMode::Off
    } else {
        if !(a.max_angle > 0.0 && a.max_angle < 90.0) {
            bail!(
                "--max-angle: the edge filter's angle must be in (0, 90) degrees, got {}",
                a.max_angle
            );
        }
        EdgeFilterMode::MaxAngle(a.max_angle)
    };
    let mut c = connect(&a.port, Some(a.scan_timeout_s))?;
    // Ctrl-C (SIGINT, SIGTERM, SIGHUP) from here on aborts the head's scan before the process
    // exits: the signal handler waits for this guard.
    let busy = interrupt::Busy::enter();
    c.set_interrupt(interrupt::process_flag());
    let (pb, mut cb) = bar(0, "rows", g.quiet);
    let exposures = a.exposures_us.unwrap_or(Exposures::NONE);
    let r = c.scan_exposed(output, a.first_row, a.rows, edge_filter, exposures, &mut cb);
    pb.finish_and_clear();
    drop(busy);
    let r = match r {
        Err(DeviceError::Refused {
            code: NakCode::Busy,
            ..
        }) => bail!(
            "the head is busy: a sequence runs or another scan streams; `fringe3d device abort` ends either (`fringe3d device stop` ends a running sequence only), then scan again"
        ),
        r => r?,
    };
    let (w, rows) = (r.width, r.rows);
    let mut valid = None;
    if let (Some(out), Some(xyz), Some(codes)) = (&cloud, &r.xyz, &r.point_validity) {
        let pts: Vec<[f32; 3]> = xyz.chunks_exact(3).map(|p| [p[0], p[1], p[2]]).collect();
        let row = |i: usize| PointRow {
            v: (r.first_row + i) as u32,
            xyz: &pts[i * w..(i + 1) * w],
            intensity: &[],
            modulation: &[],
            validity: &codes[i * w..(i + 1) * w],
        };
        let opts = PlyOptions {
            intensity: false,
            modulation: false,
            ..Default::default()
        };
        // Organized (the XYZ format keeps the valid points only, as for `fringe3d scan`).
        cloud_out::write_rows(out, w, rows, row, opts, true)?;
        valid = Some(codes.iter().filter(|&&c| c == 0).count() as u64);
    }
    if let (Some(path), Some(phase)) = (&a.phase_out, &r.phase) {
        write_tiff_f32(path, w as u32, rows as u32, phase)?;
    }
    if let (Some(0), Some(out)) = (valid, &cloud)
        && !g.quiet
    {
        errln!(
            "warning: no pixel gave a valid point: {} holds no points",
            out.describe()
        );
    }
    // With the cloud on standard output, the summary goes to standard error.
    let to_stderr = cloud.as_ref().is_some_and(CloudOut::to_stdout);
    let say = |line: String| {
        if to_stderr {
            errln!("{line}");
        } else {
            outln!("{line}");
        }
    };
    if g.json {
        say(serde_json::json!({"command": "device scan", "port": a.port.port, "protocol_version": PROTOCOL_VERSION, "width": w, "first_row": r.first_row,
                "rows": rows, "exposures_us": exposures.as_slice(), "points": valid,
                "decoded": r.counts.map(|c| c.decoded), "searched": r.counts.map(|c| c.searched), "rescans": r.rescans, "stale_rows_dropped": r.stale_rows, "wire_bytes": r.wire_bytes, "seconds": r.seconds})
            .to_string());
    } else if !g.quiet {
        let list = exposures.as_slice();
        let hdr = if list.len() > 1 {
            let us: Vec<String> = list.iter().map(|u| u.to_string()).collect();
            format!(" at {} µs (HDR)", us.join("/"))
        } else {
            String::new()
        };
        say(format!(
            "scanned rows {}..{} ({} x {}){hdr} in {:.2} s, {} bytes received{}",
            r.first_row,
            r.first_row + rows,
            w,
            rows,
            r.seconds,
            r.wire_bytes,
            if r.rescans > 0 {
                format!(", {} re-requests of lost rows", r.rescans)
            } else {
                String::new()
            }
        ));
        // The fallback rate: every decoded pixel without compiled models, fewer with them.
        if let Some(c) = r.counts.filter(|_| r.xyz.is_some()) {
            say(format!(
                "the head decoded {} pixels; the search computed the points of {} of them ({:.2} %), compiled models the rest",
                c.decoded,
                c.searched,
                100.0 * c.searched as f64 / c.decoded.max(1) as f64
            ));
        }
        if r.stale_rows > 0 {
            say(format!(
                "dropped {} rows of an earlier scan still in flight (not of this scan: not written)",
                r.stale_rows
            ));
        }
        if let (Some(n), Some(out)) = (valid, &cloud) {
            let grid = if out.format == CloudFormat::Ply {
                format!(" (organized, {w} x {rows} vertices)")
            } else {
                String::new()
            };
            say(format!(
                "wrote {n} valid points to {}{grid}",
                out.describe()
            ));
        }
        if let Some(p) = &a.phase_out {
            say(format!("wrote the phase map to {}", p.display()));
        }
    }
    Ok(())
}
