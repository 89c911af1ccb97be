//! What a simulated instrument campaign is: the machine with its actuator
//! scales, the workspace, the instrument's noise and what changes between
//! sessions.

use nalgebra::{Translation3, UnitQuaternion};
use parcal_dataset::{PriorSigma, SessionModel};
use parcal_kinematics::{Geometry, Pose, Vec3, paper};

use crate::Rng;

/// What the instrument measures in each session.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TrackerKind {
    /// Platform body poses (poses.csv).
    Poses,
    /// Tool points (points.csv).
    Points,
    /// Both: each session has its rows of poses and as many rows of points,
    /// at poses drawn independently.
    Both,
}

impl TrackerKind {
    /// Whether the sessions have poses.
    pub fn poses(self) -> bool {
        matches!(self, Self::Poses | Self::Both)
    }

    /// Whether the sessions have points.
    pub fn points(self) -> bool {
        matches!(self, Self::Points | Self::Both)
    }

    /// How many files (poses.csv, points.csv) each row is written to.
    pub fn files(self) -> usize {
        usize::from(self.poses()) + usize::from(self.points())
    }
}

/// Where the platform frame's origin is drawn, uniformly, in the base frame:
/// `|x|, |y| <= half_width`, `z` in `height`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Workspace {
    /// Half-range of x and y (mm).
    pub half_width: f64,
    /// Range of z (mm).
    pub height: [f64; 2],
}

impl Workspace {
    /// The platform parallel to the base at the workspace's centre.
    pub fn centre(&self) -> Pose {
        let z = 0.5 * (self.height[0] + self.height[1]);
        Pose::from_parts(Translation3::new(0.0, 0.0, z), UnitQuaternion::identity())
    }
}

/// How each session's instrument frame `F_k` (`x_instrument = R x_base +
/// t`) is drawn: `R` a rotation by an angle uniform in `[0, max_angle]`
/// about an axis uniform on the sphere, `t = offset + u` with each
/// coordinate of `u` uniform in `[-spread, spread]`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FrameSpread {
    /// Largest rotation angle (rad).
    pub max_angle: f64,
    /// Mean translation (mm).
    pub offset: Vec3,
    /// Half-range of each translation coordinate about `offset` (mm).
    pub spread: f64,
}

/// Everything that defines a simulated instrument campaign except the seed.
///
/// The model (shared with the calibration):
///
/// - leg `i` is `L_i = l_i + o_{k,i} + s_i q_i` long, for the reading `q_i`
///   (actuators' unit), the scale `s_i` (mm per unit) and the zero offset
///   `o_{k,i}` of session `k` (`o_0 = 0`: `l` absorbs the first session's);
/// - the instrument measures, in its frame `F_k` (`x_instrument = R_F x_base
///   + t_F`), either the platform body frame `M = F_k T B_k` (`B_k`:
///   `x_platform = R_B x_body + t_B`) or the tool tip `F_k (T E_T)`, for the
///   platform pose `T` (`x_base = R x_platform + t`).
///
/// A zero noise sigma draws no noise; such a dataset serves tests in
/// memory, but cannot be written (machine.json wants positive
/// repeatabilities).
#[derive(Debug, Clone, PartialEq)]
pub struct TrackerScenario {
    /// Nominal geometry, design frame (written to machine.json).
    pub design: Geometry,
    /// True geometry, design frame (written to truth.json).
    pub truth: Geometry,
    /// The readings' unit, free text (machine.json `actuator.unit`).
    pub unit: String,
    /// Design scales `s_i`, mm per unit (machine.json).
    pub design_scale: [f64; 6],
    /// True scales, mm per unit (truth.json).
    pub true_scale: [f64; 6],
    /// A priori sigma of each scale (mm per unit); `None`: scales known.
    pub scale_sigma: Option<[f64; 6]>,
    /// Design tolerances of the geometry (mm).
    pub prior_sigma: PriorSigma,
    /// What the instrument measures.
    pub kind: TrackerKind,
    /// Number of sessions, labelled `1`, `2`, ...
    pub sessions: usize,
    /// Rows of each file per session.
    pub rows_per_session: usize,
    /// Where the platform origin is drawn.
    pub workspace: Workspace,
    /// Largest |yaw|, |pitch|, |roll| of the platform (rad),
    /// `R = Rz(yaw) Ry(pitch) Rx(roll)`, angles uniform.
    pub max_tilt: f64,
    /// Allowed extension `s_i q_i = L_i - l_i - o_{k,i}` of every leg of the
    /// true machine (mm): the actuators' stroke.
    pub stroke: [f64; 2],
    /// Actuator noise, 1 sigma per reading, in the actuators' unit.
    pub actuator_sigma: f64,
    /// Instrument position noise, 1 sigma per axis (mm).
    pub position_sigma: f64,
    /// Instrument orientation noise, 1 sigma per axis of a small rotation
    /// `Exp(delta)` applied in the instrument frame (rad).
    pub orientation_sigma: f64,
    /// How each session's instrument frame is drawn.
    pub tracker_frame: FrameSpread,
    /// The true platform body frame of the first session (`x_platform = R
    /// x_body + t`), shared by all sessions but for the origin shift of
    /// [`SessionModel::body_origin_sigma`]. Unused without poses.
    pub body_frame: Pose,
    /// What changes between sessions: each present sigma draws session
    /// `k >= 1`'s leg offsets, or body origin shift, `N(0, sigma^2)` per
    /// coordinate; written to machine.json as the calibration's prior.
    pub session_model: SessionModel,
    /// Planned readings (`parcal plan --tracker`, actuators' unit), one
    /// list per session, or one list that every session measures: a
    /// session measures the true machine at its commands, in order,
    /// instead of drawing poses; `rows_per_session` must be each list's
    /// count.
    pub plan: Option<Vec<Vec<[f64; 6]>>>,
}

