//! What the machine reaches when its controller commands a position or its
//! actuators read given values, and the whitened rows every observation
//! kind returns.

use std::borrow::Cow;

use nalgebra::{DMatrix, DVector};
use parcal_kinematics::batch_workspace::BatchWorkspace;
use parcal_kinematics::mechanism::{
    Mechanism, MechanismError, Reached, ReachedAlong, along_of_reached, warm_start_at_readings,
};
use smallvec::SmallVec;

/// The most actuations of a batch [`Actuation::at_readings`] gathers on the
/// stack: two batches of the hexapod's four SIMD lanes.
pub const ON_STACK: usize = 8;

/// The number of pose coordinates these kinds need: a position `(x, y, z)`.
pub const POSE_COORDINATES: usize = 3;

/// Whitened residual rows and their Jacobian with respect to the
/// mechanism's parameters (and, for some kinds, other unknowns).
#[derive(Debug, Clone, PartialEq)]
pub struct Rows {
    /// Whitened residuals `e / σ`.
    pub residual: DVector<f64>,
    /// `d(e / σ)/dp` (rows × parameters).
    pub d_params: DMatrix<f64>,
}

/// Where the machine with true parameters `params` is when its controller,
/// configured with `configured`, commands `commanded`: the tool point
/// `T(p, f(p, g(p_c, x_c)))` and its `dT/dp` at fixed readings (3 x
/// parameters; module doc), the forward kinematics started at `x_c`.
pub fn reached(
    mechanism: &dyn Mechanism,
    params: &[f64],
    configured: &[f64],
    commanded: &[f64; 3],
) -> Result<(DVector<f64>, DMatrix<f64>), MechanismError> {
    let reached = reached_at_command(mechanism, params, configured, commanded)?;
    Ok((
        DVector::from_column_slice(reached.point.as_slice()),
        reached.d_params.into_dense(),
    ))
}

/// [`reached`] with the warm start: the readings `g(p_c, x_c)` through
/// [`Mechanism::tool_point_at_readings`] from `x_c`'s warm start.
fn reached_at_command(
    mechanism: &dyn Mechanism,
    params: &[f64],
    configured: &[f64],
    commanded: &[f64; 3],
) -> Result<Reached, MechanismError> {
    let readings = mechanism.inverse(configured, commanded)?;
    let start = mechanism.warm_start(commanded)?;
    mechanism.tool_point_at_readings(params, readings.as_slice(), start.as_slice())
}

/// An actuation at readings among others ([`Actuation::tool_points`]):
/// its index, its readings and the warm start its forward kinematics
/// starts from.
type AtReadings<'a> = (usize, &'a [f64], Cow<'a, [f64]>);

/// The actuators' readings of an [`Actuation`], one per actuator: inline up
/// to a hexapod's six, so that a million touches' readings are not as many
/// allocations; more on the heap.
pub type Readings = SmallVec<[f64; 6]>;

/// How the machine was put where it observed: a position `x_c` its
/// controller commanded (the readings `g(p_c, x_c)` follow from the
/// configured parameters), or the readings `q` its actuators gave (a
/// hexapod's legs at a touch).
#[derive(Debug, Clone, PartialEq)]
pub enum Actuation {
    /// A commanded position `x_c` (mm, the controller's coordinates).
    Commanded([f64; 3]),
    /// The actuators' readings `q`, one per actuator.
    Readings(Readings),
}

/// Actuations by index, each with the warm start its forward kinematics
/// starts from, if any ([`Actuation::tool_points`]): a calibration's batch
/// reads them in place from its touches and their caches, a pair of slices
/// holds them side by side.
pub trait ActuationBatch {
    /// The number of actuations.
    fn len(&self) -> usize;

    /// Whether there are none.
    fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Actuation `k`.
    fn actuation(&self, k: usize) -> &Actuation;

    /// The warm start of actuation `k`, if any.
    fn start(&self, k: usize) -> Option<&[f64]>;
}

/// The actuations and, side by side, their warm starts.
impl ActuationBatch for (&[&Actuation], &[Option<&[f64]>]) {
    /// # Panics
    /// If the actuations and the starts differ in length.
    fn len(&self) -> usize {
        assert_eq!(self.0.len(), self.1.len(), "a start for each actuation");
        self.0.len()
    }

