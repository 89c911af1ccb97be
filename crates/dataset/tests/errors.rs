//! Every malformed input is an error value that names the file and the
//! field or line: one test per case.

use crate::common;

use std::fs;

use common::*;
use parcal_dataset::*;
use serde_json::json;

/// Reads a dataset damaged by `damage` and checks the error names `file`
/// and says `expected`.
fn expect_error(parts: Parts, damage: impl FnOnce(&std::path::Path), file: &str, expected: &str) {
    let dir = written(parts);
    damage(dir.path());
    assert_error(&read_error(dir.path()), dir.path(), file, expected);
}

// ---- missing files and fields ----

#[test]
fn missing_required_file_is_named() {
    for file in [MACHINE_FILE, ARTEFACTS_FILE, MEASUREMENTS_FILE] {
        expect_error(
            NONE,
            |dir| fs::remove_file(dir.join(file)).unwrap(),
            file,
            "required file not found",
        );
    }
}

#[test]
fn missing_truth_file_is_not_an_error() {
    let dir = written(ALL);
    fs::remove_file(dir.path().join(TRUTH_FILE)).unwrap();
    assert_eq!(Dataset::read(dir.path()).unwrap().truth, None);
}

#[test]
fn missing_required_field_is_named() {
    for (file, remove, expected) in [
        (
            MACHINE_FILE,
            "/tool",
            "field tool: required field is missing",
        ),
        (
            MACHINE_FILE,
            "/prior_sigma/leg",
            "field prior_sigma.leg: required field is missing",
        ),
        (
            MACHINE_FILE,
            "/format",
            "field format: required field is missing",
        ),
        (
            ARTEFACTS_FILE,
            "/frame",
            "field frame: required field is missing",
        ),
        (
            ARTEFACTS_FILE,
            "/balls/1/radius",
            "field balls[1].radius: required field is missing",
        ),
        (
            ARTEFACTS_FILE,
            "/distances/0/sigma",
            "field distances[0].sigma: required field is missing",
        ),
        (
            TRUTH_FILE,
            "/contacts",
            "field contacts: required field is missing",
        ),
    ] {
        expect_error(
            ALL,
            |dir| {
                edit_json(dir, file, |v| {
                    let (parent, name) = remove.rsplit_once('/').unwrap();
                    let parent = v.pointer_mut(parent).unwrap();
                    match parent {
                        serde_json::Value::Object(o) => {
                            o.remove(name).unwrap();
                        }
                        _ => unreachable!(),
                    }
                })
            },
            file,
            expected,
        );
    }
}

// ---- shapes ----

#[test]
fn wrong_number_of_joints() {
    let dir = written(NONE);
    edit_json(dir.path(), MACHINE_FILE, |v| {
        v["base_joints"].as_array_mut().unwrap().pop();
    });
    let message = read_error(dir.path());
    assert!(
        message.starts_with(&format!(
            "{}: field base_joints: expected 6 joints, found 5 (line ",
            dir.path().join(MACHINE_FILE).display()
        )),
        "{message}"
    );

    expect_error(
        ALL,
        |dir| {
            edit_json(dir, TRUTH_FILE, |v| {
                v["platform_joints"]
                    .as_array_mut()
                    .unwrap()
                    .push(json!([1, 2, 3]));
            })
        },
        TRUTH_FILE,
        "field platform_joints: expected 6 joints, found 7",
    );
}

#[test]
fn wrong_number_of_coordinates() {
    expect_error(
        NONE,
        |dir| {
            edit_json(dir, MACHINE_FILE, |v| {
                v["platform_joints"][2] = json!([1.0, 2.0])
            })
        },
        MACHINE_FILE,
        "field platform_joints[2]: expected 3 coordinates, found 2",
    );
    expect_error(
        NONE,
        |dir| edit_json(dir, MACHINE_FILE, |v| v["tool"] = json!([0, 0, 60, 1])),
        MACHINE_FILE,
        "field tool: expected 3 coordinates, found 4",
    );
    expect_error(
        NONE,
        |dir| edit_json(dir, ARTEFACTS_FILE, |v| v["balls"][2]["centre"] = json!([])),
        ARTEFACTS_FILE,
        "field balls[2].centre: expected 3 coordinates, found 0",
    );
    expect_error(
        ALL,
        |dir| edit_json(dir, TRUTH_FILE, |v| v["contacts"][9] = json!([1, 2])),
        TRUTH_FILE,
        "field contacts[9]: expected 3 coordinates, found 2",
    );
    expect_error(
        ALL,
        |dir| {
            edit_json(dir, TRUTH_FILE, |v| {
                v["ball_centres"]["b02"] = json!([1, 2, 3, 4])
            })
        },
        TRUTH_FILE,
        "field ball_centres.b02: expected 3 coordinates, found 4",
    );
}

