//! The head on a pseudo-terminal: `fringe3d device --port /dev/pts/N` talks to it like to a USB
//! serial device.
//!
//! Two threads play the UART interrupts: one reads the PTY master and enqueues the bytes into the
//! RX queue, the other dequeues the TX queue and writes the master. The main loop (the caller's
//! thread) services the head over a [`QueuePort`] on the other ends of the two `heapless` queues,
//! exactly as firmware does on a board.

use std::prelude::rust_2024::*;

use std::os::fd::AsRawFd;
use std::sync::atomic::{AtomicBool, Ordering};
use std::thread;
use std::time::{Duration, Instant};

use nix::fcntl::OFlag;
use nix::poll::{PollFd, PollFlags, poll};
use nix::pty::{PtyMaster, grantpt, posix_openpt, ptsname_r, unlockpt};
use nix::sys::termios::{SetArg, cfmakeraw, tcgetattr, tcsetattr};

use crate::head::{Activity, LinkError};
use crate::port::{ByteQueue, QUEUE_LEN, QueuePort, Wait};

use super::Device;

/// A pseudo-terminal pair: the master (the head's end) and the slave's path (the host's port).
pub struct Pty {
    master: PtyMaster,
    path: String,
    // Held open so that the master never sees a hang-up between host sessions, and so that the
    // slave stays in raw mode.
    _slave: std::fs::File,
}

impl Pty {
    /// Open a PTY pair in raw mode (no echo, no line editing: a clean 8-bit byte pipe).
    pub fn open() -> std::io::Result<Pty> {
        let e = |e: nix::Error| std::io::Error::from_raw_os_error(e as i32);
        let master = posix_openpt(OFlag::O_RDWR | OFlag::O_NOCTTY).map_err(e)?;
        grantpt(&master).map_err(e)?;
        unlockpt(&master).map_err(e)?;
        let path = ptsname_r(&master).map_err(e)?;
        let slave = std::fs::OpenOptions::new()
            .read(true)
            .write(true)
            .open(&path)?;
        for fd in [slave.as_raw_fd(), master.as_raw_fd()] {
            let mut t = tcgetattr(fd).map_err(e)?;
            cfmakeraw(&mut t);
            tcsetattr(fd, SetArg::TCSANOW, &t).map_err(e)?;
        }
        Ok(Pty {
            master,
            path,
            _slave: slave,
        })
    }

    /// The slave's path (give it to `fringe3d device --port`).
    pub fn path(&self) -> &str {
        &self.path
    }
}

/// What [`serve`] did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ServeReport {
    /// Bytes read from the host.
    pub bytes_in: u64,
    /// Bytes written to the host.
    pub bytes_out: u64,
    /// Main-loop passes that did something.
    pub busy_passes: u64,
    /// Link errors reported by the head.
    pub link_errors: u64,
}

/// How long the head's transmitter may make no progress (the host stopped reading the PTY)
/// before the head gives up on what it sends (a scan ends): [`serve`]'s default.
pub const TX_STALL: Duration = Duration::from_secs(10);

/// Waiting strategy of the desktop main loop: park, and wake the TX "interrupt" thread; give up
/// on a transmitter that made no progress for `stall`.
struct ThreadWait {
    tx_thread: thread::Thread,
    stall: Duration,
    full_since: Option<Instant>,
}

impl Wait for ThreadWait {
    fn rx_empty(&mut self) {
        thread::park_timeout(Duration::from_millis(1));
    }

    fn tx_full(&mut self) -> bool {
        let since = *self.full_since.get_or_insert_with(Instant::now);
        if since.elapsed() >= self.stall {
            self.full_since = None;
            return false;
        }
        self.tx_thread.unpark();
        thread::yield_now();
        true
    }

    fn tx_written(&mut self) {
        self.full_since = None;
        self.tx_thread.unpark();
    }
}

