//! Targets to actuator commands by the calibrated model's inverse
//! kinematics.
//!
//! For a target (tool tip `T`, orientation `R`, design frame) the placed
//! calibrated geometry gives the pose `t = T - R E_T`, the leg lengths
//! `L_i = |R E_i + t - B_i|` (paper eq. 1) and the readings
//! `q_i = (L_i - l_i) / s_i` in the actuators' unit.
//!
//! A target is refused, in this order, when it puts the platform on the
//! other side of the base than the machine's assembly mode (its
//! `parcal_kinematics::assembly::platform_height` is not positive: the
//! legs cannot tell a pose from its mirror image through the base, and the
//! machine would go to the mirror image), when a reading leaves the stroke,
//! a joint is beyond machine.json's joint limits
//! (`parcal_kinematics::joints`, with the calibrated geometry), near a
//! singular configuration, or when the readings do not lead back to it: the
//! forward kinematics from the home pose (the machine's assembly mode,
//! `parcal_kinematics::assembly::reached_from_home`) must reach its pose
//! within `parcal_kinematics::assembly::REACH_TOLERANCE`. The measure of
//! singularity: the inverse-kinematics Jacobian
//! `A = dL/d(t, w)` (rows `[n_i^T, (a_i x n_i)^T]`, `a_i = R E_i`,
//! docs/formulation.md section 4) with its rotation columns divided by `r`,
//! the RMS distance of the platform joints from their centroid, so that
//! both halves are mm of leg per mm of joint motion; its singular values'
//! ratio `sigma_min / sigma_max` ([`singular_value_ratio`]) must be at
//! least [`SINGULARITY_RATIO`]. At that limit a leg-length error `dL` can
//! move the platform by up to `|dL| / sigma_min`, a hundred times what the
//! best direction allows.

use nalgebra::Matrix6;
use parcal_kinematics::assembly::{
    REACH_TOLERANCE, platform_height, pose_distance, reached_from_home, reached_from_home_batch,
};
use parcal_kinematics::forward_batch::LANES;
use parcal_kinematics::{Geometry, KinematicsError, Pose, closure::Legs};

use crate::error::in_pieces;
use crate::{AppliedModel, ApplyError, Refusal, Target};

/// The smallest allowed `sigma_min / sigma_max` of the normalised inverse
/// kinematics Jacobian (module doc).
pub const SINGULARITY_RATIO: f64 = 1e-2;

/// The command of one target.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Command {
    /// Actuator readings, in the actuators' unit.
    pub q: [f64; 6],
    /// The pose the calibrated model expects (design frame).
    pub pose: Pose,
    /// `sigma_min / sigma_max` of the normalised Jacobian at `pose`.
    pub conditioning: f64,
}

/// The normalised inverse-kinematics Jacobian of `geometry` at `legs`: `A`
/// with its rotation columns divided by the platform's RMS joint radius.
pub fn normalised_jacobian(geometry: &Geometry, legs: &Legs) -> Matrix6<f64> {
    let centroid = geometry.platform.iter().sum::<parcal_kinematics::Vec3>() / 6.0;
    let radius = (geometry
        .platform
        .iter()
        .map(|e| (e - centroid).norm_squared())
        .sum::<f64>()
        / 6.0)
        .sqrt();
    let rows = legs.closure_rows();
    Matrix6::from_fn(|i, j| {
        if j < 3 {
            rows[i][j]
        } else {
            rows[i][j] / radius
        }
    })
}

/// The command of `target` (module doc), or why it is refused.
pub fn command(model: &AppliedModel, target: &Target) -> Result<Command, Refusal> {
    let command = placed(model, target)?;
    let geometry = &model.calibrated;
    reached_at(
        geometry,
        &command.pose,
        reached_from_home(geometry, &command.pose),
    )?;
    Ok(command)
}

