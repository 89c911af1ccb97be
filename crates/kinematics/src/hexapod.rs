//! The 6-6 Stewart platform as a [`Mechanism`]: a thin adapter over the
//! crate's geometry, inverse and forward kinematics and closure Jacobian.
//!
//! - Parameters: the 33 of [`crate::params`], canonical by construction
//!   (the 45 input coordinates less the 12 of the two frames' rigid
//!   motions, [`crate::frames`]), so no gauge freedom is left.
//! - Pose: `(t_x, t_y, t_z, r_x, r_y, r_z)`, the platform's translation
//!   (mm) and rotation vector (rad, `R = exp([r]x)`); increments are
//!   `(dt, w)` with `R <- rot(w) R` ([`crate::forward::step`]).
//! - Warm start: `(t, q)`, the translation and the unit quaternion `q =
//!   (q_i, q_j, q_k, q_w)` of the rotation, what the forward kinematics
//!   starts from and ends with; the rotation vector costs a sine and a
//!   cosine to start from and an arc tangent to end with.
//! - Readings: the actuator values `q_i = L_i - l_i` (mm); or, with the
//!   actuators' scales as unknowns ([`Hexapod::with_unknown_scales`]),
//!   readings `q_i` in the actuators' own unit with leg `i` `l_i + s_i q_i`
//!   long, the scales `s_i` (mm per unit) six parameters after the 33.
//!   Then `g_i = (L_i - l_i) / s_i`, the rows below divided by `s_i`,
//!   `dq_i/ds_i = -q_i / s_i`, and at readings `dT/ds_i = q_i dT/dl_i |_q`
//!   (the leg's extension and its length enter the closure as their sum).
//! - `dq/dx` are the closure rows `[n_i^T, (R E_i x n_i)^T]`
//!   ([`crate::closure`]); `dq_i/dp` is `-n_i` at the base joint
//!   `B_i`, `R^T n_i` at the platform joint `E_i`, `-1` at `l_i`.
//! - The tool point is the tool tip `T = t + R E_T` (paper eq. 2), with
//!   `dT/dx = [I, -[R E_T]x]` and `dT/dE_T = R`; forward kinematics
//!   starts from [`Geometry::home_pose`].
//! - At readings, the tool point's `dT/dp |_q` is the crate's `J_f`
//!   ([`TipDerivatives::jacobians`]) from the LU the forward kinematics
//!   ends with, where the generic path factors `G_x` again, handed over in
//!   factored form (`K^T`, `R` and the leg directions,
//!   [`FactoredTipJacobian`], which the lanes write where the caller reads
//!   it): what a calibration takes of it, a combination of rows or a
//!   product with a step, without its 3 x 33 entries.

use std::borrow::Cow;

use bytemuck::TransparentWrapper;
use nalgebra::{
    DMatrix, DVector, Isometry3, Quaternion, Translation3, UnitQuaternion, Vector3, Vector6,
};

use crate::batch_workspace::BatchWorkspace;
use crate::closure::Legs;
use crate::derivatives::{FactoredTipJacobian, SolutionAlong, SolutionRoom, TipDerivatives};
use crate::forward::{forward, step};
use crate::forward_batch::{LANES, PivotOrder, forward_along_batch, forward_jacobian_batch};
use crate::mechanism::{
    Actuator, Mechanism, MechanismError, Parameter, PlatformPose, PoseCoordinate, Reached,
    ReachedAlong, ReadingJacobians, ToolPoint, along_of_reached, check_params, check_pose,
    check_vector, put_entry, tool_points_along_by_rows, tool_points_one_by_one, write_entry,
    write_reached,
};
use crate::params::{
    BASE_INDEX, LEG_OFFSET, N_PARAMS, PARAM_NAMES, PLATFORM_INDEX, TOOL_OFFSET, from_params,
    leg_index, to_params,
};
use crate::params_jacobian::{DENSE, JacobianForm, ParamsJacobian};
use crate::{ForwardOptions, Geometry, KinematicsError, Params, Pose, PriorSigma, actuators};

/// A hexapod's `dT/dp |_q` over the 33: its `J_f` in factored form, read
/// where its values are ([`FactoredTipJacobian::in_values`]): a combination
/// of rows is one 6 x 3 product and a sparse row per leg, a product with a
/// step one closure change.
static LEGS: JacobianForm = JacobianForm {
    name: "hexapod legs",
    combine: |values, h, out| FactoredTipJacobian::in_values(values).params_row(h, out),
    apply: |values, v| FactoredTipJacobian::in_values(values).along(&Params::from_column_slice(v)),
};

/// A hexapod's `dT/dp |_q` with the actuators' scales after the 33 (module
/// doc): [`LEGS`]'s values, then the contact's six readings `q_i`, with
/// `dT/ds_i = q_i dT/dl_i` and a step's legs `dl_i + q_i ds_i`.
static SCALED_LEGS: JacobianForm = JacobianForm {
    name: "hexapod legs with scales",
    combine: |values, h, out| {
        let (factors, readings) = values.split_at(FactoredTipJacobian::VALUES);
        let (lengths, scales) = out.split_at_mut(N_PARAMS);
        FactoredTipJacobian::in_values(factors).params_row(h, lengths);
        for (i, (s, q)) in scales.iter_mut().zip(readings).enumerate() {
            *s = q * lengths[leg_index(i)];
        }
    },
    apply: |values, v| {
        let (factors, readings) = values.split_at(FactoredTipJacobian::VALUES);
        FactoredTipJacobian::in_values(factors).along(&legs_step(v, Some(readings)))
    },
};

/// The step of the 33 geometric parameters that moves a contact at
/// `readings` as the step `dp` does: the step itself over the 33, and with
/// scales (`readings` given) leg `i`'s `dl_i + q_i ds_i` (the extension
/// `s_i q_i` and the length `l_i` enter the closure as their sum; module
/// doc).
fn legs_step(dp: &[f64], readings: Option<&[f64]>) -> Params {
    let mut step = Params::from_column_slice(&dp[..N_PARAMS]);
    if let Some(readings) = readings {
        for (i, (ds, q)) in dp[N_PARAMS..].iter().zip(readings).enumerate() {
            step[leg_index(i)] += q * ds;
        }
    }
    step
}

/// The pose coordinates of a hexapod.
const POSE: [PoseCoordinate; 6] = [
    PoseCoordinate {
        name: "t_x",
        unit: "mm",
    },
    PoseCoordinate {
        name: "t_y",
        unit: "mm",
    },
    PoseCoordinate {
        name: "t_z",
        unit: "mm",
    },
    PoseCoordinate {
        name: "r_x",
        unit: "rad",
    },
    PoseCoordinate {
        name: "r_y",
        unit: "rad",
    },
    PoseCoordinate {
        name: "r_z",
        unit: "rad",
    },
];

/// The group of the tool's parameters `x_eT, y_eT, z_eT`.
pub const TOOL_GROUP: &str = "tool";

/// A hexapod design with its tolerances.
#[derive(Debug, Clone)]
pub struct Hexapod {
    parameters: Vec<Parameter>,
    actuators: Vec<Actuator>,
    /// Whether the readings are in the actuators' own unit, their scales
    /// the parameters after the 33 (module doc); else the legs' extensions
    /// (mm).
    scaled: bool,
    options: ForwardOptions,
    /// Where the first batch of contacts of a [`BatchWorkspace`] tries to
    /// factorise its closure Jacobians ([`design_pivot_order`]); later
    /// batches start where the one before ended.
    pivot_order: PivotOrder,
}

