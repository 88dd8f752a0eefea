//! The smallest scan head around `fringe3d-core` (docs/integration.md): load the set-up blob,
//! then per camera row decode the images' rows and reconstruct the row's points, with every
//! buffer in one `static` and the whole head in 64 KiB of SRAM at 640 pixels wide (`memory.x`).
//! It runs under `qemu-system-arm -M mps2-an386` (Cortex-M4F) in a golden-vectors folder of a
//! 16-bit camera (`fringe3d vectors`, docs/golden-vectors.md; an 8-bit camera's rows are
//! `&[u8]`, the same calls), reads the frames through semihosting (standing for a head's frame
//! store) and the reference map where it lies in memory-mapped storage (QEMU loads it into the
//! board's PSRAM, standing for a QSPI flash in XIP mode), and prints digests of its outputs that
//! `tests/tests/qemu_example.rs` compares with the desktop's files.
#![no_std]
#![no_main]

mod host;
mod stack;

use core::fmt::Write as _;
use cortex_m_rt::entry;
use fringe3d_core::budget::{RowBudget, RowLayout};
use fringe3d_core::decode::{DecodeScratch, Decoder, RowOut};
use fringe3d_core::digest::Digest;
use fringe3d_core::reconstruct::{Reconstructor, ReferenceMap};
use fringe3d_core::wire::{HeadSetup, ReferenceFile, SetupError};
use host::{Console, File};

/// Widest image and most images per set this build holds.
const MAX_W: usize = 640;
const MAX_IMAGES: usize = 8;

/// Where the reference map file lies, memory-mapped: the board's 16 MiB PSRAM (`qemu-system-arm
/// -device loader,file=input/reference.f3m,addr=0x21000000,force-raw=on`), standing for a
/// QSPI/OSPI flash in memory-mapped (XIP) mode, where a head keeps its calibration tables.
const MAP_BASE: usize = 0x2100_0000;
/// Bytes of that region.
const MAP_CAPACITY: usize = 16 << 20;

/// Every per-pixel buffer: (2·N + 4 + 1 + 4·3 + 1)·W bytes, plus the decoder's scratch and the
/// set-up blob ([`RowLayout::MINIMAL`]). Lean where the core allows it: no modulation or DC rows
/// (this head wants phase and validity only; `RowOut` takes empty rows), and no reference ring:
/// the kernel reads the map where it lies (a head that streams its map from storage it cannot
/// map keeps a `ReferenceRing` of the band's rows instead, 4·B·W bytes more: the board
/// firmware, docs/integration.md).
struct Buffers {
    blob: [u8; fringe3d_core::wire::setup::MAX_SETUP_BLOB],
    images: [[u16; MAX_W]; MAX_IMAGES],
    phase: [f32; MAX_W],
    validity: [u8; MAX_W],
    xyz: [f32; 3 * MAX_W],
    point_validity: [u8; MAX_W],
    scratch: DecodeScratch,
}

static mut BUFFERS: Buffers = Buffers {
    blob: [0; fringe3d_core::wire::setup::MAX_SETUP_BLOB],
    images: [[0; MAX_W]; MAX_IMAGES],
    phase: [0.0; MAX_W],
    validity: [0; MAX_W],
    xyz: [0.0; 3 * MAX_W],
    point_validity: [0; MAX_W],
    scratch: DecodeScratch::new(), // a `const fn`
};

