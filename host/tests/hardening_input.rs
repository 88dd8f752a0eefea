//! Hardening of the input side: headers that declare huge images (decompression bombs), and
//! inputs that are no regular files.

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_fringe3d"))
}

/// A scratch folder removed at the end of the test.
struct Tmp(PathBuf);
impl Tmp {
    fn new(name: &str) -> Tmp {
        let p = std::env::temp_dir().join(format!(
            "fringe3d-hardening-in-{}-{name}",
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

/// Expect a clean failure: exit status 1 (not a signal, not a panic); returns stderr.
fn fails(o: &Output) -> String {
    let e = String::from_utf8_lossy(&o.stderr).into_owned();
    assert_eq!(o.status.code(), Some(1), "expected exit 1; stderr: {e}");
    assert!(!e.contains("panicked"), "panic: {e}");
    e
}

fn crc32(data: &[u8]) -> u32 {
    let mut c = !0u32;
    for &b in data {
        c ^= b as u32;
        for _ in 0..8 {
            c = if c & 1 != 0 {
                0xEDB8_8320 ^ (c >> 1)
            } else {
                c >> 1
            };
        }
    }
    !c
}

fn chunk(out: &mut Vec<u8>, kind: &[u8; 4], data: &[u8]) {
    out.extend_from_slice(&(data.len() as u32).to_be_bytes());
    let mut body = kind.to_vec();
    body.extend_from_slice(data);
    out.extend_from_slice(&body);
    out.extend_from_slice(&crc32(&body).to_be_bytes());
}

/// A tiny PNG whose header declares `w × h` pixels (`depth` bits, `color` type) over a few
/// hundred bytes of zeros: what a decompression bomb looks like before its data.
fn png_declaring(w: u32, h: u32, depth: u8, color: u8) -> Vec<u8> {
    let mut v = b"\x89PNG\r\n\x1a\n".to_vec();
    let mut ihdr = Vec::new();
    ihdr.extend_from_slice(&w.to_be_bytes());
    ihdr.extend_from_slice(&h.to_be_bytes());
    ihdr.extend_from_slice(&[depth, color, 0, 0, 0]);
    chunk(&mut v, b"IHDR", &ihdr);
    // A stored (uncompressed) zlib block of 512 zero bytes.
    let mut z = vec![0x78, 0x01, 0x01, 0x00, 0x02, 0xff, 0xfd];
    z.extend_from_slice(&[0u8; 512]);
    z.extend_from_slice(&[0x02, 0x00, 0x00, 0x01]); // Adler-32 of the zeros
    chunk(&mut v, b"IDAT", &z);
    chunk(&mut v, b"IEND", &[]);
    v
}

/// A BMP header with `bpp` bits per pixel and `side × side` pixels, and no pixel data.
fn bmp_declaring(side: i32, bpp: u16) -> Vec<u8> {
    let mut b = Vec::new();
    b.extend_from_slice(b"BM");
    b.extend_from_slice(&54u32.to_le_bytes());
    b.extend_from_slice(&[0; 4]);
    b.extend_from_slice(&54u32.to_le_bytes());
    b.extend_from_slice(&40u32.to_le_bytes());
    b.extend_from_slice(&side.to_le_bytes());
    b.extend_from_slice(&side.to_le_bytes());
    b.extend_from_slice(&1u16.to_le_bytes());
    b.extend_from_slice(&bpp.to_le_bytes());
    b.extend_from_slice(&[0; 24]);
    b
}

fn info(p: &Path) -> Output {
    let mut c = bin();
    c.arg("info").arg(p);
    run_within(c, Duration::from_secs(20))
}

#[test]
fn huge_declared_images_are_refused_before_decoding() {
    let t = Tmp::new("bombs");
    // 100000² 16-bit RGBA in about 1 KB: used to abort allocating 80 GB.
    let a = t.join("rgba16.png");
    std::fs::write(&a, png_declaring(100_000, 100_000, 16, 6)).unwrap();
    // 60000² gray: used to cost gigabytes and a minute before failing.
    let b = t.join("gray.png");
    std::fs::write(&b, png_declaring(60_000, 60_000, 8, 0)).unwrap();
    // A BMP with 0 bits per pixel and 2³¹−1 sides: used to abort.
    let c = t.join("zero.bmp");
    std::fs::write(&c, bmp_declaring(i32::MAX, 0)).unwrap();
    // The same sides at 8 bits per pixel: refused by size, not by a failed allocation.
    let d = t.join("big.bmp");
    std::fs::write(&d, bmp_declaring(i32::MAX, 8)).unwrap();
    for (p, name, want) in [
        (&a, "rgba16.png", "100000x100000"),
        (&b, "gray.png", "60000x60000"),
        (&c, "zero.bmp", "0-bit"),
        (&d, "big.bmp", "2147483647x2147483647"),
    ] {
        let t0 = Instant::now();
        let e = fails(&info(p));
        assert!(e.contains(name) && e.contains(want), "{e}");
        assert!(
            t0.elapsed() < Duration::from_secs(10),
            "{name}: {:?}",
            t0.elapsed()
        );
    }
    // The library says why, before allocating.
    let e =
        fringe3d::io::image::decode_gray(&png_declaring(100_000, 100_000, 16, 6), &a).unwrap_err();
    assert!(
        matches!(e, fringe3d::io::image::ImageError::TooLarge { .. }),
        "{e}"
    );
}

#[test]
fn an_image_of_another_size_in_a_set_is_refused_from_its_header() {
    let t = Tmp::new("setsize");
    let set = t.join("set.toml");
    std::fs::write(
        &set,
        "version = 1\npreset = \"paper8\"\nratio = 4.0\n[projector]\nwidth = 64\nheight = 48\n[phase]\naxis = \"xi\"\nkind = \"centered\"\n",
    )
    .unwrap();
    let mut imgs = Vec::new();
    for i in 0..8 {
        let p = t.join(&format!("i{i}.png"));
        if i == 5 {
            // Within the cap, but not the first image's size: never decoded.
            std::fs::write(&p, png_declaring(16_000, 16_000, 16, 6)).unwrap();
        } else {
            fringe3d::io::image::write_png_u8(&p, 64, 48, &vec![100u8; 64 * 48]).unwrap();
        }
        imgs.push(p);
    }
    let mut c = bin();
    c.args(["decode", "--patterns"]).arg(&set);
    c.args(&imgs).arg("--out").arg(t.join("out"));
    let e = fails(&run_within(c, Duration::from_secs(20)));
    assert!(
        e.contains("i5.png") && e.contains("16000x16000") && e.contains("64x48"),
        "{e}"
    );
    assert!(!t.join("out").exists());
}

#[cfg(unix)]
fn mkfifo(p: &Path) {
    let st = Command::new("mkfifo").arg(p).status().unwrap();
    assert!(st.success(), "mkfifo {}", p.display());
}

#[cfg(unix)]
#[test]
fn inputs_that_are_no_regular_files_are_refused_at_once() {
    let t = Tmp::new("special");
    let fifo_png = t.join("fifo.png");
    mkfifo(&fifo_png);
    let zero_png = t.join("zero.png");
    std::os::unix::fs::symlink("/dev/zero", &zero_png).unwrap();
    let fifo_toml = t.join("fifo.toml");
    mkfifo(&fifo_toml);
    let dir_toml = t.join("dir.toml");
    std::fs::create_dir(&dir_toml).unwrap();
    // An image that is a FIFO (used to block forever) or /dev/zero (used to grow without end).
    for (p, kind) in [(&fifo_png, "FIFO"), (&zero_png, "character device")] {
        let e = fails(&info(p));
        assert!(
            e.contains(&*p.file_name().unwrap().to_string_lossy()) && e.contains(kind),
            "{e}"
        );
    }
    // Pattern-set and calibration files.
    for (p, kind) in [(&fifo_toml, "FIFO"), (&dir_toml, "folder")] {
        let e = fails(&info(p));
        assert!(e.contains(&*p.to_string_lossy()) && e.contains(kind), "{e}");
        let mut c = bin();
        c.args(["scan", "--patterns"])
            .arg(p)
            .arg("--calibration")
            .arg(p);
        c.arg(&t.0).arg("-o").arg(t.join("out.ply"));
        let e = fails(&run_within(c, Duration::from_secs(20)));
        assert!(e.contains(&*p.to_string_lossy()) && e.contains(kind), "{e}");
        assert!(!t.join("out.ply").exists());
    }
    // An image of a set.
    let set = t.join("set.toml");
    std::fs::write(
        &set,
        "version = 1\npreset = \"paper8\"\nratio = 4.0\n[projector]\nwidth = 64\nheight = 48\n[phase]\naxis = \"xi\"\nkind = \"centered\"\n",
    )
    .unwrap();
    let good = t.join("good.png");
    fringe3d::io::image::write_png_u8(&good, 64, 48, &vec![100u8; 64 * 48]).unwrap();
    for bad in [&fifo_png, &zero_png] {
        let mut c = bin();
        c.args(["decode", "--patterns"]).arg(&set);
        for i in 0..8 {
            c.arg(if i == 3 { bad } else { &good });
        }
        c.arg("--out").arg(t.join("out"));
        let e = fails(&run_within(c, Duration::from_secs(20)));
        assert!(e.contains(&*bad.to_string_lossy()), "{e}");
        assert!(!t.join("out").exists());
    }
    // A scene file for render.
    let mut c = bin();
    c.args(["render", "--scene"])
        .arg(&fifo_toml)
        .arg("--out")
        .arg(t.join("r"));
    let e = fails(&run_within(c, Duration::from_secs(20)));
    assert!(e.contains("fifo.toml") && e.contains("FIFO"), "{e}");
}
