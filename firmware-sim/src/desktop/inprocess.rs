//! A host ↔ head link inside one thread, with seeded line faults both ways and virtual time.
//!
//! The host's link writes into the head's inbox through a [`FaultInjector`]; the head's answers
//! come back through another. Whenever the host finds nothing to read, the head gets one
//! [`Head::service`](crate::Head::service) pass; when that pass does nothing, nothing more can
//! arrive and the host's wait ends at once (virtual time), so thousands of lost frames cost no
//! real waiting and every run is reproducible from its seeds. The injector's cuts last a number
//! of bytes; so that a cut also ends with time, each timeout lets the line time it stands for
//! pass (idle delimiters through the injectors until one arrives).

use std::prelude::rust_2024::*;

use std::collections::VecDeque;
use std::time::Instant;

use embedded_io::{ErrorType, Read, ReadReady, Write};
use fringe3d::device::Transport;
use fringe3d_core::wire::{FaultConfig, FaultInjector, FaultStats};

use crate::hal::BoardIo;
use crate::head::{Activity, Head, LinkError};

/// An unbounded byte FIFO (`embedded-io` writer).
#[derive(Clone, Debug, Default)]
pub struct VecSink(pub VecDeque<u8>);

impl ErrorType for VecSink {
    type Error = core::convert::Infallible;
}

impl Write for VecSink {
    fn write(&mut self, buf: &[u8]) -> Result<usize, core::convert::Infallible> {
        self.0.extend(buf);
        Ok(buf.len())
    }

    fn flush(&mut self) -> Result<(), core::convert::Infallible> {
        Ok(())
    }
}

/// The head's side of an [`InProcess`] link: reads the inbox, writes through the fault injector.
pub struct HeadPort<'a> {
    inbox: &'a mut VecDeque<u8>,
    out: &'a mut FaultInjector<VecSink>,
}

impl ErrorType for HeadPort<'_> {
    type Error = core::convert::Infallible;
}

impl Read for HeadPort<'_> {
    fn read(&mut self, buf: &mut [u8]) -> Result<usize, core::convert::Infallible> {
        let n = buf.len().min(self.inbox.len());
        for (d, b) in buf.iter_mut().zip(self.inbox.drain(..n)) {
            *d = b;
        }
        Ok(n)
    }
}

impl ReadReady for HeadPort<'_> {
    fn read_ready(&mut self) -> Result<bool, core::convert::Infallible> {
        Ok(!self.inbox.is_empty())
    }
}

impl Write for HeadPort<'_> {
    fn write(&mut self, buf: &[u8]) -> Result<usize, core::convert::Infallible> {
        self.out.write(buf)
    }

    fn flush(&mut self) -> Result<(), core::convert::Infallible> {
        Ok(())
    }
}

/// Anything with a main loop over an `embedded-io` port: a [`Head`] on any board.
pub trait Device {
    /// One main-loop pass ([`Head::service`]).
    fn service_io<T: Read + ReadReady + Write>(
        &mut self,
        io: &mut T,
    ) -> Result<Activity, LinkError>;
}

impl<B: BoardIo> Device for Head<'_, B> {
    fn service_io<T: Read + ReadReady + Write>(
        &mut self,
        io: &mut T,
    ) -> Result<Activity, LinkError> {
        self.service(io)
    }
}

/// The host's end of an in-process link to `device`.
pub struct InProcess<D> {
    /// The head.
    pub device: D,
    to_head: FaultInjector<VecSink>,
    to_host: FaultInjector<VecSink>,
    cut_at: Option<u64>,
}

impl<D: Device> InProcess<D> {
    /// A link with faults `up` (host → head) and `down` (head → host), drawn from `seed`.
    pub fn new(device: D, up: FaultConfig, down: FaultConfig, seed: u64) -> Self {
        InProcess {
            device,
            to_head: FaultInjector::new(VecSink::default(), up, seed),
            to_host: FaultInjector::new(VecSink::default(), down, seed ^ 0x9E37_79B9_7F4A_7C15),
            cut_at: None,
        }
    }

