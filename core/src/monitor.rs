//! Monitors and stop conditions (`monitors: [...]` and `stop: [...]` in the case file).
//!
//! A monitor samples a few numbers of the run on its own schedule (`every: Step`, the
//! default, or `every: Time(Δ)`: the first step at or after each multiple of Δ) and
//! writes them as a row of `monitors/<name>.csv` (columns `step,time,` then the monitor's
//! own, [`MonitorSpec::columns`]), flushed row by row. Every monitor also writes a row at
//! t = 0 (a new run) and at the run's last step, whatever ends it. Kinds:
//!
//! - `Forces(bodies: [...], field: Some("f"), reference: Some((velocity, length, density)))`:
//!   the hydrodynamic force and torque summed over the named bodies (and every body of the
//!   field `f`), as `bodies.csv` reports them (the same numbers, not recomputed): columns
//!   `fx, fy, torque`, and with a reference, `c_D = fx / q`, `c_L = fy / q`,
//!   `c_M = torque / (q L)` with `q = ½ ρ U² L`; then the force's pressure and viscous
//!   parts `fx_pressure, fy_pressure, fx_viscous, fy_viscous`, summed as `bodies.csv`
//!   gives them per body (empty cells when the coupling does not give them for every
//!   body).
//! - `Probes(quantity, field, points: [...])`: a quantity at points, columns `p0, p1, …`
//!   (`p0_x, p0_y, …` for a vector).
//! - `Line(quantity, field, from, to, points: N)`: the quantity at N points evenly spaced
//!   from `from` to `to` (both included), columns `s0 … s<N−1>`.
//! - `Difference(quantity, field, from, to)`: the quantity at `from` minus that at `to`
//!   (e.g. the pressure drop across a body), columns `from, to, difference`.
//! - `Average(quantity, field, min, max)`: the mean of the quantity over the cells whose
//!   centres lie in the rectangle `min`–`max`, column `mean`.
//! - `Suspension(field, axis, bins, bed_fraction, contact_gap)`: statistics of the bodies
//!   of a field ([`suspension`]: number, solid fraction, mean and settling velocity,
//!   granular temperature, bed height, contacts), and profiles along `axis` in
//!   `monitors/<name>_profiles.csv`.
//!
//! A quantity is any cell quantity of the registry ([`crate::quantity`]), of the mixture
//! (`field: None`, the default) or of one field. Point values are interpolated
//! bilinearly from the quantity's own locations, so that a field linear in x and y is
//! sampled exactly (to round-off): `pressure` and the other cell quantities from the
//! cell centres, `velocity` from the faces of the MAC grid (u from the x-faces, v from
//! the y-faces; the mixture's face velocity is Σθu / Σθ with θ at a face the mean of its
//! two cells). Between the last cell centre and a wall the two nearest centres are
//! extrapolated linearly (still exact for a linear field). Only the values a monitor needs
//! are computed: pressure and velocity are read where they are stored; any other
//! quantity's array is computed once per sampled step, whatever the number of monitors
//! and points that read it.
//!
//! Stop conditions are evaluated after every step, after the monitors have sampled it:
//!
//! - `Steady(monitor, column, tolerance, window)`: the column's values over the last
//!   `window` of simulated time (the rows of the monitor that span it) differ by less than
//!   `tolerance` × |the latest value| (max − min);
//! - `Reaches(body, coordinate: X | Y, value, direction: Above | Below)`: the body's
//!   centre reaches `value` (≥ for `Above`, ≤ for `Below`);
//! - `WallTime(seconds: s)`: the run's time loop has taken s seconds of wall-clock time;
//! - `Steps(n)`: n steps have been taken.
//!
//! The first condition met (in the order of the list) ends the run as completed after
//! this step: every writer sees it as the last step (the last snapshot and checkpoint are
//! written at that moment) and `summary.json`'s `reason` says which condition fired, with
//! its figures. `time.end` stays the upper bound.
//!
//! A restarted run continues every monitor file as `diagnostics.csv` is continued (the
//! rows up to the checkpoint's step, [`crate::driver::resume_csv`]) and reads the `Steady`
//! conditions' history back from them, so the restarted run stops where the uninterrupted
//! one does.

use crate::case::{BodyShape, Case, QuantityName, Region, Representation};
use crate::driver::{number, resume_csv};
use crate::error::{Error, Result};
use crate::exact::{ExactSum, GROUP};
use crate::grid::{FaceVelocity, Grid, Lattice};
use crate::math::{Index, Real, AXES, DIM};
use crate::quantity::{Place, Quantity, Sample};
use crate::simulation::Simulation;
use crate::table::Table;
use serde::{Deserialize, Serialize};
use std::collections::VecDeque;
use std::fs::File;
use std::path::{Path, PathBuf};
use std::time::Instant;

pub mod suspension;

/// The folder of the monitors' CSV files in a run directory.
pub const FOLDER: &str = "monitors";

/// The most points a `Probes` or `Line` monitor may have.
pub const MAX_POINTS: usize = 10_000;

/// One monitor of the case.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MonitorSpec {
    /// Unique name: the file `monitors/<name>.csv` (letters, digits, `-`, `_`, `.`).
    pub name: String,
    /// When it samples: every step (default) or every interval of simulated time.
    #[serde(default)]
    pub every: Every,
    /// What it samples.
    pub of: Monitored,
}

/// A monitor's schedule.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub enum Every {
    /// After every step.
    #[default]
    Step,
    /// After the first step at or after each multiple of this interval of simulated time.
    Time(Real),
}

impl Every {
    /// Whether a row is due after a step from `before` to `now`.
    pub fn due(&self, before: Real, now: Real) -> bool {
        match *self {
            Every::Step => true,
            Every::Time(dt) => {
                let k = |t: Real| (t / dt + 1e-9).floor();
                k(now) > k(before)
            }
        }
    }
}

/// Reference values of the force coefficients.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Reference {
    /// Reference velocity U (length/time).
    pub velocity: Real,
    /// Reference length L (e.g. the diameter).
    pub length: Real,
    /// Reference density ρ.
    pub density: Real,
}

impl Reference {
    /// The dynamic pressure times the length, q = ½ ρ U² L.
    pub fn q(&self) -> Real {
        0.5 * self.density * self.velocity * self.velocity * self.length
    }
}

