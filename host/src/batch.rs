//! Whole-frame paths for the desktop: rows in parallel (rayon) and the core's row kernel compiled
//! for the widest instruction set the CPU has (runtime dispatch).
//!
//! Both axes of speed-up leave the bits alone: rows are independent, and the core's kernel is
//! plain IEEE arithmetic with no fused operations, so an AVX2 or AVX-512 build of it computes
//! exactly what the baseline (SSE2) build computes, lane by lane. `tests` check it.
//!
//! The AVX-512 variant exists when the compiler is 1.89 or newer (`cfg(fringe3d_avx512)`, set by
//! `build.rs`); with the MSRV the dispatch stops at AVX2.

#[cfg(target_arch = "x86_64")]
use crate::gather::Avx2Pairs;
#[cfg(all(target_arch = "x86_64", fringe3d_avx512))]
use crate::gather::Avx512Pairs;
use crate::io::image_set::{Frames, ImageSet};
use fringe3d_core::decode::{DecodeError, DecodeScratch, Decoder, RowOut, Sample, hdr};
use fringe3d_core::reconstruct::compiled::{FIELDS, SearchScratch, compiled_row_inline};
use fringe3d_core::reconstruct::{
    CellGather, ReconstructError, Reconstructor, ReferenceMap, ReferenceRows, ScalarGather,
};
use fringe3d_core::validity::Validity;
use rayon::prelude::*;

/// Which compiled variant of the kernel runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Isa {
    /// The target's baseline (x86-64: SSE2).
    Baseline,
    /// x86-64 with AVX2, detected at run time.
    Avx2,
    /// x86-64 with AVX-512 (F, BW, DQ, VL), detected at run time; only in builds by rustc ≥ 1.89,
    /// elsewhere it runs the AVX2 (or baseline) variant.
    Avx512,
}

impl Isa {
    /// The best variant this CPU runs.
    pub fn detect() -> Isa {
        if Isa::Avx512.available() {
            return Isa::Avx512;
        }
        if Isa::Avx2.available() {
            return Isa::Avx2;
        }
        Isa::Baseline
    }

    /// `true` if this build has the variant and this CPU runs it.
    pub fn available(self) -> bool {
        match self {
            Isa::Baseline => true,
            #[cfg(target_arch = "x86_64")]
            Isa::Avx2 => std::is_x86_feature_detected!("avx2"),
            #[cfg(all(target_arch = "x86_64", fringe3d_avx512))]
            Isa::Avx512 => {
                std::is_x86_feature_detected!("avx512f")
                    && std::is_x86_feature_detected!("avx512bw")
                    && std::is_x86_feature_detected!("avx512dq")
                    && std::is_x86_feature_detected!("avx512vl")
            }
            #[allow(unreachable_patterns)] // every arm exists on x86-64 with a recent compiler
            _ => false,
        }
    }

    /// The variant that actually runs for a request of `self`: the widest available one not
    /// wider than it.
    pub fn effective(self) -> Isa {
        match self {
            Isa::Avx512 if Isa::Avx512.available() => Isa::Avx512,
            Isa::Avx512 | Isa::Avx2 if Isa::Avx2.available() => Isa::Avx2,
            _ => Isa::Baseline,
        }
    }
}

/// Whole-frame outputs of a decode, each `width × height`, row-major.
pub struct FrameOut<'a> {
    /// Finest absolute phase (canonical NaN where invalid).
    pub phase: &'a mut [f32],
    /// Modulation B.
    pub modulation: &'a mut [f32],
    /// DC term A.
    pub dc: &'a mut [f32],
    /// Validity codes.
    pub validity: &'a mut [u8],
}

/// Run `f` compiled for the AVX2 instruction set.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn in_avx2<R>(f: impl FnOnce() -> R) -> R {
    // The core's row kernels are #[inline(always)]: inlined into `f`, which is inlined here, they
    // are compiled with AVX2 enabled.
    f()
}

