//! Messages that pointed nowhere or at the wrong thing (issue 20): a non-UTF-8 file had no
//! line and column, a byte-order mark was refused with "Expected opening `(`", a NaN in
//! the case made every `--set` fail with `invalid type: null` blamed on the override, and
//! `run` named the case file `<case>`.

use crate::hostile_input::{edited, example, multifield, scratch};

#[test]
fn a_byte_that_is_not_utf8_is_placed() {
    let dir = scratch("not_utf8");
    let text = std::fs::read(example("taylor_green.ron")).unwrap();
    let at = text.windows(9).position(|w| w == b"amplitude").unwrap();
    let line = text[..at].iter().filter(|&&b| b == b'\n').count() + 1;
    let column = at - text[..at].iter().rposition(|&b| b == b'\n').unwrap();
    let mut bad = text[..at].to_vec();
    bad.push(0xff);
    bad.extend_from_slice(&text[at..]);
    let case = dir.join("latin1.ron");
    std::fs::write(&case, bad).unwrap();
    multifield(&["check".as_ref(), case.as_os_str()])
        .refused_with(&[&format!("latin1.ron:{line}:{column}: the byte 0xff is not UTF-8"), "save it as UTF-8"]);
}

#[test]
fn a_byte_order_mark_is_accepted() {
    let dir = scratch("bom");
    let mut text = b"\xef\xbb\xbf".to_vec();
    text.extend(std::fs::read(example("taylor_green.ron")).unwrap());
    let case = dir.join("bom.ron");
    std::fs::write(&case, text).unwrap();
    let ran = multifield(&["check".as_ref(), case.as_os_str()]);
    assert_eq!(ran.code, Some(0), "{}", ran.stderr);
    assert!(ran.stdout.contains("taylor_green is valid"), "{}", ran.stdout);
}

#[test]
fn a_nan_in_the_case_is_blamed_on_its_entry_not_on_the_override() {
    let dir = scratch("nan_and_set");
    let case = edited(&dir, "taylor_green.ron", "amplitude: 1.0", "amplitude: NaN");
    let ran = multifield(&["check", case.to_str().unwrap(), "--set", "time.end=0.5"]);
    ran.refused_with(&["taylor_green.ron: fields.fluid.velocity.TaylorGreen.amplitude: NaN is not a finite number"]);
    assert!(!ran.stderr.contains("--set") && !ran.stderr.contains("null"), "{}", ran.stderr);
}

#[test]
fn run_names_the_case_file() {
    let dir = scratch("run_names_file");
    let out = dir.join("out");
    let case = example("settling_disk.ron");
    let ran = multifield(&[
        "run".as_ref(),
        case.as_os_str(),
        "--quiet".as_ref(),
        "--out".as_ref(),
        out.as_os_str(),
        "--set".as_ref(),
        "fields.disk.frame=(model: \"eulerian\")".as_ref(),
        "--set".as_ref(),
        "fields.disk.stress=[]".as_ref(),
        "--set".as_ref(),
        "exchange=[]".as_ref(),
    ]);
    ran.refused_with(&["settling_disk.ron: fields.disk: region `Bodies([...])` (disk) needs a Lagrangian frame"]);
    assert!(!ran.stderr.contains("<case>"), "{}", ran.stderr);
    let summary = std::fs::read_to_string(out.join("summary.json")).unwrap();
    assert!(summary.contains("settling_disk.ron: fields.disk") && !summary.contains("<case>"), "{summary}");
}
