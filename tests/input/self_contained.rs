//! The repository stands on its own: no shipped file names a path outside it.
//!
//! The shipped files are those `git ls-files` lists (without git, every file under the
//! root except `target/`, `out/` and `.git`), read as UTF-8 text; binary files are skipped.
//! A line of one fails when it holds
//!
//! 1. a name of a document kept outside the repository: the upper-case name of the design
//!    note (this repository's copy is `docs/method.md`), or the `shared` folder's
//!    `reference` and `design` subfolders (the reference data is `validation/reference/`);
//! 2. an absolute path into a machine's own tree: in the root's `work`, `home` or `Users`;
//! 3. a relative path with a `..` component (a run of letters, digits and `_-.+@~/`),
//!    resolved lexically:
//!    - in a markdown link `](…)`, from the file's directory: it fails when it leaves the
//!      repository or names nothing;
//!    - anywhere else, from the file's directory and from the root (commands in the docs
//!      run from the root): it fails when both leave the repository, or when from the
//!      file's directory it names nothing and from the root it leaves. In a fenced code
//!      block whose first line is a comment naming a file of the repository
//!      (`# examples/plugins/power_law/Cargo.toml`), "the file's directory" is that file's.
//!
//! Each offending place is printed as `file:line: token (why)`.

use std::path::{Component, Path, PathBuf};
use std::process::Command;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// The shipped files, relative to the root.
fn shipped_files(root: &Path) -> Vec<PathBuf> {
    let listed = Command::new("git").args(["ls-files", "-z"]).current_dir(root).output();
    if let Some(out) = listed.ok().filter(|o| o.status.success() && !o.stdout.is_empty()) {
        let names = out.stdout.split(|&b| b == 0).filter(|s| !s.is_empty());
        return names.map(|s| PathBuf::from(std::str::from_utf8(s).expect("a UTF-8 file name"))).collect();
    }
    let mut files = Vec::new();
    let mut stack = vec![PathBuf::new()];
    while let Some(dir) = stack.pop() {
        for entry in std::fs::read_dir(root.join(&dir)).unwrap().map(Result::unwrap) {
            let name = entry.file_name();
            if [".git", "target", "out"].iter().any(|skip| name == *skip) {
                continue;
            }
            let path = dir.join(&name);
            if entry.file_type().unwrap().is_dir() {
                stack.push(path);
            } else {
                files.push(path);
            }
        }
    }
    files
}

/// `base` joined with `rel`, `..` and `.` removed; `None` when it climbs above the root.
fn resolve(base: &Path, rel: &str) -> Option<PathBuf> {
    let joined = base.join(rel);
    let mut parts: Vec<&std::ffi::OsStr> = Vec::new();
    for c in joined.components() {
        match c {
            Component::Normal(p) => parts.push(p),
            Component::ParentDir => {
                parts.pop()?;
            }
            Component::CurDir => {}
            Component::RootDir | Component::Prefix(_) => return None,
        }
    }
    Some(parts.iter().collect())
}

fn is_path_char(c: char) -> bool {
    c.is_ascii_alphanumeric() || "_-.+@~/".contains(c)
}

