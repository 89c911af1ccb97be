//! Simulated cable robots: a true machine drawn from the design's priors,
//! effector positions drawn in its working volume, and the encoder angles
//! each position gives, with noise; a few positions measured, as a camera
//! (the Hangprinter's hp-mark) measures them.
//!
//! The first sample is the encoder zero (every reading zero up to its
//! noise, the position measured there), then the known positions on the
//! bed (`z` = 0), then the unknown ones anywhere in the volume. Every
//! position is one where every line is taut
//! ([`Mechanism::check_feasible`]). A robot whose lines are elastic
//! ([`CableRobot::with_elasticity`]) is measured under loads: the encoder
//! zero under its zero loads, every other sample under loads drawn
//! uniformly from the scenario's range, each line's on its own, and read
//! as the stretched lines read ([`Mechanism::loaded_readings`]).
//! Deterministic for a seed: the truth, the positions, the loads and the
//! noise each draw from their own stream.
//! [`simulate_cable_dataset`] writes the campaign of the typical robot (the
//! one a dataset's `"cable robot"` names) as a mechanism dataset with its
//! truth; [`measure_cable_dataset`] measures a given true machine (held-out
//! data).

use nalgebra::DVector;
use parcal_dataset::mechanism::{
    LineElasticity, MechanismDataset, MechanismMachine, MechanismTruth, Noise, SampleRow,
};
use parcal_kinematics::cable::{CableRobot, Elasticity};
use parcal_kinematics::mechanism::{Mechanism, design};

use crate::{COUNT, Rng, SimulateError};

/// The most draws of a position before a simulation gives up finding a
/// feasible one.
const MAX_TRIES: usize = 10_000;
/// The largest load a line may be drawn under (N): a hundred times the
/// Hangprinter's.
pub const MAX_LOAD: f64 = 2000.0;

/// What to simulate.
#[derive(Debug, Clone, PartialEq)]
pub struct CableScenario {
    /// The number of samples (encoder readings), the encoder zero
    /// included.
    pub samples: usize,
    /// How many of them have a measured position: the encoder zero and
    /// `known - 1` points on the bed.
    pub known: usize,
    /// The standard deviation of each encoder reading (degrees).
    pub reading_sigma: f64,
    /// The standard deviation of each measured coordinate (mm).
    pub position_sigma: [f64; 3],
    /// The working volume: `|x|, |y|` up to this (mm) ...
    pub half_width: f64,
    /// ... and `z` from 0 up to this (mm).
    pub height: f64,
    /// The range `[low, high]` each line's load is drawn from at every
    /// sample but the encoder zero (N), when the lines are elastic.
    pub loads: [f64; 2],
}

impl CableScenario {
    /// The Hangprinter data's shape (`fixtures/hangprinter`): 44 samples,
    /// 9 measured, readings to 1 degree (0.05 mm of line), positions to
    /// 1 mm, a volume 1 m wide and 1.4 m high, loads from 5 to 35 N
    /// (the data's are 7 to 24 N).
    pub fn hangprinter() -> Self {
        Self {
            samples: 44,
            known: 9,
            reading_sigma: 1.0,
            position_sigma: [1.0; 3],
            half_width: 500.0,
            height: 1400.0,
            loads: [5.0, 35.0],
        }
    }

    fn check(&self) -> Result<(), SimulateError> {
        let bad = |reason: String| Err(SimulateError::Scenario(format!("cable robot: {reason}")));
        COUNT
            .check("samples", self.samples)
            .map_err(SimulateError::Scenario)?;
        if !(1..=self.samples).contains(&self.known) {
            return bad(format!(
                "{} measured positions of {} samples: at least the encoder zero's, at most every one",
                self.known, self.samples
            ));
        }
        let sigmas = [
            self.reading_sigma,
            self.position_sigma[0],
            self.position_sigma[1],
            self.position_sigma[2],
        ];
        if sigmas.iter().any(|s| !(s.is_finite() && *s >= 0.0)) {
            return bad(format!(
                "the noise {sigmas:?} must be finite and not negative"
            ));
        }
        if !(self.half_width > 0.0
            && self.height > 0.0
            && self.half_width.is_finite()
            && self.height.is_finite())
        {
            return bad(format!(
                "the volume (half width {}, height {}) must be positive",
                self.half_width, self.height
            ));
        }
        let [low, high] = self.loads;
        if !(low > 0.0 && low <= high && high <= MAX_LOAD) {
            return bad(format!(
                "the loads' range [{low}, {high}] N must be within (0, {MAX_LOAD}], its low end first"
            ));
        }
        Ok(())
    }
}

