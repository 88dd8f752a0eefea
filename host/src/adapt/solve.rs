//! The design's optimisation (see [`super`]): the knot slopes that minimise the object's mean
//! squared point error within the camera, projector, span and floor constraints.

use std::f64::consts::TAU;

use super::{
    AdaptError, Adapted, Binding, Goal, Region, Sample, Template, camera_period, contrast,
    log_contrast_rate, optics_contrast, point_variance, predict, slope_at,
};

/// Coordinate-descent sweeps per multiplier.
const SWEEPS: usize = 30;
/// Bisection steps of one knot's slope.
const KNOT_STEPS: usize = 50;
/// Bisection steps of the multiplier's logarithm.
const LAMBDA_STEPS: usize = 80;

/// The object's pixels per projector column.
struct Columns {
    /// Summed weight per column.
    weight: Vec<f64>,
    /// Pixels per column.
    count: Vec<usize>,
    /// The goal's percentile of `|∇ξ|` per column (0 where no pixel).
    grad: Vec<f64>,
    /// The weighted mean `|∇ξ|` per column (its camera blur's loss in the objective).
    mean_grad: Vec<f64>,
}

fn quantile(mut v: Vec<f64>, q: f64, empty: f64) -> f64 {
    if v.is_empty() {
        return empty;
    }
    v.sort_by(f64::total_cmp);
    v[(((v.len() - 1) as f64) * q).round() as usize]
}

fn columns(samples: &[Sample], extent: usize, percentile: f64) -> Columns {
    let mut grads: Vec<Vec<f64>> = vec![Vec::new(); extent];
    let mut weight = vec![0.0; extent];
    let mut wg = vec![0.0; extent];
    for s in samples {
        let c = column(s.along, extent);
        weight[c] += s.weight;
        wg[c] += s.weight * s.grad;
        grads[c].push(s.grad);
    }
    let count = grads.iter().map(Vec::len).collect();
    let mean_grad = wg
        .iter()
        .zip(&weight)
        .map(|(&a, &w)| if w > 0.0 { a / w } else { 0.0 })
        .collect();
    let grad = grads
        .into_iter()
        .map(|g| quantile(g, percentile, 0.0))
        .collect();
    Columns {
        weight,
        count,
        grad,
        mean_grad,
    }
}

/// The largest slope pixel `s` resolves: its camera period and the projector's at least the
/// goal's, and the contrast the optics pass at least `min_contrast` and, with the noise known,
/// enough for the needed B/σ given its light (`bright_ref`: the brightest surface's). 0 when no
/// slope does.
fn slope_limit(s: &Sample, finest: f64, g: &Goal, bright_ref: f64) -> f64 {
    let need = match g.snr {
        Some(n) => (n.needed / (n.brightest * s.bright / bright_ref)).max(g.min_contrast),
        None => g.min_contrast,
    };
    if !(need < 1.0) {
        return 0.0;
    }
    let hard = (TAU / (finest * g.min_camera_period * s.grad))
        .min(TAU / (finest * g.min_projector_period));
    let passes = |k: f64| {
        let p = TAU / (finest * k);
        contrast(p, g.projector_blur) * contrast(p / s.grad, g.camera_blur) >= need
    };
    if passes(hard) {
        return hard;
    }
    // The contrast falls as the slope grows: bisect in (0, hard].
    let (mut a, mut b) = (0.0, hard);
    for _ in 0..60 {
        let m = 0.5 * (a + b);
        if passes(m) {
            a = m;
        } else {
            b = m;
        }
    }
    a
}

fn column(along: f64, extent: usize) -> usize {
    (along.round().max(0.0) as usize).min(extent - 1)
}

