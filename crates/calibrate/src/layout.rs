//! The global block of a calibration: named groups of parameters, laid out
//! one after the other, decided by the data.
//!
//! ```text
//! g = [ p (33 kinematic) | C_a (3) r_a (1) | C_b (3) r_b (1) | … ]     ball touches
//!       always             one per ball tied by a distance (r: per-ball radius)
//! g = [ p (33) | s (6) | F_1 (6) | F_2 (6) | … | B (6) | B_k (3) | o_k (6) | … ]
//!                scales  one frame per session   body   per session     instruments
//! ```
//!
//! - [`ParameterGroup::Kinematic`]: the 33 canonical parameters `p` of
//!   paper eq. (1)–(2), first; or [`ParameterGroup::KinematicWithoutTool`],
//!   their first 30 (joints and legs), when nothing observes the tool
//!   (poses alone: the body frame is measured, not the tool).
//! - [`ParameterGroup::BallCentre`]: the centre of a ball that a calibrated
//!   distance ties to another one. Such centres are coupled by the distance
//!   rows, so they cannot be eliminated ball by ball; they join the global
//!   block (a dense block for tens of balls), and the solver holds their
//!   own group block fixed. Every other ball keeps its centre in its group
//!   block, eliminated with its contacts (the fast path).
//!
//! - [`ParameterGroup::ActuatorScales`]: `s_1..s_6` (mm per actuator unit),
//!   when machine.json gives their sigmas.
//! - [`ParameterGroup::TrackerFrame`]: the correction `(ω, τ)` of a
//!   session's instrument frame ([`parcal_observe::frame`]).
//! - [`ParameterGroup::BodyFrame`]: the correction of the platform body
//!   frame, for measured poses.
//! - [`ParameterGroup::BodyOrigin`], [`ParameterGroup::BodyRotation`] and
//!   [`ParameterGroup::LegOffsets`]: a later session's shift of the body
//!   origin, turn of the body frame and zero offsets of the legs
//!   (machine.json's `session_model`).
//!
//! Every parameter of the block has a name (`x_b1`, …, `centre B07.x`,
//! `radius B07`), so
//! that a covariance, a prior or a weak direction can be read by name.

use std::ops::Range;

use nalgebra::{DMatrix, DVector, SVector};
use parcal_kinematics::params::TOOL_OFFSET;
use parcal_kinematics::{N_PARAMS, PARAM_NAMES, Params, SCALE_NAMES, Vec3};

/// One named group of the global block.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ParameterGroup {
    /// The 33 canonical kinematic parameters (paper section 2).
    Kinematic,
    /// The canonical kinematic parameters but the tool `E_T`: the joints
    /// and leg lengths (the first 30), when no data observe the tool.
    KinematicWithoutTool,
    /// The centre of ball `ball` (index in artefacts.json), canonical base
    /// frame.
    BallCentre {
        /// Index of the ball in artefacts.json.
        ball: usize,
    },
    /// The radius of ball `ball` (mm), right after its centre.
    BallRadius {
        /// Index of the ball in artefacts.json.
        ball: usize,
    },
    /// The actuator scales `s_1..s_6` (mm per unit).
    ActuatorScales,
    /// The correction `(ω, τ)` of a session's instrument frame.
    TrackerFrame {
        /// The session (index into the dataset's sessions).
        session: usize,
    },
    /// The correction `(ω, τ)` of the platform body frame.
    BodyFrame,
    /// A session's shift of the body frame's origin (platform frame, mm).
    BodyOrigin {
        /// The session.
        session: usize,
    },
    /// A session's turn of the body frame: a shift of its rotation vector
    /// (rad).
    BodyRotation {
        /// The session.
        session: usize,
    },
    /// A session's zero offsets of the six legs (mm).
    LegOffsets {
        /// The session.
        session: usize,
    },
}

impl ParameterGroup {
    /// Number of parameters in the group.
    pub fn size(self) -> usize {
        match self {
            Self::Kinematic => N_PARAMS,
            Self::KinematicWithoutTool => TOOL_OFFSET,
            Self::BallRadius { .. } => 1,
            Self::BallCentre { .. } | Self::BodyOrigin { .. } | Self::BodyRotation { .. } => 3,
            Self::ActuatorScales
            | Self::TrackerFrame { .. }
            | Self::BodyFrame
            | Self::LegOffsets { .. } => 6,
        }
    }

