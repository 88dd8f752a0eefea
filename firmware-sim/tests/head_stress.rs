//! Seeded stress (issue #21): the simulated head behind an in-process fault injector, over
//! hundreds of scans and uploads, with every kind of line trouble at once — byte drops, bit
//! flips, duplicates and cuts (the core's `FaultInjector`, both directions), and on the head's
//! answers whole-frame faults: drops, duplicates, delays (held back past later frames and
//! timeouts), reordering, and stale replays (frames of earlier scans and sessions; their rows
//! re-numbered with the current `seq`, as a host process restarting its numbers would see them)
//! — plus disconnects mid-session. Every scan must either equal the clean result bit for bit or
//! fail with a line error; every confirmed upload must be exactly the data. Never a silent
//! difference.

use std::collections::VecDeque;
use std::time::Instant;

use embedded_io::{ErrorType, Read, Write};
use fringe3d::device::desc::{capture_sequence, pattern_bytes, pattern_desc, render_pattern};
use fringe3d::device::{Client, DeviceError, Transport};
use fringe3d_core::wire::{
    EdgeFilterMode, FaultConfig, Flags, Header, MAX_ENCODED_FRAME, MAX_FRAME, Message, ResultRow,
    ScanDone, ScanOutput, XorShift64, cobs, emit_packet, parse_packet,
};
use fringe3d_head::desktop::{InProcess, OwnedMemory};
use fringe3d_head::sim::{NoSink, SimWorld};

use crate::link_support::*;

/// The value of every column of a stale row (no decoded phase takes it).
const MARK: f32 = 1.0e6;

/// Frame-level faults on the head's answers, per frame, in parts per million.
#[derive(Clone, Copy, Debug)]
struct Chaos {
    drop: u32,
    duplicate: u32,
    delay: u32,
    swap: u32,
    stale: u32,
}

/// What [`Chaotic`] did.
#[derive(Clone, Copy, Debug, Default)]
struct ChaosStats {
    frames: u64,
    dropped: u64,
    duplicated: u64,
    delayed: u64,
    swapped: u64,
    stale: u64,
}

impl ChaosStats {
    fn faults(&self) -> u64 {
        self.dropped + self.duplicated + self.delayed + self.swapped + self.stale
    }
}

/// A transport between the host and `inner` that mistreats whole frames of the head's answers.
struct Chaotic<T> {
    inner: T,
    cfg: Chaos,
    rng: XorShift64,
    partial: Vec<u8>,
    out: VecDeque<u8>,
    /// Frames held back: (frames still to pass before release, the encoded frame).
    held: Vec<(u32, Vec<u8>)>,
    /// One frame waiting to be swapped with the next.
    swap: Option<Vec<u8>>,
    /// Decoded frames seen so far (the stale pool).
    pool: Vec<Vec<u8>>,
    /// The scan identity of the last row or ScanDone seen: the scan streaming now. Only rows
    /// of other scans are stale (a row of this scan with other values would be a forgery, which
    /// the CRC-checked link does not claim to catch).
    current: Option<u32>,
    stats: ChaosStats,
}

fn encode(f: &[u8]) -> Vec<u8> {
    let mut out = vec![0u8; f.len() + f.len() / 254 + 2];
    let n = cobs::encode(f, &mut out).unwrap();
    out.truncate(n);
    out
}

impl<T> Chaotic<T> {
    fn new(inner: T, cfg: Chaos, seed: u64) -> Self {
        Chaotic {
            inner,
            cfg,
            rng: XorShift64::new(seed ^ 0xC4A0_5EED),
            partial: Vec::new(),
            out: VecDeque::new(),
            held: Vec::new(),
            swap: None,
            pool: Vec::new(),
            current: None,
            stats: ChaosStats::default(),
        }
    }

    fn emit(&mut self, enc: &[u8]) {
        self.out.extend(enc);
        self.out.push_back(0);
        // Frames held back move one step nearer their release.
        let mut due = Vec::new();
        self.held.retain_mut(|(left, f)| {
            if *left == 0 {
                due.push(std::mem::take(f));
                false
            } else {
                *left -= 1;
                true
            }
        });
        for f in due {
            self.out.extend(&f);
            self.out.push_back(0);
        }
    }

