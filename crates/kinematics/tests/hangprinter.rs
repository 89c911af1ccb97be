//! The cable robot's kinematics reproduce the Hangprinter author's model on
//! the real data of `fixtures/hangprinter` (its README gives the source):
//! at the published calibration, the author's cost per sample and line
//! length error, to the digits printed.

use nalgebra::{DMatrix, DVector, Matrix3, Vector3};
use parcal_kinematics::cable::{CableRobot, Tolerances};
use parcal_kinematics::mechanism::design;
use parcal_kinematics::pose_fit::least_squares_pose;

/// One row of `points.csv`: the encoder angles and the known position.
struct Sample {
    readings: [f64; 4],
    known: Option<[f64; 3]>,
}

fn samples() -> Vec<Sample> {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../fixtures/hangprinter/points.csv"
    );
    let text = std::fs::read_to_string(path).expect(path);
    let mut lines = text.lines();
    assert_eq!(lines.next(), Some("q1,q2,q3,q4,x,y,z,f1,f2,f3,f4"));
    lines
        .map(|line| {
            let fields: Vec<&str> = line.split(',').collect();
            let number = |k: usize| fields[k].parse::<f64>().expect(line);
            Sample {
                readings: std::array::from_fn(number),
                known: (!fields[4].is_empty()).then(|| std::array::from_fn(|k| number(4 + k))),
            }
        })
        .collect()
}

/// The published `M669` anchors and `M666 R` radii (README.md of the
/// source), the spools' radii tied A = B = C as the source fits them.
fn published(robot: &CableRobot) -> DVector<f64> {
    let anchors = [
        [16.83, -1584.86, -113.17],
        [1290.18, 1229.19, -157.45],
        [-1409.88, 742.61, -151.80],
        [21.85, -0.16, 2343.67],
    ];
    let mut p = design(robot);
    for (j, anchor) in anchors.iter().enumerate() {
        for (axis, value) in anchor.iter().enumerate() {
            p[robot.anchor_index(j) + axis] = *value;
        }
    }
    p[robot.radius_index(0)] = 76.017;
    p[robot.radius_index(1)] = 75.657;
    p
}

/// The author's residuals of one sample at position `p + offset` (mm):
/// `|a_j - (p + offset)| - |a_j| - dL_j(theta_j)`.
fn residuals(
    robot: &CableRobot,
    params: &DVector<f64>,
    sample: &Sample,
    p: Vector3<f64>,
) -> DVector<f64> {
    let params = params.as_slice();
    robot.line_changes(params, p.as_slice()).unwrap()
        - robot.paid_out(params, &sample.readings).unwrap()
}

/// The author's position of `sample`: the least-squares point of its
/// lines, `|a_j − p|` against `|a_j − z_0| + dL_j(θ_j)` (equal weights in
/// millimetres of line, where the forward kinematics weighs the encoder
/// angles alike), by [`least_squares_pose`] with the line directions
/// `(p − a_j)/|p − a_j|` as the derivative.
fn point_of_lines(robot: &CableRobot, params: &DVector<f64>, sample: &Sample) -> Vector3<f64> {
    let fitted = least_squares_pose(&[0.0, 0.0, 500.0], |p| {
        let p = Vector3::from_column_slice(p);
        let directions = DMatrix::from_fn(4, 3, |j, k| {
            (p - robot.anchor(params.as_slice(), j)).normalize()[k]
        });
        Ok((residuals(robot, params, sample, p), directions))
    })
    .unwrap();
    Vector3::from_column_slice(fitted.as_slice())
}

