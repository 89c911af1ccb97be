//! Simulated linear delta printers: a true printer drawn about its design
//! by the builder's tolerances, its bed probed on rings by a controller
//! that runs the design, a few distances measured on a printed part, and
//! readings taken at unknown or measured positions; written as a
//! mechanism dataset ([`MechanismDataset`]) with its truth.
//!
//! Every true parameter is `design + N(0, tolerance²)` (the prior the
//! calibration states, so that its posterior is the right one), the
//! trigger height `h + N(0, σ_h²)`. A probe at commanded `(x, y)` reports
//! the commanded height `z_t` at which the true effector is
//! `h + N(0, σ_p²)` above the bed: the root of
//! `f_z(p, g(p_c, (x, y, z_t))) = h + ε`, by Newton's method with slope 1.
//! A part distance is measured between two commanded positions opposite
//! each other about the centre at angles spread over the bed, at the
//! height of a first layer (0.2 mm), with noise `N(0, σ_d²)`. A height
//! measured by hand (a 5 mm gauge block under the nozzle sent 5 mm up, at
//! the centre and then on a ring at 0.6 of the print radius) is the true
//! nozzle's height there, `f_z(p, g(p_c, x_c)) + N(0, σ_m²)`. A point
//! sample's readings are `g(p, x) + N(0, σ_q²)` at a pose `x` drawn in the
//! print volume, its position measured with noise `N(0, σ_x²)` for the
//! first ones. Calibrated balls rest on the bed on a ring at 0.6 of the
//! print radius, their true radii `ρ + N(0, σ_ρ²)` (exactly `ρ` for an
//! exact calibration); each is touched on its upper cap at directions `u`
//! of a golden-angle spiral (polar angles up to 70°), the true tool point
//! `x = c + (ρ + N(0, σ_t²)) u` and the commanded position the controller
//! reports `x_c = f(p_c, g(p, x))`. A ball plate over the balls gives the
//! calibrated distances between their true centres, `|c_a − c_b| +
//! N(0, σ²)` ([`Plate`]). Each tracker stands at a frame drawn about the
//! printer (1.5 to 2.5 m from its axis, turned about the vertical
//! anywhere, tilted by up to 0.1 rad) and measures the true tool point at
//! commanded positions drawn in the print volume, each coordinate with
//! noise `N(0, σ_k²)`; truth.json holds their frames. Deterministic for a
//! seed: each kind draws from its own stream, the plate from its own too,
//! so that a dataset without it is the same as with it but for
//! ball_distances.csv.

use std::collections::BTreeMap;

use nalgebra::{Isometry3, Point3, Vector3};
use parcal_dataset::FrameRecord;
use parcal_dataset::bounds::Count;
use parcal_dataset::bounds::check_product;
use parcal_dataset::mechanism::{
    BALL_DISTANCES, BALLS, BallRow, MechanismDataset, MechanismMachine, MechanismTruth, Noise,
    OBSERVATIONS, SampleRow, TRACKERS, TouchRow, TrackerPointRow, ValuePrior,
};
use parcal_kinematics::Vec3;
use parcal_kinematics::delta::{
    DeltaParams, FIRST_LAYER, GAUGE_BLOCK, Limits, LinearDelta, Tolerances, probe_rings,
};
use parcal_kinematics::mechanism::Mechanism;

use crate::plate::{self, PLATE_DISTANCES};
use crate::tracker::frame_record;
use crate::{Plate, Rng, SimulateError};

/// The bounds of the touches of each ball: a centre takes three, a fourth
/// is the first that checks them.
pub const TOUCHES_PER_BALL: Count = Count::new(
    4,
    1_000_000,
    "each touch costs a forward kinematics per iteration",
);
/// The largest polar angle of a touch from the top of its ball (degrees).
const CAP_ANGLE: f64 = 70.0;