    /// The names of the group's parameters, given the balls' and the
    /// sessions' labels.
    fn names(self, ball_ids: &[String], sessions: &[String]) -> Vec<String> {
        const FRAME: [&str; 6] = ["wx", "wy", "wz", "tx", "ty", "tz"];
        match self {
            Self::Kinematic => PARAM_NAMES.iter().map(|s| s.to_string()).collect(),
            Self::KinematicWithoutTool => PARAM_NAMES[..TOOL_OFFSET]
                .iter()
                .map(|s| s.to_string())
                .collect(),
            Self::BallCentre { ball } => (0..3).map(|c| centre_name(&ball_ids[ball], c)).collect(),
            Self::BallRadius { ball } => vec![radius_name(&ball_ids[ball])],
            Self::ActuatorScales => SCALE_NAMES.map(str::to_string).into(),
            Self::TrackerFrame { session } => FRAME
                .map(|c| format!("frame {}.{c}", sessions[session]))
                .into(),
            Self::BodyFrame => FRAME.map(|c| format!("body.{c}")).into(),
            Self::BodyOrigin { session } => AXES
                .map(|axis| format!("body origin {}.{axis}", sessions[session]))
                .into(),
            Self::BodyRotation { session } => ["wx", "wy", "wz"]
                .map(|axis| format!("body rotation {}.{axis}", sessions[session]))
                .into(),
            Self::LegOffsets { session } => (1..=6)
                .map(|i| format!("o_{i} {}", sessions[session]))
                .collect(),
        }
    }
}

/// The global block: its groups in order, each with its range.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ParameterLayout {
    groups: Vec<(ParameterGroup, Range<usize>)>,
    /// For each ball (artefacts.json order), the range of its unknowns
    /// (centre, then radius if it is an unknown) in the global block, if
    /// they are there.
    balls: Vec<Option<Range<usize>>>,
    size: usize,
}

impl ParameterLayout {
    /// The kinematic parameters, then the centres of the `coupled` balls
    /// (indices into artefacts.json's `n_balls` balls, each at most once,
    /// in the order given), each followed by its radius when `radii` (each
    /// ball's radius an unknown).
    pub fn new(n_balls: usize, coupled: &[usize], radii: bool) -> Self {
        let mut layout = Self {
            groups: Vec::with_capacity(1 + 2 * coupled.len()),
            balls: vec![None; n_balls],
            size: 0,
        };
        layout.push(ParameterGroup::Kinematic);
        for &ball in coupled {
            let mut range = layout.push(ParameterGroup::BallCentre { ball });
            if radii {
                range.end = layout.push(ParameterGroup::BallRadius { ball }).end;
            }
            debug_assert!(layout.balls[ball].is_none(), "ball {ball} coupled twice");
            layout.balls[ball] = Some(range);
        }
        layout
    }

    /// The kinematic parameters, then `groups` in order (instrument
    /// measurements: no ball centre).
    pub fn with_groups(groups: impl IntoIterator<Item = ParameterGroup>) -> Self {
        Self::new(0, &[], false).extended(groups)
    }

    /// The kinematic parameters but the tool
    /// ([`ParameterGroup::KinematicWithoutTool`]), then `groups` in order:
    /// instrument measurements that do not observe the tool (poses alone).
    pub fn without_tool(groups: impl IntoIterator<Item = ParameterGroup>) -> Self {
        let mut layout = Self {
            groups: Vec::new(),
            balls: Vec::new(),
            size: 0,
        };
        layout.push(ParameterGroup::KinematicWithoutTool);
        layout.extended(groups)
    }

    /// This layout, then `groups` in order (ball touches with instrument
    /// measurements: the instrument groups after the tied centres).
    pub fn extended(mut self, groups: impl IntoIterator<Item = ParameterGroup>) -> Self {
        for group in groups {
            self.push(group);
        }
        self
    }

    /// The range of `group` in the global block, if it is there.
    pub fn range(&self, group: ParameterGroup) -> Option<Range<usize>> {
        self.groups
            .iter()
            .find(|(g, _)| *g == group)
            .map(|(_, range)| range.clone())
    }

    fn push(&mut self, group: ParameterGroup) -> Range<usize> {
        let range = self.size..self.size + group.size();
        self.size = range.end;
        self.groups.push((group, range.clone()));
        range
    }

    /// Number of global parameters.
    pub fn size(&self) -> usize {
        self.size
    }

    /// The groups in order, with their ranges.
    pub fn groups(&self) -> &[(ParameterGroup, Range<usize>)] {
        &self.groups
    }

    /// The range of the kinematic parameters: `0..33`, or `0..30` without
    /// the tool.
    pub fn kinematic(&self) -> Range<usize> {
        0..self.groups[0].0.size()
    }

