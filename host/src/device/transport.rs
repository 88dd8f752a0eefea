//! What the link runs over: an `embedded-io` byte stream that can also wait.

use std::time::{Duration, Instant};

use embedded_io_adapters::std::FromStd;
use serialport::{ClearBuffer, SerialPort};

use super::DeviceError;

/// A duplex byte stream for the link: `embedded-io` `Read + Write` (the same traits the head's
/// firmware uses), plus waiting.
///
/// A read that finds nothing returns `Ok(0)` or an error of kind `TimedOut` (a serial port
/// blocks for its own short timeout first); the link then asks [`Transport::wait`] whether more
/// may still arrive before its deadline. Any other read or write error means the line is gone.
pub trait Transport: embedded_io::Read + embedded_io::Write {
    /// Nothing was readable: wait a little for more. `false` when nothing can arrive before
    /// `deadline` (the link times out).
    fn wait(&mut self, deadline: Instant) -> bool {
        Instant::now() < deadline
    }

    /// Drop bytes received but not yet read (stale answers of an earlier session).
    fn clear_input(&mut self) {}

    /// The line's rate in bytes per second, for timeouts (`None`: fast, e.g. a PTY or USB).
    fn bytes_per_second(&self) -> Option<f64> {
        None
    }
}

/// A serial port (or PTY) through `serialport`, as an `embedded-io` stream.
pub struct SerialTransport {
    port: FromStd<Box<dyn SerialPort>>,
    baud: u32,
}

/// How long one read blocks before the link looks at its deadline.
const POLL: Duration = Duration::from_millis(20);

/// Open `path` at `baud` baud, 8N1, no flow control.
pub fn open_serial(path: &str, baud: u32) -> Result<SerialTransport, DeviceError> {
    let mut waited = Duration::ZERO;
    let port = loop {
        match serialport::new(path, baud).timeout(POLL).open() {
            Ok(port) => break port,
            // Another descriptor still holds the port's lock: a connection that is closing
            // (this process's last one, a program letting go). Wait up to LOCK_WAIT before
            // calling the port busy.
            Err(e) if is_locked(&e) && waited < LOCK_WAIT => {
                std::thread::sleep(LOCK_POLL);
                waited += LOCK_POLL;
            }
            Err(e) => {
                return Err(DeviceError::Open {
                    path: path.to_string(),
                    message: e.to_string(),
                });
            }
        }
    };
    Ok(SerialTransport {
        port: FromStd::new(port),
        baud,
    })
}

impl SerialTransport {
    /// A transport over a port opened elsewhere (e.g. one end of `serialport::TTYPort::pair`).
    pub fn from_port(port: Box<dyn SerialPort>, baud: u32) -> Self {
        SerialTransport {
            port: FromStd::new(port),
            baud,
        }
    }

    /// The nominal baud rate.
    pub fn baud(&self) -> u32 {
        self.baud
    }
}

impl embedded_io::ErrorType for SerialTransport {
    type Error = std::io::Error;
}

impl embedded_io::Read for SerialTransport {
    fn read(&mut self, buf: &mut [u8]) -> Result<usize, std::io::Error> {
        self.port.read(buf)
    }
}

impl embedded_io::Write for SerialTransport {
    fn write(&mut self, buf: &[u8]) -> Result<usize, std::io::Error> {
        self.port.write(buf)
    }

    fn flush(&mut self) -> Result<(), std::io::Error> {
        Ok(())
    }
}

impl Transport for SerialTransport {
    fn clear_input(&mut self) {
        let _ = self.port.inner().clear(ClearBuffer::Input);
    }

    fn bytes_per_second(&self) -> Option<f64> {
        // 8N1: ten bits on the line per byte.
        Some(self.baud as f64 / 10.0)
    }
}

/// How long [`open_serial`] waits for a port whose lock another descriptor holds.
const LOCK_WAIT: Duration = Duration::from_millis(500);
/// How often it tries again meanwhile.
const LOCK_POLL: Duration = Duration::from_millis(20);

/// The port is open elsewhere with its advisory lock (serialport's `flock`, EWOULDBLOCK).
fn is_locked(e: &serialport::Error) -> bool {
    e.kind == serialport::ErrorKind::NoDevice && e.description.contains("exclusive lock")
}
