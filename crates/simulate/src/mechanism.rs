//! A simulated mechanism from a front end's options (`parcal simulate
//! --mechanism`, Python's `parcal.simulate(mechanism=...)`): a mechanism
//! dataset with its truth. A linear delta printer (docs/delta.md) by
//! [`simulate_delta`]: the typical kit printer's design, its true
//! parameters and trigger height a draw of the prior machine.json states,
//! probes on rings over the printable disc, part distances across it on
//! the first layer, calibrated balls on the bed touched by the probe and a
//! ball plate's distances between them. A
//! cable robot (docs/cable-robots.md) by [`simulate_cable_dataset`]: the
//! Hangprinter's shape, its true anchors, radii and encoder zero a draw of
//! the prior, encoder samples where every line is taut, the encoder zero's
//! and a few bed positions measured; its lines elastic if their loads at
//! the encoder zero are given (the true compliances a draw of their
//! prior, every other sample under drawn loads).
//!
//! Given a simulated dataset ([`TrueMachine`]), its true machine is
//! measured again instead of drawn: held-out data for validation (new
//! noise with another seed, or another pattern with other options; a
//! cable robot's lines as its machine.json states them); its own
//! measurements (the same seed and pattern) are refused.
//!
//! Every count is bounded before work starts, an option of another
//! mechanism is refused, and every message names the option as the front
//! end spells it ([`Spelling`]).

use parcal_dataset::bounds::Count;
use parcal_dataset::mechanism::{LineElasticity, MACHINE_FILE, MechanismDataset, MechanismTruth};
use parcal_kinematics::cable::CableRobot;
use parcal_kinematics::mechanism::Mechanism;
use parcal_kinematics::mechanisms;

use crate::delta::{DeltaScenario, measure_delta, simulate_delta};
use crate::{
    COUNT, CableScenario, Plate, SimulateError, measure_cable_dataset, simulate_cable_dataset,
};

/// The bounds of `probe_rings`.
pub const RINGS: Count = Count::new(1, 20, "a bed probed on more rings than 20 gains nothing");
/// The bounds of `probes_per_ring`.
pub const PER_RING: Count = Count::new(3, 360, "a point every degree at most");
/// The bounds of `part_distances`.
pub const DISTANCES: Count = Count::new(0, 180, "one distance per degree at most");
/// The bounds of `manual_heights`.
pub const MANUAL_HEIGHTS: Count = Count::new(0, 1000, "each is measured by hand");
/// The bounds of `trackers`.
pub const TRACKERS: Count = parcal_dataset::mechanism::TRACKERS;
/// The bounds of `points_per_tracker`: three locate a tracker's frame.
pub const POINTS_PER_TRACKER: Count = Count::new(
    3,
    10_000,
    "a tracker's frame is six unknowns: ten thousand points locate it far past its noise",
);
/// The bounds of `samples` and `known_positions`.
pub const SAMPLES: Count = Count::new(
    1,
    10_000,
    "a cable robot's calibration from ten thousand encoder samples is far past what its model error allows",
);

/// How a front end names the options in its messages.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Spelling {
    /// The command's flags: `--probe-rings`.
    Flags,
    /// Keyword arguments: `probe_rings`.
    Keywords,
}

impl Spelling {
    /// The option `keyword` (snake_case, as [`MechanismOptions`]' fields)
    /// as this front end writes it.
    pub fn name(self, keyword: &str) -> String {
        match self {
            Spelling::Flags => format!("--{}", keyword.replace('_', "-")),
            Spelling::Keywords => keyword.to_string(),
        }
    }
}

