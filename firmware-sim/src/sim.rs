//! The simulated board: trigger pins, delay, projector and camera around a shared [`SimWorld`]
//! that keeps virtual time and records the trigger timeline.
//!
//! `no_std` like the rest of the firmware (the world is a `RefCell` the peripherals borrow), so
//! the same simulation runs in tests, in the desktop binary and under QEMU.
//!
//! # What the world models
//! - Virtual time advances only through [`SimDelay`] (exposures, dark times, polling waits).
//! - The projector shows the last pattern loaded ([`Projector::end_frame`]) while the projector
//!   trigger is high.
//! - An exposure runs while the camera trigger is high (trigger-width exposure: its length is
//!   the pulse's, which the frame's [`Shot`] carries to the [`FrameSource`]); it captures the
//!   pattern lit when it began if that pattern is still lit when it ends, otherwise nothing (a
//!   blurred frame, which the camera delivers dark). The frame is ready [`SimWorld::readout_ns`] after the exposure ends:
//!   the camera-ready input is high from then until the head has read the frame's last row.
//! - The external trigger input is high when armed ([`SimWorld::set_external_trigger`]).
//!
//! Every pin edge, pattern load, capture and readout is an [`Event`] on the timeline, stamped
//! with virtual time, so tests can check the sequence.
//!
//! [`SimBoard`] gathers the simulated peripherals and two stores into one [`BoardIo`].

use core::cell::RefCell;

use embedded_hal::delay::DelayNs;
use embedded_hal::digital::{ErrorKind, ErrorType, InputPin, OutputPin};
use fringe3d_core::wire::crc::Crc32c;
use heapless::{Deque, HistoryBuf};

use crate::hal::{BoardIo, Camera, HwError, Projector, Storage};

/// Events kept on the timeline (the oldest are dropped first).
pub const TIMELINE_LEN: usize = 1024;

/// Frames the simulated camera can hold before it loses one.
pub const CAMERA_FRAMES: usize = 4;

/// A trigger line.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Line {
    /// Head → projector: show the loaded pattern.
    ProjectorTrigger,
    /// Head → camera: expose.
    CameraTrigger,
    /// Camera → head: a frame is ready (recorded when the head sees it high).
    CameraReady,
    /// External → head (recorded when the head sees it high).
    ExternalTrigger,
}

/// What happened.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum EventKind {
    /// An output line was driven.
    Drive {
        /// The line.
        line: Line,
        /// New level.
        high: bool,
    },
    /// The head read an input line and found it high.
    Sensed {
        /// The line.
        line: Line,
    },
    /// The projector finished loading a pattern.
    PatternLoaded {
        /// Pattern index.
        pattern: u16,
        /// CRC-32C of the pattern's bytes as the projector received them.
        crc: u32,
    },
    /// An exposure ended.
    Captured {
        /// The pattern it captured (`None`: nothing steadily lit).
        pattern: Option<u16>,
        /// How long it lasted (the camera trigger's pulse), ns.
        exposure_ns: u64,
    },
    /// The head read a frame's last row.
    FrameRead {
        /// The pattern of the frame.
        pattern: Option<u16>,
    },
}

/// A timeline entry.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Event {
    /// Virtual time, ns.
    pub t_ns: u64,
    /// What.
    pub kind: EventKind,
}

/// Counters of the world.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct WorldStats {
    /// Events recorded (including dropped ones).
    pub events: u64,
    /// Exposures.
    pub exposures: u32,
    /// Exposures that captured nothing steadily lit.
    pub blurred: u32,
    /// Frames lost because the camera's buffer was full.
    pub lost_frames: u32,
    /// Patterns loaded into the projector.
    pub patterns_loaded: u32,
}

struct World {
    now_ns: u64,
    timeline: HistoryBuf<Event, TIMELINE_LEN>,
    stats: WorldStats,
    loaded: Option<u16>,
    lit: Option<u16>,
    /// The pattern lit when the running exposure began, and when it began.
    exposing: Option<(Option<u16>, u64)>,
    /// Frames taken and not yet read: the shot and when it is ready.
    frames: Deque<(Shot, u64), CAMERA_FRAMES>,
    external: bool,
    readout_ns: u64,
    projector_high: bool,
    camera_high: bool,
}

