//! Checkerboard inner-corner detection with sub-pixel saddle refinement.
//!
//! 1. **Candidates**: the image is smoothed with a Gaussian (σ_d = 1.5 px, then 3 and 1 px if the
//!    board is not found) and the saddle response `Ixy² − Ixx·Iyy` (minus the Hessian determinant)
//!    is computed; local maxima above 1 % of the strongest are kept if a ring of 24 samples around
//!    them shows exactly four alternating dark/light arcs (an X-junction, not an L-corner of the
//!    board's outline).
//! 2. **Grid**: from a seed, two lattice directions are chosen among its nearest candidates by an
//!    *edge test* (the midpoint of two lattice neighbours lies on a square edge, the midpoint of
//!    diagonal neighbours in a square's middle), and the lattice is grown by linear extrapolation
//!    `p(i+1) ≈ 2 p(i) − p(i−1)`. The grid must be complete and exactly `(cols−1) × (rows−1)`.
//! 3. **Labelling**: the grid is turned so that its i axis has `cols − 1` corners, it is
//!    right-handed in the image (the board is seen from its printed side), and the square at the
//!    board origin (x min, y min) is dark; when both end squares have the same colour the board is
//!    symmetric under a half turn and that ambiguity is reported (harmless for calibration).
//! 4. **Refinement**: each corner is moved to the saddle point of `F(q) = Σ_k G_σ(q − k) I(k)`
//!    (the raw samples `I(k)` at integer pixel centres, weighted by a continuous Gaussian centred at
//!    `q`) by Newton's method on `∇F = 0`. A pixel-integrated X-junction is point-symmetric about
//!    its corner, so for straight edges this saddle is the corner up to sampling (aliasing) effects,
//!    whatever the angle between the edges; σ = 0.15 × the local corner spacing (1–4 px).
//!
//! Noise: at the saddle, δq ≈ σ_noise / (1.6·C) per axis for a contrast C between the squares,
//! independent of σ (for 8-bit images with C ≈ 190 gray levels and σ_noise = 1: ~0.003 px).

use std::collections::{HashMap, VecDeque};

/// A checkerboard target.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Board {
    /// Squares along the board's x axis (inner corners: `cols − 1`).
    pub cols: u32,
    /// Squares along the board's y axis (inner corners: `rows − 1`).
    pub rows: u32,
    /// Square edge, mm.
    pub square: f64,
}

impl Board {
    /// A board of `cols × rows` squares of `square` mm; at least 3 × 3 squares.
    pub fn new(cols: u32, rows: u32, square: f64) -> Result<Board, String> {
        if cols < 3 || rows < 3 {
            return Err(format!(
                "a board needs at least 3 x 3 squares (2 x 2 inner corners), got {cols} x {rows}"
            ));
        }
        if cols > 200 || rows > 200 {
            return Err(format!("{cols} x {rows} squares is not a plausible board"));
        }
        if !(square.is_finite() && square > 0.0) {
            return Err(format!(
                "the square size must be a positive number of mm, got {square}"
            ));
        }
        Ok(Board { cols, rows, square })
    }

    /// Parse `COLSxROWS` (squares) with the square size.
    pub fn parse(spec: &str, square: f64) -> Result<Board, String> {
        let (c, r) = spec
            .split_once(['x', 'X'])
            .ok_or_else(|| format!("board {spec:?}: expected COLSxROWS (squares), e.g. 11x8"))?;
        let c = c
            .trim()
            .parse::<u32>()
            .map_err(|_| format!("board {spec:?}: bad column count"))?;
        let r = r
            .trim()
            .parse::<u32>()
            .map_err(|_| format!("board {spec:?}: bad row count"))?;
        Board::new(c, r, square)
    }

    /// Inner corners along x and y.
    pub fn inner(&self) -> (usize, usize) {
        (self.cols as usize - 1, self.rows as usize - 1)
    }

    /// Number of inner corners.
    pub fn corner_count(&self) -> usize {
        let (a, b) = self.inner();
        a * b
    }