/// [`command`] but its last check, that its readings lead back to its
/// pose.
fn placed(model: &AppliedModel, target: &Target) -> Result<Command, Refusal> {
    target.check()?;
    let geometry = &model.calibrated;
    let pose = target.pose(&geometry.tool);
    let legs = Legs::at(geometry, &pose);
    if let Some(i) = legs
        .length
        .iter()
        .position(|l| !(l.is_finite() && *l > 0.0))
    {
        return Err(Refusal::InfeasibleLeg {
            leg: i + 1,
            length: legs.length[i],
        });
    }
    let height = platform_height(geometry, &pose);
    // NaN (a degenerate geometry) is refused too.
    if height.is_nan() || height <= 0.0 {
        return Err(Refusal::OtherAssembly { depth: -height });
    }
    let q: [f64; 6] = std::array::from_fn(|i| (legs.length[i] - geometry.legs[i]) / model.scale[i]);
    if let Some([min, max]) = model.stroke
        && let Some(i) = q.iter().position(|q| !(min..=max).contains(q))
    {
        return Err(Refusal::OutsideStroke {
            leg: i + 1,
            reading: q[i],
            unit: model.unit.clone(),
            min,
            max,
        });
    }
    if let Some(violation) = model
        .joint_limits
        .as_ref()
        .and_then(|limits| limits.violation(geometry, &pose))
    {
        return Err(Refusal::BeyondJointLimit(violation));
    }
    let conditioning = singular_value_ratio(&normalised_jacobian(geometry, &legs));
    // NaN (a degenerate Jacobian) is refused too.
    if conditioning.is_nan() || conditioning < SINGULARITY_RATIO {
        return Err(Refusal::NearSingular {
            ratio: conditioning,
            limit: SINGULARITY_RATIO,
        });
    }
    Ok(Command {
        q,
        pose,
        conditioning,
    })
}

/// `σ_min / σ_max` of `a`, from the extreme eigenvalues `σ²` of the
/// symmetric `aᵀa` (cheaper than `a`'s singular value decomposition, and
/// the same to a relative `ε σ_max² / σ_min²`); NaN for a matrix that is
/// not finite or is zero.
pub fn singular_value_ratio(a: &Matrix6<f64>) -> f64 {
    if !a.iter().all(|v| v.is_finite()) {
        return f64::NAN;
    }
    let squares = a.tr_mul(a).symmetric_eigenvalues();
    (squares.min().max(0.0) / squares.max()).sqrt()
}

/// Refuses `pose` when `reached`, where its leg lengths take the machine
/// from its home pose ([`reached_from_home`]), is not `pose` (module doc).
fn reached_at(
    geometry: &Geometry,
    pose: &Pose,
    reached: Result<Pose, KinematicsError>,
) -> Result<(), Refusal> {
    let reached = reached.map_err(Refusal::Unreached)?;
    let distance = pose_distance(geometry, &reached, pose);
    if distance <= REACH_TOLERANCE {
        Ok(())
    } else {
        Err(Refusal::Elsewhere {
            tip: geometry.tool_tip(&reached),
            distance,
            tolerance: REACH_TOLERANCE,
        })
    }
}

/// The commands of `targets` ([`command`]), in order; the first refused
/// target is an error naming its row (1-based). They are made on the
/// threads, [`LANES`] targets at a time, the poses of a piece's targets
/// reached from home together ([`reached_from_home_batch`]).
pub fn compensate(model: &AppliedModel, targets: &[Target]) -> Result<Vec<Command>, ApplyError> {
    in_pieces(targets, LANES, |piece| commands_of(model, piece))
}

/// [`command`] of each of up to [`LANES`] `targets`, in order, their
/// poses reached from home together.
fn commands_of(model: &AppliedModel, targets: &[Target]) -> Vec<Result<Command, Refusal>> {
    let geometry = &model.calibrated;
    let mut outcomes: Vec<Result<Command, Refusal>> =
        targets.iter().map(|target| placed(model, target)).collect();
    let poses: Vec<Pose> = outcomes.iter().flatten().map(|c| c.pose).collect();
    let mut reached = reached_from_home_batch(geometry, &poses).into_iter();
    for outcome in &mut outcomes {
        if let Ok(command) = outcome {
            let reached = reached.next().expect("an outcome for each pose");
            if let Err(refusal) = reached_at(geometry, &command.pose, reached) {
                *outcome = Err(refusal);
            }
        }
    }
    outcomes
}

#[cfg(test)]
#[allow(clippy::needless_range_loop)]
mod tests {
    use super::*;
    use crate::tests::paper_model;
    use nalgebra::Vector6;
    use parcal_kinematics::{Vec3, forward::step, leg_lengths};

    fn target(x: f64, y: f64, z: f64, roll: f64, pitch: f64, yaw: f64) -> Target {
        Target {
            position: Vec3::new(x, y, z),
            roll,
            pitch,
            yaw,
        }
    }

