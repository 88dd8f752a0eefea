//! Issue #20 item 5: the image order of explicit `[[levels]]` cannot surprise. In a version-2
//! pattern file the listed order is the default; a version-1 file keeps its old meaning (the
//! built-in order) and the CLI says so when that differs from the listed order. Truth: the
//! projector patterns themselves, written by `fringe3d patterns` and decoded back (the phase of
//! every projector column is the set's own `finest_phase`).

use fringe3d::calib::files::read_phase_map;
use fringe3d::io::pattern_file::PatternSetFile;
use std::path::Path;

use crate::cli_support::{Tmp, fringe3d, run, s};

const LEVELS: &str = "
[projector]
width = 256
height = 48
bit_depth = 8

[phase]
axis = \"xi\"

[[levels]]
scale = 1.0
shifts = [0.0, 1.5707963267948966]

[[levels]]
scale = 8.0
shifts = [0.0, 1.5707963267948966]

[[levels]]
scale = 64.0
steps = 4
";

/// Decode `images` with `patterns`: the largest phase error of the valid pixels against the set's
/// own phase, the valid fraction, and the command's stderr.
fn decode(patterns: &Path, images: &Path, out: &Path) -> (f64, f64, String) {
    let o = fringe3d(&["decode", "-q", "-p", s(patterns), "-o", s(out), s(images)]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let set = PatternSetFile::load(patterns)
        .unwrap()
        .to_pattern_set()
        .unwrap();
    let (w, h, phase) = read_phase_map(&out.join("phase.tif")).unwrap();
    let (mut worst, mut valid) = (0.0f64, 0usize);
    for y in 0..h as usize {
        for x in 0..w as usize {
            let p = phase[y * w as usize + x];
            if p.is_finite() {
                valid += 1;
                worst = worst.max((f64::from(p) - set.finest_phase(x as f64, y as f64)).abs());
            }
        }
    }
    (
        worst,
        valid as f64 / (w * h) as f64,
        String::from_utf8_lossy(&o.stderr).into_owned(),
    )
}

#[test]
fn listed_levels_are_decoded_in_the_listed_order() {
    let t = Tmp::new("pattern-order");
    let (v1, v2) = (t.0.join("v1.toml"), t.0.join("v2.toml"));
    std::fs::write(&v2, format!("version = 2\n{LEVELS}")).unwrap();
    std::fs::write(&v1, format!("version = 1\n{LEVELS}")).unwrap();
    // Version 2: the images in the listed order, level by level.
    let set2 = PatternSetFile::load(&v2).unwrap().to_pattern_set().unwrap();
    let listed: Vec<(u8, u8)> = set2.order().iter().map(|i| (i.level, i.shift)).collect();
    assert_eq!(
        listed,
        vec![
            (0, 0),
            (0, 1),
            (1, 0),
            (1, 1),
            (2, 0),
            (2, 1),
            (2, 2),
            (2, 3)
        ]
    );
    let f1 = PatternSetFile::load(&v1).unwrap();
    assert_ne!(f1.to_pattern_set().unwrap().order(), set2.order());
    assert!(
        PatternSetFile::load(&v2)
            .unwrap()
            .implicit_order_note()
            .is_none()
    );

    // The patterns of the version-2 file, decoded with it: exact to 8-bit quantisation (the
    // pixels at the patterns' full scale, 255, are flagged saturated: about 30 %).
    let pat = t.0.join("pat");
    run(&["patterns", "-q", "-p", s(&v2), "-o", s(&pat)]);
    let (e2, f2, err2) = decode(&v2, &pat, &t.0.join("d2"));
    println!("version 2: {:.1} % valid, worst {e2:.4} rad", 100.0 * f2);
    assert!(e2 < 0.05 && f2 > 0.6, "version 2: {e2} rad, {f2} valid");
    assert!(!err2.contains("note"), "{err2}");
    // The same images with the version-1 spelling are taken in the built-in order: the phases
    // come out wrong, and the CLI says why.
    let (e1, f1v, err1) = decode(&v1, &pat, &t.0.join("d1"));
    println!("version 1: {:.1} % valid, worst {e1:.4} rad", 100.0 * f1v);
    assert!(
        e1 > 1.0 || f1v < 0.5,
        "version 1 decodes other images: {e1} rad, {f1v} valid"
    );
    for m in [
        "note:",
        "v1.toml",
        "built-in order",
        "listed order",
        "version = 2",
    ] {
        assert!(err1.contains(m), "{m:?} not in {err1}");
    }
    // A version-1 file written by fringe3d spells its order out: no note, the same set.
    let written = t.0.join("written.toml");
    PatternSetFile::from_pattern_set(&set2, 8)
        .save(&written)
        .unwrap();
    let f = PatternSetFile::load(&written).unwrap();
    assert!(f.order.is_some() && f.implicit_order_note().is_none());
    assert_eq!(f.to_pattern_set().unwrap(), set2);
}