impl Hexapod {
    /// The hexapod of a design geometry (any frames: it is canonicalised)
    /// with the tolerances of its input coordinates, each taken as the
    /// prior of the canonical parameters of its group (the propagated
    /// prior, [`crate::frames::parameter_jacobian`], couples them).
    pub fn new(design: &Geometry, prior: &PriorSigma) -> Result<Self, KinematicsError> {
        let canonical = design.canonicalize()?.geometry;
        let values = to_params(&canonical);
        let parameters = PARAM_NAMES
            .iter()
            .enumerate()
            .map(|(k, name)| {
                let (group, prior_sigma) = match k {
                    _ if k < LEG_OFFSET => ("base joints", prior.base),
                    _ if k < LEG_OFFSET + 6 => ("leg lengths", prior.leg),
                    _ if k < TOOL_OFFSET => ("platform joints", prior.platform),
                    _ => (TOOL_GROUP, prior.tool),
                };
                Parameter {
                    name: (*name).to_string(),
                    unit: "mm".into(),
                    group,
                    design: values[k],
                    prior_sigma,
                }
            })
            .collect();
        let actuators = (1..=6)
            .map(|leg| Actuator::direct(format!("leg {leg}"), "mm"))
            .collect();
        let options = ForwardOptions::default();
        Ok(Self {
            parameters,
            actuators,
            scaled: false,
            pivot_order: design_pivot_order(&canonical, &options),
            options,
        })
    }

    /// The paper's hexapod with 0.1 mm tolerances on every input
    /// coordinate.
    pub fn typical() -> Self {
        let prior = PriorSigma {
            base: 0.1,
            platform: 0.1,
            tool: 0.1,
            leg: 0.1,
        };
        Self::new(&crate::paper::design(), &prior)
            .expect("the paper's design is a hexapod of six legs of non-zero length")
    }

    /// This hexapod read in the actuators' own `unit`, each leg's scale
    /// `s_i` (mm per `unit`) a parameter `s_1..s_6` after the 33, about
    /// `design` with the prior `prior_sigma` (module doc).
    pub fn with_unknown_scales(
        mut self,
        unit: &str,
        design: [f64; 6],
        prior_sigma: [f64; 6],
    ) -> Self {
        self.parameters.truncate(N_PARAMS);
        let per_unit: Cow<'static, str> = format!("mm/{unit}").into();
        self.parameters.extend((0..6).map(|i| Parameter {
            name: crate::SCALE_NAMES[i].to_string(),
            unit: per_unit.clone(),
            group: "actuator scales",
            design: design[i],
            prior_sigma: prior_sigma[i],
        }));
        for actuator in &mut self.actuators {
            actuator.unit = unit.to_string().into();
        }
        self.scaled = true;
        self
    }

    /// The canonical geometry of a parameter vector (checked: with scales,
    /// each positive).
    fn geometry(&self, params: &[f64]) -> Result<Geometry, MechanismError> {
        check_params(self, params)?;
        if let Some(i) = (0..6).find(|&i| self.scale(params, i) <= 0.0) {
            let scale = &self.parameters[N_PARAMS + i];
            return Err(MechanismError::Unreachable {
                reason: format!(
                    "scale {} is {} {}, not positive",
                    scale.name,
                    params[N_PARAMS + i],
                    scale.unit
                ),
            });
        }
        Ok(from_params(&Params::from_column_slice(&params[..N_PARAMS])))
    }

    /// Leg `i`'s scale `s_i` in `params` (checked ones), 1 for a hexapod
    /// read in mm.
    fn scale(&self, params: &[f64], i: usize) -> f64 {
        if self.scaled {
            params[N_PARAMS + i]
        } else {
            1.0
        }
    }

    /// The legs' extensions `s_i q_i` (mm) of a reading vector at checked
    /// parameters `params` (the readings checked).
    fn extensions(&self, params: &[f64], readings: &[f64]) -> Result<[f64; 6], MechanismError> {
        check_vector(self, "readings", readings, 6)?;
        Ok(self.extensions_of(params, readings))
    }

    /// [`Hexapod::extensions`] of six readings whose values are not
    /// checked.
    fn extensions_of(&self, params: &[f64], readings: &[f64]) -> [f64; 6] {
        std::array::from_fn(|i| self.scale(params, i) * readings[i])
    }

    /// Its `dT/dp |_q`'s form: [`LEGS`], or with scales [`SCALED_LEGS`].
    fn form(&self) -> &'static JacobianForm {
        if self.scaled { &SCALED_LEGS } else { &LEGS }
    }

    /// The number of values of its `dT/dp |_q` ([`Hexapod::form`]).
    fn form_len(&self) -> usize {
        FactoredTipJacobian::VALUES + if self.scaled { 6 } else { 0 }
    }

    /// `dT/dp |_q` (3 x parameters) of a contact at `readings` from the
    /// crate's `J_f` over the 33 in factored form ([`Hexapod::form`]).
    fn reached_rows(&self, readings: &[f64], jacobian: &FactoredTipJacobian) -> ParamsJacobian {
        let mut d_params =
            ParamsJacobian::factored(self.form(), self.parameters.len(), self.form_len());
        *FactoredTipJacobian::in_values_mut(d_params.values_mut()) = *jacobian;
        self.write_readings(readings, &mut d_params);
        d_params
    }

    /// The values after `J_f`'s in `d_params` (room for its form): with
    /// scales, the contact's `readings` ([`SCALED_LEGS`]).
    fn write_readings(&self, readings: &[f64], d_params: &mut ParamsJacobian) {
        if self.scaled {
            d_params.values_mut()[FactoredTipJacobian::VALUES..].copy_from_slice(&readings[..6]);
        }
    }

    /// The step of the 33 geometric parameters that moves a contact at
    /// `readings` as the step `dp` of this hexapod's parameters does
    /// ([`legs_step`]).
    fn kinematic_step(&self, dp: &[f64], readings: &[f64]) -> Params {
        legs_step(dp, self.scaled.then_some(readings))
    }

    /// The contacts at `readings` (at checked parameters `params`) from
    /// the warm starts `starts`, in batches of up to `batch` (at most
    /// [`LANES`]), each outcome in order into `out`:
    /// `lanes(out, first, q, poses)` solves the batch from `first` (its
    /// legs' extensions `q` and start poses, of their lengths checked) and
    /// writes its outcomes, or returns `false` when its lanes fail; such a
    /// batch, and one with readings or a start of another length or a
    /// start of zero quaternion, goes one contact at a time through
    /// `alone(l)`, each with its own outcome.
    ///
    /// # Panics
    /// If `readings` and `starts` differ in length.
    #[allow(
        clippy::type_complexity,
        clippy::too_many_arguments,
        reason = "the contacts, their batch and the two ways to solve them"
    )]
    fn in_batches<T>(
        &self,
        params: &[f64],
        readings: &[&[f64]],
        starts: &[&[f64]],
        batch: usize,
        out: &mut Vec<Result<T, MechanismError>>,
        mut lanes: impl FnMut(&mut Vec<Result<T, MechanismError>>, usize, &[&[f64; 6]], &[Pose]) -> bool,
        alone: impl Fn(usize) -> Result<T, MechanismError>,
    ) {
        assert_eq!(readings.len(), starts.len(), "a start for each contact");
        out.truncate(readings.len());
        // The lanes' inputs, on the stack, of their lengths checked: a
        // value that is not finite makes its lane's forward kinematics
        // fail (the closure's factorisation refuses a pivot that is not
        // finite), and the batch then goes one contact at a time, where it
        // is refused by name.
        let mut q = [[0.0; 6]; LANES];
        let mut poses = [Pose::identity(); LANES];
        for first in (0..readings.len()).step_by(batch) {
            let n = batch.min(readings.len() - first);
            let checked = (0..n).all(|l| {
                let (readings, start) = (readings[first + l], starts[first + l]);
                if readings.len() != 6 || start.len() != WARM_START_LEN {
                    return false;
                }
                q[l] = self.extensions_of(params, readings);
                let Some(pose) = pose_of_start(start) else {
                    return false;
                };
                poses[l] = pose;
                true
            });
            let legs: [&[f64; 6]; LANES] = std::array::from_fn(|l| &q[l]);
            if !checked || !lanes(out, first, &legs[..n], &poses[..n]) {
                for l in first..first + n {
                    put_entry(out, l, alone(l));
                }
            }
        }
    }

    /// The canonical geometry of `params` ([`Hexapod::geometry`]), made
    /// again only when they differ from the last batch's, and the row order
    /// the lanes carry from batch to batch, both kept in `workspace` (its
    /// first batch starts from [`design_pivot_order`]).
    fn shared<'w>(
        &self,
        params: &[f64],
        workspace: &'w mut BatchWorkspace,
    ) -> Result<Shared<'w>, MechanismError> {
        let SharedByBatches { prepared, order } = workspace.held(|| SharedByBatches {
            prepared: None,
            order: self.pivot_order,
        });
        if !prepared
            .as_ref()
            .is_some_and(|(last, _)| same_bits(last, params))
        {
            *prepared = Some((params.to_vec(), self.geometry(params)?));
        }
        let (_, geometry) = prepared.as_ref().expect("the geometry of `params` is held");
        Ok((geometry, order))
    }

    /// The pose of a pose vector (checked).
    fn pose(&self, pose: &[f64]) -> Result<Pose, MechanismError> {
        check_pose(self, pose, 6)?;
        Ok(pose_of(pose))
    }

    /// The pose of a warm start `(t, q)` (checked), its quaternion
    /// normalised; an error for a zero quaternion, which holds no
    /// rotation.
    fn start(&self, start: &[f64]) -> Result<Pose, MechanismError> {
        check_vector(self, "warm start values", start, WARM_START_LEN)?;
        pose_of_start(start).ok_or_else(|| MechanismError::Unreachable {
            reason: "the warm start's quaternion is zero: it holds no rotation".to_string(),
        })
    }
}

