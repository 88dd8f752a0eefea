//! The decoder of one pattern set, built once ([`Decoder::with_arith`]): per-image coefficients
//! from the levels' estimators ([`crate::estimator`]) in the arithmetic's number formats, level
//! ratios and thresholds, the plane modes of the frame-sequential path and the loop kinds of the
//! row driver. The passes that run it are in the sibling modules (`row`, `fused`, `accumulate`,
//! `finish`, `level`).

use crate::arith::{Arith, F32Accurate, Limits, Plan};
use crate::decode_config::DecodeConfig;
use crate::decode_error::DecodeError;
use crate::estimator::{LevelEstimator, level_estimator};
use crate::gray::GrayCode;
use crate::limits::{CORRECTION_KNOTS, MAX_IMAGES, MAX_LEVELS, MAX_SHIFTS};
use crate::pattern::{PatternSet, Relation};

/// Per-image coefficients, in image order.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct ImageCoef<K> {
    pub(super) level: u8,
    pub(super) a: K,
    pub(super) b: K,
    pub(super) w: K,
    /// How the image enters the S, C and DC planes: [`SKIP`] (zero coefficient: `acc + 0·v` is
    /// `acc` exactly, as no accumulator is ever −0), [`INIT`] (the plane's first non-zero
    /// contribution in image order: `0 + k·v`) or [`ACC`].
    pub(super) mode: [u8; 3],
}

/// Plane mode: the coefficient is zero, the plane is left alone.
pub(super) const SKIP: u8 = 0;
/// Plane mode: first contribution, `ZERO + k·v` (the row driver then needs no zeroed state).
pub(super) const INIT: u8 = 1;
/// Plane mode: `acc + k·v`.
pub(super) const ACC: u8 = 2;

/// A decoder for one pattern set: estimators, level ratios and thresholds, computed once, in the
/// number formats of the arithmetic `A` ([`crate::arith`]; the default is [`F32Accurate`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Decoder<A: Arith = F32Accurate> {
    pub(super) n_levels: usize,
    pub(super) n_images: usize,
    pub(super) images: [ImageCoef<A::Coef>; MAX_IMAGES],
    pub(super) a_dc: [A::Coef; MAX_LEVELS],
    pub(super) b_dc: [A::Coef; MAX_LEVELS],
    /// `c_k / c_{k−1}` for k ≥ 1 (entry 0 unused).
    pub(super) ratio: [A::Ratio; MAX_LEVELS],
    pub(super) limits: Limits<A>,
    pub(super) format: A::Format,
    pub(super) config: DecodeConfig,
    /// Planes (DC, then S and C of each level) no image contributes to: the row driver zeroes them.
    pub(super) untouched: [bool; 1 + 2 * MAX_LEVELS],
    /// The images of each level, in image order (the row driver's per-level passes).
    pub(super) level_images: [LevelImages; MAX_LEVELS],
    /// The levels in the order the row driver computes them: the DC level first (the others'
    /// S and C need its A), then the rest in level order.
    pub(super) level_order: [u8; MAX_LEVELS],
    /// The level whose images carry the DC term A (eq 10/15), if any.
    pub(super) dc_level: Option<u8>,
    /// Whether the row driver computes every level in one loop ([`Self::fused_rows`]):
    /// [`FUSED_PAIRS`] or [`FUSED_QUADS`] for three levels whose finest is the DC level of
    /// kind [`KIND_QUAD_EXACT`] and whose coarser ones are both of kind [`KIND_PAIR_UNIT`] or
    /// both [`KIND_QUAD_EXACT`]; [`FUSED_NONE`] otherwise.
    pub(super) fused: u8,
    /// The phase-error table of every level (knots of 2⁻¹³ rad), if any
    /// ([`Self::with_correction`]).
    pub(super) correction: Option<[[i16; CORRECTION_KNOTS]; MAX_LEVELS]>,
    /// The code of the set's Gray-code level (level 0), if any ([`crate::gray`]).
    pub(super) gray: Option<GrayCode>,
    /// The word bit of each Gray image, in the order of `level_images[0]` (image order).
    pub(super) gray_word_bit: [u8; MAX_SHIFTS],
    /// Whether every image of the DC level comes before every Gray image (the frame-sequential
    /// path thresholds a Gray image on arrival, against the complete A); for an inverse code,
    /// whether each image comes right before its inverse among the code's images
    /// ([`PatternSet::frame_sequential_order`]).
    pub(super) gray_after_dc: bool,
    /// An inverse code's pairs ([`GrayCode::inverted`]): for the image at position `j` of
    /// `level_images[0]`, the position of its partner (the inverse of an even image, the image of
    /// an odd one).
    pub(super) gray_partner: [u8; MAX_SHIFTS],
    /// An inverse code's images at each position of `level_images[0]`: `true` for a pair's image
    /// (even shift), `false` for the inverse.
    pub(super) gray_even: [bool; MAX_SHIFTS],
    /// A heterodyne set ([`Relation::Heterodyne`]): `ratio[0..n_levels]` is the chain of
    /// unwrapping ratios from the beat, in the order of `finish`'s steps.
    pub(super) heterodyne: bool,
    /// A coprime set's `a` ([`Relation::Coprime`]: `c₀ = a·u`, `c₁ = b·u`), 0 otherwise: the
    /// candidate orders of level 0 run over `−(a/2 + 1) ..= a/2 + 1`.
    pub(super) coprime: u8,
}

