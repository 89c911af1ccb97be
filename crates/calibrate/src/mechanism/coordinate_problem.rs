//! A mechanism calibration whose ball touches are observed by their
//! coordinates (paper eq. 10) as the solver's problem.
//!
//! The global block, the global observations, the balls' blocks and every
//! prior are those of the radius observation's problem
//! ([`super::problem`]). Each touch is a point of three rows,
//! `L⁻¹ (C + ρ u(θ) − T)` ([`BallTouch::coordinate_rows`]), with two
//! unknowns of its own, its contact angles `θ`, eliminated with its ball's
//! block by the Schur complement. Its chart is fixed at the start: about
//! its approach's direction when it has one, else about the direction of
//! its tool point from its ball's start centre ([`BallTouch::chart`]); its
//! angles start at zero, with the prior `N(0, σ_θ² I)` of its approach.
//!
//! Point samples have no place here (their rows are one per actuator):
//! [`check_observation`] refuses them.

use std::ops::Range;

use nalgebra::{Const, DVector, Dyn, SMatrix, SVector, U2, UnitVector3, Vector2, Vector3};
use parcal_kinematics::mechanism::{MechanismError, Reached, ReachedAlong};
use parcal_observe::{CoordinateJacobians, DirectionChart, unit_direction};
use parcal_solver::{
    GaussianPrior, GlobalObservations, Linearization, LocalRows, Loss, Problem, State, filled,
};
use rayon::prelude::*;

use super::data::MechanismData;
use super::error::MechanismCalibrationError;
use super::options::MechanismOptions;
use super::problem::{FitProblem, MechanismProblem, Start};
use super::reaches::Reaches;
use super::touch_jacobian::TouchJacobian;
use super::touched_ball::{TouchedBall, put_group_columns, touch_failed};
use super::warm_start::WarmStart;
use crate::options::Observation;

/// A touch point's linearisation: groups of `C` unknowns, two angles,
/// three rows, its global columns in factored form.
type Local<const C: usize> = Linearization<C, 2, 3, TouchJacobian>;

/// Refuses point samples under the coordinate observation (module doc).
pub(crate) fn check_observation(
    data: &MechanismData,
    options: &MechanismOptions,
) -> Result<(), MechanismCalibrationError> {
    if options.observation == Observation::Coordinates && !data.observations.samples.is_empty() {
        return Err(MechanismCalibrationError::InvalidData {
            what: "point samples".to_string(),
            reason: "the coordinate observation (eq. 10) takes ball touches; calibrate point samples with the radius observation (eq. 9)".to_string(),
        });
    }
    Ok(())
}

/// The problem of [`MechanismData`] under the coordinate observation
/// (module doc), its local blocks of `C` unknowns.
pub(crate) struct CoordinateProblem<'a, const C: usize> {
    base: MechanismProblem<'a, C>,
    /// Each touch point's chart's direction `u0`, in the order of the
    /// points.
    directions: Vec<UnitVector3<f64>>,
}

impl<'a, const C: usize> CoordinateProblem<'a, C> {
    /// The problem of `data` (validated, without point samples) with `loss`
    /// on its observations, and the solver's start (the radius problem's,
    /// every angle zero) with every point's cache there. An error names a
    /// touch whose chart cannot be formed (its tool point at its ball's
    /// start centre, or an approach direction of zero length).
    pub(crate) fn start(
        data: &'a MechanismData,
        loss: Loss,
    ) -> Result<(Self, State<C, 2>, Vec<WarmStart>), MechanismCalibrationError> {
        let base = MechanismProblem::new(data, loss)?;
        let Start {
            state,
            caches,
            tips,
        } = base.start_state()?;
        let touches = &data.observations.touches;
        // Each touch's chart on the threads, into its place; of the touches
        // whose chart fails, the first named.
        let mut directions = filled(UnitVector3::new_unchecked(Vector3::z()), tips.len());
        let failed = (directions.par_iter_mut().enumerate())
            .filter_map(|(i, direction)| {
                let t = base.touch_at(i);
                let touch = &touches[t];
                let b = data.observations.samples.len() + touch.ball;
                let ball = base.touched_ball(touch.ball, &state.global, &state.groups[b]);
                match touch.chart(&(tips[i] - ball.centre)) {
                    Ok(chart) => {
                        *direction = UnitVector3::new_unchecked(chart.reference());
                        None
                    }
                    Err(e) => Some((i, touch_failed(t, touch.ball, e))),
                }
            })
            .min_by_key(|&(i, _)| i);
        if let Some((_, error)) = failed {
            return Err(error);
        }
        let state = State {
            points: vec![SVector::zeros(); directions.len()],
            global: state.global,
            groups: state.groups,
        };
        Ok((Self { base, directions }, state, caches))
    }