/// Check a goal and a template before any object is read; the messages name the `adapt` flags.
pub fn check(t: &Template, g: &Goal) -> Result<(), AdaptError> {
    let bad = |m: &str| Err(AdaptError::Parameter(m.into()));
    let max = (fringe3d_core::phase_function::MAX_KNOTS).min(t.extent as usize);
    if !(2..=max).contains(&g.knots) {
        return bad(&format!("--knots: 2 to {max}, got {}", g.knots));
    }
    // Below a period of 2 the fringes alias (and the contrast model no longer falls with the
    // slope); the core refuses finest phases that step more than π/2 per projector pixel.
    if !(g.min_camera_period.is_finite() && g.min_camera_period >= 2.0) {
        return bad("--min-period: at least 2 camera pixels (Nyquist)");
    }
    if !(g.min_projector_period.is_finite() && g.min_projector_period >= 4.0) {
        return bad("--min-projector-period: at least 4 projector pixels (the core's limit)");
    }
    if !(g.projector_blur.is_finite()
        && g.projector_blur >= 0.0
        && g.camera_blur.is_finite()
        && g.camera_blur >= 0.0)
    {
        return bad("--projector-blur and --camera-blur: finite and at least 0");
    }
    if !(g.min_contrast >= 0.0 && g.min_contrast < 1.0) {
        return bad("--min-contrast: in [0, 1)");
    }
    if let Some(n) = g.snr
        && !(n.brightest.is_finite() && n.brightest > 0.0 && n.needed.is_finite() && n.needed > 0.0)
    {
        return bad("--snr / --noise: B/sigma must be positive");
    }
    if !(g.floor > 0.0 && g.floor <= 1.0) {
        return bad("--floor: in (0, 1]");
    }
    if !(g.percentile >= 0.5 && g.percentile <= 1.0) {
        return bad("the percentile must be in [0.5, 1]");
    }
    if !(g.max_unresolvable >= 0.0 && g.max_unresolvable < 1.0) {
        return bad("the largest unresolvable fraction must be in [0, 1)");
    }
    let finite_pos = |x: f64| x.is_finite() && x > 0.0;
    if t.extent < 2 || t.slopes.len() != t.extent as usize {
        return bad("the template needs one slope per projector column");
    }
    if !(finite_pos(t.finest) && finite_pos(t.span) && t.slopes.iter().all(|&s| finite_pos(s))) {
        return bad("the template's scales, span and slopes must be positive");
    }
    Ok(())
}

