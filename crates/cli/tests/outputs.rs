//! What `parcal` writes, whatever the inputs and faults: bounded sizes,
//! datasets written as a set, inputs never overwritten, targets that are
//! not regular files refused, permissions kept, a rejected calibration
//! beside the accepted one, temporaries cleaned up, exit statuses.

use std::fs;
use std::path::Path;
use std::process::{Command, Output};

use crate::common;
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

/// `args` as owned strings.
fn strings(args: &[&str]) -> Vec<String> {
    args.iter().map(|a| a.to_string()).collect()
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
    // One count beyond its bound: a usage error naming the flag; a product
    // beyond the row bound: an error naming every factor.
    for (args, code, named) in [
        (
            vec!["--balls", "18446744073709551615"],
            2,
            "--balls 18446744073709551615: must be a whole number from 1 to 10000000",
        ),
        (vec!["--balls", "1000000000"], 2, "--balls 1000000000"),
        (
            vec!["--points-per-ball", "1000000000"],
            2,
            "--points-per-ball 1000000000",
        ),
        (
            vec![
                "--tracker",
                "both",
                "--sessions",
                "100",
                "--rows",
                "1000000",
            ],
            1,
            "too large: --sessions 100 x --rows 1000000",
        ),
        (
            vec!["--tracker", "poses", "--sessions", "101"],
            2,
            "--sessions 101: must be a whole number from 1 to 100",
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
            1,
            "distances",
        ),
    ] {
        let mut all = vec!["simulate", "--out", path(&out)];
        all.extend(&args);
        let output = parcal(&all);
        let message = stderr(&output);
        assert_eq!(output.status.code(), Some(code), "{args:?}: {message}");
        assert!(message.contains(named), "{message}");
        assert!(!message.contains("panicked"), "{message}");
        assert!(!out.exists(), "nothing written for {args:?}");
    }
}

#[test]
fn counts_beyond_their_bounds_are_refused_before_any_work() {
    let temp = tempfile::tempdir().unwrap();
    let out = temp.path().join("plan.csv");
    let dir = temp.path().join("d");
    let (dir_arg, out_arg) = (path(&dir).to_owned(), path(&out).to_owned());
    let plan = |counts: &[&'static str]| -> Vec<String> {
        let mut args = vec!["plan", &dir_arg, "--tilt", "10", "--out", &out_arg];
        args.extend(counts);
        args.into_iter().map(String::from).collect()
    };
    let u64_max = "18446744073709551615";
    for (args, named) in [
        (
            plan(&["--contacts", "10000000"]),
            "--contacts 10000000: must be a whole number from 1 to 10000 (",
        ),
        (
            plan(&["--contacts", "189", "--pool", u64_max]),
            "--pool 18446744073709551615: must be a whole number from 1 to 1000000 (",
        ),
        (
            plan(&["--contacts", "189", "--restarts", "0"]),
            "--restarts 0",
        ),
        (plan(&["--poses", "0"]), "--poses 0"),
        (
            plan(&["--poses", "30", "--sessions", u64_max]),
            "--sessions",
        ),
        (
            strings(&["validate", &dir_arg, "--folds", u64_max]),
            "--folds 18446744073709551615: must be a whole number from 2 to 100 (",
        ),
        (
            strings(&["validate", &dir_arg, "--folds", "1"]),
            "--folds 1",
        ),
        (
            strings(&[
                "validate",
                &dir_arg,
                "--calibration",
                "c.json",
                "--reference",
                "0",
            ]),
            "--reference 0",
        ),
        (
            strings(&[
                "calibrate",
                &dir_arg,
                "--max-iterations",
                "18446744073709551616",
            ]),
            "--max-iterations \"18446744073709551616\": must be a whole number from 0 to 10000",
        ),
    ] {
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        let output = parcal(&args);
        let message = stderr(&output);
        assert_eq!(output.status.code(), Some(2), "{args:?}: {message}");
        assert!(message.contains(named), "{args:?}: {message}");
        assert!(!out.exists());
    }
    // Counts within their bounds whose work is beyond the plan's: refused
    // by the planner before the pool is made.
    simulated(&dir);
    let args = plan(&["--contacts", "10000", "--pool", "1000000"]);
    let output = parcal(&args.iter().map(String::as_str).collect::<Vec<_>>());
    let message = stderr(&output);
    assert_eq!(output.status.code(), Some(1), "{message}");
    assert!(
        message.contains("contacts 10000 x pool 1000000 x restarts 1 make more than 200000000 candidate evaluations"),
        "{message}"
    );
    assert!(!out.exists());
    // More folds than rows: refused by the cross-validation.
    let tracked = temp.path().join("tracked");
    let output = parcal(&[
        "simulate",
        "--tracker",
        "poses",
        "--sessions",
        "1",
        "--rows",
        "10",
        "--out",
        path(&tracked),
    ]);
    assert!(output.status.success(), "{}", stderr(&output));
    let output = parcal(&["validate", path(&tracked), "--folds", "11"]);
    let message = stderr(&output);
    assert_eq!(output.status.code(), Some(1), "{message}");
    assert!(
        message.contains("11 folds of 10 rows (poses or points): a fold would hold none"),
        "{message}"
    );
    assert!(!tracked.join("validation.json").exists());
}