    /// The rows of touch point `i` that reached `reached` at its angles
    /// `angles` on its ball `ball` into `out`, the warm start of the pose
    /// it reached left in `cache`: its `dT/dp |_q` goes to `out`, whose
    /// room takes its place in `reached`.
    fn touch_rows(
        &self,
        i: usize,
        ball: &TouchedBall,
        angles: &Vector2<f64>,
        reached: &mut Result<Reached, MechanismError>,
        cache: &mut WarmStart,
        out: &mut Local<C>,
    ) -> Result<(), MechanismCalibrationError> {
        let (t, touch) = self.base.touch_of(i);
        let failed = |e: &MechanismError| touch_failed(t, touch.ball, e);
        let reached = reached.as_mut().map_err(|e| failed(e))?;
        let chart = DirectionChart::about(&self.directions[i]);
        let rows = touch.coordinate_rows(&reached.point, &chart, &ball.centre, ball.radius, angles);
        let rows = rows.map_err(|e| failed(&e))?;
        *cache = WarmStart::of(reached.warm_start.as_slice());
        put_local(out, &rows, ball);
        // `dT/dp` to the solver, the room it held left for the next batch.
        let tied = ball.tied.map(|column| (column, ball.uncertain));
        out.d_global.set(&rows, &mut reached.d_params, tied);
        Ok(())
    }

    /// [`CoordinateProblem::touch_rows`] of a touch reached along the
    /// global step `dg` (`along`, [`MechanismProblem::reach_along`]): its
    /// rows but `d_global` into `out`, the warm start predicted after the
    /// step left in `cache`; returns `d_global · dg` and its anchor, the
    /// tool point plus `dT/dp · dp`.
    #[allow(clippy::too_many_arguments)]
    fn touch_rows_along(
        &self,
        i: usize,
        ball: &TouchedBall,
        angles: &Vector2<f64>,
        along: &Result<ReachedAlong, MechanismError>,
        dg: &DVector<f64>,
        cache: &mut WarmStart,
        out: &mut Local<C>,
    ) -> Result<(SVector<f64, 3>, Vector3<f64>), MechanismCalibrationError> {
        let (t, touch) = self.base.touch_of(i);
        let failed = |e: &MechanismError| touch_failed(t, touch.ball, e);
        let along = along.as_ref().map_err(&failed)?;
        let chart = DirectionChart::about(&self.directions[i]);
        let point = &along.reached.point;
        let rows = touch.coordinate_rows(point, &chart, &ball.centre, ball.radius, angles);
        let rows = rows.map_err(|e| failed(&e))?;
        *cache = WarmStart::of(along.predicted.as_slice());
        put_local(out, &rows, ball);
        let tip_step = along.reached.d_params.apply(&[1.0]);
        let step = rows.d_tip * tip_step + ball.tied_step(&rows.d_centre, &rows.d_radius, dg);
        Ok((step, point + tip_step))
    }

    /// The touch points `first..first + out.len()` (one ball's) at its
    /// block `group` and their angles `points`, with their caches and the
    /// worker's `reaches`.
    #[allow(clippy::too_many_arguments, reason = "Problem::linearize_batch's")]
    fn fill(
        &self,
        first: usize,
        global: &DVector<f64>,
        group: &SVector<f64, C>,
        points: &[SVector<f64, 2>],
        caches: &mut [WarmStart],
        out: &mut [Local<C>],
        reaches: &mut Reaches,
    ) -> Result<(), (usize, MechanismCalibrationError)> {
        self.base
            .reach(first..first + out.len(), global, caches, reaches);
        let ball = self.base.group_ball(first, global, group);
        let each = reaches.at.iter_mut().zip(points).zip(caches).zip(out);
        for (j, (((reached, angles), cache), out)) in each.enumerate() {
            self.touch_rows(first + j, &ball, angles, reached, cache, out)
                .map_err(|e| (first + j, e))?;
        }
        Ok(())
    }
}

