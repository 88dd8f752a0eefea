//! fringe3d scan-head firmware for QEMU's `mps2-an386` (ARM AN386: Cortex-M4F, CMSDK UART).
//!
//! A minimal main loop around the core kernels that streams one scan through the head's row
//! pipeline and sends every stage's rows over UART0 (the head's serial link, behind
//! `embedded-io`), so a host can compare them bit for bit with the golden vectors:
//!
//! 1. `input/setup.bin` (the core's head set-up blob: pattern set, capture order, thresholds,
//!    calibration, edge filter) → `Decoder`, `Reconstructor`, `EdgeFilter`;
//! 2. per camera row `v`: the rows `v` of every image → `Decoder::decode_row` (and, for the
//!    vectors only, `decode_row_level` per level); reference rows pushed into a `ReferenceRing`
//!    of exactly the band's rows; `Reconstructor::reconstruct_row`; the edge filter over a
//!    3-row window (one row of latency);
//! 3. a report: flash, static RAM, stack high-water mark, instruction counts per stage.
//!
//! The frames and the reference map stay in "external memory": the vectors folder on the host,
//! read row by row through semihosting (a head reads them from its frame store the same way).
//! Every buffer in SRAM is a `static`, sized for a 1280-wide sensor with the paper's 8 images and
//! the default rig's 25-row reference band, and the linker script limits RAM to 256 KiB, so this
//! build proves the SRAM budget at link time; the painted stack gives the rest (docs/firmware.md).
//!
//! Arguments (semihosting, `-semihosting-config arg=...`): the program name, the vectors folder
//! (default `vectors`), and optionally `quiet` to send only the report (measurement runs) or
//! `records` to write the records into the folder's `records.bin` through semihosting instead
//! of UART0 (one host call per write where the emulated UART takes one per byte: the tests).
//!
//! The head engineer's full firmware logic (`fringe3d-head`'s `Head`) is not linked here:
//! this board crate runs the kernels directly.
//!
//! # Record format (UART0, or `records.bin`)
//! `"F3DR"`, tag `u8`, level `u8`, row `u16` LE, length `u32` LE, then `length` bytes (rows of
//! f32 or u8, little-endian). Tags: see [`Tag`]. The last records are the report (text) and End.
#![no_std]
#![no_main]
#![deny(missing_docs)]

mod measure;
mod params;
mod semihosting;
mod uart;

use core::fmt::Write as _;
use core::panic::PanicInfo;

use cortex_m_rt::{ExceptionFrame, entry, exception};
use embedded_io::Write;
use fringe3d_core::decode::{Decoder, RowOut};
use fringe3d_core::math::CANONICAL_NAN;
use fringe3d_core::reconstruct::{Reconstructor, ReferenceRing};
use fringe3d_core::validity::Validity;

use measure::Counter;
use semihosting::{Console, File};
use uart::CmsdkUart;

/// Widest sensor the static buffers hold.
const MAX_W: usize = 1280;
/// Most images per set the row buffers hold: the paper's 8-image set (the default).
const MAX_IMAGES: usize = 8;
/// Reference rows the ring holds at [`MAX_W`]: the band of the default rig at 1280 × 1024
/// (2 above + 22 below + 1, `reconstruction.band` of `fringe3d vectors --size 1280x1024`).
/// Narrower images get proportionally more rows.
const RING_ROWS: usize = 25;
/// Room for `setup.bin` (read into the ring's storage before the scan starts).
const PARAMS_MAX: usize = fringe3d_core::wire::setup::MAX_SETUP_BLOB;

/// Record tags.
#[repr(u8)]
#[derive(Clone, Copy)]
enum Tag {
    Phase = 1,
    Modulation = 2,
    Dc = 3,
    Validity = 4,
    Wrapped = 5,
    LevelModulation = 6,
    Points = 7,
    PointValidity = 8,
    FilteredValidity = 9,
    FilteredPoints = 10,
    Report = 0xFE,
    End = 0xFF,
}

