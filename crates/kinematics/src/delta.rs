//! The linear delta robot as a [`Mechanism`], in RepRapFirmware's
//! conventions.
//!
//! Three vertical towers A, B, C (RepRapFirmware's X, Y, Z towers) carry a
//! carriage each; a pair of parallel arms of length `L_i` (the diagonal
//! rod) joins carriage `i` to the effector, whose reference point is the
//! nozzle. Tower `i` stands at radius `r_i = R + dr_i` and angle
//! `phi_i = phi0_i + a_i` (`phi0 = 210, 330, 90` degrees, `a_i` the tower
//! angle correction, both measured counter-clockwise from +x), at
//! `P_i = r_i (cos phi_i, sin phi_i)`.
//!
//! Inverse kinematics (RepRapFirmware's `Transform`): the effector at
//! `(x, y, z)` above the bed needs carriage `i` at height
//!
//! ```text
//! Z_i = z + (t_x x + t_y y) / 100 + sqrt(L_i^2 - |(x, y) - P_i|^2)
//! ```
//!
//! with the bed tilts `t_x, t_y` in percent (M666 A, B). Homing puts the
//! carriages at their endstops, where the firmware sets carriage `i` to
//! `Z_i^home = H + sqrt(L_i^2 - r_i^2) + e_i` (`H` the homed height, `e_i`
//! the endstop correction, M666 X Y Z). The reading of carriage `i` is its
//! travel since homing, `q_i = Z_i - Z_i^home` (mm, negative below the
//! endstop): the step count that the firmware and the machine share.
//!
//! Forward kinematics intersects the spheres of radius `L_i` about the
//! carriages `(P_i, Z_i)` and keeps the root below them.
//!
//! # Gauge
//!
//! Five combinations change no measurement ([`LinearDelta::gauge_freedoms`]):
//! `H` against the mean endstop correction (only `H + e_i` enter), `R`
//! against the mean tower radius correction (only `R + dr_i` enter), and
//! the rigid motions of the horizontal frame: a rotation about z (every
//! `a_i` alike, the tilt vector turning with it) and the translations
//! along x and y (every tower moved alike). The canonical frame
//! ([`LinearDelta::canonicalize`]) has its origin at the towers'
//! circumcentre (so every `dr_i = 0` and `R` is the circumradius), tower C
//! at 90 degrees (`a_C = 0`) and mean endstop correction zero (what
//! RepRapFirmware's auto-calibration keeps).

use std::f64::consts::PI;

use nalgebra::{DMatrix, DVector, Matrix3, Vector3};

use crate::mechanism::{
    Actuator, GaugeFreedom, Mechanism, MechanismError, Parameter, PoseCoordinate, ReadingJacobians,
    check_params, check_pose, check_vector, pose_jacobian_at_fixed_readings,
};

/// How far beyond the print radius, relative to it, a point still lies
/// on it: the rounding of `r (cos θ, sin θ)` and of its distance from the
/// centre (a few units in the last place), so that a probe ring at the
/// print radius is within it.
pub const ON_THE_PRINT_RADIUS: f64 = 1e-12;

/// Number of parameters of a linear delta.
pub const N_PARAMS: usize = 16;
/// Index of the endstop correction of tower A (then B, C).
pub const ENDSTOP: usize = 0;
/// Index of the homed height `H`.
pub const HOMED_HEIGHT: usize = 3;
/// Index of the delta radius `R`.
pub const RADIUS: usize = 4;
/// Index of the radius correction of tower A (then B, C).
pub const TOWER_RADIUS: usize = 5;
/// Index of the angle correction of tower A (then B, C).
pub const ANGLE: usize = 8;
/// Index of the diagonal rod length of tower A (then B, C).
pub const DIAGONAL: usize = 11;
/// The group of the diagonal rods' lengths (a set the builder may have
/// cut together).
pub const RODS: &str = "diagonal rods";
/// Index of the bed tilt along x (then y).
pub const TILT: usize = 14;

/// The towers' names, in parameter and reading order (RepRapFirmware's
/// X, Y, Z towers).
pub const TOWERS: [&str; 3] = ["a", "b", "c"];
/// The towers' nominal angles (degrees, counter-clockwise from +x).
pub const NOMINAL_ANGLE: [f64; 3] = [210.0, 330.0, 90.0];

/// The most Newton steps [`DeltaParams::with_tower_radius`] takes: from
/// corrections of a few mm it needs three or four.
const FRAME_ITERATIONS: usize = 50;
/// Where [`DeltaParams::with_tower_radius`] stops: each tower's distance
/// from the new origin within this fraction of the largest tower radius
/// of the distance it is to have.
const FRAME_TOLERANCE: f64 = 1e-14;

const POSE: [PoseCoordinate; 3] = [
    PoseCoordinate {
        name: "x",
        unit: "mm",
    },
    PoseCoordinate {
        name: "y",
        unit: "mm",
    },
    PoseCoordinate {
        name: "z",
        unit: "mm",
    },
];

/// The parameters of a linear delta in named form (their vector order is
/// that of the index constants).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DeltaParams {
    /// Endstop corrections `e_i` (mm, M666 X Y Z).
    pub endstop: [f64; 3],
    /// Homed height `H` (mm, M665 H): the nozzle's height above the bed
    /// when homed, for zero endstop corrections.
    pub homed_height: f64,
    /// Delta radius `R` (mm, M665 R): horizontal distance from the
    /// effector's joints' centre to a carriage's joints' centre at the
    /// origin.
    pub radius: f64,
    /// Per-tower radius corrections `dr_i` (mm; no firmware field: a gauge
    /// freedom, zero in the canonical frame).
    pub tower_radius: [f64; 3],
    /// Tower angle corrections `a_i` (degrees, M665 X Y Z).
    pub angle: [f64; 3],
    /// Diagonal rod lengths `L_i` (mm, M665 L).
    pub diagonal: [f64; 3],
    /// Bed tilt `t_x, t_y` (percent, M666 A B).
    pub tilt: [f64; 2],
}

impl DeltaParams {
    /// A symmetric delta: equal rods, no corrections, no tilt.
    pub fn symmetric(diagonal: f64, radius: f64, homed_height: f64) -> Self {
        Self {
            endstop: [0.0; 3],
            homed_height,
            radius,
            tower_radius: [0.0; 3],
            angle: [0.0; 3],
            diagonal: [diagonal; 3],
            tilt: [0.0; 2],
        }
    }