#[test]
fn wrong_number_of_leg_lengths() {
    expect_error(
        NONE,
        |dir| {
            edit_json(dir, MACHINE_FILE, |v| {
                v["leg_lengths"].as_array_mut().unwrap().push(json!(235))
            })
        },
        MACHINE_FILE,
        "field leg_lengths: expected 6 leg lengths, found 7",
    );
}

// ---- numbers ----

#[test]
fn non_numeric_json_value() {
    expect_error(
        NONE,
        |dir| edit_json(dir, MACHINE_FILE, |v| v["base_joints"][0][1] = json!("abc")),
        MACHINE_FILE,
        "field base_joints[0][1]: invalid type: string \"abc\", expected f64 (line ",
    );
    expect_error(
        NONE,
        |dir| {
            edit_json(dir, MACHINE_FILE, |v| {
                v["repeatability"]["tool"] = json!(null)
            })
        },
        MACHINE_FILE,
        "field repeatability.tool: invalid type: null, expected f64",
    );
}

#[test]
fn non_finite_json_value() {
    // JSON has no NaN or infinity: such a token is invalid JSON, and a number
    // too large for f64 is out of range; either way the line is named.
    for (token, expected) in [
        ("NaN", "invalid JSON: expected value"),
        ("-Infinity", "invalid JSON: invalid number"),
        ("1e999", "invalid JSON: number out of range"),
    ] {
        let dir = written(NONE);
        let path = dir.path().join(MACHINE_FILE);
        let text = fs::read_to_string(&path).unwrap();
        let line = 1 + text
            .lines()
            .position(|l| l.contains("\"actuator\""))
            .unwrap();
        fs::write(
            &path,
            text.replacen("\"actuator\": 0.001", &format!("\"actuator\": {token}"), 1),
        )
        .unwrap();
        assert_error(
            &read_error(dir.path()),
            dir.path(),
            MACHINE_FILE,
            &format!("line {line}, column "),
        );
        assert_error(&read_error(dir.path()), dir.path(), MACHINE_FILE, expected);
    }
}

#[test]
fn malformed_json_names_the_line() {
    expect_error(
        NONE,
        |dir| {
            fs::write(dir.join(ARTEFACTS_FILE), "{\n \"format\": \"parcal-artefacts/1\",\n \"frame\": \"design\"\n \"balls\": []\n}").unwrap()
        },
        ARTEFACTS_FILE,
        "line 4, column 2: invalid JSON: expected `,` or `}`",
    );
    expect_error(
        NONE,
        |dir| fs::write(dir.join(MACHINE_FILE), "[1, 2]").unwrap(),
        MACHINE_FILE,
        "line 1, column 1: invalid type: sequence, expected a JSON object with a \"format\" field",
    );
    expect_error(
        NONE,
        |dir| fs::write(dir.join(MACHINE_FILE), "").unwrap(),
        MACHINE_FILE,
        "invalid JSON: EOF while parsing",
    );
}

