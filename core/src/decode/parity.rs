//! A fixed decoding workload and its digest, to show that a target computes the same bits as the
//! desktop for every backend (the QEMU parity test, a head's power-on self-test) and to count its
//! cost there (`core/arith-bench`).
//!
//! Each case is a pattern set, a sample type and [`WIDTH`] synthetic pixels of every image:
//! random DC term, modulation (some pixels clipped, dark or flat) and phase over the coarse range
//! and a little beyond, plus noise, all generated with integer arithmetic and the pinned `libm`
//! so that every target builds the same input. The digest is FNV-1a (64 bits) over every output
//! of [`AnyDecoder::decode_row`] and [`AnyDecoder::decode_row_level`] (f32 bits, NaN canonical,
//! [`crate::digest::Digest`]).
//!
//! [`run`] and [`digest`] (and [`crate::hdr_parity::digest`]) are `#[inline]`: they instantiate
//! the decoder for every backend and sample type, 85 % of the core's generated code, and so are
//! compiled only in the crates that call them (the parity tests, `core/arith-bench`). A crate
//! that does not, a firmware or the desktop, builds the core in a fifth of the time (6 s
//! against 30 s in release for a Cortex-M4F on 2 cores).

use super::any::AnyDecoder;
use super::buffers::RowOut;
use crate::arith::Backend;
use crate::decode_config::DecodeConfig;
use crate::decode_error::DecodeError;
use crate::digest::Digest;
use crate::pattern::{GrayCode, Level, MAX_IMAGES, Output, PatternSet, Relation};
use crate::phase_function::{Axis, PhaseFunction};

/// Pixels per row of every case.
pub const WIDTH: usize = 256;

/// Number of cases.
pub const CASES: usize = 7;

/// Names of the cases: the set and the sample depth.
pub const CASE_NAMES: [&str; CASES] = [
    "paper8-u8",
    "paper8-u12",
    "paper8-u16",
    "3/5/7-u12",
    "measured-u8",
    "gray5c+4-u8",
    "het21/26/32-u12",
];

/// Sample depth (bits) of a case.
fn bits(case: usize) -> u32 {
    [8, 12, 16, 12, 8, 8, 12][case]
}

/// The pattern set of a case.
pub fn set(case: usize) -> Result<PatternSet, DecodeError> {
    let full = ((1u32 << bits(case)) - 1) as f64;
    let out = Output {
        width: 640,
        height: 480,
        i_min: 0.0,
        i_max: full,
    };
    let fe = PhaseFunction::centered(Axis::Eta, 480, 0.9 * core::f64::consts::TAU)
        .map_err(|_| DecodeError::Config)?;
    let set = match case {
        0..=2 => PatternSet::default_for(Axis::Xi, out),
        3 => PatternSet::new(
            fe,
            &[
                Level::n_step(1.0, 3),
                Level::n_step(6.0, 5),
                Level::n_step(36.0, 7),
            ],
            out,
        ),
        4 => PatternSet::new(
            fe,
            &[
                Level::two_step(1.0),
                Level::with_shifts(7.0, &[0.0, 1.1, 2.0, 3.5, 5.2]),
            ],
            out,
        ),
        // Gray code + phase shifting (issue #20): 20 periods, a complementary 5-bit code.
        5 => PatternSet::new(
            fe,
            &[
                Level::gray_code(20.0, GrayCode::new(5, true)),
                Level::n_step(20.0, 4),
            ],
            out,
        ),
        // Three-frequency heterodyne (issue #20).
        _ => PatternSet::new_with_relation(
            fe,
            &[
                Level::n_step(21.0, 4),
                Level::n_step(26.0, 4),
                Level::n_step(32.0, 4),
            ],
            out,
            Relation::Heterodyne,
        ),
    };
    set.map_err(|_| DecodeError::Config)
}

/// The decoder thresholds of a case: the defaults of its depth, with the modulation floor at 2 %
/// of full scale as when the golden digests were recorded (the workload pins the arithmetic's
/// bits; the default thresholds may change without changing them).
pub fn config(case: usize) -> DecodeConfig {
    let bits = bits(case);
    let full = ((1u32 << bits) - 1) as f32;
    DecodeConfig {
        min_modulation: 0.02 * full,
        ..DecodeConfig::for_bit_depth(bits)
    }
}

struct SplitMix(u64);