/// The pose of the [`WARM_START_LEN`] values of a warm start `(t, q)`
/// whose values are not checked, its quaternion normalised; none for a
/// zero quaternion.
fn pose_of_start(start: &[f64]) -> Option<Pose> {
    let q = Quaternion::new(start[6], start[3], start[4], start[5]);
    let rotation = UnitQuaternion::try_new(q, 0.0)?;
    Some(Isometry3::from_parts(
        Translation3::new(start[0], start[1], start[2]),
        rotation,
    ))
}

/// The number of values of a hexapod's warm start `(t, q)` (module doc).
pub const WARM_START_LEN: usize = 7;

/// The warm start `(t, q)` of an isometry (module doc).
pub fn warm_start_values(pose: &Pose) -> [f64; WARM_START_LEN] {
    let (t, q) = (pose.translation.vector, pose.rotation.coords);
    [t.x, t.y, t.z, q.x, q.y, q.z, q.w]
}

/// The row order of the closure Jacobian of `design` at its home pose
/// (the identity if its forward kinematics fails there). The closure
/// Jacobians over a hexapod's workspace differ little, so the lanes keep
/// that order nearly always, and a batch of contacts need not start with a
/// refused trial and partial pivoting.
fn design_pivot_order(design: &Geometry, options: &ForwardOptions) -> PivotOrder {
    let q = [0.0; 6];
    forward(design, &q, &design.home_pose(&q), options)
        .map_or_else(|_| PivotOrder::default(), |at| PivotOrder::of(&at.factor))
}

/// What a hexapod's batches of one [`BatchWorkspace`] share: the last
/// parameters and their canonical geometry, and the row order the last
/// factorisation of the lanes ended with, where the next one starts.
struct SharedByBatches {
    prepared: Option<(Vec<f64>, Geometry)>,
    order: PivotOrder,
}

/// [`SharedByBatches`] as a batch uses it: the geometry of its parameters
/// and the lanes' row order.
type Shared<'w> = (&'w Geometry, &'w mut PivotOrder);

/// A hexapod contact's [`Reached`] as the lanes write into it
/// ([`SolutionRoom`]): `J_f` into the first values of its `dT/dp |_q`, which
/// has room for the hexapod's form ([`Hexapod::form`]).
#[derive(TransparentWrapper)]
#[repr(transparent)]
struct RoomOfReached(Reached);

impl SolutionRoom for RoomOfReached {
    /// The warm start of `pose` and the tool tip into the room, and `J_f`'s
    /// room in its `dT/dp |_q` (the readings after it, with scales, are the
    /// caller's).
    fn solved(
        &mut self,
        pose: &Pose,
        tool_tip: &Vector3<f64>,
        _iterations: usize,
    ) -> &mut FactoredTipJacobian {
        let room = &mut self.0;
        room.warm_start.copy_from_slice(&warm_start_values(pose));
        room.point = *tool_tip;
        FactoredTipJacobian::in_values_mut(room.d_params.values_mut())
    }
}

/// Whether `a` and `b` hold the same numbers, bit for bit (every pair
/// compared, without a branch per pair).
fn same_bits(a: &[f64], b: &[f64]) -> bool {
    let differing = (a.iter().zip(b)).fold(0, |bits, (x, y)| bits | (x.to_bits() ^ y.to_bits()));
    a.len() == b.len() && differing == 0
}

/// The isometry of a pose vector `(t, r)`.
pub fn pose_of(x: &[f64]) -> Pose {
    Isometry3::new(
        Vector3::new(x[0], x[1], x[2]),
        Vector3::new(x[3], x[4], x[5]),
    )
}

/// The pose vector `(t, r)` of an isometry.
pub fn pose_vector(pose: &Pose) -> DVector<f64> {
    DVector::from_column_slice(&pose_coordinates(pose))
}

/// The coordinates `(t, r)` of an isometry.
fn pose_coordinates(pose: &Pose) -> [f64; 6] {
    let (t, r) = (pose.translation.vector, pose.rotation.scaled_axis());
    [t.x, t.y, t.z, r.x, r.y, r.z]
}

/// Entry `index` of `along` set to where a contact's forward kinematics
/// along a step `solution` reached ([`Mechanism::tool_points_along`]), in
/// the room of the entry there when it has its sizes.
fn write_along(
    along: &mut Vec<Result<ReachedAlong, MechanismError>>,
    index: usize,
    solution: &SolutionAlong,
) {
    write_entry(
        along,
        index,
        |room| {
            room.reached.warm_start.len() == WARM_START_LEN
                && room.reached.d_params.fits(&DENSE, 1, 3)
                && room.predicted.len() == WARM_START_LEN
        },
        || ReachedAlong {
            reached: Reached {
                warm_start: DVector::zeros(WARM_START_LEN),
                point: Vector3::zeros(),
                d_params: ParamsJacobian::zeros(1),
            },
            predicted: DVector::zeros(WARM_START_LEN),
        },
        |room| {
            room.reached
                .warm_start
                .copy_from_slice(&warm_start_values(&solution.pose));
            room.reached.point = solution.tool_tip;
            room.reached
                .d_params
                .values_mut()
                .copy_from_slice(solution.tip.as_slice());
            room.predicted
                .copy_from_slice(&warm_start_values(&solution.predicted));
        },
    );
}

