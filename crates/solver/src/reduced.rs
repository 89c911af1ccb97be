//! The reduced system on the global block: the chunks' partial matrices
//! summed in chunk order, the global prior, the global observations and the
//! damping added, and its Cholesky factorisation.

use nalgebra::{DMatrix, DVector};

use crate::chunked_problem::ChunkedProblem;
use crate::chunks::run_chunks;
use crate::eliminate::{Failure, NormalSink, damping_diagonal, eliminate_chunk, find_non_finite};
use crate::problem::{GlobalObservations, Problem, State, WeighedRows};
use crate::qr::all_finite;
use crate::solution::Status;

/// `S δg = −b` on the global block, with the cost at the state it was built
/// at.
#[derive(Clone, Debug)]
pub(crate) struct ReducedSystem {
    /// `S`: `G × G`, row-major, symmetric; the global prior information, the
    /// global observations' `J_oᵀJ_o` and the damping `λ D_g` included.
    pub(crate) matrix: Vec<f64>,
    /// `b`: the reduced gradient, the global prior's `Λ_g (g − m_g)` and the
    /// global observations' `J_oᵀ r_o` included.
    pub(crate) rhs: Vec<f64>,
    /// The global observations' part of `b`, `J_oᵀ r_o` (empty if there
    /// are none).
    pub(crate) observation_gradient: Vec<f64>,
    /// `λ D_g`, the damping added to the diagonal of `S` (zeros if undamped).
    pub(crate) damping: Vec<f64>,
    /// `ρ`: the cost left once the points and groups are eliminated (each
    /// block's rows' part orthogonal to its own columns, their priors and
    /// damping rows included), plus the global prior's and the global
    /// observations' terms; the minimum of the linearised cost is `ρ −
    /// bᵀS⁻¹b` ([`ReducedSystem::linear_minimum`]).
    pub(crate) reduced_cost: f64,
    /// `Σ |r_i|²`.
    pub(crate) data_cost: f64,
    /// Each group's share of `data_cost`, `Σ |r_i|²` over its points.
    pub(crate) group_costs: Vec<f64>,
    /// `|r_o|²` of the global observations.
    pub(crate) global_observation_cost: f64,
    /// All prior terms.
    pub(crate) prior_cost: f64,
    /// With a robust loss ([`crate::Loss`]), the data's and the global
    /// observations' term of the loss; `None` for least squares.
    pub(crate) loss_cost: Option<f64>,
    /// The damping `λ` of the whole system.
    pub(crate) lambda: f64,
}

impl ReducedSystem {
    /// The cost of the (weighted) rows at the state, priors included.
    pub(crate) fn cost(&self) -> f64 {
        self.data_cost + self.global_observation_cost + self.prior_cost
    }

    /// The loss at the state, priors included: what the steps lower
    /// ([`cost`](Self::cost) for least squares).
    pub(crate) fn loss(&self) -> f64 {
        self.loss_cost
            .map_or_else(|| self.cost(), |loss| loss + self.prior_cost)
    }

    /// The minimum of the linearised cost (damped if `λ > 0`), `ρ + bᵀδg`
    /// for the step's global part `δg = −S⁻¹b`.
    pub(crate) fn linear_minimum(&self, dg: &[f64]) -> f64 {
        self.reduced_cost + self.rhs.iter().zip(dg).map(|(b, d)| b * d).sum::<f64>()
    }

    /// The number `G` of global unknowns.
    pub(crate) fn size(&self) -> usize {
        self.rhs.len()
    }

    /// Whether `S` and `b` are finite.
    pub(crate) fn is_finite(&self) -> bool {
        self.matrix.iter().chain(&self.rhs).all(|v| v.is_finite())
    }
}

/// What one chunk contributes.
struct ChunkPart {
    /// `(G + 1)²`, column-major; lower triangle of `[S b; bᵀ ρ]`.
    normal: Vec<f64>,
    data_cost: f64,
    loss_cost: f64,
    group_costs: Vec<f64>,
    prior_cost: f64,
    /// Its fixed groups' prior terms ([`crate::eliminate::Costs::fixed_prior`]).
    fixed_prior_cost: f64,
    global_norms2: Vec<f64>,
}

