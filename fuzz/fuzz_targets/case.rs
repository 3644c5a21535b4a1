//! The case parser and validation: `multifield check FILE` up to building the simulation.
//! Seeds: `cargo fuzz run case fuzz/corpus/case examples`.
#![no_main]

mod common;

use libfuzzer_sys::fuzz_target;
use multifield::fuzzing::{Depth, check_case};

fuzz_target!(|data: &[u8]| {
    // accepted or refused with a message: both are fine; a panic, abort or hang is not
    let _ = check_case(common::scratch(), data, &[], Depth::Validate);
});