/// Pixels side by side in [`Decoder::fused_rows`] (pass 1 of the paper's and the 12-pattern
/// sets): pixel `j` of each of the block's `FUSED_LANES` parts per iteration. Four vectorize on
/// SSE2, AVX2 and AVX-512 alike.
pub(super) const FUSED_LANES: usize = 4;

// The `FUSED_*` and `KIND_*` codes (and the plane modes `SKIP`/`INIT`/`ACC`) are `u8` constants,
// not enums, because they are const generic arguments of the row driver's loops
// (`fused_rows::<P, KIND_PAIR_UNIT, 1>`, `level_rows::<P, N, KIND, DC, FINE>`, `acc_loop`'s
// modes), which select the loop body at compile time: stable Rust accepts only integers, `bool`
// and `char` as const generic parameters; an enum would need the unstable `adt_const_params`.

/// [`Decoder`]'s `fused`: one loop per level.
pub(super) const FUSED_NONE: u8 = 0;
/// [`Decoder`]'s `fused`: the paper's 8-pattern structure (4-step finest level, two 2-image levels).
pub(super) const FUSED_PAIRS: u8 = 1;
/// [`Decoder`]'s `fused`: three 4-step levels (the 12-pattern set).
pub(super) const FUSED_QUADS: u8 = 2;

/// The images of one level, in image order.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct LevelImages {
    pub(super) n: u8,
    pub(super) idx: [u8; MAX_SHIFTS],
    /// Where the level's coefficients are zero, when it matches a pattern the row driver has a
    /// shorter loop for ([`KIND_GENERIC`] otherwise).
    pub(super) kind: u8,
}

/// A level without a special pattern: every product is computed.
pub(super) const KIND_GENERIC: u8 = 0;
/// Two images whose S and C each come from one of them (the paper's 2-image levels, shifts a
/// quarter period apart, eq 11): `S = a₀·I₀ + a_dc·A`, `C = b₁·I₁ + b_dc·A`.
pub(super) const KIND_PAIR: u8 = 1;
/// Four images a quarter period apart (eq 9): `S = a₀·I₀ + a₂·I₂`, `C = b₁·I₁ + b₃·I₃`, no
/// external DC term.
pub(super) const KIND_QUAD: u8 = 2;
/// [`KIND_PAIR`] with the paper's exact coefficients (shifts 0 and π/2, eq 11) in a backend whose
/// sums are exact: `S = I₀ − A`, `C = I₁ − A`, the same bits as the products and sums.
pub(super) const KIND_PAIR_UNIT: u8 = 3;
/// A Gray-code level: binary images, no S or C ([`crate::gray`]).
pub(super) const KIND_GRAY: u8 = 5;
/// [`KIND_QUAD`] with the paper's exact coefficients (eqs 9-10) in a backend whose sums are
/// exact: `S = ½·(I₀ − I₂)`, `C = ½·(I₁ − I₃)`, `A = ¼·(I₀ + I₁ + I₂ + I₃)`, the same bits as
/// the products and sums (every intermediate is exact, and no sum is −0 either way).
pub(super) const KIND_QUAD_EXACT: u8 = 4;

impl Decoder<F32Accurate> {
    /// Build the decoder of `set` with thresholds `config`, in the default arithmetic
    /// ([`F32Accurate`]). See [`Decoder::with_arith`] for the others.
    pub fn new(set: &PatternSet, config: DecodeConfig) -> Result<Self, DecodeError> {
        Self::with_arith(set, config)
    }
}

/// An all-zero estimator (a placeholder for unused levels).
const NO_ESTIMATOR: LevelEstimator = LevelEstimator {
    n: 0,
    a: [0.0; MAX_SHIFTS],
    b: [0.0; MAX_SHIFTS],
    w: [0.0; MAX_SHIFTS],
    a_dc: 0.0,
    b_dc: 0.0,
};

