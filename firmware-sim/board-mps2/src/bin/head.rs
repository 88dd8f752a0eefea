//! The fringe3d scan head on QEMU's `mps2-an386`: `fringe3d-head`'s [`Head`] — the wire
//! protocol's command handler, uploads, trigger sequences, scans — served on UART0, so that the
//! host's `fringe3d device info | upload | scan` reach it through QEMU's `-serial pty` exactly as
//! they reach the simulated head on the desktop (`fringe3d-head`).
//!
//! The board (the AN386 image has no projector or camera, so both are simulated around the
//! firmware-sim's no_std [`SimWorld`], gathered in a [`SimBoard`]):
//! - serial link: the CMSDK UART0 at 0x4000_4000, polled, behind `embedded-io` (`src/uart.rs`);
//!   QEMU holds back PTY input while the one-byte receive register is full, so nothing is lost;
//! - projector, trigger pins and delay: `SimProjector`, `SimOutput`, `SimInput`, `SimDelay`
//!   (virtual time: exposures and dark times cost no emulated time);
//! - camera: a `SimCamera` whose frames come from a file on the host through semihosting
//!   ([`HostFrames`]; layout below), row by row as the head reads them;
//! - stores for uploaded patterns and the reference map, the frame-sequential decoder's state and
//!   the reference ring: `static`s in the 16 MiB PSRAM at 0x2100_0000 (section `.psram` of
//!   `memory.x`, not loaded, zeroed here at start); the line buffers are `static`s in SRAM. The
//!   SRAM stays limited to 256 KiB by `memory.x`.
//!
//! Arguments (semihosting, `-semihosting-config enable=on,target=native,arg=NAME,arg=FRAMES`):
//! the program name, then the frames file (default `frames.bin`). For HDR scans, up to four
//! frames files, each `PATH@US` (the exposure it was captured at, µs): an exposure reads the
//! file whose exposure is nearest by ratio, as the desktop's `ReplaySeries` does.
//!
//! # The frames file
//! A 16-byte header, all little-endian: `"F3DC"`, camera width `u16`, camera height `u16`,
//! significant bits `u8` (8..=16), bytes per sample `u8` (1 or 2), frame count `u16`, projector
//! width `u16`, projector height `u16`. Then the frames in wire pattern order (levels in order,
//! shifts in order within a level: the numbering of trigger entries and uploads), each `height`
//! rows of `width` samples. Frame `p` is the camera image of the scene lit by pattern `p` (what
//! `fringe3d-head`'s dataset replay delivers); an exposure that caught no steady pattern reads
//! dark. The projector size is the board's: a pattern set must have it.
//!
//! The console (semihosting) gets a start-up line with the board's figures and, after each scan,
//! the rows sent, the stack high-water mark and the head's peak memory use.
#![no_std]
#![no_main]
#![deny(missing_docs)]

#[allow(dead_code)]
#[path = "../measure.rs"]
mod measure;
#[allow(dead_code)]
#[path = "../semihosting.rs"]
mod semihosting;
#[path = "../uart.rs"]
mod uart;

use core::cell::RefCell;
use core::fmt::Write as _;
use core::panic::PanicInfo;
use core::ptr::addr_of_mut;

use cortex_m_rt::{ExceptionFrame, entry, exception};
use fringe3d_head::hal::{HwError, SliceStore};
use fringe3d_head::head::{Activity, Head, HeadConfig};
use fringe3d_head::memory::{COMPILED_LINE_PER_COLUMN, HeadMemory};
use fringe3d_head::sim::{FrameSource, NoSink, Shot, SimBoard, SimWorld, split_exposure};

use semihosting::{Console, File};
use uart::CmsdkUart;