/// Every per-pixel buffer of the pipeline, in SRAM.
///
/// Point row `v mod 3` is free while row `v` is decoded (it held row `v − 3`, already filtered
/// and sent), so it doubles as the scratch of that phase: the modulation and DC rows of
/// `decode_row` (the reconstruction needs only phase and validity), the per-level rows sent for
/// the vectors, and the reference row on its way into the ring.
struct Buffers {
    /// Row `v` of every image (u16 samples; u8 sets use the same bytes).
    images: [u16; MAX_IMAGES * MAX_W],
    phase: [f32; MAX_W],
    validity: [u8; MAX_W],
    /// The reference ring's phase (no validity plane: the kernel reads only the NaN-encoded
    /// phase).
    ring_phase: [f32; RING_ROWS * MAX_W],
    /// Point rows `v − 2 ..= v` for the edge filter (and the scratch of row `v`, see above).
    points: [[f32; 3 * MAX_W]; 3],
    point_validity: [[u8; MAX_W]; 3],
    filtered: [u8; MAX_W],
}

/// The decoder, built in place by the set-up (a static, not a stack copy: with its
/// phase-correction table it is 1.1 KB).
static mut DECODER: Option<fringe3d_core::decode::Decoder> = None;

static mut BUFFERS: Buffers = Buffers {
    images: [0; MAX_IMAGES * MAX_W],
    phase: [0.0; MAX_W],
    validity: [0; MAX_W],
    ring_phase: [0.0; RING_ROWS * MAX_W],
    points: [[0.0; 3 * MAX_W]; 3],
    point_validity: [[0; MAX_W]; 3],
    filtered: [0; MAX_W],
};

/// The bytes of a slice of plain numbers (u16, f32: every bit pattern valid, no padding).
trait Plain: Copy {}
impl Plain for u16 {}
impl Plain for f32 {}

fn bytes_of<T: Plain>(s: &[T]) -> &[u8] {
    // SAFETY: T is a plain number type without padding; u8 has alignment 1.
    unsafe { core::slice::from_raw_parts(s.as_ptr() as *const u8, core::mem::size_of_val(s)) }
}

fn bytes_of_mut<T: Plain>(s: &mut [T]) -> &mut [u8] {
    // SAFETY: as above, and every byte pattern is a valid T.
    unsafe { core::slice::from_raw_parts_mut(s.as_mut_ptr() as *mut u8, core::mem::size_of_val(s)) }
}

