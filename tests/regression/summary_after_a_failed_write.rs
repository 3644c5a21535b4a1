//! An output that could not be written mid-run (a full disk) ended the run with exit code
//! 1 but wrote no `summary.json` (issue 20). Now the summary says `failed` with the reason
//! and the steps reached, whenever the process survives.

use crate::hostile_input::{example, multifield, scratch, Ran};
use std::path::PathBuf;

/// Runs the Taylor–Green vortex into `test`'s `out/` with `sets`, after a folder takes the
/// name of the temporary file `blocked` (so that it cannot be created).
fn run_blocked(test: &str, blocked: &str, sets: &[&str]) -> (Ran, PathBuf) {
    let out = scratch(test).join("out");
    std::fs::create_dir_all(out.join(blocked).join("blocked")).unwrap();
    let case = example("taylor_green.ron");
    let mut args = vec!["run", case.to_str().unwrap(), "--quiet", "--out", out.to_str().unwrap()];
    for set in sets {
        args.extend(["--set", set]);
    }
    (multifield(&args), out)
}

#[test]
fn a_picture_that_cannot_be_written_at_step_2_leaves_a_summary() {
    // the temporary file of the third picture cannot be created
    let sets = ["output.pictures=Some((interval: 0.05, width: 16))", "time.max_steps=5"];
    let (ran, out) = run_blocked("failed_write", "frames/.frame_000002.partial.png", &sets);
    assert_eq!(ran.code, Some(1), "the output failed: {}", ran.stderr);
    assert!(ran.stderr.contains("frame_000002.png"), "{}", ran.stderr);
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).expect("a summary")).unwrap();
    assert_eq!(summary["status"], "failed", "{summary}");
    assert!(summary["reason"].as_str().unwrap().contains("frame_000002.png"), "{summary}");
    assert_eq!(summary["steps"], 2, "{summary}");
}

#[test]
fn a_chart_the_plotting_backend_cannot_write_is_an_output_failure_naming_the_file() {
    // the temporary file of the diagnostics chart cannot be created
    let sets = ["output.charts=true", "time.max_steps=2"];
    let (ran, out) = run_blocked("failed_chart", "charts/diagnostics.partial.png", &sets);
    assert_eq!(ran.code, Some(1), "an output failure, not bad input: {}", ran.stderr);
    assert!(ran.stderr.contains("charts/diagnostics.png"), "the file is named: {}", ran.stderr);
    assert!(ran.stderr.contains("the plotting backend cannot draw and write it"), "{}", ran.stderr);
    assert!(!ran.stderr.contains("panicked"), "{}", ran.stderr);
    assert!(!out.join("charts/diagnostics.png").exists());
}
