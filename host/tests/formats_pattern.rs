//! Pattern-set files: the shipped examples map onto the pattern sets they describe (built
//! independently through the core's constructors), files round-trip exactly, and bad files get
//! messages that name the file and the problem.

use std::f64::consts::{FRAC_PI_2, PI, TAU};
use std::fs;
use std::path::{Path, PathBuf};

use fringe3d::io::calibration::FormatError;
use fringe3d::io::pattern_file::{PatternSetFile, Preset};
use fringe3d_core::pattern::{Convention, ImageId, Level, Output, PatternSet};
use fringe3d_core::phase_function::{Axis, KnotProfile, PhaseFunction, Profile};

fn examples() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("..")
        .join("examples")
        .join("patterns")
}

fn scratch(name: &str) -> crate::cli_support::Tmp {
    crate::cli_support::Tmp::new(&format!("formats-pattern-{name}"))
}

fn load_example(name: &str) -> (PatternSetFile, PatternSet) {
    let f = PatternSetFile::load(&examples().join(name)).unwrap_or_else(|e| panic!("{e}"));
    let s = f.to_pattern_set().unwrap();
    (f, s)
}

const OUT: Output = Output {
    width: 1024,
    height: 768,
    i_min: 0.0,
    i_max: 255.0,
};

#[test]
fn paper8_example_is_the_default_set() {
    let (f, s) = load_example("paper8.toml");
    assert_eq!(s, PatternSet::default_for(Axis::Xi, OUT).unwrap());
    assert_eq!(f.bit_depth(), 8);
    assert_eq!(s.image_count(), 8);
    // Hand-checked structure of eq 7.
    let l = s.levels();
    assert_eq!((l[0].scale(), l[1].scale(), l[2].scale()), (1.0, 8.0, 64.0));
    assert_eq!(l[0].shifts(), &[0.0, FRAC_PI_2]);
    assert_eq!(l[2].len(), 4);
    assert_eq!(s.convention(), Convention::Sine);
}

#[test]
fn horizontal_example() {
    let (_, s) = load_example("horizontal.toml");
    assert_eq!(s, PatternSet::default_for(Axis::Eta, OUT).unwrap());
    assert_eq!(s.axis(), Axis::Eta);
}

#[test]
fn twelve_example() {
    let (_, s) = load_example("twelve.toml");
    let f = PhaseFunction::centered(Axis::Xi, 1024, 0.9 * TAU).unwrap();
    assert_eq!(s, PatternSet::twelve_pattern(f, 8.0, OUT).unwrap());
    assert_eq!(s.image_count(), 12);
}

#[test]
fn nstep_example() {
    let (_, s) = load_example("nstep-5.toml");
    let f = PhaseFunction::linear(Axis::Xi, 511.5, 0.005).unwrap();
    let levels = [
        Level::n_step(1.0, 5),
        Level::n_step(8.0, 5),
        Level::n_step(64.0, 5),
    ];
    assert_eq!(s, PatternSet::new(f, &levels, OUT).unwrap());
    // eq 14: shifts 2π(n−1)/5.
    let want: Vec<f64> = (0..5).map(|n| TAU * n as f64 / 5.0).collect();
    assert_eq!(s.levels()[1].shifts(), want.as_slice());
}

#[test]
fn variable_width_example_is_centred() {
    let (_, s) = load_example("variable-width.toml");
    let Profile::Knots(k) = s.function().profile() else {
        panic!("knots expected")
    };
    let pos = [0.0, 256.0, 512.0, 768.0, 1023.0];
    let slopes = [0.003, 0.006, 0.0072, 0.006, 0.003];
    assert_eq!(k.positions(), &pos);
    assert_eq!(k.slopes(), &slopes);
    // Trapezoid integration by hand: total phase over the knots.
    let total = 0.0045 * 256.0 + 0.0066 * 256.0 + 0.0066 * 256.0 + 0.0045 * 255.0;
    let g0 = s.function().eval(0.0, 0.0);
    let g1 = s.function().eval(1023.0, 0.0);
    assert!((g0 + total / 2.0).abs() < 1e-12, "g(0) = {g0}");
    assert!((g1 - total / 2.0).abs() < 1e-12, "g(1023) = {g1}");
    let expected = KnotProfile::from_slopes(&pos, &slopes, g0).unwrap();
    assert_eq!(*k, expected);
}

