//! Body generators (issue 15, `fields.<f>.generate`): the same seed gives the same bodies
//! bit for bit, the disks never overlap and keep `min_gap`, the solid fraction, lattice
//! and diameter distributions are what the entry asks for, bad entries are refused with
//! exit code 2 and the entry named, and `check` prints the figures the bodies have.

use multifield::core::case::{BodyShape, BodySpec, Case, Region};
use multifield::core::generate::Generated;
use std::path::{Path, PathBuf};
use std::process::Command;

/// A case of a 10 × 10 box of water and a field `disks` with the generator `entry`
/// (the inside of `generate: [( ... )]`) and the listed bodies `listed`.
fn text(entry: &str, listed: &str) -> String {
    format!(
        r#"(
    name: "generated",
    domain: (size: (10.0, 10.0), cells: (40, 40)),
    gravity: (0.0, -981.0),
    time: (end: 0.01, max_dt: 1e-3),
    fields: [
        (name: "water", density: 1.0, frame: (model: "eulerian"), region: Rest,
         stress: [(model: "newtonian", params: (viscosity: 0.01))]),
        (name: "disks", density: 1.5, frame: (model: "lagrangian"), representation: MassPoint,
         region: Bodies([{listed}]), generate: [({entry})], stress: [(model: "rigid")]),
    ],
    exchange: [(between: ("water", "disks"), model: "no_slip",
                mass_point: Some((model: "cylinder", params: (added_mass: 1.0))))],
    pressure: Some((model: "pcg")),
)"#
    )
}

fn expand(entry: &str, listed: &str) -> (Vec<BodySpec>, Generated) {
    // resolved bodies: a listed rectangle is allowed (the cases `check` runs are mass points)
    let text = text(entry, listed).replace("representation: MassPoint,", "");
    let case = Case::from_ron(&text, Path::new("generated.ron")).unwrap();
    case.validate().unwrap();
    let (expanded, mut reports) = case.expand_generators().unwrap_or_else(|e| panic!("{entry}: {e}"));
    expanded.validate().unwrap();
    let Region::Bodies(bodies) = &expanded.fields[1].region else { panic!() };
    assert!(expanded.fields[1].generate.is_empty());
    (bodies.clone(), reports.remove(0))
}

fn disks(bodies: &[BodySpec]) -> Vec<([f64; 2], f64)> {
    bodies
        .iter()
        .map(|b| match b.shape {
            BodyShape::Disk { center, radius } => (center, radius),
            _ => panic!("{} is not a disk", b.name),
        })
        .collect()
}

/// Every pair by brute force: the smallest gap between surfaces, and whether any pair is
/// closer than r₁ + r₂ + gap (the test the generator makes).
fn brute_force(d: &[([f64; 2], f64)], gap: f64) -> (f64, usize) {
    let (mut smallest, mut closer) = (f64::INFINITY, 0);
    for i in 0..d.len() {
        for j in 0..i {
            let dist = ((d[i].0[0] - d[j].0[0]).powi(2) + (d[i].0[1] - d[j].0[1]).powi(2)).sqrt();
            smallest = smallest.min(dist - d[i].1 - d[j].1);
            if dist < d[i].1 + d[j].1 + gap {
                closer += 1;
            }
        }
    }
    (smallest, closer)
}

fn bits(bodies: &[BodySpec]) -> Vec<(String, [u64; 3])> {
    disks(bodies).iter().zip(bodies).map(|((c, r), b)| (b.name.clone(), [c[0], c[1], *r].map(f64::to_bits))).collect()
}

#[test]
fn the_same_seed_gives_the_same_bodies_bit_for_bit() {
    let entry = |seed: u64| {
        format!(
            "name: \"p\", region: (min: (1.0, 1.0), max: (9.0, 9.0)), count: Some(500), \
             diameter: LogNormal(median: 0.15, sigma: 0.3), min_gap: 0.01, seed: {seed}"
        )
    };
    let (a, ra) = expand(&entry(7), "");
    let (b, rb) = expand(&entry(7), "");
    assert_eq!(a.len(), 500);
    assert_eq!(a, b);
    assert_eq!(bits(&a), bits(&b));
    assert_eq!(ra, rb);
    let (c, _) = expand(&entry(8), "");
    assert_eq!(c.len(), 500);
    let same = bits(&a).iter().zip(bits(&c)).filter(|(x, y)| x.1 == y.1).count();
    assert_eq!(same, 0, "another seed, other bodies");
    // the names: the prefix and the index, in the order of the draws
    assert_eq!((a[0].name.as_str(), a[499].name.as_str()), ("p0", "p499"));
}