/// The options of a simulated mechanism, each `None` for its default;
/// named as the command's flags are (`probe_rings` is `--probe-rings`).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct MechanismOptions {
    /// Delta: probe rings over the printable disc and its centre (default
    /// 3; [`RINGS`]).
    pub probe_rings: Option<usize>,
    /// Delta: probe points on each ring (default 8; [`PER_RING`]).
    pub probes_per_ring: Option<usize>,
    /// Delta: distances measured across a printed disc on the first layer
    /// (default 0; [`DISTANCES`]).
    pub part_distances: Option<usize>,
    /// Delta: heights of the nozzle measured by hand with a 5 mm gauge
    /// block, at the centre and on a ring (default 0; [`MANUAL_HEIGHTS`]).
    pub manual_heights: Option<usize>,
    /// Delta: the probe's noise, 1 sigma, mm (default 0.01, at most 1).
    pub probe_sigma: Option<f64>,
    /// Delta: the part distances' noise, 1 sigma, mm (default 0.01, at
    /// most 1).
    pub distance_sigma: Option<f64>,
    /// Delta: the heights' noise, 1 sigma, mm (default 0.05, at most 1).
    pub height_sigma: Option<f64>,
    /// Delta: calibrated balls (12.7 mm radius, calibrated to 1 µm) on a
    /// ring on the bed, touched by the probe (default none; [`COUNT`]).
    pub balls: Option<usize>,
    /// Delta: touches of each ball, on its upper cap (default 7;
    /// [`COUNT`]).
    pub points_per_ball: Option<usize>,
    /// Delta: a ball plate over the balls, the calibrated distances
    /// between their centres (which pairs, each distance's standard
    /// deviation in mm; default none; needs `balls`).
    pub plate: Option<Plate>,
    /// Delta: trackers placed about the printer, each measuring the tool
    /// point in its own frame (default none; [`TRACKERS`]).
    pub trackers: Option<usize>,
    /// Delta: points each tracker measures (default 12;
    /// [`POINTS_PER_TRACKER`]).
    pub points_per_tracker: Option<usize>,
    /// Delta: a tracker's noise, 1 sigma per coordinate, mm (default
    /// 0.01, at most 1).
    pub tracker_sigma: Option<f64>,
    /// Cable robot: samples (encoder readings), the encoder zero's
    /// included (default 44, the Hangprinter data's; [`SAMPLES`]).
    pub samples: Option<usize>,
    /// Cable robot: samples whose position is measured, the encoder zero
    /// and the rest on the bed (default 9; [`SAMPLES`], at most
    /// `samples`).
    pub known_positions: Option<usize>,
    /// Cable robot: the encoders' noise, 1 sigma, degrees (default 1, at
    /// most 90).
    pub reading_sigma: Option<f64>,
    /// Cable robot: a measured position's noise, 1 sigma per coordinate,
    /// mm (default 1, at most 100).
    pub measured_sigma: Option<f64>,
    /// Cable robot: the lines' loads at the encoder zero (N, one per
    /// line), which makes them elastic (default: rigid lines).
    pub zero_loads: Option<Vec<f64>>,
    /// Cable robot, elastic lines: the compliance of each line, by its
    /// index among the compliances (default one shared, `0` for each).
    pub compliance_of_line: Option<Vec<usize>>,
    /// Cable robot, elastic lines: the range each line's load is drawn
    /// from at every other sample (N, low then high; default 5 to 35).
    pub load_range: Option<[f64; 2]>,
}

impl MechanismOptions {
    /// The names of the options given.
    pub fn given(&self) -> Vec<&'static str> {
        let options = self.delta_given().into_iter().chain(self.cable_given());
        options
            .filter(|(_, given)| *given)
            .map(|(name, _)| name)
            .collect()
    }

    /// A delta's options, each with whether it is given.
    fn delta_given(&self) -> [(&'static str, bool); 13] {
        [
            ("probe_rings", self.probe_rings.is_some()),
            ("probes_per_ring", self.probes_per_ring.is_some()),
            ("part_distances", self.part_distances.is_some()),
            ("probe_sigma", self.probe_sigma.is_some()),
            ("distance_sigma", self.distance_sigma.is_some()),
            ("manual_heights", self.manual_heights.is_some()),
            ("height_sigma", self.height_sigma.is_some()),
            ("balls", self.balls.is_some()),
            ("points_per_ball", self.points_per_ball.is_some()),
            ("plate", self.plate.is_some()),
            ("trackers", self.trackers.is_some()),
            ("points_per_tracker", self.points_per_tracker.is_some()),
            ("tracker_sigma", self.tracker_sigma.is_some()),
        ]
    }

    /// A cable robot's options, each with whether it is given.
    fn cable_given(&self) -> [(&'static str, bool); 7] {
        [
            ("samples", self.samples.is_some()),
            ("known_positions", self.known_positions.is_some()),
            ("reading_sigma", self.reading_sigma.is_some()),
            ("measured_sigma", self.measured_sigma.is_some()),
            ("zero_loads", self.zero_loads.is_some()),
            ("compliance_of_line", self.compliance_of_line.is_some()),
            ("load_range", self.load_range.is_some()),
        ]
    }
}

/// A simulated dataset whose true machine (its truth.json) is measured
/// again, and how messages name it (`--truth PATH`).
#[derive(Debug, Clone, Copy)]
pub struct TrueMachine<'a> {
    /// The dataset.
    pub dataset: &'a MechanismDataset,
    /// Its name in messages.
    pub name: &'a str,
}

