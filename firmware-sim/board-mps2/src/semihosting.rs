//! ARM semihosting (`bkpt 0xAB`): the files of the golden vectors on the host (read, and the
//! records file written), the text console and the exit code. QEMU serves them with `-semihosting-config enable=on,target=native`.
//!
//! On a real head the same calls would be a debug probe's; here they stand for the external
//! memory the frames live in (see `main.rs`).

use core::arch::asm;

const SYS_OPEN: u32 = 0x01;
const SYS_CLOSE: u32 = 0x02;
const SYS_WRITE0: u32 = 0x04;
const SYS_WRITE: u32 = 0x05;
const SYS_SEEK: u32 = 0x0A;
const SYS_FLEN: u32 = 0x0C;
const SYS_READ: u32 = 0x06;
const SYS_GET_CMDLINE: u32 = 0x15;
const SYS_EXIT: u32 = 0x18;
/// `ADP_Stopped_ApplicationExit`: QEMU exits with status 0.
const EXIT_OK: u32 = 0x20026;
/// `ADP_Stopped_RunTimeErrorUnknown`: QEMU exits with status 1.
const EXIT_FAIL: u32 = 0x20023;

/// One semihosting call: operation `op`, argument `arg` (usually a pointer to a parameter block).
///
/// # Safety
/// `arg` must be what the operation expects (a valid parameter block for its lifetime).
unsafe fn call(op: u32, arg: usize) -> i32 {
    let mut r0 = op;
    // SAFETY: the semihosting trap reads r0/r1 and the memory r1 points to, writes r0.
    unsafe {
        asm!("bkpt 0xAB", inout("r0") r0, in("r1") arg, options(nostack));
    }
    r0 as i32
}

/// An open host file.
pub struct File {
    handle: i32,
}

/// A semihosting failure: which call, on which path.
#[derive(Clone, Copy, Debug)]
pub struct HostError {
    /// What failed.
    pub what: &'static str,
}

impl File {
    /// Open `path` (at most 255 bytes) for binary reading.
    pub fn open(path: &str) -> Result<File, HostError> {
        Self::open_mode(path, 1 /* "rb" */, "cannot open a vectors file")
    }

    /// Create (or truncate) `path` (at most 255 bytes) for binary writing.
    pub fn create(path: &str) -> Result<File, HostError> {
        Self::open_mode(path, 5 /* "wb" */, "cannot create the records file")
    }

    fn open_mode(path: &str, mode: usize, fail: &'static str) -> Result<File, HostError> {
        let mut name = [0u8; 256];
        let b = path.as_bytes();
        if b.len() >= name.len() {
            return Err(HostError {
                what: "path too long",
            });
        }
        name[..b.len()].copy_from_slice(b);
        let block = [name.as_ptr() as usize, mode, b.len()];
        // SAFETY: the block holds a NUL-terminated name and its length, alive during the call.
        let h = unsafe { call(SYS_OPEN, block.as_ptr() as usize) };
        if h < 0 {
            Err(HostError { what: fail })
        } else {
            Ok(File { handle: h })
        }
    }

    /// Length in bytes.
    pub fn len(&self) -> Result<usize, HostError> {
        let block = [self.handle as usize];
        // SAFETY: a one-word block with the handle.
        let n = unsafe { call(SYS_FLEN, block.as_ptr() as usize) };
        if n < 0 {
            Err(HostError {
                what: "cannot size a vectors file",
            })
        } else {
            Ok(n as usize)
        }
    }

    /// Fill `buf` from byte `offset` on.
    pub fn read_at(&mut self, offset: usize, buf: &mut [u8]) -> Result<(), HostError> {
        let block = [self.handle as usize, offset];
        // SAFETY: handle and absolute position.
        if unsafe { call(SYS_SEEK, block.as_ptr() as usize) } != 0 {
            return Err(HostError {
                what: "seek failed",
            });
        }
        let block = [self.handle as usize, buf.as_mut_ptr() as usize, buf.len()];
        // SAFETY: the buffer is valid for writes of its length during the call.
        let left = unsafe { call(SYS_READ, block.as_ptr() as usize) };
        if left != 0 {
            Err(HostError { what: "short read" })
        } else {
            Ok(())
        }
    }

    /// Append `buf` (one `SYS_WRITE` call: the host writes it whole, or fails).
    pub fn write_all(&mut self, buf: &[u8]) -> Result<(), HostError> {
        let block = [self.handle as usize, buf.as_ptr() as usize, buf.len()];
        // SAFETY: the buffer is valid for reads of its length during the call.
        let left = unsafe { call(SYS_WRITE, block.as_ptr() as usize) };
        if left != 0 {
            Err(HostError {
                what: "short write to the records file",
            })
        } else {
            Ok(())
        }
    }
}

impl Drop for File {
    fn drop(&mut self) {
        let block = [self.handle as usize];
        // SAFETY: a one-word block with the handle.
        unsafe {
            call(SYS_CLOSE, block.as_ptr() as usize);
        }
    }
}

/// The command line QEMU passes (`-semihosting-config arg=...`), into `buf`; returns its length.
pub fn cmdline(buf: &mut [u8]) -> usize {
    let block = [buf.as_mut_ptr() as usize, buf.len()];
    // SAFETY: the buffer is valid for writes of its length; the host writes the used length back.
    let r = unsafe { call(SYS_GET_CMDLINE, block.as_ptr() as usize) };
    if r != 0 {
        return 0;
    }
    let n = block[1].min(buf.len());
    buf[..n].iter().position(|&c| c == 0).unwrap_or(n)
}

/// Print `s` on the host console (in pieces of at most 255 bytes).
pub fn print(s: &str) {
    let mut buf = [0u8; 256];
    for chunk in s.as_bytes().chunks(buf.len() - 1) {
        buf[..chunk.len()].copy_from_slice(chunk);
        buf[chunk.len()] = 0;
        // SAFETY: a NUL-terminated string alive during the call.
        unsafe {
            call(SYS_WRITE0, buf.as_ptr() as usize);
        }
    }
}

/// A `core::fmt::Write` on the host console.
pub struct Console;

impl core::fmt::Write for Console {
    fn write_str(&mut self, s: &str) -> core::fmt::Result {
        print(s);
        Ok(())
    }
}

/// Stop the emulator: exit status 0 if `ok`, else 1.
pub fn exit(ok: bool) -> ! {
    loop {
        // SAFETY: SYS_EXIT takes the reason code in r1 directly (AArch32).
        unsafe {
            call(SYS_EXIT, if ok { EXIT_OK } else { EXIT_FAIL } as usize);
        }
    }
}