    fn actuation(&self, k: usize) -> &Actuation {
        self.0[k]
    }

    fn start(&self, k: usize) -> Option<&[f64]> {
        self.1[k]
    }
}

impl Actuation {
    /// `batch` of the readings and warm starts of `actuations` when every
    /// one is at readings from a warm start given (a calibration's
    /// iterations): gathered in one pass, on the stack for a batch of at
    /// most [`ON_STACK`] (a solver's batch, some hundred thousand a pass).
    /// `None`, `batch` not called, otherwise.
    pub fn at_readings<R>(
        actuations: &impl ActuationBatch,
        batch: impl FnOnce(&[&[f64]], &[&[f64]]) -> R,
    ) -> Option<R> {
        let n = actuations.len();
        let pair = |k| match (actuations.actuation(k), actuations.start(k)) {
            (Self::Readings(readings), Some(start)) => Some((readings.as_slice(), start)),
            _ => None,
        };
        if n > ON_STACK {
            let pairs = (0..n).map(pair).collect::<Option<Vec<_>>>()?;
            let (readings, starts): (Vec<_>, Vec<_>) = pairs.into_iter().unzip();
            return Some(batch(&readings, &starts));
        }
        let mut readings: [&[f64]; ON_STACK] = [&[]; ON_STACK];
        let mut starts: [&[f64]; ON_STACK] = [&[]; ON_STACK];
        for k in 0..n {
            (readings[k], starts[k]) = pair(k)?;
        }
        Some(batch(&readings[..n], &starts[..n]))
    }

    /// The pose (as a warm start) and tool point the machine of true
    /// parameters `params` reaches and the tool point's `dT/dp` at fixed
    /// readings: [`reached`] for a commanded position; for readings, the
    /// forward kinematics from the warm start `start` (of a pose near the
    /// one reached, such as the one a previous evaluation left), else from
    /// the mechanism's [`Mechanism::start_pose`].
    pub fn tool_point(
        &self,
        mechanism: &dyn Mechanism,
        params: &[f64],
        configured: &[f64],
        start: Option<&[f64]>,
    ) -> Result<Reached, MechanismError> {
        match self {
            Self::Commanded(commanded) => {
                reached_at_command(mechanism, params, configured, commanded)
            }
            Self::Readings(readings) => match start {
                Some(start) => mechanism.tool_point_at_readings(params, readings, start),
                None => {
                    let start = warm_start_at_readings(mechanism, params, readings)?;
                    mechanism.tool_point_at_readings(params, readings, start.as_slice())
                }
            },
        }
    }

    /// [`Actuation::tool_point`] of each of `actuations`, from its warm
    /// start if given, each outcome in order into `reached`:
    /// those at readings together ([`Mechanism::tool_points_at_readings`],
    /// the hexapod's SIMD lanes), the others one at a time. When every one
    /// is at readings from a warm start given (a calibration's iterations),
    /// the mechanism writes into the room `reached` holds. The batches
    /// share `workspace` ([`BatchWorkspace`]).
    pub fn tool_points(
        mechanism: &dyn Mechanism,
        params: &[f64],
        configured: &[f64],
        actuations: &impl ActuationBatch,
        workspace: &mut BatchWorkspace,
        reached: &mut Vec<Result<Reached, MechanismError>>,
    ) {
        let batch = |readings: &[&[f64]], starts: &[&[f64]]| {
            mechanism.tool_points_at_readings(params, readings, starts, workspace, reached);
        };
        if Self::at_readings(actuations, batch).is_some() {
            return;
        }
        let mut outcomes: Vec<Option<Result<Reached, MechanismError>>> =
            Vec::with_capacity(actuations.len());
        // The actuations at readings, by index, each with its start: the
        // one given, or the mechanism's.
        let mut at_readings: Vec<AtReadings<'_>> = Vec::new();
        for k in 0..actuations.len() {
            let outcome = match (actuations.actuation(k), actuations.start(k)) {
                (Self::Commanded(commanded), _) => {
                    Some(reached_at_command(mechanism, params, configured, commanded))
                }
                (Self::Readings(readings), Some(start)) => {
                    at_readings.push((k, readings, Cow::Borrowed(start)));
                    None
                }
                (Self::Readings(readings), None) => {
                    match warm_start_at_readings(mechanism, params, readings) {
                        Ok(start) => {
                            at_readings.push((k, readings, Cow::Owned(start.as_slice().to_vec())));
                            None
                        }
                        Err(e) => Some(Err(e)),
                    }
                }
            };
            outcomes.push(outcome);
        }
        let readings: Vec<&[f64]> = at_readings.iter().map(|(_, q, _)| *q).collect();
        let starts: Vec<&[f64]> = at_readings.iter().map(|(_, _, x)| x.as_ref()).collect();
        mechanism.tool_points_at_readings(params, &readings, &starts, workspace, reached);
        for ((k, _, _), outcome) in at_readings.iter().zip(reached.drain(..)) {
            outcomes[*k] = Some(outcome);
        }
        reached.extend(
            outcomes
                .into_iter()
                .map(|outcome| outcome.expect("every actuation reached")),
        );
    }

