//! Pictures for the calibration reports: a view with its detected corners and magnified residual
//! vectors, a phase-map overview; and the camera report's `corners.json` (the detected corners of
//! every view with their reprojection residuals, layout in `docs/formats.md`).

use super::camera::{CameraCalibration, View};
use super::corners::Board;
use crate::io::preview::write_rgb_png;
use serde_json::json;
use std::path::{Path, PathBuf};

/// An RGB8 canvas.
pub struct Canvas {
    /// Width.
    pub width: usize,
    /// Height.
    pub height: usize,
    /// Pixels, RGB, row-major.
    pub rgb: Vec<u8>,
}

impl Canvas {
    /// A gray image stretched from its 1st to 99th percentile, dimmed to `brightness` (0..1) so
    /// that drawings stand out.
    pub fn from_gray(width: usize, height: usize, data: &[f32], brightness: f32) -> Canvas {
        let mut s: Vec<f32> = data
            .iter()
            .step_by(5)
            .cloned()
            .filter(|x| x.is_finite())
            .collect();
        s.sort_by(f32::total_cmp);
        let q = |p: f64| {
            s.get(((s.len().max(1) - 1) as f64 * p) as usize)
                .cloned()
                .unwrap_or(0.0)
        };
        let (lo, hi) = (q(0.01), q(0.99));
        let span = if hi > lo { hi - lo } else { 1.0 };
        let mut rgb = Vec::with_capacity(width * height * 3);
        for &v in data {
            let g = if v.is_finite() {
                (((v - lo) / span).clamp(0.0, 1.0) * 255.0 * brightness) as u8
            } else {
                0
            };
            rgb.extend([g, g, g]);
        }
        Canvas { width, height, rgb }
    }

    /// Set one pixel (ignored outside).
    pub fn put(&mut self, x: i64, y: i64, c: [u8; 3]) {
        if x >= 0 && y >= 0 && (x as usize) < self.width && (y as usize) < self.height {
            let i = 3 * (y as usize * self.width + x as usize);
            self.rgb[i..i + 3].copy_from_slice(&c);
        }
    }

    /// A straight line.
    pub fn line(&mut self, a: [f64; 2], b: [f64; 2], c: [u8; 3]) {
        let n = ((b[0] - a[0]).abs().max((b[1] - a[1]).abs()).ceil() as usize).clamp(1, 20000);
        for k in 0..=n {
            let t = k as f64 / n as f64;
            self.put(
                (a[0] + t * (b[0] - a[0])).round() as i64,
                (a[1] + t * (b[1] - a[1])).round() as i64,
                c,
            );
        }
    }

    /// A small cross.
    pub fn cross(&mut self, p: [f64; 2], r: f64, c: [u8; 3]) {
        self.line([p[0] - r, p[1]], [p[0] + r, p[1]], c);
        self.line([p[0], p[1] - r], [p[0], p[1] + r], c);
    }

    /// An arrow from `a` to `b`.
    pub fn arrow(&mut self, a: [f64; 2], b: [f64; 2], c: [u8; 3]) {
        self.line(a, b, c);
        let d = [b[0] - a[0], b[1] - a[1]];
        let l = (d[0] * d[0] + d[1] * d[1]).sqrt();
        if l > 4.0 {
            let u = [d[0] / l, d[1] / l];
            let h = 3.0f64.min(0.3 * l);
            for s in [1.0, -1.0] {
                let w = [-u[1] * s, u[0] * s];
                self.line(
                    b,
                    [
                        b[0] - h * u[0] + h * 0.6 * w[0],
                        b[1] - h * u[1] + h * 0.6 * w[1],
                    ],
                    c,
                );
            }
        }
    }

    /// Write as PNG.
    pub fn save(&self, path: &Path) -> Result<(), String> {
        write_rgb_png(path, self.width as u32, self.height as u32, &self.rgb)
    }
}

/// A "nice" magnification: `target_px / typical`, rounded down to 1, 2 or 5 × 10^k.
pub fn nice_scale(typical: f64, target_px: f64) -> f64 {
    if !(typical > 0.0) {
        return 1.0;
    }
    let raw = target_px / typical;
    let e = raw.log10().floor();
    let base = 10f64.powf(e);
    let m = raw / base;
    let k = if m >= 5.0 {
        5.0
    } else if m >= 2.0 {
        2.0
    } else {
        1.0
    };
    k * base
}

