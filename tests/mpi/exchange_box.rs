//! Two fields exchanging momentum, decomposed (issue 19): two interpenetrating Eulerian
//! fields (one a disk at θ = ½, the other taking the rest) sliding through each other with
//! a constant exchange coefficient, periodic, 64², 20 steps, under `mpirun -np 1/2/3/4`
//! (rank grids 1 × 2, 1 × 3, 2 × 2): the serial `diagnostics.csv` and snapshots (each
//! field's θ and velocity) byte for byte.

use super::common::serial_files_on_ranks;

#[test]
fn two_fields_exchanging_on_one_to_four_ranks_write_the_serial_files() {
    let t = "two_fields_exchanging_on_one_to_four_ranks_write_the_serial_files";
    let sets =
        ["time.max_steps=20", "output.interval=0", "output.charts=false", "output.snapshots=Some((interval: 0.01))"];
    let outs = serial_files_on_ranks(t, "tests/cases/exchange_box.ron", &sets, |_| Vec::new(), 20, 6);
    // (without mpirun, nothing ran)
    if let Some(np4) = outs.last() {
        // the exchange dissipates the slip: the kinetic energy falls every step
        let text = std::fs::read_to_string(np4.join("diagnostics.csv")).unwrap();
        let header: Vec<&str> = text.lines().next().unwrap().split(',').collect();
        let k = header.iter().position(|&h| h == "kinetic_energy").unwrap();
        let ke: Vec<f64> = text.lines().skip(1).map(|l| l.split(',').nth(k).unwrap().parse().unwrap()).collect();
        assert!(ke.windows(2).all(|w| w[1] < w[0]), "{ke:?}");
    }
}