impl<A: Arith> Decoder<A> {
    /// Build the decoder of `set` with thresholds `config` in the arithmetic `A`, e.g.
    /// `Decoder::<Fixed>::with_arith(&set, config)`.
    ///
    /// Besides the errors of [`Decoder::new`], a backend may refuse a set its number formats cannot
    /// hold ([`crate::arith::Fixed`]: a level whose absolute phase could exceed the fixed-point
    /// range, or coefficients too large for the accumulators), as [`DecodeError::Degenerate`] of
    /// that level.
    pub fn with_arith(set: &PatternSet, config: DecodeConfig) -> Result<Self, DecodeError> {
        let mut slot = None;
        Self::build_into(&mut slot, set, config)?;
        slot.ok_or(DecodeError::Config)
    }

    /// [`Decoder::with_arith`] built into `slot` (e.g. a head's `static`), `None` on error: the
    /// decoder is filled in place, with no copy of it on the caller's stack, which on a head is
    /// the set-up's deepest.
    #[inline(never)]
    pub fn build_into(
        slot: &mut Option<Self>,
        set: &PatternSet,
        config: DecodeConfig,
    ) -> Result<(), DecodeError> {
        *slot = None;
        let r = Self::fill(slot, set, config);
        if r.is_err() {
            *slot = None;
        }
        r
    }