/// What a monitor samples.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum Monitored {
    /// Force and torque summed over bodies.
    Forces {
        /// Named bodies.
        #[serde(default)]
        bodies: Vec<String>,
        /// Every body of this field.
        #[serde(default)]
        field: Option<String>,
        /// Reference values: adds the columns c_D, c_L, c_M.
        #[serde(default)]
        reference: Option<Reference>,
    },
    /// A quantity at points.
    Probes {
        /// A cell quantity of the registry.
        quantity: QuantityName,
        /// The field whose quantity it is (default: the mixture's).
        #[serde(default)]
        field: Option<String>,
        /// The points.
        points: Vec<[Real; DIM]>,
    },
    /// A quantity along a segment.
    Line {
        /// A cell quantity of the registry.
        quantity: QuantityName,
        /// The field whose quantity it is (default: the mixture's).
        #[serde(default)]
        field: Option<String>,
        /// First point.
        from: [Real; DIM],
        /// Last point.
        to: [Real; DIM],
        /// Number of points (at least 2).
        points: usize,
    },
    /// A quantity at `from` minus the same at `to`.
    Difference {
        /// A cell quantity of the registry.
        quantity: QuantityName,
        /// The field whose quantity it is (default: the mixture's).
        #[serde(default)]
        field: Option<String>,
        /// First point.
        from: [Real; DIM],
        /// Second point.
        to: [Real; DIM],
    },
    /// The mean of a quantity over the cells whose centres lie in a rectangle.
    Average {
        /// A cell quantity of the registry.
        quantity: QuantityName,
        /// The field whose quantity it is (default: the mixture's).
        #[serde(default)]
        field: Option<String>,
        /// Lower-left corner.
        min: [Real; DIM],
        /// Upper-right corner.
        max: [Real; DIM],
    },
    /// The running time average of a cell quantity over the whole grid, from `start` on,
    /// written into every snapshot as `/averages/<monitor name>` (the trapezoid rule over
    /// the monitor's samples, so `every` sets its resolution in time).
    TimeAverage {
        /// A cell quantity of the registry.
        quantity: QuantityName,
        /// The field whose quantity it is (default: the mixture's).
        #[serde(default)]
        field: Option<String>,
        /// Simulated time from which to average (the first sample at or after it opens the
        /// window).
        #[serde(default)]
        start: Real,
    },
    /// Statistics of the bodies of a field (a suspension, a settling bed): their number,
    /// solid fraction, mean and settling velocity, granular temperature, bed height and
    /// contacts; and profiles along `axis` in `monitors/<name>_profiles.csv`
    /// ([`suspension`] defines each figure).
    Suspension {
        /// The field of bodies.
        field: String,
        /// The axis of the profiles and of the bed height (default `Y`).
        #[serde(default = "axis_y")]
        axis: Axis,
        /// Number of slabs of the profiles across the domain along `axis` (1 to 10,000).
        #[serde(default = "default_bins")]
        bins: usize,
        /// The bed height is the level below which this fraction of the solid area lies
        /// (0 < f ≤ 1; default 0.99).
        #[serde(default = "default_bed_fraction")]
        bed_fraction: Real,
        /// Two bodies (a body and a wall) are in contact when their gap is at most this
        /// length (default 0: touching, to 10⁻⁹ of the sum of the radii).
        #[serde(default)]
        contact_gap: Real,
    },
}

fn axis_y() -> Axis {
    Axis::Y
}

fn default_bins() -> usize {
    20
}

fn default_bed_fraction() -> Real {
    0.99
}

/// A coordinate of a body.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Axis {
    /// x.
    X,
    /// y.
    Y,
}

/// Which way a value is reached.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Direction {
    /// At or above the value.
    Above,
    /// At or below the value.
    Below,
}

/// A condition that ends the run as completed.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum StopSpec {
    /// A monitor's column changes by less than `tolerance` (relative) over `window`.
    Steady {
        /// The monitor's name.
        monitor: String,
        /// One of its columns.
        column: String,
        /// Largest relative change (max − min) / |latest| over the window; positive.
        tolerance: Real,
        /// Simulated time the values must span.
        window: Real,
    },
    /// A body's centre reaches a value.
    Reaches {
        /// The body's name.
        body: String,
        /// Which coordinate of its centre.
        coordinate: Axis,
        /// The value.
        value: Real,
        /// At or above (`Above`) or at or below (`Below`).
        direction: Direction,
    },
    /// Wall-clock seconds of the time loop.
    WallTime {
        /// Seconds.
        seconds: Real,
    },
    /// A number of steps.
    Steps(u64),
}

impl Monitored {
    /// The quantity, its field and where it is sampled, for the monitors of a quantity.
    fn quantity(&self) -> Option<(&QuantityName, &Option<String>)> {
        match self {
            Monitored::Forces { .. } | Monitored::Suspension { .. } => None,
            Monitored::Probes { quantity, field, .. }
            | Monitored::Line { quantity, field, .. }
            | Monitored::Difference { quantity, field, .. }
            | Monitored::Average { quantity, field, .. }
            | Monitored::TimeAverage { quantity, field, .. } => Some((quantity, field)),
        }
    }
    /// The kind's name.
    pub fn kind(&self) -> &'static str {
        match self {
            Monitored::Forces { .. } => "Forces",
            Monitored::Probes { .. } => "Probes",
            Monitored::Line { .. } => "Line",
            Monitored::Difference { .. } => "Difference",
            Monitored::Average { .. } => "Average",
            Monitored::TimeAverage { .. } => "TimeAverage",
            Monitored::Suspension { .. } => "Suspension",
        }
    }
}

fn place(field: &Option<String>) -> Place {
    if field.is_some() {
        Place::Field
    } else {
        Place::Mixture
    }
}

/// Names of a value's columns: `base` for a scalar, `base_x, base_y` (`, base_z` in 3D)
/// for a vector.
fn components(base: &str, n: usize) -> Vec<String> {
    if n == 1 {
        vec![base.to_string()]
    } else {
        (0..n).map(|a| format!("{base}_{}", crate::math::axis_name(a))).collect()
    }
}

impl MonitorSpec {
    /// The monitor's own columns (after `step,time`); `Err` names an unknown quantity.
    pub fn columns(&self) -> std::result::Result<Vec<String>, String> {
        let n = match self.of.quantity() {
            Some((q, field)) => crate::quantity::find(q.as_str(), place(field))?.components.min(DIM),
            None => 1,
        };
        Ok(match &self.of {
            Monitored::Forces { reference, .. } => {
                let mut c: Vec<String> = ["fx", "fy", "torque"].map(String::from).to_vec();
                if reference.is_some() {
                    c.extend(["c_D", "c_L", "c_M"].map(String::from));
                }
                c.extend(["fx_pressure", "fy_pressure", "fx_viscous", "fy_viscous"].map(String::from));
                c
            }
            Monitored::Probes { points, .. } => {
                (0..points.len()).flat_map(|k| components(&format!("p{k}"), n)).collect()
            }
            Monitored::Line { points, .. } => (0..*points).flat_map(|k| components(&format!("s{k}"), n)).collect(),
            Monitored::Difference { .. } => {
                ["from", "to", "difference"].iter().flat_map(|b| components(b, n)).collect()
            }
            Monitored::Average { .. } => components("mean", n),
            Monitored::TimeAverage { .. } => {
                ["window".to_string(), "samples".to_string()].into_iter().chain(components("mean", n)).collect()
            }
            Monitored::Suspension { .. } => suspension::COLUMNS.map(String::from).to_vec(),
        })
    }

    /// The points a monitor samples (Probes, Line, Difference).
    pub fn points(&self) -> Vec<[Real; DIM]> {
        match &self.of {
            Monitored::Probes { points, .. } => points.clone(),
            Monitored::Line { from, to, points, .. } => {
                let n = (*points).max(2);
                (0..n)
                    .map(|k| {
                        let s = k as Real / (n - 1) as Real;
                        std::array::from_fn(|a| from[a] + s * (to[a] - from[a]))
                    })
                    .collect()
            }
            Monitored::Difference { from, to, .. } => vec![*from, *to],
            _ => Vec::new(),
        }
    }

