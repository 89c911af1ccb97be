//! A mechanism calibration's problem ([`MechanismProblem`], whose module
//! doc gives its blocks) as the solver takes it ([`Problem`]): the sizes
//! of its blocks, each point's rows, the global observations' rows in
//! their order, and the priors on the global block and on each group.

use std::ops::Range;

use nalgebra::{Const, DMatrix, DVector, Dyn, OMatrix, SVector, Vector3};
use parcal_kinematics::mechanism::MechanismError;
use parcal_observe::mechanism::Rows;
use parcal_solver::{GaussianPrior, GlobalObservations, Loss, Problem};

use super::error::{MechanismCalibrationError, failed};
use super::observation::{ObservationKind, ObservationRef};
use super::problem::{Local, MechanismProblem, UNUSED, block};
use super::reaches::Reaches;
use super::warm_start::WarmStart;

/// Groups of `C` unknowns, points of one row (module doc).
impl<const C: usize> Problem<C, 0, 1> for MechanismProblem<'_, C> {
    type PointCache = WarmStart;
    type Workspace = Reaches;
    type Anchor = ();
    type Error = MechanismCalibrationError;
    type Jacobian = OMatrix<f64, Const<1>, Dyn>;
    type Global = DVector<f64>;

    fn global_size(&self) -> usize {
        self.global_len()
    }

    fn prepare_global(&self, global: &DVector<f64>) -> DVector<f64> {
        global.clone()
    }

    fn n_groups(&self) -> usize {
        self.data.observations.samples.len() + self.ball_points.len()
    }

    /// A tied ball's block: its unknowns are global (module doc).
    fn group_is_fixed(&self, k: usize) -> bool {
        k.checked_sub(self.data.observations.samples.len())
            .is_some_and(|b| self.tied.column(b).is_some())
    }

    fn group_points(&self, k: usize) -> Range<usize> {
        let samples = self.data.observations.samples.len();
        if k < samples {
            let a = self.actuators();
            k * a..(k + 1) * a
        } else {
            self.ball_points[k - samples].clone()
        }
    }

    /// No pose yet: a touch at readings first starts from the
    /// mechanism's [`Mechanism::start_pose`].
    fn initial_cache(&self, _i: usize) -> WarmStart {
        WarmStart::default()
    }

    /// The row of point `i` at its group's block (module doc).
    fn linearize(
        &self,
        i: usize,
        global: &DVector<f64>,
        group: &SVector<f64, C>,
        _point: &SVector<f64, 0>,
        cache: &mut WarmStart,
        out: &mut Local<C>,
    ) -> Result<(), MechanismCalibrationError> {
        let caches = std::slice::from_mut(cache);
        let out = std::slice::from_mut(out);
        self.fill(i, global, group, caches, out, &mut Reaches::default())
            .map_err(|(_, e)| e)
    }

    /// A sample's rows of the batch from one evaluation.
    fn linearize_batch(
        &self,
        first: usize,
        global: &DVector<f64>,
        group: &SVector<f64, C>,
        _points: &[SVector<f64, 0>],
        caches: &mut [WarmStart],
        out: &mut [Local<C>],
        reaches: &mut Reaches,
    ) -> Result<(), (usize, MechanismCalibrationError)> {
        self.fill(first, global, group, caches, out, reaches)
    }

    /// A group's rows along the step ([`MechanismProblem::fill_along`]):
    /// its touches' `d_global` not written, each touch's cache at the pose
    /// predicted after the step.
    fn linearize_along_batch(
        &self,
        first: usize,
        global: &DVector<f64>,
        group: &SVector<f64, C>,
        _points: &[SVector<f64, 0>],
        caches: &mut [WarmStart],
        dg: &DVector<f64>,
        out: &mut [Local<C>],
        steps: &mut [SVector<f64, 1>],
        _anchors: &mut [()],
        reaches: &mut Reaches,
    ) -> Result<(), (usize, MechanismCalibrationError)> {
        self.fill_along(first, global, group, caches, dg, out, steps, reaches)
    }

    /// Every probe height's, part distance's, measured point's, measured
    /// quantity's, ball distance's and tracker point's rows (module doc).
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
        for (k, manual) in o.manual_heights.iter().enumerate() {
            put(
                ObservationKind::ManualHeight,
                k,
                manual.evaluate(mechanism, params, configured),
            )?;
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
        for (k, distance) in o.ball_distances.iter().enumerate() {
            let id = ObservationRef {
                kind: ObservationKind::BallDistance,
                index: k,
            };
            let (Some(a), Some(b)) = (
                self.tied.column(distance.first),
                self.tied.column(distance.second),
            ) else {
                return Err(failed(id, "its balls' centres are not global unknowns"));
            };
            let centre = |c: usize| Vector3::from_column_slice(&global.as_slice()[c..c + 3]);
            let evaluated = distance
                .evaluate(&centre(a), &centre(b))
                .map_err(|e| failed(id, e))?;
            out.residual[row] = evaluated.residual;
            let mut jacobian = out.jacobian.row_mut(row);
            jacobian.columns_mut(a, 3).copy_from(&evaluated.d_first);
            jacobian.columns_mut(b, 3).copy_from(&evaluated.d_second);
            row += 1;
        }
        for (k, point) in o.tracker_points.iter().enumerate() {
            let id = ObservationRef {
                kind: ObservationKind::TrackerPoint,
                index: k,
            };
            let frame = self.trackers.frame(point.tracker, global);
            let offsets = self.trackers.offsets(point.tracker, global);
            let evaluated = point
                .evaluate(mechanism, params, configured, &frame, offsets, None)
                .map_err(|e| failed(id, e))?;
            out.residual
                .rows_mut(row, 3)
                .copy_from(&evaluated.rows.residual);
            out.jacobian
                .view_mut((row, 0), (3, n))
                .copy_from(&evaluated.rows.d_params);
            let columns = self.trackers.columns(point.tracker);
            out.jacobian
                .view_mut((row, columns.start), (3, columns.len()))
                .copy_from(&evaluated.d_frame);
            if let (Some(columns), Some(d_offsets)) = (
                self.trackers.offset_columns(point.tracker),
                &evaluated.d_offsets,
            ) {
                out.jacobian
                    .view_mut((row, columns.start), (3, columns.len()))
                    .copy_from(d_offsets);
            }
            row += 3;
        }
        for (k, pose) in o.tracker_poses.iter().enumerate() {
            let id = ObservationRef {
                kind: ObservationKind::TrackerPose,
                index: k,
            };
            let (Some(body), Some(body_columns)) = (
                self.trackers.body_of(pose.tracker, global),
                self.trackers.body_columns(),
            ) else {
                return Err(failed(id, "the body frame is not an unknown"));
            };
            let frame = self.trackers.frame(pose.tracker, global);
            let offsets = self.trackers.offsets(pose.tracker, global);
            let evaluated = pose
                .evaluate(mechanism, params, &frame, &body, offsets)
                .map_err(|e| failed(id, e))?;
            let m = evaluated.rows.residual.len();
            out.residual
                .rows_mut(row, m)
                .copy_from(&evaluated.rows.residual);
            let mut put = |columns: Range<usize>, d: &DMatrix<f64>| {
                out.jacobian
                    .view_mut((row, columns.start), (m, columns.len()))
                    .copy_from(d);
            };
            put(0..n, &evaluated.rows.d_params);
            put(self.trackers.columns(pose.tracker), &evaluated.d_frame);
            put(body_columns, &evaluated.d_body);
            // A body shift adds to the body's correction: the same columns.
            let shift = self.trackers.body_shift(pose.tracker);
            if let Some(start) = shift.rotation {
                put(
                    start..start + 3,
                    &evaluated.d_body.columns(0, 3).into_owned(),
                );
            }
            if let Some(start) = shift.origin {
                put(
                    start..start + 3,
                    &evaluated.d_body.columns(3, 3).into_owned(),
                );
            }
            if let (Some(columns), Some(d_offsets)) = (
                self.trackers.offset_columns(pose.tracker),
                &evaluated.d_offsets,
            ) {
                put(columns, d_offsets);
            }
            row += m;
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

    /// A measured pose's coordinates with their sigmas; a ball's centre
    /// prior; with `C` 4, an uncertain ball's radius with its calibration
    /// sigma, and the unit prior of every unused fourth unknown (module
    /// doc).
    fn group_prior(&self, k: usize) -> Option<GaussianPrior<Const<C>>> {
        let o = &self.data.observations;
        let (mean, sigma) = match o.samples.get(k) {
            Some(sample) => match sample.known_pose {
                Some((pose, sigma)) => (
                    block(&Vector3::from(pose), 0.0),
                    block(&Vector3::from(sigma), UNUSED),
                ),
                None if C == 4 => (
                    SVector::zeros(),
                    block(&Vector3::repeat(f64::INFINITY), UNUSED),
                ),
                None => return None,
            },
            None => {
                let b = k - o.samples.len();
                let ball = &o.balls[b];
                // A tied ball's priors are on its global unknowns.
                if self.tied.column(b).is_some() || (ball.centre_prior.is_none() && C == 3) {
                    return None;
                }
                let (centre, sigma) = ball
                    .centre_prior
                    .map_or((Vector3::zeros(), f64::INFINITY), |prior| {
                        (Vector3::from(prior.centre), prior.sigma)
                    });
                (
                    block(&centre, ball.radius),
                    block(&Vector3::repeat(sigma), ball.radius_sigma.unwrap_or(UNUSED)),
                )
            }
        };
        Some(GaussianPrior::from_sigmas(mean, sigma))
    }
}
