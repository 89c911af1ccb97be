//! Choosing the touches: greedy selection, then Fedorov exchange, with
//! seeded restarts.
//!
//! The unknowns are the 33 parameters and every ball's centre and radius
//! (`n = 33 + 4 B`). The design's information is the prior's (the kinematic
//! prior, the centre priors or [`WEAK_CENTRE_SIGMA`], the radius priors,
//! the calibrated distances of a ball plate) plus `h hᵀ` per chosen touch
//! ([`crate::information`]); the
//! covariance `Σ = M⁻¹` is refactorised (Cholesky, `n³/3` flops) after each
//! change of the design. A candidate's gain is its Sherman–Morrison
//! decrease of the criterion ([`crate::criterion`]), evaluated for the
//! whole pool with one product `[Σ_pp; Fᵀ Σ_pp] G` (`G` the 33 x pool
//! matrix of the candidates' parameter rows) plus each ball's 4-column
//! blocks `Σ_pb`, `Σ_bb` (centre and radius) in parallel chunks of
//! [`CHUNK`] candidates: the same numbers whatever the number of threads.
//!
//! Every ball the design touches keeps at least [`min_touches_per_ball`]
//! touches (the dataset reader's minimum) spanning the directions: the
//! smallest eigenvalue of its touches' `Σ u uᵀ` (unit normals) stays at
//! least [`SPREAD`], or what its candidates allow. A ball's centre must be
//! fixed before its touches say anything about `p`, and a centre fixed by
//! a few close touches is a strongly non-linear problem for the
//! calibration (a tangential error `δ` of the start moves the distances by
//! `δ²/2r`, far beyond the noise: Gauss-Newton oscillates). One run: per
//! ball that many anchor touches, as spread as possible (greedy on
//! `det Σ u uᵀ`, the first drawn at random); when the budget `N` is below
//! that many touches of every ball the machine reaches, the design grows
//! greedily instead, each step adding whichever lowers the criterion most
//! per touch, an untouched ball's anchors or one touch of a touched ball
//! (a new ball's first touches locate its centre, so fewer balls touched
//! more often can beat more balls), once after the anchors of
//! [`SelectOptions::min_balls`] balls (none by default in this module) and
//! once after those of `⌊N / m⌋` balls (`m` that minimum), the better
//! kept;
//! otherwise greedy additions up to the budget; then exchange passes, each
//! touch in turn removed and replaced by the best candidate (itself
//! included) that keeps its ball's count and spread, until a pass improves
//! the criterion by less than a relative 1e-6 or [`SelectOptions::passes`] passes are made. Restart `r` draws its
//! seed from stream `r` of [`parcal_simulate::Rng`]; the best run is kept,
//! the earliest on ties.

use nalgebra::{DMatrix, Matrix3, Matrix4, SMatrix, SVector};
use parcal_kinematics::N_PARAMS;
use parcal_simulate::Rng;
use rayon::prelude::*;

use crate::DesignError;
use crate::criterion::{Criterion, CriterionValues, G_SHORTLIST, MapWeights, Square};
use crate::information::{BALL_UNKNOWNS, BallRow, ContactRow};

/// Candidates per parallel chunk of the gain evaluation.
pub const CHUNK: usize = 512;

/// The fewest touches of a ball: what the dataset reader accepts
/// (`parcal_dataset::ReadOptions`).
pub fn min_touches_per_ball() -> usize {
    parcal_dataset::ReadOptions::default().min_contacts_per_ball
}

/// The smallest eigenvalue of `Σ u uᵀ` over a ball's touches that a plan
/// keeps: four directions on the rim of a 60 degree cone about the stylus
/// axis give 1.
pub const SPREAD: f64 = 0.5;

/// The prior sigma of a ball centre that nothing locates (mm): weak enough
/// to leave the calibration's figures unchanged once the ball has a few
/// touches, finite so that the covariance exists for any design.
pub const WEAK_CENTRE_SIGMA: f64 = 10.0;

/// How the touches are chosen.
#[derive(Debug, Clone, PartialEq)]
pub struct SelectOptions {
    /// The budget: number of touches.
    pub contacts: usize,
    /// What is minimised.
    pub criterion: Criterion,
    /// At most this many touches per ball.
    pub per_ball: Option<usize>,
    /// Number of runs from different seeds.
    pub restarts: usize,
    /// Seed of the runs' random streams.
    pub seed: u64,
    /// Largest number of exchange passes per run.
    pub passes: usize,
    /// Whether every ball gets its anchor touches and keeps its minimum
    /// and spread (module doc); not when the balls are located already
    /// (sequential mode).
    pub anchors: bool,
    /// When the budget is below every ball's anchors: touch at least this
    /// many balls (as many as the budget's anchors and the reachable balls
    /// allow); 0 leaves the number to the criterion.
    pub min_balls: usize,
}

