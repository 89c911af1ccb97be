//! Simulation of one campaign: contacts, actuator readings with noise, and
//! the forward-kinematics check of every contact.

use nalgebra::{Matrix3, Matrix6, Translation3, UnitQuaternion};
use parcal_dataset::{
    Actuator, ArtefactFrame, Artefacts, Ball, Dataset, GeometryRecord, Machine, Measurements,
    PriorSigma, Repeatability, SessionModel, Tracker, Truth,
};
use parcal_kinematics::{
    ForwardOptions, Geometry, Pose, Vec3, actuators, forward_from_home, rotation_zyx, tip_jacobians,
};
use rayon::prelude::*;

use crate::{PlannedTouch, Rng, Scenario, SimulateError, plate};

/// A contact is accepted when the tool tip found by forward kinematics from
/// the actuator readings is back on its simulated point within this many
/// standard deviations of the noise (Mahalanobis distance; the chi-square(3)
/// tail probability of 8 sigma is ~1e-13).
const CHECK_SIGMAS: f64 = 8.0;

/// One simulated contact.
struct Contact {
    /// The true contact point `C_i + r u` (design frame).
    point: Vec3,
    /// Actuator readings with noise (actuators' unit).
    q: [f64; 6],
    /// Leg lengths `l_i + s_i q_i` of the true machine (true scales).
    legs: [f64; 6],
    /// Tilt of the platform: angle between its z axis and the base's (rad).
    tilt: f64,
    /// Mahalanobis distance of the forward-kinematics tip from `point`.
    check: f64,
}

/// The summary a person reads after a simulation.
#[derive(Debug, Clone, PartialEq)]
pub struct Summary {
    /// Number of balls.
    pub balls: usize,
    /// Number of contacts (measurement rows).
    pub contacts: usize,
    /// Number of instrument sessions.
    pub sessions: usize,
    /// Number of rows of poses.csv.
    pub poses: usize,
    /// Number of rows of points.csv.
    pub points: usize,
    /// Smallest and largest true leg length (mm).
    pub leg_length_range: (f64, f64),
    /// Smallest and largest platform tilt (rad).
    pub tilt_range: (f64, f64),
    /// Largest Mahalanobis distance of a forward-kinematics tip from its
    /// simulated contact point (in units of the noise); 0 without contacts.
    pub worst_check: f64,
}

/// A simulated dataset and its summary.
pub struct Simulation {
    /// The dataset, truth included.
    pub dataset: Dataset,
    /// What a person reads about it.
    pub summary: Summary,
}

/// Ball ids `b01`, `b02`, ... zero-padded to the width of the largest.
pub fn ball_id(index: usize, count: usize) -> String {
    let width = count.to_string().len().max(2);
    format!("b{:0width$}", index + 1)
}