/// Widest camera the SRAM line buffers hold (and the widest reference map row: a 320-wide
/// camera's with [`MAX_MARGIN_PX`] on each side fits).
const MAX_W: usize = 640;
/// Most camera pixels the PSRAM per-pixel buffers hold (320 × 256).
const MAX_PIXELS: usize = 320 * 256;
/// Widest margin past the image, on any side, of a reference map the map store holds for a
/// 320 × 256 camera (issue #17: a map wider than the image; a wider one is refused with Nak
/// OutOfMemory at its upload).
const MAX_MARGIN_PX: usize = 128;
/// Widest projector the SRAM pattern-row buffer holds.
const MAX_PW: usize = 2048;
/// Pattern levels the decoder state is sized for (the core's maximum).
const MAX_LEVELS: usize = fringe3d_core::pattern::MAX_LEVELS;
/// Decoder accumulators: `(1 + 2L)·W·H` f32.
const STATE_LEN: usize = (1 + 2 * MAX_LEVELS) * MAX_PIXELS;
/// Reference ring: up to every row of the largest image.
const RING_LEN: usize = MAX_PIXELS;
/// Pattern-image store: room for the paper's 8 × 1024 × 768 set (6 MiB).
const PATTERN_STORE: usize = 6 << 20;
/// Reference-map store: the map's samples (the 320 × 256 image and [`MAX_MARGIN_PX`] on each
/// side) × (f32 phase + validity byte), then the compiled reconstruction's models of the
/// 320 × 256 image (44 bytes a pixel, docs/compiled.md).
const MAP_STORE: usize = 5 * (320 + 2 * MAX_MARGIN_PX) * (256 + 2 * MAX_MARGIN_PX)
    + MAX_PIXELS * fringe3d_core::wire::COMPILED_BYTES_PER_PIXEL;
/// The simulated camera's readout time (the head's default `readout_us` is 1 000).
const READOUT_NS: u64 = 1_000_000;
/// Baud rate programmed into UART0 (QEMU does not pace the PTY by it).
const BAUD: u32 = 921_600;
/// Bytes of the frames file's header.
const HEADER_LEN: usize = 16;

// External memory: the PSRAM (not loaded, zeroed by `zero_psram`).
#[unsafe(link_section = ".psram")]
static mut PATTERN_BYTES: [u8; PATTERN_STORE] = [0; PATTERN_STORE];
#[unsafe(link_section = ".psram")]
static mut MAP_BYTES: [u8; MAP_STORE] = [0; MAP_STORE];
#[unsafe(link_section = ".psram")]
static mut DECODE_STATE: [f32; STATE_LEN] = [0.0; STATE_LEN];
#[unsafe(link_section = ".psram")]
static mut DECODE_FLAGS: [u8; MAX_PIXELS] = [0; MAX_PIXELS];
#[unsafe(link_section = ".psram")]
static mut RING_PHASE: [f32; RING_LEN] = [0.0; RING_LEN];
#[unsafe(link_section = ".psram")]
static mut RING_VALIDITY: [u8; RING_LEN] = [0; RING_LEN];

/// The head's line buffers, in SRAM.
struct Lines {
    camera: [u16; MAX_W],
    projector: [u8; MAX_PW],
    f32_rows: [[f32; MAX_W]; 4],
    u8_rows: [[u8; MAX_W]; 2],
    /// Three point rows (the edge filter's window).
    xyz: [f32; 9 * MAX_W],
    /// Their codes and the filter's output codes.
    codes: [u8; 4 * MAX_W],
    /// A row of compiled models and the search's points for the pixels they leave.
    compiled: [f32; COMPILED_LINE_PER_COLUMN * MAX_W],
    /// The search's codes and its input mask for those pixels.
    compiled_codes: [u8; 2 * MAX_W],
}

static mut LINES: Lines = Lines {
    camera: [0; MAX_W],
    projector: [0; MAX_PW],
    f32_rows: [[0.0; MAX_W]; 4],
    u8_rows: [[0; MAX_W]; 2],
    xyz: [0.0; 9 * MAX_W],
    codes: [0; 4 * MAX_W],
    compiled: [0.0; COMPILED_LINE_PER_COLUMN * MAX_W],
    compiled_codes: [0; 2 * MAX_W],
};

unsafe extern "C" {
    static mut __spsram: u32;
    static mut __epsram: u32;
}

/// Sleeping while the link is quiet: UART0's receive interrupt wakes a `wfi`.
///
/// Interrupts stay masked (PRIMASK), so no handler runs: a pending interrupt only ends the
/// `wfi`. The wait clears the UART's receive interrupt and the NVIC's pending bit first, then
/// sleeps only if no byte is waiting, so a byte arriving at any moment ends the sleep. Without
/// this the emulated CPU would spin on the UART's status register and take host CPU time from
/// QEMU's I/O thread, which moves the PTY's bytes in one at a time.
mod sleep {
    use core::arch::asm;
    use core::ptr::{read_volatile, write_volatile};

    /// CMSDK UART registers (src/uart.rs).
    const UART0: usize = super::uart::UART0;
    const STATE: usize = 0x04;
    const CTRL: usize = 0x08;
    const INTCLEAR: usize = 0x0C;
    const STATE_RX_FULL: u32 = 2;
    /// CTRL: TX enable, RX enable, RX interrupt enable.
    const CTRL_TX_RX_RXINT: u32 = 0b1011;
    const INT_RX: u32 = 2;
    /// UART0's receive interrupt on AN385/AN386 (QEMU hw/arm/mps2.c).
    const IRQ_UART0_RX: u32 = 0;
    const NVIC_ISER0: usize = 0xE000_E100;
    const NVIC_ICPR0: usize = 0xE000_E280;

