//! Drafting–kissing–tumbling analysis of a run: reads `bodies.csv` and `case.ron`, finds
//! the kiss time (the gap along gravity between the two centres first ≤ d) and the tumble
//! time (the trailing disk passes the leading one along gravity), measures the RMS distance
//! to Uhlmann (2005) along-gravity positions, and plots the trajectories against the
//! published curves (PNG and SVG). The curves are those of
//! `validation/reference/dkt-uhlmann2005`, built into the program ([`ReferenceCurves::Shipped`])
//! unless a folder is given.

use crate::core::case::Case;
use crate::core::error::Error;
use crate::core::math::Real;
use crate::plot::{write_chart, Chart, Series};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// The time history of one body.
#[derive(Clone, Debug, Default)]
pub struct Track {
    /// Times.
    pub t: Vec<Real>,
    /// Centroid x.
    pub x: Vec<Real>,
    /// Centroid y.
    pub y: Vec<Real>,
    /// Velocity x.
    pub vx: Vec<Real>,
    /// Velocity y.
    pub vy: Vec<Real>,
    /// Angular velocity.
    pub omega: Vec<Real>,
}

/// Reads `bodies.csv` into one track per body name (its complete rows; a row whose time
/// does not advance the body's track is skipped).
pub fn read_bodies(path: &Path) -> Result<BTreeMap<String, Track>, Error> {
    let table = crate::core::table::Table::read(path)?.ok_or_else(|| Error::Io {
        path: path.to_path_buf(),
        source: std::io::Error::new(std::io::ErrorKind::NotFound, "no such file"),
    })?;
    let mut out: BTreeMap<String, Track> = BTreeMap::new();
    for (n, f) in table.rows.iter().enumerate() {
        let num = |k: usize| {
            f[k].parse::<Real>().map_err(|_| {
                Error::Model(format!(
                    "{}:{}: column {} is not a number: `{}`",
                    path.display(),
                    table.line(n),
                    k + 1,
                    &f[k]
                ))
            })
        };
        let time = num(1)?;
        let tr = out.entry(f[2].to_string()).or_default();
        if tr.t.last().is_some_and(|&t| t >= time) {
            continue;
        }
        tr.t.push(time);
        tr.x.push(num(3)?);
        tr.y.push(num(4)?);
        tr.vx.push(num(5)?);
        tr.vy.push(num(6)?);
        tr.omega.push(num(7)?);
    }
    Ok(out)
}

/// Linear interpolation of (t, v) at `t`, `None` outside the range.
pub fn interpolate(ts: &[Real], vs: &[Real], t: Real) -> Option<Real> {
    if ts.is_empty() || t < ts[0] || t > *ts.last()? {
        return None;
    }
    let k = ts.partition_point(|&x| x < t);
    if k == 0 {
        return Some(vs[0]);
    }
    let (t0, t1, v0, v1) = (ts[k - 1], ts[k], vs[k - 1], vs[k]);
    Some(if t1 > t0 { v0 + (v1 - v0) * (t - t0) / (t1 - t0) } else { v1 })
}

/// Where the published DKT curves come from.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub enum ReferenceCurves {
    /// The repository's `validation/reference/dkt-uhlmann2005`, built into the program: found
    /// wherever the binary is installed.
    #[default]
    Shipped,
    /// The files of this folder, named and laid out as `validation/reference/dkt-uhlmann2005`.
    Folder(PathBuf),
}

/// The curves of `validation/reference/dkt-uhlmann2005` the analysis reads, built in.
const SHIPPED: [(&str, &str); 10] = {
    macro_rules! shipped {
        ($($name:literal),*) => {
            [$(($name, include_str!(concat!("../validation/reference/dkt-uhlmann2005/", $name)))),*]
        };
    }
    shipped!(
        "Uhlmann2005-fig6a-leading-particle.csv",
        "Uhlmann2005-fig6a-trailing-particle.csv",
        "Uhlmann2005-fig6b-leading-particle.csv",
        "Uhlmann2005-fig6b-trailing-particle.csv",
        "Uhlmann2005-fig7a-leading-particle.csv",
        "Uhlmann2005-fig7a-trailing-particle.csv",
        "Uhlmann2005-fig8-leading-particle.csv",
        "Uhlmann2005-fig8-trailing-particle.csv",
        "Koblitz2017-fig10c-leading-particle.csv",
        "Koblitz2017-fig10c-trailing-particle.csv"
    )
};

