//! The C ABI of `fringe3d-core`, for a scan head whose firmware is C (STM32Cube, Zephyr, a vendor
//! SDK): this crate builds a static library, `include/fringe3d.h` declares it. The calls are the
//! core's row pipeline (docs/integration.md), nothing more:
//!
//! 1. [`fringe3d_head_init`]: check the set-up blob (`docs/setup-blob.md`) and build the decoder
//!    and the reconstructor into caller storage ([`fringe3d_head`], 8 KiB, e.g. a `static`);
//! 2. [`fringe3d_reference_map`] (a map the head can address: memory-mapped flash, PSRAM) or
//!    [`fringe3d_reference_ring`] + [`fringe3d_reference_push_row`] (a map streamed from
//!    storage) for the reconstruction's reference rows;
//! 3. per camera row `v`: [`fringe3d_decode_row_u8`] or [`fringe3d_decode_row_u16`], then
//!    [`fringe3d_reconstruct_row`] (or [`fringe3d_reconstruct_row_compiled`] with the row's
//!    compiled models, docs/compiled.md).
//!
//! Every call checks its pointers and lengths and returns a status ([`FRINGE3D_OK`] or one of
//! the `FRINGE3D_ERR_*` codes, named by [`fringe3d_status_name`]); a call that fails on a head
//! records why, in words, for [`fringe3d_last_error`]. The bits are the core's: the C example
//! `examples/head-c` matches the golden vectors on an emulated Cortex-M4F
//! (`tests/tests/qemu_c_example.rs`).
//!
//! The header is kept by hand next to this file; `tools/check_c_header.py` (CI) holds its
//! prototypes, constants and storage sizes equal to the crate's, and the compile-time
//! assertions below hold the storage sizes to the Rust objects they carry.
#![no_std]
#![deny(missing_docs)]
#![allow(non_camel_case_types)]

use core::ffi::c_char;
use core::fmt::Write as _;
use core::slice;
use fringe3d_core::decode::{DecodeError, DecodeScratch, Decoder, RowOut};
use fringe3d_core::limits::MAX_IMAGES;
use fringe3d_core::reconstruct::compiled::CompiledError;
use fringe3d_core::reconstruct::{ReconstructError, Reconstructor, ReferenceMap, ReferenceRing};
use fringe3d_core::sample::Sample;
use fringe3d_core::wire::setup::FrameFormat;
use fringe3d_core::wire::{HeadSetup, ReferenceFileError, SetupError};

/// The version of this ABI (the header's `FRINGE3D_ABI_VERSION`): a change to a call's
/// meaning or to a storage size gets a new one. Version 2: a row of compiled models is
/// [`FRINGE3D_COMPILED_FIELDS`] = 11 floats a pixel (each model's own far threshold), not 10.
pub const FRINGE3D_ABI_VERSION: u32 = 2;
/// Floats a pixel of a row of compiled models ([`fringe3d_reconstruct_row_compiled`]): the
/// core's `FIELDS`.
pub const FRINGE3D_COMPILED_FIELDS: u32 = 11;
const _: () =
    assert!(FRINGE3D_COMPILED_FIELDS as usize == fringe3d_core::reconstruct::compiled::FIELDS);
/// 64-bit words of a [`fringe3d_head`] (8 KiB).
pub const FRINGE3D_HEAD_WORDS: usize = 1024;
/// 64-bit words of a [`fringe3d_reference`].
pub const FRINGE3D_REFERENCE_WORDS: usize = 16;

