//! The bounded, deterministic property test over the fuzz targets' oracles
//! (`multifield::fuzzing`, the same functions `fuzz/fuzz_targets/` drive under libFuzzer):
//! 10,000 inputs mutated from every example and study file with a seeded generator, each
//! accepted or refused with a message (exit code 2), none panicking or taking more than a
//! second; a sample of the accepted cases is also built (all of `check`) and run for a few
//! steps by the real binary. docs/reliability.md says how to run the long fuzz.

use multifield::fuzzing::{check_case, check_study, Depth, Scratch};
use rayon::prelude::*;
use std::path::PathBuf;
use std::process::Command;
use std::sync::Mutex;
use std::time::{Duration, Instant};

const CASE_INPUTS: usize = 6_000;
const SET_INPUTS: usize = 3_500;
const STUDY_INPUTS: usize = 500;
/// Accepted case inputs whose number is a multiple of this are also built as `check`
/// builds them.
const BUILD_EVERY: usize = 5;
/// Accepted cases run for a few steps by the binary.
const RUNS: usize = 12;
/// What counts as a hang: an input whose check (or a run's build) takes longer. A hang
/// detector, not a speed test: the slowest inputs take about 0.4 s on a quiet machine
/// and passed 1 s on one loaded by four builds, so the limit leaves room for that.
const LIMIT: Duration = Duration::from_secs(5);

fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn seeds(folder: &str) -> Vec<(String, Vec<u8>)> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(repo().join(folder))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "ron"))
        .collect();
    files.sort();
    files
        .into_iter()
        .map(|p| (p.file_name().unwrap().to_string_lossy().into_owned(), std::fs::read(&p).unwrap()))
        .collect()
}

/// Values that broke, or could break, a program reading numbers from users.
const NUMBERS: &[&str] = &[
    "0",
    "-1",
    "1e300",
    "-1e300",
    "1e-13",
    "5e-324",
    "1e-300",
    "inf",
    "-inf",
    "NaN",
    "4294967296",
    "18446744073709551616",
    "1e18",
    "2000000",
    "0.5",
    "3",
    "-0.0",
    "1e9",
    "100000",
    "2.5e-7",
];
const WORDS: &[&str] = &[
    "Eulerian",
    "Lagrangian",
    "MassPoint",
    "Resolved",
    "Fixed",
    "Free",
    "Prescribed",
    "Periodic",
    "Wall",
    "NoSlip",
    "FreeSlip",
    "Outflow",
    "Bodies([])",
    "All",
    "Rest",
    "None",
    "Some(1)",
    "true",
    "false",
    "\"\"",
    "()",
    "[]",
];

/// Byte ranges of the number tokens of a text.
fn numbers(text: &[u8]) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    let mut i = 0;
    while i < text.len() {
        let starts =
            text[i].is_ascii_digit() && (i == 0 || !(text[i - 1].is_ascii_alphanumeric() || text[i - 1] == b'_'));
        if starts {
            let begin = if i > 0 && text[i - 1] == b'-' { i - 1 } else { i };
            let mut j = i;
            while j < text.len() && (text[j].is_ascii_digit() || matches!(text[j], b'.' | b'e' | b'E' | b'-' | b'+')) {
                j += 1;
            }
            out.push((begin, j));
            i = j;
        } else {
            i += 1;
        }
    }
    out
}

fn nested(rng: &mut fastrand::Rng) -> String {
    let depth = [2, 40, 300, 10_000][rng.usize(..4)];
    let (open, close) = [("(", ")"), ("Some(", ")"), ("[", "]"), ("(a: ", ")")][rng.usize(..4)];
    format!("{}1{}", open.repeat(depth), close.repeat(depth))
}

fn value(rng: &mut fastrand::Rng) -> String {
    match rng.usize(..10) {
        0..=4 => NUMBERS[rng.usize(..NUMBERS.len())].to_string(),
        5 => WORDS[rng.usize(..WORDS.len())].to_string(),
        6 => nested(rng),
        7 => format!("({}, {})", NUMBERS[rng.usize(..NUMBERS.len())], NUMBERS[rng.usize(..NUMBERS.len())]),
        8 => format!("[{}]", vec!["0.5"; [3, 1000, 200_000][rng.usize(..3)]].join(", ")),
        _ => (0..rng.usize(1..12)).map(|_| rng.u8(..) as char).collect(),
    }
}