impl ReferenceCurves {
    /// The curves of `--reference DIR`, or the shipped ones without it.
    pub fn from_option(folder: Option<PathBuf>) -> Self {
        folder.map_or(Self::Shipped, Self::Folder)
    }

    /// The two columns of the curve `file` (e.g. `Uhlmann2005-fig6a-leading-particle.csv`).
    pub fn curve(&self, file: &str) -> Result<(Vec<Real>, Vec<Real>), Error> {
        match self {
            Self::Shipped => match SHIPPED.iter().find(|(name, _)| *name == file) {
                Some((_, text)) => Ok(parse_reference(text)),
                None => Err(Error::Model(format!(
                    "{file}: not among the reference curves built into multifield ({}); \
                     pass the folder that holds it",
                    SHIPPED.map(|(name, _)| name).join(", ")
                ))),
            },
            Self::Folder(dir) => read_reference(&dir.join(file)),
        }
    }
}

impl std::fmt::Display for ReferenceCurves {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Shipped => write!(f, "validation/reference/dkt-uhlmann2005 (built in)"),
            Self::Folder(dir) => write!(f, "{}", dir.display()),
        }
    }
}

/// Reads a two-column reference file.
pub fn read_reference(path: &Path) -> Result<(Vec<Real>, Vec<Real>), Error> {
    let text = std::fs::read_to_string(path).map_err(|source| Error::Io { path: path.to_path_buf(), source })?;
    Ok(parse_reference(&text))
}

/// The two whitespace-separated columns of a reference curve's text; other lines skipped.
pub fn parse_reference(text: &str) -> (Vec<Real>, Vec<Real>) {
    let mut t = vec![];
    let mut v = vec![];
    for line in text.lines() {
        let mut it = line.split_whitespace().filter_map(|s| s.parse::<Real>().ok());
        if let (Some(a), Some(b)) = (it.next(), it.next()) {
            t.push(a);
            v.push(b);
        }
    }
    (t, v)
}

/// What the analysis found.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct Report {
    /// Disk diameter d (from the bodies' radius in case.ron).
    pub diameter: Real,
    /// Name of the trailing (upstream) disk.
    pub trailing: String,
    /// Name of the leading (downstream) disk.
    pub leading: String,
    /// First time the gap along gravity between the centres is ≤ d.
    pub kiss_time: Option<Real>,
    /// First time the trailing disk passes the leading one along gravity.
    pub tumble_time: Option<Real>,
    /// Smallest gap along gravity, in units of d.
    pub min_gap_over_d: Real,
    /// RMS distance to Uhlmann's along-gravity positions of both disks over [0, 0.28] s, in d.
    pub rms_position_error_over_d: Option<Real>,
    /// RMS distance to Uhlmann's lateral positions (fig. 7a) of both disks over [0, 0.28] s,
    /// in d, with the run mirrored about the channel's axis if that is nearer (which side
    /// the pair drifts to is the symmetry breaking's choice).
    pub rms_lateral_error_over_d: Option<Real>,
    /// RMS difference to Uhlmann's settling speeds (fig. 6b) of both disks over [0, 0.28] s,
    /// in units of u_ref = √(π d (ρs/ρf − 1) |g| / 2).
    pub rms_speed_error_over_uref: Option<Real>,
    /// RMS difference to Uhlmann's angular velocities (fig. 8) of both disks over
    /// [0, 0.28] s, times t_ref = d/u_ref (mirrored with the lateral positions).
    pub rms_angular_velocity_error_tref: Option<Real>,
    /// Largest speed of either disk along gravity.
    pub max_settling_speed: Real,
}