/// What to simulate.
#[derive(Debug, Clone)]
pub struct MechanismRequest<'a> {
    /// The mechanism's name in [`mechanisms::NAMES`], or `delta`, `cable`.
    pub mechanism: &'a str,
    /// The seed of the random streams: the same seed and options give the
    /// same dataset.
    pub seed: u64,
    /// The options.
    pub options: &'a MechanismOptions,
    /// A simulated dataset whose true machine is measured instead of a
    /// drawn one (held-out data).
    pub truth: Option<TrueMachine<'a>>,
    /// How messages name the options.
    pub spelling: Spelling,
}

/// The mechanism named `name`, by its name in [`mechanisms::NAMES`] or a
/// short name (`delta`, `cable`): an error for the hexapod (simulated by
/// [`crate::simulate`]) and an unknown name.
pub fn mechanism_name(name: &str, spelling: Spelling) -> Result<&'static str, SimulateError> {
    let canonical = match name {
        "delta" => "linear delta",
        "cable" => "cable robot",
        other => other,
    };
    let option = spelling.name("mechanism");
    match mechanisms::NAMES.iter().find(|n| **n == canonical) {
        Some(&"hexapod") => Err(SimulateError::Options(format!(
            "{option} hexapod: the hexapod is simulated without {option} (the paper scenario and its options)"
        ))),
        Some(found) => Ok(found),
        None => Err(SimulateError::Options(format!(
            "{option} {name:?}: unknown (known: {}, or delta, cable)",
            mechanisms::NAMES.join(", ")
        ))),
    }
}

/// Simulates the dataset `request` asks for (module doc).
pub fn simulate_mechanism(request: &MechanismRequest) -> Result<MechanismDataset, SimulateError> {
    let spelling = request.spelling;
    let name = mechanism_name(request.mechanism, spelling)?;
    let truth = request
        .truth
        .as_ref()
        .map(|source| true_machine(source, name))
        .transpose()?;
    let dataset = match name {
        "linear delta" => delta(request, truth)?,
        "cable robot" => cable(request, truth)?,
        other => {
            return Err(SimulateError::Options(format!(
                "{} {other}: parcal simulates a linear delta or a cable robot",
                spelling.name("mechanism")
            )));
        }
    };
    if let Some(source) = &request.truth {
        check_held_out(&dataset, source, spelling)?;
    }
    Ok(dataset)
}

/// The truth of `source`, a dataset of the mechanism `name` with its
/// truth.json.
fn true_machine<'a>(
    source: &TrueMachine<'a>,
    name: &str,
) -> Result<&'a MechanismTruth, SimulateError> {
    let dataset = source.dataset;
    if dataset.machine.mechanism != name {
        return Err(SimulateError::Options(format!(
            "{}: a dataset of a {}, not of a {name}",
            source.name, dataset.machine.mechanism
        )));
    }
    dataset.truth.as_ref().ok_or_else(|| {
        SimulateError::Options(format!(
            "{}: the dataset has no truth.json (only a simulated dataset has a true machine to measure)",
            source.name
        ))
    })
}

/// Refuses the options of another mechanism than `name`'s that are given.
fn refuse_others(
    name: &str,
    given: &[(&str, bool)],
    spelling: Spelling,
) -> Result<(), SimulateError> {
    let others: Vec<String> = given
        .iter()
        .filter(|(_, given)| *given)
        .map(|(option, _)| spelling.name(option))
        .collect();
    if others.is_empty() {
        Ok(())
    } else {
        Err(SimulateError::Options(format!(
            "{} do not apply to a {name}",
            others.join(", ")
        )))
    }
}

