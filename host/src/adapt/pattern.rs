//! From a pattern set to the design's [`Template`], and from a design back to a pattern-set file
//! (`kind = "knots"`, the template's levels, image order and projector kept).

use fringe3d_core::pattern::PatternSet;
use fringe3d_core::phase_function::Axis;

use super::{Adapted, Template};
use crate::io::pattern_file::{AxisName, PatternSetFile, PhaseKind, PhaseSection};

/// The template a design starts from: `set`'s finest scale, its base phase's span and slope per
/// projector column along its axis (on the middle line across it). `Err` for curved fringes
/// (the design makes straight ones).
pub fn template_of(set: &PatternSet) -> Result<Template, String> {
    let f = set.function();
    if f.curvature() != 0.0 {
        return Err(
            "the template bends its fringes (curvature); adapt designs the fringe width and any \
             bend itself: start from a straight set"
                .into(),
        );
    }
    let (phi, finest, extent) = base_phase(set);
    let extent = extent as u32;
    let slopes = (0..extent)
        .map(|c| {
            let c = f64::from(c);
            let (a, b) = ((c - 0.5).max(0.0), (c + 0.5).min(f64::from(extent) - 1.0));
            (phi(b) - phi(a)) / (b - a)
        })
        .collect();
    Ok(Template {
        extent,
        finest,
        span: phi(f64::from(extent) - 1.0) - phi(0.0),
        slopes,
    })
}

/// `set`'s base phase Φ along its axis (on the middle line across it), its finest scale and its
/// extent along the axis, pixels.
pub fn base_phase(set: &PatternSet) -> (impl Fn(f64) -> f64 + Sync + '_, f64, f64) {
    let f = set.function();
    let o = set.output();
    let (extent, across) = match set.axis() {
        Axis::Xi => (o.width, o.height),
        Axis::Eta => (o.height, o.width),
    };
    let mid = (f64::from(across) - 1.0) / 2.0;
    let axis = set.axis();
    let phi = move |t: f64| match axis {
        Axis::Xi => f.eval(t, mid),
        Axis::Eta => f.eval(mid, t),
    };
    let finest = set
        .levels()
        .iter()
        .map(|l| l.scale())
        .fold(0.0f64, f64::max);
    (phi, finest, f64::from(extent))
}

/// `x > 0` rounded down to 6 significant digits (a readable file whose span stays within the
/// design's).
fn round_down(x: f64) -> f64 {
    let unit = 10f64.powi(x.log10().floor() as i32 - 5);
    (x / unit).floor() * unit
}

/// The pattern-set file of `design`: `template` with its phase function replaced by the designed
/// knots (centred, `phase0` absent), its levels, order and projector kept (its `images` list,
/// which names the template's captures, dropped).
pub fn adapted_file(template: &PatternSetFile, axis: Axis, design: &Adapted) -> PatternSetFile {
    bent_file(template, axis, design, None)
}

/// [`adapted_file`] with curved fringes `(curvature, bend_center)` (the design made on the bent
/// coordinate, [`crate::adapt::surface::Rig::with_bend`]).
pub fn bent_file(
    template: &PatternSetFile,
    axis: Axis,
    design: &Adapted,
    bend: Option<(f64, f64)>,
) -> PatternSetFile {
    let mut f = template.clone();
    // Another set's images: a dataset's list names the template's captures, not these.
    f.images = None;
    f.phase = Some(PhaseSection {
        axis: Some(match axis {
            Axis::Xi => AxisName::Xi,
            Axis::Eta => AxisName::Eta,
        }),
        kind: Some(PhaseKind::Knots),
        positions: Some(design.positions.clone()),
        slopes: Some(design.slopes.iter().map(|&s| round_down(s)).collect()),
        curvature: bend.map(|b| b.0),
        bend_center: bend.map(|b| b.1),
        ..PhaseSection::default()
    });
    f
}