/// Over the times `≤ until` of the reference curve (`rt`, `rv`), the sum of squared
/// differences of the run's `series` (interpolated at those times) and the count.
fn squared_differences(t: &[Real], series: &[Real], rt: &[Real], rv: &[Real], until: Real) -> (Real, Real) {
    let (mut sum, mut count) = (0.0, 0.0);
    for (t_ref, r) in rt.iter().zip(rv) {
        if (0.0..=until).contains(t_ref) {
            if let Some(v) = interpolate(t, series, *t_ref) {
                sum += (v - r).powi(2);
                count += 1.0;
            }
        }
    }
    (sum, count)
}

/// Along-gravity coordinate measured from the upstream wall, for gravity along ±x or ±y.
pub(crate) struct Frame {
    /// 0 for gravity along x, 1 along y.
    pub(crate) axis: usize,
    /// −1 when gravity points to −axis.
    pub(crate) sign: Real,
    wall: Real,
    center: Real,
}

impl Frame {
    /// The frame of `case`'s gravity and domain.
    pub(crate) fn new(case: &Case) -> Self {
        let g = case.gravity;
        let axis = if g[1].abs() >= g[0].abs() { 1 } else { 0 };
        let sign = if g[axis] < 0.0 { -1.0 } else { 1.0 };
        let (lo, size) = (case.domain.origin[axis], case.domain.size[axis]);
        let wall = if sign < 0.0 { lo + size } else { lo };
        let other = 1 - axis;
        let center = case.domain.origin[other] + 0.5 * case.domain.size[other];
        Self { axis, sign, wall, center }
    }
    /// Distance from the upstream wall along gravity.
    pub(crate) fn along(&self, x: Real, y: Real) -> Real {
        let p = if self.axis == 1 { y } else { x };
        self.sign * (p - self.wall)
    }
    fn lateral(&self, x: Real, y: Real) -> Real {
        (if self.axis == 1 { x } else { y }) - self.center
    }
}

/// Whether `case` is the scene of the reference curves (Uhlmann 2005: d = 0.25 cm disks in
/// a 2 cm × 6 cm channel): the curves are drawn and measured against only then.
pub fn is_reference_scene(case: &Case) -> bool {
    let close = |a: Real, b: Real| (a - b).abs() < 1e-9 * b.abs().max(1.0);
    let size = case.domain.size;
    let boxed = (close(size[0], 2.0) && close(size[1], 6.0)) || (close(size[0], 6.0) && close(size[1], 2.0));
    boxed
        && case.fields.iter().any(|f| match &f.region {
            crate::core::case::Region::Bodies(b) => b.iter().all(
                |body| matches!(body.shape, crate::core::case::BodyShape::Disk { radius, .. } if close(radius, 0.125)),
            ),
            _ => false,
        })
}

