//! calibration.json checked as an input: what [`Calibration::read`]
//! refuses (and [`Calibration::write`], so that parcal never writes a file
//! its reader refuses).
//!
//! A calibration is applied, reported and quoted as an accuracy, so the
//! file is not trusted for being a result:
//!
//! - **numbers in their domain**: finite everywhere; a sigma not negative
//!   (positive for a parameter with a covariance); the actuator scales
//!   within [`Check::scale`]'s bounds; radii positive;
//! - **one geometry**: the named kinematic parameters
//!   ([`PARAM_NAMES`]) equal the `canonical` geometry's
//!   ([`params::to_params`]), whose coordinates zero by definition are
//!   zero, and the calibrated actuator scales (`s_1` ... `s_6`) the
//!   calibrated machine's (`machine.actuator.scale`), within [`AGREEMENT`];
//! - **a covariance**: square (one row and column per parameter),
//!   symmetric, positive semi-definite (its correlation matrix plus
//!   [`SEMIDEFINITE`] times the identity has a Cholesky factor), with
//!   `parameters.sigma` the square roots of its diagonal; without one,
//!   every posterior sigma is 0;
//! - **no posterior accuracy without convergence**: a run that did not
//!   converge has no covariance (and so no posterior sigma);
//! - **a verdict its tests support**: `accepted`, `rejected` or empty
//!   (files written before verdicts); one that is not `rejected` needs a
//!   converged run, a global test that did not fail (its outcome the one
//!   its numbers give) and no reason saying a test failed;
//! - **texts without control characters**;
//! - **bounded lists** ([`MAX_PARAMETERS`] and the other bounds of the
//!   module above), refused while the file is parsed.

use std::path::Path;

use parcal_kinematics::params::{self, BASE_INDEX, LEG_OFFSET, PLATFORM_INDEX, TOOL_OFFSET};
use parcal_kinematics::{Geometry, PARAM_NAMES, SCALE_NAMES};

use super::{Calibration, Diagnostics};
use crate::check::{Check, shown};
use crate::error::Result;
use crate::json;
use crate::quote::{Sanitized, quoted, sanitized};

/// Relative agreement of two copies of one number (a parameter and its
/// canonical coordinate, a sigma and its variance), relative to the larger
/// of their magnitudes and 1 (mm) for a coordinate: far below any sigma,
/// far above the rounding of a write and read (none: they are exact).
const AGREEMENT: f64 = 1e-9;

/// Slack of the covariance's correlation matrix in the test of positive
/// semi-definiteness, and of its symmetry (relative to `√(c_ii c_jj)`):
/// the rounding of an inverse of a well-conditioned information matrix is
/// far smaller, an edited entry far larger.
const SEMIDEFINITE: f64 = 1e-6;

impl Calibration {
    /// Reads and checks a calibration file (extra fields are ignored);
    /// what is checked is in the module documentation.
    pub fn read(path: &Path) -> Result<Self> {
        let calibration: Self = json::read(path, json::CALIBRATION)?;
        calibration.validate(Check::result(path))?;
        Ok(calibration)
    }

    /// Writes a calibration file atomically, after the checks of
    /// [`Calibration::read`]: a value that is not finite (JSON has no NaN)
    /// or that the reader would refuse is an error naming its field, and
    /// nothing is written.
    pub fn write(&self, path: &Path) -> Result<()> {
        // A 10^6-contact calibration's 30 MB are written while checked.
        json::write_checked(path, json::CALIBRATION, self, || {
            self.validate(Check::result(path))
        })
    }

    fn validate(&self, check: Check) -> Result<()> {
        self.validate_numbers(check)?;
        self.validate_verdict(check)?;
        self.validate_geometry(check)?;
        self.validate_covariance(check)?;
        self.validate_posterior(check)?;
        self.validate_texts(check)?;
        if let Some(diagnostics) = &self.diagnostics {
            diagnostics.validate(check, self.parameters.names.len())?;
        }
        Ok(())
    }

