//! [`Reconstructor`]: one calibration and depth range, validated at construction
//! ([`Reconstructor::new`]), with its band of reference rows and the kernel's constants. Its row
//! API is in `row`.

use super::error::ReconstructError;
use super::setup::{Band, Consts, MAX_BISECTIONS, Margin, Setup, SetupAnalysis, analyse};
use super::{MAX_BAND_ROWS, MAX_MARGIN};
use crate::camera::CameraModel;
use crate::geometry::Plane;
use crate::geometry::Vec3;

/// A reconstructor for one calibration and depth range: validated, with its band and constants.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Reconstructor {
    pub(super) cam: CameraModel,
    pub(super) setup: Setup,
    pub(super) band: Band,
    pub(super) c: Consts,
    pub(super) bisections: u32,
    pub(super) max_segment_px: f32,
    /// The reference map's margin past the image.
    pub(super) margin: Margin,
    /// The margin the search segments need ([`Reconstructor::margin_needed`]).
    pub(super) reach: Margin,
    /// The plane's unit normal, `h_R` and `H` (for a re-analysis with another margin).
    pub(super) plane: (Vec3, f64, f64),
}

impl Reconstructor {
    /// Validate the geometry against the camera and compute the band and the per-pixel constants.
    ///
    /// Checks, on a 16-pixel grid of the image (plus its last row and column): every ray meets the
    /// reference plane in front of the camera; the depth range maps to a finite search segment
    /// (no projector ray parallel to the reference plane); the epipolar line is within 45° of the
    /// phase axis; and the band of reference rows the segments need fits [`MAX_BAND_ROWS`].
    pub fn new(camera: &CameraModel, setup: &Setup) -> Result<Self, ReconstructError> {
        Self::analysed(camera, setup, Margin::ZERO)
    }

    /// [`Reconstructor::new`] then [`Reconstructor::with_margin`]`(margin)`: the same
    /// reconstructor, with the grid analysis run once, for the margin, instead of twice (on a
    /// Cortex-M4F, in software f64, the analysis is most of a set-up). The same errors, but for
    /// [`ReconstructError::BandTooLarge`]'s row count, which is the band of the map with its
    /// margin (the larger).
    pub fn new_with_margin(
        camera: &CameraModel,
        setup: &Setup,
        margin: Margin,
    ) -> Result<Self, ReconstructError> {
        if margin.to_array().iter().any(|&m| m > MAX_MARGIN) {
            // The order of the two calls' errors: the geometry's first.
            return Self::new(camera, setup)?.with_margin(margin);
        }
        Self::analysed(camera, setup, margin)
    }

    /// The reconstructor for a map with `margin` past the image (a side at most
    /// [`MAX_MARGIN`]), from one grid analysis. The segments' reach and length do not depend on
    /// the margin, only the band does.
    fn analysed(
        camera: &CameraModel,
        setup: &Setup,
        margin: Margin,
    ) -> Result<Self, ReconstructError> {
        let (c, plane) = checked(camera, setup)?;
        let (n, h_r, h) = plane;
        let a = analyse(camera, setup, n, h_r, h, margin)?;
        let (band, max_segment_px) = (a.band, a.max_len);
        if band.rows() > MAX_BAND_ROWS as u32 {
            return Err(ReconstructError::BandTooLarge { rows: band.rows() });
        }
        // Bisection steps bringing the longest segment below a quarter pixel.
        let mut bisections = 0u32;
        let mut len = max_segment_px;
        while len > 0.25 && bisections < MAX_BISECTIONS {
            len *= 0.5;
            bisections += 1;
        }
        Ok(Reconstructor {
            cam: *camera,
            setup: *setup,
            band,
            c,
            bisections,
            max_segment_px: max_segment_px as f32,
            margin,
            reach: a.reach,
            plane,
        })
    }

