//! The interface every parallel mechanism implements: [`Mechanism`].
//!
//! A mechanism maps a pose `x` (its [`Mechanism::pose_coordinates`]) and a
//! parameter vector `p` (its [`Mechanism::parameters`]) to the readings `q`
//! of its actuators (inverse kinematics, `q = g(p, x)`), and back (forward
//! kinematics, `x = f(p, q)`, one assembly mode). A calibration needs the
//! analytic derivatives `G_p = dg/dp` and `G_x = dg/dx`
//! ([`Mechanism::reading_jacobians`]); the derivative of the pose at fixed
//! readings follows by implicit differentiation of `g(p, f(p, q)) = q`:
//!
//! ```text
//! dx/dp |_q = -G_x^-1 G_p            (pose_jacobian_at_fixed_readings)
//! ```
//!
//! Sizes are dynamic (slices in, [`DVector`]/[`DMatrix`] out): the hexapod
//! has 33 parameters, 6 actuators and a 6-coordinate pose, the linear delta
//! 16, 3 and 3.
//!
//! # Why a trait object
//!
//! The trait is object safe and used as `&dyn Mechanism`: a calibration
//! picks its mechanism at run time from a file ([`crate::mechanisms`], the
//! one list), the sizes are dynamic anyway, and the per-observation cost
//! of a virtual call is small next to a forward kinematics (a Newton
//! iteration or a trilateration). A mechanism with a hot path of its own
//! (the hexapod's SIMD lanes, [`crate::forward_batch`]) keeps it behind its
//! concrete type; the trait is the common door, not the only one.
//!
//! # Pose increments
//!
//! `G_x` is taken with respect to a local increment `dx` of the pose applied
//! by [`Mechanism::retract`]: plain addition by default (a delta's effector
//! translation), the left rotation increment for a pose with an
//! orientation (the hexapod). Finite-difference checks step with `retract`.
//!
//! # The tool point
//!
//! What a probe, a tracker or a touched ball sees is one point of the
//! moving body, the tool point `T(p, x)` ([`Mechanism::tool_point`]): the
//! pose itself for a mechanism whose pose is a position (a delta's
//! effector, a cable robot's), `T = t + R E_T` for the hexapod (its tool
//! offset `E_T` among the parameters). At fixed readings its derivative
//! with respect to the parameters is
//!
//! ```text
//! dT/dp |_q = dT/dp |_x + dT/dx dx/dp |_q
//!           = dT/dp |_x - (dT/dx G_x^-1) G_p       (implicit_tool_point_at_readings)
//! ```
//!
//! where `dT/dq = dT/dx G_x^-1` ([`tool_point_reading_jacobian`]) is how
//! the readings move the tool point: three transposed solves instead of
//! one per parameter.
//!
//! # The platform frame
//!
//! A tracker that measures a rigid body on the moving platform (a 6-dof
//! probe, a motion-capture body) sees the platform's frame, not one point:
//! [`Mechanism::platform_frame`] is the rigid motion (platform → base) at
//! a pose, and [`Mechanism::pose_at_platform`] its inverse with `dx/dε`,
//! `ε = (δt, δω)` a change of the frame (`t → t + δt`, `R → Exp(δω) R`).
//! Only a mechanism whose pose fixes an orientation has them (the
//! hexapod); a delta's or a cable robot's effector is a point to its
//! model.
//!
//! # Warm starts
//!
//! A calibration reaches each contact at its readings again and again, each
//! time from where the last evaluation left it. What it keeps is the
//! contact's warm start ([`Mechanism::warm_start`]): the pose coordinates
//! by default, or what the mechanism's forward kinematics starts from
//! without a conversion (the hexapod: its translation and unit
//! quaternion, where its pose coordinates' rotation vector would cost a
//! sine and an arc tangent each way). [`Mechanism::tool_point_at_readings`]
//! and its batches start from warm starts and leave one in what they
//! return ([`Reached::warm_start`]); [`Mechanism::pose_of_warm_start`]
//! gives the pose back.
//!
//! # Gauge
//!
//! Some parameter combinations change no measurement: a rigid motion of the
//! frame the mechanism is described in, or two parameters that only enter
//! as a sum. [`Mechanism::gauge_freedoms`] names them (as directions in
//! parameter space, at given parameters) and [`Mechanism::canonicalize`]
//! removes them, returning the parameters of the same machine in the
//! mechanism's canonical frame. A parametrisation that is canonical by
//! construction (the hexapod's 33) has none left.

use std::borrow::Cow;

use nalgebra::{DMatrix, DVector, Isometry3, Vector3};

use crate::KinematicsError;
use crate::batch_workspace::BatchWorkspace;
use crate::params_jacobian::{JacobianForm, ParamsJacobian};