    // The level index picks the level's coefficients, ratio and images alike.
    #[allow(clippy::needless_range_loop)]
    fn fill(
        slot: &mut Option<Self>,
        set: &PatternSet,
        config: DecodeConfig,
    ) -> Result<(), DecodeError> {
        if !config.is_sane() {
            return Err(DecodeError::Config);
        }
        let levels = set.levels();
        let offset = set.effective_offset();
        let mut est = [NO_ESTIMATOR; MAX_LEVELS];
        for (i, l) in levels.iter().enumerate() {
            if l.gray().is_some() {
                continue;
            }
            est[i] = level_estimator(l.shifts(), offset).ok_or(DecodeError::Degenerate(i as u8))?;
        }
        // The DC level: most shifts, finest on ties.
        let mut dc_level = None;
        for (i, l) in levels.iter().enumerate() {
            let dc_len = dc_level.and_then(|d: usize| levels.get(d)).map(|d| d.len());
            if l.has_dc() && dc_len.is_none_or(|d| l.len() >= d) {
                dc_level = Some(i);
            }
        }
        let mut ratios = [1.0f64; MAX_LEVELS];
        for i in 1..levels.len() {
            ratios[i] = levels[i].scale() / levels[i - 1].scale();
        }
        let n_levels = levels.len();
        // A heterodyne set's chain of unwrapping ratios from its beat (`Relation::Heterodyne`),
        // after a leading 1 (the plan's convention: entry 0 is the start).
        let heterodyne = set.relation() == Relation::Heterodyne;
        let mut chain = [1.0f64; MAX_LEVELS + 1];
        if heterodyne {
            let c = |i: usize| levels.get(i).map_or(1.0, |l| l.scale());
            let beat = set.relation().start_scale(levels).unwrap_or(1.0);
            if n_levels == 2 {
                chain[1..3].copy_from_slice(&[c(0) / beat, c(1) / c(0)]);
            } else {
                let b01 = c(1) - c(0);
                chain[1..4].copy_from_slice(&[b01 / beat, c(1) / b01, c(2) / c(1)]);
            }
        }
        // A coprime set's `a` (`Relation::Coprime`): its candidates are tested in the range of
        // `c₀·Φ`, `a` times the set's range of `u·Φ`.
        let coprime = match set.relation() {
            Relation::Coprime => {
                let c = |i: usize| levels.get(i).map_or(1.0, |l| l.scale());
                let (a, _) =
                    crate::pattern::coprime_ratio(c(0), c(1)).ok_or(DecodeError::Config)?;
                Some(a)
            }
            _ => None,
        };
        let (lo, hi) = set.coarse_range();
        let widen = coprime.map_or(1.0, |a| a as f64);
        let plan = Plan {
            levels: &est[..n_levels],
            dc_level,
            ratios: if heterodyne {
                &chain[..n_levels + 1]
            } else {
                &ratios[..n_levels]
            },
            coarse_range: (lo * widen, hi * widen),
            config: &config,
            gray: set.gray(),
            coprime,
        };
        let format = A::format(&plan)?;
        let zero = ImageCoef {
            level: 0,
            a: A::COEF_ZERO,
            b: A::COEF_ZERO,
            w: A::COEF_ZERO,
            mode: [SKIP; 3],
        };
        let d = slot.insert(Decoder {
            n_levels,
            n_images: set.image_count(),
            images: [zero; MAX_IMAGES],
            a_dc: [A::COEF_ZERO; MAX_LEVELS],
            b_dc: [A::COEF_ZERO; MAX_LEVELS],
            ratio: [A::ratio(1.0, &format); MAX_LEVELS],
            limits: A::limits(&plan, &format),
            format,
            config,
            untouched: [true; 1 + 2 * MAX_LEVELS],
            level_images: [LevelImages {
                n: 0,
                idx: [0; MAX_SHIFTS],
                kind: KIND_GENERIC,
            }; MAX_LEVELS],
            level_order: [0; MAX_LEVELS],
            dc_level: dc_level.map(|l| l as u8),
            fused: FUSED_NONE,
            correction: None,
            gray: set.gray(),
            gray_word_bit: [0; MAX_SHIFTS],
            gray_after_dc: false,
            gray_partner: [0; MAX_SHIFTS],
            gray_even: [false; MAX_SHIFTS],
            heterodyne,
            coprime: coprime.unwrap_or(0) as u8,
        });
        if heterodyne {
            for (r, c) in d.ratio.iter_mut().zip(&chain[1..=n_levels]) {
                *r = A::ratio(*c, &format);
            }
        }
        let order = dc_level
            .into_iter()
            .chain((0..n_levels).filter(|&l| Some(l) != dc_level));
        for (slot, l) in d.level_order.iter_mut().zip(order) {
            *slot = l as u8;
        }
        // Level by level, each level's images in image order: the coefficients of one level at a
        // time on the stack (a head's set-up stack is tight), and every plane (the DC plane
        // included, which only the DC level's images touch) sees its images in image order, so
        // the INIT/ACC modes are those of one pass over the images.
        for i in 0..n_levels {
            let c = A::level_coefs(&plan, i, &format);
            d.a_dc[i] = c.a_dc;
            d.b_dc[i] = c.b_dc;
            if i > 0 && !heterodyne {
                d.ratio[i] = A::ratio(ratios[i], &format);
            }
            let images = set.order().iter().enumerate();
            for (k, id) in images.filter(|(_, id)| id.level as usize == i) {
                let (l, s) = (i, id.shift as usize);
                // `get`: a valid order's shifts are < the level's count <= MAX_SHIFTS (no panic
                // path).
                let (Some(&ca), Some(&cb), Some(&cw)) = (c.a.get(s), c.b.get(s), c.w.get(s)) else {
                    return Err(DecodeError::Degenerate(id.level));
                };
                let w = if dc_level == Some(l) {
                    cw
                } else {
                    A::COEF_ZERO
                };
                let mut mode = [SKIP; 3];
                for (m, (k, plane)) in
                    mode.iter_mut()
                        .zip([(ca, 1 + 2 * l), (cb, 2 + 2 * l), (w, 0)])
                {
                    if !A::is_zero(k) {
                        *m = if d.untouched[plane] { INIT } else { ACC };
                        d.untouched[plane] = false;
                    }
                }
                let Some(image) = d.images.get_mut(k) else {
                    return Err(DecodeError::ImageCount);
                };
                *image = ImageCoef {
                    level: id.level,
                    a: ca,
                    b: cb,
                    w,
                    mode,
                };
                let li = &mut d.level_images[l];
                if let Some(slot) = li.idx.get_mut(li.n as usize) {
                    *slot = k as u8;
                    li.n += 1;
                } else {
                    return Err(DecodeError::Degenerate(id.level));
                }
            }
        }
        for l in 0..n_levels {
            let kind = d.level_kind(l);
            if let Some(li) = d.level_images.get_mut(l) {
                li.kind = kind;
            }
        }
        if let Some(code) = d.gray {
            let li = d.level_images[0];
            d.level_images[0].kind = KIND_GRAY;
            let shift_of = |k: u8| set.image(k as usize).map_or(0, |id| id.shift as usize);
            for (bit, &k) in d.gray_word_bit.iter_mut().zip(&li.idx).take(li.n as usize) {
                *bit = code.word_bit(shift_of(k)) as u8;
            }
            if code.inverse() {
                let used = li.idx.get(..li.n as usize).unwrap_or(&[]);
                for (j, &k) in used.iter().enumerate() {
                    let other = shift_of(k) ^ 1;
                    let at = used.iter().position(|&m| shift_of(m) == other);
                    let (Some(partner), Some(even)) =
                        (d.gray_partner.get_mut(j), d.gray_even.get_mut(j))
                    else {
                        return Err(DecodeError::Degenerate(0));
                    };
                    *partner = at.ok_or(DecodeError::Degenerate(0))? as u8;
                    *even = shift_of(k) % 2 == 0;
                }
            }
            d.gray_after_dc = set.frame_sequential_order();
        }
        let kinds = [
            d.level_images[0].kind,
            d.level_images[1].kind,
            d.level_images[2].kind,
        ];
        if n_levels == 3 && dc_level == Some(2) && kinds[2] == KIND_QUAD_EXACT {
            d.fused = match kinds[..2] {
                [KIND_PAIR_UNIT, KIND_PAIR_UNIT] => FUSED_PAIRS,
                [KIND_QUAD_EXACT, KIND_QUAD_EXACT] => FUSED_QUADS,
                _ => FUSED_NONE,
            };
        }
        Ok(())
    }