#[test]
fn non_positive_sigmas_and_radii() {
    for (file, pointer, value, expected) in [
        (
            MACHINE_FILE,
            "/prior_sigma/base",
            json!(0.0),
            "field prior_sigma.base: must be positive, found 0",
        ),
        (
            MACHINE_FILE,
            "/prior_sigma/leg",
            json!(-0.1),
            "field prior_sigma.leg: must be positive, found -0.1",
        ),
        (
            MACHINE_FILE,
            "/repeatability/actuator",
            json!(0),
            "field repeatability.actuator: must be positive, found 0",
        ),
        (
            MACHINE_FILE,
            "/repeatability/tool",
            json!(-1e-3),
            "field repeatability.tool: must be positive",
        ),
        (
            ARTEFACTS_FILE,
            "/balls/0/radius",
            json!(0.0),
            "field balls[0].radius: must be positive, found 0",
        ),
        (
            ARTEFACTS_FILE,
            "/balls/2/radius",
            json!(-5.0),
            "field balls[2].radius: must be positive, found -5",
        ),
        (
            ARTEFACTS_FILE,
            "/balls/1/radius_sigma",
            json!(-0.001),
            "field balls[1].radius_sigma: must be positive",
        ),
        (
            ARTEFACTS_FILE,
            "/balls/1/centre_sigma",
            json!(0),
            "field balls[1].centre_sigma: must be positive",
        ),
        (
            ARTEFACTS_FILE,
            "/distances/1/sigma",
            json!(0),
            "field distances[1].sigma: must be positive",
        ),
        (
            ARTEFACTS_FILE,
            "/distances/0/length",
            json!(-60),
            "field distances[0].length: must be positive",
        ),
        (
            TRUTH_FILE,
            "/ball_radii/b02",
            json!(0),
            "field ball_radii[1]: must be positive, found 0",
        ),
    ] {
        expect_error(
            ALL,
            |dir| edit_json(dir, file, |v| *v.pointer_mut(pointer).unwrap() = value),
            file,
            expected,
        );
    }
}

// ---- format versions ----

#[test]
fn unknown_major_version_is_refused() {
    let dir = written(NONE);
    edit_json(dir.path(), MACHINE_FILE, |v| {
        v["format"] = json!("parcal-machine/2")
    });
    assert_eq!(
        read_error(dir.path()),
        format!(
            "{}: format \"parcal-machine/2\" has unknown major version 2; this parcal reads version 1",
            dir.path().join(MACHINE_FILE).display()
        )
    );
    expect_error(
        ALL,
        |dir| {
            edit_json(dir, TRUTH_FILE, |v| {
                v["format"] = json!("parcal-truth/10.0")
            })
        },
        TRUTH_FILE,
        "format \"parcal-truth/10.0\" has unknown major version 10",
    );
}

#[test]
fn wrong_kind_of_file_is_refused() {
    expect_error(
        NONE,
        |dir| {
            fs::copy(dir.join(MACHINE_FILE), dir.join(ARTEFACTS_FILE))
                .map(drop)
                .unwrap()
        },
        ARTEFACTS_FILE,
        "format \"parcal-machine/1\" is a parcal-machine file, not a parcal-artefacts file",
    );
    expect_error(
        NONE,
        |dir| edit_json(dir, MACHINE_FILE, |v| v["format"] = json!("machine v1")),
        MACHINE_FILE,
        "format \"machine v1\" is not a parcal-machine format",
    );
}

#[test]
fn minor_versions_are_accepted() {
    let dir = written(ALL);
    edit_json(dir.path(), MACHINE_FILE, |v| {
        v["format"] = json!("parcal-machine/1.9")
    });
    edit_json(dir.path(), ARTEFACTS_FILE, |v| {
        v["format"] = json!("parcal-artefacts/1.0")
    });
    edit_json(dir.path(), TRUTH_FILE, |v| {
        v["format"] = json!("parcal-truth/1.12")
    });
    assert_bitwise_eq(&Dataset::read(dir.path()).unwrap(), &dataset(ALL));
}

// ---- artefacts ----

#[test]
fn duplicated_ball_id() {
    expect_error(
        NONE,
        |dir| edit_json(dir, ARTEFACTS_FILE, |v| v["balls"][2]["id"] = json!("b01")),
        ARTEFACTS_FILE,
        "field balls[2].id: ball id \"b01\" is used twice (also by balls[0])",
    );
}

#[test]
fn empty_or_padded_ball_id() {
    expect_error(
        NONE,
        |dir| edit_json(dir, ARTEFACTS_FILE, |v| v["balls"][1]["id"] = json!("")),
        ARTEFACTS_FILE,
        "field balls[1].id: ball id \"\" is empty",
    );
    expect_error(
        NONE,
        |dir| edit_json(dir, ARTEFACTS_FILE, |v| v["balls"][1]["id"] = json!(" b02")),
        ARTEFACTS_FILE,
        "field balls[1].id: ball id \" b02\" is empty or has leading or trailing whitespace",
    );
}