/// Random packings of 50 to about 2,000 disks: no two closer than r₁ + r₂ + min_gap (every
/// pair), all inside the region by min_gap, the solid fraction Σ π d²/4 / area to round-off.
#[test]
fn random_packings_never_overlap_and_keep_the_gap() {
    let cases = [
        ("count: Some(50), diameter: Fixed(0.5)", 0.1, [2.0, 2.0, 8.0, 8.0]),
        ("count: Some(500), diameter: Uniform(min: 0.1, max: 0.3)", 0.02, [0.0, 0.0, 10.0, 10.0]),
        ("solid_fraction: Some(0.4), diameter: Normal(mean: 0.1, std: 0.02)", 0.0, [1.0, 1.0, 4.0, 4.0]),
        ("solid_fraction: Some(0.45), diameter: Fixed(0.2)", 0.0, [0.0, 0.0, 10.0, 10.0]),
    ];
    let mut largest = 0;
    for (what, gap, [x0, y0, x1, y1]) in cases {
        let entry =
            format!("name: \"p\", region: (min: ({x0}, {y0}), max: ({x1}, {y1})), {what}, min_gap: {gap}, seed: 3");
        let (bodies, report) = expand(&entry, "");
        let d = disks(&bodies);
        let (smallest, closer) = brute_force(&d, gap);
        assert_eq!(closer, 0, "{what}: {closer} pairs closer than the gap");
        assert!(smallest >= gap - 1e-12, "{what}: smallest gap {smallest}");
        assert_eq!(report.smallest_gap, Some(smallest), "{what}: the sweep finds the brute-force gap");
        for (c, r) in &d {
            assert!(
                c[0] - r >= x0 + gap - 1e-12
                    && c[0] + r <= x1 - gap + 1e-12
                    && c[1] - r >= y0 + gap - 1e-12
                    && c[1] + r <= y1 - gap + 1e-12,
                "{what}: a disk at {c:?}, r = {r}, outside the region by the gap"
            );
        }
        let area = (x1 - x0) * (y1 - y0);
        let solid: f64 = d.iter().map(|(_, r)| std::f64::consts::PI * (2.0 * r).powi(2) / 4.0).sum::<f64>() / area;
        assert!((report.region_fraction - solid).abs() <= 1e-14, "{what}: {} vs {solid}", report.region_fraction);
        assert!((report.domain_fraction - solid * area / 100.0).abs() <= 1e-14);
        largest = largest.max(d.len());
    }
    // the last one: 0.45 × 100 / (π 0.2²/4) = 1,432 disks of d = 0.2
    assert_eq!(largest, 1432);
}

/// A solid fraction is met within half the largest disk's share of the region, and about
/// 2,000 disks are placed in well under a second.
#[test]
fn a_solid_fraction_is_met_within_half_a_disk() {
    for (phi, diameter, hi) in
        [(0.25, "Fixed(0.025)", 0.025), (0.3, "Uniform(min: 0.02, max: 0.03)", 0.03), (0.1, "Fixed(0.3)", 0.3)]
    {
        let t = std::time::Instant::now();
        let (bodies, report) = expand(
            &format!(
                "name: \"q\", region: (min: (3.0, 3.0), max: (5.0, 5.0)), solid_fraction: Some({phi}), \
                 diameter: {diameter}"
            ),
            "",
        );
        let took = t.elapsed();
        let share = std::f64::consts::PI * hi * hi / 4.0 / 4.0;
        let miss = (report.region_fraction - phi).abs();
        assert!(miss <= share / 2.0, "{phi} {diameter}: reached {} (a disk is {share})", report.region_fraction);
        if phi == 0.25 {
            // 0.25 × 4 / (π 0.025²/4) = 2,037.2: 2,037 disks
            assert_eq!(bodies.len(), 2037);
            assert!(took.as_secs_f64() < 1.0, "{took:?}");
        }
    }
}

