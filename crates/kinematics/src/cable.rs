//! The cable robot (a cable-driven parallel robot such as the Hangprinter)
//! as a [`Mechanism`], in the Hangprinter firmware's conventions.
//!
//! `N` lines run from anchors `a_j` (points in the room, mm) to one point
//! `p` of the effector, each through a block and tackle of mechanical
//! advantage `m_j`, so its spool winds `m_j` millimetres of line for each
//! millimetre the anchor's distance changes; the spool, carrying `n_j`
//! lines, is turned by a motor through a gear of ratio `G` (spool teeth
//! over motor teeth). The encoders were zeroed with the effector at the encoder zero
//! `z_0`; the line-length change of anchor `j` at `p` is
//!
//! ```text
//! dL_j = |a_j - p| - |a_j - z_0|.
//! ```
//!
//! Line builds up on the spool: with `r_j` its radius at the encoder zero
//! and `Q` the buildup factor, the area of the wound line is proportional
//! to its length, so the radius after a change `dL` is
//! `sqrt(r_j^2 - m_j n_j Q dL)`. A motor angle `theta` (degrees) turns the
//! spool by `phi = theta / G * pi/180` and `d(dL)/d(phi) = radius / m_j`,
//! which integrates to the firmware's buildup formula (Hangprinter's
//! `auto-calibration-simulation-for-hangprinter`, `simulation.py`,
//! `motor_pos_samples_to_distances_relative_to_origin`), here in both
//! directions:
//!
//! ```text
//! c_j = -m_j n_j Q,   k_j = 2 G m_j (180/pi) / c_j,
//! theta_j = k_j (sqrt(r_j^2 + c_j dL_j) - r_j),
//! dL_j(theta) = ((r_j + theta/k_j)^2 - r_j^2) / c_j.
//! ```
//!
//! The reading of spool `j` is its motor's encoder angle `theta_j`
//! (degrees, positive when line is paid out). `Q`, `G`, `m_j` and `n_j`
//! are constants of the design ([`SpoolConstants`]); the parameters are the
//! anchors, the spool radii (one per spool or shared by a group of spools,
//! [`CableDesign::radius_of_spool`]) and the encoder zero, then the lines'
//! compliances when the lines are elastic ([`elasticity`],
//! [`CableRobot::with_elasticity`]: the readings then depend on the lines'
//! forces, [`Mechanism::loaded_readings`]). The line lengths at the encoder
//! zero, `|a_j - z_0|`, are the robot's measurable quantities
//! ([`Mechanism::quantities`]): a tape measures them.
//!
//! Forward kinematics finds the point whose readings best match the
//! encoder angles in the least-squares sense ([`crate::pose_fit`],
//! Gauss-Newton from a start pose): with more lines than pose coordinates
//! the readings are overdetermined. Every reading weighs alike, as in the
//! calibration (one encoder sigma), so the pose is the readings'
//! maximum-likelihood one; a fit of the line lengths instead would weight
//! each spool by its `(d theta / dL)^2`, which its radius and mechanical
//! advantage set.
//!
//! # Gauge
//!
//! Only distances enter, so a rigid motion of the room (the anchors, the
//! encoder zero and every pose moved alike) changes no reading: three
//! translations and three rotations ([`CableRobot::rigid_motions`]). The
//! encoder zero ties the origin (a prior on it holds the translations, as
//! the Hangprinter's convention of the origin at the encoder zero does);
//! the rotations about it remain until positions measured in the room's
//! frame fix them: one known point away from the origin fixes the two
//! rotations that move it, two not in line with the origin all three.
//! Without them the priors on the anchors hold the rotations. So the
//! rigid motions are no gauge of the mechanism but of a kind of data:
//! the room's frame, the one the known positions and the priors are given
//! in, is the canonical one ([`Mechanism::gauge_freedoms`] is empty and
//! [`Mechanism::canonicalize`] the identity), a calibration reports the
//! anchors where its data put them, and a calibration from readings alone
//! finds the rotations determined by the priors only.
//!
//! Readings alone determine the rest: the `3 N + R + 3` parameters (`N`
//! anchors, `R` radii, the encoder zero) less the 6 rigid motions, against
//! `N - 3` redundant readings per sample (each sample's pose takes 3), so
//! at least `(3 N + R - 3) / (N - 3)` samples (11 for a Hangprinter with
//! two radii, 13 with four) and many more for a well-conditioned fit.

pub mod elasticity;

use std::f64::consts::PI;

use nalgebra::{DMatrix, DVector, Vector3};

use crate::mechanism::{
    Actuator, GaugeFreedom, Mechanism, MechanismError, Parameter, PoseCoordinate, Quantity,
    QuantityValue, ReadingJacobians, check_params, check_pose, check_vector,
};
pub use elasticity::{COMPLIANCE_SCALE, COMPLIANCE_UNIT, Elasticity, TYPICAL_COMPLIANCE};

use crate::pose_fit::pose_of_readings;

/// The fewest lines of a cable robot: three lines and gravity hold a
/// point, but only four can hold it taut in every direction.
pub const MIN_CABLES: usize = 4;
/// The most lines (one letter each, `a` to `z`).
pub const MAX_CABLES: usize = 26;

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