    /// Whether the tool `E_T` is in the block (the 33 are).
    pub fn has_tool(&self) -> bool {
        self.kinematic().len() == N_PARAMS
    }

    /// The range of ball `ball`'s centre in the global block, if it is
    /// there (the ball is tied by a distance).
    pub fn centre(&self, ball: usize) -> Option<Range<usize>> {
        self.ball(ball).map(|range| range.start..range.start + 3)
    }

    /// The range of ball `ball`'s unknowns in the global block (its
    /// centre, then its radius if that is an unknown), if they are there
    /// (the ball is tied by a distance).
    pub fn ball(&self, ball: usize) -> Option<Range<usize>> {
        self.balls.get(ball).cloned().flatten()
    }

    /// Whether any ball centre is in the global block.
    pub fn has_coupled_centres(&self) -> bool {
        self.balls.iter().any(Option::is_some)
    }

    /// Every ball's unknowns (centre, then radius when `G` = 4) at a state
    /// of the solver: the global block's (`global`) for a ball whose
    /// unknowns are there, its group's (`groups`, one per ball) for the
    /// others.
    pub fn ball_values<const G: usize>(
        &self,
        global: &DVector<f64>,
        groups: &[SVector<f64, G>],
    ) -> Vec<SVector<f64, G>> {
        groups
            .iter()
            .enumerate()
            .map(|(ball, group)| match self.ball(ball) {
                Some(range) => global.fixed_rows::<G>(range.start).into_owned(),
                None => *group,
            })
            .collect()
    }

    /// Every ball's centre at a state of the solver ([`Self::ball_values`],
    /// its first three).
    pub fn ball_centres<const G: usize>(
        &self,
        global: &DVector<f64>,
        groups: &[SVector<f64, G>],
    ) -> Vec<Vec3> {
        self.ball_values(global, groups)
            .iter()
            .map(|v| v.fixed_rows::<3>(0).into_owned())
            .collect()
    }

    /// Every ball's marginal sigmas (centre, then radius when `G` = 4): the
    /// square roots of the diagonal of the global covariance for a ball
    /// whose unknowns are in the global block, its group's sigmas
    /// (`groups`) for the others.
    pub fn ball_sigmas<const G: usize>(
        &self,
        global: &DMatrix<f64>,
        groups: &[SVector<f64, G>],
    ) -> Vec<SVector<f64, G>> {
        groups
            .iter()
            .enumerate()
            .map(|(ball, group)| match self.ball(ball) {
                Some(range) => {
                    SVector::from_fn(|c, _| global[(range.start + c, range.start + c)].sqrt())
                }
                None => *group,
            })
            .collect()
    }

    /// The columns calibration.json's `parameters` hold, in order: every
    /// group's but the balls' (their unknowns are in its `ball_centres`).
    pub fn recorded(&self) -> Vec<usize> {
        self.groups
            .iter()
            .filter(|(group, _)| {
                !matches!(
                    group,
                    ParameterGroup::BallCentre { .. } | ParameterGroup::BallRadius { .. }
                )
            })
            .flat_map(|(_, range)| range.clone())
            .collect()
    }

    /// The name of every global parameter, in order: the kinematic
    /// parameters' ([`PARAM_NAMES`]), then `centre ID.x` etc. with the
    /// balls' artefacts.json ids, `s_1`, `frame LABEL.wx`, `body.tx`, `body
    /// origin LABEL.x`, `o_1 LABEL` with the sessions' labels.
    pub fn names(&self, ball_ids: &[String], sessions: &[String]) -> Vec<String> {
        self.groups
            .iter()
            .flat_map(|(group, _)| group.names(ball_ids, sessions))
            .collect()
    }
}

/// The kinematic parameters of a global block: its first 33 values.
pub(crate) fn kinematic_params(global: &DVector<f64>) -> Params {
    let mut params = Params::zeros();
    params.copy_from_slice(&global.as_slice()[..N_PARAMS]);
    params
}

/// The names of the three coordinate axes.
const AXES: [&str; 3] = ["x", "y", "z"];

/// The name of coordinate `axis` (0, 1, 2: x, y, z) of the centre of the
/// ball `id`, as parameters, conflict tests and records name it.
pub(crate) fn centre_name(id: &str, axis: usize) -> String {
    format!("centre {id}.{}", AXES[axis])
}