    /// A stale frame from the pool: rows and ScanDones re-numbered with `seq` (the worst case;
    /// the rows' values replaced by a marker, as an earlier scan of another scene would give, so
    /// that a stale row assembled into a result shows), anything else as it was.
    fn stale(&mut self, seq: u8) -> Option<Vec<u8>> {
        if self.pool.is_empty() {
            return None;
        }
        let old = self.pool[self.rng.below(self.pool.len() as u32) as usize].clone();
        let (h, msg) = parse_packet(&old).ok()?;
        let mut data: Vec<u8>;
        let msg = match msg {
            Message::ResultRow(ResultRow { scan_id: id, .. })
            | Message::ScanDone(ScanDone { scan_id: id, .. })
                if Some(id) == self.current =>
            {
                return None;
            }
            Message::ResultRow(r) => {
                data = r.data.to_vec();
                let n = r.columns() * r.kind.components();
                for v in data[..4 * n].chunks_exact_mut(4) {
                    v.copy_from_slice(&MARK.to_le_bytes());
                }
                data[4 * n..].fill(0);
                Message::ResultRow(ResultRow { data: &data, ..r })
            }
            m @ Message::ScanDone(_) => m,
            _ => return Some(encode(&old)),
        };
        let mut hdr = Header::for_message(&msg, seq);
        hdr.flags = hdr
            .flags
            .with(Flags::MORE_FOLLOWS, h.flags.contains(Flags::MORE_FOLLOWS));
        let (mut scratch, mut line) = ([0u8; MAX_FRAME], [0u8; MAX_ENCODED_FRAME]);
        let k = emit_packet(&hdr, &msg, &mut scratch, &mut line).ok()?;
        Some(line[..k - 1].to_vec())
    }

    /// One frame from the head (COBS bytes without the delimiter).
    fn frame(&mut self, enc: Vec<u8>) {
        self.stats.frames += 1;
        let mut f = vec![0u8; enc.len()];
        let decoded = cobs::decode(&enc, &mut f).ok().map(|n| {
            f.truncate(n);
            f
        });
        let seq = decoded.as_ref().and_then(|f| f.get(2).copied());
        if let Some(Ok((_, Message::ResultRow(ResultRow { scan_id: id, .. }))))
        | Some(Ok((_, Message::ScanDone(ScanDone { scan_id: id, .. })))) =
            decoded.as_deref().map(parse_packet)
        {
            self.current = Some(id);
        }
        if let Some(f) = decoded.filter(|f| parse_packet(f).is_ok()) {
            if self.pool.len() < 4000 {
                self.pool.push(f);
            } else {
                let i = self.rng.below(4000) as usize;
                self.pool[i] = f;
            }
        }
        let c = self.cfg;
        if let Some(seq) = seq
            && self.rng.chance(c.stale)
            && let Some(s) = self.stale(seq)
        {
            self.stats.stale += 1;
            self.emit(&s);
        }
        if self.rng.chance(c.drop) {
            self.stats.dropped += 1;
            return;
        }
        if self.rng.chance(c.delay) {
            self.stats.delayed += 1;
            let k = 1 + self.rng.below(40);
            self.held.push((k, enc));
            return;
        }
        if let Some(prev) = self.swap.take() {
            self.emit(&enc);
            self.emit(&prev);
            return;
        }
        if self.rng.chance(c.swap) {
            self.stats.swapped += 1;
            self.swap = Some(enc);
            return;
        }
        if self.rng.chance(c.duplicate) {
            self.stats.duplicated += 1;
            self.emit(&enc);
        }
        self.emit(&enc);
    }

    /// Time passes (a timeout): every frame held back arrives.
    fn release(&mut self) -> bool {
        let mut any = false;
        for (_, f) in std::mem::take(&mut self.held) {
            self.out.extend(&f);
            self.out.push_back(0);
            any = true;
        }
        if let Some(f) = self.swap.take() {
            self.out.extend(&f);
            self.out.push_back(0);
            any = true;
        }
        any
    }
}

impl<T> ErrorType for Chaotic<T> {
    type Error = core::convert::Infallible;
}