/// Draw a view: detected corners (green crosses), residuals (projected − detected) magnified by
/// `scale` (red arrows), the board's first corner (cyan ring: the origin of the labelling) and a
/// scale bar of 0.1 px × `scale` (yellow, bottom left).
pub fn view_picture(
    width: usize,
    height: usize,
    image: &[f32],
    corners: &[[f64; 2]],
    residuals: &[[f64; 2]],
    scale: f64,
) -> Canvas {
    let mut c = Canvas::from_gray(width, height, image, 0.6);
    for (p, r) in corners.iter().zip(residuals) {
        c.arrow(
            *p,
            [p[0] + scale * r[0], p[1] + scale * r[1]],
            [255, 40, 40],
        );
    }
    for p in corners {
        c.cross(*p, 2.0, [40, 255, 40]);
    }
    if let Some(o) = corners.first() {
        for k in 0..32 {
            let a = k as f64 * std::f64::consts::TAU / 32.0;
            c.put(
                (o[0] + 6.0 * a.cos()).round() as i64,
                (o[1] + 6.0 * a.sin()).round() as i64,
                [0, 220, 255],
            );
        }
    }
    let y = height as f64 - 12.0;
    let len = (0.1 * scale).min(width as f64 - 20.0);
    c.line([10.0, y], [10.0 + len, y], [255, 230, 0]);
    c.line([10.0, y - 3.0], [10.0, y + 3.0], [255, 230, 0]);
    c.line([10.0 + len, y - 3.0], [10.0 + len, y + 3.0], [255, 230, 0]);
    c
}

/// `corners.json` of a camera report: per detected view (used or left out) its image, and per
/// inner corner its board index `(i, j)`, board position (mm), detected pixel `(u, v)` (pixel
/// centres at integer coordinates) and reprojection residual (projected − detected; `null` for a
/// view left out of the calibration).
pub fn corners_json(
    board: &Board,
    size: (u32, u32),
    views: &[View],
    cal: &CameraCalibration,
) -> serde_json::Value {
    let (ni, nj) = board.inner();
    let obj = board.object_points();
    let out: Vec<serde_json::Value> = views
        .iter()
        .map(|v| {
            let used = cal.views.iter().find(|r| r.name == v.name);
            let image = Path::new(&v.name)
                .file_name()
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_else(|| v.name.clone());
            let corners: Vec<serde_json::Value> = v
                .corners
                .iter()
                .enumerate()
                .map(|(k, uv)| {
                    let res = used
                        .and_then(|r| r.residuals.get(k))
                        .map(|r| json!([r[0], r[1]]));
                    json!({
                        "i": k % ni,
                        "j": k / ni,
                        "index": k,
                        "board_mm": obj.get(k).map(|p| [p[0], p[1]]),
                        "uv": [uv[0], uv[1]],
                        "residual": res,
                    })
                })
                .collect();
            json!({
                "image": image,
                "path": v.name,
                "used": used.is_some(),
                "rms_px": used.map(|r| r.rms),
                "corners": corners,
            })
        })
        .collect();
    json!({
        "format": "fringe3d camera corners",
        "version": 1,
        "pixel_convention": "pixel centres at integer coordinates, (0, 0) = centre of the top-left pixel, u right, v down",
        "residual": "projected - detected, pixels",
        "image_size": [size.0, size.1],
        "board": {"cols": board.cols, "rows": board.rows, "square_mm": board.square, "inner_corners": [ni, nj]},
        "corner_order": "row by row, i fastest: index = j * inner_corners[0] + i",
        "views": out,
    })
}

/// Write [`corners_json`] as `dir/corners.json` (atomically); returns its path.
pub fn write_corners_json(
    dir: &Path,
    board: &Board,
    size: (u32, u32),
    views: &[View],
    cal: &CameraCalibration,
) -> Result<PathBuf, String> {
    let j = corners_json(board, size, views, cal);
    let text = serde_json::to_string_pretty(&j).map_err(|e| e.to_string())?;
    let p = dir.join("corners.json");
    crate::io::atomic::write_atomic(&p, |w| w.write_all(text.as_bytes()))
        .map_err(|e| e.to_string())?;
    Ok(p)
}
