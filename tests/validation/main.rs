//! Validation: runs against published data the code was not tuned to
//! (`validation/reference/`).
//!
//! One test binary: `cargo test --release --test validation [module::]`.

mod dkt;
mod fluidized_bed;
mod hindered_settling;
