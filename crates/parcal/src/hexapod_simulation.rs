//! A hexapod's simulated campaign as `parcal simulate` makes it, for every
//! front end (the binary's flags, Python's keyword arguments): ball
//! touches (the paper's scenario, balls on a grid, or a plan's touches;
//! read in mm or in motor revolutions), or an instrument campaign in
//! sessions (poses, points or both, of the paper's machine or one like
//! Jugglebot; a pose plan's readings), with the paper's touches of the
//! same machine. [`hexapod_scenario`] builds the scenario from the
//! options, checking each as the command does; every refusal names the
//! option as the front end spells it ([`Spelling`]).

use std::path::PathBuf;

use parcal_kinematics::rotation_zyx;
use parcal_plan::DesignError;
use parcal_plan::plan_file::{PlanRow, read_plan};
use parcal_plan::tracker::plan_file::{PosePlanRow, read_pose_plan};
use parcal_simulate::mechanism::Spelling;
use parcal_simulate::{
    COUNT, PlannedTouch, Plate, Readings, Scenario, SimulateError, Simulation, TrackerKind,
    TrackerScenario, ball_id, check_rows, simulate, simulate_mixed, simulate_tracker,
};

/// The largest tilt of the platform by default (degrees).
pub const DEFAULT_TILT: f64 = 10.0;

/// Largest `| |u| - 1 |` of a planned touch's direction given in memory:
/// plan.csv's reader's.
const UNIT_TOLERANCE: f64 = 1e-6;

/// What the touches' actuators read (`readings`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ReadingUnit {
    /// Millimetres, scale 1 and known.
    Mm,
    /// Motor revolutions at the scales of Jugglebot-like instrument
    /// campaign (design about 71 mm/rev, true scales 1 % off, unknown with
    /// a 2 % prior).
    Rev,
}

/// The reading units by name (`--readings`'s).
pub const READINGS: [(&str, ReadingUnit); 2] = [("mm", ReadingUnit::Mm), ("rev", ReadingUnit::Rev)];

/// The machine an instrument campaign tracks (`machine`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TrackedMachine {
    /// The paper's: readings in mm, a laser tracker.
    Paper,
    /// One in the spirit of Jugglebot: readings in motor revolutions,
    /// motion capture, legs re-homed by 2 mm between sessions.
    Jugglebot,
}

/// The tracked machines by name (`--machine`'s).
pub const MACHINES: [(&str, TrackedMachine); 2] = [
    ("paper", TrackedMachine::Paper),
    ("jugglebot", TrackedMachine::Jugglebot),
];

/// The reading unit named `name` ([`READINGS`]), or a refusal naming the
/// option `readings` and the names.
pub fn reading_unit(name: &str, spelling: Spelling) -> Result<ReadingUnit, String> {
    named(&READINGS, "readings", name, spelling)
}

/// The tracked machine named `name` ([`MACHINES`]), or a refusal naming
/// the option `machine` and the names.
pub fn tracked_machine(name: &str, spelling: Spelling) -> Result<TrackedMachine, String> {
    named(&MACHINES, "machine", name, spelling)
}

