//! `--set path=value` overrides on a shipped example: the first byte picks the example, the
//! rest are the overrides, one a line. Seeds: `cargo fuzz run set fuzz/corpus/set fuzz/seeds/set`.
#![no_main]

mod common;

use libfuzzer_sys::fuzz_target;
use multifield::fuzzing::{Depth, check_case, overrides_of};
use std::sync::OnceLock;

fn examples() -> &'static [Vec<u8>] {
    static EXAMPLES: OnceLock<Vec<Vec<u8>>> = OnceLock::new();
    EXAMPLES.get_or_init(|| {
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .parent()
            .expect("fuzz/ in the repository")
            .join("examples");
        let mut files: Vec<_> = std::fs::read_dir(dir)
            .expect("the repository's examples")
            .map(|e| e.expect("a directory entry").path())
            .filter(|p| p.extension().is_some_and(|e| e == "ron"))
            .collect();
        files.sort();
        files.iter().map(|p| std::fs::read(p).expect("an example")).collect()
    })
}

fuzz_target!(|data: &[u8]| {
    let Some((&pick, rest)) = data.split_first() else { return };
    let examples = examples();
    let case = &examples[pick as usize % examples.len()];
    let _ = check_case(common::scratch(), case, &overrides_of(rest), Depth::Validate);
});
