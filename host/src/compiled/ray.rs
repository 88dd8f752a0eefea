//! One camera pixel's ray and the reference phase along it ([`Ray`], step 1 of the module
//! documentation of [`super`]): where the search meets each depth, the map's bilinear phase
//! there, the f64 crossing, the stretch the map covers, and the walk of the whole search segment
//! behind the builder's two proofs (no reference along the ray; the far rule of a clipped range).

use super::{PATH_STEP_PX, Source};
use fringe3d_core::reconstruct::compiled::PixelModel;

/// The step of [`Ray::far_threshold`]'s walk, map pixels: its points lie at most half of it
/// apart (the walk's factor of two for the path's bend, [`Ray::walk`]).
const CELL_STEP_PX: f64 = 0.5;

/// How far from a walked point of [`Ray::far_threshold`], in map pixels, the f32 search may take
/// a sample: a point of the segment lies within half the points' spacing (0.125 px) of one, the
/// rest (0.125 px) is room for the path's bend between points and the search's rounding of its
/// position (about 10⁻⁴ px). Until 2026-12-03 the walk read every sample within
/// [`super::NEAR_PX`] (4 px) of its points, 2 px apart; the values of those 3.75 px more along the
/// segment widened τ_far by a few per cent of the range (docs/compiled.md).
const CELL_REACH_PX: f64 = 0.25;

/// One pixel's ray and the reference phase along it (step 1 of the module documentation).
pub(super) struct Ray<'a> {
    pub(super) cal: &'a Source<'a>,
    /// The image row (the search reads the map's rows `rows_needed(v)`).
    v: u32,
    pub(super) x: f64,
    pub(super) y: f64,
    a: f64,
    h_r: f64,
    hh: f64,
    pz: f64,
    ex: f64,
    ey: f64,
}

impl<'a> Ray<'a> {
    pub(super) fn new(cal: &'a Source<'a>, u: usize, v: usize) -> Self {
        let s = cal.recon.setup();
        let [x, y] = cal.recon.camera().pixel_to_normalized([u as f64, v as f64]);
        let n = s.reference_normal;
        let (o, p) = (s.reference_point, s.projector_centre);
        Ray {
            cal,
            v: v as u32,
            x,
            y,
            a: n.x * x + n.y * y + n.z,
            h_r: n.x * o.x + n.y * o.y + n.z * o.z,
            hh: n.x * (o.x - p.x) + n.y * (o.y - p.y) + n.z * (o.z - p.z),
            pz: p.z,
            ex: p.x - p.z * x,
            ey: p.y - p.z * y,
        }
    }

    /// The search's parameter `t` for depth `z` (eqs 16-18 inverted).
    pub(super) fn t_at(&self, z: f64) -> f64 {
        let num = z * self.a - self.h_r;
        num / (num * self.pz + self.hh * z)
    }

    /// The depth for the search's parameter `t` (eqs 16-18 in closed form).
    pub(super) fn depth_at_t(&self, t: f64) -> f64 {
        self.h_r * (1.0 - self.pz * t) / (self.a - (self.a * self.pz + self.hh) * t)
    }

    /// The image position (distorted pixels) of the search's point `N_I = m + t·e`.
    #[inline]
    pub(super) fn pixel_at_t(&self, t: f64) -> [f64; 2] {
        let cam = self.cal.recon.camera();
        cam.normalized_to_pixel([self.x + t * self.ex, self.y + t * self.ey])
    }

    /// The image position where the search meets depth `z`.
    pub(super) fn pixel_at(&self, z: f64) -> [f64; 2] {
        self.pixel_at_t(self.t_at(z))
    }

    /// The reference phase where the search meets depth `z`.
    pub(super) fn phase_at(&self, z: f64) -> Option<f64> {
        self.cal.map.phase(self.pixel_at(z))
    }