    /// The parameter vector.
    pub fn to_vector(&self) -> DVector<f64> {
        let mut p = DVector::zeros(N_PARAMS);
        for i in 0..3 {
            p[ENDSTOP + i] = self.endstop[i];
            p[TOWER_RADIUS + i] = self.tower_radius[i];
            p[ANGLE + i] = self.angle[i];
            p[DIAGONAL + i] = self.diagonal[i];
        }
        p[HOMED_HEIGHT] = self.homed_height;
        p[RADIUS] = self.radius;
        p[TILT] = self.tilt[0];
        p[TILT + 1] = self.tilt[1];
        p
    }

    /// The parameters of a vector of [`N_PARAMS`] values.
    pub fn from_slice(p: &[f64]) -> Self {
        Self {
            endstop: std::array::from_fn(|i| p[ENDSTOP + i]),
            homed_height: p[HOMED_HEIGHT],
            radius: p[RADIUS],
            tower_radius: std::array::from_fn(|i| p[TOWER_RADIUS + i]),
            angle: std::array::from_fn(|i| p[ANGLE + i]),
            diagonal: std::array::from_fn(|i| p[DIAGONAL + i]),
            tilt: [p[TILT], p[TILT + 1]],
        }
    }

    /// The same machine in the frame, moved along the bed, in which each
    /// tower's own radius correction is `tower_radius` (mm): how a firmware
    /// with fixed per-tower radius corrections (Marlin's compiled-in
    /// `DELTA_RADIUS_TRIM_TOWER`) holds it. The towers `P_i` stay where
    /// they are; the frame's origin moves to the point `d` whose distances
    /// to them are `R' + dr_i`, `|P_i - d| = R' + dr_i` (three equations in
    /// `d` and the new delta radius `R'`, solved by Newton's method from
    /// `d = 0`), and each angle correction becomes the direction of `P_i -
    /// d`. The carriages' homed heights `Z_i^home` and the bed plane are
    /// kept: the bed's height at the new origin, `t . d`, is taken off, and
    /// each endstop correction takes up the change of its tower's rise
    /// `sqrt(L_i^2 - r_i^2)`. Unchanged when the corrections already are
    /// `tower_radius`; an error when no such frame is near (corrections
    /// of the order of the delta radius).
    pub fn with_tower_radius(&self, tower_radius: [f64; 3]) -> Result<Self, MechanismError> {
        if self.tower_radius == tower_radius {
            return Ok(*self);
        }
        let towers = Towers::of(self)?;
        let position = towers.position;
        let mut d = [0.0; 2];
        let mut radius = (0..3)
            .map(|i| towers.radius[i] - tower_radius[i])
            .sum::<f64>()
            / 3.0;
        let scale = towers.radius.iter().copied().fold(0.0, f64::max);
        let mut converged = false;
        for _ in 0..FRAME_ITERATIONS {
            let distance = |i: usize| (position[i][0] - d[0]).hypot(position[i][1] - d[1]);
            let residual = Vector3::from_fn(|i, _| distance(i) - tower_radius[i] - radius);
            if residual.amax() <= FRAME_TOLERANCE * scale {
                converged = true;
                break;
            }
            let jacobian = Matrix3::from_fn(|i, k| match k {
                2 => -1.0,
                _ => -(position[i][k] - d[k]) / distance(i),
            });
            let Some(step) = jacobian.lu().solve(&residual) else {
                break;
            };
            d = [d[0] - step[0], d[1] - step[1]];
            radius -= step[2];
        }
        if !converged || radius <= 0.0 {
            return Err(MechanismError::Unreachable {
                reason: format!(
                    "no frame near the towers' gives them the radius corrections {tower_radius:?} mm"
                ),
            });
        }
        let tilt = towers.tilt;
        let offset = tilt[0] * d[0] + tilt[1] * d[1];
        let mut moved = *self;
        moved.radius = radius;
        moved.tower_radius = tower_radius;
        moved.homed_height = self.homed_height - offset;
        for i in 0..3 {
            let (x, y) = (position[i][0] - d[0], position[i][1] - d[1]);
            moved.angle[i] = angle_correction(y.atan2(x), NOMINAL_ANGLE[i]);
        }
        let rise = Towers::of(&moved)?.rise;
        let homed_height = moved.homed_height;
        moved.endstop = std::array::from_fn(|i| towers.homed[i] - offset - homed_height - rise[i]);
        Ok(moved)
    }
}

/// The builder's tolerances (one standard deviation of each parameter's
/// prior).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Tolerances {
    /// Endstop corrections (mm).
    pub endstop: f64,
    /// Homed height (mm).
    pub homed_height: f64,
    /// Delta radius (mm).
    pub radius: f64,
    /// Per-tower radius corrections (mm).
    pub tower_radius: f64,
    /// Tower angle corrections (degrees).
    pub angle: f64,
    /// Diagonal rods (mm).
    pub diagonal: f64,
    /// Bed tilt (percent).
    pub tilt: f64,
}

impl Default for Tolerances {
    /// A kit printer's: rods 0.5 mm, radius 1 mm, tower angles 0.5 degree,
    /// endstops 1 mm, bed tilt 0.2 %, homed height 2 mm (set by jogging
    /// the nozzle to the bed), tower radius 0.5 mm (frame corners).
    fn default() -> Self {
        Self {
            endstop: 1.0,
            homed_height: 2.0,
            radius: 1.0,
            tower_radius: 0.5,
            angle: 0.5,
            diagonal: 0.5,
            tilt: 0.2,
        }
    }
}

/// The working limits of a linear delta.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Limits {
    /// The printable radius (mm, M665 B): the nozzle stays within it.
    pub print_radius: f64,
    /// The largest angle of an arm from the vertical (degrees): the
    /// joints' range.
    pub max_arm_angle: f64,
    /// How far each carriage can travel down from its endstop (mm).
    pub travel: f64,
}

impl Limits {
    /// The kinematics' own limits only, within the printable radius
    /// `print_radius` (infinite: none): arms up to the horizontal,
    /// carriages without an end of travel (what a firmware's files state).
    pub fn reach_only(print_radius: f64) -> Self {
        Self {
            print_radius,
            max_arm_angle: 90.0,
            travel: f64::INFINITY,
        }
    }
}

/// A linear delta design with its tolerances and limits.
#[derive(Debug, Clone)]
pub struct LinearDelta {
    parameters: Vec<Parameter>,
    actuators: Vec<Actuator>,
    limits: Limits,
}

/// The angle correction (degrees, in `[-180, 180)`) of a tower in the
/// direction `direction` (rad, counter-clockwise from +x) whose nominal
/// angle is `nominal` (degrees).
fn angle_correction(direction: f64, nominal: f64) -> f64 {
    (direction.to_degrees() - nominal + 180.0).rem_euclid(360.0) - 180.0
}

