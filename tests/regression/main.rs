//! Regression: each module pins a defect that was found and fixed, named after it, so that
//! it cannot come back unnoticed.
//!
//! One test binary: `cargo test --release --test regression [module::]`.

mod body_through_a_periodic_side;
mod eulerian_field_with_bodies;
mod grid_too_large_for_memory;
mod instability;
mod memory_estimate;
mod study_beyond_the_run_cap;
mod ten_thousand_bodies;