    /// Shapes and every number in its domain.
    fn validate_numbers(&self, check: Check) -> Result<()> {
        self.canonical.validate(check, "canonical.")?;
        let p = &self.parameters;
        let n = p.names.len();
        for (field, len) in [
            ("parameters.values", p.values.len()),
            ("parameters.sigma", p.sigma.len()),
        ] {
            if len != n {
                return Err(check.error(
                    field,
                    format!("expected {n} values (one per name), found {len}"),
                ));
            }
        }
        check.values("parameters.values", &p.values)?;
        for (k, &sigma) in p.sigma.iter().enumerate() {
            check.non_negative(format_args!("parameters.sigma[{k}]"), sigma)?;
        }
        for (id, estimate) in &self.ball_centres {
            let id = Sanitized(id);
            check.point(format_args!("ball_centres.{id}.centre"), &estimate.centre)?;
            for (j, &sigma) in estimate.sigma.iter().enumerate() {
                check.non_negative(format_args!("ball_centres.{id}.sigma[{j}]"), sigma)?;
            }
            if let Some(radius) = estimate.radius {
                check.positive_length(format_args!("ball_centres.{id}.radius"), radius)?;
            }
            if let Some(sigma) = estimate.radius_sigma {
                check.non_negative(format_args!("ball_centres.{id}.radius_sigma"), sigma)?;
            }
        }
        if let Some(machine) = &self.machine {
            machine.geometry.validate(check, "machine.geometry.")?;
            let actuator = &machine.actuator;
            for (i, &scale) in actuator.scale.iter().enumerate() {
                check.scale(format_args!("machine.actuator.scale[{i}]"), scale)?;
            }
            for (i, &sigma) in actuator.scale_sigma.iter().flatten().enumerate() {
                check.non_negative(format_args!("machine.actuator.scale_sigma[{i}]"), sigma)?;
            }
        }
        if let Some(design) = &self.design {
            design.validate_in(check, "design.")?;
        }
        for (k, session) in self.sessions.iter().enumerate() {
            session.validate(check, &format!("sessions[{k}]"))?;
        }
        for (k, d) in self.down_weighted_observations.iter().enumerate() {
            check.finite(
                format_args!("down_weighted_observations[{k}].weight"),
                d.weight,
            )?;
            check.finite(
                format_args!("down_weighted_observations[{k}].residual_sigmas"),
                d.residual_sigmas,
            )?;
        }
        for (k, r) in self.removed_observations.iter().enumerate() {
            let field = format!("removed_observations[{k}]");
            check.finite(
                format_args!("{field}.normalised_residual"),
                r.normalised_residual,
            )?;
            check.finite(
                format_args!("{field}.gross_error_sigmas"),
                r.gross_error_sigmas,
            )?;
            check.values(format_args!("{field}.variance_factor"), &r.variance_factor)?;
        }
        for (i, it) in self.iterations.iter().enumerate() {
            check.finite(format_args!("iterations[{i}].cost"), it.cost)?;
            check.finite(format_args!("iterations[{i}].step_norm"), it.step_norm)?;
            check.finite(
                format_args!("iterations[{i}].residual_rms"),
                it.residual_rms,
            )?;
        }
        Ok(())
    }

    /// The named kinematic parameters are the `canonical` geometry's, that
    /// geometry is in its canonical frames, and the calibrated scales are
    /// the calibrated machine's.
    fn validate_geometry(&self, check: Check) -> Result<()> {
        let c = &self.canonical;
        for (body, joints, index) in [
            ("base_joints", &c.base_joints, &BASE_INDEX),
            ("platform_joints", &c.platform_joints, &PLATFORM_INDEX),
        ] {
            for (i, (joint, index)) in joints.iter().zip(index).enumerate() {
                for (j, (&value, slot)) in joint.iter().zip(index).enumerate() {
                    if slot.is_none() && !agree(value, 0.0) {
                        return Err(check.error(
                            format!("canonical.{body}[{i}][{j}]"),
                            format!(
                                "must be 0 in the canonical frames (zero by definition), found {}",
                                shown(value)
                            ),
                        ));
                    }
                }
            }
        }
        let geometry =
            Geometry::from_arrays(&c.base_joints, &c.platform_joints, &c.tool, &c.leg_lengths);
        let canonical = params::to_params(&geometry);
        let p = &self.parameters;
        for (k, (name, &value)) in p.names.iter().zip(&p.values).enumerate() {
            let Some(j) = PARAM_NAMES.iter().position(|known| known == name) else {
                continue;
            };
            if !agree(value, canonical[j]) {
                return Err(check.error(
                    canonical_field(j),
                    format!(
                        "{} disagrees with parameters.values[{k}], {name} = {}: the canonical \
                         geometry and the parameters are two copies of one result",
                        canonical[j], value
                    ),
                ));
            }
        }
        let Some(machine) = &self.machine else {
            return Ok(());
        };
        for (i, (&scale, name)) in machine.actuator.scale.iter().zip(SCALE_NAMES).enumerate() {
            let Some(k) = p.names.iter().position(|known| *known == name) else {
                continue;
            };
            if !agree(p.values[k], scale) {
                return Err(check.error(
                    format!("machine.actuator.scale[{i}]"),
                    format!(
                        "{} disagrees with parameters.values[{k}], {name} = {}: the calibrated \
                         machine and the parameters are two copies of one result",
                        scale, p.values[k]
                    ),
                ));
            }
        }
        Ok(())
    }