    /// What the monitor writes, in one line (for `multifield check`).
    pub fn describe(&self) -> String {
        let every = match self.every {
            Every::Step => "every step".to_string(),
            Every::Time(dt) => format!("every {dt} of simulated time"),
        };
        let what = match &self.of {
            Monitored::Forces { bodies, field, reference } => {
                let mut on: Vec<String> = bodies.iter().map(|b| format!("`{b}`")).collect();
                if let Some(f) = field {
                    on.push(format!("every body of field `{f}`"));
                }
                format!(
                    "force and torque on {}{}",
                    on.join(", "),
                    reference.map(|r| format!(", coefficients with q = ½ρU²L = {}", r.q())).unwrap_or_default()
                )
            }
            Monitored::Probes { quantity, points, .. } => format!("{quantity} at {} point(s)", points.len()),
            Monitored::Line { quantity, from, to, points, .. } => {
                format!("{quantity} at {points} points from {from:?} to {to:?}")
            }
            Monitored::Difference { quantity, from, to, .. } => format!("{quantity} at {from:?} minus at {to:?}"),
            Monitored::Average { quantity, min, max, .. } => format!("mean {quantity} over {min:?}–{max:?}"),
            Monitored::TimeAverage { quantity, start, .. } => format!(
                "running time average of {quantity} from t = {start} into the snapshots as /averages/{} \
                 (its columns: the window, the samples and the average's mean over the grid)",
                self.name
            ),
            Monitored::Suspension { field, axis, bins, bed_fraction, contact_gap } => format!(
                "statistics of the bodies of field `{field}` (bed height at {} of the solid area along {axis:?}, \
                 contacts at gaps ≤ {contact_gap}), profiles in {bins} slabs along {axis:?} into {FOLDER}/{}_profiles.csv \
                 (columns step,time,{})",
                bed_fraction,
                self.name,
                suspension::PROFILE_COLUMNS[2..].join(",")
            ),
        };
        let field = match self.of.quantity() {
            Some((_, Some(f))) => format!(" of field `{f}`"),
            Some((_, None)) => " of the mixture".into(),
            None => String::new(),
        };
        let columns = self.columns().unwrap_or_default();
        let shown = if columns.len() > 8 {
            format!("{}, …, {} ({} columns)", columns[..4].join(","), columns[columns.len() - 1], columns.len())
        } else {
            columns.join(",")
        };
        format!("{}/{}.csv: {} {what}{field}, {every}; columns step,time,{shown}", FOLDER, self.name, self.of.kind())
    }
}

impl StopSpec {
    /// The condition in one line (for `multifield check`).
    pub fn describe(&self) -> String {
        match self {
            StopSpec::Steady { monitor, column, tolerance, window } => format!(
                "Steady: stop when {monitor}.{column} changes by less than {tolerance} (relative) over {window} of simulated time"
            ),
            StopSpec::Reaches { body, coordinate, value, direction } => {
                let (c, d) = (if *coordinate == Axis::X { "x" } else { "y" }, if *direction == Direction::Above { "≥" } else { "≤" });
                format!("Reaches: stop when body `{body}` has {c} {d} {value}")
            }
            StopSpec::WallTime { seconds } => format!("WallTime: stop after {seconds} s of wall-clock time"),
            StopSpec::Steps(n) => format!("Steps: stop after step {n}"),
        }
    }
}

/// The beginnings of the reasons a stop condition gives (`summary.json`'s `reason`), one
/// per kind of [`StopSpec`].
pub const STOP_REASONS: [&str; 4] = ["steady: ", "reaches: ", "wall time: ", "steps: "];

/// Whether `reason` (of a completed run) is a stop condition's.
pub fn is_stop_reason(reason: &str) -> bool {
    STOP_REASONS.iter().any(|p| reason.starts_with(p))
}

/// The names of the case's bodies, field by field.
fn bodies_of(case: &Case) -> Vec<(&str, Vec<&str>)> {
    case.fields
        .iter()
        .filter_map(|f| match &f.region {
            Region::Bodies(b) => Some((f.name.as_str(), b.iter().map(|b| b.name.as_str()).collect())),
            _ => None,
        })
        .collect()
}

/// Why a point of a `Probes` or `Difference` monitor cannot sample its quantity: it lies
/// inside a resolved body at t = 0, where the quantity of any field but the body's own is
/// not the fluid's (no_slip coupling leaves no fluid there; direct forcing leaves a
/// fictitious one, and the mixture's value there is the body's). `None` when the point may
/// be sampled. Points on a body's edge (within 10⁻⁶ of a cell) are the fluid's; a `Line` may
/// cross bodies (docs/monitors.md).
fn inside_a_body(case: &Case, m: &MonitorSpec, q: [Real; DIM]) -> Option<String> {
    if !matches!(m.of, Monitored::Probes { .. } | Monitored::Difference { .. }) {
        return None;
    }
    let (quantity, field) = m.of.quantity()?;
    let h = case.domain.size[0] / case.cells()[0] as Real;
    for f in &case.fields {
        let Region::Bodies(bodies) = &f.region else { continue };
        if f.representation == Representation::MassPoint || field.as_deref() == Some(f.name.as_str()) {
            continue;
        }
        let Some(b) = bodies.iter().find(|b| b.shape.depth(q[0], q[1]) > 1e-6 * h) else { continue };
        let of = field.as_ref().map_or("the mixture".to_string(), |f| format!("field `{f}`"));
        let hint = match b.shape {
            BodyShape::Disk { center, radius } => {
                let (dx, dy) = (q[0] - center[0], q[1] - center[1]);
                let r = dx.hypot(dy);
                if r > 0.0 {
                    let s = (radius + 0.5 * h) / r;
                    format!(
                        "move it into the fluid, e.g. to ({}, {}) half a cell off the edge",
                        center[0] + s * dx,
                        center[1] + s * dy
                    )
                } else {
                    "move it into the fluid".to_string()
                }
            }
            _ => "move it into the fluid".to_string(),
        };
        return Some(format!(
            "the point ({}, {}) lies inside body `{}` (field `{}`) at t = 0, where `{}` of {of} is not the fluid's; \
             {hint}, or sample the body's own field with `field: Some(\"{}\")`",
            q[0],
            q[1],
            b.name,
            f.name,
            quantity.as_str(),
            f.name
        ));
    }
    None
}

fn choices<'a>(name: &str, names: impl Iterator<Item = &'a str> + Clone) -> String {
    let list: Vec<&str> = names.clone().collect();
    if list.is_empty() {
        "there are none".into()
    } else {
        format!("the choices are: {}{}", list.join(", "), crate::error::did_you_mean(name, names))
    }
}