/// The count `option` if given (within `bounds`), else `default`.
fn count(
    option: &str,
    given: Option<usize>,
    default: usize,
    bounds: Count,
    spelling: Spelling,
) -> Result<usize, SimulateError> {
    match given {
        Some(value) => bounds
            .check(&spelling.name(option), value)
            .map_err(SimulateError::Options),
        None => Ok(default),
    }
}

/// The sigma `option` if given (in `(0, max]`), else `default`.
fn sigma(
    option: &str,
    given: Option<f64>,
    default: f64,
    max: f64,
    spelling: Spelling,
) -> Result<f64, SimulateError> {
    let sigma = given.unwrap_or(default);
    if sigma.is_finite() && sigma > 0.0 && sigma <= max {
        Ok(sigma)
    } else {
        Err(SimulateError::Options(format!(
            "{} must be in (0, {max}], got {sigma}",
            spelling.name(option)
        )))
    }
}

/// The delta's dataset of `request`, of the true printer `truth` if given.
fn delta(
    request: &MechanismRequest,
    truth: Option<&MechanismTruth>,
) -> Result<MechanismDataset, SimulateError> {
    let (options, spelling) = (request.options, request.spelling);
    refuse_others("linear delta", &options.cable_given(), spelling)?;
    if options.plate.is_some() && options.balls.is_none() {
        return Err(SimulateError::Options(format!(
            "{} needs {}: a ball plate's distances are between the balls, and there are none without it",
            spelling.name("plate"),
            spelling.name("balls")
        )));
    }
    let typical = DeltaScenario::typical();
    let scenario = DeltaScenario {
        rings: count(
            "probe_rings",
            options.probe_rings,
            typical.rings,
            RINGS,
            spelling,
        )?,
        per_ring: count(
            "probes_per_ring",
            options.probes_per_ring,
            typical.per_ring,
            PER_RING,
            spelling,
        )?,
        distances: count(
            "part_distances",
            options.part_distances,
            typical.distances,
            DISTANCES,
            spelling,
        )?,
        manual_heights: count(
            "manual_heights",
            options.manual_heights,
            typical.manual_heights,
            MANUAL_HEIGHTS,
            spelling,
        )?,
        height_sigma: sigma(
            "height_sigma",
            options.height_sigma,
            typical.height_sigma,
            1.0,
            spelling,
        )?,
        probe_sigma: sigma("probe_sigma", options.probe_sigma, 0.01, 1.0, spelling)?,
        distance_sigma: sigma(
            "distance_sigma",
            options.distance_sigma,
            0.01,
            1.0,
            spelling,
        )?,
        balls: count("balls", options.balls, typical.balls, COUNT, spelling)?,
        touches_per_ball: count(
            "points_per_ball",
            options.points_per_ball,
            typical.touches_per_ball,
            COUNT,
            spelling,
        )?,
        plate: options.plate,
        trackers: match options.trackers {
            Some(trackers) => TRACKERS
                .check(&spelling.name("trackers"), trackers)
                .map_err(SimulateError::Options)?,
            None => 0,
        },
        points_per_tracker: count(
            "points_per_tracker",
            options.points_per_tracker,
            typical.points_per_tracker,
            POINTS_PER_TRACKER,
            spelling,
        )?,
        tracker_sigma: sigma("tracker_sigma", options.tracker_sigma, 0.01, 1.0, spelling)?,
        ..typical
    };
    match truth {
        Some(truth) => measure_delta(&scenario, truth, request.seed),
        None => simulate_delta(&scenario, request.seed),
    }
}

/// The cable robot's dataset of `request`, of the true machine `truth` if
/// given.
fn cable(
    request: &MechanismRequest,
    truth: Option<&MechanismTruth>,
) -> Result<MechanismDataset, SimulateError> {
    let (options, spelling) = (request.options, request.spelling);
    refuse_others("cable robot", &options.delta_given(), spelling)?;
    let hangprinter = CableScenario::hangprinter();
    let samples = count(
        "samples",
        options.samples,
        hangprinter.samples,
        SAMPLES,
        spelling,
    )?;
    let known = count(
        "known_positions",
        options.known_positions,
        hangprinter.known,
        SAMPLES,
        spelling,
    )?;
    if known > samples {
        return Err(SimulateError::Options(format!(
            "{} {known} is more than the {samples} samples",
            spelling.name("known_positions")
        )));
    }
    let position = sigma(
        "measured_sigma",
        options.measured_sigma,
        1.0,
        100.0,
        spelling,
    )?;
    let scenario = CableScenario {
        samples,
        known,
        reading_sigma: sigma("reading_sigma", options.reading_sigma, 1.0, 90.0, spelling)?,
        position_sigma: [position; 3],
        loads: options.load_range.unwrap_or(hangprinter.loads),
        ..hangprinter
    };
    let lines = elastic_lines(request)?;
    match truth {
        Some(truth) => measure_cable_dataset(&scenario, truth, lines.as_ref(), request.seed),
        None => simulate_cable_dataset(&scenario, lines.as_ref(), request.seed),
    }
}