/// Run `f` with the kernel variant `isa` (the baseline when the CPU lacks it). The closure must be
/// the whole row loop, so that the core's inlined kernels are compiled inside it.
///
/// Caveat: LLVM does not always inline a large closure into the AVX2 wrapper; it then runs the
/// baseline code (no error, same bits, no speed-up). Hot paths should call their own
/// `#[target_feature(enable = "avx2")]` function that calls `#[inline(always)]` code directly, as
/// [`decode_frames`] does.
#[inline(always)]
pub fn dispatch<R>(isa: Isa, f: impl FnOnce() -> R) -> R {
    match isa.effective() {
        #[cfg(target_arch = "x86_64")]
        Isa::Avx2 | Isa::Avx512 => {
            // SAFETY: `effective` returned a variant with AVX2, so the CPU supports it (checked by
            // `Isa::available`), the only requirement of a `#[target_feature(enable = "avx2")]`
            // function.
            unsafe { in_avx2(f) }
        }
        _ => f(),
    }
}

struct RowsOut<'a> {
    phase: &'a mut [f32],
    modulation: &'a mut [f32],
    dc: &'a mut [f32],
    validity: &'a mut [u8],
}

/// The rows `y0..` of a frame, decoded row by row with the finishing pass computing `LANES`
/// pixels side by side ([`Decoder::decode_row_lanes`]; the same bits for every `LANES`): 4 for
/// the baseline (SSE2) build, 2 for the AVX2 and AVX-512 builds, where four do not vectorize.
#[inline(always)]
fn rows_generic<P: Sample, const LANES: usize>(
    d: &Decoder,
    frames: &[&[P]],
    width: usize,
    y0: usize,
    out: RowsOut<'_>,
) -> Result<(), DecodeError> {
    let n_rows = out.phase.len() / width;
    let mut rows: [&[P]; fringe3d_core::pattern::MAX_IMAGES] =
        [&[]; fringe3d_core::pattern::MAX_IMAGES];
    let k = frames.len().min(rows.len());
    let mut scratch = DecodeScratch::new();
    for r in 0..n_rows {
        let y = y0 + r;
        for (slot, f) in rows.iter_mut().zip(frames) {
            *slot = f
                .get(y * width..(y + 1) * width)
                .ok_or(DecodeError::Length)?;
        }
        let s = r * width..(r + 1) * width;
        d.decode_row_lanes::<P, LANES>(
            &mut scratch,
            &rows[..k],
            RowOut {
                phase: &mut out.phase[s.clone()],
                modulation: &mut out.modulation[s.clone()],
                dc: &mut out.dc[s.clone()],
                validity: &mut out.validity[s],
            },
        )?;
    }
    Ok(())
}

/// The row loop compiled with AVX2: `rows_generic` and the core's kernels are
/// `#[inline(always)]`, so they are compiled here, with AVX2 enabled. (A closure passed to
/// [`dispatch`] is not always inlined into its AVX2 wrapper, and then runs the baseline code.)
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn rows_avx2<P: Sample>(
    d: &Decoder,
    frames: &[&[P]],
    width: usize,
    y0: usize,
    out: RowsOut<'_>,
) -> Result<(), DecodeError> {
    rows_generic::<P, 2>(d, frames, width, y0, out)
}

/// [`rows_avx2`] with AVX-512.
#[cfg(all(target_arch = "x86_64", fringe3d_avx512))]
#[target_feature(enable = "avx512f,avx512bw,avx512dq,avx512vl")]
fn rows_avx512<P: Sample>(
    d: &Decoder,
    frames: &[&[P]],
    width: usize,
    y0: usize,
    out: RowsOut<'_>,
) -> Result<(), DecodeError> {
    rows_generic::<P, 2>(d, frames, width, y0, out)
}