#[test]
fn no_balls() {
    expect_error(
        NONE,
        |dir| edit_json(dir, ARTEFACTS_FILE, |v| v["balls"] = json!([])),
        ARTEFACTS_FILE,
        "field balls: lists no ball",
    );
}

#[test]
fn unknown_ball_id_in_distances() {
    expect_error(
        ALL,
        |dir| {
            edit_json(dir, ARTEFACTS_FILE, |v| {
                v["distances"][1]["b"] = json!("b99")
            })
        },
        ARTEFACTS_FILE,
        "field distances[1].b: unknown ball id \"b99\" (not in balls)",
    );
}

#[test]
fn distance_from_a_ball_to_itself() {
    expect_error(
        ALL,
        |dir| {
            edit_json(dir, ARTEFACTS_FILE, |v| {
                v["distances"][0]["b"] = json!("b01")
            })
        },
        ARTEFACTS_FILE,
        "field distances[0]: joins ball \"b01\" to itself",
    );
}

#[test]
fn distance_given_twice_in_either_order() {
    // The test dataset has distances b01-plate-3 and b02-b01.
    for (a, b) in [("b01", "plate-3"), ("plate-3", "b01")] {
        expect_error(
            ALL,
            |dir| {
                edit_json(dir, ARTEFACTS_FILE, |v| {
                    let d = json!({"a": a, "b": b, "length": 60.0, "sigma": 0.001});
                    v["distances"].as_array_mut().unwrap().push(d);
                })
            },
            ARTEFACTS_FILE,
            &format!(
                "field distances[2]: joins balls {a:?} and {b:?} again (as distances[0] does)"
            ),
        );
    }
}

#[test]
fn distance_length_out_of_range() {
    // JSON has no NaN or infinity; a number too large for f64 is refused
    // with its field and line.
    let dir = written(ALL);
    let path = dir.path().join(ARTEFACTS_FILE);
    let text = fs::read_to_string(&path).unwrap();
    fs::write(
        &path,
        text.replacen("\"length\": 60.0003", "\"length\": 1e999", 1),
    )
    .unwrap();
    assert_error(
        &read_error(dir.path()),
        dir.path(),
        ARTEFACTS_FILE,
        "invalid JSON: number out of range",
    );
}

/// In-memory data is checked by the same rules as a file: `validate`,
/// `write` and `write_snapshot` refuse it, naming the field.
#[test]
fn invalid_distances_in_memory() {
    type Damage = fn(&mut Distance);
    let cases: [(Damage, &str); 7] = [
        (
            |d| d.b = 99,
            "field distances[1].b: ball index 99 is out of range (3 balls)",
        ),
        (
            |d| d.a = d.b,
            "field distances[1]: joins ball \"b01\" to itself",
        ),
        (
            |d| (d.a, d.b) = (2, 0),
            "field distances[1]: joins balls \"plate-3\" and \"b01\" again (as distances[0] does)",
        ),
        (
            |d| d.length = f64::NAN,
            "field distances[1].length: value NaN is not a finite number",
        ),
        (
            |d| d.length = 0.0,
            "field distances[1].length: must be positive, found 0",
        ),
        (
            |d| d.sigma = f64::INFINITY,
            "field distances[1].sigma: value inf is not a finite number",
        ),
        (
            |d| d.sigma = -1e-3,
            "field distances[1].sigma: must be positive, found -0.001",
        ),
    ];
    for (damage, expected) in cases {
        let mut bad = dataset(ALL);
        damage(&mut bad.artefacts.distances[1]);
        assert_eq!(
            bad.validate().unwrap_err().to_string(),
            format!("artefacts.json: {expected}")
        );
        let dir = tempfile::tempdir().unwrap();
        let err = bad.write(dir.path()).unwrap_err().to_string();
        assert_error(&err, dir.path(), ARTEFACTS_FILE, expected);
        let snapshot = dir.path().join("data.parcal");
        let err = bad.write_snapshot(&snapshot).unwrap_err().to_string();
        assert_eq!(err, format!("{}: {expected}", snapshot.display()));
        assert!(
            fs::read_dir(dir.path()).unwrap().next().is_none(),
            "nothing written"
        );
    }
}

