//! Simulated instrument campaigns against their model (module doc of
//! `tracker.rs`): readings from the true geometry, scales and session
//! nuisance, the noise's size, and the dataset files.

use nalgebra::{DMatrix, DVector, Point3, Quaternion, Translation3, UnitQuaternion, Vector6};
use parcal_dataset::{Dataset, FrameRecord, SessionModel};
use parcal_kinematics::{ForwardOptions, Geometry, Pose, Vec3, forward_from_home, leg_lengths};
use parcal_simulate::{SimulateError, TrackerKind, TrackerScenario, simulate_tracker};

fn pose(frame: &FrameRecord) -> Pose {
    let [x, y, z, w] = frame.rotation;
    Pose::from_parts(
        Translation3::from(Vec3::from(frame.translation)),
        UnitQuaternion::from_quaternion(Quaternion::new(w, x, y, z)),
    )
}

fn measured_pose(position: &[f64; 3], orientation: &[f64; 4]) -> Pose {
    pose(&FrameRecord {
        translation: *position,
        rotation: *orientation,
    })
}

/// The true model of one session: geometry, scales, frames, offsets.
struct Model {
    truth: Geometry,
    scale: [f64; 6],
    tracker: Vec<Pose>,
    body: Vec<Pose>,
    offsets: Vec<[f64; 6]>,
}

impl Model {
    fn of(dataset: &Dataset) -> Self {
        let truth = dataset.truth.as_ref().unwrap();
        let g = &truth.geometry;
        Self {
            truth: Geometry::from_arrays(
                &g.base_joints,
                &g.platform_joints,
                &g.tool,
                &g.leg_lengths,
            ),
            scale: truth.actuator_scale.unwrap(),
            tracker: truth
                .sessions
                .iter()
                .map(|s| pose(&s.tracker_frame))
                .collect(),
            body: truth.sessions.iter().map(|s| pose(&s.body_frame)).collect(),
            offsets: truth.sessions.iter().map(|s| s.leg_offsets).collect(),
        }
    }

    /// The platform pose `T = F^-1 M B^-1` of a measured body pose `M`.
    fn platform(&self, k: usize, measured: &Pose) -> Pose {
        self.tracker[k].inverse() * measured * self.body[k].inverse()
    }

    /// Readings `q_i = (L_i - l_i - o_i) / s_i` at platform pose `pose`.
    fn readings(&self, k: usize, pose: &Pose) -> [f64; 6] {
        let lengths = leg_lengths(&self.truth, pose);
        std::array::from_fn(|i| {
            (lengths[i] - self.truth.legs[i] - self.offsets[k][i]) / self.scale[i]
        })
    }

    /// The tool tip in the instrument frame, by forward kinematics from
    /// readings `q`.
    fn tip(&self, k: usize, q: &[f64; 6]) -> Vec3 {
        let shifted = Geometry {
            legs: std::array::from_fn(|i| self.truth.legs[i] + self.offsets[k][i]),
            ..self.truth.clone()
        };
        let extension = std::array::from_fn(|i| self.scale[i] * q[i]);
        let solution = forward_from_home(&shifted, &extension, &ForwardOptions::default()).unwrap();
        (self.tracker[k] * solution.pose * Point3::from(self.truth.tool)).coords
    }
}

/// The paper-like scenario without noise, re-homed and with a re-mounted
/// marker body between sessions.
fn noiseless() -> TrackerScenario {
    TrackerScenario {
        actuator_sigma: 0.0,
        position_sigma: 0.0,
        orientation_sigma: 0.0,
        session_model: SessionModel {
            leg_offset_sigma: Some(1.0),
            body_origin_sigma: Some(0.5),
            body_rotation_sigma: None,
        },
        ..TrackerScenario::paper_like()
    }
}

#[test]
fn a_seed_gives_the_same_dataset() {
    let scenario = TrackerScenario::paper_like();
    let a = simulate_tracker(&scenario, 4).unwrap().dataset;
    assert_eq!(simulate_tracker(&scenario, 4).unwrap().dataset, a);
    assert_ne!(simulate_tracker(&scenario, 5).unwrap().dataset, a);
}

