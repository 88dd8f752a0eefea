//! Steps 1 and 2 of the detection: saddle-response candidates with their ring test, and the
//! lattice grown from a seed through them.

use super::{DetectFailure, Image, dist, gaussian_blur};
use std::collections::{HashMap, VecDeque};

#[derive(Clone, Copy, Debug)]
pub(super) struct Cand {
    p: [f64; 2],
    response: f32,
    contrast: f64,
}

fn response_maxima(b: &Image) -> Vec<([usize; 2], f32)> {
    let (w, h) = (b.width, b.height);
    if w < 8 || h < 8 {
        return Vec::new();
    }
    let mut r = vec![0f32; w * h];
    for y in 1..h - 1 {
        for x in 1..w - 1 {
            let c = b.at(x, y);
            let ixx = b.at(x + 1, y) - 2.0 * c + b.at(x - 1, y);
            let iyy = b.at(x, y + 1) - 2.0 * c + b.at(x, y - 1);
            let ixy = 0.25
                * (b.at(x + 1, y + 1) - b.at(x + 1, y - 1) - b.at(x - 1, y + 1)
                    + b.at(x - 1, y - 1));
            r[y * w + x] = (ixy * ixy - ixx * iyy).max(0.0);
        }
    }
    let max = r.iter().cloned().fold(0f32, f32::max);
    if !(max > 0.0) {
        return Vec::new();
    }
    let thr = 0.01 * max;
    let rad = 3usize;
    let mut out = Vec::new();
    for y in rad..h - rad {
        for x in rad..w - rad {
            let v = r[y * w + x];
            if v <= thr {
                continue;
            }
            let mut is_max = true;
            'n: for yy in y - rad..=y + rad {
                for xx in x - rad..=x + rad {
                    let o = r[yy * w + xx];
                    if o > v || (o == v && (yy, xx) < (y, x)) {
                        is_max = false;
                        break 'n;
                    }
                }
            }
            if is_max {
                out.push(([x, y], v));
            }
        }
    }
    out.sort_by(|a, b| b.1.total_cmp(&a.1));
    out.truncate(5000);
    out
}

/// Ring test: four alternating arcs. Returns the ring's contrast.
fn ring_contrast(b: &Image, p: [f64; 2], radius: f64, min_contrast: f64) -> Option<f64> {
    const N: usize = 24;
    let mut v = [0.0; N];
    for (k, s) in v.iter_mut().enumerate() {
        let a = k as f64 * std::f64::consts::TAU / N as f64;
        *s = b.sample(p[0] + radius * a.cos(), p[1] + radius * a.sin());
    }
    let lo = v.iter().cloned().fold(f64::INFINITY, f64::min);
    let hi = v.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
    if !(hi - lo > min_contrast) {
        return None;
    }
    let m = 0.5 * (lo + hi);
    let s: Vec<bool> = v.iter().map(|x| *x > m).collect();
    // Runs around the circle.
    let start = (0..N).find(|&k| s[k] != s[(k + N - 1) % N])?;
    let mut runs = Vec::new();
    let mut len = 0;
    for t in 0..N {
        let k = (start + t) % N;
        if t > 0 && s[k] != s[(k + N - 1) % N] {
            runs.push(len);
            len = 0;
        }
        len += 1;
    }
    runs.push(len);
    (runs.len() == 4 && runs.iter().all(|&l| l >= 2)).then_some(hi - lo)
}

