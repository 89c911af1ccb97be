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
//! Both quadratic forms come from the checks' pass at the minimum of
//! least squares ([`crate::verdict::at_minimum`]), where each effect rides
//! as one more right-hand side of the elimination
//! ([`parcal_solver::effects`]): nothing is linearised again.
//!
//! **Sensitivity.** The smallest effect the test finds with power
//! [`POWER`](crate::hypothesis::POWER) at level [`SYSTEMATIC_LEVEL`], its minimal detectable bias,
//! is `|∇| = δ₀ σ_t = δ₀ / √(cᵀPc)`, `δ₀ = z_{1−α₀/2} + z_{POWER}`: an
//! effect of that size moves `E(w)` to `δ₀` (Baarda 1968). An effect
//! `∇` that goes undetected shifts the estimate of the global block by
//!
//! ```text
//! Δg = (−N⁻¹ Jᵀ c)_g ∇,
//! ```
//!
//! from the same pass; its effect on the
//! registered accuracy map is the report's (`parcal_report::diagnostics`),
//! as for one observation's ([`crate::external`]).

use nalgebra::DVector;
use parcal_solver::effects::EffectProjection;

pub use crate::effect::Effect;
use crate::hypothesis::{critical_value, minimal_detectable_bias};
use crate::verdict::{GLOBAL_TEST_LEVEL, GlobalTest};

/// The level of each systematic test (Baarda's `α₀` of one test).
pub const SYSTEMATIC_LEVEL: f64 = 0.001;

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

/// The tests of `effects` from their projections at the minimum of
/// least squares, in order (module doc). An effect the unknowns absorb
/// (`cᵀPc` within the rounding of `|γ|²`: a radius prior without
/// information, a scale the distances' balls absorb) is left out: not
/// estimable.
pub fn systematic_tests(
    effects: &[Effect],
    projections: &[EffectProjection],
) -> Vec<SystematicTest> {
    effects
        .iter()
        .zip(projections)
        .filter(|(_, p)| p.c_pc.is_finite() && p.c_pc > f64::EPSILON.sqrt() * p.reduced_norm2)
        .map(|(&effect, p)| SystematicTest {
            effect,
            estimate: -p.c_pe / p.c_pc,
            sigma: p.c_pc.sqrt().recip(),
            global_shift: p.global_shift.clone(),
        })
        .collect()
}
