//! The parameter vocabulary: the numbers that describe a rig, defined once for every crate.
//!
//! These are plain data (`Copy`, serde, no allocation): the calibration TOML of the desktop
//! embeds them, the wire protocol carries them (postcard), the golden vectors and a head's set-up
//! are their encodings, and the renderer and the calibration solvers read them. Checked, working
//! forms are built from them: [`CameraModel::new`](crate::camera::CameraModel::new) validates a
//! [`CameraParams`] and prepares its inverse, [`ScanGeometry::setup`] gives the
//! [`Setup`](crate::reconstruct::Setup) of the reconstruction, and
//! `PatternSetDesc::to_set` (in [`crate::wire`]) the [`PatternSet`](crate::pattern::PatternSet).
//!
//! | type | what | paper |
//! |---|---|---|
//! | [`CameraParams`] | pinhole + skew + Brown distortion of a camera (or of a projector's lens) | §4.1, eqs 2-4 |
//! | [`Distortion`] | `[k1, k2, p1, p2, k3]`, OpenCV order (the paper's k1..k5) | eq 3 |
//! | [`ProjectorParams`] | a projector's lens and its pose relative to the camera | §4.2 |
//! | [`ScanGeometry`] | projector centre, reference plane and depth range | §6 |
//! | [`PatternSetDesc`](pattern::PatternSetDesc) | a parametric pattern set | §5, eqs 5-7, 14 |
//!
//! Conventions: OpenCV camera frame (x right, y down, z forward), millimetres, pixel centres at
//! integer coordinates.

pub mod pattern;

use serde::{Deserialize, Serialize};

/// Lens distortion coefficients of eq 3, OpenCV order `[k1, k2, p1, p2, k3]` (= the paper's
/// `[k1, k2, k3, k4, k5]`). Written (TOML, wire) as that five-element array, and read as exactly
/// five: serde's own `[f64; 5]` takes the first five elements of a longer TOML array and drops the
/// rest, so the reader here counts what follows and refuses it
/// (`` `distortion` must have exactly 5 values, got 6 ``). On the wire (postcard, a tuple) the
/// bytes are those of `[f64; 5]`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
#[serde(into = "[f64; 5]")]
pub struct Distortion {
    /// Radial, r² (paper k1).
    pub k1: f64,
    /// Radial, r⁴ (paper k2).
    pub k2: f64,
    /// Tangential (paper k3): `Δx = 2 p1 x y + p2 (r² + 2x²)`, `Δy = p1 (r² + 2y²) + 2 p2 x y`.
    pub p1: f64,
    /// Tangential (paper k4).
    pub p2: f64,
    /// Radial, r⁶ (paper k5).
    pub k3: f64,
}

impl Distortion {
    /// No distortion.
    pub const NONE: Distortion = Distortion::from_array([0.0; 5]);

    /// From `[k1, k2, p1, p2, k3]`.
    pub const fn from_array(a: [f64; 5]) -> Self {
        Distortion {
            k1: a[0],
            k2: a[1],
            p1: a[2],
            p2: a[3],
            k3: a[4],
        }
    }

    /// `[k1, k2, p1, p2, k3]`.
    pub const fn to_array(self) -> [f64; 5] {
        [self.k1, self.k2, self.p1, self.p2, self.k3]
    }
}

impl From<[f64; 5]> for Distortion {
    fn from(a: [f64; 5]) -> Self {
        Distortion::from_array(a)
    }
}

impl From<Distortion> for [f64; 5] {
    fn from(d: Distortion) -> Self {
        d.to_array()
    }
}

impl<'de> Deserialize<'de> for Distortion {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        d.deserialize_tuple(5, ExactFive)
            .map(Distortion::from_array)
    }
}

/// The visitor of [`Distortion`]: exactly five numbers, surplus elements counted (not kept) for
/// the message.
struct ExactFive;

impl<'de> serde::de::Visitor<'de> for ExactFive {
    type Value = [f64; 5];

