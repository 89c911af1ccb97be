//! What a simulated campaign is: the machine, the artefact layout and the
//! conditions of the paper's table 1, with the choices the paper leaves open
//! fixed as docs/paper-scenario.md section 3 states them.

use nalgebra::UnitQuaternion;
use parcal_kinematics::{Geometry, Vec3, paper};

use crate::{Plate, Rng};

/// The stream of [`Scenario::design_drawn`] (the balls use `0..n`, a
/// random plan and the plate `u64::MAX`).
const DESIGN_STREAM: u64 = u64::MAX - 1;

/// Everything that defines a simulated campaign except the seed.
#[derive(Debug, Clone, PartialEq)]
pub struct Scenario {
    /// Nominal geometry, design frame (written to machine.json).
    pub design: Geometry,
    /// True geometry, design frame (written to truth.json).
    pub truth: Geometry,
    /// True ball centres, design frame; also their nominal centres.
    pub centres: Vec<Vec3>,
    /// Contacts per ball.
    pub points_per_ball: usize,
    /// Largest |yaw|, |pitch|, |roll| of the platform at a contact (rad).
    pub max_tilt: f64,
    /// True ball radius (mm).
    pub radius: f64,
    /// Error of the calibrated radius given to the calibration (1 sigma, mm).
    pub radius_sigma: f64,
    /// Actuator repeatability (1 sigma per actuator and contact, in the
    /// actuators' unit: [`Scenario::readings`]).
    pub actuator_sigma: f64,
    /// Tool positioning repeatability (1 sigma per axis and contact, mm).
    pub tool_sigma: f64,
    /// Design tolerance: a priori sigma of every geometric parameter (mm).
    pub prior_sigma: f64,
    /// A priori sigma of the nominal ball centres (mm).
    pub centre_sigma: f64,
    /// A calibrated ball plate over the balls, written as the distances of
    /// artefacts.json; none in the paper.
    pub plate: Option<Plate>,
    /// The range of every actuator reading `[min, max]` (actuators' unit),
    /// written to machine.json.
    pub stroke: Option<[f64; 2]>,
    /// What the actuators read: leg `i` is `l_i + s_i q_i` long.
    pub readings: Readings,
    /// Planned touches (`parcal plan`) in place of the random ones:
    /// `points_per_ball` is then ignored.
    pub plan: Option<Vec<PlannedTouch>>,
}

/// What the actuators read (machine.json's `actuator`, truth.json's
/// `actuator_scale`): leg `i` is `l_i + s_i q_i` long for the reading `q_i`.
#[derive(Debug, Clone, PartialEq)]
pub struct Readings {
    /// The readings' unit, free text (machine.json `actuator.unit`).
    pub unit: String,
    /// Design scales `s_i`, mm per unit (machine.json).
    pub design_scale: [f64; 6],
    /// True scales, mm per unit (truth.json).
    pub true_scale: [f64; 6],
    /// A priori sigma of each scale (mm per unit); `None`: scales known.
    pub scale_sigma: Option<[f64; 6]>,
}

impl Readings {
    /// Millimetres, scale 1 and known (machine.json's default).
    pub fn millimetres() -> Self {
        Self {
            unit: "mm".to_owned(),
            design_scale: [1.0; 6],
            true_scale: [1.0; 6],
            scale_sigma: None,
        }
    }

    /// An instrument campaign's readings (`parcal simulate --tracker`'s
    /// machines: Jugglebot's motor revolutions, `TrackerScenario::jugglebot_like`).
    pub fn of(tracker: &crate::TrackerScenario) -> Self {
        Self {
            unit: tracker.unit.clone(),
            design_scale: tracker.design_scale,
            true_scale: tracker.true_scale,
            scale_sigma: tracker.scale_sigma,
        }
    }

    /// Whether these are machine.json's default readings (mm, scale 1,
    /// known).
    pub fn is_default(&self) -> bool {
        *self == Self::millimetres()
    }
}

/// One planned touch: the ball, the outward normal `u` at the contact point
/// and the platform orientation, both in the design frame.
#[derive(Debug, Clone, PartialEq)]
pub struct PlannedTouch {
    /// The ball (index into [`Scenario::centres`]).
    pub ball: usize,
    /// Unit outward normal `u`: the true contact point is `C + r u`.
    pub direction: Vec3,
    /// The platform orientation.
    pub rotation: UnitQuaternion<f64>,
}

impl Scenario {
    /// The paper's scenario: table 2's machine, 27 balls on a 3 x 3 x 3 grid
    /// (x, y in {-60, 0, 60}, z in {360, 400, 440}), 7 contacts per ball,
    /// tilts up to 10 degrees, the conditions of table 1, and the stroke of
    /// readings 20 to 250 mm (leg lengths 255 to 485 mm).
    pub fn paper() -> Self {
        let steps = [-60.0, 0.0, 60.0];
        let mut centres = Vec::with_capacity(27);
        for z in [360.0, 400.0, 440.0] {
            for y in steps {
                for x in steps {
                    centres.push(Vec3::new(x, y, z));
                }
            }
        }
        Self {
            design: paper::design(),
            truth: paper::truth(),
            centres,
            points_per_ball: 7,
            max_tilt: 10f64.to_radians(),
            radius: 5.0,
            radius_sigma: 0.001,
            actuator_sigma: 0.001,
            tool_sigma: 0.001,
            prior_sigma: 0.1,
            centre_sigma: 0.1,
            plate: None,
            stroke: Some([20.0, 250.0]),
            readings: Readings::millimetres(),
            plan: None,
        }
    }

