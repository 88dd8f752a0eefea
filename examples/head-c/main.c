/*
 * examples/head-c: a scan head in C around fringe3d-core's C ABI (core/ffi/include/fringe3d.h),
 * for QEMU mps2-an386 (Cortex-M4F), built with arm-none-eabi-gcc (tests/tests/qemu_c_example.rs
 * shows the commands). In a golden-vectors folder of a 16-bit camera (`fringe3d vectors`) it
 * loads the set-up blob, then decodes and reconstructs the scan row by row: once with the
 * reference map read in place (its checked file, input/reference.f3m, which QEMU loads into the
 * board's PSRAM at 0x21000000, standing for a memory-mapped QSPI flash), once with the map
 * streamed row by row from input/reference_phase.f32 through a ring; and, when the folder has a
 * compiled reconstruction (`fringe3d vectors --compiled`), a third time through its models, read
 * row by row from input/compiled.f3c, with the search over the mapped map for the pixels they
 * leave. It prints FNV-1a digests of each pass's outputs, which the test compares with the
 * desktop's files, and checks some refusals.
 */
#include <stdint.h>

#include "fringe3d.h"
#include "semihost.h"

#define MAX_W 640
#define MAX_IMAGES 8
#define RING_FLOATS (16 * MAX_W)
#define MAP_FILE ((const uint8_t *)0x21000000)
#define MAP_CAPACITY (16u << 20)

static fringe3d_head head;
static uint8_t blob[4108];
static uint16_t images[MAX_IMAGES][MAX_W];
static float phase[MAX_W];
static uint8_t validity[MAX_W];
static float xyz[3 * MAX_W];
static uint8_t point_validity[MAX_W];
static float ring_storage[RING_FLOATS];
static float reference_row[MAX_W];
/* The compiled pass: one row of models, and the search's scratch for the pixels they leave. */
#define FIELDS FRINGE3D_COMPILED_FIELDS
#define F3C_HEADER 72
static float models[FIELDS * MAX_W];
static float search_xyz[3 * MAX_W];
static uint8_t search_codes[MAX_W];
static uint8_t search_mask[MAX_W];

/* ---- console ---- */

static void put(const char *s) { semihost_print(s); }

static void put_u32(uint32_t v) {
    char b[11];
    int i = 10;
    b[i] = 0;
    do b[--i] = (char)('0' + v % 10); while ((v /= 10) != 0);
    put(&b[i]);
}

static void put_hex64(uint64_t v) {
    char b[17];
    for (int i = 15; i >= 0; i--, v >>= 4) b[i] = "0123456789abcdef"[v & 15];
    b[16] = 0;
    put(b);
}

/* ---- FNV-1a 64, floats as their bits with every NaN canonical (docs/golden-vectors.md) ---- */

typedef struct { uint64_t h; } digest;

static void digest_bytes(digest *d, const void *p, size_t n) {
    const uint8_t *b = p;
    for (size_t i = 0; i < n; i++) {
        d->h ^= b[i];
        d->h *= 0x100000001b3ull;
    }
}

static void digest_floats(digest *d, const float *v, size_t n) {
    for (size_t i = 0; i < n; i++) {
        union { float f; uint32_t u; } x = {v[i]};
        if (v[i] != v[i]) x.u = 0x7fc00000u;
        uint8_t le[4] = {(uint8_t)x.u, (uint8_t)(x.u >> 8), (uint8_t)(x.u >> 16),
                         (uint8_t)(x.u >> 24)};
        digest_bytes(d, le, 4);
    }
}

/* ---- stack high-water mark: paint the free stack once, find the deepest word written ---- */

extern uint32_t _bss_end[], _ram_start[], _stack_top[];
#define PAINT 0xC0FFEE55u

static void paint_stack(void) {
    uint32_t *sp;
    __asm volatile("mov %0, sp" : "=r"(sp));
    for (uint32_t *p = _bss_end; p < sp - 64; p++) *(volatile uint32_t *)p = PAINT;
}

static uint32_t sram_high_water(void) {
    uint32_t *p = _bss_end;
    while (p < _stack_top && *(volatile uint32_t *)p == PAINT) p++;
    return (uint32_t)((uintptr_t)_bss_end - (uintptr_t)_ram_start) +
           (uint32_t)((uintptr_t)_stack_top - (uintptr_t)p);
}