    fn expecting(&self, f: &mut core::fmt::Formatter) -> core::fmt::Result {
        f.write_str("an array of 5 numbers [k1, k2, p1, p2, k3]")
    }

    fn visit_seq<A: serde::de::SeqAccess<'de>>(self, mut seq: A) -> Result<[f64; 5], A::Error> {
        let mut a = [0.0; 5];
        let mut n = 0usize;
        for slot in a.iter_mut() {
            match seq.next_element::<f64>()? {
                Some(v) => *slot = v,
                None => break,
            }
            n += 1;
        }
        while seq.next_element::<serde::de::IgnoredAny>()?.is_some() {
            n += 1;
        }
        if n != 5 {
            return Err(serde::de::Error::custom(format_args!(
                "`distortion` must have exactly 5 values, got {n}"
            )));
        }
        Ok(a)
    }
}

/// A camera's intrinsic parameters (eqs 2-4): image size, pinhole with the paper's skew, Brown
/// distortion. A projector's lens uses the same type, its "pixels" being the DMD mirrors
/// (ξ = u, η = v).
///
/// ```text
/// u = fx·x_d + α·fx·y_d + cx,   v = fy·y_d + cy      (eq 4; α = skew)
/// ```
///
/// OpenCV's camera matrix holds `K[0][1] = α·fx`; Bouguet's `alpha_c` is α. The field order is
/// the wire order (postcard is positional): do not reorder.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraParams {
    /// Image width, pixels.
    pub width: u32,
    /// Image height, pixels.
    pub height: u32,
    /// Focal length along u, pixels (`f_x` of eq 4).
    pub fx: f64,
    /// Focal length along v, pixels (`f_y` of eq 4).
    pub fy: f64,
    /// Principal point u (`u_0`), pixels, pixel centres at integers.
    pub cx: f64,
    /// Principal point v (`v_0`), pixels.
    pub cy: f64,
    /// The paper's skew coefficient α (eq 4), dimensionless. Defaults to 0 when omitted.
    #[serde(default)]
    pub skew: f64,
    /// Distortion `[k1, k2, p1, p2, k3]` (eq 3). Defaults to none when omitted.
    #[serde(default)]
    pub distortion: Distortion,
}

impl CameraParams {
    /// The intrinsic parameters in the calibration solvers' order
    /// `[fx, fy, α, cx, cy, k1, k2, p1, p2, k3]`.
    pub const fn to_vector(&self) -> [f64; 10] {
        let d = self.distortion;
        [
            self.fx, self.fy, self.skew, self.cx, self.cy, d.k1, d.k2, d.p1, d.p2, d.k3,
        ]
    }

    /// The inverse of [`CameraParams::to_vector`], with the image size.
    pub const fn from_vector(width: u32, height: u32, p: [f64; 10]) -> Self {
        CameraParams {
            width,
            height,
            fx: p[0],
            fy: p[1],
            cx: p[3],
            cy: p[4],
            skew: p[2],
            distortion: Distortion::from_array([p[5], p[6], p[7], p[8], p[9]]),
        }
    }

    /// Every float is finite.
    pub fn is_finite(&self) -> bool {
        self.to_vector().iter().all(|v| v.is_finite())
    }
}

/// A projector (paper §4.2): its lens, an inverted camera whose image is the DMD
/// (`intrinsics.width × intrinsics.height` = the ξ, η extents), and its pose relative to the
/// camera: `X_cam = R·X_proj + T`. The centre of projection P of §6 is `T`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ProjectorParams {
    /// The lens and the DMD's size.
    pub intrinsics: CameraParams,
    /// Rotation R, row-major, projector → camera coordinates.
    pub rotation: [[f64; 3]; 3],
    /// Translation T: the projector's centre in the camera frame, mm.
    pub translation: [f64; 3],
}

impl ProjectorParams {
    /// The centre of projection P, camera frame, mm (`T`).
    pub const fn centre(&self) -> [f64; 3] {
        self.translation
    }
}

