//! The core's driver run from Rust in a few lines gives the rows `multifield run` writes,
//! to the bit; its checks stop a run that blows up.

use multifield::core::case::Case;
use multifield::core::driver::{BodiesCsv, DiagnosticsCsv, Driver, StopCheck};
use multifield::core::simulation::{Simulation, Status, StepDiagnostics};
use multifield::run::{run, RunOptions};
use std::path::{Path, PathBuf};

fn out(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("driver").join(name);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// A two-disk DKT, short: the library's driver with the two table writers writes the same
/// `diagnostics.csv` and `bodies.csv` bytes as `multifield run` on the same case.
#[test]
fn the_driver_from_rust_writes_what_the_command_line_writes() {
    multifield::link_all();
    let file = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/dkt_uhlmann2005.ron");
    let sets = ["domain.cells=(16, 48)", "time.end=0.02", "output.interval=0.004", "output.charts=false"];
    let case = Case::load(&file, &sets.map(String::from)).unwrap();
    let cli = out("cli");
    let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
    let outcome = pool.install(|| run(&case, &cli, &RunOptions::quiet())).unwrap();
    assert_eq!(outcome.status, Status::Completed);
    let lib = out("library");
    let end = pool.install(|| {
        let mut driver = Driver::new(Simulation::new(&case).unwrap());
        driver.add_writer(DiagnosticsCsv::create(lib.join("diagnostics.csv")).unwrap());
        driver.add_writer(BodiesCsv::create(lib.join("bodies.csv")).unwrap());
        let end = driver.run().unwrap();
        assert_eq!(driver.state.rows, outcome.summary.diagnostics_rows);
        end
    });
    assert_eq!(end.status, Status::Completed);
    for name in ["diagnostics.csv", "bodies.csv"] {
        let (a, b) = (std::fs::read(cli.join(name)).unwrap(), std::fs::read(lib.join(name)).unwrap());
        assert!(a == b, "{name} differs");
        // the interval's rows (0.004 to 0.02), and for the bodies the start's
        let rows = a.iter().filter(|&&c| c == b'\n').count() - 1;
        assert!(rows >= 5, "{name}: {rows} rows");
    }
}

/// A check of the library user's own: it stops the run as unstable after the step it
/// fires on, whose row is written.
#[test]
fn a_stop_check_of_ones_own_stops_the_run_with_its_reason() {
    struct Slow;
    impl StopCheck for Slow {
        fn check(&mut self, _sim: &Simulation, d: &StepDiagnostics) -> Option<String> {
            (d.step == 7).then(|| format!("step {} reached", d.step))
        }
    }
    multifield::link_all();
    let file = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/lid_driven_cavity.ron");
    let case = Case::load(&file, &["output.interval=1.0".to_string()]).unwrap();
    let dir = out("check");
    let mut driver = Driver::new(Simulation::new(&case).unwrap());
    driver.add_check(Slow).add_writer(DiagnosticsCsv::create(dir.join("diagnostics.csv")).unwrap());
    let end = driver.run().unwrap();
    assert_eq!(end.status, Status::Unstable("step 7 reached".into()));
    assert_eq!(driver.sim.steps, 7);
    let text = std::fs::read_to_string(dir.join("diagnostics.csv")).unwrap();
    let last = text.lines().last().unwrap();
    assert!(text.lines().count() == 2 && last.starts_with("7,"), "{text}");
}