/// What to simulate.
#[derive(Debug, Clone, PartialEq)]
pub struct DeltaScenario {
    /// The design (what the controller runs with, the priors' means).
    pub design: DeltaParams,
    /// The builder's tolerances (the priors' sigmas, and the spread of the
    /// true printer about the design).
    pub tolerances: Tolerances,
    /// The print radius: probes and parts within it (mm).
    pub print_radius: f64,
    /// Probe rings (the centre, then `per_ring` points on each).
    pub rings: usize,
    /// Probe points per ring.
    pub per_ring: usize,
    /// The probe's repeatability (mm).
    pub probe_sigma: f64,
    /// The trigger height's nominal value (mm, G31 Z).
    pub trigger_height: f64,
    /// Its prior sigma, and the spread of the true one (mm).
    pub trigger_sigma: f64,
    /// Part distances measured.
    pub distances: usize,
    /// Their standard deviation (mm).
    pub distance_sigma: f64,
    /// Heights measured by hand.
    pub manual_heights: usize,
    /// Their standard deviation (mm).
    pub height_sigma: f64,
    /// Point samples at unknown positions.
    pub unknown_samples: usize,
    /// Point samples at measured positions.
    pub known_samples: usize,
    /// The readings' standard deviation (mm).
    pub actuator_sigma: f64,
    /// A measured position's coordinate's standard deviation (mm).
    pub position_sigma: f64,
    /// Calibrated balls on the bed.
    pub balls: usize,
    /// Touches of each ball.
    pub touches_per_ball: usize,
    /// The balls' calibrated radius (mm).
    pub ball_radius: f64,
    /// Its calibration's standard deviation (mm); `None`: exact.
    pub ball_radius_sigma: Option<f64>,
    /// A touch's standard deviation along the ball's normal (mm).
    pub touch_sigma: f64,
    /// A ball plate over the balls (which pairs, each distance's
    /// standard deviation in mm); `None`: no distance between them.
    pub plate: Option<Plate>,
    /// Trackers, each placed anew (module doc).
    pub trackers: usize,
    /// Points each tracker measures.
    pub points_per_tracker: usize,
    /// A tracker's coordinate's standard deviation (mm).
    pub tracker_sigma: f64,
}

impl DeltaScenario {
    /// A kit printer ([`LinearDelta::typical`]'s design and tolerances)
    /// probed on 3 rings of 8 points (25 probes) within 100 mm at 10 µm,
    /// trigger height 0.7 ± 0.05 mm, no distance, no point sample and no
    /// ball (balls of 12.7 mm radius calibrated to 1 µm, touched 7 times
    /// each at 10 µm when asked for), no ball plate, no tracker (12
    /// points each at 10 µm when asked for).
    pub fn typical() -> Self {
        Self {
            design: DeltaParams::symmetric(270.0, 135.0, 300.0),
            tolerances: Tolerances::default(),
            print_radius: 100.0,
            rings: 3,
            per_ring: 8,
            probe_sigma: 0.01,
            trigger_height: 0.7,
            trigger_sigma: 0.05,
            distances: 0,
            distance_sigma: 0.02,
            manual_heights: 0,
            height_sigma: 0.05,
            unknown_samples: 0,
            known_samples: 0,
            actuator_sigma: 0.005,
            position_sigma: 0.01,
            balls: 0,
            touches_per_ball: 7,
            ball_radius: 12.7,
            ball_radius_sigma: Some(0.001),
            touch_sigma: 0.01,
            plate: None,
            trackers: 0,
            points_per_tracker: 12,
            tracker_sigma: 0.01,
        }
    }

    /// The delta of this scenario's design and tolerances.
    pub fn delta(&self) -> LinearDelta {
        let limits = Limits {
            print_radius: self.print_radius,
            ..*LinearDelta::typical().limits()
        };
        LinearDelta::new(&self.design, &self.tolerances, limits)
    }

