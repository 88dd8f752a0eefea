//! Accuracy of a scan against a rendered dataset's ground truth: per-pixel point errors, and
//! VDI/VDE 2634-2 style sphere diameter and ball-bar length errors from least-squares sphere fits.

use crate::io::image::{Pixels, read_gray};
use crate::scan::PointCloud;
use anyhow::{Context, Result, bail};
use std::path::Path;

/// A sphere of the scene (a primitive), with its id in `truth/object_id.png`.
#[derive(Clone, Debug)]
pub struct TrueSphere {
    /// Primitive id.
    pub id: u16,
    /// Object index (spheres of one object form a ball bar).
    pub object: u64,
    /// Name.
    pub name: String,
    /// Centre, mm.
    pub center: [f64; 3],
    /// Radius, mm.
    pub radius: f64,
}

/// Ground truth of a dataset.
pub struct Truth {
    /// Width.
    pub width: usize,
    /// Height.
    pub height: usize,
    /// True point per pixel (x, y, z), NaN where the pixel sees nothing lit.
    pub points: Vec<f64>,
    /// Primitive id per pixel (0 = none).
    pub object_id: Vec<u16>,
    /// Spheres of the scene.
    pub spheres: Vec<TrueSphere>,
    /// Every primitive's id and its object's name (`manifest.json`'s `extra.primitives`).
    pub primitives: Vec<(u16, String)>,
}

/// Load `truth/points.npy`, `truth/object_id.png` and the spheres of `manifest.json`.
pub fn load_truth(dataset: &Path) -> Result<Truth> {
    let pts_path = dataset.join("truth/points.npy");
    let bytes =
        std::fs::read(&pts_path).with_context(|| format!("{}: cannot read", pts_path.display()))?;
    let (shape, points) = crate::io::npy::decode_f64(&bytes)
        .map_err(|e| anyhow::anyhow!("{}: {e}", pts_path.display()))?;
    let [h, w, 3] = shape[..] else {
        bail!(
            "{}: expected an H x W x 3 array, got {:?}",
            pts_path.display(),
            shape
        )
    };
    let id_path = dataset.join("truth/object_id.png");
    let (img, _) = read_gray(&id_path)?;
    let object_id = match img.pixels {
        Pixels::U16(v) if v.len() == w * h => v,
        Pixels::U8(v) if v.len() == w * h => v.into_iter().map(u16::from).collect(),
        _ => bail!("{}: expected a {w}x{h} integer image", id_path.display()),
    };
    let man_path = dataset.join("manifest.json");
    let man: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(&man_path)
            .with_context(|| format!("{}: cannot read", man_path.display()))?,
    )
    .with_context(|| format!("{}: not valid JSON", man_path.display()))?;
    let mut spheres = Vec::new();
    let mut primitives = Vec::new();
    for p in man["extra"]["primitives"].as_array().into_iter().flatten() {
        primitives.push((
            p["id"].as_u64().unwrap_or(0) as u16,
            p["name"].as_str().unwrap_or("?").to_string(),
        ));
        let s = &p["geometry"]["sphere"];
        if s.is_object() {
            let c = |i: usize| s["center"][i].as_f64().unwrap_or(f64::NAN);
            spheres.push(TrueSphere {
                id: p["id"].as_u64().unwrap_or(0) as u16,
                object: p["object"].as_u64().unwrap_or(0),
                name: format!(
                    "{}/{}",
                    p["name"].as_str().unwrap_or("?"),
                    p["part"].as_str().unwrap_or("?")
                ),
                center: [c(0), c(1), c(2)],
                radius: s["radius"].as_f64().unwrap_or(f64::NAN),
            });
        }
    }
    Ok(Truth {
        width: w,
        height: h,
        points,
        object_id,
        spheres,
        primitives,
    })
}

/// Error statistics over a set of pixels, mm.
#[derive(Clone, Copy, Debug, Default, serde::Serialize)]
pub struct ErrorStats {
    /// Pixels compared.
    pub count: usize,
    /// Root mean square distance to the true point.
    pub rms: f64,
    /// Mean distance.
    pub mean: f64,
    /// 95th percentile of the distance.
    pub p95: f64,
    /// Largest distance.
    pub max: f64,
}