/// A touch's rows but `d_global` into `out` ([`put_rows`]).
fn put_local<const C: usize>(out: &mut Local<C>, rows: &CoordinateJacobians, ball: &TouchedBall) {
    put_rows(
        rows,
        ball,
        (&mut out.residual, &mut out.d_group, &mut out.d_point),
    );
}

/// A touch's rows but `d_global` into their places: its residual, its
/// angles' columns and, when its ball is in its group, its ball's
/// ([`put_group_columns`]), the group's other columns zero.
fn put_rows<const C: usize>(
    rows: &CoordinateJacobians,
    ball: &TouchedBall,
    (residual, d_group, d_angles): (
        &mut SVector<f64, 3>,
        &mut SMatrix<f64, 3, C>,
        &mut SMatrix<f64, 3, 2>,
    ),
) {
    *residual = rows.residual;
    d_group.fill(0.0);
    *d_angles = rows.d_angles;
    if ball.tied.is_none() {
        put_group_columns(d_group, ball, &rows.d_centre, &rows.d_radius);
    }
}

/// A re-seeded ball's touches are charted again (module doc): about the
/// direction of their tool point from its new centre, their angles zero;
/// a touch with an approach keeps its chart, its angles those of that
/// direction.
impl<const C: usize> FitProblem<C, 2, 3> for CoordinateProblem<'_, C> {
    fn base(&self) -> &MechanismProblem<'_, C> {
        &self.base
    }

    fn reseed(
        &mut self,
        state: &mut State<C, 2>,
        b: usize,
        centre: &Vector3<f64>,
        tips: &[Vector3<f64>],
    ) {
        self.base
            .place_ball(b, centre, &mut state.global, &mut state.groups);
        let k = self.base.data().observations.samples.len() + b;
        let points = Problem::<C, 0, 1>::group_points(&self.base, k);
        for (i, tip) in points.zip(tips) {
            let touch = &self.base.data().observations.touches[self.base.touch_at(i)];
            let direction = tip - centre;
            match (touch.approach, unit_direction(&direction)) {
                (None, Ok(u0)) => {
                    self.directions[i] = u0;
                    state.points[i] = Vector2::zeros();
                }
                (Some(_), _) | (None, Err(_)) => {
                    let chart = DirectionChart::about(&self.directions[i]);
                    state.points[i] = chart.angles_of(&direction);
                }
            }
        }
    }
}

