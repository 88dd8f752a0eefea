//! What the search can read near each sample of the reference map ([`Near`]): the tables
//! behind the builder's two proofs about a pixel's whole search segment, that the search can read
//! nothing along it ([`super::PixelModel::NO_REFERENCE`]) and that a phase far beyond a clipped
//! range is no crossing ([`super::PixelModel::far`]).

use super::NEAR_PX;

/// What the search can read near each sample of a `w × h` map: over the samples within
/// [`NEAR_PX`] of it in both directions (positions off the map count as invalid), the least and
/// the largest valid value (+∞ and −∞ when none is valid), and the largest spread (largest
/// corner minus least) of a bilinear cell whose four corners are valid.
pub(super) struct Near {
    w: usize,
    h: usize,
    /// Least valid value near each sample (+∞: none).
    pub(super) lo: Vec<f32>,
    /// Largest valid value near each sample (−∞: none).
    pub(super) hi: Vec<f32>,
    /// Largest spread of a valid cell near each sample.
    pub(super) spread: Vec<f32>,
}

impl Near {
    /// Empty (every query unknown) when the map's size does not match `phase`.
    pub(super) fn new(phase: &[f32], w: usize, h: usize) -> Near {
        let r = NEAR_PX;
        if phase.len() != w * h || w < 2 || h < 2 {
            return Near {
                w: 0,
                h: 0,
                lo: Vec::new(),
                hi: Vec::new(),
                spread: Vec::new(),
            };
        }
        let valid = |p: f32| p.is_finite();
        let lo: Vec<f32> = phase
            .iter()
            .map(|&p| if valid(p) { p } else { f32::INFINITY })
            .collect();
        let hi: Vec<f32> = phase
            .iter()
            .map(|&p| if valid(p) { p } else { f32::NEG_INFINITY })
            .collect();
        let mut spread = vec![0f32; w * h];
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
                    spread[j * w + i] = b - a;
                }
            }
        }
        Near {
            w,
            h,
            lo: dilate(&lo, w, h, r, f32::INFINITY, f32::min),
            hi: dilate(&hi, w, h, r, f32::NEG_INFINITY, f32::max),
            spread: dilate(&spread, w, h, r, 0.0, f32::max),
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
        k.is_some_and(|k| self.lo[k] <= self.hi[k])
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
mod tests {
    use super::*;

    /// The tables against a direct scan of each window, on a map with holes and an edge.
    #[test]
    fn tables_match_a_direct_scan() {
        let (w, h) = (23, 17);
        let mut seed = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        let phase: Vec<f32> = (0..w * h)
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
        let n = Near::new(&phase, w, h);
        let r = NEAR_PX as i64;
        let at = |i: i64, j: i64| {
            (i >= 0 && j >= 0 && i < w as i64 && j < h as i64)
                .then(|| phase[j as usize * w + i as usize])
        };
        for j in 0..h as i64 {
            for i in 0..w as i64 {
                let (mut lo, mut hi, mut spread) = (f32::INFINITY, f32::NEG_INFINITY, 0f32);
                for b in j - r..=j + r {
                    for a in i - r..=i + r {
                        match at(a, b) {
                            Some(p) if p.is_finite() => {
                                lo = lo.min(p);
                                hi = hi.max(p);
                            }
                            _ => {}
                        }
                        let c = [at(a, b), at(a + 1, b), at(a, b + 1), at(a + 1, b + 1)];
                        if c.iter().all(|p| p.is_some_and(f32::is_finite)) {
                            let c = c.map(|p| p.unwrap_or(0.0));
                            let (x, y) = c
                                .iter()
                                .fold((f32::INFINITY, f32::NEG_INFINITY), |(x, y), &p| {
                                    (x.min(p), y.max(p))
                                });
                            spread = spread.max(y - x);
                        }
                    }
                }
                let k = j as usize * w + i as usize;
                assert_eq!((n.lo[k], n.hi[k]), (lo, hi), "({i}, {j})");
                assert_eq!(n.spread[k], spread, "({i}, {j})");
            }
        }
        // Positions: clamped into the map, or far off it.
        assert_eq!(n.index([-2.4, 3.0]), Some(Some(3 * w)));
        assert_eq!(n.index([-(NEAR_PX as f64) - 0.5, 3.0]), Some(None));
        assert_eq!(n.index([f64::NAN, 3.0]), None);
        assert!(!n.any_valid(None));
    }
}