impl<T: Transport + ErrorType<Error = core::convert::Infallible>> Read for Chaotic<T> {
    fn read(&mut self, buf: &mut [u8]) -> Result<usize, Self::Error> {
        if self.out.is_empty() {
            let mut tmp = [0u8; 4096];
            let n = self.inner.read(&mut tmp)?;
            for &b in &tmp[..n] {
                if b == 0 {
                    let enc = std::mem::take(&mut self.partial);
                    if enc.is_empty() {
                        self.out.push_back(0);
                    } else {
                        self.frame(enc);
                    }
                } else {
                    self.partial.push(b);
                }
            }
        }
        let n = buf.len().min(self.out.len());
        for (d, b) in buf.iter_mut().zip(self.out.drain(..n)) {
            *d = b;
        }
        Ok(n)
    }
}

impl<T: Transport + ErrorType<Error = core::convert::Infallible>> Write for Chaotic<T> {
    fn write(&mut self, buf: &[u8]) -> Result<usize, Self::Error> {
        self.inner.write(buf)
    }

    fn flush(&mut self) -> Result<(), Self::Error> {
        Ok(())
    }
}

impl<T: Transport + ErrorType<Error = core::convert::Infallible>> Transport for Chaotic<T> {
    fn wait(&mut self, deadline: Instant) -> bool {
        if !self.out.is_empty() {
            return true;
        }
        let more = self.inner.wait(deadline);
        // A wait that ends is a timeout: the frames held back arrive meanwhile.
        more || self.release()
    }

    fn clear_input(&mut self) {
        self.inner.clear_input();
    }
}

/// What the stress run did.
#[derive(Debug, Default)]
struct Tally {
    scans_ok: u64,
    scans_failed: u64,
    uploads_ok: u64,
    uploads_failed: u64,
    stale_dropped: u64,
    rescans: u64,
    disconnects: u64,
    /// Frames dropped, duplicated, delayed, swapped, stale frames replayed.
    frame_faults: [u64; 5],
    /// Byte faults (drops, flips, duplicates, cuts), both directions.
    byte_faults: u64,
}

/// The row windows each session scans: (first row, rows; 0 = to the end).
const WINDOWS: [(u16, u16); 4] = [(0, 0), (5, 11), (CH - 7, 0), (20, 1)];

/// A line error, with a message: the only acceptable failure under line faults.
fn line_error(seed: u64, what: &str, e: &DeviceError) {
    let m = e.to_string();
    assert!(
        e.is_transient() || matches!(e, DeviceError::DigestMismatch { .. }),
        "seed {seed}: {what}: a non-line error under line faults: {m}"
    );
    assert!(m.len() > 20, "seed {seed}: {what}: unclear error {m:?}");
}