/// The cable robot's elastic lines that `request` asks for: those of the
/// true machine's dataset if given, else those the options state; `None`:
/// rigid lines. By default the lines share one compliance. An option of
/// elastic lines without `zero_loads`, or the lines stated beside a true
/// machine (whose machine.json states them), is refused by name.
fn elastic_lines(request: &MechanismRequest) -> Result<Option<LineElasticity>, SimulateError> {
    let (options, spelling) = (request.options, request.spelling);
    let given = |options: &[(&'static str, bool)]| {
        (options.iter().find(|(_, given)| *given)).map(|(option, _)| spelling.name(option))
    };
    let stated = [
        ("zero_loads", options.zero_loads.is_some()),
        ("compliance_of_line", options.compliance_of_line.is_some()),
    ];
    if let Some(source) = &request.truth {
        return match given(&stated) {
            Some(option) => Err(SimulateError::Options(format!(
                "{option} with {}: the true machine's lines are those its {MACHINE_FILE} states",
                source.name
            ))),
            None => Ok(source.dataset.machine.elasticity.clone()),
        };
    }
    let Some(zero_loads) = &options.zero_loads else {
        let elastic_only = [
            ("compliance_of_line", options.compliance_of_line.is_some()),
            ("load_range", options.load_range.is_some()),
        ];
        return match given(&elastic_only) {
            Some(option) => Err(SimulateError::Options(format!(
                "{option} needs {}: it describes elastic lines, which the loads at the encoder zero make",
                spelling.name("zero_loads")
            ))),
            None => Ok(None),
        };
    };
    let lines = CableRobot::typical().actuators().len();
    Ok(Some(LineElasticity {
        compliance_of_line: (options.compliance_of_line.clone()).unwrap_or_else(|| vec![0; lines]),
        zero_loads: zero_loads.clone(),
    }))
}

/// Refuses held-out data `measured` of `source` that the calibration could
/// not be judged on: data of a controller configured otherwise than the
/// simulator's, or the very measurements of `source` (the same seed and
/// options).
fn check_held_out(
    measured: &MechanismDataset,
    source: &TrueMachine,
    spelling: Spelling,
) -> Result<(), SimulateError> {
    let truth = source.dataset;
    if measured.machine.configured != truth.machine.configured {
        return Err(SimulateError::Options(format!(
            "{}: {MACHINE_FILE} configures the controller otherwise than parcal simulate does; its true machine cannot be measured with the simulator's configuration",
            source.name
        )));
    }
    let same = measured.probes == truth.probes
        && measured.distances == truth.distances
        && measured.samples == truth.samples;
    if same {
        let seed = spelling.name("seed");
        return Err(SimulateError::Options(format!(
            "{}: these are its own measurements (the same {seed} and pattern); give another {seed} for held-out data",
            source.name
        )));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The request of `mechanism` with `options`, spelled `spelling`.
    fn request<'a>(
        mechanism: &'a str,
        seed: u64,
        options: &'a MechanismOptions,
        spelling: Spelling,
    ) -> MechanismRequest<'a> {
        MechanismRequest {
            mechanism,
            seed,
            options,
            truth: None,
            spelling,
        }
    }

    /// The message of the refusal of `request`.
    fn refusal(request: &MechanismRequest) -> String {
        match simulate_mechanism(request) {
            Err(SimulateError::Options(message)) => message,
            other => panic!("not refused: {other:?}"),
        }
    }

    #[test]
    fn options_are_named_as_each_front_end_spells_them() {
        assert_eq!(Spelling::Flags.name("probes_per_ring"), "--probes-per-ring");
        assert_eq!(
            Spelling::Keywords.name("probes_per_ring"),
            "probes_per_ring"
        );
        let options = MechanismOptions {
            samples: Some(20),
            measured_sigma: Some(2.0),
            ..Default::default()
        };
        assert_eq!(options.given(), ["samples", "measured_sigma"]);
        assert_eq!(
            refusal(&request("delta", 1, &options, Spelling::Flags)),
            "--samples, --measured-sigma do not apply to a linear delta"
        );
        assert_eq!(
            refusal(&request("delta", 1, &options, Spelling::Keywords)),
            "samples, measured_sigma do not apply to a linear delta"
        );
        let options = MechanismOptions {
            points_per_ball: Some(5),
            ..Default::default()
        };
        assert_eq!(
            refusal(&request("cable", 1, &options, Spelling::Keywords)),
            "points_per_ball do not apply to a cable robot"
        );
    }

    #[test]
    fn a_ball_plate_needs_a_deltas_balls() {
        let plate = Some(Plate {
            pairs: crate::PlatePairs::Random(2),
            sigma: 0.001,
        });
        let unballed = MechanismOptions {
            plate,
            ..Default::default()
        };
        assert!(
            refusal(&request("delta", 1, &unballed, Spelling::Flags)).starts_with(
                "--plate needs --balls: a ball plate's distances are between the balls"
            )
        );
        assert_eq!(
            refusal(&request("cable", 1, &unballed, Spelling::Keywords)),
            "plate do not apply to a cable robot"
        );
        let balled = MechanismOptions {
            balls: Some(3),
            ..unballed
        };
        let dataset = simulate_mechanism(&request("delta", 1, &balled, Spelling::Flags)).unwrap();
        assert_eq!(dataset.ball_distances.len(), 2);
    }

    #[test]
    fn counts_and_sigmas_out_of_their_bounds_are_refused() {
        let cases = [
            (
                "delta",
                MechanismOptions {
                    probe_rings: Some(21),
                    ..Default::default()
                },
                "probe_rings 21: must be a whole number from 1 to 20",
            ),
            (
                "delta",
                MechanismOptions {
                    balls: Some(0),
                    ..Default::default()
                },
                "balls 0: must be a whole number from 1",
            ),
            (
                "delta",
                MechanismOptions {
                    probe_sigma: Some(f64::NAN),
                    ..Default::default()
                },
                "probe_sigma must be in (0, 1], got NaN",
            ),
            (
                "cable",
                MechanismOptions {
                    samples: Some(20),
                    known_positions: Some(21),
                    ..Default::default()
                },
                "known_positions 21 is more than the 20 samples",
            ),
        ];
        for (mechanism, options, message) in cases {
            let found = refusal(&request(mechanism, 1, &options, Spelling::Keywords));
            assert!(found.starts_with(message), "{found}");
        }
        let options = MechanismOptions::default();
        let found = refusal(&request("hexapod", 1, &options, Spelling::Keywords));
        assert!(found.starts_with("mechanism hexapod:"), "{found}");
    }

    #[test]
    fn held_out_data_measure_the_truth_again_and_not_its_own_measurements() {
        let options = MechanismOptions::default();
        let simulated =
            simulate_mechanism(&request("delta", 5, &options, Spelling::Keywords)).unwrap();
        let truth = TrueMachine {
            dataset: &simulated,
            name: "truth",
        };
        let held_out = simulate_mechanism(&MechanismRequest {
            truth: Some(truth),
            ..request("linear delta", 6, &options, Spelling::Keywords)
        })
        .unwrap();
        assert_eq!(held_out.truth, simulated.truth);
        assert_eq!(held_out.machine, simulated.machine);
        assert_ne!(held_out.probes, simulated.probes);
        let own = refusal(&MechanismRequest {
            truth: Some(truth),
            ..request("delta", 5, &options, Spelling::Keywords)
        });
        assert!(
            own.starts_with("truth: these are its own measurements (the same seed"),
            "{own}"
        );
        let other = refusal(&MechanismRequest {
            truth: Some(truth),
            ..request("cable", 6, &options, Spelling::Flags)
        });
        assert_eq!(
            other,
            "truth: a dataset of a linear delta, not of a cable robot"
        );
        let without = MechanismDataset {
            truth: None,
            ..simulated.clone()
        };
        let untrue = refusal(&MechanismRequest {
            truth: Some(TrueMachine {
                dataset: &without,
                name: "truth",
            }),
            ..request("delta", 6, &options, Spelling::Keywords)
        });
        assert!(untrue.contains("no truth.json"), "{untrue}");
    }

    #[test]
    fn elastic_lines_are_stated_and_held_out_data_keep_the_true_machines() {
        let options = MechanismOptions {
            zero_loads: Some(vec![15.0, 15.0, 15.0, 30.0]),
            compliance_of_line: Some(vec![0, 0, 1, 1]),
            load_range: Some([10.0, 20.0]),
            ..MechanismOptions::default()
        };
        let simulated =
            simulate_mechanism(&request("cable", 5, &options, Spelling::Flags)).unwrap();
        let lines = simulated.machine.elasticity.clone().unwrap();
        assert_eq!(lines.zero_loads, [15.0, 15.0, 15.0, 30.0]);
        assert_eq!(lines.compliance_of_line, [0, 0, 1, 1]);
        // Two compliances beside the rigid robot's 19 parameters.
        assert_eq!(simulated.truth.as_ref().unwrap().parameters.len(), 21);
        let loads: Vec<&Vec<f64>> = (simulated.samples.iter())
            .map(|sample| sample.loads.as_ref().unwrap())
            .collect();
        assert_eq!(loads[0], &lines.zero_loads);
        assert!(
            loads[1..]
                .iter()
                .flat_map(|l| l.iter())
                .all(|f| (10.0..20.0).contains(f))
        );
        let truth = TrueMachine {
            dataset: &simulated,
            name: "--truth D",
        };
        let held_out = simulate_mechanism(&MechanismRequest {
            truth: Some(truth),
            ..request("cable", 6, &MechanismOptions::default(), Spelling::Flags)
        })
        .unwrap();
        assert_eq!(held_out.machine, simulated.machine);
        // The default range: 5 to 35 N.
        let drawn = held_out.samples[1..]
            .iter()
            .flat_map(|s| s.loads.clone().unwrap());
        assert!(drawn.into_iter().all(|f| (5.0..35.0).contains(&f)));
        let restated = refusal(&MechanismRequest {
            truth: Some(truth),
            ..request("cable", 6, &options, Spelling::Flags)
        });
        assert_eq!(
            restated,
            "--zero-loads with --truth D: the true machine's lines are those its machine.json states"
        );
    }

    #[test]
    fn elastic_options_without_zero_loads_or_out_of_bounds_are_refused() {
        let cases = [
            (
                MechanismOptions {
                    load_range: Some([1.0, 2.0]),
                    ..MechanismOptions::default()
                },
                "load_range needs zero_loads: it describes elastic lines, which the loads at the encoder zero make",
            ),
            (
                MechanismOptions {
                    zero_loads: Some(vec![15.0, 0.0, 15.0, 30.0]),
                    ..MechanismOptions::default()
                },
                "cable robot: elastic lines: a load at the encoder zero, 0 N, is not in (0, 2000]: a line is taut under a positive load",
            ),
            (
                MechanismOptions {
                    zero_loads: Some(vec![15.0; 3]),
                    ..MechanismOptions::default()
                },
                "cable robot: elastic lines: line elasticity: the loads at the encoder zero lists 3 values for 4 lines",
            ),
            (
                MechanismOptions {
                    zero_loads: Some(vec![15.0; 4]),
                    load_range: Some([20.0, 10.0]),
                    ..MechanismOptions::default()
                },
                "cable robot: the loads' range [20, 10] N must be within (0, 2000], its low end first",
            ),
            (
                MechanismOptions {
                    zero_loads: Some(vec![15.0; 4]),
                    ..MechanismOptions::default()
                },
                "zero_loads do not apply to a linear delta",
            ),
        ];
        for (i, (options, expected)) in cases.iter().enumerate() {
            let mechanism = if i == 4 { "delta" } else { "cable" };
            let found =
                match simulate_mechanism(&request(mechanism, 1, options, Spelling::Keywords)) {
                    Err(error) => error.to_string(),
                    Ok(_) => panic!("case {i} not refused"),
                };
            assert!(found.ends_with(expected), "case {i}: {found}");
        }
    }
}