    /// The covariance: square, its diagonal the squares of
    /// `parameters.sigma`, symmetric, positive semi-definite; without one,
    /// `parameters.sigma` is 0.
    fn validate_covariance(&self, check: Check) -> Result<()> {
        let c = &self.covariance;
        let sigma = &self.parameters.sigma;
        let n = sigma.len();
        if c.is_empty() {
            return match sigma.iter().position(|&s| s != 0.0) {
                None => Ok(()),
                Some(k) => Err(check.error(
                    format!("parameters.sigma[{k}]"),
                    format!(
                        "{} without a covariance: a sigma is the square root of the \
                         covariance's diagonal, 0 when none was computed",
                        shown(sigma[k])
                    ),
                )),
            };
        }
        if c.len() != n {
            return Err(check.error(
                "covariance",
                format!("expected {n} rows (one per parameter), found {}", c.len()),
            ));
        }
        for (i, row) in c.iter().enumerate() {
            let field = format!("covariance[{i}]");
            if row.len() != n {
                return Err(
                    check.error(field, format!("expected {n} columns, found {}", row.len()))
                );
            }
            check.values(&field, row)?;
        }
        for k in 0..n {
            let variance = c[k][k];
            if variance <= 0.0 {
                return Err(check.error(
                    format!("covariance[{k}][{k}]"),
                    format!(
                        "a variance must be positive, found {} (parameter {})",
                        shown(variance),
                        quoted(&self.parameters.names[k])
                    ),
                ));
            }
            let root = variance.sqrt();
            if (sigma[k] - root).abs() > AGREEMENT * root {
                return Err(check.error(
                    format!("parameters.sigma[{k}]"),
                    format!(
                        "{} is not the square root of covariance[{k}][{k}] = {} ({})",
                        shown(sigma[k]),
                        shown(variance),
                        shown(root)
                    ),
                ));
            }
        }
        for i in 0..n {
            for j in i + 1..n {
                let scale = (c[i][i] * c[j][j]).sqrt();
                if (c[i][j] - c[j][i]).abs() > SEMIDEFINITE * scale {
                    return Err(check.error(
                        format!("covariance[{i}][{j}]"),
                        format!(
                            "{} differs from covariance[{j}][{i}] = {}: a covariance is symmetric",
                            shown(c[i][j]),
                            shown(c[j][i])
                        ),
                    ));
                }
            }
        }
        match indefinite_at(c) {
            None => Ok(()),
            Some(k) => Err(check.error(
                format!("covariance[{k}]"),
                format!(
                    "the covariance is not positive semi-definite: its first {} rows and \
                     columns (to parameter {}) give some combination of the parameters a \
                     negative variance",
                    k + 1,
                    quoted(&self.parameters.names[k])
                ),
            )),
        }
    }

