//! A captured reference wider than the image (issue #17 item 3): the fitted model of the capture
//! inside the image, continued past it by the projector model.
//!
//! A point nearer than the reference plane has its crossing displaced along its epipolar line,
//! and near the image's border that crossing lies off the image: an image-sized map loses it
//! (docs/reference-model.md, "A map wider than the image"). A capture ends at the image, and the
//! spline fitted to it is not to be trusted beyond it. But when the calibration holds the full
//! projector model, the phase the plate shows past the image follows from the plate's pose: the
//! plane the fringes put it at ([`super::reference_physical`]) and the virtual map on that plane
//! ([`virtual_reference`]). The two maps differ inside the image by the projector model's own
//! error (with a calibrated model, up to a few tenths of a millimetre at the field's edge), so
//! the continuation is shifted to meet the capture's model: a margin sample takes the virtual
//! map's value plus the difference `D = fitted − virtual` continued from the image pixel nearest
//! to it (the same row for the left and right margins, the same column for the top and bottom
//! ones, the corner pixel for the corners) by the parabola through `D` there and `SLOPE_PX` and
//! `2·SLOPE_PX` inside (a straight line, or a constant, where those have no phase); at a corner
//! the continuations along both axes add. The map is then continuous at the image's border, and
//! what is left is how the model's error departs from that parabola past the image
//! (docs/reference-model.md measures it). The largest `|D|` at the border is reported
//! (`seam_rad`): a large one says the projector model and the capture disagree, and `--margin 0`
//! keeps the map image-sized.

use fringe3d_core::params::{CameraParams, ProjectorParams};
use fringe3d_core::pattern::PatternSet;
use fringe3d_core::reconstruct::{MAX_MARGIN, Margin};

use super::virtual_reference::{VirtualError, margin_needed, virtual_reference};
use crate::io::calibration::Calibration;

/// How far inside the image the slope of the shift is taken, pixels: far enough that the
/// fitted map's noise (≈ 3e-4 rad) makes a slope error of ~1e-5 rad per pixel, near enough to
/// follow the model's error where it changes.
const SLOPE_PX: isize = 32;

/// The fitted map extended past the image.
#[derive(Clone, Debug)]
pub struct Extended {
    /// `(left + width + right) × (top + height + bottom)` phases, row-major; the image's own
    /// samples are the fitted map's, bit for bit.
    pub map: Vec<f32>,
    /// The largest `|fitted − virtual|` over the border pixels that seed the margin, radians.
    pub seam_rad: f64,
}

