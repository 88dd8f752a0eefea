//! Interrupting a device command (Ctrl-C): the scan in progress is aborted on the head before the
//! process dies, so that an interrupted `device scan` does not leave the head scanning (issue #21
//! item 10).
//!
//! A [`Client`](super::Client) given an interrupt flag
//! ([`Client::set_interrupt`](super::Client::set_interrupt)) checks it while it waits for
//! frames; once the flag is set, a scan sends Abort to the head (one short exchange) and fails
//! with [`DeviceError::Interrupted`](super::DeviceError::Interrupted). The `fringe3d` binary wires
//! SIGINT, SIGTERM and SIGHUP to [`process_flag`] through [`on_signal`], which waits (a bounded
//! time) for the commands in progress ([`Busy`] guards) to finish their abort before the process
//! exits.

use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{Arc, OnceLock};
use std::time::{Duration, Instant};

/// Longest wait of [`on_signal`] for the commands in progress to abort.
pub const ABORT_GRACE: Duration = Duration::from_secs(3);

static ACTIVE: AtomicUsize = AtomicUsize::new(0);

/// The process's interrupt flag (set by [`on_signal`]).
pub fn process_flag() -> Arc<AtomicBool> {
    static FLAG: OnceLock<Arc<AtomicBool>> = OnceLock::new();
    FLAG.get_or_init(|| Arc::new(AtomicBool::new(false)))
        .clone()
}

/// A device command in progress that must abort on the head before the process exits.
pub struct Busy(());

impl Busy {
    /// Mark a command as in progress until the guard is dropped.
    pub fn enter() -> Busy {
        ACTIVE.fetch_add(1, Ordering::SeqCst);
        Busy(())
    }
}

impl Drop for Busy {
    fn drop(&mut self) {
        ACTIVE.fetch_sub(1, Ordering::SeqCst);
    }
}

/// Called on a termination signal: set [`process_flag`], then wait until no [`Busy`] command is
/// left (they abort the head's scan and return), at most [`ABORT_GRACE`]. Returns `true` if none
/// was left in time.
pub fn on_signal() -> bool {
    process_flag().store(true, Ordering::SeqCst);
    let end = Instant::now() + ABORT_GRACE;
    while ACTIVE.load(Ordering::SeqCst) > 0 {
        if Instant::now() >= end {
            return false;
        }
        std::thread::sleep(Duration::from_millis(10));
    }
    true
}