fn stats(mut d: Vec<f64>) -> ErrorStats {
    if d.is_empty() {
        return ErrorStats::default();
    }
    d.sort_by(f64::total_cmp);
    let n = d.len();
    ErrorStats {
        count: n,
        rms: (d.iter().map(|x| x * x).sum::<f64>() / n as f64).sqrt(),
        mean: d.iter().sum::<f64>() / n as f64,
        p95: d[((n - 1) as f64 * 0.95) as usize],
        max: d[n - 1],
    }
}

/// A fitted sphere against its truth.
#[derive(Clone, Debug, serde::Serialize)]
pub struct SphereReport {
    /// Which sphere.
    pub name: String,
    /// Points used.
    pub points: usize,
    /// True diameter, mm.
    pub true_diameter: f64,
    /// Fitted diameter, mm.
    pub fitted_diameter: f64,
    /// Diameter error (fitted − true), mm.
    pub diameter_error: f64,
    /// Distance between the fitted and true centres, mm.
    pub center_error: f64,
    /// RMS of the radial residuals of the fit (form), mm.
    pub form_rms: f64,
    /// Fitted centre.
    #[serde(skip)]
    pub fitted_center: [f64; 3],
}

/// A ball bar: two spheres of one object.
#[derive(Clone, Debug, serde::Serialize)]
pub struct BallBarReport {
    /// True centre distance, mm.
    pub true_length: f64,
    /// Measured centre distance, mm.
    pub measured_length: f64,
    /// Length error, mm.
    pub length_error: f64,
}

/// The accuracy of one scan.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Accuracy {
    /// Pixels with a true point (lit, not shadowed).
    pub truth_pixels: usize,
    /// Of those, reconstructed as valid.
    pub valid_pixels: usize,
    /// Valid points with no true surface point in their pixel's 3×3 neighbourhood (should be 0).
    pub spurious_points: usize,
    /// All compared pixels; each point's error is its distance to the nearest true point of its
    /// 3×3 pixel neighbourhood, i.e. to the surfaces the pixel's footprint sees (a pixel on a
    /// silhouette legitimately reports the background that fills most of it, while its centre ray
    /// grazes the object). A flying point between two surfaces is far from both and still counts.
    pub all: ErrorStats,
    /// Pixels away from depth edges (their 3×3 neighbourhood sees one primitive), where a scanner's
    /// accuracy is specified; edge pixels mix two surfaces in one camera pixel.
    pub interior: ErrorStats,
    /// Sphere fits.
    pub spheres: Vec<SphereReport>,
    /// Ball bars.
    pub ball_bars: Vec<BallBarReport>,
}

