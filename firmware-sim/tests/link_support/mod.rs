//! Shared by the head-link tests: the link geometry, the paper's set, a head over a simulated
//! world, the desktop decode to compare with.
#![allow(dead_code)]

use fringe3d::batch::{FrameOut, Isa, decode_frames};
use fringe3d::device::desc::capture_sequence;
use fringe3d::device::desc::{pattern_bytes, render_pattern};
use fringe3d::device::{Client, ClientOptions, Transport};
use fringe3d_core::decode::{DecodeConfig, Decoder};
use fringe3d_core::math::canonical;
use fringe3d_core::pattern::{Output, PatternSet};
use fringe3d_core::phase_function::{Axis, PhaseFunction};
use fringe3d_core::wire::FaultConfig;
use fringe3d_core::wire::PatternSetDesc;
use fringe3d_head::desktop::{Device, InProcess, OwnedMemory, SimHead, sim_board};
use fringe3d_head::sim::{DirectView, FrameSource, RowSink, Shot, SimWorld};
use fringe3d_head::{Head, HeadConfig, MemoryPlan};
use std::time::Duration;

pub const PW: u16 = 128;
pub const PH: u16 = 96;
pub const CW: u16 = 64;
pub const CH: u16 = 48;
pub const EXPOSURE_US: u32 = 5_000;
pub const DARK_US: u32 = 2_000;
pub const READOUT_NS: u64 = 500_000;

/// The paper's 8-pattern set (slope 2⁻⁶ rad/px, centred); other sets (knots, curves, non-f32
/// parameters) are exercised below and in `tests/tests/head_pty.rs`. The head
/// rebuilds it bit for bit from its wire description.
pub fn exact_set() -> PatternSet {
    let f = PhaseFunction::linear(Axis::Xi, (PW as f64 - 1.0) / 2.0, 1.0 / 64.0).unwrap();
    PatternSet::paper_eight(
        f,
        8.0,
        Output {
            width: PW as u32,
            height: PH as u32,
            i_min: 0.0,
            i_max: 255.0,
        },
    )
    .unwrap()
}

pub fn view(set: &PatternSet, desc: &PatternSetDesc) -> DirectView {
    DirectView {
        set: *set,
        desc: *desc,
        width: CW,
        height: CH,
        bits: 8,
        gain: 0.8,
        offset: 20.0,
    }
}

pub fn opts() -> ClientOptions {
    ClientOptions {
        timeout: Duration::from_millis(200),
        retries: 12,
        window: 4,
        scan_timeout: Duration::from_secs(2),
    }
}

/// The desktop's answer: the camera frames the scene gives under each pattern (set order),
/// decoded by the host's batch path.
pub fn desktop_phase(set: &PatternSet, desc: &PatternSetDesc) -> (Vec<f32>, Vec<u8>) {
    let v = view(set, desc);
    let (w, h) = (CW as usize, CH as usize);
    let frames: Vec<Vec<u16>> = set
        .order()
        .iter()
        .map(|id| {
            let p = desc.pattern_index(*id).unwrap();
            let mut f = vec![0u16; w * h];
            for (y, row) in f.chunks_exact_mut(w).enumerate() {
                v.row(Shot::new(Some(p), 0), y as u16, row).unwrap();
            }
            f
        })
        .collect();
    let refs: Vec<&[u16]> = frames.iter().map(|f| f.as_slice()).collect();
    let d = Decoder::new(set, DecodeConfig::for_bit_depth(8)).unwrap();
    let n = w * h;
    let (mut p, mut m, mut a, mut q) = (vec![0.0; n], vec![0.0; n], vec![0.0; n], vec![0u8; n]);
    decode_frames(
        &d,
        &refs,
        w,
        h,
        FrameOut {
            phase: &mut p,
            modulation: &mut m,
            dc: &mut a,
            validity: &mut q,
        },
        Isa::detect(),
        false,
    )
    .unwrap();
    (p, q)
}

pub fn bits(v: &[f32]) -> Vec<u32> {
    v.iter().map(|x| canonical(*x).to_bits()).collect()
}

pub fn head<'m, 'w, R: RowSink>(
    world: &'w SimWorld,
    mem: &'m mut OwnedMemory,
    set: &PatternSet,
    desc: &PatternSetDesc,
    sink: R,
) -> SimHead<'m, 'w, DirectView, R> {
    let board = sim_board(
        world,
        view(set, desc),
        sink,
        (PW, PH),
        1 << 20,
        CW as usize * CH as usize * 5,
    );
    Head::new(board, mem.memory(), HeadConfig::DEFAULT).unwrap()
}

pub fn plan() -> MemoryPlan {
    MemoryPlan::new(CW as usize, CH as usize, PW as usize, 3, 8)
}

/// Define set 0 from `d` and configure sequence 0 for it (the first steps of every session).
pub fn define_and_configure<T: Transport>(c: &mut Client<T>, set: &PatternSet, d: &PatternSetDesc) {
    c.define_pattern_set(0, d).unwrap();
    c.configure_sequence(
        0,
        false,
        &capture_sequence(set, d, EXPOSURE_US, DARK_US).unwrap(),
    )
    .unwrap();
}

/// A client of `device` over a clean in-process link (`seed` for the link's fault generator),
/// with set 0 defined from `d` and the patterns of `set` uploaded (rendered as `fringe3d
/// patterns` does).
pub fn connect_uploaded<D: Device>(
    device: D,
    seed: u64,
    set: &PatternSet,
    d: &PatternSetDesc,
) -> Client<InProcess<D>> {
    let mut c = Client::connect(
        InProcess::new(device, FaultConfig::NONE, FaultConfig::NONE, seed),
        opts(),
    )
    .unwrap();
    c.define_pattern_set(0, d).unwrap();
    let data = pattern_bytes(set, d, |i| render_pattern(set, i)).unwrap();
    c.upload_patterns(0, d, &data, &mut |_, _| {}).unwrap();
    c
}
