//! An Eulerian field with `region: Bodies([...])` was accepted and ignored (issue 14):
//! `check` said the case was valid, the run wrote no `bodies.csv`, and the water flowed
//! through the "fixed" disk at full speed. Now `check` refuses it with the fix.

use std::path::Path;
use std::process::Command;

#[test]
fn an_eulerian_field_with_bodies_was_accepted_and_ignored() {
    let case = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/settling_disk.ron");
    let out = Command::new(env!("CARGO_BIN_EXE_multifield"))
        .arg("check")
        .arg(&case)
        .args([
            "--set",
            "fields.disk.frame=(model: \"eulerian\")",
            "--set",
            "fields.disk.stress=[]",
            "--set",
            "exchange=[]",
        ])
        .output()
        .expect("runs");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "refused as bad input: {stderr}");
    for part in [
        "settling_disk.ron: fields.disk: region `Bodies([...])` (disk) needs a Lagrangian frame",
        "give this field `frame: (model: \"lagrangian\")` and `stress: [(model: \"rigid\")]`",
    ] {
        assert!(stderr.contains(part), "message lacks `{part}`:\n{stderr}");
    }
}
