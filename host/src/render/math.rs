//! Small f64 vector and matrix maths for the renderer (independent of the core's geometry).

use std::ops::{Add, Mul, Neg, Sub};

/// A 3-vector (millimetres, or a direction).
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct Vec3 {
    /// x.
    pub x: f64,
    /// y.
    pub y: f64,
    /// z.
    pub z: f64,
}

impl Vec3 {
    /// The zero vector.
    pub const ZERO: Vec3 = Vec3 {
        x: 0.0,
        y: 0.0,
        z: 0.0,
    };

    /// A vector from components.
    #[inline]
    pub const fn new(x: f64, y: f64, z: f64) -> Self {
        Vec3 { x, y, z }
    }

    /// From an array.
    #[inline]
    pub const fn from_array(a: [f64; 3]) -> Self {
        Vec3 {
            x: a[0],
            y: a[1],
            z: a[2],
        }
    }

    /// As an array.
    #[inline]
    pub const fn to_array(self) -> [f64; 3] {
        [self.x, self.y, self.z]
    }

    /// Dot product.
    #[inline]
    pub fn dot(self, o: Vec3) -> f64 {
        self.x * o.x + self.y * o.y + self.z * o.z
    }

    /// Cross product.
    #[inline]
    pub fn cross(self, o: Vec3) -> Vec3 {
        Vec3::new(
            self.y * o.z - self.z * o.y,
            self.z * o.x - self.x * o.z,
            self.x * o.y - self.y * o.x,
        )
    }

    /// Euclidean length.
    #[inline]
    pub fn norm(self) -> f64 {
        self.dot(self).sqrt()
    }

    /// Unit vector in the same direction (NaN for the zero vector).
    #[inline]
    pub fn normalized(self) -> Vec3 {
        self * (1.0 / self.norm())
    }

    /// `true` if every component is finite.
    pub fn is_finite(self) -> bool {
        self.x.is_finite() && self.y.is_finite() && self.z.is_finite()
    }
}

impl Add for Vec3 {
    type Output = Vec3;
    #[inline]
    fn add(self, o: Vec3) -> Vec3 {
        Vec3::new(self.x + o.x, self.y + o.y, self.z + o.z)
    }
}

impl Sub for Vec3 {
    type Output = Vec3;
    #[inline]
    fn sub(self, o: Vec3) -> Vec3 {
        Vec3::new(self.x - o.x, self.y - o.y, self.z - o.z)
    }
}

impl Mul<f64> for Vec3 {
    type Output = Vec3;
    #[inline]
    fn mul(self, s: f64) -> Vec3 {
        Vec3::new(self.x * s, self.y * s, self.z * s)
    }
}

impl Neg for Vec3 {
    type Output = Vec3;
    #[inline]
    fn neg(self) -> Vec3 {
        Vec3::new(-self.x, -self.y, -self.z)
    }
}

/// A 3×3 matrix, row-major.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Mat3(pub [[f64; 3]; 3]);

impl Mat3 {
    /// The identity.
    pub const IDENTITY: Mat3 = Mat3([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]);

    /// The matrix whose columns are `a`, `b`, `c`.
    pub fn from_columns(a: Vec3, b: Vec3, c: Vec3) -> Mat3 {
        Mat3([[a.x, b.x, c.x], [a.y, b.y, c.y], [a.z, b.z, c.z]])
    }

    /// Column `i`.
    pub fn column(&self, i: usize) -> Vec3 {
        Vec3::new(self.0[0][i], self.0[1][i], self.0[2][i])
    }

    /// `M·v`.
    #[inline]
    pub fn mul_vec(&self, v: Vec3) -> Vec3 {
        let m = &self.0;
        Vec3::new(
            m[0][0] * v.x + m[0][1] * v.y + m[0][2] * v.z,
            m[1][0] * v.x + m[1][1] * v.y + m[1][2] * v.z,
            m[2][0] * v.x + m[2][1] * v.y + m[2][2] * v.z,
        )
    }

    /// `Mᵀ·v`.
    #[inline]
    pub fn tmul_vec(&self, v: Vec3) -> Vec3 {
        let m = &self.0;
        Vec3::new(
            m[0][0] * v.x + m[1][0] * v.y + m[2][0] * v.z,
            m[0][1] * v.x + m[1][1] * v.y + m[2][1] * v.z,
            m[0][2] * v.x + m[1][2] * v.y + m[2][2] * v.z,
        )
    }

    /// `A·B`.
    pub fn mul_mat(&self, o: &Mat3) -> Mat3 {
        let mut r = [[0.0; 3]; 3];
        for (i, row) in r.iter_mut().enumerate() {
            for (j, v) in row.iter_mut().enumerate() {
                *v = (0..3).map(|k| self.0[i][k] * o.0[k][j]).sum();
            }
        }
        Mat3(r)
    }

    /// Transpose.
    pub fn transpose(&self) -> Mat3 {
        let m = &self.0;
        Mat3([
            [m[0][0], m[1][0], m[2][0]],
            [m[0][1], m[1][1], m[2][1]],
            [m[0][2], m[1][2], m[2][2]],
        ])
    }

    /// Rotation about x by `a` radians.
    pub fn rot_x(a: f64) -> Mat3 {
        let (s, c) = libm::sincos(a);
        Mat3([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])
    }

    /// Rotation about y by `a` radians.
    pub fn rot_y(a: f64) -> Mat3 {
        let (s, c) = libm::sincos(a);
        Mat3([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])
    }

    /// Rotation about z by `a` radians.
    pub fn rot_z(a: f64) -> Mat3 {
        let (s, c) = libm::sincos(a);
        Mat3([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    }

    /// `Rz(c)·Ry(b)·Rx(a)` from angles in degrees `[a, b, c]` (x first, then y, then z, about the
    /// fixed camera axes).
    pub fn from_euler_deg(e: [f64; 3]) -> Mat3 {
        let r = |d: f64| d.to_radians();
        Mat3::rot_z(r(e[2]))
            .mul_mat(&Mat3::rot_y(r(e[1])))
            .mul_mat(&Mat3::rot_x(r(e[0])))
    }

    /// Largest deviation of `MᵀM` from the identity, and the determinant: a rotation has ~0 and 1.
    pub fn orthonormality_error(&self) -> (f64, f64) {
        let p = self.transpose().mul_mat(self);
        let mut e: f64 = 0.0;
        for i in 0..3 {
            for j in 0..3 {
                let id = if i == j { 1.0 } else { 0.0 };
                e = e.max((p.0[i][j] - id).abs());
            }
        }
        let m = &self.0;
        let det = m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
            - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
            + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
        (e, det)
    }
}

/// A rotation whose z column points from `from` to `to` and whose y column points "down"
/// (towards +y of the camera frame) as far as possible: the pose of a device at `from` aimed at
/// `to`, in the OpenCV convention (x right, y down, z forward). `None` if the points coincide or
/// the direction is vertical.
pub fn look_at(from: Vec3, to: Vec3) -> Option<Mat3> {
    let z = (to - from).normalized();
    let down = Vec3::new(0.0, 1.0, 0.0);
    let x = down.cross(z);
    if !(x.norm() > 1e-9) || !z.is_finite() {
        return None;
    }
    let x = x.normalized();
    let y = z.cross(x);
    Some(Mat3::from_columns(x, y, z))
}