/// A failure: what, printed on the console before exiting with status 1.
struct Fail(&'static str);

impl From<semihosting::HostError> for Fail {
    fn from(e: semihosting::HostError) -> Self {
        Fail(e.what)
    }
}

impl From<params::ParamsError> for Fail {
    fn from(e: params::ParamsError) -> Self {
        Fail(e.0)
    }
}

/// Where the records go: UART0, the head's serial link (the default), or the host file
/// `records.bin` in the vectors folder through semihosting (argument `records`). QEMU's UART
/// costs the host a system call per byte (about 13 s for a 320 × 240 scan's 4.9 MB); the file
/// takes one call per write.
enum Records {
    Uart(CmsdkUart),
    File(File),
}

impl Records {
    fn write_all(&mut self, b: &[u8]) -> Result<(), Fail> {
        match self {
            Records::Uart(u) => match u.write_all(b) {
                Ok(()) => Ok(()),
                Err(e) => match e {},
            },
            Records::File(f) => f.write_all(b).map_err(Fail::from),
        }
    }

    /// Wait until the UART has sent its last byte (the file is written at each call).
    fn flush(&mut self) {
        if let Records::Uart(u) = self {
            let _ = u.flush();
        }
    }
}

fn send(out: &mut Records, tag: Tag, level: u8, row: u16, payload: &[u8]) -> Result<(), Fail> {
    out.write_all(&header(tag, level, row, payload.len()))?;
    out.write_all(payload)
}

/// A record's header: `"F3DR"`, tag, level, row and payload length.
fn header(tag: Tag, level: u8, row: u16, len: usize) -> [u8; 12] {
    let mut h = [0u8; 12];
    h[..4].copy_from_slice(b"F3DR");
    h[4] = tag as u8;
    h[5] = level;
    h[6..8].copy_from_slice(&row.to_le_bytes());
    h[8..12].copy_from_slice(&(len as u32).to_le_bytes());
    h
}

/// What the second argument asks for.
#[derive(Clone, Copy, PartialEq)]
enum Mode {
    /// Every record on UART0.
    Uart,
    /// Every record into `records.bin` (semihosting).
    File,
    /// The report only, on UART0 (measurement runs on large scans).
    Quiet,
}

/// The vectors folder (the first semihosting argument after the program name, else `vectors`)
/// and the second argument: `quiet` for the report only, `records` for the records in a file.
fn vectors_dir(buf: &mut [u8; 256]) -> Result<(&str, Mode), Fail> {
    let n = semihosting::cmdline(buf);
    let s = core::str::from_utf8(&buf[..n]).unwrap_or("");
    let mut args = s.split(' ').filter(|t| !t.is_empty()).skip(1);
    let dir = args.next().unwrap_or("vectors");
    let mode = match args.next() {
        None => Mode::Uart,
        Some("quiet") => Mode::Quiet,
        Some("records") => Mode::File,
        Some(_) => return Err(Fail("the second argument is `quiet`, `records` or nothing")),
    };
    Ok((dir, mode))
}

/// A path `dir/rel` in `buf`.
fn join<'a>(buf: &'a mut [u8; 256], dir: &str, rel: &str) -> Result<&'a str, Fail> {
    let (d, r) = (dir.as_bytes(), rel.as_bytes());
    if d.len() + 1 + r.len() > buf.len() {
        return Err(Fail("vectors path too long"));
    }
    buf[..d.len()].copy_from_slice(d);
    buf[d.len()] = b'/';
    buf[d.len() + 1..d.len() + 1 + r.len()].copy_from_slice(r);
    core::str::from_utf8(&buf[..d.len() + 1 + r.len()])
        .map_err(|_| Fail("vectors path is not UTF-8"))
}

/// Instruction counts (in timer ticks) per stage.
#[derive(Default)]
struct Ticks {
    /// Pattern set (validated over the projector) and decoder.
    setup_decoder: u32,
    /// Camera model and reconstruction set-up (band analysis).
    setup_reconstructor: u32,
    decode: u32,
    ring: u32,
    reconstruct: u32,
    filter: u32,
}

