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
//! 4. **Refinement**: each corner is first moved to the saddle point of
//!    `F(q) = Σ_k G_σ(q − k) I(k)` (the raw samples `I(k)` at integer pixel centres, weighted by a
//!    continuous Gaussian centred at `q`) by Newton's method on `∇F = 0`, σ = 0.08 × the local
//!    corner spacing (1–4 px); then (default, [`Refinement::Model`]) an X-junction model is fitted
//!    to the pixels around it: two straight edges, each integrated over the box pixel and blurred
//!    by a Gaussian, with linear illumination terms ([`refine_model`]). Modelling the pixel
//!    integral exactly keeps the corner unbiased at every board angle: with an erf edge profile
//!    instead, edges within ~3° of the pixel axes biased corners by up to 0.04 px (issue #18,
//!    `host/tests/corners_angle_sweep.rs`).
//!
//! Noise: at the saddle, δq ≈ σ_noise / (1.6·C) per axis for a contrast C between the squares,
//! independent of σ (for 8-bit images with C ≈ 190 gray levels and σ_noise = 1: ~0.003 px).

mod grid;
mod refine;

use super::lens::Lens;
use grid::{candidates, find_grid};
use refine::{edge_angles, saddle_hessian};
pub use refine::{refine_model, refine_saddle};

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
    /// The camera's lens, when known: the model fit then straightens the board's edges, which
    /// the lens's distortion curves ([`refine_model`]). `calibrate camera` detects once without,
    /// calibrates, detects again with its result and calibrates again; the later steps, whose
    /// camera is calibrated, detect with it.
    pub lens: Option<Lens>,
}

impl Default for DetectOptions {
    fn default() -> Self {
        DetectOptions {
            refine_sigma_ratio: 0.08,
            refine_sigma_range: (1.0, 4.0),
            window_ratio: 0.45,
            method: Refinement::Model,
            lens: None,
        }
    }
}

fn dist(a: [f64; 2], b: [f64; 2]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2)).sqrt()
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
                            let r = (opts.window_ratio * sp).clamp(4.0, 20.0);
                            refine_model(img, coarse, r, a, opts.lens.as_ref())
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