#[test]
fn the_outputs_of_a_run_are_distinct_and_none_is_an_input() {
    let temp = tempfile::tempdir().unwrap();
    let (calibration, poses) = (temp.path().join("c.json"), temp.path().join("t.csv"));
    fs::write(&calibration, "{}").unwrap();
    fs::write(&poses, "x,y,z,roll,pitch,yaw\n0,0,400,0,0,0\n").unwrap();
    // The commands and the corrected poses onto one file: refused before
    // anything is read.
    let both = temp.path().join("out.csv");
    let roundabout = temp.path().join(".").join("out.csv");
    let output = parcal(&[
        "compensate",
        "--calibration",
        path(&calibration),
        "--poses",
        path(&poses),
        "--out",
        path(&both),
        "--corrected-poses",
        path(&roundabout),
    ]);
    let message = stderr(&output);
    assert_eq!(output.status.code(), Some(1), "{message}");
    assert!(
        message.contains("are the same file, and this run writes both"),
        "{message}"
    );
    assert!(!both.exists());
    // simulate --run onto its own --targets: refused, the targets kept.
    let output = parcal(&[
        "simulate",
        "--run",
        path(&temp.path().join("commands.csv")),
        "--truth",
        path(&temp.path().join("d")),
        "--targets",
        path(&poses),
        "--out",
        path(&poses),
    ]);
    let message = stderr(&output);
    assert_eq!(output.status.code(), Some(1), "{message}");
    assert!(message.contains("which this run reads"), "{message}");
    assert_eq!(
        fs::read_to_string(&poses).unwrap(),
        "x,y,z,roll,pitch,yaw\n0,0,400,0,0,0\n"
    );
    // A plan whose plan.json would be plan.csv itself.
    let output = parcal(&[
        "plan",
        path(temp.path()),
        "--contacts",
        "10",
        "--tilt",
        "10",
        "--out",
        path(&temp.path().join("plan.json")),
    ]);
    assert_eq!(output.status.code(), Some(1));
    assert!(
        stderr(&output).contains("are the same file"),
        "{}",
        stderr(&output)
    );
}

#[test]
fn simulate_run_checks_its_targets_before_writing() {
    let temp = tempfile::tempdir().unwrap();
    let data = common::copy_fixture(
        "paper-seed1",
        temp.path(),
        &[
            "machine.json",
            "artefacts.json",
            "measurements.csv",
            "truth.json",
        ],
    );
    // The first five touches' readings as commands.
    let measurements = fs::read_to_string(data.join("measurements.csv")).unwrap();
    let mut commands = String::from("q1,q2,q3,q4,q5,q6\n");
    for line in measurements.lines().skip(1).take(5) {
        commands += line.split_once(',').unwrap().1;
        commands.push('\n');
    }
    let commands_path = temp.path().join("commands.csv");
    fs::write(&commands_path, commands).unwrap();
    let targets = temp.path().join("targets.csv");
    fs::write(&targets, "x,y,z,roll,pitch,yaw\n0,0,400,0,0,0\n").unwrap();
    let out = temp.path().join("reached.csv");
    let output = parcal(&[
        "simulate",
        "--run",
        path(&commands_path),
        "--truth",
        path(&data),
        "--targets",
        path(&targets),
        "--out",
        path(&out),
    ]);
    let message = stderr(&output);
    assert_eq!(output.status.code(), Some(1), "{message}");
    assert!(
        message.contains("targets.csv: 1 targets for 5 commands"),
        "{message}"
    );
    assert!(!out.exists(), "nothing written");
}

