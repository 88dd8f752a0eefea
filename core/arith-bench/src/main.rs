//! The decoding kernel of every arithmetic backend on a Cortex-M under QEMU.
//!
//! Commands (semihosting command line, after the program name):
//! * `parity` — print `default <backend>` (the target's [`TargetDefault`]), then
//!   `parity <backend> <case> <digest>` for every backend and case of
//!   [`fringe3d_core::decode::parity`]; the host compares them with its own digests.
//!   and `compiled <digest>` for the compiled reconstruction's row
//!   ([`fringe3d_core::reconstruct::compiled::parity`]).
//! * `count <backend> <case> <reps>` — decode the case's row `reps` times with the backend and
//!   print its digest. Instructions per pixel are the difference of the instruction counts of
//!   `reps = R` and `reps = 0` (QEMU plugin `qemu/insn_count.c`) over `R·WIDTH` pixels.
//! * `count-compiled <reps>` — the same for the compiled reconstruction's row.
//! * `count-compiled-bytes <reps>` — the same row as a scan head runs it from its store: its
//!   models taken from their bytes first ([`compiled::run_from_bytes`]).
//! * `count-compiled-settle <reps>` — the same, the row settled after the conversion (a head's
//!   first scan of newly uploaded models).
#![no_std]
#![no_main]

use core::fmt::Write;
use cortex_m_rt::entry;
use cortex_m_semihosting::{debug, hio};
use fringe3d_core::arith::{Arith, Backend, TargetDefault};
use fringe3d_core::decode::parity;
use fringe3d_core::hdr_parity;
use fringe3d_core::reconstruct::compiled::parity as compiled;

/// SYS_GET_CMDLINE: the command line QEMU was given (`-semihosting-config arg=…`).
fn cmdline(buf: &mut [u8]) -> &str {
    let mut block = [buf.as_mut_ptr() as usize, buf.len()];
    // SAFETY: semihosting call 0x15 with a parameter block of (buffer, length); the host writes at
    // most `length` bytes into the buffer and the used length into the block.
    let r = unsafe { cortex_m_semihosting::syscall1(0x15, block.as_mut_ptr() as usize) };
    if r != 0 {
        return "";
    }
    let n = block[1].min(buf.len());
    core::str::from_utf8(&buf[..n]).unwrap_or("")
}

fn run(out: &mut hio::HostStream, args: &str) -> Result<(), &'static str> {
    let mut w = args.split_ascii_whitespace().skip(1);
    match w.next() {
        Some("parity") => {
            let _ = writeln!(out, "default {}", <TargetDefault as Arith>::NAME);
            for b in Backend::ALL {
                for case in 0..parity::CASES {
                    let d = parity::digest(b, case).map_err(|_| "decoder refused a parity case")?;
                    let _ = writeln!(out, "parity {} {} {:016x}", b.name(), case, d);
                }
            }
            for b in Backend::ALL {
                let d = hdr_parity::digest(b).map_err(|_| "the HDR parity case failed")?;
                let _ = writeln!(out, "hdr {} {:016x}", b.name(), d);
            }
            let _ = writeln!(out, "compiled {:016x}", compiled::run(1));
            Ok(())
        }
        Some("count") => {
            let b = w
                .next()
                .and_then(Backend::from_name)
                .ok_or("count: unknown backend")?;
            let case: usize = w
                .next()
                .and_then(|s| s.parse().ok())
                .filter(|c| *c < parity::CASES)
                .ok_or("count: bad case")?;
            let reps: u32 = w
                .next()
                .and_then(|s| s.parse().ok())
                .ok_or("count: bad repetitions")?;
            let d = parity::run(b, case, reps, false).map_err(|_| "decoder refused the case")?;
            let _ = writeln!(out, "count {} {} {} {:016x}", b.name(), case, reps, d);
            Ok(())
        }
        Some("count-compiled") => {
            let reps: u32 = w
                .next()
                .and_then(|s| s.parse().ok())
                .ok_or("count-compiled: bad repetitions")?;
            let _ = writeln!(out, "count-compiled {} {:016x}", reps, compiled::run(reps));
            Ok(())
        }
        Some(cmd @ ("count-compiled-bytes" | "count-compiled-settle")) => {
            let reps: u32 = w
                .next()
                .and_then(|s| s.parse().ok())
                .ok_or("count-compiled-bytes/settle: bad repetitions")?;
            let d = compiled::run_from_bytes(reps, cmd == "count-compiled-settle");
            let _ = writeln!(out, "{} {} {:016x}", cmd, reps, d);
            Ok(())
        }
        _ => Err(
            "usage: parity | count <backend> <case> <reps> | count-compiled <reps> \
             | count-compiled-bytes <reps> | count-compiled-settle <reps>",
        ),
    }
}

#[entry]
fn main() -> ! {
    let mut buf = [0u8; 256];
    let args = cmdline(&mut buf);
    let mut out = hio::hstdout().unwrap_or_else(|_| halt(debug::EXIT_FAILURE));
    match run(&mut out, args) {
        Ok(()) => halt(debug::EXIT_SUCCESS),
        Err(e) => {
            let _ = writeln!(out, "error: {e} (command line {args:?})");
            halt(debug::EXIT_FAILURE)
        }
    }
}

/// Stop the emulator with `status` (semihosting SYS_EXIT; QEMU ends at the first call).
fn halt(status: debug::ExitStatus) -> ! {
    loop {
        debug::exit(status);
    }
}

#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    if let Ok(mut out) = hio::hstdout() {
        let _ = writeln!(out, "panic: {info}");
    }
    halt(debug::EXIT_FAILURE)
}
