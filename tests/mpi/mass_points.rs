//! Mass points decomposed (issue 19): the `fluidized_bed` example as mass points (200
//! disks, the 2D cylinder drag law with Di Felice's voidage, `dem` contact in sub-steps, an
//! inflow and an outflow) on 64 × 192 cells, 20 steps, under `mpirun -np 1/2/3/4` with rank
//! grids 2 × 1, 1 × 3 and 2 × 2 (its `bed` monitor left out: monitors are not decomposed; every rank holds every point; each sums onto the nodes it
//! owns and reads each footprint node from its owner): the serial `diagnostics.csv`,
//! `bodies.csv` and snapshots, byte for byte.

use super::common::serial_files_on_ranks;

#[test]
fn mass_points_on_one_to_four_ranks_write_the_serial_bodies() {
    let t = "mass_points_on_one_to_four_ranks_write_the_serial_bodies";
    let sets = [
        "fields.disks.representation=MassPoint",
        "domain.point_cells=Some((64, 192))",
        "time.max_steps=20",
        "output.interval=0",
        "output.charts=false",
        "output.snapshots=Some((interval: 0.01))",
        "monitors=[]",
    ];
    let ranks = |np: usize| match np {
        2 => vec!["domain.ranks=Some((2, 1))".to_string()],
        3 => vec!["domain.ranks=Some((1, 3))".to_string()],
        4 => vec!["domain.ranks=Some((2, 2))".to_string()],
        _ => Vec::new(),
    };
    serial_files_on_ranks(t, "examples/fluidized_bed.ron", &sets, ranks, 20, 7);
}
