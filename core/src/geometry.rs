//! Small vector maths: the crate's one 3-vector type (f64), planes (point + normal), line–plane
//! intersection and the closest points of two lines.
//!
//! Everything is plain `+ − × ÷` plus `libm::sqrt`, in a fixed operation order and
//! without fused multiply-add, so the results are the same bits on every target. Degenerate cases
//! (a zero normal, a line parallel to a plane, parallel lines, NaN input) return `None`; nothing
//! panics.
//!
//! Coordinates follow the camera frame of the rest of the crate (OpenCV convention: x right,
//! y down, z forward, millimetres).

/// The crate's 3-vector, `f64` (set-up code, host code, reference computations; the per-pixel
/// kernels work on scalar f32 lanes).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Vec3 {
    /// x component.
    pub x: f64,
    /// y component.
    pub y: f64,
    /// z component.
    pub z: f64,
}

macro_rules! vec3_impl {
    ($V:ident, $T:ty, $sqrt:path) => {
        impl $V {
            /// The zero vector.
            pub const ZERO: $V = $V {
                x: 0.0,
                y: 0.0,
                z: 0.0,
            };

            /// A vector from its components.
            #[inline(always)]
            pub const fn new(x: $T, y: $T, z: $T) -> Self {
                $V { x, y, z }
            }

            /// A vector from `[x, y, z]`.
            #[inline(always)]
            pub const fn from_array(a: [$T; 3]) -> Self {
                $V {
                    x: a[0],
                    y: a[1],
                    z: a[2],
                }
            }

            /// `[x, y, z]`.
            #[inline(always)]
            pub const fn to_array(self) -> [$T; 3] {
                [self.x, self.y, self.z]
            }

            /// Component-wise sum.
            #[inline(always)]
            #[allow(clippy::should_implement_trait)]
            pub fn add(self, o: Self) -> Self {
                $V::new(self.x + o.x, self.y + o.y, self.z + o.z)
            }

            /// Component-wise difference `self − o`.
            #[inline(always)]
            #[allow(clippy::should_implement_trait)]
            pub fn sub(self, o: Self) -> Self {
                $V::new(self.x - o.x, self.y - o.y, self.z - o.z)
            }

            /// `s·self`.
            #[inline(always)]
            pub fn scale(self, s: $T) -> Self {
                $V::new(self.x * s, self.y * s, self.z * s)
            }

            /// Dot product, summed x, y, z in that order.
            #[inline(always)]
            pub fn dot(self, o: Self) -> $T {
                self.x * o.x + self.y * o.y + self.z * o.z
            }

            /// Cross product `self × o`.
            #[inline(always)]
            pub fn cross(self, o: Self) -> Self {
                $V::new(
                    self.y * o.z - self.z * o.y,
                    self.z * o.x - self.x * o.z,
                    self.x * o.y - self.y * o.x,
                )
            }

            /// Squared Euclidean norm.
            #[inline(always)]
            pub fn norm_sq(self) -> $T {
                self.dot(self)
            }

            /// Euclidean norm (`libm` square root).
            #[inline(always)]
            pub fn norm(self) -> $T {
                $sqrt(self.norm_sq())
            }

            /// The unit vector along `self`, or `None` for a zero, infinite or NaN vector.
            pub fn normalized(self) -> Option<Self> {
                let n = self.norm();
                if n > 0.0 && n.is_finite() {
                    Some(self.scale(1.0 / n))
                } else {
                    None
                }
            }

            /// `true` when every component is finite.
            #[inline(always)]
            pub fn is_finite(self) -> bool {
                self.x.is_finite() && self.y.is_finite() && self.z.is_finite()
            }
        }
    };
}

vec3_impl!(Vec3, f64, libm::sqrt);

/// A plane given by a point on it and a normal (not necessarily unit length).
///
/// This is how the paper describes the reference plane: a point `O_R` and a normal `n_R` (§6).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Plane {
    /// A point of the plane.
    pub point: Vec3,
    /// The normal; any non-zero length.
    pub normal: Vec3,
}

impl Plane {
    /// A plane through `point` with normal `normal`; `None` if either is not finite or the
    /// normal is zero.
    pub fn new(point: Vec3, normal: Vec3) -> Option<Self> {
        if point.is_finite() && normal.is_finite() && normal.norm_sq() > 0.0 {
            Some(Plane { point, normal })
        } else {
            None
        }
    }

    /// Signed distance of `p` from the plane, in units of `|normal|` (exact distance for a unit
    /// normal): `n·(p − O)`.
    #[inline]
    pub fn signed_offset(&self, p: Vec3) -> f64 {
        self.normal.dot(p.sub(self.point))
    }

