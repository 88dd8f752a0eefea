//! Test doubles for a serial link: an in-memory [`Loopback`] ring and a seeded [`FaultInjector`].
//!
//! Both implement the `embedded-io` traits, so the host's device layer and the head's firmware can
//! be driven against each other (and against line faults) without hardware, in `no_std` too. A
//! duplex link is two loopbacks, one per direction.

use embedded_io::{ErrorKind, ErrorType, Read, ReadReady, Write, WriteReady};

/// The only error of a [`Loopback`]: a write found the ring full.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum LoopbackError {
    /// No room for even one byte.
    Full,
}

impl LoopbackError {
    /// The `embedded-io` kind ([`ErrorKind::WriteZero`]).
    pub const fn kind(self) -> ErrorKind {
        ErrorKind::WriteZero
    }
}

impl core::fmt::Display for LoopbackError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str("loopback full")
    }
}

impl core::error::Error for LoopbackError {}

impl embedded_io::Error for LoopbackError {
    fn kind(&self) -> ErrorKind {
        LoopbackError::kind(*self)
    }
}

/// A FIFO of `N` bytes: what is written is read back in order.
///
/// Reading an empty ring returns `Ok(0)` (nothing *yet*; more may arrive, as `embedded-io`
/// allows); writing a full ring fails with [`LoopbackError::Full`], a partial write returns the
/// count that fit.
#[derive(Clone, Debug)]
pub struct Loopback<const N: usize> {
    buf: [u8; N],
    start: usize,
    len: usize,
}

impl<const N: usize> Default for Loopback<N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize> Loopback<N> {
    /// An empty ring.
    pub const fn new() -> Self {
        Loopback {
            buf: [0; N],
            start: 0,
            len: 0,
        }
    }

    /// Bytes waiting to be read.
    pub const fn len(&self) -> usize {
        self.len
    }

    /// `true` if nothing waits.
    pub const fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Room left.
    pub const fn free(&self) -> usize {
        N - self.len
    }

    /// Drop everything waiting.
    pub fn clear(&mut self) {
        self.start = 0;
        self.len = 0;
    }

    /// Append one byte; `false` if full.
    pub fn push(&mut self, b: u8) -> bool {
        if self.len >= N {
            return false;
        }
        let at = (self.start + self.len) % N;
        if let Some(slot) = self.buf.get_mut(at) {
            *slot = b;
            self.len += 1;
            true
        } else {
            false
        }
    }

    /// Take the oldest byte.
    pub fn pop(&mut self) -> Option<u8> {
        if self.len == 0 {
            return None;
        }
        let b = *self.buf.get(self.start)?;
        self.start = (self.start + 1) % N;
        self.len -= 1;
        Some(b)
    }
}

impl<const N: usize> ErrorType for Loopback<N> {
    type Error = LoopbackError;
}

impl<const N: usize> Read for Loopback<N> {
    fn read(&mut self, buf: &mut [u8]) -> Result<usize, LoopbackError> {
        let mut n = 0;
        for slot in buf.iter_mut() {
            match self.pop() {
                Some(b) => *slot = b,
                None => break,
            }
            n += 1;
        }
        Ok(n)
    }
}

impl<const N: usize> Write for Loopback<N> {
    fn write(&mut self, buf: &[u8]) -> Result<usize, LoopbackError> {
        if buf.is_empty() {
            return Ok(0);
        }
        let mut n = 0;
        for &b in buf {
            if !self.push(b) {
                break;
            }
            n += 1;
        }
        if n == 0 {
            Err(LoopbackError::Full)
        } else {
            Ok(n)
        }
    }

    fn flush(&mut self) -> Result<(), LoopbackError> {
        Ok(())
    }
}

impl<const N: usize> ReadReady for Loopback<N> {
    fn read_ready(&mut self) -> Result<bool, LoopbackError> {
        Ok(!self.is_empty())
    }
}

impl<const N: usize> WriteReady for Loopback<N> {
    fn write_ready(&mut self) -> Result<bool, LoopbackError> {
        Ok(self.len < N)
    }
}

/// A small, seedable, `no_std` PRNG (Marsaglia's xorshift64*), for fault injection and tests.
/// Not for cryptography.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct XorShift64 {
    state: u64,
}

impl XorShift64 {
    /// A generator from any seed (0 included: the seed is scrambled by SplitMix64 first).
    pub const fn new(seed: u64) -> Self {
        let mut z = seed.wrapping_add(0x9E37_79B9_7F4A_7C15);
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
        XorShift64 {
            state: if z == 0 { 0x2545_F491_4F6C_DD1D } else { z },
        }
    }

    /// The next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        let mut x = self.state;
        x ^= x >> 12;
        x ^= x << 25;
        x ^= x >> 27;
        self.state = x;
        x.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }

    /// The next 32 random bits.
    pub fn next_u32(&mut self) -> u32 {
        (self.next_u64() >> 32) as u32
    }

    /// A number in `0..n` (`0` if `n == 0`).
    pub fn below(&mut self, n: u32) -> u32 {
        if n == 0 {
            0
        } else {
            ((self.next_u32() as u64 * n as u64) >> 32) as u32
        }
    }

    /// `true` with probability `ppm` per million.
    pub fn chance(&mut self, ppm: u32) -> bool {
        self.below(1_000_000) < ppm
    }
}

/// Fault rates of a [`FaultInjector`], per written byte, in parts per million.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct FaultConfig {
    /// The byte is lost.
    pub drop_ppm: u32,
    /// The byte is XORed with a random non-zero value.
    pub corrupt_ppm: u32,
    /// The byte is sent twice.
    pub duplicate_ppm: u32,
    /// The line goes dead: this byte and up to `max_cut_len - 1` more are lost.
    pub cut_ppm: u32,
    /// Longest cut, bytes (at least 1 is used).
    pub max_cut_len: u32,
}