    fn check(&self) -> Result<(), SimulateError> {
        let invalid = |what: &str| Err(SimulateError::Mechanism(what.to_string()));
        let refused = SimulateError::Mechanism;
        for (name, count) in [("rings", self.rings), ("probes per ring", self.per_ring)] {
            OBSERVATIONS.check(name, count).map_err(refused)?;
        }
        check_product(
            &[("rings", self.rings), ("probes per ring", self.per_ring)],
            OBSERVATIONS.max - 1,
            "probes, the most a mechanism dataset holds with the centre's",
        )
        .map_err(SimulateError::TooLarge)?;
        for (name, count) in [
            ("distances", self.distances),
            ("manual heights", self.manual_heights),
            ("point samples", self.unknown_samples + self.known_samples),
        ] {
            if count > 0 {
                OBSERVATIONS.check(name, count).map_err(refused)?;
            }
        }
        if self.balls > 0 {
            BALLS.check("balls", self.balls).map_err(refused)?;
            TOUCHES_PER_BALL
                .check("touches per ball", self.touches_per_ball)
                .map_err(refused)?;
            check_product(
                &[
                    ("balls", self.balls),
                    ("touches per ball", self.touches_per_ball),
                ],
                OBSERVATIONS.max,
                "touches, the most a mechanism dataset holds",
            )
            .map_err(SimulateError::TooLarge)?;
        }
        if self.trackers > 0 {
            TRACKERS.check("trackers", self.trackers).map_err(refused)?;
            check_product(
                &[
                    ("trackers", self.trackers),
                    ("points per tracker", self.points_per_tracker),
                ],
                OBSERVATIONS.max,
                "tracker points, the most a mechanism dataset holds",
            )
            .map_err(SimulateError::TooLarge)?;
            if self.points_per_tracker < 3 {
                return invalid("a tracker needs at least 3 points to locate its frame");
            }
        }
        if let Some(plate) = &self.plate {
            if self.balls == 0 {
                return invalid("a ball plate needs balls: its distances are between them");
            }
            BALL_DISTANCES
                .check(PLATE_DISTANCES, plate::size(plate, self.balls))
                .map_err(SimulateError::TooLarge)?;
        }
        let sigmas = [
            self.probe_sigma,
            self.trigger_sigma,
            self.distance_sigma,
            self.height_sigma,
            self.actuator_sigma,
            self.position_sigma,
            self.ball_radius,
            self.ball_radius_sigma.unwrap_or(1.0),
            self.touch_sigma,
            self.tracker_sigma,
        ];
        if sigmas.iter().any(|s| !(s.is_finite() && *s > 0.0)) {
            return invalid(
                "every standard deviation and the balls' radius must be finite and positive",
            );
        }
        if !(self.print_radius.is_finite() && self.print_radius > 0.0) {
            return invalid("the print radius must be finite and positive");
        }
        Ok(())
    }
}

/// The streams of the draws, one per kind, so that adding one kind of
/// measurement leaves the others' draws unchanged.
#[derive(Clone, Copy)]
enum Stream {
    Truth = 0,
    Probes = 1,
    Distances = 2,
    Samples = 3,
    Balls = 4,
    Trackers = 5,
    Heights = 6,
}

/// Simulates `scenario` with `seed` (module doc).
pub fn simulate_delta(
    scenario: &DeltaScenario,
    seed: u64,
) -> Result<MechanismDataset, SimulateError> {
    scenario.check()?;
    let delta = scenario.delta();
    let mut draw = Rng::new(seed, Stream::Truth as u64);
    let parameters: Vec<f64> = delta
        .parameters()
        .iter()
        .map(|p| p.design + draw.normal(p.prior_sigma))
        .collect();
    let trigger_height = scenario.trigger_height + draw.normal(scenario.trigger_sigma);
    let truth = MechanismTruth {
        parameters,
        trigger_height: Some(trigger_height),
        trackers: BTreeMap::new(),
    };
    measure_delta(scenario, &truth, seed)
}

