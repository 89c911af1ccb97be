//! A mechanism calibration's validation on held-out data in words:
//! validation.json's record ([`validation_record`]), with the verdict's
//! reasons naming each failing row by its file and line (a ball's rows by
//! the ball's line in balls.csv and its touches' lines in touches.csv; a
//! hexapod's, whose data are a hexapod dataset, by the ball's index in
//! artefacts.json and its touches' lines in measurements.csv), and the
//! summary `parcal validate` prints ([`summary`]).

use std::fmt::Write;

use parcal_calibrate::mechanism::{
    HeldOut, MechanismCalibrationError, MechanismValidation, ObservationKind, ObservationRef,
    ValidatedRow, number_ranges,
};
use parcal_calibrate::verdict::Outcome;
use parcal_dataset::mechanism::{
    BALL_DISTANCES_FILE, BALLS_FILE, DISTANCES_FILE, HEIGHTS_FILE, KindRecord,
    MechanismValidationRecord, POINTS_FILE, PROBES_FILE, QUANTITIES_FILE, RowRecord, ShiftRecord,
    TOUCHES_FILE, TRACKER_POINTS_FILE,
};
use parcal_dataset::{
    ARTEFACTS_FILE, HEXAPOD, MEASUREMENTS_FILE, POINTS_FILE as HEXAPOD_POINTS_FILE,
    POSES_FILE as HEXAPOD_POSES_FILE,
};

use crate::instruments::{mirrored_sentence, test_record, test_statement};

/// The failing rows the reasons name one by one (the others counted).
const NAMED_ROWS: usize = 10;

/// validation.json's record of `validation`, a validation of the
/// calibration file `calibration`.
pub fn validation_record(
    validation: &MechanismValidation,
    calibration: String,
) -> MechanismValidationRecord {
    let files = Files::of(&validation.mechanism);
    let rows: Vec<RowRecord> = validation
        .rows
        .iter()
        .map(|row| row_record(files, row))
        .collect();
    let accepted = validation.accepted();
    let mut record = MechanismValidationRecord {
        mechanism: validation.mechanism.clone(),
        calibration,
        verdict: if accepted { "accepted" } else { "rejected" }.to_string(),
        reasons: Vec::new(),
        test: validation.test.as_ref().map(test_record),
        alpha: validation.alpha,
        critical_value: validation.critical_value,
        kinds: kinds(&rows),
        untested: validation.untested,
        reference: validation.reference,
        mirrored_balls: validation.mirrored_balls.clone(),
        shifts: validation
            .shifts
            .iter()
            .map(|s| ShiftRecord {
                name: s.name.clone(),
                unit: s.unit.clone(),
                shift: s.shift,
                sigma: s.sigma,
                test: s.test.as_ref().map(test_record),
            })
            .collect(),
        rows,
    };
    record.reasons = reasons(validation, &record);
    record
}

/// The files a mechanism's observations are read from: a mechanism
/// dataset's, or a hexapod dataset's (a hexapod's only door to the common
/// calibration: its ball touches in measurements.csv, its balls in
/// artefacts.json).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Files {
    Mechanism,
    Hexapod,
}

impl Files {
    /// Those of the mechanism named `mechanism`.
    fn of(mechanism: &str) -> Self {
        if mechanism == HEXAPOD {
            Self::Hexapod
        } else {
            Self::Mechanism
        }
    }

    /// The file of an observation of `kind`, if it is read from one, and
    /// whether an observation is its line there (a CSV row, after the
    /// header) rather than its index (in JSON).
    fn of_kind(self, kind: ObservationKind) -> Option<(&'static str, bool)> {
        let file = match kind {
            ObservationKind::Probe => PROBES_FILE,
            ObservationKind::ManualHeight => HEIGHTS_FILE,
            ObservationKind::Distance => DISTANCES_FILE,
            ObservationKind::Sample => POINTS_FILE,
            ObservationKind::Quantity => QUANTITIES_FILE,
            ObservationKind::Touch => self.touches(),
            ObservationKind::BallDistance => return Some(self.ball_distances()),
            ObservationKind::TrackerPoint => self.tracker_points(),
            ObservationKind::TrackerPose => match self {
                Self::Hexapod => HEXAPOD_POSES_FILE,
                Self::Mechanism => return None,
            },
            ObservationKind::Point => return None,
        };
        Some((file, true))
    }

    /// The balls' file, and whether a ball is its line there (a CSV row,
    /// after the header) rather than its index (in JSON).
    fn balls(self) -> (&'static str, bool) {
        match self {
            Self::Mechanism => (BALLS_FILE, true),
            Self::Hexapod => (ARTEFACTS_FILE, false),
        }
    }

