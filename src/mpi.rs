//! MPI through rsmpi (cargo feature `mpi`; docs/design/mpi.md §1): [`MpiComm`], the
//! [`Comm`] of a run launched by `mpirun`, and the start-up of the command line under MPI.
//!
//! The default build compiles none of this and links no MPI library. Building with
//! `--features mpi` needs an MPI library with `mpicc` (or pkg-config's `ompi`) and libclang
//! (rsmpi's bindings are generated at build time).

use crate::core::parallel::{Comm, Tag};
use mpi::collective::SystemOperation;
use mpi::datatype::PartitionMut;
use mpi::environment::Universe;
use mpi::topology::SimpleCommunicator;
use mpi::traits::*;
use mpi::Threading;
use std::sync::Mutex;

/// The ranks of `MPI_COMM_WORLD`. Every call holds a lock: MPI is initialized with
/// `MPI_THREAD_SERIALIZED`, which lets any thread call it, one at a time.
pub struct MpiComm {
    world: SimpleCommunicator,
    lock: Mutex<()>,
}

// SAFETY: the communicator is a handle that MPI lets any thread use under
// MPI_THREAD_SERIALIZED (checked by `start`), and every use holds `lock`, so no two
// threads call MPI at once.
unsafe impl Send for MpiComm {}
// SAFETY: as above.
unsafe impl Sync for MpiComm {}

impl MpiComm {
    /// The world communicator of an initialized MPI (see [`start`]).
    pub fn new(world: SimpleCommunicator) -> Self {
        Self { world, lock: Mutex::new(()) }
    }

    fn guard(&self) -> std::sync::MutexGuard<'_, ()> {
        // a poisoned lock only means a panic elsewhere: the communicator is still whole
        self.lock.lock().unwrap_or_else(|e| e.into_inner())
    }
}

impl Comm for MpiComm {
    fn rank(&self) -> usize {
        self.world.rank() as usize
    }
    fn size(&self) -> usize {
        self.world.size() as usize
    }
    fn exchange(&self, sends: &[(usize, Tag, &[u8])], receives: &[(usize, Tag)]) -> Vec<Vec<u8>> {
        let _g = self.guard();
        mpi::request::scope(|scope| {
            let requests: Vec<_> = sends
                .iter()
                .map(|&(peer, tag, data)| {
                    self.world.process_at_rank(peer as i32).immediate_send_with_tag(scope, data, tag as i32)
                })
                .collect();
            let received = receives
                .iter()
                .map(|&(peer, tag)| self.world.process_at_rank(peer as i32).receive_vec_with_tag::<u8>(tag as i32).0)
                .collect();
            for r in requests {
                r.wait();
            }
            received
        })
    }
    fn sum_words(&self, words: &mut [i64]) {
        let _g = self.guard();
        let mine = words.to_vec();
        self.world.all_reduce_into(&mine[..], words, SystemOperation::sum());
    }
    fn gather_all(&self, mine: &[u8]) -> Vec<Vec<u8>> {
        let _g = self.guard();
        let size = self.world.size() as usize;
        let mut counts = vec![0i32; size];
        self.world.all_gather_into(&(mine.len() as i32), &mut counts[..]);
        let displacements: Vec<i32> = counts
            .iter()
            .scan(0i32, |at, &c| {
                let d = *at;
                *at += c;
                Some(d)
            })
            .collect();
        let mut all = vec![0u8; counts.iter().map(|&c| c as usize).sum()];
        {
            let mut partition = PartitionMut::new(&mut all[..], &counts[..], &displacements[..]);
            self.world.all_gather_varcount_into(mine, &mut partition);
        }
        counts.iter().zip(&displacements).map(|(&c, &d)| all[d as usize..(d + c) as usize].to_vec()).collect()
    }
    fn barrier(&self) {
        let _g = self.guard();
        self.world.barrier();
    }
}

/// MPI, initialized for the whole process: kept alive until the process ends (dropping it
/// finalizes MPI).
pub struct Session {
    _universe: Universe,
    /// The world's ranks.
    pub comm: std::sync::Arc<MpiComm>,
}

/// Initializes MPI with `MPI_THREAD_SERIALIZED`; an error if the library offers less.
pub fn start() -> Result<Session, String> {
    let (universe, threading) = mpi::initialize_with_threading(Threading::Serialized)
        .ok_or("MPI was initialized already: multifield initializes it once, at start-up")?;
    if threading < Threading::Serialized {
        return Err(format!(
            "the MPI library offers thread support {threading:?}; multifield needs MPI_THREAD_SERIALIZED (build \
             Open MPI or MPICH with thread support)"
        ));
    }
    let comm = std::sync::Arc::new(MpiComm::new(universe.world()));
    if comm.size() > 1 {
        // a panic on one rank leaves the others waiting in their next exchange or sum:
        // after its message, end the whole job (MPI_Abort) instead of a hang
        let report = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            report(info);
            SimpleCommunicator::world().abort(101);
        }));
    }
    Ok(Session { _universe: universe, comm })
}

/// The MPI library's version string (`MPI_Get_library_version`), first line.
pub fn library() -> String {
    mpi::environment::library_version().unwrap_or_default().lines().next().unwrap_or("").trim().to_string()
}

/// `multifield mpi-check` on the ranks of `comm` (the 2D compile hands a 3D grid to the
/// 3D one): rank 0 prints the rank grid, the checks and pass or fail. Exit status 0 pass,
/// 1 fail, 2 bad options (the same on every rank).
pub fn check_command(comm: &MpiComm, cells: &str, ranks: Option<&str>, periodic: &str) -> std::process::ExitCode {
    use crate::mpi_check::{parse_dims, run, Setup};
    use std::process::ExitCode;
    let rank0 = comm.rank() == 0;
    let dims = match parse_dims("--cells", cells) {
        Ok(d) => d,
        Err(m) => {
            if rank0 {
                eprintln!("error: {m}");
            }
            return ExitCode::from(2);
        }
    };
    #[cfg(feature = "dim2")]
    if dims.len() == 3 {
        let comm3 = multifield3d::mpi::MpiComm::new(SimpleCommunicator::world());
        return multifield3d::mpi::check_command(&comm3, cells, ranks, periodic);
    }
    let report = Setup::parse(&dims, ranks, periodic).and_then(|setup| run(comm, &setup));
    match report {
        Err(m) => {
            if rank0 {
                eprintln!("error: mpi-check: {m}");
            }
            ExitCode::from(2)
        }
        Ok(report) => {
            if rank0 {
                println!("mpi-check: {} ({}D)", library(), crate::core::math::DIM);
                for line in &report.lines {
                    println!("  {line}");
                }
                println!("mpi-check: {}", if report.pass { "pass" } else { "FAIL" });
            }
            if report.pass {
                ExitCode::SUCCESS
            } else {
                ExitCode::from(1)
            }
        }
    }
}