    /// A run that did not converge has no covariance: no posterior
    /// accuracy anywhere. Without a covariance, every posterior sigma is 0.
    fn validate_posterior(&self, check: Check) -> Result<()> {
        if !self.converged && !self.covariance.is_empty() {
            return Err(check.error(
                "covariance",
                "the run did not converge (converged is false): it has no posterior \
                 covariance, and the file must not give one",
            ));
        }
        if !self.covariance.is_empty() {
            return Ok(());
        }
        let none = "without a covariance (none was computed, or the run did not converge) \
                    there is no posterior sigma: it must be 0";
        for (id, estimate) in &self.ball_centres {
            let sigmas = estimate.sigma.iter().chain(&estimate.radius_sigma);
            if sigmas.into_iter().any(|&s| s != 0.0) {
                return Err(check.error(format!("ball_centres.{}", sanitized(id)), none));
            }
        }
        let scale_sigma = self.machine.as_ref().and_then(|m| m.actuator.scale_sigma);
        if scale_sigma.is_some_and(|s| s.iter().any(|&s| s != 0.0)) {
            return Err(check.error("machine.actuator.scale_sigma", none));
        }
        Ok(())
    }

    /// The verdict is one the recorded tests support.
    fn validate_verdict(&self, check: Check) -> Result<()> {
        if !matches!(self.verdict.as_str(), "" | "accepted" | "rejected") {
            return Err(check.error(
                "verdict",
                format!(
                    "expected \"accepted\" or \"rejected\", found {}",
                    quoted(&self.verdict)
                ),
            ));
        }
        let failed_test = match &self.global_test {
            Some(test) => test.validate(check)?,
            None => false,
        };
        if self.is_rejected() {
            return Ok(());
        }
        let verdict = if self.verdict.is_empty() {
            "no verdict (used as accepted)".to_string()
        } else {
            quoted(&self.verdict)
        };
        let contradiction = if !self.converged {
            Some("the run did not converge (converged is false)".to_string())
        } else if failed_test {
            Some("the global test failed (its outcome is \"too large\")".to_string())
        } else {
            self.reasons
                .iter()
                .position(|r| r.contains("test failed"))
                .map(|k| {
                    format!(
                        "reasons[{k}] says a test failed: {}",
                        quoted(&self.reasons[k])
                    )
                })
        };
        match contradiction {
            None => Ok(()),
            Some(why) => Err(check.error(
                "verdict",
                format!("{verdict}, but {why}: the calibration is rejected"),
            )),
        }
    }

    /// Every text without control characters.
    fn validate_texts(&self, check: Check) -> Result<()> {
        for (k, name) in self.parameters.names.iter().enumerate() {
            check.text(format_args!("parameters.names[{k}]"), name)?;
        }
        for id in self.ball_centres.keys() {
            check.text(format_args!("ball_centres.{}", Sanitized(id)), id)?;
        }
        for (field, text) in [
            ("prior", &self.prior),
            ("status", &self.status),
            ("verdict", &self.verdict),
        ] {
            check.text(field, text)?;
        }
        for (list, texts) in [("reasons", &self.reasons), ("warnings", &self.warnings)] {
            for (k, text) in texts.iter().enumerate() {
                check.text(format_args!("{list}[{k}]"), text)?;
            }
        }
        for (key, value) in &self.options {
            let field = format!("options.{}", sanitized(key));
            check.text(&field, key)?;
            json_texts(check, &field, value)?;
        }
        if let Some(machine) = &self.machine {
            check.text("machine.actuator.unit", &machine.actuator.unit)?;
        }
        for (k, session) in self.sessions.iter().enumerate() {
            check.text(format_args!("sessions[{k}].label"), &session.label)?;
        }
        if let Some(t) = &self.global_test {
            check.text("global_test.outcome", &t.outcome)?;
        }
        if let Some(p) = &self.provenance {
            check.text("provenance.parcal_version", &p.parcal_version)?;
            check.text("provenance.dataset", &p.dataset)?;
            check.text("provenance.dataset_checksum", &p.dataset_checksum)?;
        }
        for (k, r) in self.removed_observations.iter().enumerate() {
            place_texts(
                check,
                &format!("removed_observations[{k}]"),
                &r.file,
                &r.field,
            )?;
        }
        for (k, d) in self.down_weighted_observations.iter().enumerate() {
            let field = format!("down_weighted_observations[{k}]");
            place_texts(check, &field, &d.file, &d.field)?;
        }
        Ok(())
    }
}

