//! Every observation's residuals and tests in a mechanism calibration's
//! record: held as two columns, the observations and their rows (no
//! allocation per observation: a hexapod's calibration has 10^6 touches),
//! and written as the format's list of one object per observation,
//!
//! ```json
//! {"kind": "ball touch", "index": 0, "residuals": [...], "redundancy": [...], "normalised": [...]}
//! ```

use std::borrow::Cow;
use std::fmt;

use serde::de::{self, SeqAccess, Visitor};
use serde::ser::SerializeStruct;
use serde::{Deserialize, Deserializer, Serialize, Serializer};

use crate::json;

/// One row's test: its whitened residual, its redundancy number and its
/// normalised residual, in single precision (16 bytes a row), as the
/// hexapod's own checks keep theirs: their rounding, a relative 6e-8, is
/// far below what they are read for (a normalised residual against a
/// critical value near 4, a redundancy number against 0.1). Written as
/// the shortest decimals that read back as the same single-precision
/// numbers (within a relative 1.2e-7 of the values before rounding).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct RowCheck {
    /// The whitened residual `e_j / σ_j`.
    pub residual: f32,
    /// The redundancy number `r_j`.
    pub redundancy: f32,
    /// The normalised residual `w_j = e_j / √r_j` (`None`: no other row
    /// checks it).
    pub normalised: Option<f32>,
}

/// One observation's residuals and tests, borrowed from
/// [`ObservationRecords`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ObservationRecord<'a> {
    /// Its kind (`probe height`, `part distance`, `measured point`,
    /// `point sample`, `measured quantity`, `ball touch`, ...).
    pub kind: &'a str,
    /// Its 0-based index among those of its kind in the dataset.
    pub index: usize,
    /// Its rows.
    pub rows: &'a [RowCheck],
}

impl ObservationRecord<'_> {
    /// Its row of largest `|w_j|` and that `w_j`.
    pub fn worst(&self) -> Option<(usize, f64)> {
        worst_row(self.rows)
    }
}

/// The row of largest `|w_j|` among `rows`, and that `w_j`.
pub fn worst_row(rows: &[RowCheck]) -> Option<(usize, f64)> {
    (rows.iter().enumerate())
        .filter_map(|(j, row)| row.normalised.map(|w| (j, f64::from(w))))
        .max_by(|a, b| a.1.abs().total_cmp(&b.1.abs()))
}

/// An observation of [`ObservationRecords`]: its kind, its index and where
/// its rows end.
#[derive(Debug, Clone, PartialEq)]
struct Entry {
    kind: Cow<'static, str>,
    index: usize,
    end: usize,
}

/// Every observation's residuals and tests, in order (module doc).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ObservationRecords {
    entries: Vec<Entry>,
    rows: Vec<RowCheck>,
}

impl ObservationRecords {
    /// Records of the observations whose rows, in order, are `rows`: none
    /// yet ([`ObservationRecords::push`] takes them in turn).
    pub fn of_rows(rows: Vec<RowCheck>) -> Self {
        Self {
            entries: Vec::new(),
            rows,
        }
    }

    /// The next observation, of kind `kind` and index `index`, holding the
    /// next `rows` rows; `false` (nothing added) when fewer are left.
    pub fn push(&mut self, kind: Cow<'static, str>, index: usize, rows: usize) -> bool {
        let start = self.entries.last().map_or(0, |e| e.end);
        let end = start + rows;
        if end > self.rows.len() {
            return false;
        }
        self.entries.push(Entry { kind, index, end });
        true
    }

    /// Rows no observation holds: none once every observation is pushed.
    pub fn unclaimed_rows(&self) -> usize {
        self.rows.len() - self.entries.last().map_or(0, |e| e.end)
    }

    /// The number of observations.
    pub fn len(&self) -> usize {
        self.entries.len()
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.entries.is_empty()
    }

    /// Observation `k`.
    pub fn get(&self, k: usize) -> Option<ObservationRecord<'_>> {
        (k < self.len()).then(|| self.record(k))
    }

    /// Observation `k`, one of them.
    fn record(&self, k: usize) -> ObservationRecord<'_> {
        let entry = &self.entries[k];
        let start = k.checked_sub(1).map_or(0, |j| self.entries[j].end);
        ObservationRecord {
            kind: &entry.kind,
            index: entry.index,
            rows: &self.rows[start..entry.end],
        }
    }

    /// The observations in order.
    pub fn iter(&self) -> impl Iterator<Item = ObservationRecord<'_>> + '_ {
        let starts = std::iter::once(0).chain(self.entries.iter().map(|e| e.end));
        (self.entries.iter().zip(starts)).map(|(entry, start)| ObservationRecord {
            kind: &entry.kind,
            index: entry.index,
            rows: &self.rows[start..entry.end],
        })
    }
}

/// A column of one field of some rows, written as a list.
struct Column<'a, T>(&'a [RowCheck], fn(&RowCheck) -> T);

