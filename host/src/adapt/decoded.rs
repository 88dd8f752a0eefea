//! The object from a first scan's decoded phase (`fringe3d decode`'s folder) with the §7
//! calibration alone (camera, projector centre, reference plane and its map): no projector model
//! needed, and the pixels' light is their measured modulation.
//!
//! Per valid pixel of the first scan, decoded with the set `first` (straight fringes, finest
//! scale `c`, base phase Φ along the axis):
//!
//! - its point: the §6 reconstruction of its phase (`ScanCalibration::reconstruct`);
//! - its projector coordinate ξ: `Φ(ξ) = φ/c` solved by bisection (Φ strictly increasing);
//! - `dξ/dt` along its ray: by §6's own geometry, the phase a point X shows is the reference's at
//!   the camera pixel where the line from the projector centre P through X meets the reference
//!   plane; its rate over ±0.5 mm along the ray, divided by `c·Φ'(ξ)`;
//! - its light: the decoded modulation B (the first set's fringes are coarse, so the optics pass
//!   nearly all their contrast).

use fringe3d_core::pattern::PatternSet;

use super::Sample;
use super::surface::{Gathered, PointMap, grid_samples};
use crate::calib::lens::Lens;
use crate::io::calibration::Calibration;
use crate::math::Vec3;
use crate::scan::PointCloud;

/// The reference map and geometry a first scan was reconstructed with.
pub struct Reference<'a> {
    /// The calibration (camera, projector centre, reference plane, depth range).
    pub calibration: &'a Calibration,
    /// Its raw reference map (NaN = invalid), `(width, height)` with the margin.
    pub map: (&'a [f32], usize, usize),
}

impl Reference<'_> {
    /// The reference phase a point `x` shows (§6): NaN off the map or the plane.
    fn phase_at(&self, lens: &Lens, x: Vec3) -> f64 {
        let cal = self.calibration;
        let Some(r) = &cal.reference else {
            return f64::NAN;
        };
        let p = Vec3::from_array(cal.projector_centre);
        let (o, n) = (Vec3::from_array(r.point), Vec3::from_array(r.normal));
        let den = n.dot(x - p);
        if den.abs() < 1e-12 {
            return f64::NAN;
        }
        let hit = p + (x - p) * (n.dot(o - p) / den);
        let Some((u, v)) = lens.project_point(hit.to_array()) else {
            return f64::NAN;
        };
        let m = r.margin();
        let (fu, fv) = (u + f64::from(m.left), v + f64::from(m.top));
        let (data, w, h) = self.map;
        if !(fu >= 0.0 && fv >= 0.0 && fu < (w - 1) as f64 && fv < (h - 1) as f64) {
            return f64::NAN;
        }
        let (iu, iv) = (fu.floor() as usize, fv.floor() as usize);
        let (a, b) = (fu - iu as f64, fv - iv as f64);
        let at = |x: usize, y: usize| f64::from(data[y * w + x]);
        (1.0 - b) * ((1.0 - a) * at(iu, iv) + a * at(iu + 1, iv))
            + b * ((1.0 - a) * at(iu, iv + 1) + a * at(iu + 1, iv + 1))
    }
}

/// The samples of a first scan: `cloud` reconstructed from the finest phase `phase` decoded with
/// `first` (straight fringes), its modulation `modulation`, the points inside `crop`.
pub fn samples(
    reference: &Reference<'_>,
    first: &PatternSet,
    cloud: &PointCloud,
    phase: &[f32],
    modulation: &[f32],
    crop: Option<([f64; 3], [f64; 3])>,
) -> (Vec<Sample>, Gathered) {
    let (w, h) = (cloud.width, cloud.height);
    let (phi, finest, extent) = super::pattern::base_phase(first);
    let lens = Lens::from_model(&reference.calibration.camera);
    let depth = reference.calibration.depth_range;
    let mut g = Gathered::default();
    let mut map = PointMap {
        width: w,
        height: h,
        points: vec![[f64::NAN; 3]; w * h],
        light: vec![f64::NAN; w * h],
    };
    let mut along = vec![f64::NAN; w * h];
    for i in 0..w * h {
        if cloud.validity[i] != 0 || !phase[i].is_finite() {
            continue;
        }
        let x = [0, 1, 2].map(|k| f64::from(cloud.xyz[3 * i + k]));
        if let Some((a, b)) = crop
            && (0..3).any(|k| x[k] < a[k] || x[k] > b[k])
        {
            g.cropped += 1;
            continue;
        }
        if !(x[2] >= depth[0] && x[2] <= depth[1]) {
            g.outside_depth += 1;
            continue;
        }
        // Φ(ξ) = φ/c by bisection over the projector.
        let target = f64::from(phase[i]) / finest;
        let (mut lo, mut hi) = (-0.5, extent - 0.5);
        if !(target >= phi(lo) && target <= phi(hi)) {
            g.unlit += 1;
            continue;
        }
        for _ in 0..50 {
            let m = 0.5 * (lo + hi);
            if phi(m) < target {
                lo = m;
            } else {
                hi = m;
            }
        }
        map.points[i] = x;
        along[i] = 0.5 * (lo + hi);
    }
    g.kept = along.iter().filter(|a| a.is_finite()).count();
    let along_ref = &along;
    let lens = &lens;
    let phi = &phi;
    let samples = grid_samples(&map, &along, lens.p[0], |i, x, _| {
        let xv = Vec3::from_array(x);
        let n = xv.norm();
        let at = |t: f64| reference.phase_at(lens, xv * (1.0 + t / n));
        let rate_phase = at(0.5) - at(-0.5);
        let xi = along_ref[i];
        let slope = phi(xi + 0.5) - phi(xi - 0.5);
        let light = f64::from(modulation[i]);
        light
            .is_finite()
            .then(|| (rate_phase / (finest * slope), light.max(0.0)))
    });
    (samples, g)
}
