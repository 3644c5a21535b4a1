//! `multifield mpi-check`: the check a user runs under `mpirun` to verify a cluster's MPI
//! setup for decomposed runs (docs/design/mpi.md §10, P0b). Written against the [`Comm`]
//! trait, so that it runs on fake in-process ranks in the tests of the default build as
//! well as on MPI (`src/mpi.rs`, cargo feature `mpi`).
//!
//! It decomposes a grid of the given cells into the ranks' blocks, fills every owned node
//! of every lattice with a function of its global index, exchanges the halos
//! ([`crate::core::halo`]) and checks every halo node; it sums an [`ExactSum`] of one term
//! per global cell, each rank adding its own cells', and checks that the bits equal the
//! serial sum of all the terms; and it checks the maxima, minima, `any` and `gather_all`.

use crate::core::decomposition::Block;
use crate::core::decomposition::{dims_text, wrap, RankGrid};
use crate::core::exact::ExactSum;
use crate::core::grid::Lattice;
use crate::core::halo::{exchange, global, owned, storage_shape, Layout};
use crate::core::math::{axis_name, Index, Real, AXES, DIM};
use crate::core::parallel::Comm;

/// What to check: the grid, its periodic axes and, optionally, the rank grid.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Setup {
    /// Cells along each axis.
    pub cells: Index,
    /// Whether each axis is periodic.
    pub periodic: [bool; DIM],
    /// The rank grid, else the one of least surface.
    pub ranks: Option<Index>,
}

/// `64x64` (or `64x32x32`): the numbers of an `AxBxC` list; an error says what is wrong.
pub fn parse_dims(option: &str, text: &str) -> Result<Vec<usize>, String> {
    let dims: Result<Vec<usize>, _> = text.split(['x', 'X', '×']).map(|s| s.trim().parse::<usize>()).collect();
    match dims {
        Ok(d) if (2..=3).contains(&d.len()) && d.iter().all(|&k| k > 0) => Ok(d),
        _ => Err(format!(
            "{option} {text}: expected two or three positive whole numbers joined by `x`, e.g. `{option} 64x64` \
             (2D) or `{option} 64x32x32` (3D)"
        )),
    }
}

impl Setup {
    /// The setup of the command line's options, in this compile's dimension: `cells` and
    /// `ranks` as `AxB(xC)`, `periodic` the periodic axes' names (`x,y`; `none`).
    pub fn parse(cells: &[usize], ranks: Option<&str>, periodic: &str) -> Result<Self, String> {
        let cells: Index =
            cells.try_into().map_err(|_| format!("--cells: {} numbers in a {DIM}D compile", cells.len()))?;
        let ranks = ranks
            .map(|r| {
                let d = parse_dims("--ranks", r)?;
                <Index>::try_from(d.as_slice()).map_err(|_| {
                    format!(
                        "--ranks {r}: {} numbers for a {DIM}D grid of --cells {}; give {DIM}",
                        d.len(),
                        dims_text(cells)
                    )
                })
            })
            .transpose()?;
        let mut p = [false; DIM];
        if periodic.trim() != "none" {
            for name in periodic.split(',').map(str::trim) {
                let a = AXES.into_iter().find(|&a| axis_name(a) == name).ok_or_else(|| {
                    let names: Vec<&str> = AXES.iter().map(|&a| axis_name(a)).collect();
                    format!(
                        "--periodic {periodic}: unknown axis `{name}`; give a comma-separated list of {} or `none`",
                        names.join(", ")
                    )
                })?;
                p[a] = true;
            }
        }
        Ok(Self { cells, periodic: p, ranks })
    }
}

/// The outcome: what rank 0 prints, and whether every check passed (the same on every rank).
#[derive(Clone, Debug)]
pub struct Report {
    /// Lines for the user.
    pub lines: Vec<String>,
    /// Every check passed.
    pub pass: bool,
}

/// The term of global cell `k` in the exact sum: a wide range of magnitudes and both
/// signs, with pairs that cancel to the last bit, so that a floating-point sum in another
/// order gives other bits and only an exact sum gives one answer.
pub fn term(k: usize) -> Real {
    let h = (k as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15).rotate_left(17);
    let mantissa = (h >> 11) as Real / (1u64 << 53) as Real + 0.5;
    let exponent = (h % 61) as i32 - 30;
    let sign = if h & (1 << 5) == 0 { 1.0 } else { -1.0 };
    let big = if k.is_multiple_of(7) { 1e17 * if k.is_multiple_of(14) { 1.0 } else { -1.0 } } else { 0.0 };
    sign * mantissa * (2.0 as Real).powi(exponent) + big
}