/// The default [`SelectOptions::min_balls`] of a budget of `contacts`
/// touches: enough balls that each has on average at most twice the
/// reader's minimum, `⌊N / (2 m)⌋`, so that a small budget still spreads
/// over the artefact (a metrologist's choice: the criterion alone prefers
/// few balls touched often, docs/plan.md).
pub fn default_min_balls(contacts: usize) -> usize {
    contacts / (2 * min_touches_per_ball())
}

/// The chosen touches and their predicted figures.
#[derive(Debug, Clone)]
pub struct Selection {
    /// Indices into the pool, sorted.
    pub chosen: Vec<usize>,
    /// The predicted posterior covariance of the 33 parameters (mm²).
    pub covariance: Square,
    /// Its figures.
    pub values: CriterionValues,
}

/// The fixed part of a selection problem.
pub struct Problem<'a> {
    rows: &'a [ContactRow],
    /// `G`: the candidates' parameter rows as columns (33 x pool).
    stacked: DMatrix<f64>,
    balls: usize,
    /// The prior information of all unknowns (`n x n`).
    prior: DMatrix<f64>,
    map: &'a MapWeights,
}

impl<'a> Problem<'a> {
    /// The problem of choosing among `rows` (touches of `balls` balls) with
    /// prior information `prior` (`33 + 4 balls` square: each ball's
    /// centre, then its radius) and the map `map`.
    pub fn new(
        rows: &'a [ContactRow],
        balls: usize,
        prior: DMatrix<f64>,
        map: &'a MapWeights,
    ) -> Self {
        let mut stacked = DMatrix::zeros(N_PARAMS, rows.len());
        for (k, row) in rows.iter().enumerate() {
            stacked.column_mut(k).copy_from(&row.params);
        }
        Self {
            rows,
            stacked,
            balls,
            prior,
            map,
        }
    }

    /// The figures of the prior alone (no touch).
    pub fn prior_values(&self) -> Result<CriterionValues, DesignError> {
        State::new(self)?.values()
    }

    /// The best design of `options` (module doc); `progress` hears one line
    /// per run and pass.
    pub fn select(
        &self,
        options: &SelectOptions,
        progress: &mut dyn FnMut(&str),
    ) -> Result<Selection, DesignError> {
        crate::bounds::CONTACTS
            .check("contacts", options.contacts)
            .and_then(|_| crate::bounds::RESTARTS.check("restarts", options.restarts))
            .map_err(DesignError::Options)?;
        let mut best: Option<(f64, State)> = None;
        for restart in 0..options.restarts {
            let state = self.run(options, restart as u64, progress)?;
            let value = state.values()?.value(options.criterion);
            progress(&format!("run {}: criterion {value:.6e}", restart + 1));
            if best.as_ref().is_none_or(|(v, _)| value < *v) {
                best = Some((value, state));
            }
        }
        let (_, state) = best.expect("at least one run");
        let mut chosen = state.chosen.clone();
        chosen.sort_unstable();
        Ok(Selection {
            chosen,
            covariance: state.params_covariance(),
            values: state.values()?,
        })
    }

