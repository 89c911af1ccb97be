//! calibration.json's record of a run ([`CalibrationRun::record`]), built
//! in one place, and the calibration it holds as validation reads it.

use std::collections::BTreeMap;

use nalgebra::{DMatrix, DVector};
use parcal_dataset::{Actuator, CalibratedMachine, CentreEstimate, ParameterTable};
use parcal_kinematics::{Vec3, params};

use super::result::CalibrationRun;
use crate::instruments::run::geometry_record;
use crate::instruments::validate::Calibrated;
use crate::layout::ParameterGroup;
use crate::{CalibrateError, Method};

impl CalibrationRun {
    /// The global block's covariance as calibration.json records it: none
    /// when the run did not converge (its covariance at the last iterate is
    /// no posterior accuracy), and then no sigma either.
    fn posterior(&self) -> Option<&DMatrix<f64>> {
        self.global_covariance.as_ref().filter(|_| self.converged())
    }

    /// calibration.json's `parameters` and `covariance`: the global block's
    /// [`ParameterLayout::recorded`] parameters (the balls' unknowns are in
    /// `ball_centres`); the covariance empty without one (and when the
    /// run did not converge).
    fn parameter_table(&self) -> (ParameterTable, Vec<Vec<f64>>) {
        let names = self.names();
        let columns = self.layout.recorded();
        let sigmas = self.posterior().map_or_else(
            || DVector::zeros(self.global.len()),
            |c| c.diagonal().map(f64::sqrt),
        );
        let table = ParameterTable {
            names: columns.iter().map(|&k| names[k].clone()).collect(),
            values: columns.iter().map(|&k| self.global[k]).collect(),
            sigma: columns.iter().map(|&k| sigmas[k]).collect(),
        };
        let covariance = self.posterior().map_or_else(Vec::new, |c| {
            columns
                .iter()
                .map(|&a| columns.iter().map(|&b| c[(a, b)]).collect())
                .collect()
        });
        (table, covariance)
    }

    /// calibration.json's `machine`: with poses or points, the machine in
    /// the first session's frames
    /// ([`crate::instruments::InstrumentModel::calibrated_machine`]); with
    /// touches alone and unknown scales, the canonical geometry with the
    /// calibrated scales; else none (the design's actuators hold).
    fn calibrated_machine(&self) -> Option<CalibratedMachine> {
        let sigma = |k: usize| self.posterior().map_or(0.0, |c| c[(k, k)].sqrt());
        if let Some(i) = &self.instruments {
            let values = i.model.values(&self.global);
            let sigmas = DVector::from_fn(self.global.len(), |k, _| sigma(k));
            return Some(i.model.calibrated_machine(&values, &sigmas, &self.machine));
        }
        let range = self.layout.range(ParameterGroup::ActuatorScales)?;
        Some(CalibratedMachine {
            geometry: geometry_record(&params::from_params(&self.params)),
            actuator: Actuator {
                unit: self.machine.actuator.unit.clone(),
                scale: std::array::from_fn(|i| self.global[range.start + i]),
                scale_sigma: Some(std::array::from_fn(|i| sigma(range.start + i))),
            },
        })
    }

    /// The calibration.json record of this run, with `status`, the sentence
    /// of its status (`parcal_report::sentences::status`); a run that did
    /// not converge records no posterior covariance or sigma.
    pub fn record(&self, status: String) -> parcal_dataset::Calibration {
        let geometry = params::from_params(&self.params);
        let (parameters, covariance) = self.parameter_table();
        let converged = self.converged();
        let balls = &self.balls;
        let centre_sigmas = balls.centre_sigmas.as_ref().filter(|_| converged);
        let radius_sigmas = balls.radius_sigmas.as_ref().filter(|_| converged);
        let ball_centres = balls
            .ids
            .iter()
            .enumerate()
            .map(|(k, id)| {
                let sigma = centre_sigmas.map_or(Vec3::zeros(), |s| s[k]);
                let radius = balls.radii.as_ref().map(|r| r[k]);
                (
                    id.clone(),
                    CentreEstimate {
                        centre: balls.centres[k].into(),
                        sigma: sigma.into(),
                        radius,
                        radius_sigma: radius.map(|_| radius_sigmas.map_or(0.0, |s| s[k])),
                    },
                )
            })
            .collect();
        let iterations = self
            .history
            .iter()
            .map(|r| parcal_dataset::IterationSummary {
                cost: r.cost,
                step_norm: r.step_norm,
                residual_rms: self.rms_of(r),
            })
            .collect();
        // With touches, the observation equation, the weights, the radius
        // model and the loss; poses and points alone have their one
        // observation and weighting.
        let method = match self.options.method {
            Method::GaussNewton => "gauss-newton",
            Method::LevenbergMarquardt { .. } => "levenberg-marquardt",
        };
        let mut options = BTreeMap::from([("method".to_string(), method.into())]);
        if self.has_touches() {
            let given = &self.options;
            let weights = format!("{:?}", given.weighting).to_lowercase();
            for (name, value) in [
                ("observation", given.observation.to_string()),
                ("weights", weights),
                ("radius", given.radius.to_string()),
                ("loss", given.loss.to_string()),
            ] {
                options.insert(name.to_string(), value.into());
            }
        } else {
            options.insert("observation".to_string(), "instruments".into());
        }
        parcal_dataset::Calibration {
            canonical: geometry_record(&geometry),
            parameters,
            covariance,
            ball_centres,
            prior: self.options.prior.to_string(),
            iterations,
            converged: self.converged(),
            status,
            options,
            machine: self.calibrated_machine(),
            sessions: self.instruments.as_ref().map_or_else(Vec::new, |i| {
                i.model.session_records(&i.model.values(&self.global))
            }),
            verdict: String::new(),
            reasons: Vec::new(),
            warnings: Vec::new(),
            global_test: None,
            provenance: None,
            removed_observations: Vec::new(),
            down_weighted_observations: Vec::new(),
            design: Some(self.machine.clone()),
            diagnostics: None,
        }
    }
}

impl Calibrated {
    /// From a calibration of poses and points in memory (with or without
    /// ball touches): its numbers ([`CalibrationRun::record`]) as
    /// [`Calibrated::from_record`] reads them, with its global test.
    pub fn of_run(run: &CalibrationRun) -> Result<Self, CalibrateError> {
        let mut calibrated = Self::from_record(&run.record(String::new()))?;
        calibrated.global_test = run.global_test.map(|t| (t.cost, t.redundancy));
        Ok(calibrated)
    }
}