impl Mechanism for Hexapod {
    fn name(&self) -> &str {
        "hexapod"
    }

    fn parameters(&self) -> &[Parameter] {
        &self.parameters
    }

    fn pose_coordinates(&self) -> &[PoseCoordinate] {
        &POSE
    }

    fn actuators(&self) -> &[Actuator] {
        &self.actuators
    }

    fn scale_parameters(&self) -> Option<std::ops::Range<usize>> {
        self.scaled.then_some(N_PARAMS..N_PARAMS + 6)
    }

    fn inverse(&self, params: &[f64], pose: &[f64]) -> Result<DVector<f64>, MechanismError> {
        let geometry = self.geometry(params)?;
        let extensions = actuators(&geometry, &self.pose(pose)?);
        Ok(DVector::from_fn(6, |i, _| {
            extensions[i] / self.scale(params, i)
        }))
    }

    fn forward(
        &self,
        params: &[f64],
        readings: &[f64],
        start: &[f64],
    ) -> Result<DVector<f64>, MechanismError> {
        let geometry = self.geometry(params)?;
        let q = self.extensions(params, readings)?;
        let solution = crate::forward(&geometry, &q, &self.pose(start)?, &self.options)?;
        Ok(pose_vector(&solution.pose))
    }

    fn reading_jacobians(
        &self,
        params: &[f64],
        pose: &[f64],
    ) -> Result<ReadingJacobians, MechanismError> {
        let geometry = self.geometry(params)?;
        let pose = self.pose(pose)?;
        let legs = Legs::at(&geometry, &pose);
        let rows = legs.closure_rows();
        let mut d_pose = DMatrix::from_fn(6, 6, |i, c| rows[i][c]);
        let mut d_params = DMatrix::zeros(6, self.parameters.len());
        for i in 0..6 {
            let n = legs.direction[i];
            let n_platform = legs.rotation.tr_mul(&n);
            for c in 0..3 {
                if let Some(k) = BASE_INDEX[i][c] {
                    d_params[(i, k)] = -n[c];
                }
                if let Some(k) = PLATFORM_INDEX[i][c] {
                    d_params[(i, k)] = n_platform[c];
                }
            }
            d_params[(i, leg_index(i))] = -1.0;
        }
        if self.scaled {
            let extensions = actuators(&geometry, &pose);
            for i in 0..6 {
                let s = params[N_PARAMS + i];
                d_params.row_mut(i).scale_mut(1.0 / s);
                d_pose.row_mut(i).scale_mut(1.0 / s);
                d_params[(i, N_PARAMS + i)] = -extensions[i] / (s * s);
            }
        }
        Ok(ReadingJacobians { d_params, d_pose })
    }

    fn tool_point(&self, params: &[f64], pose: &[f64]) -> Result<ToolPoint, MechanismError> {
        let geometry = self.geometry(params)?;
        let pose = self.pose(pose)?;
        let rotation = pose.rotation.to_rotation_matrix();
        let arm = rotation * geometry.tool;
        let mut d_pose = DMatrix::zeros(3, 6);
        d_pose.fixed_view_mut::<3, 3>(0, 0).fill_with_identity();
        d_pose
            .fixed_view_mut::<3, 3>(0, 3)
            .copy_from(&(-arm.cross_matrix()));
        let mut d_params = DMatrix::zeros(3, self.parameters.len());
        d_params
            .fixed_view_mut::<3, 3>(0, TOOL_OFFSET)
            .copy_from(rotation.matrix());
        Ok(ToolPoint {
            point: geometry.tool_tip(&pose),
            d_params,
            d_pose,
        })
    }

    /// Each point `geometry.tool_tip(pose)` at the pose of its warm start
    /// `(t, q)` (the quaternion normalised, no trigonometry), the geometry
    /// built once.
    fn tool_points_at_warm_starts(
        &self,
        params: &[f64],
        starts: &[&[f64]],
    ) -> Vec<Result<Vector3<f64>, MechanismError>> {
        match self.geometry(params) {
            Ok(geometry) => (starts.iter())
                .map(|start| Ok(geometry.tool_tip(&self.start(start)?)))
                .collect(),
            Err(e) => vec![Err(e); starts.len()],
        }
    }

    /// The forward kinematics in place and `J_f` from its factored
    /// closure ([`TipDerivatives::jacobians`]: three transposed solves of
    /// the LU the forward kinematics ends with), what the generic implicit
    /// differentiation forms anew.
    fn tool_point_at_readings(
        &self,
        params: &[f64],
        readings: &[f64],
        start: &[f64],
    ) -> Result<Reached, MechanismError> {
        let geometry = self.geometry(params)?;
        let q = self.extensions(params, readings)?;
        let mut derivatives = TipDerivatives::default();
        derivatives.forward(&geometry, &q, &self.start(start)?, &self.options)?;
        let pose = derivatives.solution().pose;
        Ok(Reached {
            warm_start: DVector::from_column_slice(&warm_start_values(&pose)),
            point: geometry.tool_tip(&pose),
            d_params: self.reached_rows(readings, &derivatives.factored()),
        })
    }

    /// Up to eight contacts at a time in SIMD lanes ([`forward_jacobian_batch`],
    /// `J_f` in factored form, its rows those of
    /// [`TipDerivatives::jacobians`]); the contacts of a batch whose lanes
    /// fail, or whose readings or starts are refused, one at a time, each
    /// with its own outcome.
    fn tool_points_at_readings(
        &self,
        params: &[f64],
        readings: &[&[f64]],
        starts: &[&[f64]],
        workspace: &mut BatchWorkspace,
        reached: &mut Vec<Result<Reached, MechanismError>>,
    ) {
        let Ok((geometry, order)) = self.shared(params, workspace) else {
            return tool_points_one_by_one(self, params, readings, starts, reached);
        };
        let (n_params, form, len) = (self.parameters.len(), self.form(), self.form_len());
        self.in_batches(
            params,
            readings,
            starts,
            LANES,
            reached,
            |reached, first, q, poses| {
                // Each contact's room, with its readings after `J_f`; the
                // lanes write the rest into it.
                for (l, readings) in readings[first..first + q.len()].iter().enumerate() {
                    write_reached(
                        reached,
                        first + l,
                        WARM_START_LEN,
                        form,
                        n_params,
                        len,
                        |room| {
                            self.write_readings(readings, &mut room.d_params);
                        },
                    );
                }
                let rooms = &mut reached[first..first + q.len()];
                let solved = forward_jacobian_batch(
                    geometry,
                    q,
                    poses,
                    &self.options,
                    &mut *order,
                    rooms,
                    |room| RoomOfReached::wrap_mut(room.as_mut().expect("a room written above")),
                );
                solved.is_ok()
            },
            |l| self.tool_point_at_readings(params, readings[l], starts[l]),
        );
    }

