//! Output: what a run writes (the CSV files, summaries, snapshots, pictures, checkpoints and
//! restarts, studies), read back and compared with the state that wrote it.
//!
//! One test binary: `cargo test --release --test output [module::]`.

mod common;
mod driver;
mod examples;
mod generated_bodies;
mod moments;
mod monitors;
mod output_contract;
mod pictures;
mod restart;
mod slurm;
mod snapshots;
mod study;
mod study_references;
mod suspension;
