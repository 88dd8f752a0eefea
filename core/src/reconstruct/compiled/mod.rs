//! The compiled reconstruction: paper §6 with the search replaced by one rational function per
//! pixel.
//!
//! # Why a pixel's depth is a rational function of its phase
//! Along camera pixel `(u, v)`'s ray `M = s·(x, y, 1)` (ideal normalized coordinates, camera
//! frame), every depth `s` meets one projector ray. With a pinhole projector and straight,
//! evenly spaced fringes, the phase seen there is a projective (Möbius) function of `s`, so `s` is
//! one of the phase: `s = (α + β·Φ)/(1 + γ·Φ)`, one division. Projector lens distortion and
//! fringes of varying width or curvature bend that function slightly; a low-order polynomial
//! numerator absorbs the bend. [`PixelModel`] is that function over the pixel's depth range:
//! ```text
//! τ = (Φ − Φ_c)·k                                 (the phase range of [z_min, z_max] → [−1, 1])
//! s = s_c + τ·(d₁ + d₂τ + d₃τ² + d₄τ³) / (1 + γτ)
//! M = (s·x, s·y, s)
//! ```
//! written about the range's centre `s_c` so that the large term is added last and exactly once
//! (f32 rounds the sum to half an ulp of `s`; the correction carries its own few ulps at its own,
//! smaller scale). The coefficients come from the exact search (the reference map's model of
//! §6, `fringe3d compile`), which checks each pixel against the search at build time and leaves
//! [`PixelModel::SEARCH`] where the function cannot meet its tolerance (a map that is not a model,
//! invalid reference inside the range): those pixels keep the §6 search ([`compiled_row`] returns
//! how many a row has; [`merge_search`] takes their results). Where the projector does not light
//! the whole depth range along a ray, the model covers the part the map does and is marked
//! [clipped](PixelModel::is_clipped): a phase just beyond it goes to the search too, and one
//! beyond the model's own far threshold (`|τ| > τ_far`, [`PixelModel::far`]) is
//! [`Validity::NoCrossing`], the search's answer there, where the builder could prove that
//! ([`PixelModel::far_is_no_crossing`]; elsewhere `τ_far` is +∞ and every phase beyond the range
//! goes to the search). Where the map
//! has no valid sample anywhere near the ray's path, the search can only answer
//! [`Validity::ReferenceInvalid`], whatever the phase: such a pixel is
//! [`PixelModel::NO_REFERENCE`] and answers that at once, without the search's fallback (its
//! slowest path, which an off-map pixel always takes).
//!
//! # Same answer as the search
//! A pixel is valid when its input phase is valid, `|τ| ≤ 1`, and `s` lies in `[z_min, z_max]`,
//! the search's own final test (its out-of-range phases are [`Validity::OutOfDepth`] as here;
//! `fringe3d compile` keeps a pixel only if the codes agree at every phase it checks).
//! Input codes other than `Valid` are kept, unknown codes and non-finite phases become
//! [`Validity::PhaseOutOfRange`], as the search does; every invalid point is the canonical NaN.
//!
//! # Cost
//! Per pixel: one division and about twenty other operations (the point's depth and its two
//! products, their finiteness, the range and depth tests); no table, no gather, no iteration.
//! The model is [`PixelModel::BYTES`] = 44 bytes a pixel, read row by row
//! ([`PixelModel::parse_row`]); a head needs neither the camera's lens model nor the reference
//! map for compiled pixels.
//!
//! The f64 reference of the function is [`PixelModel::depth_f64`]; [`compiled_row`] is the one
//! kernel (streaming, batch and the head), with the operation order fixed (no FMA), so it gives
//! the same bits everywhere.

pub mod parity;
mod search;
mod settle;

pub use search::{SearchScratch, merge_search, next_search_span, search_mask};
pub use settle::SETTLE_CHUNK;

use crate::math::{CANONICAL_NAN, canonical, fabs};
use crate::validity::Validity;

