//! The host's 3-vector and 3×3 matrix, f64: the renderer's geometry and the calibration's linear
//! algebra both use them; and the projector's defocus kernel [`box_gauss`], which the renderer
//! and the binary patterns' decoding model (`response::binary`) share. They are independent of the core's geometry on purpose: the renderer is
//! the test truth of the core's reconstruction.

use std::ops::{Add, Index, IndexMut, Mul, Neg, Sub};

/// `½·[erf((x + ½)/(σ√2)) − erf((x − ½)/(σ√2))]`: the box ⊗ Gaussian kernel, a DMD pixel of
/// width 1 blurred by a Gaussian of σ pixels (σ > 0), at offset `x` from its centre.
#[inline]
pub fn box_gauss(x: f64, sigma: f64) -> f64 {
    let s = 1.0 / (sigma * std::f64::consts::SQRT_2);
    0.5 * (libm::erf((x + 0.5) * s) - libm::erf((x - 0.5) * s))
}

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

    /// [`Vec3::normalized`], or `None` for a zero or non-finite length.
    pub fn try_normalized(self) -> Option<Vec3> {
        let n = self.norm();
        (n > 0.0 && n.is_finite()).then(|| self * (1.0 / n))
    }
}

impl From<[f64; 3]> for Vec3 {
    fn from(a: [f64; 3]) -> Self {
        Vec3::from_array(a)
    }
}

impl From<Vec3> for [f64; 3] {
    fn from(v: Vec3) -> Self {
        v.to_array()
    }
}

/// Components by index: 0 = x, 1 = y, 2 = z (panics on any other index, like an array).
impl Index<usize> for Vec3 {
    type Output = f64;
    #[inline]
    fn index(&self, i: usize) -> &f64 {
        match i {
            0 => &self.x,
            1 => &self.y,
            2 => &self.z,
            _ => panic!("Vec3 index {i} out of range"),
        }
    }
}

impl IndexMut<usize> for Vec3 {
    #[inline]
    fn index_mut(&mut self, i: usize) -> &mut f64 {
        match i {
            0 => &mut self.x,
            1 => &mut self.y,
            2 => &mut self.z,
            _ => panic!("Vec3 index {i} out of range"),
        }
    }
}

/// Written as the array `[x, y, z]` (reports, JSON).
impl serde::Serialize for Vec3 {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        self.to_array().serialize(s)
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

/// A 3×3 matrix, row-major; `m[i]` is row `i`, `m[i][j]` an element. Written as its rows.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Mat3(pub [[f64; 3]; 3]);

impl Index<usize> for Mat3 {
    type Output = [f64; 3];
    #[inline]
    fn index(&self, i: usize) -> &[f64; 3] {
        &self.0[i]
    }
}

impl IndexMut<usize> for Mat3 {
    #[inline]
    fn index_mut(&mut self, i: usize) -> &mut [f64; 3] {
        &mut self.0[i]
    }
}

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

    /// Row `i`.
    pub fn row(&self, i: usize) -> Vec3 {
        Vec3::from_array(self.0[i])
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

    /// `A·B`, each element `a_i0·b_0j + a_i1·b_1j + a_i2·b_2j` in that order.
    pub fn mul_mat(&self, o: &Mat3) -> Mat3 {
        let (a, b) = (&self.0, &o.0);
        let mut r = [[0.0; 3]; 3];
        for (i, row) in r.iter_mut().enumerate() {
            for (j, v) in row.iter_mut().enumerate() {
                *v = a[i][0] * b[0][j] + a[i][1] * b[1][j] + a[i][2] * b[2][j];
            }
        }
        Mat3(r)
    }

    /// The determinant, as `row0 · (row1 × row2)`.
    pub fn det(&self) -> f64 {
        self.row(0).dot(self.row(1).cross(self.row(2)))
    }

    /// `A⁻¹` from the cofactors (`None` if singular: `|det| ≤ 1e-300` or not finite).
    pub fn inverse(&self) -> Option<Mat3> {
        let d = self.det();
        if !(d.abs() > 1e-300) || !d.is_finite() {
            return None;
        }
        let c0 = self.row(1).cross(self.row(2));
        let c1 = self.row(2).cross(self.row(0));
        let c2 = self.row(0).cross(self.row(1));
        // The inverse's columns are the cofactor rows divided by det.
        Some(Mat3([
            [c0.x / d, c1.x / d, c2.x / d],
            [c0.y / d, c1.y / d, c2.y / d],
            [c0.z / d, c1.z / d, c2.z / d],
        ]))
    }

    /// The cross-product matrix `[v]×` (so `[v]× w = v × w`).
    pub fn cross_matrix(v: Vec3) -> Mat3 {
        Mat3([[0.0, -v.z, v.y], [v.z, 0.0, -v.x], [-v.y, v.x, 0.0]])
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