#[test]
fn a_plan_csv_and_a_plan_json_of_two_runs_are_refused_by_the_reader() {
    let temp = tempfile::tempdir().unwrap();
    let template = temp.path().join("t");
    let output = parcal(&[
        "simulate",
        "--balls",
        "8",
        "--points-per-ball",
        "5",
        "--out",
        path(&template),
    ]);
    assert!(output.status.success(), "{}", stderr(&output));
    let plan_csv = temp.path().join("plan.csv");
    let plan = |contacts: &str| {
        let output = parcal(&[
            "plan",
            path(&template),
            "--contacts",
            contacts,
            "--tilt",
            "20",
            "--pool",
            "500",
            "--out",
            path(&plan_csv),
        ]);
        assert!(output.status.success(), "{}", stderr(&output));
        fs::read(&plan_csv).unwrap()
    };
    let first = plan("32");
    let summary = fs::read(temp.path().join("plan.json")).unwrap();
    plan("33");
    // plan.json of the first run beside plan.csv of the second: what a
    // kill between the two renames leaves.
    fs::write(temp.path().join("plan.json"), &summary).unwrap();
    let simulate = |out: &str| {
        parcal(&[
            "simulate",
            "--balls",
            "8",
            "--plan",
            path(&plan_csv),
            "--out",
            path(&temp.path().join(out)),
        ])
    };
    let output = simulate("a");
    let message = stderr(&output);
    assert_eq!(output.status.code(), Some(1), "{message}");
    assert!(
        message.contains("plan.csv and") && message.contains("plan.json are not of the same plan"),
        "{message}"
    );
    assert!(!temp.path().join("a").exists());
    // The matching pair is read.
    fs::write(&plan_csv, &first).unwrap();
    let output = simulate("b");
    assert!(output.status.success(), "{}", stderr(&output));
}

/// A full disk while `calibrate --report` writes its calibration.json,
/// report.html and report.md: the second run may write files of at most a
/// size between calibration.json's and report.html's (RLIMIT_FSIZE, with
/// SIGXFSZ ignored so that the write fails with EFBIG as on a full disk),
/// so its calibration.json could be written but not its report. The set of
/// the first run stays whole (not a new calibration beside the old
/// report), and no temporary is left.
#[cfg(unix)]
#[test]
fn a_full_disk_while_a_calibration_and_its_report_are_written_leaves_the_earlier_set() {
    let temp = tempfile::tempdir().unwrap();
    let data = common::copy_fixture("paper-seed1", temp.path(), &common::PAPER_FILES);
    let output = parcal(&["calibrate", path(&data), "--report"]);
    assert!(output.status.success(), "{}", stderr(&output));
    let set = ["calibration.json", "report.html", "report.md"];
    let first: Vec<Vec<u8>> = set
        .iter()
        .map(|f| fs::read(data.join(f)).unwrap())
        .collect();
    let (calibration, html) = (first[0].len(), first[1].len());
    let blocks = (calibration + html) / 2 / 1024;
    assert!(
        blocks * 1024 > calibration && blocks * 1024 < html,
        "{calibration} {html}"
    );
    // Levenberg-Marquardt: the same data, another calibration.json.
    let output = Command::new("bash")
        .args([
            "-c",
            "trap '' XFSZ; ulimit -f \"$1\"; shift; exec \"$@\"",
            "limit",
            &blocks.to_string(),
            env!("CARGO_BIN_EXE_parcal"),
            "calibrate",
            path(&data),
            "--report",
            "--lm",
        ])
        .output()
        .unwrap();
    let message = stderr(&output);
    assert_eq!(output.status.code(), Some(1), "{message}");
    assert!(message.contains("report.html: cannot write"), "{message}");
    for (file, bytes) in set.iter().zip(&first) {
        assert!(
            fs::read(data.join(file)).unwrap() == *bytes,
            "{file} changed"
        );
    }
    let mut expected: Vec<&str> = common::PAPER_FILES.to_vec();
    expected.extend(set);
    expected.sort_unstable();
    assert_eq!(entries(&data), expected);
}

#[test]
fn accuracy_leaves_no_map_of_an_earlier_run() {
    let temp = tempfile::tempdir().unwrap();
    let dir = temp.path().join("d");
    simulated(&dir);
    let maps = temp.path().join("maps");
    let accuracy = |dataset: &Path| {
        let output = parcal(&["accuracy", path(dataset), "--out", path(&maps)]);
        assert!(output.status.success(), "{}", stderr(&output));
    };
    // With truth.json: predicted and true maps.
    accuracy(&dir);
    assert!(maps.join("before_true_absolute.svg").exists());
    fs::write(maps.join("notes.txt"), "mine").unwrap();
    // Without it: the true maps of the earlier run do not stay.
    fs::remove_file(dir.join("truth.json")).unwrap();
    accuracy(&dir);
    assert_eq!(
        entries(&maps),
        [
            "accuracy.csv",
            "before_predicted_absolute.svg",
            "before_predicted_registered.svg",
            "notes.txt"
        ]
    );
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
