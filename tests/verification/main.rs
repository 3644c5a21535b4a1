//! Verification: each method against analytic solutions, conserved quantities and observed
//! orders of convergence (the numbers in docs/validation.md and the module docs).
//!
//! One test binary: `cargo test --release --test verification [module::]`.

mod bodies_at_open_sides;
mod body_densities;
mod collocated;
mod contact_substeps;
mod decomposed;
mod dem;
mod drag;
mod elastic;
mod eulerian;
mod immersed_boundaries;
mod inflow_outflow;
mod lagrangian;
mod mapping;
mod mpm88;
mod multifield_coupling;
mod point_particles;
mod point_state;
mod quantities;
mod wet_collision;