/// One simulated sample.
#[derive(Debug, Clone, PartialEq)]
pub struct CableSample {
    /// The encoder angles, noisy (degrees).
    pub readings: Vec<f64>,
    /// The measured position, noisy, if measured (mm).
    pub known: Option<[f64; 3]>,
    /// The true position (mm).
    pub position: [f64; 3],
    /// The lines' loads (N), if the lines are elastic.
    pub loads: Option<Vec<f64>>,
}

/// A simulated cable robot campaign.
#[derive(Debug, Clone, PartialEq)]
pub struct CableSimulation {
    /// The true parameters.
    pub truth: DVector<f64>,
    /// The samples, the encoder zero first.
    pub samples: Vec<CableSample>,
}

/// The stream of the true machine.
const TRUTH: u64 = 0;
/// The stream of the positions.
const POSITIONS: u64 = 1;
/// The stream of the noise.
const NOISE: u64 = 2;
/// The stream of the loads.
const LOADS: u64 = 3;

/// Simulates `scenario` on `robot` for `seed`: the truth drawn from the
/// priors (each parameter its design plus a normal deviate of its prior
/// sigma), then measured by [`measure_cable`].
pub fn simulate_cable(
    robot: &CableRobot,
    scenario: &CableScenario,
    seed: u64,
) -> Result<CableSimulation, SimulateError> {
    scenario.check()?;
    let mut rng = Rng::new(seed, TRUTH);
    let mut truth = design(robot);
    for (value, parameter) in truth.iter_mut().zip(robot.parameters()) {
        *value += rng.normal(parameter.prior_sigma);
    }
    measure_cable(robot, scenario, truth, seed)
}

/// The campaign of `scenario` measured with seed `seed` on the machine of
/// true parameters `truth`: the positions, the readings with their noise.
/// Held-out data of a machine already simulated (another seed), or of one
/// changed on purpose.
pub fn measure_cable(
    robot: &CableRobot,
    scenario: &CableScenario,
    truth: DVector<f64>,
    seed: u64,
) -> Result<CableSimulation, SimulateError> {
    scenario.check()?;
    parcal_kinematics::mechanism::check_params(robot, truth.as_slice())
        .map_err(|e| SimulateError::Scenario(format!("cable robot: the true machine: {e}")))?;
    let params = truth.as_slice();
    let zero = robot.encoder_zero(params);
    let mut rng = Rng::new(seed, POSITIONS);
    let mut positions = vec![[zero.x, zero.y, zero.z]];
    for i in 1..scenario.samples {
        let on_bed = i < scenario.known;
        let position = (0..MAX_TRIES)
            .map(|_| {
                let w = scenario.half_width;
                let z = if on_bed { 0.0 } else { rng.uniform(0.0, scenario.height) };
                [rng.uniform(-w, w), rng.uniform(-w, w), z]
            })
            .find(|p| robot.check_feasible(params, p).is_ok())
            .ok_or_else(|| {
                SimulateError::Scenario(format!(
                    "cable robot: no position of sample {i} within the volume keeps every line taut in {MAX_TRIES} draws"
                ))
            })?;
        positions.push(position);
    }
    let loads = draw_loads(robot.elasticity(), scenario, positions.len(), seed);
    let mut rng = Rng::new(seed, NOISE);
    let samples = positions
        .iter()
        .zip(loads)
        .enumerate()
        .map(|(i, (position, loads))| {
            let exact = match &loads {
                Some(loads) => robot
                    .loaded_readings(params, position, loads)
                    .map(|(readings, _)| readings),
                None => robot.inverse(params, position),
            }
            .map_err(|e| SimulateError::Scenario(format!("cable robot: sample {i}: {e}")))?;
            let readings = exact
                .iter()
                .map(|q| q + rng.normal(scenario.reading_sigma))
                .collect();
            let known = (i < scenario.known).then(|| {
                std::array::from_fn(|k| position[k] + rng.normal(scenario.position_sigma[k]))
            });
            Ok(CableSample {
                readings,
                known,
                position: *position,
                loads,
            })
        })
        .collect::<Result<_, SimulateError>>()?;
    Ok(CableSimulation { truth, samples })
}

/// The loads of `samples` samples of a robot whose lines are elastic as
/// `elasticity` states (module doc); `None` each for rigid lines.
fn draw_loads(
    elasticity: Option<&Elasticity>,
    scenario: &CableScenario,
    samples: usize,
    seed: u64,
) -> Vec<Option<Vec<f64>>> {
    let Some(elasticity) = elasticity else {
        return vec![None; samples];
    };
    let [low, high] = scenario.loads;
    let mut rng = Rng::new(seed, LOADS);
    (0..samples)
        .map(|i| match i {
            0 => Some(elasticity.zero_loads.clone()),
            _ => Some(
                (elasticity.zero_loads.iter())
                    .map(|_| rng.uniform(low, high))
                    .collect(),
            ),
        })
        .collect()
}