fn run_seed(seed: u64, truth: &(Vec<f32>, Vec<u8>), data: &[u8], tally: &mut Tally) -> u64 {
    let set = exact_set();
    let d = pattern_desc(&set, 8).unwrap();
    let world = SimWorld::new(READOUT_NS);
    let mut mem = OwnedMemory::new(plan());
    let h = head(&world, &mut mem, &set, &d, NoSink);
    let up = FaultConfig {
        drop_ppm: 25,
        corrupt_ppm: 25,
        duplicate_ppm: 25,
        cut_ppm: 5,
        max_cut_len: 3000,
    };
    let down = FaultConfig {
        drop_ppm: 100,
        corrupt_ppm: 100,
        duplicate_ppm: 100,
        cut_ppm: 10,
        max_cut_len: 2000,
    };
    let chaos = Chaos {
        drop: 20_000,
        duplicate: 20_000,
        delay: 20_000,
        swap: 20_000,
        stale: 40_000,
    };
    let mut rng = XorShift64::new(seed);
    let mut io = Chaotic::new(InProcess::new(h, up, down, seed), chaos, seed);
    let w = CW as usize;
    let mut uploaded = false;
    // Sessions: a user running the command again after a failure.
    for session in 0..4 {
        // Now and then the cable is pulled somewhere in the session.
        if session < 3 && rng.chance(250_000) {
            let sent = io.inner.fault_stats().0.bytes;
            io.inner.cut_after(sent + 2_000 + rng.below(60_000) as u64);
            tally.disconnects += 1;
        }
        let mut c = Client::open(io, opts());
        let mut failed = false;
        if let Err(e) = c.hello() {
            line_error(seed, "hello", &e);
            failed = true;
        }
        if !failed && !uploaded {
            let r = c
                .define_pattern_set(0, &d)
                .and_then(|()| c.upload_patterns(0, &d, data, &mut |_, _| {}));
            match r {
                Ok(rep) => {
                    assert_eq!(rep.total, data.len() as u64);
                    let held = &c
                        .link()
                        .transport()
                        .inner
                        .device
                        .board()
                        .pattern_store
                        .bytes()[..data.len()];
                    assert!(held == data, "seed {seed}: a confirmed upload differs");
                    tally.uploads_ok += 1;
                    uploaded = true;
                }
                Err(e) => {
                    line_error(seed, "upload", &e);
                    tally.uploads_failed += 1;
                    failed = true;
                }
            }
        }
        if !failed {
            let seq = capture_sequence(&set, &d, EXPOSURE_US, DARK_US).unwrap();
            if let Err(e) = c.configure_sequence(0, false, &seq) {
                line_error(seed, "configure", &e);
                failed = true;
            }
        }
        if !failed {
            for &(first, n) in &WINDOWS {
                let rows = if n == 0 { CH - first } else { n } as usize;
                match c.scan(
                    ScanOutput::Phase,
                    first,
                    n,
                    EdgeFilterMode::Off,
                    &mut |_, _| {},
                ) {
                    Ok(out) => {
                        let r = first as usize * w..(first as usize + rows) * w;
                        assert!(
                            bits(out.phase.as_ref().unwrap()) == bits(&truth.0[r.clone()]),
                            "seed {seed}: rows {first}+{rows}: phases differ"
                        );
                        assert!(
                            out.phase_validity.as_ref().unwrap()[..] == truth.1[r],
                            "seed {seed}: rows {first}+{rows}: validity differs"
                        );
                        tally.scans_ok += 1;
                        tally.stale_dropped += out.stale_rows;
                        tally.rescans += out.rescans as u64;
                    }
                    Err(e) => {
                        line_error(seed, "scan", &e);
                        tally.scans_failed += 1;
                        failed = true;
                        break;
                    }
                }
            }
        }
        io = c.into_transport();
        io.inner.set_connected(true);
        if !failed {
            break;
        }
    }
    let (a, b) = io.inner.fault_stats();
    let k = io.stats;
    tally.frame_faults[0] += k.dropped;
    tally.frame_faults[1] += k.duplicated;
    tally.frame_faults[2] += k.delayed;
    tally.frame_faults[3] += k.swapped;
    tally.frame_faults[4] += k.stale;
    tally.byte_faults += a.faults() + b.faults();
    a.faults() + b.faults() + k.faults()
}

#[test]
fn hundreds_of_scans_and_uploads_under_every_line_fault_match_or_fail_loudly() {
    let set = exact_set();
    let d = pattern_desc(&set, 8).unwrap();
    let truth = desktop_phase(&set, &d);
    let data = pattern_bytes(&set, &d, |i| render_pattern(&set, i)).unwrap();
    let seeds: u64 = std::env::var("FRINGE3D_STRESS_SEEDS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(150);
    let t0 = Instant::now();
    let mut tally = Tally::default();
    let mut faults = 0;
    for seed in 0..seeds {
        faults += run_seed(seed, &truth, &data, &mut tally);
    }
    eprintln!(
        "{seeds} seeds in {:.1} s: {faults} faults injected; {tally:?}",
        t0.elapsed().as_secs_f64()
    );
    let scans = tally.scans_ok + tally.scans_failed;
    assert!(scans >= 3 * seeds, "{scans} scans");
    assert!(faults >= 30 * seeds, "only {faults} faults");
    assert!(
        tally.frame_faults.iter().all(|&n| n > 0) && tally.byte_faults > 0,
        "every kind of fault happened: {tally:?}"
    );
    assert!(tally.disconnects > 0, "{tally:?}");
    assert!(tally.stale_dropped > 0, "no stale frame reached a scan");
    assert!(
        tally.scans_ok * 10 >= scans * 8,
        "too few scans completed: {tally:?}"
    );
    assert!(tally.uploads_ok * 10 >= seeds * 9, "{tally:?}");
}