#[test]
fn noiseless_readings_are_the_true_inverse_kinematics() {
    let scenario = noiseless();
    let simulation = simulate_tracker(&scenario, 2).unwrap();
    let dataset = &simulation.dataset;
    let model = Model::of(dataset);
    let poses = &dataset.tracker.poses;
    assert_eq!(poses.len(), 150);
    let [low, high] = scenario.stroke;
    for row in 0..poses.len() {
        let k = poses.session[row] as usize;
        let measured = measured_pose(&poses.position[row], &poses.orientation[row]);
        let platform = model.platform(k, &measured);
        let q = model.readings(k, &platform);
        for (i, (q, written)) in q.iter().zip(&poses.q[row]).enumerate() {
            assert!((q - written).abs() < 1e-9, "pose {row}, q{}", i + 1);
            let extension = model.scale[i] * q;
            assert!(
                (low..=high).contains(&extension),
                "pose {row}, leg {}",
                i + 1
            );
        }
        let t = platform.translation.vector;
        let w = &scenario.workspace;
        assert!(t.x.abs() <= w.half_width + 1e-9 && t.y.abs() <= w.half_width + 1e-9);
        assert!((w.height[0] - 1e-9..=w.height[1] + 1e-9).contains(&t.z));
    }
    // Points: forward kinematics of the true model from the readings puts
    // the tool tip on the written point (Newton stops at closure residuals
    // below 1e-10 mm, which moves the tip by ~1e-10 mm times the closure
    // Jacobian's inverse: far below 1e-8 mm).
    let points = &dataset.tracker.points;
    assert_eq!(points.len(), 150);
    for row in 0..points.len() {
        let k = points.session[row] as usize;
        let error = model.tip(k, &points.q[row]) - Vec3::from(points.position[row]);
        assert!(error.norm() < 1e-8, "point {row}: {error}");
    }
}

#[test]
fn the_noise_has_the_size_of_the_repeatability() {
    // The readings' residual r = q - q(T) at the platform pose T of the
    // noisy measured pose is e_q - J_p e_p - J_o e_o to first order, so
    // d^2 = r^T C^-1 r with C = s_q^2 I + s_p^2 J_p J_p^T + s_o^2 J_o J_o^T
    // is chi-square with 6 degrees of freedom. Over the 150 poses the mean
    // of d^2 / 6 is 1 with standard deviation sqrt(2 / 900) = 0.047.
    let scenario = TrackerScenario::paper_like();
    let dataset = simulate_tracker(&scenario, 6).unwrap().dataset;
    let model = Model::of(&dataset);
    let poses = &dataset.tracker.poses;
    let (s_q, s_p, s_o) = (
        scenario.actuator_sigma,
        scenario.position_sigma,
        scenario.orientation_sigma,
    );
    let mut sum = 0.0;
    for row in 0..poses.len() {
        let k = poses.session[row] as usize;
        let measured = measured_pose(&poses.position[row], &poses.orientation[row]);
        let readings = |d: &Vector6<f64>| {
            let moved = Pose::from_parts(
                Translation3::from(measured.translation.vector + d.fixed_rows::<3>(0)),
                UnitQuaternion::from_scaled_axis(d.fixed_rows::<3>(3).into_owned())
                    * measured.rotation,
            );
            DVector::from_row_slice(&model.readings(k, &model.platform(k, &moved)))
        };
        let h = 1e-5;
        let jacobian = DMatrix::from_fn(6, 6, |i, j| {
            let step = Vector6::from_fn(|r, _| if r == j { h } else { 0.0 });
            (readings(&step)[i] - readings(&-step)[i]) / (2.0 * h)
        });
        let weights = DMatrix::from_diagonal(&DVector::from_fn(6, |j, _| {
            if j < 3 { s_p * s_p } else { s_o * s_o }
        }));
        let covariance =
            DMatrix::identity(6, 6) * (s_q * s_q) + &jacobian * weights * jacobian.transpose();
        let residual = DVector::from_row_slice(&poses.q[row]) - readings(&Vector6::zeros());
        let whitened = covariance.cholesky().unwrap().solve(&residual);
        sum += residual.dot(&whitened);
    }
    let mean = sum / (6.0 * poses.len() as f64);
    assert!(
        (mean - 1.0).abs() < 5.0 * 0.047,
        "mean chi-square / dof {mean}"
    );
}

