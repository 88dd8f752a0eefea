//! Hardening, issue #21 item 4: every numeric field of a pattern-set file is bounded to its
//! meaningful range. Each refusal names the file, the key and the range; the core refuses the same
//! values with a typed error (so a scan head given them over the wire does too); values at the
//! bounds still load.

use std::f64::consts::TAU;
use std::fs;
use std::path::PathBuf;

use fringe3d::io::pattern_file::PatternSetFile;
use fringe3d_core::pattern::{Level, MAX_SHIFT_MAGNITUDE, Output, PatternError, PatternSet};
use fringe3d_core::phase_function::{Axis, MIN_COARSE_SPAN, PhaseFunction, PhaseFunctionError};

const HEAD: &str = "version = 1\n[projector]\nwidth = 1024\nheight = 768\n";

const OUT: Output = Output {
    width: 1024,
    height: 768,
    i_min: 0.0,
    i_max: 255.0,
};

fn write(name: &str, text: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!(
        "fringe3d-hardening-bounds-{}-{name}",
        std::process::id()
    ));
    let _ = fs::remove_dir_all(&d);
    fs::create_dir_all(&d).unwrap();
    let p = d.join("pat.toml");
    fs::write(&p, text).unwrap();
    p
}

/// Load `text`; it must be refused with a message naming the file and containing every `needle`.
fn refused(name: &str, text: &str, needles: &[&str]) {
    let p = write(name, text);
    let r = PatternSetFile::load(&p);
    let _ = fs::remove_dir_all(p.parent().unwrap());
    let m = match r {
        Ok(_) => panic!("{name}: accepted:\n{text}"),
        Err(e) => e.to_string(),
    };
    assert!(m.contains("pat.toml: "), "{name}: no file named: {m}");
    for n in needles {
        assert!(m.contains(n), "{name}: {n:?} missing from: {m}");
    }
}

/// Load `text`; it must be accepted.
fn loads(name: &str, text: &str) -> PatternSet {
    let p = write(name, text);
    let r = PatternSetFile::load(&p);
    let _ = fs::remove_dir_all(p.parent().unwrap());
    r.unwrap_or_else(|e| panic!("{name}: {e}"))
        .to_pattern_set()
        .unwrap()
}

#[test]
fn phase_offset_is_bounded_to_two_pi() {
    for v in ["1e300", "7.0", "-6.3"] {
        refused(
            "offset",
            &format!("phase_offset = {v}\n{HEAD}"),
            &["phase_offset", "[-2pi, 2pi]", v],
        );
    }
    // At the bounds: accepted, the value kept bit for bit.
    for v in [TAU, -TAU, 3.0] {
        let s = loads("offset-ok", &format!("phase_offset = {v:?}\n{HEAD}"));
        assert_eq!(s.phase_offset().to_bits(), v.to_bits());
    }
    // The core refuses it with a typed error (firmware builds sets through the same call).
    let set = PatternSet::default_for(Axis::Xi, OUT).unwrap();
    assert_eq!(
        set.with_phase_offset(1e300).unwrap_err(),
        PatternError::PhaseOffset
    );
    assert_eq!(
        set.with_phase_offset(-MAX_SHIFT_MAGNITUDE)
            .unwrap()
            .phase_offset(),
        -TAU
    );
}

#[test]
fn shifts_are_bounded_to_two_pi() {
    // Three shifts: v between two that keep the level solvable for v = ±2π or ±360°.
    let levels = |key: &str, v: &str| {
        let (a, b) = if key == "shifts" {
            ("1.0", "2.0")
        } else {
            ("60.0", "120.0")
        };
        format!(
            "{HEAD}[[levels]]\nscale = 1.0\n{key} = [{a}, {v}, {b}]\n[[levels]]\nscale = 8.0\nsteps = 4\n"
        )
    };
    refused(
        "shift",
        &levels("shifts", "1e300"),
        &["levels[0].shifts[1]", "[-2pi, 2pi]", "1e300"],
    );
    refused(
        "shift-deg",
        &levels("shifts_deg", "400.0"),
        &["levels[0].shifts_deg[1]", "[-360, 360]"],
    );
    loads("shift-ok", &levels("shifts", "6.283185307179586"));
    loads("shift-deg-ok", &levels("shifts_deg", "-360.0"));
    // The core's typed error.
    let f = PhaseFunction::centered(Axis::Xi, 1024, 0.9 * TAU).unwrap();
    let lv = [
        Level::with_shifts(1.0, &[0.0, 1e300, 3.0]),
        Level::n_step(8.0, 4),
    ];
    assert_eq!(
        PatternSet::new(f, &lv, OUT).unwrap_err(),
        PatternError::Shift(0)
    );
}