/// Design the slope profile for `samples` (see [`super`]).
pub fn solve(samples: &[Sample], t: &Template, g: &Goal) -> Result<Adapted, AdaptError> {
    check(t, g)?;
    let extent = t.extent as usize;
    let on = |s: &&Sample| {
        s.along.is_finite()
            && s.along >= -0.5
            && s.along <= extent as f64 - 0.5
            && s.grad.is_finite()
            && s.grad > 0.0
            && s.weight.is_finite()
            && s.weight > 0.0
    };
    let samples: Vec<Sample> = samples.iter().filter(on).copied().collect();
    if samples.len() < g.min_samples {
        return Err(AdaptError::TooFewSamples {
            found: samples.len(),
            need: g.min_samples,
        });
    }
    let bright_ref = quantile(
        samples.iter().map(|s| s.bright).collect(),
        g.percentile,
        1.0,
    );
    let limits: Vec<f64> = samples
        .iter()
        .map(|s| slope_limit(s, t.finest, g, bright_ref))
        .collect();
    let last = (extent - 1) as f64;
    let lo = g.floor * t.span / last;
    let cols = columns(&samples, extent, g.percentile);
    let proj_max = TAU / (t.finest * g.min_projector_period);
    if lo > proj_max {
        return Err(AdaptError::ProjectorBinds {
            floor: lo,
            period: TAU / (t.finest * lo),
            need: g.min_projector_period,
        });
    }
    camera_feasible(&samples, &limits, &cols, g, lo)?;

    let k = g.knots;
    let positions: Vec<f64> = (0..k)
        .map(|i| (last * i as f64 / (k - 1) as f64).round())
        .collect();
    // Each knot interval's bound: the slope all but the goal's share of its pixels resolve
    // (pixels no slope above the floor resolves are lost anyway and left out); a knot takes the
    // lesser of its two intervals', so that the linear profile stays under both.
    let mut pooled: Vec<Vec<f64>> = vec![Vec::new(); k - 1];
    for (s, &l) in samples.iter().zip(&limits) {
        if l >= lo {
            let j = positions.partition_point(|&p| p <= s.along).clamp(1, k - 1) - 1;
            pooled[j].push(l);
        }
    }
    let interval: Vec<f64> = pooled
        .into_iter()
        .map(|v| quantile(v, 1.0 - g.percentile, f64::INFINITY))
        .collect();
    let (mut hi, mut camera_bound) = (vec![0.0; k], vec![false; k]);
    for i in 0..k {
        let left = if i == 0 {
            f64::INFINITY
        } else {
            interval[i - 1]
        };
        let right = interval.get(i).copied().unwrap_or(f64::INFINITY);
        let pixels = left.min(right);
        hi[i] = pixels.min(proj_max).max(lo);
        camera_bound[i] = pixels < proj_max;
    }
    let trapezoid = |m: &[f64]| {
        (1..k)
            .map(|i| 0.5 * (m[i - 1] + m[i]) * (positions[i] - positions[i - 1]))
            .sum::<f64>()
    };
    let problem = Problem::new(
        &positions,
        &cols.weight,
        &cols.mean_grad,
        (t.finest, g),
        (lo, proj_max.max(lo)),
    );
    let slopes = if trapezoid(&hi) <= t.span {
        hi.clone()
    } else {
        // Span(m(λ)) falls as λ grows: bisect log λ, keeping the side within the span.
        let mut m: Vec<f64> = hi.iter().map(|&h| (t.span / last).clamp(lo, h)).collect();
        let (mut a, mut b) = (-40.0f64, 40.0f64);
        let mut best = vec![lo; k];
        for _ in 0..LAMBDA_STEPS {
            let mid = 0.5 * (a + b);
            problem.descend(&mut m, 10f64.powf(mid), lo, &hi);
            if trapezoid(&m) > t.span {
                a = mid;
            } else {
                best.clone_from(&m);
                b = mid;
            }
        }
        best
    };
    let span = trapezoid(&slopes);

    let fixed_slope = |x: f64| t.slopes[column(x, extent)];
    let design_slope = |x: f64| slope_at(&positions, &slopes, x);
    let period_at = |slope: &dyn Fn(f64) -> f64| {
        (0..extent)
            .filter(|&c| cols.count[c] > 0)
            .map(|c| camera_period(t.finest, slope(c as f64), cols.grad[c]))
            .fold(f64::INFINITY, f64::min)
    };
    let fixed = predict(
        &samples,
        &limits,
        t.finest,
        period_at(&fixed_slope),
        g,
        fixed_slope,
    );
    let adaptive = predict(
        &samples,
        &limits,
        t.finest,
        period_at(&design_slope),
        g,
        design_slope,
    );
    let binding = |i: usize| {
        if slopes[i] >= hi[i] * (1.0 - 1e-9) && hi[i] > lo {
            if camera_bound[i] {
                Binding::Camera
            } else {
                Binding::Projector
            }
        } else if slopes[i] <= lo * (1.0 + 1e-9) {
            Binding::Floor
        } else {
            Binding::Span
        }
    };
    let mut regions = Vec::new();
    for i in 1..k {
        let (a, b) = (positions[i - 1], positions[i]);
        let inside: Vec<&Sample> = samples
            .iter()
            .filter(|s| s.along >= a && (s.along < b || (i + 1 == k && s.along <= b + 0.5)))
            .collect();
        if inside.is_empty() {
            continue;
        }
        let err = |f: &dyn Fn(f64) -> f64| {
            inside
                .iter()
                .map(|s| point_variance(s, f(s.along), t.finest, g))
                .sum::<f64>()
        };
        let centre = inside.iter().map(|s| s.along).sum::<f64>() / inside.len() as f64;
        let last_column = if i + 1 == k { b } else { b - 1.0 };
        regions.push(Region {
            columns: (a as u32, last_column as u32),
            pixels: inside.len(),
            gain: (err(&fixed_slope) / err(&design_slope)).sqrt(),
            binding: binding(if centre - a < b - centre { i - 1 } else { i }),
        });
    }
    Ok(Adapted {
        positions,
        slopes,
        span,
        fixed,
        adaptive,
        regions,
        samples: samples.len(),
    })
}