/// Simulates the campaign `scenario` with random stream `seed`: for each
/// ball (stream `(seed, ball)`) a calibrated radius `r + N(0, radius_sigma)`,
/// then per contact a direction `u` uniform on the lower hemisphere, the
/// platform orientation `Rz(yaw) Ry(pitch) Rx(roll)` with angles uniform in
/// `[-max_tilt, max_tilt]` (or the planned `u` and orientation of the
/// scenario's plan, ball by ball in plan order), the tool tip at `C + r u` plus tool noise, and
/// actuator readings `q = (L_true - l_true) / s_true` plus actuator noise
/// (`s_true`: the true scales of [`Scenario::readings`]). Every contact
/// is checked by forward kinematics with the true geometry; balls a plan
/// leaves untouched are left out of the dataset. A ball plate, if
/// the scenario has one, draws from a stream of its own (see
/// [`Plate`](crate::Plate)): the contacts are the same without it.
pub fn simulate(scenario: &Scenario, seed: u64) -> Result<Simulation, SimulateError> {
    match &scenario.plan {
        Some(plan) => crate::check_rows(&[("planned touches", plan.len())])?,
        None => crate::check_rows(&[
            ("balls", scenario.centres.len()),
            ("contacts per ball", scenario.points_per_ball),
        ])?,
    };
    if let Some(p) = &scenario.plate {
        plate::check_size(p, scenario.centres.len())?;
    }
    if let Some(touch) = scenario
        .plan
        .iter()
        .flatten()
        .find(|t| t.ball >= scenario.centres.len())
    {
        return Err(SimulateError::Scenario(format!(
            "a planned touch names ball {} of {}",
            touch.ball + 1,
            scenario.centres.len()
        )));
    }
    let per_ball: Vec<Result<(f64, Vec<Contact>), SimulateError>> = scenario
        .centres
        .par_iter()
        .enumerate()
        .map(|(ball, centre)| simulate_ball(scenario, seed, ball, centre))
        .collect();
    // The first failing ball in order, whatever the threads' timing (a
    // parallel collect into a `Result` returns whichever error came first).
    let per_ball: Vec<(f64, Vec<Contact>)> = per_ball.into_iter().collect::<Result<_, _>>()?;

    let count = scenario.centres.len();
    // A plan may leave balls untouched: the dataset holds only the others
    // (the reader wants every ball touched), under their scenario ids.
    let kept: Vec<usize> = (0..count)
        .filter(|&b| scenario.plan.is_none() || !per_ball[b].1.is_empty())
        .collect();
    let contacts: Vec<&Contact> = kept.iter().flat_map(|&b| &per_ball[b].1).collect();
    let range = |values: &mut dyn Iterator<Item = f64>| {
        values.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
            (lo.min(v), hi.max(v))
        })
    };
    let summary = Summary {
        balls: kept.len(),
        contacts: contacts.len(),
        sessions: 0,
        poses: 0,
        points: 0,
        leg_length_range: range(&mut contacts.iter().flat_map(|c| c.legs)),
        tilt_range: range(&mut contacts.iter().map(|c| c.tilt)),
        worst_check: contacts.iter().map(|c| c.check).fold(0.0, f64::max),
    };

    let balls = kept
        .iter()
        .map(|&index| Ball {
            id: ball_id(index, count),
            centre: scenario.centres[index].into(),
            centre_sigma: scenario.centre_sigma,
            radius: per_ball[index].0,
            radius_sigma: scenario.radius_sigma,
        })
        .collect();
    let mut position = vec![None; count];
    for (new, &old) in kept.iter().enumerate() {
        position[old] = Some(new);
    }
    let distances = match &scenario.plate {
        Some(p) => plate::distances(p, &scenario.centres, seed)?
            .into_iter()
            .filter_map(|d| {
                Some(parcal_dataset::Distance {
                    a: position[d.a]?,
                    b: position[d.b]?,
                    ..d
                })
            })
            .collect(),
        None => Vec::new(),
    };
    let ball_of_contact = kept
        .iter()
        .enumerate()
        .flat_map(|(b, &old)| std::iter::repeat_n(b as u32, per_ball[old].1.len()));
    let dataset = Dataset {
        machine: machine(scenario),
        artefacts: Artefacts {
            frame: ArtefactFrame::Design,
            balls,
            distances,
        },
        measurements: Measurements {
            ball: ball_of_contact.collect(),
            q: contacts.iter().map(|c| c.q).collect(),
            direction: None,
        },
        truth: Some(Truth {
            geometry: record(&scenario.truth),
            ball_centres: kept.iter().map(|&b| scenario.centres[b].into()).collect(),
            ball_radii: vec![scenario.radius; kept.len()],
            contacts: contacts.iter().map(|c| c.point.into()).collect(),
            actuator_scale: (!scenario.readings.is_default())
                .then_some(scenario.readings.true_scale),
            sessions: Vec::new(),
        }),
        tracker: Tracker::default(),
    };
    Ok(Simulation { dataset, summary })
}

/// machine.json of a scenario: the design geometry and the conditions.
fn machine(scenario: &Scenario) -> Machine {
    let sigma = scenario.prior_sigma;
    Machine {
        geometry: record(&scenario.design),
        prior_sigma: PriorSigma {
            base: sigma,
            platform: sigma,
            tool: sigma,
            leg: sigma,
        },
        repeatability: Repeatability {
            actuator: scenario.actuator_sigma,
            tool: scenario.tool_sigma,
            position: None,
            orientation: None,
        },
        actuator: Actuator {
            unit: scenario.readings.unit.clone(),
            scale: scenario.readings.design_scale,
            scale_sigma: scenario.readings.scale_sigma,
        },
        session_model: SessionModel::default(),
        stroke: scenario.stroke,
        joint_limits: None,
    }
}

/// A geometry as the dataset files hold it.
pub(crate) fn record(geometry: &Geometry) -> GeometryRecord {
    GeometryRecord {
        base_joints: geometry.base.map(Into::into),
        platform_joints: geometry.platform.map(Into::into),
        tool: geometry.tool.into(),
        leg_lengths: geometry.legs,
    }
}

/// The calibrated radius and the contacts of one ball.
fn simulate_ball(
    scenario: &Scenario,
    seed: u64,
    ball: usize,
    centre: &Vec3,
) -> Result<(f64, Vec<Contact>), SimulateError> {
    let mut rng = Rng::new(seed, ball as u64);
    let calibrated_radius = scenario.radius + rng.normal(scenario.radius_sigma);
    let error = |point: usize| {
        move |reason| SimulateError::Contact {
            ball: ball + 1,
            point: point + 1,
            reason,
        }
    };
    let contacts = match &scenario.plan {
        None => (0..scenario.points_per_ball)
            .map(|point| {
                let (u, rotation) = random_touch(scenario, &mut rng);
                simulate_contact(scenario, &mut rng, centre, &u, rotation).map_err(error(point))
            })
            .collect::<Result<_, _>>()?,
        Some(plan) => plan
            .iter()
            .filter(|touch| touch.ball == ball)
            .enumerate()
            .map(|(point, touch)| {
                simulate_contact(scenario, &mut rng, centre, &touch.direction, touch.rotation)
                    .map_err(error(point))
            })
            .collect::<Result<_, _>>()?,
    };
    Ok((calibrated_radius, contacts))
}

