//! Bad input through the real binary: every case gets one clear message that names the file and
//! the problem, a non-zero exit, and no output file or folder left behind.

use std::path::{Path, PathBuf};
use std::process::Command;

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_fringe3d"))
}

struct Tmp(PathBuf);
impl Tmp {
    fn new(name: &str) -> Tmp {
        let p =
            std::env::temp_dir().join(format!("fringe3d-cli-errors-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&p);
        std::fs::create_dir_all(&p).unwrap();
        Tmp(p)
    }
    fn join(&self, s: &str) -> PathBuf {
        self.0.join(s)
    }
}
impl Drop for Tmp {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// Run, expect failure; return stderr.
fn fails(args: &[&str]) -> String {
    let out = bin().args(args).output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr).to_string();
    assert!(
        !out.status.success(),
        "expected failure for {args:?}; stderr: {err}"
    );
    assert!(!err.contains("panicked"), "panic for {args:?}: {err}");
    err
}

/// Nothing named `out` (or a temp sibling of it) may remain.
fn no_output(dir: &Path, out_name: &str) {
    let left: Vec<_> = std::fs::read_dir(dir)
        .unwrap()
        .filter_map(|e| e.ok())
        .map(|e| e.file_name().to_string_lossy().to_string())
        .filter(|n| n.starts_with(out_name) || n.starts_with(&format!(".{out_name}")))
        .collect();
    assert!(left.is_empty(), "partial output left behind: {left:?}");
}

/// A small valid pattern set (320×200 projector) and its 8 patterns as 8-bit PNGs, used as
/// "camera images".
fn pattern_set(t: &Tmp) -> PathBuf {
    let set = t.join("set.toml");
    std::fs::write(
        &set,
        "version = 1\npreset = \"paper8\"\nratio = 4.0\n[projector]\nwidth = 320\nheight = 200\nbit_depth = 8\ni_max = 230\n[phase]\naxis = \"xi\"\nkind = \"centered\"\n",
    )
    .unwrap();
    let st = bin()
        .args(["patterns", "-q", "--patterns"])
        .arg(&set)
        .arg("--out")
        .arg(t.join("pat"))
        .status()
        .unwrap();
    assert!(st.success());
    t.join("pat")
}

fn imgs(pat: &Path) -> Vec<String> {
    (0..8)
        .map(|i| {
            pat.join(format!("pattern_{i:02}.png"))
                .display()
                .to_string()
        })
        .collect()
}

#[test]
fn decode_succeeds_on_good_input() {
    let t = Tmp::new("good");
    let pat = pattern_set(&t);
    let out = bin()
        .args(["decode", "-q", "--patterns"])
        .arg(pat.join("patterns.toml"))
        .arg("--out")
        .arg(t.join("dec"))
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    for f in [
        "phase.tif",
        "modulation.tif",
        "dc.tif",
        "validity.png",
        "preview.png",
    ] {
        assert!(t.join("dec").join(f).is_file(), "{f}");
    }
}

#[test]
fn wrong_image_count() {
    let t = Tmp::new("count");
    let pat = pattern_set(&t);
    let set = pat.join("patterns.toml");
    let mut args: Vec<String> = vec![
        "decode".into(),
        "--patterns".into(),
        set.display().to_string(),
        "--out".into(),
        t.join("out").display().to_string(),
    ];
    args.extend(imgs(&pat).into_iter().take(7));
    let a: Vec<&str> = args.iter().map(|s| s.as_str()).collect();
    let err = fails(&a);
    assert!(err.contains("8 images") && err.contains("7"), "{err}");
    assert!(
        err.contains("patterns.toml"),
        "names the pattern file: {err}"
    );
    no_output(&t.0, "out");
}

#[test]
fn missing_and_unreadable_files() {
    let t = Tmp::new("missing");
    let pat = pattern_set(&t);
    let set = pat.join("patterns.toml").display().to_string();
    let mut list = imgs(&pat);
    list[3] = t.join("nope.png").display().to_string();
    let out = t.join("out").display().to_string();
    let mut a = vec!["decode", "--patterns", &set, "--out", &out];
    a.extend(list.iter().map(|s| s.as_str()));
    let err = fails(&a);
    assert!(err.contains("nope.png"), "{err}");
    no_output(&t.0, "out");
    // a file that is no image
    std::fs::write(t.join("junk.png"), b"this is not a png").unwrap();
    list[3] = t.join("junk.png").display().to_string();
    let mut a = vec!["decode", "--patterns", &set, "--out", &out];
    a.extend(list.iter().map(|s| s.as_str()));
    let err = fails(&a);
    assert!(err.contains("junk.png"), "{err}");
    no_output(&t.0, "out");
}

#[test]
fn mixed_sizes_and_bit_depths() {
    let t = Tmp::new("mixed");
    let pat = pattern_set(&t);
    let set = pat.join("patterns.toml").display().to_string();
    // a 16-bit image of the same size, and an 8-bit one of another size
    let small = t.join("small.png");
    fringe3d::io::image::write_png_u8(&small, 100, 50, &vec![100u8; 5000]).unwrap();
    let deep = t.join("deep.png");
    fringe3d::io::image::write_png_u16(&deep, 320, 200, &vec![1000u16; 64000], 16).unwrap();
    let out = t.join("out").display().to_string();
    for (bad, want) in [(&small, "small.png"), (&deep, "deep.png")] {
        let mut list = imgs(&pat);
        list[5] = bad.display().to_string();
        let mut a = vec!["decode", "--patterns", &set, "--out", &out];
        a.extend(list.iter().map(|s| s.as_str()));
        let err = fails(&a);
        assert!(err.contains(want), "{err}");
        no_output(&t.0, "out");
    }
}

#[test]
fn non_monotonic_pattern_definition() {
    let t = Tmp::new("monotonic");
    let set = t.join("bad.toml");
    // knots whose phases decrease
    std::fs::write(
        &set,
        "version = 1\npreset = \"paper8\"\n[projector]\nwidth = 320\nheight = 200\n[phase]\naxis = \"xi\"\nkind = \"knots\"\npositions = [0.0, 100.0, 319.0]\nslopes = [0.01, 0.01, 0.01]\nphases = [0.0, -1.0, 2.0]\n",
    )
    .unwrap();
    let err = fails(&[
        "patterns",
        "--patterns",
        set.to_str().unwrap(),
        "--out",
        t.join("out").to_str().unwrap(),
    ]);
    assert!(err.contains("bad.toml"), "{err}");
    assert!(
        err.to_lowercase().contains("increase") || err.to_lowercase().contains("monoton"),
        "{err}"
    );
    no_output(&t.0, "out");
    // a coarse level that would wrap
    std::fs::write(&set, "version = 1\npreset = \"paper8\"\n[projector]\nwidth = 320\nheight = 200\n[phase]\naxis = \"xi\"\nkind = \"centered\"\nspan = 7.0\n").unwrap();
    let err = fails(&[
        "patterns",
        "--patterns",
        set.to_str().unwrap(),
        "--out",
        t.join("out").to_str().unwrap(),
    ]);
    assert!(err.contains("bad.toml") && err.contains("pi"), "{err}");
}

#[test]
fn calibration_problems() {
    let t = Tmp::new("calib");
    let pat = pattern_set(&t);
    let set = pat.join("patterns.toml").display().to_string();
    let map = t.join("ref.tif");
    // reference map 100×50 while the camera is 320×200
    fringe3d::io::image::write_tiff_f32(&map, 100, 50, &vec![0.5f32; 5000]).unwrap();
    let cal = |fx: &str| {
        format!(
            "version = 1\nprojector_centre = [200.0, 0.0, 0.0]\ndepth_range = [400.0, 800.0]\n\
             [camera]\nwidth = 320\nheight = 200\nfx = {fx}\nfy = 400.0\nskew = 0.0\ncx = 159.5\ncy = 99.5\ndistortion = [0.0, 0.0, 0.0, 0.0, 0.0]\n\
             [reference]\npoint = [0.0, 0.0, 700.0]\nnormal = [0.0, 0.0, -1.0]\nphase_map = \"ref.tif\"\n"
        )
    };
    let cfile = t.join("cal.toml");
    let out = t.join("out.ply").display().to_string();
    std::fs::write(&cfile, cal("400.0")).unwrap();
    let mut a = vec![
        "scan",
        "--patterns",
        &set,
        "--calibration",
        cfile.to_str().unwrap(),
        "-o",
        &out,
    ];
    let list = imgs(&pat);
    a.extend(list.iter().map(|s| s.as_str()));
    let err = fails(&a);
    assert!(err.contains("ref.tif") && err.contains("100x50"), "{err}");
    no_output(&t.0, "out.ply");
    // NaN and absurd parameters
    for bad in ["nan", "-5.0", "0.0"] {
        std::fs::write(&cfile, cal(bad)).unwrap();
        let err = fails(&a);
        assert!(
            err.contains("cal.toml") && err.contains("fx"),
            "fx = {bad}: {err}"
        );
        no_output(&t.0, "out.ply");
    }
}

#[test]
fn output_folder_is_not_clobbered() {
    let t = Tmp::new("clobber");
    let pat = pattern_set(&t);
    std::fs::create_dir_all(t.join("busy")).unwrap();
    std::fs::write(t.join("busy/keep.txt"), b"mine").unwrap();
    let err = fails(&[
        "decode",
        "--patterns",
        pat.join("patterns.toml").to_str().unwrap(),
        "--out",
        t.join("busy").to_str().unwrap(),
    ]);
    assert!(err.contains("busy"), "{err}");
    assert_eq!(std::fs::read(t.join("busy/keep.txt")).unwrap(), b"mine");
}