#[test]
fn curved_example() {
    let (_, s) = load_example("curved.toml");
    let f = s.function();
    assert_eq!((f.curvature(), f.bend_center()), (0.0002, 383.5));
    // Φ(ξ, η) = g(ξ + a(η − η₀)²) with g linear, span 5.2 over 1024 px centred at 511.5.
    let g = |t: f64| 5.2 / 1024.0 * (t - 511.5);
    let phi = f.eval(100.0, 0.0);
    assert!((phi - g(100.0 + 0.0002 * 383.5 * 383.5)).abs() < 1e-12);
    // Default bend_center when curvature is given without it: the middle row.
    let d = scratch("curved");
    let p = d.join("c.toml");
    fs::write(&p, "version = 1\n[projector]\nwidth = 1024\nheight = 768\n[phase]\nspan = 5.2\ncurvature = 0.0002\n").unwrap();
    let s2 = PatternSetFile::load(&p).unwrap().to_pattern_set().unwrap();
    assert_eq!(s2, s);
}

#[test]
fn cosine_example_keeps_order_and_images() {
    let path = examples().join("cosine-3step.toml");
    let (f, s) = load_example("cosine-3step.toml");
    assert_eq!(s.convention(), Convention::Cosine);
    assert_eq!(s.effective_offset(), FRAC_PI_2);
    let l = s.levels();
    assert_eq!(l.len(), 3);
    assert_eq!(l[2].scale(), 36.0);
    assert_eq!(
        l[0].shifts(),
        &[-120.0 * PI / 180.0, 0.0, 120.0 * PI / 180.0]
    );
    let order: Vec<ImageId> = (0..3u8)
        .flat_map(|level| (0..3u8).map(move |shift| ImageId { level, shift }))
        .collect();
    assert_eq!(s.order(), order.as_slice());
    assert_eq!(
        *s.output(),
        Output {
            width: 912,
            height: 1140,
            i_min: 10.0,
            i_max: 245.0
        }
    );
    let imgs = f.image_paths(&path).unwrap();
    assert_eq!(imgs.len(), 9);
    assert_eq!(imgs[4], examples().join("capture/img_04.png"));
    // The intensity follows the cosine convention: I = i_min + (i_max − i_min)/2 (1 + cos(c Φ + δ)).
    let (xi, eta) = (300.0, 10.0);
    let phi = 0.9 * TAU / 912.0 * (xi - 455.5);
    let want = 10.0 + 117.5 * (1.0 + (6.0 * phi + 120.0 * PI / 180.0).cos());
    let got = s.intensity(5, xi, eta).unwrap();
    assert!((got - want).abs() < 1e-9, "{got} vs {want}");
}

#[test]
fn every_example_loads() {
    let mut n = 0;
    for e in fs::read_dir(examples()).unwrap() {
        let p = e.unwrap().path();
        if p.extension().is_some_and(|x| x == "toml") {
            PatternSetFile::load(&p).unwrap_or_else(|e| panic!("{e}"));
            n += 1;
        }
    }
    assert_eq!(n, 13);
}

#[test]
fn binary_sets_round_trip_and_bad_names_are_refused() {
    use fringe3d_core::binary::Binarization;
    for (name, b) in [
        ("binary-square.toml", Binarization::Square),
        ("binary-bayer.toml", Binarization::Bayer),
    ] {
        let p = examples().join(name);
        let set = PatternSetFile::load(&p).unwrap().to_pattern_set().unwrap();
        assert_eq!(set.binarization(), b);
        let (f, text) = round_trip(&set, 8, name);
        assert_eq!(f.binary.map(|n| n.core()), Some(b));
        assert!(text.contains("binary = "), "{text}");
    }
    // A gray-level set writes no `binary` key; a misspelt value is one clear error.
    let set = PatternSet::default_for(Axis::Xi, OUT).unwrap();
    let (f, _) = round_trip(&set, 8, "not-binary");
    assert!(f.binary.is_none());
    let d = scratch("binary-bad");
    let p = d.join("bad.toml");
    fs::write(
        &p,
        "version = 2\nbinary = \"dither\"\n[projector]\nwidth = 64\nheight = 48\n",
    )
    .unwrap();
    let e = PatternSetFile::load(&p).unwrap_err().to_string();
    assert!(e.contains("bad.toml") && e.contains("binary"), "{e}");
}

