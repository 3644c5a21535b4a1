//! Two combinations of a study whose labels differ only in characters a directory name
//! cannot hold (`a b` and `a_b`) ran in one directory (issue 20): the second found the
//! first's output and counted as finished. Now the study is refused before any run.

use std::process::Command;
use std::time::{Duration, Instant};

#[test]
fn distinct_labels_that_make_one_directory_are_refused() {
    let dir = std::env::temp_dir().join(format!("multifield-colliding-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let base = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("studies/exchange_box.ron");
    let study = dir.join("collide.ron");
    std::fs::write(
        &study,
        format!(
            r#"(name: "collide", base: "{}", axes: [(name: "k", values: Sets([
                (label: "a b", set: ["exchange.0.params.coefficient=1.0"]),
                (label: "a_b", set: ["exchange.0.params.coefficient=2.0"]),
            ]))])"#,
            base.display()
        ),
    )
    .unwrap();
    let start = Instant::now();
    let out = Command::new(env!("CARGO_BIN_EXE_multifield"))
        .args(["study", study.to_str().unwrap(), "--quiet", "--out"])
        .arg(dir.join("out"))
        .output()
        .expect("runs");
    let took = start.elapsed();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "refused as bad input: {stderr}");
    assert!(took < Duration::from_secs(1), "took {took:?}");
    assert!(stderr.contains("the combinations k=a b and k=a_b would both run in"), "{stderr}");
    assert!(stderr.contains("runs/k-a_b"), "{stderr}");
    assert!(!dir.join("out/runs").exists(), "nothing ran");
    std::fs::remove_dir_all(&dir).unwrap();
}
