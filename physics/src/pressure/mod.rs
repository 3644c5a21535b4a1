//! Solvers of the pressure equation.

pub mod cholesky;
pub mod multigrid;
pub mod pcg;
pub mod stencil;
