/* ARM semihosting (bkpt 0xAB, served by QEMU's -semihosting-config enable=on): the golden
 * vectors' files and the console. On a real head these are the frame store and a debug UART. */
#ifndef SEMIHOST_H
#define SEMIHOST_H

#include <stddef.h>
#include <stdint.h>

/* Open a host file for binary reading; a handle, or -1. */
int semihost_open(const char *path);
/* Its length in bytes, or -1. */
long semihost_length(int handle);
/* Read len bytes from byte offset on; 0 on success. */
int semihost_read_at(int handle, size_t offset, void *buf, size_t len);
void semihost_close(int handle);
void semihost_print(const char *s);
/* Stop QEMU, exit status 0 if ok, else 1. */
void semihost_exit(int ok) __attribute__((noreturn));

#endif
