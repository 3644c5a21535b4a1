//! The 3D compile (issue 17; docs/design/three-dimensions.md): the same source as the 2D
//! packages compiled with `dim3` (`multifield-core3d`, `multifield-frames3d`,
//! `multifield-physics3d`), tested against analytic results.
//!
//! One test binary: `cargo test --test dim3 [module::]`.

mod case;
mod cavity;
mod check;
mod decomposition;
mod eulerian;
mod exchange;
mod grid;
mod output;
mod pictures;
mod poisson;
mod pressure;
mod regions;
mod stress;
