//! The C ABI (`core/ffi`, `include/fringe3d.h`) in a C firmware (`examples/head-c`), compiled with
//! `arm-none-eabi-gcc` and run on an emulated Cortex-M4F (QEMU `mps2-an386`): it decodes and
//! reconstructs a golden-vector scan (the virtual reference, compiled to 1 µm) three times, with
//! the reference map read in place, streamed through a ring, and through the compiled models read
//! row by row (issue #24: the compiled reconstruction on the head), and each pass's FNV-1a
//! digests of phase, validity, points and point validity must equal those of the desktop's
//! golden files (`reconstruct/`, `compiled/`). The library is linked with its `no-panic`
//! feature, so the link itself shows that no panic path is left in what the firmware calls. The
//! example also shows two refusals: a damaged blob (with its reason) and rows of the wrong sample
//! size.
//!
//! Skips with a notice when `qemu-system-arm`, the `thumbv7em-none-eabihf` target or
//! `arm-none-eabi-gcc` is missing; `FRINGE3D_REQUIRE_QEMU=1` (set by `.ci/run`) turns the skip
//! into a failure.

use fringe3d::compiled::CompiledFile;
use fringe3d::vectors::{self, VectorOptions, VectorReference};
use fringe3d_tests::qemu::{
    TARGET, assert_golden_digests, board_target_dir, console_value as value, repo, run_in_vectors,
    skip_without_tools,
};
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// The C compiler for the Cortex-M4F.
const CC: &str = "arm-none-eabi-gcc";

fn check(out: Output, what: &str) {
    assert!(
        out.status.success(),
        "{what} failed:\n{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
}

/// Build the static library (release, `no-panic`, its own workspace and target folder, as
/// `.ci/run` builds it ahead) and return its path.
fn build_library() -> PathBuf {
    let target_dir = board_target_dir().with_file_name("ffi");
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let out = Command::new(cargo)
        .args([
            "build",
            "--release",
            "--target",
            TARGET,
            "--features",
            "no-panic",
        ])
        .current_dir(repo().join("core/ffi"))
        .env("CARGO_TARGET_DIR", &target_dir)
        .env_remove("RUSTFLAGS")
        .env_remove("CARGO_ENCODED_RUSTFLAGS")
        .env_remove("CARGO_BUILD_TARGET")
        .output()
        .expect("run cargo for the C ABI library");
    check(out, "the C ABI library's build");
    target_dir.join(TARGET).join("release/libfringe3d_ffi.a")
}

/// Compile and link the C example against `lib` into `elf` (the commands docs/integration.md
/// gives).
fn build_example(lib: &Path, elf: &Path) {
    let dir = repo().join("examples/head-c");
    let out = Command::new(CC)
        .args([
            "-mcpu=cortex-m4",
            "-mthumb",
            "-mfloat-abi=hard",
            "-mfpu=fpv4-sp-d16",
        ])
        .args([
            "-O2",
            "-std=c11",
            "-Wall",
            "-Wextra",
            "-Werror",
            "-ffreestanding",
        ])
        .args(["-ffunction-sections", "-fdata-sections"])
        .arg("-I")
        .arg(repo().join("core/ffi/include"))
        .args(["main.c", "semihost.c", "startup.c"])
        .arg(lib)
        .args([
            "-nostdlib",
            "-T",
            "link.ld",
            "-Wl,--gc-sections",
            "-Wl,-z,noexecstack",
        ])
        .args(["-lgcc", "-o"])
        .arg(elf)
        .current_dir(&dir)
        .output()
        .expect("run arm-none-eabi-gcc");
    check(
        out,
        "the C example's compile and link (a panic path left in the library fails it)",
    );
}

#[test]
fn c_firmware_matches_the_golden_vectors() {
    if skip_without_tools("c_firmware_matches_the_golden_vectors") {
        return;
    }
    if Command::new(CC).arg("--version").output().is_err() {
        assert!(
            std::env::var_os("FRINGE3D_REQUIRE_QEMU").is_none(),
            "FRINGE3D_REQUIRE_QEMU is set but {CC} is not installed"
        );
        println!(
            "SKIPPED c_firmware_matches_the_golden_vectors: {CC} is not installed (Debian: apt-get install gcc-arm-none-eabi)"
        );
        return;
    }
    let dir = std::env::temp_dir().join(format!("fringe3d-qemu-c-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let opts = VectorOptions {
        reference: VectorReference::Virtual,
        compiled: Some(1e-3),
        ..VectorOptions::default()
    };
    vectors::generate_into(&opts, &dir, false).expect("vectors");
    // Most pixels compile at 1 µm on this 320 × 240 scan: the compiled pass runs compiled_row,
    // not only the search.
    let file = CompiledFile::read_any(&dir.join("input/compiled.f3c")).expect("compiled file");
    let pixels = (file.width * file.height) as usize;
    assert!(
        file.compiled_count() * 10 > pixels * 8,
        "{} of {pixels} pixels compiled",
        file.compiled_count()
    );
    // The golden decode, and the pixels of it the models leave to the search.
    let phase: Vec<f32> = std::fs::read(dir.join("decode/phase.f32"))
        .expect("golden phase")
        .chunks_exact(4)
        .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
        .collect();
    let validity = std::fs::read(dir.join("decode/validity.u8")).expect("golden validity");
    let decoded = validity.iter().filter(|&&q| q == 0).count();
    let left = file.left_to_search(&phase, &validity).expect("size").len();
    let elf = dir.join("head-c.elf");
    build_example(&build_library(), &elf);
    let console = run_in_vectors(&elf, &dir);
    println!("{console}");

    // Every pass, line by line: the map in place, the ring, the compiled models.
    for (pass, points) in [
        ("map", "reconstruct"),
        ("ring", "reconstruct"),
        ("compiled", "compiled"),
    ] {
        let line = console
            .lines()
            .find(|l| l.starts_with(&format!("{pass} ")))
            .unwrap_or_else(|| panic!("no {pass} pass:\n{console}"));
        assert_golden_digests(line, &dir, points, pass);
        // The pixels the search computed (`fringe3d_row_searched`, summed over the rows): every
        // decoded one without the models, with them those the models leave.
        let want = match pass {
            "compiled" => left,
            _ => decoded,
        };
        assert_eq!(
            value(line, "searched"),
            Some(want.to_string().as_str()),
            "{pass}: {line}"
        );
    }
    assert!(
        left > 0 && left < decoded / 2,
        "{left} of {decoded} pixels left"
    );
    // The refusals: a blob with a broken CRC says so; u8 rows for a 16-bit camera are refused.
    assert!(
        console.contains("damaged_blob=setup (set-up: CRC mismatch)"),
        "{console}"
    );
    assert_eq!(value(&console, "u8_rows"), Some("sample-size"), "{console}");
    // A map file one byte short is refused, with its reason, before any sample is read.
    assert!(
        console.contains("short_map_file=reference (reference map: truncated file)"),
        "{console}"
    );
    let sram: usize = value(&console, "sram_bytes")
        .and_then(|s| s.parse().ok())
        .unwrap_or(0);
    assert!(sram > 0 && sram <= 192 * 1024, "{console}");
    let _ = std::fs::remove_dir_all(&dir);
}