fn rows_dispatch<P: Sample>(
    isa: Isa,
    d: &Decoder,
    frames: &[&[P]],
    width: usize,
    y0: usize,
    out: RowsOut<'_>,
) -> Result<(), DecodeError> {
    match isa.effective() {
        #[cfg(all(target_arch = "x86_64", fringe3d_avx512))]
        Isa::Avx512 => {
            // SAFETY: `effective` returned Avx512, so the CPU has every feature the function
            // enables (checked by `Isa::available`), the only requirement of `target_feature`.
            unsafe { rows_avx512(d, frames, width, y0, out) }
        }
        #[cfg(target_arch = "x86_64")]
        Isa::Avx2 => {
            // SAFETY: `effective` returned Avx2, so the CPU supports AVX2 (checked by
            // `Isa::available`), the only requirement of a `#[target_feature(enable = "avx2")]`
            // function.
            unsafe { rows_avx2(d, frames, width, y0, out) }
        }
        _ => rows_baseline(d, frames, width, y0, out),
    }
}

/// [`rows_generic`] for the x86-64 baseline (SSE2), four pixels side by side, in a function of
/// its own like the AVX2 and AVX-512 variants: inlined into the dispatcher, the lane closures of
/// the finishing pass were left out of line (stack round trips: 26 ms a frame against 4.9 ms
/// for AVX2 on machine C).
#[inline(never)]
fn rows_baseline<P: Sample>(
    d: &Decoder,
    frames: &[&[P]],
    width: usize,
    y0: usize,
    out: RowsOut<'_>,
) -> Result<(), DecodeError> {
    rows_generic::<P, 4>(d, frames, width, y0, out)
}

/// Rows per parallel task (decode and reconstruction): enough to amortise scheduling, small
/// enough to balance two cores.
const ROWS_PER_TASK: usize = 16;

/// Decode whole frames (`frames[i]` is image `i` of the set, `width × height`, row-major) with
/// the chosen kernel variant, in parallel over rows when `parallel` is set (on rayon's current
/// pool). The results are bit-identical whatever `isa` and `parallel` are.
pub fn decode_frames<P: Sample + Sync>(
    d: &Decoder,
    frames: &[&[P]],
    width: usize,
    height: usize,
    out: FrameOut<'_>,
    isa: Isa,
    parallel: bool,
) -> Result<(), DecodeError> {
    let n = width.checked_mul(height).ok_or(DecodeError::Length)?;
    if frames.len() != d.image_count() {
        return Err(DecodeError::ImageCount);
    }
    if width == 0
        || frames.iter().any(|f| f.len() != n)
        || out.phase.len() != n
        || out.modulation.len() != n
        || out.dc.len() != n
        || out.validity.len() != n
    {
        return Err(DecodeError::Length);
    }
    let chunk = ROWS_PER_TASK * width;
    let tasks = out
        .phase
        .chunks_mut(chunk)
        .zip(out.modulation.chunks_mut(chunk))
        .zip(out.dc.chunks_mut(chunk))
        .zip(out.validity.chunks_mut(chunk))
        .enumerate();
    let run = |(i, (((phase, modulation), dc), validity)): (
        usize,
        (((&mut [f32], &mut [f32]), &mut [f32]), &mut [u8]),
    )| {
        rows_dispatch(
            isa,
            d,
            frames,
            width,
            i * ROWS_PER_TASK,
            RowsOut {
                phase,
                modulation,
                dc,
                validity,
            },
        )
    };
    if parallel {
        tasks.par_bridge().try_for_each(run)
    } else {
        tasks.into_iter().try_for_each(run)
    }
}

/// A whole decoded frame: every output of [`decode_frames`], owned.
#[derive(Clone, Debug)]
pub struct Decoded {
    /// Width.
    pub width: usize,
    /// Height.
    pub height: usize,
    /// Finest absolute phase, radians (canonical NaN where invalid).
    pub phase: Vec<f32>,
    /// Modulation B.
    pub modulation: Vec<f32>,
    /// DC term A.
    pub dc: Vec<f32>,
    /// Validity codes.
    pub validity: Vec<u8>,
}