/// One to four mutations of a seed: numbers swapped for extreme ones, nesting, spans cut,
/// doubled or spliced from another seed, bytes flipped, a byte-order mark, a truncation.
fn mutate(seed: &[u8], others: &[(String, Vec<u8>)], rng: &mut fastrand::Rng) -> Vec<u8> {
    let mut t = seed.to_vec();
    for _ in 0..rng.usize(1..=4) {
        let n = t.len().max(1);
        match rng.usize(..12) {
            0..=3 => {
                let spots = numbers(&t);
                if let Some(&(a, b)) = spots.get(rng.usize(..spots.len().max(1))) {
                    let v = if rng.usize(..6) == 0 { nested(rng) } else { value(rng) };
                    t.splice(a..b, v.into_bytes());
                }
            }
            4 => {
                let a = rng.usize(..n);
                let b = (a + rng.usize(1..64)).min(t.len());
                t.drain(a.min(t.len())..b);
            }
            5 => {
                let a = rng.usize(..n);
                let b = (a + rng.usize(1..2000)).min(t.len());
                let span = t[a.min(t.len())..b].to_vec();
                let at = rng.usize(..=t.len());
                for _ in 0..[1, 2, 50][rng.usize(..3)] {
                    t.splice(at..at, span.iter().copied());
                }
            }
            6 => {
                let other = &others[rng.usize(..others.len())].1;
                let a = rng.usize(..other.len().max(1)).min(other.len());
                let b = (a + rng.usize(1..400)).min(other.len());
                let at = rng.usize(..=t.len());
                t.splice(at..at, other[a..b].iter().copied());
            }
            7 => {
                for _ in 0..rng.usize(1..8) {
                    let at = rng.usize(..n).min(t.len().saturating_sub(1));
                    if !t.is_empty() {
                        t[at] = rng.u8(..);
                    }
                }
            }
            8 => t.splice(0..0, [0xEF, 0xBB, 0xBF]).for_each(drop),
            9 => t.truncate(rng.usize(..n)),
            10 => {
                let word = WORDS[rng.usize(..WORDS.len())];
                let at = rng.usize(..=t.len());
                t.splice(at..at, word.bytes());
            }
            _ => {
                let at = rng.usize(..=t.len());
                let v = value(rng);
                t.splice(at..at, v.into_bytes());
            }
        }
    }
    t
}

/// The dotted paths of every entry of a case (lists by position), for `--set`.
fn paths(v: &serde_json::Value, prefix: &str, out: &mut Vec<String>) {
    let join = |k: &str| if prefix.is_empty() { k.to_string() } else { format!("{prefix}.{k}") };
    match v {
        serde_json::Value::Object(m) => m.iter().for_each(|(k, v)| {
            out.push(join(k));
            paths(v, &join(k), out)
        }),
        serde_json::Value::Array(a) => a.iter().enumerate().for_each(|(k, v)| {
            out.push(join(&k.to_string()));
            paths(v, &join(&k.to_string()), out)
        }),
        _ => {}
    }
}

fn set_input(cases: &[(PathBuf, Vec<String>)], rng: &mut fastrand::Rng) -> (usize, Vec<String>) {
    let k = rng.usize(..cases.len());
    let known = &cases[k].1;
    let overrides = (0..rng.usize(1..=3))
        .map(|_| {
            let path = match rng.usize(..8) {
                0 => "nowhere.at.all".to_string(),
                1 => format!("{}.{}", known[rng.usize(..known.len())], rng.usize(..5)),
                _ => known[rng.usize(..known.len())].clone(),
            };
            format!("{path}={}", value(rng))
        })
        .collect();
    (k, overrides)
}

#[derive(Default)]
struct Tally {
    accepted: usize,
    refused: usize,
    built: usize,
    slowest: (Duration, String),
    defects: Vec<String>,
    runnable: Vec<(usize, Vec<u8>)>,
}