/// Lattices: the count asked for, on sites exactly `spacing` apart (default the diameter
/// plus min_gap, and 10⁻⁹ of it), from the region's lower-left corner, row by row.
#[test]
fn lattice_spacing_and_count_are_exact() {
    let (d, g) = (0.1, 0.02);
    let a = (d + g) * (1.0 + 1e-9);
    // square: a row of width 2 holds ⌊(2 − 2g − d)/a⌋ + 1 = ⌊1.86/0.12⌋ + 1 = 16 disks
    let (bodies, report) = expand(
        &format!(
            "name: \"s\", region: (min: (1.0, 1.0), max: (3.0, 3.0)), count: Some(40), diameter: Fixed({d}), \
             min_gap: {g}, arrangement: Lattice(Square)"
        ),
        "",
    );
    let c = disks(&bodies);
    assert_eq!(c.len(), 40);
    assert_eq!(report.count, 40);
    for (k, (center, r)) in c.iter().enumerate() {
        let (i, j) = ((k % 16) as f64, (k / 16) as f64);
        let want = [1.0 + g + d / 2.0 + i * a, 1.0 + g + d / 2.0 + j * a];
        assert!((center[0] - want[0]).abs() < 1e-14 && (center[1] - want[1]).abs() < 1e-14, "{k}: {center:?}");
        assert_eq!(*r, d / 2.0);
    }
    // the smallest gap is the spacing less a diameter
    assert!((report.smallest_gap.unwrap() - (a - d)).abs() < 1e-14);
    // hexagonal: rows a √3/2 apart, odd rows shifted by a/2; solid fraction 0.5 of a region
    // 2 × 2 by disks of d = 0.1: ⌊0.5 × 4 / (π 0.01/4)⌋ rounded to the nearest = 255 disks
    let (bodies, report) = expand(
        "name: \"h\", region: (min: (1.0, 1.0), max: (3.0, 3.0)), solid_fraction: Some(0.5), diameter: Fixed(0.1), \
         arrangement: Lattice(Hexagonal)",
        "",
    );
    let c = disks(&bodies);
    assert_eq!(c.len(), 255);
    assert!((report.region_fraction - 255.0 * std::f64::consts::PI * 0.01 / 4.0 / 4.0).abs() < 1e-14);
    let a: f64 = 0.1 * (1.0 + 1e-9);
    let per_row = ((2.0 - 0.1) / a).floor() as usize + 1; // 19
    assert_eq!(per_row, 19);
    // row 1 starts a/2 in; row 2 is √3 a above row 0
    assert!((c[per_row].0[0] - c[0].0[0] - a / 2.0).abs() < 1e-14);
    assert!((c[per_row].0[1] - c[0].0[1] - a * 3f64.sqrt() / 2.0).abs() < 1e-14);
    let (smallest, closer) = brute_force(&c, 0.0);
    assert_eq!(closer, 0);
    assert!((smallest - (a - 0.1)).abs() < 1e-12, "{smallest}");
}

