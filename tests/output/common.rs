//! Helpers shared by the output tests: scratch directories and cases.

use multifield::core::case::Case;
use std::path::{Path, PathBuf};

/// `<cargo's test tmp>/<group>/<name>`, emptied (removed if it exists) and not created: a run
/// creates its own output directory.
pub fn fresh_dir(group: &str, name: &str) -> PathBuf {
    let d = Path::new(env!("CARGO_TARGET_TMPDIR")).join(group).join(name);
    let _ = std::fs::remove_dir_all(&d);
    d
}

/// [`fresh_dir`], created.
pub fn created_dir(group: &str, name: &str) -> PathBuf {
    let d = fresh_dir(group, name);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// The case in `file` with `overrides` (`--set` expressions), every plugin linked; panics
/// with the loader's message.
pub fn load(file: &str, overrides: &[&str]) -> Case {
    multifield::link_all();
    let overrides: Vec<String> = overrides.iter().map(|s| s.to_string()).collect();
    Case::load(Path::new(file), &overrides).unwrap_or_else(|e| panic!("{e}"))
}
