//! The `fringe3d-head` binary on a PTY, driven by the `fringe3d device` CLI: info, a parametric
//! upload (the head renders the patterns) and a phase scan written to a TIFF.

use std::io::{BufRead, BufReader};
use std::process::{Command, Stdio};

#[test]
fn the_binary_serves_the_cli_on_a_pty() {
    let dir = std::env::temp_dir().join(format!("fringe3d-head-bin-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let set = dir.join("set.toml");
    std::fs::write(
        &set,
        "version = 1\npreset = \"paper8\"\nratio = 8.0\n[projector]\nwidth = 128\nheight = 96\nbit_depth = 8\n\
         [phase]\naxis = \"xi\"\nkind = \"linear\"\norigin = 63.5\nslope = 0.015625\n",
    )
    .unwrap();
    // A "dataset" whose camera sees the patterns themselves: `fringe3d patterns` lists them.
    let data = dir.join("data");
    fringe3d::cli::run([
        "fringe3d",
        "--quiet",
        "patterns",
        "--patterns",
        set.to_str().unwrap(),
        "--out",
        data.to_str().unwrap(),
    ])
    .unwrap();

    let mut child = Command::new(env!("CARGO_BIN_EXE_fringe3d-head"))
        .arg(&data)
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let mut out = BufReader::new(child.stdout.take().unwrap());
    let mut port = String::new();
    for _ in 0..4 {
        let mut line = String::new();
        out.read_line(&mut line).unwrap();
        if let Some(p) = line.strip_prefix("PTY ") {
            port = p.trim().to_string();
            break;
        }
    }
    assert!(port.starts_with("/dev/"), "no PTY line: {port:?}");
    let run = |args: &[&str]| {
        let mut v = vec!["fringe3d", "--quiet", "device"];
        v.extend_from_slice(args);
        fringe3d::cli::run(v)
    };
    let r = (|| {
        run(&["info", "--port", &port])?;
        run(&[
            "upload",
            "--port",
            &port,
            "--patterns",
            data.join("patterns.toml").to_str().unwrap(),
            "--parametric",
        ])?;
        let tif = dir.join("phase.tif");
        run(&[
            "scan",
            "--port",
            &port,
            "--output",
            "phase",
            "--phase-out",
            tif.to_str().unwrap(),
        ])?;
        let (img, _) = fringe3d::io::image::read_gray(&tif)?;
        anyhow::ensure!((img.width, img.height) == (128, 96), "phase map size");
        // A scan of points without calibration is refused with the reason.
        let e = run(&[
            "scan",
            "--port",
            &port,
            "--out",
            dir.join("c.ply").to_str().unwrap(),
        ])
        .unwrap_err();
        anyhow::ensure!(format!("{e:#}").contains("no calibration"), "{e:#}");
        Ok(())
    })();
    let _ = child.kill();
    let _ = child.wait();
    let _ = std::fs::remove_dir_all(&dir);
    r.unwrap();
}
