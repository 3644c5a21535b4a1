//! Regression: each module pins a defect that was found and fixed, named after it, so that
//! it cannot come back unnoticed.
//!
//! One test binary: `cargo test --release --test regression [module::]`.

mod body_through_a_periodic_side;
mod colliding_run_directories;
mod eulerian_field_with_bodies;
mod full_disk;
mod instability;
mod overlap_between_fields;