    /// The depth in `[z0, z1]` where the reference phase along the ray is `phi` (60 bisections),
    /// `None` if the ends do not bracket it or the map is invalid on the way.
    pub(super) fn depth_of(&self, phi: f64, z0: f64, z1: f64) -> Option<f64> {
        let (mut lo, mut hi) = (z0, z1);
        let below = self.phase_at(lo)? < phi;
        if (self.phase_at(hi)? < phi) == below {
            return None;
        }
        for _ in 0..60 {
            let mid = 0.5 * (lo + hi);
            if (self.phase_at(mid)? < phi) == below {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        Some(0.5 * (lo + hi))
    }

    /// The map position of the search's point at parameter `t`.
    pub(super) fn map_at_t(&self, t: f64) -> [f64; 2] {
        let m = self.cal.recon.margin();
        let p = self.pixel_at_t(t);
        [p[0] + m.left as f64, p[1] + m.top as f64]
    }

    /// The search's segment: `t` at the depth range's ends, as the search takes it.
    pub(super) fn segment(&self) -> (f64, f64) {
        let s = self.cal.recon.setup();
        (self.t_at(s.z_min), self.t_at(s.z_max))
    }

    /// Walk the search segment lengthened by 10⁻⁴ of it at each end (more than the f32 search's
    /// rounding of its ends), its points at most [`PATH_STEP_PX`] apart (the step is set from
    /// the largest chord between 64 probes, halved for the path's bend: a margin, not a bound;
    /// the check of step 3 runs the search itself), calling `f` with the sample nearest to each
    /// ([`super::near::Near::index`]: `None` off the map); `false` when `f` does, or when the walk
    /// cannot be made (a segment that is not finite, or too long).
    pub(super) fn walk(&self, mut f: impl FnMut(Option<usize>) -> bool) -> bool {
        let near = self.cal.near;
        self.walk_by(PATH_STEP_PX, |p| near.index(p).is_some_and(&mut f))
    }

    /// The walk of [`Ray::walk`] with points at most `step` map pixels apart, calling `f` with
    /// each point's map position.
    fn walk_by(&self, step: f64, mut f: impl FnMut([f64; 2]) -> bool) -> bool {
        const PROBE: usize = 64;
        // At most 2¹⁶ points a walk at [`PATH_STEP_PX`], proportionally more for a finer step.
        let max_steps = (1u32 << 16) as f64 * PATH_STEP_PX / step;
        let (ta, tb) = self.segment();
        let d = 1e-4 * (tb - ta);
        let (t0, t1) = (ta - d, tb + d);
        let at = |f: f64| self.map_at_t(t0 + (t1 - t0) * f);
        let mut chord = 0f64;
        let mut prev = at(0.0);
        for k in 1..=PROBE {
            let p = at(k as f64 / PROBE as f64);
            chord = chord.max((p[0] - prev[0]).abs().max((p[1] - prev[1]).abs()));
            prev = p;
        }
        // Twice the probes' largest chord over the step: room for the path's bend.
        let steps = (2.0 * PROBE as f64 * chord / step).ceil();
        if !(steps.is_finite() && steps <= max_steps) {
            return false;
        }
        let steps = (steps as usize).max(PROBE);
        (0..=steps).all(|k| {
            let p = at(k as f64 / steps as f64);
            p[0].is_finite() && p[1].is_finite() && f(p)
        })
    }

    /// Whether the search segment stays [`super::NEAR_PX`] away from every valid map sample
    /// (module documentation): the search can read nothing along it.
    pub(super) fn away_from_map(&self) -> bool {
        let near = self.cal.near;
        self.walk(|k| !near.any_valid(k))
    }

    /// A clipped model's τ_far ([`PixelModel::far`]): the least `|τ|` (at least 1) beyond which
    /// every phase gets `NoCrossing` from the search, or `None` where that cannot be shown. It
    /// needs the search's sample at one end of the segment valid and at the other invalid
    /// ([`super::map_view::MapView::end_sample`]; so the fallback brackets among valid samples, and one exists:
    /// `NoCrossing`, not `OutOfDepth` with both ends valid or `ReferenceInvalid` with none);
    /// the phases beyond τ_far then lie beyond every value the search can read along the segment
    /// by `δ`, on both sides: the corners of every valid bilinear cell a sample within
    /// [`CELL_REACH_PX`] of the walk's points reads ([`super::near::Near::read_cells`], points
    /// [`CELL_STEP_PX`] apart). With `δ` a tenth of the largest spread of those cells (the interpolant's
    /// gradient is below 1.5 spreads a pixel), every valid sample differs from such a phase by
    /// more than a Newton step of 0.07 px can close (the search accepts 0.003 px), with one
    /// sign: no crossing is found, and none is bracketed. τ_far is widened by 10⁻³ of itself
    /// for the f32 kernel's rounding of τ, and rounded up to f32.
    pub(super) fn far_threshold(&self, m: &PixelModel) -> Option<f32> {
        let near = self.cal.near;
        let mut acc = (f64::INFINITY, f64::NEG_INFINITY, 0f64);
        let walked = self.walk_by(CELL_STEP_PX, |p| {
            near.read_cells(p, CELL_REACH_PX, &mut acc);
            true
        });
        let (lo, hi, spread) = acc;
        let (ta, tb) = self.segment();
        let (pa, pb) = (self.map_at_t(ta), self.map_at_t(tb));
        let map = &self.cal.map;
        let off = |p| map.end_sample(p) == Some(false);
        // The end on the map, the rows of its sample's cell (⌊y⌋ and the next, give or take the
        // f32 search's rounding: a pixel) inside the band of rows the search reads.
        let (first, last) = self.cal.recon.rows_needed(self.v);
        let on = |p: [f64; 2]| {
            map.end_sample(p) == Some(true)
                && p[1] - 1.0 >= first as f64
                && p[1] + 2.0 <= last as f64
        };
        let ends = (on(pa) && off(pb)) || (off(pa) && on(pb));
        if !(walked && ends && lo <= hi) {
            return None;
        }
        // The f32 kernel's rounding of the phase difference, and of τ, on top.
        let delta = 0.1 * spread + 1e-3 + 1e-5 * lo.abs().max(hi.abs());
        let (pc, k) = (m.phase_centre as f64, (m.phase_scale as f64).abs());
        let need = ((pc - (lo - delta)) * k)
            .max((hi + delta - pc) * k)
            .max(1.0);
        let far = need / (1.0 - 1e-3);
        let f = far as f32;
        let f = if (f as f64) < far { f.next_up() } else { f };
        f.is_finite().then_some(f)
    }

    /// The longest stretch of `[z0, z1]` over which the map is valid along the ray, its ends
    /// found to 2⁻³⁰ of the range, each end at the map's edge pulled in by `inset` of the range;
    /// `None` when it is shorter than 1 % of the range.
    pub(super) fn valid_run(&self, z0: f64, z1: f64, inset: f64) -> Option<(f64, f64)> {
        const SAMPLES: usize = 129;
        let at = |k: usize| z0 + (z1 - z0) * k as f64 / (SAMPLES - 1) as f64;
        let ok: Vec<bool> = (0..SAMPLES)
            .map(|k| self.phase_at(at(k)).is_some())
            .collect();
        let (mut best, mut start) = ((0, 0), None);
        for k in 0..=SAMPLES {
            match (ok.get(k).copied().unwrap_or(false), start) {
                (true, None) => start = Some(k),
                (false, Some(s0)) => {
                    if k - s0 > best.1 - best.0 {
                        best = (s0, k);
                    }
                    start = None;
                }
                _ => {}
            }
        }
        let (first, end) = best;
        if end - first < 3 {
            return None;
        }
        // Refine each end between its last valid and first invalid sample.
        let refine = |mut good: f64, mut bad: f64| {
            for _ in 0..30 {
                let mid = 0.5 * (good + bad);
                if self.phase_at(mid).is_some() {
                    good = mid;
                } else {
                    bad = mid;
                }
            }
            good
        };
        // An end at the map's edge is pulled in by `inset` of the range.
        let inset = inset * (z1 - z0);
        let lo = if first == 0 {
            z0
        } else {
            refine(at(first), at(first - 1)) + inset
        };
        let hi = if end == SAMPLES {
            z1
        } else {
            refine(at(end - 1), at(end)) - inset
        };
        (hi - lo >= 0.01 * (z1 - z0)).then_some((lo, hi))
    }
}
