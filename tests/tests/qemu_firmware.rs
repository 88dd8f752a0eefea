//! The head firmware on an emulated Cortex-M4F (QEMU `mps2-an386`): it decodes, reconstructs and
//! edge-filters the golden-vector scan (320 × 240) and writes every stage's rows as records (the
//! UART0 record format, into a host file through semihosting);
//! each stage must be bit-identical to the desktop's golden vectors (NaNs mapped to the canonical
//! NaN first). Also prints the firmware's measurements (flash, static RAM, stack high-water mark,
//! instructions per pixel from QEMU's `-icount`).
//!
//! Skips with a notice when `qemu-system-arm` or the `thumbv7em-none-eabihf` target is missing;
//! `.ci/run` installs both and sets `FRINGE3D_REQUIRE_QEMU=1`, which turns the skip into a failure.

use crate::common::{
    ballbar_u8_with, coprime_set, gray_inverse_set, gray_set, gray_shifted_set, heterodyne_set,
    small_u8,
};
use fringe3d::vectors::{self, GoldenVectors, VectorOptions, VectorReference};
use fringe3d_tests::qemu::{build_firmware, skip_without_tools};
use std::collections::BTreeMap;
use std::io::Read;
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// Run the firmware on the vectors in `dir`; returns (the records, console text). The records go
/// to `dir/records.bin` through semihosting (argument `records`), not through the UART, whose
/// emulation costs QEMU a system call per byte: 4.9 MB take 13 s that way.
fn run_qemu(elf: &Path, dir: &Path) -> (Vec<u8>, String) {
    let records = dir.join("records.bin");
    let mut child = Command::new("qemu-system-arm")
        .args([
            "-M",
            "mps2-an386",
            "-cpu",
            "cortex-m4",
            "-display",
            "none",
            "-monitor",
            "none",
            "-icount",
            "shift=0",
        ])
        .args(["-serial", "null"])
        .arg("-semihosting-config")
        .arg(format!(
            "enable=on,target=native,arg=fringe3d-board-mps2,arg={},arg=records",
            dir.display()
        ))
        .arg("-kernel")
        .arg(elf)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("start qemu-system-arm");
    // QEMU writes the semihosting console to stderr; read both pipes so neither fills.
    let mut stdout = child.stdout.take().expect("piped stdout");
    let mut stderr = child.stderr.take().expect("piped stderr");
    let reader = std::thread::spawn(move || {
        let mut s = String::new();
        let _ = stdout.read_to_string(&mut s);
        s
    });
    let err_reader = std::thread::spawn(move || {
        let mut s = String::new();
        let _ = stderr.read_to_string(&mut s);
        s
    });
    let deadline = Instant::now() + Duration::from_secs(300);
    let status = loop {
        if let Some(s) = child.try_wait().expect("wait for qemu") {
            break s;
        }
        if Instant::now() > deadline {
            let _ = child.kill();
            let _ = child.wait();
            panic!("the firmware did not finish within 300 s");
        }
        std::thread::sleep(Duration::from_millis(100));
    };
    let console = reader.join().unwrap_or_default() + &err_reader.join().unwrap_or_default();
    assert!(status.success(), "firmware failed ({status}):\n{console}");
    (std::fs::read(&records).expect("the records file"), console)
}

/// Records: (tag, level, row) → payload.
fn parse_records(b: &[u8]) -> BTreeMap<(u8, u8, u16), Vec<u8>> {
    let mut m = BTreeMap::new();
    let mut i = 0;
    while i < b.len() {
        assert!(
            b.len() >= i + 12 && &b[i..i + 4] == b"F3DR",
            "bad record at byte {i}"
        );
        let (tag, level) = (b[i + 4], b[i + 5]);
        let row = u16::from_le_bytes([b[i + 6], b[i + 7]]);
        let len = u32::from_le_bytes([b[i + 8], b[i + 9], b[i + 10], b[i + 11]]) as usize;
        assert!(b.len() >= i + 12 + len, "truncated record at byte {i}");
        m.insert((tag, level, row), b[i + 12..i + 12 + len].to_vec());
        i += 12 + len;
    }
    m
}

fn canonical_nan(b: &mut [u8]) {
    for c in b.chunks_exact_mut(4) {
        let x = f32::from_le_bytes([c[0], c[1], c[2], c[3]]);
        if x.is_nan() {
            c.copy_from_slice(&0x7fc0_0000u32.to_le_bytes());
        }
    }
}