impl TrackerScenario {
    /// The paper's machine (table 2) tracked in 3 sessions of 50 poses and 50
    /// points, a laser tracker's noise (10 um, 1e-4 rad), actuators in mm
    /// with true scales 1 + ~1e-3, the workspace of the ball campaign's
    /// platform (x, y within 60 mm, z 300 to 380 mm, tilts up to 10
    /// degrees), instrument frames turned by up to 5 degrees and shifted by
    /// up to 100 mm, and a marker body 20 mm above the platform turned by 3
    /// degrees. Legs are not re-homed between sessions.
    pub fn paper_like() -> Self {
        let axis = nalgebra::Unit::new_normalize(Vec3::new(1.0, 1.0, 1.0));
        Self {
            design: paper::design(),
            truth: paper::truth(),
            unit: "mm".to_owned(),
            design_scale: [1.0; 6],
            true_scale: [1.0012, 0.9991, 1.0004, 0.9987, 1.0009, 0.9996],
            scale_sigma: Some([2e-3; 6]),
            prior_sigma: PriorSigma {
                base: 0.1,
                platform: 0.1,
                tool: 0.1,
                leg: 0.1,
            },
            kind: TrackerKind::Both,
            sessions: 3,
            rows_per_session: 50,
            workspace: Workspace {
                half_width: 60.0,
                height: [300.0, 380.0],
            },
            max_tilt: 10f64.to_radians(),
            stroke: [0.0, 200.0],
            actuator_sigma: 0.001,
            position_sigma: 0.01,
            orientation_sigma: 1e-4,
            tracker_frame: FrameSpread {
                max_angle: 5f64.to_radians(),
                offset: Vec3::zeros(),
                spread: 100.0,
            },
            body_frame: Pose::from_parts(
                Translation3::new(5.0, -3.0, 20.0),
                UnitQuaternion::from_axis_angle(&axis, 3f64.to_radians()),
            ),
            session_model: SessionModel::default(),
            plan: None,
        }
    }