/// Decode a whole set of images (`frames[i]` is image `i` of the set, `width × height`) on all
/// threads of rayon's pool with the best kernel variant of this CPU: the one desktop decode of
/// `fringe3d decode`/`scan`, the calibration steps and the renderer's reference map.
pub fn decode_whole<P: Sample + Sync>(
    d: &Decoder,
    frames: &[&[P]],
    width: usize,
    height: usize,
) -> Result<Decoded, DecodeError> {
    let n = width.checked_mul(height).ok_or(DecodeError::Length)?;
    let mut o = Decoded {
        width,
        height,
        phase: vec![0.0; n],
        modulation: vec![0.0; n],
        dc: vec![0.0; n],
        validity: vec![0; n],
    };
    let out = FrameOut {
        phase: &mut o.phase,
        modulation: &mut o.modulation,
        dc: &mut o.dc,
        validity: &mut o.validity,
    };
    decode_frames(d, frames, width, height, out, Isa::detect(), true)?;
    Ok(o)
}

/// [`decode_exposures`] over a loaded image set (8- or 16-bit): [`decode_whole`] for one
/// exposure of the set, the HDR fusion for several.
pub fn decode_image_set(d: &Decoder, imgs: &ImageSet) -> Result<Decoded, DecodeError> {
    let (w, h) = (imgs.width as usize, imgs.height as usize);
    match &imgs.frames {
        Frames::U8(f) => {
            let fr: Vec<&[u8]> = f.iter().map(|v| v.as_slice()).collect();
            decode_exposures(d, &fr, w, h)
        }
        Frames::U16(f) => {
            let fr: Vec<&[u16]> = f.iter().map(|v| v.as_slice()).collect();
            decode_exposures(d, &fr, w, h)
        }
    }
}

/// Whole frames of the set's images once per exposure, longest exposure first (at most
/// [`hdr::MAX_EXPOSURES`]), decoded into one frame: each pixel from the longest exposure in which
/// it did not saturate ([`fringe3d_core::decode::hdr`]). One exposure is [`decode_whole`].
pub fn decode_exposures<P: Sample + Sync>(
    d: &Decoder,
    frames: &[&[P]],
    width: usize,
    height: usize,
) -> Result<Decoded, DecodeError> {
    let n = d.image_count().max(1);
    let exposures = frames.len() / n;
    if frames.len() != exposures * n || !(1..=hdr::MAX_EXPOSURES).contains(&exposures) {
        return Err(DecodeError::Length);
    }
    let mut best = decode_whole(d, &frames[..n], width, height)?;
    for shorter in frames[n..].chunks_exact(n) {
        if !hdr::any_saturated(&best.validity) {
            break;
        }
        let next = decode_whole(d, shorter, width, height)?;
        hdr::fuse_exposure(
            &mut RowOut {
                phase: &mut best.phase,
                modulation: &mut best.modulation,
                dc: &mut best.dc,
                validity: &mut best.validity,
            },
            &hdr::RowRef {
                phase: &next.phase,
                modulation: &next.modulation,
                dc: &next.dc,
                validity: &next.validity,
            },
        )?;
    }
    Ok(best)
}

/// Whole-frame outputs of a reconstruction: `xyz` is `3 × width × height` (x, y, z per pixel, mm),
/// `validity` `width × height`, row-major.
pub struct PointsOut<'a> {
    /// The points (canonical NaN where invalid).
    pub xyz: &'a mut [f32],
    /// Validity codes.
    pub validity: &'a mut [u8],
    /// One count per row, when wanted: the pixels whose point the §6 search computed. Without
    /// compiled models every pixel with a valid input code; with them, those their models
    /// left to the search ([`compiled_row_inline`]'s count). A compiled scan's fallback rate is
    /// their sum over the valid input pixels.
    pub searched: Option<&'a mut [u32]>,
}