/// Terms of the numerator's polynomial `d₁ + d₂τ + d₃τ² + d₄τ³`.
pub const TERMS: usize = 4;
/// Numbers in one model: ray x, ray y, Φ_c, ±k, s_c, γ, d₁…d₄, τ_far.
pub const FIELDS: usize = 7 + TERMS;

/// The code [`compiled_row`] writes for a pixel it leaves to the search: not a [`Validity`];
/// [`merge_search`] replaces every one of them.
pub const LEFT_TO_SEARCH: u8 = 0xFF;

/// One pixel's compiled depth function (see the module documentation), or
/// [`PixelModel::SEARCH`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PixelModel {
    /// The pixel's ray `(x, y)`: ideal normalized coordinates (`M = s·(x, y, 1)`).
    pub ray: [f32; 2],
    /// Φ_c: the phase at the centre of the pixel's range, rad.
    pub phase_centre: f32,
    /// ±k: `τ = (Φ − Φ_c)·|k|` maps the pixel's phase range to `[−1, 1]`, 1/rad (the
    /// polynomial's odd terms carry the phase's direction). The sign says what a phase beyond
    /// the range means: positive, a point out of the depth range ([`Validity::OutOfDepth`]);
    /// negative, the range is the part of the depth range the reference map covers along this
    /// ray ([`PixelModel::is_clipped`]), and such a phase goes to the search, or, beyond
    /// [`PixelModel::far`], is [`Validity::NoCrossing`].
    pub phase_scale: f32,
    /// s_c: the depth at `τ = 0`, mm (not negative).
    pub depth_centre: f32,
    /// γ: the pole term of the denominator `1 + γτ`.
    pub pole: f32,
    /// d₁…d₄ of the numerator `τ·(d₁ + d₂τ + d₃τ² + d₄τ³)`, mm.
    pub slope: [f32; TERMS],
    /// τ_far: how far beyond a [clipped](PixelModel::is_clipped) range a phase must lie (`|τ| >
    /// τ_far`, at least 1) to be [`Validity::NoCrossing`] without the search; +∞ where the
    /// builder could not show that (every phase beyond the range goes to the search) and on
    /// every model that is not clipped. A builder gives a clipped model a finite τ_far only where
    /// it has shown that every phase that far out lies beyond every valid value of the map the
    /// search can read along the pixel's segment, by more than a Newton step can close, with one
    /// end of the segment on the map and the other off it (or on an invalid patch): then the
    /// search's answer is `NoCrossing`. Between `|τ| = 1` and τ_far the search answers (near the
    /// map's edge it may find a point). Each pixel has its own: how far the map the search can
    /// read reaches beyond the fitted range (its inset from the map's edge and a few pixels
    /// around the path) differs from pixel to pixel (1.06–1.4 on the benchmark's scene).
    pub far: f32,
}

impl PixelModel {
    /// Bytes of one model in a row ([`PixelModel::emit`]): eleven little-endian f32.
    pub const BYTES: usize = 4 * FIELDS;

    /// "Not compiled": the pixel keeps the §6 search. Every field is the canonical NaN.
    pub const SEARCH: PixelModel = PixelModel {
        ray: [CANONICAL_NAN; 2],
        phase_centre: CANONICAL_NAN,
        phase_scale: CANONICAL_NAN,
        depth_centre: CANONICAL_NAN,
        pole: CANONICAL_NAN,
        slope: [CANONICAL_NAN; TERMS],
        far: CANONICAL_NAN,
    };

    /// "No reference along the ray": the builder proved that every sample the search can take
    /// for this pixel is off the map or invalid, so a valid phase gets
    /// [`Validity::ReferenceInvalid`], the search's own answer, without running it. A zero phase
    /// scale; every other field is the canonical NaN.
    pub const NO_REFERENCE: PixelModel = PixelModel {
        phase_scale: 0.0,
        ..PixelModel::SEARCH
    };

    /// Whether the pixel is [`PixelModel::NO_REFERENCE`] (a zero phase scale, either sign).
    #[inline(always)]
    pub fn is_no_reference(&self) -> bool {
        self.phase_scale == 0.0
    }

