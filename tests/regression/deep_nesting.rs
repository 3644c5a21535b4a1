//! Values nested a few thousand levels deep overflowed the stack (issue 20): `--set
//! 'fields.b.density=((((…))))'` or `--set 'pressure.params=Some(Some(Some(…)))'` aborted
//! with "thread 'main' has overflowed its stack", and ron's own limit told the user to use
//! `serde_stacker`. Now a case, a study and a `--set` value nest at most 128 levels; deeper
//! is refused with the place and the fix.

use crate::hostile_input::{example, multifield, scratch};

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