#[test]
fn the_published_calibration_costs_what_the_author_printed() {
    let tolerances = Tolerances {
        anchor: 50.0,
        spool_radius: 1.0,
        encoder_zero: 1.0,
    };
    let robot = CableRobot::hangprinter_v4(&[0, 0, 0, 1], &tolerances).unwrap();
    let params = published(&robot);
    let samples = samples();
    assert_eq!(samples.len(), 44);
    assert_eq!(samples.iter().filter(|s| s.known.is_some()).count(), 9);
    // The unknown positions: each the least-squares point of its lines
    // (the author's fit), which the offset does not change.
    let mut cost = 0.0;
    for sample in samples.iter().filter(|s| s.known.is_none()) {
        let p = point_of_lines(&robot, &params, sample);
        cost += residuals(&robot, &params, sample, p).norm_squared();
    }
    // The common offset of the known positions, within the source's
    // bounds of +-1 mm per coordinate: Gauss-Newton on the coordinates
    // not held at a bound (the residuals' derivative by the offset being
    // the unit line directions (p - a_j)/|p - a_j|), a coordinate that
    // steps past its bound held there (the cost is nearly quadratic in
    // the offset, so this active set settles in a few rounds).
    let known: Vec<(&Sample, Vector3<f64>)> = samples
        .iter()
        .filter_map(|s| s.known.map(|k| (s, Vector3::from(k))))
        .collect();
    let mut offset = Vector3::zeros();
    let mut held = [false; 3];
    for _ in 0..30 {
        let (mut normal, mut gradient) = (Matrix3::zeros(), Vector3::zeros());
        for (sample, p) in &known {
            let r = residuals(&robot, &params, sample, p + offset);
            for j in 0..4 {
                let u = (p + offset - robot.anchor(params.as_slice(), j)).normalize();
                normal += u * u.transpose();
                gradient += u * r[j];
            }
        }
        for axis in (0..3).filter(|&axis| held[axis]) {
            normal.row_mut(axis).fill(0.0);
            normal.column_mut(axis).fill(0.0);
            normal[(axis, axis)] = 1.0;
            gradient[axis] = 0.0;
        }
        offset -= normal.try_inverse().unwrap() * gradient;
        for axis in 0..3 {
            if offset[axis].abs() > 1.0 {
                offset[axis] = offset[axis].signum();
                held[axis] = true;
            }
        }
    }
    cost += known
        .iter()
        .map(|(sample, p)| residuals(&robot, &params, sample, p + offset).norm_squared())
        .sum::<f64>();
    let per_sample = cost / 44.0;
    // Printed: 1.201390e+00 by the fit; its M669/M666, printed to 0.01 and
    // 0.001 mm, give 1.201395: the same to the 5 digits 1.2014.
    eprintln!("cost per sample {per_sample:.6} at offset {offset:.4}");
    assert!((per_sample - 1.2014).abs() < 5e-5, "{per_sample}");
    // Line length error sqrt(sum (|a_j| - L0_j)^2), printed 2.364123e+01.
    let hand_measured = [1597.0, 1795.0, 1582.5, 2355.0];
    let error = (0..4)
        .map(|j| (robot.anchor(params.as_slice(), j).norm() - hand_measured[j]).powi(2))
        .sum::<f64>()
        .sqrt();
    eprintln!("line length error {error:.4} mm");
    assert!((error - 23.64).abs() < 5e-3, "{error}");
}

/// The 32 hp-mark positions the author discarded (`untrusted.csv`):
/// sample number and position (mm).
fn untrusted() -> Vec<(usize, Vector3<f64>)> {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../fixtures/hangprinter/untrusted.csv"
    );
    let text = std::fs::read_to_string(path).expect(path);
    let mut lines = text.lines();
    assert_eq!(lines.next(), Some("sample,x,y,z"));
    lines
        .map(|line| {
            let f: Vec<f64> = line.split(',').map(|v| v.parse().expect(line)).collect();
            (f[0] as usize, Vector3::new(f[1], f[2], f[3]))
        })
        .collect()
}

#[test]
fn the_published_calibration_predicts_the_discarded_positions_to_5_31_mm() {
    // The author's position (the least-squares point of the lines) of
    // each discarded sample's encoders at the published calibration,
    // against hp-mark's position: 5.31 mm RMS (the figure the issue
    // quotes; the common offset is not applied).
    let tolerances = Tolerances {
        anchor: 50.0,
        spool_radius: 1.0,
        encoder_zero: 1.0,
    };
    let robot = CableRobot::hangprinter_v4(&[0, 0, 0, 1], &tolerances).unwrap();
    let params = published(&robot);
    let samples = samples();
    let untrusted = untrusted();
    assert_eq!(untrusted.len(), 32);
    let squares: f64 = untrusted
        .iter()
        .map(|(i, position)| {
            (point_of_lines(&robot, &params, &samples[*i]) - position).norm_squared()
        })
        .sum();
    let rms = (squares / 32.0).sqrt();
    eprintln!("discarded positions predicted to {rms:.4} mm RMS");
    assert!((rms - 5.31).abs() < 5e-3, "{rms}");
}