    /// The zero pattern of level `l`'s coefficients ([`KIND_PAIR`], [`KIND_QUAD`] or
    /// [`KIND_GENERIC`]). Skipping a zero product changes no bit: it adds ±0 to a sum that
    /// started at +0 and so is never −0 (and 0 in the integer backends).
    fn level_kind(&self, l: usize) -> u8 {
        // `get`: l < n_levels and every index < n_images; the fallbacks are never taken, and no
        // panic path is compiled in.
        let Some(li) = self.level_images.get(l) else {
            return KIND_GENERIC;
        };
        let none = ImageCoef {
            level: 0,
            a: A::COEF_ZERO,
            b: A::COEF_ZERO,
            w: A::COEF_ZERO,
            mode: [SKIP; 3],
        };
        let coef = |j: usize| {
            let i = li.idx.get(j).map_or(usize::MAX, |&i| i as usize);
            self.images.get(i).copied().unwrap_or(none)
        };
        let z = |k: A::Coef| A::is_zero(k);
        let kind = match li.n {
            2 if !z(coef(0).a)
                && z(coef(1).a)
                && z(coef(0).b)
                && !z(coef(1).b)
                && (0..2).all(|j| z(coef(j).w)) =>
            {
                KIND_PAIR
            }
            4 if (0..4).all(|j| (j % 2 == 0) != z(coef(j).a) && (j % 2 == 1) != z(coef(j).b))
                && z(self.a_dc[l])
                && z(self.b_dc[l]) =>
            {
                let e = |k: A::Coef, v: f32| A::exact_coef(k, v);
                // The weights of A only matter for the DC level (the others never compute it).
                let exact = e(coef(0).a, 0.5)
                    && e(coef(2).a, -0.5)
                    && e(coef(1).b, 0.5)
                    && e(coef(3).b, -0.5)
                    && (self.dc_level != Some(l as u8) || (0..4).all(|j| e(coef(j).w, 0.25)));
                if exact { KIND_QUAD_EXACT } else { KIND_QUAD }
            }
            _ => KIND_GENERIC,
        };
        match kind {
            KIND_PAIR
                if A::exact_coef(coef(0).a, 1.0)
                    && A::exact_coef(coef(1).b, 1.0)
                    && A::exact_coef(self.a_dc[l], -1.0)
                    && A::exact_coef(self.b_dc[l], -1.0) =>
            {
                KIND_PAIR_UNIT
            }
            k => k,
        }
    }

    /// The run-time number format of the backend (e.g. the accumulator fraction bits of
    /// [`crate::arith::Fixed`]; `()` for f32).
    pub fn format(&self) -> &A::Format {
        &self.format
    }

    /// The thresholds in use.
    pub fn config(&self) -> &DecodeConfig {
        &self.config
    }

    /// Number of levels.
    pub fn level_count(&self) -> usize {
        self.n_levels
    }

    /// Number of images per set.
    pub fn image_count(&self) -> usize {
        self.n_images
    }

    /// Whether level `level` has a wrapped phase of its own ([`Self::decode_row_level`],
    /// [`Self::finish_level`]): every level of the set but a Gray-code one ([`crate::gray`]).
    pub fn level_has_phase(&self, level: usize) -> bool {
        level < self.n_levels && !(level == 0 && self.gray.is_some())
    }

    /// Whether the frame-sequential path can decode the set in its order: always, except a
    /// Gray-coded set with a Gray-code image before the DC level's last image
    /// ([`DecodeError::GrayBeforeDc`]).
    pub fn frame_sequential_order(&self) -> bool {
        self.gray.is_none() || self.gray_after_dc
    }
}