    #[test]
    fn readings_scale_leg_lengths_and_the_jacobian_matches_differences() {
        let mut model = paper_model();
        model.scale = [2.0, 0.5, 1.0, 4.0, 1.5, 0.25];
        let t = target(20.0, -30.0, 410.0, 0.05, -0.08, 0.1);
        let c = command(&model, &t).unwrap();
        let lengths = leg_lengths(&model.calibrated, &c.pose);
        for i in 0..6 {
            let expected = model.calibrated.legs[i] + model.scale[i] * c.q[i];
            assert!((expected - lengths[i]).abs() < 1e-9);
        }
        // dL/d(t, w) by central differences along the pose update
        // t <- t + dt, R <- rot(w) R (kinematics' step).
        let legs = Legs::at(&model.calibrated, &c.pose);
        let rows = legs.closure_rows();
        let h = 1e-6;
        for j in 0..6 {
            let delta = Vector6::from_fn(|k, _| if k == j { 1.0 } else { 0.0 });
            let plus = leg_lengths(&model.calibrated, &step(&c.pose, &delta, h));
            let minus = leg_lengths(&model.calibrated, &step(&c.pose, &delta, -h));
            for i in 0..6 {
                let numeric = (plus[i] - minus[i]) / (2.0 * h);
                assert!(
                    (numeric - rows[i][j]).abs() < 1e-6 * (1.0 + rows[i][j].abs()),
                    "leg {i}, column {j}: {numeric} vs {}",
                    rows[i][j]
                );
            }
        }
        assert!(c.conditioning > SINGULARITY_RATIO && c.conditioning <= 1.0);
    }

    #[test]
    fn refusals_name_the_row_and_the_reason() {
        let mut model = paper_model();
        let centre = command(&model, &target(0.0, 0.0, 400.0, 0.0, 0.0, 0.0)).unwrap();
        let (min, max) = centre
            .q
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &q| {
                (a.min(q), b.max(q))
            });
        model.stroke = Some([min - 1.0, max + 1.0]);
        let targets = [
            target(0.0, 0.0, 400.0, 0.0, 0.0, 0.0),
            target(0.0, 0.0, 450.0, 0.0, 0.0, 0.0),
        ];
        let message = compensate(&model, &targets).unwrap_err().to_string();
        assert!(message.starts_with("row 2: q"), "{message}");
        assert!(message.contains("is outside the stroke"), "{message}");

        model.stroke = None;
        // A joint limit just below the tilted target's largest platform
        // joint angle refuses it, naming the joint; the level one passes.
        let tilted = target(0.0, 0.0, 400.0, 0.0, 0.3, 0.0);
        let pose = command(&model, &tilted).unwrap().pose;
        let free = parcal_kinematics::JointLimits::along_normals(None, Some(1.5));
        let angles = free.angles(&model.calibrated, &pose).platform;
        let leg = (0..6)
            .max_by(|&a, &b| angles[a].total_cmp(&angles[b]))
            .unwrap();
        model.joint_limits = Some(parcal_kinematics::JointLimits::along_normals(
            None,
            Some(angles[leg] - 1e-6),
        ));
        let level = target(0.0, 0.0, 400.0, 0.0, 0.0, 0.0);
        assert!(compensate(&model, &[level]).is_ok());
        let message = compensate(&model, &[level, tilted])
            .unwrap_err()
            .to_string();
        assert!(
            message.starts_with(&format!("row 2: the platform joint of leg {}", leg + 1)),
            "{message}"
        );
        model.joint_limits = None;
        let message = compensate(&model, &[target(0.0, f64::NAN, 400.0, 0.0, 0.0, 0.0)])
            .unwrap_err()
            .to_string();
        assert_eq!(message, "row 1: y is not a finite number");

