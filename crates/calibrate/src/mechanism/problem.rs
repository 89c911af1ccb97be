//! A mechanism calibration as the solver's problem.
//!
//! - The **global block**: the mechanism's parameters `p`, then the
//!   trigger height `h` when there are probe heights.
//! - The **global observations**: every probe height (1 row), part
//!   distance (1 row), measured point (3 rows) and measured quantity
//!   (1 row), in that order ([`parcal_observe::mechanism`]).
//! - The **points**: one per point sample, its pose (3 unknowns) eliminated
//!   by the Schur complement, `R` rows (one per actuator), with a Gaussian
//!   prior when the pose was measured. They all belong to one group whose
//!   block is fixed (the solver's groups carry no unknown here).
//! - The **prior** on the global block: each parameter's
//!   [`ParameterPrior`](super::data::ParameterPrior) with a sigma, and the
//!   trigger height's.

use std::ops::Range;

use nalgebra::{Const, DMatrix, DVector, Dyn, OMatrix, SVector, Vector3};
use parcal_kinematics::mechanism::MechanismError;
use parcal_observe::mechanism::Rows;
use parcal_solver::{GaussianPrior, GlobalObservations, Linearization, Loss, Problem};

use super::data::MechanismData;
use super::error::MechanismCalibrationError;
use super::observation::{ObservationKind, ObservationRef};

/// The problem of [`MechanismData`] (module doc).
pub(crate) struct MechanismProblem<'a> {
    data: &'a MechanismData,
    prior: Option<GaussianPrior<Dyn>>,
    loss: Loss,
}

impl<'a> MechanismProblem<'a> {
    /// The problem of `data` (validated) with `loss` on its observations.
    pub(crate) fn new(data: &'a MechanismData, loss: Loss) -> Self {
        let (mean, sigma) = global_prior_of(data);
        let prior = sigma
            .iter()
            .any(|s| s.is_finite())
            .then(|| GaussianPrior::from_sigmas(mean, sigma));
        Self { data, prior, loss }
    }

    /// The number of the mechanism's parameters (the first values of the
    /// global block).
    pub(crate) fn n_params(&self) -> usize {
        self.data.configured.len()
    }

    /// The size of the global block: the parameters and, with probe
    /// heights, the trigger height.
    pub(crate) fn global_len(&self) -> usize {
        self.n_params() + usize::from(self.data.has_trigger_height())
    }

    /// The global block's start: the priors' means.
    pub(crate) fn start(&self) -> DVector<f64> {
        global_prior_of(self.data).0
    }

    /// The prior information on the global block (zero where none).
    pub(crate) fn prior_information(&self) -> DMatrix<f64> {
        let g = self.global_len();
        self.prior
            .as_ref()
            .map_or_else(|| DMatrix::zeros(g, g), |p| p.information.clone())
    }

    /// The global observations, each with its number of rows, in the order
    /// of their rows.
    pub(crate) fn global_observation_refs(&self) -> Vec<(ObservationRef, usize)> {
        let o = &self.data.observations;
        let refs =
            |kind, count, rows| (0..count).map(move |index| (ObservationRef { kind, index }, rows));
        refs(ObservationKind::Probe, o.probes.len(), 1)
            .chain(refs(ObservationKind::Distance, o.distances.len(), 1))
            .chain(refs(ObservationKind::Point, o.points.len(), 3))
            .chain(refs(ObservationKind::Quantity, o.quantities.len(), 1))
            .collect()
    }

    /// The start of every point sample's pose: its measured pose, else
    /// the forward kinematics of its readings at `params`.
    pub(crate) fn start_poses(
        &self,
        params: &[f64],
    ) -> Result<Vec<Vector3<f64>>, MechanismCalibrationError> {
        let mechanism = self.data.mechanism.as_ref();
        let samples = &self.data.observations.samples;
        samples
            .iter()
            .enumerate()
            .map(|(index, sample)| {
                if let Some((pose, _)) = sample.known_pose {
                    return Ok(Vector3::from(pose));
                }
                let pose = mechanism
                    .forward(params, &sample.readings, &[0.0; 3])
                    .map_err(|e| MechanismCalibrationError::Observation {
                        observation: ObservationRef {
                            kind: ObservationKind::Sample,
                            index,
                        },
                        reason: format!("no start pose from its readings: {e}"),
                    })?;
                Ok(Vector3::new(pose[0], pose[1], pose[2]))
            })
            .collect()
    }
}

