//! The crate's errors: one sentence each, naming the row of a refused
//! target.

use parcal_kinematics::KinematicsError;
use rayon::prelude::*;

/// Why one target cannot be commanded.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum Refusal {
    /// A value of the target is NaN or infinite.
    #[error("{what} is not a finite number")]
    NonFinite {
        /// `x`, `roll`, ...
        what: &'static str,
    },
    /// A leg would need a non-positive length.
    #[error("leg {leg} would be {length:.6} mm long (not positive)")]
    InfeasibleLeg {
        /// The leg (1-based).
        leg: usize,
        /// Its length (mm).
        length: f64,
    },
    /// The target puts the platform on the other side of the base than the
    /// machine's assembly mode (`parcal_kinematics::assembly`).
    #[error(
        "the platform would be {depth:.3} mm below the base (its joints' centroid under the base joints' along the base's +z): that is the other assembly mode, and readings for it would drive the machine, assembled with the platform above its base, to the target's mirror image through the base"
    )]
    OtherAssembly {
        /// How far below the base (mm, `-platform_height`).
        depth: f64,
    },
    /// The readings' forward kinematics from the machine's home pose (its
    /// assembly mode) reaches another pose.
    #[error(
        "the readings would take the machine elsewhere: from its home pose (its assembly mode) they reach the tool tip ({:.3}, {:.3}, {:.3}), the platform {distance:.3e} mm from the target's pose (tolerance {tolerance:.0e} mm)",
        tip.x, tip.y, tip.z
    )]
    Elsewhere {
        /// The tool tip reached (design frame, mm).
        tip: parcal_kinematics::Vec3,
        /// `parcal_kinematics::assembly::pose_distance` of the reached and
        /// the target's pose (mm).
        distance: f64,
        /// `parcal_kinematics::assembly::REACH_TOLERANCE`.
        tolerance: f64,
    },
    /// The readings' forward kinematics from the machine's home pose failed.
    #[error("the readings' forward kinematics from the machine's home pose failed: {0}")]
    Unreached(KinematicsError),
    /// An actuator reading outside machine.json's `stroke`.
    #[error("q{leg} = {reading:.6} {unit} is outside the stroke [{min}, {max}]")]
    OutsideStroke {
        /// The actuator (1-based).
        leg: usize,
        /// Its reading.
        reading: f64,
        /// The actuators' unit.
        unit: String,
        /// The stroke.
        min: f64,
        /// The stroke.
        max: f64,
    },
    /// A joint beyond machine.json's `joint_limits`.
    #[error("{0}")]
    BeyondJointLimit(parcal_kinematics::JointViolation),
    /// Too close to a singular configuration ([`crate::SINGULARITY_RATIO`]).
    #[error(
        "near a singular configuration: the inverse kinematics Jacobian's smallest singular value is {ratio:.2e} of its largest (limit {limit:.0e})"
    )]
    NearSingular {
        /// `sigma_min / sigma_max` of the normalised Jacobian.
        ratio: f64,
        /// The limit.
        limit: f64,
    },
    /// The nominal model's forward kinematics failed at the commands.
    #[error("the nominal model's forward kinematics failed: {0}")]
    NominalForward(KinematicsError),
}

/// Why a calibration cannot be applied.
#[derive(Debug, thiserror::Error)]
pub enum ApplyError {
    /// calibration.json lacks what applying needs.
    #[error("{0}")]
    Missing(String),
    /// A geometry cannot define its frames or is not finite.
    #[error("{what}: {source}")]
    Geometry {
        /// Which geometry.
        what: &'static str,
        /// Why.
        source: KinematicsError,
    },
    /// The rigid fit of the calibrated joints onto the design's failed.
    #[error("placing the calibrated geometry in the design frame: {0}")]
    Placement(parcal_accuracy::AccuracyError),
    /// A target was refused.
    #[error("row {row}: {refusal}")]
    Refused {
        /// The row (1-based, the first after the header).
        row: usize,
        /// Why.
        refusal: Refusal,
    },
    /// The predicted accuracy could not be computed.
    #[error("predicted accuracy: {0}")]
    Prediction(String),
    /// A correction-table grid that cannot be interpolated.
    #[error("correction table grid: {0}")]
    Grid(String),
}

/// `f` of every item, in order, made on the threads; the first refusal in
/// the items' order, on any number of threads, is an error naming its row
/// (1-based).
pub(crate) fn row_by_row<T: Sync, U: Send>(
    items: &[T],
    f: impl Fn(&T) -> Result<U, Refusal> + Sync + Send,
) -> Result<Vec<U>, ApplyError> {
    first_refused(items.par_iter().map(f).collect())
}

/// [`row_by_row`] with `f` given the items `size` at a time (the last
/// piece may hold fewer), each piece's outcomes in its items' order.
pub(crate) fn in_pieces<T: Sync, U: Send>(
    items: &[T],
    size: usize,
    f: impl Fn(&[T]) -> Vec<Result<U, Refusal>> + Sync + Send,
) -> Result<Vec<U>, ApplyError> {
    first_refused(items.par_chunks(size).flat_map_iter(f).collect())
}

/// Every value of `outcomes`, in order, or the first refusal, naming its
/// row (1-based).
fn first_refused<U>(outcomes: Vec<Result<U, Refusal>>) -> Result<Vec<U>, ApplyError> {
    (outcomes.into_iter().enumerate())
        .map(|(k, outcome)| {
            outcome.map_err(|refusal| ApplyError::Refused {
                row: k + 1,
                refusal,
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Of several refused rows, the first in order is named, on any number
    /// of threads; otherwise every row's value, in order.
    #[test]
    fn the_first_refused_row_is_named_on_any_number_of_threads() {
        let items: Vec<usize> = (0..5000).collect();
        let refuse_at = |bad: &'static [usize]| {
            move |&k: &usize| match bad.contains(&k) {
                true => Err(Refusal::NonFinite { what: "x" }),
                false => Ok(2 * k),
            }
        };
        for threads in [1, 2, 3] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            let error = pool
                .install(|| row_by_row(&items, refuse_at(&[4321, 17, 2600])))
                .unwrap_err();
            assert!(
                matches!(error, ApplyError::Refused { row: 18, .. }),
                "{threads} threads: {error}"
            );
            let values = pool.install(|| row_by_row(&items, refuse_at(&[]))).unwrap();
            assert!(values.iter().enumerate().all(|(k, &v)| v == 2 * k));
            // Pieces of 8 (the last of 5000 - 4992 = 8, then of 3 with 4995
            // items) name the same row and give the same values.
            for n in [5000, 4995] {
                let pieces = |bad: &'static [usize]| {
                    let f = refuse_at(bad);
                    move |piece: &[usize]| piece.iter().map(&f).collect::<Vec<_>>()
                };
                let error = pool
                    .install(|| in_pieces(&items[..n], 8, pieces(&[4321, 17, 2600])))
                    .unwrap_err();
                assert!(matches!(error, ApplyError::Refused { row: 18, .. }));
                let values = pool
                    .install(|| in_pieces(&items[..n], 8, pieces(&[])))
                    .unwrap();
                assert_eq!(values, (0..n).map(|k| 2 * k).collect::<Vec<_>>());
            }
        }
    }
}
