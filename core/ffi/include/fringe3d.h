/*
 * fringe3d.h: the C ABI of fringe3d-core (core/ffi), for scan-head firmware written in C.
 *
 * Link the static library `libfringe3d_ffi.a`, built for your target:
 *   cd core/ffi && cargo build --release --target thumbv7em-none-eabihf
 *   -> target/ffi/thumbv7em-none-eabihf/release/libfringe3d_ffi.a
 * (add `--features no-panic` to prove at link time that no panic path is in it).
 *
 * The row pipeline (docs/integration.md, "C"):
 *   1. fringe3d_head_init(&head, blob, len): the set-up blob (docs/setup-blob.md) -> the decoder
 *      and the reconstructor, in caller storage (a fringe3d_head, 8 KiB: put it in a static);
 *   2. the reference rows: fringe3d_reference_map (a map the head can address: memory-mapped
 *      flash, PSRAM) or fringe3d_reference_ring + fringe3d_reference_push_row (a map streamed
 *      from storage);
 *   3. per camera row v: fringe3d_decode_row_u8 / _u16, then fringe3d_reconstruct_row (or
 *      fringe3d_reconstruct_row_compiled with the row's compiled models).
 *
 * Every call checks its pointers and lengths and returns a status: FRINGE3D_OK (0) or one of
 * the FRINGE3D_ERR_* codes (fringe3d_status_name names them); a call that fails on a head
 * records why, in words, for fringe3d_last_error. Conventions: OpenCV camera frame,
 * millimetres, pixel centres at integers; every invalid output value is the canonical NaN
 * 0x7fc00000; validity codes as in docs/golden-vectors.md (0 = valid).
 *
 * Kept by hand; tools/check_c_header.py (CI) holds it equal to core/ffi/src/.
 */
#ifndef FRINGE3D_H
#define FRINGE3D_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* The version of this ABI; fringe3d_abi_version() returns the library's. Version 2: a row of
 * compiled models is FRINGE3D_COMPILED_FIELDS (11) floats a pixel, not 10. */
#define FRINGE3D_ABI_VERSION 2u
/* Floats a pixel of a row of compiled models (fringe3d_reconstruct_row_compiled). */
#define FRINGE3D_COMPILED_FIELDS 11

/* Storage sizes, in 64-bit words (the library checks its objects fit at compile time). */
#define FRINGE3D_HEAD_WORDS 1024
#define FRINGE3D_REFERENCE_WORDS 16

/* Status codes. */
#define FRINGE3D_OK 0
#define FRINGE3D_ERR_ARGUMENT 1    /* a null pointer, a zero or too large count, a wrong length */
#define FRINGE3D_ERR_STATE 2       /* the head or reference is not initialised (or its init failed) */
#define FRINGE3D_ERR_SETUP 3       /* the set-up blob was refused (fringe3d_last_error says why) */
#define FRINGE3D_ERR_DECODE 4      /* the decoder refused the row (fringe3d_last_error) */
#define FRINGE3D_ERR_RECONSTRUCT 5 /* the reconstruction refused the row (fringe3d_last_error) */
#define FRINGE3D_ERR_REFERENCE 6   /* a map of the wrong size or not prepared, a ring too small,
                                      a reference row out of order */
#define FRINGE3D_ERR_SAMPLE_SIZE 7 /* the frames' sample size is not the call's (_u8 / _u16) */

/* A head: the decoder, the reconstructor and the decoder's scratch. Opaque; it must not move
 * between calls. */
typedef struct fringe3d_head {
    uint64_t opaque[FRINGE3D_HEAD_WORDS];
} fringe3d_head;

/* The reconstruction's reference rows: a map read in place, or a ring. Opaque; the map or the
 * ring's storage it was made over must stay valid (and in place) while it is used. */
typedef struct fringe3d_reference {
    uint64_t opaque[FRINGE3D_REFERENCE_WORDS];
} fringe3d_reference;

/* What a head's set-up says about the scan (pixels, samples). */
typedef struct fringe3d_info {
    uint32_t width;        /* image width: the length of every row */
    uint32_t height;       /* image height: rows per scan */
    uint32_t images;       /* images per scan, in the set-up's capture order */
    uint32_t sample_bits;  /* significant bits per camera sample */
    uint32_t sample_bytes; /* 1 (fringe3d_decode_row_u8) or 2 (fringe3d_decode_row_u16) */
    uint32_t map_width;    /* reference map width: the image's plus the set-up's margin */
    uint32_t map_height;   /* reference map height */
    uint32_t band_rows;    /* reference rows a ring must hold */
} fringe3d_info;

/* The library's ABI version (compare with FRINGE3D_ABI_VERSION at start-up). */
uint32_t fringe3d_abi_version(void);

/* Check the set-up blob blob[0..len] and build the head. On failure the head is unusable
 * (FRINGE3D_ERR_STATE from the other calls) and fringe3d_last_error says why. Needs about
 * 22 KB of stack on a Cortex-M4F (once, at set-up); may be called again on the same storage. */
int32_t fringe3d_head_init(fringe3d_head *head, const uint8_t *blob, size_t len);

/* Fill *out with the head's scan sizes. */
int32_t fringe3d_head_info(fringe3d_head *head, fringe3d_info *out);