impl Tally {
    fn record(
        &mut self,
        what: String,
        took: Duration,
        outcome: std::thread::Result<Result<(), multifield::core::error::Error>>,
    ) -> bool {
        if took > self.slowest.0 {
            self.slowest = (took, what.clone());
        }
        if took > LIMIT {
            self.defects.push(format!("{what}: took {took:?}"));
        }
        match outcome {
            Ok(Ok(())) => {
                self.accepted += 1;
                true
            }
            Ok(Err(e)) => {
                self.refused += 1;
                if e.to_string().trim().is_empty() {
                    self.defects.push(format!("{what}: refused without a message"));
                }
                false
            }
            Err(_) => {
                self.defects.push(format!("{what}: panicked"));
                false
            }
        }
    }
}

fn timed<T>(f: impl FnOnce() -> T) -> (Duration, T) {
    let start = Instant::now();
    let r = f();
    (start.elapsed(), r)
}

/// Writes the input a defect came from, so that it can be replayed with the binary.
fn keep(name: &str, data: &[u8]) -> PathBuf {
    let dir = std::env::temp_dir().join("multifield-fuzz-findings");
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join(name);
    std::fs::write(&path, data).unwrap();
    path
}

#[test]
fn mutated_inputs_are_accepted_or_refused_never_crash() {
    multifield::link_all();
    let examples = seeds("examples");
    let studies = seeds("studies");
    let scratch = Scratch::new(&repo().join("examples")).unwrap();
    let tally = Mutex::new(Tally::default());
    // an abort cannot be caught: the inputs in flight then stay in the scratch directory
    eprintln!("inputs in flight are written under {}", scratch.path().display());

    // case files
    (0..CASE_INPUTS).into_par_iter().for_each(|i| {
        let mut rng = fastrand::Rng::with_seed(i as u64);
        let (name, seed) = &examples[rng.usize(..examples.len())];
        let data = mutate(seed, &examples, &mut rng);
        let what = format!("case input {i} (from {name}; {})", keep_name(i, "case"));
        let (took, outcome) = timed(|| std::panic::catch_unwind(|| check_case(&scratch, &data, &[], Depth::Validate)));
        let mut t = tally.lock().unwrap();
        if outcome.as_ref().is_err() || took > LIMIT {
            keep(&keep_name(i, "case"), &data);
        }
        // every fifth input (by number, so that the same ones are built whatever the
        // threads) that validates is also built
        if t.record(what.clone(), took, outcome) && i.is_multiple_of(BUILD_EVERY) {
            drop(t);
            let (took, outcome) = timed(|| std::panic::catch_unwind(|| check_case(&scratch, &data, &[], Depth::Build)));
            let mut t = tally.lock().unwrap();
            t.built += 1;
            if outcome.as_ref().is_err() || took > LIMIT {
                keep(&keep_name(i, "case"), &data);
            }
            // counted once: a case the build refuses is refused, as `check` refuses it
            t.accepted -= 1;
            if t.record(format!("{what}, built"), took, outcome) {
                t.runnable.push((i, data));
            }
        }
    });

    // --set on every example
    let cases: Vec<(PathBuf, Vec<String>)> = examples
        .iter()
        .map(|(name, text)| {
            let path = repo().join("examples").join(name);
            let case = multifield::core::case::Case::from_ron(std::str::from_utf8(text).unwrap(), &path).unwrap();
            let mut known = Vec::new();
            paths(&serde_json::to_value(&case).unwrap(), "", &mut known);
            (path, known)
        })
        .collect();
    (0..SET_INPUTS).into_par_iter().for_each(|i| {
        let mut rng = fastrand::Rng::with_seed(1_000_000 + i as u64);
        let (k, overrides) = set_input(&cases, &mut rng);
        let seed = &examples[k].1;
        let (took, outcome) =
            timed(|| std::panic::catch_unwind(|| check_case(&scratch, seed, &overrides, Depth::Validate)));
        let what = format!("--set input {i}: {} {}", examples[k].0, shown(&overrides));
        tally.lock().unwrap().record(what, took, outcome);
    });

    // study files (planning builds every combination's case: fewer inputs)
    (0..STUDY_INPUTS).into_par_iter().for_each(|i| {
        let mut rng = fastrand::Rng::with_seed(2_000_000 + i as u64);
        let (name, seed) = &studies[rng.usize(..studies.len())];
        let data = mutate(seed, &studies, &mut rng);
        let (took, outcome) =
            timed(|| std::panic::catch_unwind(|| check_study(&scratch, &data, Depth::Validate).map(drop)));
        if outcome.as_ref().is_err() || took > LIMIT {
            keep(&keep_name(i, "study"), &data);
        }
        let what = format!("study input {i} (from {name}; {})", keep_name(i, "study"));
        let mut t = tally.lock().unwrap();
        if t.record(what.clone(), took, outcome) && i.is_multiple_of(BUILD_EVERY) {
            drop(t);
            // building every combination's simulation: a second a run at most
            let (took, outcome) = timed(|| std::panic::catch_unwind(|| check_study(&scratch, &data, Depth::Build)));
            let runs = outcome.as_ref().ok().and_then(|r| r.as_ref().ok()).copied().unwrap_or(1);
            let mut t = tally.lock().unwrap();
            t.built += 1;
            t.accepted -= 1;
            let what = format!("{what}, {runs} runs built");
            if took > LIMIT * runs as u32 {
                keep(&keep_name(i, "study"), &data);
                t.defects.push(format!("{what}: took {took:?}"));
            }
            t.record(what, Duration::ZERO, outcome.map(|r| r.map(drop)));
        }
    });

    let t = tally.into_inner().unwrap();
    let total = CASE_INPUTS + SET_INPUTS + STUDY_INPUTS;
    eprintln!(
        "{total} inputs: {} accepted, {} refused with a message, {} panics or hangs; {} accepted cases and studies also built; slowest {:?} ({})",
        t.accepted,
        t.refused,
        t.defects.len(),
        t.built,
        t.slowest.0,
        t.slowest.1
    );
    assert_eq!(t.accepted + t.refused + t.defects.iter().filter(|d| d.ends_with("panicked")).count(), total);
    assert!(
        t.defects.is_empty(),
        "{} defects (inputs kept in {}):\n{}",
        t.defects.len(),
        std::env::temp_dir().join("multifield-fuzz-findings").display(),
        t.defects.join("\n")
    );
    // the mutations must reach both sides, or the test tests nothing
    assert!(t.accepted > total / 20 && t.refused > total / 5, "{} accepted, {} refused", t.accepted, t.refused);

    // `run` is as safe as `check`: accepted cases run for three steps or are refused before
    // step 0, and never crash
    let bin = env!("CARGO_BIN_EXE_multifield");
    let mut runnable = t.runnable;
    runnable.sort_by_key(|r| r.0);
    let step = runnable.len().div_ceil(RUNS).max(1);
    let chosen: Vec<&Vec<u8>> = runnable.iter().step_by(step).map(|r| &r.1).collect();
    for (k, data) in chosen.iter().enumerate() {
        let file = keep(&format!("run-{k}.ron"), data);
        let out = run_dir(k);
        let (took, status) = timed(|| {
            Command::new(bin)
                .args(["run", file.to_str().unwrap(), "--quiet", "--threads", "1", "--set", "time.max_steps=Some(3)"])
                .arg("--out")
                .arg(&out)
                .output()
                .unwrap()
        });
        let stderr = String::from_utf8_lossy(&status.stderr);
        let code = status.status.code();
        assert!(
            matches!(code, Some(0..=2)) && !stderr.contains("panicked"),
            "{}: run ended with {:?} after {took:?}: {stderr}",
            file.display(),
            status.status
        );
        if code != Some(2) {
            assert!(out.join("summary.json").exists(), "{}: no summary.json", file.display());
        }
    }
    eprintln!("{} accepted cases run for three steps", chosen.len());
}

fn keep_name(i: usize, kind: &str) -> String {
    format!("{kind}-{i}.ron")
}

fn run_dir(k: usize) -> PathBuf {
    std::env::temp_dir().join(format!("multifield-fuzz-run-{}-{k}", std::process::id()))
}

fn shown(overrides: &[String]) -> String {
    overrides
        .iter()
        .map(|o| {
            if o.len() > 80 {
                format!("--set '{}…' ({} bytes)", o.chars().take(80).collect::<String>(), o.len())
            } else {
                format!("--set '{o}'")
            }
        })
        .collect::<Vec<_>>()
        .join(" ")
}