#[test]
fn sessions_carry_their_truth() {
    let scenario = noiseless();
    let dataset = simulate_tracker(&scenario, 3).unwrap().dataset;
    let truth = dataset.truth.as_ref().unwrap();
    assert_eq!(dataset.tracker.sessions, ["1", "2", "3"]);
    assert_eq!(dataset.tracker.rows_per_session(), [(50, 50); 3]);
    assert_eq!(truth.actuator_scale, Some(scenario.true_scale));
    assert_eq!(truth.sessions.len(), 3);
    let body = scenario.body_frame;
    let spread = &scenario.tracker_frame;
    for (k, session) in truth.sessions.iter().enumerate() {
        assert_eq!(session.label, (k + 1).to_string());
        let tracker = pose(&session.tracker_frame);
        assert!(tracker.rotation.angle() <= spread.max_angle + 1e-12);
        let shift = tracker.translation.vector - spread.offset;
        assert!(shift.iter().all(|v| v.abs() <= spread.spread));
        // Session 0 is the reference: no offset, the body frame itself;
        // later sessions draw offsets of sigma 1 mm and body origin shifts
        // of 0.5 mm (beyond 6 sigma with probability 2e-9 per draw).
        let marker = pose(&session.body_frame);
        assert!(marker.rotation.angle_to(&body.rotation) < 1e-12);
        let moved = (marker.translation.vector - body.translation.vector).norm();
        if k == 0 {
            assert_eq!(session.leg_offsets, [0.0; 6]);
            assert!(moved < 1e-12);
        } else {
            assert!(
                session
                    .leg_offsets
                    .iter()
                    .all(|o| *o != 0.0 && o.abs() < 6.0)
            );
            assert!(moved > 0.0 && moved < 3.0 * 6.0 * 0.5);
        }
    }
}

#[test]
fn points_only_sessions_have_no_body_frame() {
    let scenario = TrackerScenario {
        kind: TrackerKind::Points,
        ..TrackerScenario::paper_like()
    };
    let dataset = simulate_tracker(&scenario, 1).unwrap().dataset;
    assert!(dataset.tracker.poses.is_empty());
    assert_eq!(dataset.tracker.points.len(), 150);
    assert_eq!(dataset.machine.repeatability.orientation, None);
    let truth = dataset.truth.unwrap();
    assert!(
        truth
            .sessions
            .iter()
            .all(|s| s.body_frame == FrameRecord::IDENTITY)
    );
}

#[test]
fn written_datasets_read_back_equal() {
    let temp = tempfile::tempdir().unwrap();
    let cases = [
        TrackerScenario::paper_like(),
        TrackerScenario {
            kind: TrackerKind::Points,
            sessions: 1,
            ..TrackerScenario::paper_like()
        },
        TrackerScenario::jugglebot_like(),
    ];
    for (i, scenario) in cases.iter().enumerate() {
        let dataset = simulate_tracker(scenario, 9).unwrap().dataset;
        let dir = temp.path().join(i.to_string());
        dataset.write(&dir).unwrap();
        assert_eq!(Dataset::read(&dir).unwrap(), dataset, "case {i}");
        assert!(!dir.join("measurements.csv").exists());
    }
}

#[test]
fn an_unreachable_stroke_is_an_error_naming_the_row() {
    let scenario = TrackerScenario {
        stroke: [0.0, 10.0],
        ..TrackerScenario::paper_like()
    };
    match simulate_tracker(&scenario, 1) {
        Err(e @ SimulateError::Row { .. }) => assert!(
            e.to_string()
                .starts_with("session 1, poses row 1: no pose in 10000 draws"),
            "{e}"
        ),
        other => panic!("expected a row error, got {:?}", other.err()),
    }
    let scenario = TrackerScenario {
        sessions: 0,
        ..TrackerScenario::paper_like()
    };
    assert!(matches!(
        simulate_tracker(&scenario, 1),
        Err(SimulateError::Scenario(_))
    ));
}