/// The shared state of the simulated board.
pub struct SimWorld {
    w: RefCell<World>,
}

impl Default for SimWorld {
    fn default() -> Self {
        Self::new(0)
    }
}

impl SimWorld {
    /// A world at time 0 whose camera needs `readout_ns` after an exposure to have its frame
    /// ready; the external trigger is armed.
    pub fn new(readout_ns: u64) -> Self {
        SimWorld {
            w: RefCell::new(World {
                now_ns: 0,
                timeline: HistoryBuf::new(),
                stats: WorldStats::default(),
                loaded: None,
                lit: None,
                exposing: None,
                frames: Deque::new(),
                external: true,
                readout_ns,
                projector_high: false,
                camera_high: false,
            }),
        }
    }

    /// Virtual time now, ns.
    pub fn now_ns(&self) -> u64 {
        self.w.borrow().now_ns
    }

    /// The camera's readout time, ns.
    pub fn readout_ns(&self) -> u64 {
        self.w.borrow().readout_ns
    }

    /// Arm (`true`) or disarm the external trigger input.
    pub fn set_external_trigger(&self, high: bool) {
        self.w.borrow_mut().external = high;
    }

    /// The counters.
    pub fn stats(&self) -> WorldStats {
        self.w.borrow().stats
    }

    /// The recorded events, oldest first, into `f`.
    pub fn for_each_event(&self, mut f: impl FnMut(&Event)) {
        for e in self.w.borrow().timeline.oldest_ordered() {
            f(e);
        }
    }

    /// Forget the recorded events (counters stay).
    pub fn clear_timeline(&self) {
        self.w.borrow_mut().timeline.clear();
    }

    fn record(w: &mut World, kind: EventKind) {
        let t_ns = w.now_ns;
        w.timeline.write(Event { t_ns, kind });
        w.stats.events += 1;
    }

    fn advance(&self, ns: u64) {
        let mut w = self.w.borrow_mut();
        w.now_ns = w.now_ns.saturating_add(ns);
    }

    fn drive(&self, line: Line, high: bool) {
        let mut w = self.w.borrow_mut();
        let w = &mut *w;
        match line {
            Line::ProjectorTrigger => {
                w.projector_high = high;
                w.lit = if high { w.loaded } else { None };
            }
            Line::CameraTrigger => {
                if high && !w.camera_high {
                    w.exposing = Some((w.lit, w.now_ns));
                } else if !high && w.camera_high {
                    let (began, since) = w.exposing.take().unwrap_or((None, w.now_ns));
                    let pattern = if began.is_some() && began == w.lit {
                        began
                    } else {
                        None
                    };
                    let exposure_ns = w.now_ns.saturating_sub(since);
                    let shot = Shot {
                        pattern,
                        exposure_ns,
                    };
                    w.stats.exposures += 1;
                    if pattern.is_none() {
                        w.stats.blurred += 1;
                    }
                    let ready_at = w.now_ns.saturating_add(w.readout_ns);
                    if w.frames.push_back((shot, ready_at)).is_err() {
                        w.stats.lost_frames += 1;
                    }
                    Self::record(w, EventKind::Drive { line, high });
                    Self::record(
                        w,
                        EventKind::Captured {
                            pattern,
                            exposure_ns,
                        },
                    );
                    w.camera_high = high;
                    return;
                }
                w.camera_high = high;
            }
            Line::CameraReady | Line::ExternalTrigger => return,
        }
        Self::record(w, EventKind::Drive { line, high });
    }

    fn sense(&self, line: Line) -> bool {
        let mut w = self.w.borrow_mut();
        let w = &mut *w;
        let high = match line {
            Line::CameraReady => w.frames.front().is_some_and(|f| w.now_ns >= f.1),
            Line::ExternalTrigger => w.external,
            Line::ProjectorTrigger => w.projector_high,
            Line::CameraTrigger => w.camera_high,
        };
        if high && matches!(line, Line::CameraReady | Line::ExternalTrigger) {
            Self::record(w, EventKind::Sensed { line });
        }
        high
    }

