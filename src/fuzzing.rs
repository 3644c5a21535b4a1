//! What `multifield check` and `multifield study` do to an input before anything runs, as
//! functions of bytes: the oracles of the fuzz targets in `fuzz/` and of the property test
//! `tests/input/fuzzing.rs` (docs/reliability.md).
//!
//! Each returns `Ok` for an input the program accepts and `Err` with the message the program
//! prints for one it refuses (exit code 2). Anything else — a panic, an abort, a hang — is a
//! defect the fuzzers look for.

use crate::core::case::Case;
use crate::core::error::Error;
use crate::core::simulation::Simulation;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

/// How deep an oracle goes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Depth {
    /// Read, parse, override and validate the case: everything `check` does before it
    /// builds the simulation (the parser target; fast enough for millions of inputs).
    Validate,
    /// All of `check`: also build the simulation (grids, points, plugins).
    Build,
}

/// A scratch directory of this process for the inputs written to disk (the program reads
/// files; the oracles feed it through the same path). Removed by [`Scratch::drop`].
pub struct Scratch {
    dir: PathBuf,
    next: AtomicU64,
}

impl Scratch {
    /// A new directory under the system's temporary directory. `examples` is linked into it
    /// beside `studies/`, so that a study file's `base: "../examples/…"` resolves as in the
    /// repository.
    pub fn new(examples: &Path) -> std::io::Result<Scratch> {
        static COUNT: AtomicU64 = AtomicU64::new(0);
        let dir = std::env::temp_dir().join(format!(
            "multifield-fuzz-{}-{}",
            std::process::id(),
            COUNT.fetch_add(1, Ordering::Relaxed)
        ));
        std::fs::create_dir_all(dir.join("studies"))?;
        let link = dir.join("examples");
        if !link.exists() {
            #[cfg(unix)]
            std::os::unix::fs::symlink(std::path::absolute(examples)?, &link)?;
            #[cfg(not(unix))]
            std::fs::create_dir_all(&link)?;
        }
        Ok(Scratch { dir, next: AtomicU64::new(0) })
    }

    /// The directory: after an abort, the inputs that were being checked are still in its
    /// `studies/` folder (`input-N.ron`, with its overrides in `input-N.set`).
    pub fn path(&self) -> &Path {
        &self.dir
    }

    fn file(&self, folder: &str, data: &[u8], overrides: &[String]) -> Result<PathBuf, Error> {
        let n = self.next.fetch_add(1, Ordering::Relaxed);
        let path = self.dir.join(folder).join(format!("input-{n}.ron"));
        let write = |path: &Path, data: &[u8]| {
            std::fs::write(path, data).map_err(|source| Error::Io { path: path.to_path_buf(), source })
        };
        write(&path, data)?;
        if !overrides.is_empty() {
            write(&path.with_extension("set"), overrides.join("\n").as_bytes())?;
        }
        Ok(path)
    }

    fn remove(&self, file: &Path) {
        let _ = std::fs::remove_file(file);
        let _ = std::fs::remove_file(file.with_extension("set"));
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.dir);
    }
}

/// `multifield check FILE --set …` on a case file holding `data`.
pub fn check_case(scratch: &Scratch, data: &[u8], overrides: &[String], depth: Depth) -> Result<(), Error> {
    let file = scratch.file("studies", data, overrides)?;
    let result = Case::load(&file, overrides).and_then(|case| match depth {
        Depth::Validate => Ok(()),
        Depth::Build => Simulation::new(&case).map(|_| ()).map_err(|e| e.in_file(&file)),
    });
    scratch.remove(&file);
    result
}

/// The planning of `multifield study FILE` (every combination's case overridden, validated
/// and, with [`Depth::Build`], built; nothing run) on a study file holding `data`, whose
/// `base` is resolved against the linked `examples/`. `Ok` holds the number of runs.
pub fn check_study(scratch: &Scratch, data: &[u8], depth: Depth) -> Result<usize, Error> {
    let file = scratch.file("studies", data, &[])?;
    let out = Some(scratch.dir.join("out"));
    let limits = crate::study::Limits::default();
    let result = crate::study::plan_to(&file, out, &[], &limits, depth == Depth::Build).map(|p| p.runs.len());
    scratch.remove(&file);
    result
}

/// Splits a `--set` fuzz input into overrides, one a line (invalid UTF-8 replaced).
pub fn overrides_of(data: &[u8]) -> Vec<String> {
    String::from_utf8_lossy(data).lines().map(str::to_string).collect()
}
