//! The reconstruction's calls of the C ABI: the reference rows (a map read in place or a ring)
//! and the row reconstruction, by the search or through compiled models (paper §6).

use crate::{
    FRINGE3D_ERR_ARGUMENT, FRINGE3D_ERR_RECONSTRUCT, FRINGE3D_ERR_REFERENCE, FRINGE3D_ERR_STATE,
    FRINGE3D_OK, Head, LastError, REFERENCE_MAGIC, Reference, Source, fringe3d_head,
    fringe3d_reference, head_ref, items, items_mut, reference_ref,
};
use fringe3d_core::reconstruct::compiled::{FIELDS, SearchScratch, compiled_row};
use fringe3d_core::reconstruct::{ReferenceMap, ReferenceRing, ReferenceRows};
use fringe3d_core::validity::Validity;
use fringe3d_core::wire::ReferenceFile;

/// The reference rows the reconstruction of camera row `v` reads: map rows `*first ..= *last`.
/// A ring must hold them (pushed in order) before [`fringe3d_reconstruct_row`] of row `v`.
///
/// # Safety
/// `head` is null or a head; `first` and `last` are null or valid for a write.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fringe3d_rows_needed(
    head: *mut fringe3d_head,
    v: u32,
    first: *mut u32,
    last: *mut u32,
) -> i32 {
    // SAFETY: the caller's contract.
    let h = match unsafe { head_ref(head) } {
        Ok(h) => h,
        Err(s) => return s,
    };
    let Some(r) = &h.recon else {
        return FRINGE3D_ERR_STATE;
    };
    let (a, b) = r.rows_needed(v);
    if first.is_null() || last.is_null() {
        return h.fail(
            LastError::Argument("no row numbers to fill"),
            FRINGE3D_ERR_ARGUMENT,
        );
    }
    // SAFETY: non-null, the caller's.
    unsafe { (first.write(a), last.write(b)) };
    FRINGE3D_OK
}

/// Make `reference` read the head's reference map in place: `count` = map width × map height
/// f32 samples at `samples` (row after row), prepared on the desktop (the canonical NaN
/// `0x7fc00000` where invalid; `fringe3d vectors`' `input/reference_phase.f32` is). Checks every
/// sample once, here; the map is never copied or written, and must stay where it is while the
/// reference is used.
///
/// # Safety
/// `reference` is null or valid for writes of a `fringe3d_reference`; `head` null or a head;
/// `samples` null or valid for `count` reads for as long as the reference is used.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fringe3d_reference_map(
    reference: *mut fringe3d_reference,
    head: *mut fringe3d_head,
    samples: *const f32,
    count: usize,
) -> i32 {
    // SAFETY: the caller's contract.
    let (r, h) = match unsafe { reference_storage(reference, head) } {
        Ok(rh) => rh,
        Err(s) => return s,
    };
    // SAFETY: the caller's contract; the map outlives the reference.
    let map: Option<&'static [f32]> = unsafe { items(samples, count) };
    let Some(map) = map else {
        return h.fail(LastError::Argument("no map samples"), FRINGE3D_ERR_ARGUMENT);
    };
    place_map(r, h, map)
}

/// Make the reference at `r` (from [`reference_storage`]) read the prepared `samples` in place,
/// checked for `h`'s map size and every sample finite or the canonical NaN.
fn place_map(r: *mut Reference, h: &mut Head, samples: &'static [f32]) -> i32 {
    let Some(recon) = &h.recon else {
        return FRINGE3D_ERR_STATE;
    };
    match ReferenceMap::from_prepared(samples, recon.map_width(), recon.map_height()) {
        Ok(m) => make(r, Source::Map(m)),
        Err(e) => h.fail(LastError::Reconstruct(e), FRINGE3D_ERR_REFERENCE),
    }
}