/// Sample mean and standard deviation.
fn moments(x: &[f64]) -> (f64, f64) {
    let n = x.len() as f64;
    let mean = x.iter().sum::<f64>() / n;
    (mean, (x.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt())
}

/// The diameters' sample moments against the prescribed ones, within 4 standard errors
/// (mean: s/√n; standard deviation: s/√(2n)), with a fixed seed; a list exactly.
#[test]
fn the_diameters_follow_their_distributions() {
    let n = 4000;
    let diameters = |diameter: &str| -> Vec<f64> {
        let (bodies, _) = expand(
            &format!(
                "name: \"d\", region: (min: (0.0, 0.0), max: (10.0, 10.0)), count: Some({n}), diameter: {diameter}, \
                 seed: 11"
            ),
            "",
        );
        disks(&bodies).iter().map(|(_, r)| 2.0 * r).collect()
    };
    // a normal truncated at ±3σ keeps its mean; its standard deviation is σ √(1 − 6 φ(3)/(Φ(3) − Φ(−3)))
    // = 0.986579 σ
    let truncated = (1.0 - 6.0 * 0.004431848411938008 / 0.9973002039367398f64).sqrt();
    let check = |what: &str, x: &[f64], mean: f64, std: f64| {
        let (m, s) = moments(x);
        let (se_mean, se_std) = (s / (x.len() as f64).sqrt(), s / (2.0 * x.len() as f64).sqrt());
        assert!((m - mean).abs() < 4.0 * se_mean, "{what}: mean {m}, want {mean} ± 4 × {se_mean}");
        assert!((s - std).abs() < 4.0 * se_std, "{what}: std {s}, want {std} ± 4 × {se_std}");
    };
    let x = diameters("Uniform(min: 0.02, max: 0.06)");
    assert!(x.iter().all(|d| (0.02..=0.06).contains(d)));
    check("uniform", &x, 0.04, 0.04 / 12f64.sqrt());
    let x = diameters("Normal(mean: 0.05, std: 0.01)");
    assert!(x.iter().all(|d| (0.02..=0.08).contains(d)));
    check("normal", &x, 0.05, 0.01 * truncated);
    let x = diameters("Normal(mean: 0.05, std: 0.01, min: Some(0.045), max: Some(0.07))");
    assert!(x.iter().all(|d| (0.045..=0.07).contains(d)));
    let x = diameters("LogNormal(median: 0.04, sigma: 0.25)");
    let logs: Vec<f64> = x.iter().map(|d| d.ln()).collect();
    check("log-normal (ln d)", &logs, 0.04f64.ln(), 0.25 * truncated);
    assert!(x.iter().all(|d| *d >= 0.04 * (-0.75f64).exp() && *d <= 0.04 * 0.75f64.exp()));
    // a list: these diameters, in this order
    let list = [0.3, 0.1, 0.25, 0.1, 0.17, 0.3, 0.05];
    let (bodies, report) = expand(
        &format!("name: \"l\", region: (min: (2.0, 2.0), max: (5.0, 5.0)), diameter: List({list:?}), seed: 2"),
        "",
    );
    let got: Vec<f64> = disks(&bodies).iter().map(|(_, r)| 2.0 * r).collect();
    assert_eq!(got.iter().map(|d| d.to_bits()).collect::<Vec<_>>(), list.map(f64::to_bits));
    assert_eq!(report.diameters, [0.05, list.iter().sum::<f64>() / 7.0, 0.3]);
}

/// Listed bodies stay first and the generated disks keep the gap from them.
#[test]
fn generated_disks_avoid_the_listed_bodies() {
    let listed = "(name: \"big\", shape: Disk(center: (5.0, 5.0), radius: 2.0)), \
                  (name: \"wall\", shape: Rectangle(min: (0.5, 0.5), max: (9.5, 1.0)), motion: Fixed)";
    let (bodies, _) = expand(
        "name: \"p\", region: (min: (0.0, 0.0), max: (10.0, 10.0)), solid_fraction: Some(0.2), \
         diameter: Fixed(0.2), min_gap: 0.02, seed: 5",
        listed,
    );
    assert_eq!((bodies[0].name.as_str(), bodies[1].name.as_str(), bodies[2].name.as_str()), ("big", "wall", "p0"));
    for b in &bodies[2..] {
        let BodyShape::Disk { center: c, radius: r } = b.shape else { panic!() };
        let to_big = ((c[0] - 5.0).powi(2) + (c[1] - 5.0).powi(2)).sqrt() - 2.0 - r;
        assert!(to_big >= 0.02 - 1e-12, "{}: {to_big}", b.name);
        let dy = (0.5 - c[1]).max(c[1] - 1.0).max(0.0);
        let dx = (0.5 - c[0]).max(c[0] - 9.5).max(0.0);
        assert!((dx * dx + dy * dy).sqrt() - r >= 0.02 - 1e-12, "{}", b.name);
    }
    // 0.2 of the whole box, less half a disk at most: (0.2 × 100 − a/2) / a disks at least
    let a = std::f64::consts::PI * 0.04 / 4.0;
    assert!((bodies.len() - 2) as f64 >= (20.0 - a / 2.0) / a - 1.0);
}

fn file(name: &str, text: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("generators");
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    path
}

fn check(path: &Path) -> (Option<i32>, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_multifield")).arg("check").arg(path).output().unwrap();
    (
        out.status.code(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn bad_generators_are_refused_with_the_entry_named() {
    let base = "name: \"p\", region: (min: (1.0, 1.0), max: (9.0, 9.0))";
    let cases: [(&str, String, &[&str]); 11] = [
        (
            "both",
            format!("{base}, count: Some(5), solid_fraction: Some(0.1), diameter: Fixed(0.1)"),
            &["fields.disks.generate.0.count", "not both"],
        ),
        ("neither", format!("{base}, diameter: Fixed(0.1)"), &["fields.disks.generate.0.count", "solid_fraction"]),
        (
            "zero_fraction",
            format!("{base}, solid_fraction: Some(0.0), diameter: Fixed(0.1)"),
            &["fields.disks.generate.0.solid_fraction", "(0, 0.5470)"],
        ),
        (
            "jammed",
            format!("{base}, solid_fraction: Some(0.6), diameter: Fixed(0.1)"),
            &["fields.disks.generate.0.solid_fraction", "Lattice(Hexagonal)"],
        ),
        (
            "outside",
            "name: \"p\", region: (min: (1.0, 1.0), max: (11.0, 9.0)), count: Some(5), diameter: Fixed(0.1)".into(),
            &["fields.disks.generate.0.region", "outside the domain"],
        ),
        (
            "negative",
            format!("{base}, count: Some(5), diameter: Fixed(-0.1)"),
            &["fields.disks.generate.0.diameter", "positive"],
        ),
        (
            "too_large",
            format!("{base}, count: Some(1), diameter: Fixed(8.5)"),
            &["fields.disks.generate.0.diameter", "does not fit in the region"],
        ),
        (
            "unreachable",
            format!("{base}, count: Some(100), diameter: Fixed(1.0), attempts: 2000"),
            &[
                "fields.disks.generate.0: random placement could not reach 100 disks",
                "of 100 disks placed",
                "Lattice(Hexagonal)",
            ],
        ),
        (
            "too_many",
            format!("{base}, count: Some(20001), diameter: Fixed(0.01)"),
            &["fields.disks.generate.0.count", "20001 bodies; at most 20000"],
        ),
        (
            "too_many_by_fraction",
            format!("{base}, solid_fraction: Some(0.5), diameter: Fixed(0.01)"),
            &["fields.disks.generate.0.solid_fraction", "about 407437 bodies; at most 20000"],
        ),
        (
            "lattice_full",
            format!("{base}, count: Some(100), diameter: Fixed(1.0), arrangement: Lattice(Square)"),
            &["fields.disks.generate.0", "has 49 free sites in the region, 100 disks asked for"],
        ),
    ];
    for (name, entry, parts) in cases {
        let t = std::time::Instant::now();
        let (code, _, err) = check(&file(&format!("{name}.ron"), &text(&entry, "")));
        assert_eq!(code, Some(2), "{name}: {err}");
        for p in parts {
            assert!(err.contains(p), "{name}: lacks `{p}`:\n{err}");
        }
        assert!(t.elapsed().as_secs_f64() < 2.0, "{name}: {:?}", t.elapsed());
    }
    // the count achieved is in the message: 8 × 8 = 64 disks of d = 1 fit on a lattice;
    // random sequential addition jams near 0.547 × 64 / (π/4) ≈ 44
    let (_, _, err) =
        check(&file("unreachable.ron", &text(&format!("{base}, count: Some(100), diameter: Fixed(1.0)"), "")));
    let placed: usize = err.split("disks: ").nth(1).unwrap().split(' ').next().unwrap().parse().unwrap();
    assert!((30..=45).contains(&placed), "{placed}: {err}");
}

/// `check` prints, for each generator, the count, the solid fraction of the region and of
/// the domain, and the smallest gaps; the same figures computed here from the bodies.
#[test]
fn check_prints_the_figures_of_the_generated_bodies() {
    let entry = "name: \"p\", region: (min: (1.0, 2.0), max: (9.0, 8.0)), solid_fraction: Some(0.2), \
                 diameter: Fixed(0.15), min_gap: 0.01, seed: 4";
    let (code, out, err) = check(&file("figures.ron", &text(entry, "")));
    assert_eq!(code, Some(0), "{err}");
    let line =
        out.lines().find(|l| l.starts_with("bodies   fields.disks.generate.0:")).unwrap_or_else(|| panic!("{out}"));
    let number = |after: &str| -> f64 {
        line.split(after).nth(1).unwrap().trim_start().split([' ', ',', ';']).next().unwrap().parse().unwrap()
    };
    let (bodies, _) = expand(entry, "");
    let d = disks(&bodies);
    let solid: f64 = d.iter().map(|(_, r)| std::f64::consts::PI * r * r).sum();
    let (smallest, _) = brute_force(&d, 0.0);
    let wall = d
        .iter()
        .map(|(c, r)| (c[0] - r).min(10.0 - c[0] - r).min(c[1] - r).min(10.0 - c[1] - r))
        .fold(f64::INFINITY, f64::min);
    let count: usize = line.split(": ").nth(1).unwrap().split(' ').next().unwrap().parse().unwrap();
    assert_eq!(count, d.len());
    assert!((number("solid fraction") - solid / 48.0).abs() <= 5e-7, "{line}");
    assert!((number("of its region,") - solid / 100.0).abs() <= 5e-7, "{line}");
    assert!((number("smallest gap") - smallest).abs() <= 5e-7, "{line}");
    assert!((number("between its disks,") - wall).abs() <= 5e-7, "{line}");
    assert!(smallest >= 0.01 && (0.2 - solid / 48.0).abs() <= std::f64::consts::PI * 0.0225 / 4.0 / 48.0 / 2.0);
    assert!(out.contains(&format!("{} bodies (p0, p1,", d.len())), "{out}");
}