    /// Mask interrupts and route UART0's receive interrupt to the NVIC (as a wake-up source).
    pub fn init() {
        // SAFETY: PRIMASK, UART0's control register (this firmware owns UART0) and the NVIC's
        // set-enable register; with PRIMASK set no interrupt handler ever runs.
        unsafe {
            asm!("cpsid i", options(nomem, nostack, preserves_flags));
            write_volatile((UART0 + CTRL) as *mut u32, CTRL_TX_RX_RXINT);
            write_volatile(NVIC_ISER0 as *mut u32, 1 << IRQ_UART0_RX);
        }
    }

    /// Sleep until a byte arrives (or return at once if one is waiting).
    pub fn until_rx() {
        // SAFETY: UART0's interrupt-clear and status registers, the NVIC's clear-pending
        // register, and `wfi` (interrupts masked: it only waits).
        unsafe {
            write_volatile((UART0 + INTCLEAR) as *mut u32, INT_RX);
            write_volatile(NVIC_ICPR0 as *mut u32, 1 << IRQ_UART0_RX);
            if read_volatile((UART0 + STATE) as *const u32) & STATE_RX_FULL == 0 {
                asm!("wfi", options(nomem, nostack, preserves_flags));
            }
        }
    }
}

/// Zero the `.psram` section (external RAM holds anything at reset; the statics there start at 0).
fn zero_psram() {
    // SAFETY: the section's bounds from the linker; nothing references its statics yet.
    unsafe {
        let start = addr_of_mut!(__spsram) as *mut u8;
        let end = addr_of_mut!(__epsram) as *mut u8;
        core::ptr::write_bytes(start, 0, end as usize - start as usize);
    }
}

/// Bytes of the `.psram` section.
fn psram_bytes() -> usize {
    addr_of_mut!(__epsram) as usize - addr_of_mut!(__spsram) as usize
}