pub(super) fn candidates(img: &Image, sigma: f64) -> (Image, Vec<Cand>) {
    let b = gaussian_blur(img, sigma);
    // Global contrast scale: 2nd to 98th percentile of a subsample.
    let mut sub: Vec<f32> = b.data.iter().step_by(7).cloned().collect();
    sub.sort_by(f32::total_cmp);
    let q = |p: f64| {
        sub.get(((sub.len().max(1) - 1) as f64 * p) as usize)
            .cloned()
            .unwrap_or(0.0) as f64
    };
    let range = q(0.98) - q(0.02);
    let radius = (2.5 * sigma + 1.5).max(3.0);
    let mut out: Vec<Cand> = Vec::new();
    for ([x, y], resp) in response_maxima(&b) {
        let p = [x as f64, y as f64];
        if p[0] < radius + 1.0
            || p[1] < radius + 1.0
            || p[0] > (b.width as f64) - radius - 2.0
            || p[1] > (b.height as f64) - radius - 2.0
        {
            continue;
        }
        if let Some(c) = ring_contrast(&b, p, radius, 0.1 * range) {
            // Local quadratic peak of the response would not help much; the refinement does the rest.
            out.push(Cand {
                p,
                response: resp,
                contrast: c,
            });
        }
    }
    (b, out)
}

/// Whether `a` and `b` are lattice neighbours along a square edge (not diagonal).
fn edge_test(b: &Image, a: &Cand, q: &Cand) -> bool {
    let d = [q.p[0] - a.p[0], q.p[1] - a.p[1]];
    let l = (d[0] * d[0] + d[1] * d[1]).sqrt();
    if !(l > 3.0) {
        return false;
    }
    let n = [-d[1] / l, d[0] / l];
    let m = [0.5 * (a.p[0] + q.p[0]), 0.5 * (a.p[1] + q.p[1])];
    let off = 0.25 * l;
    let s1 = b.sample(m[0] + off * n[0], m[1] + off * n[1]);
    let s2 = b.sample(m[0] - off * n[0], m[1] - off * n[1]);
    (s1 - s2).abs() > 0.4 * a.contrast.min(q.contrast)
}

type Grid = HashMap<(i32, i32), usize>;

fn grow(b: &Image, c: &[Cand], seed: usize, e1: usize, e2: usize, limit: usize) -> Grid {
    let mut grid: Grid = HashMap::new();
    let mut used = vec![false; c.len()];
    grid.insert((0, 0), seed);
    grid.insert((1, 0), e1);
    grid.insert((0, 1), e2);
    used[seed] = true;
    used[e1] = true;
    used[e2] = true;
    let mut queue: VecDeque<(i32, i32)> = [(0, 0), (1, 0), (0, 1)].into_iter().collect();
    let pos = |g: &Grid, k: (i32, i32)| g.get(&k).map(|&i| c[i].p);
    while let Some(cur) = queue.pop_front() {
        if grid.len() > limit {
            break;
        }
        let pc = match pos(&grid, cur) {
            Some(p) => p,
            None => continue,
        };
        for d in [(1, 0), (-1, 0), (0, 1), (0, -1)] {
            let t = (cur.0 + d.0, cur.1 + d.1);
            if grid.contains_key(&t) {
                continue;
            }
            let back = (cur.0 - d.0, cur.1 - d.1);
            let pred = if let Some(pb) = pos(&grid, back) {
                [2.0 * pc[0] - pb[0], 2.0 * pc[1] - pb[1]]
            } else {
                // A parallel step in a neighbouring row/column.
                let side = if d.0 != 0 {
                    [(0, 1), (0, -1)]
                } else {
                    [(1, 0), (-1, 0)]
                };
                let mut step = None;
                for s in side {
                    let a = (cur.0 + s.0, cur.1 + s.1);
                    let bb = (a.0 + d.0, a.1 + d.1);
                    if let (Some(pa), Some(pb)) = (pos(&grid, a), pos(&grid, bb)) {
                        step = Some([pb[0] - pa[0], pb[1] - pa[1]]);
                        break;
                    }
                }
                match step {
                    Some(s) => [pc[0] + s[0], pc[1] + s[1]],
                    None => continue,
                }
            };
            let step_len = dist(pred, pc);
            let tol = 0.3 * step_len;
            let mut best: Option<(usize, f64)> = None;
            for (k, cand) in c.iter().enumerate() {
                if used[k] {
                    continue;
                }
                let dd = dist(cand.p, pred);
                if dd < tol && best.is_none_or(|(_, bd)| dd < bd) {
                    best = Some((k, dd));
                }
            }
            if let Some((k, _)) = best {
                let cur_c = &c[grid[&cur]];
                if edge_test(b, cur_c, &c[k]) {
                    used[k] = true;
                    grid.insert(t, k);
                    queue.push_back(t);
                }
            }
        }
    }
    grid
}