/* ---- the scan ---- */

/* Print `prefix`, `what`, the status's name and the head's reason for it, on one line. */
static void put_status(const char *prefix, const char *what, int32_t status) {
    char why[160];
    fringe3d_last_error(&head, why, sizeof why);
    put(prefix);
    put(what);
    put(fringe3d_status_name(status));
    put(" (");
    put(why);
    put(")\n");
}

static int fail(const char *what, int32_t status) {
    put("fringe3d-head-c: ");
    put_status(what, ": ", status);
    return 1;
}

/* Decode and reconstruct every row against `reference`; a ring is topped up from `map_file`;
 * with `compiled_file` (else -1) through the rows of its models. */
static int scan(const char *name, const fringe3d_info *info, fringe3d_reference *reference,
                int frames, int map_file, int compiled_file) {
    digest d[4] = {{0xcbf29ce484222325ull}, {0xcbf29ce484222325ull},
                   {0xcbf29ce484222325ull}, {0xcbf29ce484222325ull}};
    const uint32_t w = info->width, h = info->height, n = info->images;
    uint32_t searched = 0; /* pixels whose point the search computed: the fallback's share */
    const uint16_t *rows[MAX_IMAGES];
    for (uint32_t i = 0; i < n; i++) rows[i] = images[i];
    for (uint32_t v = 0; v < h; v++) {
        for (uint32_t i = 0; i < n; i++)
            if (semihost_read_at(frames, 2u * (i * h + v) * w, images[i], 2u * w) != 0)
                return fail("reading the frames", FRINGE3D_ERR_ARGUMENT);
        int32_t s = fringe3d_decode_row_u16(&head, rows, n, w, phase, 0, 0, validity);
        if (s != FRINGE3D_OK) return fail("decode", s);

        uint32_t first, last;
        s = fringe3d_rows_needed(&head, v, &first, &last);
        if (s != FRINGE3D_OK) return fail("rows needed", s);
        while (map_file >= 0 && fringe3d_reference_rows(reference) <= last) {
            uint32_t r = fringe3d_reference_rows(reference);
            size_t mw = info->map_width;
            if (semihost_read_at(map_file, 4u * r * mw, reference_row, 4u * mw) != 0)
                return fail("reading the reference map", FRINGE3D_ERR_ARGUMENT);
            s = fringe3d_reference_push_row(reference, reference_row, mw);
            if (s != FRINGE3D_OK) return fail("reference row", s);
        }
        if (compiled_file >= 0) {
            size_t row = 4u * FIELDS * w;
            if (semihost_read_at(compiled_file, F3C_HEADER + row * v, models, row) != 0)
                return fail("reading the compiled models", FRINGE3D_ERR_ARGUMENT);
            s = fringe3d_reconstruct_row_compiled(&head, reference, v, models, phase, validity,
                                                  xyz, point_validity, search_xyz, search_codes,
                                                  search_mask);
        } else {
            s = fringe3d_reconstruct_row(&head, reference, v, phase, validity, xyz,
                                         point_validity);
        }
        if (s != FRINGE3D_OK) return fail("reconstruct", s);
        searched += fringe3d_row_searched(&head);
        digest_floats(&d[0], phase, w);
        digest_bytes(&d[1], validity, w);
        digest_floats(&d[2], xyz, 3 * w);
        digest_bytes(&d[3], point_validity, w);
    }
    put(name);
    put(" phase=");
    put_hex64(d[0].h);
    put(" validity=");
    put_hex64(d[1].h);
    put(" points=");
    put_hex64(d[2].h);
    put(" point_validity=");
    put_hex64(d[3].h);
    put(" searched=");
    put_u32(searched);
    put("\n");
    return 0;
}