/// One kinematic parameter: what it is and what the designer knows of it.
#[derive(Debug, Clone, PartialEq)]
pub struct Parameter {
    /// Short name, unique within the mechanism (`diagonal_a`, `y_b2`).
    pub name: String,
    /// Unit of the value, its prior and its derivatives' denominator
    /// (`mm`, `deg`, `%`, `mm/rev`).
    pub unit: Cow<'static, str>,
    /// The group it belongs to (`endstops`, `leg lengths`): one tolerance
    /// per group in a design's file, one block per group in a report.
    pub group: &'static str,
    /// The design (nominal) value.
    pub design: f64,
    /// The builder's tolerance: one standard deviation of the prior
    /// observation `p = design` (in `unit`).
    pub prior_sigma: f64,
}

/// One coordinate of the pose.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PoseCoordinate {
    /// Name (`x`, `w_z`).
    pub name: &'static str,
    /// Unit (`mm`, `rad`).
    pub unit: &'static str,
}

/// The model of one actuator's reading: `q = scale * raw + offset`, with
/// `raw` what the controller counts (steps, encoder counts) and `q` the
/// reading the kinematics uses.
#[derive(Debug, Clone, PartialEq)]
pub struct Actuator {
    /// Name (`carriage A`, `leg 3`).
    pub name: String,
    /// Unit of `q` (`mm`, `rev`).
    pub unit: Cow<'static, str>,
    /// `q` per unit of `raw`.
    pub scale: f64,
    /// `q` at `raw = 0`.
    pub offset: f64,
}

impl Actuator {
    /// An actuator that reports `q` directly (scale 1, offset 0).
    pub fn direct(name: String, unit: impl Into<Cow<'static, str>>) -> Self {
        Self {
            name,
            unit: unit.into(),
            scale: 1.0,
            offset: 0.0,
        }
    }

    /// The reading `q` of a raw count.
    pub fn reading(&self, raw: f64) -> f64 {
        self.scale * raw + self.offset
    }
}

/// The derivatives of the readings at one pose.
#[derive(Debug, Clone, PartialEq)]
pub struct ReadingJacobians {
    /// `G_p = dq/dp` (actuators x parameters).
    pub d_params: DMatrix<f64>,
    /// `G_x = dq/dx` (actuators x pose increment), `x` stepped by
    /// [`Mechanism::retract`].
    pub d_pose: DMatrix<f64>,
}

/// The tool point at a pose and its derivatives (module documentation).
#[derive(Debug, Clone, PartialEq)]
pub struct ToolPoint {
    /// `T(p, x)` (mm).
    pub point: Vector3<f64>,
    /// `dT/dp` at fixed pose (3 x parameters).
    pub d_params: DMatrix<f64>,
    /// `dT/dx` (3 x pose increment), `x` stepped by [`Mechanism::retract`].
    pub d_pose: DMatrix<f64>,
}

/// The pose at a platform frame ([`Mechanism::pose_at_platform`]).
#[derive(Debug, Clone, PartialEq)]
pub struct PlatformPose {
    /// `x`.
    pub pose: DVector<f64>,
    /// `dx/dε` (pose increment × 6), `ε = (δt, δω)`.
    pub d_frame: DMatrix<f64>,
}

/// A quantity of the machine that is a known function of its parameters
/// and can be measured on it directly, such as a cable robot's line length
/// at the encoder zero ([`Mechanism::quantities`]).
#[derive(Debug, Clone, PartialEq)]
pub struct Quantity {
    /// Short name, unique within the mechanism (`line_length_a`).
    pub name: String,
    /// Unit of the value (`mm`).
    pub unit: &'static str,
}

/// A quantity's value at some parameters and its gradient.
#[derive(Debug, Clone, PartialEq)]
pub struct QuantityValue {
    /// The value, in the quantity's unit.
    pub value: f64,
    /// Its derivative by each parameter.
    pub gradient: DVector<f64>,
}

/// A parameter combination that no measurement can see.
#[derive(Debug, Clone, PartialEq)]
pub struct GaugeFreedom {
    /// What it is (`rotation about z`, `homed height + mean endstop`).
    pub name: &'static str,
    /// The direction in parameter space (at the parameters it was asked
    /// at; unit Euclidean norm).
    pub direction: DVector<f64>,
}

/// Why a pose cannot be reached or a reading cannot be assembled.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MechanismError {
    /// A parameter vector of the wrong length.
    #[error("{mechanism} has {expected} parameters, got {found}")]
    ParameterCount {
        /// The mechanism.
        mechanism: String,
        /// Its parameter count.
        expected: usize,
        /// The length given.
        found: usize,
    },
    /// A pose or reading vector of the wrong length.
    #[error("{mechanism} needs {expected} {what}, got {found}")]
    Dimension {
        /// The mechanism.
        mechanism: String,
        /// `pose coordinates` or `readings`.
        what: &'static str,
        /// The length it needs.
        expected: usize,
        /// The length given.
        found: usize,
    },
    /// A NaN or infinite value.
    #[error("{what} is not a finite number")]
    NonFinite {
        /// The value (`parameter diagonal_b`, `reading 2`).
        what: String,
    },
    /// A parameter's value that no machine of its kind has.
    #[error("parameter {name} = {value}: {reason}")]
    Parameter {
        /// The parameter.
        name: String,
        /// Its value.
        value: f64,
        /// Why no machine has it.
        reason: String,
    },
    /// The pose is outside the mechanism's reach or limits.
    #[error("unreachable: {reason}")]
    Unreachable {
        /// The limit violated, with its numbers.
        reason: String,
    },
    /// `dq/dx` is singular at the pose (a singular configuration).
    #[error("dq/dx is singular at this pose (a singular configuration)")]
    Singular,
    /// The mechanism has no such model or quantity.
    #[error("the {mechanism} has no {what}")]
    NoModel {
        /// The mechanism.
        mechanism: String,
        /// What it lacks (`load model`, `quantity 4`).
        what: String,
    },
    /// An error of the hexapod's kinematics.
    #[error(transparent)]
    Hexapod(#[from] KinematicsError),
}