/// Success.
pub const FRINGE3D_OK: i32 = 0;
/// A null pointer, a zero or too large count, or a row of the wrong length.
pub const FRINGE3D_ERR_ARGUMENT: i32 = 1;
/// The head or the reference was not initialised (or its initialisation failed).
pub const FRINGE3D_ERR_STATE: i32 = 2;
/// The set-up blob was refused ([`fringe3d_last_error`] says why).
pub const FRINGE3D_ERR_SETUP: i32 = 3;
/// The decoder refused the row ([`fringe3d_last_error`] says why).
pub const FRINGE3D_ERR_DECODE: i32 = 4;
/// The reconstruction refused the row ([`fringe3d_last_error`] says why).
pub const FRINGE3D_ERR_RECONSTRUCT: i32 = 5;
/// The reference map or ring was refused: a map of the wrong size or not prepared (a sample
/// neither finite nor the canonical NaN), a ring too small for the band, a row pushed out of
/// order or past the map.
pub const FRINGE3D_ERR_REFERENCE: i32 = 6;
/// The frames' sample size is not the call's (`_u8` for 1-byte samples, `_u16` for 2).
pub const FRINGE3D_ERR_SAMPLE_SIZE: i32 = 7;

/// Storage for a head: the decoder, the reconstructor and the decoder's scratch. Opaque; any
/// memory of this size and alignment (a `static`, the stack: it does not move once made).
#[repr(C)]
pub struct fringe3d_head {
    opaque: [u64; FRINGE3D_HEAD_WORDS],
}

/// Storage for the reconstruction's reference rows: a map read in place or a ring. Opaque.
#[repr(C)]
pub struct fringe3d_reference {
    opaque: [u64; FRINGE3D_REFERENCE_WORDS],
}

/// What a head's set-up says about the scan (all sizes in pixels or samples).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default)]
pub struct fringe3d_info {
    /// Image width: the length of every row the head decodes and reconstructs.
    pub width: u32,
    /// Image height: rows per scan.
    pub height: u32,
    /// Images per scan, in the set-up's capture order.
    pub images: u32,
    /// Significant bits per camera sample.
    pub sample_bits: u32,
    /// Bytes per camera sample: 1 ([`fringe3d_decode_row_u8`]) or 2 ([`fringe3d_decode_row_u16`]).
    pub sample_bytes: u32,
    /// Reference map width: the image's plus the set-up's margin.
    pub map_width: u32,
    /// Reference map height.
    pub map_height: u32,
    /// Reference rows a ring must hold (the reconstruction's band).
    pub band_rows: u32,
}

