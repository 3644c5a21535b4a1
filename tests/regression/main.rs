//! Regression: each module pins a defect that was found and fixed, named after it, so that
//! it cannot come back unnoticed.
//!
//! One test binary: `cargo test --release --test regression [module::]`.

mod body_through_a_periodic_side;
mod colliding_run_directories;
mod eulerian_field_with_bodies;
mod deep_nesting;
mod forged_checkpoint;
mod full_disk;
mod hostile_input;
mod input_messages;
mod instability;
mod limits_of_time_and_threads;
mod overlap_between_fields;
mod schedules_that_never_advance;
mod summary_after_a_failed_write;
mod unbounded_reads;
