//! Running a case from Rust, with the core's driver: build the simulation, give the driver
//! the writers you want, run. The command line (`multifield run`) does the same with every
//! writer the case asks for, the progress bar and `summary.json`.
//!
//! ```sh
//! cargo run --release --example library_run                 # the lid-driven cavity
//! cargo run --release --example library_run -- CASE.ron OUT_DIR
//! ```

use multifield::core::case::Case;
use multifield::core::driver::{BodiesCsv, DiagnosticsCsv, Driver};
use multifield::core::simulation::Simulation;
use std::path::PathBuf;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    // the shipped plugins register themselves once linked
    multifield::link_all();
    let mut args = std::env::args().skip(1);
    let case =
        args.next().unwrap_or_else(|| concat!(env!("CARGO_MANIFEST_DIR"), "/examples/lid_driven_cavity.ron").into());
    let out = args.next().map_or_else(|| std::env::temp_dir().join("multifield_library_run"), PathBuf::from);
    std::fs::create_dir_all(&out)?;

    let case = Case::load(std::path::Path::new(&case), &[])?;
    let sim = Simulation::new(&case)?;
    let has_bodies = !sim.bodies().is_empty();
    let mut driver = Driver::new(sim);
    driver.add_writer(DiagnosticsCsv::create(out.join("diagnostics.csv"))?);
    if has_bodies {
        driver.add_writer(BodiesCsv::create(out.join("bodies.csv"))?);
    }
    driver.on_progress(|sim, rate| {
        if sim.steps % 100 == 0 {
            eprintln!("step {}, t = {:.4}: {rate:.0} steps/s", sim.steps, sim.time);
        }
    });
    let end = driver.run()?;
    println!(
        "{} ({}): {} steps to t = {} in {:.2} s, kinetic energy {:.6e}; {}",
        end.status.label(),
        end.status.reason(),
        driver.sim.steps,
        driver.sim.time,
        end.wall_seconds,
        driver.state.final_kinetic_energy,
        out.join("diagnostics.csv").display()
    );
    Ok(())
}