/// Serve `head` on `pty` until `stop` is set, giving up on a stalled transmitter after
/// [`TX_STALL`]. `on_pass` is called after every busy main-loop pass (to report progress or
/// memory).
pub fn serve<D: Device>(
    head: &mut D,
    pty: &Pty,
    stop: &AtomicBool,
    on_pass: impl FnMut(&mut D),
) -> ServeReport {
    serve_with(head, pty, stop, TX_STALL, on_pass)
}

/// [`serve`] with the transmitter's stall limit `stall`: when the host stops reading for that
/// long while the head sends (a scan nobody reads), the head's write fails and the scan ends
/// (the head leaves Scanning and sets its link error bit; the serve loop goes on).
pub fn serve_with<D: Device>(
    head: &mut D,
    pty: &Pty,
    stop: &AtomicBool,
    stall: Duration,
    mut on_pass: impl FnMut(&mut D),
) -> ServeReport {
    let fd = pty.master.as_raw_fd();
    let mut rxq = ByteQueue::new();
    let mut txq = ByteQueue::new();
    let (mut rx_in, rx_out) = rxq.split();
    let (tx_in, mut tx_out) = txq.split();
    let main = thread::current();
    let bytes_in = std::sync::atomic::AtomicU64::new(0);
    let bytes_out = std::sync::atomic::AtomicU64::new(0);
    let mut report = ServeReport::default();
    thread::scope(|s| {
        // RX interrupt: line → RX queue.
        s.spawn(|| {
            let mut buf = [0u8; 4096];
            while !stop.load(Ordering::Relaxed) {
                let mut p = [PollFd::new(fd, PollFlags::POLLIN)];
                match poll(&mut p, 20) {
                    Ok(n) if n > 0 => {}
                    _ => continue,
                }
                let n = match nix::unistd::read(fd, &mut buf) {
                    Ok(n) if n > 0 => n,
                    _ => {
                        thread::sleep(Duration::from_millis(5));
                        continue;
                    }
                };
                bytes_in.fetch_add(n as u64, Ordering::Relaxed);
                for &b in &buf[..n] {
                    while rx_in.enqueue(b).is_err() {
                        main.unpark();
                        if stop.load(Ordering::Relaxed) {
                            return;
                        }
                        thread::yield_now();
                    }
                }
                main.unpark();
            }
        });
        // TX interrupt: TX queue → line.
        let tx = s.spawn(|| {
            let mut buf = Vec::with_capacity(QUEUE_LEN);
            loop {
                while let Some(b) = tx_out.dequeue() {
                    buf.push(b);
                }
                if buf.is_empty() {
                    if stop.load(Ordering::Relaxed) {
                        return;
                    }
                    thread::park_timeout(Duration::from_millis(2));
                    continue;
                }
                let mut at = 0;
                while at < buf.len() {
                    match nix::unistd::write(fd, &buf[at..]) {
                        Ok(n) => at += n,
                        Err(nix::Error::EAGAIN) | Err(nix::Error::EINTR) => thread::yield_now(),
                        Err(_) => {
                            if stop.load(Ordering::Relaxed) {
                                return;
                            }
                            thread::sleep(Duration::from_millis(5));
                        }
                    }
                }
                bytes_out.fetch_add(buf.len() as u64, Ordering::Relaxed);
                buf.clear();
            }
        });
        let mut port = QueuePort::new(
            rx_out,
            tx_in,
            ThreadWait {
                tx_thread: tx.thread().clone(),
                stall,
                full_since: None,
            },
        );
        while !stop.load(Ordering::Relaxed) {
            match service(head, &mut port) {
                Ok(Activity::Busy) => {
                    report.busy_passes += 1;
                    on_pass(head);
                }
                Ok(Activity::Idle) => thread::park_timeout(Duration::from_millis(2)),
                Err(_) => report.link_errors += 1,
            }
        }
        tx.thread().unpark();
    });
    report.bytes_in = bytes_in.load(Ordering::Relaxed);
    report.bytes_out = bytes_out.load(Ordering::Relaxed);
    report
}

fn service<D: Device, W: Wait>(
    head: &mut D,
    port: &mut QueuePort<'_, W>,
) -> Result<Activity, LinkError> {
    head.service_io(port)
}