    fn load(&self, pattern: u16, crc: u32) {
        let mut w = self.w.borrow_mut();
        w.loaded = Some(pattern);
        w.stats.patterns_loaded += 1;
        Self::record(&mut w, EventKind::PatternLoaded { pattern, crc });
    }

    /// The shot of the oldest unread frame, once it is ready.
    fn frame_shot(&self) -> Option<Shot> {
        let w = self.w.borrow();
        w.frames.front().filter(|f| w.now_ns >= f.1).map(|f| f.0)
    }

    fn release_frame(&self) {
        let mut w = self.w.borrow_mut();
        if let Some((shot, _)) = w.frames.pop_front() {
            Self::record(
                &mut w,
                EventKind::FrameRead {
                    pattern: shot.pattern,
                },
            );
        }
    }
}

/// The error of simulated pins (they cannot fail; the type exists for the traits).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SimPinError {}

impl embedded_hal::digital::Error for SimPinError {
    fn kind(&self) -> ErrorKind {
        match *self {}
    }
}

/// A simulated output line.
pub struct SimOutput<'w> {
    world: &'w SimWorld,
    line: Line,
}

impl<'w> SimOutput<'w> {
    /// The output `line` of `world` (projector or camera trigger).
    pub fn new(world: &'w SimWorld, line: Line) -> Self {
        SimOutput { world, line }
    }
}

impl ErrorType for SimOutput<'_> {
    type Error = SimPinError;
}

impl OutputPin for SimOutput<'_> {
    fn set_low(&mut self) -> Result<(), SimPinError> {
        self.world.drive(self.line, false);
        Ok(())
    }

    fn set_high(&mut self) -> Result<(), SimPinError> {
        self.world.drive(self.line, true);
        Ok(())
    }
}

/// A simulated input line.
pub struct SimInput<'w> {
    world: &'w SimWorld,
    line: Line,
}

impl<'w> SimInput<'w> {
    /// The input `line` of `world` (camera ready or external trigger).
    pub fn new(world: &'w SimWorld, line: Line) -> Self {
        SimInput { world, line }
    }
}

impl ErrorType for SimInput<'_> {
    type Error = SimPinError;
}

impl InputPin for SimInput<'_> {
    fn is_high(&mut self) -> Result<bool, SimPinError> {
        Ok(self.world.sense(self.line))
    }

    fn is_low(&mut self) -> Result<bool, SimPinError> {
        Ok(!self.world.sense(self.line))
    }
}

/// A delay that advances the world's virtual clock (no real waiting).
pub struct SimDelay<'w> {
    world: &'w SimWorld,
}

impl<'w> SimDelay<'w> {
    /// The delay of `world`.
    pub fn new(world: &'w SimWorld) -> Self {
        SimDelay { world }
    }
}

impl DelayNs for SimDelay<'_> {
    fn delay_ns(&mut self, ns: u32) {
        self.world.advance(ns as u64);
    }

    fn delay_us(&mut self, us: u32) {
        self.world.advance(us as u64 * 1_000);
    }

    fn delay_ms(&mut self, ms: u32) {
        self.world.advance(ms as u64 * 1_000_000);
    }
}

/// Receives every row the simulated projector is sent (to record or check patterns).
pub trait RowSink {
    /// Row `y` of pattern `pattern`.
    fn row(&mut self, pattern: u16, y: u16, row: &[u8]);
}

/// A sink that keeps nothing.
#[derive(Clone, Copy, Debug, Default)]
pub struct NoSink;

impl RowSink for NoSink {
    fn row(&mut self, _: u16, _: u16, _: &[u8]) {}
}

/// A simulated projector: checks the rows it is sent, fingerprints each pattern (CRC-32C) and
/// shows it to the world.
pub struct SimProjector<'w, R = NoSink> {
    world: &'w SimWorld,
    width: u16,
    height: u16,
    pattern: Option<u16>,
    next_row: u16,
    crc: Crc32c,
    sink: R,
}