/// Why `line` (of `file`, read in `dir`) names a path outside the repository, per token.
fn offences(root: &Path, dir: &Path, line: &str) -> Vec<(String, String)> {
    let mut found = Vec::new();
    let outside_words = [concat!("METHOD", ".md"), concat!("shared", "/reference"), concat!("shared", "/design")];
    for w in outside_words {
        if line.contains(w) {
            found.push((w.to_string(), "a document outside the repository".to_string()));
        }
    }
    let mut start = 0;
    for (end, c) in line.char_indices().chain([(line.len(), ' ')]) {
        if is_path_char(c) {
            continue;
        }
        let token = line[start..end].trim_end_matches([',', '.']);
        let token = if line[start..end].ends_with("..") { &line[start..end] } else { token };
        let before = line[..start].chars().next_back();
        let link = line[..start].ends_with("](");
        start = end + c.len_utf8();
        if before == Some(':') || token.starts_with("//") {
            continue; // a URL
        }
        let machine_roots = [concat!("/", "work/"), concat!("/", "home/"), concat!("/", "Users/")];
        if machine_roots.iter().any(|r| token.starts_with(r)) {
            found.push((token.to_string(), "an absolute path on one machine".to_string()));
            continue;
        }
        if !token.split('/').any(|p| p == "..") || token.starts_with('/') {
            continue;
        }
        let from_dir = resolve(dir, token);
        let exists = from_dir.as_ref().is_some_and(|p| root.join(p).exists());
        let why = if link {
            match &from_dir {
                None => Some("a link out of the repository"),
                Some(_) if !exists => Some("a link to nothing"),
                _ => None,
            }
        } else {
            let from_root = resolve(Path::new(""), token);
            match (&from_dir, &from_root) {
                (None, None) => Some("outside from the file's directory and from the root"),
                (Some(_), None) if !exists => Some("nothing from the file's directory, outside from the root"),
                _ => None,
            }
        };
        if let Some(why) = why {
            found.push((token.to_string(), why.to_string()));
        }
    }
    found
}

#[test]
fn no_shipped_file_names_a_path_outside_the_repository() {
    let root = root();
    let files = shipped_files(&root);
    assert!(files.len() > 50, "{} files found under {}", files.len(), root.display());
    let quick = ["..", concat!("/", "work/"), concat!("/", "home/"), concat!("/", "Users/"), "shared/", "METHOD"];
    let mut failures = Vec::new();
    for file in &files {
        let Ok(text) = std::fs::read_to_string(root.join(file)) else {
            continue; // binary, or listed but deleted
        };
        if !quick.iter().any(|q| text.contains(q)) {
            continue;
        }
        let own_dir = file.parent().unwrap_or(Path::new("")).to_path_buf();
        let mut dir = own_dir.clone();
        let mut fence: Option<usize> = None;
        for (n, line) in text.lines().enumerate() {
            if line.trim_start().starts_with("```") {
                fence = if fence.is_some() { None } else { Some(n) };
                dir = own_dir.clone();
                continue;
            }
            if fence.is_some_and(|f| f + 1 == n) {
                // the snippet's first line: `# path` or `// path` names the file it is from
                let named = line.trim().trim_start_matches(['#', '/']).trim();
                if !named.is_empty() && root.join(named).is_file() {
                    dir = Path::new(named).parent().unwrap_or(Path::new("")).to_path_buf();
                }
            }
            for (token, why) in offences(&root, &dir, line) {
                failures.push(format!("{}:{}: {token} ({why})", file.display(), n + 1));
            }
        }
    }
    assert!(
        failures.is_empty(),
        "{} place(s) name a path outside the repository (tests/input/self_contained.rs has the rule):\n{}",
        failures.len(),
        failures.join("\n")
    );
}

#[test]
fn the_rule_tells_inside_from_outside() {
    let root = root();
    // `UP/` stands for a parent step, so that this file does not break the rule itself
    let bad = |dir: &str, line: &str| !offences(&root, Path::new(dir), &line.replace("UP/", "../")).is_empty();
    // from src/, the sibling folder's path names nothing inside and leaves from the root
    assert!(bad("src", r#"PathBuf::from("UP/elsewhere/reference")"#));
    assert!(bad("studies", r#"reference: Uhlmann("UP/UP/elsewhere")"#));
    assert!(bad("docs", "[a link](UP/UP/README.md)"));
    assert!(bad("docs", "[a link](UP/no_such_file.md)"));
    assert!(bad("", concat!("see /", "work/x")));
    assert!(bad("core/src", concat!("(METHOD", ".md §3)")));
    assert!(!bad("src", r#"include_str!("UP/examples/dkt_seed.ron")"#));
    assert!(!bad("studies", r#"base: "UP/examples/dkt_uhlmann2005.ron","#));
    assert!(!bad("docs", "[method](UP/docs/method.md#3-one-time-step), see https://example.org/a/UP/b."));
    assert!(!bad("docs", "runs/<axis>-<label>.../ and 0..n and a/b/.."));
    assert!(!bad("src/cli", "cd UP/UP/examples && ls"), "inside from the file's directory");
}