    /// Whether the pixel has a function (a finite, non-zero phase scale); otherwise the search
    /// (or, with a zero scale, [`PixelModel::NO_REFERENCE`]).
    #[inline(always)]
    pub fn is_compiled(&self) -> bool {
        let k = fabs(self.phase_scale);
        (k > 0.0) & (k < f32::INFINITY)
    }

    /// Whether the range is clipped to the map (a negative scale): a phase beyond it goes to the
    /// search, which knows where the map ends, but beyond [`PixelModel::far`] where the model has
    /// the far rule ([`PixelModel::far_is_no_crossing`]): there it is [`Validity::NoCrossing`].
    #[inline(always)]
    pub fn is_clipped(&self) -> bool {
        self.phase_scale < 0.0
    }

    /// Whether a phase beyond [`PixelModel::far`] is [`Validity::NoCrossing`] without the
    /// search: a clipped model with a finite τ_far.
    #[inline(always)]
    pub fn far_is_no_crossing(&self) -> bool {
        self.is_clipped() && fabs(self.far) < f32::INFINITY
    }

    /// The model's eleven numbers in file order: ray x, ray y, Φ_c, k, s_c, γ, d₁…d₄, τ_far.
    pub fn to_array(&self) -> [f32; FIELDS] {
        let mut a = [0f32; FIELDS];
        a[..6].copy_from_slice(&[
            self.ray[0],
            self.ray[1],
            self.phase_centre,
            self.phase_scale,
            self.depth_centre,
            self.pole,
        ]);
        a[6..6 + TERMS].copy_from_slice(&self.slope);
        a[6 + TERMS] = self.far;
        a
    }

    /// The model from its eleven numbers ([`PixelModel::to_array`]'s order). A zero scale is
    /// [`PixelModel::NO_REFERENCE`] whatever the other numbers; any other model with a
    /// non-finite number (but τ_far), a negative s_c, or a τ_far that is neither +∞ nor (clipped)
    /// finite and at least 1 is [`PixelModel::SEARCH`] (one representation of each, whatever the
    /// bits were).
    pub fn from_array(a: [f32; FIELDS]) -> PixelModel {
        let mut slope = [0f32; TERMS];
        slope.copy_from_slice(&a[6..6 + TERMS]);
        let m = PixelModel {
            ray: [a[0], a[1]],
            phase_centre: a[2],
            phase_scale: a[3],
            depth_centre: a[4],
            pole: a[5],
            slope,
            far: a[6 + TERMS],
        };
        let finite = a[..6 + TERMS].iter().all(|v| fabs(*v) < f32::INFINITY);
        if PixelModel::usable(finite, m.phase_scale, m.depth_centre, m.far) {
            m
        } else if m.is_no_reference() {
            PixelModel::NO_REFERENCE
        } else {
            PixelModel::SEARCH
        }
    }

    /// The rule by which [`PixelModel::from_array`] keeps a model as it is (a function): its
    /// numbers but τ_far all finite (`finite`), a non-zero scale `k`, s_c not negative, and τ_far
    /// +∞ (no far rule) or, on a clipped model (`k < 0`), finite and at least 1: one encoding
    /// per model. For a reader that checks the fields of many models at once.
    #[inline(always)]
    pub fn usable(finite: bool, k: f32, s_c: f32, far: f32) -> bool {
        let far_ok = far == f32::INFINITY || (k < 0.0 && fabs(far) < f32::INFINITY && far >= 1.0);
        finite && k != 0.0 && s_c >= 0.0 && far_ok
    }

    /// Write the model as [`PixelModel::BYTES`] little-endian bytes into `out[..BYTES]`; `None`
    /// when `out` is shorter.
    pub fn emit(&self, out: &mut [u8]) -> Option<()> {
        let out = out.get_mut(..Self::BYTES)?;
        for (o, v) in out.chunks_exact_mut(4).zip(self.to_array()) {
            o.copy_from_slice(&canonical(v).to_le_bytes());
        }
        Some(())
    }

