//! Frames over a [`Transport`]: the core's `wire` emitters and stream decoder (the code the head
//! runs), sequence numbers and scan identities, receiving with a deadline, and counters.
//!
//! Sequence numbers and scan identities start, for every link, from a value drawn from the
//! time, the process id and a per-process link counter: a new process (or a new connection in
//! the same process) does not reuse the numbers of the last one, so answers still in flight
//! from an earlier session are not taken for answers to this one (issue #21 item 1).

use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, OnceLock};
use std::time::{Instant, SystemTime, UNIX_EPOCH};

use embedded_io::{Error as _, ErrorKind};
use fringe3d_core::wire::{
    FrameReceiver, Header, MAX_ENCODED_FRAME, MAX_FRAME, Message, emit_packet,
};

use super::{DeviceError, Transport};

/// What the link has done.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct LinkStats {
    /// Bytes written (framing included).
    pub bytes_sent: u64,
    /// Bytes read.
    pub bytes_received: u64,
    /// Frames sent.
    pub frames_sent: u64,
    /// Intact frames received.
    pub frames_received: u64,
    /// Damaged frames dropped (COBS, CRC, runt, overflow).
    pub bad_frames: u64,
    /// Waits that ended at their deadline.
    pub timeouts: u64,
    /// Requests sent again.
    pub retries: u64,
    /// Negative acknowledgements received.
    pub naks: u64,
}

/// Frames over a transport.
pub struct Link<T> {
    io: T,
    rx: FrameReceiver<Box<[u8]>>,
    buf: Box<[u8]>,
    pos: usize,
    len: usize,
    seq: u8,
    scan_id: u32,
    interrupt: Option<Arc<AtomicBool>>,
    scratch: Box<[u8]>,
    out: Box<[u8]>,
    stats: LinkStats,
}

/// SplitMix64's finaliser: a well-mixed 64-bit value from any input.
fn mix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE5_E9B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// A fresh starting point for a link's numbers: the process's seed (time and process id, drawn
/// once) mixed with a per-process count of links.
fn link_seed() -> u64 {
    static SEED: OnceLock<u64> = OnceLock::new();
    static LINKS: AtomicU64 = AtomicU64::new(0);
    let seed = *SEED.get_or_init(|| {
        let t = SystemTime::now()
            .duration_since(UNIX_EPOCH)
            .map(|d| d.as_nanos() as u64)
            .unwrap_or(0);
        mix(t ^ (u64::from(std::process::id()) << 32))
    });
    mix(seed ^ LINKS.fetch_add(1, Ordering::Relaxed))
}

/// How long a write may make no progress before the device counts as gone.
pub const WRITE_STALL: std::time::Duration = std::time::Duration::from_secs(5);

fn stalled(what: &str) -> DeviceError {
    DeviceError::Disconnected {
        what: what.to_string(),
        message: format!("the device stopped reading for {} s", WRITE_STALL.as_secs()),
    }
}

fn gone<E: embedded_io::Error>(what: &str, e: E) -> DeviceError {
    let message = match e.kind() {
        ErrorKind::BrokenPipe
        | ErrorKind::NotConnected
        | ErrorKind::ConnectionReset
        | ErrorKind::ConnectionAborted => {
            "the port hung up (cable pulled, or the device reset)".to_string()
        }
        ErrorKind::NotFound => "the port is gone".to_string(),
        k => format!("port error ({k:?})"),
    };
    DeviceError::Disconnected {
        what: what.to_string(),
        message,
    }
}

impl<T: Transport> Link<T> {
    /// A link over `io`.
    pub fn new(io: T) -> Self {
        let start = link_seed();
        Link {
            io,
            rx: FrameReceiver::new(vec![0u8; MAX_ENCODED_FRAME].into_boxed_slice()),
            buf: vec![0u8; 4096].into_boxed_slice(),
            pos: 0,
            len: 0,
            seq: start as u8,
            scan_id: (start >> 32) as u32,
            interrupt: None,
            scratch: vec![0u8; MAX_FRAME].into_boxed_slice(),
            out: vec![0u8; MAX_ENCODED_FRAME].into_boxed_slice(),
            stats: LinkStats::default(),
        }
    }

    /// The transport.
    pub fn transport(&self) -> &T {
        &self.io
    }

    /// The transport, mutably.
    pub fn transport_mut(&mut self) -> &mut T {
        &mut self.io
    }

    /// Unwrap.
    pub fn into_transport(self) -> T {
        self.io
    }