/// The serial sum of the terms of the first `n` cells: one accumulator, in index order.
pub fn serial_sum(n: usize) -> Real {
    let mut s = ExactSum::new();
    (0..n).for_each(|k| s.add(term(k)));
    s.round()
}

/// The value of global node `g` of lattice number `l` of a grid with `shape` nodes of that
/// lattice: exact in `f64`, different for every node and lattice.
fn value(l: usize, g: Index, shape: Index) -> Real {
    let mut linear = g[DIM - 1];
    for a in (0..DIM - 1).rev() {
        linear = g[a] + shape[a] * linear;
    }
    (l + 4 * linear) as Real
}

/// The lattices of this dimension.
fn lattices() -> Vec<Lattice> {
    std::iter::once(Lattice::Cell).chain(AXES.iter().map(|&a| Lattice::face(a))).collect()
}

/// Runs the checks on every rank of `comm` (each calls it); `Err` for a setup that cannot
/// be decomposed (bad input).
pub fn run<C: Comm + ?Sized>(comm: &C, setup: &Setup) -> Result<Report, String> {
    let n = setup.cells;
    let grid = RankGrid::new(n, setup.periodic, comm.size(), setup.ranks)?;
    let block = grid.block(comm.rank());
    let mut lines = vec![format!(
        "{} rank{} on {} cells (periodic along {}): rank grid {}, cuts {}, aligned to multigrid level {}",
        comm.size(),
        if comm.size() == 1 { "" } else { "s" },
        dims_text(n),
        {
            let p: Vec<&str> = AXES.iter().filter(|&&a| setup.periodic[a]).map(|&a| axis_name(a)).collect();
            if p.is_empty() {
                "none".to_string()
            } else {
                p.join(", ")
            }
        },
        dims_text(grid.p),
        AXES.iter()
            .map(|&a| format!(
                "{}: {}",
                axis_name(a),
                grid.cuts[a].iter().map(|c| c.to_string()).collect::<Vec<_>>().join(" ")
            ))
            .collect::<Vec<_>>()
            .join("; "),
        grid.levels
    )];

    // halo, in both layouts: every node but the halo holds value() (NaN beyond a wall), the
    // halo NaN; after the exchange every node that some rank owns must hold its value, and
    // the padding beyond a wall its NaN
    let (mut checked, mut wrong) = (0i64, 0i64);
    for layout in [Layout::Padded, Layout::Local] {
        let wrapped = |lattice: Lattice, at: Index| -> Option<Index> {
            let g = global(&block, layout, at);
            let w: Option<Vec<usize>> =
                AXES.iter().map(|&a| wrap(g[a], n[a], setup.periodic[a], lattice.axis() == Some(a))).collect();
            w.map(|w| w.try_into().expect("DIM"))
        };
        let mut arrays: Vec<(Lattice, Vec<Real>)> = lattices()
            .into_iter()
            .enumerate()
            .map(|(l, lattice)| {
                let s = storage_shape(&block, layout, lattice);
                let shape = global_shape(n, lattice);
                let data = (0..s.iter().product())
                    .map(|i| match wrapped(lattice, node(s, i)) {
                        Some(w) if !in_halo(&block, layout, lattice, node(s, i)) => value(l, w, shape),
                        _ => Real::NAN,
                    })
                    .collect();
                (lattice, data)
            })
            .collect();
        {
            let mut views: Vec<(Lattice, &mut [Real])> =
                arrays.iter_mut().map(|(l, a)| (*l, a.as_mut_slice())).collect();
            exchange(comm, &block, layout, &mut views);
        }
        for (l, (lattice, data)) in arrays.iter().enumerate() {
            let s = storage_shape(&block, layout, *lattice);
            let shape = global_shape(n, *lattice);
            for (i, &v) in data.iter().enumerate() {
                let at = node(s, i);
                match wrapped(*lattice, at) {
                    Some(w) => {
                        let halo = in_halo(&block, layout, *lattice, at);
                        checked += halo as i64;
                        wrong += (v.to_bits() != value(l, w, shape).to_bits()) as i64;
                    }
                    None => wrong += !v.is_nan() as i64,
                }
            }
        }
    }

    // exact sum: each rank adds the terms of its own cells
    let mut mine = ExactSum::new();
    let own = owned(&block, Layout::Local, Lattice::Cell);
    let s = storage_shape(&block, Layout::Local, Lattice::Cell);
    let mut owned_cells = 0i64;
    for i in 0..s.iter().product() {
        let at = node(s, i);
        if AXES.iter().all(|&a| own[a].contains(&at[a])) {
            let g = global(&block, Layout::Local, at).map(|v| v as usize);
            mine.add(term(linear(g, n)));
            owned_cells += 1;
        }
    }
    let mut words = mine.words();
    comm.sum_words(&mut words);
    let sum = ExactSum::from_words(&words).round();
    let serial = serial_sum(n.iter().product());

    // the other collectives: counts, maxima, minima, any, gather_all
    let mut counts = [checked, wrong, owned_cells];
    comm.sum_words(&mut counts);
    let [checked, wrong_halo, cells] = counts;
    let r = comm.rank() as Real;
    let mut extremes = [r, -r];
    comm.max(&mut extremes);
    let mut low = [r];
    comm.min(&mut low);
    let top = (comm.size() - 1) as Real;
    let gathered = comm.gather_all(&(comm.rank() as u64).to_le_bytes());
    let collectives_ok = extremes == [top, 0.0]
        && low == [0.0]
        && comm.any(comm.rank() + 1 == comm.size())
        && !comm.any(false)
        && gathered.iter().enumerate().all(|(k, b)| b.as_slice() == (k as u64).to_le_bytes());
    let sum_ok = sum.to_bits() == serial.to_bits();
    let cells_ok = cells as usize == n.iter().product::<usize>();
    // every rank's verdict, so that all of them exit with one status
    let fail = comm.any(!(collectives_ok && sum_ok && cells_ok && wrong_halo == 0));
    comm.barrier();

    lines.push(format!(
        "halo: {checked} halo nodes of {} lattices in the two layouts checked, {wrong_halo} wrong{}",
        lattices().len(),
        if wrong_halo == 0 { "" } else { " (a node off its owner's value, or padding beyond a wall written)" }
    ));
    lines.push(format!(
        "exact sum of {} terms, one per cell, each rank its own {}: {:#018x} ({sum:e}); the serial sum {:#018x}: {}",
        n.iter().product::<usize>(),
        if cells_ok { "cells".to_string() } else { format!("cells, {cells} in all: wrong") },
        sum.to_bits(),
        serial.to_bits(),
        if sum_ok { "equal bits" } else { "DIFFERENT" }
    ));
    lines.push(format!("max, min, any, gather_all: {}", if collectives_ok { "ok" } else { "WRONG" }));
    Ok(Report { lines, pass: !fail })
}

