//! Tests of systematic errors: when the global test says the data misfit
//! their noise, which common error of the entered data explains it (the
//! w-test of a one-dimensional alternative hypothesis: Baarda, "A testing
//! procedure for use in geodetic networks", 1968; Teunissen, "Testing
//! theory", 2000, section 3.2); and whatever the global test says, how
//! large such an error must be to show, and what one that does not show
//! does to the parameters.
//!
//! An [`Effect`] of size `t` (every ball's entered radius off by `t` mm,
//! every calibrated distance off by the factor `1 + t`) changes the
//! whitened residuals at the estimate by `t c`. With `P = I − J N⁻¹ Jᵀ`,
//! the projector onto the residuals (`J` the whitened Jacobian of every
//! row, priors included), the estimate of `t` from the residuals `ê`, its
//! standard deviation and its normalised value are
//!
//! ```text
//! t̂ = −cᵀPê / cᵀPc,     σ_t = 1 / √(cᵀPc),     w = t̂ / σ_t,
//! ```
//!
//! and removing the effect (one more unknown) lowers the weighted sum of
//! squares `Ω` by `w²`: the variance factor becomes `(Ω − w²) / (r − 1)`.
//! The two quadratic forms come from the minimum of the linearised cost of
//! the problem with the effect applied, `m(t) = ‖P e(t)‖² = Ω + 2t cᵀPê +
//! t² cᵀPc` ([`parcal_solver::reduced_step`]: `ρ − bᵀS⁻¹b` of the reduced
//! system; `Pê = ê` at convergence), at `t = ±h`: two passes over the
//! contacts per effect, no back-substitution, made for every converged
//! least-squares run ([`crate::verdict::at_minimum`]). The residuals are
//! linear in both effects, so the two values give the quadratic exactly.
//!
//! **Sensitivity.** The smallest effect the test finds with power
//! [`POWER`](crate::hypothesis::POWER) at level [`SYSTEMATIC_LEVEL`], its minimal detectable bias,
//! is `|∇| = δ₀ σ_t = δ₀ / √(cᵀPc)`, `δ₀ = z_{1−α₀/2} + z_{POWER}`: an
//! effect of that size moves `E(w)` to `δ₀` (Baarda 1968). An effect
//! `∇` that goes undetected shifts the estimate of the global block by
//!
//! ```text
//! Δg = −N⁻¹ Jᵀ c ∇ = ∇ (δ_g(h) − δ_g(−h)) / 2h,
//! ```
//!
//! `δ_g(t)` the global part of the Gauss–Newton step of the same two
//! reduced systems (the step is linear in `t`); its effect on the registered accuracy map is the
//! report's (`parcal_report::diagnostics`), as for one observation's
//! ([`crate::external`]).

use nalgebra::DVector;
use parcal_solver::{Problem, State, reduced_step};

use crate::CalibrateError;
use crate::hypothesis::{critical_value, minimal_detectable_bias};
use crate::problem::{CalibrationProblem, ContactObservations};
use crate::verdict::{GLOBAL_TEST_LEVEL, GlobalTest};

/// The level of each systematic test (Baarda's `α₀` of one test).
pub const SYSTEMATIC_LEVEL: f64 = 0.001;

/// A common error of the entered data.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Effect {
    /// Every ball's entered radius off by `t` mm (the nominal radius for
    /// the calibrated one, an uncompensated stylus): artefacts.json's
    /// radii, the ball touches' model.
    BallRadius,
    /// Every calibrated distance off by the factor `1 + t` (the plate's
    /// temperature, its calibration's scale): artefacts.json's distances.
    DistanceScale,
}

impl Effect {
    /// Its name in sentences and in calibration.json.
    pub fn name(self) -> &'static str {
        match self {
            Self::BallRadius => "ball radius",
            Self::DistanceScale => "distance scale",
        }
    }

    /// The unit of `t`.
    pub fn unit(self) -> &'static str {
        match self {
            Self::BallRadius => "mm",
            Self::DistanceScale => "1",
        }
    }

    /// `d(entered value)/dt` of an entered value `v`.
    fn derivative(self, v: f64) -> f64 {
        match self {
            Self::BallRadius => 1.0,
            Self::DistanceScale => v,
        }
    }

    /// The size `h` of the effect applied to measure it: large enough that
    /// `h² cᵀPc` stands well above the rounding of `Ω`.
    fn step(self) -> f64 {
        match self {
            Self::BallRadius => 0.01,
            Self::DistanceScale => 1e-4,
        }
    }
}

/// The test of one systematic effect.
#[derive(Debug, Clone, PartialEq)]
pub struct SystematicTest {
    /// The effect.
    pub effect: Effect,
    /// Its estimate `t̂` from the residuals: the correction of the entered
    /// data (in [`Effect::unit`]).
    pub estimate: f64,
    /// Its standard deviation `σ_t`.
    pub sigma: f64,
    /// The shift of the global block's estimate per unit of the effect in
    /// the entered data, `−N⁻¹ Jᵀ c` (module doc; the global block's units
    /// per [`Effect::unit`]).
    pub global_shift: DVector<f64>,
}

impl SystematicTest {
    /// `w = t̂ / σ_t`, standard normal without the effect.
    pub fn normalised(&self) -> f64 {
        self.estimate / self.sigma
    }

    /// The critical value of `|w|` at [`SYSTEMATIC_LEVEL`].
    pub fn critical_value(&self) -> f64 {
        critical_value(SYSTEMATIC_LEVEL, 1)
    }

