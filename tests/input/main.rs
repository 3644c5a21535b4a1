//! Input: what the program accepts and refuses (case files, `--set`, plugins and their
//! registration, the repository's own files), with the messages a user reads.
//!
//! One test binary: `cargo test --release --test input [module::]`; the external plugin's
//! test is a binary of its own (`--test external_plugin`), because linking the plugin adds
//! it to the registries the tests here list.

mod bad_input;
mod default_build;
mod fuzzing;
mod generators;
mod registry;
mod self_contained;
