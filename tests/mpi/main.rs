//! MPI: the binary built with the cargo feature `mpi`, launched by `mpirun` on 1–4 ranks
//! (docs/design/mpi.md §8). `cargo test --features mpi --test mpi`.
//!
//! Each test finds the launcher as `MULTIFIELD_MPIRUN` or `mpirun` on `PATH`; without one it
//! prints why and passes, unless `MULTIFIELD_REQUIRE_MPI=1` (set by .ci/run): then it fails.

mod check;
mod common;
mod dkt;
mod exchange_box;
mod mass_points;
mod per_rank;
mod refusals;
mod restart;
mod taylor_green;