impl<'w, R: RowSink> SimProjector<'w, R> {
    /// A `width × height` projector in `world`, passing rows to `sink`.
    pub fn new(world: &'w SimWorld, width: u16, height: u16, sink: R) -> Self {
        SimProjector {
            world,
            width,
            height,
            pattern: None,
            next_row: 0,
            crc: Crc32c::new(),
            sink,
        }
    }

    /// The sink.
    pub fn sink(&self) -> &R {
        &self.sink
    }

    /// The sink, mutably.
    pub fn sink_mut(&mut self) -> &mut R {
        &mut self.sink
    }
}

impl<R: RowSink> Projector for SimProjector<'_, R> {
    fn width(&self) -> u16 {
        self.width
    }

    fn height(&self) -> u16 {
        self.height
    }

    fn begin_frame(&mut self, pattern: u16) -> Result<(), HwError> {
        self.pattern = Some(pattern);
        self.next_row = 0;
        self.crc = Crc32c::new();
        Ok(())
    }

    fn write_row(&mut self, y: u16, row: &[u8]) -> Result<(), HwError> {
        let p = self.pattern.ok_or(HwError::Projector)?;
        if y != self.next_row || y >= self.height || row.len() != self.width as usize {
            return Err(HwError::Projector);
        }
        self.crc.update(row);
        self.sink.row(p, y, row);
        self.next_row += 1;
        Ok(())
    }

    fn end_frame(&mut self) -> Result<(), HwError> {
        let p = self.pattern.take().ok_or(HwError::Projector)?;
        if self.next_row != self.height {
            return Err(HwError::Projector);
        }
        self.world.load(p, self.crc.finish());
        Ok(())
    }
}

/// One exposure of the simulated camera: what was lit, and for how long.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Shot {
    /// The pattern steadily lit through the exposure (`None`: nothing, a dark frame).
    pub pattern: Option<u16>,
    /// The exposure's length (the camera trigger's pulse), ns.
    pub exposure_ns: u64,
}

impl Shot {
    /// Pattern `pattern` exposed for `exposure_ns`.
    pub const fn new(pattern: Option<u16>, exposure_ns: u64) -> Shot {
        Shot {
            pattern,
            exposure_ns,
        }
    }

    /// Which of the captures made at `exposures_us` (µs each) this shot replays: the one whose
    /// exposure is nearest to the shot's by ratio, `max(t/E, E/t)` (compared exactly, as
    /// fractions), the first on a tie; `None` if there are none. A replayed camera cannot take
    /// what nobody captured, so a shot between two exposures gets the nearer one's images.
    pub fn nearest(&self, exposures_us: impl IntoIterator<Item = u32>) -> Option<usize> {
        let t = u128::from(self.exposure_ns.max(1));
        let off = |us: u32| {
            let e = u128::from(us.max(1)) * 1000;
            (t.max(e), t.min(e))
        };
        let mut best: Option<(usize, (u128, u128))> = None;
        for (i, us) in exposures_us.into_iter().enumerate() {
            let (n, d) = off(us);
            match best {
                Some((_, (bn, bd))) if n * bd >= bn * d => {}
                _ => best = Some((i, (n, d))),
            }
        }
        best.map(|b| b.0)
    }
}

/// A capture's argument `PATH` or `PATH@US` (the exposure it was made at, µs, above 0): the path
/// and the exposure, if given; `Err` for an exposure that is not such a number.
pub fn split_exposure(arg: &str) -> Result<(&str, Option<u32>), &'static str> {
    match arg.rsplit_once('@') {
        None => Ok((arg, None)),
        Some((path, us)) => match us.parse::<u32>() {
            Ok(u) if u > 0 => Ok((path, Some(u))),
            _ => Err("the exposure after @ must be a whole number of µs above 0"),
        },
    }
}

/// Where the simulated camera's pictures come from: the scene under each pattern.
pub trait FrameSource {
    /// Width, pixels.
    fn width(&self) -> u16;
    /// Height, pixels.
    fn height(&self) -> u16;
    /// Significant bits per sample.
    fn bit_depth(&self) -> u8;
    /// Row `y` of the picture `shot` takes: the scene lit by its pattern (`None`: unlit) for
    /// its exposure.
    fn row(&self, shot: Shot, y: u16, out: &mut [u16]) -> Result<(), HwError>;
}

