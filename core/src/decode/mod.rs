//! Phase decoding: DC term, wrapped phases, modulation and validity, then hierarchical unwrapping
//! (paper §5.2, eqs 8-15).
//!
//! # Model
//! Every image of level k, shift δ_n (plus the set's offset) is modelled as (eqs 8, 14)
//!
//! ```text
//! I_n = A + B·sin(Φ + δ_n) = A + S·cos δ_n + C·sin δ_n,   S = B·sin Φ,  C = B·cos Φ
//! ```
//!
//! which is linear in (A, S, C). A level with ≥ 3 shifts estimates all three by least squares —
//! for the paper's 4-step level that is exactly eq 9 (`Φ = atan2(I₁ − I₃, I₂ − I₄)`) and eq 10
//! (`A = ΣI/4`), and for uniform N-step levels eqs 14-15. A level with 2 shifts uses the DC term A
//! of the DC level and solves the 2×2 system for (S, C): for shifts 0 and π/2 that is eq 11,
//! `Φ = atan2(I₁ − A, I₂ − A)`. Every estimator is a fixed linear combination of the images,
//! computed once per set ([`level_estimator`]), so decoding is a weighted sum per image followed by
//! one `atan2` per level — no per-pixel branching on the set's structure.
//!
//! **Read [`reference`](mod@reference) first**: the same decoding for one pixel, plain f64 written as the
//! paper's equations 8-15, with no blocks, lanes or backends. Everything below computes that,
//! reorganised for speed; a unit test ties the two together.
//!
//! # One kernel, two drivers
//! Per block of [`BLOCK`] pixels, pass 1 computes each level's S and C (and the DC level's A),
//! its wrapped phase and modulation measure; pass 2 unwraps (eqs 12-13) and sets validity and
//! outputs. The row API ([`Decoder::decode_row`]) runs pass 1 straight from each level's image
//! rows, with every sum in registers. The frame-sequential API ([`crate::sequential`]) folds
//! frames as they arrive into a caller buffer ([`Decoder::accumulate`]) and runs the same passes
//! from it at the end ([`Decoder::finish`]). The sums are the same products added in the same
//! order from +0 (a skipped zero product adds ±0, which changes no sum that is never −0), and the
//! rest is the same code, so both give the same bits. For the two common three-level structures
//! (the paper's 8-pattern set and the 12-pattern set) the row driver's pass 1 computes all three
//! levels in one loop with their arctangents side by side ([`crate::math::atan2_levels3_lanes`]),
//! and pass 2 computes two or four pixels side by side ([`Decoder::decode_row_lanes`]): the
//! same operations per pixel in another order.
//!
//! # Arithmetic
//! The kernel is generic over an [`Arith`] backend ([`crate::arith`]): f32 with the accurate
//! polynomial `atan2` ([`F32Accurate`], the default, and what [`Decoder::new`] builds), fast f32,
//! or fixed point for heads without an FPU. `Decoder::<A>::with_arith` builds any of them; all run
//! this one kernel.
//!
//! # Files
//! | module | holds |
//! |---|---|
//! | [`reference`](mod@reference) | the one-pixel f64 reference decoder (eqs 8-15 as written) |
//! | `decoder` | [`Decoder`]: set-up from the pattern set (coefficients, plane modes, loop kinds) |
//! | `row` | the row driver ([`Decoder::decode_row`]): blocks, pass 1 from image rows |
//! | `fused` | the row driver's pass 1 for the paper's and the 12-pattern sets (one loop, lanes) |
//! | `accumulate` | frame-sequential accumulation ([`Decoder::accumulate`]) |
//! | `finish` | pass 1 from planes, pass 2 (unwrapping, validity, outputs: [`Decoder::finish`]) |
//! | `gray` | the Gray-code pass of both drivers (code words, ambiguity, the level-0 estimate) |
//! | `correction` | [`PhaseCorrection`]: the per-level phase-error table (projector gamma) |
//! | [`hdr`] | multi-exposure fusion: each pixel from the longest exposure that did not saturate |
//! | `level` | one level's wrapped phase ([`Decoder::finish_level`], [`Decoder::decode_row_level`]) |
//! | `buffers` | [`RowOut`], [`State`], [`DecodeScratch`] and the per-block arrays |
//! | `any` | [`AnyDecoder`]: a decoder of any backend chosen at run time ([`Backend`]) |
//! | [`parity`] | the fixed workload and digest of the desktop/Cortex-M parity tests |
//!
//! The types the arithmetic shares with the decoder live below both and are re-exported here:
//! [`Sample`] ([`crate::sample`]), [`DecodeConfig`] ([`crate::decode_config`]), [`DecodeError`]
//! ([`crate::decode_error`]), [`LevelEstimator`] and [`level_estimator`] ([`crate::estimator`]).

mod accumulate;
mod any;
mod buffers;
mod correction;
mod decoder;
mod finish;
mod fused;
mod gray;
pub mod hdr;
mod level;
pub mod parity;
pub mod reference;
mod row;

pub use any::AnyDecoder;
pub use buffers::{DecodeScratch, RowOut, State};
pub use correction::{CORRECTION_KNOTS, CORRECTION_LSB, PhaseCorrection};
pub use decoder::Decoder;

pub use crate::decode_config::DecodeConfig;
pub use crate::decode_error::DecodeError;
pub use crate::estimator::{LevelEstimator, level_estimator};
pub use crate::sample::Sample;

#[cfg(doc)]
use crate::arith::{Arith, Backend, F32Accurate};

/// Pixels per block of the row driver; the state of one block lives on the stack.
pub const BLOCK: usize = 64;
