//! Hardening of the output side: what `-o` may replace, standard output, cloud formats, temporary
//! files on interruption and their names.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::sync::atomic::{AtomicUsize, Ordering};

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_fringe3d"))
}

/// A scratch folder removed at the end of the test.
struct Tmp(PathBuf);
impl Tmp {
    fn new(name: &str) -> Tmp {
        let p = std::env::temp_dir().join(format!(
            "fringe3d-hardening-out-{}-{name}",
            std::process::id()
        ));
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

/// A small rendered dataset (64×48 sphere, a few milliseconds), in its own scratch folder
/// removed with it.
fn dataset() -> Tmp {
    static N: AtomicUsize = AtomicUsize::new(0);
    let t = Tmp::new(&format!("dataset-{}", N.fetch_add(1, Ordering::Relaxed)));
    let out = bin()
        .args(["render", "-q", "--scene", "sphere", "--size", "64x48"])
        .args(["--supersample", "1", "--overwrite", "--out"])
        .arg(&t.0)
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", stderr(&out));
    t
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// `fringe3d scan` of dataset `ds` with extra arguments.
fn scan(ds: &Tmp, extra: &[&std::ffi::OsStr]) -> Output {
    bin()
        .arg("scan")
        .arg("--patterns")
        .arg(ds.join("patterns.toml"))
        .arg("--calibration")
        .arg(ds.join("calibration.toml"))
        .arg(&ds.0)
        .args(extra)
        .output()
        .unwrap()
}

/// Expect a clean failure: non-zero exit, no panic; returns stderr.
fn fails(o: &Output) -> String {
    let e = stderr(o);
    assert!(!o.status.success(), "expected failure; stderr: {e}");
    assert!(!e.contains("panicked"), "panic: {e}");
    e
}

/// Names in a folder, sorted.
fn listing(d: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(d)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

#[cfg(unix)]
fn mkfifo(p: &Path) {
    let st = Command::new("mkfifo").arg(p).status().unwrap();
    assert!(st.success(), "mkfifo {}", p.display());
}

#[cfg(unix)]
fn is_fifo(p: &Path) -> bool {
    use std::os::unix::fs::FileTypeExt;
    std::fs::symlink_metadata(p)
        .map(|m| m.file_type().is_fifo())
        .unwrap_or(false)
}

#[cfg(unix)]
#[test]
fn a_fifo_or_device_given_as_output_is_refused_and_kept() {
    let ds = dataset();
    let t = Tmp::new("fifo");
    let fifo = t.join("cloud.ply");
    mkfifo(&fifo);
    let err = fails(&scan(
        &ds,
        &["-q".as_ref(), "-o".as_ref(), fifo.as_os_str()],
    ));
    assert!(
        err.contains("cloud.ply") && err.contains("FIFO") && err.contains("not a regular file"),
        "{err}"
    );
    assert!(is_fifo(&fifo), "the FIFO was replaced");
    assert_eq!(listing(&t.0), ["cloud.ply"], "temporary files left");
    // Behind a symbolic link too.
    let link = t.join("link.ply");
    std::os::unix::fs::symlink(&fifo, &link).unwrap();
    let err = fails(&scan(
        &ds,
        &["-q".as_ref(), "-o".as_ref(), link.as_os_str()],
    ));
    assert!(err.contains("link.ply") && err.contains("FIFO"), "{err}");
    assert!(
        std::fs::symlink_metadata(&link)
            .unwrap()
            .file_type()
            .is_symlink()
    );
    // The library refuses it as well.
    let e = fringe3d::io::atomic::write_atomic(&fifo, |w| w.write_all(b"x")).unwrap_err();
    assert!(
        matches!(e, fringe3d::io::atomic::AtomicError::NotRegular { .. }),
        "{e}"
    );
    assert!(is_fifo(&fifo));
    // A character device node (the /dev/null numbers), where this user may create one.
    let dev = t.join("dev.ply");
    let made = Command::new("mknod")
        .arg(&dev)
        .args(["c", "1", "3"])
        .stderr(std::process::Stdio::null())
        .status()
        .map(|s| s.success())
        .unwrap_or(false);
    if made {
        use std::os::unix::fs::FileTypeExt;
        let err = fails(&scan(&ds, &["-q".as_ref(), "-o".as_ref(), dev.as_os_str()]));
        assert!(err.contains("character device"), "{err}");
        let ft = std::fs::symlink_metadata(&dev).unwrap().file_type();
        assert!(ft.is_char_device(), "the device node was replaced");
    }
}

#[test]
fn a_cloud_goes_to_stdout_only_when_asked_with_dash() {
    let ds = dataset();
    let t = Tmp::new("stdout");
    let file = t.join("c.ply");
    let o = scan(&ds, &["-q".as_ref(), "-o".as_ref(), file.as_os_str()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let o = scan(&ds, &["-o".as_ref(), "-".as_ref()]);
    assert!(o.status.success(), "{}", stderr(&o));
    // The whole file, byte for byte, and the summary on stderr, not mixed into the cloud.
    assert_eq!(o.stdout, std::fs::read(&file).unwrap());
    assert!(stderr(&o).contains("standard output"), "{}", stderr(&o));
    // XYZ on request.
    let o = scan(
        &ds,
        &["-q", "-o", "-", "--format", "xyz"].map(std::ffi::OsStr::new),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let text = String::from_utf8(o.stdout).unwrap();
    let first = text.lines().next().unwrap();
    assert_eq!(first.split(' ').count(), 3, "{first}");
    // Commands whose output is no cloud refuse `-` rather than writing a file named `-`.
    let o = bin()
        .current_dir(&t.0)
        .arg("decode")
        .arg("--patterns")
        .arg(ds.join("patterns.toml"))
        .arg(&ds.0)
        .args(["--out", "-"])
        .output()
        .unwrap();
    let err = fails(&o);
    assert!(err.contains("--out -") && err.contains("./-"), "{err}");
    assert!(!t.join("-").exists());
}

/// Copy the dataset's files (not `truth/`) into `to`.
fn copy_dataset(to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(&dataset().0).unwrap() {
        let e = e.unwrap();
        if e.file_type().unwrap().is_file() {
            std::fs::copy(e.path(), to.join(e.file_name())).unwrap();
        }
    }
}

#[test]
fn a_cloud_extension_is_ply_or_xyz_or_an_error() {
    let ds = dataset();
    let t = Tmp::new("ext");
    let obj = t.join("x.obj");
    let e = fails(&scan(&ds, &["-o".as_ref(), obj.as_os_str()]));
    assert!(e.contains("x.obj") && e.contains(".ply or .xyz"), "{e}");
    let e = fails(&scan(
        &ds,
        &["-o", "x.xyz", "--format", "ply"].map(std::ffi::OsStr::new),
    ));
    assert!(e.contains("does not match"), "{e}");
    // device scan checks it before it touches the port.
    let o = bin()
        .args(["device", "scan", "--port", "/nonexistent/port", "-o"])
        .arg(&obj)
        .output()
        .unwrap();
    let e = fails(&o);
    assert!(e.contains("x.obj") && e.contains(".ply or .xyz"), "{e}");
    // An explicit format names the file whatever its extension.
    let o = scan(
        &ds,
        &[
            "-q".as_ref(),
            "--format".as_ref(),
            "xyz".as_ref(),
            "-o".as_ref(),
            obj.as_os_str(),
        ],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let text = std::fs::read_to_string(&obj).unwrap();
    assert_eq!(text.lines().next().unwrap().split(' ').count(), 3);
    assert_eq!(listing(&t.0), ["x.obj"]);
}

#[test]
fn reconstruct_refuses_incomplete_or_inconsistent_decode_folders() {
    let t = Tmp::new("recon");
    let ds = dataset();
    let dec = t.join("dec");
    let o = bin()
        .args(["decode", "-q", "--patterns"])
        .arg(ds.join("patterns.toml"))
        .arg(&ds.0)
        .arg("--out")
        .arg(&dec)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    let out = t.join("c.ply");
    let recon = || {
        bin()
            .args(["reconstruct", "-q", "--calibration"])
            .arg(ds.join("calibration.toml"))
            .arg("--decoded")
            .arg(&dec)
            .arg("-o")
            .arg(&out)
            .output()
            .unwrap()
    };
    let o = recon();
    assert!(o.status.success(), "{}", stderr(&o));
    std::fs::remove_file(&out).unwrap();
    let vpath = dec.join("validity.png");
    let (img, _) = fringe3d::io::image::read_gray(&vpath).unwrap();
    let fringe3d::io::image::Pixels::U8(codes) = img.pixels else {
        panic!("8-bit validity")
    };
    let (w, h) = (img.width, img.height);
    // An unknown validity code.
    let mut bad = codes.clone();
    bad[w as usize * 2 + 5] = 200;
    fringe3d::io::image::write_png_u8(&vpath, w, h, &bad).unwrap();
    let e = fails(&recon());
    assert!(
        e.contains("validity.png") && e.contains("code 200") && e.contains("(5, 2)"),
        "{e}"
    );
    assert!(!out.exists());
    // A valid pixel without a phase.
    let (img, _) = fringe3d::io::image::read_gray(&dec.join("phase.tif")).unwrap();
    let fringe3d::io::image::Pixels::F32(mut phase) = img.pixels else {
        panic!("float phase")
    };
    let i = codes.iter().position(|&c| c == 0).unwrap();
    phase[i] = f32::NAN;
    fringe3d::io::image::write_png_u8(&vpath, w, h, &codes).unwrap();
    fringe3d::io::image::write_tiff_f32(&dec.join("phase.tif"), w, h, &phase).unwrap();
    let e = fails(&recon());
    assert!(
        e.contains("phase.tif") && e.contains("marks it valid"),
        "{e}"
    );
    assert!(!out.exists());
    // No validity map at all.
    std::fs::remove_file(&vpath).unwrap();
    let e = fails(&recon());
    assert!(e.contains("validity.png") && e.contains("missing"), "{e}");
    assert!(!out.exists());
}

#[test]
fn a_reference_map_without_finite_phase_is_an_error() {
    let t = Tmp::new("refmap");
    let ds = t.join("ds");
    copy_dataset(&ds);
    let map = ds.join("reference_phase.tif");
    let (img, _) = fringe3d::io::image::read_gray(&map).unwrap();
    let (w, h) = (img.width, img.height);
    let n = (w * h) as usize;
    let out = t.join("c.ply");
    for (what, data) in [("NaN", vec![f32::NAN; n]), ("inf", vec![f32::INFINITY; n])] {
        fringe3d::io::image::write_tiff_f32(&map, w, h, &data).unwrap();
        let o = bin()
            .args(["scan", "-q", "--patterns"])
            .arg(ds.join("patterns.toml"))
            .arg("--calibration")
            .arg(ds.join("calibration.toml"))
            .arg(&ds)
            .arg("-o")
            .arg(&out)
            .output()
            .unwrap();
        let e = fails(&o);
        assert!(e.contains("reference_phase.tif"), "{what}: {e}");
        assert!(!out.exists(), "{what}");
    }
}

#[cfg(unix)]
#[test]
fn an_interrupted_run_leaves_no_temporary_files() {
    use std::os::unix::process::ExitStatusExt;
    let t = Tmp::new("signal");
    for (sig, num) in [("-INT", 2), ("-TERM", 15)] {
        // A full-size render takes seconds: long enough to be interrupted while it writes.
        let mut child = bin()
            .args(["render", "-q", "--scene", "sphere", "--out"])
            .arg(t.join("ds"))
            .stderr(std::process::Stdio::piped())
            .spawn()
            .unwrap();
        let t0 = std::time::Instant::now();
        while listing(&t.0).is_empty() {
            assert!(
                child.try_wait().unwrap().is_none(),
                "render ended too early"
            );
            assert!(t0.elapsed().as_secs() < 60, "no temporary folder appeared");
            std::thread::sleep(std::time::Duration::from_millis(5));
        }
        let st = Command::new("kill")
            .arg(sig)
            .arg(child.id().to_string())
            .status()
            .unwrap();
        assert!(st.success());
        let out = child.wait_with_output().unwrap();
        assert_eq!(out.status.signal(), Some(num), "{}", stderr(&out));
        assert_eq!(listing(&t.0), Vec::<String>::new(), "left after {sig}");
    }
}

#[cfg(unix)]
#[test]
fn stale_temporary_files_of_dead_processes_are_swept() {
    let ds = dataset();
    let t = Tmp::new("sweep");
    // A PID that just ended.
    let mut c = Command::new("true").spawn().unwrap();
    let dead = c.id();
    c.wait().unwrap();
    let live = std::process::id();
    std::fs::write(t.join(&format!(".c.ply.f3d-tmp-{dead}-0")), b"stale").unwrap();
    std::fs::create_dir(t.join(&format!("ds.f3d-tmp-{dead}-3"))).unwrap();
    std::fs::write(t.join(&format!("ds.f3d-tmp-{dead}-3/img.png")), b"x").unwrap();
    std::fs::write(t.join(&format!(".c.ply.f3d-tmp-{live}-0")), b"in use").unwrap();
    // An old folder moved aside whose replacement never arrived: kept, it may be the only copy.
    std::fs::create_dir(t.join(&format!("gone.f3d-old-{dead}-1"))).unwrap();
    std::fs::write(t.join("notes.tmp-1-0"), b"user file").unwrap();
    let out = t.join("c.ply");
    let o = scan(&ds, &["-q".as_ref(), "-o".as_ref(), out.as_os_str()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let mut want = vec![
        format!(".c.ply.f3d-tmp-{live}-0"),
        "c.ply".to_string(),
        format!("gone.f3d-old-{dead}-1"),
        "notes.tmp-1-0".to_string(),
    ];
    want.sort();
    assert_eq!(listing(&t.0), want);
}

#[test]
fn output_names_up_to_255_bytes_work() {
    let ds = dataset();
    let t = Tmp::new("longname");
    // 251 + ".ply": the longest legal name; its temporary name must fit too.
    let name = format!("{}.ply", "a".repeat(251));
    let out = t.join(&name);
    let o = scan(&ds, &["-q".as_ref(), "-o".as_ref(), out.as_os_str()]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(listing(&t.0), [name]);
    // Multi-byte characters are cut at a character boundary.
    let name = format!("{}.ply", "é".repeat(125));
    let o = scan(
        &ds,
        &["-q".as_ref(), "-o".as_ref(), t.join(&name).as_os_str()],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    // A folder of 255 bytes.
    let dir = t.join(&"d".repeat(255));
    let o = bin()
        .args(["decode", "-q", "--patterns"])
        .arg(ds.join("patterns.toml"))
        .arg(&ds.0)
        .arg("--out")
        .arg(&dir)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(dir.join("phase.tif").is_file());
    assert_eq!(listing(&t.0).len(), 3, "{:?}", listing(&t.0));
}
