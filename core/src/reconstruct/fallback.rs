//! The fallback search of a pixel the fast path did not settle (rare): the ends of the depth
//! interval, the closest valid bracket of the crossing, a fixed number of bisections and two
//! regula-falsi steps.

use crate::math::CANONICAL_NAN;
use crate::validity::Validity;

/// The bracketed search over `[tlo, thi]` for a pixel the fast path did not settle.
///
/// `ends` are the samples at `tlo` and `thi`, `known` other samples `(t, g)` already taken (NaN g
/// where unusable). Returns the crossing `t`, or the reason there is none.
pub(super) fn fallback<F: Fn(f32) -> f32>(
    eval: F,
    tlo: f32,
    thi: f32,
    ends: (f32, f32),
    known: &[(f32, f32)],
    bisections: u32,
) -> Result<f32, Validity> {
    let (glo, ghi) = ends;
    let (mut ta, mut ga, mut tb, mut gb);
    if glo.is_finite() && ghi.is_finite() {
        if (glo < 0.0) == (ghi < 0.0) {
            return Err(Validity::OutOfDepth);
        }
        (ta, ga, tb, gb) = (tlo, glo, thi, ghi);
    } else {
        let mut cands = [(0f32, CANONICAL_NAN); 10];
        cands[0] = (tlo, glo);
        cands[1] = (thi, ghi);
        for (dst, src) in cands[2..8].iter_mut().zip(known) {
            *dst = *src;
        }
        let found = match bracket(&cands[..8], tlo, thi) {
            Err(Validity::NoCrossing) => {
                // Every valid sample has the same sign: the crossing may lie between them and an
                // end of the interval that is off the map (or on an invalid patch). Clip the
                // interval to the valid samples' extent: from the valid sample nearest to each
                // invalid end, bisect towards it on validity (the same fixed count as the
                // bracket's bisection, so within a quarter pixel of where the map ends), and
                // look again with the last valid sample found.
                cands[8] = clip(&eval, &cands[..8], tlo, thi, glo, bisections, true);
                cands[9] = clip(&eval, &cands[..8], tlo, thi, ghi, bisections, false);
                bracket(&cands, tlo, thi)
            }
            other => other,
        };
        (ta, ga, tb, gb) = found?;
    }
    // Orient so that ga < 0 ≤ gb.
    if ga >= 0.0 {
        core::mem::swap(&mut ta, &mut tb);
        core::mem::swap(&mut ga, &mut gb);
    }
    if !(ga < 0.0 && gb >= 0.0) {
        return Err(Validity::NoCrossing);
    }
    for _ in 0..bisections {
        let tm = 0.5 * (ta + tb);
        let gm = eval(tm);
        if !gm.is_finite() {
            return Err(Validity::ReferenceInvalid);
        }
        if gm < 0.0 {
            (ta, ga) = (tm, gm);
        } else {
            (tb, gb) = (tm, gm);
        }
    }
    let mut tm = ta;
    for _ in 0..2 {
        tm = ta - ga * (tb - ta) / (gb - ga);
        let gm = eval(tm);
        if !gm.is_finite() {
            return Err(Validity::ReferenceInvalid);
        }
        if gm < 0.0 {
            (ta, ga) = (tm, gm);
        } else {
            (tb, gb) = (tm, gm);
        }
    }
    if tm.is_finite() {
        Ok(tm)
    } else {
        Err(Validity::NoCrossing)
    }
}

/// The innermost bracket `(ta, ga, tb, gb)` of the crossing among the valid samples `cands`
/// inside `[tlo, thi]`: with a monotonic phase, the valid samples below the phase lie on one side
/// of those at or above it. `NoCrossing` when all have one sign (or they are not monotonic),
/// `ReferenceInvalid` when none is valid.
fn bracket(cands: &[(f32, f32)], tlo: f32, thi: f32) -> Result<(f32, f32, f32, f32), Validity> {
    let (mut neg_lo, mut neg_hi) = ((f32::INFINITY, 0f32), (f32::NEG_INFINITY, 0f32));
    let (mut pos_lo, mut pos_hi) = ((f32::INFINITY, 0f32), (f32::NEG_INFINITY, 0f32));
    let mut any = false;
    for &(tc, gc) in cands {
        if !gc.is_finite() || !(tlo..=thi).contains(&tc) {
            continue;
        }
        any = true;
        let (lo, hi) = if gc < 0.0 {
            (&mut neg_lo, &mut neg_hi)
        } else {
            (&mut pos_lo, &mut pos_hi)
        };
        if tc < lo.0 {
            *lo = (tc, gc);
        }
        if tc > hi.0 {
            *hi = (tc, gc);
        }
    }
    if !(neg_lo.0.is_finite() && pos_lo.0.is_finite()) {
        return Err(if any {
            Validity::NoCrossing
        } else {
            Validity::ReferenceInvalid
        });
    }
    if neg_hi.0 < pos_lo.0 {
        Ok((neg_hi.0, neg_hi.1, pos_lo.0, pos_lo.1))
    } else if pos_hi.0 < neg_lo.0 {
        Ok((neg_lo.0, neg_lo.1, pos_hi.0, pos_hi.1))
    } else {
        Err(Validity::NoCrossing) // not monotonic along the segment
    }
}

/// The last valid sample towards the low (`low`) or high end of `[tlo, thi]` whose own sample
/// `g_end` is invalid: `steps` bisections on validity between the valid sample nearest to that
/// end and the end. `(0, NaN)` when the end is valid or no sample is.
fn clip<F: Fn(f32) -> f32>(
    eval: &F,
    cands: &[(f32, f32)],
    tlo: f32,
    thi: f32,
    g_end: f32,
    steps: u32,
    low: bool,
) -> (f32, f32) {
    const NONE: (f32, f32) = (0.0, CANONICAL_NAN);
    if g_end.is_finite() {
        return NONE;
    }
    let mut anchor = NONE;
    for &(tc, gc) in cands {
        if gc.is_finite()
            && (tlo..=thi).contains(&tc)
            && (!anchor.1.is_finite() || (tc < anchor.0) == low)
        {
            anchor = (tc, gc);
        }
    }
    if !anchor.1.is_finite() {
        return NONE;
    }
    let (mut good, mut bad) = (anchor, if low { tlo } else { thi });
    for _ in 0..steps {
        let tm = 0.5 * (good.0 + bad);
        let gm = eval(tm);
        if gm.is_finite() {
            good = (tm, gm);
        } else {
            bad = tm;
        }
    }
    good
}