/// The towers of a parameter vector, where the kinematics need them.
struct Towers {
    /// `P_i` (mm).
    position: [[f64; 2]; 3],
    /// `r_i` (mm).
    radius: [f64; 3],
    /// `phi_i` (rad).
    angle: [f64; 3],
    /// `L_i` (mm).
    diagonal: [f64; 3],
    /// `sqrt(L_i^2 - r_i^2)`: the carriage's height above the effector at
    /// the origin (mm).
    rise: [f64; 3],
    /// `Z_i^home` (mm).
    homed: [f64; 3],
    /// Tilt as fractions (mm per mm).
    tilt: [f64; 2],
}

impl Towers {
    fn of(p: &DeltaParams) -> Result<Self, MechanismError> {
        let radius: [f64; 3] = std::array::from_fn(|i| p.radius + p.tower_radius[i]);
        let angle: [f64; 3] = std::array::from_fn(|i| (NOMINAL_ANGLE[i] + p.angle[i]).to_radians());
        let mut rise = [0.0; 3];
        for (i, tower) in TOWERS.iter().enumerate() {
            if radius[i] <= 0.0 {
                // The tower's own radius correction, if it has one, else
                // the common radius.
                let (name, value) = if p.tower_radius[i] == 0.0 {
                    ("radius".to_string(), p.radius)
                } else {
                    (format!("radius_{tower}"), p.tower_radius[i])
                };
                return Err(MechanismError::Parameter {
                    name,
                    value,
                    reason: format!(
                        "tower {tower} stands at radius {:.3} mm from the centre: it must be positive",
                        radius[i]
                    ),
                });
            }
            if p.diagonal[i] <= radius[i] {
                return Err(MechanismError::Parameter {
                    name: format!("diagonal_{tower}"),
                    value: p.diagonal[i],
                    reason: format!(
                        "the diagonal rod must be longer than tower {tower}'s radius {:.3} mm to reach the centre",
                        radius[i]
                    ),
                });
            }
            rise[i] = (p.diagonal[i].powi(2) - radius[i].powi(2)).sqrt();
        }
        Ok(Self {
            position: std::array::from_fn(|i| {
                [radius[i] * angle[i].cos(), radius[i] * angle[i].sin()]
            }),
            radius,
            angle,
            diagonal: p.diagonal,
            rise,
            homed: std::array::from_fn(|i| p.homed_height + rise[i] + p.endstop[i]),
            tilt: [p.tilt[0] / 100.0, p.tilt[1] / 100.0],
        })
    }

    /// The tilted height `z + t_x x + t_y y` of the tower frame.
    fn tower_height(&self, pose: &[f64]) -> f64 {
        pose[2] + self.tilt[0] * pose[0] + self.tilt[1] * pose[1]
    }

    /// `(u_i, v_i, s_i)`: the effector's horizontal offset from tower `i`
    /// and the carriage's height above the effector,
    /// `s_i = sqrt(L_i^2 - u_i^2 - v_i^2)`.
    fn arm(&self, i: usize, pose: &[f64]) -> Result<(f64, f64, f64), MechanismError> {
        let (u, v) = (pose[0] - self.position[i][0], pose[1] - self.position[i][1]);
        let square = self.diagonal[i].powi(2) - u * u - v * v;
        if square <= 0.0 {
            return Err(MechanismError::Unreachable {
                reason: format!(
                    "tower {}: the effector at ({:.3}, {:.3}) is {:.3} mm from the tower, beyond its diagonal rod of {:.3} mm",
                    TOWERS[i],
                    pose[0],
                    pose[1],
                    u.hypot(v),
                    self.diagonal[i]
                ),
            });
        }
        Ok((u, v, square.sqrt()))
    }
}

impl LinearDelta {
    /// A delta of the given design, tolerances and limits.
    pub fn new(design: &DeltaParams, tolerances: &Tolerances, limits: Limits) -> Self {
        let values = design.to_vector();
        let parameter =
            |k: usize, name: String, unit: &'static str, group, prior_sigma| Parameter {
                name,
                unit: unit.into(),
                group,
                design: values[k],
                prior_sigma,
            };
        let mut parameters = Vec::with_capacity(N_PARAMS);
        for (i, tower) in TOWERS.iter().enumerate() {
            let name = format!("endstop_{tower}");
            parameters.push(parameter(
                ENDSTOP + i,
                name,
                "mm",
                "endstops",
                tolerances.endstop,
            ));
        }
        parameters.push(parameter(
            HOMED_HEIGHT,
            "homed_height".into(),
            "mm",
            "homed height",
            tolerances.homed_height,
        ));
        parameters.push(parameter(
            RADIUS,
            "radius".into(),
            "mm",
            "radius",
            tolerances.radius,
        ));
        for (i, tower) in TOWERS.iter().enumerate() {
            let name = format!("radius_{tower}");
            let sigma = tolerances.tower_radius;
            parameters.push(parameter(
                TOWER_RADIUS + i,
                name,
                "mm",
                "tower radii",
                sigma,
            ));
        }
        for (i, tower) in TOWERS.iter().enumerate() {
            let name = format!("angle_{tower}");
            parameters.push(parameter(
                ANGLE + i,
                name,
                "deg",
                "tower angles",
                tolerances.angle,
            ));
        }
        for (i, tower) in TOWERS.iter().enumerate() {
            let name = format!("diagonal_{tower}");
            let sigma = tolerances.diagonal;
            parameters.push(parameter(DIAGONAL + i, name, "mm", RODS, sigma));
        }
        for (k, axis) in ["x", "y"].iter().enumerate() {
            let name = format!("tilt_{axis}");
            parameters.push(parameter(TILT + k, name, "%", "bed tilt", tolerances.tilt));
        }
        let actuators = TOWERS
            .iter()
            .map(|tower| Actuator::direct(format!("carriage {}", tower.to_uppercase()), "mm"))
            .collect();
        Self {
            parameters,
            actuators,
            limits,
        }
    }

    /// A typical kit printer: rods 270 mm, delta radius 135 mm, homed
    /// height 300 mm, print radius 110 mm, arms within 70 degrees of the
    /// vertical, carriages 400 mm of travel; [`Tolerances::default`].
    pub fn typical() -> Self {
        let limits = Limits {
            print_radius: 110.0,
            max_arm_angle: 70.0,
            travel: 400.0,
        };
        Self::new(
            &DeltaParams::symmetric(270.0, 135.0, 300.0),
            &Tolerances::default(),
            limits,
        )
    }

    /// The limits.
    pub fn limits(&self) -> &Limits {
        &self.limits
    }

    /// This delta with the printable radius `print_radius` (mm, its
    /// firmware's `M665 B`): the nozzle stays within it.
    pub fn within_print_radius(mut self, print_radius: f64) -> Self {
        self.limits.print_radius = print_radius;
        self
    }

    /// The carriages' heights at their endstops in the firmware's
    /// coordinate, `Z_i^home = H + sqrt(L_i^2 - r_i^2) + e_i` (mm): a
    /// reading `q_i` is the carriage at `Z_i = q_i + Z_i^home`.
    pub fn homed_carriage_heights(&self, params: &[f64]) -> Result<[f64; 3], MechanismError> {
        Ok(self.towers(params)?.homed)
    }

    fn towers(&self, params: &[f64]) -> Result<Towers, MechanismError> {
        check_params(self, params)?;
        Towers::of(&DeltaParams::from_slice(params))
    }
}