    /// [`Actuation::tool_points`] for a back-substitution along the step
    /// `dp` of the parameters, each outcome in order into `along`
    /// ([`ReachedAlong`]: `dT/dp |_q · dp` in place of `dT/dp |_q`, and the
    /// warm start predicted at `p + dp`): when every one is at readings from
    /// a warm start given (a calibration's iterations), the mechanism's
    /// [`Mechanism::tool_points_along`], into the room `along` holds; else
    /// from [`Actuation::tool_points`], each warm start its own prediction.
    pub fn tool_points_along(
        mechanism: &dyn Mechanism,
        params: &[f64],
        configured: &[f64],
        actuations: &impl ActuationBatch,
        dp: &[f64],
        workspace: &mut BatchWorkspace,
        along: &mut Vec<Result<ReachedAlong, MechanismError>>,
    ) {
        let batch = |readings: &[&[f64]], starts: &[&[f64]]| {
            mechanism.tool_points_along(params, readings, starts, dp, workspace, along);
        };
        if Self::at_readings(actuations, batch).is_some() {
            return;
        }
        let mut reached = Vec::with_capacity(actuations.len());
        Self::tool_points(
            mechanism,
            params,
            configured,
            actuations,
            workspace,
            &mut reached,
        );
        along.clear();
        along.extend(
            (reached.into_iter())
                .map(|outcome| outcome.and_then(|r| along_of_reached(mechanism, r, dp))),
        );
    }

    /// [`Actuation::tool_points`] of `actuations`, each from the
    /// mechanism's [`Mechanism::start_pose`] (or its commanded position),
    /// into a new vector.
    pub fn tool_points_from_scratch(
        mechanism: &dyn Mechanism,
        params: &[f64],
        configured: &[f64],
        actuations: &[&Actuation],
    ) -> Vec<Result<Reached, MechanismError>> {
        let starts = vec![None; actuations.len()];
        let mut reached = Vec::with_capacity(actuations.len());
        Self::tool_points(
            mechanism,
            params,
            configured,
            &(actuations, &starts[..]),
            &mut BatchWorkspace::default(),
            &mut reached,
        );
        reached
    }
}