/// The choice named `name` among `names`, or a refusal naming `option`.
fn named<T: Copy>(
    names: &[(&'static str, T)],
    option: &str,
    name: &str,
    spelling: Spelling,
) -> Result<T, String> {
    crate::named::by_name(names, name).ok_or_else(|| {
        let known: Vec<&str> = names.iter().map(|(n, _)| *n).collect();
        format!(
            "{}: {name:?} is not one of {}",
            spelling.name(option),
            known.join(", ")
        )
    })
}

/// The largest tilt of the platform (degrees), in `[0, 90)`.
pub fn tilt(degrees: f64, spelling: Spelling) -> Result<f64, String> {
    crate::hexapod_plan::tilt(Some(degrees), spelling)
}

/// The plan a campaign simulates exactly (`plan`).
#[derive(Debug, Clone, PartialEq)]
pub enum PlanSource {
    /// A plan.csv (`parcal plan`), read as a plan of ball touches, or with
    /// `tracker` as a pose plan; messages name its lines.
    File(PathBuf),
    /// A plan of ball touches in memory, as plan.csv's rows (the readings
    /// `q` are not used); messages name it `plan` and its rows, 0-based.
    Touches(Vec<PlanRow>),
    /// A pose plan in memory, as plan.csv's rows (only the sessions and
    /// readings are used); messages name it `plan` and its rows, 0-based.
    Poses(Vec<PosePlanRow>),
}

/// The options of a hexapod's simulated campaign, each `None` (or
/// `false`) when not given; named as the command's flags are (`balls` is
/// `--balls`).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct HexapodOptions {
    /// Balls on a regular grid filling x, y in [-80, 80], z in [340, 460]
    /// (default: the paper's 27 balls; [`COUNT`]).
    pub balls: Option<usize>,
    /// Contacts per ball (default 7; [`COUNT`]).
    pub points_per_ball: Option<usize>,
    /// What the touches' actuators read (default mm).
    pub readings: Option<ReadingUnit>,
    /// Largest |yaw|, |pitch|, |roll| of the platform at a contact or a
    /// tracked pose, degrees (default [`DEFAULT_TILT`]).
    pub tilt: Option<f64>,
    /// An instrument campaign instead of ball touches: what it measures.
    pub tracker: Option<TrackerKind>,
    /// The tracked machine (default the paper's).
    pub machine: Option<TrackedMachine>,
    /// Also the paper's ball touches of the same true machine.
    pub touches: bool,
    /// Measuring sessions (default 3; [`COUNT`]).
    pub sessions: Option<usize>,
    /// Rows of each file per session (default 50 for the paper's machine,
    /// 108 for Jugglebot's; [`COUNT`]).
    pub rows: Option<usize>,
    /// Re-homing between sessions: each leg's zero offset's sigma in
    /// sessions 2, 3, ..., mm (0: none; default the machine's).
    pub rehome: Option<f64>,
    /// The instrument's position noise, 1 sigma per axis, mm (default 0.01
    /// for the paper's machine, 0.3 for Jugglebot's).
    pub position_sigma: Option<f64>,
    /// The instrument's orientation noise, 1 sigma per axis, rad (default
    /// 1e-4 for the paper's machine, 1e-3 for Jugglebot's).
    pub orientation_sigma: Option<f64>,
    /// A calibrated ball plate over the balls (artefacts.json's distances).
    pub plate: Option<Plate>,
    /// The touches or poses to simulate exactly.
    pub plan: Option<PlanSource>,
    /// machine.json's design drawn about the truth by its tolerance.
    pub design_drawn: bool,
}

impl HexapodOptions {
    /// The names of the options given, in the order of the command's
    /// flags.
    pub fn given(&self) -> Vec<&'static str> {
        [
            ("balls", self.balls.is_some()),
            ("points_per_ball", self.points_per_ball.is_some()),
            ("readings", self.readings.is_some()),
            ("tilt", self.tilt.is_some()),
            ("tracker", self.tracker.is_some()),
            ("machine", self.machine.is_some()),
            ("touches", self.touches),
            ("sessions", self.sessions.is_some()),
            ("rows", self.rows.is_some()),
            ("rehome", self.rehome.is_some()),
            ("position_sigma", self.position_sigma.is_some()),
            ("orientation_sigma", self.orientation_sigma.is_some()),
            ("plate", self.plate.is_some()),
            ("plan", self.plan.is_some()),
            ("design_drawn", self.design_drawn),
        ]
        .into_iter()
        .filter(|(_, given)| *given)
        .map(|(name, _)| name)
        .collect()
    }

    /// The options of ball touches only, each with whether it is given.
    fn touch_given(&self) -> [(&'static str, bool); 5] {
        [
            ("balls", self.balls.is_some()),
            ("points_per_ball", self.points_per_ball.is_some()),
            ("readings", self.readings.is_some()),
            ("plate", self.plate.is_some()),
            ("design_drawn", self.design_drawn),
        ]
    }

    /// The options of an instrument campaign only, each with whether it is
    /// given (`tracker` itself apart).
    fn tracker_given(&self) -> [(&'static str, bool); 7] {
        [
            ("machine", self.machine.is_some()),
            ("touches", self.touches),
            ("sessions", self.sessions.is_some()),
            ("rows", self.rows.is_some()),
            ("rehome", self.rehome.is_some()),
            ("position_sigma", self.position_sigma.is_some()),
            ("orientation_sigma", self.orientation_sigma.is_some()),
        ]
    }

    /// Refuses the combinations the command's parser refuses, naming the
    /// options: those of ball touches with `tracker`, those of an
    /// instrument campaign without it. ([`hexapod_scenario`] does not
    /// check them: the command's parser has, and it passes its defaults
    /// as given.)
    pub fn check_combinations(&self, spelling: Spelling) -> Result<(), String> {
        let names = |options: &[(&str, bool)]| -> Vec<String> {
            options
                .iter()
                .filter(|(_, given)| *given)
                .map(|(name, _)| spelling.name(name))
                .collect()
        };
        let tracker = spelling.name("tracker");
        let (others, relation) = match self.tracker {
            Some(_) => (names(&self.touch_given()), "with"),
            None => (names(&self.tracker_given()), "without"),
        };
        if others.is_empty() {
            Ok(())
        } else {
            Err(format!(
                "{} cannot be used {relation} {tracker}",
                others.join(", ")
            ))
        }
    }
}

/// A hexapod's campaign, ready to simulate.
#[derive(Debug, Clone, PartialEq)]
pub enum HexapodScenario {
    /// Ball touches.
    Touches(Scenario),
    /// Instrument measurements in sessions, and the paper's touches of the
    /// same true machine if asked for.
    Tracker {
        /// The instrument campaign.
        tracker: Box<TrackerScenario>,
        /// The touches.
        touches: Option<Scenario>,
    },
}

impl HexapodScenario {
    /// The campaign simulated with `seed`: the same seed, the same
    /// dataset.
    pub fn simulate(&self, seed: u64) -> Result<Simulation, SimulateError> {
        match self {
            Self::Touches(scenario) => simulate(scenario, seed),
            Self::Tracker {
                tracker,
                touches: Some(touches),
            } => simulate_mixed(touches, tracker, seed),
            Self::Tracker {
                tracker,
                touches: None,
            } => simulate_tracker(tracker, seed),
        }
    }
}

/// Why a hexapod's campaign cannot be made.
#[derive(Debug, thiserror::Error)]
pub enum HexapodSimulationError {
    /// An option, or a combination, is refused; the message names it.
    #[error("{0}")]
    Options(String),
    /// plan.csv could not be read.
    #[error(transparent)]
    Plan(#[from] DesignError),
    /// The campaign is beyond the simulator's bounds.
    #[error(transparent)]
    Simulate(#[from] SimulateError),
}

impl From<String> for HexapodSimulationError {
    fn from(message: String) -> Self {
        Self::Options(message)
    }
}

/// The campaign `options` ask for, with `seed` for a design drawn about
/// the truth, as `parcal simulate` makes it: each value checked (the tilt,
/// the counts and their product, the sigmas), the plan read and matched
/// to the campaign, or a refusal naming the option.
pub fn hexapod_scenario(
    options: &HexapodOptions,
    seed: u64,
    spelling: Spelling,
) -> Result<HexapodScenario, HexapodSimulationError> {
    let degrees = tilt(options.tilt.unwrap_or(DEFAULT_TILT), spelling)?;
    match options.tracker {
        Some(kind) => tracker_scenario(options, kind, degrees, spelling),
        None => Ok(HexapodScenario::Touches(touch_scenario(
            options, degrees, seed, spelling,
        )?)),
    }
}

/// The count `option` if given, within [`COUNT`].
fn count(option: &str, given: Option<usize>, spelling: Spelling) -> Result<Option<usize>, String> {
    given
        .map(|value| COUNT.check(&spelling.name(option), value))
        .transpose()
}

/// A campaign of ball touches, the platform tilted by up to `degrees`.
fn touch_scenario(
    options: &HexapodOptions,
    degrees: f64,
    seed: u64,
    spelling: Spelling,
) -> Result<Scenario, HexapodSimulationError> {
    let paper = Scenario::paper();
    let given_balls = count("balls", options.balls, spelling)?;
    let balls = given_balls.unwrap_or(paper.centres.len());
    let points_per_ball = count("points_per_ball", options.points_per_ball, spelling)?
        .unwrap_or(paper.points_per_ball);
    let (balls_name, points_name) = (spelling.name("balls"), spelling.name("points_per_ball"));
    check_rows(&[(&balls_name, balls), (&points_name, points_per_ball)])?;
    let mut scenario = match given_balls {
        None => Scenario {
            points_per_ball,
            max_tilt: degrees.to_radians(),
            ..paper
        },
        Some(balls) => Scenario::scaled(balls, points_per_ball, degrees.to_radians()),
    };
    scenario.plate = options.plate;
    if let Some(plan) = &options.plan {
        scenario.plan = Some(planned_touches(plan, scenario.centres.len(), spelling)?);
    }
    if options.readings == Some(ReadingUnit::Rev) {
        scenario = scenario.reading(Readings::of(&TrackerScenario::jugglebot_like()));
    }
    if options.design_drawn {
        scenario = scenario.design_drawn(seed);
    }
    Ok(scenario)
}

/// An instrument campaign measuring `kind`, the platform tilted by up to
/// `degrees`.
fn tracker_scenario(
    options: &HexapodOptions,
    kind: TrackerKind,
    degrees: f64,
    spelling: Spelling,
) -> Result<HexapodScenario, HexapodSimulationError> {
    let machine = options.machine.unwrap_or(TrackedMachine::Paper);
    let mut scenario = match machine {
        TrackedMachine::Paper => TrackerScenario::paper_like(),
        TrackedMachine::Jugglebot => TrackerScenario::jugglebot_like(),
    };
    scenario.kind = kind;
    scenario.max_tilt = degrees.to_radians();
    let sessions = count("sessions", options.sessions, spelling)?;
    let rows = count("rows", options.rows, spelling)?;
    if let Some(sessions) = sessions {
        scenario.sessions = sessions;
    }
    if let Some(rows) = rows {
        scenario.rows_per_session = rows;
    }
    if let Some(sigma) = options.rehome {
        if !(sigma.is_finite() && sigma >= 0.0) {
            return Err(format!(
                "{} must be a sigma in mm (0: none), got {sigma}",
                spelling.name("rehome")
            )
            .into());
        }
        scenario.session_model.leg_offset_sigma = (sigma > 0.0).then_some(sigma);
    }
    for (option, value, field) in [
        (
            "position_sigma",
            options.position_sigma,
            &mut scenario.position_sigma,
        ),
        (
            "orientation_sigma",
            options.orientation_sigma,
            &mut scenario.orientation_sigma,
        ),
    ] {
        if let Some(value) = value {
            if !(value.is_finite() && value > 0.0) {
                return Err(
                    format!("{} must be positive, got {value}", spelling.name(option)).into(),
                );
            }
            *field = value;
        }
    }
    if let Some(plan) = &options.plan {
        let plan = planned_sessions(plan, spelling)?;
        let (plan_name, rows_name) = (spelling.name("plan"), spelling.name("rows"));
        if rows.is_some() {
            return Err(format!(
                "{rows_name} and {plan_name}: the plan's {} poses per session are the rows of each session",
                plan[0].len()
            )
            .into());
        }
        if plan.len() > 1 {
            if let Some(sessions) = sessions.filter(|&k| k != plan.len()) {
                return Err(format!(
                    "{} and {plan_name}: the plan has {} sessions",
                    with_value(spelling, "sessions", &sessions.to_string()),
                    plan.len()
                )
                .into());
            }
            scenario.sessions = plan.len();
        }
        scenario.rows_per_session = plan[0].len();
        scenario.plan = Some(plan);
    }
    let (sessions_name, rows_name) = (spelling.name("sessions"), spelling.name("rows"));
    check_rows(&[
        (&sessions_name, scenario.sessions),
        (&rows_name, scenario.rows_per_session),
        ("files (poses and points)", scenario.kind.files()),
    ])?;
    let touches = if options.touches {
        if machine != TrackedMachine::Paper {
            return Err(format!(
                "{}: the ball touches are the paper machine's ({})",
                spelling.name("touches"),
                with_value(spelling, "machine", "paper")
            )
            .into());
        }
        scenario.true_scale = [1.0; 6];
        scenario.scale_sigma = None;
        Some(Scenario {
            max_tilt: degrees.to_radians(),
            ..Scenario::paper()
        })
    } else {
        None
    };
    Ok(HexapodScenario::Tracker {
        tracker: Box::new(scenario),
        touches,
    })
}

/// The option `name` given `value`, as the front end writes it:
/// `--machine paper`, `machine="paper"`; a number unquoted (`sessions=3`).
fn with_value(spelling: Spelling, name: &str, value: &str) -> String {
    match spelling {
        Spelling::Flags => format!("{} {value}", spelling.name(name)),
        Spelling::Keywords if value.parse::<f64>().is_ok() => format!("{name}={value}"),
        Spelling::Keywords => format!("{name}={value:?}"),
    }
}

/// A plan in memory's name in messages, and its row `k` (0-based).
fn memory_row(k: usize) -> String {
    format!("plan: row {k}")
}

/// The touches of `plan` on the scenario's `balls` balls (ids `b01`..).
fn planned_touches(
    plan: &PlanSource,
    balls: usize,
    spelling: Spelling,
) -> Result<Vec<PlannedTouch>, HexapodSimulationError> {
    let (rows, place): (Vec<PlanRow>, Box<dyn Fn(usize) -> String>) = match plan {
        PlanSource::File(path) => (
            read_plan(path)?,
            Box::new(move |k| format!("{}: line {}", path.display(), k + 2)),
        ),
        PlanSource::Touches(rows) => {
            check_touch_rows(rows)?;
            (rows.clone(), Box::new(memory_row))
        }
        PlanSource::Poses(_) => {
            return Err(format!(
                "{}: a pose plan, for an instrument campaign ({}); ball touches need a plan of touches",
                spelling.name("plan"),
                spelling.name("tracker")
            )
            .into());
        }
    };
    rows.iter()
        .enumerate()
        .map(|(k, row)| {
            let ball = (0..balls)
                .find(|&b| ball_id(b, balls) == row.ball)
                .ok_or_else(|| {
                    format!(
                        "{}: ball {:?} is not one of the simulated balls {} .. {}",
                        place(k),
                        row.ball,
                        ball_id(0, balls),
                        ball_id(balls - 1, balls)
                    )
                })?;
            let [roll, pitch, yaw] = row.angles;
            Ok(PlannedTouch {
                ball,
                direction: row.direction.normalize(),
                rotation: rotation_zyx(yaw, pitch, roll),
            })
        })
        .collect()
}

/// Refuses a plan of touches in memory that plan.csv's reader would
/// refuse: no rows, a number that is not finite, a direction that is not
/// a unit vector.
fn check_touch_rows(rows: &[PlanRow]) -> Result<(), String> {
    if rows.is_empty() {
        return Err("plan: no touches (a plan has one row per touch)".to_string());
    }
    for (k, row) in rows.iter().enumerate() {
        let u = row.direction;
        if !row.angles.iter().chain(u.iter()).all(|v| v.is_finite()) {
            return Err(format!(
                "{}: direction {:?} and angles {:?} must be finite numbers",
                memory_row(k),
                [u.x, u.y, u.z],
                row.angles
            ));
        }
        if (u.norm() - 1.0).abs() > UNIT_TOLERANCE {
            return Err(format!(
                "{}: u = ({}, {}, {}) is not a unit vector",
                memory_row(k),
                u.x,
                u.y,
                u.z
            ));
        }
    }
    Ok(())
}

/// The planned readings of a pose plan by session, in order of the
/// sessions' first rows; every session must have as many poses.
fn planned_sessions(
    plan: &PlanSource,
    spelling: Spelling,
) -> Result<Vec<Vec<[f64; 6]>>, HexapodSimulationError> {
    let (rows, name) = match plan {
        PlanSource::File(path) => (read_pose_plan(path)?, path.display().to_string()),
        PlanSource::Poses(rows) => {
            check_pose_rows(rows)?;
            (rows.clone(), "plan".to_string())
        }
        PlanSource::Touches(_) => {
            return Err(format!(
                "{}: a plan of ball touches; an instrument campaign ({}) needs a pose plan",
                spelling.name("plan"),
                spelling.name("tracker")
            )
            .into());
        }
    };
    let mut labels: Vec<String> = Vec::new();
    let mut sessions: Vec<Vec<[f64; 6]>> = Vec::new();
    for row in rows {
        match labels.iter().position(|l| *l == row.session) {
            Some(k) => sessions[k].push(row.q),
            None => {
                labels.push(row.session);
                sessions.push(vec![row.q]);
            }
        }
    }
    if let Some(k) = sessions.iter().position(|s| s.len() != sessions[0].len()) {
        return Err(format!(
            "{name}: session {:?} has {} poses and session {:?} {}: the simulator measures as many in every session",
            labels[k],
            sessions[k].len(),
            labels[0],
            sessions[0].len()
        )
        .into());
    }
    Ok(sessions)
}

/// Refuses a pose plan in memory that plan.csv's reader would refuse: no
/// rows, an empty session label, readings that are not finite.
fn check_pose_rows(rows: &[PosePlanRow]) -> Result<(), String> {
    if rows.is_empty() {
        return Err("plan: no poses (a pose plan has one row per pose)".to_string());
    }
    for (k, row) in rows.iter().enumerate() {
        if row.session.is_empty() || row.session.chars().any(char::is_control) {
            return Err(format!(
                "{}: session {:?}: expected a label (not empty, no control character)",
                memory_row(k),
                row.session
            ));
        }
        if !row.q.iter().all(|v| v.is_finite()) {
            return Err(format!(
                "{}: q {:?} must be finite numbers",
                memory_row(k),
                row.q
            ));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use parcal_kinematics::Vec3;

    use super::*;

    /// The message of the refusal of `options`.
    fn refusal(options: &HexapodOptions, spelling: Spelling) -> String {
        match hexapod_scenario(options, 1, spelling) {
            Err(error) => error.to_string(),
            Ok(scenario) => panic!("not refused: {scenario:?}"),
        }
    }

    fn touch(ball: &str, direction: Vec3) -> PlanRow {
        PlanRow {
            ball: ball.to_string(),
            direction,
            angles: [0.0, 0.1, -0.2],
            q: [0.0; 6],
        }
    }

    fn pose(session: &str, q: f64) -> PosePlanRow {
        PosePlanRow {
            session: session.to_string(),
            angles: [0.0; 3],
            tip: Vec3::zeros(),
            q: [q; 6],
        }
    }

    #[test]
    fn the_defaults_are_the_papers_campaigns() {
        let HexapodScenario::Touches(scenario) =
            hexapod_scenario(&HexapodOptions::default(), 1, Spelling::Flags).unwrap()
        else {
            panic!("not touches")
        };
        let paper = Scenario::paper();
        assert_eq!(scenario.centres, paper.centres);
        assert_eq!(scenario.points_per_ball, 7);
        assert_eq!(scenario.max_tilt, DEFAULT_TILT.to_radians());
        let tracked = HexapodOptions {
            tracker: Some(TrackerKind::Both),
            touches: true,
            ..Default::default()
        };
        let HexapodScenario::Tracker { tracker, touches } =
            hexapod_scenario(&tracked, 1, Spelling::Keywords).unwrap()
        else {
            panic!("not an instrument campaign")
        };
        assert_eq!((tracker.sessions, tracker.rows_per_session), (3, 50));
        assert_eq!(tracker.kind, TrackerKind::Both);
        assert_eq!(touches.unwrap().centres.len(), 27);
    }

    #[test]
    fn the_options_set_the_scenario() {
        let options = HexapodOptions {
            balls: Some(8),
            points_per_ball: Some(5),
            readings: Some(ReadingUnit::Rev),
            tilt: Some(20.0),
            design_drawn: true,
            ..Default::default()
        };
        let HexapodScenario::Touches(scenario) =
            hexapod_scenario(&options, 3, Spelling::Keywords).unwrap()
        else {
            panic!("not touches")
        };
        assert_eq!((scenario.centres.len(), scenario.points_per_ball), (8, 5));
        assert_eq!(scenario.readings.unit, "rev");
        assert_ne!(scenario.design, scenario.truth);
        let options = HexapodOptions {
            tracker: Some(TrackerKind::Poses),
            machine: Some(TrackedMachine::Jugglebot),
            sessions: Some(2),
            rows: Some(12),
            rehome: Some(0.0),
            position_sigma: Some(0.5),
            orientation_sigma: Some(0.002),
            ..Default::default()
        };
        let HexapodScenario::Tracker { tracker, touches } =
            hexapod_scenario(&options, 1, Spelling::Flags).unwrap()
        else {
            panic!("not an instrument campaign")
        };
        assert!(touches.is_none());
        assert_eq!((tracker.sessions, tracker.rows_per_session), (2, 12));
        assert_eq!(tracker.session_model.leg_offset_sigma, None);
        assert_eq!(
            (tracker.position_sigma, tracker.orientation_sigma),
            (0.5, 0.002)
        );
        assert_eq!(tracker.unit, TrackerScenario::jugglebot_like().unit);
    }

    #[test]
    fn values_are_refused_naming_the_option_as_each_front_end_spells_it() {
        let tracked = |options: HexapodOptions| HexapodOptions {
            tracker: Some(TrackerKind::Points),
            ..options
        };
        let cases = [
            (
                HexapodOptions {
                    tilt: Some(90.0),
                    ..Default::default()
                },
                "--tilt must be in [0, 90) degrees, got 90",
                "tilt must be in [0, 90) degrees, got 90",
            ),
            (
                HexapodOptions {
                    balls: Some(0),
                    ..Default::default()
                },
                "--balls 0: must be a whole number from 1",
                "balls 0: must be a whole number from 1",
            ),
            (
                HexapodOptions {
                    balls: Some(5_000_000),
                    points_per_ball: Some(3),
                    ..Default::default()
                },
                "too large: --balls 5000000 x --points-per-ball 3",
                "too large: balls 5000000 x points_per_ball 3",
            ),
            (
                tracked(HexapodOptions {
                    rehome: Some(-1.0),
                    ..Default::default()
                }),
                "--rehome must be a sigma in mm (0: none), got -1",
                "rehome must be a sigma in mm (0: none), got -1",
            ),
            (
                tracked(HexapodOptions {
                    orientation_sigma: Some(f64::NAN),
                    ..Default::default()
                }),
                "--orientation-sigma must be positive, got NaN",
                "orientation_sigma must be positive, got NaN",
            ),
            (
                tracked(HexapodOptions {
                    rows: Some(0),
                    ..Default::default()
                }),
                "--rows 0: must be a whole number from 1",
                "rows 0: must be a whole number from 1",
            ),
            (
                tracked(HexapodOptions {
                    sessions: Some(1_000_000),
                    rows: Some(1_000_000),
                    ..Default::default()
                }),
                "too large: --sessions 1000000 x --rows 1000000",
                "too large: sessions 1000000 x rows 1000000",
            ),
            (
                tracked(HexapodOptions {
                    touches: true,
                    machine: Some(TrackedMachine::Jugglebot),
                    ..Default::default()
                }),
                "--touches: the ball touches are the paper machine's (--machine paper)",
                "touches: the ball touches are the paper machine's (machine=\"paper\")",
            ),
        ];
        for (options, flags, keywords) in cases {
            let found = refusal(&options, Spelling::Flags);
            assert!(found.starts_with(flags), "{found}");
            let found = refusal(&options, Spelling::Keywords);
            assert!(found.starts_with(keywords), "{found}");
        }
        assert_eq!(
            reading_unit("revolutions", Spelling::Keywords).unwrap_err(),
            "readings: \"revolutions\" is not one of mm, rev"
        );
        assert_eq!(
            tracked_machine("stewart", Spelling::Flags).unwrap_err(),
            "--machine: \"stewart\" is not one of paper, jugglebot"
        );
        assert_eq!(
            tracked_machine("jugglebot", Spelling::Flags),
            Ok(TrackedMachine::Jugglebot)
        );
    }

    #[test]
    fn combinations_the_command_refuses_are_refused_by_name() {
        let touches = HexapodOptions {
            balls: Some(3),
            design_drawn: true,
            readings: Some(ReadingUnit::Mm),
            tracker: Some(TrackerKind::Both),
            ..Default::default()
        };
        assert_eq!(
            touches.check_combinations(Spelling::Keywords).unwrap_err(),
            "balls, readings, design_drawn cannot be used with tracker"
        );
        let sessions = HexapodOptions {
            sessions: Some(2),
            position_sigma: Some(0.1),
            ..Default::default()
        };
        assert_eq!(
            sessions.check_combinations(Spelling::Flags).unwrap_err(),
            "--sessions, --position-sigma cannot be used without --tracker"
        );
        assert_eq!(sessions.given(), ["sessions", "position_sigma"]);
        assert_eq!(
            touches.given(),
            ["balls", "readings", "tracker", "design_drawn"]
        );
        let fine = HexapodOptions {
            tracker: Some(TrackerKind::Poses),
            ..sessions
        };
        assert_eq!(fine.check_combinations(Spelling::Keywords), Ok(()));
        assert_eq!(
            HexapodOptions::default().check_combinations(Spelling::Keywords),
            Ok(())
        );
    }

    #[test]
    fn a_plan_in_memory_is_simulated_as_its_file_and_checked_as_it() {
        let down = Vec3::new(0.0, 0.0, -1.0);
        let options = |rows: Vec<PlanRow>| HexapodOptions {
            balls: Some(4),
            plan: Some(PlanSource::Touches(rows)),
            ..Default::default()
        };
        let rows = vec![touch("b02", down), touch("b01", Vec3::new(0.6, 0.0, -0.8))];
        let HexapodScenario::Touches(scenario) =
            hexapod_scenario(&options(rows), 1, Spelling::Keywords).unwrap()
        else {
            panic!("not touches")
        };
        let plan = scenario.plan.unwrap();
        assert_eq!(plan.iter().map(|t| t.ball).collect::<Vec<_>>(), [1, 0]);
        assert_eq!(plan[1].rotation, rotation_zyx(-0.2, 0.1, 0.0));
        for (rows, message) in [
            (vec![], "plan: no touches"),
            (
                vec![touch("b01", down), touch("b09", down)],
                "plan: row 1: ball \"b09\" is not one of the simulated balls b01 .. b04",
            ),
            (
                vec![touch("b01", Vec3::new(0.0, 0.0, -2.0))],
                "plan: row 0: u = (0, 0, -2) is not a unit vector",
            ),
            (
                vec![touch("b01", Vec3::new(f64::NAN, 0.0, -1.0))],
                "plan: row 0: direction [NaN, 0.0, -1.0] and angles",
            ),
        ] {
            let found = refusal(&options(rows), Spelling::Keywords);
            assert!(found.starts_with(message), "{found}");
        }
        let poses = HexapodOptions {
            plan: Some(PlanSource::Poses(vec![pose("1", 1.0)])),
            ..Default::default()
        };
        assert!(
            refusal(&poses, Spelling::Keywords).starts_with("plan: a pose plan"),
            "{}",
            refusal(&poses, Spelling::Keywords)
        );
    }

    #[test]
    fn a_pose_plan_sets_the_sessions_and_rows() {
        let options =
            |rows: Vec<PosePlanRow>, sessions: Option<usize>, rows_given: Option<usize>| {
                HexapodOptions {
                    tracker: Some(TrackerKind::Poses),
                    sessions,
                    rows: rows_given,
                    plan: Some(PlanSource::Poses(rows)),
                    ..Default::default()
                }
            };
        let two = vec![
            pose("a", 1.0),
            pose("b", 2.0),
            pose("a", 3.0),
            pose("b", 4.0),
        ];
        let HexapodScenario::Tracker { tracker, .. } =
            hexapod_scenario(&options(two.clone(), None, None), 1, Spelling::Keywords).unwrap()
        else {
            panic!("not an instrument campaign")
        };
        assert_eq!((tracker.sessions, tracker.rows_per_session), (2, 2));
        assert_eq!(
            tracker.plan.unwrap(),
            [vec![[1.0; 6], [3.0; 6]], vec![[2.0; 6], [4.0; 6]]]
        );
        // A plan of one session is measured in every session asked for.
        let one = vec![pose("1", 1.0), pose("1", 2.0)];
        let HexapodScenario::Tracker { tracker, .. } =
            hexapod_scenario(&options(one.clone(), Some(4), None), 1, Spelling::Keywords).unwrap()
        else {
            panic!("not an instrument campaign")
        };
        assert_eq!((tracker.sessions, tracker.rows_per_session), (4, 2));
        for (options, message) in [
            (
                options(two.clone(), Some(3), None),
                "sessions=3 and plan: the plan has 2 sessions",
            ),
            (
                options(one.clone(), None, Some(2)),
                "rows and plan: the plan's 2 poses per session are the rows of each session",
            ),
            (
                options(
                    vec![pose("a", 1.0), pose("b", 2.0), pose("a", 3.0)],
                    None,
                    None,
                ),
                "plan: session \"b\" has 1 poses and session \"a\" 2",
            ),
            (options(vec![], None, None), "plan: no poses"),
            (
                options(vec![pose("", 1.0)], None, None),
                "plan: row 0: session \"\": expected a label",
            ),
            (
                options(vec![pose("1", f64::INFINITY)], None, None),
                "plan: row 0: q [inf,",
            ),
        ] {
            let found = refusal(&options, Spelling::Keywords);
            assert!(found.starts_with(message), "{found}");
        }
        let touches = HexapodOptions {
            tracker: Some(TrackerKind::Poses),
            plan: Some(PlanSource::Touches(vec![touch("b01", Vec3::z())])),
            ..Default::default()
        };
        assert!(refusal(&touches, Spelling::Keywords).starts_with("plan: a plan of ball touches"));
        let flags = options(two, Some(3), None);
        assert!(
            refusal(&flags, Spelling::Flags)
                .starts_with("--sessions 3 and --plan: the plan has 2 sessions")
        );
    }
}
