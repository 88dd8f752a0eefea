//! `input/params.bin` of the golden vectors (layout: docs/golden-vectors.md) as core types.
//!
//! Every value is the desktop's f64 or f32 bit for bit, and the core builds its decoder and
//! reconstructor from them with the same code on both sides, so the head's kernels see the same
//! constants as the desktop's.

use fringe3d_core::camera::CameraModel;
use fringe3d_core::decode::{DecodeConfig, Decoder};
use fringe3d_core::filter::EdgeFilter;
use fringe3d_core::geometry::Vec3;
use fringe3d_core::params::{CameraParams, Distortion};
use fringe3d_core::pattern::{
    Convention, ImageId, Level, MAX_IMAGES, MAX_LEVELS, MAX_SHIFTS, Output, PatternSet,
};
use fringe3d_core::phase_function::{Axis, KnotProfile, MAX_KNOTS, PhaseFunction, Profile};
use fringe3d_core::reconstruct::{Reconstructor, Setup};

/// Why `params.bin` was refused.
#[derive(Clone, Copy, Debug)]
pub struct ParamsError(pub &'static str);

/// Everything a scan needs besides the images and the reference map.
pub struct Params {
    /// Image width.
    pub width: usize,
    /// Image height.
    pub height: usize,
    /// Images per set.
    pub images: usize,
    /// Significant bits of the camera codes.
    pub bits: u32,
    /// Bytes per sample in `images.*` (1 or 2).
    pub sample_bytes: usize,
    /// The decoder of the pattern set with the thresholds.
    pub decoder: Decoder,
    /// The reconstructor of the camera model and geometry.
    pub recon: Reconstructor,
    /// The depth-edge filter.
    pub filter: EdgeFilter,
}

/// Counter ticks of the two set-up steps.
#[derive(Clone, Copy, Debug, Default)]
pub struct SetupTicks {
    /// Pattern set (validated over the projector) and decoder.
    pub decoder: u32,
    /// Camera model, reconstruction set-up (band analysis) and edge filter.
    pub reconstructor: u32,
}

struct Reader<'a> {
    b: &'a [u8],
    at: usize,
}

impl Reader<'_> {
    fn take<const N: usize>(&mut self) -> Result<[u8; N], ParamsError> {
        let s = self
            .b
            .get(self.at..self.at + N)
            .ok_or(ParamsError("params.bin is truncated"))?;
        self.at += N;
        let mut a = [0u8; N];
        a.copy_from_slice(s);
        Ok(a)
    }
    fn u32(&mut self) -> Result<u32, ParamsError> {
        Ok(u32::from_le_bytes(self.take()?))
    }
    fn count(&mut self, max: usize) -> Result<usize, ParamsError> {
        let n = self.u32()? as usize;
        if n > max {
            Err(ParamsError(
                "a count in params.bin exceeds the firmware's limits",
            ))
        } else {
            Ok(n)
        }
    }
    fn f32(&mut self) -> Result<f32, ParamsError> {
        Ok(f32::from_le_bytes(self.take()?))
    }
    fn f64(&mut self) -> Result<f64, ParamsError> {
        Ok(f64::from_le_bytes(self.take()?))
    }
    fn vec3(&mut self) -> Result<Vec3, ParamsError> {
        Ok(Vec3::new(self.f64()?, self.f64()?, self.f64()?))
    }
    fn axis(&mut self) -> Result<Axis, ParamsError> {
        match self.u32()? {
            0 => Ok(Axis::Xi),
            1 => Ok(Axis::Eta),
            _ => Err(ParamsError("bad axis code")),
        }
    }
}

/// Parse `params.bin` and build the decoder and reconstructor; `now` reads a down-counter for
/// the ticks of each step. The pattern set and camera model live only in the frames of the two
/// steps, so the set-up's stack stays small.
#[inline(never)]
pub fn parse(
    b: &[u8],
    now: &dyn Fn() -> u32,
    ticks: &mut SetupTicks,
) -> Result<Params, ParamsError> {
    let mut r = Reader { b, at: 0 };
    if r.take::<8>()? != *b"F3DVPAR1" {
        return Err(ParamsError("not a params.bin (magic)"));
    }
    let width = r.u32()? as usize;
    let height = r.u32()? as usize;
    let images = r.count(MAX_IMAGES)?;
    let bits = r.u32()?;
    let sample_bytes = r.u32()? as usize;
    let decode = DecodeConfig {
        dark_level: r.f32()?,
        saturation_level: r.f32()?,
        min_modulation: r.f32()?,
        unwrap_tolerance: r.f32()?,
        range_tolerance: r.f32()?,
    };
    let t = now();
    let decoder = decoder(&mut r, decode)?;
    ticks.decoder = t.wrapping_sub(now());
    let t = now();
    let recon = reconstructor(&mut r)?;
    let (focal, angle) = (r.f64()?, r.f64()?);
    let filter = EdgeFilter::new(focal, angle).ok_or(ParamsError("edge filter refused"))?;
    ticks.reconstructor = t.wrapping_sub(now());
    if r.take::<4>()? != *b"END1" || r.at != b.len() {
        return Err(ParamsError("params.bin does not end where expected"));
    }
    if width != recon.width()
        || height != recon.height()
        || images != decoder.image_count()
        || !(sample_bytes == 1 || sample_bytes == 2)
    {
        return Err(ParamsError(
            "params.bin is inconsistent (size, image count or sample size)",
        ));
    }
    Ok(Params {
        width,
        height,
        images,
        bits,
        sample_bytes,
        decoder,
        recon,
        filter,
    })
}

