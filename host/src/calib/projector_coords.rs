//! The projector pixel `(ξ, η)` that lights each board corner, from the two absolute phase maps
//! of its pose (issue #18 item 2; the projector seen as an inverted camera, paper §4.2).
//!
//! Per corner at camera position `(u_c, v_c)` (sub-pixel, from the board image of the same pose):
//!
//! 1. **Local interpolation, not the nearest pixel.** Over the valid pixels of a
//!    `(2r + 1) × (2r + 1)` window around the corner, each phase map is fitted by a quadratic
//!    `Φ(u, v) ≈ c₀ + c₁ du + c₂ dv + c₃ du² + c₄ du dv + c₅ dv²` (`du = u − u_c`,
//!    `dv = v − v_c`), and `Φ(u_c, v_c) = c₀`. A plane's phase is smooth (a ratio of linear
//!    functions through two lenses), so the quadratic's bias over a few pixels is far below the
//!    noise it averages away; the fit also gives `σ(c₀)` from its residuals.
//! 2. **Phase → projector pixel.** `(ξ, η)` solves `c_K·Φ_V(ξ, η) = Φ_V`,
//!    `c_K·Φ_H(ξ, η) = Φ_H` ([`PatternSet::finest_phase`] of each set: eq 7), by Newton's method
//!    from the DMD's centre. Straight fringes make this two independent 1-D inversions; curved or
//!    varying-width fringes (§5.1) are handled by the same 2-D iteration.
//!
//! A corner gets no projector coordinates when its window is less than 70 % valid, either map's
//! fit is degenerate, or the inversion does not converge inside the DMD (± 2 px).

use fringe3d_core::pattern::PatternSet;

use super::linalg::{cholesky, cholesky_solve, spd_inverse};

/// One absolute phase map of a pose (NaN where not valid), `width × height`, row-major.
#[derive(Clone, Copy, Debug)]
pub struct PhaseMap<'a> {
    /// Width, pixels.
    pub width: usize,
    /// Height, pixels.
    pub height: usize,
    /// The phases.
    pub phase: &'a [f32],
}

/// A phase interpolated at a sub-pixel position.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LocalPhase {
    /// The phase there, radians.
    pub phase: f64,
    /// Its standard deviation from the fit's residuals, radians.
    pub std: f64,
    /// Pixels used.
    pub pixels: usize,
}

/// The fewest valid fraction of a corner's window.
pub const MIN_WINDOW_VALID: f64 = 0.7;

/// The quadratic fit of step 1 at `(u, v)` over a window of radius `r` pixels (≥ 2).
pub fn local_phase(map: &PhaseMap<'_>, (u, v): (f64, f64), r: usize) -> Option<LocalPhase> {
    let r = r.max(2) as isize;
    if !(u.is_finite() && v.is_finite()) {
        return None;
    }
    let (cu, cv) = (u.round() as isize, v.round() as isize);
    let (w, h) = (map.width as isize, map.height as isize);
    let mut ata = [0.0; 36];
    let mut atb = [0.0; 6];
    let mut rows: Vec<([f64; 6], f64)> = Vec::with_capacity(((2 * r + 1) * (2 * r + 1)) as usize);
    for y in cv - r..=cv + r {
        for x in cu - r..=cu + r {
            if x < 0 || y < 0 || x >= w || y >= h {
                continue;
            }
            let p = map.phase[(y * w + x) as usize];
            if !p.is_finite() {
                continue;
            }
            // Scaled to O(1) so the normal equations stay well conditioned.
            let (du, dv) = ((x as f64 - u) / r as f64, (y as f64 - v) / r as f64);
            let t = [1.0, du, dv, du * du, du * dv, dv * dv];
            rows.push((t, f64::from(p)));
        }
    }
    let window = ((2 * r + 1) * (2 * r + 1)) as f64;
    if (rows.len() as f64) < MIN_WINDOW_VALID * window || rows.len() < 12 {
        return None;
    }
    // Centre the phases on their mean first (absolute phases reach hundreds of radians).
    let mean = rows.iter().map(|(_, p)| p).sum::<f64>() / rows.len() as f64;
    for (t, p) in &rows {
        for i in 0..6 {
            atb[i] += t[i] * (p - mean);
            for j in 0..6 {
                ata[i * 6 + j] += t[i] * t[j];
            }
        }
    }
    let mut l = ata;
    if !cholesky(&mut l, 6) {
        return None;
    }
    let mut c = atb;
    cholesky_solve(&l, 6, &mut c);
    let ss: f64 = rows
        .iter()
        .map(|(t, p)| {
            let f: f64 = t.iter().zip(&c).map(|(a, b)| a * b).sum();
            (p - mean - f).powi(2)
        })
        .sum();
    let s2 = ss / (rows.len() - 6) as f64;
    let inv = spd_inverse(&ata, 6)?;
    let phase = mean + c[0];
    phase.is_finite().then_some(LocalPhase {
        phase,
        std: (s2 * inv[0]).max(0.0).sqrt(),
        pixels: rows.len(),
    })
}

