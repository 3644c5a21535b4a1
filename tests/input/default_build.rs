//! The default build links no MPI library (docs/design/mpi.md §1): `cargo build` needs no
//! MPI installed, and the binary runs where none is. Built with the feature `mpi`, the same
//! test checks the opposite, so that it is known to see an MPI library when one is linked.

use std::process::Command;

/// The shared libraries the binary names in its ELF `NEEDED` entries (`readelf -d`), or
/// `None` without readelf.
fn needed() -> Option<Vec<String>> {
    let o = Command::new("readelf").arg("-d").arg(env!("CARGO_BIN_EXE_multifield")).output().ok()?;
    assert!(o.status.success(), "readelf -d: {}", String::from_utf8_lossy(&o.stderr));
    let text = String::from_utf8_lossy(&o.stdout).into_owned();
    Some(
        text.lines()
            .filter(|l| l.contains("(NEEDED)"))
            .filter_map(|l| l.split('[').nth(1)?.split(']').next().map(str::to_string))
            .collect(),
    )
}

#[test]
fn default_build_has_no_mpi() {
    let Some(libs) = needed() else {
        eprintln!("default_build_has_no_mpi: skipped: readelf not found (Debian's binutils)");
        return;
    };
    // every binary needs the C library: an empty list would mean the parsing failed
    assert!(libs.iter().any(|l| l.starts_with("libc.so")), "{libs:?}");
    let mpi = libs.iter().any(|l| l.starts_with("libmpi"));
    if cfg!(feature = "mpi") {
        assert!(mpi, "built with the feature mpi, the binary should need libmpi: {libs:?}");
    } else {
        assert!(!mpi, "the default build links an MPI library: {libs:?}");
    }
}
