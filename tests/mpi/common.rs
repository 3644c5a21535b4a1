//! Launching the feature-built binary under `mpirun`.

use std::path::PathBuf;
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
