//! The integrator's example (`examples/head-minimal`, docs/integration.md) on an emulated
//! Cortex-M4F (QEMU `mps2-an386`): it decodes and reconstructs the golden-vector scan and prints
//! FNV-1a digests of its phase, validity, point and point-validity rows, which must equal the
//! digests of the desktop's golden files. QEMU loads the folder's reference map into the board's
//! PSRAM, where the example reads it in place (memory-mapped). Also checks the stack and SRAM
//! figures it reports: the whole head, statics and measured stack, within 64 KiB at 640 wide
//! (issue #23 item 4), and its statics equal to the core's budget of its layout.
//!
//! Skips with a notice when `qemu-system-arm` or the `thumbv7em-none-eabihf` target is missing;
//! `FRINGE3D_REQUIRE_QEMU=1` (set by `.ci/run`) turns the skip into a failure.

use fringe3d::vectors::{self, VectorOptions};
use fringe3d_tests::qemu::{
    TARGET, assert_golden_digests, board_target_dir, repo, run_in_vectors, skip_without_tools,
};
use std::path::PathBuf;
use std::process::Command;

/// Build the example (release, its own workspace) and return its ELF.
fn build_example() -> PathBuf {
    let target_dir = board_target_dir().with_file_name("head-minimal");
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let out = Command::new(cargo)
        .args(["build", "--release", "--target", TARGET])
        .current_dir(repo().join("examples/head-minimal"))
        .env("CARGO_TARGET_DIR", &target_dir)
        .env_remove("RUSTFLAGS")
        .env_remove("CARGO_ENCODED_RUSTFLAGS")
        .env_remove("CARGO_BUILD_TARGET")
        .output()
        .expect("run cargo for the example");
    assert!(
        out.status.success(),
        "example build failed:\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    target_dir
        .join(TARGET)
        .join("release/fringe3d-head-minimal")
}

use fringe3d_tests::qemu::console_value as value;

#[test]
fn qemu_example_matches_the_golden_vectors() {
    if skip_without_tools("qemu_example_matches_the_golden_vectors") {
        return;
    }
    let elf = build_example();
    let dir = std::env::temp_dir().join(format!("fringe3d-qemu-example-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    vectors::generate_into(&VectorOptions::default(), &dir, false).expect("vectors");
    let console = run_in_vectors(&elf, &dir);
    println!("{console}");

    assert_golden_digests(&console, &dir, "reconstruct", "the example");

    // The example leaves out the core's `short-rows` path: a 1-pixel row is refused.
    assert_eq!(
        value(&console, "short_row_refused"),
        Some("true"),
        "{console}"
    );

    let figure = |key: &str| -> usize {
        value(&console, key)
            .and_then(|s| s.parse().ok())
            .unwrap_or_else(|| panic!("no figure for {key}:\n{console}"))
    };
    // The statics are the core's account of the example's layout (RowLayout::MINIMAL at its
    // 640-pixel capacity, evaluated on the target with its type sizes)...
    assert_eq!(figure("buffers"), figure("budget"), "{console}");
    // ...each call's measured stack is there and non-zero, and statics plus the deepest stack
    // fit the 64 KiB the example's memory.x gives it (the link checks the statics alone).
    let stacks = ["setup", "decode_row", "reconstruct_row"].map(|k| (k, figure(k)));
    for (key, bytes) in stacks {
        assert!(bytes > 0, "{key}: {bytes} bytes of stack");
    }
    let deepest = stacks.iter().map(|s| s.1).max().unwrap_or(0);
    let sram = figure("sram_bytes");
    assert!(
        sram >= figure("buffers") + deepest && sram <= 64 * 1024,
        "SRAM high-water {sram} B: {console}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}