/// Refuses monitors and stop conditions that cannot run (called by [`Case::validate`]).
pub fn validate(case: &Case) -> Result<()> {
    let bad = |path: String, message: String| Err(Error::invalid(path, message));
    let d = &case.domain;
    let inside = |p: &[Real; DIM]| AXES.iter().all(|&a| p[a] >= d.origin[a] && p[a] <= d.origin[a] + d.size[a]);
    // the domain as "[x0, x1] × [y0, y1]" (× [z0, z1])
    let domain = AXES.map(|a| format!("[{}, {}]", d.origin[a], d.origin[a] + d.size[a])).join(" × ");
    let bodies = bodies_of(case);
    let all_bodies = || bodies.iter().flat_map(|(_, b)| b.iter().copied());
    for (k, m) in case.monitors.iter().enumerate() {
        let p =
            |what: &str| format!("monitors.{}.{what}", if m.name.is_empty() { k.to_string() } else { m.name.clone() });
        if m.name.is_empty()
            || !m.name.chars().all(|c| c.is_ascii_alphanumeric() || "-_.".contains(c))
            || m.name.starts_with('.')
        {
            return bad(
                p("name"),
                format!("`{}`: a monitor's name is its file name: use letters, digits, `-`, `_` and `.`", m.name),
            );
        }
        if case.monitors[..k].iter().any(|o| o.name == m.name) {
            return bad(p("name"), format!("two monitors are named `{}`; names must be unique", m.name));
        }
        if let Some(o) = case
            .monitors
            .iter()
            .find(|o| matches!(o.of, Monitored::Suspension { .. }) && m.name == format!("{}_profiles", o.name))
        {
            return bad(
                p("name"),
                format!("`{}` is the file of the profiles of monitor `{}`; choose another name", m.name, o.name),
            );
        }
        if let Every::Time(dt) = m.every {
            if !(dt > 0.0) {
                return bad(p("every"), format!("Time({dt}): the interval must be a positive time (or `Step`)"));
            }
        }
        if let Some((q, field)) = m.of.quantity() {
            if let Some(f) = field {
                if !case.fields.iter().any(|s| &s.name == f) {
                    return bad(
                        p("of.field"),
                        format!("no field `{f}`; {}", choices(f, case.fields.iter().map(|s| s.name.as_str()))),
                    );
                }
            }
            if let Err(message) = crate::quantity::find(q.as_str(), place(field)) {
                return bad(p("of.quantity"), message);
            }
        }
        match &m.of {
            Monitored::Forces { bodies: names, field, reference } => {
                if names.is_empty() && field.is_none() {
                    return bad(
                        p("of.bodies"),
                        "name the bodies (`bodies: [\"...\"]`) or a field of bodies (`field: Some(\"...\")`)".into(),
                    );
                }
                for b in names {
                    if !all_bodies().any(|n| n == b) {
                        return bad(p("of.bodies"), format!("no body `{b}`; {}", choices(b, all_bodies())));
                    }
                }
                if let Some(f) = field {
                    if !bodies.iter().any(|(n, _)| n == f) {
                        return bad(
                            p("of.field"),
                            format!("no field of bodies `{f}`; {}", choices(f, bodies.iter().map(|(n, _)| *n))),
                        );
                    }
                }
                if let Some(r) = reference {
                    for (what, v) in [("velocity", r.velocity), ("length", r.length), ("density", r.density)] {
                        if !(v > 0.0) {
                            return bad(p(&format!("of.reference.{what}")), format!("{v}: must be positive"));
                        }
                    }
                }
            }
            Monitored::Probes { points, .. } => {
                if points.is_empty() || points.len() > MAX_POINTS {
                    return bad(p("of.points"), format!("{} points: give 1 to {MAX_POINTS}", points.len()));
                }
            }
            Monitored::Line { points, .. } => {
                if !(2..=MAX_POINTS).contains(points) {
                    return bad(p("of.points"), format!("{points}: a line has 2 to {MAX_POINTS} points"));
                }
            }
            Monitored::Difference { .. } => {}
            Monitored::Suspension { field, bins, bed_fraction, contact_gap, .. } => {
                let of_bodies =
                    || case.fields.iter().filter(|f| matches!(f.region, Region::Bodies(_))).map(|f| f.name.as_str());
                let Some(f) = case.fields.iter().find(|f| &f.name == field) else {
                    return bad(p("of.field"), format!("no field `{field}`; {}", choices(field, of_bodies())));
                };
                let has_bodies = match &f.region {
                    Region::Bodies(b) => !b.is_empty() || !f.generate.is_empty(),
                    _ => false,
                };
                if !has_bodies {
                    return bad(
                        p("of.field"),
                        format!(
                            "field `{field}` has no bodies (neither `region: Bodies([...])` nor `generate`); {}",
                            choices(field, of_bodies())
                        ),
                    );
                }
                if !(1..=MAX_POINTS).contains(bins) {
                    return bad(p("of.bins"), format!("{bins}: give 1 to {MAX_POINTS} slabs"));
                }
                if !(*bed_fraction > 0.0 && *bed_fraction <= 1.0) {
                    return bad(p("of.bed_fraction"), format!("{bed_fraction}: a fraction 0 < f ≤ 1, e.g. 0.99"));
                }
                if !(contact_gap.is_finite() && *contact_gap >= 0.0) {
                    return bad(p("of.contact_gap"), format!("{contact_gap}: a length ≥ 0"));
                }
            }
            Monitored::TimeAverage { start, .. } => {
                if !(start.is_finite() && *start >= 0.0) {
                    return bad(p("of.start"), format!("{start}: the start must be a time ≥ 0"));
                }
            }
            Monitored::Average { min, max, .. } => {
                if !AXES.iter().all(|&a| min[a] < max[a]) {
                    return bad(p("of"), format!("rectangle min {min:?} must lie below and left of max {max:?}"));
                }
                let h = d.size[0] / case.cells()[0] as Real;
                let centres =
                    |lo: Real, hi: Real, o: Real| ((hi - o) / h - 0.5).floor() - ((lo - o) / h - 0.5).ceil() + 1.0;
                if AXES.iter().any(|&a| centres(min[a], max[a], d.origin[a]) < 1.0) {
                    return bad(p("of"), format!("the rectangle {min:?}–{max:?} holds no cell centre; make it larger"));
                }
                if !inside(min) || !inside(max) {
                    return bad(
                        p("of"),
                        format!("the rectangle {min:?}–{max:?} reaches outside the domain {domain}; move it inside"),
                    );
                }
            }
        }
        for q in m.points() {
            if !inside(&q) {
                let what = if matches!(m.of, Monitored::Probes { .. }) { "of.points" } else { "of" };
                return bad(
                    p(what),
                    format!(
                        "the point ({}) lies outside the domain {domain}; move it inside",
                        q.map(|x| x.to_string()).join(", ")
                    ),
                );
            }
            if let Some(message) = inside_a_body(case, m, q) {
                let what = if matches!(m.of, Monitored::Probes { .. }) { "of.points" } else { "of" };
                return bad(p(what), message);
            }
        }
    }
    for (k, s) in case.stop.iter().enumerate() {
        let p = |what: &str| format!("stop.{k}.{what}");
        match s {
            StopSpec::Steady { monitor, column, tolerance, window } => {
                let Some(m) = case.monitors.iter().find(|m| &m.name == monitor) else {
                    return bad(
                        p("monitor"),
                        format!(
                            "no monitor `{monitor}`; {}",
                            choices(monitor, case.monitors.iter().map(|m| m.name.as_str()))
                        ),
                    );
                };
                let columns = m.columns().unwrap_or_default();
                if !columns.iter().any(|c| c == column) {
                    return bad(
                        p("column"),
                        format!(
                            "monitor `{monitor}` has no column `{column}`; {}",
                            choices(column, columns.iter().map(String::as_str))
                        ),
                    );
                }
                if !(*tolerance > 0.0) {
                    return bad(
                        p("tolerance"),
                        format!("{tolerance}: a relative tolerance must be positive, e.g. 1e-4"),
                    );
                }
                if !(*window > 0.0) {
                    return bad(p("window"), format!("{window}: the window must be a positive time"));
                }
            }
            StopSpec::Reaches { body, .. } => {
                if !all_bodies().any(|n| n == body) {
                    return bad(p("body"), format!("no body `{body}`; {}", choices(body, all_bodies())));
                }
            }
            StopSpec::WallTime { seconds } => {
                if !(*seconds > 0.0) {
                    return bad(p("seconds"), format!("{seconds}: must be a positive number of seconds"));
                }
            }
            StopSpec::Steps(n) => {
                if *n == 0 {
                    return bad(p("0"), "0 steps: give at least 1".into());
                }
            }
        }
    }
    Ok(())
}

