//! `fringe3d device` against a missing port, a silent line, a device speaking another protocol
//! version and one speaking garbage: every case ends quickly with an error that says what is
//! wrong. The far ends are fakes on a pseudo-terminal pair (no head involved).

use std::io::{Read, Write};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use fringe3d::device::{Client, ClientOptions, DeviceError, SerialTransport, open_serial};
use fringe3d_core::wire::crc::crc32c;
use fringe3d_core::wire::{
    Capabilities, FirmwareVersion, FrameReceiver, MAX_ENCODED_FRAME, Message, Nak, NakCode,
    PROTOCOL_VERSION, cobs,
};
use serialport::{SerialPort, TTYPort};

fn quick() -> ClientOptions {
    ClientOptions {
        timeout: Duration::from_millis(60),
        retries: 2,
        window: 2,
        scan_timeout: Duration::from_millis(200),
    }
}

/// A fake device on the master end of a PTY pair: `answer` maps each intact frame received to the
/// bytes sent back. Returns the client's transport on the slave end.
fn fake(
    answer: impl Fn(&[u8]) -> Vec<u8> + Send + 'static,
) -> (
    SerialTransport,
    Arc<AtomicBool>,
    std::thread::JoinHandle<()>,
) {
    let (mut master, slave) = TTYPort::pair().expect("a PTY pair");
    master.set_timeout(Duration::from_millis(10)).unwrap();
    let stop = Arc::new(AtomicBool::new(false));
    let s = stop.clone();
    let h = std::thread::spawn(move || {
        let mut dec = FrameReceiver::new([0u8; MAX_ENCODED_FRAME]);
        let mut buf = [0u8; 512];
        while !s.load(Ordering::Relaxed) {
            let n = match master.read(&mut buf) {
                Ok(n) => n,
                Err(_) => continue,
            };
            let mut input = &buf[..n];
            while !input.is_empty() {
                let (used, ev) = dec.feed(input);
                input = &input[used..];
                if let Some(Ok(f)) = ev {
                    let reply = answer(f);
                    let _ = master.write_all(&reply);
                }
            }
        }
    });
    (
        SerialTransport::from_port(Box::new(slave) as Box<dyn SerialPort>, 921_600),
        stop,
        h,
    )
}

/// Line bytes of a frame with an arbitrary version byte.
fn frame_with_version(version: u8, seq: u8, msg: &Message<'_>) -> Vec<u8> {
    let mut payload = [0u8; 256];
    let n = msg.encode(&mut payload).unwrap();
    let flags = if matches!(msg, Message::Nak(_)) {
        0x04
    } else {
        0
    }; // ERROR on a Nak
    let mut f = vec![version, flags, seq, msg.command() as u8, n as u8, 0];
    f.extend_from_slice(&payload[..n]);
    let crc = crc32c(&f);
    f.extend_from_slice(&crc.to_le_bytes());
    let mut out = vec![0u8; f.len() + 8];
    let m = cobs::encode(&f, &mut out).unwrap();
    out.truncate(m);
    out.push(0);
    out
}

#[test]
fn a_missing_port_is_named() {
    let e = open_serial("/dev/fringe3d-no-such-port", 921_600)
        .err()
        .expect("no such port");
    let m = e.to_string();
    assert!(matches!(e, DeviceError::Open { .. }), "{m}");
    assert!(
        m.contains("/dev/fringe3d-no-such-port") && m.contains("plugged in"),
        "{m}"
    );
    // Through the CLI as a user runs it.
    let e = fringe3d::cli::run([
        "fringe3d",
        "--quiet",
        "device",
        "info",
        "--port",
        "/dev/fringe3d-no-such-port",
    ])
    .unwrap_err();
    let m = format!("{e:#}");
    assert!(m.contains("cannot open /dev/fringe3d-no-such-port"), "{m}");
}

#[test]
fn a_silent_line_times_out_with_a_hint() {
    let (io, stop, h) = fake(|_| Vec::new());
    let t0 = Instant::now();
    let e = Client::connect(io, quick()).err().expect("nobody answers");
    let m = e.to_string();
    assert!(
        matches!(e, DeviceError::NoResponse { attempts: 3, .. }),
        "{m}"
    );
    assert!(
        m.contains("no answer from the device to Hello after 3 attempts"),
        "{m}"
    );
    assert!(t0.elapsed() < Duration::from_secs(3));
    stop.store(true, Ordering::Relaxed);
    h.join().unwrap();
}