/// The global block's prior: means, and sigmas (infinite where there is
/// no prior).
fn global_prior_of(data: &MechanismData) -> (DVector<f64>, DVector<f64>) {
    let mut priors = data.priors.clone();
    if data.has_trigger_height() {
        priors.push(data.trigger_height);
    }
    let mean = DVector::from_iterator(priors.len(), priors.iter().map(|p| p.mean));
    let sigma = DVector::from_iterator(
        priors.len(),
        priors.iter().map(|p| p.sigma.unwrap_or(f64::INFINITY)),
    );
    (mean, sigma)
}

fn failed(observation: ObservationRef, error: impl std::fmt::Display) -> MechanismCalibrationError {
    MechanismCalibrationError::Observation {
        observation,
        reason: error.to_string(),
    }
}

/// `R` rows per point sample (one per actuator); the group block is a
/// fixed placeholder.
impl<const R: usize> Problem<1, 3, R> for MechanismProblem<'_> {
    type PointCache = ();
    type Workspace = ();
    type Error = MechanismCalibrationError;
    type Jacobian = OMatrix<f64, Const<R>, Dyn>;
    type Global = DVector<f64>;

    fn global_size(&self) -> usize {
        self.global_len()
    }

    fn prepare_global(&self, global: &DVector<f64>) -> DVector<f64> {
        global.clone()
    }

    fn n_groups(&self) -> usize {
        usize::from(!self.data.observations.samples.is_empty())
    }

    fn group_points(&self, _k: usize) -> Range<usize> {
        0..self.data.observations.samples.len()
    }

    fn group_is_fixed(&self, _k: usize) -> bool {
        true
    }

    fn initial_cache(&self, _i: usize) {}

    /// The rows of point sample `i` at its pose `point`.
    fn linearize(
        &self,
        i: usize,
        global: &DVector<f64>,
        _group: &SVector<f64, 1>,
        point: &SVector<f64, 3>,
        _cache: &mut (),
        out: &mut Linearization<1, 3, R, Self::Jacobian>,
    ) -> Result<(), MechanismCalibrationError> {
        let observation = ObservationRef {
            kind: ObservationKind::Sample,
            index: i,
        };
        let n = self.n_params();
        let rows = self.data.observations.samples[i]
            .evaluate(
                self.data.mechanism.as_ref(),
                &global.as_slice()[..n],
                point.as_slice(),
            )
            .map_err(|e| failed(observation, e))?;
        out.residual = SVector::from_iterator(rows.rows.residual.iter().copied());
        out.d_global.fill(0.0);
        out.d_global
            .columns_mut(0, n)
            .copy_from(&rows.rows.d_params);
        out.d_point.copy_from(&rows.d_pose);
        Ok(())
    }

    /// Every probe height's, part distance's, measured point's and
    /// measured quantity's rows (module doc).
    fn global_observations(
        &self,
        global: &DVector<f64>,
        out: &mut GlobalObservations,
    ) -> Result<(), MechanismCalibrationError> {
        let mechanism = self.data.mechanism.as_ref();
        let n = self.n_params();
        let params = &global.as_slice()[..n];
        let configured = self.data.configured.as_slice();
        let m = self
            .global_observation_refs()
            .iter()
            .map(|(_, rows)| rows)
            .sum();
        *out = GlobalObservations::zeros(m, global.len());
        let mut row = 0;
        let mut put = |kind, index, evaluated: Result<Rows, MechanismError>| {
            let rows = evaluated.map_err(|e| failed(ObservationRef { kind, index }, e))?;
            let m = rows.residual.len();
            out.residual.rows_mut(row, m).copy_from(&rows.residual);
            out.jacobian
                .view_mut((row, 0), (m, n))
                .copy_from(&rows.d_params);
            row += m;
            Ok::<usize, MechanismCalibrationError>(row - m)
        };
        let o = &self.data.observations;
        let mut trigger_rows = Vec::with_capacity(o.probes.len());
        for (k, probe) in o.probes.iter().enumerate() {
            let evaluated = probe.evaluate(mechanism, params, configured, global[n]);
            let d_trigger_height = evaluated.as_ref().map_or(0.0, |e| e.d_trigger_height);
            let at = put(ObservationKind::Probe, k, evaluated.map(|e| e.rows))?;
            trigger_rows.push((at, d_trigger_height));
        }
        for (k, distance) in o.distances.iter().enumerate() {
            put(
                ObservationKind::Distance,
                k,
                distance.evaluate(mechanism, params, configured),
            )?;
        }
        for (k, point) in o.points.iter().enumerate() {
            put(
                ObservationKind::Point,
                k,
                point.evaluate(mechanism, params, configured),
            )?;
        }
        for (k, quantity) in o.quantities.iter().enumerate() {
            put(
                ObservationKind::Quantity,
                k,
                quantity.evaluate(mechanism, params),
            )?;
        }
        for (at, d_trigger_height) in trigger_rows {
            out.jacobian[(at, n)] = d_trigger_height;
        }
        Ok(())
    }

    fn loss(&self) -> Loss {
        self.loss
    }

    fn global_observation_rows(&self) -> Option<Vec<usize>> {
        Some(
            self.global_observation_refs()
                .into_iter()
                .map(|(_, rows)| rows)
                .collect(),
        )
    }

    fn global_prior(&self) -> Option<&GaussianPrior<Dyn>> {
        self.prior.as_ref()
    }

    /// A measured pose's coordinates with their sigmas.
    fn point_prior(&self, i: usize) -> Option<GaussianPrior<Const<3>>> {
        let (pose, sigma) = self.data.observations.samples[i].known_pose?;
        Some(GaussianPrior::from_sigmas(
            Vector3::from(pose),
            Vector3::from(sigma),
        ))
    }
}