/// A failure at start-up, printed before exiting with status 1.
struct Fail(&'static str);

/// Most frames files (exposures) the camera takes.
const MAX_TAKES: usize = 4;

/// One frames file and the exposure it was captured at (µs; 0: not given).
struct Take {
    file: RefCell<File>,
    exposure_us: u32,
}

/// The camera's pictures: frames files on the host, one per exposure, read through
/// semihosting (module docs).
struct HostFrames {
    takes: [Option<Take>; MAX_TAKES],
    width: u16,
    height: u16,
    bits: u8,
    sample_bytes: usize,
    count: u16,
    projector: (u16, u16),
    /// One row of the file (2 bytes per sample at most).
    row: RefCell<[u8; 2 * MAX_W]>,
}

impl HostFrames {
    /// The frames files of the arguments `args` (`PATH` or `PATH@US` each), which must agree in
    /// their headers.
    fn open_all<'a>(args: impl Iterator<Item = &'a str>) -> Result<HostFrames, Fail> {
        let mut all: Option<HostFrames> = None;
        for (k, arg) in args.enumerate() {
            let (path, us) = split_exposure(arg).map_err(Fail)?;
            let f = HostFrames::open(path, us.unwrap_or(0))?;
            match all.as_mut() {
                None => all = Some(f),
                Some(a) => {
                    if (
                        f.width,
                        f.height,
                        f.bits,
                        f.sample_bytes,
                        f.count,
                        f.projector,
                    ) != (
                        a.width,
                        a.height,
                        a.bits,
                        a.sample_bytes,
                        a.count,
                        a.projector,
                    ) {
                        return Err(Fail("frames files: their headers differ"));
                    }
                    let [Some(t), ..] = f.takes else {
                        return Err(Fail("frames file: not opened"));
                    };
                    let slot = a
                        .takes
                        .get_mut(k)
                        .ok_or(Fail("more than four frames files"))?;
                    *slot = Some(t);
                }
            }
        }
        let all = all.ok_or(Fail("no frames file"))?;
        if all.takes.iter().flatten().count() > 1
            && all.takes.iter().flatten().any(|t| t.exposure_us == 0)
        {
            return Err(Fail(
                "with several frames files, give each its exposure as PATH@US",
            ));
        }
        Ok(all)
    }

    /// The take `shot` reads ([`Shot::nearest`]).
    fn take(&self, shot: Shot) -> Option<&Take> {
        let takes = || self.takes.iter().flatten();
        takes().nth(shot.nearest(takes().map(|t| t.exposure_us))?)
    }

    fn open(path: &str, exposure_us: u32) -> Result<HostFrames, Fail> {
        let mut file = File::open(path).map_err(|_| Fail("cannot open the frames file"))?;
        let len = file
            .len()
            .map_err(|_| Fail("cannot size the frames file"))?;
        if len < HEADER_LEN {
            return Err(Fail("the frames file is shorter than its header"));
        }
        let mut h = [0u8; HEADER_LEN];
        file.read_at(0, &mut h)
            .map_err(|_| Fail("cannot read the frames file's header"))?;
        let u16_at = |i: usize| u16::from_le_bytes([h[i], h[i + 1]]);
        if &h[..4] != b"F3DC" {
            return Err(Fail("the frames file does not start with \"F3DC\""));
        }
        let (width, height, bits, sb, count) =
            (u16_at(4), u16_at(6), h[8], h[9] as usize, u16_at(10));
        let projector = (u16_at(12), u16_at(14));
        if !(8..=16).contains(&bits) || !(sb == 1 && bits == 8 || sb == 2) {
            return Err(Fail(
                "frames file: bits must be 8 (1 byte) or 9..=16 (2 bytes)",
            ));
        }
        if width < 2 || height < 2 || count == 0 || projector.0 == 0 || projector.1 == 0 {
            return Err(Fail("frames file: a zero size or no frames"));
        }
        if width as usize > MAX_W || width as usize * height as usize > MAX_PIXELS {
            return Err(Fail(
                "frames file: camera wider than 640 or more than 320 x 256 pixels (this build's buffers)",
            ));
        }
        if projector.0 as usize > MAX_PW {
            return Err(Fail(
                "frames file: projector wider than 2048 (this build's row buffer)",
            ));
        }
        let want = HEADER_LEN + count as usize * height as usize * width as usize * sb;
        if len != want {
            return Err(Fail("frames file: its length does not match its header"));
        }
        Ok(HostFrames {
            takes: [
                Some(Take {
                    file: RefCell::new(file),
                    exposure_us,
                }),
                None,
                None,
                None,
            ],
            width,
            height,
            bits,
            sample_bytes: sb,
            count,
            projector,
            row: RefCell::new([0; 2 * MAX_W]),
        })
    }
}

impl FrameSource for HostFrames {
    fn width(&self) -> u16 {
        self.width
    }

    fn height(&self) -> u16 {
        self.height
    }

    fn bit_depth(&self) -> u8 {
        self.bits
    }

    /// From the file whose exposure is nearest to the shot's.
    fn row(&self, shot: Shot, y: u16, out: &mut [u16]) -> Result<(), HwError> {
        let w = self.width as usize;
        let out = out.get_mut(..w).ok_or(HwError::Camera)?;
        let Some(p) = shot.pattern else {
            out.fill(0);
            return Ok(());
        };
        if p >= self.count || y >= self.height {
            return Err(HwError::Camera);
        }
        let sb = self.sample_bytes;
        let at = HEADER_LEN + (p as usize * self.height as usize + y as usize) * w * sb;
        let mut row = self.row.borrow_mut();
        let bytes = row.get_mut(..w * sb).ok_or(HwError::Camera)?;
        self.take(shot)
            .ok_or(HwError::Camera)?
            .file
            .borrow_mut()
            .read_at(at, bytes)
            .map_err(|_| HwError::Camera)?;
        if sb == 1 {
            for (o, b) in out.iter_mut().zip(bytes.iter()) {
                *o = *b as u16;
            }
        } else {
            for (o, b) in out.iter_mut().zip(bytes.chunks_exact(2)) {
                *o = u16::from_le_bytes([b[0], b[1]]);
            }
        }
        Ok(())
    }
}

/// The frames files: the semihosting arguments after the program name, else `frames.bin`.
fn frames_args(buf: &mut [u8; 256]) -> impl Iterator<Item = &str> {
    let n = semihosting::cmdline(buf);
    let s = core::str::from_utf8(&buf[..n]).unwrap_or("");
    let mut args = s.split(' ').filter(|t| !t.is_empty()).skip(1).peekable();
    let none = args.peek().is_none();
    args.chain(none.then_some("frames.bin"))
}