impl SplitMix {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    fn uniform(&mut self) -> f64 {
        (self.next() >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// The samples of a case: `rows[i]` is image `i` (set order). Returns the number of images.
pub fn samples(case: usize, rows: &mut [[u16; WIDTH]; MAX_IMAGES]) -> Result<usize, DecodeError> {
    let set = set(case)?;
    let full = ((1u32 << bits(case)) - 1) as f64;
    let (lo, hi) = set.coarse_range();
    // The scale of the coarse range: the coarsest level's, or a heterodyne set's beat.
    let c0 = set
        .relation()
        .start_scale(set.levels())
        .ok_or(DecodeError::Config)?;
    let mut rng = SplitMix(0x5eed_0000 + case as u64);
    let mut px = [(0.0f64, 0.0f64, 0.0f64); WIDTH];
    for p in px.iter_mut() {
        let a = full * (0.01 + 0.7 * rng.uniform());
        let b = a * 1.1 * rng.uniform();
        let t = -0.05 + 1.1 * rng.uniform();
        *p = (a, b, (lo + (hi - lo) * t) / c0);
    }
    for (i, row) in rows.iter_mut().enumerate().take(set.image_count()) {
        let id = set.image(i).ok_or(DecodeError::Config)?;
        let level = &set.levels()[id.level as usize];
        let delta = level
            .shifts()
            .get(id.shift as usize)
            .copied()
            .unwrap_or(0.0);
        let delta = delta + set.effective_offset();
        for (o, &(a, b, phi)) in row.iter_mut().zip(px.iter()) {
            let noise = full * 0.01 * (rng.uniform() - 0.5);
            // A Gray-code image: ±B about A where its bit is set or clear.
            let wave = match level.gray() {
                Some(g) => {
                    let u = level.scale() * phi / core::f64::consts::TAU;
                    if g.bright(id.shift as usize, g.half_stripe(u)) {
                        1.0
                    } else {
                        -1.0
                    }
                }
                None => libm::sin(level.scale() * phi + delta),
            };
            let v = libm::round(a + b * wave + noise);
            *o = if v < 0.0 {
                0
            } else if v > full {
                full as u16
            } else {
                v as u16
            };
        }
    }
    Ok(set.image_count())
}

/// Decode case `case` with `backend` `reps` times (the row API; `reps = 0` builds the decoder
/// and the input only) and return the digest of the outputs, including every level's wrapped
/// phase and modulation when `levels` is set.
#[inline]
pub fn run(backend: Backend, case: usize, reps: u32, levels: bool) -> Result<u64, DecodeError> {
    let set = set(case)?;
    let d = AnyDecoder::new(&set, config(case), backend)?;
    let first_phase_level = set.gray().is_some() as usize;
    let mut rows = [[0u16; WIDTH]; MAX_IMAGES];
    let n = samples(case, &mut rows)?;
    let mut phase = [0.0f32; WIDTH];
    let mut modulation = [0.0f32; WIDTH];
    let mut dc = [0.0f32; WIDTH];
    let mut validity = [0u8; WIDTH];
    let mut h = Digest::default();
    if bits(case) == 8 {
        let mut rows8 = [[0u8; WIDTH]; MAX_IMAGES];
        for (r8, r) in rows8.iter_mut().zip(rows.iter()).take(n) {
            for (o, v) in r8.iter_mut().zip(r.iter()) {
                *o = *v as u8;
            }
        }
        let refs: [&[u8]; MAX_IMAGES] = core::array::from_fn(|i| &rows8[i][..]);
        for _ in 0..reps {
            d.decode_row(
                &refs[..n],
                RowOut {
                    phase: &mut phase,
                    modulation: &mut modulation,
                    dc: &mut dc,
                    validity: &mut validity,
                },
            )?;
        }
        if levels {
            // (A Gray-code level has no wrapped phase.)
            for l in first_phase_level..d.level_count() {
                let (mut w, mut m) = ([0.0f32; WIDTH], [0.0f32; WIDTH]);
                d.decode_row_level(&refs[..n], l, &mut w, &mut m)?;
                h.f32s(&w);
                h.f32s(&m);
            }
        }
    } else {
        let refs: [&[u16]; MAX_IMAGES] = core::array::from_fn(|i| &rows[i][..]);
        for _ in 0..reps {
            d.decode_row(
                &refs[..n],
                RowOut {
                    phase: &mut phase,
                    modulation: &mut modulation,
                    dc: &mut dc,
                    validity: &mut validity,
                },
            )?;
        }
        if levels {
            // (A Gray-code level has no wrapped phase.)
            for l in first_phase_level..d.level_count() {
                let (mut w, mut m) = ([0.0f32; WIDTH], [0.0f32; WIDTH]);
                d.decode_row_level(&refs[..n], l, &mut w, &mut m)?;
                h.f32s(&w);
                h.f32s(&m);
            }
        }
    }
    h.f32s(&phase);
    h.f32s(&modulation);
    h.f32s(&dc);
    h.bytes(&validity);
    Ok(h.0)
}

/// The parity digest of a case: every output of one decode, every level.
#[inline]
pub fn digest(backend: Backend, case: usize) -> Result<u64, DecodeError> {
    run(backend, case, 1, true)
}