#[test]
fn a_dataset_without_distances_reads_as_before() {
    let dir = written(ALL);
    edit_json(dir.path(), ARTEFACTS_FILE, |v| {
        v.as_object_mut().unwrap().remove("distances");
    });
    let read = Dataset::read(dir.path()).unwrap();
    assert!(read.artefacts.distances.is_empty());
    edit_json(dir.path(), ARTEFACTS_FILE, |v| v["distances"] = json!([]));
    assert!(
        Dataset::read(dir.path())
            .unwrap()
            .artefacts
            .distances
            .is_empty()
    );
}

#[test]
fn unknown_frame() {
    expect_error(
        NONE,
        |dir| edit_json(dir, ARTEFACTS_FILE, |v| v["frame"] = json!("world")),
        ARTEFACTS_FILE,
        "field frame: unknown variant `world`, expected `design` or `canonical`",
    );
}

// ---- measurements.csv ----

const HEADER: &str = "ball,q1,q2,q3,q4,q5,q6";

/// A valid body for the 3 balls (4 rows each), after `header`.
fn csv_with(header: &str, extra: &str, rows_before: &[&str]) -> String {
    let mut text = format!("{header}\n");
    for row in rows_before {
        text.push_str(row);
        text.push('\n');
    }
    for id in ["b01", "b02", "plate-3"] {
        for _ in 0..4 {
            text.push_str(&format!("{id},1,2,3,4,5,6{extra}\n"));
        }
    }
    text
}

fn expect_csv_error(text: &str, expected: &str) {
    expect_error(
        NONE,
        |dir| write_csv(dir, text),
        MEASUREMENTS_FILE,
        expected,
    );
}

#[test]
fn csv_valid_body_reads() {
    let dir = written(NONE);
    write_csv(dir.path(), &csv_with(HEADER, "", &[]));
    assert_eq!(Dataset::read(dir.path()).unwrap().measurements.len(), 12);
    write_csv(
        dir.path(),
        &csv_with(&format!("{HEADER},dir_x,dir_y,dir_z"), ",0,0,-1", &[]),
    );
    let d = Dataset::read(dir.path()).unwrap();
    assert_eq!(d.measurements.direction.unwrap()[11], [0.0, 0.0, -1.0]);
}

#[test]
fn csv_header_without_a_required_column() {
    expect_csv_error(
        &csv_with("ball,q1,q2,q3,q5,q6,q7", "", &[]),
        "line 1: the header has no column q4 (it must name ball,q1,q2,q3,q4,q5,q6)",
    );
    expect_csv_error(
        &csv_with("id,q1,q2,q3,q4,q5,q6", "", &[]),
        "line 1: the header has no column ball",
    );
}

#[test]
fn csv_header_with_a_duplicated_column() {
    expect_csv_error(
        &csv_with("ball,q1,q2,q3,q4,q5,q6,q2", "", &[]),
        "line 1: the header names column q2 twice",
    );
}

#[test]
fn csv_some_but_not_all_direction_columns() {
    expect_csv_error(
        &csv_with(&format!("{HEADER},dir_x,dir_z"), ",0,1", &[]),
        "line 1: the header has column dir_x, dir_z but not dir_y (give all of dir_x,dir_y,dir_z or none)",
    );
}

#[test]
fn csv_row_with_wrong_number_of_columns() {
    expect_csv_error(
        &csv_with(HEADER, "", &["b01,1,2,3,4,5"]),
        "line 2: expected 7 fields, found 6",
    );
    expect_csv_error(
        &csv_with(HEADER, "", &["b01,1,2,3,4,5,6", "b01,1,2,3,4,5,6,7"]),
        "line 3: expected 7 fields, found 8",
    );
}