    /// Up to eight contacts at a time in SIMD lanes ([`forward_along_batch`]:
    /// `J_f dp` and the pose predicted at `p + dp`, without `J_f`), as
    /// [`Mechanism::tool_points_at_readings`] runs them; with unknown
    /// scales one at a time, each contact's step of its legs its own
    /// (`dl_i + q_i ds_i`, module doc).
    fn tool_points_along(
        &self,
        params: &[f64],
        readings: &[&[f64]],
        starts: &[&[f64]],
        dp: &[f64],
        workspace: &mut BatchWorkspace,
        along: &mut Vec<Result<ReachedAlong, MechanismError>>,
    ) {
        let step_refused = check_vector(self, "parameter step values", dp, self.parameters.len());
        let shared = step_refused.and_then(|()| self.shared(params, workspace));
        let Ok((geometry, order)) = shared else {
            return tool_points_along_by_rows(self, params, readings, starts, dp, workspace, along);
        };
        let mut solutions = [SolutionAlong::default(); LANES];
        let batch = if self.scaled { 1 } else { LANES };
        self.in_batches(
            params,
            readings,
            starts,
            batch,
            along,
            |along, first, q, poses| {
                let solutions = &mut solutions[..q.len()];
                let step = self.kinematic_step(dp, readings[first]);
                let solved = forward_along_batch(
                    geometry,
                    q,
                    poses,
                    &step,
                    &self.options,
                    &mut *order,
                    solutions,
                );
                solved.is_ok_and(|()| {
                    for (l, solution) in solutions.iter().enumerate() {
                        write_along(along, first + l, solution);
                    }
                    true
                })
            },
            |l| {
                self.tool_point_at_readings(params, readings[l], starts[l])
                    .and_then(|reached| along_of_reached(self, reached, dp))
            },
        );
    }

    fn warm_start_len(&self) -> usize {
        WARM_START_LEN
    }

    /// `(t, q)` of the pose `(t, r)` (module doc).
    fn warm_start(&self, pose: &[f64]) -> Result<DVector<f64>, MechanismError> {
        Ok(DVector::from_column_slice(&warm_start_values(
            &self.pose(pose)?,
        )))
    }

    /// `(t, r)` of the warm start `(t, q)` (module doc).
    fn pose_of_warm_start(&self, start: &[f64]) -> Result<DVector<f64>, MechanismError> {
        Ok(pose_vector(&self.start(start)?))
    }

    fn start_pose(&self, params: &[f64], readings: &[f64]) -> Result<DVector<f64>, MechanismError> {
        let geometry = self.geometry(params)?;
        Ok(pose_vector(
            &geometry.home_pose(&self.extensions(params, readings)?),
        ))
    }

    /// The platform's pose itself: `T = (R, t)`.
    fn platform_frame(&self, pose: &[f64]) -> Result<Isometry3<f64>, MechanismError> {
        self.pose(pose)
    }

    /// `x = (t, r)` of the frame; `dx/dε = I`, the pose's increments being
    /// `ε` ([`Mechanism::retract`]).
    fn pose_at_platform(&self, frame: &Isometry3<f64>) -> Result<PlatformPose, MechanismError> {
        Ok(PlatformPose {
            pose: pose_vector(frame),
            d_frame: DMatrix::identity(6, 6),
        })
    }