    /// This campaign with the actuators reading `readings` instead of mm:
    /// the same physical noise and stroke in their unit, the actuator
    /// sigma divided by the mean design scale, the stroke widened to hold
    /// every leg's readings (`[min / max s, max / min s]`).
    pub fn reading(self, readings: Readings) -> Self {
        let scales = readings.design_scale;
        let mean = scales.iter().sum::<f64>() / 6.0;
        let (low, high) = scales
            .iter()
            .fold((f64::INFINITY, 0.0f64), |(l, h), &s| (l.min(s), h.max(s)));
        Self {
            actuator_sigma: self.actuator_sigma / mean,
            stroke: self.stroke.map(|[min, max]| [min / high, max / low]),
            readings,
            ..self
        }
    }

    /// The paper's machine and conditions with `balls` balls on a regular
    /// grid filling the box x, y in [-80, 80], z in [340, 460] (design
    /// frame), `points_per_ball` contacts each and tilts up to `max_tilt` rad.
    pub fn scaled(balls: usize, points_per_ball: usize, max_tilt: f64) -> Self {
        Self {
            centres: box_grid(balls),
            points_per_ball,
            max_tilt,
            ..Self::paper()
        }
    }

    /// This campaign with its design drawn about its truth: every
    /// coordinate of the design (base and platform joints, tool, leg
    /// lengths) the truth's plus a normal deviate of sigma `prior_sigma`,
    /// from stream `(seed, DESIGN_STREAM)`. The truth is then a draw of the
    /// prior the design states (design ± tolerance), as the statistical
    /// tests of a calibration assume; the paper's table 2 is one fixed
    /// truth, whose prior rows do not scatter from seed to seed.
    pub fn design_drawn(self, seed: u64) -> Self {
        let mut rng = Rng::new(seed, DESIGN_STREAM);
        let sigma = self.prior_sigma;
        let mut near = |v: &Vec3| v.map(|c| c + rng.normal(sigma));
        let truth = &self.truth;
        let base = truth.base.each_ref().map(&mut near);
        let platform = truth.platform.each_ref().map(&mut near);
        let tool = near(&truth.tool);
        let legs = truth.legs.map(|l| l + rng.normal(sigma));
        Self {
            design: Geometry {
                base,
                platform,
                tool,
                legs,
            },
            ..self
        }
    }

    /// Number of contacts of the campaign.
    pub fn contacts(&self) -> usize {
        match &self.plan {
            Some(plan) => plan.len(),
            None => self.centres.len() * self.points_per_ball,
        }
    }
}

/// `count` points of a regular grid over x, y in [-80, 80], z in [340, 460]:
/// `n x n x m` nodes with the spacing as even as the box allows, filled
/// layer by layer from the bottom (the top layer may be partial).
fn box_grid(count: usize) -> Vec<Vec3> {
    let (side, height) = (160.0, 120.0);
    // n^2 m >= count with m / n ~ height / side.
    let n = ((count as f64 * side / height).cbrt().ceil() as usize).max(1);
    let m = count.div_ceil(n * n).max(1);
    let node = |k: usize, nodes: usize, low: f64, span: f64| {
        if nodes == 1 {
            low + span / 2.0
        } else {
            low + span * k as f64 / (nodes - 1) as f64
        }
    };
    (0..count)
        .map(|k| {
            let (ix, iy, iz) = (k % n, (k / n) % n, k / (n * n));
            Vec3::new(
                node(ix, n, -80.0, side),
                node(iy, n, -80.0, side),
                node(iz, m, 340.0, height),
            )
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn paper_grid_is_3x3x3() {
        let scenario = Scenario::paper();
        assert_eq!(scenario.centres.len(), 27);
        assert_eq!(scenario.contacts(), 189);
        assert_eq!(scenario.centres[0], Vec3::new(-60.0, -60.0, 360.0));
        assert_eq!(scenario.centres[26], Vec3::new(60.0, 60.0, 440.0));
    }

    #[test]
    fn box_grid_fills_the_box() {
        for count in [1, 8, 27, 100, 14_286] {
            let grid = box_grid(count);
            assert_eq!(grid.len(), count);
            for c in &grid {
                assert!(c.x.abs() <= 80.0 && c.y.abs() <= 80.0 && (340.0..=460.0).contains(&c.z));
            }
            for (a, b) in grid.iter().zip(grid.iter().skip(1)) {
                assert!(a != b, "duplicated node");
            }
        }
        let grid = box_grid(27);
        assert_eq!(grid[0], Vec3::new(-80.0, -80.0, 340.0));
    }
}