/// A parallel mechanism (module documentation). `Send + Sync`: a
/// calibration evaluates its observations from several threads.
pub trait Mechanism: Send + Sync {
    /// The mechanism's name (`hexapod`, `linear delta`).
    fn name(&self) -> &str;

    /// The parameters, in the order of every parameter vector.
    fn parameters(&self) -> &[Parameter];

    /// The pose coordinates, in the order of every pose vector.
    fn pose_coordinates(&self) -> &[PoseCoordinate];

    /// The actuators, in the order of every reading vector.
    fn actuators(&self) -> &[Actuator];

    /// Refuses parameters no machine of this kind has, naming the first
    /// parameter at fault ([`MechanismError::Parameter`]); by default a
    /// vector of the wrong length or with a value that is not finite
    /// ([`check_params`]).
    fn check_parameters(&self, params: &[f64]) -> Result<(), MechanismError> {
        check_params(self, params)
    }

    /// The parameters that are the actuators' scales when they are
    /// unknowns: actuator `i`'s scale `s_i` (its extension per unit of its
    /// reading) is parameter `start + i`. `None` (the default) when the
    /// readings are the extensions, or their scales are known.
    fn scale_parameters(&self) -> Option<std::ops::Range<usize>> {
        None
    }

    /// The scales' values at `params` (the parameters
    /// [`Mechanism::scale_parameters`] names), one per actuator; `None`
    /// when they are not parameters.
    fn scales<'p>(&self, params: &'p [f64]) -> Option<&'p [f64]> {
        self.scale_parameters().map(|range| &params[range])
    }

    /// Inverse kinematics: the readings `q = g(p, x)` that put the
    /// mechanism at `pose`. An error when the pose cannot be assembled.
    fn inverse(&self, params: &[f64], pose: &[f64]) -> Result<DVector<f64>, MechanismError>;

    /// Forward kinematics: the pose `x = f(p, q)` at `readings`, in the
    /// mechanism's working assembly mode; `start` is a nearby pose for an
    /// iterative solution (closed forms ignore it). With more actuators
    /// than pose coordinates, the least-squares pose of the readings
    /// ([`crate::pose_fit`]).
    fn forward(
        &self,
        params: &[f64],
        readings: &[f64],
        start: &[f64],
    ) -> Result<DVector<f64>, MechanismError>;

    /// `dq/dp` and `dq/dx` at `pose`, analytic.
    fn reading_jacobians(
        &self,
        params: &[f64],
        pose: &[f64],
    ) -> Result<ReadingJacobians, MechanismError>;

    /// The pose `x` moved by a local increment `dx` (module documentation);
    /// by default `x + dx`.
    fn retract(&self, pose: &[f64], increment: &[f64]) -> DVector<f64> {
        DVector::from_column_slice(pose) + DVector::from_column_slice(increment)
    }

    /// The tool point `T(p, x)` at `pose`, with its analytic derivatives
    /// (module documentation). By default the pose is the point, for a
    /// mechanism whose pose is a position `(x, y, z)`: `dT/dp = 0`,
    /// `dT/dx = I`; a mechanism with another pose must say where its tool
    /// is (an error otherwise).
    fn tool_point(&self, params: &[f64], pose: &[f64]) -> Result<ToolPoint, MechanismError> {
        check_params(self, params)?;
        check_pose(self, pose, 3)?;
        Ok(ToolPoint {
            point: Vector3::new(pose[0], pose[1], pose[2]),
            d_params: DMatrix::zeros(3, params.len()),
            d_pose: DMatrix::identity(3, 3),
        })
    }

    /// The tool points `T(p, x)` at the poses `x` of several warm starts
    /// `starts` (module doc), in order, without their derivatives:
    /// [`Mechanism::tool_point`]'s points at
    /// [`Mechanism::pose_of_warm_start`] by default; a mechanism that
    /// builds something of `p` for each point overrides it with the same
    /// values, built once (the hexapod: its geometry, each pose from its
    /// translation and quaternion).
    fn tool_points_at_warm_starts(
        &self,
        params: &[f64],
        starts: &[&[f64]],
    ) -> Vec<Result<Vector3<f64>, MechanismError>> {
        (starts.iter())
            .map(|start| {
                let pose = self.pose_of_warm_start(start)?;
                Ok(self.tool_point(params, pose.as_slice())?.point)
            })
            .collect()
    }

    /// The number of values of a warm start (module doc): the pose
    /// coordinates' by default.
    fn warm_start_len(&self) -> usize {
        self.pose_coordinates().len()
    }

    /// The warm start at the pose `pose` (module doc): the pose itself by
    /// default. An error for other than one finite value per pose
    /// coordinate.
    fn warm_start(&self, pose: &[f64]) -> Result<DVector<f64>, MechanismError> {
        check_vector(
            self,
            "pose coordinates",
            pose,
            self.pose_coordinates().len(),
        )?;
        Ok(DVector::from_column_slice(pose))
    }

    /// The pose of the warm start `start` ([`Mechanism::warm_start`]'s
    /// inverse): the start itself by default. An error for other than
    /// [`Mechanism::warm_start_len`] finite values.
    fn pose_of_warm_start(&self, start: &[f64]) -> Result<DVector<f64>, MechanismError> {
        check_vector(self, "warm start values", start, self.warm_start_len())?;
        Ok(DVector::from_column_slice(start))
    }

    /// Where the machine is at `readings` ([`Reached`]): its forward
    /// kinematics from the warm start `start` (module doc), its tool point
    /// and `dT/dp |_q`. By default
    /// by implicit differentiation ([`implicit_tool_point_at_readings`]); a
    /// mechanism that has these from its own factorisation of the closure
    /// overrides it with the same values (the hexapod: its `J_f`).
    fn tool_point_at_readings(
        &self,
        params: &[f64],
        readings: &[f64],
        start: &[f64],
    ) -> Result<Reached, MechanismError> {
        implicit_tool_point_at_readings(self, params, readings, start)
    }

    /// [`Mechanism::tool_point_at_readings`] of several contacts, contact
    /// `l` at `readings[l]` from the warm start `starts[l]`, each outcome in order into
    /// `reached` (as many as the contacts): one after another by default;
    /// a mechanism whose forward kinematics runs several contacts at once
    /// overrides it with the same values, to rounding (the hexapod: four
    /// in SIMD lanes), and may write them into the room of the `Ok`
    /// entries `reached` holds ([`write_reached`]), so that a caller who
    /// keeps `reached` from batch to batch allocates nothing, and keep in
    /// `workspace` what its batches share ([`BatchWorkspace`]).
    ///
    /// # Panics
    /// If `readings` and `starts` differ in length.
    fn tool_points_at_readings(
        &self,
        params: &[f64],
        readings: &[&[f64]],
        starts: &[&[f64]],
        _workspace: &mut BatchWorkspace,
        reached: &mut Vec<Result<Reached, MechanismError>>,
    ) {
        tool_points_one_by_one(self, params, readings, starts, reached);
    }

    /// [`Mechanism::tool_points_at_readings`] for a back-substitution,
    /// which needs of `dT/dp |_q` only its product with a step `dp` of the
    /// parameters: each entry as [`ReachedAlong`] (`dT/dp |_q · dp` in
    /// place of `dT/dp |_q`, and the warm start predicted at `p + dp`,
    /// where the contact's next forward kinematics starts). By default
    /// from [`Mechanism::tool_points_at_readings`], each warm start its own
    /// prediction ([`along_of_reached`]); a mechanism that can form the
    /// product without `dT/dp` and predict the pose overrides it (the
    /// hexapod: eight in SIMD lanes), writing into the room of the `Ok`
    /// entries `along` holds ([`write_entry`]), with `workspace` as
    /// [`Mechanism::tool_points_at_readings`]'s.
    ///
    /// # Panics
    /// If `readings` and `starts` differ in length.
    fn tool_points_along(
        &self,
        params: &[f64],
        readings: &[&[f64]],
        starts: &[&[f64]],
        dp: &[f64],
        workspace: &mut BatchWorkspace,
        along: &mut Vec<Result<ReachedAlong, MechanismError>>,
    ) {
        tool_points_along_by_rows(self, params, readings, starts, dp, workspace, along);
    }

    /// A pose near the one `readings` reach, for an iterative
    /// [`Mechanism::forward`] to start from when no nearer pose is known
    /// (the origin by default: closed forms ignore it).
    fn start_pose(&self, params: &[f64], readings: &[f64]) -> Result<DVector<f64>, MechanismError> {
        check_params(self, params)?;
        check_vector(self, "readings", readings, self.actuators().len())?;
        Ok(DVector::zeros(self.pose_coordinates().len()))
    }

    /// The combinations of the parameters no measurement can see, at
    /// `params` (none by default: a canonical parametrisation).
    fn gauge_freedoms(&self, params: &[f64]) -> Result<Vec<GaugeFreedom>, MechanismError> {
        check_params(self, params)?;
        Ok(Vec::new())
    }

    /// The parameters of the same machine in the canonical frame, where
    /// the gauge freedoms are fixed (the identity by default).
    fn canonicalize(&self, params: &[f64]) -> Result<DVector<f64>, MechanismError> {
        Ok(DVector::from_column_slice(params))
    }

    /// The quantities of the machine that are functions of its parameters
    /// ([`Quantity`]); none by default.
    fn quantities(&self) -> &[Quantity] {
        &[]
    }

    /// Quantity `index` of [`Mechanism::quantities`] at `params`, with its
    /// analytic gradient; an error for an index beyond them.
    fn quantity(&self, index: usize, params: &[f64]) -> Result<QuantityValue, MechanismError> {
        check_params(self, params)?;
        Err(MechanismError::NoModel {
            mechanism: self.name().to_string(),
            what: format!("quantity {index}"),
        })
    }

    /// The readings at `pose` with the actuators holding `loads` (one per
    /// actuator: a cable robot's line forces), and their analytic
    /// derivatives: the model of a mechanism whose readings depend on the
    /// load (lines that stretch). [`Mechanism::inverse`] is the same model
    /// under the loads the actuators held when they were zeroed. By
    /// default a mechanism has no load model: an error.
    fn loaded_readings(
        &self,
        params: &[f64],
        pose: &[f64],
        loads: &[f64],
    ) -> Result<(DVector<f64>, ReadingJacobians), MechanismError> {
        let _ = (params, pose, loads);
        Err(MechanismError::NoModel {
            mechanism: self.name().to_string(),
            what: "load model".to_string(),
        })
    }

    /// The load model of [`Mechanism::loaded_readings`] as what rebuilds
    /// the mechanism states it: for each actuator's line the index of its
    /// compliance among the compliance parameters, and the loads the
    /// actuators held when they were zeroed (a cable robot's elastic
    /// lines). `None` (the default): readings that do not depend on the
    /// load.
    fn line_compliances(&self) -> Option<(&[usize], &[f64])> {
        None
    }

    /// The platform's frame (platform → base) at `pose` (module doc). By
    /// default a mechanism's pose fixes no orientation: an error.
    fn platform_frame(&self, pose: &[f64]) -> Result<Isometry3<f64>, MechanismError> {
        let _ = pose;
        Err(no_platform_frame(self))
    }

    /// The pose `x` at which the platform's frame is `frame`, and `dx/dε`
    /// (pose increment × 6), `ε = (δt, δω)` with `t → t + δt`, `R → Exp(δω)
    /// R` (module doc). By default an error, as for
    /// [`Mechanism::platform_frame`].
    fn pose_at_platform(&self, frame: &Isometry3<f64>) -> Result<PlatformPose, MechanismError> {
        let _ = frame;
        Err(no_platform_frame(self))
    }

    /// Whether `pose` is within the mechanism's limits (stroke, joint
    /// angles, workspace); the first limit violated otherwise. Every pose
    /// the inverse kinematics accepts by default.
    fn check_feasible(&self, params: &[f64], pose: &[f64]) -> Result<(), MechanismError> {
        self.inverse(params, pose).map(|_| ())
    }
}

