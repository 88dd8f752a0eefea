//! Eqs 16-18 written out in f64 ([`triangulate_eq16_18`]), the literal form of the kernel's
//! closed-form depth, for comparison and host use.

use super::setup::Setup;
use crate::geometry::Vec3;

/// Eqs 16-18 evaluated literally in f64, for reference and host use: the point M for the pixel
/// whose ideal normalized coordinates are `m_i` (M_I) and the crossing `n_i` (N_I).
///
/// `M_R = C + (CO_R·n / CM_I·n)·CM_I` and `N_R` likewise (eq 16), `Q = C + (CP·n / CM_I·n)·CM_I`
/// (eq 17), `M = Q + |PQ||QM_R| / (|PQ + M_R N_R| |CM_I|) · CM_I` (eq 18), with C = 0 and
/// `CM_I = (x, y, 1)`. The magnitudes of eq 18 are right for every point in front of the plane
/// through P parallel to the reference plane. `None` when a denominator vanishes.
pub fn triangulate_eq16_18(setup: &Setup, m_i: [f64; 2], n_i: [f64; 2]) -> Option<Vec3> {
    let n = setup.reference_normal;
    let cm = Vec3::new(m_i[0], m_i[1], 1.0);
    let cn = Vec3::new(n_i[0], n_i[1], 1.0);
    let dm = cm.dot(n);
    let dn = cn.dot(n);
    if dm == 0.0 || dn == 0.0 {
        return None;
    }
    let m_r = cm.scale(setup.reference_point.dot(n) / dm);
    let n_r = cn.scale(setup.reference_point.dot(n) / dn);
    let p = setup.projector_centre;
    let q = cm.scale(p.dot(n) / dm);
    let pq = q.sub(p);
    let den = pq.add(n_r.sub(m_r)).norm() * cm.norm();
    if !(den > 0.0) {
        return None;
    }
    let m = q.add(cm.scale(pq.norm() * m_r.sub(q).norm() / den));
    if m.is_finite() { Some(m) } else { None }
}
