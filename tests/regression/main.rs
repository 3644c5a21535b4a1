//! Regression: each module pins a defect that was found and fixed, named after it, so that
//! it cannot come back unnoticed.
//!
//! One test binary: `cargo test --release --test regression [module::]`.

mod body_through_a_periodic_side;
mod eulerian_field_with_bodies;
mod hostile_input;
mod instability;

mod deep_nesting;
mod forged_checkpoint;
mod input_messages;
mod limits_of_time_and_threads;
mod schedules_that_never_advance;
mod summary_after_a_failed_write;
mod unbounded_reads;
