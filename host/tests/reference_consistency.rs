//! The reference's pattern set is recorded and checked (a scan's phase and the reference map are
//! comparable only for the same phase function, scales and shifts): two renders of the same
//! scene on the same rig, one under the default linear set (A), one under a variable-width set
//! (B). Scanning B's images with A's calibration is refused by `scan`, `reconstruct` (through
//! `decode`'s record) and `device upload` with one error naming both sides and nothing written;
//! A with A works; the digest ignores names and comments but not a scale; calibrations written
//! before the digest still load and scan.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use fringe3d::io::calibration::{
    Calibration, PatternCheck, ScanPatterns, check_pattern_set, is_digest, pattern_digest,
    pattern_file_digest,
};
use fringe3d::io::pattern_file::PatternSetFile;
use fringe3d::render::dataset::{DatasetOptions, write_dataset};
use fringe3d::render::{Overrides, Scene, SceneSpec};

struct Tmp(PathBuf);
impl Tmp {
    fn new(tag: &str) -> Tmp {
        let d = std::env::temp_dir().join(format!("fringe3d-refcons-{tag}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        Tmp(d)
    }
    fn join(&self, p: &str) -> PathBuf {
        self.0.join(p)
    }
}
impl Drop for Tmp {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

const VARIABLE_WIDTH: &str = "version = 1\npreset = \"paper8\"\nratio = 8.0\n\
[projector]\nwidth = 1024\nheight = 768\n\
[phase]\naxis = \"xi\"\nkind = \"knots\"\npositions = [0.0, 256.0, 512.0, 768.0, 1023.0]\n\
slopes = [0.003, 0.006, 0.0072, 0.006, 0.003]\n";

/// A small sphere scene rendered into `dir`, under the default set or the one in `set_file`.
fn render(dir: &Path, set_file: Option<&Path>) {
    let mut spec = SceneSpec::builtin("sphere").unwrap();
    spec.apply(&Overrides {
        size: Some((160, 128)),
        supersample: Some(1),
        pattern_bits: Some(8),
        ..Default::default()
    });
    if let Some(f) = set_file {
        spec.patterns.set = Some(PatternSetFile::load(f).unwrap());
    }
    let scene = Scene::new(spec, None).unwrap();
    write_dataset(
        &scene,
        dir,
        DatasetOptions {
            overwrite: true,
            progress: None,
        },
    )
    .unwrap();
}

/// Datasets A (default linear set) and B (variable width) of the same scene and rig.
fn datasets(t: &Tmp) -> (PathBuf, PathBuf) {
    let (a, b) = (t.join("a"), t.join("b"));
    let vw = t.join("variable-width.toml");
    std::fs::write(&vw, VARIABLE_WIDTH).unwrap();
    render(&a, None);
    render(&b, Some(&vw));
    (a, b)
}

fn fringe3d(args: &[&Path]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_fringe3d"))
        .args(args)
        .output()
        .unwrap()
}

fn p(s: &str) -> &Path {
    Path::new(s)
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn ok(o: &Output, what: &str) {
    assert!(o.status.success(), "{what}: {}", stderr(o));
}

fn scan(ds_images: &Path, patterns: &Path, cal: &Path, out: &Path) -> Output {
    fringe3d(&[
        p("scan"),
        p("-q"),
        p("--patterns"),
        patterns,
        p("--calibration"),
        cal,
        ds_images,
        p("-o"),
        out,
    ])
}

/// The one mismatch error: names the calibration and both digests, and the scan's side.
fn assert_mismatch(o: &Output, cal: &Path, scan_side: &str, ref_digest: &str, scan_digest: &str) {
    assert!(!o.status.success(), "a mismatch must fail");
    let e = stderr(o);
    assert_eq!(
        e.lines().filter(|l| l.starts_with("error")).count(),
        1,
        "one error: {e}"
    );
    assert!(e.contains("pattern set mismatch"), "{e}");
    assert!(
        e.contains(&cal.display().to_string()),
        "names the calibration: {e}"
    );
    assert!(
        e.contains(scan_side),
        "names the scan's side {scan_side}: {e}"
    );
    assert!(e.contains(ref_digest), "the reference's digest: {e}");
    assert!(e.contains(scan_digest), "the scan's digest: {e}");
}

/// Rewrite `cal` without the lines starting with any of `keys` (an older calibration file).
fn strip(cal: &Path, keys: &[&str], to: &Path) {
    let text = std::fs::read_to_string(cal).unwrap();
    let kept: Vec<&str> = text
        .lines()
        .filter(|l| !keys.iter().any(|k| l.starts_with(k)))
        .collect();
    assert!(
        kept.len() < text.lines().count(),
        "{keys:?} were in {}",
        cal.display()
    );
    std::fs::write(to, kept.join("\n")).unwrap();
}

#[test]
fn scan_reconstruct_and_device_refuse_another_pattern_set() {
    let t = Tmp::new("cli");
    let (a, b) = datasets(&t);
    let (cal_a, set_a, set_b) = (
        a.join("calibration.toml"),
        a.join("patterns.toml"),
        b.join("patterns.toml"),
    );
    let d_a = pattern_file_digest(&set_a).unwrap();
    let d_b = pattern_file_digest(&set_b).unwrap();
    assert_ne!(d_a, d_b, "variable width is another pattern set");
    // The rendered calibration records A's digest.
    let cal = Calibration::load(&cal_a).unwrap();
    assert_eq!(
        cal.reference.as_ref().unwrap().pattern_digest.as_deref(),
        Some(d_a.as_str())
    );

    // scan: B's images and set against A's reference: refused, nothing written.
    let out = t.join("b.ply");
    let o = scan(&b, &set_b, &cal_a, &out);
    assert_mismatch(&o, &cal_a, &set_b.display().to_string(), &d_a, &d_b);
    assert!(!out.exists(), "nothing written");
    // The matching set works.
    let out_a = t.join("a.ply");
    ok(&scan(&a, &set_a, &cal_a, &out_a), "scan A with A");
    assert!(std::fs::metadata(&out_a).unwrap().len() > 1000);

    // decode records the set; reconstruct checks the record.
    let (dec_a, dec_b) = (t.join("dec-a"), t.join("dec-b"));
    for (ds, set, dec) in [(&a, &set_a, &dec_a), (&b, &set_b, &dec_b)] {
        ok(
            &fringe3d(&[
                p("decode"),
                p("-q"),
                p("--patterns"),
                set,
                ds,
                p("--out"),
                dec,
            ]),
            "decode",
        );
        let rec = std::fs::read_to_string(dec.join("decode.toml")).unwrap();
        assert!(rec.contains(&pattern_file_digest(set).unwrap()), "{rec}");
    }
    let recon = |dec: &Path, cal: &Path, out: &Path| {
        fringe3d(&[
            p("reconstruct"),
            p("-q"),
            p("--calibration"),
            cal,
            p("--decoded"),
            dec,
            p("-o"),
            out,
        ])
    };
    let out = t.join("rb.ply");
    let o = recon(&dec_b, &cal_a, &out);
    assert_mismatch(&o, &cal_a, &dec_b.display().to_string(), &d_a, &d_b);
    assert!(!out.exists(), "nothing written");
    let out = t.join("ra.ply");
    ok(&recon(&dec_a, &cal_a, &out), "reconstruct A with A");
    assert!(out.is_file());

    // A decode folder without its record (an older decode) is refused by a calibration that
    // records a digest, and accepted with a warning by one that records no pattern set.
    std::fs::remove_file(dec_b.join("decode.toml")).unwrap();
    let out = t.join("old.ply");
    let o = recon(&dec_b, &cal_a, &out);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("decode.toml"), "{}", stderr(&o));
    assert!(!out.exists());
    let bare = t.join("a/bare.toml");
    strip(&cal_a, &["pattern_digest", "pattern_set"], &bare);
    let o = fringe3d(&[
        p("reconstruct"),
        p("--calibration"),
        &bare,
        p("--decoded"),
        &dec_b,
        p("-o"),
        &out,
    ]);
    ok(&o, "an old decode folder with an old calibration");
    assert!(
        stderr(&o).contains("warning") && stderr(&o).contains("decode.toml"),
        "{}",
        stderr(&o)
    );

    // device upload (the only way a set and a reference meet on a head) checks before it opens
    // the port: a mismatch is that error, a match gets as far as the (missing) port.
    let port = t.join("no-such-port");
    let upload = |set: &Path| {
        fringe3d(&[
            p("device"),
            p("upload"),
            p("--port"),
            &port,
            p("--patterns"),
            set,
            p("--calibration"),
            &cal_a,
        ])
    };
    let o = upload(&set_b);
    assert_mismatch(&o, &cal_a, &set_b.display().to_string(), &d_a, &d_b);
    let o = upload(&set_a);
    assert!(!o.status.success());
    assert!(!stderr(&o).contains("mismatch"), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("no-such-port"),
        "fails at the port: {}",
        stderr(&o)
    );
}

#[test]
fn calibrations_without_a_digest_still_load_and_scan() {
    let t = Tmp::new("old");
    let (a, b) = datasets(&t);
    let (cal_a, set_a, set_b) = (
        a.join("calibration.toml"),
        a.join("patterns.toml"),
        b.join("patterns.toml"),
    );
    // Older file: pattern_set but no pattern_digest. The digest comes from pattern_set.
    let old = a.join("old.toml");
    strip(&cal_a, &["pattern_digest"], &old);
    let c = Calibration::load(&old).unwrap();
    assert_eq!(c.reference.as_ref().unwrap().pattern_digest, None);
    let out = t.join("old-a.ply");
    let o = scan(&a, &set_a, &old, &out);
    ok(&o, "old calibration, same set");
    assert!(out.is_file());
    assert!(stderr(&o).is_empty(), "nothing to warn: {}", stderr(&o));
    let out = t.join("old-b.ply");
    let o = scan(&b, &set_b, &old, &out);
    let d_a = pattern_file_digest(&set_a).unwrap();
    let d_b = pattern_file_digest(&set_b).unwrap();
    assert_mismatch(&o, &old, &set_b.display().to_string(), &d_a, &d_b);
    assert!(
        stderr(&o).contains("pattern_set"),
        "says where the reference's digest came from"
    );
    assert!(!out.exists());

    // Oldest: neither. Accepted, with one warning line that nothing could be checked.
    let bare = a.join("bare.toml");
    strip(&cal_a, &["pattern_digest", "pattern_set"], &bare);
    let out = t.join("bare-a.ply");
    let o = fringe3d(&[
        p("scan"),
        p("--patterns"),
        &set_a,
        p("--calibration"),
        &bare,
        &a,
        p("-o"),
        &out,
    ]);
    ok(&o, "calibration without pattern set");
    assert!(out.is_file());
    let warnings: Vec<_> = stderr(&o)
        .lines()
        .filter(|l| l.starts_with("warning"))
        .map(String::from)
        .collect();
    assert_eq!(warnings.len(), 1, "{warnings:?}");
    assert!(warnings[0].contains("cannot be checked"), "{warnings:?}");

    // The library's answer for the three kinds of calibration.
    let scan_b = ScanPatterns {
        source: "B".into(),
        digest: d_b.clone(),
    };
    let load = |f: &Path| Calibration::load(f).unwrap();
    assert!(check_pattern_set(&load(&cal_a), &cal_a, &scan_b).is_err());
    assert!(check_pattern_set(&load(&old), &old, &scan_b).is_err());
    assert!(matches!(
        check_pattern_set(&load(&bare), &bare, &scan_b),
        Ok(PatternCheck::Unchecked(_))
    ));
    let scan_a = ScanPatterns {
        source: "A".into(),
        digest: d_a,
    };
    assert_eq!(
        check_pattern_set(&load(&old), &old, &scan_a).unwrap(),
        PatternCheck::Match
    );
}

const EXPLICIT: &str = "version = 1\n\
[projector]\nwidth = 1024\nheight = 768\n\
[phase]\nkind = \"linear\"\nslope = 0.005\n\
[[levels]]\nscale = 1.0\nshifts_deg = [0, 90]\n\
[[levels]]\nscale = 8.0\nshifts_deg = [0, 90]\n\
[[levels]]\nscale = 64.0\nsteps = 4\n";

#[test]
fn the_digest_is_of_the_phase_not_of_the_file() {
    let t = Tmp::new("digest");
    let digest = |name: &str, text: &str| {
        let f = t.join(name);
        std::fs::write(&f, text).unwrap();
        pattern_file_digest(&f).unwrap()
    };
    let base = digest("base.toml", EXPLICIT);
    assert!(is_digest(&base), "{base}");
    // Another name, comments, an image list, other gray levels: the same phase, the same digest.
    let dressed = format!(
        "# my projector's set\n{}",
        EXPLICIT.replace(
            "[projector]\n",
            "images = [\"a.png\", \"b.png\", \"c.png\", \"d.png\", \"e.png\", \"f.png\", \"g.png\", \"h.png\"]\n\
             [projector]  # DLP\ni_min = 10.0\ni_max = 240.0\n"
        )
    );
    assert_ne!(dressed, EXPLICIT);
    assert_eq!(digest("other-name.toml", &dressed), base);
    // A 16-bit version of the set (no 8-bit wire description) has a digest, the same one.
    let deep = EXPLICIT.replace("height = 768\n", "height = 768\nbit_depth = 16\n");
    assert_eq!(digest("deep.toml", &deep), base);
    // A changed scale coefficient, shift, slope, axis or size is another set.
    for (what, from, to) in [
        ("scale", "scale = 8.0", "scale = 8.5"),
        ("shift", "steps = 4", "steps = 5"),
        ("slope", "slope = 0.005", "slope = 0.0051"),
        ("size", "width = 1024", "width = 1000"),
        (
            "convention",
            "version = 1\n",
            "version = 1\nconvention = \"cosine\"\n",
        ),
    ] {
        let changed = EXPLICIT.replacen(from, to, 1);
        assert_ne!(changed, EXPLICIT, "{what}");
        assert_ne!(digest(&format!("{what}.toml"), &changed), base, "{what}");
    }
    // The file and the set it builds agree.
    let set = PatternSetFile::load(&t.join("base.toml"))
        .unwrap()
        .to_pattern_set()
        .unwrap();
    assert_eq!(pattern_digest(&set).unwrap(), base);
}

#[test]
fn a_malformed_recorded_digest_is_refused_on_load() {
    let t = Tmp::new("malformed");
    let cal = t.join("c.toml");
    std::fs::write(
        &cal,
        "version = 1\nprojector_centre = [-200.0, 0.0, 30.0]\ndepth_range = [650.0, 900.0]\n\
         [camera]\nwidth = 64\nheight = 48\nfx = 100.0\nfy = 100.0\nskew = 0.0\ncx = 31.5\ncy = 23.5\n\
         distortion = [0.0, 0.0, 0.0, 0.0, 0.0]\n\
         [reference]\npoint = [0.0, 0.0, 800.0]\nnormal = [0.0, 0.0, -1.0]\nphase_map = \"r.tif\"\n\
         pattern_digest = \"sha256:ABC\"\n",
    )
    .unwrap();
    let e = Calibration::load(&cal).unwrap_err().to_string();
    assert!(e.contains("pattern_digest"), "{e}");
}