/// Why the last call on a head failed.
#[derive(Clone, Copy)]
enum LastError {
    None,
    Argument(&'static str),
    Setup(SetupError),
    Decode(DecodeError),
    Reconstruct(ReconstructError),
    Compiled(CompiledError),
    ReferenceFile(ReferenceFileError),
}

const HEAD_MAGIC: u32 = u32::from_le_bytes(*b"F3DH");
const REFERENCE_MAGIC: u32 = u32::from_le_bytes(*b"F3DR");

/// What a [`fringe3d_head`] holds.
struct Head {
    magic: u32,
    frames: FrameFormat,
    decoder: Option<Decoder>,
    recon: Option<Reconstructor>,
    scratch: DecodeScratch,
    error: LastError,
    /// The last reconstructed row's pixels that the search computed ([`fringe3d_row_searched`]).
    searched: u32,
}

/// The reference rows a [`fringe3d_reference`] holds; its buffers are the caller's, which
/// outlive it (the header's contract).
enum Source {
    Map(ReferenceMap<'static>),
    Ring(ReferenceRing<'static>),
}

struct Reference {
    magic: u32,
    source: Source,
}

mod reconstruct;
pub use reconstruct::*;

const _: () = {
    assert!(size_of::<Head>() <= size_of::<fringe3d_head>());
    assert!(align_of::<Head>() <= align_of::<fringe3d_head>());
    assert!(size_of::<Reference>() <= size_of::<fringe3d_reference>());
    assert!(align_of::<Reference>() <= align_of::<fringe3d_reference>());
};

/// The head behind `p` if it was initialised.
///
/// # Safety
/// `p` is null or points to a `fringe3d_head` the caller owns.
unsafe fn head_ref<'a>(p: *mut fringe3d_head) -> Result<&'a mut Head, i32> {
    let h = p.cast::<Head>();
    // SAFETY: non-null storage of at least size_of::<Head>() bytes, 8-aligned (the caller's);
    // the magic word is read before anything else, and set only by a successful init.
    if h.is_null() || unsafe { core::ptr::addr_of!((*h).magic).read() } != HEAD_MAGIC {
        return Err(FRINGE3D_ERR_STATE);
    }
    // SAFETY: initialised by fringe3d_head_init (the magic says so).
    Ok(unsafe { &mut *h })
}

/// The reference behind `p` if it was initialised.
///
/// # Safety
/// `p` is null or points to a `fringe3d_reference` the caller owns.
unsafe fn reference_ref<'a>(p: *mut fringe3d_reference) -> Result<&'a mut Reference, i32> {
    let r = p.cast::<Reference>();
    // SAFETY: as in `head`.
    if r.is_null() || unsafe { core::ptr::addr_of!((*r).magic).read() } != REFERENCE_MAGIC {
        return Err(FRINGE3D_ERR_STATE);
    }
    // SAFETY: initialised by fringe3d_reference_map or _ring (the magic says so).
    Ok(unsafe { &mut *r })
}

/// `len` items at `p`, or `None` for a null pointer (an empty slice for `len == 0`).
///
/// # Safety
/// `p` is null or valid for `len` reads.
unsafe fn items<'a, T>(p: *const T, len: usize) -> Option<&'a [T]> {
    match (p.is_null(), len) {
        (_, 0) => Some(&[]),
        (true, _) => None,
        // SAFETY: the caller's contract.
        (false, _) => Some(unsafe { slice::from_raw_parts(p, len) }),
    }
}

/// As [`items`], writable.
///
/// # Safety
/// `p` is null or valid for `len` writes, and not aliased during the call.
unsafe fn items_mut<'a, T>(p: *mut T, len: usize) -> Option<&'a mut [T]> {
    match (p.is_null(), len) {
        (_, 0) => Some(&mut []),
        (true, _) => None,
        // SAFETY: the caller's contract.
        (false, _) => Some(unsafe { slice::from_raw_parts_mut(p, len) }),
    }
}

/// The ABI version this library implements ([`FRINGE3D_ABI_VERSION`]): compare it with the
/// header's at start-up.
#[unsafe(no_mangle)]
pub extern "C" fn fringe3d_abi_version() -> u32 {
    FRINGE3D_ABI_VERSION
}

/// Check the set-up blob `blob[0..len]` and build the head in `head`: the decoder (the pattern
/// set's estimators, the thresholds, the projector-response table if any) and the
/// reconstructor. On failure the head is unusable ([`FRINGE3D_ERR_STATE`] from every other
/// call) and [`fringe3d_last_error`] says why. May be called again on the same storage.
///
/// # Safety
/// `head` is null or valid for writes of a `fringe3d_head`; `blob` is null or valid for `len`
/// reads.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fringe3d_head_init(
    head: *mut fringe3d_head,
    blob: *const u8,
    len: usize,
) -> i32 {
    let h = head.cast::<Head>();
    if h.is_null() {
        return FRINGE3D_ERR_ARGUMENT;
    }
    // SAFETY: the caller's storage, large and aligned enough (the assertions above).
    unsafe { h.write(Head::EMPTY) };
    // SAFETY: written just above.
    let h = unsafe { &mut *h };
    // SAFETY: the caller's contract.
    let Some(blob) = (unsafe { items(blob, len) }).filter(|b| !b.is_empty()) else {
        h.error = LastError::Argument("no set-up blob (a null pointer or 0 bytes)");
        return FRINGE3D_ERR_ARGUMENT;
    };
    match h.load(blob) {
        Ok(()) => {
            h.magic = HEAD_MAGIC;
            FRINGE3D_OK
        }
        Err(e) => {
            (h.decoder, h.recon, h.error) = (None, None, LastError::Setup(e));
            FRINGE3D_ERR_SETUP
        }
    }
}

impl Head {
    const EMPTY: Head = Head {
        magic: 0,
        frames: FrameFormat {
            width: 0,
            height: 0,
            sample_bits: 0,
            sample_bytes: 0,
        },
        decoder: None,
        recon: None,
        scratch: DecodeScratch::new(),
        error: LastError::None,
        searched: 0,
    };