    /// One run: seed, greedy, exchange.
    fn run(
        &self,
        options: &SelectOptions,
        restart: u64,
        progress: &mut dyn FnMut(&str),
    ) -> Result<State<'_>, DesignError> {
        let mut state = State::new(self)?;
        let mut by_ball = vec![Vec::new(); self.balls];
        for (k, row) in self.rows.iter().enumerate() {
            by_ball[row.ball].push(k);
        }
        let reachable = by_ball.iter().filter(|c| !c.is_empty()).count();
        let seeds = if options.anchors {
            min_touches_per_ball()
        } else {
            0
        };
        if options.contacts < seeds || options.per_ball.is_some_and(|k| k < seeds) {
            let cap = options
                .per_ball
                .map_or(String::new(), |k| format!(" at most {k} per ball"));
            return Err(DesignError::Options(format!(
                "{} contacts{cap} cannot give a ball {seeds} touches (the dataset reader's minimum)",
                options.contacts
            )));
        }
        let mut rng = Rng::new(options.seed, restart);
        let anchors: Vec<(usize, Vec<usize>)> = by_ball
            .iter()
            .enumerate()
            .filter(|(_, c)| seeds > 0 && !c.is_empty())
            .map(|(ball, candidates)| (ball, self.anchors(candidates, seeds, &mut rng)))
            .collect();
        if seeds > 0 && options.contacts < seeds * reachable {
            state.allowed = vec![false; self.balls];
            let mut best: Option<(f64, State)> = None;
            let most = options.contacts / seeds;
            let floor = options.min_balls.min(most).min(reachable);
            let mut leasts = vec![floor, most];
            leasts.dedup();
            for least in leasts.into_iter().filter(|&l| l >= floor) {
                let mut grown = state.clone();
                grown.grow(anchors.clone(), least, options)?;
                let value = grown.values()?.value(options.criterion);
                if best.as_ref().is_none_or(|(v, _)| value < *v) {
                    best = Some((value, grown));
                }
            }
            state = best.expect("two growths").1;
        } else {
            for k in anchors.into_iter().flat_map(|(_, touches)| touches) {
                state.push(k);
            }
        }
        // A ball whose candidates cannot reach SPREAD keeps what its anchors
        // reach.
        let spread: Vec<f64> = state
            .scatter
            .iter()
            .map(|s| SPREAD.min(smallest_eigenvalue(s) * (1.0 - 1e-9)))
            .collect();
        state.refresh()?;
        while state.chosen.len() < options.contacts {
            let best = state.best_addition(options, None)?;
            state.push(best);
            state.refresh()?;
        }
        let mut value = state.values()?.value(options.criterion);
        for pass in 0..options.passes {
            for slot in 0..state.chosen.len() {
                let removed = state.chosen[slot];
                let ball = self.rows[removed].ball;
                state.remove(slot);
                let short = state.counts[ball] < seeds
                    || smallest_eigenvalue(&state.scatter[ball]) < spread[ball];
                let required = short.then(|| Required {
                    ball,
                    spread: spread[ball],
                });
                state.refresh()?;
                let best = state.best_addition(options, required)?;
                state.put(slot, best);
                state.refresh()?;
            }
            let next = state.values()?.value(options.criterion);
            progress(&format!(
                "run {}, exchange pass {}: criterion {next:.6e}",
                restart + 1,
                pass + 1
            ));
            let converged = value - next <= 1e-6 * value.abs();
            value = next;
            if converged {
                break;
            }
        }
        Ok(state)
    }
}

impl Problem<'_> {
    /// `u uᵀ` of touch `k`'s unit normal (the direction of its centre row).
    fn direction(&self, k: usize) -> Matrix3<f64> {
        let u = self.rows[k].centre().normalize();
        u * u.transpose()
    }

    /// `count` anchor touches among one ball's `candidates` (module doc):
    /// the first at random, each next maximising `det(Σ u uᵀ + ε I)` of
    /// those chosen (`u` the rows' centre parts, whitened normals), the
    /// lowest index on ties.
    fn anchors(&self, candidates: &[usize], count: usize, rng: &mut Rng) -> Vec<usize> {
        let mut chosen = vec![candidates[rng.below(candidates.len() as u64) as usize]];
        let mut scatter = self.direction(chosen[0]) + Matrix3::identity() * 1e-6;
        while chosen.len() < count {
            let next = argmax(
                candidates
                    .iter()
                    .map(|&k| (scatter + self.direction(k)).determinant()),
            )
            .map(|i| candidates[i])
            .expect("a ball with candidates");
            scatter += self.direction(next);
            chosen.push(next);
        }
        chosen
    }
}

/// A design in progress: its information and covariance.
#[derive(Clone)]
struct State<'a> {
    problem: &'a Problem<'a>,
    information: DMatrix<f64>,
    covariance: DMatrix<f64>,
    /// The chosen touches (pool indices); `usize::MAX` marks a slot being
    /// exchanged.
    chosen: Vec<usize>,
    counts: Vec<usize>,
    /// Per ball, `Σ u uᵀ` of its touches' unit normals.
    scatter: Vec<Matrix3<f64>>,
    /// Per ball, whether the design may touch it (all, unless the budget
    /// is below the anchors of every ball).
    allowed: Vec<bool>,
}

/// A replacement that must restore a ball's count and spread.
#[derive(Clone, Copy)]
struct Required {
    ball: usize,
    spread: f64,
}