/// The error of a mechanism without a platform frame.
fn no_platform_frame<M: Mechanism + ?Sized>(mechanism: &M) -> MechanismError {
    MechanismError::NoModel {
        mechanism: mechanism.name().to_string(),
        what: "platform orientation (its pose is a point)".to_string(),
    }
}

/// The design parameter vector of a mechanism.
pub fn design(mechanism: &dyn Mechanism) -> DVector<f64> {
    DVector::from_iterator(
        mechanism.parameters().len(),
        mechanism.parameters().iter().map(|p| p.design),
    )
}

/// The prior standard deviations of a mechanism's parameters.
pub fn prior_sigma(mechanism: &dyn Mechanism) -> DVector<f64> {
    DVector::from_iterator(
        mechanism.parameters().len(),
        mechanism.parameters().iter().map(|p| p.prior_sigma),
    )
}

/// Refuses a parameter vector of the wrong length or with a non-finite
/// value (named).
pub fn check_params<M: Mechanism + ?Sized>(
    mechanism: &M,
    params: &[f64],
) -> Result<(), MechanismError> {
    let expected = mechanism.parameters().len();
    if params.len() != expected {
        return Err(MechanismError::ParameterCount {
            mechanism: mechanism.name().to_string(),
            expected,
            found: params.len(),
        });
    }
    match params.iter().position(|v| !v.is_finite()) {
        Some(k) => Err(MechanismError::NonFinite {
            what: format!("parameter {}", mechanism.parameters()[k].name),
        }),
        None => Ok(()),
    }
}