pub(super) fn find_grid(
    b: &Image,
    c: &[Cand],
    want: (usize, usize),
) -> Result<Vec<[f64; 2]>, DetectFailure> {
    let need = want.0 * want.1;
    let mut best: Option<(usize, usize, usize)> = None; // (count, ni, nj) of the best failure
    let limit = 4 * need + 16;
    // Neighbour lists.
    let mut order: Vec<usize> = (0..c.len()).collect();
    order.sort_by(|&a, &b2| c[b2].response.total_cmp(&c[a].response));
    for &seed in order.iter().take(40) {
        let mut nb: Vec<(usize, f64)> = (0..c.len())
            .filter(|&k| k != seed)
            .map(|k| (k, dist(c[k].p, c[seed].p)))
            .collect();
        nb.sort_by(|a, b2| a.1.total_cmp(&b2.1));
        nb.truncate(10);
        let axis: Vec<usize> = nb
            .iter()
            .filter(|(k, _)| edge_test(b, &c[seed], &c[*k]))
            .map(|x| x.0)
            .collect();
        let Some(&e1) = axis.first() else { continue };
        let d1 = [c[e1].p[0] - c[seed].p[0], c[e1].p[1] - c[seed].p[1]];
        let l1 = (d1[0] * d1[0] + d1[1] * d1[1]).sqrt();
        let e2 = axis.iter().skip(1).find(|&&k| {
            let d2 = [c[k].p[0] - c[seed].p[0], c[k].p[1] - c[seed].p[1]];
            let l2 = (d2[0] * d2[0] + d2[1] * d2[1]).sqrt();
            let cos = (d1[0] * d2[0] + d1[1] * d2[1]) / (l1 * l2);
            cos.abs() < 0.85 && l2 < 3.5 * l1 && l1 < 3.5 * l2
        });
        let Some(&e2) = e2 else { continue };
        let g = grow(b, c, seed, e1, e2, limit);
        let (imin, imax) = (
            g.keys().map(|k| k.0).min().unwrap_or(0),
            g.keys().map(|k| k.0).max().unwrap_or(0),
        );
        let (jmin, jmax) = (
            g.keys().map(|k| k.1).min().unwrap_or(0),
            g.keys().map(|k| k.1).max().unwrap_or(0),
        );
        let (ni, nj) = ((imax - imin + 1) as usize, (jmax - jmin + 1) as usize);
        let complete = g.len() == ni * nj;
        if complete && ((ni, nj) == want || (nj, ni) == want) {
            // Into a dense array, i fastest, possibly transposed to the wanted extents.
            let transpose = (ni, nj) != want;
            let mut pts = vec![[0.0; 2]; need];
            for (&(i, j), &k) in &g {
                let (ii, jj) = ((i - imin) as usize, (j - jmin) as usize);
                let (ii, jj) = if transpose { (jj, ii) } else { (ii, jj) };
                pts[jj * want.0 + ii] = c[k].p;
            }
            return Ok(pts);
        }
        if best.is_none_or(|bb| g.len() > bb.0) {
            best = Some((g.len(), ni, nj));
        }
        if g.len() >= need / 2 && !complete && g.len() > need {
            // A big but wrong grid: more seeds will not help much, but keep trying a few.
            continue;
        }
    }
    let (_, ni, nj) = best.unwrap_or((0, 0, 0));
    Err(DetectFailure::Grid {
        found_i: ni,
        found_j: nj,
        want_i: want.0,
        want_j: want.1,
    })
}
