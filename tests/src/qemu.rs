//! Building and finding the QEMU firmware (`firmware-sim/board-mps2`, its own workspace) for the
//! tests that run it under `qemu-system-arm` (`qemu_firmware.rs`, `qemu_head_pty.rs`).

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

/// The board crate, relative to the repository.
pub const BOARD: &str = "firmware-sim/board-mps2";
/// The firmware's target: QEMU `mps2-an386` is a Cortex-M4F.
pub const TARGET: &str = "thumbv7em-none-eabihf";

/// The repository's root folder.
pub fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .map(Path::to_path_buf)
        .unwrap_or_else(|| PathBuf::from(".."))
}

/// Why the QEMU tests cannot run here, if they cannot: `qemu-system-arm` or the
/// `thumbv7em-none-eabihf` target missing.
pub fn missing_tools() -> Option<String> {
    match Command::new("qemu-system-arm")
        .arg("--version")
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
    {
        Ok(s) if s.success() => {}
        _ => {
            return Some(
                "qemu-system-arm is not installed (Debian: apt-get install qemu-system-arm)".into(),
            );
        }
    }
    let Ok(sysroot) = Command::new("rustc").args(["--print", "sysroot"]).output() else {
        return Some("rustc is not on PATH".into());
    };
    let root = String::from_utf8_lossy(&sysroot.stdout).trim().to_string();
    if !Path::new(&root).join("lib/rustlib").join(TARGET).exists() {
        return Some(format!(
            "the {TARGET} target is not installed (rustup target add {TARGET})"
        ));
    }
    None
}

/// Skip a QEMU test with a notice when the tools are missing — or fail when the environment
/// variable `FRINGE3D_REQUIRE_QEMU` is set (CI sets it: there a skip would hide a failure).
/// Returns `true` when the test should return early.
pub fn skip_without_tools(test: &str) -> bool {
    let Some(why) = missing_tools() else {
        return false;
    };
    assert!(
        std::env::var_os("FRINGE3D_REQUIRE_QEMU").is_none(),
        "FRINGE3D_REQUIRE_QEMU is set but {why}"
    );
    println!("SKIPPED {test}: {why}");
    true
}

/// The board crate's target folder: `<this build's target dir>/board-mps2` (what `.ci/run` and
/// the board's `.cargo/config.toml` use for the default target dir).
pub fn board_target_dir() -> PathBuf {
    if let Some(d) = std::env::var_os("CARGO_TARGET_DIR") {
        return PathBuf::from(d).join("board-mps2");
    }
    // target/<profile>/deps/<this test> → target
    std::env::current_exe()
        .ok()
        .and_then(|exe| exe.ancestors().nth(3).map(|t| t.join("board-mps2")))
        .unwrap_or_else(|| repo().join("target/board-mps2"))
}

/// The `--config` that makes the firmware's bytes independent of where the checkout and the cargo
/// home are. The panic locations in `.rodata` name source files, and cargo hands rustc absolute
/// paths for the crates outside the board's workspace (the core, registry crates); remapped to
/// `/fringe3d` and `/cargo`, the flash the firmware reports is the same on every machine and
/// docs/firmware.md's figures reproduce. `tools/firmware_figures.py` builds with the same flags
/// (`path_independent_config`), so it and these tests share one build.
pub fn path_independent_config() -> String {
    let cargo_home = std::env::var_os("CARGO_HOME")
        .map(PathBuf::from)
        .or_else(|| std::env::var_os("HOME").map(|h| PathBuf::from(h).join(".cargo")))
        .unwrap_or_else(|| PathBuf::from("/root/.cargo"));
    let quote = |s: String| format!("\"{}\"", s.replace('\\', "\\\\").replace('"', "\\\""));
    let flags = [
        quote(format!(
            "--remap-path-prefix={}=/fringe3d",
            repo().display()
        )),
        quote(format!(
            "--remap-path-prefix={}=/cargo",
            cargo_home.display()
        )),
    ];
    format!("target.{TARGET}.rustflags=[{}]", flags.join(", "))
}

/// Build the board crate's binary `bin` (release, for [`TARGET`]) and return the ELF's path.
/// Panics with cargo's output when the build fails (these are test helpers).
pub fn build_firmware(bin: &str) -> PathBuf {
    let target_dir = board_target_dir();
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let out = Command::new(cargo)
        .args(["build", "--release", "--target", TARGET, "--bin", bin])
        .arg("--config")
        .arg(path_independent_config())
        .current_dir(repo().join(BOARD))
        .env("CARGO_TARGET_DIR", &target_dir)
        .env_remove("RUSTFLAGS")
        .env_remove("CARGO_ENCODED_RUSTFLAGS")
        .env_remove("CARGO_BUILD_TARGET")
        .output()
        .expect("run cargo for the firmware");
    assert!(
        out.status.success(),
        "firmware build failed:\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let elf = target_dir.join(TARGET).join("release").join(bin);
    assert!(elf.exists(), "no firmware at {}", elf.display());
    elf
}