/// Where a sampled quantity comes from.
#[derive(Clone, Copy)]
enum Source {
    /// The shared pressure, at the cell centres.
    Pressure,
    /// The face velocities of a field (or of the mixture).
    Faces(Option<usize>),
    /// Any other cell quantity: its array, computed once per sampled step (`key` into the
    /// step's cache).
    Cells { quantity: &'static Quantity, field: Option<usize>, key: usize },
}

impl Source {
    fn components(&self) -> usize {
        match self {
            Source::Pressure => 1,
            Source::Faces(_) => DIM,
            Source::Cells { quantity, .. } => quantity.components.min(DIM),
        }
    }
}

/// What the fields' grid state is at a sampled step: the state the step left (borrowed),
/// or the start's reconstruction before the first step ([`Sample`]).
struct View<'a> {
    sim: &'a Simulation,
    start: Option<Vec<(Vec<Real>, FaceVelocity)>>,
    sample: Option<Sample<'a>>,
    arrays: Vec<Option<Vec<Real>>>,
}

impl<'a> View<'a> {
    fn new(sim: &'a Simulation, keys: usize) -> Self {
        let start = (sim.steps == 0).then(|| crate::quantity::grid_states(sim));
        Self { sim, start, sample: None, arrays: vec![None; keys] }
    }
    fn theta(&self, k: usize) -> &[Real] {
        match &self.start {
            Some(s) => &s[k].0,
            None => &self.sim.fields[k].state.theta,
        }
    }
    fn faces(&self, k: usize) -> &FaceVelocity {
        match &self.start {
            Some(s) => &s[k].1,
            None => &self.sim.fields[k].state.velocity,
        }
    }
    /// Component `c` of the face velocity of `field` (None: the mixture) at node `at` of
    /// its lattice.
    fn face(&self, field: Option<usize>, c: usize, at: Index) -> Real {
        let g = &self.sim.grid;
        let index = g.index(Lattice::face(c), at);
        let value = |k: usize| self.faces(k)[c].get(index).copied().unwrap_or(0.0);
        match field {
            Some(k) => value(k),
            None if self.sim.fields.len() == 1 => value(0),
            None => {
                let (mut num, mut den) = (0.0, 0.0);
                for k in 0..self.sim.fields.len() {
                    let t = crate::quantity::face_theta(g, self.theta(k), c, at);
                    num += t * value(k);
                    den += t;
                }
                if den > 0.0 {
                    num / den
                } else {
                    0.0
                }
            }
        }
    }
    fn array(&mut self, s: Source) -> &[Real] {
        let Source::Cells { quantity, field, key } = s else { unreachable!("only cell quantities have arrays") };
        if self.arrays[key].is_none() {
            if self.sample.is_none() {
                self.sample = Some(Sample::of(self.sim));
            }
            let sample = self.sample.as_ref().expect("made above");
            self.arrays[key] = Some(sample.cells(quantity, field).unwrap_or_default());
        }
        self.arrays[key].as_deref().expect("made above")
    }
    /// Component `c` of `s` at cell `at`.
    fn cell(&mut self, s: Source, c: usize, at: Index) -> Real {
        let g = &self.sim.grid;
        let cell = g.index(Lattice::Cell, at);
        match s {
            Source::Pressure => self.sim.pressure.get(cell).copied().unwrap_or(0.0),
            Source::Faces(field) => {
                let mut next = at;
                next[c] += 1;
                0.5 * (self.face(field, c, at) + self.face(field, c, next))
            }
            Source::Cells { quantity, .. } => {
                let n = quantity.components;
                self.array(s).get(n * cell + c).copied().unwrap_or(Real::NAN)
            }
        }
    }
    /// Component `c` of `s` at the point `p`, multilinear on its lattice (module doc):
    /// along x first, then y (then z).
    fn at(&mut self, s: Source, c: usize, p: [Real; DIM]) -> Real {
        let lattice = match s {
            Source::Faces(_) => Lattice::face(c),
            _ => Lattice::Cell,
        };
        let g: &Grid = &self.sim.grid;
        let shape = g.shape(lattice);
        let mut nodes = [(0, 0); DIM];
        let mut weight = [0.0; DIM];
        for a in AXES {
            let offset = if lattice.axis() == Some(a) { 0.0 } else { 0.5 };
            let (lo, hi, w) = corner((p[a] - g.origin[a]) / g.h - offset, shape[a]);
            (nodes[a], weight[a]) = ((lo, hi), w);
        }
        // the 2^DIM corners, bit a of m choosing the high node along axis a
        let mut values: Vec<Real> = (0..1usize << DIM)
            .map(|m| {
                let at: Index = std::array::from_fn(|a| if m >> a & 1 == 0 { nodes[a].0 } else { nodes[a].1 });
                match s {
                    Source::Faces(field) => self.face(field, c, at),
                    _ => self.cell(s, c, at),
                }
            })
            .collect();
        for w in weight {
            values = values.chunks(2).map(|v| (1.0 - w) * v[0] + w * v[1]).collect();
        }
        values[0]
    }
}

/// The two nodes of an axis of `n` nodes around the fractional index `f`, and the weight
/// of the second: interpolation inside, linear extrapolation from the last two beyond.
fn corner(f: Real, n: usize) -> (usize, usize, Real) {
    if n < 2 {
        return (0, 0, 0.0);
    }
    let i = (f.floor().max(0.0) as usize).min(n - 2);
    (i, i + 1, f - i as Real)
}

/// One monitor as it runs: its spec resolved against the simulation, and its file.
struct Running {
    spec: MonitorSpec,
    source: Option<Source>,
    points: Vec<[Real; DIM]>,
    /// Cells of an `Average`.
    cells: Vec<Index>,
    /// Indices into [`Simulation::bodies`] of a `Forces`.
    bodies: Vec<usize>,
    file: csv::Writer<File>,
    path: PathBuf,
    /// Sampled at the current step already.
    written: bool,
    /// Index into [`Simulation::averages`] of a `TimeAverage`.
    average: Option<usize>,
    /// A `Suspension`'s geometry and profiles file.
    stats: Option<Stats>,
}

/// What a `Suspension` monitor keeps.
struct Stats {
    geometry: suspension::Geometry,
    file: csv::Writer<File>,
    path: PathBuf,
}

