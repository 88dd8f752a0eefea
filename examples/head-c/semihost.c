/* ARM semihosting calls (semihost.h). */
#include "semihost.h"

static size_t length(const char *s) {
    size_t n = 0;
    while (s[n]) n++;
    return n;
}

static int call(int op, const void *arg) {
    register int r0 __asm__("r0") = op;
    register const void *r1 __asm__("r1") = arg;
    __asm volatile("bkpt 0xAB" : "+r"(r0) : "r"(r1) : "memory");
    return r0;
}

int semihost_open(const char *path) {
    const uintptr_t block[3] = {(uintptr_t)path, 1 /* "rb" */, length(path)};
    return call(0x01, block);
}

long semihost_length(int handle) {
    const uintptr_t block[1] = {(uintptr_t)handle};
    return call(0x0C, block);
}

int semihost_read_at(int handle, size_t offset, void *buf, size_t len) {
    const uintptr_t seek[2] = {(uintptr_t)handle, offset};
    const uintptr_t read[3] = {(uintptr_t)handle, (uintptr_t)buf, len};
    if (call(0x0A, seek) != 0) return -1;
    return call(0x06, read) == 0 ? 0 : -1; /* returns the bytes NOT read */
}

void semihost_close(int handle) {
    const uintptr_t block[1] = {(uintptr_t)handle};
    call(0x02, block);
}

void semihost_print(const char *s) { call(0x04, s); }

void semihost_exit(int ok) {
    /* SYS_EXIT with ADP_Stopped_ApplicationExit (0x20026) or ADP_Stopped_RunTimeErrorUnknown. */
    for (;;) call(0x18, (const void *)(uintptr_t)(ok ? 0x20026 : 0x20023));
}
