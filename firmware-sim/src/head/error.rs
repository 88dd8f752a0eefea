//! What can go wrong: building a head ([`HeadError`]), its serial link ([`LinkError`]), and a
//! scan or sequence entry on the way (`ScanFail`), with the status bit of each hardware fault.

use fringe3d_core::wire::{HeadErrors, WireError};

use crate::hal::HwError;

/// Why a head could not be built.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum HeadError {
    /// A line buffer of [`HeadMemory`](crate::memory::HeadMemory) is shorter than the camera or
    /// projector width needs.
    LineBuffers,
    /// The camera or projector has a zero dimension.
    Dimensions,
    /// A [`HeadConfig`](super::HeadConfig) value is out of range.
    Config,
}

impl HeadError {
    /// The error's class (the enum is its own kind).
    pub const fn kind(self) -> HeadError {
        self
    }
}

impl core::fmt::Display for HeadError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            HeadError::LineBuffers => "a line buffer is shorter than the sensor or projector width",
            HeadError::Dimensions => "the camera or projector has a zero dimension",
            HeadError::Config => "a head configuration value is out of range",
        })
    }
}

/// Why [`Head::service`](super::Head::service) stopped: the serial port failed (the board
/// decides what to do; the head keeps its state and can be serviced again).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LinkError {
    /// Reading or writing the port failed.
    Io(embedded_io::ErrorKind),
    /// A frame could not be emitted (a bug: every reply is validated before it is sent).
    Wire(WireError),
}

impl LinkError {
    /// The error's class (the enum is its own kind).
    pub const fn kind(self) -> LinkError {
        self
    }
}

impl core::fmt::Display for LinkError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            LinkError::Io(k) => write!(f, "serial port: {k:?}"),
            LinkError::Wire(e) => write!(f, "cannot emit a frame: {e}"),
        }
    }
}

/// A port error as a [`LinkError`].
pub(super) fn io_err<E: embedded_io::Error>(e: E) -> LinkError {
    LinkError::Io(e.kind())
}

/// Why a scan (or a sequence entry) failed.
pub(super) enum ScanFail {
    /// A peripheral failed: the head goes to Fault.
    Hw(HwError),
    /// A state the checks before the scan should have excluded.
    Internal,
    /// The serial port failed.
    Link(LinkError),
}

impl From<HwError> for ScanFail {
    fn from(e: HwError) -> Self {
        ScanFail::Hw(e)
    }
}

impl From<LinkError> for ScanFail {
    fn from(e: LinkError) -> Self {
        ScanFail::Link(e)
    }
}

/// The Status error bit of a hardware fault.
pub(super) fn hw_bit(e: HwError) -> u32 {
    match e {
        HwError::Timeout => HeadErrors::TRIGGER_TIMEOUT,
        HwError::Camera => HeadErrors::CAMERA,
        HwError::Projector | HwError::Pin => HeadErrors::PROJECTOR,
        HwError::Storage => HeadErrors::MEMORY,
    }
}
