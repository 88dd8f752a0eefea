//! What the search can read near each sample of the reference map ([`Near`]): the tables
//! behind the builder's two proofs about a pixel's whole search segment, that the search can read
//! nothing along it ([`super::PixelModel::NO_REFERENCE`]) and that a phase far beyond a clipped
//! range is no crossing ([`super::PixelModel::far`]).

use super::NEAR_PX;

/// What the search can read from a `w × h` map: for each sample, whether a valid sample lies
/// within [`NEAR_PX`] of it in both directions (positions off the map count as invalid), and for
/// each bilinear cell the least and the largest of its corners when all four are valid.
pub(super) struct Near {
    w: usize,
    h: usize,
    /// Whether a valid sample lies within [`NEAR_PX`] of each sample.
    valid_near: Vec<bool>,
    /// Least corner of each bilinear cell, indexed by its first sample (`j·w + i` for the cell
    /// of samples `i, i + 1` × `j, j + 1`); +∞ when a corner is invalid (and for the map's last
    /// row and column, which start no cell).
    cell_lo: Vec<f32>,
    /// Largest corner of each bilinear cell (−∞ when a corner is invalid).
    cell_hi: Vec<f32>,
}

impl Near {
    /// Empty (every query unknown) when the map's size does not match `phase`.
    pub(super) fn new(phase: &[f32], w: usize, h: usize) -> Near {
        if phase.len() != w * h || w < 2 || h < 2 {
            return Near {
                w: 0,
                h: 0,
                valid_near: Vec::new(),
                cell_lo: Vec::new(),
                cell_hi: Vec::new(),
            };
        }
        let valid: Vec<bool> = phase.iter().map(|p| p.is_finite()).collect();
        let mut cell_lo = vec![f32::INFINITY; w * h];
        let mut cell_hi = vec![f32::NEG_INFINITY; w * h];
        for j in 0..h - 1 {
            for i in 0..w - 1 {
                let c = [
                    phase[j * w + i],
                    phase[j * w + i + 1],
                    phase[(j + 1) * w + i],
                    phase[(j + 1) * w + i + 1],
                ];
                if c.iter().all(|p| p.is_finite()) {
                    let (a, b) = c
                        .iter()
                        .fold((f32::INFINITY, f32::NEG_INFINITY), |(a, b), &p| {
                            (a.min(p), b.max(p))
                        });
                    cell_lo[j * w + i] = a;
                    cell_hi[j * w + i] = b;
                }
            }
        }
        Near {
            w,
            h,
            valid_near: dilate(&valid, w, h, NEAR_PX, false, |a, b| a | b),
            cell_lo,
            cell_hi,
        }
    }

    /// Where map position `p` lies: `Some(Some(k))`, sample `k` is the nearest to `p` clamped
    /// into the map (clamping only brings a position nearer to every sample); `Some(None)`, more
    /// than [`NEAR_PX`] off the map (no sample near); `None` when `p` is not finite or the table
    /// is empty.
    pub(super) fn index(&self, p: [f64; 2]) -> Option<Option<usize>> {
        if !(p[0].is_finite() && p[1].is_finite()) || self.w == 0 {
            return None;
        }
        let r = NEAR_PX as f64;
        let (wl, hl) = ((self.w - 1) as f64, (self.h - 1) as f64);
        if p[0] < -r || p[1] < -r || p[0] > wl + r || p[1] > hl + r {
            return Some(None);
        }
        let i = p[0].clamp(0.0, wl).round() as usize;
        let j = p[1].clamp(0.0, hl).round() as usize;
        Some(Some(j * self.w + i))
    }

    /// Whether a valid sample may lie within [`NEAR_PX`] of sample `k` (`None`: off the map).
    pub(super) fn any_valid(&self, k: Option<usize>) -> bool {
        k.is_some_and(|k| self.valid_near[k])
    }

