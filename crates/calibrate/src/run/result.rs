//! The one result type of a calibration ([`CalibrationRun`]) and what it
//! answers about itself: convergence, verdict, names, sigmas.

use nalgebra::{DMatrix, DVector};
use parcal_dataset::Machine;
use parcal_kinematics::{Geometry, ParamCovariance, Params, Vec3};
use parcal_observe::KinematicPrior;
use parcal_solver::{IterationRecord, SpectrumDiagnostics, Status};

use crate::CalibrationOptions;
use crate::conflict::{ConflictTest, PaperPriorInconsistency};
use crate::fit::BallMisfit;
use crate::instruments::InstrumentResult;
use crate::layout::{ParameterGroup, ParameterLayout};
use crate::mirror::Mirrored;
use crate::reliability::Reliability;
use crate::run_away::RunAway;
use crate::verdict::{GlobalTest, Verdict};

/// The outcome of one calibration. What every run has (the options, the
/// design, the status and history, the global block and its covariance,
/// its layout and spectrum, the global test, the checks, the verdict) is
/// here; the touches' parts (balls, contacts, conflicts) are empty or
/// `None` for poses and points alone, and the poses' and points' parts
/// are in [`CalibrationRun::instruments`].
#[non_exhaustive]
pub struct CalibrationRun {
    /// What the run was asked to do.
    pub options: CalibrationOptions,
    /// The design geometry as given (machine.json's frames): where the
    /// accuracy maps place their targets.
    pub design: Geometry,
    /// machine.json as given (recorded in calibration.json's `design`).
    pub machine: Machine,
    /// The design's canonical parameters (the initial estimate).
    pub initial_params: Params,
    /// The a priori knowledge on the parameters, if any.
    pub prior: Option<KinematicPrior>,
    /// Identified parameters (canonical frames; poses alone hold the
    /// design's tool).
    pub params: Params,
    /// Posterior covariance of the 33 (inverse of the undamped reduced
    /// matrix at the final state; poses alone: the tool's rows from the
    /// prior conditional on the rest, which the data do not change);
    /// `None` when the run did not converge or the matrix is not positive
    /// definite.
    pub covariance: Option<ParamCovariance>,
    /// The identified global block ([`CalibrationRun::layout`]): the 33,
    /// the tied balls' unknowns, the scales and the instrument groups.
    pub global: DVector<f64>,
    /// Its posterior covariance (the 33's is its leading block).
    pub global_covariance: Option<DMatrix<f64>>,
    /// The calibrated balls of the touches (empty without touches).
    pub balls: CalibratedBalls,
    /// How the solver's run ended.
    pub status: Status,
    /// One record per iterate at which a step was computed, then the final
    /// iterate's ([`CalibrationRun::iterations`]).
    pub history: Vec<IterationRecord>,
    /// Whitened residual rows: contacts x rows per contact; without
    /// touches, 6 per pose and 3 per point.
    pub residual_rows: usize,
    /// measurements.csv row of each contact in the solver's (by-ball) order.
    pub rows: Vec<u32>,
    /// Spectrum of the reduced matrix at the end.
    pub spectrum: Option<SpectrumDiagnostics>,
    /// Prior-data conflict tests (kinematic parameters, ball centres) of a
    /// converged run ([`crate::verdict::at_minimum`]).
    pub conflicts: Vec<ConflictTest>,
    /// The global block: the kinematic parameters, then the centres of the
    /// balls tied by calibrated distances, then the groups of the poses and
    /// points if any ([`crate::mixed`]).
    pub layout: ParameterLayout,
    /// The calibrated distances (artefacts.json) used as observations.
    pub distances_used: usize,
    /// The poses and points, if the dataset has any (with touches:
    /// [`crate::mixed`]).
    pub instruments: Option<InstrumentResult>,
    /// Paper mode: the check of the diagonal prior against the propagated
    /// design tolerances ([`crate::conflict::paper_prior_consistency`]).
    pub prior_consistency: Option<PaperPriorInconsistency>,
    /// The global test at the final state ([`crate::verdict`]).
    pub global_test: Option<GlobalTest>,
    /// Every observation's check at the final state of a run that converged
    /// ([`crate::verdict::at_minimum`]); `None` otherwise.
    pub reliability: Option<Reliability>,
    /// When this is the Levenberg-Marquardt run made after a Gauss-Newton
    /// run ran away: how that run ended ([`calibrate`](crate::calibrate)).
    pub gauss_newton: Option<RunAway>,
}