/// Compiled models standing in for the search pixel by pixel ([`crate::compiled`]): the
/// models of consecutive camera rows (the camera's whole `width × height`, or a band's) and the
/// depth range they were compiled for.
#[derive(Clone, Copy, Debug)]
pub struct CompiledRows<'a> {
    /// The models: a row of [`FIELDS`] × width values per camera row, each field by field
    /// ([`crate::compiled::CompiledFile::models`]), from camera row `first_row` on.
    pub models: &'a [f32],
    /// The camera row of the first row of `models` (0 for the whole camera's).
    pub first_row: usize,
    /// Near end of the depth range, mm.
    pub z_min: f32,
    /// Far end, mm.
    pub z_max: f32,
}

/// What every reconstruction task of one frame shares.
struct ReconFrame<'a, R: ?Sized> {
    recon: &'a Reconstructor,
    map: &'a R,
    compiled: Option<CompiledRows<'a>>,
    /// The camera row of `phase[0]` and `validity[0]`.
    base: usize,
    phase: &'a [f32],
    validity: &'a [u8],
}

/// Reconstruct a whole frame (paper §6, [`Reconstructor::reconstruct_row`] for every row) with
/// the kernel variant `isa` and, on x86-64 with AVX2 or AVX-512, the pair gathers of
/// [`crate::gather`]; rows in parallel when `parallel` is set (on rayon's current pool). The
/// results are bit-identical whatever `isa` and `parallel` are.
pub fn reconstruct_frame(
    recon: &Reconstructor,
    map: &ReferenceMap<'_>,
    phase: &[f32],
    validity: &[u8],
    out: PointsOut<'_>,
    isa: Isa,
    parallel: bool,
) -> Result<(), ReconstructError> {
    reconstruct_frame_compiled(recon, map, None, phase, validity, out, isa, parallel)
}

/// [`reconstruct_frame`] with compiled models (`Some`): each row runs [`compiled_row_inline`]
/// (inlined into the AVX2 build), and the search only over the chunks that hold a pixel it
/// leaves ([`Reconstructor::search_left_gather`]).
#[allow(clippy::too_many_arguments)]
pub fn reconstruct_frame_compiled(
    recon: &Reconstructor,
    map: &ReferenceMap<'_>,
    compiled: Option<CompiledRows<'_>>,
    phase: &[f32],
    validity: &[u8],
    out: PointsOut<'_>,
    isa: Isa,
    parallel: bool,
) -> Result<(), ReconstructError> {
    let w = recon.width();
    if phase.len() != w * recon.height() {
        return Err(ReconstructError::Length);
    }
    check_rows(recon, compiled, 0, phase, validity, &out)?;
    let f = ReconFrame {
        recon,
        map,
        compiled,
        base: 0,
        phase,
        validity,
    };
    type Task<'t> = (
        usize,
        ((&'t mut [f32], &'t mut [u8]), Option<&'t mut [u32]>),
    );
    let job =
        |(k, ((o, ov), n)): Task<'_>| recon_rows_dispatch(isa, &f, k * ROWS_PER_TASK, o, ov, n);
    let mut counts = out.searched.map(|s| s.chunks_mut(ROWS_PER_TASK));
    let counts = std::iter::from_fn(move || Some(counts.as_mut().and_then(|c| c.next())));
    let mut rows = out
        .xyz
        .chunks_mut(3 * w * ROWS_PER_TASK)
        .zip(out.validity.chunks_mut(w * ROWS_PER_TASK))
        .zip(counts)
        .enumerate();
    if parallel {
        rows.par_bridge().try_for_each(job)
    } else {
        rows.try_for_each(job)
    }
}

