//! Hardening of the command line: numeric options out of range, standard output closed early,
//! messages.

use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_fringe3d"))
}

/// Run `cmd`, killing it after `limit`; panics if it had to be killed.
fn run_within(mut cmd: Command, limit: Duration) -> Output {
    let mut child = cmd
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let t0 = Instant::now();
    loop {
        if child.try_wait().unwrap().is_some() {
            return child.wait_with_output().unwrap();
        }
        if t0.elapsed() > limit {
            let _ = child.kill();
            let out = child.wait_with_output().unwrap();
            panic!(
                "still running after {limit:?}; stderr: {}",
                String::from_utf8_lossy(&out.stderr)
            );
        }
        std::thread::sleep(Duration::from_millis(20));
    }
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// Run with `args`, expect a refusal of the command line (exit 2, no panic); returns stderr.
fn refused(args: &[&str]) -> String {
    let mut c = bin();
    c.args(args);
    let o = run_within(c, Duration::from_secs(20));
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{args:?}: {e}");
    assert!(!e.contains("panicked"), "{args:?}: {e}");
    e
}

/// A small 8-bit PNG to describe.
fn image(name: &str) -> std::path::PathBuf {
    let p = std::env::temp_dir().join(format!(
        "fringe3d-hardening-cli-{}-{name}.png",
        std::process::id()
    ));
    fringe3d::io::image::write_png_u8(&p, 4, 3, &[7u8; 12]).unwrap();
    p
}

#[test]
fn threads_must_be_1_to_256() {
    let img = image("threads");
    let img = img.to_str().unwrap();
    for bad in [
        "0",
        "257",
        "100000",
        "18446744073709551615",
        "18446744073709551616",
        "x",
    ] {
        let e = refused(&["-j", bad, "info", img]);
        assert!(
            e.contains("--threads") && e.contains("1 to 256"),
            "-j {bad}: {e}"
        );
    }
    let o = bin().args(["-j", "2", "info", img]).output().unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        bin()
            .arg("--help")
            .output()
            .unwrap()
            .stdout
            .windows(10)
            .any(|w| w == b"1 to 256 (")
    );
    let _ = std::fs::remove_file(img);
}

#[test]
fn a_closed_stdout_ends_quietly_with_141() {
    let img = image("pipe");
    for args in [
        vec!["info", img.to_str().unwrap()],
        vec!["--json", "info", img.to_str().unwrap()],
        vec!["render", "--list"],
    ] {
        // A pipe whose reader is gone before the command starts: every write fails (EPIPE).
        let (reader, writer) = std::io::pipe().unwrap();
        drop(reader);
        let o = bin()
            .args(&args)
            .stdout(Stdio::from(writer))
            .stderr(Stdio::piped())
            .output()
            .unwrap();
        let e = stderr(&o);
        assert!(!e.contains("panicked"), "{args:?}: {e}");
        assert_eq!(o.status.code(), Some(141), "{args:?}: {e}");
        assert!(e.is_empty(), "{args:?}: quiet, got {e}");
    }
    // A full standard output is an error, said once.
    if let Ok(full) = std::fs::OpenOptions::new().write(true).open("/dev/full") {
        let o = bin()
            .args(["info", img.to_str().unwrap()])
            .stdout(Stdio::from(full))
            .output()
            .unwrap();
        let e = stderr(&o);
        assert_eq!(o.status.code(), Some(1), "{e}");
        assert!(e.starts_with("error: standard output: cannot write"), "{e}");
        assert!(!e.contains("panicked"), "{e}");
    }
    let _ = std::fs::remove_file(img);
}

#[test]
fn device_numbers_are_checked_when_parsed() {
    let cases: [(&[&str], &str, &str); 9] = [
        (&["info", "--baud", "0"], "--baud", "50 to 20000000"),
        (
            &["info", "--baud", "4294967296"],
            "--baud",
            "50 to 20000000",
        ),
        (
            &["info", "--retries", "4294967295"],
            "--retries",
            "0 to 100",
        ),
        (
            &["info", "--timeout-ms", "0"],
            "--timeout-ms",
            "1 to 3600000",
        ),
        (
            &["info", "--timeout-ms", "18446744073709551615"],
            "--timeout-ms",
            "1 to 3600000",
        ),
        (
            &["scan", "-o", "x.ply", "--scan-timeout-s", "1e300"],
            "--scan-timeout-s",
            "86400",
        ),
        (
            &["scan", "-o", "x.ply", "--scan-timeout-s", "inf"],
            "--scan-timeout-s",
            "86400",
        ),
        (
            &["scan", "-o", "x.ply", "--scan-timeout-s", "NaN"],
            "--scan-timeout-s",
            "86400",
        ),
        (
            &["scan", "-o", "x.ply", "--scan-timeout-s", "0"],
            "--scan-timeout-s",
            "86400",
        ),
    ];
    for (args, opt, range) in cases {
        let mut a = vec!["device"];
        a.extend_from_slice(args);
        a.extend_from_slice(&["--port", "/nonexistent/port"]);
        let e = refused(&a);
        assert!(e.contains(opt) && e.contains(range), "{a:?}: {e}");
    }
}

#[test]
fn messages_say_each_cause_once_and_name_the_option() {
    let dir = std::env::temp_dir().join(format!(
        "fringe3d-hardening-cli-{}-dir.toml",
        std::process::id()
    ));
    std::fs::create_dir_all(&dir).unwrap();
    let d = dir.to_str().unwrap();
    let missing = "/nonexistent/fringe3d/x.png";
    for (args, cause) in [
        (
            vec!["patterns", "--patterns", d, "--out", "/nonexistent/o"],
            "not a regular file",
        ),
        (vec!["info", missing], "(os error 2)"),
    ] {
        let o = bin().args(&args).output().unwrap();
        let e = stderr(&o);
        assert_eq!(o.status.code(), Some(1), "{args:?}: {e}");
        assert_eq!(e.matches(cause).count(), 1, "{args:?}: said twice: {e}");
        assert_eq!(e.lines().count(), 1, "{args:?}: one line: {e}");
    }
    // A zero exposure is refused for what it is, with its range (it was "trigger table:
    // invalid field: lut-entry" from the head).
    let e = refused(&[
        "device",
        "upload",
        "--port",
        "/nonexistent/port",
        "-p",
        d,
        "--exposure-us",
        "0",
    ]);
    assert!(
        e.contains("--exposure-us") && e.contains("1 to 60000000"),
        "{e}"
    );
    let e = refused(&[
        "device",
        "upload",
        "--port",
        "/nonexistent/port",
        "-p",
        d,
        "--dark-us",
        "60000001",
    ]);
    assert!(
        e.contains("--dark-us") && e.contains("0 to 60000000"),
        "{e}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}
