//! Multi-exposure (HDR) fusion (issue #19 item 4): one pattern set captured at several exposures,
//! **longest first**, fused per pixel.
//!
//! # The rule
//! Each pixel takes the decode of the longest exposure in which none of its samples saturated,
//! or the shortest exposure's (then [`Validity::Saturated`]) if it saturated in all:
//!
//! ```text
//! e*(pixel) = min { e : no sample of exposure e saturated at the pixel },  else E − 1
//! out(pixel) = decode_e*(pixel)          (phase, modulation, DC, validity: one exposure's)
//! ```
//!
//! The longest unsaturated exposure carries the most light without clipping, so the largest
//! modulation B and the smallest phase noise (`σ_φ = σ·√(2/N)/B` for an N-step level, eq 9's
//! noise): a pixel that a shorter exposure would also decode gains nothing from it, and one that
//! clipped is biased (the sinusoid is cut; [`Validity::Saturated`] refuses it). No blending: the
//! phase of every output pixel is one exposure's decode, bit for bit, so the fused map inherits
//! every property of a single decode (its thresholds, its parity across backends). The
//! modulation and DC are in the chosen exposure's camera codes: the modulation over the read
//! noise is still that pixel's B/σ.
//!
//! # Two drivers, one rule
//! - **Rows** ([`fuse_exposure`]): decode each exposure's rows as usual and fold them into the
//!   output, longest first; a pixel is replaced while it is [`Validity::Saturated`] (the decoder
//!   gives that code exactly when a sample saturated: it has the highest priority).
//! - **Frames as they arrive** ([`crate::sequential::FrameDecoder::next_exposure`]): after the
//!   last frame of an exposure, every pixel that did not saturate is locked (its accumulators
//!   keep that exposure's sums) and every other pixel's state is cleared, so the next exposure's
//!   frames accumulate from zero into it alone. No store beyond the frame-sequential state: one
//!   flag bit per pixel. The sums of a pixel are then exactly those of a decode of its exposure
//!   alone, so both drivers give the same bits (`core/tests/hdr_fusion.rs`).

use super::buffers::RowOut;
use crate::decode_error::DecodeError;
use crate::validity::Validity;

/// Most exposures of one scan (the wire's and the head's bound; a CLI's too).
pub const MAX_EXPOSURES: usize = 4;

/// One exposure's decoded row, read-only: what [`fuse_exposure`] folds in.
#[derive(Clone, Copy)]
pub struct RowRef<'a> {
    /// Absolute phase (canonical NaN where invalid).
    pub phase: &'a [f32],
    /// Modulation B, camera codes (empty if the output has none).
    pub modulation: &'a [f32],
    /// DC term A, camera codes (empty if the output has none).
    pub dc: &'a [f32],
    /// [`Validity`] codes.
    pub validity: &'a [u8],
}

/// `true` if some pixel of the decoded row saturated: the next (shorter) exposure is needed
/// there. A driver may skip decoding a row of the next exposure when this is `false`.
pub fn any_saturated(validity: &[u8]) -> bool {
    validity.contains(&(Validity::Saturated as u8))
}

/// Fold the decoded row of the next (shorter) exposure into `best`, which holds the fusion of the
/// longer ones (the longest exposure's row to begin with): every pixel of `best` that is
/// [`Validity::Saturated`] takes `next`'s phase, modulation, DC and code. Returns the number of
/// pixels taken. The outputs' optional planes (modulation, DC) must be both present or both
/// empty in `best` and `next`.
pub fn fuse_exposure(best: &mut RowOut<'_>, next: &RowRef<'_>) -> Result<usize, DecodeError> {
    let n = best.validity.len();
    if !best.len_ok(n)
        || next.phase.len() != n
        || next.validity.len() != n
        || best.modulation.len() != next.modulation.len()
        || best.dc.len() != next.dc.len()
    {
        return Err(DecodeError::Length);
    }
    let sat = Validity::Saturated as u8;
    let mut taken = 0;
    for i in 0..n {
        if best.validity[i] == sat {
            best.validity[i] = next.validity[i];
            best.phase[i] = next.phase[i];
            if let (Some(m), Some(&x)) = (best.modulation.get_mut(i), next.modulation.get(i)) {
                *m = x;
            }
            if let (Some(d), Some(&x)) = (best.dc.get_mut(i), next.dc.get(i)) {
                *d = x;
            }
            taken += 1;
        }
    }
    Ok(taken)
}