/// The balls a calibration of touches identified, in artefacts.json's
/// order.
#[derive(Debug, Clone, Default)]
#[non_exhaustive]
pub struct CalibratedBalls {
    /// artefacts.json's ball ids.
    pub ids: Vec<String>,
    /// Identified centres (canonical base frame).
    pub centres: Vec<Vec3>,
    /// Marginal sigmas of the centres (with the parameters' uncertainty).
    pub centre_sigmas: Option<Vec<Vec3>>,
    /// Identified radii, when each ball's radius was an unknown
    /// ([`crate::RadiusModel::PerBall`]).
    pub radii: Option<Vec<f64>>,
    /// Their marginal sigmas.
    pub radius_sigmas: Option<Vec<f64>>,
    /// Balls whose contacts fit far worse than the noise allows
    /// ([`crate::fit`]) at the final iterate of a converged run
    /// ([`crate::verdict::at_minimum`]); empty when none is, or when the
    /// run did not converge.
    pub misfits: Vec<BallMisfit>,
    /// Balls that a settled iterate showed on the wrong side of their
    /// contacts, re-seeded at the mirror image of their centre fit before
    /// the calibration resumed ([`crate::mirror`]).
    pub mirrored: Vec<Mirrored>,
}

impl CalibrationRun {
    /// Whether the solver converged.
    pub fn converged(&self) -> bool {
        matches!(self.status, Status::Converged)
    }

    /// Whether the run calibrated ball touches (else poses and points
    /// alone).
    pub fn has_touches(&self) -> bool {
        !self.rows.is_empty()
    }

    /// The run's verdict ([`crate::verdict`]).
    /// With a robust loss, the test of data snooping is replaced by the
    /// number of observations it down-weighted ([`crate::robust`]).
    pub fn verdict(&self) -> Verdict {
        let outlier = self
            .reliability
            .as_ref()
            .is_some_and(|r| match &r.down_weighted {
                Some(down_weighted) => crate::robust::too_many(down_weighted),
                None => r.fails_snooping(crate::hypothesis::SNOOPING_LEVEL),
            });
        Verdict::new(&self.status, self.global_test, outlier)
    }

    /// Gauss-Newton iterations (linear solves; Levenberg-Marquardt: steps
    /// tried): one per record but the final iterate's, and that iterate's
    /// own when the run converged there (its step certified convergence
    /// and was not applied, as in Ceres). The independent reference
    /// implementation applies that last step and records one more iterate;
    /// both count the same solves.
    pub fn iterations(&self) -> usize {
        self.history.len().saturating_sub(1) + usize::from(self.converged())
    }

    /// The names of the global block's parameters
    /// ([`ParameterLayout::names`] with the balls' ids and the sessions'
    /// labels).
    pub fn names(&self) -> Vec<String> {
        let sessions = self
            .instruments
            .as_ref()
            .map_or(&[][..], |i| &i.model.sessions[..]);
        self.layout.names(&self.balls.ids, sessions)
    }

    /// Marginal sigmas of the parameters.
    pub fn sigmas(&self) -> Option<Params> {
        self.covariance.map(|c| c.diagonal().map(f64::sqrt))
    }

    /// Marginal sigmas of the global block.
    pub fn global_sigmas(&self) -> Option<DVector<f64>> {
        self.global_covariance
            .as_ref()
            .map(|c| c.diagonal().map(f64::sqrt))
    }

    /// The global block's parameters after the kinematic ones and the tied
    /// balls' (the actuator scales, the frames, the sessions' nuisances),
    /// named, with their values and sigmas (zero without a covariance);
    /// none without poses and points.
    pub fn instrument_parameters(&self) -> Vec<(String, f64, f64)> {
        if self.instruments.is_none() {
            return Vec::new();
        }
        let names = self.names();
        let sigmas = self
            .global_sigmas()
            .unwrap_or_else(|| DVector::zeros(self.global.len()));
        let first = self
            .layout
            .groups()
            .iter()
            .find(|(group, _)| {
                !matches!(
                    group,
                    ParameterGroup::Kinematic
                        | ParameterGroup::BallCentre { .. }
                        | ParameterGroup::BallRadius { .. }
                )
            })
            .map_or(self.global.len(), |(_, range)| range.start);
        (first..self.global.len())
            .map(|k| (names[k].clone(), self.global[k], sigmas[k]))
            .collect()
    }

    /// Condition number of the posterior covariance (ratio of the extreme
    /// eigenvalues of the reduced matrix); infinite when the data and prior
    /// leave a direction undetermined.
    pub fn condition_number(&self) -> Option<f64> {
        let spectrum = self.spectrum.as_ref()?;
        (!spectrum.eigenvalues.is_empty()).then(|| spectrum.condition_number())
    }

    /// RMS of the whitened residuals at the final iterate (1 at the noise
    /// level).
    pub fn residual_rms(&self) -> f64 {
        self.history.last().map_or(f64::NAN, |r| self.rms_of(r))
    }

    /// The RMS of the whitened residuals of `record` over the
    /// [`CalibrationRun::residual_rows`]: the touches' with touches (the
    /// poses and points beside them are global observations), else the
    /// poses' and points'.
    pub(super) fn rms_of(&self, record: &IterationRecord) -> f64 {
        let cost = if self.has_touches() {
            record.data_cost
        } else {
            record.global_observation_cost
        };
        (cost / self.residual_rows as f64).sqrt()
    }
}