impl<'a> State<'a> {
    fn new(problem: &'a Problem<'a>) -> Result<Self, DesignError> {
        let mut state = Self {
            problem,
            information: problem.prior.clone(),
            covariance: DMatrix::zeros(0, 0),
            chosen: Vec::new(),
            counts: vec![0; problem.balls],
            scatter: vec![Matrix3::zeros(); problem.balls],
            allowed: vec![true; problem.balls],
        };
        state.refresh()?;
        Ok(state)
    }

    /// Grows the design to the budget of `options` from `anchors` (each a
    /// ball and its anchor touches) and the touched balls' candidates:
    /// each step takes whichever lowers the criterion most per touch, the
    /// anchors of an untouched ball (while the budget has room for them)
    /// or the best single touch of a touched ball; only anchors until
    /// `least` balls are touched.
    fn grow(
        &mut self,
        mut anchors: Vec<(usize, Vec<usize>)>,
        least: usize,
        options: &SelectOptions,
    ) -> Result<(), DesignError> {
        let criterion = options.criterion;
        while self.chosen.len() < options.contacts {
            let current = self.values()?.value(criterion);
            let room = options.contacts - self.chosen.len();
            let mut best: Option<(f64, Option<usize>, Vec<usize>)> = None;
            let mut consider = |decrease: f64, anchor: Option<usize>, touches: &[usize]| {
                if best.as_ref().is_none_or(|(d, _, _)| decrease > *d) {
                    best = Some((decrease, anchor, touches.to_vec()));
                }
            };
            let touched = self.allowed.iter().filter(|&&a| a).count();
            if touched > 0 && (touched >= least || anchors.is_empty()) {
                match self.best_addition(options, None) {
                    Ok(k) => consider(current - self.value_with(&[k], criterion)?, None, &[k]),
                    Err(DesignError::Capacity { .. }) => {}
                    Err(error) => return Err(error),
                }
            }
            for (i, (_, touches)) in anchors.iter().enumerate() {
                if touches.len() <= room {
                    let decrease = current - self.value_with(touches, criterion)?;
                    consider(decrease / touches.len() as f64, Some(i), touches);
                }
            }
            let (_, anchor, touches) = best.ok_or(DesignError::Capacity {
                per_ball: options.per_ball.unwrap_or(usize::MAX),
                contacts: options.contacts,
            })?;
            if let Some(i) = anchor {
                self.allowed[anchors.remove(i).0] = true;
            }
            for k in touches {
                self.push(k);
            }
            self.refresh()?;
        }
        Ok(())
    }

    /// The criterion after adding `touches`.
    fn value_with(&self, touches: &[usize], criterion: Criterion) -> Result<f64, DesignError> {
        let mut trial = self.clone();
        for &k in touches {
            trial.push(k);
        }
        trial.refresh()?;
        Ok(trial.values()?.value(criterion))
    }

    /// `M += sign h hᵀ` for touch `k`.
    fn accumulate(&mut self, k: usize, sign: f64) {
        let row = &self.problem.rows[k];
        let c = ball_offset(row.ball);
        let (g, u) = (&row.params, &row.on_ball);
        let m = &mut self.information;
        let mut pp = m.view_mut((0, 0), (N_PARAMS, N_PARAMS));
        pp += sign * g * g.transpose();
        let mut pc = m.view_mut((0, c), (N_PARAMS, BALL_UNKNOWNS));
        pc += sign * g * u.transpose();
        let mut cp = m.view_mut((c, 0), (BALL_UNKNOWNS, N_PARAMS));
        cp += sign * u * g.transpose();
        let mut cc = m.view_mut((c, c), (BALL_UNKNOWNS, BALL_UNKNOWNS));
        cc += sign * u * u.transpose();
    }

    fn push(&mut self, k: usize) {
        self.chosen.push(k);
        self.put(self.chosen.len() - 1, k);
    }

    fn remove(&mut self, slot: usize) {
        let k = self.chosen[slot];
        let ball = self.problem.rows[k].ball;
        self.accumulate(k, -1.0);
        self.counts[ball] -= 1;
        self.scatter[ball] -= self.problem.direction(k);
        self.chosen[slot] = usize::MAX;
    }

    fn put(&mut self, slot: usize, k: usize) {
        let ball = self.problem.rows[k].ball;
        self.accumulate(k, 1.0);
        self.counts[ball] += 1;
        self.scatter[ball] += self.problem.direction(k);
        self.chosen[slot] = k;
    }

