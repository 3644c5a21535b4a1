//! The cell-list neighbour search and the `dem` contact forces against the O(N²) double
//! loop, for N = 100, 1,000 and 10,000 random disks at a fixed solid fraction, timed with
//! criterion.
//!
//! Scene: N disks of radii uniform in [r, 1.2 r] placed uniformly at random (seeded) in a
//! square of side L chosen for a solid fraction Σπr²/L² = 0.3, walls all round (closed box),
//! a grid of 64 × 64 cells on it (the walls and h of the contact context only). Timed, per
//! N: `search`: `neighbours::pairs_within` with a search distance of 0.1 r (the cell list);
//! `dem`: one call of the `dem` model's `forces` (its search, every touching pair's
//! spring–dashpot and friction with the history, and the walls); `repulsion`: one call of
//! `repulsion`'s `forces` (which now uses the cell list); `brute`: `neighbours::brute`, the
//! O(N²) double loop over all pairs with the same test — the loop `repulsion` ran before
//! the cell list, the baseline. Before criterion measures, a line goes to stderr per N:
//! `neighbours n <N> pairs <P> search_ns_per_body <a> dem_ns_per_body <b> repulsion_ns_per_body <c>
//! brute_ns_per_body <d>`: medians over repeated calls divided by N.
//!
//! `cargo bench --bench neighbours`. `NEIGHBOURS_SIZES=100,1000` limits the sizes.

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, SamplingMode};
use multifield::core::boundary::Boundaries;
use multifield::core::grid::Grid;
use multifield::core::math::{Real, Vector};
use multifield::core::neighbours::{brute, pairs_within, SearchDomain};
use multifield::core::plugin::{BodyState, ContactContext};
use multifield::core::registry::build_contact;
use multifield::core::timing::median;
use std::hint::black_box;
use std::time::{Duration, Instant};

/// N random disks at solid fraction 0.3 in a square (side L), and L.
fn packing(n: usize) -> (Vec<BodyState>, Real) {
    let r = 1.0;
    let mut rng = fastrand::Rng::with_seed(7);
    let radii: Vec<Real> = (0..n).map(|_| r * (1.0 + 0.2 * rng.f64())).collect();
    let area: Real = radii.iter().map(|r| std::f64::consts::PI * r * r).sum();
    let l = (area / 0.3).sqrt();
    let bodies = radii
        .iter()
        .enumerate()
        .map(|(k, &radius)| {
            let mass = std::f64::consts::PI * radius * radius;
            BodyState {
                name: format!("d{k}"),
                mass,
                inertia: 0.5 * mass * radius * radius,
                volume: std::f64::consts::PI * radius * radius,
                radius,
                position: Vector::new(l * rng.f64(), l * rng.f64()),
                velocity: Vector::new(rng.f64() - 0.5, rng.f64() - 0.5),
                free: true,
                ..Default::default()
            }
        })
        .collect();
    (bodies, l)
}

/// Median wall time of `f` in ns over calls lasting about `budget` seconds in all.
fn time(budget: f64, mut f: impl FnMut()) -> f64 {
    let t0 = Instant::now();
    f();
    let once = t0.elapsed().as_secs_f64();
    let repeats = ((budget / once.max(1e-9)) as usize).clamp(5, 2001);
    median(
        (0..repeats)
            .map(|_| {
                let t = Instant::now();
                f();
                t.elapsed().as_secs_f64() * 1e9
            })
            .collect(),
    )
}

fn bench(c: &mut Criterion) {
    multifield::link_all();
    let sizes: Vec<usize> = std::env::var("NEIGHBOURS_SIZES")
        .map(|s| s.split(',').map(|v| v.parse().expect("NEIGHBOURS_SIZES=100,1000")).collect())
        .unwrap_or_else(|_| vec![100, 1000, 10_000]);
    let params = serde_json::json!({ "restitution": 0.5, "collision_time": 1e-3, "friction": 0.3 });
    for &n in &sizes {
        let (bodies, l) = packing(n);
        let grid = Grid::new(64, 64, l / 64.0, Vector::zeros());
        let bc = Boundaries::default();
        let ctx = ContactContext {
            grid: &grid,
            boundaries: &bc,
            gravity: Vector::new(0.0, -1.0),
            fluid_density: 0.0,
            fluid_viscosity: None,
            bodies: &bodies,
            resolved: &[],
        };
        let centres: Vec<Vector> = bodies.iter().map(|b| b.position).collect();
        let radii: Vec<Real> = bodies.iter().map(|b| b.radius).collect();
        let domain = SearchDomain { origin: Vector::zeros(), size: Vector::new(l, l), periodic: [false, false] };
        let search = 0.1;
        let mut dem = build_contact("dem", &params, "contact").expect("dem");
        let mut repulsion =
            build_contact("repulsion", &serde_json::json!({ "max_range": 0.05 }), "contact").expect("repulsion");
        let mut out = vec![(Vector::zeros(), 0.0); n];
        let pairs = pairs_within(&centres, &radii, search, &domain).len();
        assert_eq!(pairs, brute(&centres, &radii, search, &domain).len());
        let per = |ns: f64| ns / n as f64;
        let s = per(time(1.0, || {
            black_box(pairs_within(&centres, &radii, search, &domain));
        }));
        let d = per(time(1.0, || dem.forces(&ctx, 1e-5, black_box(&mut out))));
        let r = per(time(1.0, || repulsion.forces(&ctx, 1e-5, black_box(&mut out))));
        let b = per(time(2.0, || {
            black_box(brute(&centres, &radii, search, &domain));
        }));
        eprintln!(
            "neighbours n {n} pairs {pairs} search_ns_per_body {s:.1} dem_ns_per_body {d:.1} \
             repulsion_ns_per_body {r:.1} brute_ns_per_body {b:.1}"
        );
        let mut group = c.benchmark_group(format!("neighbours/{n}"));
        group.sample_size(10).sampling_mode(SamplingMode::Flat).warm_up_time(Duration::from_millis(500));
        group.measurement_time(Duration::from_secs(2));
        group.bench_function(BenchmarkId::new("search", n), |bch| {
            bch.iter(|| black_box(pairs_within(&centres, &radii, search, &domain)))
        });
        group
            .bench_function(BenchmarkId::new("dem", n), |bch| bch.iter(|| dem.forces(&ctx, 1e-5, black_box(&mut out))));
        group.bench_function(BenchmarkId::new("brute", n), |bch| {
            bch.iter(|| black_box(brute(&centres, &radii, search, &domain)))
        });
        group.finish();
    }
}

// No plots: criterion's plotters backend panics where no font is installed (this machine).
criterion_group! {
    name = benches;
    config = Criterion::default().without_plots();
    targets = bench
}
criterion_main!(benches);
