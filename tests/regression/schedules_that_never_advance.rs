//! `--set output.interval=1e-13` hung forever, and so did snapshot and checkpoint intervals
//! of 5e-324 and picture intervals of 1e-300 (issue 20): `while next <= t { next +=
//! interval }` stops moving once the interval is below the spacing of the reals near t.
//! Now a schedule moves past t in a bounded number of operations (at every step when its
//! interval is below the step).

use crate::hostile_input::{example, multifield, scratch};
use std::time::Duration;

#[test]
fn intervals_below_the_resolution_of_time_end() {
    let dir = scratch("tiny_intervals");
    let case = example("taylor_green.ron");
    for (k, (set, folder, files)) in [
        ("output.interval=1e-13", None, 0),
        ("output.snapshots=Some((interval: 5e-324))", Some("snapshots"), 6 + 1), // t = 0, 5 steps, the XDMF
        ("output.checkpoints=Some((interval: 5e-324))", Some("checkpoints"), 2), // the last two kept
        ("output.pictures=Some((interval: 1e-300, width: 16))", Some("frames"), 6 + 1), // and frames.csv
    ]
    .into_iter()
    .enumerate()
    {
        let out = dir.join(k.to_string());
        let ran = multifield(&[
            "run".as_ref(),
            case.as_os_str(),
            "--quiet".as_ref(),
            "--out".as_ref(),
            out.as_os_str(),
            "--set".as_ref(),
            set.as_ref(),
            "--set".as_ref(),
            "time.max_steps=5".as_ref(),
            "--set".as_ref(),
            "output.charts=false".as_ref(),
        ]);
        assert_eq!(ran.code, Some(0), "{set}: {}", ran.stderr);
        assert!(ran.wall < Duration::from_secs(1), "{set}: took {:?}", ran.wall);
        if folder.is_none() {
            let rows = std::fs::read_to_string(out.join("diagnostics.csv")).unwrap().lines().count() - 1;
            assert_eq!(rows, 5, "{set}: a row at every step");
        }
        if let Some(folder) = folder {
            let n = std::fs::read_dir(out.join(folder)).unwrap().count();
            assert_eq!(n, files, "{set}: files in {folder}/");
        }
    }
}
