//! Launching the feature-built binary under `mpirun`.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// The launcher: `MULTIFIELD_MPIRUN`, else `mpirun` on `PATH`.
fn launcher() -> Option<PathBuf> {
    if let Some(p) = std::env::var_os("MULTIFIELD_MPIRUN") {
        return Some(PathBuf::from(p));
    }
    let path = std::env::var_os("PATH")?;
    std::env::split_paths(&path).map(|d| d.join("mpirun")).find(|p| p.is_file())
}

/// `mpirun -np N --oversubscribe multifield ARGS` (as root too), or `None` after printing
/// why the test is skipped; with `MULTIFIELD_REQUIRE_MPI=1` a missing launcher fails.
pub fn mpirun(test: &str, np: usize, args: &[&str]) -> Option<Output> {
    let Some(mpirun) = launcher() else {
        assert!(
            std::env::var("MULTIFIELD_REQUIRE_MPI").as_deref() != Ok("1"),
            "{test}: MULTIFIELD_REQUIRE_MPI=1 but mpirun was not found (install Debian's openmpi-bin, or set \
             MULTIFIELD_MPIRUN)"
        );
        eprintln!("{test}: skipped: mpirun not found (install Debian's openmpi-bin, or set MULTIFIELD_MPIRUN)");
        return None;
    };
    let output = Command::new(&mpirun)
        .args(["-np", &np.to_string(), "--oversubscribe"])
        .arg(env!("CARGO_BIN_EXE_multifield"))
        .args(args)
        .env("OMPI_ALLOW_RUN_AS_ROOT", "1")
        .env("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1")
        // Open MPI's shared-memory single copy (CMA) needs ptrace rights that containers often lack
        .env("OMPI_MCA_btl_vader_single_copy_mechanism", "none")
        .output()
        .unwrap_or_else(|e| panic!("{test}: {} does not start: {e}", mpirun.display()));
    Some(output)
}

/// Stdout and stderr, for messages.
pub fn text(o: &Output) -> (String, String) {
    (String::from_utf8_lossy(&o.stdout).into_owned(), String::from_utf8_lossy(&o.stderr).into_owned())
}

/// A fresh scratch directory under the target directory.
pub fn scratch(name: &str) -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("mpi").join(name);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("scratch directory");
    dir
}

/// Runs `case` (a path under the repository) with `sets` serially and under `mpirun -np 1`
/// to `4` (with `more(np)` settings too), 1 thread each, and asserts that every rank count
/// writes the serial run's `diagnostics.csv` (a row for each of `steps` steps), its
/// `bodies.csv` if it has one, and its `snapshot_files` snapshots byte for byte. Returns the
/// output directories by rank count (empty when mpirun is missing).
pub fn serial_files_on_ranks(
    t: &str,
    case: &str,
    sets: &[&str],
    more: impl Fn(usize) -> Vec<String>,
    steps: usize,
    snapshot_files: usize,
) -> Vec<PathBuf> {
    let dir = scratch(t);
    let case = Path::new(env!("CARGO_MANIFEST_DIR")).join(case).display().to_string();
    let args = |out: &Path| {
        let mut a: Vec<String> = ["run", &case, "--out", &out.display().to_string(), "--quiet", "--threads", "1"]
            .map(str::to_string)
            .to_vec();
        for s in sets {
            a.extend(["--set".to_string(), s.to_string()]);
        }
        a
    };
    let serial = dir.join("serial");
    let o = Command::new(env!("CARGO_BIN_EXE_multifield")).args(args(&serial)).output().unwrap();
    assert!(o.status.success(), "{:?}", text(&o));
    let reference = std::fs::read(serial.join("diagnostics.csv")).unwrap();
    // a header and a row a step
    assert_eq!(String::from_utf8_lossy(&reference).lines().count(), steps + 1);
    let mut snapshots: Vec<String> = std::fs::read_dir(serial.join("snapshots"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    snapshots.sort();
    assert_eq!(snapshots.len(), snapshot_files, "{snapshots:?}");
    let mut outs = Vec::new();
    for np in 1..=4 {
        let out = dir.join(format!("np{np}"));
        let mut a = args(&out);
        for s in more(np) {
            a.extend(["--set".to_string(), s]);
        }
        let Some(o) = mpirun(t, np, &a.iter().map(String::as_str).collect::<Vec<_>>()) else { return Vec::new() };
        let (stdout, err) = text(&o);
        assert!(o.status.success(), "np {np}: {stdout}\n{err}");
        let done = format!("completed: {steps} steps");
        assert_eq!(stdout.matches(&done).count(), 1, "np {np}: rank 0 alone reports: {stdout}");
        let got = std::fs::read(out.join("diagnostics.csv")).unwrap();
        assert!(got == reference, "np {np}: diagnostics.csv differs from the serial run's");
        if let Ok(bodies) = std::fs::read(serial.join("bodies.csv")) {
            let got = std::fs::read(out.join("bodies.csv")).unwrap_or_default();
            assert!(got == bodies, "np {np}: bodies.csv differs from the serial run's");
        }
        for file in &snapshots {
            let (a, b) =
                (std::fs::read(serial.join("snapshots").join(file)), std::fs::read(out.join("snapshots").join(file)));
            assert!(a.unwrap() == b.unwrap_or_default(), "np {np}: snapshots/{file} differs from the serial run's");
        }
        outs.push(out);
    }
    outs
}