    /// The reconstructor [`Reconstructor::new`] and [`Reconstructor::with_margin`]`(margin)`
    /// make, from the analysis they found ([`Reconstructor::analysis`], computed on a desktop
    /// and shipped in the head set-up blob) instead of finding it again: the geometry's checks
    /// that cost little are made, the grid analysis (millions to billions of soft-f64
    /// instructions on a Cortex-M4F) is not. An analysis that is not
    /// [sane](SetupAnalysis::is_sane) is refused ([`ReconstructError::BandTooLarge`],
    /// [`ReconstructError::Margin`] or [`ReconstructError::NotFinite`]); a sane one of another
    /// geometry is not detected here (the blob's CRC and its maker vouch for it), and would
    /// make the search read other reference rows.
    pub fn from_analysis(
        camera: &CameraModel,
        setup: &Setup,
        margin: Margin,
        a: &SetupAnalysis,
    ) -> Result<Self, ReconstructError> {
        let (c, plane) = checked(camera, setup)?;
        let band = Band {
            above: a.above,
            below: a.below,
        };
        if margin.to_array().iter().any(|&m| m > MAX_MARGIN)
            || a.reach.to_array().iter().any(|&m| m > MAX_MARGIN)
        {
            return Err(ReconstructError::Margin);
        }
        if !a.is_sane() {
            let rows = a.above.saturating_add(a.below).saturating_add(1);
            if rows > MAX_BAND_ROWS as u32 {
                return Err(ReconstructError::BandTooLarge { rows });
            }
            return Err(ReconstructError::NotFinite);
        }
        Ok(Reconstructor {
            cam: *camera,
            setup: *setup,
            band,
            c,
            bisections: a.bisections,
            max_segment_px: a.max_segment_px,
            margin,
            reach: a.reach,
            plane,
        })
    }

    /// What the set-up found (the camera model's checks; the band analysis for this
    /// reconstructor's margin): what [`CameraModel::from_check`] and
    /// [`Reconstructor::from_analysis`] take to make this reconstructor again, bit for bit.
    pub fn analysis(&self) -> SetupAnalysis {
        SetupAnalysis {
            camera: self.cam.check(),
            above: self.band.above,
            below: self.band.below,
            bisections: self.bisections,
            max_segment_px: self.max_segment_px,
            reach: self.reach,
        }
    }

    /// This reconstructor for a reference map with margin `margin` past the image ([`Margin`]):
    /// the map it reads is [`Reconstructor::map_width`] × [`Reconstructor::map_height`] samples
    /// and its rows are numbered from the map's top (row `top` is image row 0), in
    /// [`Reconstructor::rows_needed`], a [`ReferenceRing`](super::ReferenceRing) and a
    /// [`ReferenceMap`](super::ReferenceMap) alike. The band is measured again over the wider
    /// map. A side above [`MAX_MARGIN`] is [`ReconstructError::Margin`]. With
    /// [`Margin::ZERO`] it is the reconstructor [`Reconstructor::new`] made, bit for bit.
    pub fn with_margin(mut self, margin: Margin) -> Result<Self, ReconstructError> {
        if margin.to_array().iter().any(|&m| m > MAX_MARGIN) {
            return Err(ReconstructError::Margin);
        }
        let (n, h_r, h) = self.plane;
        let a = analyse(&self.cam, &self.setup, n, h_r, h, margin)?;
        if a.band.rows() > MAX_BAND_ROWS as u32 {
            return Err(ReconstructError::BandTooLarge {
                rows: a.band.rows(),
            });
        }
        self.band = a.band;
        self.margin = margin;
        Ok(self)
    }

    /// The reference map's margin past the image ([`Reconstructor::with_margin`]).
    pub fn margin(&self) -> Margin {
        self.margin
    }

    /// The margin this geometry's search segments need, so that every pixel's search over the
    /// whole depth range stays on the map: how far the segments reach past each side of the
    /// image (measured on the set-up grid), plus the bilinear neighbour and two pixels for the
    /// grid's sub-sampling, each side capped at [`MAX_MARGIN`].
    pub fn margin_needed(&self) -> Margin {
        self.reach
    }

    /// Width of the reference map: the image's plus the left and right margins.
    pub fn map_width(&self) -> usize {
        self.width() + self.margin.left as usize + self.margin.right as usize
    }

    /// Height of the reference map: the image's plus the top and bottom margins.
    pub fn map_height(&self) -> usize {
        self.height() + self.margin.top as usize + self.margin.bottom as usize
    }