    /// Read a model written by [`PixelModel::emit`]; `None` when `bytes` is shorter than
    /// [`PixelModel::BYTES`]. Any bits parse, as [`PixelModel::from_array`] reads them.
    pub fn parse(bytes: &[u8]) -> Option<PixelModel> {
        let b = bytes.get(..Self::BYTES)?;
        let mut a = [0f32; FIELDS];
        for (v, c) in a.iter_mut().zip(b.chunks_exact(4)) {
            *v = f32::from_le_bytes([c[0], c[1], c[2], c[3]]);
        }
        Some(PixelModel::from_array(a))
    }

    /// Put the model of pixel `u` into a row stored field by field (`row[k·w + u]` is field `k`,
    /// in [`PixelModel::to_array`]'s order, of pixel `u`; `w = row.len() / FIELDS`), the layout
    /// [`compiled_row`] reads. `None` when `u` is outside the row.
    pub fn store(&self, row: &mut [f32], u: usize) -> Option<()> {
        let w = row.len() / FIELDS;
        if u >= w {
            return None;
        }
        for (k, v) in self.to_array().into_iter().enumerate() {
            row[k * w + u] = v;
        }
        Some(())
    }

    /// The model of pixel `u` of a row stored field by field ([`PixelModel::store`]), checked as
    /// [`PixelModel::from_array`] does. `None` when `u` is outside the row.
    pub fn load(row: &[f32], u: usize) -> Option<PixelModel> {
        let w = row.len() / FIELDS;
        if u >= w {
            return None;
        }
        Some(PixelModel::from_array(core::array::from_fn(|k| {
            row[k * w + u]
        })))
    }

    /// The f64 reference of the function: the depth `s` for phase `phase`, `None` outside
    /// `|τ| ≤ 1` or for [`PixelModel::SEARCH`]. The kernel ([`compiled_row`]) evaluates the same
    /// expression in f32 in this order.
    pub fn depth_f64(&self, phase: f64) -> Option<f64> {
        if !self.is_compiled() {
            return None;
        }
        let tau = (phase - self.phase_centre as f64) * (self.phase_scale as f64).abs();
        if !(tau.abs() <= 1.0) {
            return None;
        }
        Some(self.depth_f64_unbounded(phase))
    }

    /// [`PixelModel::depth_f64`] without the range check: the function continued past `|τ| = 1`
    /// (for a builder checking its fit up to the range's ends).
    pub fn depth_f64_unbounded(&self, phase: f64) -> f64 {
        let tau = (phase - self.phase_centre as f64) * (self.phase_scale as f64).abs();
        let mut p = 0.0;
        for d in self.slope.iter().rev() {
            p = *d as f64 + tau * p;
        }
        self.depth_centre as f64 + tau * p / (1.0 + self.pole as f64 * tau)
    }
}

/// Why a compiled row was refused (a caller's error: the data itself never fails).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CompiledError {
    /// The slices do not have the row's lengths (`models`, phase and validity `w`, points `3w`).
    Length,
    /// The depth range is not finite and increasing.
    DepthRange,
}

impl core::fmt::Display for CompiledError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            CompiledError::Length => "a row's slices do not have the row's lengths",
            CompiledError::DepthRange => "the depth range must be finite with z_min < z_max",
        })
    }
}

/// Pixels per pass of [`compiled_row`]: the arithmetic over a chunk runs as one vector loop,
/// the interleaved stores of the points as a second.
const CHUNK: usize = 64;

