//! What the head needs from its board: a projector, a camera, two stores for uploaded data, the
//! trigger lines and a delay.
//!
//! The trigger lines are `embedded-hal` 1.0 digital pins and exposure timing goes through
//! [`DelayNs`], so a board support crate plugs in its GPIO and timer drivers unchanged; the
//! simulated board ([`crate::sim`]) implements the same traits and records what happens on them.
//! Projector, camera and storage are small traits of this crate: on real hardware they wrap the
//! projector controller's video port, the sensor's readout and external RAM or flash.
//! [`BoardIo`] gathers them: the firmware is generic over that one trait.

use embedded_hal::delay::DelayNs;
use embedded_hal::digital::{InputPin, OutputPin};

/// A hardware fault. Small and `Copy`, like every error of the firmware.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum HwError {
    /// A trigger pin could not be driven or read.
    Pin,
    /// The projector refused a frame or row.
    Projector,
    /// The camera failed to deliver a row.
    Camera,
    /// A store access was out of range or failed.
    Storage,
    /// A trigger input did not arrive in time.
    Timeout,
}

impl HwError {
    /// The error's class (the enum is its own kind: every variant names one peripheral).
    pub const fn kind(self) -> HwError {
        self
    }

    /// A short lowercase name.
    pub const fn name(self) -> &'static str {
        match self {
            HwError::Pin => "pin",
            HwError::Projector => "projector",
            HwError::Camera => "camera",
            HwError::Storage => "storage",
            HwError::Timeout => "trigger-timeout",
        }
    }
}

impl core::fmt::Display for HwError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(self.name())
    }
}

/// The projector's video input: the head sends a pattern row by row, then triggers its display
/// with the projector trigger line.
pub trait Projector {
    /// Pattern width, pixels.
    fn width(&self) -> u16;
    /// Pattern height, pixels.
    fn height(&self) -> u16;
    /// Start loading pattern `pattern` (index in its set, for the record).
    fn begin_frame(&mut self, pattern: u16) -> Result<(), HwError>;
    /// Row `y` of the pattern being loaded (`width` bytes, one per pixel).
    fn write_row(&mut self, y: u16, row: &[u8]) -> Result<(), HwError>;
    /// The pattern is complete; it shows while the projector trigger line is high.
    fn end_frame(&mut self) -> Result<(), HwError>;
}

/// The camera's readout: after an exposure (camera trigger pulse) and its ready line, the head
/// reads the frame row by row, top to bottom.
pub trait Camera {
    /// Sensor width, pixels.
    fn width(&self) -> u16;
    /// Sensor height, pixels.
    fn height(&self) -> u16;
    /// Significant bits per sample (8 to 16).
    fn bit_depth(&self) -> u8;
    /// Row `y` of the frame of the last exposure into `out` (`width` samples). Reading the last
    /// row releases the frame.
    fn read_row(&mut self, y: u16, out: &mut [u16]) -> Result<(), HwError>;
}

/// Byte storage for uploads (external RAM or flash on a head).
pub trait Storage {
    /// Size, bytes.
    fn capacity(&self) -> u32;
    /// Write `data` at `offset`.
    fn write(&mut self, offset: u32, data: &[u8]) -> Result<(), HwError>;
    /// Read `out.len()` bytes at `offset`.
    fn read(&mut self, offset: u32, out: &mut [u8]) -> Result<(), HwError>;
}

/// Everything the head drives, as one type: a board names the types of its peripherals once
/// (associated types, like `embedded-io`'s `ErrorType`) and lends each of them out, so that the
/// firmware is generic over a single `B: BoardIo`.
///
/// The head borrows one peripheral at a time (an exposure drives a trigger, then waits on the
/// delay), so each accessor may hand out the same `&mut self`. [`crate::sim::SimBoard`] is the
/// simulated board, used on the desktop and under QEMU.
pub trait BoardIo {
    /// The projector.
    type Projector: Projector;
    /// The camera.
    type Camera: Camera;
    /// The stores of uploaded pattern images and of the reference phase map.
    type Store: Storage;
    /// Output: high while the projector shows the loaded pattern.
    type ProjectorTrigger: OutputPin;
    /// Output: high while the camera exposes.
    type CameraTrigger: OutputPin;
    /// Input: high while the camera holds a frame ready to read.
    type CameraReady: InputPin;
    /// Input: the external trigger, for sequence entries that wait for it.
    type ExternalTrigger: InputPin;
    /// Exposure and dark-time delays.
    type Delay: DelayNs;

    /// The projector.
    fn projector(&mut self) -> &mut Self::Projector;
    /// The camera.
    fn camera(&mut self) -> &mut Self::Camera;
    /// Store of uploaded pattern images.
    fn pattern_store(&mut self) -> &mut Self::Store;
    /// Store of the reference phase map.
    fn map_store(&mut self) -> &mut Self::Store;
    /// The projector trigger line.
    fn projector_trigger(&mut self) -> &mut Self::ProjectorTrigger;
    /// The camera trigger line.
    fn camera_trigger(&mut self) -> &mut Self::CameraTrigger;
    /// The camera-ready line.
    fn camera_ready(&mut self) -> &mut Self::CameraReady;
    /// The external trigger line.
    fn external_trigger(&mut self) -> &mut Self::ExternalTrigger;
    /// The delay.
    fn delay(&mut self) -> &mut Self::Delay;
}

/// A [`Storage`] over a borrowed byte slice (a `static` buffer on a board, or a test's).
pub struct SliceStore<'a> {
    bytes: &'a mut [u8],
}

impl<'a> SliceStore<'a> {
    /// Storage over `bytes`.
    pub fn new(bytes: &'a mut [u8]) -> Self {
        SliceStore { bytes }
    }

    /// The stored bytes.
    pub fn bytes(&self) -> &[u8] {
        self.bytes
    }
}

impl Storage for SliceStore<'_> {
    fn capacity(&self) -> u32 {
        u32::try_from(self.bytes.len()).unwrap_or(u32::MAX)
    }

    fn write(&mut self, offset: u32, data: &[u8]) -> Result<(), HwError> {
        let start = offset as usize;
        let dst = self
            .bytes
            .get_mut(start..start.checked_add(data.len()).ok_or(HwError::Storage)?)
            .ok_or(HwError::Storage)?;
        dst.copy_from_slice(data);
        Ok(())
    }

    fn read(&mut self, offset: u32, out: &mut [u8]) -> Result<(), HwError> {
        let start = offset as usize;
        let src = self
            .bytes
            .get(start..start.checked_add(out.len()).ok_or(HwError::Storage)?)
            .ok_or(HwError::Storage)?;
        out.copy_from_slice(src);
        Ok(())
    }
}