/// Reconstruct the rows `v0..` whose outputs are `xyz` (3 × width per row) and `codes` (width
/// per row), and when `searched` is given (one per row) the pixels of each that the search
/// computed ([`PointsOut::searched`]); `g` fetches the reference samples (the same values, and
/// bits, whichever it is).
#[inline(always)]
fn recon_rows<G: CellGather, R: ReferenceRows + ?Sized>(
    g: G,
    f: &ReconFrame<'_, R>,
    v0: usize,
    xyz: &mut [f32],
    codes: &mut [u8],
    mut searched: Option<&mut [u32]>,
) -> Result<(), ReconstructError> {
    let w = f.recon.width();
    // The search's pass over a compiled row's leftovers: allocated at the first one.
    let mut left: Option<(Vec<u8>, Vec<f32>, Vec<u8>)> = None;
    for (j, (o, ov)) in xyz.chunks_mut(3 * w).zip(codes.chunks_mut(w)).enumerate() {
        let v = v0 + j;
        let r = (v - f.base) * w..(v - f.base + 1) * w;
        let (p, q) = (&f.phase[r.clone()], &f.validity[r]);
        let count = searched.as_deref_mut().and_then(|s| s.get_mut(j));
        let Some(c) = f.compiled else {
            if let Some(n) = count {
                let valid = q.iter().filter(|&&c| c == Validity::Valid as u8).count();
                *n = valid as u32;
            }
            f.recon
                .reconstruct_row_gather(g, f.map, v as u32, p, q, o, ov)?;
            continue;
        };
        let r = v.checked_sub(c.first_row).ok_or(ReconstructError::Length)?;
        let models = c
            .models
            .get(r * FIELDS * w..(r + 1) * FIELDS * w)
            .ok_or(ReconstructError::Length)?;
        let n = compiled_row_inline(models, c.z_min, c.z_max, p, q, o, ov)
            .map_err(|_| ReconstructError::Length)?;
        if let Some(k) = count {
            *k = n as u32;
        }
        if n == 0 {
            continue;
        }
        let (mask, sx, sq) = left.get_or_insert_with(|| (vec![0; w], vec![0.0; 3 * w], vec![0; w]));
        let scratch = SearchScratch {
            mask,
            xyz: sx,
            codes: sq,
        };
        f.recon
            .search_left_gather(g, f.map, v as u32, p, q, o, ov, scratch)?;
    }
    Ok(())
}

/// [`recon_rows`] compiled with AVX2 (the core's kernel is `#[inline(always)]`, so it is compiled
/// here with AVX2 enabled).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn recon_rows_avx2<R: ReferenceRows + ?Sized>(
    g: Avx2Pairs,
    f: &ReconFrame<'_, R>,
    v0: usize,
    xyz: &mut [f32],
    codes: &mut [u8],
    searched: Option<&mut [u32]>,
) -> Result<(), ReconstructError> {
    recon_rows(g, f, v0, xyz, codes, searched)
}

/// [`recon_rows`] compiled with AVX-512.
#[cfg(all(target_arch = "x86_64", fringe3d_avx512))]
#[target_feature(enable = "avx512f,avx512bw,avx512dq,avx512vl")]
fn recon_rows_avx512<R: ReferenceRows + ?Sized>(
    g: Avx512Pairs,
    f: &ReconFrame<'_, R>,
    v0: usize,
    xyz: &mut [f32],
    codes: &mut [u8],
    searched: Option<&mut [u32]>,
) -> Result<(), ReconstructError> {
    recon_rows(g, f, v0, xyz, codes, searched)
}

fn recon_rows_dispatch<R: ReferenceRows + ?Sized>(
    isa: Isa,
    f: &ReconFrame<'_, R>,
    v0: usize,
    xyz: &mut [f32],
    codes: &mut [u8],
    searched: Option<&mut [u32]>,
) -> Result<(), ReconstructError> {
    match isa.effective() {
        #[cfg(all(target_arch = "x86_64", fringe3d_avx512))]
        Isa::Avx512 => match Avx512Pairs::detect() {
            // SAFETY: `effective` returned Avx512, so the CPU has every feature the function
            // enables (checked by `Isa::available`), the only requirement of `target_feature`.
            Some(g) => unsafe { recon_rows_avx512(g, f, v0, xyz, codes, searched) },
            None => recon_rows(ScalarGather, f, v0, xyz, codes, searched),
        },
        #[cfg(target_arch = "x86_64")]
        Isa::Avx2 => match Avx2Pairs::detect() {
            // SAFETY: `effective` returned Avx2, so the CPU supports AVX2 (checked by
            // `Isa::available`), the only requirement of a `#[target_feature(enable = "avx2")]`
            // function.
            Some(g) => unsafe { recon_rows_avx2(g, f, v0, xyz, codes, searched) },
            None => recon_rows(ScalarGather, f, v0, xyz, codes, searched),
        },
        _ => recon_rows(ScalarGather, f, v0, xyz, codes, searched),
    }
}

