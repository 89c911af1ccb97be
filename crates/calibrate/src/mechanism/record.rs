//! A mechanism calibration as its `calibration.json` record
//! ([`parcal_dataset::mechanism::MechanismCalibrationRecord`]), built in
//! this one place.

use nalgebra::DMatrix;
use parcal_dataset::mechanism::{
    BallRecord, BodyRecord, IdentifiabilityRecord, MechanismCalibrationRecord, MirroredRecord,
    ParameterRecord, RemovalRecord, RunAwayRecord, TestsRecord, TrackerRecord, UndeterminedRecord,
};
use parcal_dataset::{FrameRecord, GlobalTestRecord};

use super::result::{EstimatedBody, MechanismCalibration, not_converged};

impl MechanismCalibration {
    /// The record of this calibration ([`MechanismCalibration::into_record`]
    /// of a copy).
    pub fn record(&self) -> MechanismCalibrationRecord {
        self.clone().into_record()
    }

    /// This calibration as its record, each observation's rows moved into
    /// it rather than copied (at 10^6 observations, the copy would be
    /// most of the memory).
    pub fn into_record(self) -> MechanismCalibrationRecord {
        let ratio = |k: usize| {
            self.identifiability
                .as_ref()
                .and_then(|i| i.sigma_ratio.get(k).copied().flatten())
        };
        let finite = |v: f64| v.is_finite().then_some(v);
        let parameters = self
            .parameters
            .iter()
            .enumerate()
            .map(|(k, p)| ParameterRecord {
                name: p.name.clone(),
                unit: p.unit.clone(),
                group: p.group.clone(),
                value: p.value,
                sigma: p.sigma,
                prior_mean: p.prior.mean,
                prior_sigma: p.prior.sigma,
                sigma_ratio: ratio(k),
            })
            .collect();
        let observations = self.observations.into_records();
        let removed = self
            .removals
            .iter()
            .map(|r| RemovalRecord {
                kind: r.observation.kind.name().to_string(),
                index: r.observation.index,
                row: r.row,
                normalised: r.normalised,
                variance_factor_before: finite(r.variance_factor_before),
                variance_factor_after: finite(r.variance_factor_after),
            })
            .collect();
        MechanismCalibrationRecord {
            mechanism: self.mechanism,
            provenance: None,
            print_radius: self.print_radius,
            elasticity: self.elasticity,
            status: format!("{:?}", self.status),
            iterations: self.iterations,
            accepted: self.verdict.accepted,
            reasons: self.reasons,
            warnings: self.warnings,
            parameters,
            covariance: self.covariance.as_ref().map(rows),
            prior_correlation: self.prior_correlation.as_ref().map(rows),
            global_test: self.global_test.map(|t| GlobalTestRecord {
                cost: t.cost,
                redundancy: t.redundancy,
                variance_factor: t.variance_factor,
                level: t.level,
                interval: [t.interval.0, t.interval.1],
                outcome: t.outcome.name().to_string(),
            }),
            tests: TestsRecord {
                alpha: self.alpha,
                data_rows: self.data_rows,
                tests: (self.tests != self.data_rows).then_some(self.tests),
                critical_value: self.critical_value,
                observations,
                removed,
                snooping_stopped: self.snooping_stopped,
            },
            identifiability: self
                .identifiability
                .as_ref()
                .map(|i| IdentifiabilityRecord {
                    gauge: i.gauge.clone(),
                    undetermined: i
                        .undetermined
                        .iter()
                        .map(|u| UndeterminedRecord {
                            components: u.components.clone(),
                            data_to_prior: finite(u.data_to_prior),
                        })
                        .collect(),
                    statements: i.statements.clone(),
                }),
            balls: self
                .balls
                .iter()
                .map(|b| BallRecord {
                    centre: b.centre,
                    centre_sigma: b.centre_sigma,
                    radius: b.radius,
                    radius_sigma: b.radius_sigma,
                })
                .collect(),
            mirrored: self
                .mirrored
                .iter()
                .map(|m| MirroredRecord {
                    ball: m.ball,
                    iteration: m.iteration,
                    chi_square: m.chi_square,
                    gain: m.gain,
                    centre: m.centre,
                })
                .collect(),
            gauss_newton: self.gauss_newton.as_ref().map(|run| RunAwayRecord {
                status: not_converged(&run.status),
                iterations: run.iterations,
                cost: [finite(run.initial_cost), finite(run.final_cost)],
            }),
            trackers: self
                .trackers
                .iter()
                .map(|t| TrackerRecord {
                    label: t.label.clone(),
                    frame: FrameRecord::of(&t.frame),
                    sigma: t.sigma(),
                    offsets: t.offsets.iter().map(|&(value, _)| value).collect(),
                    offset_sigmas: (!t.offsets.is_empty())
                        .then(|| t.offsets.iter().map(|&(_, sigma)| sigma).collect())
                        .flatten(),
                    body: t.body.as_ref().map(body_record),
                })
                .collect(),
            body: self.body.as_ref().map(body_record),
            observation: self.observation.map(|o| o.to_string()),
        }
    }
}

/// A body frame's record.
fn body_record(body: &EstimatedBody) -> BodyRecord {
    BodyRecord {
        frame: FrameRecord::of(&body.frame),
        sigma: body.sigma(),
    }
}

/// A matrix row by row.
fn rows(matrix: &DMatrix<f64>) -> Vec<Vec<f64>> {
    matrix
        .row_iter()
        .map(|row| row.iter().copied().collect())
        .collect()
}