    /// Out of line: the parsed set-up and the build's temporaries (about 20 KB on a Cortex-M4F)
    /// are gone when it returns.
    #[inline(never)]
    fn load(&mut self, blob: &[u8]) -> Result<(), SetupError> {
        let setup = HeadSetup::parse(blob)?;
        setup.decoder_into(&mut self.decoder)?;
        self.recon = Some(setup.reconstructor()?);
        self.frames = setup.frames;
        Ok(())
    }

    fn fail(&mut self, e: LastError, status: i32) -> i32 {
        self.error = e;
        status
    }
}

/// Fill `out` with what the head's set-up says about the scan.
///
/// # Safety
/// `head` and `out` are null or valid (`head` initialised by [`fringe3d_head_init`]).
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fringe3d_head_info(
    head: *mut fringe3d_head,
    out: *mut fringe3d_info,
) -> i32 {
    // SAFETY: the caller's contract.
    let h = match unsafe { head_ref(head) } {
        Ok(h) => h,
        Err(s) => return s,
    };
    let (Some(d), Some(r)) = (&h.decoder, &h.recon) else {
        return FRINGE3D_ERR_STATE;
    };
    if out.is_null() {
        return h.fail(
            LastError::Argument("no info to fill"),
            FRINGE3D_ERR_ARGUMENT,
        );
    }
    let info = fringe3d_info {
        width: r.width() as u32,
        height: r.height() as u32,
        images: d.image_count() as u32,
        sample_bits: h.frames.sample_bits.into(),
        sample_bytes: h.frames.sample_bytes.into(),
        map_width: r.map_width() as u32,
        map_height: r.map_height() as u32,
        band_rows: r.band().rows(),
    };
    // SAFETY: non-null, the caller's.
    unsafe { out.write(info) };
    FRINGE3D_OK
}

/// Decode one camera row (paper §5.2, eqs 8-15): `rows[i]` is row `v` of image `i` in the
/// set-up's capture order, `count` of them (the set's image count), each `width` samples.
/// Writes the absolute phase (rad, the canonical NaN where invalid) and the validity codes
/// (`core/src/validity.rs`; 0 = valid) of `width` pixels; `modulation` and `dc` may be null
/// (not wanted) or `width` floats each. Rows narrower than 64 pixels are refused (this library
/// is built without the core's `short-rows` path).
///
/// # Safety
/// `head` is null or a head; `rows` is null or `count` pointers, each null or valid for `width`
/// reads; the outputs are null or valid for `width` writes each, and do not overlap.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fringe3d_decode_row_u8(
    head: *mut fringe3d_head,
    rows: *const *const u8,
    count: usize,
    width: usize,
    phase: *mut f32,
    modulation: *mut f32,
    dc: *mut f32,
    validity: *mut u8,
) -> i32 {
    let out = (phase, modulation, dc, validity);
    // SAFETY: the caller's contract, passed on.
    unsafe { decode_row(head, rows, count, width, out) }
}

/// [`fringe3d_decode_row_u8`] for 2-byte samples (cameras of 9 to 16 bits).
///
/// # Safety
/// As [`fringe3d_decode_row_u8`].
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fringe3d_decode_row_u16(
    head: *mut fringe3d_head,
    rows: *const *const u16,
    count: usize,
    width: usize,
    phase: *mut f32,
    modulation: *mut f32,
    dc: *mut f32,
    validity: *mut u8,
) -> i32 {
    let out = (phase, modulation, dc, validity);
    // SAFETY: the caller's contract, passed on.
    unsafe { decode_row(head, rows, count, width, out) }
}

/// The row outputs of a decode: phase, modulation, DC, validity.
type DecodeOut = (*mut f32, *mut f32, *mut f32, *mut u8);

/// # Safety
/// As [`fringe3d_decode_row_u8`].
unsafe fn decode_row<P: Sample>(
    head: *mut fringe3d_head,
    rows: *const *const P,
    count: usize,
    width: usize,
    (phase, modulation, dc, validity): DecodeOut,
) -> i32 {
    // SAFETY: the caller's contract.
    let h = match unsafe { head_ref(head) } {
        Ok(h) => h,
        Err(s) => return s,
    };
    if usize::from(h.frames.sample_bytes) != size_of::<P>() {
        let e = LastError::Argument("the frames' sample size is not this call's");
        return h.fail(e, FRINGE3D_ERR_SAMPLE_SIZE);
    }
    if width == 0 || count == 0 || count > MAX_IMAGES {
        let e = LastError::Argument("a row of 0 pixels, or no or too many images");
        return h.fail(e, FRINGE3D_ERR_ARGUMENT);
    }
    let mut slices: [&[P]; MAX_IMAGES] = [&[]; MAX_IMAGES];
    // SAFETY: `count` pointers (the caller's contract).
    let Some(ptrs) = (unsafe { items(rows, count) }) else {
        return h.fail(LastError::Argument("no rows"), FRINGE3D_ERR_ARGUMENT);
    };
    for (s, &p) in slices.iter_mut().zip(ptrs) {
        // SAFETY: each row valid for `width` reads.
        match unsafe { items(p, width) } {
            Some(row) => *s = row,
            None => return h.fail(LastError::Argument("a null row"), FRINGE3D_ERR_ARGUMENT),
        }
    }
    // SAFETY: the outputs, `width` each, not overlapping (the caller's contract).
    let (phase, validity) = unsafe { (items_mut(phase, width), items_mut(validity, width)) };
    let optional = |p: *mut f32| {
        // SAFETY: as above; null means not wanted.
        (!p.is_null()).then(|| unsafe { slice::from_raw_parts_mut(p, width) })
    };
    let (Some(phase), Some(validity)) = (phase, validity) else {
        return h.fail(
            LastError::Argument("no phase or validity row"),
            FRINGE3D_ERR_ARGUMENT,
        );
    };
    let out = RowOut {
        phase,
        modulation: optional(modulation).unwrap_or(&mut []),
        dc: optional(dc).unwrap_or(&mut []),
        validity,
    };
    let Some(decoder) = &h.decoder else {
        return FRINGE3D_ERR_STATE;
    };
    let rows = slices.get(..count).unwrap_or(&[]);
    match decoder.decode_row_with(&mut h.scratch, rows, out) {
        Ok(()) => FRINGE3D_OK,
        Err(e) => h.fail(LastError::Decode(e), FRINGE3D_ERR_DECODE),
    }
}

/// The pixels of the last row reconstructed on `head` whose point the §6 search computed: for
/// [`fringe3d_reconstruct_row_compiled`] those the row's models left to the search (summed over
/// a scan and divided by the pixels with a valid phase, the compiled reconstruction's fallback
/// rate: docs/compiled.md), for [`fringe3d_reconstruct_row`] every pixel with a valid phase. 0
/// before any row, after a reconstruction call that failed, and for a null `head`.
///
/// # Safety
/// `head` is null or storage a [`fringe3d_head_init`] call wrote.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fringe3d_row_searched(head: *const fringe3d_head) -> u32 {
    let h = head.cast::<Head>();
    if h.is_null() {
        return 0;
    }
    // SAFETY: storage an init call wrote (the caller's contract): `searched` is set there.
    unsafe { core::ptr::addr_of!((*h).searched).read() }
}