/// [`fringe3d_reference_map`] from the map's file as a head stores it (`fringe3d vectors`'
/// `input/reference.f3m`; docs/setup-blob.md, "The reference map file"): `len` bytes at `file`,
/// checked whole (header, size and margin against the head's calibration, CRC-32C) so that a
/// damaged map is refused ([`FRINGE3D_ERR_REFERENCE`], [`fringe3d_last_error`] says why), then
/// its samples read in place. `file` must be 4-byte aligned (the samples are 32 bytes in).
///
/// # Safety
/// As [`fringe3d_reference_map`], with `file` valid for `len` reads for as long as the
/// reference is used.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fringe3d_reference_map_file(
    reference: *mut fringe3d_reference,
    head: *mut fringe3d_head,
    file: *const u8,
    len: usize,
) -> i32 {
    // SAFETY: the caller's contract.
    let (r, h) = match unsafe { reference_storage(reference, head) } {
        Ok(rh) => rh,
        Err(s) => return s,
    };
    let Some(recon) = &h.recon else {
        return FRINGE3D_ERR_STATE;
    };
    // SAFETY: the caller's contract; the file outlives the reference.
    let bytes: Option<&'static [u8]> = unsafe { items(file, len) };
    let Some(bytes) = bytes else {
        return h.fail(LastError::Argument("no map file"), FRINGE3D_ERR_ARGUMENT);
    };
    let f = match ReferenceFile::check_for(bytes, recon) {
        Ok(f) => f,
        Err(e) => return h.fail(LastError::ReferenceFile(e), FRINGE3D_ERR_REFERENCE),
    };
    let Some(raw) = bytes.get(f.samples_range()) else {
        return FRINGE3D_ERR_REFERENCE;
    };
    if cfg!(target_endian = "big") || raw.as_ptr().align_offset(4) != 0 {
        let e = LastError::Argument("the map file's samples are not aligned little-endian f32");
        return h.fail(e, FRINGE3D_ERR_ARGUMENT);
    }
    // SAFETY: `raw` is 4-byte aligned (checked), `4 × n` bytes long, valid as long as the file
    // (the caller's contract), and any bit pattern is an f32 (the core checks them below).
    let samples: &'static [f32] =
        unsafe { core::slice::from_raw_parts(raw.as_ptr().cast::<f32>(), raw.len() / 4) };
    place_map(r, h, samples)
}

/// Make `reference` a ring of reference rows in `storage` (`count` floats: at least
/// `band_rows × map_width`, [`fringe3d_info`](crate::fringe3d_info)), for a map the head streams from storage it
/// cannot address. The first row to push is `first_row` (0, or for a region of interest starting
/// at camera row `v0`, the `first` of [`fringe3d_rows_needed`] for `v0`).
///
/// # Safety
/// `reference` is null or valid for writes of a `fringe3d_reference`; `head` null or a head;
/// `storage` null or valid for `count` reads and writes, used by nothing else, for as long as the
/// reference is used.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fringe3d_reference_ring(
    reference: *mut fringe3d_reference,
    head: *mut fringe3d_head,
    storage: *mut f32,
    count: usize,
    first_row: u32,
) -> i32 {
    // SAFETY: the caller's contract.
    let (r, h) = match unsafe { reference_storage(reference, head) } {
        Ok(rh) => rh,
        Err(s) => return s,
    };
    let Some(recon) = &h.recon else {
        return FRINGE3D_ERR_STATE;
    };
    // SAFETY: the caller's contract; the storage outlives the reference.
    let storage: Option<&'static mut [f32]> = unsafe { items_mut(storage, count) };
    let Some(storage) = storage else {
        return h.fail(
            LastError::Argument("no ring storage"),
            FRINGE3D_ERR_ARGUMENT,
        );
    };
    let ring = ReferenceRing::new(recon, storage, &mut []).and_then(|mut ring| {
        if first_row > 0 {
            ring.start_at(first_row)?;
        }
        Ok(ring)
    });
    match ring {
        Ok(ring) => make(r, Source::Ring(ring)),
        Err(e) => h.fail(LastError::Reconstruct(e), FRINGE3D_ERR_REFERENCE),
    }
}

/// The storage of a reference being made (marked unusable until it is), and its head.
///
/// # Safety
/// As [`fringe3d_reference_map`].
unsafe fn reference_storage<'a>(
    reference: *mut fringe3d_reference,
    head: *mut fringe3d_head,
) -> Result<(*mut Reference, &'a mut Head), i32> {
    let r = reference.cast::<Reference>();
    if r.is_null() {
        return Err(FRINGE3D_ERR_ARGUMENT);
    }
    // SAFETY: the caller's storage, large and aligned enough; whatever it held is forgotten
    // (a map or ring owns nothing).
    unsafe { core::ptr::addr_of_mut!((*r).magic).write(0) };
    // SAFETY: the caller's contract.
    let h = unsafe { head_ref(head) }?;
    Ok((r, h))
}