    /// `Σ = M⁻¹`.
    fn refresh(&mut self) -> Result<(), DesignError> {
        let cholesky = self
            .information
            .clone()
            .cholesky()
            .ok_or(DesignError::Singular)?;
        self.covariance = cholesky.inverse();
        Ok(())
    }

    fn params_covariance(&self) -> Square {
        self.covariance
            .fixed_view::<N_PARAMS, N_PARAMS>(0, 0)
            .clone_owned()
    }

    fn values(&self) -> Result<CriterionValues, DesignError> {
        CriterionValues::of(&self.params_covariance(), self.problem.map)
            .ok_or(DesignError::Singular)
    }

    /// The candidate whose addition decreases the criterion most (module
    /// doc of [`crate::criterion`]), among those of balls below capacity
    /// (and those that restore the `required` ball's count and spread); the
    /// lowest index on ties.
    fn best_addition(
        &self,
        options: &SelectOptions,
        required: Option<Required>,
    ) -> Result<usize, DesignError> {
        let (ratios, sigma_pp, per_ball) = self.ratios(options, required)?;
        let best = match options.criterion {
            Criterion::G => self.best_worst_point(&ratios, &sigma_pp, &per_ball),
            _ => argmax(ratios.iter().copied()),
        };
        best.ok_or(DesignError::Capacity {
            per_ball: options.per_ball.unwrap_or(usize::MAX),
            contacts: options.contacts,
        })
    }

    /// Every candidate's `|Fᵀ s_p|² / d` ([`crate::criterion`]; minus
    /// infinity for those not allowed), with `Σ_pp` and the balls' blocks.
    #[allow(clippy::type_complexity)]
    fn ratios(
        &self,
        options: &SelectOptions,
        required: Option<Required>,
    ) -> Result<(Vec<f64>, Square, Vec<BallBlocks>), DesignError> {
        let problem = self.problem;
        let sigma_pp = self.params_covariance();
        let factor = match options.criterion {
            Criterion::Registered | Criterion::G => problem.map.factor,
            Criterion::A => Square::identity(),
            // F Fᵀ = Σ_pp⁻¹ with F = L⁻ᵀ, Σ_pp = L Lᵀ.
            Criterion::D => {
                let l = sigma_pp.cholesky().ok_or(DesignError::Singular)?.l();
                l.try_inverse().ok_or(DesignError::Singular)?.transpose()
            }
        };
        let mut top = DMatrix::zeros(2 * N_PARAMS, N_PARAMS);
        top.view_mut((0, 0), (N_PARAMS, N_PARAMS))
            .copy_from(&sigma_pp);
        top.view_mut((N_PARAMS, 0), (N_PARAMS, N_PARAMS))
            .copy_from(&(factor.transpose() * sigma_pp));
        let per_ball: Vec<BallBlocks> = (0..problem.balls)
            .map(|b| {
                let c = ball_offset(b);
                let pc = self
                    .covariance
                    .fixed_view::<N_PARAMS, BALL_UNKNOWNS>(0, c)
                    .clone_owned();
                BallBlocks {
                    factor_pc: factor.transpose() * pc,
                    cc: self
                        .covariance
                        .fixed_view::<BALL_UNKNOWNS, BALL_UNKNOWNS>(c, c)
                        .clone_owned(),
                    pc,
                }
            })
            .collect();
        let capacity = options.per_ball.unwrap_or(usize::MAX);
        let ratios: Vec<f64> = (0..problem.rows.len())
            .step_by(CHUNK)
            .collect::<Vec<_>>()
            .par_iter()
            .flat_map_iter(|&start| {
                let len = CHUNK.min(problem.rows.len() - start);
                let y = &top * problem.stacked.columns(start, len);
                (0..len)
                    .map(|j| {
                        let row = &problem.rows[start + j];
                        // One touch of the ball restores its count; its
                        // spread, only if the eigenvalue is back.
                        let restores = |r: Required| {
                            row.ball == r.ball
                                && smallest_eigenvalue(
                                    &(self.scatter[r.ball] + problem.direction(start + j)),
                                ) >= r.spread
                        };
                        if !self.allowed[row.ball]
                            || self.counts[row.ball] >= capacity
                            || required.is_some_and(|r| !restores(r))
                        {
                            return f64::NEG_INFINITY;
                        }
                        let blocks = &per_ball[row.ball];
                        let (s_p, w) = blocks.update(&y, j, &row.on_ball);
                        let s_c = blocks.pc.tr_mul(&row.params) + blocks.cc * row.on_ball;
                        let d = 1.0 + row.params.dot(&s_p) + row.on_ball.dot(&s_c);
                        w.norm_squared() / d
                    })
                    .collect::<Vec<_>>()
            })
            .collect();
        Ok((ratios, sigma_pp, per_ball))
    }