/// Step 2: the projector pixel where the finest phases of the vertical set `set_v` (phase
/// along ξ) and the horizontal set `set_h` (along η) equal `(pv, ph)`. `None` if Newton's method
/// does not converge to within 1e-9 px or the pixel lies more than 2 px off the DMD.
pub fn invert_phases(set_v: &PatternSet, set_h: &PatternSet, pv: f64, ph: f64) -> Option<[f64; 2]> {
    let out = set_v.output();
    let (pw, phh) = (f64::from(out.width), f64::from(out.height));
    let (mut xi, mut eta) = (0.5 * (pw - 1.0), 0.5 * (phh - 1.0));
    let f = |xi: f64, eta: f64| {
        (
            set_v.finest_phase(xi, eta) - pv,
            set_h.finest_phase(xi, eta) - ph,
        )
    };
    const H: f64 = 1e-3;
    for _ in 0..40 {
        let (a, b) = f(xi, eta);
        let (ax, bx) = f(xi + H, eta);
        let (ae, be) = f(xi, eta + H);
        let (j11, j12, j21, j22) = ((ax - a) / H, (ae - a) / H, (bx - b) / H, (be - b) / H);
        let det = j11 * j22 - j12 * j21;
        if !(det.abs() > 1e-300) {
            return None;
        }
        let dxi = (j22 * a - j12 * b) / det;
        let deta = (-j21 * a + j11 * b) / det;
        // Damp huge first steps (a phase far outside the set's range).
        let s = (pw.max(phh) / (dxi.abs() + deta.abs()).max(1e-300)).min(1.0);
        xi -= s * dxi;
        eta -= s * deta;
        if !(xi.is_finite() && eta.is_finite()) {
            return None;
        }
        if dxi.abs() < 1e-9 && deta.abs() < 1e-9 {
            let inside = (-2.0..=pw + 1.0).contains(&xi) && (-2.0..=phh + 1.0).contains(&eta);
            return inside.then_some([xi, eta]);
        }
    }
    None
}

/// Projector coordinates of corners, and their standard deviations.
#[derive(Clone, Debug, Default)]
pub struct CornerCoords {
    /// Per corner, `(ξ, η)` or `None` (see the module doc).
    pub coords: Vec<Option<[f64; 2]>>,
    /// Per corner with coordinates, the standard deviation of `(ξ, η)` from the phase fits,
    /// projector pixels (the phase's σ over the local fringe slope).
    pub std: Vec<Option<[f64; 2]>>,
}

/// Steps 1 and 2 for every corner.
pub fn corner_coords(
    v: &PhaseMap<'_>,
    h: &PhaseMap<'_>,
    set_v: &PatternSet,
    set_h: &PatternSet,
    corners: &[[f64; 2]],
    radius: usize,
) -> CornerCoords {
    let mut out = CornerCoords::default();
    for c in corners {
        let lv = local_phase(v, (c[0], c[1]), radius);
        let lh = local_phase(h, (c[0], c[1]), radius);
        let r = match (lv, lh) {
            (Some(a), Some(b)) => invert_phases(set_v, set_h, a.phase, b.phase).map(|x| {
                // Phase slope per projector pixel along each set's axis.
                let dv = (set_v.finest_phase(x[0] + 0.5, x[1])
                    - set_v.finest_phase(x[0] - 0.5, x[1]))
                .abs();
                let dh = (set_h.finest_phase(x[0], x[1] + 0.5)
                    - set_h.finest_phase(x[0], x[1] - 0.5))
                .abs();
                (x, [a.std / dv.max(1e-12), b.std / dh.max(1e-12)])
            }),
            _ => None,
        };
        out.coords.push(r.map(|x| x.0));
        out.std.push(r.map(|x| x.1));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use fringe3d_core::pattern::Output;
    use fringe3d_core::phase_function::Axis;

    fn sets() -> (PatternSet, PatternSet) {
        let o = Output {
            width: 1024,
            height: 768,
            i_min: 0.0,
            i_max: 255.0,
        };
        (
            PatternSet::default_for(Axis::Xi, o).unwrap(),
            PatternSet::default_for(Axis::Eta, o).unwrap(),
        )
    }

    /// A smooth map sampled exactly recovers the value at a sub-pixel point (independent truth:
    /// the analytic function), and an exact quadratic is recovered to rounding.
    #[test]
    fn the_local_fit_interpolates_a_smooth_map() {
        let (w, hh) = (40, 30);
        let f = |x: f64, y: f64| 100.0 + 0.7 * x - 0.3 * y + 0.002 * x * x + 0.001 * x * y;
        let m: Vec<f32> = (0..w * hh)
            .map(|i| f((i % w) as f64, (i / w) as f64) as f32)
            .collect();
        let map = PhaseMap {
            width: w,
            height: hh,
            phase: &m,
        };
        let p = local_phase(&map, (17.3, 12.6), 4).unwrap();
        assert!((p.phase - f(17.3, 12.6)).abs() < 2e-5, "{p:?}");
        assert_eq!(p.pixels, 81);
        // Too little of the window valid: none.
        let mut holes = m.clone();
        for y in 8..17 {
            for x in 13..19 {
                holes[y * w + x] = f32::NAN;
            }
        }
        let map = PhaseMap {
            width: w,
            height: hh,
            phase: &holes,
        };
        assert!(local_phase(&map, (17.3, 12.6), 4).is_none());
    }

    /// The inversion returns the projector pixel whose phases were asked for (truth: the sets'
    /// own forward phases).
    #[test]
    fn phases_invert_to_the_projector_pixel() {
        let (sv, sh) = sets();
        for (xi, eta) in [
            (0.0, 0.0),
            (511.5, 383.5),
            (1023.0, 767.0),
            (100.25, 700.75),
        ] {
            let p = invert_phases(&sv, &sh, sv.finest_phase(xi, eta), sh.finest_phase(xi, eta))
                .unwrap();
            assert!(
                (p[0] - xi).abs() < 1e-6 && (p[1] - eta).abs() < 1e-6,
                "{p:?}"
            );
        }
        // A phase pair beyond the DMD by far: none.
        let far = sv.finest_phase(5000.0, 0.0);
        assert!(invert_phases(&sv, &sh, far, sh.finest_phase(0.0, 0.0)).is_none());
    }
}