/// Write why the last failed call on `head` failed, in words, into `buf` (at most `len` bytes,
/// NUL-terminated, cut short if need be); returns the message's length without the NUL. An
/// empty message if nothing failed. Works on a head whose [`fringe3d_head_init`] failed.
///
/// # Safety
/// `head` is null or storage a [`fringe3d_head_init`] call wrote; `buf` null or valid for `len`
/// writes.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fringe3d_last_error(
    head: *const fringe3d_head,
    buf: *mut c_char,
    len: usize,
) -> usize {
    let h = head.cast::<Head>();
    // SAFETY: the caller's contract.
    let Some(out) = (unsafe { items_mut(buf.cast::<u8>(), len) }).filter(|b| !b.is_empty()) else {
        return 0;
    };
    let mut w = Cut { out, at: 0 };
    if !h.is_null() {
        // SAFETY: storage an init call wrote (the caller's contract): `error` is set there.
        let e = unsafe { core::ptr::addr_of!((*h).error).read() };
        let _ = match e {
            LastError::None => Ok(()),
            LastError::Argument(m) => w.write_str(m),
            LastError::Setup(e) => write!(w, "{e}"),
            LastError::Decode(e) => write!(w, "decode: {e}"),
            LastError::Reconstruct(e) => write!(w, "reconstruction: {e}"),
            LastError::Compiled(e) => write!(w, "compiled reconstruction: {e}"),
            LastError::ReferenceFile(e) => write!(w, "{e}"),
        };
    }
    let end = w.at.min(w.out.len() - 1);
    if let Some(nul) = w.out.get_mut(end) {
        *nul = 0;
    }
    end
}

