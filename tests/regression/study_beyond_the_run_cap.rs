//! Issue 20: `multifield study` with a range axis of 10¹⁸ entries panicked with `capacity
//! overflow`, and axes that multiply to millions of combinations started enumerating them
//! without a word. The number of runs is now counted in checked arithmetic before any list
//! is built, printed, and refused beyond 10,000 unless `--max-runs` raises the cap.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::time::{Duration, Instant};

fn study(name: &str, axes: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("study_beyond_the_run_cap").join(name);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let base = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/taylor_green.ron");
    let file = dir.join("study.ron");
    std::fs::write(&file, format!("(name: \"{name}\", base: {:?}, axes: [{axes}])", base.to_str().unwrap())).unwrap();
    file
}

fn multifield(args: &[&str]) -> (Output, Duration) {
    let start = Instant::now();
    let out = Command::new(env!("CARGO_BIN_EXE_multifield")).args(args).output().unwrap();
    (out, start.elapsed())
}

fn refused(out: &Output, took: Duration) -> String {
    let err = String::from_utf8_lossy(&out.stderr).to_string();
    assert_eq!(out.status.code(), Some(2), "not refused with code 2: {err}");
    assert!(took < Duration::from_secs(1), "{took:?}: {err}");
    assert!(err.starts_with("error: ") && !err.contains("panicked"), "{err}");
    err
}

#[test]
fn a_range_of_ten_to_the_eighteen_entries_is_refused() {
    let file = study(
        "range",
        r#"(name: "cfl", values: Range(path: "time.cfl", from: 0.1, to: 0.9, steps: 1000000000000000000))"#,
    );
    let (out, took) = multifield(&["study", file.to_str().unwrap(), "--quiet"]);
    let err = refused(&out, took);
    assert!(err.contains("axes.cfl") && err.contains("1000000000000000000 runs"), "{err}");
    assert!(err.contains("at most 10000") && err.contains("--max-runs"), "{err}");
    // --max-runs cannot raise the cap past what a list can hold: still a refusal
    let (out, took) = multifield(&["study", file.to_str().unwrap(), "--quiet", "--max-runs", "18446744073709551615"]);
    let err = refused(&out, took);
    assert!(err.contains("axes.cfl"), "{err}");
}

#[test]
fn a_billion_combinations_are_counted_and_refused() {
    let axis =
        |n: &str, p: &str| format!(r#"(name: "{n}", values: Range(path: "{p}", from: 0.1, to: 0.9, steps: 1000))"#);
    let axes = [axis("a", "time.cfl"), axis("b", "time.max_dt"), axis("c", "fields.fluid.density")].join(", ");
    let file = study("billion", &axes);
    let (out, took) = multifield(&["study", file.to_str().unwrap(), "--quiet"]);
    let err = refused(&out, took);
    assert!(err.contains("1000 × 1000 × 1000 = 1000000000 runs"), "{err}");
    assert!(err.contains("at most 10000") && err.contains("--max-runs"), "{err}");
    // axes whose product overflows u64: the same refusal
    let huge = |n: &str, p: &str| {
        format!(r#"(name: "{n}", values: Range(path: "{p}", from: 0.1, to: 0.9, steps: 4294967296))"#)
    };
    let axes = [huge("a", "time.cfl"), huge("b", "time.max_dt"), huge("c", "fields.fluid.density")].join(", ");
    let file = study("overflow", &axes);
    let (out, took) = multifield(&["study", file.to_str().unwrap(), "--quiet"]);
    let err = refused(&out, took);
    assert!(err.contains("more than 18446744073709551615 runs") || err.contains("runs"), "{err}");
}

#[test]
fn max_runs_lowers_and_raises_the_cap() {
    let file = study("small", r#"(name: "cfl", values: Range(path: "time.cfl", from: 0.2, to: 0.4, steps: 3))"#);
    let (out, took) = multifield(&["study", file.to_str().unwrap(), "--quiet", "--max-runs", "2"]);
    let err = refused(&out, took);
    assert!(err.contains("3 runs") && err.contains("at most 2"), "{err}");
}