    /// Fold into `acc` (least value, largest value, largest spread) every valid bilinear cell
    /// that a sample taken within `r` of map position `p` (Chebyshev distance) can read: every
    /// value such a sample can have. A sample at `x` reads the cell `⌊x⌋`, the last one at the
    /// map's far edge ([`super::map_view::MapView::phase`]); a sample off the map reads none.
    pub(super) fn read_cells(&self, p: [f64; 2], r: f64, acc: &mut (f64, f64, f64)) {
        if self.w < 2 || self.h < 2 {
            return;
        }
        // The cells along one axis of `n` samples that positions within `r` of `c` read.
        let span = |c: f64, n: usize| {
            let (a, b) = ((c - r).max(0.0), (c + r).min((n - 1) as f64));
            (a <= b).then(|| ((a as usize).min(n - 2), (b as usize).min(n - 2)))
        };
        let (Some((i0, i1)), Some((j0, j1))) = (span(p[0], self.w), span(p[1], self.h)) else {
            return;
        };
        for j in j0..=j1 {
            for i in i0..=i1 {
                let (a, b) = (self.cell_lo[j * self.w + i], self.cell_hi[j * self.w + i]);
                if a <= b {
                    acc.0 = acc.0.min(a as f64);
                    acc.1 = acc.1.max(b as f64);
                    acc.2 = acc.2.max((b - a) as f64);
                }
            }
        }
    }
}

/// A square dilation of a `w × h` table by `r` in both directions with `f` (rows, then columns);
/// positions off the table read `outside`.
fn dilate<T: Copy>(
    src: &[T],
    w: usize,
    h: usize,
    r: usize,
    outside: T,
    f: fn(T, T) -> T,
) -> Vec<T> {
    let pass = |src: &[T], along_rows: bool| -> Vec<T> {
        let mut out = src.to_vec();
        let (n, len) = if along_rows { (h, w) } else { (w, h) };
        let at = |line: usize, k: usize| {
            if along_rows {
                line * w + k
            } else {
                k * w + line
            }
        };
        for line in 0..n {
            for k in 0..len {
                let mut acc = if k < r || k + r >= len {
                    outside
                } else {
                    src[at(line, k)]
                };
                for q in k.saturating_sub(r)..(k + r + 1).min(len) {
                    acc = f(acc, src[at(line, q)]);
                }
                out[at(line, k)] = acc;
            }
        }
        out
    };
    pass(&pass(src, true), false)
}

#[cfg(test)]
pub(super) mod tests {
    use super::*;

    /// A 23 × 17 map with holes (NaN: a tenth of the samples at random and the corner
    /// `i + j < 6`), a smooth phase elsewhere (the tests of [`super::super::map_view`] too).
    pub(in crate::compiled) fn map() -> (Vec<f32>, usize, usize) {
        let (w, h) = (23, 17);
        let mut seed = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        let phase = (0..w * h)
            .map(|k| {
                let (i, j) = (k % w, k / w);
                let hole = next() < 0.1 || i + j < 6;
                if hole {
                    f32::NAN
                } else {
                    (0.3 * i as f64 + 0.05 * j as f64 + 0.01 * next()) as f32
                }
            })
            .collect();
        (phase, w, h)
    }

    /// Whether a valid sample lies near each sample, against a direct scan of each window.
    #[test]
    fn valid_near_matches_a_direct_scan() {
        let (phase, w, h) = map();
        let n = Near::new(&phase, w, h);
        let r = NEAR_PX as i64;
        for j in 0..h as i64 {
            for i in 0..w as i64 {
                let any = (j - r..=j + r).any(|b| {
                    (i - r..=i + r).any(|a| {
                        a >= 0
                            && b >= 0
                            && a < w as i64
                            && b < h as i64
                            && phase[b as usize * w + a as usize].is_finite()
                    })
                });
                assert_eq!(
                    n.any_valid(Some(j as usize * w + i as usize)),
                    any,
                    "({i}, {j})"
                );
            }
        }
        // Positions: clamped into the map, or far off it.
        assert_eq!(n.index([-2.4, 3.0]), Some(Some(3 * w)));
        assert_eq!(n.index([-(NEAR_PX as f64) - 0.5, 3.0]), Some(None));
        assert_eq!(n.index([f64::NAN, 3.0]), None);
        assert!(!n.any_valid(None));
    }