/// Write a made reference into its storage `r` (from [`reference_storage`]: non-null, large
/// and aligned enough).
fn make(r: *mut Reference, source: Source) -> i32 {
    let magic = REFERENCE_MAGIC;
    // SAFETY: `r` as above, the caller's storage.
    unsafe { r.write(Reference { magic, source }) };
    FRINGE3D_OK
}

/// Push the next reference row into a ring: map row number [`fringe3d_reference_rows`] ("rows
/// available"), `len` = map width f32 samples, the canonical NaN (or any NaN) where invalid.
/// [`FRINGE3D_ERR_REFERENCE`] for a map (it holds every row), a row of the wrong length, or a
/// row past the map.
///
/// # Safety
/// `reference` is null or a reference; `row` null or valid for `len` reads.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fringe3d_reference_push_row(
    reference: *mut fringe3d_reference,
    row: *const f32,
    len: usize,
) -> i32 {
    // SAFETY: the caller's contract.
    let r = match unsafe { reference_ref(reference) } {
        Ok(r) => r,
        Err(s) => return s,
    };
    // SAFETY: the caller's contract.
    let Some(row) = (unsafe { items(row, len) }) else {
        return FRINGE3D_ERR_ARGUMENT;
    };
    match &mut r.source {
        Source::Ring(ring) => match ring.push_row(row, &[]) {
            Ok(()) => FRINGE3D_OK,
            Err(_) => FRINGE3D_ERR_REFERENCE,
        },
        Source::Map(_) => FRINGE3D_ERR_REFERENCE,
    }
}

/// Map rows available so far: a ring's next row to push (the rows pushed, from its first row
/// on), a map's height (it holds them all); 0 for a reference not made.
///
/// # Safety
/// `reference` is null or a reference.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fringe3d_reference_rows(reference: *mut fringe3d_reference) -> u32 {
    // SAFETY: the caller's contract.
    match unsafe { reference_ref(reference) }.map(|r| &r.source) {
        Ok(Source::Ring(ring)) => ring.rows_pushed(),
        Ok(Source::Map(map)) => map.height() as u32,
        Err(_) => 0,
    }
}

/// Reconstruct camera row `v` (paper §6, eqs 16-18) from its decoded `phase` and `validity`
/// (the head's width each): `xyz` gets x, y, z per pixel (mm, camera frame; the canonical NaN
/// where invalid), `point_validity` the codes (0 = a point). A ring must hold the rows
/// [`fringe3d_rows_needed`] names for `v`.
///
/// # Safety
/// `head` and `reference` are null or initialised; `phase` and `validity` null or valid for
/// width reads; `xyz` null or valid for 3 × width writes, `point_validity` for width writes, not
/// overlapping the inputs.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fringe3d_reconstruct_row(
    head: *mut fringe3d_head,
    reference: *mut fringe3d_reference,
    v: u32,
    phase: *const f32,
    validity: *const u8,
    xyz: *mut f32,
    point_validity: *mut u8,
) -> i32 {
    // SAFETY: the caller's contract.
    let (h, rows) = match unsafe { row_context(head, reference) } {
        Ok(c) => c,
        Err(s) => return s,
    };
    h.searched = 0;
    let Some(recon) = &h.recon else {
        return FRINGE3D_ERR_STATE;
    };
    let w = recon.width();
    // SAFETY: the caller's contract: width (3 × width) items each.
    let bufs = unsafe {
        (
            items(phase, w),
            items(validity, w),
            items_mut(xyz, 3 * w),
            items_mut(point_validity, w),
        )
    };
    let (Some(phase), Some(validity), Some(xyz), Some(codes)) = bufs else {
        return h.fail(LastError::Argument("a null row"), FRINGE3D_ERR_ARGUMENT);
    };
    match recon.reconstruct_row(rows, v, phase, validity, xyz, codes) {
        Ok(()) => {
            let valid = validity
                .iter()
                .filter(|&&q| q == Validity::Valid as u8)
                .count();
            h.searched = valid as u32;
            FRINGE3D_OK
        }
        Err(e) => h.fail(LastError::Reconstruct(e), FRINGE3D_ERR_RECONSTRUCT),
    }
}