impl Mechanism for LinearDelta {
    fn name(&self) -> &str {
        "linear delta"
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

    /// Refuses parameters of the wrong length, non-finite, with a tower at
    /// a radius that is not positive or a diagonal rod not longer than its
    /// tower's radius.
    fn check_parameters(&self, params: &[f64]) -> Result<(), MechanismError> {
        self.towers(params).map(|_| ())
    }

    fn inverse(&self, params: &[f64], pose: &[f64]) -> Result<DVector<f64>, MechanismError> {
        let towers = self.towers(params)?;
        check_pose(self, pose, 3)?;
        let height = towers.tower_height(pose);
        let mut q = DVector::zeros(3);
        for i in 0..3 {
            let (_, _, s) = towers.arm(i, pose)?;
            q[i] = height + s - towers.homed[i];
        }
        Ok(q)
    }

    /// The three-sphere intersection: with the carriages `C_i`, the frame
    /// `e_x = (C_2 - C_1)/d`, `e_y` towards `C_3` in their plane,
    /// `e_z = e_x x e_y`, and `i = e_x . (C_3 - C_1)`,
    /// `j = e_y . (C_3 - C_1)`, the effector is at
    /// `C_1 + a e_x + b e_y + c e_z` with `a = (L_1^2 - L_2^2 + d^2)/(2d)`,
    /// `b = (L_1^2 - L_3^2 + i^2 + j^2)/(2j) - a i/j`,
    /// `c = ±sqrt(L_1^2 - a^2 - b^2)`, the sign that puts it below.
    fn forward(
        &self,
        params: &[f64],
        readings: &[f64],
        _start: &[f64],
    ) -> Result<DVector<f64>, MechanismError> {
        let towers = self.towers(params)?;
        check_vector(self, "readings", readings, 3)?;
        let carriage = |i: usize| {
            let [x, y] = towers.position[i];
            Vector3::new(x, y, readings[i] + towers.homed[i])
        };
        let (c1, c2, c3) = (carriage(0), carriage(1), carriage(2));
        let d = (c2 - c1).norm();
        let e_x = (c2 - c1) / d;
        let i = e_x.dot(&(c3 - c1));
        let e_y = (c3 - c1 - i * e_x).normalize();
        let e_z = e_x.cross(&e_y);
        let j = e_y.dot(&(c3 - c1));
        let [l1, l2, l3] = towers.diagonal.map(|l| l * l);
        let a = (l1 - l2 + d * d) / (2.0 * d);
        let b = (l1 - l3 + i * i + j * j) / (2.0 * j) - a * i / j;
        let square = l1 - a * a - b * b;
        if square.is_nan() || square < 0.0 {
            return Err(MechanismError::Unreachable {
                reason: format!(
                    "the arms do not meet: carriages at {:.3}, {:.3}, {:.3} mm from their endstops are too far apart",
                    readings[0], readings[1], readings[2]
                ),
            });
        }
        let c = square.sqrt() * if e_z.z > 0.0 { -1.0 } else { 1.0 };
        let p = c1 + a * e_x + b * e_y + c * e_z;
        let z = p.z - towers.tilt[0] * p.x - towers.tilt[1] * p.y;
        Ok(DVector::from_column_slice(&[p.x, p.y, z]))
    }

    /// With `(u_i, v_i, s_i)` the effector's offset from tower `i` and the
    /// carriage's rise above it:
    ///
    /// ```text
    /// dq_i/dx = t_x - u_i/s_i     dq_i/dy = t_y - v_i/s_i     dq_i/dz = 1
    /// dq_i/de_i = dq_i/dH = -1
    /// dq_i/dr_i = (u_i cos phi_i + v_i sin phi_i)/s_i + r_i/sqrt(L_i^2 - r_i^2)
    /// dq_i/da_i = r_i (v_i cos phi_i - u_i sin phi_i)/s_i * pi/180
    /// dq_i/dL_i = L_i/s_i - L_i/sqrt(L_i^2 - r_i^2)
    /// dq_i/dt_x = x/100           dq_i/dt_y = y/100
    /// ```
    ///
    /// (`dr_i` and `R` both enter through `r_i`).
    fn reading_jacobians(
        &self,
        params: &[f64],
        pose: &[f64],
    ) -> Result<ReadingJacobians, MechanismError> {
        let towers = self.towers(params)?;
        check_pose(self, pose, 3)?;
        let mut d_params = DMatrix::zeros(3, N_PARAMS);
        let mut d_pose = DMatrix::zeros(3, 3);
        for i in 0..3 {
            let (u, v, s) = towers.arm(i, pose)?;
            let (sin, cos) = towers.angle[i].sin_cos();
            let (r, l, rise) = (towers.radius[i], towers.diagonal[i], towers.rise[i]);
            d_pose[(i, 0)] = towers.tilt[0] - u / s;
            d_pose[(i, 1)] = towers.tilt[1] - v / s;
            d_pose[(i, 2)] = 1.0;
            d_params[(i, ENDSTOP + i)] = -1.0;
            d_params[(i, HOMED_HEIGHT)] = -1.0;
            let d_radius = (u * cos + v * sin) / s + r / rise;
            d_params[(i, RADIUS)] = d_radius;
            d_params[(i, TOWER_RADIUS + i)] = d_radius;
            d_params[(i, ANGLE + i)] = r * (v * cos - u * sin) / s * PI / 180.0;
            d_params[(i, DIAGONAL + i)] = l / s - l / rise;
            d_params[(i, TILT)] = pose[0] / 100.0;
            d_params[(i, TILT + 1)] = pose[1] / 100.0;
        }
        Ok(ReadingJacobians { d_params, d_pose })
    }

    /// At parameters `p` (tower positions `P_i`, radii `r_i`, tilt `t`
    /// as fractions), the unnormalised directions are: `H` -1 with every
    /// `e_i` +1; `R` +1 with every `dr_i` -1; the rotation, every `a_i`
    /// +1 degree and `dt = (pi/180) (-t_y, t_x)` (percent); the
    /// translation by `d`, each tower's `dr_i = d . (cos phi_i, sin phi_i)`
    /// and `da_i = (180/pi) d . (-sin phi_i, cos phi_i) / r_i`, with
    /// `de_i = r_i dr_i / sqrt(L_i^2 - r_i^2)` keeping the homed carriage
    /// heights and `dH = t . d` keeping the bed at `z = 0`.
    fn gauge_freedoms(&self, params: &[f64]) -> Result<Vec<GaugeFreedom>, MechanismError> {
        let towers = self.towers(params)?;
        let p = DeltaParams::from_slice(params);
        let unit = |name, v: DVector<f64>| GaugeFreedom {
            name,
            direction: v.normalize(),
        };
        let mut height = DVector::zeros(N_PARAMS);
        height[HOMED_HEIGHT] = -1.0;
        let mut radius = DVector::zeros(N_PARAMS);
        radius[RADIUS] = 1.0;
        let mut rotation = DVector::zeros(N_PARAMS);
        rotation[TILT] = -p.tilt[1] * PI / 180.0;
        rotation[TILT + 1] = p.tilt[0] * PI / 180.0;
        for i in 0..3 {
            height[ENDSTOP + i] = 1.0;
            radius[TOWER_RADIUS + i] = -1.0;
            rotation[ANGLE + i] = 1.0;
        }
        let translation = |d: [f64; 2]| {
            let mut v = DVector::zeros(N_PARAMS);
            for i in 0..3 {
                let (sin, cos) = towers.angle[i].sin_cos();
                let dr = d[0] * cos + d[1] * sin;
                v[TOWER_RADIUS + i] = dr;
                v[ANGLE + i] = (-d[0] * sin + d[1] * cos) / towers.radius[i] * 180.0 / PI;
                v[ENDSTOP + i] = towers.radius[i] * dr / towers.rise[i];
            }
            v[HOMED_HEIGHT] = towers.tilt[0] * d[0] + towers.tilt[1] * d[1];
            v
        };
        Ok(vec![
            unit("homed height against the mean endstop correction", height),
            unit(
                "delta radius against the mean tower radius correction",
                radius,
            ),
            unit("rotation about z", rotation),
            unit("translation along x", translation([1.0, 0.0])),
            unit("translation along y", translation([0.0, 1.0])),
        ])
    }

    /// The same machine with its towers' circumcentre at the origin,
    /// tower C at 90 degrees and the mean endstop correction zero: the
    /// homed carriage heights `Z_i^home` and the bed plane are kept.
    fn canonicalize(&self, params: &[f64]) -> Result<DVector<f64>, MechanismError> {
        let towers = self.towers(params)?;
        let p = DeltaParams::from_slice(params);
        let [a, b, c] = towers.position;
        // Circumcentre of the three towers.
        let (bx, by, cx, cy) = (b[0] - a[0], b[1] - a[1], c[0] - a[0], c[1] - a[1]);
        let det = 2.0 * (bx * cy - by * cx);
        let (b2, c2) = (bx * bx + by * by, cx * cx + cy * cy);
        let centre = [
            a[0] + (cy * b2 - by * c2) / det,
            a[1] + (bx * c2 - cx * b2) / det,
        ];
        let circumradius = (a[0] - centre[0]).hypot(a[1] - centre[1]);
        let tower_c = (c[1] - centre[1]).atan2(c[0] - centre[0]);
        let turn = NOMINAL_ANGLE[2].to_radians() - tower_c;
        let (sin, cos) = turn.sin_cos();
        let mut canonical = p;
        canonical.radius = circumradius;
        canonical.tower_radius = [0.0; 3];
        for ((slot, [x, y]), nominal) in canonical
            .angle
            .iter_mut()
            .zip(towers.position)
            .zip(NOMINAL_ANGLE)
        {
            *slot = angle_correction((y - centre[1]).atan2(x - centre[0]) + turn, nominal);
        }
        // The bed plane Z = t . x + 0 in the old frame is, with
        // x = centre + rot(-turn) x', the plane Z = (rot(turn) t) . x' + t . centre.
        let t = towers.tilt;
        canonical.tilt = [
            100.0 * (cos * t[0] - sin * t[1]),
            100.0 * (sin * t[0] + cos * t[1]),
        ];
        let offset = t[0] * centre[0] + t[1] * centre[1];
        // Keep every homed carriage height Z_i^home - offset (the bed
        // lowered to z = 0), then move the mean endstop correction into H.
        let rise = |i: usize| (p.diagonal[i].powi(2) - circumradius.powi(2)).sqrt();
        canonical.homed_height = p.homed_height - offset;
        for i in 0..3 {
            canonical.endstop[i] = towers.homed[i] - offset - canonical.homed_height - rise(i);
        }
        let mean = canonical.endstop.iter().sum::<f64>() / 3.0;
        canonical.endstop = canonical.endstop.map(|e| e - mean);
        canonical.homed_height += mean;
        let result = canonical.to_vector();
        check_params(self, result.as_slice())?;
        Ok(result)
    }

    /// Within the print radius (a point on it, to [`ON_THE_PRINT_RADIUS`],
    /// too), every arm within its largest angle from the vertical, every
    /// carriage between its endstop and the end of its travel.
    fn check_feasible(&self, params: &[f64], pose: &[f64]) -> Result<(), MechanismError> {
        let q = self.inverse(params, pose)?;
        let towers = self.towers(params)?;
        let limits = &self.limits;
        let reach = pose[0].hypot(pose[1]);
        let unreachable = |reason| Err(MechanismError::Unreachable { reason });
        if reach > limits.print_radius * (1.0 + ON_THE_PRINT_RADIUS) {
            return unreachable(format!(
                "the effector at ({:.3}, {:.3}) is {reach:.3} mm from the centre, beyond the print radius {:.3} mm",
                pose[0], pose[1], limits.print_radius
            ));
        }
        for i in 0..3 {
            let (u, v, s) = towers.arm(i, pose)?;
            let angle = u.hypot(v).atan2(s).to_degrees();
            if angle > limits.max_arm_angle {
                return unreachable(format!(
                    "the arms of tower {} lean {angle:.2} degrees from the vertical, beyond {:.2}",
                    TOWERS[i], limits.max_arm_angle
                ));
            }
            if q[i] > 0.0 || q[i] < -limits.travel {
                return unreachable(format!(
                    "carriage {} would be {:.3} mm from its endstop, outside its travel of {:.3} mm below it",
                    TOWERS[i].to_uppercase(),
                    -q[i],
                    limits.travel
                ));
            }
        }
        Ok(())
    }
}

/// The height that `G30 S-1` reports at commanded `(x, y)`: the firmware,
/// with parameters `firmware`, lowers the nozzle until it touches the bed
/// of the machine whose true parameters are `truth` (both of `delta`), and
/// reports its own `z` there: the root of
/// `f_z(truth, g(firmware, (x, y, z))) = 0`, by Newton's method with the
/// slope 1 of a correct firmware (converges in a few steps for errors of
/// a few millimetres).
pub fn probe_height(
    delta: &LinearDelta,
    truth: &[f64],
    firmware: &[f64],
    x: f64,
    y: f64,
) -> Result<f64, MechanismError> {
    let mut z = 0.0;
    for _ in 0..50 {
        let q = delta.inverse(firmware, &[x, y, z])?;
        let bed = delta.forward(truth, q.as_slice(), &[x, y, z])?[2];
        z -= bed;
        if bed.abs() < 1e-12 {
            return Ok(z);
        }
    }
    Err(MechanismError::Unreachable {
        reason: format!("the probe at ({x:.3}, {y:.3}) does not settle on the bed"),
    })
}

/// The derivatives of the probe heights at `points` with respect to the
/// machine's true parameters, at a firmware that knows them (`params`):
/// differentiating `f_z(p, g(p_0, (x, y, z_p))) = 0` at `p = p_0`
/// gives `dz_p/dp = -(dx/dp|_q)_z = (G_x^-1 G_p)_z`. One row per point.
pub fn probe_height_jacobian(
    delta: &LinearDelta,
    params: &[f64],
    points: &[[f64; 2]],
) -> Result<DMatrix<f64>, MechanismError> {
    let mut jacobian = DMatrix::zeros(points.len(), N_PARAMS);
    for (row, [x, y]) in points.iter().enumerate() {
        let dx = pose_jacobian_at_fixed_readings(delta, params, &[*x, *y, 0.0])?;
        jacobian.set_row(row, &(-dx.row(2)));
    }
    Ok(jacobian)
}

/// The height of a first layer (mm): where part distances are measured
/// on a printed part (the simulator's, the planner's candidates).
pub const FIRST_LAYER: f64 = 0.2;

/// The height of the gauge block a height is measured on by hand (mm):
/// the nozzle is sent this far up and the block slid under it (the
/// simulator's manual heights, the planner's candidates).
pub const GAUGE_BLOCK: f64 = 5.0;

/// Probe points on rings over the bed: the centre, then `per_ring` points
/// on each of `rings` circles out to `radius`, the first point of each
/// ring towards tower A (as RepRapFirmware's calibration wizards place
/// them).
pub fn probe_rings(radius: f64, rings: usize, per_ring: usize) -> Vec<[f64; 2]> {
    let mut points = vec![[0.0, 0.0]];
    for ring in 1..=rings {
        let r = radius * ring as f64 / rings as f64;
        for k in 0..per_ring {
            let angle = (NOMINAL_ANGLE[0] + 360.0 * k as f64 / per_ring as f64).to_radians();
            points.push([r * angle.cos(), r * angle.sin()]);
        }
    }
    points
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mechanism::{design, reading_jacobians_by_differences};
    use rand::rngs::StdRng;
    use rand::{RngExt, SeedableRng};

    /// A realistic printer off its design by a few tenths.
    fn perturbed(rng: &mut StdRng) -> DeltaParams {
        let mut p = DeltaParams::symmetric(
            rng.random_range(250.0..300.0),
            rng.random_range(120.0..150.0),
            rng.random_range(250.0..350.0),
        );
        let mut small = |scale: f64| rng.random_range(-scale..scale);
        p.endstop = [small(0.5), small(0.5), small(0.5)];
        p.tower_radius = [small(0.3), small(0.3), small(0.3)];
        p.angle = [small(0.3), small(0.3), small(0.3)];
        p.diagonal = p.diagonal.map(|l| l + small(0.3));
        p.radius += small(0.5);
        p.tilt = [small(0.2), small(0.2)];
        p
    }

    fn random_pose(rng: &mut StdRng) -> [f64; 3] {
        let r = 100.0 * rng.random_range(0.0..1.0f64).sqrt();
        let angle = rng.random_range(0.0..2.0 * PI);
        [
            r * angle.cos(),
            r * angle.sin(),
            rng.random_range(0.0..200.0),
        ]
    }

    #[test]
    fn inverse_follows_the_firmware_transform() {
        // A symmetric printer at the centre: every carriage at
        // z + sqrt(L^2 - R^2), i.e. q = z - H.
        let delta = LinearDelta::typical();
        let p = design(&delta);
        let q = delta.inverse(p.as_slice(), &[0.0, 0.0, 120.0]).unwrap();
        for value in q.iter() {
            assert!((value - (120.0 - 300.0)).abs() < 1e-12, "{q}");
        }
        // Homed (every q = 0), the nozzle of a printer without endstop
        // corrections is at the homed height above the centre; a positive
        // endstop correction puts carriage A's home higher, and the
        // nozzle's with it.
        let home = delta.forward(p.as_slice(), &[0.0; 3], &[0.0; 3]).unwrap();
        assert!((home - DVector::from_column_slice(&[0.0, 0.0, 300.0])).amax() < 1e-9);
        let mut corrected = p.clone();
        corrected[ENDSTOP] = 0.3;
        let home = delta
            .forward(corrected.as_slice(), &[0.0; 3], &[0.0; 3])
            .unwrap();
        assert!(home[2] > 300.0, "{home}");
        // Tower A at 210 degrees: moving towards it raises carriage A most.
        let towards_a = [-50.0 * 3f64.sqrt() / 2.0, -25.0, 120.0];
        let q = delta.inverse(p.as_slice(), &towards_a).unwrap();
        assert!(q[0] > q[1] && q[0] > q[2], "{q}");
        assert!((q[1] - q[2]).abs() < 1e-9, "B and C symmetric: {q}");
    }

    /// The default tool points at warm starts (a delta's warm start is
    /// its pose) are `tool_point`'s, to the bit; a start refused is
    /// refused alone.
    #[test]
    fn tool_points_at_warm_starts_are_each_tool_point() {
        let delta = LinearDelta::typical();
        let p = design(&delta);
        let (x, y, refused) = ([10.0, -20.0, 5.0], [0.0, 30.0, 40.0], [0.0, f64::NAN, 1.0]);
        let starts: [&[f64]; 3] = [&x, &refused, &y];
        let points = delta.tool_points_at_warm_starts(p.as_slice(), &starts);
        assert_eq!(points.len(), 3);
        for (point, pose) in [&points[0], &points[2]].into_iter().zip([&x, &y]) {
            let expected = delta.tool_point(p.as_slice(), pose).unwrap().point;
            assert_eq!(point.as_ref().unwrap(), &expected);
        }
        assert!(points[1].is_err());
    }

    #[test]
    fn forward_inverts_inverse_over_the_workspace() {
        let delta = LinearDelta::typical();
        let mut rng = StdRng::seed_from_u64(36);
        let mut worst: f64 = 0.0;
        for _ in 0..200 {
            let p = perturbed(&mut rng).to_vector();
            let pose = random_pose(&mut rng);
            let q = delta.inverse(p.as_slice(), &pose).unwrap();
            let back = delta
                .forward(p.as_slice(), q.as_slice(), &[0.0; 3])
                .unwrap();
            worst = worst.max((back - DVector::from_column_slice(&pose)).amax());
        }
        assert!(worst < 1e-9, "largest error {worst:e} mm");
    }

    #[test]
    fn reading_derivatives_match_central_differences() {
        let delta = LinearDelta::typical();
        let mut rng = StdRng::seed_from_u64(7);
        for _ in 0..50 {
            let p = perturbed(&mut rng).to_vector();
            let pose = random_pose(&mut rng);
            let analytic = delta.reading_jacobians(p.as_slice(), &pose).unwrap();
            let numeric = reading_jacobians_by_differences(
                &delta,
                p.as_slice(),
                &pose,
                &[1e-4; N_PARAMS],
                1e-4,
            )
            .unwrap();
            // Steps 1e-4 on O(1) derivatives of lengths ~300 mm:
            // truncation ~h^2 / L^2, rounding ~1e-16 * 300 / 1e-4.
            let (dp, dx) = (
                (&analytic.d_params - &numeric.d_params).amax(),
                (&analytic.d_pose - &numeric.d_pose).amax(),
            );
            assert!(dp < 1e-8 && dx < 1e-8, "d_params {dp:e}, d_pose {dx:e}");
        }
    }

    #[test]
    fn probe_height_derivatives_match_simulated_probing() {
        let delta = LinearDelta::typical();
        let mut rng = StdRng::seed_from_u64(11);
        let p = perturbed(&mut rng).to_vector();
        let points = probe_rings(100.0, 2, 6);
        let jacobian = probe_height_jacobian(&delta, p.as_slice(), &points).unwrap();
        let h = 1e-3;
        for k in 0..N_PARAMS {
            let (mut plus, mut minus) = (p.clone(), p.clone());
            plus[k] += h;
            minus[k] -= h;
            for (row, [x, y]) in points.iter().enumerate() {
                let up = probe_height(&delta, plus.as_slice(), p.as_slice(), *x, *y).unwrap();
                let down = probe_height(&delta, minus.as_slice(), p.as_slice(), *x, *y).unwrap();
                let numeric = (up - down) / (2.0 * h);
                let error = (numeric - jacobian[(row, k)]).abs();
                assert!(
                    error < 1e-7,
                    "{} at point {row}: {error:e}",
                    delta.parameters()[k].name
                );
            }
        }
    }

    #[test]
    fn gauge_freedoms_leave_the_machine_unchanged() {
        // Along each gauge direction the readings of the moved machine at
        // the moved pose equal the readings before, to first order: the
        // change of q over a step of 1e-3 is O(1e-6) (second order), not
        // O(1e-3).
        let delta = LinearDelta::typical();
        let mut rng = StdRng::seed_from_u64(3);
        let p = perturbed(&mut rng).to_vector();
        let freedoms = delta.gauge_freedoms(p.as_slice()).unwrap();
        assert_eq!(freedoms.len(), 5);
        let points = probe_rings(100.0, 3, 8);
        let jacobian = probe_height_jacobian(&delta, p.as_slice(), &points).unwrap();
        for freedom in &freedoms {
            let seen = (&jacobian * &freedom.direction).amax();
            assert!(
                seen < 1e-10,
                "{}: probe heights move by {seen:e}",
                freedom.name
            );
        }
        // And they are the whole nullspace: 16 - 5 = 11 singular values
        // clearly above zero.
        let singular = jacobian.singular_values();
        let mut sorted: Vec<f64> = singular.iter().copied().collect();
        sorted.sort_by(f64::total_cmp);
        assert!(sorted[4] < 1e-9 * sorted[15], "{sorted:?}");
        assert!(sorted[5] > 1e-6 * sorted[15], "{sorted:?}");
    }

    #[test]
    fn probe_heights_barely_see_a_common_scaling_of_rods_and_radius() {
        // Lengthening every rod or the radius alone shows in the probe
        // heights; together, in the best proportion, the two nearly cancel
        // (both mainly bow the bed's apparent surface): probe heights see
        // Z, hardly the XY scale.
        let delta = LinearDelta::typical();
        let p = design(&delta);
        let jacobian =
            probe_height_jacobian(&delta, p.as_slice(), &probe_rings(100.0, 3, 8)).unwrap();
        let largest = jacobian.singular_values().max();
        let mut rods = DVector::zeros(N_PARAMS);
        for i in 0..3 {
            rods[DIAGONAL + i] = 1.0;
        }
        let mut radius = DVector::zeros(N_PARAMS);
        radius[RADIUS] = 1.0;
        let (seen_rods, seen_radius) = (&jacobian * &rods, &jacobian * &radius);
        let k = -seen_rods.dot(&seen_radius) / seen_radius.norm_squared();
        let scale = &rods + k * &radius;
        let gain = |v: &DVector<f64>| (&jacobian * v).norm() / v.norm() / largest;
        let (rods, radius, scale) = (gain(&rods), gain(&radius), gain(&scale));
        eprintln!(
            "probe heights per unit change, relative to the largest singular value: rods {rods:.4}, radius {radius:.4}, rods with radius {k:.3} mm per mm {scale:.4}"
        );
        assert!(
            scale < 0.2 * rods.min(radius) && k > 0.0,
            "rods {rods:e}, radius {radius:e}, together {scale:e} (radius {k} mm per mm of rod)"
        );
    }

    /// Asserts that the machines `a` and `b` give the same probe heights to
    /// 1e-9 mm, a firmware that knows the design probing them.
    fn same_probe_heights(delta: &LinearDelta, a: &[f64], b: &[f64]) {
        let firmware = design(delta);
        for [x, y] in probe_rings(100.0, 2, 6) {
            let before = probe_height(delta, a, firmware.as_slice(), x, y).unwrap();
            let after = probe_height(delta, b, firmware.as_slice(), x, y).unwrap();
            assert!((before - after).abs() < 1e-9, "{before} vs {after}");
        }
    }

    #[test]
    fn canonicalize_keeps_the_machine_and_fixes_the_gauge() {
        let delta = LinearDelta::typical();
        let mut rng = StdRng::seed_from_u64(5);
        for _ in 0..20 {
            let p = perturbed(&mut rng).to_vector();
            let canonical = delta.canonicalize(p.as_slice()).unwrap();
            let c = DeltaParams::from_slice(canonical.as_slice());
            assert_eq!(c.tower_radius, [0.0; 3]);
            assert!(c.angle[2].abs() < 1e-12);
            assert!(c.endstop.iter().sum::<f64>().abs() < 1e-12);
            // The same machine: its probe heights (a firmware that knows
            // the design probing it) are the same to 1e-9 mm. Rigid motions
            // move the probed point over the bed, not its height: a flat bed
            // reads the same.
            same_probe_heights(&delta, p.as_slice(), canonical.as_slice());
            // Canonical twice is canonical.
            let again = delta.canonicalize(canonical.as_slice()).unwrap();
            assert!((again - &canonical).amax() < 1e-9);
        }
    }

    #[test]
    fn a_frame_with_given_tower_radius_corrections_is_the_same_machine() {
        let delta = LinearDelta::typical();
        let mut rng = StdRng::seed_from_u64(11);
        for _ in 0..20 {
            let p = perturbed(&mut rng);
            let trims: [f64; 3] = std::array::from_fn(|_| rng.random_range(-2.0..2.0));
            let moved = p.with_tower_radius(trims).unwrap();
            assert_eq!(moved.tower_radius, trims);
            // The towers where they were, seen from the new origin.
            let (before, after) = (Towers::of(&p).unwrap(), Towers::of(&moved).unwrap());
            let shift = |i: usize| {
                [
                    before.position[i][0] - after.position[i][0],
                    before.position[i][1] - after.position[i][1],
                ]
            };
            for i in 1..3 {
                let (d0, di) = (shift(0), shift(i));
                assert!(
                    (d0[0] - di[0]).hypot(d0[1] - di[1]) < 1e-9,
                    "{d0:?} vs {di:?}"
                );
            }
            // The same machine: the same canonical parameters, and the same
            // probe heights for a firmware that knows the design.
            let (p, moved) = (p.to_vector(), moved.to_vector());
            let canonical = delta.canonicalize(p.as_slice()).unwrap();
            let again = delta.canonicalize(moved.as_slice()).unwrap();
            assert!(
                (&again - &canonical).amax() < 1e-9,
                "{again} vs {canonical}"
            );
            same_probe_heights(&delta, p.as_slice(), moved.as_slice());
        }
        // Already in that frame: unchanged, bit for bit.
        let p = perturbed(&mut rng);
        assert_eq!(p.with_tower_radius(p.tower_radius).unwrap(), p);
        // Corrections no frame near the towers has.
        let error = p
            .with_tower_radius([400.0, 0.0, 0.0])
            .unwrap_err()
            .to_string();
        assert!(error.contains("radius corrections"), "{error}");
    }

    #[test]
    fn feasibility_names_the_limit() {
        let delta = LinearDelta::typical();
        let p = design(&delta);
        assert!(
            delta
                .check_feasible(p.as_slice(), &[10.0, 20.0, 50.0])
                .is_ok()
        );
        let err = delta
            .check_feasible(p.as_slice(), &[120.0, 0.0, 50.0])
            .unwrap_err();
        assert!(err.to_string().contains("print radius"), "{err}");
        // On the print radius (110 mm), a point is within it whatever the
        // rounding of its coordinates; a micrometre beyond, it is not.
        for k in 0..360 {
            let angle = f64::from(k).to_radians();
            let on = [110.0 * angle.cos(), 110.0 * angle.sin(), 50.0];
            assert!(delta.check_feasible(p.as_slice(), &on).is_ok(), "{k}");
        }
        let beyond = [0.0, 110.001, 50.0];
        assert!(delta.check_feasible(p.as_slice(), &beyond).is_err());
        let err = delta
            .check_feasible(p.as_slice(), &[0.0, 0.0, 310.0])
            .unwrap_err();
        assert!(err.to_string().contains("carriage A"), "{err}");
        let err = delta.inverse(p.as_slice(), &[500.0, 0.0, 0.0]).unwrap_err();
        assert!(err.to_string().contains("beyond its diagonal rod"), "{err}");
        let steep = LinearDelta::new(
            &DeltaParams::symmetric(270.0, 135.0, 300.0),
            &Tolerances::default(),
            Limits {
                print_radius: 110.0,
                max_arm_angle: 25.0,
                travel: 400.0,
            },
        );
        let err = steep
            .check_feasible(p.as_slice(), &[0.0, 0.0, 50.0])
            .unwrap_err();
        assert!(err.to_string().contains("lean"), "{err}");
    }

    #[test]
    fn parameters_no_delta_has_are_refused_by_name() {
        let delta = LinearDelta::typical();
        let base = DeltaParams::symmetric(270.0, 135.0, 300.0);
        assert_eq!(delta.check_parameters(base.to_vector().as_slice()), Ok(()));
        let refused = |edit: &dyn Fn(&mut DeltaParams)| {
            let mut p = base;
            edit(&mut p);
            match delta.check_parameters(p.to_vector().as_slice()) {
                Err(MechanismError::Parameter { name, value, .. }) => (name, value),
                other => panic!("{other:?}"),
            }
        };
        assert_eq!(
            refused(&|p| p.diagonal[1] = 135.0),
            ("diagonal_b".into(), 135.0)
        );
        assert_eq!(
            refused(&|p| p.diagonal[2] = -300.0),
            ("diagonal_c".into(), -300.0)
        );
        assert_eq!(refused(&|p| p.radius = 0.0), ("radius".into(), 0.0));
        assert_eq!(
            refused(&|p| p.tower_radius[0] = -140.0),
            ("radius_a".into(), -140.0)
        );
        // The kinematics refuse them alike.
        let mut p = base;
        p.diagonal[0] = 100.0;
        let err = delta
            .inverse(p.to_vector().as_slice(), &[0.0, 0.0, 0.0])
            .unwrap_err();
        assert!(
            err.to_string().starts_with("parameter diagonal_a = 100:"),
            "{err}"
        );
    }
}
