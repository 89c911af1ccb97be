//! Every observation's residuals and tests in a mechanism calibration's
//! record: held as two columns, the observations and their rows (no
//! allocation per observation: a hexapod's calibration has 10^6 touches),
//! and written as the format's list of runs: observations of one kind at
//! consecutive indices, each of the same number of rows,
//!
//! ```json
//! {"kind": "ball touch", "index": 0, "count": 64, "residuals": [...], "redundancy": [...]}
//! ```
//!
//! the run's `count` observations (1 when absent) from `index` on, each
//! list holding their rows observation by observation, `len / count` rows
//! each. A run holds at most [`RUN_CAP`] observations, and an observation
//! without rows is a run of its own. Records of version 1.0 list each
//! row's normalised residual too (`"normalised": [...]`): that list is
//! read past, its length checked, since the residuals and redundancy
//! numbers give it ([`RowCheck::normalised`]).

use std::borrow::Cow;
use std::fmt;

use serde::de::{self, SeqAccess, Visitor};
use serde::ser::SerializeStruct;
use serde::{Deserialize, Deserializer, Serialize, Serializer};

use crate::json;

/// The largest redundancy number of a row that no other row checks: its
/// normalised residual is not formed. The solver's threshold
/// (`parcal_solver::MIN_REDUNDANCY`; the calibration's tests assert that
/// the two agree).
pub const UNCHECKED_REDUNDANCY: f64 = 1e-10;

/// One row's test: its whitened residual and its redundancy number, in
/// single precision (8 bytes a row), as the hexapod's own checks keep
/// theirs: their rounding, a relative 6e-8, is far below what they are
/// read for (a normalised residual against a critical value near 4, a
/// redundancy number against 0.1). Written as the shortest decimals that
/// read back as the same single-precision numbers (within a relative
/// 1.2e-7 of the values before rounding). Its normalised residual follows
/// from the two ([`RowCheck::normalised`]), and is not kept.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct RowCheck {
    /// The whitened residual `e_j / σ_j`.
    pub residual: f32,
    /// The redundancy number `r_j`.
    pub redundancy: f32,
}

impl RowCheck {
    /// The normalised residual `w_j = e_j / √r_j` of its residual and
    /// redundancy number as kept; `None` for a row no other row checks
    /// (`r_j` at most [`UNCHECKED_REDUNDANCY`]).
    pub fn normalised(&self) -> Option<f64> {
        let redundancy = f64::from(self.redundancy);
        (redundancy > UNCHECKED_REDUNDANCY).then(|| f64::from(self.residual) / redundancy.sqrt())
    }
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
        .filter_map(|(j, row)| row.normalised().map(|w| (j, w)))
        .max_by(|a, b| a.1.abs().total_cmp(&b.1.abs()))
}

/// An observation of [`ObservationRecords`]: its kind (its place among
/// the kinds), its index and where its rows end.
#[derive(Debug, Clone, PartialEq)]
struct Entry {
    kind: usize,
    index: usize,
    end: usize,
}

/// Every observation's residuals and tests, in order (module doc).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ObservationRecords {
    /// The kinds present, each once (a few: one name per kind, not per
    /// observation).
    kinds: Vec<Cow<'static, str>>,
    entries: Vec<Entry>,
    rows: Vec<RowCheck>,
}

impl ObservationRecords {
    /// Records of the observations whose rows, in order, are `rows`: none
    /// yet ([`ObservationRecords::push`] takes them in turn).
    pub fn of_rows(rows: Vec<RowCheck>) -> Self {
        Self {
            kinds: Vec::new(),
            entries: Vec::new(),
            rows,
        }
    }

    /// The next observation, of kind `kind` and index `index`, holding the
    /// next `rows` rows; `false` (nothing added) when fewer are left.
    pub fn push(&mut self, kind: Cow<'static, str>, index: usize, rows: usize) -> bool {
        rows <= self.unclaimed_rows() && self.push_of_kind(kind, [(index, rows)])
    }