impl Running {
    fn values(
        &self,
        view: &mut View,
        bodies: &[(String, crate::plugin::BodyState)],
        pressure: &[Option<crate::math::Vector>],
    ) -> Vec<Real> {
        match &self.spec.of {
            Monitored::Forces { reference, .. } => {
                let (mut fx, mut fy, mut t) = (0.0, 0.0, 0.0);
                let (mut px, mut py) = (0.0, 0.0);
                for &k in &self.bodies {
                    let b = &bodies[k].1;
                    fx += b.force.x;
                    fy += b.force.y;
                    t += b.torque;
                    // the pressure part where the coupling gives it for every body (NaN:
                    // an empty cell, as in bodies.csv)
                    match pressure.get(k).copied().flatten() {
                        Some(p) => {
                            px += p.x;
                            py += p.y;
                        }
                        None => (px, py) = (Real::NAN, Real::NAN),
                    }
                }
                let mut v = vec![fx, fy, t];
                if let Some(r) = reference {
                    let q = r.q();
                    v.extend([fx / q, fy / q, t / (q * r.length)]);
                }
                v.extend([px, py, fx - px, fy - py]);
                v
            }
            Monitored::TimeAverage { .. } | Monitored::Suspension { .. } => Vec::new(),
            Monitored::Average { .. } => {
                let s = self.source.expect("a quantity");
                let n = s.components();
                // the reduction rule (docs/design/mpi.md §3): the cells (in storage order) in
                // row groups of 32 along x, each summed in order, the groups added exactly
                let mut sums = vec![ExactSum::new(); n];
                let mut group = vec![0.0; n];
                let key = |at: &Index| {
                    let mut k = *at;
                    k[0] /= GROUP;
                    k
                };
                for (i, at) in self.cells.iter().enumerate() {
                    if i > 0 && key(at) != key(&self.cells[i - 1]) {
                        for (s, g) in sums.iter_mut().zip(&mut group) {
                            s.add(std::mem::take(g));
                        }
                    }
                    for (c, x) in group.iter_mut().enumerate() {
                        *x += view.cell(s, c, *at);
                    }
                }
                if !self.cells.is_empty() {
                    for (s, g) in sums.iter_mut().zip(&group) {
                        s.add(*g);
                    }
                }
                let sums = reduce_all(&sums);
                sums.iter().map(|x| x / self.cells.len() as Real).collect()
            }
            _ => {
                let s = self.source.expect("a quantity");
                let n = s.components();
                let mut v = Vec::with_capacity(n * self.points.len());
                for p in &self.points {
                    for c in 0..n {
                        v.push(view.at(s, c, *p));
                    }
                }
                if matches!(self.spec.of, Monitored::Difference { .. }) {
                    let d: Vec<Real> = (0..n).map(|c| v[c] - v[n + c]).collect();
                    v.extend(d);
                }
                v
            }
        }
    }
    fn needs_grid(&self) -> bool {
        !matches!(self.source, None | Some(Source::Pressure))
    }
}

/// A value as written: [`number`], an empty cell for NaN (a force's pressure part where
/// the coupling does not give it).
fn cell(x: Real) -> String {
    if x.is_nan() {
        String::new()
    } else {
        number(x)
    }
}

/// Stage 3 of the reduction rule for a number of sums known at run time (as
/// [`crate::exact::reduce`], through which it goes).
fn reduce_all(sums: &[ExactSum]) -> Vec<Real> {
    sums.iter().map(|s| crate::exact::reduce(&crate::exact::Sums([s.clone()]))[0]).collect()
}

/// The running time average of a `TimeAverage` monitor. The [`Simulation`] carries it
/// ([`Simulation::averages`]) so that snapshots write it and checkpoints keep it: a
/// restarted run continues the average bit for bit.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TimeAverage {
    /// The monitor's name (`/averages/<name>` in the snapshots).
    pub name: String,
    /// The quantity averaged.
    pub quantity: String,
    /// Its field (None: the mixture's).
    pub field: Option<String>,
    /// Values per cell (1, or 3 for a vector with z = 0, as the registry gives them).
    pub components: usize,
    /// The requested start.
    pub start: Real,
    /// Time of the first sample (NaN before it).
    pub first: Real,
    /// Time of the last sample (NaN before the first).
    pub last_time: Real,
    /// Samples taken.
    pub samples: u64,
    /// The last sample, cell by cell (the cell's components together).
    pub last: Vec<Real>,
    /// ∫ q dt from the first sample to the last, by the trapezoid rule over the samples.
    pub integral: Vec<Real>,
}

impl TimeAverage {
    fn new(name: &str, quantity: &str, field: &Option<String>, components: usize, start: Real) -> Self {
        Self {
            name: name.into(),
            quantity: quantity.into(),
            field: field.clone(),
            components,
            start,
            first: Real::NAN,
            last_time: Real::NAN,
            samples: 0,
            last: Vec::new(),
            integral: Vec::new(),
        }
    }

    /// Whether `saved` (from a checkpoint) continues this average: the same monitor
    /// name, quantity, field and start.
    fn continued_by(&self, saved: &TimeAverage) -> bool {
        (&self.name, &self.quantity, &self.field, self.components, self.start.to_bits())
            == (&saved.name, &saved.quantity, &saved.field, saved.components, saved.start.to_bits())
    }

    /// The length of simulated time averaged over (0 with one sample or none).
    pub fn window(&self) -> Real {
        if self.samples > 1 {
            self.last_time - self.first
        } else {
            0.0
        }
    }

    /// The average, ∫ q dt / window (the only sample while the window is empty); empty
    /// before the first sample.
    pub fn mean(&self) -> Vec<Real> {
        let w = self.window();
        if w > 0.0 {
            self.integral.iter().map(|x| x / w).collect()
        } else {
            self.last.clone()
        }
    }

    /// Adds the sample `q` at time `t` (ignored before the start; a time short of it by
    /// round-off, 10⁻⁹ of it, counts as the start, as the monitors' schedules do).
    fn add(&mut self, t: Real, q: Vec<Real>) {
        if t < self.start * (1.0 - 1e-9) {
            return;
        }
        if self.samples == 0 {
            self.first = t;
            self.integral = vec![0.0; q.len()];
        } else {
            let half = 0.5 * (t - self.last_time);
            for ((s, a), b) in self.integral.iter_mut().zip(&self.last).zip(&q) {
                *s += half * (a + b);
            }
        }
        self.last = q;
        self.last_time = t;
        self.samples += 1;
    }

    /// The monitor's row: the window, the samples, and the average's mean over the cells
    /// (per component, at most DIM); NaN before the first sample.
    /// The cells are those of the grid in storage order, rows of `nx` cells: summed by the
    /// reduction rule (docs/design/mpi.md §3).
    fn row(&self, nx: usize) -> Vec<Real> {
        let n = self.components.min(DIM);
        let mean = self.mean();
        let cells = mean.len() / self.components.max(1);
        let mut row = vec![self.window(), self.samples as Real];
        let per = self.components;
        let sums = crate::exact::row_sums(cells, nx, nx, GROUP, |g| {
            let mut v = [0.0; DIM];
            for (c, v) in v.iter_mut().enumerate().take(n) {
                *v = g.clone().map(|k| mean[k * per + c]).sum();
            }
            v
        });
        let sums = crate::exact::reduce(&sums);
        for sum in &sums[..n] {
            row.push(if cells > 0 { sum / cells as Real } else { Real::NAN });
        }
        row
    }

    /// Checks a saved average against the grid of `n_cells` cells (a checkpoint's).
    pub fn check(&self, n_cells: usize) -> std::result::Result<(), String> {
        let n = if self.samples == 0 { 0 } else { n_cells * self.components };
        if self.last.len() != n || self.integral.len() != n || !(1..=3).contains(&self.components) {
            return Err(format!(
                "time average `{}`: {} and {} values for {} samples of {} component(s) on {n_cells} cells",
                self.name,
                self.last.len(),
                self.integral.len(),
                self.samples,
                self.components
            ));
        }
        Ok(())
    }
}

/// The `Steady` history of one stop condition.
struct Steady {
    monitor: usize,
    column: usize,
    history: VecDeque<(Real, Real)>,
}

/// The monitors and stop conditions of a run, sampled and evaluated by the driver after
/// every step ([`crate::driver::Driver::set_monitors`]).
pub struct Monitors {
    running: Vec<Running>,
    stops: Vec<StopSpec>,
    steady: Vec<Option<Steady>>,
    keys: usize,
    before: Real,
    resumed: bool,
    started: Instant,
    seconds: f64,
}

fn io(path: &Path) -> impl Fn(std::io::Error) -> Error + '_ {
    move |source| Error::Io { path: path.to_path_buf(), source }
}