/// Compare a reconstructed organized cloud with the truth.
pub fn evaluate(cloud: &PointCloud, truth: &Truth) -> Result<Accuracy> {
    let (w, h) = (truth.width, truth.height);
    if (cloud.width, cloud.height) != (w, h) {
        bail!(
            "the cloud is {}x{} but the truth is {w}x{h}",
            cloud.width,
            cloud.height
        );
    }
    let interior = |i: usize| -> bool {
        let (x, y) = (i % w, i / w);
        if x == 0 || y == 0 || x + 1 >= w || y + 1 >= h {
            return false;
        }
        let id = truth.object_id[i];
        (0..3).all(|dy| {
            (0..3).all(|dx| {
                truth.object_id[(y + dy - 1) * w + x + dx - 1] == id
                    && truth.points[3 * ((y + dy - 1) * w + x + dx - 1)].is_finite()
            })
        })
    };
    let (mut all, mut inner) = (Vec::new(), Vec::new());
    let (mut truth_px, mut valid, mut spurious) = (0, 0, 0);
    for i in 0..w * h {
        let t = &truth.points[3 * i..3 * i + 3];
        let ok = cloud.validity[i] == 0;
        let p = &cloud.xyz[3 * i..3 * i + 3];
        let dist = |t: &[f64]| {
            ((p[0] as f64 - t[0]).powi(2)
                + (p[1] as f64 - t[1]).powi(2)
                + (p[2] as f64 - t[2]).powi(2))
            .sqrt()
        };
        // Distance to the nearest true point of the pixel's 3×3 neighbourhood, if any.
        let (x, y) = (i % w, i / w);
        let mut near: Option<f64> = None;
        for yy in y.saturating_sub(1)..(y + 2).min(h) {
            for xx in x.saturating_sub(1)..(x + 2).min(w) {
                let q = &truth.points[3 * (yy * w + xx)..3 * (yy * w + xx) + 3];
                if q[0].is_finite() {
                    near = Some(near.map_or(dist(q), |n: f64| n.min(dist(q))));
                }
            }
        }
        if !t[0].is_finite() {
            // The centre ray sees nothing lit, but part of the pixel may: score the point against
            // the surfaces around it; with none there, it is spurious.
            if ok {
                match near {
                    Some(d) => all.push(d),
                    None => spurious += 1,
                }
            }
            continue;
        }
        truth_px += 1;
        if !ok {
            continue;
        }
        valid += 1;
        let d = dist(t);
        all.push(near.map_or(d, |n| n.min(d)));
        if interior(i) {
            inner.push(d);
        }
    }
    let mut spheres = Vec::new();
    for s in &truth.spheres {
        let pts: Vec<[f64; 3]> = (0..w * h)
            .filter(|&i| truth.object_id[i] == s.id && cloud.validity[i] == 0 && interior(i))
            .map(|i| {
                [
                    cloud.xyz[3 * i] as f64,
                    cloud.xyz[3 * i + 1] as f64,
                    cloud.xyz[3 * i + 2] as f64,
                ]
            })
            .collect();
        if let Some((c, r, form)) = fit_sphere(&pts) {
            let ce = ((c[0] - s.center[0]).powi(2)
                + (c[1] - s.center[1]).powi(2)
                + (c[2] - s.center[2]).powi(2))
            .sqrt();
            spheres.push(SphereReport {
                name: s.name.clone(),
                points: pts.len(),
                true_diameter: 2.0 * s.radius,
                fitted_diameter: 2.0 * r,
                diameter_error: 2.0 * (r - s.radius),
                center_error: ce,
                form_rms: form,
                fitted_center: c,
            });
        }
    }
    let mut ball_bars = Vec::new();
    for (i, a) in truth.spheres.iter().enumerate() {
        for b in truth
            .spheres
            .iter()
            .skip(i + 1)
            .filter(|b| b.object == a.object)
        {
            let find = |s: &TrueSphere| {
                spheres
                    .iter()
                    .find(|r| r.name == s.name)
                    .map(|r| r.fitted_center)
            };
            if let (Some(ca), Some(cb)) = (find(a), find(b)) {
                let dist = |p: [f64; 3], q: [f64; 3]| {
                    ((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2) + (p[2] - q[2]).powi(2)).sqrt()
                };
                let (t, m) = (dist(a.center, b.center), dist(ca, cb));
                ball_bars.push(BallBarReport {
                    true_length: t,
                    measured_length: m,
                    length_error: m - t,
                });
            }
        }
    }
    Ok(Accuracy {
        truth_pixels: truth_px,
        valid_pixels: valid,
        spurious_points: spurious,
        all: stats(all),
        interior: stats(inner),
        spheres,
        ball_bars,
    })
}

