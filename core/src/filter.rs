//! The edge filter: invalidate points that straddle a depth discontinuity or the edge of the
//! light.
//!
//! A camera pixel that sees two surfaces at once (the silhouette of an object in front of a
//! background) integrates two sinusoids of different phase; the decoded phase lies between them and
//! the reconstructed point floats between the surfaces ("flying pixel"). Such a point is wrong
//! however good the phase is, so it must not leave the scanner as valid.
//!
//! The test is local and needs one row above and below: a valid point `p` is flagged
//! [`Validity::DepthEdge`] when its depth differs from that of a valid 4-neighbour `q` by more than
//! a surface of slope `max_slope` (tangent of the largest accepted angle between the surface normal
//! and the viewing ray) would explain over one pixel:
//!
//! ```text
//! |z_p − z_q| > max_slope · z_p / f
//! ```
//!
//! (`z_p / f` is the pixel's footprint at that depth, f the focal length in pixels). Real surfaces
//! steeper than the limit are flagged too; their points are unreliable anyway (grazing incidence).
//!
//! **The edge of the light.** A camera pixel that straddles the edge of the projector's light (the
//! frame of the DMD on a background, a shadow's border, a black or saturated patch) integrates
//! the sinusoid over its lit part only, so its phase is that part's: biased by up to half a
//! pixel's change of phase, a systematic error of many noise σ (on the renderer's object scenes
//! at 16 bits, 0.3 to 1.5 mm where the noise is 20 to 90 µm). One of its 4-neighbours then lies
//! beyond the edge and is refused by the decoder for lack of light ([`Validity::Dark`],
//! [`Validity::LowModulation`]) or for clipping ([`Validity::Saturated`]): a valid point with such a
//! neighbour is flagged [`Validity::LightEdge`]. On the renderer's object scenes the interior pixels
//! it flags are ones the renderer's truth marks as not clean (none clean measured; the test allows
//! 0.5 %), whose errors were several noise σ (`tests/tests/reference_quality.rs`). A depth edge
//! wins where both hold.
//!
//! The filter reads the input validity and writes the output validity of the middle row only, so a
//! streaming head runs it with a 3-row window and one row of latency, and the batch path gives the
//! same codes.

use crate::math::fabs;
use crate::validity::Validity;

/// Configuration of the edge filter (depth and light edges).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EdgeFilter {
    /// `max_slope / f`: largest accepted relative depth step between neighbouring pixels.
    step: f32,
}

impl EdgeFilter {
    /// A filter for a camera of focal length `focal_px` (pixels) accepting surfaces up to
    /// `max_angle_deg` from facing the camera (80° by default in the host: a depth step of 5.7
    /// pixel footprints). Returns `None` for non-finite or non-positive parameters or an angle
    /// of 90° or more.
    pub fn new(focal_px: f64, max_angle_deg: f64) -> Option<Self> {
        if !(focal_px.is_finite() && focal_px > 0.0 && max_angle_deg > 0.0 && max_angle_deg < 90.0)
        {
            return None;
        }
        let slope = libm::tan(max_angle_deg.to_radians());
        Some(EdgeFilter {
            step: (slope / focal_px) as f32,
        })
    }

    /// Filter row `cur` (points `3·w` floats, validity `w` codes) given the rows above and below
    /// (`None` at the image border), writing the output validity of `cur` into `out`. Points
    /// already invalid keep their code; only valid points can become [`Validity::DepthEdge`] or
    /// [`Validity::LightEdge`].
    /// Returns `false` (and writes nothing) if the slice lengths disagree.
    pub fn filter_row(
        &self,
        above: Option<(&[f32], &[u8])>,
        cur: (&[f32], &[u8]),
        below: Option<(&[f32], &[u8])>,
        out: &mut [u8],
    ) -> bool {
        let (xyz, val) = cur;
        let w = val.len();
        if xyz.len() != 3 * w || out.len() != w {
            return false;
        }
        for r in [above, below].into_iter().flatten() {
            if r.0.len() != 3 * w || r.1.len() != w {
                return false;
            }
        }
        let valid = Validity::Valid as u8;
        for i in 0..w {
            out[i] = val[i];
            if val[i] != valid {
                continue;
            }
            let z = xyz[3 * i + 2];
            let limit = self.step * z;
            let (mut edge, mut unlit) = (false, false);
            let mut check = |zq: f32, vq: u8| {
                if vq == valid && !(fabs(z - zq) <= limit) {
                    edge = true;
                }
                unlit |= is_unlit(vq);
            };
            if i > 0 {
                check(xyz[3 * (i - 1) + 2], val[i - 1]);
            }
            if i + 1 < w {
                check(xyz[3 * (i + 1) + 2], val[i + 1]);
            }
            if let Some((p, v)) = above {
                check(p[3 * i + 2], v[i]);
            }
            if let Some((p, v)) = below {
                check(p[3 * i + 2], v[i]);
            }
            if edge {
                out[i] = Validity::DepthEdge as u8;
            } else if unlit {
                out[i] = Validity::LightEdge as u8;
            }
        }
        true
    }
}

/// `true` for the decoder's codes of a pixel without usable light: [`Validity::Dark`],
/// [`Validity::Saturated`], [`Validity::LowModulation`].
#[inline]
fn is_unlit(code: u8) -> bool {
    code == Validity::Dark as u8
        || code == Validity::Saturated as u8
        || code == Validity::LowModulation as u8
}