    /// G: among the [`G_SHORTLIST`] best by the registered ratio, the one
    /// whose addition leaves the smallest worst map variance.
    fn best_worst_point(
        &self,
        ratios: &[f64],
        sigma_pp: &Square,
        per_ball: &[BallBlocks],
    ) -> Option<usize> {
        let mut order: Vec<usize> = (0..ratios.len())
            .filter(|&k| ratios[k].is_finite())
            .collect();
        order.sort_by(|&a, &b| ratios[b].total_cmp(&ratios[a]).then(a.cmp(&b)));
        order.truncate(G_SHORTLIST);
        order.sort_unstable();
        let map = self.problem.map;
        let variances = map.variances(sigma_pp);
        let worst: Vec<f64> = order
            .par_iter()
            .map(|&k| {
                let row = &self.problem.rows[k];
                let blocks = &per_ball[row.ball];
                let s_p = sigma_pp * row.params + blocks.pc * row.on_ball;
                let s_c = blocks.pc.tr_mul(&row.params) + blocks.cc * row.on_ball;
                let d = 1.0 + row.params.dot(&s_p) + row.on_ball.dot(&s_c);
                map.jacobians
                    .iter()
                    .zip(&variances)
                    .map(|(j, v)| v - (j * s_p).norm_squared() / d)
                    .fold(f64::NEG_INFINITY, f64::max)
            })
            .collect();
        argmax(worst.iter().map(|w| -w)).map(|i| order[i])
    }
}

/// Where ball `ball`'s unknowns (centre, then radius) start among all
/// unknowns.
pub fn ball_offset(ball: usize) -> usize {
    N_PARAMS + BALL_UNKNOWNS * ball
}

/// One ball's blocks of `Σ` for the gain evaluation (`b` its centre and
/// radius).
struct BallBlocks {
    /// `Σ_pb` (33 x 4).
    pc: SMatrix<f64, N_PARAMS, BALL_UNKNOWNS>,
    /// `Fᵀ Σ_pb`.
    factor_pc: SMatrix<f64, N_PARAMS, BALL_UNKNOWNS>,
    /// `Σ_bb`.
    cc: Matrix4<f64>,
}

impl BallBlocks {
    /// `s_p = Σ_pp g + Σ_pb h_b` and `w = Fᵀ s_p` from column `j` of
    /// `y = [Σ_pp; Fᵀ Σ_pp] G`.
    fn update(
        &self,
        y: &DMatrix<f64>,
        j: usize,
        on_ball: &BallRow,
    ) -> (SVector<f64, N_PARAMS>, SVector<f64, N_PARAMS>) {
        let s_p = y.fixed_view::<N_PARAMS, 1>(0, j) + self.pc * on_ball;
        let w = y.fixed_view::<N_PARAMS, 1>(N_PARAMS, j) + self.factor_pc * on_ball;
        (s_p, w)
    }
}

/// The smallest eigenvalue of a symmetric 3 x 3 matrix.
fn smallest_eigenvalue(m: &Matrix3<f64>) -> f64 {
    m.symmetric_eigenvalues().min()
}