/// The arithmetic of [`compiled_row`] over one chunk: depths and codes. One vector loop (fixed
/// length, no branch that depends on a lane).
#[inline(always)]
fn pass(
    f: [&[f32; CHUNK]; FIELDS],
    p: &[f32; CHUNK],
    q: &[u8; CHUNK],
    z_min: f32,
    z_max: f32,
    s: &mut [f32; CHUNK],
    code: &mut [u8; CHUNK],
) {
    const _: () = assert!(TERMS == 4);
    let [rx, ry, pc, ps, dc, pole, d1, d2, d3, d4, far_tau] = f;
    for i in 0..CHUNK {
        let (act, code_in) = super::input_code(q[i], p[i]);
        // The depth: PixelModel::depth_f64's expression, in its order, in f32.
        let k = fabs(ps[i]);
        let tau = ((if act { p[i] } else { 0.0 }) - pc[i]) * k;
        let poly = d1[i] + tau * (d2[i] + tau * (d3[i] + tau * d4[i]));
        let si = dc[i] + tau * poly / (1.0 + pole[i] * tau);
        let in_range = fabs(tau) <= 1.0;
        let compiled = (k > 0.0) & (k < f32::INFINITY);
        // No reference along the ray: the search's own answer, at once.
        let none = k == 0.0;
        // Beyond a range the map's end clipped: the search, or beyond τ_far, no crossing.
        let clipped_out = compiled & !in_range & (ps[i] < 0.0);
        let far = fabs(tau) > far_tau[i];
        let left = act & !none & (!compiled | (clipped_out & !far));
        // Inside the range only (beyond it the point is out of depth, as in the search), and
        // the whole point: a model whose ray is not finite gives no point.
        let finite = (fabs(si) < f32::INFINITY)
            & (fabs(si * rx[i]) < f32::INFINITY)
            & (fabs(si * ry[i]) < f32::INFINITY);
        let degenerate = in_range & !finite;
        let inside = in_range & (si >= z_min) & (si <= z_max);
        s[i] = si;
        let c = if inside {
            Validity::Valid as u8
        } else {
            Validity::OutOfDepth as u8
        };
        let c = if degenerate {
            Validity::Degenerate as u8
        } else {
            c
        };
        let c = if none {
            Validity::ReferenceInvalid as u8
        } else {
            c
        };
        let c = if clipped_out {
            Validity::NoCrossing as u8
        } else {
            c
        };
        let c = if left { LEFT_TO_SEARCH } else { c };
        code[i] = if act { c } else { code_in };
    }
}

/// Reconstruct one row with its compiled models: for each pixel `u`, the point into
/// `out_xyz[3u..3u+3]` and its [`Validity`] code into `out_validity[u]`, as
/// [`crate::reconstruct::Reconstructor::reconstruct_row`] would for the same phase (module
/// documentation). `models` is the row's models field by field ([`PixelModel::store`]: [`FIELDS`]
/// arrays of `w` values). A valid pixel whose model is [`PixelModel::SEARCH`], or whose phase lies
/// beyond a [clipped](PixelModel::is_clipped) range (within its [`PixelModel::far`], +∞ when the
/// model lacks the far rule; farther, it is [`Validity::NoCrossing`]), is left to the
/// search: its point is NaN and
/// its code [`LEFT_TO_SEARCH`]; the return value counts them (0: the row is done; otherwise run
/// [`search_mask`], the search, and [`merge_search`]). A valid pixel whose model is
/// [`PixelModel::NO_REFERENCE`] gets [`Validity::ReferenceInvalid`] and a NaN point. `z_min`,
/// `z_max`: the depth range the models were compiled for, mm.
///
/// Out of line (the flash policy, docs/integration.md): one copy however many places call it.
/// [`compiled_row_inline`] is the same, always inlined, for a caller that compiles the kernel
/// with its own target features (the desktop's AVX2 build).
#[allow(clippy::too_many_arguments)]
#[inline(never)]
pub fn compiled_row(
    models: &[f32],
    z_min: f32,
    z_max: f32,
    phase_row: &[f32],
    validity_row: &[u8],
    out_xyz: &mut [f32],
    out_validity: &mut [u8],
) -> Result<usize, CompiledError> {
    compiled_row_inline(
        models,
        z_min,
        z_max,
        phase_row,
        validity_row,
        out_xyz,
        out_validity,
    )
}