impl<const C: usize, const P: usize, const R: usize, Pr> ChunkedProblem<'_, C, P, R, Pr>
where
    Pr: Problem<C, P, R>,
{
    /// Linearises every point at `state` and builds the reduced system with
    /// damping `lambda` (0: Gauss–Newton / undamped).
    pub(crate) fn reduce(
        &mut self,
        state: &State<C, P>,
        lambda: f64,
    ) -> Result<ReducedSystem, Failure> {
        let g = self.dims.g;
        let w = g + 1;
        let dims = self.dims;
        let problem = self.problem;
        let (observations, weighed) = self.global_observations(&state.global)?;
        let mut total = vec![0.0; w * w];
        let mut global_norms2 = vec![0.0; g];
        let (mut data_cost, mut prior_cost, mut fixed_prior_cost) = (0.0, 0.0, 0.0);
        let mut loss_cost = weighed.map(|w| w.cost);
        let mut group_costs = Vec::with_capacity(state.groups.len());
        let global = problem.prepare_global(&state.global);
        let global = &global;
        let (pool, jobs) = self.jobs();
        run_chunks(
            pool,
            jobs,
            |ws, (chunk, caches)| {
                let (bufs, rows, _) = ws.split();
                let mut part = ChunkPart {
                    normal: vec![0.0; w * w],
                    data_cost: 0.0,
                    loss_cost: 0.0,
                    group_costs: Vec::with_capacity(chunk.groups.len()),
                    prior_cost: 0.0,
                    fixed_prior_cost: 0.0,
                    global_norms2: vec![0.0; if lambda > 0.0 { g } else { 0 }],
                };
                let mut sink = NormalSink::new(rows, w, &mut part.normal, &mut part.group_costs);
                let gn = (lambda > 0.0).then_some(&mut part.global_norms2[..]);
                let costs = match eliminate_chunk::<C, P, R, _, _>(
                    problem, chunk, state, global, caches, lambda, dims, bufs, gn, &mut sink,
                ) {
                    Ok(costs) => costs,
                    // NaN makes blocks look singular: name the culprit instead.
                    Err(Failure::Singular(block)) => {
                        return Err(find_non_finite::<C, P, R, _>(
                            problem, chunk, state, global, caches,
                        )
                        .unwrap_or(Failure::Singular(block)));
                    }
                    Err(f) => return Err(f),
                };
                sink.flush();
                part.data_cost = costs.data;
                part.loss_cost = costs.loss;
                part.prior_cost = costs.prior;
                part.fixed_prior_cost = costs.fixed_prior;
                let finite = all_finite(&part.normal) && all_finite(&[costs.data, costs.prior]);
                if finite {
                    return Ok(part);
                }
                match find_non_finite::<C, P, R, _>(problem, chunk, state, global, caches) {
                    Some(failure) => Err(failure),
                    None => Ok(part),
                }
            },
            |part: ChunkPart| {
                for (t, x) in total.iter_mut().zip(&part.normal) {
                    *t += x;
                }
                for (t, x) in global_norms2.iter_mut().zip(&part.global_norms2) {
                    *t += x;
                }
                data_cost += part.data_cost;
                if let Some(loss) = &mut loss_cost {
                    *loss += part.loss_cost;
                }
                group_costs.extend(part.group_costs);
                prior_cost += part.prior_cost;
                fixed_prior_cost += part.fixed_prior_cost;
            },
        )?;
        // Lower triangle (column-major) → symmetric row-major S; last row → b.
        let mut matrix = vec![0.0; g * g];
        let mut rhs = vec![0.0; g];
        for j in 0..g {
            for i in j..g {
                let v = total[j * w + i];
                matrix[i * g + j] = v;
                matrix[j * g + i] = v;
            }
            rhs[j] = total[j * w + g];
        }
        let mut reduced_cost = total[g * w + g] + fixed_prior_cost;
        if let Some(prior) = problem.global_prior() {
            let e = &state.global - &prior.mean;
            for j in 0..g {
                for i in j..g {
                    let v = prior.information[(i, j)];
                    matrix[i * g + j] += v;
                    if i != j {
                        matrix[j * g + i] += v;
                    }
                    rhs[i] += v * e[j];
                    if i != j {
                        rhs[j] += v * e[i];
                    }
                }
                global_norms2[j] += if lambda > 0.0 {
                    prior.information[(j, j)]
                } else {
                    0.0
                };
            }
            let cost = prior.cost(&state.global);
            prior_cost += cost;
            reduced_cost += cost;
        }
        let observation_gradient =
            observations.add_normal(&mut matrix, &mut rhs, &mut global_norms2);
        let mut damping = vec![0.0; g];
        if lambda > 0.0 {
            for j in 0..g {
                damping[j] = lambda * damping_diagonal(global_norms2[j]);
                matrix[j * g + j] += damping[j];
            }
        }
        let global_observation_cost = observations.cost();
        Ok(ReducedSystem {
            matrix,
            rhs,
            observation_gradient,
            damping,
            reduced_cost: reduced_cost + global_observation_cost,
            data_cost,
            group_costs,
            global_observation_cost,
            prior_cost,
            loss_cost,
            lambda,
        })
    }

    /// The problem's global observations at `global`, checked: `m` rows and
    /// `G` columns, finite; with a robust loss, weighted
    /// ([`GlobalObservations::weigh`]), with each row's weight and the
    /// observations' term of the loss.
    pub(crate) fn global_observations(
        &self,
        global: &DVector<f64>,
    ) -> Result<(GlobalObservations, Option<WeighedRows>), Failure> {
        let g = self.dims.g;
        let mut observations = GlobalObservations::zeros(0, g);
        self.problem
            .global_observations(global, &mut observations)
            .map_err(|e| Failure::Linearize {
                point: None,
                message: e.to_string(),
            })?;
        let (m, columns) = observations.jacobian.shape();
        if observations.residual.len() != m || columns != g {
            return Err(Failure::Linearize {
                point: None,
                message: format!(
                    "{} residuals with a {m} x {columns} Jacobian on {g} global unknowns",
                    observations.residual.len()
                ),
            });
        }
        let finite = all_finite(observations.residual.as_slice())
            && all_finite(observations.jacobian.as_slice());
        if !finite {
            return Err(Failure::NonFinite { point: None });
        }
        let loss = self.problem.loss();
        if loss.is_squared() {
            return Ok((observations, None));
        }
        let sizes = self.problem.global_observation_rows();
        let weighed = observations
            .weigh(loss, sizes.as_deref())
            .map_err(|message| Failure::Linearize {
                point: None,
                message,
            })?;
        Ok((observations, Some(weighed)))
    }
}