#[cfg(test)]
mod tests {
    use std::sync::Arc;

    use nalgebra::DVector;
    use parcal_kinematics::cable::{CableRobot, Elasticity};
    use parcal_kinematics::delta::{DeltaParams, LinearDelta, probe_height};
    use parcal_kinematics::mechanism::{Mechanism, design};
    use parcal_observe::mechanism::{MeasuredQuantity, PartDistance, PointSample, ProbeHeight};
    use parcal_solver::{SolverOptions, State, Status, dense_reference, linear_step, solve};

    use super::*;
    use crate::mechanism::data::Observations;

    /// A delta configured as designed, truly a few tenths off: 7 probe
    /// heights, 2 part distances, 3 point samples (the first at a measured
    /// pose).
    fn small_delta() -> MechanismData {
        let delta = LinearDelta::typical();
        let configured = design(&delta);
        let mut truth = DeltaParams::from_slice(configured.as_slice());
        truth.endstop = [0.3, -0.2, 0.1];
        truth.radius += 0.4;
        truth.angle = [0.2, -0.3, 0.1];
        truth.diagonal = [270.3, 269.8, 270.1];
        truth.tilt = [0.1, -0.15];
        let truth = truth.to_vector();
        let (p, c) = (truth.as_slice(), configured.as_slice());
        let probes = [
            [0.0, 0.0],
            [80.0, 0.0],
            [-40.0, 69.0],
            [-40.0, -69.0],
            [30.0, 30.0],
            [-50.0, 10.0],
            [10.0, -60.0],
        ]
        .iter()
        .map(|&[x, y]| ProbeHeight {
            commanded: [x, y, probe_height(&delta, p, c, x, y).unwrap() + 0.7],
            sigma: 0.01,
        })
        .collect();
        let distances = [
            ([-60.0, -20.0, 0.2], [60.0, 20.0, 0.2]),
            ([0.0, -70.0, 0.2], [0.0, 70.0, 0.2]),
        ]
        .iter()
        .map(|&(first, second)| PartDistance {
            first,
            second,
            distance: DVector::from_column_slice(&first)
                .metric_distance(&DVector::from_column_slice(&second))
                + 0.05,
            sigma: 0.02,
        })
        .collect();
        let samples = [
            [10.0, 20.0, 50.0],
            [-30.0, 40.0, 120.0],
            [50.0, -10.0, 80.0],
        ]
        .iter()
        .enumerate()
        .map(|(k, pose)| PointSample {
            readings: delta.inverse(p, pose).unwrap().iter().copied().collect(),
            sigma: 0.005,
            known_pose: (k == 0).then_some((*pose, [0.01; 3])),
            loads: None,
        })
        .collect();
        let observations = Observations {
            probes,
            distances,
            points: Vec::new(),
            samples,
            quantities: Vec::new(),
        };
        MechanismData::new(
            Arc::new(delta),
            configured.iter().copied().collect(),
            observations,
        )
        .with_trigger_height(0.6, Some(0.05))
    }