/// [`compiled_row`], always inlined: each call site gets its own copy of the kernel.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub fn compiled_row_inline(
    models: &[f32],
    z_min: f32,
    z_max: f32,
    phase_row: &[f32],
    validity_row: &[u8],
    out_xyz: &mut [f32],
    out_validity: &mut [u8],
) -> Result<usize, CompiledError> {
    let w = phase_row.len();
    if models.len() != FIELDS * w
        || validity_row.len() != w
        || out_xyz.len() != 3 * w
        || out_validity.len() != w
    {
        return Err(CompiledError::Length);
    }
    if !(z_min < z_max) || !(fabs(z_min) < f32::INFINITY) || !(fabs(z_max) < f32::INFINITY) {
        return Err(CompiledError::DepthRange);
    }
    let mut search = 0usize;
    let mut c0 = 0;
    while c0 < w {
        let n = (w - c0).min(CHUNK);
        // A whole chunk is read in place; the row's last, shorter one through padded copies
        // (their extra lanes are never written out).
        let mut s = [0f32; CHUNK];
        let mut code = [0u8; CHUNK];
        let whole = |k: usize| -> Option<&[f32; CHUNK]> {
            models.get(k * w + c0..k * w + c0 + CHUNK)?.try_into().ok()
        };
        let fields: Option<[&[f32; CHUNK]; FIELDS]> = if n == CHUNK {
            let f: [Option<&[f32; CHUNK]>; FIELDS] = core::array::from_fn(whole);
            if f.iter().all(Option::is_some) {
                Some(f.map(|x| x.unwrap_or(&[0.0; CHUNK])))
            } else {
                None
            }
        } else {
            None
        };
        // Every range below is inside the lengths checked above: `get` only keeps panic code out
        // of a head's build (docs/integration.md, "No panics").
        let (Some(p), Some(q)) = (phase_row.get(c0..c0 + n), validity_row.get(c0..c0 + n)) else {
            return Err(CompiledError::Length);
        };
        match (
            fields,
            <&[f32; CHUNK]>::try_from(p),
            <&[u8; CHUNK]>::try_from(q),
        ) {
            (Some(f), Ok(p), Ok(q)) => pass(f, p, q, z_min, z_max, &mut s, &mut code),
            _ => {
                let mut pad = [[0f32; CHUNK]; FIELDS];
                let mut pp = [0f32; CHUNK];
                let mut pq = [Validity::Dark as u8; CHUNK];
                for (k, row) in pad.iter_mut().enumerate() {
                    let src = models.get(k * w + c0..k * w + c0 + n).unwrap_or(&[]);
                    row.iter_mut().zip(src).for_each(|(d, s)| *d = *s);
                }
                pp.iter_mut().zip(p).for_each(|(d, s)| *d = *s);
                pq.iter_mut().zip(q).for_each(|(d, s)| *d = *s);
                let f: [&[f32; CHUNK]; FIELDS] = core::array::from_fn(|k| &pad[k]);
                pass(f, &pp, &pq, z_min, z_max, &mut s, &mut code);
            }
        }
        let (Some(rx), Some(ry), Some(xyz), Some(ov)) = (
            models.get(c0..c0 + n),
            models.get(w + c0..w + c0 + n),
            out_xyz.get_mut(3 * c0..3 * (c0 + n)),
            out_validity.get_mut(c0..c0 + n),
        ) else {
            return Err(CompiledError::Length);
        };
        let pixels = s.iter().zip(&code).zip(rx.iter().zip(ry));
        for (o, ((&si, &ci), (&x, &y))) in xyz.chunks_exact_mut(3).zip(pixels) {
            let good = ci == Validity::Valid as u8;
            if let [ox, oy, oz] = o {
                *ox = if good { si * x } else { CANONICAL_NAN };
                *oy = if good { si * y } else { CANONICAL_NAN };
                *oz = if good { si } else { CANONICAL_NAN };
            }
        }
        for (o, c) in ov.iter_mut().zip(&code) {
            *o = *c;
            search += (*c == LEFT_TO_SEARCH) as usize;
        }
        c0 += n;
    }
    Ok(search)
}
