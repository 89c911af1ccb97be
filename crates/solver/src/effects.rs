//! Effects: common changes `t` of the entered data (every ball's radius
//! off by `t`, every distance's scale) that move the whitened rows
//! linearly, `e(t) = ê + t c` ([`crate::Problem::effects`]), projected at a state
//! in the checks' pass ([`crate::redundancy`]).
//!
//! With `J` the whitened Jacobian of every row (priors included), `N =
//! JᵀJ` and `P = I − J N⁻¹ Jᵀ` the projector onto the residuals, what a
//! test of an effect needs (Teunissen, "Testing theory", 2000, section
//! 3.2) is
//!
//! ```text
//! cᵀPc,     cᵀPê,     δ_g = −(N⁻¹ Jᵀ c)_g,
//! ```
//!
//! the last being the shift of the global block per unit `t`. Each effect
//! is one more right-hand side of the elimination: a point's rows carry
//! `Qᵀc` beside `Qᵀê`, a group's prior rows `U(x − m)` carry `−U ∂m/∂t`,
//! and the group QR turns them into the reduced rows `[B | β | γ]` with
//! the rest. As every `Q` is orthogonal, `cᵀPc` and `cᵀPê` are the global
//! level's, where the reduced rows, the global prior's and the global
//! observations' rows make a least-squares problem of their own:
//!
//! ```text
//! cᵀPc = |γ|² − b_cᵀ Cov(g) b_c,    cᵀPê = βᵀγ − b_cᵀ Cov(g) b_e,
//! δ_g = −Cov(g) b_c,
//! ```
//!
//! with `b_c = Bᵀγ` and `b_e = Bᵀβ` summed over all of them and `Cov(g) =
//! S⁻¹`. The point priors' means never move with an effect.

use nalgebra::{DMatrix, DVector};

use crate::problem::{GaussianPrior, GlobalObservations};

/// One effect projected at a state (module doc).
#[derive(Clone, Debug, PartialEq)]
pub struct EffectProjection {
    /// `cᵀPc`: the squared size of the effect's column that the unknowns
    /// do not absorb.
    pub c_pc: f64,
    /// `cᵀPê`, `ê` the whitened residuals at the state.
    pub c_pe: f64,
    /// `|γ|²`, of which `cᵀPc` is what the global block leaves: the scale
    /// of the rounding of `cᵀPc`.
    pub reduced_norm2: f64,
    /// `δ_g = −Cov(g) b_c`: the global block's shift per unit effect.
    pub global_shift: DVector<f64>,
}

/// The sums over the reduced rows `[B | β | γ_1 … γ_K]` (`G + 1 + K`
/// values a row) that the projections need.
#[derive(Clone, Debug)]
pub(crate) struct EffectSums {
    g: usize,
    /// `[b_e | b_c1 … b_cK]`, `G` values each.
    gradients: Vec<f64>,
    /// `βᵀγ_k`.
    cross: Vec<f64>,
    /// `|γ_k|²`.
    norms2: Vec<f64>,
}

impl EffectSums {
    /// Zero sums for `effects` effects on `g` global unknowns.
    pub(crate) fn new(g: usize, effects: usize) -> Self {
        Self {
            g,
            gradients: vec![0.0; g * (1 + effects)],
            cross: vec![0.0; effects],
            norms2: vec![0.0; effects],
        }
    }