/// The pattern set and its decoder.
#[inline(never)]
fn decoder(r: &mut Reader<'_>, cfg: DecodeConfig) -> Result<Decoder, ParamsError> {
    let set = pattern_set(r)?;
    Decoder::new(&set, cfg).map_err(|_| ParamsError("the decoder refused the pattern set"))
}

/// The camera model, the geometry and the reconstructor.
#[inline(never)]
fn reconstructor(r: &mut Reader<'_>) -> Result<Reconstructor, ParamsError> {
    let camera = camera(r)?;
    let projector_centre = r.vec3()?;
    let reference_point = r.vec3()?;
    let reference_normal = r.vec3()?;
    let axis = r.axis()?;
    let (z_min, z_max) = (r.f64()?, r.f64()?);
    let setup = Setup {
        projector_centre,
        reference_point,
        reference_normal,
        axis,
        z_min,
        z_max,
    };
    Reconstructor::new(&camera, &setup)
        .map_err(|_| ParamsError("the reconstruction set-up refused the calibration"))
}

/// The pattern-set part of `params.bin` (its own stack frame: the set is validated over the
/// whole projector here).
#[inline(never)]
fn pattern_set(r: &mut Reader<'_>) -> Result<PatternSet, ParamsError> {
    // Pattern set.
    let axis = r.axis()?;
    let function = match r.u32()? {
        0 => {
            let (origin, slope) = (r.f64()?, r.f64()?);
            PhaseFunction::linear(axis, origin, slope)
                .map_err(|_| ParamsError("linear phase function refused"))?
        }
        1 => {
            let n = r.count(MAX_KNOTS)?;
            let mut k = [[0.0f64; MAX_KNOTS]; 3];
            for row in k.iter_mut() {
                for v in row.iter_mut().take(n) {
                    *v = r.f64()?;
                }
            }
            let p = KnotProfile::new(&k[0][..n], &k[1][..n], &k[2][..n])
                .map_err(|_| ParamsError("knot profile refused"))?;
            PhaseFunction::with_profile(axis, Profile::Knots(p))
                .map_err(|_| ParamsError("phase function refused"))?
        }
        _ => return Err(ParamsError("bad profile code")),
    };
    let (curvature, center) = (r.f64()?, r.f64()?);
    let function = function
        .curved(curvature, center)
        .map_err(|_| ParamsError("curvature refused"))?;
    let n_levels = r.count(MAX_LEVELS)?;
    let mut levels = [Level::with_shifts(0.0, &[]); MAX_LEVELS];
    for l in levels.iter_mut().take(n_levels) {
        let scale = r.f64()?;
        let n = r.count(MAX_SHIFTS)?;
        let mut s = [0.0f64; MAX_SHIFTS];
        for v in s.iter_mut().take(n) {
            *v = r.f64()?;
        }
        *l = Level::with_shifts(scale, &s[..n]);
    }
    let output = Output {
        width: r.u32()?,
        height: r.u32()?,
        i_min: r.f64()?,
        i_max: r.f64()?,
    };
    let convention = match r.u32()? {
        0 => Convention::Sine,
        1 => Convention::Cosine,
        _ => return Err(ParamsError("bad convention code")),
    };
    let offset = r.f64()?;
    let n_order = r.count(MAX_IMAGES)?;
    let mut order = [ImageId { level: 0, shift: 0 }; MAX_IMAGES];
    for id in order.iter_mut().take(n_order) {
        *id = ImageId {
            level: r.u32()? as u8,
            shift: r.u32()? as u8,
        };
    }
    let mut set = PatternSet::new(function, &levels[..n_levels], output)
        .map_err(|_| ParamsError("pattern set refused"))?;
    // Each `with_*` moves the whole set; call them only when they change it.
    if convention != set.convention() {
        set = set.with_convention(convention);
    }
    if offset.to_bits() != set.phase_offset().to_bits() {
        set = set
            .with_phase_offset(offset)
            .map_err(|_| ParamsError("phase offset refused"))?;
    }
    if set.order() != &order[..n_order] {
        set = set
            .with_order(&order[..n_order])
            .map_err(|_| ParamsError("image order refused"))?;
    }
    Ok(set)
}

/// The camera part of `params.bin` (its own stack frame: the model checks its inverse here).
#[inline(never)]
fn camera(r: &mut Reader<'_>) -> Result<CameraModel, ParamsError> {
    // Camera.
    let (fx, fy, skew, u0, v0) = (r.f64()?, r.f64()?, r.f64()?, r.f64()?, r.f64()?);
    let (cw, ch) = (r.u32()?, r.u32()?);
    let mut d = [0.0f64; 5];
    for v in d.iter_mut() {
        *v = r.f64()?;
    }
    CameraModel::new(CameraParams {
        width: cw,
        height: ch,
        fx,
        fy,
        cx: u0,
        cy: v0,
        skew,
        distortion: Distortion::from_array(d),
    })
    .map_err(|_| ParamsError("camera model refused"))
}