/// Decode the rows `y0..` of a set (`frames[i]` is image `i`, `width` pixels wide, whole
/// frames) into band buffers (`out`: as many whole rows as they hold) on the calling thread, with
/// the kernel variant `isa`: the rows of [`decode_frames`], bit for bit.
pub fn decode_rows<P: Sample>(
    d: &Decoder,
    frames: &[&[P]],
    width: usize,
    y0: usize,
    out: FrameOut<'_>,
    isa: Isa,
) -> Result<(), DecodeError> {
    let n = out.phase.len();
    if frames.len() != d.image_count()
        || width == 0
        || !n.is_multiple_of(width)
        || out.modulation.len() != n
        || out.dc.len() != n
        || out.validity.len() != n
    {
        return Err(DecodeError::Length);
    }
    rows_dispatch(
        isa,
        d,
        frames,
        width,
        y0,
        RowsOut {
            phase: out.phase,
            modulation: out.modulation,
            dc: out.dc,
            validity: out.validity,
        },
    )
}

/// Reconstruct the camera rows `v0..` from band buffers (`phase`, `validity`: whole rows
/// starting at row `v0`; `out` as many rows) on the calling thread, with the kernel variant
/// `isa`: the rows of [`reconstruct_frame`], bit for bit.
pub fn reconstruct_rows<R: ReferenceRows + ?Sized>(
    recon: &Reconstructor,
    map: &R,
    v0: usize,
    phase: &[f32],
    validity: &[u8],
    out: PointsOut<'_>,
    isa: Isa,
) -> Result<(), ReconstructError> {
    reconstruct_rows_compiled(recon, map, None, v0, phase, validity, out, isa)
}

/// The lengths of a band of whole rows from `v0` (the batch entry points' one check): `phase`,
/// `validity` and the outputs whole rows of the image, inside it, and compiled models of whole
/// rows that cover the band.
fn check_rows(
    recon: &Reconstructor,
    compiled: Option<CompiledRows<'_>>,
    v0: usize,
    phase: &[f32],
    validity: &[u8],
    out: &PointsOut<'_>,
) -> Result<(), ReconstructError> {
    let w = recon.width();
    let n = phase.len();
    let rows_fit = w > 0 && n.is_multiple_of(w) && v0 + n / w <= recon.height();
    let rows = n / w.max(1);
    let same = validity.len() == n
        && out.xyz.len() == 3 * n
        && out.validity.len() == n
        && out.searched.as_ref().is_none_or(|s| s.len() == rows);
    let models = compiled.is_none_or(|c| {
        let held = c.models.len() / (FIELDS * w).max(1);
        c.models.len().is_multiple_of((FIELDS * w).max(1))
            && c.first_row <= v0
            && v0 + rows <= c.first_row + held
    });
    if rows_fit && same && models {
        Ok(())
    } else {
        Err(ReconstructError::Length)
    }
}

/// [`reconstruct_rows`] with compiled models (`Some`), as [`reconstruct_frame_compiled`].
#[allow(clippy::too_many_arguments)]
pub fn reconstruct_rows_compiled<R: ReferenceRows + ?Sized>(
    recon: &Reconstructor,
    map: &R,
    compiled: Option<CompiledRows<'_>>,
    v0: usize,
    phase: &[f32],
    validity: &[u8],
    out: PointsOut<'_>,
    isa: Isa,
) -> Result<(), ReconstructError> {
    check_rows(recon, compiled, v0, phase, validity, &out)?;
    let f = ReconFrame {
        recon,
        map,
        compiled,
        base: v0,
        phase,
        validity,
    };
    recon_rows_dispatch(isa, &f, v0, out.xyz, out.validity, out.searched)
}