/// The index of the largest finite value, the lowest on ties.
fn argmax(values: impl Iterator<Item = f64>) -> Option<usize> {
    let mut best: Option<(usize, f64)> = None;
    for (k, v) in values.enumerate() {
        if v.is_finite() && best.is_none_or(|(_, b)| v > b) {
            best = Some((k, v));
        }
    }
    best.map(|(k, _)| k)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::information::contact_row;
    use crate::pool::{NominalBall, PoolOptions, candidate_pool};
    use parcal_accuracy::{CanonicalTargets, MapGrid, registered_jacobians};
    use parcal_calibrate::RadiusModel;
    use parcal_kinematics::{paper, params};
    use parcal_observe::Repeatability;

    /// Rows of a small pool on four balls, the map and a prior.
    fn small_problem() -> (Vec<ContactRow>, MapWeights, DMatrix<f64>) {
        let design = paper::design();
        let canonical = design.canonicalize().unwrap();
        let balls: Vec<NominalBall> = [
            (-50.0, -40.0, 380.0),
            (50.0, 0.0, 420.0),
            (0.0, 60.0, 400.0),
            (-30.0, 30.0, 440.0),
        ]
        .iter()
        .map(|&(x, y, z)| NominalBall {
            centre: parcal_kinematics::Vec3::new(x, y, z),
            radius: 5.0,
        })
        .collect();
        let pool = candidate_pool(
            &design,
            &balls,
            &PoolOptions {
                tilt: 0.3,
                size: 400,
                max_approach: 1.3,
                min_conditioning: 0.05,
                stroke: [20.0, 250.0],
                scale: [1.0; 6],
                joint_limits: None,
            },
        )
        .unwrap();
        let repeatability = Repeatability {
            actuator: 1e-3,
            tool: 1e-3,
            radius: 1e-3,
        };
        let rows = pool
            .iter()
            .map(|c| {
                let model = RadiusModel::PerBall;
                contact_row(
                    &design,
                    &canonical,
                    &balls[c.ball],
                    c,
                    &repeatability,
                    model,
                )
                .unwrap()
            })
            .collect();
        let targets = CanonicalTargets::new(&design, &MapGrid::square(100.0, 25.0, 400.0)).unwrap();
        let map = MapWeights::new(
            registered_jacobians(&targets, &params::to_params(&canonical.geometry)).unwrap(),
        );
        let n = ball_offset(4);
        let mut prior = DMatrix::identity(n, n) * WEAK_CENTRE_SIGMA.powi(-2);
        prior
            .view_mut((0, 0), (N_PARAMS, N_PARAMS))
            .fill_with_identity();
        prior
            .view_mut((0, 0), (N_PARAMS, N_PARAMS))
            .scale_mut(0.1f64.powi(-2));
        // Each ball's radius about its calibrated value (1 um).
        for ball in 0..4 {
            let r = ball_offset(ball) + 3;
            prior[(r, r)] = repeatability.radius.powi(-2);
        }
        (rows, map, prior)
    }

    fn options(criterion: Criterion) -> SelectOptions {
        SelectOptions {
            contacts: 24,
            criterion,
            per_ball: None,
            restarts: 1,
            seed: 3,
            passes: 2,
            anchors: true,
            min_balls: 0,
        }
    }

    #[test]
    fn the_sherman_morrison_gains_are_the_criterion_decreases() {
        let (rows, map, prior) = small_problem();
        let problem = Problem::new(&rows, 4, prior, &map);
        let mut state = State::new(&problem).unwrap();
        for k in (0..rows.len()).step_by(rows.len() / 20) {
            state.push(k);
        }
        state.refresh().unwrap();
        for criterion in [Criterion::Registered, Criterion::A, Criterion::D] {
            let (ratios, _, _) = state.ratios(&options(criterion), None).unwrap();
            let before = state.values().unwrap();
            for k in [0, rows.len() / 3, rows.len() - 1] {
                let mut after = state.clone();
                after.push(k);
                after.refresh().unwrap();
                let after = after.values().unwrap();
                let (expected, actual) = match criterion {
                    Criterion::Registered => (
                        ratios[k],
                        (before.registered_rms_um.powi(2) - after.registered_rms_um.powi(2)) * 1e-6,
                    ),
                    Criterion::A => (ratios[k], before.a - after.a),
                    _ => (-(1.0 - ratios[k]).ln(), before.d - after.d),
                };
                assert!(
                    (expected - actual).abs() <= 1e-6 * expected.abs().max(1e-12),
                    "{criterion:?}, candidate {k}: Sherman-Morrison {expected:e}, refactorised {actual:e}"
                );
            }
        }
    }

    #[test]
    fn selection_is_the_same_for_any_number_of_threads() {
        let (rows, map, prior) = small_problem();
        let problem = Problem::new(&rows, 4, prior, &map);
        let select = |threads: usize| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| {
                    problem
                        .select(&options(Criterion::Registered), &mut |_| {})
                        .unwrap()
                })
        };
        let (one, two) = (select(1), select(2));
        assert_eq!(one.chosen, two.chosen);
        assert_eq!(one.values, two.values);
        // Exchange never makes the greedy design worse, and every ball keeps
        // its minimum of touches and its spread.
        let mut counts = [0; 4];
        let mut scatter = [Matrix3::zeros(); 4];
        for &k in &one.chosen {
            counts[rows[k].ball] += 1;
            scatter[rows[k].ball] += problem.direction(k);
        }
        assert!(
            counts.iter().all(|&c| c >= min_touches_per_ball()),
            "{counts:?}"
        );
        assert!(
            scatter.iter().all(|s| smallest_eigenvalue(s) >= SPREAD),
            "spread"
        );
        // 24 touches of 4 balls: a fraction of the prior's registered error.
        let prior = problem.prior_values().unwrap().registered_rms_um;
        assert!(
            one.values.registered_rms_um < prior / 2.0,
            "{prior} {:?}",
            one.values
        );
    }

    #[test]
    fn the_per_ball_capacity_holds() {
        let (rows, map, prior) = small_problem();
        let problem = Problem::new(&rows, 4, prior, &map);
        let capped = SelectOptions {
            per_ball: Some(6),
            ..options(Criterion::Registered)
        };
        let selection = problem.select(&capped, &mut |_| {}).unwrap();
        let mut counts = [0; 4];
        for &k in &selection.chosen {
            counts[rows[k].ball] += 1;
        }
        assert_eq!(counts, [6; 4]);
        let too_small = SelectOptions {
            per_ball: Some(3),
            ..options(Criterion::Registered)
        };
        let error = problem.select(&too_small, &mut |_| {}).unwrap_err();
        assert!(error.to_string().contains("at most 3 per ball"), "{error}");
    }

    #[test]
    fn a_budget_below_every_balls_anchors_touches_the_best_balls() {
        let (rows, map, prior) = small_problem();
        let problem = Problem::new(&rows, 4, prior, &map);
        let seeds = min_touches_per_ball();
        let counts = |contacts| {
            let selection = problem
                .select(
                    &SelectOptions {
                        contacts,
                        ..options(Criterion::Registered)
                    },
                    &mut |_| {},
                )
                .unwrap();
            let mut counts = [0; 4];
            for &k in &selection.chosen {
                counts[rows[k].ball] += 1;
            }
            (counts, selection.values.registered_rms_um)
        };
        // Below m touches of every ball: some balls untouched, each touched
        // ball at least m touches, the whole budget spent, and a larger
        // budget predicts better.
        let mut previous = f64::INFINITY;
        for contacts in [seeds, 2 * seeds + 3, 3 * seeds, 4 * seeds - 1] {
            let (counts, rms) = counts(contacts);
            assert!(counts.contains(&0), "{contacts}: {counts:?}");
            assert!(counts.iter().all(|&c| c == 0 || c >= seeds), "{counts:?}");
            assert_eq!(counts.iter().sum::<usize>(), contacts);
            assert!(rms < previous, "{contacts}: {rms} after {previous}");
            previous = rms;
        }
        let error = problem
            .select(
                &SelectOptions {
                    contacts: seeds - 1,
                    ..options(Criterion::Registered)
                },
                &mut |_| {},
            )
            .unwrap_err();
        assert!(error.to_string().contains("cannot give a ball"), "{error}");
        // A floor on the balls touched holds, up to what the budget's
        // anchors allow.
        let floors = [(2 * seeds + 3, 2, 2), (3 * seeds, 3, 3), (3 * seeds, 9, 3)];
        for (contacts, min_balls, least) in floors {
            let selection = problem
                .select(
                    &SelectOptions {
                        contacts,
                        min_balls,
                        ..options(Criterion::Registered)
                    },
                    &mut |_| {},
                )
                .unwrap();
            let mut touched = [0; 4];
            for &k in &selection.chosen {
                touched[rows[k].ball] += 1;
            }
            assert!(
                touched.iter().filter(|&&c| c > 0).count() >= least,
                "{touched:?}"
            );
            assert!(touched.iter().all(|&c| c == 0 || c >= seeds), "{touched:?}");
            assert_eq!(touched.iter().sum::<usize>(), contacts);
        }
    }

    #[test]
    fn every_criterion_plans_and_g_lowers_the_worst_point() {
        let (rows, map, prior) = small_problem();
        let problem = Problem::new(&rows, 4, prior, &map);
        let plan = |c| problem.select(&options(c), &mut |_| {}).unwrap().values;
        let (registered, g, d, a) = (
            plan(Criterion::Registered),
            plan(Criterion::G),
            plan(Criterion::D),
            plan(Criterion::A),
        );
        // Each criterion does at least as well on its own figure as the
        // registered plan does (a small tolerance: exchange finds local optima).
        assert!(
            g.registered_max_um <= registered.registered_max_um * 1.02,
            "{g:?} {registered:?}"
        );
        assert!(d.d <= registered.d + 0.5, "{d:?} {registered:?}");
        assert!(a.a <= registered.a * 1.02, "{a:?} {registered:?}");
        assert!(registered.registered_rms_um <= g.registered_rms_um * 1.02);
    }
}