/* Decode one camera row (paper section 5.2, eqs 8-15): rows[i] is row v of image i in the
 * set-up's capture order, count of them, each width samples. phase gets the absolute phase (rad,
 * NaN where invalid), validity the codes; modulation and dc may be NULL (not wanted) or width
 * floats each. Rows narrower than 64 pixels are refused. About 1.8 KB of stack. */
int32_t fringe3d_decode_row_u8(fringe3d_head *head, const uint8_t *const *rows, size_t count,
                               size_t width, float *phase, float *modulation, float *dc,
                               uint8_t *validity);
int32_t fringe3d_decode_row_u16(fringe3d_head *head, const uint16_t *const *rows, size_t count,
                                size_t width, float *phase, float *modulation, float *dc,
                                uint8_t *validity);

/* The reference map rows *first ..= *last that the reconstruction of camera row v reads (a ring
 * must hold them before fringe3d_reconstruct_row of row v). */
int32_t fringe3d_rows_needed(fringe3d_head *head, uint32_t v, uint32_t *first, uint32_t *last);

/* A reference that reads the map in place: count = map_width * map_height floats, row after
 * row, prepared (the canonical NaN where invalid, as `fringe3d vectors` writes
 * input/reference_phase.f32). Every sample is checked once, here; the map is never written. */
int32_t fringe3d_reference_map(fringe3d_reference *reference, fringe3d_head *head,
                               const float *samples, size_t count);

/* fringe3d_reference_map from the map's file as a head stores it (`fringe3d vectors`'
 * input/reference.f3m; docs/setup-blob.md, "The reference map file"): len bytes at file, checked
 * whole (header, size and margin against the head's calibration, CRC-32C), so that a damaged map
 * is refused (FRINGE3D_ERR_REFERENCE, fringe3d_last_error says why); then its samples, 32 bytes
 * in, are read in place. file must be 4-byte aligned. */
int32_t fringe3d_reference_map_file(fringe3d_reference *reference, fringe3d_head *head,
                                    const uint8_t *file, size_t len);

/* A reference that is a ring of map rows in storage (count floats, at least band_rows *
 * map_width), for a map streamed from storage. The first row to push is first_row (0, or the
 * first row fringe3d_rows_needed names for a region of interest's first camera row). */
int32_t fringe3d_reference_ring(fringe3d_reference *reference, fringe3d_head *head,
                                float *storage, size_t count, uint32_t first_row);

/* Push the next map row (number fringe3d_reference_rows(reference)) into a ring: len =
 * map_width floats, NaN where invalid. */
int32_t fringe3d_reference_push_row(fringe3d_reference *reference, const float *row, size_t len);

/* Map rows available: a ring's next row to push, a map's height; 0 if not made. */
uint32_t fringe3d_reference_rows(fringe3d_reference *reference);

/* Reconstruct camera row v (paper section 6, eqs 16-18) from its decoded phase and validity
 * (width each): xyz gets x, y, z per pixel (3 * width floats; mm, camera frame; NaN where
 * invalid), point_validity the codes (0 = a point). About 14 KB of stack on a Cortex-M4F. */
int32_t fringe3d_reconstruct_row(fringe3d_head *head, fringe3d_reference *reference, uint32_t v,
                                 const float *phase, const uint8_t *validity, float *xyz,
                                 uint8_t *point_validity);

/* fringe3d_reconstruct_row through row v's compiled models (docs/compiled.md): models is row v of
 * a `fringe3d compile` file (after its 72-byte header, FRINGE3D_COMPILED_FIELDS * width
 * little-endian floats per row),
 * one rational function of the phase per pixel (about 200 Cortex-M4F instructions a pixel
 * instead of the search's 1 100). The pixels it leaves go to the search over reference, with
 * search_xyz (3 * width floats), search_codes and mask (width bytes each) as scratch; these may
 * be NULL for a file that compiled every pixel (else FRINGE3D_ERR_ARGUMENT). The models are
 * trusted as `fringe3d compile` wrote them for this calibration and reference map. */
int32_t fringe3d_reconstruct_row_compiled(fringe3d_head *head, fringe3d_reference *reference,
                                          uint32_t v, const float *models, const float *phase,
                                          const uint8_t *validity, float *xyz,
                                          uint8_t *point_validity, float *search_xyz,
                                          uint8_t *search_codes, uint8_t *mask);

/* The pixels of the last row reconstructed on head whose point the search computed: for
 * fringe3d_reconstruct_row_compiled those the row's models left to the search (summed over a
 * scan and divided by the pixels with a valid phase: the compiled reconstruction's fallback
 * rate, docs/compiled.md), for fringe3d_reconstruct_row every pixel with a valid phase. 0 before
 * any row, after a reconstruction call that failed, and for a NULL head. */
uint32_t fringe3d_row_searched(const fringe3d_head *head);

/* Why the last failed call on head failed, in words, NUL-terminated into buf (len bytes, cut
 * short if need be); returns the message's length. Empty if nothing failed. */
size_t fringe3d_last_error(const fringe3d_head *head, char *buf, size_t len);

/* The name of a status code: a static string ("ok", "argument", ...). */
const char *fringe3d_status_name(int32_t status);

/* Provided by the firmware, unless the library is built with the `no-panic` feature: called if
 * the library panics (no input is known to make it: every call checks its inputs). Must not
 * return. */
void fringe3d_panic(void) __attribute__((noreturn));

#ifdef __cplusplus
}
#endif

#endif /* FRINGE3D_H */