/// The name of the radius of the ball `id`.
pub(crate) fn radius_name(id: &str) -> String {
    format!("radius {id}")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn groups_follow_each_other_and_are_named() {
        let layout = ParameterLayout::new(4, &[3, 1], false);
        assert_eq!(layout.size(), N_PARAMS + 6);
        assert_eq!(layout.kinematic(), 0..N_PARAMS);
        assert_eq!(layout.centre(3), Some(N_PARAMS..N_PARAMS + 3));
        assert_eq!(layout.centre(1), Some(N_PARAMS + 3..N_PARAMS + 6));
        assert_eq!(layout.centre(0), None);
        assert_eq!(layout.centre(7), None);
        let ids: Vec<String> = ["A", "B", "C", "D"].map(String::from).into();
        let names = layout.names(&ids, &[]);
        assert_eq!(names.len(), layout.size());
        assert_eq!(names[0], PARAM_NAMES[0]);
        assert_eq!(names[N_PARAMS], "centre D.x");
        assert_eq!(names[N_PARAMS + 5], "centre B.z");
    }

    #[test]
    fn a_tied_ball_radius_follows_its_centre() {
        let layout = ParameterLayout::new(4, &[3, 1], true);
        assert_eq!(layout.size(), N_PARAMS + 8);
        assert_eq!(layout.ball(3), Some(N_PARAMS..N_PARAMS + 4));
        assert_eq!(layout.centre(3), Some(N_PARAMS..N_PARAMS + 3));
        assert_eq!(layout.ball(1), Some(N_PARAMS + 4..N_PARAMS + 8));
        assert_eq!(layout.ball(0), None);
        let ids: Vec<String> = ["A", "B", "C", "D"].map(String::from).into();
        let names = layout.names(&ids, &[]);
        assert_eq!(names.len(), layout.size());
        assert_eq!(names[N_PARAMS + 2], "centre D.z");
        assert_eq!(names[N_PARAMS + 3], "radius D");
        assert_eq!(names[N_PARAMS + 7], "radius B");
        let global = DVector::from_fn(layout.size(), |k, _| k as f64);
        let groups = vec![SVector::<f64, 4>::repeat(-1.0); 4];
        let values = layout.ball_values(&global, &groups);
        assert_eq!(values[1][3], (N_PARAMS + 7) as f64);
        assert_eq!(values[0], groups[0]);
    }

    #[test]
    fn instrument_groups_follow_the_kinematic_parameters() {
        let layout = ParameterLayout::with_groups([
            ParameterGroup::ActuatorScales,
            ParameterGroup::TrackerFrame { session: 0 },
            ParameterGroup::BodyFrame,
            ParameterGroup::TrackerFrame { session: 1 },
            ParameterGroup::BodyOrigin { session: 1 },
            ParameterGroup::LegOffsets { session: 1 },
        ]);
        assert_eq!(layout.size(), N_PARAMS + 6 + 6 + 6 + 6 + 3 + 6);
        assert_eq!(
            layout.range(ParameterGroup::TrackerFrame { session: 1 }),
            Some(N_PARAMS + 18..N_PARAMS + 24)
        );
        assert_eq!(
            layout.range(ParameterGroup::LegOffsets { session: 0 }),
            None
        );
        assert!(!layout.has_coupled_centres());
        let names = layout.names(&[], &["mon".into(), "tue".into()]);
        assert_eq!(names.len(), layout.size());
        assert_eq!(names[N_PARAMS], "s_1");
        assert_eq!(names[N_PARAMS + 6], "frame mon.wx");
        assert_eq!(names[N_PARAMS + 17], "body.tz");
        assert_eq!(names[N_PARAMS + 24], "body origin tue.x");
        assert_eq!(names[N_PARAMS + 32], "o_6 tue");
    }

    #[test]
    fn without_the_tool_the_block_starts_with_the_joints_and_legs() {
        let layout = ParameterLayout::without_tool([ParameterGroup::ActuatorScales]);
        assert_eq!(layout.kinematic(), 0..TOOL_OFFSET);
        assert!(!layout.has_tool());
        assert_eq!(
            layout.range(ParameterGroup::ActuatorScales),
            Some(TOOL_OFFSET..TOOL_OFFSET + 6)
        );
        let names = layout.names(&[], &[]);
        assert_eq!(names.len(), layout.size());
        assert_eq!(names[TOOL_OFFSET - 1], PARAM_NAMES[TOOL_OFFSET - 1]);
        assert_eq!(names[TOOL_OFFSET], "s_1");
        assert!(ParameterLayout::with_groups([]).has_tool());
    }

    #[test]
    fn without_distances_the_block_is_the_kinematic_parameters() {
        let layout = ParameterLayout::new(27, &[], true);
        assert_eq!(layout.size(), N_PARAMS);
        assert!(!layout.has_coupled_centres());
    }
}