/// The measurements of `scenario` made with seed `seed` on the printer
/// `truth` (its true parameters and trigger height): held-out data of a
/// machine already simulated, or of one changed on purpose.
pub fn measure_delta(
    scenario: &DeltaScenario,
    truth: &MechanismTruth,
    seed: u64,
) -> Result<MechanismDataset, SimulateError> {
    scenario.check()?;
    let delta = scenario.delta();
    let configured: Vec<f64> = scenario.design.to_vector().iter().copied().collect();
    let rng = |stream: Stream| Rng::new(seed, stream as u64);
    let mut truth_record = truth.clone();
    let trigger = truth.trigger_height.ok_or_else(|| {
        SimulateError::Mechanism("the true printer has no trigger height".to_string())
    })?;
    let truth = truth.parameters.clone();
    parcal_kinematics::mechanism::check_params(&delta, &truth)
        .map_err(|e| SimulateError::Mechanism(format!("the true printer: {e}")))?;
    let failed = |what: String| SimulateError::Mechanism(what);

    let mut noise = rng(Stream::Probes);
    let probes = probe_rings(scenario.print_radius, scenario.rings, scenario.per_ring)
        .into_iter()
        .enumerate()
        .map(|(k, [x, y])| {
            let target = trigger + noise.normal(scenario.probe_sigma);
            let z = trigger_height_command(&delta, &truth, &configured, [x, y], target)
                .map_err(|e| failed(format!("probe {k}: {e}")))?;
            Ok([x, y, z])
        })
        .collect::<Result<Vec<_>, SimulateError>>()?;

    let mut noise = rng(Stream::Distances);
    let distances = (0..scenario.distances)
        .map(|k| {
            let angle = std::f64::consts::PI * (k as f64 + 0.5) / scenario.distances as f64;
            let r = 0.8 * scenario.print_radius;
            let first = [r * angle.cos(), r * angle.sin(), FIRST_LAYER];
            let second = [-first[0], -first[1], FIRST_LAYER];
            let reached = |c: &[f64; 3]| {
                let q = delta.inverse(&configured, c)?;
                delta.forward(&truth, q.as_slice(), c)
            };
            let (a, b) = (reached(&first), reached(&second));
            let (a, b) = a
                .and_then(|a| Ok((a, b?)))
                .map_err(|e| failed(format!("distance {k}: {e}")))?;
            let d = (a - b).norm() + noise.normal(scenario.distance_sigma);
            Ok([
                first[0], first[1], first[2], second[0], second[1], second[2], d,
            ])
        })
        .collect::<Result<Vec<_>, SimulateError>>()?;

    let mut noise = rng(Stream::Heights);
    let heights = manual_height_positions(scenario.print_radius, scenario.manual_heights)
        .into_iter()
        .enumerate()
        .map(|(k, commanded)| {
            let reached = delta
                .inverse(&configured, &commanded)
                .and_then(|q| delta.forward(&truth, q.as_slice(), &commanded))
                .map_err(|e| failed(format!("manual height {k}: {e}")))?;
            let [x, y, z] = commanded;
            Ok([x, y, z, reached[2] + noise.normal(scenario.height_sigma)])
        })
        .collect::<Result<Vec<_>, SimulateError>>()?;

    let mut noise = rng(Stream::Samples);
    let total = scenario.known_samples + scenario.unknown_samples;
    let samples = (0..total)
        .map(|k| {
            let r = scenario.print_radius * noise.unit().sqrt();
            let angle = noise.uniform(0.0, 2.0 * std::f64::consts::PI);
            let pose = [r * angle.cos(), r * angle.sin(), noise.uniform(0.0, 150.0)];
            let q = delta
                .inverse(&truth, &pose)
                .map_err(|e| failed(format!("point sample {k}: {e}")))?;
            let readings = q
                .iter()
                .map(|q| q + noise.normal(scenario.actuator_sigma))
                .collect();
            let position = (k < scenario.known_samples)
                .then(|| pose.map(|x| x + noise.normal(scenario.position_sigma)));
            Ok(SampleRow {
                readings,
                position,
                loads: None,
            })
        })
        .collect::<Result<Vec<_>, SimulateError>>()?;

    let TouchedBalls {
        balls,
        touches,
        centres,
    } = touch_balls(
        scenario,
        &delta,
        &truth,
        &configured,
        &mut rng(Stream::Balls),
    )?;
    let ball_distances = match &scenario.plate {
        Some(plate) => plate::distances(plate, &centres, seed)?,
        None => Vec::new(),
    };
    let (tracker_points, tracker_frames) = track(
        scenario,
        &delta,
        &truth,
        &configured,
        &mut rng(Stream::Trackers),
    )?;
    truth_record.trackers = tracker_frames;

    let machine = MechanismMachine {
        noise: Noise {
            probe: Some(scenario.probe_sigma),
            distance: (!distances.is_empty()).then_some(scenario.distance_sigma),
            actuator: (!samples.is_empty()).then_some(scenario.actuator_sigma),
            position: (scenario.known_samples > 0).then_some(scenario.position_sigma),
            touch: (!touches.is_empty()).then_some(scenario.touch_sigma),
            tracker: (!tracker_points.is_empty()).then_some(scenario.tracker_sigma),
            height: (!heights.is_empty()).then_some(scenario.height_sigma),
        },
        trigger_height: Some(ValuePrior {
            value: scenario.trigger_height,
            sigma: Some(scenario.trigger_sigma),
        }),
        print_radius: Some(scenario.print_radius),
        ..MechanismMachine::stating_tolerances(&delta)
    };
    Ok(MechanismDataset {
        machine,
        probes,
        heights,
        distances,
        samples,
        quantities: Vec::new(),
        balls,
        touches,
        ball_distances,
        tracker_points,
        truth: Some(truth_record),
    })
}

