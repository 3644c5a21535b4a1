//! Solvers of the pressure equation.

#[cfg(feature = "dim2")]
pub mod cholesky;
#[cfg(feature = "dim2")]
pub mod multigrid;
pub mod pcg;
pub mod stencil;