fn run(uart: &mut CmsdkUart) -> Result<(), Fail> {
    let mut c = Console;
    let mut cmd = [0u8; 256];
    let frames = HostFrames::open_all(frames_args(&mut cmd))?;
    let files = frames.takes.iter().flatten().count();
    let (w, h, bits, n, (pw, ph)) = (
        frames.width,
        frames.height,
        frames.bits,
        frames.count,
        frames.projector,
    );

    let world = SimWorld::new(READOUT_NS);
    // SAFETY: the only references ever made to these statics (`run` runs once, never returns
    // while they are used; the PSRAM was zeroed before).
    let (patterns, maps, state, flags, ring_phase, ring_validity, lines) = unsafe {
        (
            &mut *addr_of_mut!(PATTERN_BYTES),
            &mut *addr_of_mut!(MAP_BYTES),
            &mut *addr_of_mut!(DECODE_STATE),
            &mut *addr_of_mut!(DECODE_FLAGS),
            &mut *addr_of_mut!(RING_PHASE),
            &mut *addr_of_mut!(RING_VALIDITY),
            &mut *addr_of_mut!(LINES),
        )
    };
    let board = SimBoard::new(
        &world,
        frames,
        NoSink,
        (pw, ph),
        SliceStore::new(patterns),
        SliceStore::new(maps),
    );
    let Lines {
        camera,
        projector,
        f32_rows,
        u8_rows,
        xyz,
        codes,
        compiled,
        compiled_codes,
    } = lines;
    let [phase_row, modulation_row, dc_row, reference_phase] = f32_rows;
    let [validity_row, reference_validity] = u8_rows;
    let mem = HeadMemory {
        decode_state: state,
        decode_flags: flags,
        ring_phase,
        ring_validity,
        camera_line: camera,
        projector_line: projector,
        phase_row,
        modulation_row,
        dc_row,
        validity_row,
        xyz_rows: xyz,
        point_codes: codes,
        reference_phase,
        reference_validity,
        compiled_line: compiled,
        compiled_codes,
    };
    let mut head = Head::new(board, mem, HeadConfig::DEFAULT)
        .map_err(|_| Fail("the head refused the board (sizes or buffers)"))?;

    let lay = measure::layout();
    let _ = writeln!(
        c,
        "fringe3d-board-mps2-head: camera {w}x{h} {bits}-bit, {n} frames in each of {files} frames file(s); projector {pw}x{ph}"
    );
    let _ = writeln!(
        c,
        "flash_bytes={} static_ram_bytes={} stack_room_bytes={} psram_bytes={} head_struct_bytes={} stack_high_water_bytes={}",
        lay.flash,
        lay.static_ram,
        lay.stack_room,
        psram_bytes(),
        head.memory_report().head_struct,
        measure::stack_high_water()
    );
    let _ = writeln!(c, "serving the head on UART0");

    let mut rows_sent = head.status().rows_sent;
    loop {
        match head.service(uart) {
            Ok(Activity::Busy) => {}
            Ok(Activity::Idle) => sleep::until_rx(),
            Err(e) => {
                let _ = writeln!(c, "fringe3d-board-mps2-head: link error: {e}");
            }
        }
        let st = head.status();
        if st.rows_sent != rows_sent {
            let m = head.memory_report();
            let _ = writeln!(
                c,
                "scan: {} rows sent; stack_high_water_bytes={}; head peak memory: decode_state={} decode_flags={} ring={} lines={} head_struct={} total={}",
                st.rows_sent.wrapping_sub(rows_sent),
                measure::stack_high_water(),
                m.decode_state,
                m.decode_flags,
                m.ring,
                m.lines,
                m.head_struct,
                m.total()
            );
            rows_sent = st.rows_sent;
        }
    }
}

#[entry]
fn main() -> ! {
    zero_psram();
    measure::paint_stack();
    // SAFETY: UART0 of AN386; only this code drives it.
    let mut uart = unsafe { CmsdkUart::new(uart::UART0, BAUD) };
    sleep::init();
    match run(&mut uart) {
        Ok(()) => semihosting::exit(true),
        Err(Fail(why)) => {
            let _ = writeln!(Console, "fringe3d-board-mps2-head: error: {why}");
            semihosting::exit(false)
        }
    }
}

#[exception]
unsafe fn HardFault(_ef: &ExceptionFrame) -> ! {
    semihosting::print("fringe3d-board-mps2-head: hard fault\n");
    semihosting::exit(false)
}

#[panic_handler]
fn panic(info: &PanicInfo) -> ! {
    let _ = writeln!(Console, "fringe3d-board-mps2-head: panic: {info}");
    semihosting::exit(false)
}
