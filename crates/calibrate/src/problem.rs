//! The calibration as the solver sees it: one global block (the
//! [`ParameterLayout`]: the 33 kinematic parameters, then the unknowns of
//! the balls tied by calibrated distances), one group per ball (its centre
//! and, for a per-ball radius, its radius: `G` = 3 or 4; held fixed for a
//! ball whose unknowns are in the global block), one point per contact (its
//! two angles for the coordinate observation, none for the radius
//! observation), the distances as global observations, and the priors.
//!
//! Each contact's residual is its observation block (`parcal_observe`) at the
//! tool tip given by forward kinematics of the current parameters at the
//! contact's leg extensions `s_i q_i` (readings `q_i` in the actuators' unit,
//! scales `s_i` in mm per unit: known, or the layout's
//! [`ParameterGroup::ActuatorScales`]), whitened by the weight computed once
//! at the initial estimate. Forward kinematics starts from the pose the solver
//! keeps as the contact's point cache: the first time the design's forward
//! kinematics (from the set-up), then the first-order prediction of the pose
//! at the next iteration's parameters, made during the back-substitution.

use std::ops::Range;

use nalgebra::{Const, DMatrix, DVector, Dyn, SMatrix, SVector, U2, UnitVector3, Vector2, Vector6};
use parcal_dataset::Dataset;
use parcal_kinematics::forward_batch::{
    LANES, PivotOrder, forward_along_batch, forward_jacobian_batch, in_groups,
};
use parcal_kinematics::params::leg_index;
use parcal_kinematics::{
    ForwardOptions, Geometry, KinematicsError, N_PARAMS, Params, Pose, SolutionAlong,
    SolutionJacobian, Vec3, params,
};
use parcal_observe::{
    BlockJacobians, CoordinateBlock, CoordinateWhitening, DirectionChart, DistanceBlock,
    ObserveError, RadiusBlock, RadiusWhitening, Whitening,
};
use parcal_solver::{
    BATCH, GaussianPrior, GlobalJacobian, GlobalObservations, Linearization, LocalRows, Loss,
    Problem,
};

use crate::CalibrateError;
use crate::effect::Effect;
use crate::layout::{ParameterGroup, ParameterLayout, kinematic_params};
use crate::mixed::InstrumentObservations;
use crate::observation::ObservationId;

/// Paper eq. (9) for every contact.
pub struct RadiusObservations {
    /// The whitening of each contact's row (sorted order).
    pub weights: Vec<RadiusWhitening>,
}

/// Paper eq. (10) for every contact, the angles charted about each
/// contact's initial direction `u0`.
pub struct CoordinateObservations {
    /// `u0` of each contact (canonical base frame), from
    /// [`parcal_observe::unit_direction`].
    pub directions: Vec<UnitVector3<f64>>,
    /// The whitening of each contact's three rows (sorted order).
    pub weights: Vec<CoordinateWhitening>,
    /// Sigma of the angle prior of every contact (rad); `None`: no prior.
    pub angle_sigma: Option<f64>,
}

/// One kind of observation of every contact: `R` residual rows, `P` angles
/// per contact.
pub trait ContactObservations<const R: usize, const P: usize>: Sync {
    /// The block of contact `i` on a ball of `radius`, at the tool tip, the
    /// ball centre and the contact's angles, whitened by the contact's
    /// weight (paper eq. 5).
    fn block(
        &self,
        i: usize,
        radius: f64,
        tip: &Vec3,
        centre: &Vec3,
        angles: &SVector<f64, P>,
    ) -> Result<BlockJacobians<R, P>, ObserveError>;

    /// The prior on contact `i`'s angles, if any.
    fn angle_prior(&self, i: usize) -> Option<GaussianPrior<Const<P>>> {
        let _ = i;
        None
    }

    /// Contact `i`'s angles for the contact direction of `direction` (from
    /// the ball centre to the tip; any non-zero length).
    fn angles_toward(&self, i: usize, direction: &Vec3) -> Result<SVector<f64, P>, ObserveError>;

    /// `dc/dr` of contact `i`'s whitened block at its `angles`: how its
    /// rows move with its ball's radius (the block's `d_radius`, which
    /// needs neither the tip nor the centre).
    fn d_radius(&self, i: usize, angles: &SVector<f64, P>) -> SVector<f64, R>;
}

impl ContactObservations<1, 0> for RadiusObservations {
    fn block(
        &self,
        i: usize,
        radius: f64,
        tip: &Vec3,
        centre: &Vec3,
        _angles: &SVector<f64, 0>,
    ) -> Result<BlockJacobians<1, 0>, ObserveError> {
        Ok(RadiusBlock { radius }
            .evaluate(tip, centre)?
            .whiten(&self.weights[i]))
    }

    /// The radius observation has no angles.
    fn angles_toward(&self, _i: usize, _direction: &Vec3) -> Result<SVector<f64, 0>, ObserveError> {
        Ok(SVector::zeros())
    }

