//! A cable robot's line elasticity, an option of its model: a line of
//! length `L` pulled by a force `F` is longer than unloaded by `c F L`,
//! `c = 1/(E A)` its compliance (the inverse of the line's stiffness per
//! unit length, `E A`). The encoders count unstretched line, zeroed with
//! the lines pulled by `F_0`; so a line pulled by `F` rather than `F_0` at
//! length `L` reads as if it were `c (F - F_0) L` shorter, and the
//! line-length change the encoder of line `j` sees is
//!
//! ```text
//! dL_j = (1 - c_j (F_j - F0_j)) |a_j - p| - |a_j - z_0|
//! ```
//!
//! (exactly `U(p) - U(z_0)` with `U = L / (1 + c F)` the unstretched
//! length, up to a factor `1 - c F_0` on `|a_j - p| - |a_j - z_0|`,
//! a scale of the spool's radius, to first order in `c F`). Under the
//! loads of the encoder zero it is the rigid model's. The compliance is in
//! `um/m/N` (1e-6 per newton): a line of `E A` = 20000 N, the constant the
//! Hangprinter's calibration script assumes (`springKPerUnitLength`), has
//! `c` = 50.

use crate::mechanism::Parameter;

/// The unit of a compliance: micrometres per metre of line per newton.
pub const COMPLIANCE_UNIT: &str = "um/m/N";
/// One compliance unit as a strain per newton.
pub const COMPLIANCE_SCALE: f64 = 1e-6;
/// A line's compliance when nothing else is stated, and its prior sigma
/// (um/m/N): a stiffness per unit length `E A` of 20000 N (module doc),
/// as uncertain as its value.
pub const TYPICAL_COMPLIANCE: f64 = 50.0;

/// The elasticity option of a cable robot (module documentation).
#[derive(Debug, Clone, PartialEq)]
pub struct Elasticity {
    /// For each line, the index of its compliance among the compliance
    /// parameters (lines of one reel of line may share one).
    pub compliance_of_line: Vec<usize>,
    /// The forces `F0_j` pulling the lines when the encoders were zeroed
    /// (N, the unit of the loads).
    pub zero_loads: Vec<f64>,
    /// The compliances' design value (um/m/N).
    pub compliance: f64,
    /// Their prior standard deviation (um/m/N).
    pub compliance_sigma: f64,
}

impl Elasticity {
    /// Lines elastic as `compliance_of_line` shares their compliances,
    /// pulled by `zero_loads` at the encoder zero, each compliance
    /// [`TYPICAL_COMPLIANCE`] with that sigma.
    pub fn typical(compliance_of_line: Vec<usize>, zero_loads: Vec<f64>) -> Self {
        Self {
            compliance_of_line,
            zero_loads,
            compliance: TYPICAL_COMPLIANCE,
            compliance_sigma: TYPICAL_COMPLIANCE,
        }
    }

    /// Refuses an option that does not fit `cables` lines: lists of
    /// another length, a compliance index without its parameter or a
    /// parameter no line uses, a non-finite load, a prior that is not a
    /// finite value with a positive sigma. The message names the value.
    pub fn check(&self, cables: usize) -> Result<(), String> {
        for (what, found) in [
            ("the compliance of each line", self.compliance_of_line.len()),
            ("the loads at the encoder zero", self.zero_loads.len()),
        ] {
            if found != cables {
                return Err(format!("{what} lists {found} values for {cables} lines"));
            }
        }
        let count = self.count();
        if let Some(k) = (0..count).find(|k| !self.compliance_of_line.contains(k)) {
            return Err(format!(
                "no line has compliance index {k}: the indices run from 0 to {} without a gap",
                count - 1
            ));
        }
        if let Some(load) = self.zero_loads.iter().find(|f| !is_taut(**f)) {
            return Err(format!(
                "a load at the encoder zero, {load} N, is not positive and finite: a line is taut under a positive load"
            ));
        }
        if !self.compliance.is_finite() {
            return Err(format!("the compliance {} is not finite", self.compliance));
        }
        if !(self.compliance_sigma.is_finite() && self.compliance_sigma > 0.0) {
            return Err(format!(
                "the compliance's sigma {} is not finite and positive",
                self.compliance_sigma
            ));
        }
        Ok(())
    }

    /// The number of compliance parameters.
    pub fn count(&self) -> usize {
        self.compliance_of_line.iter().max().map_or(0, |k| k + 1)
    }

    /// The compliance parameters, named after their lines
    /// (`compliance_abcd` for one shared by all four), in the group
    /// `line compliance`.
    pub fn parameters(&self, line_name: impl Fn(usize) -> char) -> Vec<Parameter> {
        (0..self.count())
            .map(|k| {
                let lines: String = (0..self.compliance_of_line.len())
                    .filter(|&j| self.compliance_of_line[j] == k)
                    .map(&line_name)
                    .collect();
                Parameter {
                    name: format!("compliance_{lines}"),
                    unit: COMPLIANCE_UNIT.into(),
                    group: "line compliance",
                    design: self.compliance,
                    prior_sigma: self.compliance_sigma,
                }
            })
            .collect()
    }
}

/// Whether a line's load `force` (N) is one a taut line holds: positive
/// and finite.
pub fn is_taut(force: f64) -> bool {
    force.is_finite() && force > 0.0
}