#[test]
fn gray_code_sets_round_trip() {
    let p = examples().join("gray-complementary.toml");
    let set = PatternSetFile::load(&p).unwrap().to_pattern_set().unwrap();
    assert_eq!(set.image_count(), 11);
    assert_eq!(
        set.gray().map(|g| (g.bits(), g.complementary())),
        Some((6, true))
    );
    let (f, text) = round_trip(&set, 8, "gray");
    let levels = f.levels.unwrap();
    assert_eq!(levels[0].gray_bits, Some(6));
    assert_eq!(levels[0].complementary, Some(true));
    assert!(text.contains("gray_bits = 6"), "{text}");
    // The plain code: one image fewer.
    let plain = fs::read_to_string(&p)
        .unwrap()
        .replace("complementary = true ", "complementary = false");
    let d = scratch("gray-plain");
    fs::write(d.join("plain.toml"), plain).unwrap();
    let set = PatternSetFile::load(&d.join("plain.toml"))
        .unwrap()
        .to_pattern_set()
        .unwrap();
    assert_eq!(set.image_count(), 10);
    round_trip(&set, 8, "gray-plain-rt");
}

#[test]
fn a_shifted_gray_code_round_trips_and_is_checked() {
    let p = examples().join("gray-shifted.toml");
    let set = PatternSetFile::load(&p).unwrap().to_pattern_set().unwrap();
    assert_eq!(set.image_count(), 10);
    let g = set.gray().unwrap();
    assert_eq!(
        (g.bits(), g.complementary(), g.is_shifted()),
        (6, false, true)
    );
    let (f, text) = round_trip(&set, 8, "gray-shifted");
    assert_eq!(f.levels.unwrap()[0].shifted, Some(true));
    assert!(text.contains("shifted = true"), "{text}");
    let d = scratch("gray-shifted-bad");
    let original = fs::read_to_string(&p).unwrap();
    for (edit, want) in [
        // With the complementary image: refused by name.
        (
            original.replace("complementary = false", "complementary = true"),
            "shifted = true needs complementary = false",
        ),
        // 5 bits: the shifted code covers [-17, 15) periods, the 32 centred ones leave it.
        (original.replace("gray_bits = 6", "gray_bits = 5"), "bits"),
        // On a phase level.
        (
            original.replace("steps = 4", "steps = 4\nshifted = true"),
            "Gray-code level (gray_bits) only",
        ),
    ] {
        let f = d.join("bad.toml");
        fs::write(&f, edit).unwrap();
        let e = PatternSetFile::load(&f)
            .map(|_| ())
            .unwrap_err()
            .to_string();
        assert!(e.contains(want), "{want}: {e}");
    }
}

fn round_trip(set: &PatternSet, bits: u8, name: &str) -> (PatternSetFile, String) {
    let d = scratch(name);
    let p = d.join("set.toml");
    let f = PatternSetFile::from_pattern_set(set, bits);
    assert_eq!(f.to_pattern_set().unwrap(), *set, "in memory");
    f.save(&p).unwrap();
    let text = fs::read_to_string(&p).unwrap();
    let back = PatternSetFile::load(&p).unwrap();
    assert_eq!(back, f, "file content");
    assert_eq!(
        back.to_pattern_set().unwrap(),
        *set,
        "through the file:\n{text}"
    );
    assert_eq!(back.bit_depth(), bits);
    (back, text)
}

#[test]
fn default_set_round_trips_as_a_preset() {
    let set = PatternSet::default_for(Axis::Xi, OUT).unwrap();
    let (f, text) = round_trip(&set, 8, "default");
    assert_eq!(f.preset, Some(Preset::Paper8));
    assert_eq!(f.ratio, Some(8.0));
    assert!(f.levels.is_none() && f.order.is_none());
    assert!(
        text.starts_with("# fringe3d pattern set, format version 1"),
        "{text}"
    );
    assert!(
        text.contains("preset = \"paper8\"") && text.contains("kind = \"linear\""),
        "{text}"
    );
}

#[test]
fn twelve_and_sixteen_bit_round_trip() {
    let f = PhaseFunction::centered(Axis::Eta, 800, 5.0).unwrap();
    let out = Output {
        width: 1280,
        height: 800,
        i_min: 100.0,
        i_max: 60000.0,
    };
    let set = PatternSet::twelve_pattern(f, 6.5, out).unwrap();
    let (file, _) = round_trip(&set, 16, "twelve16");
    assert_eq!(file.preset, Some(Preset::Twelve));
    let s = file.to_pattern_set().unwrap();
    let mut row = vec![0u16; 1280];
    s.generate_row(11, 799, &mut row).unwrap();
}