/// Refuses a vector of `what` (`readings`, `loads`) of length other than
/// `expected` or with a non-finite value, naming it by its position.
pub fn check_vector<M: Mechanism + ?Sized>(
    mechanism: &M,
    what: &'static str,
    values: &[f64],
    expected: usize,
) -> Result<(), MechanismError> {
    check_values(mechanism, what, values, expected, |k| {
        format!("{what} {}", k + 1)
    })
}

/// Refuses a pose of other than `expected` coordinates or with a
/// non-finite one, naming it ([`Mechanism::pose_coordinates`]: `pose
/// coordinate x`).
pub fn check_pose<M: Mechanism + ?Sized>(
    mechanism: &M,
    pose: &[f64],
    expected: usize,
) -> Result<(), MechanismError> {
    check_values(
        mechanism,
        "pose coordinates",
        pose,
        expected,
        |k| match mechanism.pose_coordinates().get(k) {
            Some(coordinate) => format!("pose coordinate {}", coordinate.name),
            None => format!("pose coordinate {}", k + 1),
        },
    )
}

/// Refuses `values` (of `what`) of length other than `expected`, or with
/// a non-finite value, the `k`-th named `name(k)`.
fn check_values<M: Mechanism + ?Sized>(
    mechanism: &M,
    what: &'static str,
    values: &[f64],
    expected: usize,
    name: impl Fn(usize) -> String,
) -> Result<(), MechanismError> {
    if values.len() != expected {
        return Err(MechanismError::Dimension {
            mechanism: mechanism.name().to_string(),
            what,
            expected,
            found: values.len(),
        });
    }
    match values.iter().position(|v| !v.is_finite()) {
        Some(k) => Err(MechanismError::NonFinite { what: name(k) }),
        None => Ok(()),
    }
}