fn run(b: &mut Buffers, uart: CmsdkUart, clock: &Counter) -> Result<(), Fail> {
    let mut c = Console;
    let mut cmd = [0u8; 256];
    let mut cmd_copy = [0u8; 256];
    let (dir_len, mode) = {
        let (d, mode) = vectors_dir(&mut cmd)?;
        let n = d.len();
        cmd_copy[..n].copy_from_slice(d.as_bytes());
        (n, mode)
    };
    let quiet = mode == Mode::Quiet;
    // Rows are sent unless `quiet`.
    let send = |out: &mut Records, tag: Tag, level: u8, row: u16, payload: &[u8]| {
        if quiet {
            Ok(())
        } else {
            send(out, tag, level, row, payload)
        }
    };
    let dir = core::str::from_utf8(&cmd_copy[..dir_len]).map_err(|_| Fail("bad vectors path"))?;
    let _ = writeln!(c, "fringe3d-board-mps2: vectors in {dir:?}");
    let mut path = [0u8; 256];
    let out = &mut match mode {
        Mode::File => Records::File(File::create(join(&mut path, dir, "records.bin")?)?),
        Mode::Uart | Mode::Quiet => Records::Uart(uart),
    };

    // Set-up: parameters, decoder, reconstructor.
    let mut pf = File::open(join(&mut path, dir, "input/setup.bin")?)?;
    let plen = pf.len()?;
    if plen > PARAMS_MAX {
        return Err(Fail("setup.bin is too large"));
    }
    let params_buf = &mut bytes_of_mut(&mut b.ring_phase[..])[..plen];
    pf.read_at(0, params_buf)?;
    drop(pf);
    let mut ticks = Ticks::default();
    let mut st = params::SetupTicks::default();
    // SAFETY: the only reference ever made to DECODER (main runs once and never returns).
    let slot = unsafe { &mut *core::ptr::addr_of_mut!(DECODER) };
    let p = params::parse(
        &bytes_of(&b.ring_phase[..])[..plen],
        &|| clock.now(),
        &mut st,
        slot,
    )?;
    (ticks.setup_decoder, ticks.setup_reconstructor) = (st.decoder, st.reconstructor);
    let dec = slot.as_ref().ok_or(Fail("no decoder"))?;
    let recon = &p.recon;
    // Stack of the set-up (parsing, pattern-set validation, camera model, band analysis), then
    // a fresh paint for the streaming loop.
    let stack_setup = measure::stack_high_water();
    measure::paint_stack();
    let (w, h, n) = (p.width, p.height, p.images);
    if w > MAX_W || n > MAX_IMAGES {
        return Err(Fail(
            "image wider than 1280 or more than 8 images: beyond this build's buffers",
        ));
    }
    let band = recon.band();
    // The reference map's rows are its own width: the image's and its margin past the image
    // (field 9 of the set-up blob). A row is staged in a free point row (3 · MAX_W).
    let (mw, mh) = (recon.map_width(), recon.map_height());
    let ring_rows = (band.rows() as usize).min(mh);
    if ring_rows * mw > RING_ROWS * MAX_W || mw > 3 * MAX_W {
        return Err(Fail("the reference band does not fit the ring buffer"));
    }
    let _ = writeln!(
        c,
        "scan {w}x{h}, {n} images, {} levels, {}-bit samples; band {} above + {} below = {} rows ({} B ring)",
        dec.level_count(),
        p.bits,
        band.above,
        band.below,
        band.rows(),
        recon.ring_bytes(ring_rows as u32)
    );

    let mut img_file = File::open(join(
        &mut path,
        dir,
        if p.sample_bytes == 1 {
            "input/images.u8"
        } else {
            "input/images.u16"
        },
    )?)?;
    let mut ref_file = File::open(join(&mut path, dir, "input/reference_phase.f32")?)?;
    if img_file.len()? != n * w * h * p.sample_bytes || ref_file.len()? != 4 * mw * mh {
        return Err(Fail("images or reference map have the wrong size"));
    }

    let Buffers {
        images,
        phase,
        validity,
        ring_phase,
        points,
        point_validity,
        filtered,
    } = b;
    let mut ring = ReferenceRing::new(recon, &mut ring_phase[..ring_rows * mw], &mut [])
        .map_err(|_| Fail("reference ring refused"))?;
    let (phase, validity) = (&mut phase[..w], &mut validity[..w]);

    for v in 0..h {
        let slot = v % 3;
        // The camera rows v of every image, from external memory.
        let sb = p.sample_bytes;
        {
            let img_bytes = bytes_of_mut(&mut images[..]);
            for i in 0..n {
                let dst = &mut img_bytes[i * w * sb..(i + 1) * w * sb];
                img_file.read_at((i * h + v) * w * sb, dst)?;
            }
        }
        // Decode (timed) with modulation and DC in the free point row; then, for the vectors
        // only, the per-level rows in the same scratch (not timed).
        {
            let (modulation, rest) = points[slot].split_at_mut(w);
            let out = RowOut {
                phase: &mut phase[..],
                modulation,
                dc: &mut rest[..w],
                validity: &mut validity[..],
            };
            let t = clock.now();
            if sb == 1 {
                let bytes = bytes_of(&images[..]);
                let rows: [&[u8]; MAX_IMAGES] = core::array::from_fn(|i| {
                    if i < n {
                        &bytes[i * w..(i + 1) * w]
                    } else {
                        &[]
                    }
                });
                decode_row(dec, &rows[..n], out)?;
            } else {
                let rows: [&[u16]; MAX_IMAGES] = core::array::from_fn(|i| {
                    if i < n {
                        &images[i * w..(i + 1) * w]
                    } else {
                        &[]
                    }
                });
                decode_row(dec, &rows[..n], out)?;
            }
            ticks.decode = ticks.decode.wrapping_add(clock.since(t));
        }
        send(
            out,
            Tag::Modulation,
            0,
            v as u16,
            bytes_of(&points[slot][..w]),
        )?;
        send(out, Tag::Dc, 0, v as u16, bytes_of(&points[slot][w..2 * w]))?;
        send(out, Tag::Phase, 0, v as u16, bytes_of(phase))?;
        send(out, Tag::Validity, 0, v as u16, validity)?;
        if !quiet {
            // (A Gray-code level has no wrapped phase to send.)
            for l in (0..dec.level_count()).filter(|&l| dec.level_has_phase(l)) {
                let (wrapped, rest) = points[slot].split_at_mut(w);
                let lmod = &mut rest[..w];
                if sb == 1 {
                    let bytes = bytes_of(&images[..]);
                    let rows: [&[u8]; MAX_IMAGES] = core::array::from_fn(|i| {
                        if i < n {
                            &bytes[i * w..(i + 1) * w]
                        } else {
                            &[]
                        }
                    });
                    dec.decode_row_level(&rows[..n], l, wrapped, lmod)
                        .map_err(|_| Fail("decode_row_level failed"))?;
                } else {
                    let rows: [&[u16]; MAX_IMAGES] = core::array::from_fn(|i| {
                        if i < n {
                            &images[i * w..(i + 1) * w]
                        } else {
                            &[]
                        }
                    });
                    dec.decode_row_level(&rows[..n], l, wrapped, lmod)
                        .map_err(|_| Fail("decode_row_level failed"))?;
                }
                send(out, Tag::Wrapped, l as u8, v as u16, bytes_of(wrapped))?;
                send(out, Tag::LevelModulation, l as u8, v as u16, bytes_of(lmod))?;
            }
        }

        // Reference rows up to the band's end, from external memory into the ring (staged in the
        // free point row). The map is NaN where invalid, so no codes travel with it.
        let (_, last) = recon.rows_needed(v as u32);
        while ring.rows_pushed() <= last {
            let r = ring.rows_pushed() as usize;
            let ref_phase = &mut points[slot][..mw];
            ref_file.read_at(4 * r * mw, bytes_of_mut(ref_phase))?;
            let t = clock.now();
            ring.push_row(ref_phase, &[])
                .map_err(|_| Fail("reference ring push failed"))?;
            ticks.ring = ticks.ring.wrapping_add(clock.since(t));
        }

        // Reconstruct (timed).
        let t = clock.now();
        reconstruct_row(
            recon,
            &ring,
            v as u32,
            phase,
            validity,
            &mut points[slot][..3 * w],
            &mut point_validity[slot][..w],
        )?;
        ticks.reconstruct = ticks.reconstruct.wrapping_add(clock.since(t));
        send(
            out,
            Tag::Points,
            0,
            v as u16,
            bytes_of(&points[slot][..3 * w]),
        )?;
        send(
            out,
            Tag::PointValidity,
            0,
            v as u16,
            &point_validity[slot][..w],
        )?;

        // The edge filter of the previous row, now that its lower neighbour exists.
        if v >= 1 {
            filter_and_send(
                out,
                clock,
                &mut ticks,
                &p.filter,
                points,
                point_validity,
                filtered,
                v - 1,
                h,
                w,
                quiet,
            )?;
        }
    }
    filter_and_send(
        out,
        clock,
        &mut ticks,
        &p.filter,
        points,
        point_validity,
        filtered,
        h - 1,
        h,
        w,
        quiet,
    )?;
    let sizes = [
        core::mem::size_of::<Decoder>(),
        core::mem::size_of::<Reconstructor>(),
        core::mem::size_of::<fringe3d_core::pattern::PatternSet>(),
        core::mem::size_of::<fringe3d_core::camera::CameraModel>(),
    ];
    report(out, clock, &ticks, w, h, stack_setup, sizes)
}