    /// `dc/dr = 1`, whitened.
    fn d_radius(&self, i: usize, _angles: &SVector<f64, 0>) -> SVector<f64, 1> {
        self.weights[i].whiten(&SVector::<f64, 1>::new(1.0))
    }
}

impl ContactObservations<3, 2> for CoordinateObservations {
    /// [`CoordinateBlock::evaluate_whitened`] in the contact's chart.
    #[inline(always)]
    fn block(
        &self,
        i: usize,
        radius: f64,
        tip: &Vec3,
        centre: &Vec3,
        angles: &Vector2<f64>,
    ) -> Result<BlockJacobians<3, 2>, ObserveError> {
        let chart = DirectionChart::about(&self.directions[i]);
        let block = CoordinateBlock { radius, chart };
        Ok(block.evaluate_whitened(tip, centre, angles, &self.weights[i]))
    }

    fn angle_prior(&self, _i: usize) -> Option<GaussianPrior<U2>> {
        let sigma = self.angle_sigma?;
        Some(GaussianPrior::from_sigmas(
            Vector2::zeros(),
            Vector2::repeat(sigma),
        ))
    }

    /// The chart's inverse about the contact's `u0`
    /// ([`DirectionChart::angles_of`]).
    fn angles_toward(&self, i: usize, direction: &Vec3) -> Result<Vector2<f64>, ObserveError> {
        Ok(DirectionChart::about(&self.directions[i]).angles_of(direction))
    }

    /// `dc/dr = u(θ)`, whitened.
    fn d_radius(&self, i: usize, angles: &Vector2<f64>) -> SVector<f64, 3> {
        let direction = DirectionChart::about(&self.directions[i]).direction(angles);
        self.weights[i].whiten(&direction)
    }
}

/// The global Jacobian of one whitened contact block, `dc_w/dp = d_tip J_f`
/// (paper eq. 2 through eq. 9 or 10, whitened as in eq. 5), applied through
/// `J_f` in factored form instead of formed: a combination of its rows
/// costs a 6 x 3 product and a sparse row, a product with a step a sparse
/// row and a 3 x 6 product. The kinematic parameters are the global
/// block's first 33 columns; a contact on a ball whose unknowns are in the
/// global block ([`ParameterLayout::ball`]) also has their `G` columns
/// there (`dc/dC`, and `dc/dr` for a per-ball radius); with unknown
/// actuator scales, the six columns of `s` ([`ContactJacobian::scales`]);
/// every other column is zero.
#[derive(Debug, Clone)]
pub struct ContactJacobian<const R: usize, const G: usize> {
    /// The whitened `dc/dT` (R x 3).
    pub d_tip: SMatrix<f64, R, 3>,
    /// The contact's forward kinematics and `J_f` there.
    pub tip: SolutionJacobian,
    /// For a ball whose unknowns are in the global block: their first
    /// column and the whitened `dc/d(C, r)` (R x G).
    pub centre: Option<(usize, SMatrix<f64, R, G>)>,
    /// With unknown actuator scales: their first column and the contact's
    /// readings `q`. Leg `i` is `l_i + s_i q_i` long, so
    /// `dT/ds_i = q_i dT/dl_i`: the scale columns are the leg-length
    /// columns of `J_f` times the readings.
    pub scales: Option<(usize, [f64; 6])>,
}

impl<const R: usize, const G: usize> ContactJacobian<R, G> {
    /// `dc/d(C, r) · δ(C, r)` for a ball whose unknowns are in the global
    /// block, else 0.
    fn centre_step(&self, v: &DVector<f64>) -> SVector<f64, R> {
        self.centre.map_or_else(SVector::zeros, |(start, d_ball)| {
            d_ball * v.fixed_rows::<G>(start)
        })
    }

    /// `dT/ds · δs = Σ_i q_i δs_i dT/dl_i` (mm) with unknown scales, else 0:
    /// `dT/dl = Kᵀ`'s transpose, the factored `J_f`'s closure weights.
    fn scale_tip_step(&self, v: &DVector<f64>) -> Vec3 {
        self.scales.map_or_else(Vec3::zeros, |(start, q)| {
            let extension = Vector6::from_fn(|i, _| q[i] * v[start + i]);
            self.tip.jacobian.weights.tr_mul(&extension)
        })
    }
}

impl<const R: usize, const G: usize> GlobalJacobian<R> for ContactJacobian<R, G> {
    fn zeros(_global_size: usize) -> Self {
        Self {
            d_tip: SMatrix::zeros(),
            tip: SolutionJacobian::default(),
            centre: None,
            scales: None,
        }
    }

    fn combine_rows(&self, c: &[f64; R], out: &mut [f64]) {
        let c = SVector::from(*c);
        let h = self.d_tip.tr_mul(&c);
        let (params, rest) = out.split_at_mut(N_PARAMS);
        self.tip.jacobian.params_row(&h, params);
        rest.fill(0.0);
        if let Some((start, d_centre)) = &self.centre {
            let row = d_centre.tr_mul(&c);
            out[*start..*start + G].copy_from_slice(row.as_slice());
        }
        if let Some((start, q)) = &self.scales {
            for (i, q) in q.iter().enumerate() {
                out[start + i] = out[leg_index(i)] * q;
            }
        }
    }