/// Refuse a design whose object has more than the goal's share of pixels that no slope at or
/// above the floor resolves, naming the columns that hold most of them.
fn camera_feasible(
    samples: &[Sample],
    limits: &[f64],
    cols: &Columns,
    g: &Goal,
    lo: f64,
) -> Result<(), AdaptError> {
    let extent = cols.count.len();
    let mut lost = vec![0usize; extent];
    let mut dim = 0usize;
    for (s, &l) in samples.iter().zip(limits) {
        if l < lo {
            lost[column(s.along, extent)] += 1;
            // A limit of 0: too dim for the needed B/σ at any slope.
            dim += usize::from(l == 0.0);
        }
    }
    let total: usize = lost.iter().sum();
    if (total as f64) <= g.max_unresolvable * samples.len() as f64 {
        return Ok(());
    }
    // The run of columns with lost pixels that holds the most of them.
    let (mut best, mut run) = ((0, 0, 0usize), None::<(usize, usize)>);
    for c in 0..=extent {
        match (run, c < extent && lost[c] > 0) {
            (None, true) => run = Some((c, lost[c])),
            (Some((a, n)), true) => run = Some((a, n + lost[c])),
            (Some((a, n)), false) => {
                if n > best.2 {
                    best = (a, c - 1, n);
                }
                run = None;
            }
            (None, false) => {}
        }
    }
    let columns = (best.0 as u32, best.1 as u32);
    let share = total as f64 / samples.len() as f64;
    match g.snr {
        Some(n) if 2 * dim > total => Err(AdaptError::NoiseBinds {
            columns,
            share,
            needed: n.needed,
            brightest: n.brightest,
        }),
        _ => Err(AdaptError::CameraBinds {
            columns,
            share,
            floor: lo,
        }),
    }
}

/// Points of a column's table of the objective's derivative, over `ln s`.
const TABLE: usize = 512;

/// The objective `Σ_c W_c / (s(c)·C_c(s(c)))²` as seen by each knot (`C_c` the contrast the
/// optics pass at column c's slope and mean gradient, [`optics_contrast`]): the weighted columns
/// in its two intervals, with their hat weight and the other knot of the interval. Each term is
/// convex in s over the slopes the camera and projector limits allow (for a Gaussian blur alone
/// `s⁻²·exp(2ks²)` has a positive second derivative everywhere), so the knot subproblems stay
/// unimodal. The derivative `−2(1/s + d ln C/ds)/(s·C)²` of each column's term per unit weight
/// is tabulated over `ln s` from the floor to the projector's limit (the only slopes a knot
/// takes) and interpolated: the descent evaluates it millions of times.
struct Problem {
    /// Per knot: `(weight, hat weight b, other knot, table)` of each column with pixels.
    terms: Vec<Vec<(f64, f64, usize, usize)>>,
    /// Per knot: `∂span/∂m_k`.
    span_rate: Vec<f64>,
    /// The derivative tables, one per column with pixels, over `ln s` in `[ln lo, ln hi]`.
    tables: Vec<[f64; TABLE]>,
    /// `ln lo` and the table's step in `ln s`.
    ln_lo: f64,
    step: f64,
}

impl Problem {
    fn new(
        positions: &[f64],
        weight: &[f64],
        grad: &[f64],
        (finest, goal): (f64, &Goal),
        (lo, hi): (f64, f64),
    ) -> Problem {
        let (ln_lo, ln_hi) = (lo.ln(), hi.max(lo * (1.0 + 1e-9)).ln());
        let step = (ln_hi - ln_lo) / (TABLE - 1) as f64;
        let mut tables = Vec::new();
        let mut table_of = vec![usize::MAX; weight.len()];
        for (c, &w) in weight.iter().enumerate() {
            if w > 0.0 {
                table_of[c] = tables.len();
                tables.push(std::array::from_fn(|k| {
                    let s = (ln_lo + step * k as f64).exp();
                    let cc = optics_contrast(finest, s, grad[c], goal);
                    let rate = 1.0 / s + log_contrast_rate(finest, s, grad[c], goal);
                    -2.0 * rate / (s * s * cc * cc)
                }));
            }
        }
        let k = positions.len();
        let mut terms = vec![Vec::new(); k];
        let mut span_rate = vec![0.0; k];
        for i in 1..k {
            let (a, b) = (positions[i - 1], positions[i]);
            let d = b - a;
            span_rate[i - 1] += 0.5 * d;
            span_rate[i] += 0.5 * d;
            for (c, &w) in weight.iter().enumerate() {
                let x = c as f64;
                // Each column belongs to one interval (the last takes its right end).
                if w > 0.0 && x >= a && (x < b || (i + 1 == k && x <= b)) {
                    let f = (x - a) / d;
                    terms[i - 1].push((w, 1.0 - f, i, table_of[c]));
                    terms[i].push((w, f, i - 1, table_of[c]));
                }
            }
        }
        Problem {
            terms,
            span_rate,
            tables,
            ln_lo,
            step,
        }
    }