/// `Decoder::decode_row` in a frame of its own (so that its stack is measured alone).
#[inline(never)]
fn decode_row<P: fringe3d_core::decode::Sample>(
    dec: &Decoder,
    rows: &[&[P]],
    out: RowOut<'_>,
) -> Result<(), Fail> {
    dec.decode_row(rows, out)
        .map_err(|_| Fail("decode_row failed"))
}

/// `Reconstructor::reconstruct_row` in a frame of its own.
#[inline(never)]
fn reconstruct_row(
    recon: &Reconstructor,
    ring: &ReferenceRing<'_>,
    v: u32,
    phase: &[f32],
    validity: &[u8],
    xyz: &mut [f32],
    out: &mut [u8],
) -> Result<(), Fail> {
    recon
        .reconstruct_row(ring, v, phase, validity, xyz, out)
        .map_err(|_| Fail("reconstruct_row failed"))
}

#[allow(clippy::too_many_arguments)]
#[inline(never)]
fn filter_and_send(
    out: &mut Records,
    clock: &Counter,
    ticks: &mut Ticks,
    filter: &fringe3d_core::filter::EdgeFilter,
    points: &[[f32; 3 * MAX_W]; 3],
    point_validity: &[[u8; MAX_W]; 3],
    filtered: &mut [u8; MAX_W],
    r: usize,
    h: usize,
    w: usize,
    quiet: bool,
) -> Result<(), Fail> {
    let row = |k: usize| (&points[k % 3][..3 * w], &point_validity[k % 3][..w]);
    let above = (r > 0).then(|| row(r - 1));
    let below = (r + 1 < h).then(|| row(r + 1));
    let t = clock.now();
    if !filter.filter_row(above, row(r), below, &mut filtered[..w]) {
        return Err(Fail("edge filter: row lengths disagree"));
    }
    ticks.filter = ticks.filter.wrapping_add(clock.since(t));
    if quiet {
        return Ok(());
    }
    send(out, Tag::FilteredValidity, 0, r as u16, &filtered[..w])?;
    // Filtered points: the points, canonical NaN where the filtered code is not Valid; sent in
    // pieces of 32 pixels from the stack.
    out.write_all(&header(Tag::FilteredPoints, 0, r as u16, 12 * w))?;
    let pts = &points[r % 3][..3 * w];
    let mut piece = [0f32; 3 * 32];
    for (codes, xyz) in filtered[..w].chunks(32).zip(pts.chunks(3 * 32)) {
        for ((q, p), o) in codes.iter().zip(xyz.chunks(3)).zip(piece.chunks_mut(3)) {
            if *q == Validity::Valid as u8 {
                o.copy_from_slice(p);
            } else {
                o.fill(CANONICAL_NAN);
            }
        }
        out.write_all(bytes_of(&piece[..3 * codes.len()]))?;
    }
    Ok(())
}

