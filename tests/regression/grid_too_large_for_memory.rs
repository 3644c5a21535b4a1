//! Issue 20: `domain.cells` of 2,000,000 × 2,000,000 passed validation and `check`
//! allocated the grid (`memory allocation of 19200000000000 bytes failed`, SIGABRT). The
//! memory of a case is now estimated from the case alone and checked against the memory
//! the machine has (or `--max-memory`, `MULTIFIELD_MAX_MEMORY`) before anything is
//! allocated, in `check`, `run` and `study`.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::time::{Duration, Instant};

fn scratch(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("grid_too_large_for_memory").join(name);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn examples() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("examples")
}

/// Runs `multifield ARGS` with `MULTIFIELD_MAX_MEMORY` unset (or set to `env`); its output
/// and wall time.
fn multifield(args: &[&str], env: Option<&str>) -> (Output, Duration) {
    let mut c = Command::new(env!("CARGO_BIN_EXE_multifield"));
    c.args(args).env_remove("MULTIFIELD_MAX_MEMORY");
    if let Some(v) = env {
        c.env("MULTIFIELD_MAX_MEMORY", v);
    }
    let start = Instant::now();
    let out = c.output().unwrap();
    (out, start.elapsed())
}

fn refused(out: &Output, took: Duration) -> String {
    let err = String::from_utf8_lossy(&out.stderr).to_string();
    assert_eq!(out.status.code(), Some(2), "not refused with code 2: {err}");
    assert!(took < Duration::from_secs(1), "{took:?}: {err}");
    assert!(err.starts_with("error: ") && !err.contains("panicked") && !err.contains("memory allocation"), "{err}");
    err
}

#[test]
fn two_million_squared_cells_are_refused_by_check_and_run_before_allocating() {
    let case = examples().join("lid_driven_cavity.ron");
    let case = case.to_str().unwrap();
    let cells = "domain.cells=(2000000, 2000000)";
    for command in ["check", "run"] {
        let out_dir = scratch(command);
        let mut args = vec![command, case, "--set", cells];
        if command == "run" {
            args.extend(["--quiet", "--out", out_dir.to_str().unwrap()]);
        }
        let (out, took) = multifield(&args, None);
        let err = refused(&out, took);
        // the estimate, the numbers of cells, the limit and the fix, at the entry
        assert!(err.contains("domain.cells"), "{err}");
        assert!(err.contains("needed for 2,000,000 × 2,000,000 cells"), "{err}");
        assert!(err.contains("reduce domain.cells"), "{err}");
        assert!(err.contains("available") || err.contains("at most"), "{err}");
        // a run that cannot start writes nothing
        assert!(!out_dir.join("diagnostics.csv").exists());
    }
}

#[test]
fn a_grid_beyond_the_cell_cap_is_refused_whatever_the_memory_limit() {
    let case = examples().join("lid_driven_cavity.ron");
    let (out, took) = multifield(
        &["check", case.to_str().unwrap(), "--set", "domain.cells=(2000000, 2000000)", "--max-memory", "1EB"],
        None,
    );
    let err = refused(&out, took);
    assert!(err.contains("domain.cells") && err.contains("at most 1073741824 cells"), "{err}");
    // cells whose product overflows usize: the same refusal, no overflow
    let max = usize::MAX.to_string();
    let (out, took) =
        multifield(&["check", case.to_str().unwrap(), "--set", &format!("domain.cells=({max}, {max})")], None);
    let err = refused(&out, took);
    assert!(err.contains("domain.cells"), "{err}");
}

#[test]
fn the_memory_cap_comes_from_the_option_or_the_environment() {
    let case = examples().join("lid_driven_cavity.ron");
    let case = case.to_str().unwrap();
    // the example (0.8 MB) fits the machine, not 100 kB
    let (out, took) = multifield(&["check", case, "--max-memory", "100kB"], None);
    let err = refused(&out, took);
    assert!(err.contains("791.2 kB needed for 32 × 32 cells") && err.contains("--max-memory is 100.0 kB"), "{err}");
    assert!(err.contains("raise --max-memory"), "{err}");
    let (out, took) = multifield(&["check", case], Some("100kB"));
    let err = refused(&out, took);
    assert!(err.contains("MULTIFIELD_MAX_MEMORY is 100.0 kB"), "{err}");
    // a size that is not one
    let (out, took) = multifield(&["check", case, "--max-memory", "lots"], None);
    let err = refused(&out, took);
    assert!(err.contains("--max-memory") && err.contains("`lots` is not a size"), "{err}");
    // and the option wins over the environment
    let (out, _) = multifield(&["check", case, "--max-memory", "1GB"], Some("100kB"));
    assert_eq!(out.status.code(), Some(0), "{}", String::from_utf8_lossy(&out.stderr));
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("memory   about"), "{text}");
}