impl super::GlobalTestRecord {
    /// Finite numbers, `s₀² = Ω / r`, an interval of `s₀²` and the outcome
    /// it gives; whether that outcome is `too large` (the test failed).
    fn validate(&self, check: Check) -> Result<bool> {
        check.finite("global_test.cost", self.cost)?;
        check.finite("global_test.variance_factor", self.variance_factor)?;
        check.finite("global_test.level", self.level)?;
        check.values("global_test.interval", &self.interval)?;
        let [lower, upper] = self.interval;
        if !(0.0 <= lower && lower <= upper) {
            return Err(check.error(
                "global_test.interval",
                format!(
                    "expected [lower, upper] with 0 <= lower <= upper, found [{}, {}]",
                    shown(lower),
                    shown(upper)
                ),
            ));
        }
        let s0 = self.cost / self.redundancy as f64;
        if self.redundancy == 0 || !agree(self.variance_factor, s0) {
            return Err(check.error(
                "global_test.variance_factor",
                format!(
                    "{} is not cost / redundancy = {} / {}",
                    shown(self.variance_factor),
                    shown(self.cost),
                    self.redundancy
                ),
            ));
        }
        let outcome = if self.variance_factor > upper {
            "too large"
        } else if self.variance_factor < lower {
            "too small"
        } else {
            "consistent"
        };
        if self.outcome != outcome {
            return Err(check.error(
                "global_test.outcome",
                format!(
                    "{}, but the variance factor {} against the interval [{}, {}] gives {outcome:?}",
                    quoted(&self.outcome),
                    shown(self.variance_factor),
                    shown(lower),
                    shown(upper)
                ),
            ));
        }
        Ok(outcome == "too large")
    }
}