#[test]
fn custom_set_round_trips_exactly() {
    let k = KnotProfile::new(
        &[0.0, 100.0, 333.3, 639.0],
        &[-2.9, -1.7, 0.1, 2.5],
        &[0.01, 0.013, 0.009, 0.006],
    )
    .unwrap();
    let f = PhaseFunction::with_profile(Axis::Xi, Profile::Knots(k))
        .unwrap()
        .curved(1e-5, 123.25)
        .unwrap();
    let out = Output {
        width: 640,
        height: 400,
        i_min: 3.5,
        i_max: 250.25,
    };
    let levels = [
        Level::n_step(1.0, 3),
        Level::with_shifts(4.5, &[0.1, 1.7]),
        Level::with_shifts(1.0 / 0.0517, &[0.0, 1.1, 2.9, 4.0, 5.5]),
    ];
    let set = PatternSet::new(f, &levels, out)
        .unwrap()
        .with_convention(Convention::Cosine)
        .with_phase_offset(0.1 + 0.2)
        .unwrap();
    let order: Vec<ImageId> = set.order().iter().rev().copied().collect();
    let set = set.with_order(&order).unwrap();
    let (file, _) = round_trip(&set, 8, "custom");
    let lv = file.levels.as_ref().unwrap();
    assert_eq!(lv[0].steps, Some(3));
    assert_eq!(lv[1].shifts.as_deref(), Some(&[0.1, 1.7][..]));
    assert!(file.order.is_some());
}

fn bad(text: &str) -> String {
    let d = scratch("bad");
    let p = d.join("pat.toml");
    fs::write(&p, text).unwrap();
    let e = PatternSetFile::load(&p).unwrap_err();
    let m = e.to_string();
    assert!(
        m.contains("pat.toml: "),
        "the message must name the file: {m}"
    );
    m
}

const HEAD: &str = "version = 1\n[projector]\nwidth = 1024\nheight = 768\n";

#[test]
fn bad_files_get_clear_messages() {
    // Core errors, in the core's words.
    let m = bad(&format!(
        "{HEAD}[phase]\nkind = \"knots\"\npositions = [0.0, 500.0, 400.0]\nslopes = [0.004, 0.004, 0.004]\nphases = [-2.0, 0.0, 2.0]\n"
    ));
    assert!(
        m.contains("phase function: knot 2: positions and phases must strictly increase"),
        "{m}"
    );
    let m = bad(&format!("{HEAD}[phase]\nspan = 7.0\n"));
    assert!(m.contains("coarsest level spans"), "{m}");
    let m = bad(&format!(
        "{HEAD}[phase]\nkind = \"linear\"\nslope = -0.001\n"
    ));
    assert!(m.contains("slope must be positive"), "{m}");
    let m = bad(&format!(
        "{HEAD}[[levels]]\nscale = 1.0\nshifts_deg = [0, 90]\n"
    ));
    assert!(m.contains("no level has 3 or more"), "{m}");
    let m = bad(&format!(
        "{HEAD}[[levels]]\nscale = 8.0\nsteps = 4\n[[levels]]\nscale = 1.0\nsteps = 4\n"
    ));
    assert!(m.contains("strictly increase"), "{m}");

    // File-level problems.
    let m = bad(&format!(
        "preset = \"paper8\"\n{HEAD}[[levels]]\nscale = 1.0\nsteps = 4\n"
    ));
    assert!(m.contains("either preset or [[levels]]"), "{m}");
    let m = bad(&format!("{HEAD}[[levels]]\nscale = 1.0\nsteps = 2\n"));
    assert!(m.contains("levels[0]: steps = 2"), "{m}");
    let m = bad(&format!(
        "{HEAD}[[levels]]\nscale = 1.0\nsteps = 4\nshifts = [0.0, 1.0, 2.0]\n"
    ));
    assert!(
        m.contains("exactly one of steps, shifts, shifts_deg or gray_bits"),
        "{m}"
    );
    // Gray-code levels (issue #20).
    let gray = |rest: &str| bad(&format!("{HEAD}[[levels]]\nscale = 4.0\n{rest}"));
    let m = gray("gray_bits = 11\n[[levels]]\nscale = 4.0\nsteps = 4\n");
    assert!(
        m.contains("levels[0]: gray_bits = 11; a Gray-code level has 1 to 10 bits"),
        "{m}"
    );
    for key in ["complementary", "inverse", "shifted"] {
        let m = gray(&format!("steps = 4\n{key} = true\n"));
        assert!(
            m.contains("complementary, inverse and shifted apply to a Gray-code level"),
            "{m}"
        );
    }
    let m = gray("gray_bits = 8\ninverse = true\n[[levels]]\nscale = 4.0\nsteps = 4\n");
    assert!(
        m.contains("gray_bits = 8 with inverse = true is 18 images"),
        "{m}"
    );
    let m = gray("steps = 4\n[[levels]]\nscale = 8.0\ngray_bits = 3\n");
    assert!(
        m.contains("levels[1]: a Gray-code level (gray_bits) must be the first"),
        "{m}"
    );
    let m = gray("gray_bits = 3\n[[levels]]\nscale = 8.0\nsteps = 4\n");
    assert!(
        m.contains("followed by a phase level of the same scale"),
        "{m}"
    );
    let m = gray("gray_bits = 3\n[[levels]]\nscale = 4.0\nshifts_deg = [0, 90]\n");
    assert!(m.contains("its threshold is that level's DC term A"), "{m}");
    // 1 bit covers [-1.5, 0.5) periods; 4.0·0.9·2π/2π = 3.6 periods span [-1.8, 1.8].
    let m = gray("gray_bits = 1\n[[levels]]\nscale = 4.0\nsteps = 4\n");
    assert!(
        m.contains("spans periods -1.80 to 1.80") && m.contains("raise levels[0].gray_bits"),
        "{m}"
    );
    let m = bad(&format!("{HEAD}[phase]\nslope = 0.01\n"));
    assert!(
        m.contains("phase.slope is not used by kind = \"centered\" (the default)"),
        "{m}"
    );
    let m = bad(&format!("{HEAD}[phase]\nkind = \"linear\"\n"));
    assert!(
        m.contains("phase.slope (radians per pixel) is required"),
        "{m}"
    );
    let m = bad(&format!("images = [\"a.png\"]\n{HEAD}"));
    assert!(
        m.contains("images lists 1 files but the set has 8 images"),
        "{m}"
    );
    let m = bad(&format!("order = [[0, 0], [0, 0]]\n{HEAD}"));
    assert!(m.contains("order:"), "{m}");
    let m = bad("version = 1\n[projector]\nwidth = 1024\nheight = 768\ni_max = 300\n");
    assert!(m.contains("i_max = 300"), "{m}");
    let m = bad("version = 1\n[projector]\nwidth = 1024\nheight = 768\nbit_depth = 12\n");
    assert!(m.contains("bit_depth must be 8 or 16, got 12"), "{m}");
    let m = bad("version = 1\n[projector]\nwidth = 4000000000\nheight = 4000000000\n");
    assert!(
        m.contains("projector size must be 1 to 16384 pixels each way"),
        "{m}"
    );
    let m = bad(&format!("ratio = 1.0\n{HEAD}"));
    assert!(m.contains("ratio must be greater than 1"), "{m}");

    // Syntax and schema.
    let m = bad(&format!("{HEAD}[phase]\naxsi = \"xi\"\n"));
    assert!(m.contains("axsi"), "{m}");
    let m = bad(&format!("{HEAD}[phase]\naxis = \"zeta\"\n"));
    assert!(m.contains("zeta"), "{m}");
    let m = bad("version = 3\n");
    assert!(m.contains("format version 3 is not supported"), "{m}");
}