    /// The next observations, all of kind `kind`, each given by its index
    /// and its number of rows, as [`ObservationRecords::push`] takes them
    /// in turn (the kind looked up once); `false` at the first that has
    /// fewer rows left, which is not added, nor any after it.
    pub fn push_of_kind(
        &mut self,
        kind: Cow<'static, str>,
        observations: impl IntoIterator<Item = (usize, usize)>,
    ) -> bool {
        let kind = self.place_of(kind);
        for (index, rows) in observations {
            if rows > self.unclaimed_rows() {
                return false;
            }
            self.push_placed(kind, index, rows);
        }
        true
    }

    /// The place of `kind` among the kinds, added if new.
    fn place_of(&mut self, kind: Cow<'static, str>) -> usize {
        self.kinds
            .iter()
            .position(|k| *k == kind)
            .unwrap_or_else(|| {
                self.kinds.push(kind);
                self.kinds.len() - 1
            })
    }

    /// The next observation, of the kind at place `kind`, holding the next
    /// `rows` rows (as many are left).
    fn push_placed(&mut self, kind: usize, index: usize, rows: usize) {
        let end = self.rows_start(self.len()) + rows;
        debug_assert!(end <= self.rows.len(), "rows held by observations");
        self.entries.push(Entry { kind, index, end });
    }

    /// Rows no observation holds: none once every observation is pushed.
    pub fn unclaimed_rows(&self) -> usize {
        self.rows.len() - self.rows_start(self.len())
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
        ObservationRecord {
            kind: &self.kinds[entry.kind],
            index: entry.index,
            rows: &self.rows[self.rows_start(k)..entry.end],
        }
    }

    /// The observations in order.
    pub fn iter(&self) -> impl Iterator<Item = ObservationRecord<'_>> + '_ {
        let starts = std::iter::once(0).chain(self.entries.iter().map(|e| e.end));
        (self.entries.iter().zip(starts)).map(|(entry, start)| ObservationRecord {
            kind: &self.kinds[entry.kind],
            index: entry.index,
            rows: &self.rows[start..entry.end],
        })
    }
}

/// The most observations a run of the record holds: a run's text stays a
/// few kilobytes, and the runs of a wave are formatted side by side.
pub const RUN_CAP: usize = 64;

/// How many runs are formatted at once: as many observations as
/// `RUN_CAP` each hold.
const RUNS_A_WAVE: usize = 128;

/// A run of observations (module doc): `count` of kind `kind` from index
/// `index` on, their rows `rows`.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Run<'a> {
    kind: &'a str,
    index: usize,
    count: usize,
    rows: &'a [RowCheck],
}

impl ObservationRecords {
    /// Where observation `k`'s rows start (for `k` the number held, the
    /// next observation's).
    fn rows_start(&self, k: usize) -> usize {
        k.checked_sub(1).map_or(0, |j| self.entries[j].end)
    }

    /// Whether observation `k` follows observation `k - 1` in a run: of
    /// the same kind, at the next index, with as many rows (at least one).
    fn continues_run(&self, k: usize) -> bool {
        let (before, entry) = (&self.entries[k - 1], &self.entries[k]);
        let rows = entry.end - before.end;
        entry.kind == before.kind
            && before.index.checked_add(1) == Some(entry.index)
            && rows == before.end - self.rows_start(k - 1)
            && rows > 0
    }

    /// The observations in runs (module doc), in order: where each run's
    /// observations start.
    fn run_starts(&self) -> Vec<usize> {
        let mut starts = Vec::new();
        let mut run_start = 0;
        for k in 0..self.len() {
            let extends = k > run_start && k - run_start < RUN_CAP && self.continues_run(k);
            if !extends {
                starts.push(k);
                run_start = k;
            }
        }
        starts
    }

    /// The run of observations `first..end`.
    fn run(&self, first: usize, end: usize) -> Run<'_> {
        let entry = &self.entries[first];
        Run {
            kind: &self.kinds[entry.kind],
            index: entry.index,
            count: end - first,
            rows: &self.rows[self.rows_start(first)..self.entries[end - 1].end],
        }
    }
}

