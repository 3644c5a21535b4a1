//! The scratch directory every target shares, with the repository's examples linked in.

use multifield::fuzzing::Scratch;
use std::sync::OnceLock;

pub fn scratch() -> &'static Scratch {
    static SCRATCH: OnceLock<Scratch> = OnceLock::new();
    SCRATCH.get_or_init(|| {
        multifield::link_all();
        let examples = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .parent()
            .expect("fuzz/ in the repository")
            .join("examples");
        Scratch::new(&examples).expect("a scratch directory under the temporary directory")
    })
}