/// Refuses a `G_x` of a mechanism with other than one actuator per pose
/// coordinate (one that `G_x^-1` does not exist for).
fn check_square<M: Mechanism + ?Sized>(
    mechanism: &M,
    g_x: &DMatrix<f64>,
) -> Result<(), MechanismError> {
    let (actuators, coordinates) = g_x.shape();
    if actuators == coordinates {
        return Ok(());
    }
    Err(MechanismError::Dimension {
        mechanism: mechanism.name().to_string(),
        what: "actuators (one per pose coordinate)",
        expected: coordinates,
        found: actuators,
    })
}

/// `dx/dp` at fixed readings, `-G_x^-1 G_p` (module documentation), for a
/// mechanism with as many actuators as pose coordinates. An error at a
/// singular configuration (`G_x` not invertible).
pub fn pose_jacobian_at_fixed_readings(
    mechanism: &dyn Mechanism,
    params: &[f64],
    pose: &[f64],
) -> Result<DMatrix<f64>, MechanismError> {
    let jacobians = mechanism.reading_jacobians(params, pose)?;
    check_square(mechanism, &jacobians.d_pose)?;
    let lu = jacobians.d_pose.lu();
    let solved = lu
        .solve(&jacobians.d_params)
        .filter(|m| m.iter().all(|v| v.is_finite()))
        .ok_or(MechanismError::Singular)?;
    Ok(-solved)
}

/// Where the machine is at given readings: its pose as a warm start, its
/// tool point and the tool point's derivative at fixed readings
/// ([`Mechanism::tool_point_at_readings`]). The default is empty (no
/// storage): what a caller leaves in place of one it takes.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Reached {
    /// The pose `x = f(p, q)` as a warm start (module doc;
    /// [`Mechanism::pose_of_warm_start`] gives `x`).
    pub warm_start: DVector<f64>,
    /// The tool point `T(p, x)` (mm).
    pub point: Vector3<f64>,
    /// `dT/dp |_q` (3 x parameters), dense or in its mechanism's factored
    /// form; in a [`ReachedAlong`], the derivative along its step, `dT/dp
    /// |_q · dp` (3 x 1: the derivative by `t` of `T` at `p + t dp`), so
    /// that what takes a `Reached` gives its rows' derivative along the
    /// step alike.
    pub d_params: ParamsJacobian,
}

/// Where the machine is at given readings and how its tool point moves
/// along a step `dp` of the parameters
/// ([`Mechanism::tool_points_along`]).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ReachedAlong {
    /// The warm start, the tool point and `dT/dp |_q · dp` (3 x 1, its
    /// `d_params`).
    pub reached: Reached,
    /// The warm start at `p + dp` to first order, of `x` moved by `dx/dp
    /// |_q · dp` ([`Mechanism::retract`]); `x`'s own for a mechanism that
    /// does not predict it.
    pub predicted: DVector<f64>,
}

/// [`Mechanism::tool_points_at_readings`] one contact after another
/// ([`Mechanism::tool_point_at_readings`]) into `reached`: the trait's
/// default, and the fallback of a mechanism whose batch cannot run.
///
/// # Panics
/// If `readings` and `starts` differ in length.
pub fn tool_points_one_by_one<M: Mechanism + ?Sized>(
    mechanism: &M,
    params: &[f64],
    readings: &[&[f64]],
    starts: &[&[f64]],
    reached: &mut Vec<Result<Reached, MechanismError>>,
) {
    assert_eq!(readings.len(), starts.len(), "a start for each contact");
    reached.clear();
    reached.extend(
        readings
            .iter()
            .zip(starts)
            .map(|(readings, start)| mechanism.tool_point_at_readings(params, readings, start)),
    );
}