/// Analyses the run in `dir`; with `reference` and the reference scene
/// ([`is_reference_scene`]), measures against Uhlmann's curves.
pub fn analyse(
    dir: &Path,
    reference: Option<&ReferenceCurves>,
) -> Result<(Report, BTreeMap<String, Track>, Case), Error> {
    let case_text = std::fs::read_to_string(dir.join("case.ron"))
        .map_err(|source| Error::Io { path: dir.join("case.ron"), source })?;
    let case = Case::from_ron(&case_text, &dir.join("case.ron"))?;
    let tracks = read_bodies(&dir.join("bodies.csv"))?;
    if tracks.len() != 2 {
        return Err(Error::Model(format!(
            "{}: DKT analysis needs exactly two bodies, found {}",
            dir.join("bodies.csv").display(),
            tracks.len()
        )));
    }
    let mut diameter = 0.0;
    for f in &case.fields {
        if let crate::core::case::Region::Bodies(b) = &f.region {
            for body in b {
                if let crate::core::case::BodyShape::Disk { radius, .. } = body.shape {
                    diameter = 2.0 * radius;
                }
            }
        }
    }
    let reference = reference.filter(|_| is_reference_scene(&case));
    let fr = Frame::new(&case);
    let names: Vec<&String> = tracks.keys().collect();
    let s0 = |n: &String| fr.along(tracks[n].x[0], tracks[n].y[0]);
    let (trailing, leading) = if s0(names[0]) < s0(names[1]) { (names[0], names[1]) } else { (names[1], names[0]) };
    let (a, b) = (&tracks[trailing], &tracks[leading]);
    let mut report = Report {
        diameter,
        trailing: trailing.clone(),
        leading: leading.clone(),
        min_gap_over_d: Real::INFINITY,
        ..Report::default()
    };
    let n = a.t.len().min(b.t.len());
    for k in 0..n {
        let gap = fr.along(b.x[k], b.y[k]) - fr.along(a.x[k], a.y[k]);
        report.min_gap_over_d = report.min_gap_over_d.min(gap / diameter);
        if report.kiss_time.is_none() && gap <= diameter {
            report.kiss_time = Some(a.t[k]);
        }
        if report.tumble_time.is_none() && gap < 0.0 {
            report.tumble_time = Some(a.t[k]);
        }
        let speed = |tr: &Track| (if fr.axis == 1 { tr.vy[k] } else { tr.vx[k] }).abs();
        report.max_settling_speed = report.max_settling_speed.max(speed(a)).max(speed(b));
    }
    if let Some(curves) = reference {
        // the window of the comparison: before the pair's paths part after the tumble
        let until = 0.28;
        let rms = |series: &dyn Fn(&Track, usize) -> Real, file: &str| -> Result<Option<Real>, Error> {
            let (mut sum, mut count) = (0.0, 0.0);
            for (track, which) in [(a, "trailing"), (b, "leading")] {
                let (rt, rv) = curves.curve(&format!("Uhlmann2005-{file}-{which}-particle.csv"))?;
                let s: Vec<Real> = (0..track.t.len()).map(|k| series(track, k)).collect();
                let (ds, dc) = squared_differences(&track.t, &s, &rt, &rv, until);
                sum += ds;
                count += dc;
            }
            Ok((count > 0.0).then(|| (sum / count).sqrt()))
        };
        report.rms_position_error_over_d = rms(&|tr, k| fr.along(tr.x[k], tr.y[k]), "fig6a")?.map(|e| e / diameter);
        let lateral = |m: Real| rms(&|tr: &Track, k| m * fr.lateral(tr.x[k], tr.y[k]), "fig7a");
        let (plain, mirrored) = (lateral(1.0)?, lateral(-1.0)?);
        let mirror = if mirrored.unwrap_or(Real::INFINITY) < plain.unwrap_or(Real::INFINITY) { -1.0 } else { 1.0 };
        report.rms_lateral_error_over_d = plain.zip(mirrored).map(|(p, m)| p.min(m) / diameter);
        let u_ref = reference_speed(&case, diameter);
        let speed = |tr: &Track, k: usize| fr.sign * if fr.axis == 1 { tr.vy[k] } else { tr.vx[k] };
        report.rms_speed_error_over_uref = rms(&speed, "fig6b")?.zip(u_ref).map(|(e, u)| e / u);
        // a mirror image turns the other way; gravity along x turns the frame by a right angle
        let spin = |tr: &Track, k: usize| mirror * tr.omega[k];
        report.rms_angular_velocity_error_tref = rms(&spin, "fig8")?.zip(u_ref).map(|(e, u)| e * diameter / u);
    }
    Ok((report, tracks, case))
}

/// u_ref = √(π d (ρs/ρf − 1) |g| / 2) of Uhlmann (2005), ρs the density of the field
/// holding the bodies and ρf that of the first other field; `None` for bodies lighter than
/// the fluid or a case without both.
fn reference_speed(case: &Case, diameter: Real) -> Option<Real> {
    let bodies = |f: &&crate::core::case::FieldSpec| matches!(f.region, crate::core::case::Region::Bodies(_));
    let rho_s = case.fields.iter().find(bodies)?.density;
    let rho_f = case.fields.iter().find(|f| !bodies(f))?.density;
    let g = (case.gravity[0].powi(2) + case.gravity[1].powi(2)).sqrt();
    let u2 = std::f64::consts::PI * diameter * (rho_s / rho_f - 1.0) * g / 2.0;
    (u2 > 0.0).then(|| u2.sqrt())
}

/// One analysed run, for charts that overlay several.
pub struct Run<'a> {
    /// Legend text (the run directory's name, or the case name for a single run).
    pub label: String,
    /// What the analysis found.
    pub report: &'a Report,
    /// The bodies' tracks.
    pub tracks: &'a BTreeMap<String, Track>,
    /// The case as run.
    pub case: &'a Case,
}

