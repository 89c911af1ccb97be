//! `validation.json`: a calibration applied to measurements it was not
//! fitted on (`parcal validate`).

use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::check::Check;
use crate::error::Result;
use crate::json;

/// The content of `validation.json`. Residuals are leg lengths for poses
/// (`|R p_i + t − b_i| − l_i − s_i q_i`), coordinates for points, and the
/// distance to the ball's surface for ball touches, mm.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ValidationRecord {
    /// The calibration file applied.
    pub calibration: String,
    /// Rows of each session used to re-fit its nuisance (0: none, the
    /// calibration's frames).
    pub reference_rows: usize,
    /// The nuisance groups re-fitted, by name.
    pub refitted: Vec<String>,
    /// The candidate nuisance models with their expected prediction RMS;
    /// the one with the least was re-fitted.
    pub selection: Vec<NuisanceCandidate>,
    /// Predicted rows (poses plus points plus touches).
    pub rows: usize,
    /// Predicted poses.
    pub poses: usize,
    /// Predicted points.
    pub points: usize,
    /// Predicted ball touches.
    #[serde(default)]
    pub contacts: usize,
    /// RMS of the residuals of the predicted rows.
    pub rms_mm: f64,
    /// Largest absolute residual.
    pub max_mm: f64,
    /// RMS of each leg's residual over the predicted poses (zeros without
    /// poses).
    pub per_leg_rms_mm: [f64; 6],
    /// The RMS predicted from the calibration's covariance and the noise
    /// model.
    pub predicted_rms_mm: f64,
    /// `"accepted"` or `"rejected"` (empty in a file written before
    /// validations had a verdict).
    #[serde(default)]
    pub verdict: String,
    /// Why, one sentence each: the test, and for a rejection what may have
    /// changed and what to do.
    #[serde(default)]
    pub reasons: Vec<String>,
    /// The test behind the verdict.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub test: Option<PredictionTestRecord>,
    /// The balls (artefacts.json ids) whose reference touches fit their
    /// centre and its mirror image through their plane about as well,
    /// located at the image all their touches fit: the mirror image.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub mirrored_balls: Vec<String>,
}

/// The test of a validation's residuals `r` against their predicted
/// covariance `C` (the calibration's covariance propagated, the re-fitted
/// nuisance's and the rows' noise): `T = rᵀ C⁻¹ r` over `n` rows, its
/// variance factor `T / n` against the calibration's `s₀² = Ω / r`, `F =
/// (T / n) / s₀² ~ F(n, r)` (without the calibration's global test, `s₀² =
/// 1`: `T ~ χ²(n)`), two-sided at `level`; above the interval rejects.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PredictionTestRecord {
    /// `T = rᵀ C⁻¹ r`.
    pub statistic: f64,
    /// `n`, the predicted rows.
    pub degrees_of_freedom: usize,
    /// The calibration's `s₀²` (absent: taken as 1).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub calibration_variance_factor: Option<f64>,
    /// The calibration's redundancy `r` (absent: `χ²(n)`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub calibration_redundancy: Option<usize>,
    /// `F = (T / n) / s₀²`.
    pub ratio: f64,
    /// The test's level.
    pub level: f64,
    /// The interval of `F` that passes: the quantiles of `F(n, r)` (or of
    /// `χ²(n) / n`) at `level / 2` and `1 − level / 2`.
    pub interval: [f64; 2],
    /// `"consistent"`, `"too large"` or `"too small"`.
    pub outcome: String,
}

/// One candidate nuisance model of a validation.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct NuisanceCandidate {
    /// Its groups, joined by ` + `.
    pub model: String,
    /// Expected RMS of a predicted row's residual (mm): the reference
    /// rows' residual variance after the re-fit plus the re-fitted
    /// nuisance's variance propagated to the predicted rows.
    pub expected_rms_mm: f64,
}

impl ValidationRecord {
    /// Writes `validation.json` atomically; every number must be finite.
    pub fn write(&self, path: &Path) -> Result<()> {
        let check = Check::result(path);
        check.finite("rms_mm", self.rms_mm)?;
        check.finite("max_mm", self.max_mm)?;
        check.values("per_leg_rms_mm", &self.per_leg_rms_mm)?;
        check.finite("predicted_rms_mm", self.predicted_rms_mm)?;
        if let Some(test) = &self.test {
            check.finite("test.statistic", test.statistic)?;
            check.finite("test.ratio", test.ratio)?;
            check.values("test.interval", &test.interval)?;
        }
        json::write(path, json::VALIDATION, self)
    }

    /// Reads `validation.json`.
    pub fn read(path: &Path) -> Result<Self> {
        json::read(path, json::VALIDATION)
    }

    /// Whether the verdict is `"rejected"`.
    pub fn is_rejected(&self) -> bool {
        self.verdict == "rejected"
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A validation.json written before validations had a verdict reads
    /// with an empty verdict, no reason and no test, and is not rejected.
    #[test]
    fn a_file_without_a_verdict_still_reads() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("validation.json");
        std::fs::write(
            &path,
            r#"{
 "format": "parcal-validation/1",
 "calibration": "day1/calibration.json",
 "reference_rows": 12,
 "refitted": ["frame tuesday"],
 "selection": [],
 "rows": 96, "poses": 96, "points": 0,
 "rms_mm": 0.434, "max_mm": 1.32,
 "per_leg_rms_mm": [0.46, 0.51, 0.51, 0.38, 0.37, 0.35],
 "predicted_rms_mm": 0.442
}"#,
        )
        .unwrap();
        let record = ValidationRecord::read(&path).unwrap();
        assert_eq!(record.verdict, "");
        assert!(record.reasons.is_empty() && record.test.is_none());
        assert!(!record.is_rejected());
        assert_eq!(record.rows, 96);
    }
}
