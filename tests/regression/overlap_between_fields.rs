//! Two fields whose regions overlap were accepted (issue 20): `check` said the case was
//! valid with cells holding Σθ = 1.5 or 2 of their volume, and the run started from a state
//! the pressure solve then squeezed. Now the case is refused before step 0, with the cell
//! and the fields; regions that only touch are still accepted.

use std::path::Path;
use std::process::Command;
use std::time::{Duration, Instant};

fn check(sets: &[&str]) -> (Option<i32>, String, Duration) {
    let case = Path::new(env!("CARGO_MANIFEST_DIR")).join("studies/exchange_box.ron");
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_multifield"));
    cmd.arg("check").arg(&case);
    for s in sets {
        cmd.args(["--set", s]);
    }
    let start = Instant::now();
    let out = cmd.output().expect("runs");
    (out.status.code(), String::from_utf8_lossy(&out.stderr).into_owned(), start.elapsed())
}

#[test]
fn overlapping_regions_of_two_fields_were_accepted() {
    // a fills the box at θ = 0.5, b the whole box too (instead of the rest): Σθ = 1.5
    let (code, stderr, took) = check(&["fields.b.region=All", "fields.b.volume_fraction=1.0"]);
    assert_eq!(code, Some(2), "refused as bad input: {stderr}");
    assert!(took < Duration::from_secs(1), "took {took:?}");
    for part in ["fields.b.region: overlaps `a`", "the cell at (0.062500, 0.062500) would hold Σθ = 1.5000"] {
        assert!(stderr.contains(part), "message lacks `{part}`:\n{stderr}");
    }
    // two rectangles overlapping on [0.5, 0.7]: the first cell past x = 0.5 holds Σθ = 2
    let (code, stderr, _) = check(&[
        "fields.a.region=Rectangle(min: (0, 0), max: (0.7, 1))",
        "fields.a.volume_fraction=1.0",
        "fields.b.region=Rectangle(min: (0.5, 0), max: (1, 1))",
    ]);
    assert_eq!(code, Some(2), "refused as bad input: {stderr}");
    assert!(stderr.contains("the cell at (0.562500, 0.062500) would hold Σθ = 2.0000"), "{stderr}");
    // rectangles that only touch, at x = 0.5 and (not on a face) x = 0.53, are accepted
    for edge in ["0.5", "0.53"] {
        let (code, stderr, _) = check(&[
            &format!("fields.a.region=Rectangle(min: (0, 0), max: ({edge}, 1))"),
            "fields.a.volume_fraction=1.0",
            &format!("fields.b.region=Rectangle(min: ({edge}, 0), max: (1, 1))"),
        ]);
        assert_eq!(code, Some(0), "touching regions at x = {edge} are valid: {stderr}");
    }
}
