//! Shape functions of the Lagrangian frame, chosen per field in the case.
//!
//! Coordinates are in lattice units (node k at k). `Linear` is the seed's tent function
//! (support 2 nodes); `Quadratic` is the quadratic B-spline (support 3 nodes, C¹, removes
//! most cell-crossing noise).

use super::lanes::Arith;
use multifield_core::math::Real;
use serde::{Deserialize, Serialize};

/// A 1D shape function.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Shape {
    /// Tent function, 2 nodes.
    Linear,
    /// Quadratic B-spline, 3 nodes.
    Quadratic,
}

/// Weights of the (up to) three nodes `base, base+1, base+2` and their derivatives
/// (per lattice unit).
#[derive(Clone, Copy, Debug)]
pub struct Weights1 {
    /// First node.
    pub base: isize,
    /// Weights.
    pub w: [Real; 3],
    /// Derivatives dw/dξ.
    pub dw: [Real; 3],
}

impl Shape {
    /// Number of nodes in the support.
    pub fn support(self) -> usize {
        match self {
            Shape::Linear => 2,
            Shape::Quadratic => 3,
        }
    }

    /// Weights at lattice coordinate `xi` (`xi` within ±2⁶³).
    #[inline(always)]
    pub fn weights(self, xi: Real) -> Weights1 {
        match self {
            Shape::Linear => {
                let b = floor(xi);
                let f = xi - b;
                Weights1 { base: b as isize, w: [1.0 - f, f, 0.0], dw: [-1.0, 1.0, 0.0] }
            }
            Shape::Quadratic => {
                let b = floor(xi - 0.5);
                let f = xi - b; // in [0.5, 1.5)
                Weights1 {
                    base: b as isize,
                    w: [0.5 * (1.5 - f).powi(2), 0.75 - (f - 1.0).powi(2), 0.5 * (f - 0.5).powi(2)],
                    dw: [f - 1.5, -2.0 * (f - 1.0), f - 0.5],
                }
            }
        }
    }

    /// The APIC inertia-like factor: for the quadratic B-spline D = h²/4 I.
    pub fn apic_d_inverse(self, h: Real) -> Option<Real> {
        match self {
            Shape::Linear => None,
            Shape::Quadratic => Some(4.0 / (h * h)),
        }
    }
}

/// The quadratic B-spline along one axis at lattice coordinate `xi` ≥ −½, as the collocated
/// grid's transfers take it: first node, fraction from it in [½, 3/2), weights and
/// derivatives dw/dξ. ⌊xi − ½⌋ is `(xi + ½) as isize − 1` (truncation is ⌊·⌋ for the
/// non-negative xi + ½): no libm call, no branch. [`Shape::weights`] takes ⌊xi − ½⌋ for any
/// `xi`; the two can differ in the last bit (xi + ½ and xi − ½ round differently), and each
/// path keeps its own so that its results keep their bits.
#[inline(always)]
pub fn quadratic(xi: Real) -> (isize, Real, [Real; 3], [Real; 3]) {
    let (base, f, w, dw) = quadratic_lanes(xi);
    (base as isize, f, w, dw)
}

/// [`quadratic`] for any [`Arith`] number (one or the four lanes of the collocated grid's
/// transfers, by the same operations: the same bits), the first node as a number.
#[inline(always)]
pub fn quadratic_lanes<T: Arith>(xi: T) -> (T, T, [T; 3], [T; 3]) {
    let k = |c: Real| xi.splat_as(c);
    let base = (xi + k(0.5)).trunc_small() - k(1.0);
    let f = xi - base;
    let (a, b, c) = (k(1.5) - f, f - k(1.0), f - k(0.5));
    let half = k(0.5);
    (base, f, [half * a * a, k(0.75) - b * b, half * c * c], [-a, k(-2.0) * b, c])
}

/// ⌊x⌋ for |x| < 2⁶³, inlined: without SSE4.1 (the x86-64 baseline) `f64::floor` is a call
/// into libm, 4 % of a particle step.
#[inline(always)]
fn floor(x: Real) -> Real {
    let t = x as i64 as Real;
    if t > x {
        t - 1.0
    } else {
        t
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn partition_of_unity_linear_reproduction_and_derivative_sum() {
        for shape in [Shape::Linear, Shape::Quadratic] {
            for k in 0..100 {
                let xi = 3.0 + k as Real * 0.0137;
                let w = shape.weights(xi);
                let s: Real = w.w.iter().sum();
                let first: Real = (0..3).map(|a| w.w[a] * (w.base + a as isize) as Real).sum();
                let ds: Real = w.dw.iter().sum();
                let dfirst: Real = (0..3).map(|a| w.dw[a] * (w.base + a as isize) as Real).sum();
                assert!((s - 1.0).abs() < 1e-14, "{shape:?} sum {s}");
                assert!((first - xi).abs() < 1e-13, "{shape:?} reproduces x");
                assert!(ds.abs() < 1e-14);
                assert!((dfirst - 1.0).abs() < 1e-13);
            }
        }
    }
}
