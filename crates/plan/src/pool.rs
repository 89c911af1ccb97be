//! The candidate pool: every ball touch the machine can make, nominally.
//!
//! Platform orientations `R = Rz(yaw) Ry(pitch) Rx(roll)` (design frame,
//! fixed axes) on a grid of the tilt box `[-tilt, tilt]^3` with
//! [`ORIENTATION_LEVELS`] levels per angle, corners and edges included
//! (the extremes carry the information), times approach directions per
//! ball and orientation. The stylus points along the platform's `+z`
//! (`R e_z`, from the platform to the tool tip), so it approaches the ball
//! without the shaft touching it when the outward normal `u` at the contact
//! point is within [`PoolOptions::max_approach`] of `-R e_z`; the directions
//! are a Fibonacci lattice of that spherical cap about `-R e_z`.
//!
//! A candidate is kept when, with the design geometry, the tool tip at the
//! nominal contact point `C + r u` and orientation `R`:
//! - the platform is above the base, in the machine's assembly mode
//!   ([`parcal_kinematics::assembly::platform_height`] positive: below
//!   the base its readings would drive the machine to the mirror image);
//! - every actuator reading `q_i = L_i - l_i` is inside the stroke;
//! - the pose is away from singularity: the closure Jacobian `A` (rows
//!   `[n_i^T, (R E_i x n_i)^T]`, `crates/kinematics/src/closure.rs`) with
//!   its rotation columns divided by the platform's joint radius `rho`
//!   (RMS of `|E_i|`, so that both halves are mm/mm) has
//!   `sigma_min / sigma_max >= PoolOptions::min_conditioning`;
//! - every joint is within machine.json's joint limits, when it gives them
//!   ([`parcal_kinematics::joints`]: the angle between each leg and its
//!   base and platform joints' axes).

use nalgebra::{Matrix6, Translation3, UnitQuaternion};
use parcal_kinematics::assembly::platform_height;
use parcal_kinematics::{
    Geometry, JointLimits, Pose, Vec3, actuators, closure::Legs, rotation_zyx,
};

use crate::DesignError;

/// Levels of each orientation angle on the tilt box: `-tilt, 0, tilt`.
pub const ORIENTATION_LEVELS: usize = 3;

/// How the pool is built.
#[derive(Debug, Clone, PartialEq)]
pub struct PoolOptions {
    /// Largest |roll|, |pitch|, |yaw| (rad).
    pub tilt: f64,
    /// Approximate number of candidates before the feasibility checks.
    pub size: usize,
    /// Largest angle between the approach direction `-u` and the stylus
    /// axis `R e_z` (rad).
    pub max_approach: f64,
    /// Smallest accepted `sigma_min / sigma_max` of the scaled closure
    /// Jacobian (module doc).
    pub min_conditioning: f64,
    /// The range of every actuator reading `[min, max]` (the readings'
    /// unit).
    pub stroke: [f64; 2],
    /// The design's actuator scales `s_i` (mm per reading unit): a
    /// reading is its leg's extension over its scale.
    pub scale: [f64; 6],
    /// The largest joint angles, when the machine has any.
    pub joint_limits: Option<JointLimits>,
}

/// The default largest approach angle: 80 degrees off the stylus axis (a
/// stylus whose shaft is thinner than its tip touches a ball up to its
/// equator and a little beyond).
pub const MAX_APPROACH_DEGREES: f64 = 80.0;

/// The default singularity threshold on `sigma_min / sigma_max`.
pub const MIN_CONDITIONING: f64 = 0.05;

/// A nominal ball in the design frame.
#[derive(Debug, Clone, PartialEq)]
pub struct NominalBall {
    /// Nominal centre (mm, design frame).
    pub centre: Vec3,
    /// Calibrated radius (mm).
    pub radius: f64,
}

/// One feasible touch: a ball, the outward normal at the intended contact
/// point and the platform orientation, with its nominal commands.
#[derive(Debug, Clone, PartialEq)]
pub struct Candidate {
    /// The ball (artefacts.json order).
    pub ball: usize,
    /// Unit outward normal `u` at the contact point (design frame).
    pub direction: Vec3,
    /// `[roll, pitch, yaw]` (rad), `R = Rz(yaw) Ry(pitch) Rx(roll)`.
    pub angles: [f64; 3],
    /// The design's actuator readings with the tool tip at `C + r u`.
    pub q: [f64; 6],
}

impl Candidate {
    /// The platform orientation `R`.
    pub fn rotation(&self) -> UnitQuaternion<f64> {
        let [roll, pitch, yaw] = self.angles;
        rotation_zyx(yaw, pitch, roll)
    }
}