    /// The trackers' points' file (a CSV: a point is its line there).
    fn tracker_points(self) -> &'static str {
        match self {
            Self::Mechanism => TRACKER_POINTS_FILE,
            Self::Hexapod => HEXAPOD_POINTS_FILE,
        }
    }

    /// The ball distances' file, and whether a distance is its line
    /// there rather than its index.
    fn ball_distances(self) -> (&'static str, bool) {
        match self {
            Self::Mechanism => (BALL_DISTANCES_FILE, true),
            Self::Hexapod => (ARTEFACTS_FILE, false),
        }
    }

    /// The touches' file.
    fn touches(self) -> &'static str {
        match self {
            Self::Mechanism => TOUCHES_FILE,
            Self::Hexapod => MEASUREMENTS_FILE,
        }
    }
}

/// An observation of the mechanism named `mechanism` by its file and line
/// (the header is line 1), and its kind and index: `probes.csv line 5
/// (probe height 3)`, a hexapod's `measurements.csv line 9 (ball touch
/// 7)`; in a JSON file, by its file alone: a hexapod's `artefacts.json
/// (ball distance 2)`.
pub fn observation_place(mechanism: &str, observation: ObservationRef) -> String {
    match Files::of(mechanism).of_kind(observation.kind) {
        Some((file, true)) => format!("{file} line {} ({observation})", observation.index + 2),
        Some((file, false)) => format!("{file} ({observation})"),
        None => observation.to_string(),
    }
}

/// An observation of the mechanism named `mechanism` by its file and line
/// as [`observation_place`], with the row of it a test names: `probes.csv
/// line 5 (probe height 3, row 0)`; the calibration's own naming when it
/// is read from no file: `measured point 2 (row 1)`.
pub fn observation_row_place(
    mechanism: &str,
    observation: ObservationRef,
    row: Option<usize>,
) -> String {
    let Some(row) = row else {
        return observation_place(mechanism, observation);
    };
    match Files::of(mechanism).of_kind(observation.kind) {
        Some((file, true)) => format!(
            "{file} line {} ({observation}, row {row})",
            observation.index + 2
        ),
        Some((file, false)) => format!("{file} ({observation}, row {row})"),
        None => format!("{observation} (row {row})"),
    }
}

/// What went wrong with a calibration of the mechanism named `mechanism`,
/// an observation's failure placed by its file and line
/// ([`observation_place`]): `probes.csv line 5 (probe height 3):
/// unreachable: ...`.
pub fn placed_error(mechanism: &str, error: &MechanismCalibrationError) -> String {
    match error {
        MechanismCalibrationError::Observation {
            observation,
            reason,
        } => format!("{}: {reason}", observation_place(mechanism, *observation)),
        other => other.to_string(),
    }
}

/// A row's record, its observation placed by its file and line (a
/// ball's rows by the ball's: its line in balls.csv, or its index in a
/// hexapod's artefacts.json).
fn row_record(files: Files, row: &ValidatedRow) -> RowRecord {
    let (file, line, index) = match &row.observation {
        HeldOut::Observation(observation) => {
            let source = files.of_kind(observation.kind);
            let line = source.and_then(|(_, by_line)| by_line.then_some(observation.index + 2));
            (source.map(|(file, _)| file), line, observation.index)
        }
        HeldOut::Ball { ball, .. } => {
            let (file, by_line) = files.balls();
            (Some(file), by_line.then_some(ball + 2), *ball)
        }
        // Rows of several points or balls together: no one line; a
        // tracker's in its points' file, or its poses' without points.
        HeldOut::Tracker {
            tracker, points, ..
        } => {
            let poses = files
                .of_kind(ObservationKind::TrackerPose)
                .map(|(file, _)| file);
            let file = match points.is_empty() {
                true => poses,
                false => Some(files.tracker_points()),
            };
            (file, None, *tracker)
        }
        HeldOut::TiedBalls { balls, .. } => (Some(files.balls().0), None, balls[0]),
    };
    RowRecord {
        file: file.map(str::to_string),
        line,
        kind: row.observation.name().to_string(),
        index,
        row: row.row,
        unit: row.unit.clone(),
        residual: row.residual,
        sigma: row.sigma,
        w: row.w,
    }
}

