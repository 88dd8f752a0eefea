//! `fringe3d calibrate` on bad input, through the binary: too few views, a board that is not in
//! the image, plate poses whose corners are coplanar, plate phase maps that do not overlap, a camera for
//! another image size, reference images that do not decode. Each must fail with a non-zero exit
//! and one message naming the images (or plate folders) concerned, and write nothing. A positive
//! control on the same data shows each failure comes from the defect, not from the data.
//!
//! Small renders (320 × 256, same field of view) keep this quick.

use fringe3d::io::image::{GrayImage, Pixels, read_gray, write_png_u8, write_png_u16};
use fringe3d::render::Scene;
use fringe3d::render::dataset::{DatasetOptions, write_dataset};
use fringe3d::render::scene::{Overrides, SceneSpec};
use std::path::{Path, PathBuf};

use crate::cli_support::{Tmp, fringe3d, s};

const SIZE: (u32, u32) = (320, 256);

/// Run and expect success.
fn ok(args: &[&str]) -> String {
    let o = fringe3d(args);
    assert!(
        o.status.success(),
        "{args:?} failed: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// Run and expect a failure whose message holds every string of `must`; returns the message.
fn fails(args: &[&str], must: &[&str]) -> String {
    let o = fringe3d(args);
    let err = String::from_utf8_lossy(&o.stderr).into_owned();
    assert!(
        !o.status.success(),
        "{args:?} should fail; stdout: {}",
        String::from_utf8_lossy(&o.stdout)
    );
    assert_ne!(o.status.code(), Some(0));
    for m in must {
        assert!(
            err.contains(m),
            "{args:?}: the error should mention {m:?}: {err}"
        );
    }
    assert!(!err.contains("panicked"), "{args:?} panicked: {err}");
    err
}

fn render(name: &str, dir: &Path, edit: impl FnOnce(&mut SceneSpec)) {
    let mut spec = SceneSpec::builtin(name).unwrap();
    spec.apply(&Overrides {
        size: Some(SIZE),
        noise: Some(1.0),
        bits: Some(8),
        ..Overrides::default()
    });
    edit(&mut spec);
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

fn blank_png(path: &Path, level: u8) {
    write_png_u8(
        path,
        SIZE.0,
        SIZE.1,
        &vec![level; (SIZE.0 * SIZE.1) as usize],
    )
    .unwrap();
}

/// Set the columns of an image for which `keep(x)` is false to a constant gray.
fn mask_columns(path: &Path, keep: impl Fn(u32) -> bool) {
    let (g, _): (GrayImage, _) = read_gray(path).unwrap();
    let w = g.width;
    match g.pixels {
        Pixels::U8(mut v) => {
            for (i, p) in v.iter_mut().enumerate() {
                if !keep(i as u32 % w) {
                    *p = 100;
                }
            }
            write_png_u8(path, w, g.height, &v).unwrap();
        }
        Pixels::U16(mut v) => {
            for (i, p) in v.iter_mut().enumerate() {
                if !keep(i as u32 % w) {
                    *p = 25000;
                }
            }
            write_png_u16(path, w, g.height, &v, 16).unwrap();
        }
        Pixels::F32(_) => panic!("{}: unexpected float image", path.display()),
    }
}

fn refs(v: &[String]) -> Vec<&str> {
    v.iter().map(String::as_str).collect()
}

fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap() {
        let p = e.unwrap().path();
        let q = to.join(p.file_name().unwrap());
        if p.is_dir() {
            copy_dir(&p, &q);
        } else {
            std::fs::copy(&p, &q).unwrap();
        }
    }
}

fn no_files(dir: &Path, what: &str) {
    let left: Vec<_> = std::fs::read_dir(dir)
        .map(|r| r.filter_map(|e| e.ok()).map(|e| e.path()).collect())
        .unwrap_or_default();
    assert!(
        left.is_empty(),
        "{what}: partial output left behind: {left:?}"
    );
}

#[test]
fn camera_too_few_views_and_boards_not_found() {
    let t = Tmp::new("calib-bad-camera");
    let cb = t.0.join("cb");
    render("checkerboard", &cb, |s| s.board.as_mut().unwrap().count = 3);
    let out = t.0.join("out");
    let yml = out.join("camera.yml");
    let board = ["--board", "11x8", "--square", "25"];
    // Positive control: the three views calibrate.
    let good = ok(&[
        &["calibrate", "camera", "-q", s(&cb)][..],
        &board,
        &["-o", s(&t.0.join("good.yml"))],
    ]
    .concat());
    assert!(good.is_empty());
    assert!(t.0.join("good.yml").is_file());

    // Two board views and an image without a board: too few views; the message names the usable
    // views and the rejected image with its reason.
    let blank = t.0.join("blank.png");
    blank_png(&blank, 120);
    let (a, b) = (cb.join("board_00.png"), cb.join("board_01.png"));
    let err = fails(
        &[
            &["calibrate", "camera", s(&a), s(&b), s(&blank)][..],
            &board,
            &["-o", s(&yml)],
        ]
        .concat(),
        &[
            "too few usable views: 2",
            "board_00.png",
            "board_01.png",
            "blank.png",
        ],
    );
    assert!(err.contains("left out"), "{err}");
    no_files(&out, "too few views");

    // The wrong board: no image shows it; every image is named.
    let err = fails(
        &[
            "calibrate",
            "camera",
            s(&cb),
            "--board",
            "9x7",
            "--square",
            "30",
            "-o",
            s(&yml),
        ],
        &[
            "too few usable views: 0",
            "board_00.png",
            "board_01.png",
            "board_02.png",
        ],
    );
    assert!(err.contains("left out"), "{err}");
    no_files(&out, "wrong board");

    // Images of two sizes.
    let small = t.0.join("small.png");
    write_png_u8(&small, 160, 128, &vec![0; 160 * 128]).unwrap();
    fails(
        &[
            &["calibrate", "camera", s(&a), s(&b), s(&small)][..],
            &board,
            &["-o", s(&yml)],
        ]
        .concat(),
        &["small.png", "160x128"],
    );
    no_files(&out, "mixed sizes");
}

#[test]
fn plates_not_parallel_calibrate_without_the_line_method() {
    let t = Tmp::new("calib-bad-tilted");
    let pl = t.0.join("plates");
    // Two positions, the second turned by 6 degrees about the vertical.
    render("plates", &pl, |s| {
        let p = s.plates.as_mut().unwrap();
        p.positions.truncate(2);
        p.positions[1].euler_deg[1] -= 6.0;
    });
    let out = t.0.join("out");
    let cal = out.join("calibration.toml");
    let (p0, p1) = (pl.join("plate_00"), pl.join("plate_01"));
    let args = |a: &Path, b: &Path| -> Vec<String> {
        [
            "--json",
            "calibrate",
            "projector",
            s(a),
            s(b),
            "--camera-from",
            s(&pl.join("calibration.toml")),
            "--board",
            "9x7",
            "--square",
            "30",
            "-o",
            s(&cal),
        ]
        .iter()
        .map(|x| x.to_string())
        .collect()
    };
    // Turned plates are freely posed boards to the full projector model: calibrated, with the
    // line method of §7 (which needs a translation) skipped and the reason reported.
    let a = args(&p0, &p1);
    let j: serde_json::Value =
        serde_json::from_str(&ok(&a.iter().map(String::as_str).collect::<Vec<_>>())).unwrap();
    let why = j["line_method_skipped"].as_str().unwrap_or_default();
    assert!(
        why.contains("not parallel") && why.contains("plate_00") && why.contains("plate_01"),
        "{why}"
    );
    // The angle reported is the one rendered (6 degrees, to the board-pose accuracy).
    let ang: f64 = why
        .split("differ by ")
        .nth(1)
        .and_then(|r| r.split(' ').next())
        .and_then(|x| x.parse().ok())
        .unwrap_or_else(|| panic!("no angle in {why}"));
    assert!(
        (ang - 6.0).abs() < 0.3,
        "angle {ang} (rendered 6 degrees): {why}"
    );
    assert!(cal.is_file());
    // One pose given twice: every corner on one plane, no projector model; named, nothing written.
    let out2 = t.0.join("out2");
    let cal2 = out2.join("calibration.toml");
    let mut b = args(&p0, &p0);
    let k = b.len() - 1;
    b[k] = s(&cal2).to_string();
    b.remove(0);
    fails(
        &b.iter().map(String::as_str).collect::<Vec<_>>(),
        &["coplanar", "plate_00"],
    );
    no_files(&out2, "coplanar");
}

#[test]
fn plate_and_reference_errors() {
    let t = Tmp::new("calib-bad-plates");
    let pl = t.0.join("plates");
    render("plates", &pl, |_| {});
    let cam = pl.join("calibration.toml");
    let board = ["--board", "9x7", "--square", "30"];
    let out = t.0.join("out");
    let cal = out.join("calibration.toml");
    let plates: Vec<PathBuf> = (0..3).map(|k| pl.join(format!("plate_{k:02}"))).collect();
    let proj = |dirs: &[&Path], camera: &Path, cal: &Path| -> Vec<String> {
        let mut a: Vec<String> = ["calibrate", "projector", "-q"]
            .iter()
            .map(|x| x.to_string())
            .collect();
        a.extend(dirs.iter().map(|d| s(d).to_string()));
        a.extend(["--camera-from", s(camera)].iter().map(|x| x.to_string()));
        a.extend(board.iter().map(|x| x.to_string()));
        a.extend(
            [
                "--patterns-v",
                s(&pl.join("patterns_v.toml")),
                "--patterns-h",
                s(&pl.join("patterns_h.toml")),
                "-o",
                s(cal),
            ]
            .iter()
            .map(|x| x.to_string()),
        );
        a
    };

    // Positive control: the three plates give P (to within 1 mm at this small size).
    let good = t.0.join("good").join("calibration.toml");
    ok(&refs(&proj(
        &[&plates[0], &plates[1], &plates[2]],
        &cam,
        &good,
    )));
    let got = fringe3d::io::calibration::Calibration::load(&good)
        .unwrap()
        .projector_centre;
    let truth = fringe3d::render::Scene::new(SceneSpec::builtin("plates").unwrap(), None)
        .unwrap()
        .rig
        .translation;
    let d =
        ((got[0] - truth[0]).powi(2) + (got[1] - truth[1]).powi(2) + (got[2] - truth[2]).powi(2))
            .sqrt();
    assert!(d < 1.0, "control: P {got:?} vs true {truth:?}");

    // One plate position.
    fails(&refs(&proj(&[&plates[0]], &cam, &cal)), &["at least two"]);
    no_files(&out, "one plate");

    // A camera calibrated for another image size.
    let other = t.0.join("other.yml");
    std::fs::write(
        &other,
        "%YAML:1.0\n---\nimage_width: 640\nimage_height: 512\ncamera_matrix: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n   data: [ 775., 0., 320.6, 0., 775., 254.1, 0., 0., 1. ]\ndistortion_coefficients: !!opencv-matrix\n   rows: 5\n   cols: 1\n   dt: d\n   data: [ -0.085, 0.11, 0.0004, -0.0003, 0. ]\n",
    )
    .unwrap();
    fails(
        &refs(&proj(&[&plates[0], &plates[1]], &other, &cal)),
        &["other.yml", "640x512", "320x256"],
    );
    no_files(&out, "camera size");

    // A plate whose board image shows no board.
    let nb = t.0.join("noboard");
    copy_dir(&plates[1], &nb);
    blank_png(&nb.join("board.png"), 90);
    fails(
        &refs(&proj(&[&plates[0], &nb], &cam, &cal)),
        &["noboard/board.png"],
    );
    no_files(&out, "no board");

    // A plate folder without its board image.
    std::fs::remove_file(nb.join("board.png")).unwrap();
    fails(
        &refs(&proj(&[&plates[0], &nb], &cam, &cal)),
        &["noboard", "board.png"],
    );
    no_files(&out, "missing board image");

    // Phase maps that do not overlap: the far plate (710 mm) decodes only on the left 30 % of the
    // image, the near one (490 mm) only on the right 30 % (one projector ray meets the two ~55 px
    // apart at this size, so no (Φ_V, Φ_H) pair is seen on both).
    let (left, right) = (t.0.join("left"), t.0.join("right"));
    copy_dir(&plates[0], &left);
    copy_dir(&plates[2], &right);
    let w = SIZE.0;
    for (dir, keep) in [
        (
            &left,
            Box::new(move |x: u32| x < 3 * w / 10) as Box<dyn Fn(u32) -> bool>,
        ),
        (&right, Box::new(move |x: u32| x >= 7 * w / 10)),
    ] {
        for sub in ["v", "h"] {
            for e in std::fs::read_dir(dir.join(sub)).unwrap() {
                mask_columns(&e.unwrap().path(), &keep);
            }
        }
    }
    // (The full projector model needs no overlap, but poses with too few board corners lit are
    // left out, each named with its count.)
    fails(
        &refs(&proj(&[&left, &right], &cam, &cal)),
        &[
            "too few usable views",
            "left: 0 corners with projector coordinates",
            "right: 6 corners",
        ],
    );
    no_files(&out, "no overlap");
    // Control: the same plates unmasked calibrate.
    ok(&refs(&proj(
        &[&plates[0], &plates[2]],
        &cam,
        &t.0.join("good2").join("calibration.toml"),
    )));

    // `calibrate reference` (the near plate's vertical set as a "reference plane"): a board image
    // without a board, fringe images that do not decode, no pose, a mix of pose sources.
    let rcal = out.join("ref.toml");
    let set_v = pl.join("patterns_v.toml");
    let rargs = |imgs: &Path, board_img: &Path| -> Vec<String> {
        [
            "calibrate",
            "reference",
            "-q",
            s(imgs),
            "--patterns",
            s(&set_v),
            "--calibration",
            s(&good),
            "-o",
            s(&rcal),
            "--board-image",
            s(board_img),
            "--board",
            "9x7",
            "--square",
            "30",
        ]
        .iter()
        .map(|x| x.to_string())
        .collect()
    };
    // Positive control into its own folder.
    let good_ref = t.0.join("goodref");
    std::fs::create_dir_all(&good_ref).unwrap();
    let mut a = rargs(&plates[0].join("v"), &plates[0].join("board.png"));
    let pos = a.iter().position(|x| x == s(&rcal)).unwrap();
    a[pos] = s(&good_ref.join("ref.toml")).to_string();
    ok(&refs(&a));
    assert!(good_ref.join("reference_phase.tif").is_file() && good_ref.join("ref.toml").is_file());

    let blank = t.0.join("blank.png");
    blank_png(&blank, 90);
    fails(&refs(&rargs(&plates[0].join("v"), &blank)), &["blank.png"]);
    no_files(&out, "reference: no board");
    let dark = t.0.join("dark");
    std::fs::create_dir_all(&dark).unwrap();
    for k in 0..8 {
        blank_png(&dark.join(format!("img_{k:02}.png")), 60);
    }
    fails(
        &refs(&rargs(&dark, &plates[0].join("board.png"))),
        &["dark", "valid phase"],
    );
    no_files(&out, "reference: no phase");
    fails(
        &[
            "calibrate",
            "reference",
            s(&plates[0].join("v")),
            "--patterns",
            s(&set_v),
            "--calibration",
            s(&good),
            "-o",
            s(&rcal),
        ],
        &["--board-image", "--plane-point"],
    );
    fails(
        &[
            "calibrate",
            "reference",
            s(&plates[0].join("v")),
            "--patterns",
            s(&set_v),
            "--calibration",
            s(&good),
            "-o",
            s(&rcal),
            "--board-image",
            s(&blank),
            "--plane-point",
            "0,0,700",
        ],
        &["not a mix"],
    );
    no_files(&out, "reference: pose arguments");
}