/// A message into a fixed buffer, cut at its last byte (kept for the NUL) on a character
/// boundary.
struct Cut<'a> {
    out: &'a mut [u8],
    at: usize,
}

impl core::fmt::Write for Cut<'_> {
    fn write_str(&mut self, s: &str) -> core::fmt::Result {
        let room = self.out.len().saturating_sub(1 + self.at);
        let mut n = s.len().min(room);
        while !s.is_char_boundary(n) {
            n -= 1;
        }
        if let (Some(dst), Some(src)) = (self.out.get_mut(self.at..self.at + n), s.get(..n)) {
            dst.copy_from_slice(src.as_bytes());
            self.at += n;
        }
        Ok(())
    }
}

/// The name of a status code, a static NUL-terminated string ("ok", "argument", …; "unknown"
/// for a code this library does not return).
#[unsafe(no_mangle)]
pub extern "C" fn fringe3d_status_name(status: i32) -> *const c_char {
    let name = match status {
        FRINGE3D_OK => c"ok",
        FRINGE3D_ERR_ARGUMENT => c"argument",
        FRINGE3D_ERR_STATE => c"state",
        FRINGE3D_ERR_SETUP => c"setup",
        FRINGE3D_ERR_DECODE => c"decode",
        FRINGE3D_ERR_RECONSTRUCT => c"reconstruct",
        FRINGE3D_ERR_REFERENCE => c"reference",
        FRINGE3D_ERR_SAMPLE_SIZE => c"sample-size",
        _ => c"unknown",
    };
    name.as_ptr()
}

/// A panic calls a function that exists nowhere: the firmware's link fails unless no panic path
/// survived optimisation (the `no-panic` feature; examples/head-c links so).
#[cfg(feature = "no-panic")]
#[panic_handler]
fn panic(_: &core::panic::PanicInfo) -> ! {
    unsafe extern "C" {
        fn fringe3d_panic_path_survived() -> !;
    }
    // SAFETY: never linked; reaching this line is a link error, not a run-time one.
    unsafe { fringe3d_panic_path_survived() }
}

/// A panic (none is expected: every call checks its inputs) calls the firmware's
/// `fringe3d_panic(void)`, which must not return (log, reset).
#[cfg(not(feature = "no-panic"))]
#[panic_handler]
fn panic(_: &core::panic::PanicInfo) -> ! {
    unsafe extern "C" {
        fn fringe3d_panic() -> !;
    }
    // SAFETY: the firmware's handler, declared in fringe3d.h.
    unsafe { fringe3d_panic() }
}