/// `fitted` (`camera.width × camera.height`, the model of the capture) extended by `margin` with
/// the virtual map of `projector` on `plane` (the plane the fringes show), shifted to meet
/// `fitted` at the image's border (see the module's documentation). A margin sample is NaN
/// where the virtual map is (off the DMD, the edge of the light) or where the border pixel it
/// continues has no phase in either map.
pub fn extend_fitted_map(
    camera: &CameraParams,
    projector: &ProjectorParams,
    set: &PatternSet,
    fitted: &[f32],
    plane: ([f64; 3], [f64; 3]),
    margin: Margin,
) -> Result<Extended, VirtualError> {
    let (w, h) = (camera.width as usize, camera.height as usize);
    if margin == Margin::ZERO {
        return Ok(Extended {
            map: fitted.to_vec(),
            seam_rad: 0.0,
        });
    }
    let virt = virtual_reference(camera, projector, set, plane, margin)?;
    let (l, t) = (margin.left as usize, margin.top as usize);
    let mw = w + l + margin.right as usize;
    let mh = h + t + margin.bottom as usize;
    // The shift at image pixel (u, v): fitted − virtual.
    let shift =
        |u: usize, v: usize| f64::from(fitted[v * w + u]) - f64::from(virt[(v + t) * mw + u + l]);
    let mut map = vec![f32::NAN; mw * mh];
    let mut seam: f64 = 0.0;
    for j in 0..mh {
        for i in 0..mw {
            let (u, v) = (i as isize - l as isize, j as isize - t as isize);
            let inside = (0..w as isize).contains(&u) && (0..h as isize).contains(&v);
            if inside {
                map[j * mw + i] = fitted[v as usize * w + u as usize];
                continue;
            }
            let uc = u.clamp(0, w as isize - 1) as usize;
            let vc = v.clamp(0, h as isize - 1) as usize;
            let d0 = shift(uc, vc);
            // The shift continued across the border by the parabola through its values at the
            // border and SLOPE_PX and 2·SLOPE_PX inside (a straight line, or a constant, where
            // those pixels have no phase).
            let along = |du: isize, dv: isize, dist: f64| -> f64 {
                let at = |k: isize| {
                    let (a, b) = (uc as isize + du * k, vc as isize + dv * k);
                    if (0..w as isize).contains(&a) && (0..h as isize).contains(&b) {
                        shift(a as usize, b as usize)
                    } else {
                        f64::NAN
                    }
                };
                let (d1, d2, k) = (at(SLOPE_PX), at(2 * SLOPE_PX), SLOPE_PX as f64);
                let q = d0
                    + dist * (3.0 * d0 - 4.0 * d1 + d2) / (2.0 * k)
                    + dist * dist * (d0 - 2.0 * d1 + d2) / (2.0 * k * k);
                let l = d0 + dist * (d0 - d1) / k;
                if q.is_finite() {
                    q - d0
                } else if l.is_finite() {
                    l - d0
                } else {
                    0.0
                }
            };
            let (out_u, out_v) = ((u - uc as isize).abs(), (v - vc as isize).abs());
            let mut d = d0;
            if out_u > 0 {
                d += along((uc as isize - u).signum(), 0, out_u as f64);
            }
            if out_v > 0 {
                d += along(0, (vc as isize - v).signum(), out_v as f64);
            }
            let x = f64::from(virt[j * mw + i]) + d;
            if x.is_finite() {
                map[j * mw + i] = x as f32;
                seam = seam.max(d0.abs());
            }
        }
    }
    Ok(Extended {
        map,
        seam_rad: seam,
    })
}

/// `Err` when a margin past the image is requested that a capture cannot have: without the
/// calibration's projector model, or for the raw capture (`model` false).
pub(crate) fn check_request(
    calibration: &Calibration,
    model: bool,
    requested: Option<Margin>,
) -> Result<(), String> {
    if let Some(m) = requested
        && m.to_array().iter().any(|&x| x > MAX_MARGIN)
    {
        return Err(format!(
            "--margin: at most {MAX_MARGIN} pixels per side, got {:?}",
            m.to_array()
        ));
    }
    if requested == Some(Margin::ZERO) || (calibration.projector.is_some() && model) {
        Ok(())
    } else if !model {
        Err("--margin extends the model fitted to the capture: --raw writes the capture itself, which ends at the image".into())
    } else {
        Err("--margin extends the model fitted to the capture with the projector model: the calibration has no [projector] section (a capture alone ends at the image)".into())
    }
}

