//! The serial port as the main loop sees it: two `heapless` single-producer single-consumer
//! queues between the UART interrupts and the main loop.
//!
//! The receive interrupt enqueues each byte it reads into the RX queue; the transmit interrupt
//! dequeues bytes from the TX queue into the UART. The main loop holds the other ends, wrapped in
//! a [`QueuePort`] that implements the `embedded-io` traits the head is written against. On the
//! desktop the "interrupts" are two threads moving bytes between the queues and a PTY.
//!
//! A transmitter that makes no progress (the host stopped reading, and the line applies back
//! pressure, as a PTY or USB CDC does) is given up on when the [`Wait`] says so: the write fails
//! with [`PortError::Stalled`], and the head ends what it was sending (a scan ends, the head leaves Scanning)
//! instead of waiting for good (issue #21 item 10).

use embedded_io::{ErrorType, Read, ReadReady, Write, WriteReady};
use heapless::spsc::{Consumer, Producer};

/// Bytes the UART queues hold (each way).
pub const QUEUE_LEN: usize = 8192;

/// The queue type between an interrupt and the main loop.
pub type ByteQueue = heapless::spsc::Queue<u8, QUEUE_LEN>;

/// What the main loop does while it waits on a queue.
pub trait Wait {
    /// The RX queue is empty and a read must block: wait a little.
    fn rx_empty(&mut self);
    /// The TX queue is full: wait for the transmit interrupt to drain it. `false` gives up: the
    /// transmitter has made no progress for too long, and the write fails
    /// ([`PortError::Stalled`]).
    fn tx_full(&mut self) -> bool;
    /// Bytes were put into the TX queue (wake the transmitter).
    fn tx_written(&mut self) {}
}

/// Busy-waiting, for bare metal (the interrupts make progress meanwhile).
#[derive(Clone, Copy, Debug, Default)]
pub struct Spin;

impl Wait for Spin {
    fn rx_empty(&mut self) {
        core::hint::spin_loop();
    }

    fn tx_full(&mut self) -> bool {
        core::hint::spin_loop();
        true
    }
}

/// Why a [`QueuePort`] write failed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PortError {
    /// The TX queue stayed full for longer than the [`Wait`] allows: nobody reads the line.
    Stalled,
}

impl core::fmt::Display for PortError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str("the transmitter made no progress (nobody reads the line)")
    }
}

impl core::error::Error for PortError {}

impl embedded_io::Error for PortError {
    fn kind(&self) -> embedded_io::ErrorKind {
        embedded_io::ErrorKind::TimedOut
    }
}

/// The main loop's ends of the two UART queues.
pub struct QueuePort<'q, W> {
    rx: Consumer<'q, u8>,
    tx: Producer<'q, u8>,
    wait: W,
}

impl<'q, W: Wait> QueuePort<'q, W> {
    /// A port reading from `rx` and writing to `tx`.
    pub fn new(rx: Consumer<'q, u8>, tx: Producer<'q, u8>, wait: W) -> Self {
        QueuePort { rx, tx, wait }
    }

    /// The waiting strategy.
    pub fn wait(&mut self) -> &mut W {
        &mut self.wait
    }
}

impl<W> ErrorType for QueuePort<'_, W> {
    type Error = PortError;
}

impl<W: Wait> Read for QueuePort<'_, W> {
    fn read(&mut self, buf: &mut [u8]) -> Result<usize, PortError> {
        if buf.is_empty() {
            return Ok(0);
        }
        loop {
            let mut n = 0;
            while n < buf.len() {
                match self.rx.dequeue() {
                    Some(b) => {
                        buf[n] = b;
                        n += 1;
                    }
                    None => break,
                }
            }
            if n > 0 {
                return Ok(n);
            }
            self.wait.rx_empty();
        }
    }
}

impl<W: Wait> ReadReady for QueuePort<'_, W> {
    fn read_ready(&mut self) -> Result<bool, PortError> {
        Ok(self.rx.ready())
    }
}

impl<W: Wait> Write for QueuePort<'_, W> {
    fn write(&mut self, buf: &[u8]) -> Result<usize, PortError> {
        if buf.is_empty() {
            return Ok(0);
        }
        loop {
            let mut n = 0;
            for &b in buf {
                if self.tx.enqueue(b).is_err() {
                    break;
                }
                n += 1;
            }
            if n > 0 {
                self.wait.tx_written();
                return Ok(n);
            }
            if !self.wait.tx_full() {
                return Err(PortError::Stalled);
            }
        }
    }

    fn flush(&mut self) -> Result<(), PortError> {
        self.wait.tx_written();
        Ok(())
    }
}

impl<W: Wait> WriteReady for QueuePort<'_, W> {
    fn write_ready(&mut self) -> Result<bool, PortError> {
        Ok(self.tx.ready())
    }
}