    /// The counters.
    pub fn stats(&self) -> &LinkStats {
        &self.stats
    }

    /// The counters, mutably (the client counts retries and naks here).
    pub fn stats_mut(&mut self) -> &mut LinkStats {
        &mut self.stats
    }

    /// Check `flag` while waiting for frames: once it is set, [`Link::recv`] fails with
    /// [`DeviceError::Interrupted`] (`None`: never). Returns the flag checked before.
    pub fn set_interrupt(&mut self, flag: Option<Arc<AtomicBool>>) -> Option<Arc<AtomicBool>> {
        std::mem::replace(&mut self.interrupt, flag)
    }

    /// The next scan identity (for a Scan request; its rows and ScanDone echo it).
    pub fn next_scan_id(&mut self) -> u32 {
        self.scan_id = self.scan_id.wrapping_add(1);
        self.scan_id
    }

    /// The next sequence number.
    pub fn next_seq(&mut self) -> u8 {
        self.seq = self.seq.wrapping_add(1);
        self.seq
    }

    /// Start clean: drop stale input and send a lone delimiter, so that the far decoder drops any
    /// partial frame left by an earlier session.
    pub fn resync(&mut self, what: &str) -> Result<(), DeviceError> {
        self.io.clear_input();
        self.pos = 0;
        self.len = 0;
        self.rx.reset();
        self.write(what, &[0])
    }

    /// Write all of `bytes`. A port that accepts nothing for [`WRITE_STALL`] (its reader stopped)
    /// counts as gone; short waits (a full transmit buffer) are normal.
    fn write(&mut self, what: &str, bytes: &[u8]) -> Result<(), DeviceError> {
        let deadline = Instant::now() + WRITE_STALL;
        let mut at = 0;
        while at < bytes.len() {
            match self.io.write(&bytes[at..]) {
                Ok(0) => {
                    if !self.io.wait(deadline) {
                        return Err(stalled(what));
                    }
                }
                Ok(n) => at += n,
                Err(e) if matches!(e.kind(), ErrorKind::TimedOut | ErrorKind::Interrupted) => {
                    if Instant::now() >= deadline {
                        return Err(stalled(what));
                    }
                }
                Err(e) => return Err(gone(what, e)),
            }
        }
        self.stats.bytes_sent += bytes.len() as u64;
        Ok(())
    }

    /// Emit one frame: `header` (its payload length is computed) and `msg`. Returns the bytes put
    /// on the line.
    pub fn send(
        &mut self,
        what: &str,
        header: &Header,
        msg: &Message<'_>,
    ) -> Result<usize, DeviceError> {
        let n = emit_packet(header, msg, &mut self.scratch, &mut self.out)
            .map_err(|e| DeviceError::Input(format!("cannot encode {what}: {e}")))?;
        let out = std::mem::take(&mut self.out);
        let r = self.write(what, &out[..n]);
        self.out = out;
        r?;
        self.stats.frames_sent += 1;
        Ok(n)
    }

    /// The next intact frame (decoded, CRC checked, not yet parsed), or `None` if none arrived
    /// before `deadline`. Damaged frames are counted and skipped.
    pub fn recv(&mut self, what: &str, deadline: Instant) -> Result<Option<Vec<u8>>, DeviceError> {
        loop {
            if self
                .interrupt
                .as_ref()
                .is_some_and(|f| f.load(Ordering::SeqCst))
            {
                return Err(DeviceError::Interrupted {
                    what: what.to_string(),
                    note: String::new(),
                });
            }
            while self.pos < self.len {
                let (used, event) = self.rx.feed(&self.buf[self.pos..self.len]);
                self.pos += used;
                match event {
                    Some(Ok(f)) => {
                        self.stats.frames_received += 1;
                        return Ok(Some(f.to_vec()));
                    }
                    Some(Err(_)) => self.stats.bad_frames += 1,
                    None => {}
                }
            }
            match self.io.read(&mut self.buf) {
                Ok(0) => {
                    if !self.io.wait(deadline) {
                        self.stats.timeouts += 1;
                        return Ok(None);
                    }
                }
                Ok(n) => {
                    self.pos = 0;
                    self.len = n;
                    self.stats.bytes_received += n as u64;
                }
                Err(e) if matches!(e.kind(), ErrorKind::TimedOut | ErrorKind::Interrupted) => {
                    if !self.io.wait(deadline) {
                        self.stats.timeouts += 1;
                        return Ok(None);
                    }
                }
                Err(e) => return Err(gone(what, e)),
            }
        }
    }
}