/// The fixed constants of a cable robot's spools and gearing.
#[derive(Debug, Clone, PartialEq)]
pub struct SpoolConstants {
    /// The buildup factor `Q` (mm): the square of the spool's radius falls
    /// by `m n Q` per mm of line paid out. Positive.
    pub buildup: f64,
    /// The gear ratio `G` from motor to spool (spool teeth over motor
    /// teeth).
    pub gear_ratio: f64,
    /// The mechanical advantage `m_j` of each line's block and tackle.
    pub mechanical_advantage: Vec<f64>,
    /// The number of lines `n_j` on each spool.
    pub lines: Vec<f64>,
}

/// A cable robot's design: the parameters' nominal values and the fixed
/// constants.
#[derive(Debug, Clone, PartialEq)]
pub struct CableDesign {
    /// The anchors `a_j` (mm), one per line, in the room's frame.
    pub anchors: Vec<[f64; 3]>,
    /// The spool radii at the encoder zero (mm), one per radius parameter.
    pub spool_radius: Vec<f64>,
    /// For each spool, the index of its radius in `spool_radius` (spools
    /// built alike may share one).
    pub radius_of_spool: Vec<usize>,
    /// The point `z_0` where the encoders were zeroed (mm).
    pub encoder_zero: [f64; 3],
    /// The spools' and gears' constants.
    pub spools: SpoolConstants,
}

/// The builder's tolerances (one standard deviation of each parameter's
/// prior).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Tolerances {
    /// Each anchor coordinate (mm).
    pub anchor: f64,
    /// Each spool radius (mm).
    pub spool_radius: f64,
    /// Each coordinate of the encoder zero (mm).
    pub encoder_zero: f64,
}

/// Why a cable robot's design is refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CableDesignError {
    /// Too few or too many lines.
    #[error("a cable robot needs {MIN_CABLES} to {MAX_CABLES} lines, the design has {0}")]
    CableCount(usize),
    /// A per-spool list of the wrong length.
    #[error("{what} lists {found} values for {cables} lines")]
    PerSpool {
        /// The list.
        what: &'static str,
        /// Its length.
        found: usize,
        /// The number of lines.
        cables: usize,
    },
    /// A spool naming a radius that does not exist, or a radius no spool
    /// uses.
    #[error("spool radii: {0}")]
    Radii(String),
    /// An elasticity option that does not fit the design.
    #[error("line elasticity: {0}")]
    Elasticity(String),
    /// A constant or value out of its range.
    #[error("{what} = {value} must be {must}")]
    Range {
        /// The constant.
        what: String,
        /// Its value.
        value: f64,
        /// The range.
        must: &'static str,
    },
}

/// A cable robot: its parameters with their tolerances, its actuators and
/// its constants.
#[derive(Debug, Clone)]
pub struct CableRobot {
    parameters: Vec<Parameter>,
    actuators: Vec<Actuator>,
    spools: SpoolConstants,
    radius_of_spool: Vec<usize>,
    radii: usize,
    quantities: Vec<Quantity>,
    elasticity: Option<Elasticity>,
}

/// The name of line `j` (`a`, `b`, ...).
pub fn cable_name(j: usize) -> char {
    (b'a' + j as u8) as char
}

/// One line's geometry at a pose.
struct Line {
    /// `|a_j - p|` (mm).
    length: f64,
    /// `(p - a_j) / |p - a_j|`: the derivative of the length by `p`.
    direction: Vector3<f64>,
    /// `|a_j - z_0|` (mm).
    length_at_zero: f64,
    /// `(z_0 - a_j) / |z_0 - a_j|`.
    direction_at_zero: Vector3<f64>,
}

impl CableRobot {
    /// A cable robot of the given design and tolerances.
    pub fn new(design: &CableDesign, tolerances: &Tolerances) -> Result<Self, CableDesignError> {
        let cables = design.anchors.len();
        if !(MIN_CABLES..=MAX_CABLES).contains(&cables) {
            return Err(CableDesignError::CableCount(cables));
        }
        let spools = &design.spools;
        for (what, found) in [
            (
                "the mechanical advantages",
                spools.mechanical_advantage.len(),
            ),
            ("the lines per spool", spools.lines.len()),
            ("the radius of each spool", design.radius_of_spool.len()),
        ] {
            if found != cables {
                return Err(CableDesignError::PerSpool {
                    what,
                    found,
                    cables,
                });
            }
        }
        let radii = design.spool_radius.len();
        if let Some(j) = design.radius_of_spool.iter().position(|&k| k >= radii) {
            return Err(CableDesignError::Radii(format!(
                "spool {} uses radius {} of {radii}",
                cable_name(j).to_ascii_uppercase(),
                design.radius_of_spool[j] + 1
            )));
        }
        if let Some(k) = (0..radii).find(|k| !design.radius_of_spool.contains(k)) {
            return Err(CableDesignError::Radii(format!(
                "radius {} is used by no spool",
                k + 1
            )));
        }
        let positive = |what: String, value: f64| {
            if value.is_finite() && value > 0.0 {
                Ok(())
            } else {
                Err(CableDesignError::Range {
                    what,
                    value,
                    must: "a positive number",
                })
            }
        };
        positive("the buildup factor Q".into(), spools.buildup)?;
        positive("the gear ratio".into(), spools.gear_ratio)?;
        for j in 0..cables {
            let name = cable_name(j).to_ascii_uppercase();
            positive(
                format!("the mechanical advantage of {name}"),
                spools.mechanical_advantage[j],
            )?;
            positive(format!("the lines on spool {name}"), spools.lines[j])?;
        }
        for (k, &r) in design.spool_radius.iter().enumerate() {
            positive(format!("spool radius {}", k + 1), r)?;
        }
        positive("the anchor tolerance".into(), tolerances.anchor)?;
        positive("the spool radius tolerance".into(), tolerances.spool_radius)?;
        positive("the encoder zero tolerance".into(), tolerances.encoder_zero)?;

        let mut parameters = Vec::with_capacity(3 * cables + radii + 3);
        for (j, anchor) in design.anchors.iter().enumerate() {
            for (axis, value) in ["x", "y", "z"].iter().zip(anchor) {
                parameters.push(Parameter {
                    name: format!("anchor_{}_{axis}", cable_name(j)),
                    unit: "mm".into(),
                    group: "anchors",
                    design: *value,
                    prior_sigma: tolerances.anchor,
                });
            }
        }
        for (k, &value) in design.spool_radius.iter().enumerate() {
            let spools: String = (0..cables)
                .filter(|&j| design.radius_of_spool[j] == k)
                .map(cable_name)
                .collect();
            parameters.push(Parameter {
                name: format!("radius_{spools}"),
                unit: "mm".into(),
                group: "spool radii",
                design: value,
                prior_sigma: tolerances.spool_radius,
            });
        }
        for (axis, value) in ["x", "y", "z"].iter().zip(design.encoder_zero) {
            parameters.push(Parameter {
                name: format!("zero_{axis}"),
                unit: "mm".into(),
                group: "encoder zero",
                design: value,
                prior_sigma: tolerances.encoder_zero,
            });
        }
        let actuators = (0..cables)
            .map(|j| {
                Actuator::direct(
                    format!("spool {}", cable_name(j).to_ascii_uppercase()),
                    "deg",
                )
            })
            .collect();
        let quantities = (0..cables)
            .map(|j| Quantity {
                name: format!("line_length_{}", cable_name(j)),
                unit: "mm",
            })
            .collect();
        Ok(Self {
            parameters,
            actuators,
            spools: design.spools.clone(),
            radius_of_spool: design.radius_of_spool.clone(),
            radii,
            quantities,
            elasticity: None,
        })
    }