    /// The camera model.
    pub fn camera(&self) -> &CameraModel {
        &self.cam
    }

    /// The geometry this reconstructor was built for.
    pub fn setup(&self) -> &Setup {
        &self.setup
    }

    /// The band of reference rows a row needs.
    pub fn band(&self) -> Band {
        self.band
    }

    /// Image width, pixels.
    pub fn width(&self) -> usize {
        self.cam.width() as usize
    }

    /// Image height, pixels.
    pub fn height(&self) -> usize {
        self.cam.height() as usize
    }

    /// The longest search segment (depth range) over the image, distorted pixels.
    pub fn max_segment_px(&self) -> f32 {
        self.max_segment_px
    }

    /// Bisection steps of the fallback search (fixed by the longest segment).
    pub fn fallback_bisections(&self) -> u32 {
        self.bisections
    }

    /// Bytes of a ring of `rows` rows of the reference map: `rows × map_width × (4 + 1)`.
    pub fn ring_bytes(&self, rows: u32) -> usize {
        (rows as usize)
            .saturating_mul(self.map_width())
            .saturating_mul(5)
    }

    /// Reference map rows `first..=last` that image row `v` reads (clipped to the map; map row
    /// `top + v` is image row `v`, so without a margin these are image rows).
    pub fn rows_needed(&self, v: u32) -> (u32, u32) {
        let last = (self.map_height() as u32).saturating_sub(1);
        let vm = v.saturating_add(self.margin.top);
        (
            vm.saturating_sub(self.band.above),
            (vm.saturating_add(self.band.below)).min(last),
        )
    }

    pub(super) fn consts(&self) -> &Consts {
        &self.c
    }

    pub(super) fn bisection_count(&self) -> u32 {
        self.bisections
    }
}

/// The geometry's checks that cost little (finite values, the depth range, the reference plane
/// and the projector centre), and the kernel's constants and the plane's unit normal, `h_R` and
/// `H` from them.
#[allow(clippy::type_complexity)]
fn checked(
    camera: &CameraModel,
    setup: &Setup,
) -> Result<(Consts, (Vec3, f64, f64)), ReconstructError> {
    let s = setup;
    if !(s.projector_centre.is_finite()
        && s.reference_point.is_finite()
        && s.reference_normal.is_finite()
        && s.z_min.is_finite()
        && s.z_max.is_finite())
    {
        return Err(ReconstructError::NotFinite);
    }
    if !(s.z_min > 0.0 && s.z_min < s.z_max) {
        return Err(ReconstructError::DepthRange);
    }
    let plane = Plane::new(s.reference_point, s.reference_normal)
        .ok_or(ReconstructError::ReferencePlane)?;
    let mut n = plane
        .normal
        .normalized()
        .ok_or(ReconstructError::ReferencePlane)?;
    let mut h_r = n.dot(plane.point);
    if h_r < 0.0 {
        n = n.scale(-1.0);
        h_r = -h_r;
    }
    if !(h_r > 1e-3 * s.z_min) {
        return Err(ReconstructError::ReferencePlane);
    }
    let p = s.projector_centre;
    let h = h_r - n.dot(p);
    if !(p.norm() > 1e-6 * s.z_max) || !(libm::fabs(h) > 1e-6 * s.z_max) {
        return Err(ReconstructError::ProjectorCentre);
    }
    let i = camera.params();
    let c = Consts {
        nx: n.x as f32,
        ny: n.y as f32,
        nz: n.z as f32,
        h_r: h_r as f32,
        h: h as f32,
        px: p.x as f32,
        py: p.y as f32,
        pz: p.z as f32,
        z_min: s.z_min as f32,
        z_max: s.z_max as f32,
        fx: i.fx as f32,
        fy: i.fy as f32,
        sfx: (i.skew * i.fx) as f32,
        k: {
            let d = camera.distortion();
            [
                d.k1 as f32,
                d.k2 as f32,
                d.p1 as f32,
                d.p2 as f32,
                d.k3 as f32,
            ]
        },
    };
    Ok((c, (n, h_r, h)))
}
