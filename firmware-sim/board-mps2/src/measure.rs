//! Measurements: an instruction counter (CMSDK timer under QEMU `-icount`), the stack high-water
//! mark (painted stack), and the flash and static RAM the linker laid out.

use core::arch::asm;
use core::ptr::{read_volatile, write_volatile};

/// CMSDK APB timer 0 of AN385/AN386, clocked at 25 MHz (SYSCLK).
const TIMER0: usize = 0x4000_0000;
const CTRL: usize = 0x00;
const VALUE: usize = 0x04;
const RELOAD: usize = 0x08;

/// A free-running 32-bit down-counter on timer 0.
///
/// Under `qemu-system-arm -icount shift=0` the virtual clock advances exactly 1 ns per executed
/// guest instruction, so the 25 MHz timer ticks once per 40 instructions: ticks are an
/// instruction count with a resolution of 40. [`Counter::calibrate`] checks the ratio against a
/// loop of known length. Without `-icount` the ticks follow host time and mean nothing.
pub struct Counter;

impl Counter {
    /// Start timer 0 from `u32::MAX`, counting down, no interrupt.
    pub fn start() -> Counter {
        // SAFETY: timer 0's registers; nothing else uses the timer.
        unsafe {
            write_volatile((TIMER0 + CTRL) as *mut u32, 0);
            write_volatile((TIMER0 + RELOAD) as *mut u32, u32::MAX);
            write_volatile((TIMER0 + VALUE) as *mut u32, u32::MAX);
            write_volatile((TIMER0 + CTRL) as *mut u32, 1);
        }
        Counter
    }

    /// The counter (decreasing).
    #[inline(always)]
    pub fn now(&self) -> u32 {
        // SAFETY: a read of timer 0's value register.
        unsafe { read_volatile((TIMER0 + VALUE) as *const u32) }
    }

    /// Ticks since `then` (a value of [`Counter::now`]).
    #[inline(always)]
    pub fn since(&self, then: u32) -> u32 {
        then.wrapping_sub(self.now())
    }

    /// Run a loop of exactly `2·n` instructions (`subs`, `bne`) and return the ticks it took.
    pub fn calibrate(&self, n: u32) -> u32 {
        let t0 = self.now();
        // SAFETY: a register-only loop.
        unsafe {
            asm!(
                "2:",
                "subs {n}, {n}, #1",
                "bne 2b",
                n = inout(reg) n.max(1) => _,
                options(nomem, nostack),
            );
        }
        self.since(t0)
    }
}

unsafe extern "C" {
    static _stack_start: u32;
    static _stack_end: u32;
    static __sdata: u32;
    static __edata: u32;
    static __euninit: u32;
    static __erodata: u32;
}

const PAINT: u32 = 0xC0FF_EE55;

fn addr(s: &u32) -> usize {
    s as *const u32 as usize
}

/// The linker's layout: flash and static RAM, bytes.
#[derive(Clone, Copy, Debug)]
pub struct Layout {
    /// Flash (ZBT SSRAM1 image): vector table, code, read-only data, the initial values of `.data`.
    pub flash: usize,
    /// `.data` + `.bss` + `.uninit`.
    pub static_ram: usize,
    /// Bytes between the end of static RAM and the top of RAM: the stack's room.
    pub stack_room: usize,
}

/// The current layout.
pub fn layout() -> Layout {
    // SAFETY: only the addresses of linker symbols are taken.
    unsafe {
        let data = addr(&__edata) - addr(&__sdata);
        Layout {
            flash: addr(&__erodata) + data,
            static_ram: addr(&__euninit) - addr(&__sdata),
            stack_room: addr(&_stack_start) - addr(&_stack_end),
        }
    }
}

#[inline(always)]
fn sp() -> usize {
    let sp: usize;
    // SAFETY: reads the stack pointer.
    unsafe { asm!("mov {}, sp", out(reg) sp, options(nomem, nostack, preserves_flags)) };
    sp
}

/// Fill the unused stack (from the end of static RAM up to a little below the current stack
/// pointer) with a pattern.
#[inline(never)]
pub fn paint_stack() {
    // SAFETY: addresses of linker symbols; the painted words lie below the live stack (a 256-byte
    // margin under this function's own frame) and above all statics.
    unsafe {
        let lo = addr(&_stack_end);
        let hi = sp() - 256;
        let mut p = lo;
        while p < hi {
            write_volatile(p as *mut u32, PAINT);
            p += 4;
        }
    }
}

/// Bytes of stack ever used since [`paint_stack`]: the top of RAM minus the lowest overwritten word.
pub fn stack_high_water() -> usize {
    // SAFETY: reads words of the unused stack region painted by `paint_stack`.
    unsafe {
        let lo = addr(&_stack_end);
        let top = addr(&_stack_start);
        let mut p = lo;
        while p < top && read_volatile(p as *const u32) == PAINT {
            p += 4;
        }
        top - p
    }
}
