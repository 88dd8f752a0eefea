//! Stack measurement by painting: fill the free stack below the caller with a pattern, run the
//! call, and find the lowest word it overwrote. The free stack is everything between the end of
//! the statics (`_stack_end`, cortex-m-rt's linker script) and the caller's frame, so a call that
//! needed more than there is would have overwritten the statics, and the deepest one sets the
//! program's SRAM high-water mark ([`sram_high_water`]).

use core::arch::asm;
use core::ptr::{addr_of, read_volatile, write_volatile};
use core::sync::atomic::{AtomicUsize, Ordering};

const PAINT: u32 = 0xC0FF_EE55;

unsafe extern "C" {
    /// First byte of RAM (`memory.x`'s `RAM` origin).
    static _ram_start: u32;
    /// End of the statics (.data, .bss, .uninit): the lowest address the stack may reach.
    static _stack_end: u32;
    /// Top of RAM, where the stack starts.
    static _stack_start: u32;
}

/// The lowest stack address any measured call wrote.
static LOWEST: AtomicUsize = AtomicUsize::new(usize::MAX);

/// Run `f` and return its result and the bytes of stack it used below the caller's frame.
#[inline(always)]
pub fn measure<R>(f: impl FnOnce() -> R) -> (R, usize) {
    let sp: usize;
    // SAFETY: reads the stack pointer.
    unsafe { asm!("mov {}, sp", out(reg) sp, options(nomem, nostack, preserves_flags)) };
    let lo = addr_of!(_stack_end) as usize;
    paint(lo, sp - 256);
    let r = f();
    let mut p = lo;
    // SAFETY: words of the free stack below our frame, painted above.
    while p < sp && unsafe { read_volatile(p as *const u32) } == PAINT {
        p += 4;
    }
    LOWEST.fetch_min(p.min(sp), Ordering::Relaxed);
    (r, sp - p)
}

/// Bytes of SRAM the program has used: its statics, and the stack from the top of RAM down to the
/// deepest word a measured call wrote (calls outside [`measure`] are shallower: printing and
/// file reads at `main`'s level).
pub fn sram_high_water() -> usize {
    let (ram, statics_end, top) = (
        addr_of!(_ram_start) as usize,
        addr_of!(_stack_end) as usize,
        addr_of!(_stack_start) as usize,
    );
    let lowest = LOWEST.load(Ordering::Relaxed).min(top);
    (statics_end - ram) + (top - lowest)
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