        // The platform lowered to within a millimetre above the base's
        // plane (the tool is 60.4 mm above it): every leg nearly
        // horizontal, no leg can lift it.
        let flat = target(0.0, 0.0, 61.0, 0.0, 0.0, 0.0);
        let message = compensate(&model, &[flat]).unwrap_err().to_string();
        assert!(message.starts_with("row 1: near a singular"), "{message}");
    }

    #[test]
    fn a_target_below_the_base_is_refused_with_and_without_joint_limits() {
        let mut model = paper_model();
        let above = target(0.0, 0.0, 400.0, 0.0, 0.0, 0.0);
        let below = target(0.0, 0.0, -400.0, 0.0, 0.0, 0.0);
        for limits in [
            None,
            Some(parcal_kinematics::JointLimits::along_normals(
                Some(0.7),
                Some(0.7),
            )),
        ] {
            model.joint_limits = limits;
            assert!(compensate(&model, &[above]).is_ok());
            let message = compensate(&model, &[above, below]).unwrap_err().to_string();
            // The platform's joints at z = -400 - 60 = -460, the base's
            // within 0.1 mm of z = 0 (the paper's truth).
            assert!(
                message.starts_with("row 2: the platform would be 46")
                    && message.contains("mm below the base"),
                "{message}"
            );
            assert!(message.contains("other assembly mode"), "{message}");
        }
    }

    #[test]
    fn readings_that_lead_to_another_pose_are_refused() {
        let model = paper_model();
        let geometry = &model.calibrated;
        let reaches = |pose: &Pose| reached_at(geometry, pose, reached_from_home(geometry, pose));
        let above = target(10.0, -20.0, 400.0, 0.05, 0.0, 0.1).pose(&geometry.tool);
        assert_eq!(reaches(&above), Ok(()));
        // The platform below the base, level: its legs take the machine to
        // near the mirror image, level at z = +460 (tool tip z = +520);
        // near, for the truth's base joints lie up to 0.08 mm out of
        // plane, which the 900 mm lever turns into millimetres.
        let below = target(0.0, 0.0, -400.0, 0.0, 0.0, 0.0).pose(&geometry.tool);
        match reaches(&below) {
            Err(Refusal::Elsewhere { tip, distance, .. }) => {
                assert!((tip - Vec3::new(0.0, 0.0, 520.0)).norm() < 5.0, "{tip}");
                assert!(distance > 900.0, "{distance}");
            }
            other => panic!("{other:?}"),
        }
    }

    /// `σ_min / σ_max` from `aᵀa`'s eigenvalues is the singular value
    /// decomposition's: well conditioned and at ratios down to 1e-4 (the
    /// squares' rounding, a relative 1e-16 of `σ_max²`, is 1e-8 of `σ_min²`
    /// there); NaN for a matrix that is zero or not finite.
    #[test]
    fn the_singular_value_ratio_is_the_decompositions() {
        for (k, smallest) in [0.5, 0.3, 1e-2, 1e-4].into_iter().enumerate() {
            // U diag(s) Vᵀ with orthogonal U, V from the QR of fixed matrices.
            let m =
                |seed: usize| Matrix6::from_fn(|i, j| ((seed * 37 + i * 11 + j * 5) as f64).sin());
            let (u, v) = (m(k).qr().q(), m(k + 9).qr().q());
            let s = nalgebra::Vector6::new(3.0, 2.7, 2.4, 2.1, 1.8, 3.0 * smallest);
            let a = u * Matrix6::from_diagonal(&s) * v.transpose();
            let svd = a.singular_values();
            let expected = svd.min() / svd.max();
            let ratio = singular_value_ratio(&a);
            assert!(
                (ratio - expected).abs() < 1e-12,
                "{ratio:e} against {expected:e}"
            );
            assert!((expected - smallest).abs() < 1e-12, "{expected:e}");
        }
        assert!(singular_value_ratio(&Matrix6::zeros()).is_nan());
        let mut a = Matrix6::identity();
        a[(2, 4)] = f64::NAN;
        assert!(singular_value_ratio(&a).is_nan());
        a[(2, 4)] = f64::INFINITY;
        assert!(singular_value_ratio(&a).is_nan());
    }

    /// Targets compensated together, [`LANES`] at a time, are each the
    /// command [`command`] makes of it alone, refusals too: the first
    /// refused in order is named wherever it falls in a piece.
    #[test]
    fn targets_in_pieces_are_each_its_own_command() {
        let model = paper_model();
        let targets: Vec<Target> = (0..29)
            .map(|k| {
                let f = k as f64;
                target(
                    30.0 * (0.7 * f).sin(),
                    -25.0 * (1.3 * f).cos(),
                    380.0 + 40.0 * (0.37 * f).sin(),
                    0.05 * (0.9 * f).cos(),
                    -0.04 * (1.1 * f).sin(),
                    0.08 * (0.5 * f).sin(),
                )
            })
            .collect();
        let alone: Vec<Command> = targets
            .iter()
            .map(|t| command(&model, t).unwrap())
            .collect();
        assert_eq!(compensate(&model, &targets).unwrap(), alone);
        // Below the base (refused by its height) at 19, a flat platform
        // (near singular) at 22: row 20 is named.
        let mut refused = targets.clone();
        refused[19] = target(0.0, 0.0, -400.0, 0.0, 0.0, 0.0);
        refused[22] = target(0.0, 0.0, 61.0, 0.0, 0.0, 0.0);
        let message = compensate(&model, &refused).unwrap_err().to_string();
        let expected = command(&model, &refused[19]).unwrap_err();
        assert_eq!(message, format!("row 20: {expected}"));
    }
}
