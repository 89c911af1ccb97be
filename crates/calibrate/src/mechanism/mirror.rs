//! Balls on the wrong side of their touches in a mechanism calibration
//! ([`crate::mirror`] for why a ball's centre fit can start at the mirror
//! image of where it is). Once the fit has settled ([`SETTLED`]), each
//! ball whose share of the data cost is beyond its family's quantile
//! ([`misfit_balls`]) is tested with the tool points its touches reach at
//! that iterate ([`mirror_side`]). If some fit the mirror image
//! [`MIRROR_GAIN`](crate::mirror::MIRROR_GAIN) times better, the fit stops
//! there, re-seeds each at the mirror image of its centre fit (its
//! touches' own unknowns too: [`super::fit::FitProblem::reseed`]), and
//! resumes from that iterate, once, within the iteration and time limits.
//! A ball's centre prior, if any, stays where it was stated.

use nalgebra::{DVector, SVector, Vector3};
use parcal_solver::{Decision, Iterate, IterationRecord, Monitor, Problem};

use crate::fit::misfit_balls;
use crate::mirror::{SETTLED, mirror_side};

use super::problem::MechanismProblem;
use super::reaches::Reaches;
use super::warm_start::WarmStart;

/// A ball found on the wrong side of its touches.
#[derive(Debug, Clone, PartialEq)]
pub struct MirroredBall {
    /// Its 0-based index.
    pub ball: usize,
    /// The linear solves before the iterate that showed it.
    pub iteration: usize,
    /// Its whitened data cost at that iterate.
    pub chi_square: f64,
    /// How many times better its touches' tool points there fit the
    /// mirror image of its centre than the side it was on.
    pub gain: f64,
    /// Its re-seeded centre: the mirror fit of those tool points.
    pub centre: [f64; 3],
}

/// A ball found on the wrong side, with the tool points its touches
/// reached there (in the order of its touches' points), which its
/// re-seeding needs.
pub(crate) type Found = (MirroredBall, Vec<Vector3<f64>>);

/// Watches the first solve of a fit for balls on the wrong side of their
/// touches (module doc), passing each iteration's record to `observer`.
pub(crate) struct WrongSideWatch<'w, 'p, const C: usize> {
    base: &'w MechanismProblem<'p, C>,
    observer: &'w mut dyn FnMut(&IterationRecord),
    /// The balls found at the iterate the solve stopped at.
    pub found: Vec<Found>,
}

impl<'w, 'p, const C: usize> WrongSideWatch<'w, 'p, C> {
    /// A watch over the balls of `base`.
    pub(crate) fn new(
        base: &'w MechanismProblem<'p, C>,
        observer: &'w mut dyn FnMut(&IterationRecord),
    ) -> Self {
        Self {
            base,
            observer,
            found: Vec::new(),
        }
    }

    /// Ball `b` (its group `k`) tested at `global` and its block `block`,
    /// its touches reached from `caches`: the mirror fit when it is on the
    /// wrong side (a touch the machine no longer reaches leaves it
    /// untested: the solve names it).
    fn test(
        &self,
        b: usize,
        k: usize,
        global: &DVector<f64>,
        block: &SVector<f64, C>,
        caches: &[WarmStart],
    ) -> Option<(f64, [f64; 3], Vec<Vector3<f64>>)> {
        let points = Problem::<C, 0, 1>::group_points(self.base, k);
        let mut reaches = Reaches::default();
        (self.base).reach(points.clone(), global, &caches[points], &mut reaches);
        let tips = (reaches.at.iter())
            .map(|reached| reached.as_ref().ok().map(|reached| reached.point))
            .collect::<Option<Vec<_>>>()?;
        let ball = self.base.touched_ball(b, global, block);
        let (side, mirror) = mirror_side(&tips, ball.radius, &ball.centre)?;
        Some((side.cost / mirror.cost, mirror.centre.into(), tips))
    }
}

impl<const C: usize, const P: usize> Monitor<C, P, WarmStart> for WrongSideWatch<'_, '_, C> {
    fn record(&mut self, record: &IterationRecord) {
        (self.observer)(record);
    }

    fn inspect(&mut self, iterate: &Iterate<'_, C, P, WarmStart>) -> Decision {
        if iterate.relative_change() > SETTLED {
            return Decision::Continue;
        }
        let samples = self.base.data().observations.samples.len();
        let costs = &iterate.group_costs[samples..];
        let touches = (0..costs.len())
            .map(|b| Problem::<C, 0, 1>::group_points(self.base, samples + b).len());
        let state = iterate.state;
        for misfit in misfit_balls(|b| format!("ball {b}"), costs, touches) {
            let (b, k) = (misfit.ball, samples + misfit.ball);
            let found = self.test(b, k, &state.global, &state.groups[k], iterate.caches);
            if let Some((gain, centre, tips)) = found {
                let ball = MirroredBall {
                    ball: b,
                    iteration: iterate.solves,
                    chi_square: misfit.chi_square,
                    gain,
                    centre,
                };
                self.found.push((ball, tips));
            }
        }
        if self.found.is_empty() {
            Decision::Continue
        } else {
            Decision::Stop
        }
    }
}
