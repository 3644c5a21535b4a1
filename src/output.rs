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
        if p.slice.is_empty() {
            out.push(Box::new(crate::picture::Pictures::create(sim, dir, p, None)?));
        } else {
            // 3D: a writer per slice, each into its own folder
            for s in &p.slice {
                out.push(Box::new(crate::picture::Pictures::create(sim, dir, p.clone(), Some(s))?));
            }
        }
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

/// When a writer with an optional interval, exact times and `at_end` writes
/// (`output.snapshots`, `output.pictures`): on its interval schedule ([`Due`]), at the
/// first step that reaches each of its `times` (the step lands on it, see
/// [`crate::core::case::OutputSpec::next_moment`]), and at the run's last step when it has
/// an interval or `at_end`. The times still to come are derived from the simulated time,
/// so a run continued from a checkpoint needs no state of this schedule.
#[derive(Clone, Debug)]
pub struct Moments {
    due: Option<Due>,
    times: Vec<Real>,
    pending: usize,
    at_end: bool,
}

impl Moments {
    /// The schedule of `due` (none without an interval), `times` and `at_end` for a run at
    /// simulated time `t`: the times reached by `t` are past.
    pub fn new(due: Option<Due>, times: &[Real], at_end: bool, t: Real) -> Self {
        let pending = crate::core::case::first_pending(times, t);
        let at_end = at_end || due.is_some();
        Self { due, times: times.to_vec(), pending, at_end }
    }
    /// Whether a write is due at time `t` on the `last` step, without moving the schedule.
    pub fn peek(&self, t: Real, last: bool) -> bool {
        self.due.is_some_and(|d| d.peek(t))
            || self.times.get(self.pending).is_some_and(|&m| crate::core::case::moment_reached(m, t))
            || (last && self.at_end)
    }
    /// Whether a write is due at time `t` on the `last` step; moves the schedule past `t`.
    pub fn check(&mut self, t: Real, last: bool) -> bool {
        let interval = self.due.as_mut().is_some_and(|d| d.check(t));
        let before = self.pending;
        self.pending = before + crate::core::case::first_pending(&self.times[before..], t);
        interval || self.pending > before || (last && self.at_end)
    }
    /// Whether it has an interval (whose schedule starts with a write at t = 0).
    pub fn has_interval(&self) -> bool {
        self.due.is_some()
    }
    /// Whether `t` is one of the exact times, to round-off.
    pub fn is_exact_time(&self, t: Real) -> bool {
        self.times.iter().any(|&m| (t - m).abs() <= 1e-12 * m)
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
    fn moments_fire_at_each_time_once_and_at_the_end() {
        let mut m = Moments::new(None, &[0.25, 0.5], true, 0.0);
        let steps = [0.1, 0.2, 0.25 - 1e-15, 0.3, 0.5, 0.6];
        let fired: Vec<bool> = steps.iter().enumerate().map(|(k, &t)| m.check(t, k == steps.len() - 1)).collect();
        assert_eq!(fired, [false, false, true, false, true, true]);
        // continued at t = 0.25: only 0.5 is to come
        let m = Moments::new(None, &[0.25, 0.5], false, 0.25);
        assert!(!m.peek(0.3, true) && m.peek(0.5, false));
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