    /// The inner corners in the board frame (mm, z = 0), row by row with x fastest (OpenCV's
    /// order). The origin is the centre of the squared area; x along the columns, y along the
    /// rows; the square at (x min, y min) is dark.
    pub fn object_points(&self) -> Vec<[f64; 2]> {
        let (w, h) = (
            self.cols as f64 * self.square,
            self.rows as f64 * self.square,
        );
        let mut v = Vec::with_capacity(self.corner_count());
        for j in 1..self.rows {
            for i in 1..self.cols {
                v.push([
                    i as f64 * self.square - 0.5 * w,
                    j as f64 * self.square - 0.5 * h,
                ]);
            }
        }
        v
    }
}

/// A gray image as f32 samples (any scale), row-major, pixel centres at integer coordinates.
#[derive(Clone, Debug)]
pub struct Image {
    /// Width.
    pub width: usize,
    /// Height.
    pub height: usize,
    /// Samples.
    pub data: Vec<f32>,
}

impl Image {
    /// From a decoded file (integer or float samples).
    pub fn from_gray(g: &crate::io::image::GrayImage) -> Image {
        use crate::io::image::Pixels;
        let data = match &g.pixels {
            Pixels::U8(v) => v.iter().map(|&x| x as f32).collect(),
            Pixels::U16(v) => v.iter().map(|&x| x as f32).collect(),
            Pixels::F32(v) => v.clone(),
        };
        Image {
            width: g.width as usize,
            height: g.height as usize,
            data,
        }
    }

    #[inline]
    fn at(&self, x: usize, y: usize) -> f32 {
        self.data[y * self.width + x]
    }

    /// Bilinear sample (clamped to the image).
    pub fn sample(&self, x: f64, y: f64) -> f64 {
        let (w, h) = (self.width as f64, self.height as f64);
        let x = x.clamp(0.0, w - 1.0);
        let y = y.clamp(0.0, h - 1.0);
        let (x0, y0) = (x.floor() as usize, y.floor() as usize);
        let (x1, y1) = ((x0 + 1).min(self.width - 1), (y0 + 1).min(self.height - 1));
        let (fx, fy) = (x - x0 as f64, y - y0 as f64);
        let a = self.at(x0, y0) as f64 * (1.0 - fx) + self.at(x1, y0) as f64 * fx;
        let b = self.at(x0, y1) as f64 * (1.0 - fx) + self.at(x1, y1) as f64 * fx;
        a * (1.0 - fy) + b * fy
    }
}

/// Separable Gaussian blur with replicated edges.
pub fn gaussian_blur(img: &Image, sigma: f64) -> Image {
    let r = (3.0 * sigma).ceil().max(1.0) as isize;
    let k: Vec<f32> = (-r..=r)
        .map(|i| (-(i * i) as f64 / (2.0 * sigma * sigma)).exp() as f32)
        .collect();
    let s: f32 = k.iter().sum();
    let k: Vec<f32> = k.iter().map(|x| x / s).collect();
    let (w, h) = (img.width, img.height);
    let mut tmp = vec![0f32; w * h];
    for y in 0..h {
        let row = &img.data[y * w..(y + 1) * w];
        for x in 0..w {
            let mut acc = 0.0;
            for (t, kv) in k.iter().enumerate() {
                let xx = (x as isize + t as isize - r).clamp(0, w as isize - 1) as usize;
                acc += kv * row[xx];
            }
            tmp[y * w + x] = acc;
        }
    }
    let mut out = vec![0f32; w * h];
    for y in 0..h {
        for x in 0..w {
            let mut acc = 0.0;
            for (t, kv) in k.iter().enumerate() {
                let yy = (y as isize + t as isize - r).clamp(0, h as isize - 1) as usize;
                acc += kv * tmp[yy * w + x];
            }
            out[y * w + x] = acc;
        }
    }
    Image {
        width: w,
        height: h,
        data: out,
    }
}

/// Why no board was found in an image.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum DetectFailure {
    /// Too few X-junctions.
    #[error("board not found: only {found} checkerboard-corner candidates (need {need})")]
    FewCandidates {
        /// Candidates found.
        found: usize,
        /// Inner corners of the board.
        need: usize,
    },
    /// The corners found do not form the board's grid.
    #[error(
        "board not found: the corners form a {found_i} x {found_j} grid, expected {want_i} x {want_j} inner corners (whole board in view?)"
    )]
    Grid {
        /// Grid found, i extent.
        found_i: usize,
        /// Grid found, j extent.
        found_j: usize,
        /// Expected i extent.
        want_i: usize,
        /// Expected j extent.
        want_j: usize,
    },
    /// Sub-pixel refinement failed at a corner.
    #[error(
        "corner ({i}, {j}) at ({u:.1}, {v:.1}) px could not be refined to a saddle point ({why})"
    )]
    Refine {
        /// Corner column index.
        i: usize,
        /// Corner row index.
        j: usize,
        /// Approximate pixel u.
        u: f64,
        /// Approximate pixel v.
        v: f64,
        /// What went wrong.
        why: &'static str,
    },
}