int main(void) {
    paint_stack();
    if (fringe3d_abi_version() != FRINGE3D_ABI_VERSION) {
        put("fringe3d-head-c: the library's ABI is not the header's\n");
        return 1;
    }
    /* 1. The set-up blob -> the head. A damaged blob is refused, with a reason. */
    int f = semihost_open("input/setup.bin");
    long len = f < 0 ? -1 : semihost_length(f);
    if (len <= 0 || (size_t)len > sizeof blob || semihost_read_at(f, 0, blob, (size_t)len) != 0) {
        put("fringe3d-head-c: cannot read input/setup.bin\n");
        return 1;
    }
    semihost_close(f);
    blob[len - 1] ^= 0x01; /* the CRC's last byte */
    int32_t s = fringe3d_head_init(&head, blob, (size_t)len);
    put_status("", "damaged_blob=", s);
    if (s != FRINGE3D_ERR_SETUP) return 1;
    blob[len - 1] ^= 0x01;
    s = fringe3d_head_init(&head, blob, (size_t)len);
    if (s != FRINGE3D_OK) return fail("set-up", s);

    fringe3d_info info;
    s = fringe3d_head_info(&head, &info);
    if (s != FRINGE3D_OK) return fail("info", s);
    if (info.width > MAX_W || info.images > MAX_IMAGES || info.sample_bytes != 2 ||
        (size_t)info.map_width * info.band_rows > RING_FLOATS ||
        (size_t)info.map_width * info.map_height * 4 + 36 > MAP_CAPACITY) {
        put("fringe3d-head-c: the scan does not fit this build's buffers\n");
        return 1;
    }
    put("scan ");
    put_u32(info.width);
    put("x");
    put_u32(info.height);
    put(", ");
    put_u32(info.images);
    put(" images, band ");
    put_u32(info.band_rows);
    put(" rows\n");

    /* The wrong sample size is refused, not decoded. */
    const uint8_t *rows8[MAX_IMAGES] = {0};
    s = fringe3d_decode_row_u8(&head, rows8, info.images, info.width, phase, 0, 0, validity);
    put("u8_rows=");
    put(fringe3d_status_name(s));
    put("\n");

    int frames = semihost_open("input/images.u16");
    int map_file = semihost_open("input/reference_phase.f32");
    if (frames < 0 || map_file < 0) {
        put("fringe3d-head-c: cannot open the frames or the map\n");
        return 1;
    }

    /* 2a. The map in place (memory-mapped): its file, checked whole (CRC) before use; a damaged
     * or short one is refused (here: the file one byte short). */
    fringe3d_reference reference;
    size_t map_file_len = 32 + 4 * (size_t)info.map_width * info.map_height + 4;
    if (map_file_len > MAP_CAPACITY) {
        put("fringe3d-head-c: the map file does not fit the mapped region\n");
        return 1;
    }
    s = fringe3d_reference_map_file(&reference, &head, MAP_FILE, map_file_len - 1);
    put_status("", "short_map_file=", s);
    if (s != FRINGE3D_ERR_REFERENCE) return 1;
    s = fringe3d_reference_map_file(&reference, &head, MAP_FILE, map_file_len);
    if (s != FRINGE3D_OK) return fail("reference map", s);
    if (scan("map", &info, &reference, frames, -1, -1) != 0) return 1;

    /* 2b. The map streamed through a ring of the band's rows. */
    s = fringe3d_reference_ring(&reference, &head, ring_storage,
                                (size_t)info.band_rows * info.map_width, 0);
    if (s != FRINGE3D_OK) return fail("reference ring", s);
    if (scan("ring", &info, &reference, frames, map_file, -1) != 0) return 1;

    /* 2c. The compiled reconstruction, if the folder has one: its models row by row, the
     * search over the map in place for the pixels they leave. */
    int compiled_file = semihost_open("input/compiled.f3c");
    if (compiled_file >= 0) {
        s = fringe3d_reference_map_file(&reference, &head, MAP_FILE, map_file_len);
        if (s != FRINGE3D_OK) return fail("reference map", s);
        if (scan("compiled", &info, &reference, frames, -1, compiled_file) != 0) return 1;
    }

    put("sram_bytes=");
    put_u32(sram_high_water());
    put("\n");
    return 0;
}

/* The library is linked with its `no-panic` feature (the link would fail if a panic path were
 * left); this is what a firmware provides otherwise. */
void fringe3d_panic(void) {
    put("fringe3d-head-c: panic\n");
    semihost_exit(0);
}