/// A random design: `points_per_ball` touches of every ball drawn as
/// [`simulate`] draws them (`u` uniform on the lower hemisphere, angles
/// uniform in `[-max_tilt, max_tilt]`), from stream `seed` alone. As the
/// scenario's plan it fixes the design, so that simulations over seeds
/// differ by their noise only.
pub fn random_plan(scenario: &Scenario, seed: u64) -> Vec<PlannedTouch> {
    let mut rng = Rng::new(seed, u64::MAX);
    let mut plan = Vec::with_capacity(scenario.centres.len() * scenario.points_per_ball);
    for ball in 0..scenario.centres.len() {
        for _ in 0..scenario.points_per_ball {
            let (direction, rotation) = random_touch(scenario, &mut rng);
            plan.push(PlannedTouch {
                ball,
                direction,
                rotation,
            });
        }
    }
    plan
}

/// A random touch (docs/paper-scenario.md section 3): `u` uniform on the lower hemisphere,
/// the orientation's angles uniform in `[-max_tilt, max_tilt]`.
fn random_touch(scenario: &Scenario, rng: &mut Rng) -> (Vec3, UnitQuaternion<f64>) {
    let u_z = -rng.unit();
    let azimuth = rng.uniform(0.0, std::f64::consts::TAU);
    let horizontal = (1.0 - u_z * u_z).sqrt();
    let u = Vec3::new(horizontal * azimuth.cos(), horizontal * azimuth.sin(), u_z);
    let tilt = scenario.max_tilt;
    let [yaw, pitch, roll] = [(); 3].map(|()| rng.uniform(-tilt, tilt));
    (u, rotation_zyx(yaw, pitch, roll))
}

/// The touch of direction `u` at orientation `rotation`: the true tip at
/// `C + r u` plus tool noise, the true machine's readings (true scales)
/// plus actuator noise, checked by forward kinematics.
fn simulate_contact(
    scenario: &Scenario,
    rng: &mut Rng,
    centre: &Vec3,
    u: &Vec3,
    rotation: UnitQuaternion<f64>,
) -> Result<Contact, String> {
    let truth = &scenario.truth;
    let point = centre + scenario.radius * u;
    let tool_noise = Vec3::from_fn(|_, _| rng.normal(scenario.tool_sigma));
    let tip = point + tool_noise;
    let pose = Pose::from_parts(Translation3::from(tip - rotation * truth.tool), rotation);

    let scale = &scenario.readings.true_scale;
    let exact = actuators(truth, &pose);
    let q: [f64; 6] =
        std::array::from_fn(|i| exact[i] / scale[i] + rng.normal(scenario.actuator_sigma));
    let extensions = std::array::from_fn(|i| scale[i] * q[i]);
    let legs = std::array::from_fn(|i| truth.legs[i] + extensions[i]);
    let check = check_contact(truth, scenario, &extensions, &point)?;
    let z_axis = rotation * Vec3::z();
    Ok(Contact {
        point,
        q,
        legs,
        tilt: z_axis.z.clamp(-1.0, 1.0).acos(),
        check,
    })
}

/// Forward kinematics of the true machine from its home pose at the leg
/// extensions `extensions` (mm): the Mahalanobis distance of the tip from
/// the simulated contact point under the noise covariance
/// `s_t^2 I + s_a^2 J_q S² J_q^T` (`S`: the true scales, `s_a` in the
/// actuators' unit); refuses a contact beyond [`CHECK_SIGMAS`] or where
/// forward kinematics fails.
fn check_contact(
    truth: &Geometry,
    scenario: &Scenario,
    extensions: &[f64; 6],
    point: &Vec3,
) -> Result<f64, String> {
    let solution = forward_from_home(truth, extensions, &ForwardOptions::default())
        .map_err(|e| e.to_string())?;
    let scale = Matrix6::from_diagonal(&scenario.readings.true_scale.into());
    let d_q = tip_jacobians(truth, &solution).d_q * scale;
    let covariance = Matrix3::identity() * scenario.tool_sigma.powi(2)
        + d_q * d_q.transpose() * scenario.actuator_sigma.powi(2);
    let error = truth.tool_tip(&solution.pose) - point;
    let distance = covariance
        .cholesky()
        .map(|c| error.dot(&c.solve(&error)).sqrt())
        .ok_or_else(|| "the noise covariance is not positive definite".to_string())?;
    if distance > CHECK_SIGMAS {
        return Err(format!(
            "forward kinematics puts the tool tip {:.4} mm ({distance:.1} sigma) from the simulated contact",
            error.norm()
        ));
    }
    Ok(distance)
}
