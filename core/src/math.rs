//! The one place that fixes dimension and precision.
//!
//! Every crate of multifield uses these aliases; nothing else names `f64` or
//! `nalgebra::Vector2` directly. The same source is compiled twice: by the 2D packages
//! (`multifield-core`, …, feature `dim2`) and by the 3D packages under `dim3/`
//! (`multifield-core3d`, …, feature `dim3`); see `docs/design/three-dimensions.md`.
//! Code written for both loops over [`AXES`] and indexes components by axis; code that
//! exists in one dimension only is gated with `#[cfg(feature = "dim2")]` (or `dim3`).

#[cfg(all(feature = "dim2", feature = "dim3"))]
compile_error!("a multifield package is compiled for one dimension: features `dim2` and `dim3` are exclusive");
#[cfg(not(any(feature = "dim2", feature = "dim3")))]
compile_error!("a multifield package needs its dimension: feature `dim2` (the 2D packages) or `dim3` (dim3/*)");

/// Floating-point type of every quantity.
pub type Real = f64;
/// Spatial dimension of this compile.
#[cfg(feature = "dim2")]
pub const DIM: usize = 2;
/// Spatial dimension of this compile.
#[cfg(feature = "dim3")]
pub const DIM: usize = 3;
/// Number of sides of the domain (two per axis).
pub const SIDES: usize = 2 * DIM;
/// The axes, in order: `for a in AXES` is the loop over dimensions (Basilisk's
/// `foreach_dimension`).
#[cfg(feature = "dim2")]
pub const AXES: [usize; DIM] = [0, 1];
/// The axes, in order: `for a in AXES` is the loop over dimensions (Basilisk's
/// `foreach_dimension`).
#[cfg(feature = "dim3")]
pub const AXES: [usize; DIM] = [0, 1, 2];
/// A vector of the space (position, velocity, force): `Vector2` in 2D, `Vector3` in 3D.
pub type Vector = nalgebra::SVector<Real, DIM>;
/// A DIM × DIM matrix (stress, deformation gradient, velocity gradient).
pub type Matrix = nalgebra::SMatrix<Real, DIM, DIM>;
/// A grid index, one entry per axis: `(i, j)` or `(i, j, k)`.
pub type Index = [usize; DIM];
/// An angular velocity or a torque: a scalar (the z component) in 2D, a vector in 3D.
#[cfg(feature = "dim2")]
pub type AngVector = Real;
/// An angular velocity or a torque: a scalar (the z component) in 2D, a vector in 3D.
#[cfg(feature = "dim3")]
pub type AngVector = Vector;

/// Converts a case-file tuple `(x, y)` (or `(x, y, z)`) into a [`Vector`].
pub fn vector(v: [Real; DIM]) -> Vector {
    Vector::from(v)
}

/// The cross product `a × b`: its z component (a scalar) in 2D.
#[cfg(feature = "dim2")]
pub fn cross(a: Vector, b: Vector) -> AngVector {
    a.x * b.y - a.y * b.x
}

/// The cross product `a × b`.
#[cfg(feature = "dim3")]
pub fn cross(a: Vector, b: Vector) -> AngVector {
    a.cross(&b)
}

/// The unit vector along `axis`.
pub fn unit(axis: usize) -> Vector {
    Vector::from_fn(|c, _| if c == axis { 1.0 } else { 0.0 })
}

/// The name of an axis in messages and output columns (`x`, `y`, `z`).
pub fn axis_name(axis: usize) -> &'static str {
    ["x", "y", "z"][axis]
}

#[cfg(all(test, feature = "dim2"))]
mod tests {
    use super::*;

    #[test]
    fn vector_from_a_tuple_and_the_cross_product() {
        assert_eq!(vector([1.0, 2.0]), Vector::new(1.0, 2.0));
        assert_eq!(cross(vector([1.0, 2.0]), vector([3.0, 5.0])), -1.0);
        assert_eq!(unit(1), Vector::new(0.0, 1.0));
    }
}