    /// Adds one reduced row `[B | β | γ_1 … γ_K]`: `b_e += β B`, `b_ck +=
    /// γ_k B`, `βᵀγ_k += β γ_k`, `|γ_k|² += γ_k²`.
    ///
    /// Compiled twice: for AVX2, chosen at run time where the machine has
    /// it (the gradients four wide instead of two), and for any x86-64.
    /// Both multiply and add in the same order, so they give the same bits.
    #[allow(unsafe_code, reason = "the AVX2 build, called after the feature check")]
    pub(crate) fn add_row(&mut self, row: &[f64]) {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the machine runs AVX2.
            return unsafe { self.add_row_avx2(row) };
        }
        self.add_row_in(row);
    }

    /// [`EffectSums::add_row`] compiled for AVX2.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn add_row_avx2(&mut self, row: &[f64]) {
        self.add_row_in(row);
    }

    /// The body of [`EffectSums::add_row`], inlined into each of its builds.
    #[inline(always)]
    fn add_row_in(&mut self, row: &[f64]) {
        let g = self.g;
        let (b, tail) = row.split_at(g);
        let (beta, gamma) = (tail[0], &tail[1..]);
        for (gradient, &t) in self.gradients.chunks_exact_mut(g).zip(tail) {
            if t != 0.0 {
                for (s, &x) in gradient.iter_mut().zip(b) {
                    *s += x * t;
                }
            }
        }
        for ((cross, norm2), &t) in self.cross.iter_mut().zip(&mut self.norms2).zip(gamma) {
            *cross += beta * t;
            *norm2 += t * t;
        }
    }

    /// Adds another chunk's sums.
    pub(crate) fn add(&mut self, other: &Self) {
        let pairs = [
            (&mut self.gradients, &other.gradients),
            (&mut self.cross, &other.cross),
            (&mut self.norms2, &other.norms2),
        ];
        for (sum, part) in pairs {
            for (s, x) in sum.iter_mut().zip(part) {
                *s += x;
            }
        }
    }

    /// Adds the global prior's rows `U(g − m)` at the global block
    /// `global`, each effect moving its mean by a column of `mean_effects`
    /// (`G × K`), and the global observations `observations` with the
    /// effects' columns `observation_effects` (`m × K`).
    pub(crate) fn add_global(
        &mut self,
        prior: Option<&GaussianPrior<nalgebra::Dyn>>,
        global: &DVector<f64>,
        mean_effects: &DMatrix<f64>,
        observations: &GlobalObservations,
        observation_effects: &DMatrix<f64>,
    ) {
        let g = self.g;
        if let Some(prior) = prior {
            let lower = &prior.information;
            let information = DMatrix::from_fn(g, g, |i, j| lower[(i.max(j), i.min(j))]);
            // Rows U(g − m) and −U ∂m/∂t: UᵀU = Λ gives every product.
            let mut columns = DMatrix::zeros(g, 1 + mean_effects.ncols());
            columns.column_mut(0).copy_from(&(global - &prior.mean));
            columns
                .columns_mut(1, mean_effects.ncols())
                .copy_from(&(-mean_effects));
            let gradients = &information * &columns;
            self.add_columns(&gradients, &(columns.transpose() * &gradients));
        }
        let jacobian = &observations.jacobian;
        if jacobian.nrows() > 0 {
            let mut columns = DMatrix::zeros(jacobian.nrows(), 1 + observation_effects.ncols());
            columns.column_mut(0).copy_from(&observations.residual);
            columns
                .columns_mut(1, observation_effects.ncols())
                .copy_from(observation_effects);
            let gram = columns.transpose() * &columns;
            self.add_columns(&(jacobian.transpose() * &columns), &gram);
        }
    }

    /// Adds rows `[B | β | γ]` given by `Bᵀ[β | γ]` (`gradients`) and
    /// `[β | γ]ᵀ[β | γ]` (`gram`).
    fn add_columns(&mut self, gradients: &DMatrix<f64>, gram: &DMatrix<f64>) {
        for (sum, column) in self
            .gradients
            .chunks_exact_mut(self.g)
            .zip(gradients.column_iter())
        {
            for (s, x) in sum.iter_mut().zip(column.iter()) {
                *s += x;
            }
        }
        for (k, (cross, norm2)) in self.cross.iter_mut().zip(&mut self.norms2).enumerate() {
            *cross += gram[(0, 1 + k)];
            *norm2 += gram[(1 + k, 1 + k)];
        }
    }

    /// The projections of every effect, given the symmetric `Cov(g)`
    /// (module doc).
    pub(crate) fn projections(&self, covariance: &DMatrix<f64>) -> Vec<EffectProjection> {
        let g = self.g;
        let mut gradients = self
            .gradients
            .chunks_exact(g)
            .map(DVector::from_column_slice);
        let Some(b_e) = gradients.next() else {
            return Vec::new();
        };
        let shift_e = covariance * &b_e;
        gradients
            .zip(self.cross.iter().zip(&self.norms2))
            .map(|(b_c, (&cross, &norm2))| {
                let shift = covariance * &b_c;
                EffectProjection {
                    c_pc: norm2 - b_c.dot(&shift),
                    c_pe: cross - b_c.dot(&shift_e),
                    reduced_norm2: norm2,
                    global_shift: -shift,
                }
            })
            .collect()
    }
}