/// Refuses a standard deviation that is not finite and positive.
pub(crate) fn check_sigma(what: &'static str, sigma: f64) -> Result<(), MechanismError> {
    if sigma.is_finite() && sigma > 0.0 {
        Ok(())
    } else {
        Err(MechanismError::NonFinite {
            what: format!("{what} {sigma} (a standard deviation must be finite and positive)"),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mechanism::test_support::delta;
    use parcal_kinematics::delta::LinearDelta;
    use parcal_kinematics::mechanism::design;
    use parcal_kinematics::mechanisms::by_name;

    /// The true delta of [`delta`] commanded twice and read twice, the
    /// one at commanded positions and the other at readings interleaved,
    /// and a start for the first read (the second starts from its own).
    fn mixed_actuations() -> (
        LinearDelta,
        DVector<f64>,
        DVector<f64>,
        [Actuation; 4],
        [f64; 3],
    ) {
        let (delta, configured, truth) = delta();
        let read = |x: [f64; 3]| {
            Readings::from_slice(delta.inverse(truth.as_slice(), &x).unwrap().as_slice())
        };
        let actuations = [
            Actuation::Commanded([40.0, -30.0, 18.0]),
            Actuation::Readings(read([10.0, 5.0, 30.0])),
            Actuation::Readings(read([-20.0, 15.0, 12.0])),
            Actuation::Commanded([0.0, 60.0, 5.0]),
        ];
        (delta, configured, truth, actuations, [9.0, 5.5, 29.0])
    }

    /// A batch at readings hands over each one's readings and warm start
    /// in order, on the stack and beyond it; one commanded position or one
    /// missing warm start hands over none.
    #[test]
    fn a_batch_at_readings_is_gathered_only_when_every_one_has_a_start() {
        let actuations: Vec<Actuation> = (0..ON_STACK + 3)
            .map(|k| Actuation::Readings(Readings::from_slice(&[k as f64, -(k as f64)])))
            .collect();
        let starts: Vec<[f64; 1]> = (0..actuations.len()).map(|k| [0.5 * k as f64]).collect();
        /// The pairs `at_readings` hands over for the first `n`
        /// actuations, copied.
        type Pairs = Vec<(Vec<f64>, Vec<f64>)>;
        fn handed_over(
            n: usize,
            actuations: &[Actuation],
            starts: &[Option<&[f64]>],
        ) -> Option<Pairs> {
            let refs: Vec<&Actuation> = actuations[..n].iter().collect();
            let batch = |readings: &[&[f64]], starts: &[&[f64]]| {
                let pairs = readings.iter().zip(starts);
                pairs.map(|(q, x)| (q.to_vec(), x.to_vec())).collect()
            };
            Actuation::at_readings(&(&refs[..], &starts[..n]), batch)
        }
        let given: Vec<Option<&[f64]>> = starts.iter().map(|x| Some(&x[..])).collect();
        for n in [0, 1, ON_STACK, ON_STACK + 3] {
            let all = handed_over(n, &actuations, &given).unwrap();
            let expected: Vec<(Vec<f64>, Vec<f64>)> = (0..n)
                .map(|k| (vec![k as f64, -(k as f64)], vec![0.5 * k as f64]))
                .collect();
            assert_eq!(all, expected, "{n} actuations");
        }
        for n in [3, ON_STACK + 2] {
            let mut missing = given.clone();
            missing[1] = None;
            assert!(
                handed_over(n, &actuations, &missing).is_none(),
                "{n} actuations"
            );
            let mut commanded = actuations.clone();
            commanded[n - 1] = Actuation::Commanded([0.0, 0.0, 1.0]);
            assert!(handed_over(n, &commanded, &given).is_none());
        }
    }

    #[test]
    fn actuations_together_reach_what_each_reaches_alone() {
        // The delta's mixed actuations: the same outcomes as one at a
        // time, to the bit (the delta has no batched forward kinematics).
        let (delta, configured, truth, actuations, start) = mixed_actuations();
        let (c, p) = (configured.as_slice(), truth.as_slice());
        let starts = [None, Some(&start[..]), None, None];
        let refs: Vec<&Actuation> = actuations.iter().collect();
        let mut together = Vec::new();
        let workspace = &mut BatchWorkspace::default();
        Actuation::tool_points(
            &delta,
            p,
            c,
            &(&refs[..], &starts[..]),
            workspace,
            &mut together,
        );
        for ((actuation, start), reached) in actuations.iter().zip(starts).zip(together) {
            let alone = actuation.tool_point(&delta, p, c, start).unwrap();
            assert_eq!(reached.unwrap(), alone);
        }
        // The hexapod's legs read at three poses, one reading short: the
        // other two reached (its lanes, to rounding), that one refused.
        let hexapod = by_name("hexapod").unwrap();
        let hexapod = hexapod.as_ref();
        let p = design(hexapod);
        let p = p.as_slice();
        let legs = |x: [f64; 6]| Readings::from_slice(hexapod.inverse(p, &x).unwrap().as_slice());
        let mut short = legs([5.0, 0.0, 235.0, 0.0, 0.02, 0.0]);
        short.pop();
        let actuations = [
            Actuation::Readings(legs([-30.0, 20.0, 240.0, 0.08, -0.05, 0.1])),
            Actuation::Readings(short),
            Actuation::Readings(legs([12.0, -8.0, 250.0, -0.03, 0.0, 0.05])),
        ];
        let refs: Vec<&Actuation> = actuations.iter().collect();
        // From the mechanism's starts, then from starts given (straight
        // into the room of the first outcomes, the geometry and row order
        // the first batch left in the workspace).
        let home = hexapod
            .start_pose(p, &legs([0.0, 0.0, 240.0, 0.0, 0.0, 0.0]))
            .unwrap();
        let home = hexapod.warm_start(home.as_slice()).unwrap();
        let mut together = Vec::new();
        let workspace = &mut BatchWorkspace::default();
        for starts in [[None; 3], [Some(home.as_slice()); 3]] {
            let batch = (&refs[..], &starts[..]);
            Actuation::tool_points(hexapod, p, &[], &batch, workspace, &mut together);
            assert_eq!(together.len(), 3);
            assert_eq!(
                together[1].as_ref().unwrap_err().to_string(),
                "hexapod needs 6 readings, got 5"
            );
            for k in [0, 2] {
                let alone = actuations[k].tool_point(hexapod, p, &[], None).unwrap();
                let reached = together[k].as_ref().unwrap();
                // The forward kinematics' 1e-9 mm.
                assert!((reached.point - alone.point).amax() < 1e-9);
                assert!((reached.d_params.to_dense() - alone.d_params.to_dense()).amax() < 1e-9);
            }
        }
    }

    #[test]
    fn actuations_along_a_step_are_their_rows_times_the_step() {
        // The delta's mixed actuations: each one's product with the step
        // from its own rows, to the bit, its warm start its prediction; a step
        // of the wrong length refuses each.
        let (delta, configured, truth, actuations, start) = mixed_actuations();
        let (c, p) = (configured.as_slice(), truth.as_slice());
        let starts = [None, Some(&start[..]), None, None];
        let refs: Vec<&Actuation> = actuations.iter().collect();
        let dp: Vec<f64> = (0..p.len()).map(|k| 1e-3 * (k as f64).cos()).collect();
        let mut along = Vec::new();
        let workspace = &mut BatchWorkspace::default();
        let batch = (&refs[..], &starts[..]);
        Actuation::tool_points_along(&delta, p, c, &batch, &dp, workspace, &mut along);
        for ((actuation, start), along) in actuations.iter().zip(starts).zip(&along) {
            let alone = actuation.tool_point(&delta, p, c, start).unwrap();
            let expected = along_of_reached(&delta, alone, &dp).unwrap();
            assert_eq!(along.as_ref().unwrap(), &expected);
            assert_eq!(expected.predicted, expected.reached.warm_start);
        }
        let short = &dp[1..];
        Actuation::tool_points_along(&delta, p, c, &batch, short, workspace, &mut along);
        for outcome in &along {
            let error = outcome.as_ref().unwrap_err().to_string();
            assert!(error.contains("parameter step values"), "{error}");
        }
        // The hexapod's legs read from starts given: its own lanes.
        let hexapod = by_name("hexapod").unwrap();
        let hexapod = hexapod.as_ref();
        let p = design(hexapod);
        let p = p.as_slice();
        let pose = [-30.0, 20.0, 240.0, 0.08, -0.05, 0.1];
        let readings = Readings::from_slice(hexapod.inverse(p, &pose).unwrap().as_slice());
        let home = warm_start_at_readings(hexapod, p, &readings).unwrap();
        let dp = vec![1e-4; p.len()];
        let read = Actuation::Readings(readings.clone());
        let starts = [Some(home.as_slice())];
        let workspace = &mut BatchWorkspace::default();
        Actuation::tool_points_along(
            hexapod,
            p,
            &[],
            &(&[&read][..], &starts[..]),
            &dp,
            workspace,
            &mut along,
        );
        let (mut own, workspace) = (Vec::new(), &mut BatchWorkspace::default());
        let x = [home.as_slice()];
        hexapod.tool_points_along(p, &[&readings], &x, &dp, workspace, &mut own);
        assert_eq!(along, own);
    }
}