/// The corners of one view.
#[derive(Clone, Debug)]
pub struct Detection {
    /// Inner corners in [`Board::object_points`] order, pixels.
    pub corners: Vec<[f64; 2]>,
    /// The board looks the same after a half turn, so the labelling is one of two.
    pub half_turn_ambiguous: bool,
    /// Median distance between neighbouring corners, pixels.
    pub spacing_px: f64,
    /// Smoothing scale at which the board was found, pixels.
    pub detect_sigma: f64,
}

/// The sub-pixel refinement.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Refinement {
    /// Saddle point of the Gaussian-weighted image ([`refine_saddle`]): fast; biased by
    /// illumination gradients (~σ²·|∇L|/L).
    Saddle,
    /// X-junction model with linear illumination terms ([`refine_model`]) (default).
    Model,
}

/// Options of [`detect`].
#[derive(Clone, Copy, Debug)]
pub struct DetectOptions {
    /// Saddle σ as a fraction of the local corner spacing.
    pub refine_sigma_ratio: f64,
    /// Lower and upper bounds of the saddle σ, pixels.
    pub refine_sigma_range: (f64, f64),
    /// Model-fit window radius as a fraction of the local corner spacing (clamped to 4..20 px).
    pub window_ratio: f64,
    /// The final refinement.
    pub method: Refinement,
}

impl Default for DetectOptions {
    fn default() -> Self {
        DetectOptions {
            refine_sigma_ratio: 0.08,
            refine_sigma_range: (1.0, 4.0),
            window_ratio: 0.45,
            method: Refinement::Model,
        }
    }
}

