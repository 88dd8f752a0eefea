//! `input/setup.bin`: the core's head set-up blob ([`fringe3d_core::wire::setup`]) of the
//! vectors' scan — what the firmware loads instead of recomputing anything.

use super::pipeline::Inputs;
use super::{VectorsError, kernel};
use fringe3d_core::decode::Decoder;
use fringe3d_core::pattern::PatternSet;
use fringe3d_core::wire::setup::MAX_SETUP_BLOB;
use fringe3d_core::wire::{EdgeFilterParams, FrameFormat, HeadSetup};

/// The set-up blob of `inp` (images of `set`, decoded by `dec`), checked to rebuild the
/// desktop's pattern set, decoder, reconstructor and edge filter exactly: the head ships the
/// desktop's parameters, it does not recompute them differently.
pub(super) fn setup_bytes(
    inp: &Inputs,
    set: &PatternSet,
    dec: &Decoder,
) -> Result<Vec<u8>, VectorsError> {
    let stage = "set-up blob";
    let recon = &inp.calibration.recon;
    let side = |n: usize| u16::try_from(n).map_err(|_| kernel(stage, "image wider than 65535"));
    let frames = FrameFormat {
        width: side(recon.width())?,
        height: side(recon.height())?,
        sample_bits: inp.bits,
        sample_bytes: if inp.bits == 8 { 1 } else { 2 },
    };
    let setup = HeadSetup::from_core(
        frames,
        set,
        u32::from(inp.scene.pattern_bits),
        inp.decode_config,
        recon.camera().params(),
        recon.setup(),
        EdgeFilterParams {
            focal_px: inp.edge_focal_px,
            max_angle_deg: inp.edge_max_angle_deg,
        },
    )
    .map_err(|e| kernel(stage, e))?
    .with_margin(recon.margin())
    .map_err(|e| kernel(stage, e))?;
    let setup = match &inp.correction {
        Some(c) => setup.with_correction(c).map_err(|e| kernel(stage, e))?,
        None => setup,
    };
    // Field 10: the reconstructor's set-up analysis, so that the head does not walk the image
    // in soft f64 at boot; the check below holds the head's reconstructor built from it to the
    // desktop's.
    let setup = setup.with_analysis().map_err(|e| kernel(stage, e))?;
    let same = setup.pattern_set().as_ref() == Ok(set)
        && setup.decoder().as_ref() == Ok(dec)
        && setup.reconstructor().as_ref() == Ok(recon)
        && setup.edge_filter().as_ref() == Ok(&inp.edge_filter);
    if !same {
        return Err(kernel(
            stage,
            "the head would rebuild other objects than the desktop's",
        ));
    }
    let mut blob = vec![0u8; MAX_SETUP_BLOB];
    let n = setup.emit(&mut blob).map_err(|e| kernel(stage, e))?;
    blob.truncate(n);
    Ok(blob)
}