    fn retract(&self, pose: &[f64], increment: &[f64]) -> DVector<f64> {
        pose_vector(&step(
            &pose_of(pose),
            &Vector6::from_column_slice(increment),
            1.0,
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mechanism::{
        design, implicit_tool_point_at_readings, reading_jacobians_by_differences,
        tool_point_reading_jacobian, tool_points_along_by_rows,
    };
    use crate::{paper, rotation_zyx, tip_jacobians_at};
    use nalgebra::Translation3;

    fn hexapod() -> Hexapod {
        Hexapod::typical()
    }

    /// The same hexapod read in revolutions of scales 0.5 to 4 mm/rev.
    fn scaled() -> Hexapod {
        hexapod().with_unknown_scales("rev", [0.5, 0.8, 1.0, 1.25, 2.0, 4.0], [0.01; 6])
    }

    fn sample_pose() -> Pose {
        Pose::from_parts(
            Translation3::new(-30.0, 20.0, 240.0),
            rotation_zyx(0.1, -0.05, 0.08),
        )
    }

    #[test]
    fn the_adapter_gives_the_crates_kinematics() {
        let hexapod = hexapod();
        let p = to_params(&paper::truth().canonicalize().unwrap().geometry);
        let geometry = from_params(&p);
        let pose = sample_pose();
        let x = pose_vector(&pose);
        let q = hexapod.inverse(p.as_slice(), x.as_slice()).unwrap();
        assert_eq!(q.as_slice(), &actuators(&geometry, &pose));
        let start = pose_vector(&geometry.home_pose(&[0.0; 6]));
        let back = hexapod
            .forward(p.as_slice(), q.as_slice(), start.as_slice())
            .unwrap();
        assert!((back - &x).amax() < 1e-10, "forward kinematics");
        assert_eq!(design(&hexapod).len(), N_PARAMS);
        // Canonical by construction: no gauge freedom left.
        assert!(hexapod.gauge_freedoms(p.as_slice()).unwrap().is_empty());
        assert_eq!(hexapod.parameters()[LEG_OFFSET].group, "leg lengths");
    }

    /// The points at several warm starts, the geometry built once, are
    /// the tool points at their poses (to rounding: a pose from its
    /// quaternion, not its rotation vector); a start refused (not finite,
    /// or a zero quaternion) is refused alone, and parameters refused
    /// refuse every start.
    #[test]
    fn tool_points_at_warm_starts_are_each_tool_point() {
        let hexapod = hexapod();
        let p = design(&hexapod);
        let poses = [sample_pose(), Pose::identity()];
        let starts: Vec<[f64; WARM_START_LEN]> = poses.iter().map(warm_start_values).collect();
        let not_finite = [0.0, 0.0, f64::NAN, 0.0, 0.0, 0.0, 1.0];
        let no_rotation = [0.0, 0.0, 240.0, 0.0, 0.0, 0.0, 0.0];
        let mut slices: Vec<&[f64]> = starts.iter().map(|x| x.as_slice()).collect();
        slices.insert(1, &not_finite);
        slices.push(&no_rotation);
        let points = hexapod.tool_points_at_warm_starts(p.as_slice(), &slices);
        assert_eq!(points.len(), 4);
        for (point, pose) in [&points[0], &points[2]].into_iter().zip(&poses) {
            let expected = (hexapod.tool_point(p.as_slice(), pose_vector(pose).as_slice()))
                .unwrap()
                .point;
            assert!((point.as_ref().unwrap() - expected).amax() < 1e-12);
        }
        assert!(points[1].is_err() && points[3].is_err());
        let mut wrong = p.clone();
        wrong[LEG_OFFSET] = f64::INFINITY;
        let refused_params = hexapod.tool_points_at_warm_starts(wrong.as_slice(), &slices);
        assert_eq!(refused_params.len(), 4);
        assert!(refused_params.iter().all(Result::is_err));
    }

    #[test]
    fn reading_derivatives_match_central_differences() {
        for hexapod in [hexapod(), scaled()] {
            let p = design(&hexapod);
            let x = pose_vector(&sample_pose());
            let steps: Vec<f64> = (0..p.len())
                .map(|k| if k < N_PARAMS { 1e-4 } else { 1e-6 })
                .collect();
            let analytic = hexapod
                .reading_jacobians(p.as_slice(), x.as_slice())
                .unwrap();
            let numeric = reading_jacobians_by_differences(
                &hexapod,
                p.as_slice(),
                x.as_slice(),
                &steps,
                1e-5,
            )
            .unwrap();
            // Central differences with steps h = 1e-4 (joints, legs, tool),
            // 1e-6 (scales) and 1e-5 (pose): truncation h^2 |q'''| / 6, at
            // most 1e-8 for the geometry and 6e-10 for a scale (q =
            // e / s, |q'''| = 6 e / s^4 < 3000 with e < 45 mm, s >=
            // 0.5); rounding ~1e-16 |q| / h < 1e-8.
            assert!((&analytic.d_params - &numeric.d_params).amax() < 1e-7);
            assert!((&analytic.d_pose - &numeric.d_pose).amax() < 1e-6);
        }
    }

    #[test]
    fn scaled_readings_are_the_extensions_over_the_scales() {
        // The same pose read in mm and in revolutions; forward kinematics
        // from the revolutions; dT/dp |_q, the scales' columns included,
        // against central differences of the tool point reached at fixed
        // readings, and against the generic implicit differentiation.
        let (mm, rev) = (hexapod(), scaled());
        let p = design(&rev);
        let p = p.as_slice();
        let x = pose_vector(&sample_pose());
        let extensions = mm.inverse(&p[..N_PARAMS], x.as_slice()).unwrap();
        let q = rev.inverse(p, x.as_slice()).unwrap();
        for i in 0..6 {
            assert_eq!(q[i], extensions[i] / p[N_PARAMS + i]);
        }
        let start = rev.start_pose(p, q.as_slice()).unwrap();
        let back = rev.forward(p, q.as_slice(), start.as_slice()).unwrap();
        assert!((&back - &x).amax() < 1e-10, "forward kinematics");
        let start = rev.warm_start(start.as_slice()).unwrap();
        let own = rev
            .tool_point_at_readings(p, q.as_slice(), start.as_slice())
            .unwrap();
        let implicit = implicit_tool_point_at_readings(&rev, p, q.as_slice(), start.as_slice());
        // Two differentiations of one closure: rounding.
        let own_dense = own.d_params.to_dense();
        assert!((&own_dense - implicit.unwrap().d_params.to_dense()).amax() < 1e-9);
        assert_products_are_the_matrix(&own.d_params);
        let at = |p: &[f64]| {
            rev.tool_point_at_readings(p, q.as_slice(), start.as_slice())
                .unwrap()
                .point
        };
        let h = 1e-4;
        for k in N_PARAMS - 9..p.len() {
            let (mut plus, mut minus) = (p.to_vec(), p.to_vec());
            plus[k] += h;
            minus[k] -= h;
            let column = (at(&plus) - at(&minus)) / (2.0 * h);
            // The forward kinematics' closure tolerance, 1e-10 mm, over
            // 2h: 5e-7; truncation h^2 q^3 |T'''| / 6 with q below 100
            // rev: as small.
            let difference = (column - own_dense.column(k)).amax();
            assert!(difference < 1e-6, "parameter {k}: {difference:e}");
        }
    }

    #[test]
    fn tool_point_derivatives_match_central_differences() {
        let hexapod = hexapod();
        let p = design(&hexapod);
        let x = pose_vector(&sample_pose());
        let tool = hexapod.tool_point(p.as_slice(), x.as_slice()).unwrap();
        let geometry = from_params(&Params::from_column_slice(p.as_slice()));
        assert_eq!(tool.point, geometry.tool_tip(&sample_pose()));
        let at = |p: &[f64], x: &[f64]| hexapod.tool_point(p, x).unwrap().point;
        let h = 1e-5;
        for k in 0..N_PARAMS {
            let (mut plus, mut minus) = (p.clone(), p.clone());
            plus[k] += h;
            minus[k] -= h;
            let column = (at(plus.as_slice(), x.as_slice()) - at(minus.as_slice(), x.as_slice()))
                / (2.0 * h);
            // Linear in E_T, constant elsewhere: only rounding,
            // ~1e-16 * 400 mm / 1e-5.
            assert!(
                (column - tool.d_params.column(k)).amax() < 1e-8,
                "parameter {k}"
            );
        }
        for k in 0..6 {
            let step = DVector::from_fn(6, |i, _| if i == k { h } else { 0.0 });
            let plus = hexapod.retract(x.as_slice(), step.as_slice());
            let minus = hexapod.retract(x.as_slice(), (-step).as_slice());
            let column = (at(p.as_slice(), plus.as_slice()) - at(p.as_slice(), minus.as_slice()))
                / (2.0 * h);
            // Truncation ~h^2 |E_T| ~1e-8, rounding ~1e-16 * 400 / 1e-5.
            assert!(
                (column - tool.d_pose.column(k)).amax() < 1e-7,
                "pose increment {k}"
            );
        }
    }

    /// The pose at a platform frame is the frame's, and `G_x dx/dε` is
    /// the derivative of the readings by a change `ε = (δt, δω)` of the
    /// frame, against central differences.
    #[test]
    fn the_pose_at_a_platform_frame_moves_with_the_frame() {
        let hexapod = hexapod();
        let p = design(&hexapod);
        let frame = sample_pose();
        let at = hexapod.pose_at_platform(&frame).unwrap();
        let back = hexapod.platform_frame(at.pose.as_slice()).unwrap();
        assert!((back.to_homogeneous() - frame.to_homogeneous()).amax() < 1e-12);
        let readings = |e: &Vector6<f64>| {
            let moved = Isometry3::from_parts(
                (frame.translation.vector + e.fixed_rows::<3>(0)).into(),
                nalgebra::UnitQuaternion::from_scaled_axis(e.fixed_rows::<3>(3).into_owned())
                    * frame.rotation,
            );
            let x = hexapod.pose_at_platform(&moved).unwrap().pose;
            hexapod.inverse(p.as_slice(), x.as_slice()).unwrap()
        };
        let jacobians = hexapod
            .reading_jacobians(p.as_slice(), at.pose.as_slice())
            .unwrap();
        let analytic = &jacobians.d_pose * &at.d_frame;
        let h = 1e-6;
        for k in 0..6 {
            let step = Vector6::ith(k, h);
            let column = (readings(&step) - readings(&-step)) / (2.0 * h);
            // Truncation ~h^2 * 400 mm, rounding ~1e-16 * 700 mm / 1e-6.
            assert!(
                (column - analytic.column(k)).amax() < 1e-7,
                "frame change {k}"
            );
        }
        let delta = crate::delta::LinearDelta::typical();
        assert!(matches!(
            delta.pose_at_platform(&frame),
            Err(MechanismError::NoModel { .. })
        ));
    }

    #[test]
    fn the_tool_point_at_readings_is_the_crates_tool_tip_and_its_jacobian() {
        // The hexapod's own `J_f` and the generic implicit differentiation,
        // dT/dp = [I, -[R E_T]x] dx/dp + R dE_T/dp, from the readings and
        // the home pose, against the crate's tool tip and `J_f` at the
        // pose.
        let hexapod = hexapod();
        let p = design(&hexapod);
        let geometry = from_params(&Params::from_column_slice(p.as_slice()));
        let pose = sample_pose();
        let q = hexapod
            .inverse(p.as_slice(), pose_vector(&pose).as_slice())
            .unwrap();
        let start = hexapod.start_pose(p.as_slice(), q.as_slice()).unwrap();
        let start = hexapod.warm_start(start.as_slice()).unwrap();
        let reference = tip_jacobians_at(&geometry, &pose).unwrap().d_params;
        let reference = DMatrix::from_column_slice(3, N_PARAMS, reference.as_slice());
        let own = hexapod.tool_point_at_readings(p.as_slice(), q.as_slice(), start.as_slice());
        let implicit =
            implicit_tool_point_at_readings(&hexapod, p.as_slice(), q.as_slice(), start.as_slice());
        for reached in [own.unwrap(), implicit.unwrap()] {
            // The forward kinematics' tolerance, 1e-9 mm in the tip.
            assert!((reached.point - geometry.tool_tip(&pose)).amax() < 1e-9);
            let reached_pose = hexapod.pose_of_warm_start(reached.warm_start.as_slice());
            let turned = pose_of(reached_pose.unwrap().as_slice()).inverse() * pose;
            assert!(turned.translation.vector.amax() < 1e-9 && turned.rotation.angle() < 1e-9);
            let difference = (reached.d_params.to_dense() - &reference).amax();
            assert!(difference < 1e-9, "{difference:e}");
            assert_products_are_the_matrix(&reached.d_params);
        }
    }

    /// A `dT/dp |_q`'s products, dense or factored, against its matrix
    /// (whose rows are its combinations of the base-frame axes): a
    /// combination of rows and a product with a step, of entries of order
    /// 1 and sums of at most 45 products, to rounding.
    fn assert_products_are_the_matrix(d_params: &ParamsJacobian) {
        let dense = d_params.to_dense();
        let n = dense.ncols();
        let v = DVector::from_fn(n, |k, _| ((k as f64) * 0.37).sin());
        let difference = (d_params.apply(v.as_slice()) - &dense * &v).amax();
        assert!(
            difference < 1e-12 * dense.amax() * n as f64,
            "J v: {difference:e}"
        );
        let h = Vector3::new(0.6, -0.3, 1.1);
        let difference = (d_params.combination(&h) - dense.tr_mul(&h)).amax();
        assert!(difference < 1e-12 * dense.amax(), "h^T J: {difference:e}");
    }

    #[test]
    fn a_warm_start_is_the_pose_s_translation_and_quaternion() {
        // (t, r) -> (t, q) -> (t, r) to rounding; any nonzero quaternion
        // is normalised; a zero one, a short start or a NaN refused.
        let hexapod = hexapod();
        let pose = pose_vector(&sample_pose());
        let start = hexapod.warm_start(pose.as_slice()).unwrap();
        assert_eq!(start.len(), hexapod.warm_start_len());
        let rotation = sample_pose().rotation.coords;
        let quaternion = start.rows(3, 4);
        assert!(
            (quaternion - rotation).amax() < 1e-15,
            "{quaternion} {rotation}"
        );
        let back = hexapod.pose_of_warm_start(start.as_slice()).unwrap();
        assert!((&back - &pose).amax() < 1e-15, "{back} {pose}");
        let mut scaled = start.clone();
        scaled.as_mut_slice()[3..]
            .iter_mut()
            .for_each(|v| *v *= -3.0);
        let back = hexapod.pose_of_warm_start(scaled.as_slice()).unwrap();
        assert!((&back - &pose).amax() < 1e-15, "{back} {pose}");
        let refused = |start: &[f64]| hexapod.pose_of_warm_start(start).unwrap_err().to_string();
        let mut zero = start.clone();
        zero.as_mut_slice()[3..].fill(0.0);
        assert!(refused(zero.as_slice()).contains("quaternion is zero"));
        assert_eq!(
            refused(&start.as_slice()[..6]),
            "hexapod needs 7 warm start values, got 6"
        );
        let mut nan = start;
        nan[4] = f64::NAN;
        assert!(refused(nan.as_slice()).contains("warm start values 5"));
    }

    #[test]
    fn the_lanes_reach_what_one_contact_at_a_time_reaches() {
        // Seven contacts (one batch of the lanes), each
        // from its home pose; then the same with a short reading vector
        // among them, which is refused alone, and with a reading and a warm
        // start value that are not finite, each refused alone.
        for hexapod in [hexapod(), scaled()] {
            lanes_reach_one_by_one(&hexapod);
        }
    }

    /// Seven contacts' readings at the design `p` of `hexapod` (one batch of
    /// the lanes: eight of AVX-512, or four and three of AVX2), and each
    /// one's home pose as a warm start.
    fn seven_contacts(hexapod: &Hexapod, p: &[f64]) -> (Vec<DVector<f64>>, Vec<DVector<f64>>) {
        let readings: Vec<DVector<f64>> = (0..7)
            .map(|k| {
                let k = f64::from(k);
                let pose = Pose::from_parts(
                    Translation3::new(-30.0 + 9.0 * k, 20.0 - 4.0 * k, 230.0 + 3.0 * k),
                    rotation_zyx(0.1 - 0.02 * k, -0.05, 0.01 * k),
                );
                hexapod.inverse(p, pose_vector(&pose).as_slice()).unwrap()
            })
            .collect();
        let starts = readings
            .iter()
            .map(|q| {
                let home = hexapod.start_pose(p, q.as_slice()).unwrap();
                hexapod.warm_start(home.as_slice()).unwrap()
            })
            .collect();
        (readings, starts)
    }

    fn lanes_reach_one_by_one(hexapod: &Hexapod) {
        let p = design(hexapod);
        let p = p.as_slice();
        let (readings, starts) = seven_contacts(hexapod, p);
        let mut q: Vec<&[f64]> = readings.iter().map(|q| q.as_slice()).collect();
        let x: Vec<&[f64]> = starts.iter().map(|x| x.as_slice()).collect();
        let same_as_one_by_one =
            |p: &[f64], q: &[&[f64]], x: &[&[f64]], batch: &[Result<Reached, MechanismError>]| {
                assert_eq!(batch.len(), q.len());
                for ((q, x), reached) in q.iter().zip(x).zip(batch) {
                    let one = hexapod.tool_point_at_readings(p, q, x).unwrap();
                    let reached = reached.as_ref().unwrap();
                    // The lanes' LU may pivot otherwise: rounding of the
                    // forward kinematics' 1e-9 mm.
                    assert!((reached.point - one.point).amax() < 1e-9);
                    assert!((&reached.warm_start - &one.warm_start).amax() < 1e-9);
                    let difference = (reached.d_params.to_dense() - one.d_params.to_dense()).amax();
                    assert!(difference < 1e-9, "{difference:e}");
                }
            };
        let (mut batch, workspace) = (Vec::new(), &mut BatchWorkspace::default());
        hexapod.tool_points_at_readings(p, &q, &x, workspace, &mut batch);
        same_as_one_by_one(p, &q, &x, &batch);
        // Into the room of the first batch, one contact's readings refused.
        let full = q.clone();
        q[5] = &q[5][..5];
        hexapod.tool_points_at_readings(p, &q, &x, workspace, &mut batch);
        for (k, reached) in batch.iter().enumerate() {
            match k {
                5 => assert_eq!(
                    reached.as_ref().unwrap_err().to_string(),
                    "hexapod needs 6 readings, got 5"
                ),
                _ => assert!(reached.is_ok(), "{k}: {reached:?}"),
            }
        }
        // A reading and a warm start value that are not finite: each
        // contact refused by name, as one at a time, the others reached.
        let mut q = full.clone();
        let mut not_finite = x.clone();
        let nan_reading = readings[2].map(|v| v + f64::NAN);
        let mut infinite_start = starts[4].clone();
        infinite_start[1] = f64::INFINITY;
        (q[2], not_finite[4]) = (nan_reading.as_slice(), infinite_start.as_slice());
        for along in [false, true] {
            let outcomes: Vec<Result<(), MechanismError>> = if along {
                let dp = vec![0.0; p.len()];
                let mut along = Vec::new();
                hexapod.tool_points_along(p, &q, &not_finite, &dp, workspace, &mut along);
                along.into_iter().map(|r| r.map(drop)).collect()
            } else {
                hexapod.tool_points_at_readings(p, &q, &not_finite, workspace, &mut batch);
                batch
                    .iter()
                    .map(|r| r.as_ref().map(drop).map_err(Clone::clone))
                    .collect()
            };
            for (k, outcome) in outcomes.iter().enumerate() {
                match k {
                    2 | 4 => {
                        let alone = hexapod.tool_point_at_readings(p, q[k], not_finite[k]);
                        let error = outcome.as_ref().unwrap_err().to_string();
                        assert_eq!(error, alone.unwrap_err().to_string());
                        assert!(error.contains("not a finite number"), "{k}: {error}");
                    }
                    _ => assert!(outcome.is_ok(), "{k}: {outcome:?}"),
                }
            }
        }
        // The contacts in another order into that room, then fewer.
        let (mut q, mut x) = (full, x.clone());
        q.reverse();
        x.reverse();
        hexapod.tool_points_at_readings(p, &q, &x, workspace, &mut batch);
        same_as_one_by_one(p, &q, &x, &batch);
        hexapod.tool_points_at_readings(p, &q[..3], &x[..3], workspace, &mut batch);
        same_as_one_by_one(p, &q[..3], &x[..3], &batch);
        // Other parameters in the same workspace (a leg 0.1 mm longer):
        // their own geometry, not the last batch's.
        let mut longer = p.to_vec();
        longer[LEG_OFFSET] += 0.1;
        hexapod.tool_points_at_readings(&longer, &q, &x, workspace, &mut batch);
        same_as_one_by_one(&longer, &q, &x, &batch);
    }

    #[test]
    fn the_lanes_along_a_step_give_its_product_and_predict_the_pose() {
        for hexapod in [hexapod(), scaled()] {
            lanes_along_a_step(&hexapod);
        }
    }

    /// Seven contacts along a step `dp` of every parameter (tenths of a
    /// micrometre, parts in 1e6 of a scale): the lanes give `dT/dp |_q dp`
    /// of the rows one contact at a time, and a pose predicted to first
    /// order, its error against the forward kinematics at `p + dp` of the
    /// second order; a step of the wrong length refuses every contact.
    fn lanes_along_a_step(hexapod: &Hexapod) {
        let p = design(hexapod);
        let (readings, starts) = seven_contacts(hexapod, p.as_slice());
        let q: Vec<&[f64]> = readings.iter().map(|q| q.as_slice()).collect();
        let x: Vec<&[f64]> = starts.iter().map(|x| x.as_slice()).collect();
        let dp = DVector::from_fn(p.len(), |k, _| {
            let size = if k < N_PARAMS { 1e-4 } else { 1e-6 * p[k] };
            size * (1.0 + k as f64).sin()
        });
        let (mut along, workspace) = (Vec::new(), &mut BatchWorkspace::default());
        hexapod.tool_points_along(p.as_slice(), &q, &x, dp.as_slice(), workspace, &mut along);
        let (mut by_rows, fresh) = (Vec::new(), &mut BatchWorkspace::default());
        tool_points_along_by_rows(
            hexapod,
            p.as_slice(),
            &q,
            &x,
            dp.as_slice(),
            fresh,
            &mut by_rows,
        );
        let moved = &p + &dp;
        for (k, (lanes, rows)) in along.iter().zip(&by_rows).enumerate() {
            let (lanes, rows) = (lanes.as_ref().unwrap(), rows.as_ref().unwrap());
            // Rounding of the forward kinematics' 1e-9 mm, as above.
            assert!((lanes.reached.point - rows.reached.point).amax() < 1e-9);
            assert!((&lanes.reached.warm_start - &rows.reached.warm_start).amax() < 1e-9);
            assert_eq!(lanes.reached.d_params.ncols(), 1);
            let product = &rows.reached.d_params;
            let difference = (lanes.reached.d_params.to_dense() - product.to_dense()).amax();
            assert!(
                difference < 1e-9 * product.to_dense().amax(),
                "{k}: {difference:e}"
            );
            // The pose moves by ~1e-4 (mm and rad) along the step; the
            // prediction's error is of its square over the machine's
            // ~100 mm: 1e-10 and below.
            let pose = |start: &DVector<f64>| hexapod.pose_of_warm_start(start.as_slice()).unwrap();
            let exact = hexapod.forward(moved.as_slice(), q[k], pose(&starts[k]).as_slice());
            let exact = exact.unwrap();
            let shift = (&exact - pose(&lanes.reached.warm_start)).amax();
            let error = (&exact - pose(&lanes.predicted)).amax();
            assert!(
                shift > 1e-6 && error < 1e-3 * shift,
                "{k}: {shift:e} {error:e}"
            );
        }
        let short = &dp.as_slice()[1..];
        hexapod.tool_points_along(p.as_slice(), &q, &x, short, workspace, &mut along);
        assert_eq!(along.len(), q.len());
        for outcome in &along {
            let error = outcome.as_ref().unwrap_err().to_string();
            assert!(error.contains("parameter step values"), "{error}");
        }
    }

    #[test]
    fn the_tool_points_reading_jacobian_is_the_crates() {
        // dT/dq = dT/dx G_x^-1 through the trait against the crate's own,
        // K = P A^-1 from the forward kinematics' factorisation.
        let hexapod = hexapod();
        let p = design(&hexapod);
        let geometry = from_params(&Params::from_column_slice(p.as_slice()));
        let pose = sample_pose();
        let d_q =
            tool_point_reading_jacobian(&hexapod, p.as_slice(), pose_vector(&pose).as_slice())
                .unwrap();
        let reference = tip_jacobians_at(&geometry, &pose).unwrap().d_q;
        let difference = (d_q - DMatrix::from_column_slice(3, 6, reference.as_slice())).amax();
        // Two solves of one well-conditioned 6 x 6 system: rounding.
        assert!(difference < 1e-12, "{difference:e}");
    }

    #[test]
    fn wrong_lengths_and_non_finite_values_are_named() {
        let hexapod = hexapod();
        let p = design(&hexapod);
        let err = hexapod.inverse(&p.as_slice()[..5], &[0.0; 6]).unwrap_err();
        assert_eq!(err.to_string(), "hexapod has 33 parameters, got 5");
        let mut bad = p.clone();
        bad[13] = f64::NAN;
        let err = hexapod.inverse(bad.as_slice(), &[0.0; 6]).unwrap_err();
        assert_eq!(err.to_string(), "parameter l_2 is not a finite number");
        let err = hexapod.inverse(p.as_slice(), &[0.0; 5]).unwrap_err();
        assert_eq!(err.to_string(), "hexapod needs 6 pose coordinates, got 5");
        let pose = [0.0, 0.0, 200.0, 0.0, f64::INFINITY, 0.0];
        let err = hexapod.inverse(p.as_slice(), &pose).unwrap_err();
        assert_eq!(
            err.to_string(),
            "pose coordinate r_y is not a finite number"
        );
        let scaled = scaled();
        let mut p = design(&scaled);
        p[N_PARAMS + 2] = 0.0;
        let err = scaled
            .forward(p.as_slice(), &[1.0; 6], &[0.0; 6])
            .unwrap_err();
        assert_eq!(
            err.to_string(),
            "unreachable: scale s_3 is 0 mm/rev, not positive"
        );
    }
}