    /// A machine in the spirit of Jugglebot (`fixtures/jugglebot`): its
    /// nominal 6-6 geometry (base joints on a 410 mm circle, platform
    /// joints on a 219.075 mm circle, retracted legs 640.1966 mm, a tool
    /// point 100 mm above the platform), readings in motor revolutions with
    /// its rig-measured scales (about 71 mm/rev), 3 sessions of 108 poses
    /// seen by motion capture (0.3 mm, 1e-3 rad), legs re-homed between
    /// sessions (2 mm), platform origin within 100 mm of the axis at z 620
    /// to 800 mm, tilts up to 10 degrees, strokes of 7 to 290 mm, the
    /// instrument's origin about 60 mm below the base's (body origins at z
    /// ~700 to ~870 mm in the instrument frame, as in the recorded poses).
    ///
    /// The true machine is the design perturbed by fixed draws (stream
    /// `(0, 0)` of [`Rng`]): 2 mm per joint coordinate and the tool, 5 mm
    /// per leg, 1 % per scale; the priors are 5 mm, 10 mm and 2 %.
    pub fn jugglebot_like() -> Self {
        let design = jugglebot::design();
        let design_scale = jugglebot::SCALE;
        let mut rng = Rng::new(0, 0);
        let mut perturbed = |v: Vec3, sigma: f64| v + Vec3::from_fn(|_, _| rng.normal(sigma));
        let base = design.base.map(|b| perturbed(b, 2.0));
        let platform = design.platform.map(|e| perturbed(e, 2.0));
        let tool = perturbed(design.tool, 2.0);
        let legs = design.legs.map(|l| l + rng.normal(5.0));
        let true_scale = design_scale.map(|s| s * (1.0 + rng.normal(0.01)));
        let axis = nalgebra::Unit::new_normalize(Vec3::new(0.3, -1.0, 0.2));
        Self {
            truth: Geometry {
                base,
                platform,
                tool,
                legs,
            },
            design,
            unit: "rev".to_owned(),
            design_scale,
            true_scale,
            scale_sigma: Some(design_scale.map(|s| 0.02 * s)),
            prior_sigma: PriorSigma {
                base: 5.0,
                platform: 5.0,
                tool: 5.0,
                leg: 10.0,
            },
            kind: TrackerKind::Poses,
            sessions: 3,
            rows_per_session: 108,
            workspace: Workspace {
                half_width: 100.0,
                height: [620.0, 800.0],
            },
            max_tilt: 10f64.to_radians(),
            stroke: [7.0, 290.0],
            actuator_sigma: 2e-4,
            position_sigma: 0.3,
            orientation_sigma: 1e-3,
            tracker_frame: FrameSpread {
                max_angle: 2f64.to_radians(),
                offset: Vec3::new(0.0, 0.0, 60.0),
                spread: 20.0,
            },
            body_frame: Pose::from_parts(
                Translation3::new(2.0, -4.0, 10.0),
                UnitQuaternion::from_axis_angle(&axis, 1f64.to_radians()),
            ),
            session_model: SessionModel {
                leg_offset_sigma: Some(2.0),
                body_origin_sigma: None,
                body_rotation_sigma: None,
            },
            plan: None,
        }
    }

    /// Rows of each session: poses and points.
    pub fn rows(&self) -> (usize, usize) {
        let rows = |has: bool| if has { self.rows_per_session } else { 0 };
        (rows(self.kind.poses()), rows(self.kind.points()))
    }
}

/// Jugglebot's nominal machine (`fixtures/jugglebot/README.md`).
mod jugglebot {
    use parcal_kinematics::{Geometry, Vec3};

    /// Rig-measured scales, mm per motor revolution.
    pub const SCALE: [f64; 6] = [75.692, 71.197, 72.342, 70.801, 70.621, 71.263];

    /// The nominal geometry table, legs at their retracted length, a tool
    /// point 100 mm above the platform (a choice: the machine has none).
    pub fn design() -> Geometry {
        Geometry {
            base: [
                Vec3::new(-385.2740, -140.2283, 0.0),
                Vec3::new(-314.0782, -263.5429, 0.0),
                Vec3::new(314.0782, -263.5429, 0.0),
                Vec3::new(385.2740, -140.2283, 0.0),
                Vec3::new(71.1958, 403.7712, 0.0),
                Vec3::new(-71.1958, 403.7712, 0.0),
            ],
            platform: [
                Vec3::new(-197.4055, 94.9997, 0.0),
                Vec3::new(-16.4306, -218.4580, 0.0),
                Vec3::new(16.4306, -218.4580, 0.0),
                Vec3::new(197.4055, 94.9997, 0.0),
                Vec3::new(180.9749, 123.4583, 0.0),
                Vec3::new(-180.9749, 123.4583, 0.0),
            ],
            tool: Vec3::new(0.0, 0.0, 100.0),
            legs: [640.1966; 6],
        }
    }
}