    fn apply(&self, v: &DVector<f64>) -> SVector<f64, R> {
        let tip = self.tip.jacobian.along(&kinematic_params(v)) + self.scale_tip_step(v);
        self.d_tip * tip + self.centre_step(v)
    }

    /// `d_tip` and the centre's columns (`J_f` is the kinematics').
    fn scale(&mut self, factor: f64) {
        self.d_tip *= factor;
        if let Some((_, d_ball)) = &mut self.centre {
            *d_ball *= factor;
        }
    }

    /// The kinematic rows formed on the stack (33 values), the centre's
    /// columns from `dc/dC`, the scales' from the leg-length columns: no
    /// scratch needed.
    fn add_column_norms2(&self, out: &mut [f64], _row: &mut [f64]) {
        let mut row = [0.0; N_PARAMS];
        for r in 0..R {
            let mut c = [0.0; R];
            c[r] = 1.0;
            let h = self.d_tip.tr_mul(&SVector::from(c));
            self.tip.jacobian.params_row(&h, &mut row);
            for (o, x) in out.iter_mut().zip(&row) {
                *o += x * x;
            }
            if let Some((start, q)) = &self.scales {
                for (i, q) in q.iter().enumerate() {
                    out[start + i] += (row[leg_index(i)] * q).powi(2);
                }
            }
        }
        if let Some((start, d_centre)) = &self.centre {
            for (o, column) in out[*start..*start + G]
                .iter_mut()
                .zip(d_centre.column_iter())
            {
                *o += column.norm_squared();
            }
        }
    }

    /// The kinematic rows formed on the stack (33 values): no scratch
    /// needed.
    fn is_finite(&self, _row: &mut [f64]) -> bool {
        let mut row = [0.0; N_PARAMS];
        let kinematic = (0..R).all(|r| {
            let mut c = [0.0; R];
            c[r] = 1.0;
            let h = self.d_tip.tr_mul(&SVector::from(c));
            self.tip.jacobian.params_row(&h, &mut row);
            row.iter().all(|x| x.is_finite())
        });
        kinematic
            && self
                .centre
                .is_none_or(|(_, d)| d.iter().all(|x| x.is_finite()))
    }
}

/// What every contact of a pass needs of the global block, made once per
/// pass: the canonical geometry of the kinematic parameters, the actuator
/// scales, and the unknowns of the balls whose unknowns are in the global
/// block.
pub struct GlobalValues<const G: usize> {
    /// The canonical geometry of the kinematic parameters.
    pub geometry: Geometry,
    /// The actuator scales `s_i` (mm per unit) and, when they are
    /// unknowns, their first column.
    pub scales: ActuatorScales,
    /// Per ball (artefacts.json order): its centre (and radius, `G` = 4)
    /// if they are in the global block.
    pub balls: Vec<Option<SVector<f64, G>>>,
}

/// The actuator scales at one state: leg `i` is `l_i + s_i q_i` long for
/// the reading `q_i` (machine.json's `actuator`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ActuatorScales {
    /// `s_i` (mm per unit).
    pub values: [f64; 6],
    /// The first column of [`ParameterGroup::ActuatorScales`] in the
    /// global block, when the scales are unknowns.
    pub column: Option<usize>,
}

impl ActuatorScales {
    /// The scales at the global block `global` of `layout`: its
    /// [`ParameterGroup::ActuatorScales`] if there, else the known `fixed`
    /// ones.
    pub fn at(layout: &ParameterLayout, global: &DVector<f64>, fixed: &[f64; 6]) -> Self {
        let column = layout
            .range(ParameterGroup::ActuatorScales)
            .map(|r| r.start);
        Self {
            values: column.map_or(*fixed, |c| std::array::from_fn(|i| global[c + i])),
            column,
        }
    }

    /// The leg extensions `s_i q_i` (mm) of the readings `q`: what forward
    /// kinematics takes.
    pub fn extensions(&self, q: &[f64; 6]) -> [f64; 6] {
        std::array::from_fn(|i| self.values[i] * q[i])
    }

    /// A parameter step `dp` with the change of the leg extensions of the
    /// readings `q` along the scales' step in `dg` added to the leg
    /// lengths' (`δ(l_i + s_i q_i) = δl_i + q_i δs_i`); `dp` itself with
    /// known scales.
    fn along(&self, dp: &Params, q: &[f64; 6], dg: &DVector<f64>) -> Params {
        let mut dp = *dp;
        if let Some(column) = self.column {
            for (i, q) in q.iter().enumerate() {
                dp[leg_index(i)] += q * dg[column + i];
            }
        }
        dp
    }
}

/// A calibrated distance between two balls' centres, both in the global
/// block.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DistanceObservation {
    /// The first column of each ball's centre in the global block.
    pub columns: [usize; 2],
    /// Its length and uncertainty.
    pub block: DistanceBlock,
}