#[test]
fn an_instrument_campaign_beyond_the_row_bound_is_refused() {
    let huge = TrackerScenario {
        sessions: 100,
        rows_per_session: 1 << 20,
        ..TrackerScenario::paper_like()
    };
    let Err(error) = simulate_tracker(&huge, 1) else {
        panic!("simulated")
    };
    let error = error.to_string();
    assert!(
        error.starts_with(
            "too large: sessions 100 x rows per session 1048576 x files (poses and points) 2"
        ),
        "{error}"
    );
    // More sessions than a dataset may hold: refused by their own bound.
    let many = TrackerScenario {
        sessions: 101,
        rows_per_session: 1,
        ..TrackerScenario::paper_like()
    };
    let Err(error) = simulate_tracker(&many, 1) else {
        panic!("simulated")
    };
    assert!(
        error
            .to_string()
            .starts_with("too large: sessions 101: must be a whole number from 1 to 100"),
        "{error}"
    );
}

#[test]
fn planned_readings_are_measured_on_the_true_machine() {
    // Readings of the design at three poses, measured noiselessly in two
    // sessions re-homed by 1 mm, the second in reverse order: each row
    // records its session's planned readings and
    // the true machine's pose at them (forward kinematics with the true
    // legs, scales and the session's offsets), seen through its frames.
    let design = parcal_kinematics::paper::design();
    let plan: Vec<[f64; 6]> = [
        Pose::from_parts(
            Translation3::new(0.0, 0.0, 340.0),
            UnitQuaternion::identity(),
        ),
        Pose::from_parts(
            Translation3::new(40.0, -30.0, 310.0),
            UnitQuaternion::from_euler_angles(0.1, -0.05, 0.15),
        ),
        Pose::from_parts(
            Translation3::new(-50.0, 20.0, 370.0),
            UnitQuaternion::from_euler_angles(-0.1, 0.12, -0.08),
        ),
    ]
    .iter()
    .map(|p| {
        let lengths = leg_lengths(&design, p);
        std::array::from_fn(|i| lengths[i] - design.legs[i])
    })
    .collect();
    let scenario = TrackerScenario {
        kind: TrackerKind::Poses,
        sessions: 2,
        rows_per_session: plan.len(),
        plan: Some(vec![plan.clone(), plan.iter().rev().copied().collect()]),
        ..noiseless()
    };
    let planned = |session: usize, row: usize| plan[if session == 0 { row } else { 2 - row }];
    let dataset = simulate_tracker(&scenario, 3).unwrap().dataset;
    let truth = dataset.truth.as_ref().unwrap();
    let poses = &dataset.tracker.poses;
    assert_eq!(poses.len(), 6);
    for j in 0..6 {
        let session = poses.session[j] as usize;
        let q = planned(session, j % 3);
        assert!((0..6).all(|i| (poses.q[j][i] - q[i]).abs() < 1e-9));
        let record = &truth.sessions[session];
        let shifted = Geometry {
            legs: std::array::from_fn(|i| scenario.truth.legs[i] + record.leg_offsets[i]),
            ..scenario.truth.clone()
        };
        let extension = std::array::from_fn(|i| scenario.true_scale[i] * q[i]);
        let t = forward_from_home(&shifted, &extension, &ForwardOptions::default())
            .unwrap()
            .pose;
        let expected = pose(&record.tracker_frame) * t * pose(&record.body_frame);
        let measured = measured_pose(&poses.position[j], &poses.orientation[j]);
        let error = expected.inverse() * measured;
        assert!(error.translation.vector.norm() < 1e-9 && error.rotation.angle() < 1e-12);
    }
    // A plan of another length than the rows, or of more sessions, is
    // refused.
    let refused = |scenario: &TrackerScenario| {
        matches!(
            simulate_tracker(scenario, 3),
            Err(SimulateError::Scenario(_))
        )
    };
    assert!(refused(&TrackerScenario {
        rows_per_session: 2,
        ..scenario.clone()
    }));
    assert!(refused(&TrackerScenario {
        plan: Some(vec![plan.clone(); 3]),
        ..scenario
    }));
}