    /// This robot with elastic lines ([`elasticity`]): its compliance
    /// parameters follow the encoder zero's, and its readings depend on
    /// the lines' loads ([`Mechanism::loaded_readings`]). An error names
    /// what does not fit.
    pub fn with_elasticity(mut self, elasticity: Elasticity) -> Result<Self, CableDesignError> {
        if self.elasticity.is_some() {
            return Err(CableDesignError::Elasticity(
                "the robot's lines are elastic already".into(),
            ));
        }
        elasticity
            .check(self.cables())
            .map_err(CableDesignError::Elasticity)?;
        self.parameters.extend(elasticity.parameters(cable_name));
        self.elasticity = Some(elasticity);
        Ok(self)
    }

    /// The elasticity option, if the lines are elastic
    /// ([`Mechanism::line_compliances`] gives what rebuilds it).
    pub fn elasticity(&self) -> Option<&Elasticity> {
        self.elasticity.as_ref()
    }

    /// The Hangprinter v4 of `auto-calibration-simulation-for-hangprinter`
    /// (`simulation.py`, lines 19-27 and 981-988): gear 255/20, buildup
    /// factor 0.06875 mm, mechanical advantage 2 on A, B, C and 4 on D, one
    /// line per spool, spool radii 75 mm, the hand-measured anchors as the
    /// design; `radius_of_spool` groups the spools' radii (`[0, 0, 0, 1]`
    /// is the source's A = B = C, D; `[0, 1, 2, 3]` one each).
    pub fn hangprinter_v4(
        radius_of_spool: &[usize],
        tolerances: &Tolerances,
    ) -> Result<Self, CableDesignError> {
        let radii = radius_of_spool.iter().max().map_or(0, |k| k + 1);
        let (s45, c30) = (0.5f64.sqrt(), 3f64.sqrt() / 2.0);
        let design = CableDesign {
            anchors: vec![
                [0.0, -1620.0, -150.0],
                [1800.0 * s45, 1800.0 * s45, -150.0],
                [-1620.0 * c30, 1620.0 * 0.5, -150.0],
                [0.0, 0.0, 2350.0],
            ],
            spool_radius: vec![75.0; radii],
            radius_of_spool: radius_of_spool.to_vec(),
            encoder_zero: [0.0; 3],
            spools: SpoolConstants {
                buildup: 0.06875,
                gear_ratio: 255.0 / 20.0,
                mechanical_advantage: vec![2.0, 2.0, 2.0, 4.0],
                lines: vec![1.0; 4],
            },
        };
        Self::new(&design, tolerances)
    }

    /// The Hangprinter v4 with one radius per spool and the tolerances of
    /// a hand-built machine: anchors 50 mm (measured by hand: the source's
    /// differ from its calibration by up to 67 mm), spool radii 1 mm
    /// (the source's bounds 74.5..76.5), encoder zero 5 mm (where the
    /// effector stood when the encoders were zeroed, against the frame of
    /// the measured positions).
    pub fn typical() -> Self {
        let tolerances = Tolerances {
            anchor: 50.0,
            spool_radius: 1.0,
            encoder_zero: 5.0,
        };
        Self::hangprinter_v4(&[0, 1, 2, 3], &tolerances)
            .expect("the Hangprinter v4's design is valid")
    }

