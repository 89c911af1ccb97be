//! Plain numeric CSV tables (targets, actuator commands, corrected poses,
//! correction tables of docs/apply.md): named columns of finite numbers,
//! read and written with the rules of the dataset's CSV files.

use std::fmt::Write as _;
use std::io::Write as _;
use std::path::Path;

use rayon::prelude::*;

use crate::bounds::Count;
use crate::error::Result;
use crate::quote::{has_control, quoted_bytes};
use crate::table::{self, Header};

/// The most rows of actuator commands a commands file may hold.
pub const COMMANDS: Count = Count::new(
    1,
    1_000_000,
    "each costs a forward kinematics and a row of poses held in memory",
);

/// Reads the CSV file `path` whose header names (at least) `columns`, in any
/// order; returns every data row's values in the order of `columns`, at most
/// `limit.max` of them (the row after them refused at its line, before the
/// rest is read). `what` names a row in errors (`"target"`). Errors name the
/// file, the line and the column, as for measurements.csv; a file without
/// data rows is an error.
pub fn read_numbers<const N: usize>(
    path: &Path,
    columns: &[&'static str; N],
    what: &str,
    limit: &Count,
) -> Result<Vec<[f64; N]>> {
    read_numbers_within(path, columns, what, (Some(limit), OtherColumns::Allowed))
}

/// Whether a table may have columns besides those read.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum OtherColumns {
    /// Passed over (a file `parcal` wrote with more, read again).
    Allowed,
    /// Refused, each by its name ([`Header::only`]).
    Refused,
}