/// [`Mechanism::tool_points_along`] from
/// [`Mechanism::tool_points_at_readings`] ([`along_of_reached`]): the
/// trait's default.
///
/// # Panics
/// If `readings` and `starts` differ in length.
pub fn tool_points_along_by_rows<M: Mechanism + ?Sized>(
    mechanism: &M,
    params: &[f64],
    readings: &[&[f64]],
    starts: &[&[f64]],
    dp: &[f64],
    workspace: &mut BatchWorkspace,
    along: &mut Vec<Result<ReachedAlong, MechanismError>>,
) {
    let mut reached = Vec::with_capacity(readings.len());
    mechanism.tool_points_at_readings(params, readings, starts, workspace, &mut reached);
    along.clear();
    along.extend(
        (reached.into_iter())
            .map(|outcome| outcome.and_then(|r| along_of_reached(mechanism, r, dp))),
    );
}

/// Where a contact `reached` (of `mechanism`) is, along the parameter
/// step `dp`: `dT/dp |_q · dp`, its warm start its own prediction. An error for
/// a step of other than one finite value per parameter.
pub fn along_of_reached<M: Mechanism + ?Sized>(
    mechanism: &M,
    reached: Reached,
    dp: &[f64],
) -> Result<ReachedAlong, MechanismError> {
    check_vector(
        mechanism,
        "parameter step values",
        dp,
        reached.d_params.ncols(),
    )?;
    let d_step = reached.d_params.apply(dp);
    Ok(ReachedAlong {
        predicted: reached.warm_start.clone(),
        reached: Reached {
            d_params: DMatrix::from_column_slice(3, 1, d_step.as_slice()).into(),
            ..reached
        },
    })
}

/// The warm start of the mechanism's [`Mechanism::start_pose`] at
/// `readings`: where a contact's forward kinematics starts when no nearer
/// pose is known.
pub fn warm_start_at_readings<M: Mechanism + ?Sized>(
    mechanism: &M,
    params: &[f64],
    readings: &[f64],
) -> Result<DVector<f64>, MechanismError> {
    mechanism.warm_start(mechanism.start_pose(params, readings)?.as_slice())
}

/// Entry `index` of `reached` (at most its length: an entry is added at
/// the end) set to where a contact is, as `write` writes it into room for
/// a warm start of `warm_start` values and `dT/dp` of `params` columns
/// held as `len` values of `form`: the room of the `Ok` entry there when
/// it has those sizes, else new zero room.
pub fn write_reached(
    reached: &mut Vec<Result<Reached, MechanismError>>,
    index: usize,
    warm_start: usize,
    form: &'static JacobianForm,
    params: usize,
    len: usize,
    write: impl FnOnce(&mut Reached),
) {
    write_entry(
        reached,
        index,
        |room| room.warm_start.len() == warm_start && room.d_params.fits(form, params, len),
        || Reached {
            warm_start: DVector::zeros(warm_start),
            point: Vector3::zeros(),
            d_params: ParamsJacobian::factored(form, params, len),
        },
        write,
    );
}

/// Entry `index` of `entries` (at most its length: an entry is added at
/// the end) set to `Ok`, as `write` writes it into room: the room of the
/// `Ok` entry there when it `fits` (written in place), else `fresh` room.
pub fn write_entry<T>(
    entries: &mut Vec<Result<T, MechanismError>>,
    index: usize,
    fits: impl FnOnce(&T) -> bool,
    fresh: impl FnOnce() -> T,
    write: impl FnOnce(&mut T),
) {
    if let Some(Ok(room)) = entries.get_mut(index)
        && fits(room)
    {
        write(room);
        return;
    }
    let mut room = fresh();
    write(&mut room);
    put_entry(entries, index, Ok(room));
}

/// Entry `index` of `entries` (at most its length) set to `outcome`.
pub fn put_entry<T>(
    entries: &mut Vec<Result<T, MechanismError>>,
    index: usize,
    outcome: Result<T, MechanismError>,
) {
    if index == entries.len() {
        entries.push(outcome);
    } else {
        entries[index] = outcome;
    }
}

/// The pose and tool point the machine of parameters `params` reaches at
/// `readings`, `T(p, f(p, q))`, and the tool point's derivative at fixed
/// readings, `dT/dp |_q = dT/dp |_x + dT/dx (-G_x^-1 G_p) = dT/dp |_x -
/// (dT/dq) G_p` (3 x parameters; module documentation), with `dT/dq =
/// dT/dx G_x^-1` ([`tool_point_reading_jacobian`]) taken by three
/// transposed solves rather than one per parameter; the forward kinematics
/// starts from the warm start `start`. Any mechanism's
/// [`Mechanism::tool_point_at_readings`], unless it has its own.
pub fn implicit_tool_point_at_readings<M: Mechanism + ?Sized>(
    mechanism: &M,
    params: &[f64],
    readings: &[f64],
    start: &[f64],
) -> Result<Reached, MechanismError> {
    let start = mechanism.pose_of_warm_start(start)?;
    let pose = mechanism.forward(params, readings, start.as_slice())?;
    let jacobians = mechanism.reading_jacobians(params, pose.as_slice())?;
    let tool = mechanism.tool_point(params, pose.as_slice())?;
    let d_readings = reading_to_tool(mechanism, &jacobians.d_pose, &tool.d_pose)?;
    let mut d_params = tool.d_params;
    d_params.gemm(-1.0, &d_readings, &jacobians.d_params, 1.0);
    Ok(Reached {
        warm_start: mechanism.warm_start(pose.as_slice())?,
        point: tool.point,
        d_params: d_params.into(),
    })
}