    /// The parameter `λ` at which the line `origin + λ·dir` meets the plane:
    /// `λ = n·(O − origin) / n·dir` — the form of eqs 16 and 17 with `origin = C`.
    ///
    /// `None` when the line is parallel to the plane (|n·dir| below `1e-12·|n||dir|`) or the
    /// result is not finite.
    pub fn intersect_param(&self, origin: Vec3, dir: Vec3) -> Option<f64> {
        let den = self.normal.dot(dir);
        let scale = libm::sqrt(self.normal.norm_sq() * dir.norm_sq());
        if !(libm::fabs(den) > 1e-12 * scale) {
            return None;
        }
        let lambda = self.normal.dot(self.point.sub(origin)) / den;
        if lambda.is_finite() {
            Some(lambda)
        } else {
            None
        }
    }

    /// The point where the line `origin + λ·dir` meets the plane ([`Plane::intersect_param`]).
    pub fn intersect_line(&self, origin: Vec3, dir: Vec3) -> Option<Vec3> {
        self.intersect_param(origin, dir)
            .map(|l| origin.add(dir.scale(l)))
    }
}

/// A line `origin + λ·dir`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Line {
    /// A point of the line.
    pub origin: Vec3,
    /// The direction; any non-zero length.
    pub dir: Vec3,
}

impl Line {
    /// The line through `a` and `b`.
    pub fn through(a: Vec3, b: Vec3) -> Self {
        Line {
            origin: a,
            dir: b.sub(a),
        }
    }

    /// The point at parameter `λ`.
    #[inline]
    pub fn at(&self, lambda: f64) -> Vec3 {
        self.origin.add(self.dir.scale(lambda))
    }
}

/// The parameters `(λ₁, λ₂)` of the closest points of two lines, `l1.at(λ₁)` and `l2.at(λ₂)`.
///
/// Solves the 2×2 normal equations. `None` for (nearly) parallel lines — when the Gram determinant
/// is below `1e-12·|d₁|²|d₂|²` — or non-finite input.
pub fn closest_params(l1: &Line, l2: &Line) -> Option<(f64, f64)> {
    let d1 = l1.dir;
    let d2 = l2.dir;
    let w = l1.origin.sub(l2.origin);
    let a = d1.dot(d1);
    let b = d1.dot(d2);
    let c = d2.dot(d2);
    let d = d1.dot(w);
    let e = d2.dot(w);
    let det = a * c - b * b;
    if !(det > 1e-12 * a * c) {
        return None;
    }
    let l1p = (b * e - c * d) / det;
    let l2p = (a * e - b * d) / det;
    if l1p.is_finite() && l2p.is_finite() {
        Some((l1p, l2p))
    } else {
        None
    }
}

/// The closest points of two lines, `(on l1, on l2)` ([`closest_params`]).
pub fn closest_points(l1: &Line, l2: &Line) -> Option<(Vec3, Vec3)> {
    closest_params(l1, l2).map(|(a, b)| (l1.at(a), l2.at(b)))
}

/// The midpoint of the closest points of two lines: the least-squares "intersection" of two
/// nearly-intersecting lines.
pub fn closest_midpoint(l1: &Line, l2: &Line) -> Option<Vec3> {
    closest_points(l1, l2).map(|(p, q)| p.add(q).scale(0.5))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn plane_and_lines() {
        let p = Plane::new(Vec3::new(0.0, 0.0, 700.0), Vec3::new(0.0, 0.0, -2.0)).unwrap();
        let x = p
            .intersect_line(Vec3::ZERO, Vec3::new(0.1, -0.2, 1.0))
            .unwrap();
        assert!((x.z - 700.0).abs() < 1e-9 && (x.x - 70.0).abs() < 1e-9);
        assert!(
            p.intersect_line(Vec3::ZERO, Vec3::new(1.0, 0.0, 0.0))
                .is_none()
        );
        let l1 = Line::through(Vec3::ZERO, Vec3::new(0.0, 0.0, 1.0));
        let l2 = Line::through(Vec3::new(1.0, 0.0, 5.0), Vec3::new(1.0, 1.0, 5.0));
        let (a, b) = closest_points(&l1, &l2).unwrap();
        assert!((a.z - 5.0).abs() < 1e-12 && (b.x - 1.0).abs() < 1e-12 && b.y.abs() < 1e-12);
        assert!(closest_points(&l1, &l1).is_none());
        assert!(Vec3::new(f64::NAN, 0.0, 0.0).normalized().is_none());
    }
}