impl FaultConfig {
    /// A perfect line.
    pub const NONE: FaultConfig = FaultConfig {
        drop_ppm: 0,
        corrupt_ppm: 0,
        duplicate_ppm: 0,
        cut_ppm: 0,
        max_cut_len: 0,
    };
}

/// What a [`FaultInjector`] has done so far.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct FaultStats {
    /// Bytes offered by the writer.
    pub bytes: u64,
    /// Bytes dropped (not counting cuts).
    pub dropped: u64,
    /// Bytes corrupted.
    pub corrupted: u64,
    /// Bytes duplicated.
    pub duplicated: u64,
    /// Cuts started.
    pub cuts: u64,
    /// Bytes lost in cuts (and while disconnected).
    pub cut_bytes: u64,
}

impl FaultStats {
    /// Number of fault events of any kind.
    pub const fn faults(&self) -> u64 {
        self.dropped + self.corrupted + self.duplicated + self.cuts
    }
}

/// Wraps a link and damages what is written through it, reproducibly from a seed. Reads pass
/// through untouched (wrap the other direction's link to damage replies).
///
/// Per written byte, in order: while a cut lasts (or [`set_connected`](Self::set_connected) is
/// `false`) the byte is lost; else a new cut may start (the byte is lost); else it may be dropped;
/// else it may be corrupted, then it may be duplicated. Lost bytes count as written, as on a real
/// cable.
#[derive(Clone, Debug)]
pub struct FaultInjector<L> {
    inner: L,
    rng: XorShift64,
    config: FaultConfig,
    stats: FaultStats,
    cut_left: u32,
    connected: bool,
}

impl<L> FaultInjector<L> {
    /// Wrap `inner`, with faults drawn from `seed`.
    pub const fn new(inner: L, config: FaultConfig, seed: u64) -> Self {
        FaultInjector {
            inner,
            rng: XorShift64::new(seed),
            config,
            stats: FaultStats {
                bytes: 0,
                dropped: 0,
                corrupted: 0,
                duplicated: 0,
                cuts: 0,
                cut_bytes: 0,
            },
            cut_left: 0,
            connected: true,
        }
    }

    /// The wrapped link.
    pub const fn inner(&self) -> &L {
        &self.inner
    }

    /// The wrapped link, mutably (to read what got through, for example).
    pub fn inner_mut(&mut self) -> &mut L {
        &mut self.inner
    }

    /// Unwrap.
    pub fn into_inner(self) -> L {
        self.inner
    }

    /// The faults so far.
    pub const fn stats(&self) -> &FaultStats {
        &self.stats
    }

    /// Change the fault rates.
    pub fn set_config(&mut self, config: FaultConfig) {
        self.config = config;
    }

    /// Cut (`false`) or restore (`true`) the line; while cut every written byte is lost.
    pub fn set_connected(&mut self, connected: bool) {
        self.connected = connected;
    }

    /// Decide the fate of one byte: `None` lost, else the byte and whether to send it twice.
    fn fate(&mut self, b: u8) -> Option<(u8, bool)> {
        let c = self.config;
        self.stats.bytes += 1;
        if !self.connected || self.cut_left > 0 {
            self.cut_left = self.cut_left.saturating_sub(1);
            self.stats.cut_bytes += 1;
            return None;
        }
        if c.cut_ppm > 0 && self.rng.chance(c.cut_ppm) {
            self.stats.cuts += 1;
            self.stats.cut_bytes += 1;
            self.cut_left = self.rng.below(c.max_cut_len.max(1));
            return None;
        }
        if c.drop_ppm > 0 && self.rng.chance(c.drop_ppm) {
            self.stats.dropped += 1;
            return None;
        }
        let mut b = b;
        if c.corrupt_ppm > 0 && self.rng.chance(c.corrupt_ppm) {
            self.stats.corrupted += 1;
            b ^= 1 + self.rng.below(255) as u8;
        }
        let dup = c.duplicate_ppm > 0 && self.rng.chance(c.duplicate_ppm);
        if dup {
            self.stats.duplicated += 1;
        }
        Some((b, dup))
    }
}

impl<L: ErrorType> ErrorType for FaultInjector<L> {
    type Error = L::Error;
}

impl<L: Read> Read for FaultInjector<L> {
    fn read(&mut self, buf: &mut [u8]) -> Result<usize, L::Error> {
        self.inner.read(buf)
    }
}

impl<L: ReadReady> ReadReady for FaultInjector<L> {
    fn read_ready(&mut self) -> Result<bool, L::Error> {
        self.inner.read_ready()
    }
}

impl<L: Write> Write for FaultInjector<L> {
    /// Writes byte by byte through the fault model. If the inner link refuses a byte, returns the
    /// count so far (or the inner error if that is zero); the refused byte's fate is drawn again
    /// when it is offered again (its first draw stays in the fault counters, not in `bytes`).
    fn write(&mut self, buf: &[u8]) -> Result<usize, L::Error> {
        let mut n = 0;
        for &b in buf {
            if let Some((b, dup)) = self.fate(b) {
                if let Err(e) = self.inner.write(&[b]) {
                    self.stats.bytes -= 1;
                    return if n == 0 { Err(e) } else { Ok(n) };
                }
                if dup {
                    // A duplicate that does not fit is simply lost.
                    let _ = self.inner.write(&[b]);
                }
            }
            n += 1;
        }
        Ok(n)
    }

    fn flush(&mut self) -> Result<(), L::Error> {
        self.inner.flush()
    }
}