impl Diagnostics {
    /// Finite numbers, one prior sigma and attribution per parameter (of
    /// `n`) when given, at most one parameter shift per parameter, texts
    /// without control characters.
    fn validate(&self, check: Check, n: usize) -> Result<()> {
        for (k, c) in self.variance_components.iter().enumerate() {
            let field = format!("diagnostics.variance_components[{k}]");
            check.text(format_args!("{field}.group"), &c.group)?;
            check.finite(format_args!("{field}.cost"), c.cost)?;
            check.finite(format_args!("{field}.redundancy"), c.redundancy)?;
        }
        for (k, t) in self.systematic_tests.iter().enumerate() {
            let field = format!("diagnostics.systematic_tests[{k}]");
            for (name, value) in [
                ("estimate", t.estimate),
                ("sigma", t.sigma),
                ("level", t.level),
                ("critical_value", t.critical_value),
                ("variance_factor_without", t.variance_factor_without),
            ] {
                check.finite(format_args!("{field}.{name}"), value)?;
            }
            for (name, text) in [
                ("effect", &t.effect),
                ("unit", &t.unit),
                ("outcome_without", &t.outcome_without),
            ] {
                check.text(format_args!("{field}.{name}"), text)?;
            }
        }
        for (k, t) in self.systematic_sensitivity.iter().enumerate() {
            let field = format!("diagnostics.systematic_sensitivity[{k}]");
            check.positive(format_args!("{field}.sigma"), t.sigma)?;
            check.positive(format_args!("{field}.mdb"), t.mdb)?;
            for (name, value) in [("level", t.level), ("power", t.power)] {
                check.finite(format_args!("{field}.{name}"), value)?;
            }
            for (name, text) in [("effect", &t.effect), ("unit", &t.unit)] {
                check.text(format_args!("{field}.{name}"), text)?;
            }
            if t.parameter_shift.len() > n {
                return Err(check.error(
                    format!("{field}.parameter_shift"),
                    format!(
                        "expected at most {n} values (one per parameter), found {}",
                        t.parameter_shift.len()
                    ),
                ));
            }
            check.values(format_args!("{field}.parameter_shift"), &t.parameter_shift)?;
            for (name, value) in [("map_rms_um", t.map_rms_um), ("map_max_um", t.map_max_um)] {
                if let Some(value) = value {
                    check.non_negative(format_args!("{field}.{name}"), value)?;
                }
            }
        }
        for (field, len) in [
            ("diagnostics.prior_sigma", self.prior_sigma.len()),
            ("diagnostics.determined_by", self.determined_by.len()),
        ] {
            if len != 0 && len != n {
                return Err(check.error(
                    field,
                    format!("expected {n} values (one per parameter), found {len}"),
                ));
            }
        }
        for (k, sigma) in self.prior_sigma.iter().enumerate() {
            if let Some(sigma) = sigma {
                check.positive(format_args!("diagnostics.prior_sigma[{k}]"), *sigma)?;
            }
        }
        for (k, by) in self.determined_by.iter().enumerate() {
            check.text(format_args!("diagnostics.determined_by[{k}]"), by)?;
        }
        for (k, weak) in self.weak_directions.iter().enumerate() {
            let field = format!("diagnostics.weak_directions[{k}]");
            check.finite(format_args!("{field}.eigenvalue"), weak.eigenvalue)?;
            if let Some(sigma) = weak.sigma {
                check.non_negative(format_args!("{field}.sigma"), sigma)?;
            }
            for (j, (name, component)) in weak.dominant.iter().enumerate() {
                check.text(format_args!("{field}.dominant[{j}]"), name)?;
                check.finite(format_args!("{field}.dominant[{j}]"), *component)?;
            }
        }
        for (k, e) in self.external_reliability.iter().enumerate() {
            let field = format!("diagnostics.external_reliability[{k}]");
            if e.parameter_shift.len() > n {
                return Err(check.error(
                    format!("{field}.parameter_shift"),
                    format!(
                        "expected at most {n} values (one per parameter), found {}",
                        e.parameter_shift.len()
                    ),
                ));
            }
            check.values(format_args!("{field}.parameter_shift"), &e.parameter_shift)?;
            observation_check(check, &format!("{field}.observation"), &e.observation)?;
            let numbers = [
                ("row_redundancy", Some(e.row_redundancy)),
                ("row_mdb_sigmas", Some(e.row_mdb_sigmas)),
                ("bias_to_noise", Some(e.bias_to_noise)),
                ("map_rms_um", e.map_rms_um),
                ("map_max_um", e.map_max_um),
            ];
            for (name, value) in numbers {
                if let Some(value) = value {
                    check.finite(format_args!("{field}.{name}"), value)?;
                }
            }
        }
        if let Some(tests) = &self.observations {
            for (name, value) in [
                ("level", tests.level),
                ("critical_value", tests.critical_value),
                ("redundancy", tests.redundancy),
                ("uncontrolled_below", tests.uncontrolled_below),
            ] {
                check.finite(format_args!("diagnostics.observations.{name}"), value)?;
            }
            for (field, h) in [
                ("normalised_histogram", &tests.normalised_histogram),
                ("redundancy_histogram", &tests.redundancy_histogram),
            ] {
                if !(h.width > 0.0 && h.width.is_finite() && h.lower.is_finite()) {
                    return Err(check.error(
                        format!("diagnostics.observations.{field}"),
                        "expected a finite lower edge and a positive bin width".to_string(),
                    ));
                }
            }
            for (list, checks) in [
                ("largest", &tests.largest),
                ("least_controlled", &tests.least_controlled),
            ] {
                for (k, c) in checks.iter().enumerate() {
                    observation_check(check, &format!("diagnostics.observations.{list}[{k}]"), c)?;
                }
            }
        }
        Ok(())
    }
}

/// One observation's test: finite numbers, texts without control
/// characters.
fn observation_check(check: Check, field: &str, c: &super::ObservationCheck) -> Result<()> {
    let values = [c.normalised_residual, c.gross_error_sigmas, c.mdb_sigmas];
    check.values(
        field,
        &[c.redundancy]
            .into_iter()
            .chain(values.into_iter().flatten())
            .collect::<Vec<_>>(),
    )?;
    check.text(format_args!("{field}.observes"), &c.observes)?;
    place_texts(check, field, &c.file, &c.field)
}

/// An observation's file and field name without control characters.
fn place_texts(check: Check, parent: &str, file: &str, field: &Option<String>) -> Result<()> {
    check.text(format_args!("{parent}.file"), file)?;
    match field {
        Some(field) => check.text(format_args!("{parent}.field"), field),
        None => Ok(()),
    }
}