    /// Whether the data show the effect: `|w|` above its critical value.
    pub fn significant(&self) -> bool {
        self.normalised().abs() > self.critical_value()
    }

    /// The effect's minimal detectable bias `δ₀ σ_t` (in [`Effect::unit`]):
    /// the smallest the test finds at [`SYSTEMATIC_LEVEL`] with power
    /// [`POWER`](crate::hypothesis::POWER).
    pub fn minimal_detectable_bias(&self) -> f64 {
        minimal_detectable_bias(1.0, SYSTEMATIC_LEVEL) * self.sigma
    }

    /// The shift of the global block that an undetected effect of one
    /// minimal detectable bias makes.
    pub fn undetected_shift(&self) -> DVector<f64> {
        &self.global_shift * self.minimal_detectable_bias()
    }

    /// The global test of the run `global` with the effect removed: `Ω −
    /// w²` with one degree of freedom fewer.
    pub fn without(&self, global: &GlobalTest) -> Option<GlobalTest> {
        let w = self.normalised();
        GlobalTest::new(
            global.cost - w * w,
            global.redundancy.checked_sub(1)?,
            GLOBAL_TEST_LEVEL,
        )
    }
}

/// The tests of the effects the data of `problem` can show, with their
/// shifts, at its converged `state` whose global test is `global` (module
/// doc); `caches`
/// as [`reduced_step`] takes them. An effect no observation carries (no
/// distances, no radius information) is left out.
pub fn systematic_tests<const R: usize, const P: usize, const G: usize, O>(
    problem: &mut CalibrationProblem<'_, O, G>,
    state: &State<G, P>,
    caches: &mut Vec<<CalibrationProblem<'_, O, G> as Problem<G, P, R>>::PointCache>,
    groups_per_chunk: usize,
    global: &GlobalTest,
) -> Result<Vec<SystematicTest>, CalibrateError>
where
    O: ContactObservations<R, P>,
{
    let mut tests = Vec::new();
    for effect in [Effect::BallRadius, Effect::DistanceScale] {
        let entered = problem.entered(effect);
        if entered.is_empty() {
            continue;
        }
        let h = effect.step();
        // The minimum of the linearised cost and the step's global part.
        let mut reduced = |t: f64| -> Result<(f64, DVector<f64>), CalibrateError> {
            let shifted: Vec<f64> = entered
                .iter()
                .map(|&v| v + t * effect.derivative(v))
                .collect();
            problem.set_entered(effect, &shifted);
            let step = reduced_step(&*problem, state, caches, groups_per_chunk);
            problem.set_entered(effect, &entered);
            let step = step.map_err(|status| CalibrateError::Calibration {
                reason: format!("the test of a common {} error: {status:?}", effect.name()),
            })?;
            Ok((step.minimum, step.global))
        };
        let ((up, step_up), (down, step_down)) = (reduced(h)?, reduced(-h)?);
        let c_pe = (up - down) / (4.0 * h);
        let c_pc = (up + down - 2.0 * global.cost) / (2.0 * h * h);
        // Nothing carries the effect (a radius prior without information,
        // an effect the unknowns absorb): not estimable.
        if c_pc.is_finite() && c_pc > f64::EPSILON.sqrt() * (up + down) / (h * h) {
            tests.push(SystematicTest {
                effect,
                estimate: -c_pe / c_pc,
                sigma: c_pc.sqrt().recip(),
                global_shift: (step_up - step_down) / (2.0 * h),
            });
        }
    }
    Ok(tests)
}

impl<O, const G: usize> CalibrationProblem<'_, O, G> {
    /// The entered values `effect` changes, in a fixed order: each ball's
    /// radius (the prior's mean for a per-ball radius, the global prior's
    /// for a ball in the global block), each distance's length.
    fn entered(&self, effect: Effect) -> Vec<f64> {
        match effect {
            Effect::BallRadius if G == 4 => {
                let Some(priors) = &self.ball_priors else {
                    return Vec::new();
                };
                let mut values: Vec<f64> = priors.iter().map(|p| p.mean[G - 1]).collect();
                if let Some(global) = &self.global_prior {
                    values.extend(self.radius_columns().map(|c| global.mean[c]));
                }
                values
            }
            Effect::BallRadius => self.radii.clone(),
            Effect::DistanceScale => self.distances.iter().map(|d| d.block.length).collect(),
        }
    }

    /// Sets the values [`Self::entered`] lists.
    fn set_entered(&mut self, effect: Effect, values: &[f64]) {
        match effect {
            Effect::BallRadius if G == 4 => {
                let columns: Vec<usize> = self.radius_columns().collect();
                let Some(priors) = &mut self.ball_priors else {
                    return;
                };
                let (balls, global) = values.split_at(priors.len());
                for (prior, &v) in priors.iter_mut().zip(balls) {
                    prior.mean[G - 1] = v;
                }
                if let Some(prior) = &mut self.global_prior {
                    for (c, &v) in columns.into_iter().zip(global) {
                        prior.mean[c] = v;
                    }
                }
            }
            Effect::BallRadius => self.radii.copy_from_slice(values),
            Effect::DistanceScale => {
                for (d, &v) in self.distances.iter_mut().zip(values) {
                    d.block.length = v;
                }
            }
        }
    }

    /// The global column of the radius of each ball in the global block.
    fn radius_columns(&self) -> impl Iterator<Item = usize> + '_ {
        (0..self.radii.len()).filter_map(|k| self.layout.ball(k).map(|r| r.start + G - 1))
    }
}
