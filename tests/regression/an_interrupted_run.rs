//! Ctrl-C (or a scheduler's SIGTERM) ended the process like a kill: no `summary.json`, and
//! nothing to continue from but the last regular checkpoint (issue 20: "a summary.json on
//! any exit the process survives"). Now the first signal ends the run after its step as
//! `"interrupted"` (exit code 130) with its rows, summary and a checkpoint of that step,
//! and a restart from it gives the uninterrupted run's rows, bit for bit.

use crate::hostile_input::{example, scratch};
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

const SETS: [&str; 4] = ["--set", "output.checkpoints=Some((interval: 1000.0))", "--set", "output.charts=false"];

fn run(dir: &Path, extra: &[&str]) -> std::process::Child {
    let case = example("lid_driven_cavity.ron");
    Command::new(env!("CARGO_BIN_EXE_multifield"))
        .args(["run", case.to_str().unwrap(), "--quiet", "--threads", "1", "--out", dir.to_str().unwrap()])
        .args(SETS)
        .args(extra)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap()
}

fn rows(dir: &Path) -> usize {
    std::fs::read_to_string(dir.join("diagnostics.csv")).map(|t| t.lines().count().saturating_sub(1)).unwrap_or(0)
}

#[test]
fn an_interrupted_run_writes_its_summary_and_continues_bit_for_bit() {
    let dir = scratch("an_interrupted_run");
    // the uninterrupted run: the lid-driven cavity to t = 10
    let full = dir.join("full");
    let done = run(&full, &[]).wait_with_output().unwrap();
    assert_eq!(done.status.code(), Some(0), "{}", String::from_utf8_lossy(&done.stderr));
    let summary = |d: &Path| -> serde_json::Value {
        serde_json::from_str(&std::fs::read_to_string(d.join("summary.json")).unwrap()).unwrap()
    };
    let total = summary(&full)["steps"].as_u64().unwrap();
    for (signal, name) in [(libc::SIGINT, "sigint"), (libc::SIGTERM, "sigterm")] {
        let cut = dir.join(name);
        let child = run(&cut, &[]);
        let started = Instant::now();
        while rows(&cut) < 3 {
            assert!(started.elapsed() < Duration::from_secs(60), "no rows after a minute");
            std::thread::sleep(Duration::from_millis(5));
        }
        // SAFETY: sending a signal to the child process we spawned and still own
        assert_eq!(unsafe { libc::kill(child.id() as libc::pid_t, signal) }, 0);
        let out = child.wait_with_output().unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(130), "{name}: {stderr}");
        let summary = summary(&cut);
        assert_eq!(summary["status"], "interrupted", "{name}: {summary}");
        let steps = summary["steps"].as_u64().unwrap();
        assert!(steps > 0 && steps < total, "{name}: interrupted at step {steps} of {total}");
        let reason = summary["reason"].as_str().unwrap();
        assert!(reason.starts_with(&format!("interrupted by a signal after step {steps}, t = ")), "{reason}");
        assert!(stderr.contains(&format!("the run was interrupted by a signal after step {steps}")), "{stderr}");
        // its last row is the step it stopped after
        let text = std::fs::read_to_string(cut.join("diagnostics.csv")).unwrap();
        let last = text.lines().last().unwrap();
        assert!(last.starts_with(&format!("{steps},")), "{last}");
        // a checkpoint of that step, from which the run continues to the same rows and end
        let checkpoint = cut.join("checkpoints").join(format!("checkpoint_{steps}.bin"));
        assert_eq!(summary["last_checkpoint"].as_str(), Some(checkpoint.to_str().unwrap()));
        let resumed = dir.join(format!("{name}_resumed"));
        let out = run(&resumed, &["--restart", checkpoint.to_str().unwrap()]).wait_with_output().unwrap();
        assert_eq!(out.status.code(), Some(0), "{}", String::from_utf8_lossy(&out.stderr));
        let rows = |d: &Path| std::fs::read(d.join("diagnostics.csv")).unwrap();
        assert!(rows(&full) == rows(&resumed), "{name}: diagnostics.csv differs from the uninterrupted run's");
        let end = |d: &Path| std::fs::read(d.join("checkpoints").join(format!("checkpoint_{total}.bin"))).unwrap();
        assert!(end(&full) == end(&resumed), "{name}: the final state differs");
    }
}