/// The nominal pose (design frame) with the tool tip of `design` at
/// `point` and orientation `rotation`.
pub fn tip_pose(design: &Geometry, point: &Vec3, rotation: UnitQuaternion<f64>) -> Pose {
    tip_pose_of_tool(&design.tool, point, rotation)
}

/// The pose with the tool point `tool` (platform frame) at `point` and
/// orientation `rotation`.
pub fn tip_pose_of_tool(tool: &Vec3, point: &Vec3, rotation: UnitQuaternion<f64>) -> Pose {
    Pose::from_parts(Translation3::from(point - rotation * tool), rotation)
}

/// `sigma_min / sigma_max` of the closure Jacobian of `design` at `pose`,
/// rotation columns divided by the joint radius (module doc).
pub fn conditioning(design: &Geometry, pose: &Pose) -> f64 {
    let rho = (design
        .platform
        .iter()
        .map(|e| e.norm_squared())
        .sum::<f64>()
        / 6.0)
        .sqrt();
    let rows = Legs::at(design, pose).closure_rows();
    let a = Matrix6::from_fn(|i, j| if j < 3 { rows[i][j] } else { rows[i][j] / rho });
    let sigma = a.singular_values();
    sigma.min() / sigma.max()
}

/// The design's actuator readings `q_i = (L_i - l_i) / s_i` at `pose`
/// (`s_i` in mm per unit) when the platform is above the base, every
/// reading is inside `stroke`, the pose's
/// [`conditioning`] is at least `min_conditioning` and every joint is
/// within `joint_limits` if given (module doc); `None` otherwise.
pub fn feasible_commands(
    design: &Geometry,
    pose: &Pose,
    scale: &[f64; 6],
    stroke: &[f64; 2],
    min_conditioning: f64,
    joint_limits: Option<&JointLimits>,
) -> Option<[f64; 6]> {
    let extension = actuators(design, pose);
    let q: [f64; 6] = std::array::from_fn(|i| extension[i] / scale[i]);
    let in_stroke = q.iter().all(|q| (stroke[0]..=stroke[1]).contains(q));
    let in_joints = || joint_limits.is_none_or(|l| l.violation(design, pose).is_none());
    (platform_height(design, pose) > 0.0
        && in_stroke
        && conditioning(design, pose) >= min_conditioning
        && in_joints())
    .then_some(q)
}

/// The feasible candidates of `balls` for `design` (module doc), in a fixed
/// order (ball, orientation, direction). Errors: bad options, or no
/// feasible candidate at all.
pub fn candidate_pool(
    design: &Geometry,
    balls: &[NominalBall],
    options: &PoolOptions,
) -> Result<Vec<Candidate>, DesignError> {
    crate::bounds::POOL
        .check("pool size", options.size)
        .map_err(DesignError::Options)?;
    let [low, high] = options.stroke;
    let right_angle = std::f64::consts::FRAC_PI_2;
    let refused = [
        (
            (0.0..right_angle).contains(&options.tilt),
            format!("tilt {} rad: not in [0, pi/2)", options.tilt),
        ),
        (
            options.max_approach > 0.0 && options.max_approach < right_angle,
            format!("approach {} rad: not in (0, pi/2)", options.max_approach),
        ),
        (
            (0.0..1.0).contains(&options.min_conditioning),
            format!("conditioning {}: not in [0, 1)", options.min_conditioning),
        ),
        (
            low.is_finite() && high.is_finite() && low < high,
            format!(
                "stroke {:?}: not a finite range, its low end first",
                options.stroke
            ),
        ),
        (
            options.scale.iter().all(|s| s.is_finite() && *s > 0.0),
            format!(
                "actuator scales {:?}: not all positive and finite",
                options.scale
            ),
        ),
        (!balls.is_empty(), "no ball to touch".to_string()),
    ];
    if let Some((_, why)) = refused.into_iter().find(|(valid, _)| !valid) {
        return Err(DesignError::Options(format!("pool: {why}")));
    }
    let orientations = orientation_grid(options.tilt);
    let per_orientation = options
        .size
        .div_ceil(orientations.len() * balls.len())
        .max(1);
    let cap = cap_lattice(per_orientation, options.max_approach);
    let mut pool = Vec::new();
    for (ball, nominal) in balls.iter().enumerate() {
        for angles in &orientations {
            let [roll, pitch, yaw] = *angles;
            let rotation = rotation_zyx(yaw, pitch, roll);
            for v in &cap {
                let direction = rotation * v;
                let point = nominal.centre + nominal.radius * direction;
                let pose = tip_pose(design, &point, rotation);
                if let Some(q) = feasible_commands(
                    design,
                    &pose,
                    &options.scale,
                    &options.stroke,
                    options.min_conditioning,
                    options.joint_limits.as_ref(),
                ) {
                    pool.push(Candidate {
                        ball,
                        direction,
                        angles: *angles,
                        q,
                    });
                }
            }
        }
    }
    if pool.is_empty() {
        return Err(DesignError::EmptyPool {
            stroke: options.stroke,
        });
    }
    Ok(pool)
}