/// Where `count` heights are measured by hand within the print radius
/// `print_radius` (module doc): the commanded positions, the first at the
/// centre, the others evenly on a ring at 0.6 of the print radius from
/// +x, the nozzle over a gauge block ([`GAUGE_BLOCK`]).
pub fn manual_height_positions(print_radius: f64, count: usize) -> Vec<[f64; 3]> {
    let around = count.saturating_sub(1) as f64;
    let r = 0.6 * print_radius;
    (0..count)
        .map(|k| {
            if k == 0 {
                return [0.0, 0.0, GAUGE_BLOCK];
            }
            let angle = 2.0 * std::f64::consts::PI * (k - 1) as f64 / around;
            [r * angle.cos(), r * angle.sin(), GAUGE_BLOCK]
        })
        .collect()
}

/// The trackers of `scenario` measuring the printer of true parameters
/// `truth` run with `configured`, drawing from `draw` (module doc): their
/// points, and each one's true frame by its label.
fn track(
    scenario: &DeltaScenario,
    delta: &LinearDelta,
    truth: &[f64],
    configured: &[f64],
    draw: &mut Rng,
) -> Result<(Vec<TrackerPointRow>, BTreeMap<String, FrameRecord>), SimulateError> {
    let tau = 2.0 * std::f64::consts::PI;
    let mut rows = Vec::with_capacity(scenario.trackers * scenario.points_per_tracker);
    let mut frames = BTreeMap::new();
    for tracker in 0..scenario.trackers {
        let label = format!("T{}", tracker + 1);
        let (bearing, distance) = (draw.uniform(0.0, tau), draw.uniform(1500.0, 2500.0));
        let frame = Isometry3::new(
            Vector3::new(
                distance * bearing.cos(),
                distance * bearing.sin(),
                draw.uniform(-300.0, 300.0),
            ),
            Vector3::new(
                draw.uniform(-0.1, 0.1),
                draw.uniform(-0.1, 0.1),
                draw.uniform(0.0, tau),
            ),
        );
        for k in 0..scenario.points_per_tracker {
            let r = scenario.print_radius * draw.unit().sqrt();
            let angle = draw.uniform(0.0, tau);
            let commanded = [r * angle.cos(), r * angle.sin(), draw.uniform(0.0, 150.0)];
            let reached = delta
                .inverse(configured, &commanded)
                .and_then(|q| delta.forward(truth, q.as_slice(), &commanded))
                .map_err(|e| {
                    SimulateError::Mechanism(format!("point {k} of tracker {tracker}: {e}"))
                })?;
            let seen = frame.transform_point(&Point3::new(reached[0], reached[1], reached[2]));
            rows.push(TrackerPointRow {
                tracker: label.clone(),
                commanded,
                measured: std::array::from_fn(|i| seen[i] + draw.normal(scenario.tracker_sigma)),
            });
        }
        frames.insert(label, frame_record(&frame));
    }
    Ok((rows, frames))
}