/// The prior of a ball's unknowns as artefacts.json states it: each value
/// independent about its mean, with its standard deviation (infinite: no
/// information). `2 G` values a ball where the full prior would keep `G +
/// G²` (a million contacts have some 140 000 balls).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BallPrior<const G: usize> {
    /// The mean: the centre, then the radius when `G` = 4.
    pub mean: SVector<f64, G>,
    /// The standard deviation of each value.
    pub sigma: SVector<f64, G>,
}

impl<const G: usize> BallPrior<G> {
    /// As the solver takes it: information `diag(1/σ²)`.
    pub fn gaussian(&self) -> GaussianPrior<Const<G>> {
        GaussianPrior::from_sigmas(self.mean, self.sigma)
    }
}

/// The least-squares problem of one calibration, contacts sorted by ball;
/// `G` unknowns per ball: its centre (`G` = 3, the calibrated radius is
/// data), or its centre and radius (`G` = 4,
/// [`crate::RadiusModel::PerBall`]).
pub struct CalibrationProblem<'a, O, const G: usize> {
    /// The design in canonical frames (its home pose is the start of a
    /// contact's first forward kinematics when the solver is given no
    /// caches).
    pub design: Geometry,
    /// Actuator readings, measurements.csv order (borrowed from the dataset).
    pub q: &'a [[f64; 6]],
    /// The ball of each measurements.csv row (borrowed from the dataset).
    pub ball: &'a [u32],
    /// The measurements.csv row of each contact, sorted by ball.
    pub rows: &'a [u32],
    /// Contacts of each ball (contiguous).
    pub groups: &'a [Range<usize>],
    /// Calibrated radius of each ball (the groups are the balls, in order);
    /// with `G` = 4 only the prior's mean and the start.
    pub radii: Vec<f64>,
    /// The observation of every contact (radius or coordinates).
    pub observations: O,
    /// The global block: the kinematic parameters, then the unknowns of the
    /// balls tied by distances.
    pub layout: ParameterLayout,
    /// The actuators' scales when they are not unknowns (machine.json's
    /// `actuator.scale`, mm per unit).
    pub fixed_scales: [f64; 6],
    /// The calibrated distances (artefacts.json order).
    pub distances: Vec<DistanceObservation>,
    /// The prior on the global block (kinematic parameters and, where the
    /// balls have priors, the ball unknowns in the block).
    pub global_prior: Option<GaussianPrior<Dyn>>,
    /// The priors of the balls' unknowns (artefacts.json order): the
    /// centre's where it has one (zero information otherwise) and, with
    /// `G` = 4, the radius's; those of balls whose unknowns are in the
    /// global block are part of `global_prior` instead.
    pub ball_priors: Option<Vec<BallPrior<G>>>,
    /// Forward kinematics' tolerance and iteration limit.
    pub forward_options: ForwardOptions,
    /// The poses and points measured with the touches, global
    /// observations after the distances ([`crate::mixed`]).
    pub instruments: Option<InstrumentObservations<'a>>,
    /// The loss of every contact, distance, pose and point
    /// ([`crate::robust`]).
    pub loss: Loss,
}