/// Least-squares sphere: algebraic fit, then 10 Gauss-Newton steps on the geometric distance.
/// Returns centre, radius and the RMS radial residual.
pub fn fit_sphere(p: &[[f64; 3]]) -> Option<([f64; 3], f64, f64)> {
    if p.len() < 10 {
        return None;
    }
    // x² + y² + z² = 2a·x + 2b·y + 2c·z + d (centred on the mean for conditioning)
    let n = p.len() as f64;
    let m = [0, 1, 2].map(|k| p.iter().map(|q| q[k]).sum::<f64>() / n);
    let mut ata = [[0.0; 4]; 4];
    let mut atb = [0.0; 4];
    for q in p {
        let (x, y, z) = (q[0] - m[0], q[1] - m[1], q[2] - m[2]);
        let row = [2.0 * x, 2.0 * y, 2.0 * z, 1.0];
        let rhs = x * x + y * y + z * z;
        for i in 0..4 {
            atb[i] += row[i] * rhs;
            for j in 0..4 {
                ata[i][j] += row[i] * row[j];
            }
        }
    }
    let s = solve4(ata, atb)?;
    let mut c = [s[0], s[1], s[2]];
    let mut r = (s[3] + c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt();
    for _ in 0..10 {
        // residual f = |q − c| − r; ∂f/∂c = −(q − c)/|q − c|, ∂f/∂r = −1
        let mut ata = [[0.0; 4]; 4];
        let mut atb = [0.0; 4];
        for q in p {
            let d = [q[0] - m[0] - c[0], q[1] - m[1] - c[1], q[2] - m[2] - c[2]];
            let l = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt().max(1e-12);
            let row = [-d[0] / l, -d[1] / l, -d[2] / l, -1.0];
            let f = l - r;
            for i in 0..4 {
                atb[i] -= row[i] * f;
                for j in 0..4 {
                    ata[i][j] += row[i] * row[j];
                }
            }
        }
        let dx = solve4(ata, atb)?;
        c = [c[0] + dx[0], c[1] + dx[1], c[2] + dx[2]];
        r += dx[3];
    }
    let form = (p
        .iter()
        .map(|q| {
            let d = [q[0] - m[0] - c[0], q[1] - m[1] - c[1], q[2] - m[2] - c[2]];
            let e = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt() - r;
            e * e
        })
        .sum::<f64>()
        / n)
        .sqrt();
    Some(([c[0] + m[0], c[1] + m[1], c[2] + m[2]], r, form))
}

fn solve4(mut a: [[f64; 4]; 4], mut b: [f64; 4]) -> Option<[f64; 4]> {
    for col in 0..4 {
        let piv = (col..4).max_by(|&i, &j| a[i][col].abs().total_cmp(&a[j][col].abs()))?;
        if a[piv][col].abs() < 1e-300 {
            return None;
        }
        a.swap(col, piv);
        b.swap(col, piv);
        for row in col + 1..4 {
            let f = a[row][col] / a[col][col];
            for k in col..4 {
                a[row][k] -= f * a[col][k];
            }
            b[row] -= f * b[col];
        }
    }
    let mut x = [0.0; 4];
    for i in (0..4).rev() {
        let s: f64 = (i + 1..4).map(|k| a[i][k] * x[k]).sum();
        x[i] = (b[i] - s) / a[i][i];
    }
    x.iter().all(|v| v.is_finite()).then_some(x)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sphere_fit_recovers_an_analytic_sphere() {
        // points on a cap of a known sphere, with a deterministic ±5 µm ripple
        let (c, r) = ([12.0, -7.0, 600.0], 25.0);
        let mut pts = Vec::new();
        for i in 0..40 {
            for j in 0..40 {
                let th = 0.1 + 1.2 * i as f64 / 40.0;
                let ph = std::f64::consts::TAU * j as f64 / 40.0;
                let rr = r + 0.005 * ((i * 7 + j * 3) % 3) as f64 - 0.005;
                pts.push([
                    c[0] + rr * th.sin() * ph.cos(),
                    c[1] + rr * th.sin() * ph.sin(),
                    c[2] - rr * th.cos(),
                ]);
            }
        }
        let (fc, fr, form) = fit_sphere(&pts).unwrap();
        assert!((fr - r).abs() < 0.005, "radius {fr}");
        assert!((0..3).all(|k| (fc[k] - c[k]).abs() < 0.01), "centre {fc:?}");
        assert!(form < 0.006 && form > 0.001, "form {form}");
    }
}
