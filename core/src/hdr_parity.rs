//! The HDR case of the parity workload ([`crate::decode::parity`]; docs/hdr.md): one row of the
//! paper8-u8 case at two exposures, fused by both drivers, so that the QEMU parity test and a
//! head's self-test show the fusion gives the desktop's bits.

use crate::arith::{Arith, Backend};
use crate::decode::hdr::{RowRef, any_saturated, fuse_exposure};
use crate::decode::parity::{WIDTH, config, samples, set};
use crate::decode::{AnyDecoder, DecodeError, Decoder, RowOut};
use crate::digest::Digest;
use crate::pattern::{MAX_IMAGES, MAX_LEVELS};
use crate::sequential::FrameDecoder;

/// The digest of the HDR case: the paper8-u8 case's samples as the short exposure, and three
/// times their light, clipped at full scale, as the long one (a third of its pixels clip; [`DecodeError::Config`] if none did),
/// fused by both drivers: the rows ([`fuse_exposure`]) and the frames as they arrive
/// ([`FrameDecoder::next_exposure`], one row of state). Their outputs must be the same bits
/// (else [`DecodeError::Sequence`]); the digest is over those outputs, as [`crate::decode::parity::digest`]'s.
#[inline]
pub fn digest(backend: Backend) -> Result<u64, DecodeError> {
    let set = set(0)?;
    match AnyDecoder::new(&set, config(0), backend)? {
        AnyDecoder::F32Accurate(d) => hdr_run(&d),
        AnyDecoder::F32Fast(d) => hdr_run(&d),
        #[cfg(feature = "micromath")]
        AnyDecoder::F32Micromath(d) => hdr_run(&d),
        AnyDecoder::Fixed(d) => hdr_run(&d),
    }
}

/// One decoded row: phase, modulation, DC, codes.
type Row = ([f32; WIDTH], [f32; WIDTH], [f32; WIDTH], [u8; WIDTH]);

fn out(r: &mut Row) -> RowOut<'_> {
    RowOut {
        phase: &mut r.0,
        modulation: &mut r.1,
        dc: &mut r.2,
        validity: &mut r.3,
    }
}

fn hdr_run<A: Arith>(d: &Decoder<A>) -> Result<u64, DecodeError> {
    let mut short = [[0u16; WIDTH]; MAX_IMAGES];
    let n = samples(0, &mut short)?;
    // Exposure 0 (long) and 1 (short), 8-bit.
    let mut rows = [[[0u8; WIDTH]; MAX_IMAGES]; 2];
    for (i, s) in short.iter().enumerate().take(n) {
        for (x, &v) in s.iter().enumerate() {
            rows[0][i][x] = (3 * v).min(255) as u8;
            rows[1][i][x] = v.min(255) as u8;
        }
    }
    let refs = |e: usize| -> [&[u8]; MAX_IMAGES] { core::array::from_fn(|i| &rows[e][i][..]) };
    let zero: Row = ([0.0; WIDTH], [0.0; WIDTH], [0.0; WIDTH], [0; WIDTH]);
    // The rows.
    let (mut best, mut next) = (zero, zero);
    d.decode_row(&refs(0)[..n], out(&mut best))?;
    // A case where nothing clips would prove nothing.
    if !any_saturated(&best.3) {
        return Err(DecodeError::Config);
    }
    {
        d.decode_row(&refs(1)[..n], out(&mut next))?;
        let r = RowRef {
            phase: &next.0,
            modulation: &next.1,
            dc: &next.2,
            validity: &next.3,
        };
        fuse_exposure(&mut out(&mut best), &r)?;
    }
    // The frames as they arrive.
    let mut state = [A::ZERO; (1 + 2 * MAX_LEVELS) * WIDTH];
    let mut flags = [0u8; WIDTH];
    let mut frames = zero;
    {
        let mut fd = FrameDecoder::new(d, WIDTH, 1, &mut state, &mut flags)?;
        for e in 0..2 {
            if e > 0 {
                fd.next_exposure()?;
            }
            for r in refs(e).iter().take(n) {
                fd.push_row(r)?;
            }
        }
        fd.finish_row(0, out(&mut frames))?;
    }
    let bits = |r: &Row| {
        let mut h = Digest::default();
        h.f32s(&r.0);
        h.f32s(&r.1);
        h.f32s(&r.2);
        h.bytes(&r.3);
        h.0
    };
    if bits(&best) != bits(&frames) {
        return Err(DecodeError::Sequence);
    }
    Ok(bits(&best))
}