/// Groups of `C` unknowns, points of two angles and three rows (module
/// doc).
impl<const C: usize> Problem<C, 2, 3> for CoordinateProblem<'_, C> {
    type PointCache = WarmStart;
    type Workspace = Reaches;
    /// A touch's tool point at the new parameters, to first order: its
    /// rows there take nothing else of the global block.
    type Anchor = Vector3<f64>;
    type Error = MechanismCalibrationError;
    type Jacobian = TouchJacobian;
    type Global = DVector<f64>;

    fn global_size(&self) -> usize {
        self.base.global_len()
    }

    fn prepare_global(&self, global: &DVector<f64>) -> DVector<f64> {
        global.clone()
    }

    fn n_groups(&self) -> usize {
        Problem::<C, 0, 1>::n_groups(&self.base)
    }

    fn group_is_fixed(&self, k: usize) -> bool {
        Problem::<C, 0, 1>::group_is_fixed(&self.base, k)
    }

    fn group_points(&self, k: usize) -> Range<usize> {
        Problem::<C, 0, 1>::group_points(&self.base, k)
    }

    fn initial_cache(&self, i: usize) -> WarmStart {
        Problem::<C, 0, 1>::initial_cache(&self.base, i)
    }

    fn linearize(
        &self,
        i: usize,
        global: &DVector<f64>,
        group: &SVector<f64, C>,
        point: &SVector<f64, 2>,
        cache: &mut WarmStart,
        out: &mut Local<C>,
    ) -> Result<(), MechanismCalibrationError> {
        self.fill(
            i,
            global,
            group,
            std::slice::from_ref(point),
            std::slice::from_mut(cache),
            std::slice::from_mut(out),
            &mut Reaches::default(),
        )
        .map_err(|(_, e)| e)
    }

    /// A ball's touches together ([`MechanismProblem::reach`]).
    fn linearize_batch(
        &self,
        first: usize,
        global: &DVector<f64>,
        group: &SVector<f64, C>,
        points: &[SVector<f64, 2>],
        caches: &mut [WarmStart],
        out: &mut [Local<C>],
        reaches: &mut Reaches,
    ) -> Result<(), (usize, MechanismCalibrationError)> {
        self.fill(first, global, group, points, caches, out, reaches)
    }

    /// A ball's touches along the step
    /// ([`CoordinateProblem::touch_rows_along`]): their `d_global` not
    /// written, each touch's cache at the warm start predicted after the
    /// step, its anchor its tool point plus `dT/dp · dp`.
    fn linearize_along_batch(
        &self,
        first: usize,
        global: &DVector<f64>,
        group: &SVector<f64, C>,
        points: &[SVector<f64, 2>],
        caches: &mut [WarmStart],
        dg: &DVector<f64>,
        out: &mut [Local<C>],
        steps: &mut [SVector<f64, 3>],
        anchors: &mut [Vector3<f64>],
        reaches: &mut Reaches,
    ) -> Result<(), (usize, MechanismCalibrationError)> {
        let batch = first..first + out.len();
        self.base.reach_along(batch, global, dg, caches, reaches);
        let ball = self.base.group_ball(first, global, group);
        let each = (reaches.along.iter().zip(points))
            .zip(caches.iter_mut().zip(out))
            .zip(steps.iter_mut().zip(anchors));
        for (j, (((along, angles), (cache, out)), (step, anchor))) in each.enumerate() {
            (*step, *anchor) = self
                .touch_rows_along(first + j, &ball, angles, along, dg, cache, out)
                .map_err(|e| (first + j, e))?;
        }
        Ok(())
    }

    /// Touch point `i`'s rows ([`BallTouch::coordinate_rows`]) at the tool
    /// point `anchor`, its ball's block `group` and its angles `point`;
    /// none for a tied ball.
    fn local_rows(
        &self,
        i: usize,
        anchor: &Vector3<f64>,
        group: &SVector<f64, C>,
        point: &SVector<f64, 2>,
        out: &mut LocalRows<C, 2, 3>,
    ) -> Result<bool, MechanismCalibrationError> {
        let (t, touch) = self.base.touch_of(i);
        let Some(ball) = self.base.ball_in_group(touch.ball, group) else {
            return Ok(false);
        };
        let chart = DirectionChart::about(&self.directions[i]);
        let rows = touch.coordinate_rows(anchor, &chart, &ball.centre, ball.radius, point);
        let rows = rows.map_err(|e| touch_failed(t, touch.ball, e))?;
        put_rows(
            &rows,
            &ball,
            (&mut out.residual, &mut out.d_group, &mut out.d_point),
        );
        Ok(true)
    }

    fn global_observations(
        &self,
        global: &DVector<f64>,
        out: &mut GlobalObservations,
    ) -> Result<(), MechanismCalibrationError> {
        Problem::<C, 0, 1>::global_observations(&self.base, global, out)
    }

    fn loss(&self) -> Loss {
        Problem::<C, 0, 1>::loss(&self.base)
    }

    fn global_observation_rows(&self) -> Option<Vec<usize>> {
        Problem::<C, 0, 1>::global_observation_rows(&self.base)
    }

    fn global_prior(&self) -> Option<&GaussianPrior<Dyn>> {
        Problem::<C, 0, 1>::global_prior(&self.base)
    }

    fn group_prior(&self, k: usize) -> Option<GaussianPrior<Const<C>>> {
        Problem::<C, 0, 1>::group_prior(&self.base, k)
    }

    /// Its approach's `N(0, σ_θ² I)` (module doc).
    fn point_prior(&self, i: usize) -> Option<GaussianPrior<U2>> {
        let touch = &self.base.data().observations.touches[self.base.touch_at(i)];
        let sigma = touch.approach?.sigma;
        Some(GaussianPrior::from_sigmas(
            Vector2::zeros(),
            Vector2::repeat(sigma),
        ))
    }
}

#[cfg(test)]
mod tests {
    use nalgebra::{DMatrix, Vector3};
    use parcal_solver::{
        GlobalJacobian, SolverOptions, Status, dense_reference, linear_step, solve,
    };