/// `[roll, pitch, yaw]` on the grid of the tilt box.
pub(crate) fn orientation_grid(tilt: f64) -> Vec<[f64; 3]> {
    let n = ORIENTATION_LEVELS;
    let level = |k: usize| -tilt + 2.0 * tilt * k as f64 / (n - 1) as f64;
    let mut grid = Vec::with_capacity(n * n * n);
    for yaw in 0..n {
        for pitch in 0..n {
            for roll in 0..n {
                grid.push([level(roll), level(pitch), level(yaw)]);
            }
        }
    }
    grid
}

/// `count` unit vectors spread evenly (Fibonacci lattice) over the cap of
/// half-angle `half_angle` about `-e_z`: the outward normals a stylus
/// pointing along `+e_z` can touch.
fn cap_lattice(count: usize, half_angle: f64) -> Vec<Vec3> {
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    let depth = 1.0 - half_angle.cos();
    (0..count)
        .map(|k| {
            let cos = 1.0 - depth * (k as f64 + 0.5) / count as f64;
            let sin = (1.0 - cos * cos).max(0.0).sqrt();
            let azimuth = golden * k as f64;
            Vec3::new(sin * azimuth.cos(), sin * azimuth.sin(), -cos)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use parcal_kinematics::paper;

    fn paper_balls() -> Vec<NominalBall> {
        let mut balls = Vec::new();
        for z in [360.0, 400.0, 440.0] {
            for y in [-60.0, 0.0, 60.0] {
                for x in [-60.0, 0.0, 60.0] {
                    balls.push(NominalBall {
                        centre: Vec3::new(x, y, z),
                        radius: 5.0,
                    });
                }
            }
        }
        balls
    }

    fn options(tilt_degrees: f64) -> PoolOptions {
        PoolOptions {
            tilt: tilt_degrees.to_radians(),
            size: 3000,
            max_approach: MAX_APPROACH_DEGREES.to_radians(),
            min_conditioning: MIN_CONDITIONING,
            stroke: [20.0, 250.0],
            scale: [1.0; 6],
            joint_limits: None,
        }
    }

    #[test]
    fn every_candidate_is_feasible_and_touches_its_ball() {
        let design = paper::design();
        let balls = paper_balls();
        let pool = candidate_pool(&design, &balls, &options(30.0)).unwrap();
        assert!(pool.len() > 500, "{} candidates", pool.len());
        for c in &pool {
            assert!(c.q.iter().all(|q| (20.0..=250.0).contains(q)));
            assert!((c.direction.norm() - 1.0).abs() < 1e-12);
            let rotation = c.rotation();
            let axis = rotation * Vec3::z();
            let approach = (-c.direction).dot(&axis).clamp(-1.0, 1.0).acos();
            assert!(approach <= MAX_APPROACH_DEGREES.to_radians() + 1e-12);
            // The commands put the design's tip on the contact point.
            let ball = &balls[c.ball];
            let point = ball.centre + ball.radius * c.direction;
            let pose = tip_pose(&design, &point, rotation);
            assert!((design.tool_tip(&pose) - point).norm() < 1e-12);
            assert!(conditioning(&design, &pose) >= MIN_CONDITIONING);
        }
        // The corners of the tilt box are in the pool.
        let t = 30f64.to_radians();
        assert!(pool.iter().any(|c| c.angles == [t, t, t]));
        assert!(pool.iter().any(|c| c.angles == [-t, -t, -t]));
    }

    /// Legs read in another unit (2 mm a unit) under the same stroke in
    /// that unit: the same candidates, their readings the extensions over
    /// the scale.
    #[test]
    fn readings_in_another_unit_keep_the_pool() {
        let (design, balls) = (paper::design(), paper_balls());
        let in_mm = candidate_pool(&design, &balls, &options(30.0)).unwrap();
        let in_units = PoolOptions {
            stroke: [10.0, 125.0],
            scale: [2.0; 6],
            ..options(30.0)
        };
        let read = candidate_pool(&design, &balls, &in_units).unwrap();
        assert_eq!(read.len(), in_mm.len());
        for (r, m) in read.iter().zip(&in_mm) {
            assert_eq!(
                (r.ball, r.angles, r.direction),
                (m.ball, m.angles, m.direction)
            );
            assert_eq!(r.q, m.q.map(|q| q / 2.0));
        }
        let unscaled = PoolOptions {
            scale: [1.0, 1.0, 0.0, 1.0, 1.0, 1.0],
            ..options(30.0)
        };
        let error = candidate_pool(&design, &balls, &unscaled).unwrap_err();
        assert!(
            error.to_string().contains("pool: actuator scales"),
            "{error}"
        );
        // The option refused is named alone.
        let approach = PoolOptions {
            max_approach: f64::NAN,
            ..options(30.0)
        };
        let error = candidate_pool(&design, &balls, &approach).unwrap_err();
        assert!(
            error
                .to_string()
                .ends_with("pool: approach NaN rad: not in (0, pi/2)"),
            "{error}"
        );
    }

    #[test]
    fn the_conditioning_falls_towards_a_singular_pose() {
        // The home pose is well conditioned (0.15); yawing the platform by
        // 90 degrees turns the paper's machine into its singular
        // configuration (every leg in a plane through the vertical axis).
        let design = paper::design();
        let home = tip_pose(
            &design,
            &Vec3::new(0.0, 0.0, 400.0),
            rotation_zyx(0.0, 0.0, 0.0),
        );
        let turned = tip_pose(
            &design,
            &Vec3::new(0.0, 0.0, 400.0),
            rotation_zyx(89f64.to_radians(), 0.0, 0.0),
        );
        let (a, b) = (conditioning(&design, &home), conditioning(&design, &turned));
        assert!(a > 2.0 * MIN_CONDITIONING, "home {a}");
        assert!(b < MIN_CONDITIONING / 2.0, "home {a}, turned {b}");
    }

    /// The largest base and platform joint angles of `design` at `pose`
    /// (degrees) about `+z` of each frame, from the leg vectors
    /// `R E_i + t - B_i` directly.
    fn leg_leans(design: &Geometry, pose: &Pose) -> (f64, f64) {
        let rotation = pose.rotation.to_rotation_matrix();
        let mut largest = (0.0f64, 0.0f64);
        for i in 0..6 {
            let leg = rotation * design.platform[i] + pose.translation.vector - design.base[i];
            let base = (leg.z / leg.norm()).acos().to_degrees();
            let in_platform = rotation.inverse() * leg;
            let platform = (in_platform.z / leg.norm()).acos().to_degrees();
            largest = (largest.0.max(base), largest.1.max(platform));
        }
        largest
    }

    #[test]
    fn joint_limits_remove_exactly_the_touches_beyond_them() {
        let design = paper::design();
        let balls = paper_balls();
        let free = candidate_pool(&design, &balls, &options(30.0)).unwrap();
        let pose_of = |c: &Candidate| {
            let ball = &balls[c.ball];
            tip_pose(
                &design,
                &(ball.centre + ball.radius * c.direction),
                c.rotation(),
            )
        };
        // Limits between the pool's smallest and largest leans, so that
        // both kinds of candidate exist.
        let (base_deg, platform_deg) = (40.0, 35.0);
        let within = |c: &Candidate| {
            let (base, platform) = leg_leans(&design, &pose_of(c));
            base <= base_deg && platform <= platform_deg
        };
        let expected: Vec<&Candidate> = free.iter().filter(|c| within(c)).collect();
        assert!(
            expected.len() > 100 && expected.len() + 100 < free.len(),
            "{} of {} within the limits",
            expected.len(),
            free.len()
        );
        let mut limited_options = options(30.0);
        limited_options.joint_limits = Some(JointLimits::along_normals(
            Some(base_deg.to_radians()),
            Some(platform_deg.to_radians()),
        ));
        let limited = candidate_pool(&design, &balls, &limited_options).unwrap();
        assert_eq!(limited.len(), expected.len());
        assert!(limited.iter().zip(&expected).all(|(a, b)| a == *b));
    }

    #[test]
    fn balls_below_the_base_give_no_candidate() {
        // The paper's balls mirrored through the base plane for a level
        // platform (tip z -> 120 - z, the tool 60 mm above it): a level
        // touch has the legs of a feasible touch above the base, the one
        // the machine, assembled with the platform above, would make.
        let below: Vec<NominalBall> = paper_balls()
            .into_iter()
            .map(|b| NominalBall {
                centre: Vec3::new(b.centre.x, b.centre.y, 120.0 - b.centre.z),
                ..b
            })
            .collect();
        let error = candidate_pool(&paper::design(), &below, &options(30.0)).unwrap_err();
        assert!(error.to_string().contains("below the base"), "{error}");
    }

    #[test]
    fn a_stroke_nothing_fits_is_an_error() {
        let mut options = options(10.0);
        options.stroke = [0.0, 1.0];
        let error = candidate_pool(&paper::design(), &paper_balls(), &options).unwrap_err();
        assert!(error.to_string().contains("stroke"), "{error}");
    }
}
