//! The `fringe3d` command line: one file per command.

use clap::{Parser, Subcommand};

pub mod calibrate;
pub mod cloud_out;
pub mod common;
pub mod decode;
pub mod demo;
pub mod demo_calibrate;
pub mod device;
pub mod info;
pub mod patterns;
pub mod reconstruct;
pub mod render;
pub mod scan;
pub mod vectors;

/// fringe3d: structured-light 3-D scanning (Peng & Gupta 2007).
#[derive(Parser, Debug)]
#[command(name = "fringe3d", version, about, long_about = None)]
pub struct Cli {
    /// Print nothing but errors.
    #[arg(long, short, global = true)]
    pub quiet: bool,
    /// Print a machine-readable JSON summary on stdout.
    #[arg(long, global = true)]
    pub json: bool,
    /// Worker threads (default: all cores).
    #[arg(long, short = 'j', global = true)]
    pub threads: Option<usize>,
    /// The command.
    #[command(subcommand)]
    pub command: Command,
}

/// The commands.
#[derive(Subcommand, Debug)]
pub enum Command {
    /// Write the projector patterns of a pattern-set file as PNG.
    Patterns(patterns::PatternsArgs),
    /// Decode a set of fringe images into absolute phase, modulation, DC term and validity.
    Decode(decode::DecodeArgs),
    /// Reconstruct a point cloud from a decoded phase map and a calibration (paper §6).
    Reconstruct(reconstruct::ReconstructArgs),
    /// Images + calibration → point cloud in one go (decode and reconstruct).
    Scan(scan::ScanArgs),
    /// Render a synthetic fringe-projection dataset with ground truth.
    Render(render::RenderArgs),
    /// Calibrate the camera, the projector centre or the reference plane (paper §7).
    Calibrate(calibrate::CalibrateArgs),
    /// Render a built-in scene, scan it and report the accuracy against ground truth.
    Demo(demo::DemoArgs),
    /// Describe a dataset folder, calibration, pattern set or image.
    Info(info::InfoArgs),
    /// Talk to a scan head over a serial port: info, upload, scan.
    Device(device::DeviceArgs),
    /// Write (or verify) golden test vectors: a small scan's inputs and every stage's outputs.
    Vectors(vectors::VectorsArgs),
}

/// Options every command sees.
#[derive(Clone, Copy, Debug)]
pub struct Global {
    /// `--quiet`.
    pub quiet: bool,
    /// `--json`.
    pub json: bool,
}

/// Parse `args` (including the program name) and run the command.
pub fn run<I, T>(args: I) -> anyhow::Result<()>
where
    I: IntoIterator<Item = T>,
    T: Into<std::ffi::OsString> + Clone,
{
    let cli = Cli::try_parse_from(args).inspect_err(|e| {
        // --help and --version are "errors" to clap; print them and succeed.
        if matches!(
            e.kind(),
            clap::error::ErrorKind::DisplayHelp | clap::error::ErrorKind::DisplayVersion
        ) {
            let _ = e.print();
            std::process::exit(0);
        }
    });
    let cli = match cli {
        Ok(c) => c,
        Err(e) => {
            let _ = e.print();
            std::process::exit(2);
        }
    };
    if let Some(n) = cli.threads {
        rayon::ThreadPoolBuilder::new()
            .num_threads(n.max(1))
            .build_global()
            .ok();
    }
    let g = Global {
        quiet: cli.quiet,
        json: cli.json,
    };
    match cli.command {
        Command::Patterns(a) => patterns::run(a, g),
        Command::Decode(a) => decode::run(a, g),
        Command::Reconstruct(a) => reconstruct::run(a, g),
        Command::Scan(a) => scan::run(a, g),
        Command::Render(a) => render::run(a, g),
        Command::Calibrate(a) => calibrate::run(a, g),
        Command::Demo(a) => demo::run(a, g),
        Command::Info(a) => info::run(a, g),
        Command::Device(a) => device::run(a, g),
        Command::Vectors(a) => vectors::run(a, g),
    }
}
