//! # multifield
//!
//! Multifield (multiphase) flow after Los Alamos' CFDLIB: every field of a case picks its
//! frame (Eulerian on the grid, or Lagrangian on material points), and its stress, the
//! momentum exchange between fields and the pressure solve are plugins chosen by name in a
//! RON case file.
//!
//! This crate is the facade and the command line: it re-exports the [`core`], the
//! [`frames`] and the [`physics`] crates, and [`run`] runs a case and writes its output
//! (`case.ron`, `diagnostics.csv`, `summary.json`).
//!
//! ```no_run
//! use multifield::core::case::Case;
//! multifield::link_all();
//! let case = Case::load("examples/lid_driven_cavity.ron".as_ref(), &["time.end=0.5".into()]).unwrap();
//! let outcome = multifield::run::run(&case, "out/cavity".as_ref(), &multifield::run::RunOptions::quiet()).unwrap();
//! println!("{} after {} steps", outcome.summary.status, outcome.summary.steps);
//! ```
#![warn(missing_docs)]

pub use multifield_core as core;
pub use multifield_frames as frames;
pub use multifield_physics as physics;

pub mod charts;
pub mod checkpoint;
pub mod cli;
pub mod compare;
pub mod dkt;
pub mod fuzzing;
#[cfg(feature = "mpi")]
pub mod mpi;
pub mod mpi_check;
pub mod output;
pub mod picture;
pub mod plot;
pub mod run;
pub mod slurm;
pub mod snapshot;
pub mod study;
pub mod study_chart;

/// Keeps the registrations of the frames and physics crates in the final binary
/// (inventory drops a crate nothing references). Call it once before building a case.
pub fn link_all() {
    multifield_frames::link();
    multifield_physics::link();
    multifield_core::mapping::set_snapshot_reader(snapshot::read_velocity);
}

/// The case run by `multifield` with no arguments (`examples/dkt_seed.ron`: the seed's
/// drafting–kissing–tumbling of two disks, 8 cells per diameter).
pub const DEFAULT_CASE: &str = include_str!("../examples/dkt_seed.ron");

/// File name under which [`DEFAULT_CASE`] is reported in messages.
pub const DEFAULT_CASE_FILE: &str = "examples/dkt_seed.ron";
