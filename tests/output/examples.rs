//! Every example case (`examples/*.ron`) parses, validates, builds every plugin, and runs
//! a few steps with finite energy: examples that nobody runs rot.

use multifield::core::case::Case;
use multifield::core::simulation::Simulation;
use multifield::run::{run, RunOptions};
use std::path::{Path, PathBuf};

fn examples() -> Vec<PathBuf> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples");
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .expect("examples/ exists")
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "ron"))
        .collect();
    files.sort();
    files
}

#[test]
fn the_shipped_examples_are_there() {
    let names: Vec<String> = examples().iter().map(|p| p.file_name().unwrap().to_string_lossy().into_owned()).collect();
    for required in ["lid_driven_cavity.ron", "taylor_green.ron", "taylor_green_flip.ron"] {
        assert!(names.iter().any(|n| n == required), "examples/{required} is missing; have {names:?}");
    }
}

#[test]
fn every_example_runs_five_steps_with_finite_energy() {
    multifield::link_all();
    for file in examples() {
        let case =
            Case::load(&file, &["time.max_steps=5".into()]).unwrap_or_else(|e| panic!("{}: {e}", file.display()));
        let sim = Simulation::new(&case).unwrap_or_else(|e| panic!("{}: {e}", file.display()));
        assert!(sim.initial_energy.is_finite());
        let out = Path::new(env!("CARGO_TARGET_TMPDIR")).join("examples").join(file.file_stem().unwrap());
        let outcome = run(&case, &out, &RunOptions::quiet()).unwrap_or_else(|e| panic!("{}: {e}", file.display()));
        let s = &outcome.summary;
        assert_eq!(s.status, "completed", "{}: {}", file.display(), s.reason);
        assert_eq!(s.steps, 5, "{}", file.display());
        assert!(s.reason.contains("time.max_steps = 5"), "{}: {}", file.display(), s.reason);
        // time.max_steps is not a stop condition: a study's `stop_time` stays empty
        assert!(!multifield::core::monitor::is_stop_reason(&s.reason), "{}", s.reason);
        assert!(s.final_kinetic_energy.is_finite() && s.final_kinetic_energy >= 0.0, "{}", file.display());
        assert!(s.max_divergence < 1e-6, "{}: max divergence {}", file.display(), s.max_divergence);
    }
}

#[test]
fn the_built_in_default_case_is_the_example_file_it_names() {
    let file = Path::new(env!("CARGO_MANIFEST_DIR")).join(multifield::DEFAULT_CASE_FILE);
    assert_eq!(std::fs::read_to_string(file).unwrap(), multifield::DEFAULT_CASE);
}