    /// A Hangprinter with elastic lines (one compliance), truly a few mm
    /// off its design: 14 samples under loads (3 at measured poses) and
    /// the four line lengths measured 3 mm long.
    fn small_cable() -> MechanismData {
        let robot = CableRobot::typical()
            .with_elasticity(Elasticity {
                compliance_of_line: vec![0; 4],
                zero_loads: vec![14.0; 4],
                compliance: 50.0,
                compliance_sigma: 50.0,
            })
            .unwrap();
        let configured = design(&robot);
        let truth = DVector::from_fn(configured.len(), |k, _| {
            configured[k] + 4.0 * ((k * 7) as f64).sin()
        });
        let samples = (0..14)
            .map(|k| {
                let t = k as f64;
                let pose = [300.0 * t.cos(), 250.0 * (1.3 * t).sin(), 80.0 * t];
                let loads = [12.0 + t, 15.0 - 0.5 * t, 10.0 + 0.3 * t, 20.0 + t];
                let (readings, _) = robot
                    .loaded_readings(truth.as_slice(), &pose, &loads)
                    .unwrap();
                PointSample {
                    readings: readings.iter().copied().collect(),
                    sigma: 1.0,
                    known_pose: (k % 5 == 0).then_some((pose, [0.1; 3])),
                    loads: Some(loads.to_vec()),
                }
            })
            .collect();
        let quantities = (0..4)
            .map(|quantity| MeasuredQuantity {
                quantity,
                value: robot.quantity(quantity, truth.as_slice()).unwrap().value + 3.0,
                sigma: 10.0,
            })
            .collect();
        let observations = Observations {
            samples,
            quantities,
            ..Observations::default()
        };
        MechanismData::new(
            Arc::new(robot),
            configured.iter().copied().collect(),
            observations,
        )
    }

    /// The Schur complement's step and the solution's covariance against
    /// the dense reference, from the start poses moved by `offset`.
    fn check_against_dense<const R: usize>(data: &MechanismData, offset: Vector3<f64>) {
        let problem = MechanismProblem::new(data, Loss::Squared);
        let start = problem.start();
        let n = problem.n_params();
        let poses = problem.start_poses(&start.as_slice()[..n]).unwrap();
        let state = State {
            global: start,
            groups: vec![SVector::zeros()],
            points: poses.iter().map(|p| p + offset).collect(),
        };
        let dense = dense_reference::solve::<1, 3, R, _>(&problem, &state, 0.0).unwrap();
        let schur = linear_step::<1, 3, R, _>(&problem, &state, &mut Vec::new(), 0.0, 64).unwrap();
        let global = (&schur.delta.global - &dense.step.global).amax();
        let points = schur
            .delta
            .points
            .iter()
            .zip(&dense.step.points)
            .map(|(a, b)| (a - b).amax())
            .fold(0.0, f64::max);
        // Steps of O(1) from two factorisations of a system of condition
        // ~1e8: agreement to ~1e-8 relative.
        let scale = dense.step.global.amax();
        assert!(
            global < 1e-7 * scale && points < 1e-7 * scale,
            "{global:e} {points:e}"
        );

        let solution = solve::<1, 3, R, _>(&problem, state, &SolverOptions::default(), &mut |_| {});
        assert_eq!(solution.status, Status::Converged);
        let covariance = solution.covariance.unwrap();
        let dense = dense_reference::solve::<1, 3, R, _>(&problem, &solution.state, 0.0).unwrap();
        let reference = dense.global_covariance().unwrap();
        let error = (&covariance - &reference).amax();
        assert!(error < 1e-7 * reference.amax(), "{error:e}");
    }

    #[test]
    fn the_schur_step_and_covariance_match_the_dense_reference() {
        check_against_dense::<3>(&small_delta(), Vector3::new(0.3, -0.2, 0.1));
    }

    #[test]
    fn loads_and_measured_quantities_match_the_dense_reference() {
        check_against_dense::<4>(&small_cable(), Vector3::new(3.0, -2.0, 1.0));
    }
}