fn report_value(report: &str, key: &str) -> Option<u64> {
    report
        .split_whitespace()
        .find_map(|kv| kv.strip_prefix(key)?.strip_prefix('=')?.parse().ok())
}

/// Generate the vectors of `opts`, run the firmware on them and compare every stage.
fn check_scan(elf: &Path, opts: &VectorOptions, name: &str) {
    let dir = std::env::temp_dir().join(format!("fringe3d-qemu-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let v: GoldenVectors = vectors::generate_into(opts, &dir, false).expect("golden vectors");
    let t0 = Instant::now();
    let (records, console) = run_qemu(elf, &dir);
    println!("{console}");
    println!(
        "{name}: firmware run {:.1} s under QEMU (-icount shift=0), {} record bytes",
        t0.elapsed().as_secs_f64(),
        records.len()
    );

    let recs = parse_records(&records);
    assert!(
        recs.contains_key(&(0xFF, 0, 0)),
        "no End record: the firmware stopped early"
    );
    let report =
        String::from_utf8_lossy(recs.get(&(0xFE, 0, 0)).expect("report record")).to_string();
    let h = v.height;
    let levels = v.info["pattern_set"]["levels"].as_array().expect("levels");
    let mut stages: Vec<((u8, u8), String)> = vec![
        ((1, 0), "decode/phase.f32".into()),
        ((2, 0), "decode/modulation.f32".into()),
        ((3, 0), "decode/dc.f32".into()),
        ((4, 0), "decode/validity.u8".into()),
        ((7, 0), "reconstruct/points.f32".into()),
        ((8, 0), "reconstruct/validity.u8".into()),
        ((9, 0), "filter/validity.u8".into()),
        ((10, 0), "filter/points.f32".into()),
    ];
    // (A Gray-code level has no wrapped phase: neither side has its files.)
    for (l, info) in levels.iter().enumerate() {
        if info.get("gray_bits").is_none() {
            let l = l as u8;
            stages.push(((5, l), format!("decode/wrapped_level{l}.f32")));
            stages.push(((6, l), format!("decode/modulation_level{l}.f32")));
        }
    }
    let mut bad = Vec::new();
    for ((tag, level), path) in &stages {
        let mut bytes = Vec::new();
        for r in 0..h as u16 {
            match recs.get(&(*tag, *level, r)) {
                Some(p) => bytes.extend_from_slice(p),
                None => panic!("{path}: the firmware sent no row {r}"),
            }
        }
        if path.ends_with(".f32") {
            canonical_nan(&mut bytes);
        }
        let golden = v.file(path).expect("golden file");
        if vectors::sha256_hex(&bytes) != golden.sha256() {
            bad.push(format!(
                "{path}: {}",
                vectors::first_difference(golden, &bytes)
            ));
        }
    }
    assert!(
        bad.is_empty(),
        "{name}: the Cortex-M4F differs from the desktop:\n{}",
        bad.join("\n")
    );
    println!(
        "{name}: all {} stage files bit-identical to the desktop's golden vectors",
        stages.len()
    );

    // The measurements are there and plausible: the set-up and scan stacks stay inside the room
    // left by the statics (a full room would mean the stack ran into them), all within 256 KiB.
    let ram = report_value(&report, "static_ram_bytes").expect("static RAM in the report");
    // The core's budget of the board's layout (`fringe3d budget --layout board`), computed on the
    // target, is what the linker laid out: every static accounted for, none forgotten.
    let budget = report_value(&report, "budget_bytes").expect("the budget in the report");
    assert_eq!(
        budget, ram,
        "the core's budget against the board's static RAM"
    );
    let stack_scan = report_value(&report, "scan").expect("scan stack in the report");
    let stack_setup = report_value(&report, "setup").expect("setup stack in the report");
    let room = report_value(&report, "stack_room_bytes").expect("stack room in the report");
    assert!(
        stack_scan > 1024 && stack_setup < room && stack_scan < room,
        "stack high-water marks {stack_setup}/{stack_scan} vs room {room}"
    );
    assert!(
        ram + stack_setup.max(stack_scan) <= 256 * 1024,
        "static RAM + stack exceed 256 KiB"
    );
    // The blob ships the reconstructor's set-up analysis (field 10): the head builds its
    // reconstructor without the soft-f64 grid walk, which took 154 M instructions at 320 × 240
    // (docs/firmware.md). 40 instructions a tick.
    let setup = report_value(&report, "setup_reconstructor").expect("set-up ticks") * 40;
    println!("{name}: reconstructor set-up {setup} instructions");
    assert!(
        setup < 2_000_000,
        "the reconstructor's set-up took {setup} instructions: is the analysis shipped?"
    );
    // 2 000 000 instructions are 50 000 ticks of 40; where the loop starts within a tick (the
    // instructions before it, which every firmware change moves) adds at most one boundary.
    let ticks = report_value(&report, "calibration_ticks").expect("calibration ticks");
    assert!(
        ticks.abs_diff(50_000) <= 1,
        "-icount shift=0 should give 40 instructions per tick: {ticks} ticks"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn qemu_firmware_matches_the_golden_vectors_bit_for_bit() {
    if skip_without_tools("qemu_firmware_matches_the_golden_vectors_bit_for_bit") {
        return;
    }
    let elf = build_firmware("fringe3d-board-mps2");
    // The golden vectors as `fringe3d vectors` writes them by default (16-bit camera)...
    check_scan(&elf, &VectorOptions::default(), "ballbar-320x240-u16");
    // ...and an 8-bit camera with noise on another scene (the u8 kernel), its projector of gamma
    // 2.2 corrected by the set-up blob's phase-error table (docs/gamma.md).
    let u8_opts = VectorOptions {
        gamma: Some(2.2),
        ..small_u8("steps", 7)
    };
    check_scan(&elf, &u8_opts, "steps-160x128-u8-gamma2.2");
    // The codes real rigs use (issue #20), 8 images each: a complementary 3-bit Gray code (4
    // images) ordering a 4-step level of 128-pixel fringes, and the same set Bayer-dithered
    // through a projector blurred by 3 pixels, decoded with the set-up blob's table of that
    // blur (docs/binary.md).
    let gray_opts = VectorOptions {
        patterns: Some(gray_set("off")),
        ..small_u8("sphere", 5)
    };
    check_scan(&elf, &gray_opts, "sphere-160x128-u8-gray3c");
    let binary_opts = VectorOptions {
        patterns: Some(gray_set("bayer")),
        defocus: Some(3.0),
        ..gray_opts
    };
    check_scan(&elf, &binary_opts, "sphere-160x128-u8-gray3c-bayer");
    // Two-frequency heterodyne (8 images), its relation carried by the set-up blob (version 4).
    let heterodyne_opts = VectorOptions {
        patterns: Some(heterodyne_set()),
        ..small_u8("sphere", 6)
    };
    check_scan(&elf, &heterodyne_opts, "sphere-160x128-u8-heterodyne");
    // A coprime pair of 4-step levels (scales 5 and 7), number-theoretic unwrapping.
    let coprime_opts = VectorOptions {
        patterns: Some(coprime_set()),
        ..small_u8("sphere", 8)
    };
    check_scan(&elf, &coprime_opts, "sphere-160x128-u8-coprime");
    // A 2-bit Gray code with inverse patterns: each bit against its inverse.
    let inverse_opts = VectorOptions {
        patterns: Some(gray_inverse_set()),
        ..small_u8("sphere", 9)
    };
    check_scan(&elf, &inverse_opts, "sphere-160x128-u8-gray2-inverse");
    // A shifted 4-bit Gray code: stripes moved by half a period (protocol version 6).
    let shifted_opts = VectorOptions {
        patterns: Some(gray_shifted_set()),
        ..small_u8("sphere", 10)
    };
    check_scan(&elf, &shifted_opts, "sphere-160x128-u8-gray4-shifted");
    // The reference maps of issue #17: the model fitted to a noisy capture, the virtual map of
    // the rig's projector (both image-sized), and the virtual map on the default far plane
    // with the margin past the image the geometry needs (the set-up blob's field 9).
    for reference in [
        VectorReference::Model,
        VectorReference::Virtual,
        VectorReference::VirtualMargin,
    ] {
        let opts = ballbar_u8_with(reference);
        check_scan(
            &elf,
            &opts,
            &format!("ballbar-320x240-u8-{}", reference.name()),
        );
    }
}