/// The map `calibrate reference` writes for a capture: `fitted` extended by `requested` (`None`:
/// what the geometry needs with the reference on `plane`, [`margin_needed`]), which needs the map
/// to be the fitted model (`model`) and the calibration to hold the projector and the plane the
/// fringes show (`fringes_plane`). `Err` with the message for a margin requested where it cannot
/// be made, or a geometry that gives none.
pub(crate) fn capture_map(
    calibration: &Calibration,
    set: &PatternSet,
    fitted: Vec<f32>,
    (plane, fringes_plane): (([f64; 3], [f64; 3]), Option<([f64; 3], [f64; 3])>),
    model: bool,
    requested: Option<Margin>,
) -> Result<(Vec<f32>, Margin, Option<f64>), String> {
    check_request(calibration, model, requested)?;
    let (Some(projector), Some(fringes_plane), true) =
        (&calibration.projector, fringes_plane, model)
    else {
        return Ok((fitted, Margin::ZERO, None));
    };
    let margin = match requested {
        Some(m) => m,
        None => margin_needed(calibration, set, plane)
            .map_err(|m| format!("the margin past the image: the scan geometry: {m}"))?,
    };
    if margin.to_array().iter().any(|&m| m > MAX_MARGIN) {
        return Err(format!(
            "a margin of at most {MAX_MARGIN} pixels per side, got {:?}",
            margin.to_array()
        ));
    }
    let e = extend_fitted_map(
        &calibration.camera,
        projector,
        set,
        &fitted,
        fringes_plane,
        margin,
    )
    .map_err(|e| format!("the margin past the image: {e}"))?;
    Ok((
        e.map,
        margin,
        (margin != Margin::ZERO).then_some(e.seam_rad),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::rig::default_rig;
    use fringe3d_core::pattern::Output;
    use fringe3d_core::phase_function::{Axis, PhaseFunction};

    /// On the exact geometry (the renderer's rig), a fitted map equal to the virtual map plus a
    /// shift quadratic in u and in v is extended by the virtual map plus that same shift: the
    /// parabola continues it exactly, along rows, columns and into the corners.
    #[test]
    fn the_margin_continues_the_fitted_map() {
        let rig = default_rig().with_camera_size(160, 128);
        let cal = rig.calibration(None, None, None);
        let (camera, projector) = (cal.camera, cal.projector.expect("the rig's projector"));
        let out = Output {
            width: projector.intrinsics.width,
            height: projector.intrinsics.height,
            i_min: 0.0,
            i_max: 255.0,
        };
        let f = PhaseFunction::centered(Axis::Xi, out.width, 0.85 * std::f64::consts::TAU)
            .expect("function");
        let set = PatternSet::paper_eight(f, 8.0, out).expect("set");
        // A plane at 600 mm: the projector lights the whole image and its corners' margins.
        let plane = ([0.0, 0.0, 600.0], [0.0, 0.0, -1.0]);
        let margin = Margin::from_array([12, 3, 7, 5]);
        let (w, h) = (160usize, 128usize);
        let shift = |u: f64, v: f64| 0.25 + 2e-3 * u - 6e-6 * u * u - 1e-3 * v + 8e-6 * v * v;
        let image = virtual_reference(&camera, &projector, &set, plane, Margin::ZERO).unwrap();
        let fitted: Vec<f32> = image
            .iter()
            .enumerate()
            .map(|(k, p)| (f64::from(*p) + shift((k % w) as f64, (k / w) as f64)) as f32)
            .collect();
        let e = extend_fitted_map(&camera, &projector, &set, &fitted, plane, margin).unwrap();
        let wide = virtual_reference(&camera, &projector, &set, plane, margin).unwrap();
        let mw = w + 19;
        let (mut compared, mut corners, mut worst) = (0, 0, 0.0f64);
        for (k, (a, b)) in e.map.iter().zip(&wide).enumerate() {
            let (u, v) = ((k % mw) as isize - 12, (k / mw) as isize - 3);
            let (out_u, out_v) = (!(0..w as isize).contains(&u), !(0..h as isize).contains(&v));
            if !out_u && !out_v {
                assert_eq!(a.to_bits(), fitted[v as usize * w + u as usize].to_bits());
            } else if b.is_finite() && a.is_finite() {
                // Where the parabola's seeds inside the image have a phase (elsewhere the
                // continuation is a straight line or a constant).
                let (uc, vc) = (u.clamp(0, w as isize - 1), v.clamp(0, h as isize - 1));
                let lit = |x: isize, y: isize| {
                    (0..w as isize).contains(&x)
                        && (0..h as isize).contains(&y)
                        && fitted[y as usize * w + x as usize].is_finite()
                };
                let (su, sv) = ((uc - u).signum(), (vc - v).signum());
                let seeds = (1..=2).all(|k| {
                    (!out_u || lit(uc + su * k * SLOPE_PX, vc))
                        && (!out_v || lit(uc, vc + sv * k * SLOPE_PX))
                });
                if !seeds {
                    continue;
                }
                let want = f64::from(*b) + shift(u as f64, v as f64);
                worst = worst.max((f64::from(*a) - want).abs());
                compared += 1;
                corners += usize::from(out_u && out_v);
            }
        }
        // f32 phases of up to ~120 rad: a few 1e-6 rad, amplified by the extrapolation.
        assert!(worst < 2e-4, "{worst} rad from the continued shift");
        assert!(
            compared > 1000 && corners > 20,
            "{compared} samples, {corners} in corners"
        );
        assert!((e.seam_rad - 0.55).abs() < 0.4, "{}", e.seam_rad);
        let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        let same = extend_fitted_map(&camera, &projector, &set, &fitted, plane, Margin::ZERO);
        assert!(bits(&same.unwrap().map) == bits(&fitted));
    }
}