    /// [`Self::typical`] with elastic lines ([`Self::with_elasticity`],
    /// [`Elasticity::typical`]): each line's compliance among
    /// `compliance_of_line`'s, pulled by `zero_loads` (N) at the encoder
    /// zero; an error naming what does not fit its lines.
    pub fn typical_elastic(
        compliance_of_line: Vec<usize>,
        zero_loads: Vec<f64>,
    ) -> Result<Self, CableDesignError> {
        Self::typical().with_elasticity(Elasticity::typical(compliance_of_line, zero_loads))
    }

    /// The number of lines `N`.
    pub fn cables(&self) -> usize {
        self.radius_of_spool.len()
    }

    /// The number of spool radius parameters.
    pub fn radii(&self) -> usize {
        self.radii
    }

    /// The spools' and gears' constants.
    pub fn spools(&self) -> &SpoolConstants {
        &self.spools
    }

    /// The index of the radius parameter spool `j` uses, among the radii.
    pub fn radius_of_spool(&self, j: usize) -> usize {
        self.radius_of_spool[j]
    }

    /// The index of anchor `j`'s x coordinate in the parameter vector (y
    /// and z follow).
    pub fn anchor_index(&self, j: usize) -> usize {
        3 * j
    }

    /// The index of radius `k` in the parameter vector.
    pub fn radius_index(&self, k: usize) -> usize {
        3 * self.cables() + k
    }

    /// The index of the encoder zero's x coordinate in the parameter
    /// vector (y and z follow).
    pub fn zero_index(&self) -> usize {
        3 * self.cables() + self.radii
    }

    /// The index of line `j`'s compliance in the parameter vector, for a
    /// robot with elastic lines.
    pub fn compliance_index(&self, j: usize) -> Option<usize> {
        let elasticity = self.elasticity.as_ref()?;
        Some(self.zero_index() + 3 + elasticity.compliance_of_line[j])
    }

    /// Anchor `j` of a parameter vector.
    pub fn anchor(&self, params: &[f64], j: usize) -> Vector3<f64> {
        Vector3::from_column_slice(&params[self.anchor_index(j)..self.anchor_index(j) + 3])
    }

    /// The encoder zero of a parameter vector.
    pub fn encoder_zero(&self, params: &[f64]) -> Vector3<f64> {
        Vector3::from_column_slice(&params[self.zero_index()..self.zero_index() + 3])
    }

    /// Spool `j`'s radius at the encoder zero in a parameter vector.
    pub fn spool_radius(&self, params: &[f64], j: usize) -> f64 {
        params[self.radius_index(self.radius_of_spool[j])]
    }

    /// `c_j = -m_j n_j Q` (mm).
    fn buildup(&self, j: usize) -> f64 {
        -self.spools.mechanical_advantage[j] * self.spools.lines[j] * self.spools.buildup
    }

    /// `k_j = 2 G m_j (180/pi) / c_j` (degrees per mm).
    fn angle_scale(&self, j: usize) -> f64 {
        2.0 * self.spools.gear_ratio * self.spools.mechanical_advantage[j] * 180.0
            / PI
            / self.buildup(j)
    }

    fn line(&self, params: &[f64], j: usize, pose: &[f64]) -> Result<Line, MechanismError> {
        let anchor = self.anchor(params, j);
        let to_pose = Vector3::from_column_slice(pose) - anchor;
        let to_zero = self.encoder_zero(params) - anchor;
        let (length, length_at_zero) = (to_pose.norm(), to_zero.norm());
        if length == 0.0 || length_at_zero == 0.0 {
            return Err(MechanismError::Unreachable {
                reason: format!(
                    "the effector or the encoder zero is at anchor {}",
                    cable_name(j).to_ascii_uppercase()
                ),
            });
        }
        Ok(Line {
            length,
            direction: to_pose / length,
            length_at_zero,
            direction_at_zero: to_zero / length_at_zero,
        })
    }

    /// `sqrt(r_j^2 + c_j dL)`: spool `j`'s radius after a line-length
    /// change `dL` (mm); an error when the spool would run empty.
    fn wound_radius(&self, params: &[f64], j: usize, change: f64) -> Result<f64, MechanismError> {
        let r = self.spool_radius(params, j);
        let square = r * r + self.buildup(j) * change;
        if square > 0.0 {
            Ok(square.sqrt())
        } else {
            Err(MechanismError::Unreachable {
                reason: format!(
                    "spool {} would run out of line: {change:.1} mm paid out from a spool of radius {r:.3} mm",
                    cable_name(j).to_ascii_uppercase()
                ),
            })
        }
    }

    /// The line-length changes `dL_j = |a_j - p| - |a_j - z_0|` at `pose`
    /// (mm).
    pub fn line_changes(
        &self,
        params: &[f64],
        pose: &[f64],
    ) -> Result<DVector<f64>, MechanismError> {
        self.check_parameters(params)?;
        check_pose(self, pose, 3)?;
        let mut changes = DVector::zeros(self.cables());
        for j in 0..self.cables() {
            let line = self.line(params, j, pose)?;
            changes[j] = line.length - line.length_at_zero;
        }
        Ok(changes)
    }

