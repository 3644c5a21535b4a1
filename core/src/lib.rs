//! # multifield-core
//!
//! The core of multifield: math types, the MAC grid, the case schema, the plugin traits
//! and their registries, and the time loop that runs the phases of a step
//! (see `docs/method.md` §3). It depends on neither the frames nor the physics:
//! they register themselves.
#![warn(missing_docs)]
// `!(x > 0.0)` is deliberate throughout validation: it also rejects NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod boundary;
pub mod case;
pub mod decomposition;
pub mod driver;
pub mod error;
pub mod exact;
pub mod exchange;
pub mod field;
pub mod finite;
pub mod generate;
#[cfg(feature = "dim2")]
pub mod geometry;
pub mod grid;
pub mod halo;
#[cfg(feature = "dim2")]
pub mod immersed;
pub mod input;
pub mod limits;
pub mod mapping;
pub mod math;
pub mod monitor;
pub mod neighbours;
pub mod parallel;
pub mod part;
pub mod plugin;
pub mod poisson;
pub mod quantity;
pub mod registry;
pub mod ron_value;
pub mod simulation;
pub mod state;
pub mod table;
pub mod timing;

pub use error::{Error, Result};
#[doc(hidden)]
pub use inventory;