#[test]
fn csv_unknown_ball_id() {
    expect_csv_error(
        &csv_with(HEADER, "", &["b01,1,2,3,4,5,6", "", "b04,1,2,3,4,5,6"]),
        "line 4, column ball: unknown ball id \"b04\" (not in artefacts.json)",
    );
    // The earliest error in the file, whichever its kind, although the ids
    // are resolved once every row is read.
    expect_csv_error(
        &csv_with(HEADER, "", &["b04,1,2,3,4,5,6", "b01,1,2,3,four,5,6"]),
        "line 2, column ball: unknown ball id \"b04\"",
    );
    expect_csv_error(
        &csv_with(HEADER, "", &["b01,1,2,3,four,5,6", "b04,1,2,3,4,5,6"]),
        "line 2, column q4: expected a number, found \"four\"",
    );
}

#[test]
fn csv_non_numeric_value() {
    expect_csv_error(
        &csv_with(HEADER, "", &["b01,1,2,3,four,5,6"]),
        "line 2, column q4: expected a number, found \"four\"",
    );
    expect_csv_error(
        &csv_with(HEADER, "", &["b01,1,2,3, four ,5,6"]),
        "line 2, column q4: expected a number, found \"four\"",
    );
    expect_csv_error(
        &csv_with(HEADER, "", &["b01,1,2,3,4,,6"]),
        "line 2, column q5: empty field, expected a number",
    );
    expect_csv_error(
        &csv_with(HEADER, "", &["b01,1,2,3,4, \t ,6"]),
        "line 2, column q5: empty field, expected a number",
    );
    expect_csv_error(
        &csv_with(
            &format!("{HEADER},dir_x,dir_y,dir_z"),
            ",0,0,1",
            &["b02,1,2,3,4,5,6,0,0x1,1"],
        ),
        "line 2, column dir_y: expected a number, found \"0x1\"",
    );
}

#[test]
fn csv_non_finite_value() {
    expect_csv_error(
        &csv_with(HEADER, "", &["b01,1,2,3,4,5,6", "b01,NaN,2,3,4,5,6"]),
        "line 3, column q1: value NaN is not a finite number",
    );
    expect_csv_error(
        &csv_with(HEADER, "", &["b01,1,2,3,4,5,-inf"]),
        "line 2, column q6: value -inf is not a finite number",
    );
    expect_csv_error(
        &csv_with(HEADER, "", &["b01,1,2,1e400,4,5,6"]),
        "line 2, column q3: value inf is not a finite number",
    );
    expect_csv_error(
        &csv_with(
            &format!("{HEADER},dir_x,dir_y,dir_z"),
            ",0,0,1",
            &["b02,1,2,3,4,5,6,0,0,infinity"],
        ),
        "line 2, column dir_z: value inf is not a finite number",
    );
}

#[test]
fn csv_empty_file() {
    expect_csv_error(
        "",
        "line 1: the file is empty (expected the header ball,q1,q2,q3,q4,q5,q6)",
    );
}

#[test]
fn csv_header_but_no_rows() {
    expect_csv_error(
        &format!("{HEADER}\n"),
        "line 1: the header is followed by no measurement row",
    );
}

/// A measurements.csv over a block of pieces (8 MiB on two threads):
/// `rows` rows, row `i` touching ball `i mod 3` with `q1 = i`; the rows
/// `bad` (0-based) with a word for `q4`, the rows `quoted` with their ball
/// id in quotes; lines ending in `end`, after a byte order mark if `bom`.
fn large_csv(rows: usize, bad: &[usize], quoted: &[usize], end: &str, bom: bool) -> String {
    let mut text = String::from(if bom { "\u{feff}" } else { "" });
    text.push_str(HEADER);
    text.push_str(end);
    let ids = ["b01", "b02", "plate-3"];
    for i in 0..rows {
        let q4 = if bad.contains(&i) { "four" } else { "4.0625" };
        let id = ids[i % 3];
        let id = if quoted.contains(&i) {
            format!("\"{id}\"")
        } else {
            id.to_owned()
        };
        text.push_str(&format!("{id},{i},2.5,3.75,{q4},5,6.125{end}"));
    }
    text
}

/// Reads `dir` on a pool of `threads` threads.
fn read_on(threads: usize, dir: &std::path::Path) -> Result<Dataset, DatasetError> {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap()
        .install(|| Dataset::read(dir))
}

