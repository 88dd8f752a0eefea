//! Building and finding the QEMU firmware (`firmware-sim/board-mps2`, its own workspace) for the
//! tests that run it under `qemu-system-arm` (`qemu_firmware.rs`, `qemu_head_pty.rs`).

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

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

/// Where the firmware is built from: a symbolic link to the checkout, at one path on every
/// machine. cargo hashes the absolute path of every crate outside the board's own workspace (the
/// core, the head) into the symbol names, which order what LLVM optimises and how the linker lays
/// out the code, so a build from the checkout's own path moves the flash by up to a kilobyte with
/// the path. Built from here, the flash image is the same byte for byte on any checkout path, and
/// `tools/firmware_figures.py` (its `CANON`) shares this build.
pub const CANON: &str = "/tmp/fringe3d-firmware-src";
/// The lock that serialises [`CANON`]'s re-pointing and the build between checkouts on one machine
/// (the same file as `tools/firmware_figures.py`'s `LOCK`).
const CANON_LOCK: &str = "/tmp/fringe3d-firmware-src.lock";

/// Point [`CANON`] at this checkout (atomically: a new link renamed over the old one).
fn point_canon(repo: &Path) -> std::io::Result<()> {
    let canon = Path::new(CANON);
    if std::fs::read_link(canon).is_ok_and(|t| t == repo) {
        return Ok(());
    }
    let tmp = PathBuf::from(format!("{CANON}.{}", std::process::id()));
    let _ = std::fs::remove_file(&tmp);
    #[cfg(unix)]
    {
        std::os::unix::fs::symlink(repo, &tmp)?;
        std::fs::rename(&tmp, canon)
    }
    #[cfg(not(unix))]
    Err(std::io::Error::new(
        std::io::ErrorKind::Unsupported,
        format!("no symbolic link for {}", canon.display()),
    ))
}

/// The `--config` that makes the firmware's bytes independent of where the checkout and the cargo
/// home are. The panic locations in `.rodata` and the debug lines name source files: by
/// [`CANON`]'s path for the crates the build reaches through it, by the real path for the working
/// directory, under the cargo home for registry crates; remapped to `/fringe3d` and `/cargo`, the
/// flash the firmware reports is the same on every machine and docs/firmware.md's figures
/// reproduce. `tools/firmware_figures.py` builds with the same flags (`path_independent_config`),
/// so it and these tests share one build.
pub fn path_independent_config() -> String {
    let cargo_home = std::env::var_os("CARGO_HOME")
        .map(PathBuf::from)
        .or_else(|| std::env::var_os("HOME").map(|h| PathBuf::from(h).join(".cargo")))
        .unwrap_or_else(|| PathBuf::from("/root/.cargo"));
    let quote = |s: String| format!("\"{}\"", s.replace('\\', "\\\\").replace('"', "\\\""));
    let flags = [
        quote(format!("--remap-path-prefix={CANON}=/fringe3d")),
        quote(format!(
            "--remap-path-prefix={}=/fringe3d",
            real_repo().display()
        )),
        quote(format!(
            "--remap-path-prefix={}=/cargo",
            cargo_home.display()
        )),
    ];
    format!("target.{TARGET}.rustflags=[{}]", flags.join(", "))
}

/// The checkout's physical path (symbolic links resolved), as the working directory rustc records.
fn real_repo() -> PathBuf {
    let repo = repo();
    std::fs::canonicalize(&repo).unwrap_or(repo)
}

/// Build the board crate's binary `bin` (release, for [`TARGET`]) and return the ELF's path.
/// Panics with cargo's output when the build fails (these are test helpers).
pub fn build_firmware(bin: &str) -> PathBuf {
    let target_dir = board_target_dir();
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let board = Path::new(CANON).join(BOARD);
    let lock = std::fs::File::create(CANON_LOCK).expect("create the firmware build's lock file");
    lock.lock().expect("take the firmware build's lock");
    if let Err(e) = point_canon(&real_repo()) {
        panic!("cannot point {CANON} at the checkout: {e}");
    }
    let out = Command::new(cargo)
        .args(["build", "--release", "--target", TARGET, "--bin", bin])
        .arg("--manifest-path")
        .arg(board.join("Cargo.toml"))
        .arg("--config")
        .arg(path_independent_config())
        .current_dir(&board)
        .env("CARGO_TARGET_DIR", &target_dir)
        .env_remove("RUSTFLAGS")
        .env_remove("CARGO_ENCODED_RUSTFLAGS")
        .env_remove("CARGO_BUILD_TARGET")
        .output()
        .expect("run cargo for the firmware");
    drop(lock);
    assert!(
        out.status.success(),
        "firmware build failed:\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let elf = target_dir.join(TARGET).join("release").join(bin);
    assert!(elf.exists(), "no firmware at {}", elf.display());
    elf
}

/// Run the bare-metal ELF `elf` on QEMU `mps2-an386` in the golden-vectors folder `dir`
/// (semihosting reads its files) with the folder's reference map loaded into the board's PSRAM
/// at `0x2100_0000` (a memory-mapped map, as `examples/head-minimal` and `examples/head-c` read
/// it); returns its console output. Panics if it fails or runs longer than 300 s.
pub fn run_in_vectors(elf: &Path, dir: &Path) -> String {
    let mut child = Command::new("qemu-system-arm")
        .args(["-M", "mps2-an386", "-cpu", "cortex-m4", "-display", "none"])
        .args(["-monitor", "none"])
        .args(["-semihosting-config", "enable=on,target=native"])
        .args([
            "-device",
            "loader,file=input/reference.f3m,addr=0x21000000,force-raw=on",
        ])
        .arg("-kernel")
        .arg(elf)
        .current_dir(dir)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("start qemu-system-arm");
    let deadline = Instant::now() + Duration::from_secs(300);
    while child.try_wait().expect("wait for qemu").is_none() {
        if Instant::now() > deadline {
            let _ = child.kill();
            let _ = child.wait();
            panic!("{} did not finish within 300 s", elf.display());
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    let out = child.wait_with_output().expect("qemu output");
    let console =
        String::from_utf8_lossy(&out.stdout).to_string() + &String::from_utf8_lossy(&out.stderr);
    assert!(
        out.status.success(),
        "{} failed ({}):\n{console}",
        elf.display(),
        out.status
    );
    console
}

/// The value of `key=value` in a console output (the first one).
pub fn console_value<'a>(console: &'a str, key: &str) -> Option<&'a str> {
    console
        .split_whitespace()
        .find_map(|kv| kv.strip_prefix(key)?.strip_prefix('='))
}

/// Check the digests a head example printed in `console` (`phase=… validity=… points=…
/// point_validity=…`, FNV-1a 64 as `fringe3d_core::digest::Digest`) against the golden
/// files of the vectors folder `dir`, the points those of its folder `points` (`reconstruct`,
/// or `compiled` for the compiled reconstruction); `what` names the run in a failure.
pub fn assert_golden_digests(console: &str, dir: &Path, points: &str, what: &str) {
    for (key, path) in [
        ("phase", "decode/phase.f32".to_string()),
        ("validity", "decode/validity.u8".to_string()),
        ("points", format!("{points}/points.f32")),
        ("point_validity", format!("{points}/validity.u8")),
    ] {
        let mut d = fringe3d_core::digest::Digest::default();
        d.bytes(&std::fs::read(dir.join(&path)).expect("golden file"));
        let want = format!("{:016x}", d.0);
        assert_eq!(
            console_value(console, key),
            Some(want.as_str()),
            "{what}: {path} differs"
        );
    }
}
