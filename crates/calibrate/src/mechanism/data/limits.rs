//! What a mechanism calibration accepts: the most observations, balls,
//! tied balls, actuators, pose coordinates, warm-start values and
//! trackers, and the fewest actuators, touches of a ball and points of a
//! tracker ([`MechanismData::validate`](super::MechanismData::validate)
//! refuses data beyond them).

/// The most observations of each kind: far beyond a calibration's needs
/// (a probed bed holds tens to hundreds), and small enough that the
/// dense checks over the rows stay within memory.
pub const MAX_OBSERVATIONS: usize = 1_000_000;
/// The most calibrated balls: as many as the most touches allow, each
/// ball taking at least [`MIN_TOUCHES_PER_BALL`] (every ball is a block
/// of its own, its radius too, which the solver eliminates).
pub const MAX_BALLS: usize = MAX_OBSERVATIONS / MIN_TOUCHES_PER_BALL;
/// The fewest touches of a ball: its centre takes three, and a fourth
/// is the first that checks them.
pub const MIN_TOUCHES_PER_BALL: usize = 4;
/// The most balls that calibrated distances tie together (a ball plate
/// holds tens): each adds its centre (and an uncertain radius) to the
/// dense global block, whose work per row grows with its square.
pub const MAX_TIED_BALLS: usize = 100;
/// The fewest actuators a mechanism calibrated here may have (one per
/// pose coordinate).
pub const MIN_ACTUATORS: usize = 3;
/// The most actuators (a cable robot of eight cables).
pub const MAX_ACTUATORS: usize = 8;
/// The most coordinates of a mechanism's pose (a rigid body's six).
pub const MAX_POSE_COORDINATES: usize = 6;
/// The most values of a mechanism's warm start
/// ([`Mechanism::warm_start`](parcal_kinematics::mechanism::Mechanism::warm_start):
/// a rigid body's translation and unit quaternion).
pub const MAX_WARM_START: usize = 7;
/// The most trackers: each adds its frame's six unknowns to the dense
/// global block (a calibration uses one per placement of the instrument,
/// a handful).
pub const MAX_TRACKERS: usize = 16;
/// The fewest points of a tracker (its poses' body origins counted as
/// points): three not on a line locate its frame.
pub const MIN_POINTS_PER_TRACKER: usize = 3;
