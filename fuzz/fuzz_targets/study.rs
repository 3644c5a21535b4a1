//! Study files: `multifield study FILE` up to running (every combination's case built), with
//! the repository's examples as bases. Seeds: `cargo fuzz run study fuzz/corpus/study studies`.
#![no_main]

mod common;

use libfuzzer_sys::fuzz_target;
use multifield::fuzzing::{Depth, check_study};

fuzz_target!(|data: &[u8]| {
    let _ = check_study(common::scratch(), data, Depth::Build);
});
