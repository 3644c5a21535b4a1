//! `multifield mpi-check` under `mpirun -np 1…4`: the halo exchange fills every halo node
//! with its owner's value, and the exact sum split across the ranks has the serial sum's
//! bits, on rank grids with cuts along each axis, corners and periodic wraps, in 2D and 3D.

use super::common::{mpirun, text};
use multifield::mpi_check::serial_sum;

/// Runs the check and asserts its verdict, rank grid, halo count and the sum's bits.
fn passes(test: &str, np: usize, cells: &str, ranks: Option<&str>, periodic: &str, grid: &str, n_cells: usize) {
    let mut args = vec!["mpi-check", "--cells", cells, "--periodic", periodic];
    if let Some(r) = ranks {
        args.extend(["--ranks", r]);
    }
    let Some(o) = mpirun(test, np, &args) else { return };
    let (out, err) = text(&o);
    assert!(o.status.success(), "{test} np {np}: {:?}\n{out}\n{err}", o.status);
    assert!(out.trim_end().ends_with("mpi-check: pass"), "{out}");
    assert!(out.contains(&format!("{np} rank")) && out.contains(&format!("rank grid {grid},")), "{out}");
    // the halo line: some nodes checked (with more than one rank or a periodic side), none wrong
    let halo = out.lines().find(|l| l.contains("halo nodes")).expect("the halo line");
    let checked: usize = halo.split("halo: ").nth(1).unwrap().split(' ').next().unwrap().parse().unwrap();
    assert!(checked > 0 && halo.contains(", 0 wrong"), "{halo}");
    // the sum's bits as printed by rank 0 against the serial sum computed here
    let bits = format!("{:#018x}", serial_sum(n_cells).to_bits());
    let sum = out.lines().find(|l| l.contains("exact sum of")).expect("the sum line");
    assert!(
        sum.contains(&format!("{n_cells} terms")) && sum.contains(&format!(": {bits} (")),
        "{sum} (expected {bits})"
    );
    assert!(sum.ends_with("equal bits"), "{sum}");
    // only rank 0 prints
    assert_eq!(out.matches("mpi-check: pass").count(), 1, "{out}");
}

#[test]
fn halos_and_exact_sums_in_2d_on_1_to_4_ranks() {
    let t = "halos_and_exact_sums_in_2d_on_1_to_4_ranks";
    // the rank grids of the design's tests: (1), (2, 1), (1, 3), (2, 2); a periodic wrap across cuts
    passes(t, 1, "64x64", None, "x,y", "1 × 1", 64 * 64);
    passes(t, 2, "64x64", Some("2x1"), "x,y", "2 × 1", 64 * 64);
    passes(t, 3, "64x64", Some("1x3"), "x,y", "1 × 3", 64 * 64);
    passes(t, 4, "64x64", Some("2x2"), "x", "2 × 2", 64 * 64);
    // the automatic grid: odd sizes, walls; 3 ranks along y (x has one row group)
    passes(t, 3, "45x67", None, "none", "1 × 3", 45 * 67);
}

#[test]
fn halos_and_exact_sums_in_3d() {
    let t = "halos_and_exact_sums_in_3d";
    passes(t, 2, "64x16x12", Some("1x1x2"), "x,y,z", "1 × 1 × 2", 64 * 16 * 12);
    passes(t, 3, "64x16x12", Some("1x1x3"), "z", "1 × 1 × 3", 64 * 16 * 12);
    passes(t, 4, "64x16x12", Some("1x2x2"), "x,y", "1 × 2 × 2", 64 * 16 * 12);
}

/// A rank grid that does not fit is bad input: exit status 2 on every rank and one message.
#[test]
fn a_rank_grid_that_does_not_fit_is_refused() {
    let t = "a_rank_grid_that_does_not_fit_is_refused";
    let Some(o) = mpirun(t, 3, &["mpi-check", "--cells", "64x64", "--ranks", "3x1"]) else { return };
    let (out, err) = text(&o);
    assert_eq!(o.status.code(), Some(2), "{out}\n{err}");
    assert!(err.contains("error: mpi-check: the rank grid 3 × 1 does not fit 64 × 64 cells"), "{err}");
    assert!(err.contains("use at most 2 ranks along x"), "{err}");
    assert_eq!(err.matches("does not fit").count(), 1, "rank 0 alone prints: {err}");
}
