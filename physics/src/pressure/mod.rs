//! Solvers of the pressure equation.

pub mod pcg;