/// [`fringe3d_reconstruct_row`] through the row's compiled models (docs/compiled.md): `models`
/// is row `v` of a compiled reconstruction (`fringe3d compile`'s file: after its 72-byte header,
/// `FIELDS × width` = [`FRINGE3D_COMPILED_FIELDS`](crate::FRINGE3D_COMPILED_FIELDS) × width =
/// 11 × width little-endian f32 per row, read as floats), one rational
/// function of the phase per pixel, about 200 Cortex-M4F instructions a pixel instead of the
/// search's 1 100. The pixels it leaves (no function; a phase just past a range clipped to the
/// map) go to the search over `reference`, with `search_xyz` (3 × width floats), `search_codes`
/// and `mask` (width bytes each) as its scratch: needed only when a row has such pixels, so
/// they may be null for a file that compiled every pixel (else [`FRINGE3D_ERR_ARGUMENT`]). The
/// models are trusted as `fringe3d compile` wrote them for this calibration and reference map.
///
/// # Safety
/// As [`fringe3d_reconstruct_row`]; `models` null or valid for 11 × width reads; the scratch
/// null or valid for its writes, overlapping nothing else.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fringe3d_reconstruct_row_compiled(
    head: *mut fringe3d_head,
    reference: *mut fringe3d_reference,
    v: u32,
    models: *const f32,
    phase: *const f32,
    validity: *const u8,
    xyz: *mut f32,
    point_validity: *mut u8,
    search_xyz: *mut f32,
    search_codes: *mut u8,
    mask: *mut u8,
) -> i32 {
    // SAFETY: the caller's contract.
    let (h, rows) = match unsafe { row_context(head, reference) } {
        Ok(c) => c,
        Err(s) => return s,
    };
    h.searched = 0;
    let Some(recon) = &h.recon else {
        return FRINGE3D_ERR_STATE;
    };
    let w = recon.width();
    // SAFETY: the caller's contract: (11 ×, 3 ×) width items each.
    let bufs = unsafe {
        (
            items(models, FIELDS * w),
            items(phase, w),
            items(validity, w),
            items_mut(xyz, 3 * w),
            items_mut(point_validity, w),
        )
    };
    let (Some(models), Some(phase), Some(validity), Some(xyz), Some(codes)) = bufs else {
        return h.fail(LastError::Argument("a null row"), FRINGE3D_ERR_ARGUMENT);
    };
    let s = recon.setup();
    let (z_min, z_max) = (s.z_min as f32, s.z_max as f32);
    let left = match compiled_row(models, z_min, z_max, phase, validity, xyz, codes) {
        Ok(n) => n,
        Err(e) => return h.fail(LastError::Compiled(e), FRINGE3D_ERR_RECONSTRUCT),
    };
    if left == 0 {
        return FRINGE3D_OK;
    }
    // SAFETY: the caller's contract: the scratch, 3 × width and width items.
    let scratch = unsafe {
        (
            items_mut(search_xyz, 3 * w),
            items_mut(search_codes, w),
            items_mut(mask, w),
        )
    };
    let (Some(sx), Some(sq), Some(mask)) = scratch else {
        let e = LastError::Argument("a row has pixels for the search and no scratch was given");
        return h.fail(e, FRINGE3D_ERR_ARGUMENT);
    };
    let scratch = SearchScratch {
        mask,
        xyz: sx,
        codes: sq,
    };
    match recon.search_left(rows, v, phase, validity, xyz, codes, scratch) {
        Ok(()) => {
            h.searched = left as u32;
            FRINGE3D_OK
        }
        Err(e) => h.fail(LastError::Reconstruct(e), FRINGE3D_ERR_RECONSTRUCT),
    }
}

/// The initialised head and reference rows of a row call.
///
/// # Safety
/// `head` and `reference` are null or the caller's initialised storage.
unsafe fn row_context<'a>(
    head: *mut fringe3d_head,
    reference: *mut fringe3d_reference,
) -> Result<(&'a mut Head, &'a dyn ReferenceRows), i32> {
    // SAFETY: the caller's contract.
    let h = unsafe { head_ref(head) }?;
    // SAFETY: the caller's contract.
    let rows: &dyn ReferenceRows = match &unsafe { reference_ref(reference) }?.source {
        Source::Map(m) => m,
        Source::Ring(r) => r,
    };
    Ok((h, rows))
}