/// [`simulate_cable`] on [`CableRobot::typical`], its lines elastic as
/// `lines` states if given, as a mechanism dataset: machine.json with the
/// design as configured, its tolerances and elastic lines stated, the
/// readings' and positions' noise; points.csv (with the loads of elastic
/// lines); truth.json with the true parameters (no trigger height: a
/// cable robot has no probe). A dataset holds one standard deviation for
/// every measured coordinate, so the scenario's three must be equal; both
/// noises must be positive, as the calibration weights by them.
pub fn simulate_cable_dataset(
    scenario: &CableScenario,
    lines: Option<&LineElasticity>,
    seed: u64,
) -> Result<MechanismDataset, SimulateError> {
    check_dataset_noise(scenario)?;
    let robot = typical_robot(lines)?;
    let simulation = simulate_cable(&robot, scenario, seed)?;
    Ok(cable_dataset(scenario, &robot, simulation))
}

/// [`measure_cable`] of the true machine `truth` of [`CableRobot::typical`],
/// its lines elastic as `lines` states if given, as a mechanism dataset,
/// as [`simulate_cable_dataset`] writes it: the held-out data of a
/// simulated robot.
pub fn measure_cable_dataset(
    scenario: &CableScenario,
    truth: &MechanismTruth,
    lines: Option<&LineElasticity>,
    seed: u64,
) -> Result<MechanismDataset, SimulateError> {
    check_dataset_noise(scenario)?;
    let robot = typical_robot(lines)?;
    let truth = DVector::from_column_slice(&truth.parameters);
    let simulation = measure_cable(&robot, scenario, truth, seed)?;
    Ok(cable_dataset(scenario, &robot, simulation))
}

/// [`CableRobot::typical`], its lines elastic as `lines` states if given,
/// each compliance's prior [`Elasticity::typical`]'s; an error naming
/// what does not fit its lines, or a load at the encoder zero that is not
/// positive (a slack line).
fn typical_robot(lines: Option<&LineElasticity>) -> Result<CableRobot, SimulateError> {
    let Some(lines) = lines else {
        return Ok(CableRobot::typical());
    };
    let refused =
        |reason: String| SimulateError::Scenario(format!("cable robot: elastic lines: {reason}"));
    if let Some(load) = lines
        .zero_loads
        .iter()
        .find(|f| !(**f > 0.0 && **f <= MAX_LOAD))
    {
        return Err(refused(format!(
            "a load at the encoder zero, {load} N, is not in (0, {MAX_LOAD}]: a line is taut under a positive load"
        )));
    }
    CableRobot::typical_elastic(lines.compliance_of_line.clone(), lines.zero_loads.clone())
        .map_err(|error| refused(error.to_string()))
}

/// Refuses a scenario a dataset cannot state (one positive position sigma,
/// a positive reading sigma).
fn check_dataset_noise(scenario: &CableScenario) -> Result<(), SimulateError> {
    let [sx, sy, sz] = scenario.position_sigma;
    if !(sx == sy && sy == sz && sx > 0.0 && scenario.reading_sigma > 0.0) {
        return Err(SimulateError::Scenario(format!(
            "cable robot: a dataset needs one positive position sigma (got {:?}) and a positive reading sigma (got {})",
            scenario.position_sigma, scenario.reading_sigma
        )));
    }
    Ok(())
}