impl GlobalObservations {
    /// Adds `J_oᵀJ_o` to the row-major `G × G` matrix `s`, `J_oᵀ r_o` to `b`
    /// and the squared column norms of `J_o` to `norms2` (the global
    /// observations' part of the damping diagonal); returns `J_oᵀ r_o`
    /// (empty without rows).
    fn add_normal(&self, s: &mut [f64], b: &mut [f64], norms2: &mut [f64]) -> Vec<f64> {
        let (m, g) = self.jacobian.shape();
        if m == 0 {
            return Vec::new();
        }
        let j = &self.jacobian;
        let mut gradient = vec![0.0; g];
        for a in 0..g {
            let column = j.column(a);
            for c in 0..=a {
                let v = column.dot(&j.column(c));
                s[a * g + c] += v;
                if a != c {
                    s[c * g + a] += v;
                }
            }
            norms2[a] += column.norm_squared();
            gradient[a] = column.dot(&self.residual);
            b[a] += gradient[a];
        }
        gradient
    }
}

/// Pivots of the Jacobi-scaled matrix (unit diagonal) at or below this count
/// as zero: the reduced matrix is then treated as singular.
pub(crate) const PIVOT_TOLERANCE: f64 = 1e-13;

/// Cholesky factorisation `D^{-1/2} S D^{-1/2} = L Lᵀ` of a symmetric matrix
/// scaled to unit diagonal (`D = diag S`), so that the pivot test is
/// independent of the units of the parameters.
pub(crate) struct ScaledCholesky {
    n: usize,
    /// `1/√S_jj`.
    scale: Vec<f64>,
    /// `L`, row-major, lower triangle.
    l: Vec<f64>,
}

impl ScaledCholesky {
    /// Factorises the row-major symmetric `n × n` matrix; `None` unless it is
    /// numerically positive definite (a non-positive diagonal entry, or a
    /// scaled pivot ≤ [`PIVOT_TOLERANCE`]).
    pub(crate) fn new(a: &[f64], n: usize) -> Option<Self> {
        let mut scale = vec![0.0; n];
        for j in 0..n {
            let d = a[j * n + j];
            if !(d > 0.0 && d.is_finite()) {
                return None;
            }
            scale[j] = 1.0 / d.sqrt();
        }
        let mut l = vec![0.0; n * n];
        for i in 0..n {
            for j in 0..=i {
                l[i * n + j] = a[i * n + j] * scale[i] * scale[j];
            }
        }
        for j in 0..n {
            let mut d = l[j * n + j];
            for k in 0..j {
                d -= l[j * n + k] * l[j * n + k];
            }
            if d.is_nan() || d <= PIVOT_TOLERANCE {
                return None;
            }
            let ljj = d.sqrt();
            l[j * n + j] = ljj;
            for i in j + 1..n {
                let mut x = l[i * n + j];
                for k in 0..j {
                    x -= l[i * n + k] * l[j * n + k];
                }
                l[i * n + j] = x / ljj;
            }
        }
        Some(Self { n, scale, l })
    }