/// Whether storage node `at` lies in the padding of an exchanged side.
fn in_halo(block: &Block, layout: Layout, lattice: Lattice, at: Index) -> bool {
    let own = owned(block, layout, lattice);
    AXES.iter().any(|&a| {
        (layout.exchanged(block, a, false) && at[a] < own[a].start)
            || (layout.exchanged(block, a, true) && at[a] >= own[a].end)
    })
}

fn node(s: Index, mut i: usize) -> Index {
    let mut at = [0; DIM];
    for a in AXES {
        at[a] = i % s[a];
        i /= s[a];
    }
    at
}

fn linear(g: Index, n: Index) -> usize {
    let mut k = g[DIM - 1];
    for a in (0..DIM - 1).rev() {
        k = g[a] + n[a] * k;
    }
    k
}

/// The nodes of a lattice of the whole grid.
fn global_shape(n: Index, lattice: Lattice) -> Index {
    std::array::from_fn(|a| n[a] + (lattice.axis() == Some(a)) as usize)
}

#[cfg(all(test, feature = "dim2"))]
mod tests {
    use super::*;
    use crate::core::parallel::fake;

    /// The check passes on 1–6 fake ranks, and its sum has the serial bits, which a
    /// floating-point sum in index order does not have (the check would mean little otherwise).
    #[test]
    fn passes_on_fake_ranks() {
        let n = 64 * 48;
        let naive: Real = (0..n).map(term).sum();
        assert_ne!(naive.to_bits(), serial_sum(n).to_bits());
        for ranks in 1..=6 {
            let setup = Setup::parse(&[64, 48], None, "x").unwrap();
            for report in fake::run(ranks, |c| run(c, &setup).unwrap()) {
                assert!(report.pass, "{ranks} ranks: {:?}", report.lines);
                assert!(report.lines[2].contains("equal bits"));
            }
        }
    }

    #[test]
    fn bad_options_say_what_to_give() {
        assert!(parse_dims("--cells", "64x").unwrap_err().contains("e.g. `--cells 64x64`"));
        assert!(Setup::parse(&[64, 64], None, "x,w")
            .unwrap_err()
            .contains("unknown axis `w`; give a comma-separated list of x, y"));
        assert!(Setup::parse(&[64, 64], Some("2x2x1"), "none").unwrap_err().contains("give 2"));
        let e =
            run(&crate::core::parallel::Serial, &Setup::parse(&[64, 64], Some("2x1"), "none").unwrap()).unwrap_err();
        assert!(e.contains("the rank grid 2 × 1 has 2 ranks but the run has 1"), "{e}");
    }
}