    /// The line-length changes the readings say were paid out,
    /// `dL_j(theta_j) = ((r_j + theta_j/k_j)^2 - r_j^2) / c_j` (mm); an
    /// error for a reading that would wind the spool past its core.
    pub fn paid_out(
        &self,
        params: &[f64],
        readings: &[f64],
    ) -> Result<DVector<f64>, MechanismError> {
        self.check_parameters(params)?;
        check_vector(self, "readings", readings, self.cables())?;
        let mut changes = DVector::zeros(self.cables());
        for j in 0..self.cables() {
            let r = self.spool_radius(params, j);
            let turned = readings[j] / self.angle_scale(j);
            if r + turned <= 0.0 {
                return Err(MechanismError::Unreachable {
                    reason: format!(
                        "spool {}: {:.2} degrees would unwind it past its core",
                        cable_name(j).to_ascii_uppercase(),
                        readings[j]
                    ),
                });
            }
            changes[j] = turned * (2.0 * r + turned) / self.buildup(j);
        }
        Ok(changes)
    }

    /// The readings at `pose` under `loads` (the loads at the encoder zero
    /// without), with their derivatives. With `R_j = sqrt(r_j^2 + c_j dL_j)`
    /// the wound radius after the change the encoder sees, `dL_j`
    /// ([`elasticity`]; `s_j = 1 - c_j (F_j - F0_j)`, 1 for rigid lines or
    /// no loads), `g_j = dtheta_j/d(dL_j) = k_j c_j / (2 R_j) =
    /// G m_j (180/pi) / R_j`, `u_j = (p - a_j)/|p - a_j|` and
    /// `u0_j = (z_0 - a_j)/|z_0 - a_j|`:
    ///
    /// ```text
    /// theta_j = k_j (R_j - r_j)
    /// dtheta_j/dp   = g_j s_j u_j
    /// dtheta_j/da_j = g_j (u0_j - s_j u_j)
    /// dtheta_j/dz_0 = -g_j u0_j
    /// dtheta_j/dr_j = k_j (r_j / R_j - 1)
    /// dtheta_j/dc_j = -g_j (F_j - F0_j) |a_j - p|
    /// ```
    ///
    /// A load that is not positive is refused: it would be a slack line's.
    fn readings_under(
        &self,
        params: &[f64],
        pose: &[f64],
        loads: Option<&[f64]>,
    ) -> Result<(DVector<f64>, ReadingJacobians), MechanismError> {
        self.check_parameters(params)?;
        check_pose(self, pose, 3)?;
        let n = self.cables();
        if let Some(loads) = loads {
            check_vector(self, "loads", loads, n)?;
            if let Some(j) = loads.iter().position(|f| !elasticity::is_taut(*f)) {
                return Err(MechanismError::Unreachable {
                    reason: format!(
                        "line {}'s load, {} N, is not positive: a line is taut under a positive load",
                        cable_name(j).to_ascii_uppercase(),
                        loads[j]
                    ),
                });
            }
        }
        let mut q = DVector::zeros(n);
        let mut d_params = DMatrix::zeros(n, self.parameters.len());
        let mut d_pose = DMatrix::zeros(n, 3);
        let zero = self.zero_index();
        for j in 0..n {
            let line = self.line(params, j, pose)?;
            // The load beyond the encoder zero's, and the compliance.
            let stretched = match (self.compliance_index(j), loads) {
                (Some(index), Some(loads)) => {
                    let load = loads[j] - self.elasticity.as_ref().map_or(0.0, |e| e.zero_loads[j]);
                    Some((index, load))
                }
                _ => None,
            };
            let s = stretched.map_or(1.0, |(index, load)| {
                1.0 - params[index] * COMPLIANCE_SCALE * load
            });
            let change = s * line.length - line.length_at_zero;
            let wound = self.wound_radius(params, j, change)?;
            let r = self.spool_radius(params, j);
            let k = self.angle_scale(j);
            // k (R - r) = k c dL / (R + r), without the cancellation.
            q[j] = k * self.buildup(j) * change / (wound + r);
            let g = k * self.buildup(j) / (2.0 * wound);
            let anchor = self.anchor_index(j);
            for axis in 0..3 {
                d_pose[(j, axis)] = g * s * line.direction[axis];
                d_params[(j, anchor + axis)] =
                    g * (line.direction_at_zero[axis] - s * line.direction[axis]);
                d_params[(j, zero + axis)] = -g * line.direction_at_zero[axis];
            }
            d_params[(j, self.radius_index(self.radius_of_spool[j]))] = k * (r / wound - 1.0);
            if let Some((index, load)) = stretched {
                d_params[(j, index)] = -g * load * COMPLIANCE_SCALE * line.length;
            }
        }
        Ok((q, ReadingJacobians { d_params, d_pose }))
    }

    /// The rigid motions of the room, which no reading sees (module
    /// documentation): a translation `e_k` moves every anchor and the
    /// encoder zero by `e_k`; a rotation `w` about the origin moves each
    /// of them, `v`, by `w x v`. Six directions, each normalised. They are
    /// not [`Mechanism::gauge_freedoms`]: a measured position sees them.
    pub fn rigid_motions(&self, params: &[f64]) -> Result<Vec<GaugeFreedom>, MechanismError> {
        self.check_parameters(params)?;
        let points: Vec<usize> = (0..self.cables())
            .map(|j| self.anchor_index(j))
            .chain([self.zero_index()])
            .collect();
        let motion = |name, of: &dyn Fn(Vector3<f64>) -> Vector3<f64>| {
            let mut v = DVector::zeros(self.parameters.len());
            for &index in &points {
                let moved = of(Vector3::from_column_slice(&params[index..index + 3]));
                v.rows_mut(index, 3).copy_from(&moved);
            }
            GaugeFreedom {
                name,
                direction: v.normalize(),
            }
        };
        let names = [
            ("translation along x", "rotation about x"),
            ("translation along y", "rotation about y"),
            ("translation along z", "rotation about z"),
        ];
        let mut freedoms = Vec::with_capacity(6);
        for (axis, (translation, _)) in names.iter().enumerate() {
            freedoms.push(motion(translation, &|_| Vector3::ith(axis, 1.0)));
        }
        for (axis, (_, rotation)) in names.iter().enumerate() {
            freedoms.push(motion(rotation, &|v| {
                Vector3::<f64>::ith(axis, 1.0).cross(&v)
            }));
        }
        Ok(freedoms)
    }
}