#[test]
fn a_large_file_reads_the_same_on_any_number_of_threads() {
    let rows = 300_000;
    let dir = written(NONE);
    for quoted in [vec![], vec![250_000]] {
        write_csv(dir.path(), &large_csv(rows, &[], &quoted, "\n", false));
        let len = fs::metadata(dir.path().join(MEASUREMENTS_FILE))
            .unwrap()
            .len();
        assert!(len > 8 << 20, "{len} bytes");
        let one = read_on(1, dir.path()).unwrap().measurements;
        for threads in [2, 3, 7] {
            assert_eq!(read_on(threads, dir.path()).unwrap().measurements, one);
        }
        assert_eq!(one.len(), rows);
        for (i, (q, &ball)) in one.q.iter().zip(&one.ball).enumerate() {
            assert_eq!((q[0], ball), (i as f64, (i % 3) as u32), "row {i}");
        }
    }
}

/// An error in any piece and block names its line, with a byte order mark
/// and CRLF line ends too, and after a quoted field; of two, the earlier.
#[test]
fn a_large_file_names_the_line_of_its_first_error() {
    for (end, bom) in [("\n", false), ("\r\n", true)] {
        let dir = written(NONE);
        let cases = [
            (vec![280_000], vec![]),
            (vec![3, 280_000], vec![]),
            (vec![149_999, 150_000], vec![]),
            (vec![280_000], vec![250_000]),
        ];
        for (bad, quoted) in cases {
            write_csv(dir.path(), &large_csv(300_000, &bad, &quoted, end, bom));
            let line = bad[0] + 2;
            for threads in [1, 2] {
                let err = read_on(threads, dir.path()).err().unwrap().to_string();
                assert!(
                    err.ends_with(&format!(
                        "line {line}, column q4: expected a number, found \"four\""
                    )),
                    "{end:?}, {threads} threads: {err}"
                );
            }
        }
    }
}

// ---- contacts per ball ----

#[test]
fn ball_with_too_few_contacts() {
    let mut text = csv_with(HEADER, "", &[]);
    // Drop one contact of b02: 3 left.
    text = text.replacen("b02,1,2,3,4,5,6\n", "", 1);
    let dir = written(NONE);
    write_csv(dir.path(), &text);
    assert_error(
        &read_error(dir.path()),
        dir.path(),
        MEASUREMENTS_FILE,
        "ball \"b02\" has 3 contacts, fewer than the minimum of 4",
    );
    // A lower minimum accepts it; a higher one names every short ball.
    let lenient = ReadOptions {
        min_contacts_per_ball: 3,
        ..ReadOptions::default()
    };
    assert_eq!(
        Dataset::read_with(dir.path(), &lenient)
            .unwrap()
            .contacts_per_ball(),
        [4, 3, 4]
    );
    let strict = ReadOptions {
        min_contacts_per_ball: 5,
        ..ReadOptions::default()
    };
    assert_error(
        &read_error_with(dir.path(), &strict),
        dir.path(),
        MEASUREMENTS_FILE,
        "ball \"b01\" has 4 contacts, fewer than the minimum of 5 (2 other balls are short too)",
    );
}

#[test]
fn ball_listed_in_artefacts_with_no_contact() {
    let text: String = csv_with(HEADER, "", &[])
        .lines()
        .filter(|line| !line.starts_with("plate-3"))
        .map(|line| format!("{line}\n"))
        .collect();
    let dir = written(NONE);
    write_csv(dir.path(), &text);
    assert_error(
        &read_error(dir.path()),
        dir.path(),
        MEASUREMENTS_FILE,
        "ball \"plate-3\" has 0 contacts, fewer than the minimum of 4",
    );
    let none = ReadOptions {
        min_contacts_per_ball: 0,
        ..ReadOptions::default()
    };
    assert_eq!(
        Dataset::read_with(dir.path(), &none)
            .unwrap()
            .contacts_per_ball(),
        [4, 4, 0]
    );
}

// ---- truth.json ----

#[test]
fn truth_contacts_count_must_match_the_rows() {
    expect_error(
        ALL,
        |dir| {
            edit_json(dir, TRUTH_FILE, |v| {
                v["contacts"].as_array_mut().unwrap().pop();
            })
        },
        TRUTH_FILE,
        "field contacts: expected 15 contact points (one per row of measurements.csv), found 14",
    );
}

