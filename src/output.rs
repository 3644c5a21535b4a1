//! Writers that run beside the diagnostics, each on its own schedule in simulated time
//! (`output` in the case): HDF5 snapshots ([`crate::snapshot`]) and PNG pictures
//! ([`crate::picture`]), [`Writer`]s of the core's driver ([`crate::core::driver`]), which
//! calls [`Writer::start`] before the first step and [`Writer::after_step`] after every
//! step, with `last` set on the final step of the run whatever ended it; charts
//! ([`crate::charts`]) are drawn from the CSV files at the end.
//! Every file is written under a temporary name and renamed ([`write_atomically`]), so
//! a killed run never leaves a half-written one.

use crate::core::error::Error;
use crate::core::math::Real;
use crate::core::simulation::Simulation;
use std::path::Path;

pub use crate::core::driver::{write_atomically, Writer};

/// The writers the case asks for.
pub fn writers(sim: &Simulation, dir: &Path) -> Result<Vec<Box<dyn Writer>>, Error> {
    let mut out: Vec<Box<dyn Writer>> = Vec::new();
    if let Some(s) = sim.case.output.snapshots.clone() {
        out.push(Box::new(crate::snapshot::Snapshots::create(sim, dir, s)?));
    }
    if let Some(p) = sim.case.output.pictures.clone() {
        out.push(Box::new(crate::picture::Pictures::create(sim, dir, p)?));
    }
    Ok(out)
}

/// When a scheduled write is due: at `first`, then every `interval` of simulated time.
#[derive(Clone, Copy, Debug)]
pub struct Due {
    next: Real,
    interval: Real,
}

impl Due {
    /// A schedule whose first write is at `first`.
    pub fn new(first: Real, interval: Real) -> Self {
        Self { next: first, interval }
    }
    /// Simulated time of the next write.
    pub fn next(&self) -> Real {
        self.next
    }
    /// Whether a write is due at time `t`, without moving the schedule.
    pub fn peek(&self, t: Real) -> bool {
        t >= self.next - 1e-9 * self.interval
    }
    /// Whether a write is due at time `t`; if so, moves the schedule past `t`.
    pub fn check(&mut self, t: Real) -> bool {
        if t < self.next - 1e-9 * self.interval {
            return false;
        }
        self.next = crate::core::driver::schedule_past(self.next, t + 1e-9 * self.interval, self.interval);
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn due_fires_at_first_then_every_interval() {
        let mut d = Due::new(0.0, 0.1);
        let fired: Vec<Real> = (0..=25).map(|k| k as Real * 0.02).filter(|&t| d.check(t)).collect();
        assert_eq!(fired.len(), 6, "{fired:?}");
        assert!((fired[1] - 0.1).abs() < 1e-12 && (fired[5] - 0.5).abs() < 1e-12, "{fired:?}");
    }

    #[test]
    fn an_atomic_write_replaces_the_whole_file() {
        let dir = std::env::temp_dir().join(format!("multifield-atomic-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join("a.txt");
        write_atomically(&p, b"old").unwrap();
        write_atomically(&p, b"new").unwrap();
        assert_eq!(std::fs::read(&p).unwrap(), b"new");
        assert!(!dir.join(".a.txt.tmp").exists());
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