#[derive(Clone, Copy, Debug)]
struct Cand {
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

fn candidates(img: &Image, sigma: f64) -> (Image, Vec<Cand>) {
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

fn dist(a: [f64; 2], b: [f64; 2]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2)).sqrt()
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

fn find_grid(b: &Image, c: &[Cand], want: (usize, usize)) -> Result<Vec<[f64; 2]>, DetectFailure> {
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

/// Saddle point of `Σ_k G_σ(q − k) I(k)` near `q0` by Newton's method.
pub fn refine_saddle(img: &Image, q0: [f64; 2], sigma: f64) -> Result<[f64; 2], &'static str> {
    let r = (4.5 * sigma).ceil() as isize;
    let s2 = sigma * sigma;
    let mut q = q0;
    for _ in 0..40 {
        let (cx, cy) = (q[0].round() as isize, q[1].round() as isize);
        if cx - r < 0 || cy - r < 0 || cx + r >= img.width as isize || cy + r >= img.height as isize
        {
            return Err("too close to the image border");
        }
        let mut mean = 0.0;
        for y in cy - r..=cy + r {
            for x in cx - r..=cx + r {
                mean += img.at(x as usize, y as usize) as f64;
            }
        }
        mean /= ((2 * r + 1) * (2 * r + 1)) as f64;
        let (mut g0, mut g1, mut h00, mut h01, mut h11) = (0.0, 0.0, 0.0, 0.0, 0.0);
        for y in cy - r..=cy + r {
            let dy = q[1] - y as f64;
            for x in cx - r..=cx + r {
                let dx = q[0] - x as f64;
                let w = (-(dx * dx + dy * dy) / (2.0 * s2)).exp();
                let v = (img.at(x as usize, y as usize) as f64 - mean) * w;
                g0 -= dx * v;
                g1 -= dy * v;
                h00 += (dx * dx / s2 - 1.0) * v;
                h01 += dx * dy / s2 * v;
                h11 += (dy * dy / s2 - 1.0) * v;
            }
        }
        // Common factors 1/σ² (gradient) and 1/σ² (Hessian) cancel in the Newton step.
        let det = h00 * h11 - h01 * h01;
        if !(det < 0.0) {
            return Err("not a saddle");
        }
        let mut d = [-(h11 * g0 - h01 * g1) / det, -(-h01 * g0 + h00 * g1) / det];
        let l = (d[0] * d[0] + d[1] * d[1]).sqrt();
        if !l.is_finite() {
            return Err("singular");
        }
        if l > 0.5 {
            d = [d[0] * 0.5 / l, d[1] * 0.5 / l];
        }
        q = [q[0] + d[0], q[1] + d[1]];
        if l < 1e-6 {
            return Ok(q);
        }
    }
    Err("no convergence")
}

/// Smallest edge width β of the corner model, pixels: a step integrated over a box pixel has a
/// profile of standard deviation √(1/12) = 0.29 px whatever its direction; a free β → 0 would
/// leave the position of a step that falls on a pixel boundary undetermined within the pixel.
const BETA_MIN: f64 = 0.3;

/// Hessian of `Σ_k G_σ(q − k) I(k)` at `q` (up to a positive factor).
fn saddle_hessian(img: &Image, q: [f64; 2], sigma: f64) -> Option<[f64; 3]> {
    let r = (4.5 * sigma).ceil() as isize;
    let s2 = sigma * sigma;
    let (cx, cy) = (q[0].round() as isize, q[1].round() as isize);
    if cx - r < 0 || cy - r < 0 || cx + r >= img.width as isize || cy + r >= img.height as isize {
        return None;
    }
    let (mut h00, mut h01, mut h11) = (0.0, 0.0, 0.0);
    for y in cy - r..=cy + r {
        let dy = q[1] - y as f64;
        for x in cx - r..=cx + r {
            let dx = q[0] - x as f64;
            let w = (-(dx * dx + dy * dy) / (2.0 * s2)).exp();
            let v = img.at(x as usize, y as usize) as f64 * w;
            h00 += (dx * dx / s2 - 1.0) * v;
            h01 += dx * dy / s2 * v;
            h11 += (dy * dy / s2 - 1.0) * v;
        }
    }
    Some([h00, h01, h11])
}

/// The two edge directions (angles of the lines, radians) of an X-junction from its Hessian: the
/// asymptotes of the saddle's quadratic form.
fn edge_angles(h: [f64; 3]) -> Option<(f64, f64)> {
    let [a, b, c] = h;
    let tr = 0.5 * (a + c);
    let disc = (0.25 * (a - c) * (a - c) + b * b).sqrt();
    let (la, lb) = (tr + disc, tr - disc);
    if !(la > 0.0 && lb < 0.0) {
        return None;
    }
    // Eigenvector of la.
    let th = 0.5 * (2.0 * b).atan2(a - c);
    let (ea, eb) = ([th.cos(), th.sin()], [-th.sin(), th.cos()]);
    let k = (-lb / la).sqrt();
    let t1 = [k * ea[0] + eb[0], k * ea[1] + eb[1]];
    let t2 = [-k * ea[0] + eb[0], -k * ea[1] + eb[1]];
    Some((t1[1].atan2(t1[0]), t2[1].atan2(t2[0])))
}

/// Sub-pixel corner by fitting an X-junction model to the pixels within `radius` of `q0`:
///
/// `I(p) ≈ c0 + c1·dx + c2·dy + (c3 + c4·dx + c5·dy)·E(n1·d)·E(n2·d)`, `d = p − q`,
///
/// with `E(x) = erf(x / (√2·β))` an edge of width β, `n_i` the normals of the two edges through
/// q. The linear terms absorb the illumination gradient across the corner (additive ambient and
/// multiplicative projector light), which otherwise shifts a saddle-point estimate by ~σ²·|∇L|/L.
/// Model errors (edge profile, non-orthogonal blur) are point-symmetric about q and do not bias it.
/// Levenberg–Marquardt over the 11 parameters; the window is re-centred once on the result.
pub fn refine_model(
    img: &Image,
    q0: [f64; 2],
    radius: f64,
    angles: (f64, f64),
) -> Result<[f64; 2], &'static str> {
    let taper = 3.0f64.min(0.5 * radius);
    // Pixels within `radius` of `c` with a cosine taper over the outer `taper` pixels (so that
    // the estimate does not jump when a rim pixel enters or leaves the window).
    let window = |c: [f64; 2]| -> Result<Vec<(f64, f64, f64, f64)>, &'static str> {
        let r = radius.ceil() as isize;
        let (cx, cy) = (c[0].round() as isize, c[1].round() as isize);
        if cx - r < 0 || cy - r < 0 || cx + r >= img.width as isize || cy + r >= img.height as isize
        {
            return Err("too close to the image border");
        }
        let mut px = Vec::with_capacity(((2 * r + 1) * (2 * r + 1)) as usize);
        for y in cy - r..=cy + r {
            for x in cx - r..=cx + r {
                let (dx, dy) = (x as f64 - c[0], y as f64 - c[1]);
                let d = (dx * dx + dy * dy).sqrt();
                if d < radius {
                    let t = ((d - (radius - taper)) / taper).max(0.0);
                    let w = if t > 0.0 {
                        0.5 * (1.0 + (std::f64::consts::PI * t).cos())
                    } else {
                        1.0
                    };
                    px.push((
                        x as f64,
                        y as f64,
                        img.at(x as usize, y as usize) as f64,
                        w.sqrt(),
                    ));
                }
            }
        }
        Ok(px)
    };
    let sq2 = std::f64::consts::SQRT_2;
    let k_g = (2.0 / std::f64::consts::PI).sqrt();
    // Model pieces for the nonlinear parameters (qx, qy, φ1, φ2, b).
    let piece = |x: &[f64], p: &(f64, f64, f64, f64)| {
        let (dx, dy) = (p.0 - x[0], p.1 - x[1]);
        let (s1, c1) = x[2].sin_cos();
        let (s2, c2) = x[3].sin_cos();
        let beta = x[4];
        let a1 = -s1 * dx + c1 * dy;
        let a2 = -s2 * dx + c2 * dy;
        let (e1, x1) = erf_exp(a1 / (sq2 * beta));
        let (e2, x2) = erf_exp(a2 / (sq2 * beta));
        let g1 = k_g / beta * x1;
        let g2 = k_g / beta * x2;
        (dx, dy, e1, e2, g1, g2, a1, a2, [c1, s1], [c2, s2], beta)
    };
    let mut q = q0;
    let mut state: Option<Vec<f64>> = None;
    for _pass in 0..2 {
        let px = window(q)?;
        let lo = px.iter().map(|p| p.2).fold(f64::INFINITY, f64::min);
        let hi = px.iter().map(|p| p.2).fold(f64::NEG_INFINITY, f64::max);
        let span = hi - lo;
        if !(span > 0.0) {
            return Err("flat window");
        }
        let mid = 0.5 * (hi + lo);
        let px: Vec<(f64, f64, f64, f64)> = px
            .into_iter()
            .map(|p| (p.0, p.1, (p.2 - mid) / span, p.3))
            .collect();
        // Linear coefficients for a nonlinear guess (first pass).
        let linear = |x: &[f64]| -> Option<[f64; 6]> {
            let mut ata = [0.0; 36];
            let mut atb = [0.0; 6];
            for p in &px {
                let (dx, dy, e1, e2, ..) = piece(x, p);
                let s = e1 * e2;
                let row = [1.0, dx, dy, s, s * dx, s * dy].map(|v| v * p.3);
                for i in 0..6 {
                    atb[i] += row[i] * p.2 * p.3;
                    for j in 0..6 {
                        ata[i * 6 + j] += row[i] * row[j];
                    }
                }
            }
            if !super::linalg::cholesky(&mut ata, 6) {
                return None;
            }
            super::linalg::cholesky_solve(&ata, 6, &mut atb);
            Some(atb)
        };
        let x0 = match state.take() {
            // Re-centred window: the previous solution, its linear part re-solved for the new
            // normalisation.
            Some(mut x) => {
                let l = linear(&x).ok_or("degenerate window")?;
                x.truncate(5);
                x.extend(l);
                x
            }
            None => {
                let mut x = vec![q[0], q[1], angles.0, angles.1, 0.7];
                x.extend(linear(&x).ok_or("degenerate window")?);
                x
            }
        };
        let eval = |x: &Vec<f64>, _j: bool| -> Option<super::lm::Eval> {
            if !(x[4] >= BETA_MIN && x[4] < 20.0) {
                return None;
            }
            let mut e = super::lm::Eval {
                width: 11,
                ..Default::default()
            };
            e.r.reserve(px.len());
            e.vals.reserve(11 * px.len());
            e.cols.reserve(11 * px.len());
            for p in &px {
                let (dx, dy, e1, e2, g1, g2, a1, a2, t1, t2, beta) = piece(x, p);
                let sw = p.3;
                let s = e1 * e2;
                let lin = x[8] + x[9] * dx + x[10] * dy;
                e.r.push(sw * (x[5] + x[6] * dx + x[7] * dy + lin * s - p.2));
                let (s1, c1) = (t1[1], t1[0]);
                let (s2, c2) = (t2[1], t2[0]);
                // ∂S/∂q = −(g1 e2 n1 + e1 g2 n2), n = (−sin φ, cos φ).
                let dsq = [
                    -(g1 * e2 * -s1 + e1 * g2 * -s2),
                    -(g1 * e2 * c1 + e1 * g2 * c2),
                ];
                // ∂(n·d)/∂φ = −(cos φ·dx + sin φ·dy).
                let ds1 = g1 * e2 * -(c1 * dx + s1 * dy);
                let ds2 = e1 * g2 * -(c2 * dx + s2 * dy);
                // ∂S/∂β · ∂β/∂b.
                let dsb = -(g1 * e2 * a1 + e1 * g2 * a2) / beta;
                e.vals.extend(
                    [
                        -x[6] - x[9] * s + lin * dsq[0],
                        -x[7] - x[10] * s + lin * dsq[1],
                        lin * ds1,
                        lin * ds2,
                        lin * dsb,
                        1.0,
                        dx,
                        dy,
                        s,
                        s * dx,
                        s * dy,
                    ]
                    .map(|v| v * sw),
                );
                e.cols.extend(0..11);
            }
            Some(e)
        };
        let apply =
            |x: &Vec<f64>, d: &[f64]| x.iter().zip(d).map(|(a, b)| a + b).collect::<Vec<f64>>();
        let sol = super::lm::solve(
            x0,
            11,
            eval,
            apply,
            super::lm::Options {
                max_iterations: 100,
                cost_tolerance: 1e-12,
                step_tolerance: 1e-9,
            },
        )
        .ok_or("model fit failed")?;
        let x = sol.state;
        let nq = [x[0], x[1]];
        if !(nq[0].is_finite() && nq[1].is_finite()) || dist(nq, q0) > 0.5 * radius {
            return Err("model fit wandered off");
        }
        if x[8].abs() < 0.1 {
            return Err("no contrast at the corner");
        }
        q = nq;
        state = Some(x);
    }
    Ok(q)
}