/// The dataset of `simulation`, a campaign of `scenario` on `robot`
/// ([`CableRobot::typical`], its lines elastic or not).
fn cable_dataset(
    scenario: &CableScenario,
    robot: &CableRobot,
    simulation: CableSimulation,
) -> MechanismDataset {
    let samples = simulation
        .samples
        .into_iter()
        .map(|sample| SampleRow {
            readings: sample.readings,
            position: sample.known,
            loads: sample.loads,
        })
        .collect();
    let machine = MechanismMachine {
        noise: Noise {
            actuator: Some(scenario.reading_sigma),
            position: Some(scenario.position_sigma[0]),
            ..Noise::default()
        },
        ..MechanismMachine::stating_tolerances(robot)
    };
    MechanismDataset {
        machine,
        samples,
        truth: Some(MechanismTruth {
            parameters: simulation.truth.iter().copied().collect(),
            trigger_height: None,
            trackers: std::collections::BTreeMap::new(),
        }),
        ..MechanismDataset::default()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_seed_gives_one_campaign_of_taut_lines() {
        let robot = CableRobot::typical();
        let scenario = CableScenario::hangprinter();
        let a = simulate_cable(&robot, &scenario, 7).unwrap();
        assert_eq!(a, simulate_cable(&robot, &scenario, 7).unwrap());
        assert_ne!(a.truth, simulate_cable(&robot, &scenario, 8).unwrap().truth);
        assert_eq!(a.samples.len(), 44);
        assert_eq!(a.samples.iter().filter(|s| s.known.is_some()).count(), 9);
        let params = a.truth.as_slice();
        for (i, sample) in a.samples.iter().enumerate() {
            robot.check_feasible(params, &sample.position).unwrap();
            // The noise is the scenario's: readings within 6 sigma of the
            // exact ones.
            let exact = robot.inverse(params, &sample.position).unwrap();
            let worst = exact
                .iter()
                .zip(&sample.readings)
                .map(|(e, r)| (e - r).abs())
                .fold(0.0, f64::max);
            assert!(worst < 6.0 * scenario.reading_sigma, "sample {i}: {worst}");
        }
        // The encoder zero reads zero, up to the noise.
        assert!(a.samples[0].readings.iter().all(|q| q.abs() < 6.0));
    }

    #[test]
    fn elastic_lines_are_read_under_their_loads() {
        let elasticity = Elasticity::typical(vec![0; 4], vec![15.0, 15.0, 15.0, 30.0]);
        let robot = CableRobot::typical().with_elasticity(elasticity).unwrap();
        let scenario = CableScenario::hangprinter();
        let a = simulate_cable(&robot, &scenario, 7).unwrap();
        let params = a.truth.as_slice();
        // A compliance far from zero, so that the loads change the readings.
        let compliance = params[robot.compliance_index(0).unwrap()];
        assert!(compliance.abs() > 10.0, "{compliance}");
        let mut changed = 0.0_f64;
        for (i, sample) in a.samples.iter().enumerate() {
            let loads = sample.loads.as_ref().unwrap();
            let [low, high] = scenario.loads;
            assert!(
                i == 0 || loads.iter().all(|f| (low..high).contains(f)),
                "{i}: {loads:?}"
            );
            let (loaded, _) = robot
                .loaded_readings(params, &sample.position, loads)
                .unwrap();
            let rigid = robot.inverse(params, &sample.position).unwrap();
            let worst = (loaded.iter().zip(&sample.readings))
                .map(|(e, r)| (e - r).abs())
                .fold(0.0, f64::max);
            assert!(worst < 6.0 * scenario.reading_sigma, "sample {i}: {worst}");
            changed = changed.max((&loaded - &rigid).amax());
        }
        // The encoder zero is under its zero loads, read as by rigid lines.
        assert_eq!(
            a.samples[0].loads.as_deref(),
            Some(&[15.0, 15.0, 15.0, 30.0][..])
        );
        assert!(changed > 6.0 * scenario.reading_sigma, "{changed}");
        let rigid = simulate_cable(&CableRobot::typical(), &scenario, 7).unwrap();
        assert!(rigid.samples.iter().all(|s| s.loads.is_none()));
    }

    #[test]
    fn a_dataset_reads_back_with_its_truth() {
        let scenario = CableScenario::hangprinter();
        let dataset = simulate_cable_dataset(&scenario, None, 3).unwrap();
        assert_eq!(dataset.samples.len(), 44);
        assert!(dataset.truth.as_ref().unwrap().trigger_height.is_none());
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("cable");
        dataset.write(&path).unwrap();
        assert_eq!(MechanismDataset::read(&path).unwrap(), dataset);
        let uneven = CableScenario {
            position_sigma: [1.0, 1.0, 2.0],
            ..scenario
        };
        let error = simulate_cable_dataset(&uneven, None, 3)
            .unwrap_err()
            .to_string();
        assert!(error.contains("one positive position sigma"), "{error}");
        let lines = LineElasticity {
            compliance_of_line: vec![0, 1, 2, 3],
            zero_loads: vec![15.0, 15.0, 15.0, 30.0],
        };
        let elastic = simulate_cable_dataset(&scenario, Some(&lines), 3).unwrap();
        assert_eq!(elastic.machine.elasticity.as_ref(), Some(&lines));
        assert!(elastic.samples.iter().all(|s| s.loads.is_some()));
        elastic.write(&dir.path().join("elastic")).unwrap();
        assert_eq!(
            MechanismDataset::read(&dir.path().join("elastic")).unwrap(),
            elastic
        );
    }

    #[test]
    fn an_impossible_scenario_is_refused() {
        let robot = CableRobot::typical();
        let mut scenario = CableScenario::hangprinter();
        scenario.known = 0;
        let err = simulate_cable(&robot, &scenario, 1).unwrap_err();
        assert!(err.to_string().contains("0 measured positions"), "{err}");
        let mut scenario = CableScenario::hangprinter();
        // Bed positions over a square of 2 km: one in a million or so is
        // under the anchors.
        scenario.half_width = 1e6;
        scenario.known = 44;
        let err = simulate_cable(&robot, &scenario, 1).unwrap_err();
        assert!(err.to_string().contains("taut"), "{err}");
    }
}
