//! A mechanism calibration's validation on held-out data
//! (`validation.json`, format `parcal-mechanism-validation/1`): the
//! verdict and its reasons, the prediction test, each observation kind's
//! residuals against their prediction, every row's w-test naming its file
//! and line, and the single changes of the machine that best explain the
//! residuals.

use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::check::Check;
use crate::error::Result;
use crate::json;
use crate::validation::PredictionTestRecord;

/// One predicted row and its w-test.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RowRecord {
    /// The file of its observation (`probes.csv`), if it came from one.
    pub file: Option<String>,
    /// Its line there (the header is line 1); none in a JSON file (a
    /// hexapod's ball in artefacts.json, by [`RowRecord::index`]).
    pub line: Option<usize>,
    /// Its observation's kind (`probe height`).
    pub kind: String,
    /// The observation's 0-based index among those of its kind.
    pub index: usize,
    /// The row within the observation (`x`, `y`, `z` of a position: 0-2).
    pub row: usize,
    /// The residual's unit.
    pub unit: String,
    /// The residual: prediction less measurement.
    pub residual: f64,
    /// Its predicted standard deviation (noise and the calibration's
    /// covariance).
    pub sigma: f64,
    /// `residual / sigma`, its w-test statistic.
    pub w: f64,
}

/// The residuals of one observation kind.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct KindRecord {
    /// The kind.
    pub kind: String,
    /// Its unit.
    pub unit: String,
    /// Its predicted rows.
    pub rows: usize,
    /// Their residuals' RMS.
    pub rms: f64,
    /// The RMS the calibration predicts.
    pub predicted_rms: f64,
    /// The largest absolute residual.
    pub max: f64,
}

/// A change of one unknown that would explain the residuals.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ShiftRecord {
    /// The unknown.
    pub name: String,
    /// Its unit.
    pub unit: String,
    /// The change.
    pub shift: f64,
    /// Its standard deviation.
    pub sigma: f64,
    /// The prediction test with it applied.
    pub test: Option<PredictionTestRecord>,
}

/// A mechanism validation's record (module doc).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MechanismValidationRecord {
    /// The mechanism.
    pub mechanism: String,
    /// The calibration file applied.
    pub calibration: String,
    /// `"accepted"` or `"rejected"`.
    pub verdict: String,
    /// Why, one sentence each.
    pub reasons: Vec<String>,
    /// The prediction test of all rows.
    pub test: Option<PredictionTestRecord>,
    /// The w-tests' family-wise level.
    pub alpha: f64,
    /// Their critical value of `|w|`.
    pub critical_value: f64,
    /// Each observation kind's residuals.
    pub kinds: Vec<KindRecord>,
    /// Point samples that gave no row (as many actuators as pose
    /// coordinates and no measured position).
    pub untested: usize,
    /// The reference observations `N`: each ball's centre located by its
    /// first `N` touches and each tracker's frame by its first `N` points
    /// and poses, the others predicted (absent: each projected out of all
    /// its rows).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reference: Option<usize>,
    /// The held-out balls (their indices) whose reference touches fit
    /// their centre and its mirror image through their plane about as
    /// well, located at the mirror image, which all their touches fit.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub mirrored_balls: Vec<usize>,
    /// The single changes that best explain the residuals, the best
    /// first.
    pub shifts: Vec<ShiftRecord>,
    /// Every predicted row.
    pub rows: Vec<RowRecord>,
}

impl MechanismValidationRecord {
    /// Whether the verdict is `"rejected"`.
    pub fn is_rejected(&self) -> bool {
        self.verdict == "rejected"
    }

    /// Checks every number and writes `validation.json` atomically.
    pub fn write(&self, path: &Path) -> Result<()> {
        let check = Check::result(path);
        check.finite("critical_value", self.critical_value)?;
        for (k, kind) in self.kinds.iter().enumerate() {
            check.values(
                format!("kinds[{k}]"),
                &[kind.rms, kind.predicted_rms, kind.max],
            )?;
        }
        for (k, row) in self.rows.iter().enumerate() {
            check.values(format_args!("rows[{k}]"), &[row.residual, row.sigma, row.w])?;
        }
        for (k, shift) in self.shifts.iter().enumerate() {
            check.values(format!("shifts[{k}]"), &[shift.shift, shift.sigma])?;
        }
        if let Some(test) = &self.test {
            check.values("test", &[test.statistic, test.ratio])?;
        }
        json::write(path, json::MECHANISM_VALIDATION, self)
    }

    /// Reads `validation.json` of a mechanism.
    pub fn read(path: &Path) -> Result<Self> {
        json::read(path, json::MECHANISM_VALIDATION)
    }
}
