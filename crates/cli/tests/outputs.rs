//! What `parcal` writes, whatever the inputs and faults: bounded sizes,
//! datasets written as a set, inputs never overwritten, targets that are
//! not regular files refused, permissions kept, a rejected calibration
//! beside the accepted one, temporaries cleaned up, exit statuses.

use std::fs;
use std::path::Path;
use std::process::{Command, Output};

mod common;
use common::parcal;

fn stderr(output: &Output) -> String {
    String::from_utf8_lossy(&output.stderr).into_owned()
}

fn path(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// The names in `dir`, sorted.
fn entries(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .collect();
    names.sort();
    names
}

/// The paper scenario (seed 7) simulated into `dir`.
fn simulated(dir: &Path) {
    let output = parcal(&["simulate", "--seed", "7", "--out", path(dir)]);
    assert!(output.status.success(), "{}", stderr(&output));
}

#[test]
fn sizes_beyond_the_bound_are_refused_before_anything_is_allocated() {
    let temp = tempfile::tempdir().unwrap();
    let out = temp.path().join("d");
    for (args, named) in [
        (
            vec!["--balls", "18446744073709551615"],
            "--balls 18446744073709551615",
        ),
        (vec!["--balls", "1000000000"], "--balls 1000000000"),
        (
            vec!["--points-per-ball", "1000000000"],
            "--points-per-ball 1000000000",
        ),
        (
            vec![
                "--tracker",
                "both",
                "--sessions",
                "1000000",
                "--rows",
                "1000000",
            ],
            "--sessions 1000000 x --rows 1000000",
        ),
        (
            vec![
                "--balls",
                "5000",
                "--points-per-ball",
                "1",
                "--plate",
                "all",
            ],
            "distances",
        ),
    ] {
        let mut all = vec!["simulate", "--out", path(&out)];
        all.extend(&args);
        let output = parcal(&all);
        let message = stderr(&output);
        assert_eq!(output.status.code(), Some(1), "{args:?}: {message}");
        assert!(
            message.contains("too large") && message.contains(named),
            "{message}"
        );
        assert!(!message.contains("panicked"), "{message}");
        assert!(!out.exists(), "nothing written for {args:?}");
    }
}

#[test]
fn a_dataset_is_replaced_only_with_force_and_then_as_a_whole() {
    let temp = tempfile::tempdir().unwrap();
    let dir = temp.path().join("d");
    simulated(&dir);
    let measurements = fs::read(dir.join("measurements.csv")).unwrap();
    fs::write(dir.join("calibration.json"), "of the old data").unwrap();
    let output = parcal(&["simulate", "--seed", "8", "--out", path(&dir)]);
    assert_eq!(output.status.code(), Some(1));
    assert!(
        stderr(&output).contains("give --force to replace it"),
        "{}",
        stderr(&output)
    );
    assert_eq!(
        fs::read(dir.join("measurements.csv")).unwrap(),
        measurements
    );

    let output = parcal(&[
        "simulate",
        "--seed",
        "8",
        "--out",
        path(&dir),
        "--force",
        "--binary",
    ]);
    assert!(output.status.success(), "{}", stderr(&output));
    assert_ne!(
        fs::read(dir.join("measurements.csv")).unwrap(),
        measurements
    );
    assert_eq!(
        entries(&dir),
        [
            "artefacts.json",
            "dataset.bin",
            "machine.json",
            "measurements.csv",
            "truth.json"
        ],
        "no stale calibration.json beside the new data"
    );
    assert_eq!(entries(temp.path()), ["d"], "no temporaries left");

    // Only a dataset is replaced, even with --force.
    fs::write(temp.path().join("notes.txt"), "mine").unwrap();
    let output = parcal(&["simulate", "--out", path(temp.path()), "--force"]);
    assert_eq!(output.status.code(), Some(1));
    assert!(
        stderr(&output).contains("not a dataset"),
        "{}",
        stderr(&output)
    );
    assert!(temp.path().join("notes.txt").exists());
}

#[test]
fn an_input_of_the_run_is_never_overwritten() {
    let temp = tempfile::tempdir().unwrap();
    let dir = temp.path().join("d");
    simulated(&dir);
    let before = fs::read(dir.join("measurements.csv")).unwrap();
    let output = parcal(&[
        "calibrate",
        path(&dir),
        "--out",
        path(&dir.join("measurements.csv")),
    ]);
    assert_eq!(output.status.code(), Some(1));
    assert!(
        stderr(&output).contains("which this run reads"),
        "{}",
        stderr(&output)
    );
    assert!(output.stdout.is_empty(), "refused before calibrating");
    // Under another name: a symbolic link to an input, a roundabout path.
    #[cfg(unix)]
    {
        let link = temp.path().join("accuracy-out");
        fs::create_dir(&link).unwrap();
        std::os::unix::fs::symlink(dir.join("truth.json"), link.join("accuracy.csv")).unwrap();
        let output = parcal(&["accuracy", path(&dir), "--out", path(&link)]);
        assert_eq!(output.status.code(), Some(1));
        assert!(
            stderr(&output).contains("which this run reads"),
            "{}",
            stderr(&output)
        );
    }
    // A plan over one of the dataset's files, or into a missing
    // directory, is refused before planning.
    let before_machine = fs::read(dir.join("machine.json")).unwrap();
    for out in [
        dir.join("artefacts.json"),
        temp.path().join("missing").join("plan.csv"),
    ] {
        let output = parcal(&[
            "plan",
            path(&dir),
            "--contacts",
            "189",
            "--tilt",
            "10",
            "--out",
            path(&out),
        ]);
        assert_eq!(output.status.code(), Some(1));
        assert!(output.stdout.is_empty(), "refused before planning");
    }
    assert_eq!(fs::read(dir.join("machine.json")).unwrap(), before_machine);
    let roundabout = dir.join("..").join("d").join("machine.json");
    let output = parcal(&[
        "validate",
        path(&dir),
        "--folds",
        "2",
        "--out",
        path(&roundabout),
    ]);
    assert_eq!(output.status.code(), Some(1));
    assert_eq!(fs::read(dir.join("measurements.csv")).unwrap(), before);
}

#[test]
fn outputs_that_cannot_be_written_are_found_before_the_work() {
    let temp = tempfile::tempdir().unwrap();
    let dir = temp.path().join("d");
    simulated(&dir);
    // A directory that cannot take files, whoever runs the test (root
    // too): its parent is a regular file.
    let file = temp.path().join("file");
    fs::write(&file, "x").unwrap();
    let inside = file.join("calibration.json");
    let output = parcal(&["calibrate", path(&dir), "--out", path(&inside)]);
    assert_eq!(output.status.code(), Some(1));
    let message = stderr(&output);
    assert!(
        message.contains(&format!("{}: cannot write", inside.display())),
        "{message}"
    );
    assert!(
        !message.contains("calibrating"),
        "before the calibration: {message}"
    );
    assert!(output.stdout.is_empty());
    let output = parcal(&["accuracy", path(&dir), "--out", path(&file.join("maps"))]);
    assert_eq!(output.status.code(), Some(1));
    let output = parcal(&["simulate", "--out", path(&file.join("d"))]);
    assert_eq!(output.status.code(), Some(1));
    assert!(stderr(&output).contains("file/d"), "{}", stderr(&output));
}

#[cfg(unix)]
#[test]
fn a_read_only_output_directory_is_found_before_the_work_and_its_files_kept() {
    use std::os::unix::fs::PermissionsExt;
    let temp = tempfile::tempdir().unwrap();
    let dir = temp.path().join("d");
    simulated(&dir);
    let maps = temp.path().join("maps");
    fs::create_dir(&maps).unwrap();
    fs::write(maps.join("accuracy.csv"), "good").unwrap();
    fs::set_permissions(&maps, fs::Permissions::from_mode(0o555)).unwrap();
    // Root (or CAP_DAC_OVERRIDE) writes there anyway: nothing to test.
    if fs::write(maps.join("probe"), "x").is_ok() {
        eprintln!("skipped: this user writes into read-only directories (root)");
        return;
    }
    let output = parcal(&["accuracy", path(&dir), "--out", path(&maps)]);
    assert_eq!(output.status.code(), Some(1));
    let message = stderr(&output);
    assert!(
        message.contains("accuracy.csv: cannot create a temporary file"),
        "{message}"
    );
    assert!(
        output.stdout.is_empty(),
        "refused before the maps are computed"
    );
    assert_eq!(
        fs::read_to_string(maps.join("accuracy.csv")).unwrap(),
        "good"
    );
    fs::set_permissions(&maps, fs::Permissions::from_mode(0o755)).unwrap();
}

#[cfg(unix)]
#[test]
fn special_files_are_refused_and_symbolic_links_written_through() {
    use std::os::unix::fs::{FileTypeExt, PermissionsExt};
    let temp = tempfile::tempdir().unwrap();
    let dir = temp.path().join("d");
    simulated(&dir);
    // Refused before anything is written, so /dev/null stays a device even
    // when the test runs as root.
    let output = parcal(&["calibrate", path(&dir), "--out", "/dev/null"]);
    assert_eq!(output.status.code(), Some(1));
    assert!(
        stderr(&output).contains("not a regular file but a device"),
        "{}",
        stderr(&output)
    );
    assert!(
        fs::metadata("/dev/null")
            .unwrap()
            .file_type()
            .is_char_device()
    );

    let results = temp.path().join("results");
    fs::create_dir(&results).unwrap();
    let target = results.join("machine-a.json");
    fs::write(&target, "old").unwrap();
    fs::set_permissions(&target, fs::Permissions::from_mode(0o600)).unwrap();
    let link = temp.path().join("calibration.json");
    std::os::unix::fs::symlink(&target, &link).unwrap();
    let output = parcal(&["calibrate", path(&dir), "--out", path(&link)]);
    assert!(output.status.success(), "{}", stderr(&output));
    assert!(
        fs::symlink_metadata(&link)
            .unwrap()
            .file_type()
            .is_symlink()
    );
    assert!(
        fs::read_to_string(&target)
            .unwrap()
            .contains("\"converged\": true")
    );
    let mode = fs::metadata(&target).unwrap().permissions().mode() & 0o777;
    assert_eq!(mode, 0o600, "a replaced file keeps its permissions");
    assert_eq!(entries(&results), ["machine-a.json"]);
}

#[test]
fn a_rejected_calibration_leaves_the_accepted_one() {
    let temp = tempfile::tempdir().unwrap();
    let dir = temp.path().join("d");
    simulated(&dir);
    let output = parcal(&["calibrate", path(&dir)]);
    assert!(output.status.success(), "{}", stderr(&output));
    let accepted = fs::read(dir.join("calibration.json")).unwrap();
    let output = parcal(&["calibrate", path(&dir), "--max-iterations", "1"]);
    assert_eq!(output.status.code(), Some(3));
    let message = stderr(&output);
    let rejected = dir.join("calibration.rejected.json");
    assert!(
        message.contains(&format!("written to {}", rejected.display()))
            && message.contains("calibration.json is left as it was"),
        "{message}"
    );
    assert!(String::from_utf8_lossy(&output.stdout).contains("calibration.rejected.json"));
    assert_eq!(fs::read(dir.join("calibration.json")).unwrap(), accepted);
    assert!(
        fs::read_to_string(&rejected)
            .unwrap()
            .contains("\"verdict\": \"rejected\"")
    );
    // The accepted one still serves; the rejected one only when asked.
    let maps = temp.path().join("maps");
    let calibration = dir.join("calibration.json");
    let output = parcal(&[
        "accuracy",
        path(&dir),
        "--calibration",
        path(&calibration),
        "--out",
        path(&maps),
    ]);
    assert!(output.status.success(), "{}", stderr(&output));
    let output = parcal(&[
        "accuracy",
        path(&dir),
        "--calibration",
        path(&rejected),
        "--out",
        path(&maps),
    ]);
    assert_eq!(output.status.code(), Some(1));
    assert!(
        stderr(&output).contains("--accept-rejected"),
        "{}",
        stderr(&output)
    );
}

#[cfg(unix)]
#[test]
fn stale_temporaries_of_a_dead_run_are_removed_by_the_next() {
    if !Path::new("/proc/self").exists() {
        eprintln!("skipped: no /proc to tell running processes");
        return;
    }
    let mut child = Command::new("true").spawn().unwrap();
    let dead = child.id();
    child.wait().unwrap();
    let temp = tempfile::tempdir().unwrap();
    let stale = temp.path().join(format!(".d.parcal-{dead}-Ab12Cd.tmp"));
    fs::create_dir(&stale).unwrap();
    fs::write(stale.join("machine.json"), "half").unwrap();
    simulated(&temp.path().join("d"));
    assert_eq!(entries(temp.path()), ["d"]);
}

#[cfg(unix)]
#[test]
fn a_run_terminated_while_writing_exits_143_and_leaves_no_temporaries() {
    let temp = tempfile::tempdir().unwrap();
    let out = temp.path().join("d");
    // About 10^6 contacts: their files take a while to write.
    let mut child = Command::new(env!("CARGO_BIN_EXE_parcal"))
        .args(["simulate", "--balls", "150000", "--out", path(&out)])
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    // The signal comes once the dataset's hidden directory exists: while
    // the files are being written.
    let started = std::time::Instant::now();
    while entries(temp.path()).is_empty() {
        assert!(started.elapsed().as_secs() < 120, "no write started");
        std::thread::sleep(std::time::Duration::from_millis(5));
    }
    let killed = Command::new("kill")
        .args(["-TERM", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(killed.success());
    let status = child.wait().unwrap();
    if status.success() {
        eprintln!("skipped: the write finished before the signal");
        return;
    }
    assert_eq!(status.code(), Some(143), "{status}");
    assert!(
        entries(temp.path()).is_empty(),
        "{:?}",
        entries(temp.path())
    );
}

#[test]
fn usage_errors_exit_2_and_other_errors_1() {
    for args in [
        vec!["simulate"],
        vec!["bogus"],
        vec!["simulate", "--out", "x", "--balls", "many"],
    ] {
        let output = parcal(&args);
        assert_eq!(
            output.status.code(),
            Some(2),
            "{args:?}: {}",
            stderr(&output)
        );
    }
    let temp = tempfile::tempdir().unwrap();
    let output = parcal(&["inspect", path(&temp.path().join("missing"))]);
    assert_eq!(output.status.code(), Some(1));
}
