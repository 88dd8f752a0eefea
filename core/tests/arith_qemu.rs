//! Bit parity between x86-64 and Cortex-M for every arithmetic backend (and the compiled
//! reconstruction's row, `reconstruct::compiled::parity`): builds `core/arith-bench`
//! for thumbv7m-none-eabi (Cortex-M3, no FPU) and thumbv7em-none-eabihf (Cortex-M4F), runs its
//! `parity` command under `qemu-system-arm` (mps2-an385 / mps2-an386) and compares every digest
//! with the one computed here ([`fringe3d_core::decode::parity`]); checks the targets'
//! [`fringe3d_core::arith::TargetDefault`] too.
//!
//! Needs `qemu-system-arm` and the two rustup targets. Without QEMU, or for a target that is not
//! installed, it prints a notice and passes, checking what it can (`FRINGE3D_REQUIRE_QEMU=1` makes
//! that a failure, `FRINGE3D_SKIP_QEMU=1` skips the test). The first run builds the bench (a few
//! minutes; its crates come from crates.io).

use fringe3d_core::arith::Backend;
use fringe3d_core::decode::parity;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

fn skip(why: &str) {
    if std::env::var_os("FRINGE3D_REQUIRE_QEMU").is_some() {
        panic!("QEMU parity test cannot run: {why}");
    }
    eprintln!("note: skipping the QEMU parity test: {why}");
}

fn bench_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("arith-bench")
}

fn target_dir() -> PathBuf {
    Path::new(env!("CARGO_TARGET_TMPDIR")).join("arith-bench")
}

/// `cargo build --release` of the bench for `targets` at once.
///
/// With more codegen units and no debug info than the bench's own release profile (whose
/// instruction counts `run.sh` reports), and without the core's short-row path (no case has a
/// row narrower than 64 pixels; `--no-default-features`, see its Cargo.toml): the core is
/// rebuilt for each target at every change, and this more than halves that time in CI; the
/// digests must not depend on code generation anyway, which is what this test checks.
fn cargo_build(targets: &[&str]) -> std::io::Result<std::process::Output> {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let mut c = Command::new(cargo);
    c.current_dir(bench_dir()) // its .cargo/config.toml (linker script flags) applies
        .args(["build", "--release", "--no-default-features"]);
    for t in targets {
        c.args(["--target", t]);
    }
    c.args(["--config", "profile.release.codegen-units=16"])
        .args(["--config", "profile.release.debug=false"])
        .env("CARGO_TARGET_DIR", target_dir())
        .env_remove("RUSTFLAGS")
        .env_remove("CARGO_ENCODED_RUSTFLAGS")
        .env_remove("CARGO_BUILD_TARGET")
        .output()
}

/// Build the bench for `target`; `Err` with the reason when the toolchain lacks the target.
fn build(target: &str) -> Result<PathBuf, String> {
    let target_dir = target_dir();
    let out = cargo_build(&[target]).map_err(|e| format!("cannot run cargo: {e}"))?;
    if !out.status.success() {
        let err = String::from_utf8_lossy(&out.stderr);
        if err.contains("target may not be installed")
            || err.contains("can't find crate for `core`")
        {
            return Err(format!(
                "the {target} target is not installed (rustup target add {target})"
            ));
        }
        panic!("building core/arith-bench for {target} failed:\n{err}");
    }
    Ok(target_dir
        .join(target)
        .join("release")
        .join("fringe3d-arith-bench"))
}

/// Run the bench's `parity` command; its stdout.
fn run(machine: &str, cpu: &str, elf: &Path) -> String {
    let mut child = Command::new("qemu-system-arm")
        .args([
            "-machine",
            machine,
            "-cpu",
            cpu,
            "-nographic",
            "-monitor",
            "none",
            "-serial",
            "none",
        ])
        .args([
            "-semihosting-config",
            "enable=on,target=native,arg=bench,arg=parity",
            "-kernel",
        ])
        .arg(elf)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("qemu-system-arm starts");
    let start = Instant::now();
    loop {
        if let Some(status) = child.try_wait().expect("wait for qemu") {
            let out = child.wait_with_output().expect("qemu output");
            let text = String::from_utf8_lossy(&out.stdout).into_owned();
            assert!(
                status.success(),
                "{machine}: the bench failed ({status}):\n{text}\n{}",
                String::from_utf8_lossy(&out.stderr)
            );
            return text;
        }
        if start.elapsed() > Duration::from_secs(600) {
            let _ = child.kill();
            panic!("{machine}: the bench did not finish in 10 minutes");
        }
        std::thread::sleep(Duration::from_millis(100));
    }
}

#[test]
fn every_backend_gives_the_same_bits_on_cortex_m3_and_m4f() {
    if std::env::var_os("FRINGE3D_SKIP_QEMU").is_some() {
        return skip("FRINGE3D_SKIP_QEMU is set");
    }
    if Command::new("qemu-system-arm")
        .arg("--version")
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .is_err()
    {
        return skip("qemu-system-arm is not installed (apt-get install qemu-system-arm)");
    }
    let mut want = Vec::new();
    for b in Backend::ALL {
        for case in 0..parity::CASES {
            want.push(format!(
                "parity {} {} {:016x}",
                b.name(),
                case,
                parity::digest(b, case).unwrap()
            ));
        }
    }
    for b in Backend::ALL {
        want.push(format!(
            "hdr {} {:016x}",
            b.name(),
            fringe3d_core::hdr_parity::digest(b).unwrap()
        ));
    }
    want.push(format!(
        "compiled {:016x}",
        fringe3d_core::reconstruct::compiled::parity::run(1)
    ));
    let boards = [
        ("thumbv7m-none-eabi", "mps2-an385", "cortex-m3", "fixed"),
        ("thumbv7em-none-eabihf", "mps2-an386", "cortex-m4", "f32"),
    ];
    // Both targets in one cargo run first (its jobs share the cores); if that fails (a target
    // not installed), the per-target builds below say which.
    let _ = cargo_build(&boards.map(|b| b.0));
    for (target, machine, cpu, default) in boards {
        let elf = match build(target) {
            Ok(e) => e,
            Err(why) => {
                skip(&why);
                continue;
            }
        };
        let out = run(machine, cpu, &elf);
        let got: Vec<&str> = out
            .lines()
            .map(str::trim)
            .filter(|l| {
                l.starts_with("parity ") || l.starts_with("hdr ") || l.starts_with("compiled ")
            })
            .collect();
        assert_eq!(
            got.len(),
            want.len(),
            "{target}: expected {} digests, got:\n{out}",
            want.len()
        );
        for (g, w) in got.iter().zip(&want) {
            assert_eq!(g, w, "{target} ({machine}) differs from x86-64");
        }
        assert!(
            out.lines()
                .any(|l| l.trim() == format!("default {default}")),
            "{target}: TargetDefault should be {default}:\n{out}"
        );
        eprintln!(
            "{target} on {machine}: {} digests equal to x86-64's",
            got.len()
        );
    }
}