#[test]
fn truth_fields_missing_or_given_twice_are_named_and_others_ignored() {
    for field in ["ball_centres", "ball_radii", "contacts"] {
        expect_error(
            ALL,
            |dir| {
                edit_json(dir, TRUTH_FILE, |v| {
                    v.as_object_mut().unwrap().remove(field);
                })
            },
            TRUTH_FILE,
            &format!("field {field}: required field is missing"),
        );
    }
    expect_error(
        ALL,
        |dir| {
            edit_text(
                dir,
                TRUTH_FILE,
                "\"contacts\": [",
                "\"contacts\": [],\n\"contacts\": [",
            )
        },
        TRUTH_FILE,
        "duplicate field `contacts`",
    );
    let dir = written(ALL);
    let truth = Dataset::read(dir.path()).unwrap().truth;
    edit_json(dir.path(), TRUTH_FILE, |v| {
        v["note"] = json!({"any": [1, "thing"]})
    });
    assert_eq!(Dataset::read(dir.path()).unwrap().truth, truth);
}

#[test]
fn truth_ball_centres_must_have_exactly_the_artefact_ids() {
    expect_error(
        ALL,
        |dir| {
            edit_json(dir, TRUTH_FILE, |v| {
                v["ball_centres"].as_object_mut().unwrap().remove("b02");
            })
        },
        TRUTH_FILE,
        "field ball_centres: ball \"b02\" of artefacts.json is missing",
    );
    expect_error(
        ALL,
        |dir| {
            edit_json(dir, TRUTH_FILE, |v| {
                v["ball_centres"]["b99"] = json!([0, 0, 0])
            })
        },
        TRUTH_FILE,
        "field ball_centres.b99: unknown ball id \"b99\" (not in artefacts.json) (line 13,",
    );
}

#[test]
fn truth_ball_radii_must_have_exactly_the_artefact_ids() {
    expect_error(
        ALL,
        |dir| {
            edit_json(dir, TRUTH_FILE, |v| {
                v["ball_radii"].as_object_mut().unwrap().remove("plate-3");
            })
        },
        TRUTH_FILE,
        "field ball_radii: ball \"plate-3\" of artefacts.json is missing",
    );
    expect_error(
        ALL,
        |dir| edit_json(dir, TRUTH_FILE, |v| v["ball_radii"]["B01"] = json!(5)),
        TRUTH_FILE,
        "field ball_radii.B01: unknown ball id \"B01\" (not in artefacts.json) (line 20,",
    );
}

#[test]
fn truth_ball_id_given_twice() {
    expect_error(
        ALL,
        |dir| {
            edit_text(
                dir,
                TRUTH_FILE,
                "\"ball_radii\": {",
                "\"ball_radii\": {\n  \"b01\": 5.0,",
            )
        },
        TRUTH_FILE,
        "field ball_radii: ball id \"b01\" appears twice",
    );
}

#[test]
fn csv_line_numbers_count_blank_lines_crlf_and_quoted_newlines() {
    let ok = "b01,1,2,3,4,5,6";
    // Blank lines, CRLF line ends, a quoted id spanning two lines, and a
    // last row without a line end: the error names the line where the bad
    // row starts.
    for (text, line) in [
        (format!("{HEADER}\n{ok}\n\n\n{ok}\nbad,1,2,3,4,5,6\n"), 6),
        (
            format!("{HEADER}\r\n{ok}\r\n\r\n{ok}\r\nbad,1,2,3,4,5,6\r\n"),
            5,
        ),
        (format!("\n\n{HEADER}\n{ok}\nbad,1,2,3,4,5,6"), 5),
        (
            format!("{HEADER},note\n{ok},\"two\nlines\"\nbad,1,2,3,4,5,6,\"x\ny\"\n"),
            4,
        ),
    ] {
        expect_csv_error(&text, &format!("line {line}, column ball: unknown ball id"));
    }
    expect_csv_error(
        "\r\n\r\nball,q1,q2,q3,q4,q5\r\n",
        "line 3: the header has no column q6",
    );
}
