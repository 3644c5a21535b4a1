//! The one place that fixes dimension and precision.
//!
//! Every crate of multifield uses these aliases; nothing else names `f64` or
//! `nalgebra::Vector2` directly.

/// Floating-point type of every quantity.
pub type Real = f64;
/// A 2D vector (position, velocity, force).
pub type Vector = nalgebra::Vector2<Real>;
/// A 2×2 matrix (stress, deformation gradient, velocity gradient).
pub type Matrix = nalgebra::Matrix2<Real>;
/// Spatial dimension.
pub const DIM: usize = 2;

/// Converts a case-file pair `(x, y)` into a [`Vector`].
pub fn vector(v: [Real; 2]) -> Vector {
    Vector::new(v[0], v[1])
}

/// Scalar 2D cross product `a × b` (the z component).
pub fn cross(a: Vector, b: Vector) -> Real {
    a.x * b.y - a.y * b.x
}