/// Calibrated balls on the bed, touched.
struct TouchedBalls {
    /// The balls as calibrated.
    balls: Vec<BallRow>,
    /// Their touches.
    touches: Vec<TouchRow>,
    /// Their true centres (mm, the bed's frame).
    centres: Vec<Vec3>,
}

/// The balls of `scenario` and their touches by the printer of true
/// parameters `truth` run with `configured`, drawing from `noise` (module
/// doc).
fn touch_balls(
    scenario: &DeltaScenario,
    delta: &LinearDelta,
    truth: &[f64],
    configured: &[f64],
    noise: &mut Rng,
) -> Result<TouchedBalls, SimulateError> {
    let (b_count, k_count) = (scenario.balls, scenario.touches_per_ball);
    let mut balls = Vec::with_capacity(b_count);
    let mut touches = Vec::with_capacity(b_count * k_count);
    let mut centres = Vec::with_capacity(b_count);
    let golden = std::f64::consts::PI * (3.0 - 5.0f64.sqrt());
    let lowest = CAP_ANGLE.to_radians().cos();
    for ball in 0..b_count {
        let angle = 2.0 * std::f64::consts::PI * ball as f64 / b_count as f64;
        let ring = 0.6 * scenario.print_radius;
        let radius = scenario.ball_radius
            + scenario
                .ball_radius_sigma
                .map_or(0.0, |sigma| noise.normal(sigma));
        let centre = [ring * angle.cos(), ring * angle.sin(), radius];
        centres.push(Vec3::from(centre));
        balls.push(BallRow {
            radius: scenario.ball_radius,
            radius_sigma: scenario.ball_radius_sigma,
            placement: None,
        });
        for k in 0..k_count {
            let polar = (1.0 - (1.0 - lowest) * (k as f64 + 0.5) / k_count as f64).acos();
            let azimuth = golden * k as f64;
            let u = [
                polar.sin() * azimuth.cos(),
                polar.sin() * azimuth.sin(),
                polar.cos(),
            ];
            let distance = radius + noise.normal(scenario.touch_sigma);
            let point: [f64; 3] = std::array::from_fn(|i| centre[i] + distance * u[i]);
            let commanded = delta
                .inverse(truth, &point)
                .and_then(|q| delta.forward(configured, q.as_slice(), &point))
                .map_err(|e| SimulateError::Mechanism(format!("touch {k} of ball {ball}: {e}")))?;
            touches.push(TouchRow {
                ball,
                commanded: [commanded[0], commanded[1], commanded[2]],
            });
        }
    }
    Ok(TouchedBalls {
        balls,
        touches,
        centres,
    })
}

