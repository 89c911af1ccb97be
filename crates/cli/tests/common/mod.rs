//! Helpers shared by the end-to-end tests of the `parcal` binary: running
//! it, its outcome, and copies of the fixtures.

use std::fs;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// The files of a simulated paper dataset (fixtures/paper-seed1).
pub const PAPER_FILES: [&str; 4] = [
    "machine.json",
    "artefacts.json",
    "measurements.csv",
    "truth.json",
];

/// Runs `parcal` with `args`.
pub fn parcal(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_parcal"))
        .args(args)
        .output()
        .expect("the parcal binary runs")
}

/// The standard output of a run that must succeed.
pub fn ok(args: &[&str]) -> String {
    let output = parcal(args);
    assert!(
        output.status.success(),
        "parcal {args:?}: {}",
        String::from_utf8_lossy(&output.stderr)
    );
    String::from_utf8_lossy(&output.stdout).into_owned()
}

/// The standard error of a run that must fail.
pub fn fails(args: &[&str]) -> String {
    let output = parcal(args);
    assert!(!output.status.success(), "parcal {args:?} should fail");
    String::from_utf8_lossy(&output.stderr).into_owned()
}

/// `bytes` as text.
pub fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

/// A path as an argument.
pub fn s(path: &Path) -> &str {
    path.to_str().unwrap()
}

/// `parcal compensate`'s arguments: the target poses of `targets` through
/// the calibration `calibration`, the commands to `commands`.
pub fn compensate_poses<'a>(
    calibration: &'a Path,
    targets: &'a Path,
    commands: &'a Path,
) -> [&'a str; 7] {
    [
        "compensate",
        "--calibration",
        s(calibration),
        "--poses",
        s(targets),
        "--out",
        s(commands),
    ]
}

/// `dir/sim`, the dataset `parcal simulate --mechanism MECHANISM --seed
/// SEED` writes.
pub fn simulated(dir: &Path, mechanism: &str, seed: u64) -> PathBuf {
    let sim = dir.join("sim");
    let seed = seed.to_string();
    ok(&[
        "simulate",
        "--mechanism",
        mechanism,
        "--seed",
        &seed,
        "--out",
        s(&sim),
    ]);
    sim
}

/// A copy of the fixture `name`'s `files` in `dir/data`.
pub fn copy_fixture(name: &str, dir: &Path, files: &[&str]) -> PathBuf {
    let fixture = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../fixtures")
        .join(name);
    let data = dir.join("data");
    fs::create_dir_all(&data).unwrap();
    for file in files {
        fs::copy(fixture.join(file), data.join(file)).unwrap();
    }
    data
}

/// The last cell of tracker `label`'s row in a report's trackers table:
/// its error in its sigmas, six numbers (`r_x, r_y, r_z; t_x, t_y, t_z`).
pub fn tracker_errors(markdown: &str, label: &str) -> Vec<f64> {
    let row = (markdown.lines())
        .find(|l| l.starts_with(&format!("| {label} |")))
        .unwrap_or_else(|| panic!("no row of tracker {label}:\n{markdown}"));
    let last = row.trim_end_matches(" |").rsplit(" | ").next().unwrap();
    let errors: Vec<f64> = (last.split([',', ';']))
        .map(|e| e.trim().parse().unwrap())
        .collect();
    assert_eq!(errors.len(), 6, "{row}");
    errors
}