/// Writes `dkt_position.{png,svg}` (along gravity) and `dkt_lateral.{png,svg}` into `out`,
/// with the published curves when `reference` is given and the case is their scene.
pub fn plot(
    out: &Path,
    report: &Report,
    tracks: &BTreeMap<String, Track>,
    case: &Case,
    reference: Option<&ReferenceCurves>,
) -> Result<Vec<PathBuf>, Error> {
    plot_runs(out, &[Run { label: "this run".into(), report, tracks, case }], reference)
}

/// Like [`plot`], for several runs of the same scene on one chart (a resolution study,
/// or resolved against point bodies): each run in its own colour, both bodies solid.
pub fn plot_runs(out: &Path, runs: &[Run], reference: Option<&ReferenceCurves>) -> Result<Vec<PathBuf>, Error> {
    let Some(first) = runs.first() else {
        return Ok(vec![]);
    };
    let case = first.case;
    let reference = reference.filter(|_| is_reference_scene(case));
    let fr = Frame::new(case);
    let mut along = vec![];
    let mut lateral = vec![];
    let single = runs.len() == 1;
    let n_ref_colors = if reference.is_some() { 2 } else { 0 };
    for (r, run) in runs.iter().enumerate() {
        for (k, (name, which)) in
            [(&run.report.trailing, "trailing"), (&run.report.leading, "leading")].into_iter().enumerate()
        {
            let tr = &run.tracks[name];
            let idx = 0..tr.t.len();
            let (label, color) = if single {
                (format!("{name} ({which}), {}", run.label), k)
            } else {
                (format!("{}, {which}", run.label), n_ref_colors + r)
            };
            along.push(Series {
                label: label.clone(),
                points: idx.clone().map(|i| (tr.t[i], fr.along(tr.x[i], tr.y[i]))).collect(),
                color,
                markers: false,
            });
            lateral.push(Series {
                label,
                points: idx.map(|i| (tr.t[i], fr.lateral(tr.x[i], tr.y[i]))).collect(),
                color,
                markers: false,
            });
        }
    }
    if let Some(curves) = reference {
        let d = first.report.diameter;
        for (k, which) in ["trailing", "leading"].into_iter().enumerate() {
            let (c_u, c_k) = if single { (k + 2, k + 4) } else { (0, 1) };
            let (t, s) = curves.curve(&format!("Uhlmann2005-fig6a-{which}-particle.csv"))?;
            along.push(Series {
                label: format!("Uhlmann 2005, {which}"),
                points: t.into_iter().zip(s).collect(),
                color: c_u,
                markers: true,
            });
            let (t, s) = curves.curve(&format!("Uhlmann2005-fig7a-{which}-particle.csv"))?;
            lateral.push(Series {
                label: format!("Uhlmann 2005, {which}"),
                points: t.into_iter().zip(s).collect(),
                color: c_u,
                markers: true,
            });
            let (t, s) = curves.curve(&format!("Koblitz2017-fig10c-{which}-particle.csv"))?;
            let tref = d / 13.88;
            along.push(Series {
                label: format!("Koblitz 2017, {which}"),
                points: t.into_iter().zip(s).map(|(t, s)| (t * tref, -s * d)).collect(),
                color: c_k,
                markers: true,
            });
        }
    }
    let stem_a = out.join("dkt_position");
    write_chart(
        &stem_a,
        &Chart {
            title: format!("{}: position along gravity (from the upstream wall)", case.name),
            x_label: "time".into(),
            y_label: "position along gravity".into(),
            series: along,
            log: (false, false),
        },
    )?;
    let stem_l = out.join("dkt_lateral");
    write_chart(
        &stem_l,
        &Chart {
            title: format!("{}: lateral position (from the channel axis)", case.name),
            x_label: "time".into(),
            y_label: "lateral position".into(),
            series: lateral,
            log: (false, false),
        },
    )?;
    Ok(vec![stem_a.with_extension("png"), stem_l.with_extension("png")])
}