impl<T: Serialize> Serialize for Column<'_, T> {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        serializer.collect_seq(self.0.iter().map(self.1))
    }
}

impl Serialize for ObservationRecord<'_> {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        let mut s = serializer.serialize_struct("ObservationRecord", 5)?;
        s.serialize_field("kind", self.kind)?;
        s.serialize_field("index", &self.index)?;
        s.serialize_field("residuals", &Column(self.rows, |r| r.residual))?;
        s.serialize_field("redundancy", &Column(self.rows, |r| r.redundancy))?;
        s.serialize_field("normalised", &Column(self.rows, |r| r.normalised))?;
        s.end()
    }
}

/// The observations formatted on the threads: JSON only (the record's
/// format).
impl Serialize for ObservationRecords {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        json::serialize_seq_on_threads(serializer, self.len(), |k| self.record(k))
    }
}

/// One observation as the format lists it, read.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct OwnedRecord {
    kind: String,
    index: usize,
    residuals: Vec<f32>,
    redundancy: Vec<f32>,
    normalised: Vec<Option<f32>>,
}

impl<'de> Deserialize<'de> for ObservationRecords {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        struct Records;
        impl<'de> Visitor<'de> for Records {
            type Value = ObservationRecords;

            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("a list of observations")
            }

            fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Self::Value, A::Error> {
                let mut records = ObservationRecords::default();
                while let Some(r) = seq.next_element::<OwnedRecord>()? {
                    let rows = r.residuals.len();
                    if r.redundancy.len() != rows || r.normalised.len() != rows {
                        return Err(de::Error::custom(format!(
                            "observation {}: its residuals, redundancy and normalised lists differ in length ({rows}, {}, {})",
                            records.len(),
                            r.redundancy.len(),
                            r.normalised.len()
                        )));
                    }
                    let each = r.residuals.iter().zip(&r.redundancy).zip(&r.normalised);
                    records
                        .rows
                        .extend(
                            each.map(|((&residual, &redundancy), &normalised)| RowCheck {
                                residual,
                                redundancy,
                                normalised,
                            }),
                        );
                    records.push(Cow::Owned(r.kind), r.index, rows);
                }
                Ok(records)
            }
        }
        deserializer.deserialize_seq(Records)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(residual: f32, redundancy: f32, normalised: Option<f32>) -> RowCheck {
        RowCheck {
            residual,
            redundancy,
            normalised,
        }
    }

    fn two() -> ObservationRecords {
        let rows = vec![
            row(0.5, 0.25, Some(1.0)),
            row(-0.1, 0.5, None),
            row(0.2, 0.04, Some(-5.0)),
            row(1.5, 0.9, Some(1.58)),
        ];
        let mut records = ObservationRecords::of_rows(rows);
        assert!(records.push(Cow::Borrowed("ball touch"), 7, 3));
        assert!(
            !records.push(Cow::Borrowed("probe height"), 2, 2),
            "one row left"
        );
        assert!(records.push(Cow::Borrowed("probe height"), 2, 1));
        assert_eq!(records.unclaimed_rows(), 0);
        records
    }

    /// The format's objects, one per observation, each with its rows'
    /// lists; read back the same.
    #[test]
    fn records_are_written_as_one_object_per_observation_and_read_back() {
        let records = two();
        let json = serde_json::to_string(&records).unwrap();
        assert_eq!(
            json,
            r#"[{"kind":"ball touch","index":7,"residuals":[0.5,-0.1,0.2],"redundancy":[0.25,0.5,0.04],"normalised":[1.0,null,-5.0]},{"kind":"probe height","index":2,"residuals":[1.5],"redundancy":[0.9],"normalised":[1.58]}]"#
        );
        let read: ObservationRecords = serde_json::from_str(&json).unwrap();
        assert_eq!(read, records.clone());
        let touch = read.get(0).unwrap();
        assert_eq!(
            (touch.kind, touch.index, touch.rows.len()),
            ("ball touch", 7, 3)
        );
        assert_eq!(touch.worst(), Some((2, -5.0)));
        assert_eq!(read.iter().map(|r| r.index).collect::<Vec<_>>(), [7, 2]);
        assert!(read.get(2).is_none());
    }

    #[test]
    fn lists_of_different_lengths_are_refused() {
        let json = r#"[{"kind":"probe height","index":0,"residuals":[1.0,2.0],"redundancy":[0.5],"normalised":[1.0,2.0]}]"#;
        let error = serde_json::from_str::<ObservationRecords>(json)
            .unwrap_err()
            .to_string();
        assert!(
            error.contains("observation 0") && error.contains("(2, 1, 2)"),
            "{error}"
        );
        let unknown = r#"[{"kind":"probe height","index":0,"residuals":[],"redundancy":[],"normalised":[],"w":1}]"#;
        assert!(serde_json::from_str::<ObservationRecords>(unknown).is_err());
    }
}
