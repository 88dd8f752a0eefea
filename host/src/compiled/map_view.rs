//! The reference map as the compiled build reads it ([`MapView`]): the f64 bilinear phase at an
//! image position, the rule the f32 search's samples follow, and whether the search's sample at
//! an end of its segment is valid wherever its rounding puts it.

/// How far from an end of its segment, in map pixels, the builder allows the f32 search to take
/// that end's sample ([`super::ray::Ray::far_threshold`]): its absolute pixel positions carry
/// about 10⁻⁴ px of rounding and the distortion polynomial in `t` its own small error; a quarter
/// pixel covers both many times over.
const END_SLACK_PX: f64 = 0.25;

/// A prepared reference map (`w × h` samples, row-major, NaN invalid) and where the image lies
/// on it: image position + (`left`, `top`) = map position.
#[derive(Clone, Copy)]
pub(super) struct MapView<'a> {
    phase: &'a [f32],
    w: usize,
    h: usize,
    left: f64,
    top: f64,
}

impl<'a> MapView<'a> {
    /// The map `phase` of `w × h` samples with the image at (`left`, `top`) on it; a slice
    /// shorter than `w × h` is a map with no sample.
    pub(super) fn new(phase: &'a [f32], w: usize, h: usize, left: u32, top: u32) -> Self {
        let (w, h) = if w.checked_mul(h).is_some_and(|n| n <= phase.len()) {
            (w, h)
        } else {
            (0, 0)
        };
        MapView {
            phase,
            w,
            h,
            left: left as f64,
            top: top as f64,
        }
    }

    /// The f64 phase at image position `p`: bilinear in the cell `(⌊x⌋, ⌊y⌋)` of its map
    /// position (the last row and column belong to the cell before them), `None` off the map or
    /// where one of the cell's four samples is invalid. The search's rule for its f32 samples.
    #[inline(always)]
    pub(super) fn phase(&self, p: [f64; 2]) -> Option<f64> {
        let (mw, mh) = (self.w, self.h);
        let (x, y) = (p[0] + self.left, p[1] + self.top);
        if mw < 2
            || mh < 2
            || !(x >= 0.0 && y >= 0.0 && x <= (mw - 1) as f64 && y <= (mh - 1) as f64)
        {
            return None;
        }
        let (i, j) = ((x as usize).min(mw - 2), (y as usize).min(mh - 2));
        let (fx, fy) = (x - i as f64, y - j as f64);
        let at = |a: usize, b: usize| self.phase[b * mw + a] as f64;
        let (q00, q10, q01, q11) = (at(i, j), at(i + 1, j), at(i, j + 1), at(i + 1, j + 1));
        let top = q00 + (q10 - q00) * fx;
        let bot = q01 + (q11 - q01) * fx;
        let g = top + (bot - top) * fy;
        g.is_finite().then_some(g)
    }

    /// Whether the search's sample at map position `p` (an end of its segment) is valid
    /// (`Some(true)`) or not (`Some(false)`) wherever within [`END_SLACK_PX`] of `p` the f32
    /// search takes it; `None` when that depends on where. A sample is the bilinear value of its
    /// cell ([`MapView::phase`]): valid when the cell lies on the map and its four samples are,
    /// invalid otherwise. The cells a square of side `2·END_SLACK_PX` (less than a pixel)
    /// touches are those of its corners.
    pub(super) fn end_sample(&self, p: [f64; 2]) -> Option<bool> {
        let (x, y) = (p[0] - self.left, p[1] - self.top);
        let e = END_SLACK_PX;
        let mut seen = [false; 2];
        for (dx, dy) in [(-e, -e), (e, -e), (-e, e), (e, e)] {
            seen[usize::from(self.phase([x + dx, y + dy]).is_some())] = true;
        }
        match seen {
            [false, true] => Some(true),
            [true, false] => Some(false),
            _ => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::compiled::near::tests::map;
    use crate::render::rng::Rng;

    #[test]
    fn the_phase_is_bilinear_within_a_valid_cell_and_none_elsewhere() {
        let (phase, w, h) = map();
        let view = MapView::new(&phase, w, h, 3, 2);
        let valid = |i: usize, j: usize| phase[j * w + i].is_finite();
        for j in 0..h - 1 {
            for i in 0..w - 1 {
                // The cell's centre, in image coordinates (the margin taken off).
                let p = [i as f64 + 0.5 - 3.0, j as f64 + 0.5 - 2.0];
                let cell = [(i, j), (i + 1, j), (i, j + 1), (i + 1, j + 1)];
                match view.phase(p) {
                    Some(g) => {
                        assert!(cell.iter().all(|&(a, b)| valid(a, b)), "({i}, {j})");
                        let mean = cell
                            .iter()
                            .map(|&(a, b)| phase[b * w + a] as f64)
                            .sum::<f64>();
                        assert!((g - mean / 4.0).abs() < 1e-12, "({i}, {j}): {g}");
                    }
                    None => assert!(cell.iter().any(|&(a, b)| !valid(a, b)), "({i}, {j})"),
                }
            }
        }
        // Off the map on each side, and the far edge itself (the last cell's).
        for p in [
            [-3.01, 0.0],
            [0.0, -2.01],
            [w as f64 - 3.99, 5.0],
            [5.0, h as f64 - 2.99],
        ] {
            assert_eq!(view.phase(p), None, "{p:?}");
        }
        let far = view.phase([w as f64 - 4.0, h as f64 - 3.0]);
        let last = [
            (w - 2, h - 2),
            (w - 1, h - 2),
            (w - 2, h - 1),
            (w - 1, h - 1),
        ];
        if last.iter().all(|&(a, b)| valid(a, b)) {
            let want = phase[h * w - 1] as f64;
            assert!(far.is_some_and(|g| (g - want).abs() < 1e-12), "{far:?}");
        } else {
            assert_eq!(far, None);
        }
        // A slice too short for its size is a map without samples.
        assert_eq!(
            MapView::new(&phase[1..], w, h, 0, 0).phase([5.0, 5.0]),
            None
        );
    }

    /// The end sample's verdict against a dense grid over its square: wherever the search
    /// takes the sample within the slack, it is valid (or invalid) as stated; `None` only where
    /// both occur.
    #[test]
    fn an_end_sample_is_judged_by_its_whole_square() {
        let (phase, w, h) = map();
        let view = MapView::new(&phase, w, h, 3, 2);
        let mut rng = Rng::new(7);
        let mut next = || rng.uniform();
        let (mut mixed, mut decided) = (0, 0);
        for _ in 0..4000 {
            // Map positions over the map and a pixel beyond it.
            let p = [next() * (w + 1) as f64 - 1.0, next() * (h + 1) as f64 - 1.0];
            let mut seen = [false; 2];
            const N: usize = 16;
            for a in 0..=N {
                for b in 0..=N {
                    let d = |k: usize| END_SLACK_PX * (2.0 * k as f64 / N as f64 - 1.0);
                    let q = [p[0] + d(a) - 3.0, p[1] + d(b) - 2.0];
                    seen[usize::from(view.phase(q).is_some())] = true;
                }
            }
            let want = match seen {
                [false, true] => Some(true),
                [true, false] => Some(false),
                _ => None,
            };
            assert_eq!(view.end_sample(p), want, "{p:?}");
            if want.is_none() {
                mixed += 1;
            } else {
                decided += 1;
            }
        }
        // Both kinds were tried.
        assert!(
            mixed > 100 && decided > 1000,
            "{mixed} mixed, {decided} decided"
        );
    }
}