impl Mechanism for CableRobot {
    fn name(&self) -> &str {
        "cable robot"
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

    /// Refuses parameters of the wrong length, non-finite or with a spool
    /// radius that is not positive.
    fn check_parameters(&self, params: &[f64]) -> Result<(), MechanismError> {
        check_params(self, params)?;
        for k in 0..self.radii {
            let value = params[self.radius_index(k)];
            if value <= 0.0 {
                return Err(MechanismError::Parameter {
                    name: self.parameters[self.radius_index(k)].name.clone(),
                    value,
                    reason: "a spool radius must be positive".to_string(),
                });
            }
        }
        Ok(())
    }

    /// `theta_j = k_j (sqrt(r_j^2 + c_j dL_j) - r_j)` (module
    /// documentation), the lines loaded as at the encoder zero.
    fn inverse(&self, params: &[f64], pose: &[f64]) -> Result<DVector<f64>, MechanismError> {
        Ok(self.readings_under(params, pose, None)?.0)
    }

    /// The least-squares pose of the readings from `start`
    /// ([`pose_of_readings`], module doc).
    fn forward(
        &self,
        params: &[f64],
        readings: &[f64],
        start: &[f64],
    ) -> Result<DVector<f64>, MechanismError> {
        // Readings that unwind a spool past its core have no pose.
        self.paid_out(params, readings)?;
        pose_of_readings(self, params, readings, start)
    }

    /// The derivatives of `CableRobot::readings_under` without loads.
    fn reading_jacobians(
        &self,
        params: &[f64],
        pose: &[f64],
    ) -> Result<ReadingJacobians, MechanismError> {
        Ok(self.readings_under(params, pose, None)?.1)
    }

    /// `CableRobot::readings_under` the lines' forces `loads` (N): with
    /// rigid lines the loads change nothing.
    fn loaded_readings(
        &self,
        params: &[f64],
        pose: &[f64],
        loads: &[f64],
    ) -> Result<(DVector<f64>, ReadingJacobians), MechanismError> {
        self.readings_under(params, pose, Some(loads))
    }

    /// The line lengths at the encoder zero, `line_length_a`, ...
    fn line_compliances(&self) -> Option<(&[usize], &[f64])> {
        (self.elasticity.as_ref())
            .map(|e| (e.compliance_of_line.as_slice(), e.zero_loads.as_slice()))
    }

    fn quantities(&self) -> &[Quantity] {
        &self.quantities
    }

    /// `|a_j - z_0|`, with `d/da_j = -u0_j` and `d/dz_0 = u0_j`
    /// (`u0_j = (z_0 - a_j)/|z_0 - a_j|`).
    fn quantity(&self, index: usize, params: &[f64]) -> Result<QuantityValue, MechanismError> {
        self.check_parameters(params)?;
        if index >= self.cables() {
            return Err(MechanismError::NoModel {
                mechanism: self.name().to_string(),
                what: format!("quantity {index} (it has {})", self.cables()),
            });
        }
        let zero = self.encoder_zero(params);
        let line = self.line(params, index, zero.as_slice())?;
        let mut gradient = DVector::zeros(self.parameters.len());
        let direction = line.direction_at_zero;
        gradient
            .rows_mut(self.anchor_index(index), 3)
            .copy_from(&-direction);
        gradient
            .rows_mut(self.zero_index(), 3)
            .copy_from(&direction);
        Ok(QuantityValue {
            value: line.length_at_zero,
            gradient,
        })
    }

    /// Every spool within its line ([`Mechanism::inverse`]) and the
    /// effector strictly inside the anchors' convex hull: only there can
    /// every line be taut whatever the load (the lines' directions then
    /// span every direction with positive tensions).
    fn check_feasible(&self, params: &[f64], pose: &[f64]) -> Result<(), MechanismError> {
        self.inverse(params, pose)?;
        let anchors: Vec<Vector3<f64>> =
            (0..self.cables()).map(|j| self.anchor(params, j)).collect();
        let p = Vector3::from_column_slice(pose);
        let scale = anchors.iter().map(|a| a.norm()).fold(0.0, f64::max);
        let mut faces = 0;
        for i in 0..anchors.len() {
            for j in i + 1..anchors.len() {
                for k in j + 1..anchors.len() {
                    let normal = (anchors[j] - anchors[i]).cross(&(anchors[k] - anchors[i]));
                    if normal.norm() <= 1e-12 * scale * scale {
                        continue;
                    }
                    let side = |v: &Vector3<f64>| normal.dot(&(v - anchors[i]));
                    let others: Vec<f64> = (0..anchors.len())
                        .filter(|&l| l != i && l != j && l != k)
                        .map(|l| side(&anchors[l]))
                        .collect();
                    let inside = if others.iter().all(|&s| s <= 0.0) {
                        -1.0
                    } else if others.iter().all(|&s| s >= 0.0) {
                        1.0
                    } else {
                        continue;
                    };
                    faces += 1;
                    if side(&p) * inside <= 0.0 {
                        let name = |l: usize| cable_name(l).to_ascii_uppercase();
                        return Err(MechanismError::Unreachable {
                            reason: format!(
                                "the effector at ({:.1}, {:.1}, {:.1}) is outside the anchors' hull, beyond the face {}{}{}: a line would go slack",
                                p.x,
                                p.y,
                                p.z,
                                name(i),
                                name(j),
                                name(k)
                            ),
                        });
                    }
                }
            }
        }
        if faces == 0 {
            return Err(MechanismError::Unreachable {
                reason: "the anchors lie in one plane: no point is held taut".into(),
            });
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mechanism::{design, reading_jacobians_by_differences};
    use rand::rngs::StdRng;
    use rand::{RngExt, SeedableRng};

    /// A Hangprinter off its hand-measured design by up to 80 mm, radii by
    /// up to 1 mm, encoder zero by up to 2 mm.
    fn perturbed(robot: &CableRobot, rng: &mut StdRng) -> DVector<f64> {
        let mut p = design(robot);
        for (value, parameter) in p.iter_mut().zip(robot.parameters()) {
            let scale = match parameter.group {
                "anchors" => 80.0,
                "spool radii" => 1.0,
                _ => 2.0,
            };
            *value += rng.random_range(-scale..scale);
        }
        p
    }

    /// A pose in the Hangprinter's working volume.
    fn random_pose(rng: &mut StdRng) -> [f64; 3] {
        [
            rng.random_range(-500.0..500.0),
            rng.random_range(-500.0..500.0),
            rng.random_range(0.0..1500.0),
        ]
    }

    #[test]
    fn readings_follow_the_firmware_buildup_formula() {
        // To first order dL = r theta / (G m) * pi/180: at the published
        // radii 0.0520 mm per degree on A, B, C and 0.0259 on D.
        let robot = CableRobot::typical();
        let mut p = design(&robot);
        for (j, r) in [76.017, 76.017, 76.017, 75.657].iter().enumerate() {
            p[robot.radius_index(j)] = *r;
        }
        let small = robot.paid_out(p.as_slice(), &[1e-3; 4]).unwrap() * 1e3;
        for (j, expected) in [0.0520, 0.0520, 0.0520, 0.0259].iter().enumerate() {
            assert!((small[j] - expected).abs() < 5e-5, "{small}");
        }
        // The buildup: paying out line empties the spool, so a degree pays
        // out less at the end of a long line.
        let long = robot.paid_out(p.as_slice(), &[15000.0; 4]).unwrap();
        let linear = 15000.0 * &small;
        assert!((0..4).all(|j| long[j] < linear[j]), "{long} vs {linear}");
        // Readings to line lengths and back.
        let mut rng = StdRng::seed_from_u64(1);
        for _ in 0..50 {
            let p = perturbed(&robot, &mut rng);
            let pose = random_pose(&mut rng);
            let q = robot.inverse(p.as_slice(), &pose).unwrap();
            let back = robot.paid_out(p.as_slice(), q.as_slice()).unwrap();
            let changes = robot.line_changes(p.as_slice(), &pose).unwrap();
            assert!((back - changes).amax() < 1e-9);
        }
        // At the encoder zero every reading is zero.
        let zero = robot.encoder_zero(p.as_slice());
        let q = robot.inverse(p.as_slice(), zero.as_slice()).unwrap();
        assert!(q.amax() < 1e-9, "{q}");
    }

    #[test]
    fn forward_inverts_inverse_over_the_workspace() {
        let robot = CableRobot::typical();
        let mut rng = StdRng::seed_from_u64(36);
        let mut worst: f64 = 0.0;
        for _ in 0..200 {
            let p = perturbed(&robot, &mut rng);
            let pose = random_pose(&mut rng);
            let q = robot.inverse(p.as_slice(), &pose).unwrap();
            let back = robot
                .forward(p.as_slice(), q.as_slice(), &[0.0; 3])
                .unwrap();
            worst = worst.max((back - DVector::from_column_slice(&pose)).amax());
        }
        assert!(worst < 1e-8, "largest error {worst:e} mm");
    }

    #[test]
    fn reading_derivatives_match_central_differences() {
        for radii in [&[0, 0, 0, 1][..], &[0, 1, 2, 3]] {
            let tolerances = Tolerances {
                anchor: 50.0,
                spool_radius: 1.0,
                encoder_zero: 1.0,
            };
            let robot = CableRobot::hangprinter_v4(radii, &tolerances).unwrap();
            let mut rng = StdRng::seed_from_u64(7);
            for _ in 0..50 {
                let p = perturbed(&robot, &mut rng);
                let pose = random_pose(&mut rng);
                let analytic = robot.reading_jacobians(p.as_slice(), &pose).unwrap();
                // Steps of 0.01 mm: dtheta/dL ~ 40 deg/mm at most, its
                // third derivative along a line ~40 / L^2 ~ 1e-5 deg/mm^3,
                // truncation h^2/6 * 1e-5 ~ 2e-10; rounding of lengths
                // ~2000 mm, 1e-16 * 2000 * 40 / h ~ 1e-9. Along a radius
                // the third derivative is ~k c dL / R^4 ~ 1 deg/mm^3, so
                // its steps are 1e-3 mm (truncation ~2e-7).
                let steps: Vec<f64> = robot
                    .parameters()
                    .iter()
                    .map(|q| if q.group == "spool radii" { 1e-3 } else { 1e-2 })
                    .collect();
                let numeric =
                    reading_jacobians_by_differences(&robot, p.as_slice(), &pose, &steps, 1e-2)
                        .unwrap();
                let (dp, dx) = (
                    (&analytic.d_params - &numeric.d_params).amax(),
                    (&analytic.d_pose - &numeric.d_pose).amax(),
                );
                assert!(dp < 1e-6 && dx < 1e-8, "d_params {dp:e}, d_pose {dx:e}");
            }
        }
    }

    /// The derivatives of every reading of `poses` with respect to the
    /// parameters and the poses: `[G_p | blockdiag(G_x)]`.
    fn measurement_jacobian(robot: &CableRobot, p: &[f64], poses: &[[f64; 3]]) -> DMatrix<f64> {
        let (n, m) = (robot.cables(), p.len());
        let mut jacobian = DMatrix::zeros(n * poses.len(), m + 3 * poses.len());
        for (i, pose) in poses.iter().enumerate() {
            let g = robot.reading_jacobians(p, pose).unwrap();
            jacobian.view_mut((n * i, 0), (n, m)).copy_from(&g.d_params);
            jacobian
                .view_mut((n * i, m + 3 * i), (n, 3))
                .copy_from(&g.d_pose);
        }
        jacobian
    }

    #[test]
    fn the_readings_see_everything_but_the_rigid_motions() {
        let robot = CableRobot::typical();
        let mut rng = StdRng::seed_from_u64(3);
        let p = perturbed(&robot, &mut rng);
        let poses: Vec<[f64; 3]> = (0..30).map(|_| random_pose(&mut rng)).collect();
        let jacobian = measurement_jacobian(&robot, p.as_slice(), &poses);
        let freedoms = robot.rigid_motions(p.as_slice()).unwrap();
        assert!(robot.gauge_freedoms(p.as_slice()).unwrap().is_empty());
        assert_eq!(freedoms.len(), 6);
        let m = p.len();
        for (k, freedom) in freedoms.iter().enumerate() {
            // The poses move with the room: by the translation, or by the
            // rotation w x pose (w scaled as the direction was).
            let scale = if k < 3 {
                freedom.direction[robot.zero_index() + k]
            } else {
                let axis = Vector3::ith(k - 3, 1.0);
                let a = robot.anchor(p.as_slice(), 0);
                let moved = Vector3::from_column_slice(&freedom.direction.as_slice()[0..3]);
                moved.norm() / axis.cross(&a).norm()
            };
            let mut v = DVector::zeros(m + 3 * poses.len());
            v.rows_mut(0, m).copy_from(&freedom.direction);
            for (i, pose) in poses.iter().enumerate() {
                let step = if k < 3 {
                    Vector3::ith(k, scale)
                } else {
                    Vector3::ith(k - 3, scale).cross(&Vector3::from_column_slice(pose))
                };
                v.rows_mut(m + 3 * i, 3).copy_from(&step);
            }
            let seen = (&jacobian * &v).amax();
            assert!(seen < 1e-9, "{}: readings move by {seen:e}", freedom.name);
        }
        // The rest is identifiable: 6 singular values at zero, the 7th
        // clearly above.
        let mut sorted: Vec<f64> = jacobian.singular_values().iter().copied().collect();
        sorted.sort_by(f64::total_cmp);
        let largest = sorted[sorted.len() - 1];
        assert!(sorted[5] < 1e-10 * largest, "{:?}", &sorted[..8]);
        assert!(sorted[6] > 1e-7 * largest, "{:?}", &sorted[..8]);
    }

    #[test]
    fn bad_designs_and_poses_are_named() {
        let robot = CableRobot::typical();
        let p = design(&robot);
        assert!(
            robot
                .check_feasible(p.as_slice(), &[0.0, 0.0, 500.0])
                .is_ok()
        );
        let err = robot
            .check_feasible(p.as_slice(), &[0.0, 0.0, 3000.0])
            .unwrap_err();
        assert!(
            err.to_string().contains("outside the anchors' hull"),
            "{err}"
        );
        let err = robot
            .check_feasible(p.as_slice(), &[0.0, -1700.0, 0.0])
            .unwrap_err();
        assert!(err.to_string().contains("hull"), "{err}");
        let err = robot
            .inverse(p.as_slice(), &[0.0, 0.0, -30000.0])
            .unwrap_err();
        assert!(err.to_string().contains("run out of line"), "{err}");
        let err = robot
            .paid_out(p.as_slice(), &[0.0, 0.0, 0.0, 2e6])
            .unwrap_err();
        assert!(err.to_string().contains("spool D"), "{err}");
        let mut bad = p.clone();
        bad[robot.radius_index(1)] = -1.0;
        let err = robot.inverse(bad.as_slice(), &[0.0; 3]).unwrap_err();
        assert!(err.to_string().contains("radius_b"), "{err}");
        let tolerances = Tolerances {
            anchor: 50.0,
            spool_radius: 1.0,
            encoder_zero: 1.0,
        };
        let err = CableRobot::hangprinter_v4(&[0, 0, 2, 2], &tolerances).unwrap_err();
        assert!(
            err.to_string().contains("radius 2 is used by no spool"),
            "{err}"
        );
        let err = CableRobot::hangprinter_v4(&[0, 0, 0], &tolerances).unwrap_err();
        assert!(err.to_string().contains("3 values for 4 lines"), "{err}");
    }
}
