//! Printing that never panics: standard output closed early (`fringe3d info x | head -1`) or
//! full (`> /dev/full`), or standard error gone, is noted, not fatal in the middle of a command.
//!
//! `outln!` and `out!` (macros of the `cli` module) print to standard output; after the first
//! failure nothing more is written there and the failure is kept for [`finish`], which the binary
//! calls at the end: a broken pipe then ends the process quietly with status 141 (128 + SIGPIPE,
//! what a shell reports for a Unix tool killed by SIGPIPE), any other failure is an error.
//! `errln!` prints to standard error and ignores failures.

use std::io::{self, Write};
use std::sync::Mutex;

/// The first failure writing to standard output.
static FAILED: Mutex<Option<io::Error>> = Mutex::new(None);

/// Exit status after a broken pipe on standard output (128 + SIGPIPE).
pub const BROKEN_PIPE_STATUS: i32 = 141;

/// Note a failure writing to standard output (the first one is kept).
pub fn note_stdout_error(e: io::Error) {
    if let Ok(mut f) = FAILED.lock()
        && f.is_none()
    {
        *f = Some(e);
    }
}

fn stdout_failed() -> bool {
    FAILED.lock().map(|f| f.is_some()).unwrap_or(true)
}

/// Write to standard output (see the module doc).
pub fn stdout(args: std::fmt::Arguments<'_>) {
    if stdout_failed() {
        return;
    }
    let mut o = io::stdout().lock();
    if let Err(e) = o.write_fmt(args) {
        note_stdout_error(e);
    }
}

/// Write to standard error, ignoring failures.
pub fn stderr(args: std::fmt::Arguments<'_>) {
    let _ = io::stderr().lock().write_fmt(args);
}

/// How writing to standard output ended.
#[derive(Debug)]
pub enum Finish {
    /// Everything was written.
    Ok,
    /// The reader went away (broken pipe): exit quietly with [`BROKEN_PIPE_STATUS`].
    BrokenPipe,
    /// Another failure, to report.
    Failed(io::Error),
}

/// Flush standard output and say how writing to it went.
pub fn finish() -> Finish {
    if !stdout_failed()
        && let Err(e) = io::stdout().lock().flush()
    {
        note_stdout_error(e);
    }
    match FAILED.lock().ok().and_then(|mut f| f.take()) {
        None => Finish::Ok,
        Some(e) if e.kind() == io::ErrorKind::BrokenPipe => Finish::BrokenPipe,
        Some(e) => Finish::Failed(e),
    }
}