/// A `core::fmt::Write` into a fixed buffer.
struct Text {
    buf: [u8; 1024],
    len: usize,
}

impl core::fmt::Write for Text {
    fn write_str(&mut self, s: &str) -> core::fmt::Result {
        let b = s.as_bytes();
        let end = (self.len + b.len()).min(self.buf.len());
        self.buf[self.len..end].copy_from_slice(&b[..end - self.len]);
        self.len = end;
        Ok(())
    }
}

#[inline(never)]
fn report(
    out: &mut Records,
    clock: &Counter,
    ticks: &Ticks,
    w: usize,
    h: usize,
    stack_setup: usize,
    sizes: [usize; 4],
) -> Result<(), Fail> {
    // Instructions per tick, measured on a loop of 2·N instructions (40 expected under -icount).
    const CAL_N: u32 = 1_000_000;
    let cal_ticks = clock.calibrate(CAL_N);
    let lay = measure::layout();
    let stack = measure::stack_high_water();
    let px = (w * h) as u64;
    // Instructions per pixel × 10, from ticks × (2N / cal_ticks).
    let per_px10 = |t: u32| {
        if cal_ticks == 0 {
            0
        } else {
            (t as u64 * 2 * CAL_N as u64 * 10) / (cal_ticks as u64 * px)
        }
    };
    let mut t = Text {
        buf: [0; 1024],
        len: 0,
    };
    let _ = writeln!(t, "flash_bytes={}", lay.flash);
    let _ = writeln!(t, "static_ram_bytes={}", lay.static_ram);
    // The core's account of the same buffers (`fringe3d budget --layout board`), computed here
    // with this target's type sizes: the test holds it to what the linker laid out.
    let budget = fringe3d_core::budget::RowBudget {
        width: MAX_W,
        images: MAX_IMAGES,
        sample_bytes: 2,
        band_rows: RING_ROWS,
        margin_columns: 0,
        layout: fringe3d_core::budget::RowLayout::BOARD,
    };
    let _ = writeln!(t, "budget_bytes={}", budget.total());
    let _ = writeln!(t, "stack_room_bytes={}", lay.stack_room);
    let _ = writeln!(t, "stack_high_water_bytes setup={stack_setup} scan={stack}");
    let _ = writeln!(
        t,
        "sizeof decoder={} reconstructor={} pattern_set={} camera_model={}",
        sizes[0], sizes[1], sizes[2], sizes[3]
    );
    let _ = writeln!(t, "pixels={px}");
    let _ = writeln!(
        t,
        "calibration_instructions={} calibration_ticks={cal_ticks}",
        2 * CAL_N
    );
    let _ = writeln!(
        t,
        "ticks setup_decoder={} setup_reconstructor={} decode={} ring={} reconstruct={} filter={}",
        ticks.setup_decoder,
        ticks.setup_reconstructor,
        ticks.decode,
        ticks.ring,
        ticks.reconstruct,
        ticks.filter
    );
    let _ = writeln!(
        t,
        "instructions_per_pixel_x10 decode={} reconstruct={} ring={} filter={}",
        per_px10(ticks.decode),
        per_px10(ticks.reconstruct),
        per_px10(ticks.ring),
        per_px10(ticks.filter)
    );
    let text = &t.buf[..t.len];
    semihosting::print(core::str::from_utf8(text).unwrap_or("report\n"));
    send(out, Tag::Report, 0, 0, text)?;
    send(out, Tag::End, 0, 0, &[])?;
    out.flush();
    Ok(())
}

#[entry]
fn main() -> ! {
    measure::paint_stack();
    let clock = Counter::start();
    // SAFETY: UART0 of AN386; only this code drives it.
    let uart = unsafe { CmsdkUart::new(uart::UART0, 115_200) };
    // SAFETY: the only reference ever made to BUFFERS (main runs once and never returns).
    let buffers = unsafe { &mut *core::ptr::addr_of_mut!(BUFFERS) };
    match run(buffers, uart, &clock) {
        Ok(()) => semihosting::exit(true),
        Err(Fail(why)) => {
            let _ = writeln!(Console, "fringe3d-board-mps2: error: {why}");
            semihosting::exit(false)
        }
    }
}

#[exception]
unsafe fn HardFault(_ef: &ExceptionFrame) -> ! {
    semihosting::print("fringe3d-board-mps2: hard fault\n");
    semihosting::exit(false)
}

#[panic_handler]
fn panic(info: &PanicInfo) -> ! {
    let _ = writeln!(Console, "fringe3d-board-mps2: panic: {info}");
    semihosting::exit(false)
}