/// Each kind's (and unit's) residual RMS, predicted RMS and largest
/// residual, in the order the kinds first appear.
fn kinds(rows: &[RowRecord]) -> Vec<KindRecord> {
    let mut kinds: Vec<(String, String, Vec<&RowRecord>)> = Vec::new();
    for row in rows {
        match kinds
            .iter_mut()
            .find(|(kind, unit, _)| *kind == row.kind && *unit == row.unit)
        {
            Some((_, _, members)) => members.push(row),
            None => kinds.push((row.kind.clone(), row.unit.clone(), vec![row])),
        }
    }
    let rms = |values: &mut dyn Iterator<Item = f64>, n: usize| {
        (values.map(|v| v * v).sum::<f64>() / n as f64).sqrt()
    };
    kinds
        .into_iter()
        .map(|(kind, unit, members)| KindRecord {
            kind,
            unit,
            rows: members.len(),
            rms: rms(&mut members.iter().map(|r| r.residual), members.len()),
            predicted_rms: rms(&mut members.iter().map(|r| r.sigma), members.len()),
            max: members.iter().fold(0.0, |m, r| m.max(r.residual.abs())),
        })
        .collect()
}

/// A row by its file and line, else by its observation; a ball's by its
/// line (or index) and its touches' lines: `balls.csv line 3 (ball 1,
/// touched at touches.csv lines 9-15, row 0)`.
fn place(files: Files, row: &ValidatedRow) -> String {
    match &row.observation {
        HeldOut::Observation(observation) => match files.of_kind(observation.kind) {
            Some((file, true)) => format!(
                "{file} line {} ({observation}, row {})",
                observation.index + 2,
                row.row
            ),
            Some((file, false)) => format!("{file} ({observation}, row {})", row.row),
            None => format!("{observation}, row {}", row.row),
        },
        HeldOut::Ball { ball, touches } => {
            let (file, by_line) = files.balls();
            let at = if by_line {
                format!("{file} line {}", ball + 2)
            } else {
                format!("{file} ball {ball}")
            };
            format!(
                "{at} (ball {ball}, touched at {} lines {}, row {})",
                files.touches(),
                number_ranges(touches.iter().map(|t| t + 2)),
                row.row
            )
        }
        HeldOut::Tracker {
            tracker,
            points,
            poses,
        } => {
            let poses_file = files
                .of_kind(ObservationKind::TrackerPose)
                .map(|(file, _)| file);
            let listed = [(Some(files.tracker_points()), points), (poses_file, poses)]
                .into_iter()
                .filter(|(_, indices)| !indices.is_empty())
                .map(|(file, indices)| {
                    let lines = number_ranges(indices.iter().map(|j| j + 2));
                    match file {
                        Some(file) => format!("{file} lines {lines}"),
                        None => format!("tracker poses {}", number_ranges(indices.iter().copied())),
                    }
                })
                .collect::<Vec<_>>();
            format!(
                "{} (tracker {tracker}, row {})",
                listed.join(" and "),
                row.row
            )
        }
        HeldOut::TiedBalls {
            balls,
            touches,
            distances,
        } => {
            // CSV rows by their lines, JSON entries by their indices.
            let listed = |(file, by_line): (&str, bool), what: &str, indices: &[usize]| {
                let offset = if by_line { 2 } else { 0 };
                let numbers = number_ranges(indices.iter().map(|i| i + offset));
                match by_line {
                    true => format!("{file} lines {numbers}"),
                    false => format!("{file} {what} {numbers}"),
                }
            };
            format!(
                "{} (touched at {}, tied by {}, row {})",
                listed(files.balls(), "balls", balls),
                listed((files.touches(), true), "touches", touches),
                listed(files.ball_distances(), "distances", distances),
                row.row
            )
        }
    }
}