#[test]
fn another_protocol_version_is_reported_as_such() {
    // An old head (protocol 1) cannot parse our version-4 Hello: it answers, in its own version,
    // Nak Version naming the version it speaks.
    let (io, stop, h) = fake(|f| {
        let nak = Nak {
            command: f[3],
            code: NakCode::Version,
            detail: 1,
        };
        frame_with_version(1, f[2], &Message::Nak(nak))
    });
    let e = Client::connect(io, quick()).err().expect("version 1");
    let m = e.to_string();
    assert!(
        matches!(
            e,
            DeviceError::Version {
                device: 1,
                host: PROTOCOL_VERSION
            }
        ),
        "{m}"
    );
    assert!(
        m.contains("protocol version 1")
            && m.contains(&format!("version {PROTOCOL_VERSION}"))
            && m.contains("update"),
        "{m}"
    );
    stop.store(true, Ordering::Relaxed);
    h.join().unwrap();

    // A newer head (the next protocol) answering Capabilities in its version.
    const NEWER: u8 = PROTOCOL_VERSION + 1;
    let (io, stop, h) = fake(|f| {
        let caps = Capabilities {
            protocol_version: NEWER,
            firmware: FirmwareVersion {
                major: 4,
                minor: 0,
                patch: 0,
            },
            sensor_width: 64,
            sensor_height: 48,
            projector_width: 64,
            projector_height: 48,
            free_memory: 1,
            max_chunk: 64,
            max_sets: 1,
            max_lut_entries: 1,
        };
        frame_with_version(NEWER, f[2], &Message::Capabilities(caps))
    });
    let e = Client::connect(io, quick()).err().expect("a newer version");
    let m = e.to_string();
    assert!(
        matches!(
            e,
            DeviceError::Version {
                device: NEWER,
                host: PROTOCOL_VERSION
            }
        ),
        "{m}"
    );
    stop.store(true, Ordering::Relaxed);
    h.join().unwrap();
}

#[test]
fn a_device_speaking_garbage_is_not_mistaken_for_a_head() {
    let (io, stop, h) = fake(|f| {
        // Bytes with delimiters: frames, but never intact ones.
        let mut v: Vec<u8> = f
            .iter()
            .map(|b| b.wrapping_mul(31).wrapping_add(7))
            .collect();
        v.extend_from_slice(&[0x41, 0x54, 0x0d, 0x00, 0x05, 0x99, 0x98, 0x97, 0x96, 0x00]);
        v
    });
    let e = Client::connect(io, quick()).err().expect("garbage");
    let m = e.to_string();
    assert!(matches!(e, DeviceError::NoResponse { .. }), "{m}");
    assert!(m.contains("damaged frames received"), "{m}");
    stop.store(true, Ordering::Relaxed);
    h.join().unwrap();
}

/// A reference map wider than the image (issue #17 item 3) travels on the wire since protocol
/// version 6: `device upload` prepares it like an image-sized one and only then meets the
/// (missing) port. (`tests/tests/head_pty.rs` scans with such a map on a simulated head.)
#[test]
fn a_reference_wider_than_the_image_goes_to_the_line_like_any_other() {
    let dir = std::env::temp_dir().join(format!("fringe3d-dev-margin-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let s = |p: &std::path::Path| p.to_str().unwrap().to_string();
    let cli = |args: &[&str]| {
        let mut a = vec!["fringe3d", "--quiet"];
        a.extend(args);
        fringe3d::cli::run(a)
    };
    let ds = dir.join("ds");
    cli(&[
        "render",
        "--scene",
        "sphere",
        "--size",
        "160x128",
        "--bits",
        "8",
        "--pattern-bits",
        "8",
        "--out",
        &s(&ds),
    ])
    .unwrap();
    let (set, cal) = (
        s(&ds.join("patterns.toml")),
        s(&ds.join("calibration.toml")),
    );
    let port = "/dev/fringe3d-no-such-port";
    for margin in ["auto", "0"] {
        let out = dir.join(format!("v{margin}/calibration.toml"));
        cli(&[
            "calibrate",
            "reference",
            "--virtual",
            "-p",
            &set,
            "-c",
            &cal,
            "--margin",
            margin,
            "-o",
            &s(&out),
        ])
        .unwrap();
        let e = cli(&[
            "device",
            "upload",
            "--port",
            port,
            "--patterns",
            &set,
            "--calibration",
            &s(&out),
        ])
        .unwrap_err();
        let m = format!("{e:#}");
        assert!(m.contains(port) && !m.contains("margin"), "{m}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}
