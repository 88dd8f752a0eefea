//! Stack measurement by painting: fill the free stack below the caller with a pattern, run the
//! call, and find the lowest word it overwrote.

use core::arch::asm;
use core::ptr::{read_volatile, write_volatile};

const PAINT: u32 = 0xC0FF_EE55;
/// How deep below the caller's stack pointer to paint (more than any call here needs).
const DEPTH: usize = 48 * 1024;

/// Run `f` and return its result and the bytes of stack it used below the caller's frame
/// (`DEPTH` or more if it ran past the painted region).
#[inline(always)]
pub fn measure<R>(f: impl FnOnce() -> R) -> (R, usize) {
    let sp: usize;
    // SAFETY: reads the stack pointer.
    unsafe { asm!("mov {}, sp", out(reg) sp, options(nomem, nostack, preserves_flags)) };
    let lo = sp - DEPTH;
    paint(lo, sp - 256);
    let r = f();
    let mut p = lo;
    // SAFETY: words of the free stack below our frame, painted above.
    while p < sp && unsafe { read_volatile(p as *const u32) } == PAINT {
        p += 4;
    }
    (r, sp - p)
}

/// Paint the words `lo..hi` (below the live stack: `hi` is 256 bytes under the caller's frame).
#[inline(never)]
fn paint(lo: usize, hi: usize) {
    let mut p = lo;
    while p < hi {
        // SAFETY: free stack between the statics and the live frames (the caller's check).
        unsafe { write_volatile(p as *mut u32, PAINT) };
        p += 4;
    }
}