impl Monitors {
    /// The monitors of `sim`'s case writing into `dir/monitors/` (new files), or None when
    /// the case has neither monitors nor stop conditions.
    pub fn create(sim: &mut Simulation, dir: &Path) -> Result<Option<Self>> {
        Self::open(sim, dir, None)
    }

    /// The monitors of a run restarted at `sim`'s step: each file keeps its rows up to that
    /// step (taken from `source_dir`'s file when it exists, [`resume_csv`]).
    /// The running time averages continue from the checkpoint's
    /// ([`Simulation::averages`]) where the monitor is the same; others start anew.
    pub fn resume(sim: &mut Simulation, dir: &Path, source_dir: Option<&Path>) -> Result<Option<Self>> {
        Self::open(sim, dir, Some(source_dir))
    }

    fn open(sim: &mut Simulation, dir: &Path, resume: Option<Option<&Path>>) -> Result<Option<Self>> {
        let saved = std::mem::take(&mut sim.averages);
        let case = &sim.case;
        if case.monitors.is_empty() && case.stop.is_empty() {
            return Ok(None);
        }
        let mut averages = Vec::new();
        let folder = dir.join(FOLDER);
        if !case.monitors.is_empty() {
            std::fs::create_dir_all(&folder).map_err(io(&folder))?;
        }
        let bodies = sim.bodies();
        let mut keys = 0;
        let mut running = Vec::new();
        for m in &case.monitors {
            let bad = |message: String| Error::invalid(format!("monitors.{}", m.name), message);
            let field = |f: &Option<String>| -> Result<Option<usize>> {
                f.as_ref().map(|f| sim.field_index(f).ok_or_else(|| bad(format!("no field `{f}`")))).transpose()
            };
            let source = match m.of.quantity() {
                None => None,
                Some((q, f)) => {
                    let k = field(f)?;
                    let quantity = crate::quantity::find(q.as_str(), place(f)).map_err(bad)?;
                    let whole = matches!(m.of, Monitored::TimeAverage { .. });
                    Some(match (q.as_str(), k) {
                        ("pressure", None) if !whole => Source::Pressure,
                        ("velocity", k) if !whole => Source::Faces(k),
                        (_, field) => {
                            keys += 1;
                            Source::Cells { quantity, field, key: keys - 1 }
                        }
                    })
                }
            };
            let mut chosen = Vec::new();
            if let Monitored::Forces { bodies: names, field: f, .. } = &m.of {
                for (k, (field, b)) in bodies.iter().enumerate() {
                    if names.contains(&b.name) || f.as_ref() == Some(field) {
                        chosen.push(k);
                    }
                }
            }
            let mut stats = None;
            if let Monitored::Suspension { field: f, axis, bins, bed_fraction, contact_gap } = &m.of {
                chosen = (0..bodies.len()).filter(|&k| &bodies[k].0 == f).collect();
                if chosen.is_empty() {
                    return Err(bad(format!("field `{f}` has no bodies")));
                }
                let geometry = suspension::Geometry::new(
                    case.domain.origin,
                    case.domain.size,
                    &case.boundaries,
                    case.gravity,
                    *axis,
                    *bins,
                    *bed_fraction,
                    *contact_gap,
                );
                let path = folder.join(format!("{}_profiles.csv", m.name));
                let header = suspension::PROFILE_COLUMNS.join(",");
                let file = match resume {
                    None => crate::driver::create_csv(&path, &header)?,
                    Some(source) => {
                        let step = sim.steps;
                        let from = source.map(|d| d.join(FOLDER).join(format!("{}_profiles.csv", m.name)));
                        resume_csv(&path, from.as_deref(), &header, |s| s <= step)?.0
                    }
                };
                stats = Some(Stats { geometry, file, path });
            }
            let mut cells = Vec::new();
            if let Monitored::Average { min, max, .. } = &m.of {
                let g = &sim.grid;
                for (_, at) in g.nodes(Lattice::Cell) {
                    let c = g.position(Lattice::Cell, at);
                    if AXES.iter().all(|&a| c[a] >= min[a] && c[a] <= max[a]) {
                        cells.push(at);
                    }
                }
            }
            let columns = m.columns().map_err(bad)?;
            let header = ["step", "time"].iter().map(|s| s.to_string()).chain(columns).collect::<Vec<_>>().join(",");
            let path = folder.join(format!("{}.csv", m.name));
            let file = match resume {
                None => crate::driver::create_csv(&path, &header)?,
                Some(source) => {
                    let step = sim.steps;
                    let from = source.map(|d| d.join(FOLDER).join(format!("{}.csv", m.name)));
                    resume_csv(&path, from.as_deref(), &header, |s| s <= step)?.0
                }
            };
            let average = match (&m.of, source) {
                (Monitored::TimeAverage { quantity, field, start }, Some(Source::Cells { quantity: q, .. })) => {
                    let fresh = TimeAverage::new(&m.name, quantity.as_str(), field, q.components, *start);
                    let kept = saved.iter().find(|s| resume.is_some() && fresh.continued_by(s)).cloned();
                    averages.push(kept.unwrap_or(fresh));
                    Some(averages.len() - 1)
                }
                _ => None,
            };
            running.push(Running {
                spec: m.clone(),
                source,
                points: m.points(),
                cells,
                bodies: chosen,
                file,
                path,
                written: false,
                average,
                stats,
            });
        }
        let mut steady = Vec::new();
        for s in &case.stop {
            steady.push(match s {
                StopSpec::Steady { monitor, column, .. } => {
                    let m = running.iter().position(|r| &r.spec.name == monitor).expect("validated");
                    let c = running[m]
                        .spec
                        .columns()
                        .unwrap_or_default()
                        .iter()
                        .position(|c| c == column)
                        .expect("validated");
                    Some(Steady { monitor: m, column: c + 2, history: VecDeque::new() })
                }
                _ => None,
            });
        }
        let stops = case.stop.clone();
        sim.averages = averages;
        let mut out = Self {
            running,
            stops,
            steady,
            keys,
            before: sim.time,
            resumed: resume.is_some(),
            started: Instant::now(),
            seconds: 0.0,
        };
        if out.resumed {
            // the Steady conditions' history from the rows kept
            for k in 0..out.running.len() {
                if let Some(t) = Table::read(&out.running[k].path)? {
                    for r in &t.rows {
                        let row: Vec<Real> = r.iter().map(|s| s.parse().unwrap_or(Real::NAN)).collect();
                        out.record(k, &row);
                    }
                }
            }
        }
        Ok(Some(out))
    }

    /// The files of the monitors.
    pub fn files(&self) -> Vec<PathBuf> {
        let profiles = self.running.iter().filter_map(|r| r.stats.as_ref().map(|s| s.path.clone()));
        self.running.iter().map(|r| r.path.clone()).chain(profiles).collect()
    }

    /// Before the first step: the rows at t = 0 of a new run.
    pub fn start(&mut self, sim: &mut Simulation) -> Result<()> {
        self.started = Instant::now();
        self.before = sim.time;
        if !self.resumed {
            let all: Vec<usize> = (0..self.running.len()).collect();
            self.sample(sim, &all)?;
        }
        Ok(())
    }

    /// After a step: samples the monitors that are due (all of them when `last`), then,
    /// unless the run stops as unstable, evaluates the stop conditions; the first met
    /// gives the reason to stop, and every monitor then gets this step's row.
    pub fn after_step(&mut self, sim: &mut Simulation, last: bool, unstable: bool) -> Result<Option<String>> {
        let clock = Instant::now();
        let out = self.sample_and_stop(sim, last, unstable);
        self.seconds += clock.elapsed().as_secs_f64();
        out
    }

