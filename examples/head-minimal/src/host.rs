//! ARM semihosting (`bkpt 0xAB`, served by QEMU's `-semihosting-config enable=on`): the files of
//! the golden vectors and the console. On a real head, [`File::read_at`] is the frame store (the
//! camera's frames, the reference map in flash) and [`print`] a debug UART.

use core::arch::asm;

/// One semihosting call: operation `op`, parameter block at `arg`.
fn call(op: u32, arg: usize) -> i32 {
    let mut r0 = op;
    // SAFETY: the trap reads r0/r1 and the block r1 points to (alive for the call), writes r0.
    unsafe { asm!("bkpt 0xAB", inout("r0") r0, in("r1") arg, options(nostack)) };
    r0 as i32
}

/// A file of the host, open for binary reading.
pub struct File(usize);

impl File {
    /// Open `path` (relative to QEMU's working folder, at most 63 bytes).
    pub fn open(path: &str) -> Result<File, &'static str> {
        let mut name = [0u8; 64];
        let n = path.len().min(name.len() - 1);
        name[..n].copy_from_slice(&path.as_bytes()[..n]);
        let h = call(
            0x01,
            [name.as_ptr() as usize, 1 /* "rb" */, n].as_ptr() as usize,
        );
        if h < 0 {
            Err("cannot open a vectors file")
        } else {
            Ok(File(h as usize))
        }
    }

    /// Length in bytes.
    pub fn len(&self) -> usize {
        call(0x0C, [self.0].as_ptr() as usize).max(0) as usize
    }

    /// Fill `buf` from byte `offset` of the file on.
    pub fn read_at(&mut self, offset: usize, buf: &mut [u8]) -> Result<(), &'static str> {
        let seek = call(0x0A, [self.0, offset].as_ptr() as usize);
        let left = call(
            0x06,
            [self.0, buf.as_mut_ptr() as usize, buf.len()].as_ptr() as usize,
        );
        if seek == 0 && left == 0 {
            Ok(())
        } else {
            Err("short read")
        }
    }
}

impl Drop for File {
    fn drop(&mut self) {
        call(0x02, [self.0].as_ptr() as usize);
    }
}

/// Print `s` on the host's console.
pub fn print(s: &str) {
    let mut buf = [0u8; 128];
    for chunk in s.as_bytes().chunks(buf.len() - 1) {
        buf[..chunk.len()].copy_from_slice(chunk);
        buf[chunk.len()] = 0;
        call(0x04, buf.as_ptr() as usize);
    }
}

/// `write!` on the host's console.
pub struct Console;

impl core::fmt::Write for Console {
    fn write_str(&mut self, s: &str) -> core::fmt::Result {
        print(s);
        Ok(())
    }
}

/// Stop QEMU: exit status 0 if `ok`, else 1.
pub fn exit(ok: bool) -> ! {
    loop {
        call(0x18, if ok { 0x20026 } else { 0x20023 });
    }
}