    use super::*;
    use crate::mechanism::problem::tests::{sigmas_apart, small_delta, tied_delta};

    /// `data` without its point samples.
    fn touches_only(mut data: MechanismData) -> MechanismData {
        data.observations.samples.clear();
        data
    }

    /// The Schur complement's step and the solution's covariance against
    /// the dense reference, from the start moved by `offset` (the balls'
    /// blocks, a tied ball's global unknowns and every touch's angles).
    fn check_against_dense<const C: usize>(data: &MechanismData, offset: Vector3<f64>) {
        let (problem, mut state, _) = CoordinateProblem::<C>::start(data, Loss::Squared).unwrap();
        for group in &mut state.groups {
            for k in 0..3 {
                group[k] += offset[k];
            }
        }
        for (_, columns) in problem.base().tied().iter() {
            for k in 0..3 {
                state.global[columns.start + k] += offset[k];
            }
        }
        for (i, angles) in state.points.iter_mut().enumerate() {
            *angles = Vector2::new(0.01, -0.02) * (i as f64).sin();
        }
        let dense = dense_reference::solve::<C, 2, 3, _>(&problem, &state, 0.0).unwrap();
        let schur = linear_step::<C, 2, 3, _>(&problem, &state, &mut Vec::new(), 0.0, 64).unwrap();
        let scale = dense.step.global.amax();
        let global = (&schur.delta.global - &dense.step.global).amax();
        let groups = (schur.delta.groups.iter().zip(&dense.step.groups))
            .map(|(a, b)| (a - b).amax())
            .fold(0.0, f64::max);
        let points = (schur.delta.points.iter().zip(&dense.step.points))
            .map(|(a, b)| (a - b).amax())
            .fold(0.0, f64::max);
        // Steps of O(1) from two factorisations of a system of condition
        // ~1e8: agreement to ~1e-8 relative.
        assert!(
            global < 1e-7 * scale && groups < 1e-7 * scale && points < 1e-7 * scale,
            "{global:e} {groups:e} {points:e}"
        );
        let solution = solve::<C, 2, 3, _>(&problem, state, &SolverOptions::default(), &mut |_| {});
        assert_eq!(solution.status, Status::Converged);
        let covariance = solution.covariance.unwrap();
        let dense = dense_reference::solve::<C, 2, 3, _>(&problem, &solution.state, 0.0).unwrap();
        let reference = dense.global_covariance().unwrap();
        let error = (&covariance - &reference).amax();
        assert!(error < 1e-7 * reference.amax(), "{error:e}");
    }

    #[test]
    fn the_schur_step_and_covariance_match_the_dense_reference() {
        // Probes, part distances and two balls (the first with a centre
        // prior, the second with an uncertain radius: blocks of four).
        let data = touches_only(small_delta());
        check_against_dense::<4>(&data, Vector3::new(0.3, -0.2, 0.1));
        let mut exact = data.clone();
        exact.observations.balls[1].radius_sigma = None;
        check_against_dense::<3>(&exact, Vector3::new(0.3, -0.2, 0.1));
        // Both balls tied by a distance: their unknowns global.
        let tied = touches_only(tied_delta());
        check_against_dense::<4>(&tied, Vector3::new(0.3, -0.2, 0.1));
        // Every touch's angles with a prior about a direction of its own.
        let mut approached = exact;
        for (k, touch) in approached.observations.touches.iter_mut().enumerate() {
            let t = k as f64;
            touch.approach = Some(parcal_observe::mechanism::Approach {
                direction: [t.sin(), t.cos(), 2.0],
                sigma: 0.05,
            });
        }
        check_against_dense::<3>(&approached, Vector3::new(0.3, -0.2, 0.1));
    }

