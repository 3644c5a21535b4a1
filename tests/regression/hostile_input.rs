//! Running the real binary on hostile input (issue 20): each test reproduces one input and
//! asserts the exit code, the message and a wall time under one second.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

/// What the binary did with one input.
pub struct Ran {
    pub code: Option<i32>,
    pub stderr: String,
    pub stdout: String,
    pub wall: Duration,
}

/// Runs `multifield ARGS` and times it.
pub fn multifield<S: AsRef<std::ffi::OsStr>>(args: &[S]) -> Ran {
    let start = Instant::now();
    let out = Command::new(env!("CARGO_BIN_EXE_multifield")).args(args).output().expect("the binary runs");
    Ran {
        code: out.status.code(),
        stderr: String::from_utf8_lossy(&out.stderr).into_owned(),
        stdout: String::from_utf8_lossy(&out.stdout).into_owned(),
        wall: start.elapsed(),
    }
}

impl Ran {
    /// Refused as bad input (exit code 2), in under a second, with every part in the message.
    pub fn refused_with(&self, parts: &[&str]) {
        assert_eq!(self.code, Some(2), "refused as bad input:\n{}", self.stderr);
        assert!(self.wall < Duration::from_secs(1), "took {:?}", self.wall);
        for part in parts {
            assert!(self.stderr.contains(part), "the message lacks `{part}`:\n{}", self.stderr);
        }
    }
}

/// An example case.
pub fn example(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("examples").join(name)
}

/// A fresh scratch folder for `test`.
pub fn scratch(test: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("multifield_regression_{test}_{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// A copy of the example `name` with `from` replaced by `to`, in `dir`.
pub fn edited(dir: &Path, name: &str, from: &str, to: &str) -> PathBuf {
    let text = std::fs::read_to_string(example(name)).unwrap();
    assert!(text.contains(from), "{name} has `{from}`");
    let path = dir.join(name);
    std::fs::write(&path, text.replacen(from, to, 1)).unwrap();
    path
}