    /// Wall-clock seconds spent after the steps sampling the monitors and evaluating the
    /// stop conditions (the refresh of a stale grid state included).
    pub fn seconds(&self) -> f64 {
        self.seconds
    }

    fn sample_and_stop(&mut self, sim: &mut Simulation, last: bool, unstable: bool) -> Result<Option<String>> {
        for r in &mut self.running {
            r.written = false;
        }
        let due: Vec<usize> = (0..self.running.len())
            .filter(|&k| last || self.running[k].spec.every.due(self.before, sim.time))
            .collect();
        self.before = sim.time;
        self.refresh(sim, &due)?;
        self.sample(sim, &due)?;
        if unstable {
            return Ok(None);
        }
        let reason = self.stop_reason(sim);
        if reason.is_some() {
            let rest: Vec<usize> = (0..self.running.len()).filter(|&k| !self.running[k].written).collect();
            self.refresh(sim, &rest)?;
            self.sample(sim, &rest)?;
        }
        Ok(reason)
    }

    fn refresh(&self, sim: &mut Simulation, which: &[usize]) -> Result<()> {
        if sim.steps > 0 && sim.grid_state_stale() && which.iter().any(|&k| self.running[k].needs_grid()) {
            sim.refresh_grid_state()?;
        }
        Ok(())
    }

    fn sample(&mut self, sim: &mut Simulation, which: &[usize]) -> Result<()> {
        if which.is_empty() {
            return Ok(());
        }
        let mut rows = Vec::with_capacity(which.len());
        let mut fresh = Vec::new();
        let mut profiles = Vec::new();
        {
            let mut view = View::new(sim, self.keys);
            let any_bodies = which.iter().any(|&k| !self.running[k].bodies.is_empty());
            let forces = which.iter().any(|&k| matches!(self.running[k].spec.of, Monitored::Forces { .. }));
            let bodies = if any_bodies { sim.bodies() } else { Vec::new() };
            let pressure = if forces { sim.pressure_forces() } else { Vec::new() };
            for &k in which {
                let r = &self.running[k];
                if let (Some(a), Some(s)) = (r.average, r.source) {
                    fresh.push((a, view.array(s).to_vec()));
                }
                if let Some(stats) = &r.stats {
                    let chosen: Vec<&crate::plugin::BodyState> = r.bodies.iter().map(|&b| &bodies[b].1).collect();
                    let (row, profile) = suspension::sample(&stats.geometry, &chosen);
                    rows.push(row);
                    profiles.push((k, profile));
                } else {
                    rows.push(r.values(&mut view, &bodies, &pressure));
                }
            }
        }
        for (k, profile) in profiles {
            let Some(stats) = self.running[k].stats.as_mut() else { continue };
            for (j, p) in profile.iter().enumerate() {
                let text: Vec<String> = [sim.steps.to_string(), cell(sim.time), j.to_string()]
                    .into_iter()
                    .chain(p.iter().map(|&x| cell(x)))
                    .collect();
                stats.file.write_record(&text).map_err(|e| crate::driver::csv_error(&stats.path, e))?;
            }
            stats.file.flush().map_err(io(&stats.path))?;
        }
        let t = sim.time;
        for (a, q) in fresh {
            sim.averages[a].add(t, q);
        }
        for (&k, values) in which.iter().zip(rows) {
            let values = self.running[k].average.map_or(values, |a| sim.averages[a].row(sim.grid.nx));
            let mut row = Vec::with_capacity(values.len() + 2);
            row.push(sim.steps as Real);
            row.push(sim.time);
            row.extend(values);
            let r = &mut self.running[k];
            let text: Vec<String> =
                std::iter::once(sim.steps.to_string()).chain(row[1..].iter().map(|&x| cell(x))).collect();
            r.file.write_record(&text).map_err(|e| crate::driver::csv_error(&r.path, e))?;
            r.file.flush().map_err(io(&r.path))?;
            r.written = true;
            // the history holds the values as written (the restarted run reads them back)
            let row: Vec<Real> = text.iter().map(|s| s.parse().unwrap_or(Real::NAN)).collect();
            self.record(k, &row);
        }
        Ok(())
    }

    /// Adds a row of monitor `k` to the Steady conditions that read it.
    fn record(&mut self, k: usize, row: &[Real]) {
        for (s, spec) in self.steady.iter_mut().zip(&self.stops) {
            let (Some(s), StopSpec::Steady { window, .. }) = (s, spec) else { continue };
            if s.monitor != k || row.len() <= s.column {
                continue;
            }
            let t = row[1];
            s.history.push_back((t, row[s.column]));
            // keep the newest row at or before t − window, and the rows after it
            while s.history.len() > 2 && s.history[1].0 <= t - window {
                s.history.pop_front();
            }
        }
    }

    fn stop_reason(&self, sim: &Simulation) -> Option<String> {
        for (spec, steady) in self.stops.iter().zip(&self.steady) {
            let reason = match (spec, steady) {
                (StopSpec::Steady { monitor, column, tolerance, window }, Some(s)) => {
                    let (Some(first), Some(latest)) = (s.history.front(), s.history.back()) else { continue };
                    let span = latest.0 - first.0;
                    if !(span >= window * (1.0 - 1e-9)) {
                        continue;
                    }
                    let (lo, hi) = s
                        .history
                        .iter()
                        .fold((Real::INFINITY, Real::NEG_INFINITY), |(lo, hi), x| (lo.min(x.1), hi.max(x.1)));
                    let change = (hi - lo) / latest.1.abs();
                    if !(hi - lo < tolerance * latest.1.abs()) {
                        continue;
                    }
                    format!(
                        "steady: {monitor}.{column} changed {} (relative; max − min {}) over {} of simulated time, \
                         below the tolerance {tolerance}, at step {}, t = {}",
                        number(change),
                        number(hi - lo),
                        number(span),
                        sim.steps,
                        sim.time
                    )
                }
                (StopSpec::Reaches { body, coordinate, value, direction }, _) => {
                    let bodies = sim.bodies();
                    let Some((_, b)) = bodies.iter().find(|(_, b)| &b.name == body) else { continue };
                    let (x, c) = match coordinate {
                        Axis::X => (b.position.x, "x"),
                        Axis::Y => (b.position.y, "y"),
                    };
                    let met = match direction {
                        Direction::Above => x >= *value,
                        Direction::Below => x <= *value,
                    };
                    if !met {
                        continue;
                    }
                    let d = if *direction == Direction::Above { "≥" } else { "≤" };
                    format!(
                        "reaches: body `{body}` has {c} = {} {d} {value} at step {}, t = {}",
                        number(x),
                        sim.steps,
                        sim.time
                    )
                }
                (StopSpec::WallTime { seconds }, _) => {
                    let s = self.started.elapsed().as_secs_f64();
                    if s < *seconds {
                        continue;
                    }
                    format!(
                        "wall time: {s:.1} s reached the limit of {seconds} s at step {}, t = {}",
                        sim.steps, sim.time
                    )
                }
                (StopSpec::Steps(n), _) => {
                    if sim.steps < *n {
                        continue;
                    }
                    format!("steps: {n} steps reached at t = {}", sim.time)
                }
                _ => continue,
            };
            return Some(reason);
        }
        None
    }
}