/// The geometry of a scan besides the camera and the reference phase (paper §6): the projector's
/// centre of projection P, the reference plane (a point O_R and a normal n_R) and the depth range
/// of the measurement volume. The field order is the wire order: do not reorder.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ScanGeometry {
    /// Projector centre of projection P, camera frame, mm.
    pub projector_centre: [f64; 3],
    /// A point O_R of the reference plane, camera frame, mm.
    pub plane_point: [f64; 3],
    /// The reference plane's normal n_R, non-zero (any length, either orientation: eqs 16-17 use
    /// it only in ratios).
    pub plane_normal: [f64; 3],
    /// Nearest accepted depth (camera z), mm.
    pub depth_min: f64,
    /// Farthest accepted depth, mm, `> depth_min`.
    pub depth_max: f64,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn distortion_is_written_as_the_five_element_array() {
        let d = Distortion::from_array([0.1, -0.2, 0.003, -0.004, 0.05]);
        let (mut a, mut b) = ([0u8; 64], [0u8; 64]);
        let x = postcard::to_slice(&d, &mut a).map(|s| s.len()).unwrap_or(0);
        let y = postcard::to_slice(&d.to_array(), &mut b)
            .map(|s| s.len())
            .unwrap_or(1);
        assert_eq!(x, 40);
        assert_eq!(x, y);
        assert_eq!(a, b);
        let back: Distortion = postcard::from_bytes(&a).unwrap_or_default();
        assert_eq!(back, d);
    }

    /// The exact reader, through serde's own sequence deserializer (what a TOML array looks
    /// like to a visitor): five numbers load, any other count is refused with the count.
    #[test]
    fn distortion_is_read_as_exactly_five_numbers() {
        use core::fmt::{self, Write};
        use serde::de::value::SeqDeserializer;
        /// A message in a fixed buffer (no allocation in the core, tests included).
        #[derive(Debug, PartialEq)]
        struct Message {
            buf: [u8; 96],
            len: usize,
        }
        impl Message {
            fn of(args: fmt::Arguments) -> Message {
                let mut m = Message {
                    buf: [0; 96],
                    len: 0,
                };
                let _ = m.write_fmt(args);
                m
            }
        }
        impl Write for Message {
            fn write_str(&mut self, s: &str) -> fmt::Result {
                let end = self.len + s.len();
                let dst = self.buf.get_mut(self.len..end).ok_or(fmt::Error)?;
                dst.copy_from_slice(s.as_bytes());
                self.len = end;
                Ok(())
            }
        }
        impl fmt::Display for Message {
            fn fmt(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str(core::str::from_utf8(&self.buf[..self.len]).map_err(|_| fmt::Error)?)
            }
        }
        impl serde::de::StdError for Message {}
        impl serde::de::Error for Message {
            fn custom<T: fmt::Display>(m: T) -> Self {
                Message::of(format_args!("{m}"))
            }
        }
        let read = |v: &[f64]| {
            Distortion::deserialize(SeqDeserializer::<_, Message>::new(v.iter().copied()))
        };
        let five = [0.1, -0.2, 0.003, -0.004, 0.05];
        assert_eq!(read(&five).ok(), Some(Distortion::from_array(five)));
        for n in [0usize, 4, 6, 100] {
            let v = [0.5; 100];
            let want = Message::of(format_args!(
                "`distortion` must have exactly 5 values, got {n}"
            ));
            assert_eq!(read(&v[..n]).err(), Some(want), "{n} values");
        }
    }

    #[test]
    fn vector_order_round_trips() {
        let c = CameraParams {
            width: 640,
            height: 480,
            fx: 800.0,
            fy: 801.0,
            cx: 320.5,
            cy: 240.25,
            skew: 1e-3,
            distortion: Distortion::from_array([0.1, 0.2, 0.3, 0.4, 0.5]),
        };
        assert_eq!(CameraParams::from_vector(640, 480, c.to_vector()), c);
        assert_eq!(c.to_vector()[2], 1e-3);
    }
}