impl<O, const G: usize> CalibrationProblem<'_, O, G> {
    /// Whether each ball's radius is an unknown (its group's last value).
    const RADIUS_UNKNOWN: bool = G == 4;

    fn row(&self, i: usize) -> usize {
        self.rows[i] as usize
    }

    fn actuators(&self, i: usize) -> &[f64; 6] {
        &self.q[self.row(i)]
    }

    /// The leg extensions at `scales` of the contacts `first..first + n`
    /// (at most [`BATCH`]; the rest of the array repeats the last).
    fn batch_extensions(
        &self,
        scales: &ActuatorScales,
        first: usize,
        n: usize,
    ) -> [[f64; 6]; BATCH] {
        std::array::from_fn(|j| {
            scales.extensions(self.actuators(first + j.min(n.saturating_sub(1))))
        })
    }

    /// `each(j)` for the contacts `first + j`, `j < n`, of a batch whose
    /// forward kinematics gave `kinematics`, in order, up to the first
    /// whose kinematics failed: the first error in contact order, named by
    /// its contact, as one contact at a time would give it.
    fn contact_by_contact(
        &self,
        first: usize,
        n: usize,
        kinematics: Result<(), (usize, KinematicsError)>,
        mut each: impl FnMut(usize) -> Result<(), CalibrateError>,
    ) -> Result<(), (usize, CalibrateError)> {
        let solved = kinematics.as_ref().map_or_else(|(j, _)| *j, |()| n);
        for j in 0..solved {
            each(j).map_err(|e| (first + j, e))?;
        }
        kinematics.map_err(|(j, source)| {
            let row = self.row(first + j);
            (first + j, CalibrateError::ForwardKinematics { row, source })
        })
    }

    /// Contact `i`'s whitened observation block at the tool tip `tip`
    /// (from its forward kinematics, paper eq. 2), its ball's unknowns and
    /// its angles, into `out` (all but `d_global.tip`, the kinematics).
    /// `dc/d(C, r)` goes to the group's columns, or to the global block's
    /// for a ball whose unknowns are there (`in_global`: their first
    /// column).
    fn observe_contact<const R: usize, const P: usize>(
        &self,
        i: usize,
        tip: &Vec3,
        (ball, in_global): (&SVector<f64, G>, Option<usize>),
        angles: &SVector<f64, P>,
        out: &mut Linearization<G, P, R, ContactJacobian<R, G>>,
    ) -> Result<(), CalibrateError>
    where
        O: ContactObservations<R, P>,
    {
        let mut d_ball = SMatrix::<f64, R, G>::zeros();
        let rows = (&mut out.residual, &mut d_ball, &mut out.d_point);
        out.d_global.d_tip = self.ball_rows(i, tip, ball, angles, rows)?;
        match in_global {
            Some(start) => {
                out.d_global.centre = Some((start, d_ball));
                out.d_group = SMatrix::zeros();
            }
            None => {
                out.d_global.centre = None;
                out.d_group = d_ball;
            }
        }
        Ok(())
    }

    /// Contact `i`'s whitened observation block at the tool tip `tip`, its
    /// ball's unknowns `ball` (the centre, then the radius when it is an
    /// unknown) and its angles: the residual, `dc/d(C, r)` and `dc/dθ` into
    /// `rows`, `dc/dT` returned.
    fn ball_rows<const R: usize, const P: usize>(
        &self,
        i: usize,
        tip: &Vec3,
        ball: &SVector<f64, G>,
        angles: &SVector<f64, P>,
        (residual, d_ball, d_angles): (
            &mut SVector<f64, R>,
            &mut SMatrix<f64, R, G>,
            &mut SMatrix<f64, R, P>,
        ),
    ) -> Result<SMatrix<f64, R, 3>, CalibrateError>
    where
        O: ContactObservations<R, P>,
    {
        let centre = ball.fixed_rows::<3>(0).into_owned();
        let radius = if Self::RADIUS_UNKNOWN {
            ball[G - 1]
        } else {
            self.radius(i)
        };
        // Read where the call returned it: moving the block out of its
        // `Result` would copy it whole.
        let evaluated = self.observations.block(i, radius, tip, &centre, angles);
        let block = match evaluated {
            Ok(ref block) => block,
            Err(source) => {
                return Err(CalibrateError::Observation {
                    row: self.row(i),
                    source,
                });
            }
        };
        *residual = block.residual;
        d_ball.fixed_columns_mut::<3>(0).copy_from(&block.d_centre);
        if Self::RADIUS_UNKNOWN {
            d_ball.column_mut(G - 1).copy_from(&block.d_radius);
        }
        *d_angles = block.d_angles;
        Ok(block.d_tip)
    }

    /// The common errors of the entered data that the problem's rows
    /// carry, in the order of [`Problem::effects`]: the balls' radius (as
    /// data, `G` = 3, or as the radius priors' mean, `G` = 4) and, with
    /// distances, their scale.
    pub fn tested_effects(&self) -> Vec<Effect> {
        let radius = !Self::RADIUS_UNKNOWN || self.ball_priors.is_some();
        let scale = !self.distances.is_empty();
        [(radius, Effect::BallRadius), (scale, Effect::DistanceScale)]
            .into_iter()
            .filter_map(|(carried, effect)| carried.then_some(effect))
            .collect()
    }

    /// The global column of the radius of each ball in the global block.
    fn radius_columns(&self) -> impl Iterator<Item = usize> + '_ {
        (0..self.radii.len()).filter_map(|k| self.layout.ball(k).map(|r| r.start + G - 1))
    }

    /// The ball of contact `i` (artefacts.json index).
    fn ball_of(&self, i: usize) -> usize {
        self.ball[self.row(i)] as usize
    }

    /// The calibrated radius of contact `i`'s ball.
    fn radius(&self, i: usize) -> f64 {
        self.radii[self.ball_of(i)]
    }

    /// The unknowns of the ball of contact `first` (its group's, or the
    /// global block's) and, for the latter, their first global column.
    fn ball_unknowns(
        &self,
        first: usize,
        global: &GlobalValues<G>,
        group: &SVector<f64, G>,
    ) -> (SVector<f64, G>, Option<usize>) {
        let ball = self.ball_of(first);
        match global.balls[ball] {
            Some(values) => (values, self.layout.ball(ball).map(|r| r.start)),
            None => (*group, None),
        }
    }
}

impl<const R: usize, const P: usize, const G: usize, O> Problem<G, P, R>
    for CalibrationProblem<'_, O, G>
