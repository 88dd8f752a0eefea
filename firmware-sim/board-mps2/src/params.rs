//! `input/setup.bin` of the golden vectors: the core's head set-up blob
//! (`fringe3d_core::wire::setup`, docs/setup-blob.md), loaded with the core's own parser and
//! turned into the decoder, reconstructor and edge filter with the core's constructors, so the
//! head's kernels see the desktop's constants bit for bit.

use fringe3d_core::decode::Decoder;
use fringe3d_core::filter::EdgeFilter;
use fringe3d_core::reconstruct::Reconstructor;
use fringe3d_core::wire::{HeadSetup, SetupError};

/// Why `setup.bin` was refused.
#[derive(Clone, Copy, Debug)]
pub struct ParamsError(pub &'static str);

impl From<SetupError> for ParamsError {
    fn from(e: SetupError) -> Self {
        ParamsError(e.what())
    }
}

/// Everything a scan needs besides the images and the reference map.
pub struct Params {
    /// Image width.
    pub width: usize,
    /// Image height.
    pub height: usize,
    /// Images per set.
    pub images: usize,
    /// Significant bits of the camera codes.
    pub bits: u32,
    /// Bytes per sample in `images.*` (1 or 2).
    pub sample_bytes: usize,
    /// The reconstructor of the camera model and geometry.
    pub recon: Reconstructor,
    /// The edge filter.
    pub filter: EdgeFilter,
}

/// Counter ticks of the two set-up steps.
#[derive(Clone, Copy, Debug, Default)]
pub struct SetupTicks {
    /// Pattern set (validated over the projector) and decoder.
    pub decoder: u32,
    /// Camera model, reconstruction set-up (band analysis) and edge filter.
    pub reconstructor: u32,
}

/// Parse `setup.bin` and build the decoder (into `decoder_slot`, a static's: no copy of it on
/// the stack) and the reconstructor; `now` reads a down-counter for the ticks of each step. The
/// pattern set and camera model live only in the frames of the two steps, so the set-up's stack
/// stays small.
#[inline(never)]
pub fn parse(
    b: &[u8],
    now: &dyn Fn() -> u32,
    ticks: &mut SetupTicks,
    decoder_slot: &mut Option<Decoder>,
) -> Result<Params, ParamsError> {
    // Borrowed from the result, not moved out of it (the set-up is 1.7 KB).
    let setup = load(b);
    let s = setup.as_ref().map_err(|e| ParamsError::from(*e))?;
    // The reconstructor first: its band analysis is the set-up's deepest call, and the decoder
    // (with its phase-correction table) is not on the stack yet.
    let t = now();
    let recon = reconstructor(s)?;
    let filter = s.edge_filter()?;
    ticks.reconstructor = t.wrapping_sub(now());
    let t = now();
    s.decoder_into(decoder_slot)?;
    ticks.decoder = t.wrapping_sub(now());
    Ok(Params {
        width: s.frames.width as usize,
        height: s.frames.height as usize,
        images: s.image_count(),
        bits: s.frames.sample_bits as u32,
        sample_bytes: s.frames.sample_bytes as usize,
        recon,
        filter,
    })
}

/// The core's parser (its own stack frame: postcard's temporaries stay out of [`parse`]'s).
#[inline(never)]
fn load(b: &[u8]) -> Result<HeadSetup, SetupError> {
    HeadSetup::parse(b)
}

/// The camera model, the geometry and the reconstructor (its own stack frame).
#[inline(never)]
fn reconstructor(s: &HeadSetup) -> Result<Reconstructor, SetupError> {
    s.reconstructor()
}
