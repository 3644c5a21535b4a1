//! The Taylor–Green vortex decomposed (issue 19): `mpirun -np 1/2/3/4 multifield run` at
//! 64² (rank grids 1, 1 × 2, 1 × 3, 2 × 2), 20 steps of the Eulerian frame with
//! Crank–Nicolson viscosity and the multigrid-preconditioned PCG (its default), writes the `diagnostics.csv`
//! of the run without mpirun byte for byte (a row every step: time, Δt, kinetic energy,
//! momentum, mass, max speed, max divergence, volume fractions, pressure iterations and
//! residual), and the same snapshots (HDF5 and XDMF, gathered onto rank 0, byte for
//! byte). `tests/verification/decomposed.rs` checks the fields themselves on in-process
//! ranks.

use super::common::serial_files_on_ranks;

#[test]
fn taylor_green_on_one_to_four_ranks_writes_the_serial_diagnostics() {
    let t = "taylor_green_on_one_to_four_ranks_writes_the_serial_diagnostics";
    let sets = [
        "domain.cells=(64, 64)",
        "time.max_steps=20",
        "output.interval=0",
        "output.charts=false",
        "output.snapshots=Some((interval: 0.25, faces: true))",
    ];
    // t = 0, 0.25, 0.5, 0.75 and the last step's (t = 0.79), and the XDMF
    for (k, out) in
        serial_files_on_ranks(t, "examples/taylor_green.ron", &sets, |_| Vec::new(), 20, 6).iter().enumerate()
    {
        let np = k + 1;
        let summary = std::fs::read_to_string(out.join("summary.json")).unwrap();
        assert!(summary.contains("\"status\": \"completed\""), "np {np}: {summary}");
        let s: serde_json::Value = serde_json::from_str(&summary).unwrap();
        let c = &s["communication"];
        if np == 1 {
            assert!(c.is_null(), "np 1 is not decomposed: {summary}");
            continue;
        }
        assert_eq!(c["ranks"], np, "{summary}");
        let per = c["per_step"].as_array().unwrap();
        assert_eq!(per.len(), np);
        // every rank takes part in the same collectives; each sends its halos
        for key in ["reductions", "gathers", "exchanges"] {
            assert!(per.iter().all(|r| r[key] == per[0][key]), "np {np}: {key} differ between ranks: {summary}");
        }
        assert!(per.iter().all(|r| r["bytes"].as_f64().unwrap() > 0.0), "{summary}");
        if np == 2 {
            // 1 × 2 ranks, each block 64 × 32 cells with a halo of H = 2 rows on both sides
            // (periodic along y, the other rank on each); x periodic within the block. On
            // multigrid level l (64/2^l cells along x) an exchange of cells sends 2 messages
            // of 2 rows of 64/2^l values; of x-faces, rows of 64/2^l + 1; of y-faces, 2 rows
            // up and 3 (H + 1) down; 8 bytes a value, 4 in the V-cycle.
            let cells = |l: i32, word: f64| 2.0 * (2.0 * 64.0 / 2f64.powi(l) * word);
            let faces = |l: i32| {
                let nx = 64.0 / 2f64.powi(l);
                2.0 * (2.0 * (nx + 1.0) * 8.0) + (2.0 + 3.0) * nx * 8.0
            };
            let phase = |name: &str| {
                let p = c["rank0_phases"].as_array().unwrap().iter().find(|p| p["phase"] == name);
                p.unwrap_or_else(|| panic!("no phase {name}: {summary}"))["bytes"].as_f64().unwrap()
            };
            // θ's two Heun stages
            assert_eq!(phase("8 advection"), 2.0 * cells(0, 8.0), "{summary}");
            // u* before the constraint, x before the PCG, p in each PCG iteration, the
            // pressure for the gradient, the corrected u. The multigrid levels on the blocks:
            // 0 to 3 (64 × 32 cells a block down to 8 × 4; the cuts are multiples of 16, so
            // even down to level 3; level 4's 4 × 4 cells are gathered). Once a solve, each
            // block level's operator has its halo couplings (x- and y-faces), diagonal and
            // inverse (cells) exchanged. Each V-cycle (one an iteration) exchanges each
            // block level's f32 cells 4ν − 1 = 7 times: before each colour of the ν = 2
            // sweeps but the first of each side of the coarse correction (after the
            // prolongation the first halo layer is the owners' already) and before the
            // restriction; below the finest level the right-hand side takes the place of the
            // exchange after the first colour (from zero, b/d needs b's halo only)
            let iterations = s["pressure_iterations_total"].as_f64().unwrap() / 20.0;
            let operators: f64 = (0..4).map(|l| faces(l) + 2.0 * cells(l, 8.0)).sum();
            let v_cycle: f64 = (0..4).map(|l| 7.0 * cells(l, 4.0)).sum();
            assert_eq!(
                phase("5 pressure"),
                2.0 * faces(0) + (2.0 + iterations) * cells(0, 8.0) + operators + iterations * v_cycle,
                "{summary}"
            );
        }
    }
}

/// The vortex carried by material points (`taylor_green_flip`: APIC on the quadratic
/// B-spline) at 64², 20 steps: the points migrate between the blocks every step; the
/// snapshots hold every rank's points in id order.
#[test]
fn taylor_green_on_material_points_on_one_to_four_ranks_writes_the_serial_files() {
    let t = "taylor_green_on_material_points_on_one_to_four_ranks_writes_the_serial_files";
    let sets = [
        "domain.cells=(64, 64)",
        "time.max_steps=20",
        "output.interval=0",
        "output.charts=false",
        "output.snapshots=Some((interval: 0.25))",
    ];
    let outs = serial_files_on_ranks(t, "examples/taylor_green_flip.ron", &sets, |_| Vec::new(), 20, 6);
    for (np, out) in outs.iter().enumerate().map(|(k, o)| (k + 1, o)).skip(1) {
        let summary = std::fs::read_to_string(out.join("summary.json")).unwrap();
        let s: serde_json::Value = serde_json::from_str(&summary).unwrap();
        // the points' traffic: ghost points and the fold's ghost nodes before the scatter;
        // after the gather, the points that cross a cut. On 1 × 2 and 2 × 2 ranks the cuts
        // lie on the vortices' separatrices (multiples of π, where the normal velocity is
        // zero) and no point crosses; on 1 × 3 they do not.
        let phase = |name: &str| {
            let p = s["communication"]["rank0_phases"].as_array().unwrap().iter().find(|p| p["phase"] == name);
            p.map_or(0.0, |p| p["bytes"].as_f64().unwrap())
        };
        assert!(phase("1 particles to grid") > 0.0, "np {np}: {summary}");
        if np == 3 {
            assert!(phase("7 grid to particles") > 0.0, "np {np}: {summary}");
        }
    }
}