#[test]
fn coarsest_level_must_span_a_meaningful_range() {
    // A tiny span, slope or coarse scale made every pattern (nearly) constant.
    refused(
        "span",
        &format!("{HEAD}[phase]\nspan = 1e-300\n"),
        &[
            "phase.span",
            "at least 0.1 rad",
            "coarsest level spans only",
        ],
    );
    refused(
        "slope",
        &format!("{HEAD}[phase]\nkind = \"linear\"\nslope = 1e-9\n"),
        &["phase.slope", "at least 0.1 rad"],
    );
    refused(
        "scale",
        &format!("{HEAD}[[levels]]\nscale = 1e-9\nsteps = 4\n[[levels]]\nscale = 1.0\nsteps = 4\n"),
        &["coarsest scale", "at least 0.1 rad"],
    );
    // Just above the floor: accepted.
    let s = loads(
        "span-ok",
        &format!(
            "{HEAD}[phase]\nspan = {}\n",
            1.01 * MIN_COARSE_SPAN * 1024.0 / 1023.0
        ),
    );
    let (lo, hi) = s.coarse_range();
    assert!(hi - lo >= MIN_COARSE_SPAN, "{lo} {hi}");
    // The core's typed error.
    let f = PhaseFunction::centered(Axis::Xi, 1024, 1e-300).unwrap();
    assert!(matches!(
        PatternSet::default_for(Axis::Xi, OUT).map(|_| ()),
        Ok(())
    ));
    assert!(matches!(
        PatternSet::paper_eight(f, 8.0, OUT).unwrap_err(),
        PatternError::Function(PhaseFunctionError::CoarseRangeTooSmall { .. })
    ));
}

#[test]
fn curvature_keeps_the_bend_within_the_projector() {
    // A shallow linear phase (±0.51 rad) left room for a bend of 1471 px on a 1024 px wide
    // projector: fringes moved off the projector altogether.
    let shallow = "[phase]\nkind = \"linear\"\nslope = 0.001\n";
    refused(
        "curvature",
        &format!("{HEAD}{shallow}curvature = 0.01\n"),
        &["phase.curvature", "1024 pixels"],
    );
    refused(
        "curvature-neg",
        &format!("{HEAD}{shallow}curvature = -0.01\n"),
        &["phase.curvature"],
    );
    // A bend of 1000 px (< 1024) is fine.
    let a = 1000.0 / (383.5f64 * 383.5);
    loads(
        "curvature-ok",
        &format!("{HEAD}{shallow}curvature = {a:?}\n"),
    );
    let f = PhaseFunction::linear(Axis::Xi, 511.5, 0.001)
        .unwrap()
        .curved(0.01, 383.5)
        .unwrap();
    assert!(matches!(
        f.check(1024, 768, 1.0, 64.0, 0.05).unwrap_err(),
        PhaseFunctionError::BendTooLarge { size: 1024, .. }
    ));
}

#[test]
fn bend_centre_lies_near_the_projector() {
    // Straight fringes with an absurd centre were accepted (and kept in the file).
    refused(
        "centre",
        &format!("{HEAD}[phase]\nbend_center = 1e150\n"),
        &["phase.bend_center", "[-n, 2n]"],
    );
    refused(
        "centre-curved",
        &format!("{HEAD}[phase]\ncurvature = 1e-12\nbend_center = -1e5\n"),
        &["phase.bend_center"],
    );
    // The edges of the allowed band: -768 and 1536 for 768 rows.
    for c in ["-768.0", "1536.0"] {
        loads(
            "centre-ok",
            &format!("{HEAD}[phase]\ncurvature = 1e-6\nbend_center = {c}\n"),
        );
    }
    let f = PhaseFunction::centered(Axis::Xi, 1024, 5.0)
        .unwrap()
        .curved(0.0, 1e150)
        .unwrap();
    assert_eq!(
        f.check(1024, 768, 1.0, 64.0, 0.05).unwrap_err(),
        PhaseFunctionError::BendCenter
    );
}