/// `dT/dq` at fixed parameters, `dT/dx G_x^-1` (3 x actuators): how the
/// readings' errors move the tool point at `pose`, for a mechanism with as
/// many actuators as pose coordinates. An error at a singular
/// configuration.
pub fn tool_point_reading_jacobian(
    mechanism: &dyn Mechanism,
    params: &[f64],
    pose: &[f64],
) -> Result<DMatrix<f64>, MechanismError> {
    let g_x = mechanism.reading_jacobians(params, pose)?.d_pose;
    let tool = mechanism.tool_point(params, pose)?;
    reading_to_tool(mechanism, &g_x, &tool.d_pose)
}

/// `dT/dq = dT/dx G_x^-1` from `G_x` and `dT/dx`, by the transposed solves
/// `G_x^T (dT/dq)^T = (dT/dx)^T` (one per tool coordinate). An error for a
/// `G_x` that is not square or is singular.
fn reading_to_tool<M: Mechanism + ?Sized>(
    mechanism: &M,
    g_x: &DMatrix<f64>,
    tool_d_pose: &DMatrix<f64>,
) -> Result<DMatrix<f64>, MechanismError> {
    check_square(mechanism, g_x)?;
    g_x.transpose()
        .lu()
        .solve(&tool_d_pose.transpose())
        .filter(|m| m.iter().all(|v| v.is_finite()))
        .map(|m| m.transpose())
        .ok_or(MechanismError::Singular)
}

/// The largest number of corrections [`forward_under_loads`] makes.
const LOADED_FORWARD_ITERATIONS: usize = 50;

/// Forward kinematics under loads: the pose at which
/// [`Mechanism::loaded_readings`] are `readings`, found by correcting the
/// readings by the load's effect at the last pose,
/// `x_{k+1} = f(p, q - (q_F(p, x_k) - g(p, x_k)))`, until the pose moves
/// less than `tolerance` (a contraction when the load's effect changes
/// slowly with the pose, as a line's stretch does). An error if it does
/// not settle.
pub fn forward_under_loads(
    mechanism: &dyn Mechanism,
    params: &[f64],
    readings: &[f64],
    loads: &[f64],
    start: &[f64],
    tolerance: f64,
) -> Result<DVector<f64>, MechanismError> {
    let q = DVector::from_column_slice(readings);
    let mut pose = mechanism.forward(params, readings, start)?;
    for _ in 0..LOADED_FORWARD_ITERATIONS {
        let (loaded, _) = mechanism.loaded_readings(params, pose.as_slice(), loads)?;
        let effect = loaded - mechanism.inverse(params, pose.as_slice())?;
        let next = mechanism.forward(params, (&q - effect).as_slice(), pose.as_slice())?;
        let moved = (&next - &pose).norm();
        pose = next;
        if moved < tolerance {
            return Ok(pose);
        }
    }
    Err(MechanismError::Unreachable {
        reason: format!(
            "the forward kinematics under loads {loads:?} did not settle in {LOADED_FORWARD_ITERATIONS} corrections"
        ),
    })
}

/// Central-difference derivatives of the readings, for checking
/// [`Mechanism::reading_jacobians`]: steps `h_p[k]` in parameter `k` and
/// `h_x` in each pose increment.
pub fn reading_jacobians_by_differences(
    mechanism: &dyn Mechanism,
    params: &[f64],
    pose: &[f64],
    h_p: &[f64],
    h_x: f64,
) -> Result<ReadingJacobians, MechanismError> {
    check_params(mechanism, params)?;
    check_vector(mechanism, "parameter steps", h_p, params.len())?;
    let n_q = mechanism.actuators().len();
    let n_p = params.len();
    let n_x = pose.len();
    let mut d_params = DMatrix::zeros(n_q, n_p);
    for k in 0..n_p {
        let (mut plus, mut minus) = (params.to_vec(), params.to_vec());
        plus[k] += h_p[k];
        minus[k] -= h_p[k];
        let column =
            (mechanism.inverse(&plus, pose)? - mechanism.inverse(&minus, pose)?) / (2.0 * h_p[k]);
        d_params.set_column(k, &column);
    }
    let mut d_pose = DMatrix::zeros(n_q, n_x);
    for k in 0..n_x {
        let step = DVector::from_fn(n_x, |i, _| if i == k { h_x } else { 0.0 });
        let plus = mechanism.retract(pose, step.as_slice());
        let minus = mechanism.retract(pose, (-step).as_slice());
        let column = (mechanism.inverse(params, plus.as_slice())?
            - mechanism.inverse(params, minus.as_slice())?)
            / (2.0 * h_x);
        d_pose.set_column(k, &column);
    }
    Ok(ReadingJacobians { d_params, d_pose })
}