    /// The cells read near a position against the bilinear samples themselves: over a fine grid
    /// of positions within the reach (its corners included), the least and largest corner of the
    /// valid cells the samples read ([`super::super::map_view::MapView::phase`]'s rule: the cell `⌊x⌋`,
    /// clamped at the far edge; invalid off the map or with a corner invalid) and their largest
    /// spread; every sample's value lies between the least and the largest.
    #[test]
    fn cells_read_match_the_samples_taken() {
        let (phase, w, h) = map();
        let n = Near::new(&phase, w, h);
        let at = |a: usize, b: usize| phase[b * w + a] as f64;
        // The cell a sample at (x, y) reads, when valid: its corners' least and largest, and the
        // bilinear value.
        let sample = |x: f64, y: f64| -> Option<(f64, f64, f64)> {
            if !(x >= 0.0 && y >= 0.0 && x <= (w - 1) as f64 && y <= (h - 1) as f64) {
                return None;
            }
            let (i, j) = ((x as usize).min(w - 2), (y as usize).min(h - 2));
            let c = [at(i, j), at(i + 1, j), at(i, j + 1), at(i + 1, j + 1)];
            let (fx, fy) = (x - i as f64, y - j as f64);
            let top = c[0] + (c[1] - c[0]) * fx;
            let bot = c[2] + (c[3] - c[2]) * fx;
            let g = top + (bot - top) * fy;
            g.is_finite().then(|| {
                let lo = c.iter().copied().fold(f64::INFINITY, f64::min);
                let hi = c.iter().copied().fold(f64::NEG_INFINITY, f64::max);
                (lo, hi, g)
            })
        };
        let mut seed = 0x2545_f491_4f6c_dd1du64;
        let mut next = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        let mut some = 0;
        // Random positions and reaches, and positions on the map's edges and corners.
        let edges = [
            [(w - 1) as f64, 5.0],
            [7.0, (h - 1) as f64],
            [(w - 1) as f64, (h - 1) as f64],
        ];
        for k in 0..3000 {
            let p = match edges.get(k % 100) {
                Some(&e) => e,
                None => [
                    -2.0 + (w + 3) as f64 * next(),
                    -2.0 + (h + 3) as f64 * next(),
                ],
            };
            let r = [0.0, 0.25, 0.5, 1.3][(4.0 * next()) as usize];
            let mut got = (f64::INFINITY, f64::NEG_INFINITY, 0f64);
            n.read_cells(p, r, &mut got);
            let mut want = (f64::INFINITY, f64::NEG_INFINITY, 0f64);
            let steps = 40;
            for a in 0..=steps {
                for b in 0..=steps {
                    let x = p[0] - r + 2.0 * r * a as f64 / steps as f64;
                    let y = p[1] - r + 2.0 * r * b as f64 / steps as f64;
                    if let Some((lo, hi, g)) = sample(x, y) {
                        assert!(got.0 <= g && g <= got.1, "{p:?} ± {r}: {g} outside {got:?}");
                        want = (want.0.min(lo), want.1.max(hi), want.2.max(hi - lo));
                    }
                }
            }
            // Spreads compared in f32, as the table holds them.
            let f = |s: f64| s as f32;
            assert_eq!(
                (got.0, got.1, f(got.2)),
                (want.0, want.1, f(want.2)),
                "{p:?} ± {r}"
            );
            some += usize::from(want.0 <= want.1);
        }
        assert!(some > 1000, "{some} positions near valid cells");
    }
}