    /// Unplug (both directions) once the host has written `host_bytes` bytes in all.
    pub fn cut_after(&mut self, host_bytes: u64) {
        self.cut_at = Some(host_bytes);
    }

    /// Cut (`false`) or restore both directions.
    pub fn set_connected(&mut self, on: bool) {
        if on {
            self.cut_at = None;
        }
        self.to_head.set_connected(on);
        self.to_host.set_connected(on);
    }

    /// Change the fault rates.
    pub fn set_faults(&mut self, up: FaultConfig, down: FaultConfig) {
        self.to_head.set_config(up);
        self.to_host.set_config(down);
    }

    /// Faults injected so far: (host → head, head → host).
    pub fn fault_stats(&self) -> (FaultStats, FaultStats) {
        (*self.to_head.stats(), *self.to_host.stats())
    }

    /// Give the head one pass; `true` if it did or sent something.
    pub fn step(&mut self) -> bool {
        let before = self.to_host.stats().bytes;
        let mut port = HeadPort {
            inbox: &mut self.to_head.inner_mut().0,
            out: &mut self.to_host,
        };
        let act = self.device.service_io(&mut port);
        matches!(act, Ok(Activity::Busy)) || self.to_host.stats().bytes != before
    }
}

impl<D> ErrorType for InProcess<D> {
    type Error = core::convert::Infallible;
}

impl<D: Device> Read for InProcess<D> {
    fn read(&mut self, buf: &mut [u8]) -> Result<usize, core::convert::Infallible> {
        if self.to_host.inner().0.is_empty() {
            self.step();
        }
        let q = &mut self.to_host.inner_mut().0;
        let n = buf.len().min(q.len());
        for (d, b) in buf.iter_mut().zip(q.drain(..n)) {
            *d = b;
        }
        Ok(n)
    }
}

impl<D: Device> Write for InProcess<D> {
    fn write(&mut self, buf: &[u8]) -> Result<usize, core::convert::Infallible> {
        if let Some(limit) = self.cut_at {
            let done = self.to_head.stats().bytes;
            if done + buf.len() as u64 > limit {
                let keep = limit.saturating_sub(done) as usize;
                self.to_head.write_all(&buf[..keep])?;
                self.to_head.set_connected(false);
                self.to_host.set_connected(false);
            }
        }
        self.to_head.write(buf)
    }

    fn flush(&mut self) -> Result<(), core::convert::Infallible> {
        Ok(())
    }
}

/// Line time of one host timeout, in bytes (200 ms at 921600 baud).
const TIMEOUT_LINE_BYTES: u32 = 18_432;

/// Let line time pass on a faulty line: idle delimiters go through `inj` until one arrives (a
/// cut ends with time, not only with bytes), at most `max`. A receiver's inter-byte timeout then
/// ends any partial frame.
fn age(inj: &mut FaultInjector<VecSink>, max: u32) {
    for _ in 0..max {
        let before = inj.inner().0.len();
        let _ = inj.write(&[0]);
        let q = &mut inj.inner_mut().0;
        if q.len() > before {
            if q.back() != Some(&0) {
                q.push_back(0);
            }
            return;
        }
    }
}

impl<D: Device> Transport for InProcess<D> {
    fn wait(&mut self, deadline: Instant) -> bool {
        // Virtual time: the wait ends as soon as the head has nothing more to do (a head that
        // keeps busy, e.g. a repeating sequence, is bounded by the real deadline). A wait that
        // ends is a timeout: the line time it stands for passes on both directions.
        let more = (self.step() || !self.to_host.inner().0.is_empty()) && Instant::now() < deadline;
        if !more && self.cut_at.is_none() {
            age(&mut self.to_head, TIMEOUT_LINE_BYTES);
            age(&mut self.to_host, TIMEOUT_LINE_BYTES);
        }
        more
    }
}
