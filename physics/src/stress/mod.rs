//! Stress (constitutive) models: `ls physics/src/stress/` lists them.

pub mod newtonian;