#[test]
fn missing_file_names_the_path() {
    let e = PatternSetFile::load(Path::new("/nonexistent/pat.toml")).unwrap_err();
    assert!(matches!(e, FormatError::Io { .. }));
    assert!(
        e.to_string()
            .starts_with("/nonexistent/pat.toml: cannot read"),
        "{e}"
    );
}

#[test]
fn minimal_file_is_the_default_set() {
    let d = scratch("minimal");
    let p = d.join("m.toml");
    fs::write(&p, HEAD).unwrap();
    let f = PatternSetFile::load(&p).unwrap();
    assert_eq!(
        f.to_pattern_set().unwrap(),
        PatternSet::default_for(Axis::Xi, OUT).unwrap()
    );
    assert_eq!(f.image_paths(&p), None);
}

#[test]
fn order_entry_of_three_indices_is_refused() {
    // Cut to its first two indices, this order is the default one and would load. (Its own
    // folder: `bad` shares one between the tests of bad_files_get_clear_messages.)
    let d = scratch("order-entry");
    let p = d.join("pat.toml");
    fs::write(
        &p,
        format!(
            "order = [[2, 0], [2, 1], [2, 2], [2, 3], [0, 0], [0, 1], [1, 0], [1, 1, 5]]\n{HEAD}"
        ),
    )
    .unwrap();
    let e = PatternSetFile::load(&p).unwrap_err();
    assert!(matches!(e, FormatError::Parse { .. }), "{e}");
    let m = e.to_string();
    assert!(m.contains("pat.toml: "), "{m}");
    assert!(
        m.contains("`order` must have exactly 2 values per entry, got 3"),
        "{m}"
    );
}