    /// `S⁻¹ b`.
    pub(crate) fn solve(&self, b: &[f64]) -> Vec<f64> {
        let n = self.n;
        let mut y: Vec<f64> = b.iter().zip(&self.scale).map(|(b, s)| b * s).collect();
        for i in 0..n {
            let mut x = y[i];
            for k in 0..i {
                x -= self.l[i * n + k] * y[k];
            }
            y[i] = x / self.l[i * n + i];
        }
        for i in (0..n).rev() {
            let mut x = y[i];
            for k in i + 1..n {
                x -= self.l[k * n + i] * y[k];
            }
            y[i] = x / self.l[i * n + i];
        }
        for (y, s) in y.iter_mut().zip(&self.scale) {
            *y *= s;
        }
        y
    }

    /// The lower-triangular factor of `S` itself, `D^{1/2} L` with
    /// `S = (D^{1/2} L)(D^{1/2} L)ᵀ`, row-major, zero above the diagonal.
    pub(crate) fn lower_factor(&self) -> Vec<f64> {
        let n = self.n;
        let mut l = vec![0.0; n * n];
        for i in 0..n {
            for j in 0..=i {
                l[i * n + j] = self.l[i * n + j] / self.scale[i];
            }
        }
        l
    }

    /// `S⁻¹`, row-major, symmetrised.
    pub(crate) fn inverse(&self) -> Vec<f64> {
        let n = self.n;
        let mut inv = vec![0.0; n * n];
        let mut e = vec![0.0; n];
        for j in 0..n {
            e.fill(0.0);
            e[j] = 1.0;
            let col = self.solve(&e);
            for i in 0..n {
                inv[i * n + j] = col[i];
            }
        }
        for i in 0..n {
            for j in 0..i {
                let v = 0.5 * (inv[i * n + j] + inv[j * n + i]);
                inv[i * n + j] = v;
                inv[j * n + i] = v;
            }
        }
        inv
    }
}

/// `Cov(g)` (`G × G`, from the lower triangle of `covariance`) and `L`
/// with `Cov(g) = LLᵀ` (row-major, lower triangular); fails with
/// [`Status::InvalidProblem`] if it is not `G × G` and numerically positive
/// definite.
pub(crate) fn covariance_factor(
    covariance: &DMatrix<f64>,
    g: usize,
) -> Result<(DMatrix<f64>, Vec<f64>), Status> {
    let invalid = |message: String| Status::InvalidProblem { message };
    if covariance.shape() != (g, g) {
        let (rows, columns) = covariance.shape();
        return Err(invalid(format!(
            "a {rows} x {columns} covariance for {g} global unknowns"
        )));
    }
    let symmetric = DMatrix::from_fn(g, g, |i, j| covariance[(i.max(j), i.min(j))]);
    let factor = ScaledCholesky::new(symmetric.as_slice(), g)
        .ok_or_else(|| invalid("the covariance is not positive definite".into()))?;
    Ok((symmetric, factor.lower_factor()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scaled_cholesky_solves_and_inverts_badly_scaled_matrix() {
        // S = D^{1/2} M D^{1/2} with M well conditioned, D spanning 1e-8..1e8.
        let n = 3;
        let m = [4.0, 1.0, 0.5, 1.0, 3.0, 0.2, 0.5, 0.2, 2.0];
        let d: [f64; 3] = [1e8, 1.0, 1e-8];
        let s: Vec<f64> = (0..9)
            .map(|k| m[k] * (d[k / 3] * d[k % 3]).sqrt())
            .collect();
        let f = ScaledCholesky::new(&s, n).unwrap();
        let x_true = [1e-4, 2.0, -3e4];
        let b: Vec<f64> = (0..n)
            .map(|i| (0..n).map(|j| s[i * n + j] * x_true[j]).sum())
            .collect();
        let x = f.solve(&b);
        for i in 0..n {
            assert!((x[i] - x_true[i]).abs() <= 1e-12 * x_true[i].abs());
        }
        let l = f.lower_factor();
        for i in 0..n {
            for j in 0..n {
                let p: f64 = (0..n).map(|k| l[i * n + k] * l[j * n + k]).sum();
                assert!((p - s[i * n + j]).abs() <= 1e-14 * (s[i * n + i] * s[j * n + j]).sqrt());
            }
        }
        let inv = f.inverse();
        for i in 0..n {
            for j in 0..n {
                let p: f64 = (0..n).map(|k| s[i * n + k] * inv[k * n + j]).sum();
                assert!((p - f64::from(u8::from(i == j))).abs() < 1e-12);
            }
        }
    }

    #[test]
    fn scaled_cholesky_rejects_singular() {
        assert!(ScaledCholesky::new(&[1.0, 0.0, 0.0, 0.0], 2).is_none());
        assert!(ScaledCholesky::new(&[1.0, 1.0, 1.0, 1.0], 2).is_none());
        assert!(ScaledCholesky::new(&[1.0, 2.0, 2.0, 1.0], 2).is_none());
        assert!(ScaledCholesky::new(&[f64::NAN, 0.0, 0.0, 1.0], 2).is_none());
    }
}