/// The commanded height at `(x, y)` at which the machine of true
/// parameters `truth`, run with `configured`, has its effector `target`
/// above the bed (module doc).
fn trigger_height_command(
    delta: &LinearDelta,
    truth: &[f64],
    configured: &[f64],
    [x, y]: [f64; 2],
    target: f64,
) -> Result<f64, String> {
    let mut z = target;
    for _ in 0..50 {
        let q = delta
            .inverse(configured, &[x, y, z])
            .map_err(|e| e.to_string())?;
        let height = delta
            .forward(truth, q.as_slice(), &[x, y, z])
            .map_err(|e| e.to_string())?[2];
        let error = height - target;
        z -= error;
        if error.abs() < 1e-12 {
            return Ok(z);
        }
    }
    Err(format!("the probe at ({x:.3}, {y:.3}) does not settle"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_simulation_is_a_function_of_its_seed_and_reads_back() {
        let scenario = DeltaScenario {
            distances: 3,
            unknown_samples: 2,
            known_samples: 1,
            ..DeltaScenario::typical()
        };
        let a = simulate_delta(&scenario, 7).unwrap();
        assert_eq!(a, simulate_delta(&scenario, 7).unwrap());
        assert_ne!(a, simulate_delta(&scenario, 8).unwrap());
        assert_eq!(
            (a.probes.len(), a.distances.len(), a.samples.len()),
            (25, 3, 3)
        );
        assert!(a.samples[0].position.is_some() && a.samples[1].position.is_none());
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("delta");
        a.write(&path).unwrap();
        assert_eq!(MechanismDataset::read(&path).unwrap(), a);
        let bad = DeltaScenario {
            rings: 0,
            ..DeltaScenario::typical()
        };
        let error = simulate_delta(&bad, 1).unwrap_err().to_string();
        assert!(error.contains("rings"), "{error}");
    }

    #[test]
    fn the_truth_holds_each_trackers_frame() {
        // Two trackers of 12 points at 10 um: truth.json gives each one's
        // frame, which takes the true tool point at each commanded
        // position to the point measured within 6 sigma a coordinate;
        // written and read back.
        let scenario = DeltaScenario {
            trackers: 2,
            ..DeltaScenario::typical()
        };
        let dataset = simulate_delta(&scenario, 5).unwrap();
        let truth = dataset.truth.as_ref().unwrap();
        let labels: Vec<&String> = truth.trackers.keys().collect();
        assert_eq!(labels, ["T1", "T2"]);
        let delta = scenario.delta();
        let configured: Vec<f64> = scenario.design.to_vector().iter().copied().collect();
        for row in &dataset.tracker_points {
            let frame = truth.trackers[&row.tracker].isometry();
            let q = delta.inverse(&configured, &row.commanded).unwrap();
            let x = delta
                .forward(&truth.parameters, q.as_slice(), &row.commanded)
                .unwrap();
            let seen = frame.transform_point(&Point3::new(x[0], x[1], x[2]));
            for k in 0..3 {
                let miss = (seen[k] - row.measured[k]).abs();
                assert!(
                    miss < 6.0 * scenario.tracker_sigma,
                    "{}: {miss}",
                    row.tracker
                );
            }
        }
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("tracked");
        dataset.write(&path).unwrap();
        assert_eq!(MechanismDataset::read(&path).unwrap(), dataset);
    }

    #[test]
    fn a_ball_plate_measures_the_true_centres_and_changes_nothing_else() {
        let plain = DeltaScenario {
            balls: 5,
            ..DeltaScenario::typical()
        };
        let plated = DeltaScenario {
            plate: Some(Plate {
                pairs: crate::PlatePairs::All,
                sigma: 0.001,
            }),
            ..plain.clone()
        };
        let without = simulate_delta(&plain, 3).unwrap();
        let with = simulate_delta(&plated, 3).unwrap();
        assert!(without.ball_distances.is_empty());
        assert_eq!(
            MechanismDataset {
                ball_distances: Vec::new(),
                ..with.clone()
            },
            without
        );
        // The true centres, drawn again from the balls' stream.
        let truth = &with.truth.as_ref().unwrap().parameters;
        let configured: Vec<f64> = plain.design.to_vector().iter().copied().collect();
        let mut noise = Rng::new(3, Stream::Balls as u64);
        let centres = touch_balls(&plain, &plain.delta(), truth, &configured, &mut noise)
            .unwrap()
            .centres;
        let pairs: Vec<_> = with.ball_distances.iter().map(|d| (d.a, d.b)).collect();
        let all: Vec<_> = (0..5)
            .flat_map(|a| (a + 1..5).map(move |b| (a, b)))
            .collect();
        assert_eq!(pairs, all);
        for d in &with.ball_distances {
            let error = d.length - (centres[d.a] - centres[d.b]).norm();
            assert!(error.abs() < 5.0 * d.sigma, "{d:?}: {error}");
            assert_eq!(d.sigma, 0.001);
        }
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("plated");
        with.write(&path).unwrap();
        assert_eq!(MechanismDataset::read(&path).unwrap(), with);
        let unballed = DeltaScenario { balls: 0, ..plated };
        let error = simulate_delta(&unballed, 3).unwrap_err().to_string();
        assert!(error.contains("a ball plate needs balls"), "{error}");
    }
}
