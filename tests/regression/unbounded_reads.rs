//! `check /dev/urandom` read without limit (issue 20). Case and study files are now read
//! to at most 16 MiB, never further.

use crate::hostile_input::{example, multifield, scratch};

#[test]
fn an_endless_file_is_refused_after_16_mib() {
    multifield(&["check", "/dev/urandom"])
        .refused_with(&["/dev/urandom: the file holds more than 16777216 bytes", "at most 16 MiB"]);
    multifield(&["study", "/dev/zero"]).refused_with(&["/dev/zero: the file holds more than", "at most 16 MiB"]);
}

#[test]
fn a_file_over_16_mib_is_refused_by_its_size() {
    let dir = scratch("large_case");
    let big = dir.join("big.ron");
    std::fs::File::create(&big).unwrap().set_len(17 << 20).unwrap(); // sparse: nothing written
    multifield(&["check".as_ref(), big.as_os_str()])
        .refused_with(&["big.ron: the file has 17825792 bytes", "at most 16 MiB"]);
    // a case at the limit's side reads as before
    let ran = multifield(&["check".as_ref(), example("taylor_green.ron").as_os_str()]);
    assert_eq!(ran.code, Some(0), "{}", ran.stderr);
}