/// The verdict's reasons: the prediction test, the w-tests, what change
/// would explain a rejection, the samples not tested, the verdict.
fn reasons(validation: &MechanismValidation, record: &MechanismValidationRecord) -> Vec<String> {
    let files = Files::of(&validation.mechanism);
    let mut reasons = Vec::new();
    if let Some(test) = &validation.test {
        let statement = test_statement(test);
        reasons.push(match test.outcome {
            Outcome::Consistent => format!(
                "prediction test passed: the residuals are as large as the calibration predicts: {statement}"
            ),
            Outcome::TooLarge => format!(
                "prediction test failed: the residuals are larger than the calibration predicts: {statement}"
            ),
            Outcome::TooSmall => format!(
                "prediction test: the residuals are smaller than predicted: {statement}: the calibration's covariance or the stated noise is pessimistic"
            ),
        });
    }
    let critical = record.critical_value;
    let family = format!(
        "family-wise level {} over {} rows",
        record.alpha,
        record.rows.len()
    );
    let failing: Vec<&ValidatedRow> = validation.failing_rows().collect();
    for row in failing.iter().take(NAMED_ROWS) {
        reasons.push(format!(
            "{} fails its w-test: |w| = {:.2} > {critical:.2} ({family}): residual {:+.4} {} against a predicted sigma of {:.4}",
            place(files, row),
            row.w.abs(),
            row.residual,
            row.unit,
            row.sigma
        ));
    }
    if failing.len() > NAMED_ROWS {
        reasons.push(format!(
            "{} more rows fail their w-tests (validation.json lists every row)",
            failing.len() - NAMED_ROWS
        ));
    }
    if let (true, Some(worst)) = (failing.is_empty(), validation.worst()) {
        reasons.push(format!(
            "every w-test passes: the largest, {}, |w| = {:.2} <= {critical:.2} ({family})",
            place(files, worst),
            worst.w.abs()
        ));
    }
    if let (false, Some(best)) = (validation.accepted(), record.shifts.first()) {
        let change = format!(
            "{} by {:+.4} +- {:.4} {}",
            best.name, best.shift, best.sigma, best.unit
        );
        reasons.push(match &best.test {
            Some(t) if t.outcome != "too large" => format!(
                "a change of {change} alone explains the residuals ((T/n) / s₀² would be {:.3}, within [{:.3}, {:.3}]): the machine may have changed since the calibration; re-calibrate on data of the machine as it is",
                t.ratio, t.interval[0], t.interval[1]
            ),
            _ => format!(
                "no change of one unknown explains the residuals (the best, {change}, leaves them too large): the data or their stated noise are in question, or the machine changed in more than one way"
            ),
        });
    }
    if let Some(n) = record.reference {
        let rows_of = |kinds: [ObservationKind; 2]| {
            validation.rows.iter().any(|row| {
                matches!(&row.observation, HeldOut::Observation(o) if kinds.contains(&o.kind))
            })
        };
        let balls = rows_of([ObservationKind::Touch, ObservationKind::BallDistance])
            .then(|| format!("each ball's centre located by its first {n} touches"));
        let trackers = rows_of([ObservationKind::TrackerPoint, ObservationKind::TrackerPose])
            .then(|| format!("each tracker's frame located by its first {n} points and poses"));
        let located: Vec<String> = balls.into_iter().chain(trackers).collect();
        if !located.is_empty() {
            reasons.push(format!("{}, the others predicted", located.join(" and ")));
        }
        if !validation.mirrored_balls.is_empty() {
            let (file, by_line) = files.balls();
            let names: Vec<String> = validation
                .mirrored_balls
                .iter()
                .map(|b| match by_line {
                    true => format!("{b} ({file} line {})", b + 2),
                    false => format!("{b} (in {file})"),
                })
                .collect();
            reasons.push(mirrored_sentence(&names, n));
        }
    }
    if record.untested > 0 {
        reasons.push(format!(
            "{} point samples at unknown positions gave no row: the {}'s readings only locate their own pose",
            record.untested, record.mechanism
        ));
    }
    reasons.push(record.verdict.clone());
    reasons
}

/// A validation in a few lines: its verdict and reasons, what was
/// applied, each kind's residuals observed and predicted, the changes
/// that best explain them.
pub fn summary(record: &MechanismValidationRecord) -> String {
    let mut out = String::new();
    let _ = writeln!(out, "verdict: {}", record.verdict);
    for reason in &record.reasons {
        let _ = writeln!(out, "  - {reason}");
    }
    let _ = writeln!(
        out,
        "applied: {} (a {})",
        record.calibration, record.mechanism
    );
    for kind in &record.kinds {
        let _ = writeln!(
            out,
            "predicted {} {} rows: residual RMS {:.4} {unit}, max {:.4} {unit}; the calibration predicts RMS {:.4} {unit}",
            kind.rows,
            kind.kind,
            kind.rms,
            kind.max,
            kind.predicted_rms,
            unit = kind.unit
        );
    }
    let shifts = if record.is_rejected() {
        record.shifts.as_slice()
    } else {
        &[]
    };
    for shift in shifts {
        let _ = writeln!(
            out,
            "  change of {} alone: {:+.4} +- {:.4} {}{}",
            shift.name,
            shift.shift,
            shift.sigma,
            shift.unit,
            shift.test.as_ref().map_or(String::new(), |t| format!(
                ", then (T/n) / s₀² = {:.3}",
                t.ratio
            ))
        );
    }
    out
}