/// A simulated camera: delivers the frame of each exposure from its [`FrameSource`].
pub struct SimCamera<'w, F> {
    world: &'w SimWorld,
    source: F,
}

impl<'w, F: FrameSource> SimCamera<'w, F> {
    /// A camera in `world` seeing `source`.
    pub fn new(world: &'w SimWorld, source: F) -> Self {
        SimCamera { world, source }
    }

    /// The source.
    pub fn source(&self) -> &F {
        &self.source
    }
}

impl<F: FrameSource> Camera for SimCamera<'_, F> {
    fn width(&self) -> u16 {
        self.source.width()
    }

    fn height(&self) -> u16 {
        self.source.height()
    }

    fn bit_depth(&self) -> u8 {
        self.source.bit_depth()
    }

    fn read_row(&mut self, y: u16, out: &mut [u16]) -> Result<(), HwError> {
        let shot = self.world.frame_shot().ok_or(HwError::Camera)?;
        if y >= self.source.height() || out.len() != self.source.width() as usize {
            return Err(HwError::Camera);
        }
        self.source.row(shot, y, out)?;
        if y + 1 == self.source.height() {
            self.world.release_frame();
        }
        Ok(())
    }
}

/// The simulated board: projector, camera, two stores of type `S`, the trigger lines and the
/// delay, all in one [`SimWorld`]. Fields are public so that a board's `main` or a test builds
/// it directly and inspects its parts.
pub struct SimBoard<'w, F, R, S> {
    /// The projector.
    pub projector: SimProjector<'w, R>,
    /// The camera.
    pub camera: SimCamera<'w, F>,
    /// Store of uploaded pattern images.
    pub pattern_store: S,
    /// Store of the reference phase map.
    pub map_store: S,
    /// Output: high while the projector shows the loaded pattern.
    pub projector_trigger: SimOutput<'w>,
    /// Output: high while the camera exposes.
    pub camera_trigger: SimOutput<'w>,
    /// Input: high while the camera holds a frame ready to read.
    pub camera_ready: SimInput<'w>,
    /// Input: the external trigger.
    pub external_trigger: SimInput<'w>,
    /// Exposure and dark-time delays (virtual time).
    pub delay: SimDelay<'w>,
}

impl<'w, F: FrameSource, R: RowSink, S: Storage> SimBoard<'w, F, R, S> {
    /// A board in `world`: a camera seeing `source`, a `projector.0 × projector.1` projector
    /// passing its rows to `sink`, and the two stores.
    pub fn new(
        world: &'w SimWorld,
        source: F,
        sink: R,
        projector: (u16, u16),
        pattern_store: S,
        map_store: S,
    ) -> Self {
        SimBoard {
            projector: SimProjector::new(world, projector.0, projector.1, sink),
            camera: SimCamera::new(world, source),
            pattern_store,
            map_store,
            projector_trigger: SimOutput::new(world, Line::ProjectorTrigger),
            camera_trigger: SimOutput::new(world, Line::CameraTrigger),
            camera_ready: SimInput::new(world, Line::CameraReady),
            external_trigger: SimInput::new(world, Line::ExternalTrigger),
            delay: SimDelay::new(world),
        }
    }
}

impl<'w, F: FrameSource, R: RowSink, S: Storage> BoardIo for SimBoard<'w, F, R, S> {
    type Projector = SimProjector<'w, R>;
    type Camera = SimCamera<'w, F>;
    type Store = S;
    type ProjectorTrigger = SimOutput<'w>;
    type CameraTrigger = SimOutput<'w>;
    type CameraReady = SimInput<'w>;
    type ExternalTrigger = SimInput<'w>;
    type Delay = SimDelay<'w>;

    fn projector(&mut self) -> &mut Self::Projector {
        &mut self.projector
    }

    fn camera(&mut self) -> &mut Self::Camera {
        &mut self.camera
    }

