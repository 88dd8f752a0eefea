//! The `fringe3d` command line: one file per command.

use clap::{Parser, Subcommand};

// Printing for the commands (see `print`): to standard output without panicking on a closed pipe,
// and to standard error ignoring failures. Defined before the modules that use them.
macro_rules! outln {
    () => { $crate::cli::print::stdout(format_args!("\n")) };
    ($($t:tt)*) => { $crate::cli::print::stdout(format_args!("{}\n", format_args!($($t)*))) };
}
macro_rules! out {
    ($($t:tt)*) => { $crate::cli::print::stdout(format_args!($($t)*)) };
}
macro_rules! errln {
    ($($t:tt)*) => { $crate::cli::print::stderr(format_args!("{}\n", format_args!($($t)*))) };
}

pub mod adapt;
pub mod budget;
pub mod calibrate;
pub mod calibrate_defocus;
pub mod calibrate_gamma;
pub mod calibrate_import;
pub mod cloud_out;
pub mod common;
pub mod compile;
pub mod decode;
pub mod demo;
pub mod demo_calibrate;
pub mod device;
pub mod info;
pub mod parse;
pub mod patterns;
pub mod print;
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
    /// Worker threads, 1 to 256 (default: all cores).
    #[arg(long, short = 'j', global = true, value_name = "N", value_parser = parse::threads)]
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
    /// Compile a calibration's reconstruction to one rational function per pixel (for `scan
    /// --compiled` and for heads), checked against the search.
    Compile(compile::CompileArgs),
    /// Render a synthetic fringe-projection dataset with ground truth.
    Render(render::RenderArgs),
    /// Calibrate the camera, the projector centre or the reference plane (paper §7); import or
    /// export a full calibration of another tool.
    Calibrate(calibrate::CalibrateArgs),
    /// Render a built-in scene, scan it and report the accuracy against ground truth.
    Demo(demo::DemoArgs),
    /// Describe a dataset folder, calibration, pattern set or image.
    Info(info::InfoArgs),
    /// Talk to a scan head over a serial port: info, upload, scan.
    Device(device::DeviceArgs),
    /// Write (or verify) golden test vectors: a small scan's inputs and every stage's outputs.
    Vectors(vectors::VectorsArgs),
    /// The static memory a scan head needs for a pattern set and a rig, buffer by buffer.
    Budget(budget::BudgetArgs),
    /// Design a pattern set for one object from a first scan or a model of it (paper Fig. 10):
    /// fringes as dense as the camera resolves on it, with a virtual reference for the new set.
    Adapt(adapt::AdaptArgs),
}

/// Options every command sees.
#[derive(Clone, Copy, Debug)]
pub struct Global {
    /// `--quiet`.
    pub quiet: bool,
    /// `--json`.
    pub json: bool,
}

/// An error and its causes on one line, `outer: inner: …`, without repeating a cause whose text
/// the message already holds (several error types print their source in their own message and
/// also return it as their `source()`: "Is a directory (os error 21): Is a directory (os error
/// 21)").
pub fn error_message(e: &anyhow::Error) -> String {
    let mut msg = String::new();
    for cause in e.chain() {
        let s = cause.to_string();
        if s.is_empty() || msg.contains(&s) {
            continue;
        }
        if !msg.is_empty() {
            msg.push_str(": ");
        }
        msg.push_str(&s);
    }
    msg
}

/// Report how a run ended and give the process's exit status: 0 on success; 1 after an error
/// (printed to standard error) or when standard output could not be written; 141 (128 +
/// SIGPIPE, as for a Unix tool killed by SIGPIPE) when the reader of standard output went away
/// early (`fringe3d info x | head -1`), quietly.
pub fn exit_status(result: anyhow::Result<()>) -> i32 {
    let stdout = print::finish();
    if let Err(e) = result {
        errln!("error: {}", error_message(&e));
        return 1;
    }
    match stdout {
        print::Finish::Ok => 0,
        print::Finish::BrokenPipe => print::BROKEN_PIPE_STATUS,
        print::Finish::Failed(e) => {
            errln!("error: standard output: cannot write: {e}");
            1
        }
    }
}

/// Build rayon's global pool here, not lazily at the first parallel call, so that a failure to
/// start the threads is an error rather than a panic (`None`: rayon's default, all cores). A pool
/// that already exists (a program that runs several commands in one process, or used rayon
/// before) is used as it is.
fn start_pool(threads: Option<usize>) -> anyhow::Result<()> {
    use std::error::Error as _;
    match rayon::ThreadPoolBuilder::new()
        .num_threads(threads.unwrap_or(0))
        .build_global()
    {
        Ok(()) => Ok(()),
        // "Already initialized" has no source; a failure to spawn threads has its OS error.
        Err(e) if e.source().is_none() => Ok(()),
        Err(e) => Err(match threads {
            Some(n) => anyhow::anyhow!("-j {n}: cannot start {n} worker threads: {e}"),
            None => anyhow::anyhow!("cannot start the worker threads: {e}"),
        }),
    }
}

/// On SIGINT, SIGTERM or SIGHUP: remove this process's temporary files and folders (see
/// [`crate::io::atomic::clean_up_for_exit`]), then die of the signal as if it had not been caught
/// (exit status 130 for Ctrl-C in a shell). Installed once per process; best effort.
fn install_signal_cleanup() {
    #[cfg(unix)]
    {
        use signal_hook::consts::{SIGHUP, SIGINT, SIGTERM};
        static ONCE: std::sync::Once = std::sync::Once::new();
        ONCE.call_once(|| {
            let Ok(mut signals) = signal_hook::iterator::Signals::new([SIGINT, SIGTERM, SIGHUP])
            else {
                return;
            };
            let spawned = std::thread::Builder::new()
                .name("signals".into())
                .spawn(move || {
                    if let Some(sig) = signals.forever().next() {
                        // A `device scan` in progress aborts the head's scan first.
                        crate::device::interrupt::on_signal();
                        crate::io::atomic::clean_up_for_exit();
                        let _ = signal_hook::low_level::emulate_default_handler(sig);
                        std::process::exit(128 + sig);
                    }
                });
            drop(spawned);
        });
    }
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
    start_pool(cli.threads)?;
    install_signal_cleanup();
    let g = Global {
        quiet: cli.quiet,
        json: cli.json,
    };
    match cli.command {
        Command::Patterns(a) => patterns::run(a, g),
        Command::Decode(a) => decode::run(a, g),
        Command::Reconstruct(a) => reconstruct::run(a, g),
        Command::Scan(a) => scan::run(a, g),
        Command::Compile(a) => compile::run(a, g),
        Command::Render(a) => render::run(a, g),
        Command::Calibrate(a) => calibrate::run(a, g),
        Command::Demo(a) => demo::run(a, g),
        Command::Info(a) => info::run(a, g),
        Command::Device(a) => device::run(a, g),
        Command::Vectors(a) => vectors::run(a, g),
        Command::Budget(a) => budget::run(a, g),
        Command::Adapt(a) => adapt::run(a, g),
    }
}