    /// A column's derivative per unit weight at slope `s` (linear in `ln s` between the table's
    /// points, the ends held beyond them).
    fn rate(&self, table: usize, s: f64) -> f64 {
        let t = &self.tables[table];
        let x = ((s.ln() - self.ln_lo) / self.step).clamp(0.0, (TABLE - 1) as f64);
        let i = (x as usize).min(TABLE - 2);
        let f = x - i as f64;
        t[i] * (1.0 - f) + t[i + 1] * f
    }

    /// Minimise `Σ W/(s·C)² + λ·span` over the knots within `[lo, hi_k]`, starting from `m`.
    fn descend(&self, m: &mut [f64], lambda: f64, lo: f64, hi: &[f64]) {
        for _ in 0..SWEEPS {
            for i in 0..m.len() {
                // d/ds of W/(s·C(s))² is −2W/(s·C)²·(1/s + d ln C/ds), tabulated.
                let grad = |x: f64| {
                    let mut d = lambda * self.span_rate[i];
                    for &(w, b, j, table) in &self.terms[i] {
                        let s = b * x + (1.0 - b) * m[j];
                        d += w * b * self.rate(table, s);
                    }
                    d
                };
                m[i] = if grad(hi[i]) <= 0.0 {
                    hi[i]
                } else if grad(lo) >= 0.0 {
                    lo
                } else {
                    let (mut a, mut b) = (lo, hi[i]);
                    for _ in 0..KNOT_STEPS {
                        let mid = 0.5 * (a + b);
                        if grad(mid) < 0.0 {
                            a = mid;
                        } else {
                            b = mid;
                        }
                    }
                    0.5 * (a + b)
                };
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A template of 1024 columns, finest scale 64, the default span, linear.
    fn template() -> Template {
        let span = 0.9 * TAU;
        Template {
            extent: 1024,
            finest: 64.0,
            span,
            slopes: vec![span / 1023.0; 1024],
        }
    }

    /// Uniform pixels over columns `a..b`, 20 per column, of image gradient `grad`.
    fn object(a: usize, b: usize, grad: f64) -> Vec<Sample> {
        (a..b)
            .flat_map(|c| {
                (0..20).map(move |k| Sample {
                    along: c as f64 + 0.05 * k as f64 - 0.5,
                    grad,
                    weight: 1.0,
                    bright: 1.0,
                })
            })
            .collect()
    }

    /// The least limits the goal accepts (none binds these objects but the span).
    fn loose() -> Goal {
        Goal {
            min_contrast: 0.0,
            min_projector_period: 4.0,
            min_camera_period: 2.0,
            ..Goal::default()
        }
    }

    fn objective(d: &Adapted, s: &[Sample], g: &Goal) -> f64 {
        s.iter()
            .map(|x| point_variance(x, slope_at(&d.positions, &d.slopes, x.along), 64.0, g))
            .sum()
    }

    #[test]
    fn the_budget_goes_to_the_object_and_no_move_improves_it() {
        let (t, g) = (template(), loose());
        let s = object(300, 700, 0.5);
        let d = solve(&s, &t, &g).unwrap();
        // The span is the template's (the budget binds), the object's knots hold most of it
        // (not evenly: with a linear profile the knots next to the object's edges carry its edge
        // pixels too), and the knots far from it sit at the floor.
        assert!(
            (d.span - t.span).abs() < 1e-6 * t.span,
            "{} {}",
            d.span,
            t.span
        );
        let floor = g.floor * t.span / 1023.0;
        let inside: Vec<f64> = (0..16)
            .filter(|&i| d.positions[i] >= 341.0 && d.positions[i] <= 614.0)
            .map(|i| d.slopes[i])
            .collect();
        let (lo, hi) = inside
            .iter()
            .fold((f64::INFINITY, 0.0f64), |(a, b), &x| (a.min(x), b.max(x)));
        assert!(hi / lo < 1.5, "{inside:?}");
        assert!(lo > 2.0 * t.slopes[0], "{inside:?}");
        for i in [0, 1, 2, 13, 14, 15] {
            assert!(
                (d.slopes[i] - floor).abs() < 1e-12,
                "knot {i}: {}",
                d.slopes[i]
            );
        }
        // Optimality, checked independently of the solver: moving slope between any two knots
        // while keeping the span (and the bounds) never lowers the objective.
        let base = objective(&d, &s, &g);
        let width = |i: usize| {
            let l = if i > 0 {
                d.positions[i] - d.positions[i - 1]
            } else {
                0.0
            };
            let r = if i < 15 {
                d.positions[i + 1] - d.positions[i]
            } else {
                0.0
            };
            0.5 * (l + r)
        };
        for i in 0..16 {
            for j in 0..16 {
                let e = 1e-3 * d.slopes[i];
                let mut m = d.clone();
                m.slopes[i] += e;
                m.slopes[j] -= e * width(i) / width(j);
                if i == j || m.slopes[j] < floor {
                    continue;
                }
                assert!(
                    objective(&m, &s, &g) >= base * (1.0 - 1e-9),
                    "move {i} -> {j}"
                );
            }
        }
        // The predictions follow: the template's error over the design's. The object's slope
        // is about 2.5 times the template's, its finest period ~7 instead of ~18 projector
        // pixels, where the projector's blur (σ 1 px) passes about 0.69 of the contrast instead
        // of 0.94: a gain of about 2.5 × 0.69 / 0.94 ≈ 1.8, not 2.5.
        let gain = d.fixed.rms_per_rad / d.adaptive.rms_per_rad;
        assert!(gain > 1.6 && gain < 2.2, "gain {gain}");
        assert_eq!(d.adaptive.unresolvable, 0.0);
    }

    #[test]
    fn a_steep_object_gets_the_camera_limit_and_keeps_its_pixels() {
        let t = template();
        let g = Goal {
            min_camera_period: 5.0,
            ..loose()
        };
        // 6 projector pixels per camera pixel: the camera allows 2π/(64·5·6) rad/px, well under
        // what the span could give the object.
        let s = object(400, 600, 6.0);
        let d = solve(&s, &t, &g).unwrap();
        let limit = TAU / (64.0 * 5.0 * 6.0);
        for i in (0..16).filter(|&i| d.positions[i] >= 409.0 && d.positions[i] <= 546.0) {
            assert!((d.slopes[i] - limit).abs() < 1e-9 * limit, "knot {i}");
        }
        assert!(d.span < t.span);
        assert_eq!(d.adaptive.unresolvable, 0.0);
        assert!(d.adaptive.min_camera_period >= 5.0 * (1.0 - 1e-9));
        // The template's fringes are too fine for that camera: it loses them all.
        assert_eq!(d.fixed.unresolvable, 1.0);
    }

    #[test]
    fn each_binding_constraint_is_named() {
        let t = template();
        let few = object(400, 410, 0.5);
        assert!(matches!(
            solve(&few, &t, &loose()),
            Err(AdaptError::TooFewSamples {
                found: 200,
                need: 1000
            })
        ));
        let s = object(300, 700, 0.5);
        let knots = Goal {
            knots: 17,
            ..loose()
        };
        assert!(matches!(
            solve(&s, &t, &knots),
            Err(AdaptError::Parameter(_))
        ));
        let proj = Goal {
            min_projector_period: 1e4,
            ..loose()
        };
        assert!(matches!(
            solve(&s, &t, &proj),
            Err(AdaptError::ProjectorBinds { .. })
        ));
        let cam = Goal {
            min_camera_period: 1e4,
            ..loose()
        };
        match solve(&s, &t, &cam) {
            Err(e @ AdaptError::CameraBinds { .. }) => {
                assert!(e.to_string().contains("columns 300 to 699"), "{e}");
            }
            r => panic!("{r:?}"),
        }
        let dim = Goal {
            snr: Some(super::super::Snr {
                brightest: 10.0,
                needed: 20.0,
            }),
            ..loose()
        };
        assert!(matches!(
            solve(&s, &t, &dim),
            Err(AdaptError::NoiseBinds { .. })
        ));
    }
}