/// [`read_numbers`] of at most `limit.max` rows when a `limit` is given:
/// the row after them is refused at its line, before it is stored; other
/// columns as `others` says.
pub(crate) fn read_numbers_within<const N: usize>(
    path: &Path,
    columns: &[&'static str; N],
    what: &str,
    (limit, others): (Option<&Count>, OtherColumns),
) -> Result<Vec<[f64; N]>> {
    let expected = columns.join(",");
    table::read_file(path, |reader| {
        let header = Header::read(reader, &expected)?;
        if others == OtherColumns::Refused {
            header.only(columns, &expected)?;
        }
        let at = header.require_all(columns, &expected)?;
        let mut rows = Vec::new();
        table::for_each_row(reader, &header, what, |row| {
            if let Some(limit) = limit.filter(|limit| rows.len() == limit.max) {
                return Err(row.error(
                    None,
                    limit.refusal(&format!("the number of {what} rows"), "more"),
                ));
            }
            rows.push(row.numbers(&at, columns)?);
            Ok(())
        })?;
        Ok(rows)
    })
}

/// [`read_numbers`] of a table whose rows also carry a text `label` column
/// (e.g. a ball id): each row's label (not empty, no control character) and
/// its values in the order of `columns`, which `check` accepts (or refuses
/// with a reason, reported at the row's line).
pub fn read_labelled_numbers<const N: usize>(
    path: &Path,
    label: &'static str,
    columns: &[&'static str; N],
    what: &str,
    check: impl Fn(&[f64; N]) -> std::result::Result<(), String>,
) -> Result<Vec<(String, [f64; N])>> {
    let rows = read_labels_and_numbers(path, label, true, columns, what, check)?;
    Ok(rows
        .into_iter()
        .map(|(label, values)| (label.expect("a required label"), values))
        .collect())
}

/// [`read_labelled_numbers`] of a table whose `label` column is optional
/// (poses.csv's `session`): `None` for every row of a table without it.
pub fn read_optionally_labelled_numbers<const N: usize>(
    path: &Path,
    label: &'static str,
    columns: &[&'static str; N],
    what: &str,
) -> Result<Vec<(Option<String>, [f64; N])>> {
    read_labels_and_numbers(path, label, false, columns, what, |_| Ok(()))
}

fn read_labels_and_numbers<const N: usize>(
    path: &Path,
    label: &'static str,
    required: bool,
    columns: &[&'static str; N],
    what: &str,
    check: impl Fn(&[f64; N]) -> std::result::Result<(), String>,
) -> Result<Vec<(Option<String>, [f64; N])>> {
    let expected = std::iter::once(label)
        .chain(columns.iter().copied())
        .collect::<Vec<_>>()
        .join(",");
    table::read_file(path, |reader| {
        let header = Header::read(reader, &expected)?;
        let at_label = if required {
            Some(header.require(label, &expected)?)
        } else {
            header.find(label)?
        };
        let at = header.require_all(columns, &expected)?;
        let mut rows = Vec::new();
        table::for_each_row(reader, &header, what, |row| {
            let text = match at_label {
                None => None,
                Some(at_label) => {
                    let bytes = row.field(at_label);
                    let text = std::str::from_utf8(bytes)
                        .ok()
                        .filter(|text| !text.is_empty() && !has_control(text))
                        .ok_or_else(|| {
                            row.error(
                                Some(label),
                                format!(
                                    "expected a label (not empty, no control character), found {}",
                                    quoted_bytes(bytes)
                                ),
                            )
                        })?;
                    Some(text.to_owned())
                }
            };
            let values = row.numbers(&at, columns)?;
            check(&values).map_err(|reason| row.error(None, reason))?;
            rows.push((text, values));
            Ok(())
        })?;
        Ok(rows)
    })
}

/// Writes `rows` to `path` atomically under `header`, every number in
/// Rust's shortest form that reads back bit for bit. Refuses a row of
/// another width or a non-finite value, naming the row (1-based) and the
/// column; nothing is written then.
pub fn write_numbers(path: &Path, header: &[&str], rows: &[Vec<f64>]) -> Result<()> {
    let check = crate::check::Check::new(path);
    for (k, row) in rows.iter().enumerate() {
        if row.len() != header.len() {
            return Err(check.error(
                format!("row {}", k + 1),
                format!("expected {} values, found {}", header.len(), row.len()),
            ));
        }
        if let Some(j) = row.iter().position(|v| !v.is_finite()) {
            return Err(check.error(
                format!("row {}, column {}", k + 1, header[j]),
                crate::check::not_finite(row[j]),
            ));
        }
    }
    // Pieces of rows formatted on the threads, a wave of them at a time,
    // and written in order: the bytes the CSV writer makes field by field
    // (a finite number needs no quoting), on any number of threads.
    table::write_text_file(path, header, |w| {
        for wave in rows.chunks(FORMAT_PIECE * FORMAT_WAVE) {
            let texts: Vec<String> = (wave.par_chunks(FORMAT_PIECE))
                .map(|piece| {
                    let mut text = String::new();
                    for row in piece {
                        for (j, v) in row.iter().enumerate() {
                            let separator = if j == 0 { "" } else { "," };
                            write!(text, "{separator}{v}").expect("formatting into a String");
                        }
                        text.push('\n');
                    }
                    text
                })
                .collect();
            for text in &texts {
                w.write_all(text.as_bytes())?;
            }
        }
        Ok(())
    })
}

/// The rows [`write_numbers`] formats at a time on a thread.
const FORMAT_PIECE: usize = 4096;

/// The pieces of rows [`write_numbers`] formats before writing them.
const FORMAT_WAVE: usize = 16;

#[cfg(test)]
mod tests {
    use super::*;

    /// Rows formatted in pieces on the threads, across waves, are the bytes
    /// the CSV writer makes field by field, on any number of threads.
    #[test]
    fn rows_formatted_on_the_threads_are_the_csv_writers_bytes() {
        let dir = tempfile::tempdir().unwrap();
        let rows: Vec<Vec<f64>> = (0..FORMAT_PIECE * FORMAT_WAVE + 7)
            .map(|k| {
                let x = k as f64;
                let tiny = if k % 997 == 0 { 1e-300 } else { 1e-3 };
                vec![x / 3.0, -0.0, (x * 0.37).sin() * tiny, x * 1e20 + 0.5]
            })
            .collect();
        let header = ["a", "b c", "d", "e"];
        let by_field = dir.path().join("by_field.csv");
        table::write_file(&by_field, &header, |w| {
            for row in &rows {
                w.numbers(row)?;
                w.end_row()?;
            }
            Ok(())
        })
        .unwrap();
        let expected = std::fs::read(&by_field).unwrap();
        for threads in [1, 2, 3] {
            let path = dir.path().join(format!("{threads}.csv"));
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            pool.install(|| write_numbers(&path, &header, &rows))
                .unwrap();
            assert!(
                std::fs::read(&path).unwrap() == expected,
                "{threads} threads"
            );
        }
    }

    #[test]
    fn rows_round_trip_and_errors_name_line_and_column() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("t.csv");
        let rows = vec![vec![1.0, -0.0, 1.0 / 3.0], vec![1e-300, 2.5, -7.0]];
        write_numbers(&path, &["a", "b", "c"], &rows).unwrap();
        let read = read_numbers(&path, &["c", "a", "b"], "test", &COMMANDS).unwrap();
        assert_eq!(
            read[0].map(f64::to_bits),
            [1.0 / 3.0, 1.0, -0.0].map(f64::to_bits)
        );
        assert_eq!(read[1], [-7.0, 1e-300, 2.5]);

        std::fs::write(&path, "a,b\n1,2\n\n3,x\n").unwrap();
        let error = read_numbers(&path, &["a", "b"], "test", &COMMANDS)
            .unwrap_err()
            .to_string();
        assert!(
            error.ends_with("line 4, column b: expected a number, found \"x\""),
            "{error}"
        );
        std::fs::write(&path, "a,c\n1,2\n").unwrap();
        let error = read_numbers(&path, &["a", "b"], "test", &COMMANDS)
            .unwrap_err()
            .to_string();
        assert!(error.contains("the header has no column b"), "{error}");

        // The row after the bound is refused at its line.
        let two = Count::new(1, 2, "a test's");
        std::fs::write(&path, "a,b\n1,2\n3,4\n5,6\n").unwrap();
        let error = read_numbers(&path, &["a", "b"], "test", &two)
            .unwrap_err()
            .to_string();
        assert!(
            error.contains("line 4") && error.contains("the number of test rows"),
            "{error}"
        );
        std::fs::write(&path, "a,b\n1,2\n3,4\n").unwrap();
        let read = read_numbers(&path, &["a", "b"], "test", &two).unwrap();
        assert_eq!(read, [[1.0, 2.0], [3.0, 4.0]]);

        std::fs::write(&path, "id,a\nb01,1\n\n,2\n").unwrap();
        let labelled = |path: &Path| {
            read_labelled_numbers(path, "id", &["a"], "test", |v| {
                if v[0] > 0.0 {
                    Ok(())
                } else {
                    Err("a must be positive".into())
                }
            })
        };
        let error = labelled(&path).unwrap_err().to_string();
        assert!(
            error.ends_with(
                "line 4, column id: expected a label (not empty, no control character), found \"\""
            ),
            "{error}"
        );
        std::fs::write(&path, "a,id\n1,b01\n-1,b02\n").unwrap();
        let error = labelled(&path).unwrap_err().to_string();
        assert!(error.ends_with("line 3: a must be positive"), "{error}");
        std::fs::write(&path, "a,id\n1,b01\n").unwrap();
        assert_eq!(labelled(&path).unwrap(), [("b01".to_owned(), [1.0])]);

        let error = write_numbers(&path, &["a"], &[vec![f64::NAN]])
            .unwrap_err()
            .to_string();
        assert!(error.contains("row 1, column a"), "{error}");
        assert_eq!(std::fs::read_to_string(&path).unwrap(), "a,id\n1,b01\n");
    }
}
