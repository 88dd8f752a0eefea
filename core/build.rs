// Build-time probe of the compiler (no dependencies): sets `cfg(fringe3d_avx512)` when the target
// is x86-64 and rustc is 1.89 or newer, the first release where `#[target_feature(enable =
// "avx512f")]` and its run-time detection are stable. The workspace's MSRV (1.88) builds without
// the AVX-512 kernels; the host's dispatch then stops at AVX2. `host/build.rs` includes this file.

use std::process::Command;

fn main() {
    println!("cargo::rustc-check-cfg=cfg(fringe3d_avx512)");
    println!("cargo::rerun-if-changed=build.rs");
    let x86_64 = std::env::var("CARGO_CFG_TARGET_ARCH").is_ok_and(|a| a == "x86_64");
    let rustc = std::env::var("RUSTC").unwrap_or_else(|_| "rustc".into());
    // "rustc 1.95.0 (59807616e 2026-04-14)" → minor version 95.
    let minor = Command::new(rustc)
        .arg("--version")
        .output()
        .ok()
        .and_then(|o| String::from_utf8(o.stdout).ok())
        .and_then(|v| {
            v.split_whitespace()
                .nth(1)
                .and_then(|ver| ver.split('.').nth(1))
                .and_then(|m| m.parse::<u32>().ok())
        });
    if x86_64 && minor.is_some_and(|m| m >= 89) {
        println!("cargo::rustc-cfg=fringe3d_avx512");
    }
}