fn run(b: &mut Buffers) -> Result<(), &'static str> {
    // 1. The set-up blob → decoder and reconstructor (parsed and checked by the core).
    let mut file = File::open("input/setup.bin")?;
    let blob = b.blob.get_mut(..file.len()).ok_or("setup.bin too large")?;
    file.read_at(0, blob)?;
    let (objects, setup_stack) = stack::measure(|| load(blob));
    let (decoder, recon) = objects.map_err(|e| e.what())?;
    let (w, h, n) = (recon.width(), recon.height(), decoder.image_count());
    if w > MAX_W || n > MAX_IMAGES {
        return Err("the scan does not fit this build's buffers");
    }
    // This build leaves out the core's `short-rows` path (Cargo.toml): a row narrower than one
    // 64-pixel block is refused, not decoded.
    let short = decoder.decode_row_with(
        &mut b.scratch,
        &[&b.images[0][..1]; MAX_IMAGES][..n],
        RowOut {
            phase: &mut b.phase[..1],
            modulation: &mut [],
            dc: &mut [],
            validity: &mut b.validity[..1],
        },
    );
    let refused = matches!(short, Err(fringe3d_core::decode::DecodeError::ShortRow));
    let _ = writeln!(Console, "short_row_refused={refused}");

    // 2. The reference map where it lies: its file's header, size and CRC checked against this
    // calibration (a damaged map is refused, not used), then its `(mw, mh)` f32 samples, 32
    // bytes in, read in place (`from_prepared` checks each is finite or the canonical NaN).
    let (mw, mh) = (recon.map_width(), recon.map_height());
    let want = ReferenceFile::of(&recon);
    if want.file_len() > MAP_CAPACITY {
        return Err("the reference map does not fit the mapped region");
    }
    // SAFETY: MAP_BASE..MAP_BASE + MAP_CAPACITY is the board's PSRAM, memory this program never
    // writes; QEMU loaded the file there before reset. Any byte pattern is a valid u8.
    let file = unsafe { core::slice::from_raw_parts(MAP_BASE as *const u8, want.file_len()) };
    let f = ReferenceFile::check_for(file, &recon).map_err(|e| e.what())?;
    // SAFETY: the samples, 32 bytes into a 4-byte-aligned region, are 4-byte aligned, lie in
    // the file checked above, and any bit pattern is a valid f32.
    let map = unsafe {
        core::slice::from_raw_parts(
            (MAP_BASE + f.samples_range().start) as *const f32,
            f.samples_len() / 4,
        )
    };
    let reference =
        ReferenceMap::from_prepared(map, mw, mh).map_err(|_| "reference map refused")?;
    let mut frames = File::open("input/images.u16")?;
    let mut digests = [Digest::default(); 4];
    let (mut decode_stack, mut reconstruct_stack) = (0, 0);

    // 3. Per camera row: decode, reconstruct.
    for v in 0..h {
        for (i, row) in b.images.iter_mut().take(n).enumerate() {
            frames.read_at(2 * (i * h + v) * w, bytes_of(&mut row[..w]))?;
        }
        let rows: [&[u16]; MAX_IMAGES] = core::array::from_fn(|i| &b.images[i][..w]);
        let out = RowOut {
            phase: &mut b.phase[..w],
            modulation: &mut [],
            dc: &mut [],
            validity: &mut b.validity[..w],
        };
        let rows = rows.get(..n).ok_or("too many images")?;
        let (r, used) = stack::measure(|| decoder.decode_row_with(&mut b.scratch, rows, out));
        r.map_err(|_| "decode_row failed")?;
        decode_stack = decode_stack.max(used);

        let (phase, validity) = (&b.phase[..w], &b.validity[..w]);
        let (xyz, point_validity) = (&mut b.xyz[..3 * w], &mut b.point_validity[..w]);
        let (r, used) = stack::measure(|| {
            recon.reconstruct_row(&reference, v as u32, phase, validity, xyz, point_validity)
        });
        r.map_err(|_| "reconstruct_row failed")?;
        reconstruct_stack = reconstruct_stack.max(used);

        digests[0].f32s(phase);
        digests[1].bytes(validity);
        digests[2].f32s(xyz);
        digests[3].bytes(point_validity);
    }

    let [p, q, x, xq] = digests.map(|d| d.0);
    let _ = writeln!(Console, "scan {w}x{h}, {n} images, map {mw}x{mh} in place");
    let _ = writeln!(Console, "digest phase={p:016x} validity={q:016x}");
    let _ = writeln!(Console, "digest points={x:016x} point_validity={xq:016x}");
    // The core's account of this layout at this build's capacity, with this target's type sizes
    // (`fringe3d budget --layout minimal` prints the host's): equal to the statics' size.
    let budget = RowBudget {
        width: MAX_W,
        images: MAX_IMAGES,
        sample_bytes: 2,
        band_rows: 0,
        margin_columns: 0,
        layout: RowLayout::MINIMAL,
    };
    let sizes = (
        size_of_val(&decoder),
        size_of_val(&recon),
        size_of::<Buffers>(),
    );
    let _ = writeln!(
        Console,
        "sizeof decoder={} reconstructor={} buffers={} budget={}",
        sizes.0,
        sizes.1,
        sizes.2,
        budget.total()
    );
    let _ = writeln!(
        Console,
        "stack_bytes setup={setup_stack} decode_row={decode_stack} reconstruct_row={reconstruct_stack}"
    );
    let _ = writeln!(Console, "sram_bytes={}", stack::sram_high_water());
    Ok(())
}

/// Parse the set-up blob and build the decoder and the reconstructor. Out of line: the parsed
/// set-up and the build's temporaries live in this call's frame, gone when it returns, not in
/// the frame of the loop that runs for the whole scan.
#[inline(never)]
fn load(blob: &[u8]) -> Result<(Decoder, Reconstructor), SetupError> {
    let setup = HeadSetup::parse(blob)?;
    Ok((setup.decoder()?, setup.reconstructor()?))
}

/// The bytes of a row of u16 samples (plain numbers: every bit pattern is valid).
fn bytes_of<T: Copy>(s: &mut [T]) -> &mut [u8] {
    let len = core::mem::size_of_val(s);
    // SAFETY: only used on u16 slices, whose every byte pattern is a valid value.
    unsafe { core::slice::from_raw_parts_mut(s.as_mut_ptr().cast(), len) }
}

#[entry]
fn main() -> ! {
    // SAFETY: the only reference ever made to BUFFERS (main never returns).
    let buffers = unsafe { &mut *core::ptr::addr_of_mut!(BUFFERS) };
    match run(buffers) {
        Ok(()) => host::exit(true),
        Err(why) => {
            let _ = writeln!(Console, "fringe3d-head-minimal: error: {why}");
            host::exit(false)
        }
    }
}

/// A panic prints and fails the run...
#[cfg(not(feature = "no-panic"))]
#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    let _ = writeln!(Console, "fringe3d-head-minimal: panic: {info}");
    host::exit(false)
}

/// ...or, with the `no-panic` feature, refers to a symbol that exists nowhere: the link fails
/// unless no panic path survived optimisation.
#[cfg(feature = "no-panic")]
#[panic_handler]
fn panic(_: &core::panic::PanicInfo) -> ! {
    unsafe extern "C" {
        fn fringe3d_a_panic_path_survived() -> !;
    }
    // SAFETY: never linked; reaching this line is a link error, not a run-time one.
    unsafe { fringe3d_a_panic_path_survived() }
}
