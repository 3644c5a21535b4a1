//! Regression: each module pins a defect that was found and fixed, named after it, so that
//! it cannot come back unnoticed.
//!
//! One test binary: `cargo test --release --test regression [module::]`.

mod a_missed_blow_up;
mod a_one_megabyte_list;
mod an_eulerian_blob_that_never_moved;
mod an_interrupted_run;
mod body_through_a_periodic_side;
mod colliding_run_directories;
mod deep_nesting;
mod eulerian_field_with_bodies;
mod forged_checkpoint;
mod full_disk;
mod grid_too_large_for_memory;
mod hostile_input;
mod input_messages;
mod instability;
mod limits_of_time_and_threads;
mod memory_estimate;
mod overlap_between_fields;
mod schedules_that_never_advance;
mod study_beyond_the_run_cap;
mod summary_after_a_failed_write;
mod ten_thousand_bodies;
mod unbounded_reads;