/// `(erf(x), exp(−x²))` (Abramowitz & Stegun 7.1.26, |error| ≤ 1.5e-7).
#[inline]
fn erf_exp(x: f64) -> (f64, f64) {
    let e = (-x * x).exp();
    let a = x.abs();
    let t = 1.0 / (1.0 + 0.327_591_1 * a);
    let poly = t
        * (0.254_829_592
            + t * (-0.284_496_736
                + t * (1.421_413_741 + t * (-1.453_152_027 + t * 1.061_405_429))));
    let v = 1.0 - poly * e;
    (if x < 0.0 { -v } else { v }, e)
}

/// Find the inner corners of `board` in `img`.
pub fn detect(
    img: &Image,
    board: &Board,
    opts: &DetectOptions,
) -> Result<Detection, DetectFailure> {
    let want = board.inner();
    let need = board.corner_count();
    let mut last = DetectFailure::FewCandidates { found: 0, need };
    for sigma in [1.5, 3.0, 1.0] {
        let (blurred, cands) = candidates(img, sigma);
        if cands.len() < need {
            if !matches!(last, DetectFailure::Grid { .. }) {
                last = DetectFailure::FewCandidates {
                    found: cands.len(),
                    need,
                };
            }
            continue;
        }
        match find_grid(&blurred, &cands, want) {
            Ok(pts) => return finish(img, &blurred, board, pts, sigma, opts),
            Err(e) => last = e,
        }
    }
    Err(last)
}

