//! `check` on a 1 MB case with one very long list took more than 5 s (issue 20). Now the
//! list is parsed in linear time and refused by its length, with the entry and the cap.

use std::process::Command;
use std::time::{Duration, Instant};

#[test]
fn a_list_of_a_megabyte_is_refused_by_its_length_in_under_a_second() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let base = std::fs::read_to_string(root.join("examples/settling_disk.ron")).unwrap();
    let one = r#"(model: "newtonian", params: (viscosity: 0.1)), "#;
    let n = 1_000_000 / one.len();
    let text =
        base.replacen("stress: [(model: \"newtonian\"", &format!("stress: [{}(model: \"newtonian\"", one.repeat(n)), 1);
    assert!(text.len() > 1_000_000);
    let dir = std::env::temp_dir().join(format!("multifield-long-list-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("long_list.ron");
    std::fs::write(&file, &text).unwrap();
    let start = Instant::now();
    let out = Command::new(env!("CARGO_BIN_EXE_multifield")).arg("check").arg(&file).output().expect("runs");
    let took = start.elapsed();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(took < Duration::from_secs(1), "took {took:?}");
    let expected = format!("long_list.ron: fields.water.stress: {} stress models; at most 64", n + 1);
    assert!(stderr.contains(&expected), "{stderr}");
    std::fs::remove_dir_all(&dir).unwrap();
}