where
    O: ContactObservations<R, P>,
{
    type PointCache = Pose;
    /// The row order the lanes first try in their factorisations
    /// ([`forward_jacobian_batch`], [`forward_along_batch`]).
    type Workspace = PivotOrder;
    type Error = CalibrateError;
    type Jacobian = ContactJacobian<R, G>;
    /// Every contact of a pass is linearised at the same parameters: their
    /// canonical geometry is built once per pass.
    type Global = GlobalValues<G>;
    /// A contact's tool tip at the new parameters, to first order: its
    /// observation block there takes nothing else of the global block.
    type Anchor = Vec3;

    /// The layout's size: 33, plus `G` per ball tied by a distance, plus
    /// the instrument groups (the scales among them).
    fn global_size(&self) -> usize {
        self.layout.size()
    }

    fn prepare_global(&self, global: &DVector<f64>) -> GlobalValues<G> {
        GlobalValues {
            geometry: params::from_params(&kinematic_params(global)),
            scales: ActuatorScales::at(&self.layout, global, &self.fixed_scales),
            balls: (0..self.radii.len())
                .map(|ball| {
                    let range = self.layout.ball(ball)?;
                    Some(global.fixed_rows::<G>(range.start).into_owned())
                })
                .collect(),
        }
    }

    /// The balls whose unknowns are in the global block.
    fn group_is_fixed(&self, k: usize) -> bool {
        self.layout.ball(k).is_some()
    }

    fn n_groups(&self) -> usize {
        self.groups.len()
    }

    fn group_points(&self, k: usize) -> Range<usize> {
        self.groups[k].clone()
    }

    /// The design's home pose at contact `i`'s leg extensions at the known
    /// (or design) scales (a calibration hands the solver the design's
    /// forward kinematics instead, [`crate::setup::Setup::poses`]).
    fn initial_cache(&self, i: usize) -> Pose {
        let known = ActuatorScales {
            values: self.fixed_scales,
            column: None,
        };
        self.design.home_pose(&known.extensions(self.actuators(i)))
    }

    fn linearize(
        &self,
        i: usize,
        global: &GlobalValues<G>,
        group: &SVector<f64, G>,
        point: &SVector<f64, P>,
        cache: &mut Pose,
        out: &mut Linearization<G, P, R, ContactJacobian<R, G>>,
    ) -> Result<(), CalibrateError> {
        let (points, caches, out) = (
            std::slice::from_ref(point),
            std::slice::from_mut(cache),
            std::slice::from_mut(out),
        );
        let workspace = &mut PivotOrder::default();
        self.linearize_batch(i, global, group, points, caches, out, workspace)
            .map_err(|(_, e)| e)
    }

    /// The whitened blocks of the contacts `first..first + out.len()` (at
    /// most [`BATCH`], of one ball) at the canonical geometry of the current
    /// parameters, the ball centre and the contacts' angles: forward
    /// kinematics (paper eq. 1) of all of them from their cached poses
    /// (updated; in SIMD lanes where the machine has AVX2,
    /// [`in_groups`]), then for each
    /// the tool tip (eq. 2) and its derivatives and the observation block.
    /// An error names the first failing contact, as one contact at a time
    /// would. The lanes' row order is carried from batch to batch in the
    /// workspace.
    fn linearize_batch(
        &self,
        first: usize,
        global: &GlobalValues<G>,
        group: &SVector<f64, G>,
        points: &[SVector<f64, P>],
        caches: &mut [Pose],
        out: &mut [Linearization<G, P, R, ContactJacobian<R, G>>],
        workspace: &mut PivotOrder,
    ) -> Result<(), (usize, CalibrateError)> {
        let n = out.len();
        let extensions = self.batch_extensions(&global.scales, first, n);
        let extensions: [&[f64; 6]; BATCH] = std::array::from_fn(|j| &extensions[j]);
        let kinematics = in_groups(n, LANES, |lanes| {
            forward_jacobian_batch(
                &global.geometry,
                &extensions[lanes.clone()],
                &caches[lanes.clone()],
                &self.forward_options,
                &mut *workspace,
                &mut out[lanes],
                |out| &mut out.d_global.tip,
            )
        });
        let (ball, in_global) = self.ball_unknowns(first, global, group);
        self.contact_by_contact(first, n, kinematics, |j| {
            let solution = &out[j].d_global.tip;
            let tip = solution.tool_tip;
            caches[j] = solution.pose;
            out[j].d_global.scales = global
                .scales
                .column
                .map(|column| (column, *self.actuators(first + j)));
            self.observe_contact(first + j, &tip, (&ball, in_global), &points[j], &mut out[j])
        })
    }

    /// As [`Problem::linearize`], with `d_global dg` from one solve; the
    /// cached pose becomes the first-order prediction of the pose at
    /// `p + dg`, the next iteration's parameters, so that its forward
    /// kinematics starts within `O(|dg|^2)` of the solution.
    fn linearize_along(
        &self,
        i: usize,
        global: &GlobalValues<G>,
        group: &SVector<f64, G>,
        point: &SVector<f64, P>,
        cache: &mut Pose,
        dg: &DVector<f64>,
        out: &mut Linearization<G, P, R, ContactJacobian<R, G>>,
    ) -> Result<SVector<f64, R>, CalibrateError> {
        let mut step = SVector::zeros();
        let (points, caches, out, steps) = (
            std::slice::from_ref(point),
            std::slice::from_mut(cache),
            std::slice::from_mut(out),
            std::slice::from_mut(&mut step),
        );
        let workspace = &mut PivotOrder::default();
        let anchors = &mut [Vec3::zeros()];
        self.linearize_along_batch(
            i, global, group, points, caches, dg, out, steps, anchors, workspace,
        )
        .map_err(|(_, e)| e)?;
        Ok(step)
    }

    /// As [`Problem::linearize_batch`], with each contact's forward
    /// kinematics and its change along `dg` together (in SIMD lanes where
    /// the machine has AVX2, [`forward_along_batch`]), the lanes' row order
    /// carried from batch to batch in the workspace. With unknown scales
    /// each contact's step of its leg extensions differs
    /// (`ActuatorScales::along`): the contacts go one at a time.
    /// `d_global.tip` is not written: the back-substitution needs only
    /// `d_global dg`. Each contact's anchor is its tool tip plus `J_f dp`.
    fn linearize_along_batch(
        &self,
        first: usize,
        global: &GlobalValues<G>,
        group: &SVector<f64, G>,
        points: &[SVector<f64, P>],
        caches: &mut [Pose],
        dg: &DVector<f64>,
        out: &mut [Linearization<G, P, R, ContactJacobian<R, G>>],
        steps: &mut [SVector<f64, R>],
        anchors: &mut [Vec3],
        workspace: &mut PivotOrder,
    ) -> Result<(), (usize, CalibrateError)> {
        let n = out.len();
        let d_params = &kinematic_params(dg);
        let mut solutions = [SolutionAlong::default(); BATCH];
        let extensions = self.batch_extensions(&global.scales, first, n);
        let extensions: [&[f64; 6]; BATCH] = std::array::from_fn(|j| &extensions[j]);
        let mut along = |contacts: Range<usize>, dp: &Params, solutions: &mut [SolutionAlong]| {
            forward_along_batch(
                &global.geometry,
                &extensions[contacts.clone()],
                &caches[contacts],
                dp,
                &self.forward_options,
                &mut *workspace,
                solutions,
            )
        };
        let kinematics = match global.scales.column {
            None => in_groups(n, LANES, |lanes| {
                along(lanes.clone(), d_params, &mut solutions[lanes])
            }),
            Some(_) => (0..n).try_for_each(|j| {
                let dp = global.scales.along(d_params, self.actuators(first + j), dg);
                along(j..j + 1, &dp, &mut solutions[j..j + 1]).map_err(|(_, e)| (j, e))
            }),
        };
        let (ball, in_global) = self.ball_unknowns(first, global, group);
        self.contact_by_contact(first, n, kinematics, |j| {
            let solution = &solutions[j];
            self.observe_contact(
                first + j,
                &solution.tool_tip,
                (&ball, in_global),
                &points[j],
                &mut out[j],
            )?;
            caches[j] = solution.predicted;
            anchors[j] = solution.tool_tip + solution.tip;
            let d_global = &out[j].d_global;
            steps[j] = d_global.d_tip * solution.tip + d_global.centre_step(dg);
            Ok(())
        })
    }

    /// Contact `i`'s observation block at the tool tip `anchor`, its ball's
    /// unknowns `group` and its angles `point`.
    fn local_rows(
        &self,
        i: usize,
        anchor: &Vec3,
        group: &SVector<f64, G>,
        point: &SVector<f64, P>,
        out: &mut LocalRows<G, P, R>,
    ) -> Result<bool, CalibrateError> {
        let rows = (&mut out.residual, &mut out.d_group, &mut out.d_point);
        self.ball_rows(i, anchor, group, point, rows)?;
        Ok(true)
    }

    fn global_prior(&self) -> Option<&GaussianPrior<Dyn>> {
        self.global_prior.as_ref()
    }

    /// A ball's prior, unless its unknowns are in the global block (then
    /// the prior is part of the global one).
    fn group_prior(&self, k: usize) -> Option<GaussianPrior<Const<G>>> {
        if self.group_is_fixed(k) {
            return None;
        }
        self.ball_priors.as_ref().map(|priors| priors[k].gaussian())
    }

    /// The calibrated distances, `c = (L_ab − |C_a − C_b|) / σ_ab`
    /// ([`DistanceBlock`]), on the centres in the global block; then the
    /// poses and points measured with the touches, if any
    /// ([`InstrumentObservations::append`]).
    fn global_observations(
        &self,
        global: &DVector<f64>,
        out: &mut GlobalObservations,
    ) -> Result<(), CalibrateError> {
        *out = GlobalObservations::zeros(self.distances.len(), global.len());
        for (k, distance) in self.distances.iter().enumerate() {
            let [a, b] = distance.columns;
            let block = distance
                .block
                .evaluate(
                    &global.fixed_rows::<3>(a).into_owned(),
                    &global.fixed_rows::<3>(b).into_owned(),
                )
                .map_err(|source| CalibrateError::Distance { index: k, source })?;
            out.residual[k] = block.residual[0];
            for c in 0..3 {
                out.jacobian[(k, a + c)] = block.d_first[c];
                out.jacobian[(k, b + c)] = block.d_second[c];
            }
        }
        match &self.instruments {
            Some(instruments) => instruments.append(global, out),
            None => Ok(()),
        }
    }

    fn point_prior(&self, i: usize) -> Option<GaussianPrior<Const<P>>> {
        self.observations.angle_prior(i)
    }

    /// [`CalibrationProblem::tested_effects`].
    fn effects(&self) -> usize {
        self.tested_effects().len()
    }

    /// With the radius as data (`G` = 3), the balls' radius, the first
    /// effect, moves every contact's rows by its block's `dc/dr`.
    fn point_effects(
        &self,
        i: usize,
        _lin: &Linearization<G, P, R, ContactJacobian<R, G>>,
        angles: &SVector<f64, P>,
        out: &mut [SVector<f64, R>],
    ) {
        if !Self::RADIUS_UNKNOWN {
            out[0] = self.observations.d_radius(i, angles);
        }
    }

    /// With a per-ball radius (`G` = 4) and priors, the balls' radius,
    /// the first effect, moves each radius prior's mean by `t`.
    fn group_prior_effects(&self, _k: usize, out: &mut [SVector<f64, G>]) {
        if Self::RADIUS_UNKNOWN {
            out[0][G - 1] = 1.0;
        }
    }

    /// The radius priors' means of the balls in the global block (`G` =
    /// 4) move by `t`; each distance `L` by `L t`, its whitened row by `L
    /// / σ` per unit `t`.
    fn global_effects(&self, prior_mean: &mut DMatrix<f64>, observations: &mut DMatrix<f64>) {
        let effects = self.tested_effects();
        for (k, effect) in effects.iter().enumerate() {
            match effect {
                Effect::BallRadius if Self::RADIUS_UNKNOWN && self.global_prior.is_some() => {
                    for column in self.radius_columns() {
                        prior_mean[(column, k)] = 1.0;
                    }
                }
                Effect::BallRadius => {}
                Effect::DistanceScale => {
                    for (row, distance) in self.distances.iter().enumerate() {
                        observations[(row, k)] = distance.block.length / distance.block.sigma;
                    }
                }
            }
        }
    }

    fn loss(&self) -> Loss {
        self.loss
    }

    /// A distance of one row, a pose of six, a point of three
    /// ([`CalibrationProblem::global_observation_ids`]).
    fn global_observation_rows(&self) -> Option<Vec<usize>> {
        Some(
            self.global_observation_ids()
                .iter()
                .map(|o| o.rows())
                .collect(),
        )
    }
}