    fn pattern_store(&mut self) -> &mut S {
        &mut self.pattern_store
    }

    fn map_store(&mut self) -> &mut S {
        &mut self.map_store
    }

    fn projector_trigger(&mut self) -> &mut Self::ProjectorTrigger {
        &mut self.projector_trigger
    }

    fn camera_trigger(&mut self) -> &mut Self::CameraTrigger {
        &mut self.camera_trigger
    }

    fn camera_ready(&mut self) -> &mut Self::CameraReady {
        &mut self.camera_ready
    }

    fn external_trigger(&mut self) -> &mut Self::ExternalTrigger {
        &mut self.external_trigger
    }

    fn delay(&mut self) -> &mut Self::Delay {
        &mut self.delay
    }
}

/// A scene seen straight on: camera pixel `(u, v)` sees projector pixel
/// `(u·pw/cw, v·ph/ch)`, with `I = offset + gain·pattern` (clamped to the bit depth). Patterns
/// are rendered on the fly from a core pattern set (wire pattern indices), whatever the
/// exposure. For tests and throughput runs without image files.
pub struct DirectView {
    /// The projected set.
    pub set: fringe3d_core::pattern::PatternSet,
    /// Its wire description (for the pattern index → image mapping).
    pub desc: fringe3d_core::wire::PatternSetDesc,
    /// Camera width.
    pub width: u16,
    /// Camera height.
    pub height: u16,
    /// Camera bits.
    pub bits: u8,
    /// Gain applied to the pattern's gray level.
    pub gain: f32,
    /// Offset added.
    pub offset: f32,
}

impl FrameSource for DirectView {
    fn width(&self) -> u16 {
        self.width
    }

    fn height(&self) -> u16 {
        self.height
    }

    fn bit_depth(&self) -> u8 {
        self.bits
    }

    fn row(&self, shot: Shot, y: u16, out: &mut [u16]) -> Result<(), HwError> {
        let full = ((1u32 << self.bits.clamp(1, 16)) - 1) as f32;
        let o = self.set.output();
        let Some(p) = shot.pattern else {
            out.fill(0);
            return Ok(());
        };
        let id = self.desc.pattern_id(p).ok_or(HwError::Camera)?;
        let image = fringe3d_core::wire::image_index(&self.set, id).ok_or(HwError::Camera)?;
        let eta = (y as u64 * o.height as u64 / self.height.max(1) as u64) as f64;
        for (u, s) in out.iter_mut().enumerate() {
            let xi = (u as u64 * o.width as u64 / self.width.max(1) as u64) as f64;
            let g = self.set.intensity(image, xi, eta).ok_or(HwError::Camera)? as f32;
            let v = self.offset + self.gain * g;
            *s = if v >= full {
                full as u16
            } else if v > 0.0 {
                (v + 0.5) as u16
            } else {
                0
            };
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::{Shot, split_exposure};

    #[test]
    fn a_shot_replays_the_capture_nearest_by_ratio() {
        let at = |us: u64| Shot::new(Some(0), us * 1000);
        let takes = [40_000u32, 10_000, 2_500];
        assert_eq!(at(40_000).nearest(takes), Some(0));
        assert_eq!(at(10_000).nearest(takes), Some(1));
        assert_eq!(at(3_000).nearest(takes), Some(2));
        // 20 000 µs is ×2 from both 40 000 and 10 000: the first listed.
        assert_eq!(at(20_000).nearest(takes), Some(0));
        // By ratio, not difference: 6 000 is ×2.4 from 2 500 and ×1.67 from 10 000.
        assert_eq!(at(6_000).nearest(takes), Some(1));
        assert_eq!(at(1).nearest([]), None);
    }

    #[test]
    fn capture_arguments_split_at_the_last_at_sign() {
        assert_eq!(split_exposure("a/b.bin"), Ok(("a/b.bin", None)));
        assert_eq!(
            split_exposure("x@y/long@10000"),
            Ok(("x@y/long", Some(10_000)))
        );
        assert!(split_exposure("long@0").is_err());
        assert!(split_exposure("long@ten").is_err());
    }
}
