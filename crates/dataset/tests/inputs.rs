//! Any input, read safely: files that are not regular files, endless or
//! over-long content, a snapshot header that lies about its length, a byte
//! order mark. Huge cases are checked by their bound, never by making them.

use crate::common;

use std::fs;

use common::*;
use parcal_dataset::*;

#[cfg(unix)]
#[test]
fn a_fifo_or_a_device_in_place_of_a_file_is_refused_by_name() {
    let dir = written(NONE);
    let csv = dir.path().join(MEASUREMENTS_FILE);
    fs::remove_file(&csv).unwrap();
    // /dev/zero through a symbolic link: an endless file.
    std::os::unix::fs::symlink("/dev/zero", &csv).unwrap();
    assert_error(
        &read_error(dir.path()),
        dir.path(),
        MEASUREMENTS_FILE,
        "is a character device, not a regular file",
    );
    fs::remove_file(&csv).unwrap();
    let made = std::process::Command::new("mkfifo").arg(&csv).status();
    if made.is_ok_and(|s| s.success()) {
        // Opening it would block until a writer came.
        assert_error(
            &read_error(dir.path()),
            dir.path(),
            MEASUREMENTS_FILE,
            "is a FIFO (named pipe), not a regular file",
        );
    }
    let machine = dir.path().join(MACHINE_FILE);
    fs::remove_file(&machine).unwrap();
    fs::create_dir(&machine).unwrap();
    assert_error(
        &read_error(dir.path()),
        dir.path(),
        MACHINE_FILE,
        "is a directory, not a regular file",
    );
    let snapshot = dir.path().join("zero.parcal");
    std::os::unix::fs::symlink("/dev/zero", &snapshot).unwrap();
    let err = Dataset::read_snapshot(&snapshot).unwrap_err().to_string();
    assert!(err.contains("zero.parcal: is a character device"), "{err}");
}

#[test]
fn a_csv_line_longer_than_the_cap_is_refused_with_its_line() {
    let dir = written(NONE);
    let long = "x".repeat(CSV_LINE_CAP as usize + 1);
    // Quoted: one field that the CSV reader would otherwise keep growing.
    write_csv(
        dir.path(),
        &format!("ball,q1,q2,q3,q4,q5,q6\nb01,1,2,3,4,5,6\n\"{long}\n"),
    );
    assert_error(
        &read_error(dir.path()),
        dir.path(),
        MEASUREMENTS_FILE,
        &format!("line 3: the line is longer than {CSV_LINE_CAP} bytes"),
    );
    // A line of exactly the cap is read (and refused for what it holds).
    let field = "y".repeat(CSV_LINE_CAP as usize - "b01,1,2,3,4,5,".len());
    write_csv(
        dir.path(),
        &format!("ball,q1,q2,q3,q4,q5,q6\nb01,1,2,3,4,5,{field}\n"),
    );
    assert_error(
        &read_error(dir.path()),
        dir.path(),
        MEASUREMENTS_FILE,
        "line 2, column q6: expected a number",
    );
}

#[test]
fn a_snapshot_header_longer_than_the_file_is_refused_before_reading() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("d.parcal");
    dataset(NONE).write_snapshot(&path).unwrap();
    let mut bytes = fs::read(&path).unwrap();
    // A payload of 2^60 bytes declared: refused by the file's size, not
    // by an allocation that fails.
    bytes[12..20].copy_from_slice(&(1u64 << 60).to_le_bytes());
    fs::write(&path, &bytes).unwrap();
    let err = Dataset::read_snapshot(&path).unwrap_err().to_string();
    assert!(
        err.contains(&format!(
            "is truncated: {} payload bytes, {} expected",
            bytes.len() - 24,
            1u64 << 60
        )),
        "{err}"
    );
}

#[test]
fn a_byte_order_mark_is_skipped_in_json_and_csv() {
    let dir = written(ALL);
    let expected = Dataset::read(dir.path()).unwrap();
    for file in [MACHINE_FILE, ARTEFACTS_FILE, TRUTH_FILE, MEASUREMENTS_FILE] {
        let path = dir.path().join(file);
        let mut bytes = b"\xEF\xBB\xBF".to_vec();
        bytes.extend(fs::read(&path).unwrap());
        fs::write(&path, bytes).unwrap();
    }
    assert_bitwise_eq(&Dataset::read(dir.path()).unwrap(), &expected);
    // Line numbers are those of the file, byte order mark or not.
    let mut csv = b"\xEF\xBB\xBFball,q1,q2,q3,q4,q5,q6\n".to_vec();
    csv.extend(b"b01,1,2,3,4,5,6\nb01,1,2,3,4,5,x\n");
    fs::write(dir.path().join(MEASUREMENTS_FILE), csv).unwrap();
    assert_error(
        &read_error(dir.path()),
        dir.path(),
        MEASUREMENTS_FILE,
        "line 3, column q6: expected a number, found \"x\"",
    );
    // Only at the start: anywhere else it is a character like any other.
    let path = dir.path().join(MACHINE_FILE);
    let text = fs::read_to_string(&path).unwrap();
    fs::write(&path, format!(" {text}")).unwrap();
    assert_error(
        &read_error(dir.path()),
        dir.path(),
        MACHINE_FILE,
        "invalid JSON",
    );
}

#[test]
fn quoted_input_is_escaped_and_shortened_in_every_message() {
    let dir = written(NONE);
    let red = "\u{1b}[31m";
    let long = red.repeat(100_000);
    let short = |message: &str| {
        assert!(
            message.len() < 400,
            "{} bytes: {message:.300}",
            message.len()
        );
        assert!(!message.contains('\u{1b}'), "{message:.300}");
    };
    write_csv(
        dir.path(),
        &format!("ball,q1,q2,q3,q4,q5,q6\nb01,1,2,3,4,5,{long}\n"),
    );
    let err = read_error(dir.path());
    short(&err);
    assert!(
        err.contains("line 2, column q6: expected a number, found \"\\u{1b}[31m"),
        "{err}"
    );
    assert!(err.ends_with("…\" (500000 characters)"), "{err}");
    write_csv(
        dir.path(),
        &format!("ball,q1,q2,q3,q4,q5,q6\n{long},1,2,3,4,5,6\n"),
    );
    let err = read_error(dir.path());
    short(&err);
    assert!(
        err.contains("line 2, column ball: unknown ball id \"\\u{1b}[31m"),
        "{err}"
    );
    // A ball id is text for a terminal: a control character is refused.
    let dir = written(NONE);
    edit_json(dir.path(), ARTEFACTS_FILE, |v| {
        v["balls"][1]["id"] = format!("b{red}02").into();
    });
    let err = read_error(dir.path());
    assert_error(
        &err,
        dir.path(),
        ARTEFACTS_FILE,
        "field balls[1].id: ball id \"b\\u{1b}[31m02\" has a control character",
    );
    edit_json(dir.path(), ARTEFACTS_FILE, |v| {
        v["balls"][1]["id"] = long.clone().into();
        v["balls"][2]["id"] = long.clone().into();
    });
    short(&read_error(dir.path()));
    edit_json(dir.path(), MACHINE_FILE, |v| {
        v["prior_sigma"]["leg"] = long.clone().into();
    });
    short(&read_error(dir.path()));
}