impl<'p, O, const G: usize> CalibrationProblem<'p, O, G> {
    /// Number of global observation rows: the distances', then the
    /// instruments'.
    pub fn global_rows(&self) -> usize {
        self.distances.len() + self.instruments.as_ref().map_or(0, |i| i.rows.len())
    }

    /// The global observations, in the order of their rows: the
    /// distances, then the poses (6 rows each), then the points (3 rows
    /// each).
    pub fn global_observation_ids(&self) -> Vec<ObservationId> {
        let (poses, points) = self.instruments.as_ref().map_or((0, 0), |i| {
            let t = i.rows.tracker;
            (t.poses.len(), t.points.len())
        });
        (0..self.distances.len())
            .map(ObservationId::Distance)
            .chain((0..poses).map(ObservationId::Pose))
            .chain((0..points).map(ObservationId::Point))
            .collect()
    }

    /// Adds `dataset`'s poses and points to the problem (none without
    /// them): their rows, weighed at the initial block `initial` (the
    /// priors of their groups are part of the global prior already,
    /// [`crate::setup::Setup::problem`]).
    pub fn attach_instruments(
        &mut self,
        dataset: &'p Dataset,
        initial: &DVector<f64>,
    ) -> Result<(), CalibrateError> {
        self.instruments =
            InstrumentObservations::new(dataset, &self.design, &self.layout, initial)?;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use nalgebra::Matrix3;

    use super::*;

    /// `d_radius` is the block's `dc/dr`, whatever the tip and centre.
    #[test]
    fn d_radius_is_the_blocks_radius_column() {
        let (tip, centre) = (Vec3::new(3.0, -1.0, 402.0), Vec3::new(1.0, 2.0, 397.0));
        let direction = UnitVector3::new_normalize(Vec3::new(0.3, -0.5, 0.8));
        let covariance = Matrix3::new(2e-6, 1e-7, 0.0, 1e-7, 3e-6, 2e-7, 0.0, 2e-7, 4e-6);
        let coordinates = CoordinateObservations {
            directions: vec![direction],
            weights: vec![CoordinateWhitening::from_covariance(&covariance).unwrap()],
            angle_sigma: None,
        };
        let angles = Vector2::new(0.1, -0.2);
        let block = coordinates.block(0, 12.7, &tip, &centre, &angles).unwrap();
        assert_eq!(coordinates.d_radius(0, &angles), block.d_radius);
        let radius = RadiusObservations {
            weights: vec![RadiusWhitening::from_variance(4e-6).unwrap()],
        };
        let block = radius
            .block(0, 12.7, &tip, &centre, &SVector::zeros())
            .unwrap();
        assert_eq!(radius.d_radius(0, &SVector::zeros()), block.d_radius);
    }
}
