//! `parcal` under an address-space limit (`ulimit -v`, as batch schedulers
//! set it): the run needs an address space near the memory it uses
//! (docs/reliability.md, "Address space").

use std::path::Path;
use std::process::{Command, Output};

use crate::common;
use common::{PAPER_FILES, copy_fixture, s, text};

/// The limit of the test, KiB: 512 MiB.
const LIMIT_KIB: u32 = 512 * 1024;

/// Runs `parcal args` on `threads` threads, its address space limited to
/// `limit_kib` by the shell's `ulimit -v` (a limit the process cannot
/// raise; setting it in a `pre_exec` would need `unsafe`).
fn parcal_limited(limit_kib: u32, threads: usize, args: &[&str]) -> Output {
    Command::new("sh")
        .arg("-c")
        .arg(format!("ulimit -v {limit_kib} && exec \"$0\" \"$@\""))
        .arg(env!("CARGO_BIN_EXE_parcal"))
        .args(args)
        .env("RAYON_NUM_THREADS", threads.to_string())
        .output()
        .expect("sh runs")
}

/// The calibration the run wrote.
fn calibration(path: &Path) -> serde_json::Value {
    let bytes = std::fs::read(path).expect("calibration.json written");
    serde_json::from_slice(&bytes).expect("calibration.json is JSON")
}

#[test]
fn the_papers_189_contacts_calibrate_within_512_mib_of_address_space() {
    let temp = tempfile::tempdir().unwrap();
    let data = copy_fixture("paper-seed1", temp.path(), &PAPER_FILES);
    let mut results = Vec::new();
    for threads in [1, 2] {
        let out = temp.path().join(format!("calibration-{threads}.json"));
        let output = parcal_limited(
            LIMIT_KIB,
            threads,
            &["calibrate", s(&data), "--out", s(&out)],
        );
        assert!(
            output.status.success(),
            "under ulimit -v {LIMIT_KIB}, {threads} thread(s): {:?}\n{}",
            output.status,
            text(&output.stderr)
        );
        results.push(calibration(&out));
    }
    assert_eq!(
        results[0]["parameters"], results[1]["parameters"],
        "the same parameters on 1 and 2 threads"
    );
}