/// A column of one field of some rows, written as a list.
struct Column<'a, T>(&'a [RowCheck], fn(&RowCheck) -> T);

impl<T: Serialize> Serialize for Column<'_, T> {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        serializer.collect_seq(self.0.iter().map(self.1))
    }
}

impl Serialize for Run<'_> {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        let mut s = serializer.serialize_struct("Run", 5)?;
        s.serialize_field("kind", self.kind)?;
        s.serialize_field("index", &self.index)?;
        if self.count != 1 {
            s.serialize_field("count", &self.count)?;
        }
        s.serialize_field("residuals", &Column(self.rows, |r| r.residual))?;
        s.serialize_field("redundancy", &Column(self.rows, |r| r.redundancy))?;
        s.end()
    }
}

/// The observations in runs, formatted on the threads: JSON only (the
/// record's format).
impl Serialize for ObservationRecords {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        let starts = self.run_starts();
        let end = |j: usize| starts.get(j + 1).copied().unwrap_or(self.len());
        json::serialize_seq_on_threads(serializer, starts.len(), RUNS_A_WAVE, |j| {
            self.run(starts[j], end(j))
        })
    }
}

/// One run as the format lists it, read.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct OwnedRun {
    kind: String,
    index: usize,
    #[serde(default = "one")]
    count: usize,
    residuals: Vec<f32>,
    redundancy: Vec<f32>,
    /// Version 1.0's list of the rows' normalised residuals (module doc).
    #[serde(default)]
    normalised: Option<Vec<Option<f32>>>,
}

