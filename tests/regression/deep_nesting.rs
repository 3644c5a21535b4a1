//! Values nested a few thousand levels deep overflowed the stack (issue 20): `--set
//! 'fields.b.density=((((…))))'` or `--set 'pressure.params=Some(Some(Some(…)))'` aborted
//! with "thread 'main' has overflowed its stack", and ron's own limit told the user to use
//! `serde_stacker`. Now a case, a study and a `--set` value nest at most 128 levels; deeper
//! is refused with the place and the fix.

use crate::hostile_input::{example, multifield, scratch};
use std::path::Path;

const DEPTH: usize = 10_000;

fn nested(open: &str, inner: &str, close: &str) -> String {
    format!("{}{inner}{}", open.repeat(DEPTH), close.repeat(DEPTH))
}

#[test]
fn a_case_file_nested_10000_deep_is_refused_with_its_place() {
    let dir = scratch("deep_case");
    let text = std::fs::read_to_string(example("taylor_green.ron")).unwrap();
    let deep = text.replacen("viscosity: 0.01", &format!("viscosity: {}", nested("[", "0.01", "]")), 1);
    let case = dir.join("deep.ron");
    std::fs::write(&case, deep).unwrap();
    let line = text.lines().position(|l| l.contains("viscosity: 0.01")).unwrap() + 1;
    let ran = multifield(&["check".as_ref(), case.as_os_str()]);
    ran.refused_with(&[&format!("deep.ron:{line}:"), "nest more than 128 levels", "remove the extra brackets"]);
    assert!(!ran.stderr.contains("serde_stacker"), "{}", ran.stderr);
}

#[test]
fn a_set_value_nested_10000_deep_is_refused() {
    let case = example("dkt_seed.ron");
    for (path, value) in
        [("fields.disks.density", nested("(", "1", ")")), ("pressure.params", nested("Some(", "1", ")"))]
    {
        let set = format!("{path}={value}");
        let ran = multifield(&["check", case.to_str().unwrap(), "--set", &set]);
        ran.refused_with(&[&format!("--set {path}="), "nest more than 128 levels deep", "at column"]);
        assert!(ran.stderr.len() < 1000, "the message shows the value cut short: {} bytes", ran.stderr.len());
    }
}

#[test]
fn a_study_file_nested_10000_deep_is_refused_with_its_place() {
    let dir = scratch("deep_study");
    let study = Path::new(env!("CARGO_MANIFEST_DIR")).join("studies/transfers_taylor_green.ron");
    let text = std::fs::read_to_string(study).unwrap();
    let base = example("taylor_green_flip.ron");
    // the study's case (a path relative to studies/), named by its absolute path instead
    let end = text.find("taylor_green_flip.ron\"").unwrap() + "taylor_green_flip.ron\"".len();
    let start = text[..end - 1].rfind('"').unwrap();
    let text = format!("{}{:?}{}", &text[..start], base.to_str().unwrap(), &text[end..]);
    // an axis value `((((…0.1…))))`
    let from = "values: [0.1, 0.2,";
    let deep = text.replacen(from, &format!("values: [{}, 0.2,", nested("(", "0.1", ")")), 1);
    assert_ne!(deep, text, "the study has `{from}`");
    let file = dir.join("deep_study.ron");
    std::fs::write(&file, deep).unwrap();
    let line = text.lines().position(|l| l.contains(from)).unwrap() + 1;
    let out = dir.join("out");
    let ran = multifield(&["study".as_ref(), file.as_os_str(), "--out".as_ref(), out.as_os_str()]);
    ran.refused_with(&[
        &format!("deep_study.ron:{line}:"),
        "brackets nest more than 128 levels deep",
        "remove the extra brackets",
    ]);
    assert!(!ran.stderr.contains("serde_stacker") && !ran.stderr.contains("overflow"), "{}", ran.stderr);
    assert!(ran.stderr.len() < 1000, "the message does not echo the value: {} bytes", ran.stderr.len());
    assert!(!out.exists(), "nothing was run");
}
