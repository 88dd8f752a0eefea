//! `fringe3d budget` (issue #23 item 4): the buffers of a head's row pipeline for a pattern set
//! and a rig. The band comes from the calibration's reconstructor (built here through the core
//! as a second path); the per-column sums are the formulas docs/integration.md and
//! docs/firmware.md state. The board layout's total is held to the linker's static RAM on the
//! Cortex-M4F by `tests/tests/qemu_firmware.rs`.

use crate::cli_support::{fringe3d, run};
use fringe3d::io::calibration::Calibration;
use fringe3d_core::phase_function::Axis;
use fringe3d_core::reconstruct::Reconstructor;
use std::path::Path;

const SET: &str = "../examples/patterns/paper8.toml";
const CAL: &str = "../examples/calibration/calib.toml";

fn json(args: &[&str]) -> serde_json::Value {
    let mut all = vec!["--json", "budget"];
    all.extend_from_slice(args);
    serde_json::from_str(&run(&all)).unwrap()
}

#[test]
fn the_budget_of_a_rig_is_its_buffers() {
    let cal = Calibration::load(Path::new(CAL)).unwrap();
    let (cam, setup) = cal.core_setup(Axis::Xi).unwrap();
    let band = Reconstructor::new(&cam, &setup).unwrap().band().rows() as u64;
    let j = json(&["-p", SET, "-c", CAL, "--layout", "minimal-ring"]);
    let (w, h) = (cal.camera.width as u64, cal.camera.height as u64);
    assert_eq!(j["width"], w);
    assert_eq!(j["band_rows"], band);
    // The example head's layout with the map streamed through a ring, 8-bit samples:
    // (N + 5 + 4B + 4 + 13)·W plus scratch and blob.
    let per_column = 8 + 5 + 4 * band + 4 + 13;
    assert_eq!(j["bytes_per_column"], per_column);
    let buffers = j["buffers"].as_array().unwrap();
    let sum: u64 = buffers.iter().map(|b| b["bytes"].as_u64().unwrap()).sum();
    assert_eq!(j["total_bytes"], sum);
    for b in buffers {
        let per = b["bytes_per_column"].as_u64().unwrap();
        assert!(per == 0 || b["bytes"] == per * w, "{b}");
    }
    let fixed: u64 = buffers
        .iter()
        .filter(|b| b["bytes_per_column"] == 0)
        .map(|b| b["bytes"].as_u64().unwrap())
        .sum();
    assert_eq!(sum, per_column * w + fixed);
    // The frame-sequential state: 4 bytes for A and S, C of 3 levels, and a flag byte.
    assert_eq!(j["frame_sequential"]["bytes"], (4 * 7 + 1) * w * h);
    // The frame store: the 8 frames of one byte a sample.
    assert_eq!(j["frame_store"]["bytes_per_pixel"], 8);
    assert_eq!(j["frame_store"]["bytes"], 8 * w * h);
    // The example itself reads the map in place (memory-mapped): no ring, no staging row, and
    // no band needed; the same fixed buffers.
    let in_place = json(&["-p", SET, "--width", &w.to_string()]);
    assert_eq!(in_place["bytes_per_column"], 8 + 5 + 13);
    assert_eq!(in_place["total_bytes"], (8 + 5 + 13) * w + fixed);

    // The board's layout at its 1280-wide, 25-row build: (2N + 45 + 4B)·W + the decoder.
    let b = json(&[
        "-p", SET, "--width", "1280", "--band", "25", "--bits", "16", "--layout", "board",
    ]);
    assert_eq!(b["bytes_per_column"], 2 * 8 + 45 + 4 * 25);
    // Phase only: the images and the phase row.
    let p = json(&["-p", SET, "--width", "640", "--layout", "phase"]);
    assert_eq!(p["bytes_per_column"], 8 + 5);
}

#[test]
fn a_budget_without_a_rig_says_what_it_needs() {
    for (args, want) in [
        (&["-p", SET][..], "--width"),
        (
            &["-p", SET, "--width", "640", "--layout", "minimal-ring"][..],
            "--band",
        ),
        (&["-p", SET, "--width", "0", "--band", "9"][..], "--width"),
        (&["-p", SET, "--width", "640", "--band", "0"][..], "--band"),
        (
            &["-p", "no-such.toml", "--width", "640", "--band", "9"][..],
            "no-such.toml",
        ),
    ] {
        let mut all = vec!["budget"];
        all.extend_from_slice(args);
        let o = fringe3d(&all);
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success() && err.contains(want), "{args:?}: {err}");
    }
}

/// A reference map wider than the image (issue #17 item 3): the ring and the staging row are the
/// map's width, the image's plus the margin the calibration records; the band is the
/// reconstructor's for that margin; every other buffer keeps the image's width.
#[test]
fn a_map_wider_than_the_image_widens_the_ring() {
    let dir = std::env::temp_dir().join(format!("fringe3d-budget-margin-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let out = dir.join("calibration.toml");
    crate::cli_support::virtual_reference(Path::new(SET), Path::new(CAL), &out);
    let cal = Calibration::load(&out).unwrap();
    let margin = cal.reference.as_ref().unwrap().margin();
    let columns = (margin.left + margin.right) as u64;
    assert!(columns > 0, "the far plane needs a margin: {margin:?}");
    let (cam, setup) = cal.core_setup(Axis::Xi).unwrap();
    let recon = Reconstructor::new(&cam, &setup)
        .unwrap()
        .with_margin(margin)
        .unwrap();
    let band = recon.band().rows() as u64;
    let j = json(&[
        "-p",
        SET,
        "-c",
        out.to_str().unwrap(),
        "--layout",
        "minimal-ring",
    ]);
    let w = cal.camera.width as u64;
    assert_eq!(j["margin_columns"], columns);
    assert_eq!(j["band_rows"], band);
    let bytes = |name: &str| {
        j["buffers"]
            .as_array()
            .unwrap()
            .iter()
            .find(|b| b["buffer"].as_str().unwrap().starts_with(name))
            .unwrap()["bytes"]
            .as_u64()
            .unwrap()
    };
    assert_eq!(bytes("reference ring"), 4 * band * (w + columns));
    assert_eq!(bytes("reference row staging"), 4 * (w + columns));
    assert_eq!(bytes("point rows"), 13 * w);
    // The same by hand, and the ring's bytes as the core counts them (its phase plane).
    let by_hand = json(&[
        "-p",
        SET,
        "--width",
        &w.to_string(),
        "--band",
        &band.to_string(),
        "--margin-columns",
        &columns.to_string(),
        "--layout",
        "minimal-ring",
    ]);
    assert_eq!(by_hand["total_bytes"], j["total_bytes"]);
    assert_eq!(
        4 * band * (w + columns),
        (recon.ring_bytes(band as u32) / 5 * 4) as u64
    );
    let _ = std::fs::remove_dir_all(&dir);
}