    /// Every touch's rows, as the problem linearises them, against central
    /// differences over the whole global block, its ball's block and its
    /// angles, for balls in their blocks and tied in the global block.
    #[test]
    fn the_touches_rows_match_central_differences() {
        for data in [touches_only(small_delta()), touches_only(tied_delta())] {
            let (problem, state, _) = CoordinateProblem::<4>::start(&data, Loss::Squared).unwrap();
            let (g, h) = (state.global.len(), 1e-6);
            for k in 0..problem.n_groups() {
                for i in problem.group_points(k) {
                    let angles = Vector2::new(0.02, -0.01);
                    let at = |global: &DVector<f64>, group: &SVector<f64, 4>, angles| {
                        let mut out = Local::<4>::zeros(g);
                        let mut cache = WarmStart::default();
                        problem
                            .linearize(i, global, group, &angles, &mut cache, &mut out)
                            .unwrap();
                        out
                    };
                    let analytic = at(&state.global, &state.groups[k], angles);
                    let mut numeric = DMatrix::zeros(3, g + 4 + 2);
                    for j in 0..g + 6 {
                        let (mut gp, mut gm) = (state.global.clone(), state.global.clone());
                        let (mut bp, mut bm) = (state.groups[k], state.groups[k]);
                        let (mut ap, mut am) = (angles, angles);
                        match j {
                            _ if j < g => (gp[j], gm[j]) = (gp[j] + h, gm[j] - h),
                            _ if j < g + 4 => {
                                (bp[j - g], bm[j - g]) = (bp[j - g] + h, bm[j - g] - h)
                            }
                            _ => {
                                (ap[j - g - 4], am[j - g - 4]) =
                                    (ap[j - g - 4] + h, am[j - g - 4] - h)
                            }
                        }
                        let column =
                            (at(&gp, &bp, ap).residual - at(&gm, &bm, am).residual) / (2.0 * h);
                        numeric.set_column(j, &column);
                    }
                    let mut expected = DMatrix::zeros(3, g + 6);
                    let mut row = vec![0.0; g];
                    for r in 0..3 {
                        analytic.d_global.row(r, &mut row);
                        expected.view_mut((r, 0), (1, g)).copy_from_slice(&row);
                    }
                    expected
                        .view_mut((0, g), (3, 4))
                        .copy_from(&analytic.d_group);
                    expected
                        .view_mut((0, g + 4), (3, 2))
                        .copy_from(&analytic.d_point);
                    let error = (&numeric - &expected).amax();
                    // Steps of 1e-6 over residuals of ~1e3 (whitened by a
                    // 5 um sigma): rounding ~1e-13 / 1e-6 relative.
                    assert!(error < 1e-5 * expected.amax(), "point {i}: {error:e}");
                }
            }
        }
    }

    #[test]
    fn isotropic_coordinates_fit_as_the_radius_rows() {
        // Without angle priors and with W = σ² I, the angles take up the
        // tangential rows: the same minimum as the radius observation's.
        let data = touches_only(tied_delta());
        let radius = MechanismProblem::<4>::new(&data, Loss::Squared).unwrap();
        let start = radius.start_state().unwrap().state;
        let options = SolverOptions::default();
        let by_radius = solve::<4, 0, 1, _>(&radius, start, &options, &mut |_| {});
        let (coordinates, start, _) = CoordinateProblem::<4>::start(&data, Loss::Squared).unwrap();
        let by_coordinates = solve::<4, 2, 3, _>(&coordinates, start, &options, &mut |_| {});
        assert_eq!(by_radius.status, Status::Converged);
        assert_eq!(by_coordinates.status, Status::Converged);
        let covariance = by_radius.covariance.unwrap();
        let difference = sigmas_apart(
            &by_radius.state.global,
            &by_coordinates.state.global,
            &covariance,
        );
        // Both stop within the solver's tolerance of their sigmas.
        assert!(
            difference < 2.0 * parcal_solver::SIGMA_TOLERANCE,
            "{difference:e}"
        );
        let sigma = covariance.diagonal().map(f64::sqrt);
        let sigma_ratio = (by_coordinates.covariance.unwrap().diagonal().map(f64::sqrt))
            .component_div(&sigma)
            .map(|r| (r - 1.0).abs())
            .amax();
        assert!(sigma_ratio < 1e-6, "{sigma_ratio:e}");
    }

    #[test]
    fn point_samples_are_refused_under_the_coordinate_observation() {
        let data = small_delta();
        let options = MechanismOptions::default().with_observation(Observation::Coordinates);
        let error = check_observation(&data, &options).unwrap_err().to_string();
        assert!(error.contains("point samples"), "{error}");
        assert!(check_observation(&data, &MechanismOptions::default()).is_ok());
        assert!(check_observation(&touches_only(data), &options).is_ok());
    }
}