/// Every text of a free-form JSON value (an option) without control
/// characters.
fn json_texts(check: Check, field: &str, value: &serde_json::Value) -> Result<()> {
    match value {
        serde_json::Value::String(text) => check.text(field, text),
        serde_json::Value::Array(values) => values
            .iter()
            .enumerate()
            .try_for_each(|(k, v)| json_texts(check, &format!("{field}[{k}]"), v)),
        serde_json::Value::Object(map) => map.iter().try_for_each(|(key, v)| {
            let field = format!("{field}.{}", sanitized(key));
            check.text(&field, key)?;
            json_texts(check, &field, v)
        }),
        _ => Ok(()),
    }
}

/// Whether `a` and `b` are one number ([`AGREEMENT`], relative to the
/// larger magnitude and 1).
fn agree(a: f64, b: f64) -> bool {
    (a - b).abs() <= AGREEMENT * a.abs().max(b.abs()).max(1.0)
}

/// The field of `canonical` that holds kinematic parameter `k` (of
/// [`PARAM_NAMES`]).
fn canonical_field(k: usize) -> String {
    for (body, index) in [
        ("base_joints", &BASE_INDEX),
        ("platform_joints", &PLATFORM_INDEX),
    ] {
        for (i, joint) in index.iter().enumerate() {
            if let Some(j) = joint.iter().position(|slot| *slot == Some(k)) {
                return format!("canonical.{body}[{i}][{j}]");
            }
        }
    }
    if k < TOOL_OFFSET {
        format!("canonical.leg_lengths[{}]", k - LEG_OFFSET)
    } else {
        format!("canonical.tool[{}]", k - TOOL_OFFSET)
    }
}

/// The first row `k` at which the Cholesky factorisation of the
/// correlation matrix of the symmetric covariance `c` (positive diagonal)
/// plus [`SEMIDEFINITE`] times the identity fails: its leading `k + 1`
/// rows and columns have a negative eigenvalue below `−SEMIDEFINITE` in
/// correlation units; `None` when positive semi-definite within that.
fn indefinite_at(c: &[Vec<f64>]) -> Option<usize> {
    let n = c.len();
    let s: Vec<f64> = (0..n).map(|k| c[k][k].sqrt()).collect();
    // Lower triangle of the factor, row by row.
    let mut l = vec![0.0; n * (n + 1) / 2];
    let row = |i: usize| i * (i + 1) / 2;
    for i in 0..n {
        for j in 0..=i {
            let r = c[i][j] / (s[i] * s[j]) + if i == j { SEMIDEFINITE } else { 0.0 };
            let (ri, rj) = (row(i), row(j));
            let dot: f64 = (0..j).map(|k| l[ri + k] * l[rj + k]).sum();
            if i == j {
                let pivot = r - dot;
                if pivot.is_nan() || pivot <= 0.0 {
                    return Some(i);
                }
                l[ri + i] = pivot.sqrt();
            } else {
                l[ri + j] = (r - dot) / l[rj + j];
            }
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn canonical_fields_follow_the_parameters() {
        assert_eq!(canonical_field(0), "canonical.base_joints[1][1]");
        assert_eq!(canonical_field(12), "canonical.leg_lengths[0]");
        assert_eq!(canonical_field(18), "canonical.platform_joints[1][1]");
        assert_eq!(canonical_field(32), "canonical.tool[2]");
    }

    #[test]
    fn cholesky_finds_the_first_indefinite_block() {
        let identity = vec![vec![1.0, 0.0], vec![0.0, 1.0]];
        assert_eq!(indefinite_at(&identity), None);
        // Correlation exactly 1: semi-definite.
        let singular = vec![vec![4.0, 2.0], vec![2.0, 1.0]];
        assert_eq!(indefinite_at(&singular), None);
        // Correlation 1.5: indefinite at the second row.
        let indefinite = vec![
            vec![1.0, 1.5, 0.0],
            vec![1.5, 1.0, 0.0],
            vec![0.0, 0.0, 1.0],
        ];
        assert_eq!(indefinite_at(&indefinite), Some(1));
    }
}