fn finish(
    img: &Image,
    blurred: &Image,
    board: &Board,
    mut pts: Vec<[f64; 2]>,
    sigma: f64,
    opts: &DetectOptions,
) -> Result<Detection, DetectFailure> {
    let (ni, nj) = board.inner();
    let at = |p: &Vec<[f64; 2]>, i: usize, j: usize| p[j * ni + i];
    // Right-handed in the image: e_i × e_j > 0 (v points down).
    let (ci, cj) = (ni / 2, nj / 2);
    let (i0, j0) = (ci.min(ni - 2), cj.min(nj - 2));
    let o = at(&pts, i0, j0);
    let ei = at(&pts, i0 + 1, j0);
    let ej = at(&pts, i0, j0 + 1);
    let cross = (ei[0] - o[0]) * (ej[1] - o[1]) - (ei[1] - o[1]) * (ej[0] - o[0]);
    if cross < 0.0 {
        // Mirror i.
        let old = pts.clone();
        for j in 0..nj {
            for i in 0..ni {
                pts[j * ni + i] = old[j * ni + (ni - 1 - i)];
            }
        }
    }
    // The square at the origin corner must be dark: sample its centre, extrapolated.
    let square_centre = |p: &Vec<[f64; 2]>| {
        // Half a diagonal step outwards from corner (0, 0).
        let a = at(p, 0, 0);
        let d = at(p, 1, 1);
        [a[0] - 0.5 * (d[0] - a[0]), a[1] - 0.5 * (d[1] - a[1])]
    };
    let opposite_same_colour = (ni + nj) % 2 == 0; // squares (0,0) and (cols−1, rows−1): parity of cols+rows
    let centre_val = blurred.sample(square_centre(&pts)[0], square_centre(&pts)[1]);
    let rot =
        |p: &Vec<[f64; 2]>| -> Vec<[f64; 2]> { (0..ni * nj).map(|k| p[ni * nj - 1 - k]).collect() };
    let other = rot(&pts);
    let other_val = blurred.sample(square_centre(&other)[0], square_centre(&other)[1]);
    if !opposite_same_colour && other_val < centre_val {
        pts = other;
    }
    // Spacing per corner: the smallest distance to a grid neighbour.
    let mut spacing = vec![f64::INFINITY; ni * nj];
    for j in 0..nj {
        for i in 0..ni {
            let p = at(&pts, i, j);
            let mut s = f64::INFINITY;
            if i + 1 < ni {
                s = s.min(dist(p, at(&pts, i + 1, j)));
            }
            if i > 0 {
                s = s.min(dist(p, at(&pts, i - 1, j)));
            }
            if j + 1 < nj {
                s = s.min(dist(p, at(&pts, i, j + 1)));
            }
            if j > 0 {
                s = s.min(dist(p, at(&pts, i, j - 1)));
            }
            spacing[j * ni + i] = s;
        }
    }
    let mut sp: Vec<f64> = spacing.clone();
    sp.sort_by(f64::total_cmp);
    let median = sp[sp.len() / 2];
    let (lo, hi) = opts.refine_sigma_range;
    let mut out = Vec::with_capacity(ni * nj);
    for j in 0..nj {
        for i in 0..ni {
            let p = at(&pts, i, j);
            let sp = spacing[j * ni + i];
            let s = (opts.refine_sigma_ratio * sp).clamp(lo, hi);
            // A saddle pass at the detection scale, then the model fit.
            let coarse =
                refine_saddle(img, p, s.max(sigma)).map_err(|why| DetectFailure::Refine {
                    i,
                    j,
                    u: p[0],
                    v: p[1],
                    why,
                })?;
            let q = match opts.method {
                Refinement::Saddle => refine_saddle(img, coarse, s),
                Refinement::Model => {
                    let h = saddle_hessian(img, coarse, s.max(sigma))
                        .ok_or("too close to the image border");
                    h.and_then(|h| edge_angles(h).ok_or("not a saddle"))
                        .and_then(|a| {
                            refine_model(img, coarse, (opts.window_ratio * sp).clamp(4.0, 20.0), a)
                        })
                }
            }
            .map_err(|why| DetectFailure::Refine {
                i,
                j,
                u: p[0],
                v: p[1],
                why,
            })?;
            if dist(q, p) > (0.25 * sp).max(2.0) {
                return Err(DetectFailure::Refine {
                    i,
                    j,
                    u: p[0],
                    v: p[1],
                    why: "moved too far from the detected position",
                });
            }
            out.push(q);
        }
    }
    Ok(Detection {
        corners: out,
        half_turn_ambiguous: opposite_same_colour,
        spacing_px: median,
        detect_sigma: sigma,
    })
}