/// A run's count when the format leaves it out.
fn one() -> usize {
    1
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
                while let Some(r) = seq.next_element::<OwnedRun>()? {
                    let rows = r.residuals.len();
                    let refused = |why: String| {
                        de::Error::custom(format!("observation {}: {why}", records.len()))
                    };
                    let normalised = r.normalised.as_ref().map_or(rows, Vec::len);
                    if r.redundancy.len() != rows || normalised != rows {
                        return Err(refused(format!(
                            "its residuals, redundancy and normalised lists differ in length ({rows}, {}, {normalised})",
                            r.redundancy.len(),
                        )));
                    }
                    // At least a row each, but for an observation of its own:
                    // the runs a file holds are bounded by its numbers.
                    let fits = r.count == 1 || (r.count > 1 && rows % r.count == 0 && rows > 0);
                    if !fits || r.index.checked_add(r.count).is_none() {
                        return Err(refused(format!(
                            "a run of {} observations from index {} cannot share its {rows} rows",
                            r.count, r.index
                        )));
                    }
                    let each = r.residuals.iter().zip(&r.redundancy);
                    records
                        .rows
                        .extend(each.map(|(&residual, &redundancy)| RowCheck {
                            residual,
                            redundancy,
                        }));
                    let kind = records.place_of(Cow::Owned(r.kind));
                    for k in 0..r.count {
                        records.push_placed(kind, r.index + k, rows / r.count);
                    }
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

    fn row(residual: f32, redundancy: f32) -> RowCheck {
        RowCheck {
            residual,
            redundancy,
        }
    }

    fn two() -> ObservationRecords {
        let rows = vec![
            row(0.5, 0.25),
            row(-0.1, 0.0),
            row(-1.5, 0.5625),
            row(1.5, 0.9),
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

    /// A row's normalised residual is its residual over the root of its
    /// redundancy number, and none where that number is at most the
    /// threshold.
    #[test]
    fn a_rows_normalised_residual_follows_from_its_residual_and_redundancy() {
        assert_eq!(row(0.5, 0.25).normalised(), Some(1.0));
        assert_eq!(row(-1.5, 0.5625).normalised(), Some(-2.0));
        assert_eq!(row(0.2, 0.0).normalised(), None);
        assert_eq!(row(0.2, 1e-11).normalised(), None);
        let w = row(1e-5, 1e-9).normalised().unwrap();
        assert!((w - 1e-5 / 1e-9f64.sqrt()).abs() < 1e-6 * w, "{w}");
    }

    /// Observations of one kind pushed together are those pushed in turn;
    /// the first with fewer rows left ends them.
    #[test]
    fn observations_of_one_kind_pushed_together_are_those_pushed_in_turn() {
        let rows: Vec<RowCheck> = (0..7).map(|k| row(k as f32, 0.5)).collect();
        let mut in_turn = ObservationRecords::of_rows(rows.clone());
        assert!(in_turn.push(Cow::Borrowed("probe height"), 0, 1));
        for (index, count) in [(3, 2), (4, 3)] {
            assert!(in_turn.push(Cow::Borrowed("ball touch"), index, count));
        }
        let mut together = ObservationRecords::of_rows(rows);
        assert!(together.push_of_kind(Cow::Borrowed("probe height"), [(0, 1)]));
        let touches = [(3, 2), (4, 3), (5, 3), (6, 1)];
        assert!(!together.push_of_kind(Cow::Borrowed("ball touch"), touches));
        assert_eq!(together, in_turn);
        assert_eq!(together.unclaimed_rows(), 1);
    }

    /// The format's objects, one per observation, each with its rows'
    /// lists; read back the same.
    #[test]
    fn records_are_written_as_one_object_per_observation_and_read_back() {
        let records = two();
        let json = serde_json::to_string(&records).unwrap();
        assert_eq!(
            json,
            r#"[{"kind":"ball touch","index":7,"residuals":[0.5,-0.1,-1.5],"redundancy":[0.25,0.0,0.5625]},{"kind":"probe height","index":2,"residuals":[1.5],"redundancy":[0.9]}]"#
        );
        let read: ObservationRecords = serde_json::from_str(&json).unwrap();
        assert_eq!(read, records.clone());
        let touch = read.get(0).unwrap();
        assert_eq!(
            (touch.kind, touch.index, touch.rows.len()),
            ("ball touch", 7, 3)
        );
        assert_eq!(touch.worst(), Some((2, -2.0)));
        assert_eq!(read.iter().map(|r| r.index).collect::<Vec<_>>(), [7, 2]);
        assert!(read.get(2).is_none());
    }

    /// A record of version 1.0, which lists the rows' normalised residuals
    /// too, reads as the same rows.
    #[test]
    fn the_normalised_lists_of_version_1_0_are_read_past() {
        let old = r#"[{"kind":"ball touch","index":7,"residuals":[0.5,-0.1,-1.5],"redundancy":[0.25,0.0,0.5625],"normalised":[1.0,null,-2.0]},{"kind":"probe height","index":2,"residuals":[1.5],"redundancy":[0.9],"normalised":[1.58]}]"#;
        let read: ObservationRecords = serde_json::from_str(old).unwrap();
        assert_eq!(read, two());
    }

    /// Observations of one kind at consecutive indices with as many rows
    /// are written as runs of at most [`RUN_CAP`]; a change of kind, an
    /// index skipped, another number of rows or none start a new run. Read
    /// back, they are the same observations; written again, the same text.
    #[test]
    fn observations_in_sequence_are_written_as_runs_and_read_back() {
        let touches = RUN_CAP + 3;
        let mut rows = Vec::new();
        let mut layout: Vec<(&'static str, usize, usize)> = Vec::new();
        for k in 0..touches {
            layout.push(("ball touch", k, 3));
        }
        layout.extend([
            ("ball touch", touches + 1, 3),
            ("ball touch", touches + 2, 2),
            ("probe height", touches + 3, 1),
            ("probe height", touches + 4, 0),
            ("probe height", touches + 5, 0),
            ("probe height", touches + 6, 1),
        ]);
        for (j, &(_, _, n)) in layout.iter().enumerate() {
            for i in 0..n {
                let x = (j * 3 + i) as f32;
                rows.push(row(x / 8.0, x / 64.0));
            }
        }
        let mut records = ObservationRecords::of_rows(rows);
        for &(kind, index, n) in &layout {
            assert!(records.push(Cow::Borrowed(kind), index, n));
        }
        let json = serde_json::to_string(&records).unwrap();
        let runs: Vec<serde_json::Value> = serde_json::from_str(&json).unwrap();
        let shape: Vec<(String, u64, u64, usize)> = runs
            .iter()
            .map(|r| {
                (
                    r["kind"].as_str().unwrap().to_string(),
                    r["index"].as_u64().unwrap(),
                    r.get("count").map_or(1, |c| c.as_u64().unwrap()),
                    r["residuals"].as_array().unwrap().len(),
                )
            })
            .collect();
        let touch = |index: usize, count: usize, rows: usize| {
            ("ball touch".to_string(), index as u64, count as u64, rows)
        };
        let probe = |index: usize, rows: usize| ("probe height".to_string(), index as u64, 1, rows);
        assert_eq!(
            shape,
            [
                touch(0, RUN_CAP, 3 * RUN_CAP),
                touch(RUN_CAP, 3, 9),
                touch(touches + 1, 1, 3),
                touch(touches + 2, 1, 2),
                probe(touches + 3, 1),
                probe(touches + 4, 0),
                probe(touches + 5, 0),
                probe(touches + 6, 1),
            ]
        );
        assert!(runs[2].get("count").is_none(), "a run of one has no count");
        let read: ObservationRecords = serde_json::from_str(&json).unwrap();
        assert_eq!(read, records);
        assert_eq!(serde_json::to_string(&read).unwrap(), json);
    }

    /// A run whose count its rows cannot share, a count of none, a run of
    /// observations without rows (which a file could make of any size)
    /// and indices past the largest are refused, naming the observation.
    #[test]
    fn runs_that_cannot_share_their_rows_are_refused() {
        let run = |count: &str, index: &str, rows: &str| {
            format!(
                r#"[{{"kind":"probe height","index":0,"residuals":[1.0],"redundancy":[0.5],"normalised":[1.0]}},{{"kind":"ball touch","index":{index},"count":{count},"residuals":{rows},"redundancy":{rows},"normalised":{rows}}}]"#
            )
        };
        for (count, index, rows) in [
            ("2", "0", "[1.0,2.0,3.0]"),
            ("0", "0", "[]"),
            ("0", "0", "[1.0]"),
            ("1000000000000", "0", "[]"),
            ("2", &usize::MAX.to_string(), "[1.0,2.0]"),
        ] {
            let error = serde_json::from_str::<ObservationRecords>(&run(count, index, rows))
                .unwrap_err()
                .to_string();
            assert!(
                error.contains("observation 1:") && error.contains("cannot share"),
                "{count} {index} {rows}: {error}"
            );
        }
        let fine = run("2", "5", "[1.0,2.0,3.0,4.0]");
        let read: ObservationRecords = serde_json::from_str(&fine).unwrap();
        let indices: Vec<_> = read.iter().map(|r| (r.index, r.rows.len())).collect();
        assert_eq!(indices, [(0, 1), (5, 2), (6, 2)]);
    }

    #[test]
    fn lists_of_different_lengths_are_refused() {
        for (json, lengths) in [
            (
                r#"[{"kind":"probe height","index":0,"residuals":[1.0,2.0],"redundancy":[0.5]}]"#,
                "(2, 1, 2)",
            ),
            (
                r#"[{"kind":"probe height","index":0,"residuals":[1.0,2.0],"redundancy":[0.5,0.5],"normalised":[1.0]}]"#,
                "(2, 2, 1)",
            ),
        ] {
            let error = serde_json::from_str::<ObservationRecords>(json)
                .unwrap_err()
                .to_string();
            assert!(
                error.contains("observation 0") && error.contains(lengths),
                "{error}"
            );
        }
        let unknown = r#"[{"kind":"probe height","index":0,"residuals":[],"redundancy":[],"normalised":[],"w":1}]"#;
        assert!(serde_json::from_str::<ObservationRecords>(unknown).is_err());
    }
}
