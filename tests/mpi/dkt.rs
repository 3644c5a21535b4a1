//! Drafting, kissing, tumbling decomposed (issue 19): `dkt_seed` (two resolved rigid disks
//! falling in a channel, `no_slip` exchange, `repulsion` contact) at 32 cells per unit, 20
//! steps, under `mpirun -np 1/2/3/4` with rank grids that cut through the disks (2 × 1,
//! 1 × 3, 2 × 2): the serial `diagnostics.csv`, `bodies.csv` (positions, velocities,
//! forces, torques every step) and snapshots, byte for byte.

use super::common::serial_files_on_ranks;

#[test]
fn dkt_on_one_to_four_ranks_writes_the_serial_bodies() {
    let t = "dkt_on_one_to_four_ranks_writes_the_serial_bodies";
    let sets = [
        "domain.cells=(64, 256)",
        "time.max_steps=20",
        "output.interval=0",
        "output.charts=false",
        "output.snapshots=Some((interval: 0.05))",
    ];
    let ranks = |np: usize| match np {
        2 => vec!["domain.ranks=Some((2, 1))".to_string()],
        3 => vec!["domain.ranks=Some((1, 3))".to_string()],
        4 => vec!["domain.ranks=Some((2, 2))".to_string()],
        _ => Vec::new(),
    };
    serial_files_on_ranks(t, "examples/dkt_seed.ron", &sets, ranks, 20, 4);
}
