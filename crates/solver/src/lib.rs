//! Sparse nonlinear least squares with three levels of unknowns, eliminated
//! by a Schur complement in square-root (QR) form, in the manner of bundle
//! adjustment. The crate knows nothing about hexapods.
//!
//! # The problem
//!
//! The unknowns are one dense **global** block `g ∈ Rᴳ`, one **group** block
//! `c_k ∈ Rᶜ` per group `k`, and one **point** block `p_i ∈ Rᴾ` per point `i`
//! (`P` may be 0); each point belongs to exactly one group `k(i)`, and the
//! points of a group are contiguous. `C`, `P` and the number of rows per
//! point are compile-time constants; `G` is the problem's
//! ([`Problem::global_size`]). Point `i` has `R` whitened residual rows
//! `r_i(g, c_k(i), p_i)`, and a few **global observations** `r_o(g)`
//! (`m` rows, [`Problem::global_observations`]) depend on the global block
//! only. The cost is
//!
//! ```text
//! F(x) = Σ_i |r_i|²  +  |r_o|²  +  Σ_blocks (x_b − m_b)ᵀ Λ_b (x_b − m_b)
//! ```
//!
//! with optional Gaussian priors (mean `m_b`, full information `Λ_b`) on the
//! global block, on each group block and on each point block. A prior is a
//! set of extra rows `U_b (x_b − m_b)` with `U_bᵀU_b = Λ_b`, stacked under
//! the Jacobian. The Gauss–Newton step (Sato et al. 2004, eq. 5) solves
//!
//! ```text
//! (JᵀJ + Λ) δ = −(Jᵀr + Λ (x − m)),     x ← x + δ.
//! ```
//!
//! A group may be **fixed** ([`Problem::group_is_fixed`]): its block keeps
//! its value and is not an unknown (its columns are left out of `J`).
//!
//! # Block structure
//!
//! Two groups, points 0–1 in group 0 and 2–3 in group 1, and the global
//! observations (`·` is zero):
//!
//! ```text
//!            p0   p1   p2   p3 │ c0   c1 │  g
//!   r0    [ P0    ·    ·    ·  │ C0    · │ G0 ]
//!   r1    [  ·   P1    ·    ·  │ C1    · │ G1 ]
//!   r2    [  ·    ·   P2    ·  │  ·   C2 │ G2 ]
//!   r3    [  ·    ·    ·   P3  │  ·   C3 │ G3 ]
//!   r_o   [  ·    ·    ·    ·  │  ·    · │ J_o]
//! ```
//!
//! Point columns are block-diagonal, group columns block-diagonal over the
//! groups, and the global columns dense. Eliminating points, then groups,
//! leaves a small dense `G × G` system. If group 1 were fixed, its column
//! `c1` would be absent.
//!
//! # Elimination in square-root form
//!
//! Nothing is formed as a normal matrix except the final `G × G` one; all
//! eliminations are orthogonal transformations of rows (cf. Demmel et al.,
//! "Square Root Bundle Adjustment", CVPR 2021; Ceres'
//! `SchurEliminatorForOneFBlock`).
//!
//! 1. **Point.** The rows `[P_i | C_i | G_i | r_i]` of point `i` (plus its
//!    prior rows `[U_p | 0 | 0 | U_p(p−m_p)]`, plus damping rows) get a
//!    Householder QR on the `P` point columns (3 data rows and 2 point
//!    columns alone: in closed form, the eliminated row being the unit
//!    normal of the two columns):
//!
//!    ```text
//!    Qᵢᵀ [P_i C_i G_i r_i] = [ R_pp  R_pc  R_pg  z_p ]   back-substitution rows (P)
//!                            [  0    A_c   A_g   a   ]   point-eliminated rows
//!    ```
//!
//! 2. **Group.** The point-eliminated rows of all points of group `k` (plus
//!    the group prior and damping rows) get a QR on the `C` group columns:
//!
//!    ```text
//!    Q_kᵀ [A_c A_g a] = [ R_cc  R_cg  z_c ]   back-substitution rows (C)
//!                       [  0    B_g   β   ]   reduced rows
//!    ```
//!
//!    The point-eliminated rows `[A_g a]` of a fixed group are reduced rows
//!    as they are (no `A_c`: no group QR).
//!
//! 3. **Reduced system.** As the `Q`s are orthogonal, the reduced rows of all
//!    groups satisfy `Σ [B_g β]ᵀ[B_g β] = [S b; bᵀ ρ]`, where `S` is the Schur
//!    complement of the normal matrix onto the global block,
//!    `S = H_gg − H_g,cp H_cp,cp⁻¹ H_cp,g`, and `b` the reduced gradient. `S`
//!    and `b` come from one Gram update `AᵀA` per buffer of reduced rows.
//!    The global prior and the global observations, which involve no other
//!    block, are added as they are (`S += Λ_g + J_oᵀJ_o`,
//!    `b += Λ_g(g − m_g) + J_oᵀr_o`) and `S δg = −b` is solved by a
//!    Cholesky factorisation of `S` scaled to unit diagonal.
//!
//! 4. **Back-substitution.** A second pass linearises every point again
//!    (its [`Problem::PointCache`] makes this cheap), folds the now known
//!    `δg` into the residual column and repeats the small QRs; then
//!    `R_cc δc = −(z_c + R_cg δg)` and `R_pp δp = −(z_p + R_pc δc + R_pg δg)`
//!    (`δc = 0` for a fixed group). Until the iteration has settled, each
//!    group then takes Gauss–Newton steps of its own in the same pass,
//!    against its points' rows at the new global block predicted to first
//!    order ([`Problem::local_rows`], [`SolverOptions::local_steps`]); once
//!    it has, the few groups that carry a large share of the step take
//!    steps of their own with `δg = 0` before the trial point is evaluated
//!    ([`refine`]).
//!
//! 5. **Covariance** (after the last iterate, undamped): `Cov(g) = S⁻¹`, and
//!    the full marginal covariance of each group,
//!    `Cov(c_k) = R_cc⁻¹R_cc⁻ᵀ + K Cov(g) Kᵀ` with `K = R_cc⁻¹R_cg`, from one
//!    more pass that recomputes the groups' triangles. A fixed group's block
//!    is known: its sigmas are reported as zero, and `Cov(g)` is the
//!    covariance given the fixed blocks.
//!
//! 6. **Redundancy** (on request, [`redundancy`]): the redundancy number
//!    `r_j = 1 − h_j` of every whitened row, `h_j` its diagonal entry of
//!    `J Cov Jᵀ` over all unknowns, from one more pass: a point's rows
//!    through its `Q`, its group's triangle and `Cov(g)`, never the full
//!    matrix; and the normalised residuals `e_j / √r_j`
//!    ([`normalised_residual`]). The same pass carries the problem's
//!    effects ([`Problem::effects`]) as extra right-hand sides and projects
//!    them ([`effects`]).
//!
//! # Gauss–Newton and Levenberg–Marquardt
//!
//! One loop solves each step, evaluates its trial point (building the
//! reduced system there) and leaves the decision to a step policy
//! ([`Method`]), as Ceres keeps its trust-region strategy out of the
//! minimiser.
//!
//! [`Method::GaussNewton`] takes the full step, with no line search, and
//! may diverge: the run ends (`Diverged`, at the iterate before the step)
//! when the cost becomes non-finite, exceeds
//! [`SolverOptions::divergence_ratio`] times the initial cost, or rises by
//! more than [`SolverOptions::step_divergence_ratio`] in one step; it ends
//! too where there is no step (a singular reduced matrix, a non-finite
//! step, a failed evaluation).
//!
//! [`Method::LevenbergMarquardt`] solves `(H + λD) δ = −b` with Marquardt's
//! scaling `D = clamp(diag H, 1e-6, 1e32)` (diagonal of the full normal
//! matrix, priors and global observations included; the clamp as in Ceres,
//! so that a parameter no residual sees is still damped). The damping
//! enters as extra rows `√(λ D_j) e_j` at each level: in each point block,
//! in each group block (with `D` of the group summed over its points' raw
//! Jacobians), and on the diagonal of `S`. The predicted decrease is
//! `−bᵀδ + δᵀ(λD)δ`, accumulated during back-substitution; the step is
//! accepted if the cost decreases (gain ratio `ρ > 0`), and `λ` follows
//! Nielsen (`λ·max(1/3, 1 − (2ρ−1)³)` on acceptance, `λ·ν, ν ← 2ν` on
//! rejection), with one change: the trial point is evaluated by building
//! its reduced system with `λ/3`, and a good step (`ρ ≥ 0.75`) keeps that
//! system and that `λ/3` (Nielsen would divide by 1.1–3 there). A good step
//! then costs two passes over the points, like a Gauss–Newton step; a
//! weaker step or a rejection one more. A singular reduced matrix, a
//! non-finite step or a failed evaluation at a trial point counts as a
//! rejection.
//!
//! # Robust loss
//!
//! A problem may put a robust loss ([`Loss`]: Huber's, Cauchy's) on its
//! observations ([`Problem::loss`]): each point's rows form one
//! observation ([`point_degrees_of_freedom`]), the global observations are
//! grouped by [`Problem::global_observation_rows`], priors are never
//! weighted. Every pass scales each observation's rows by `√w(u)` at the
//! state it linearises at, right after the linearisation, so that the
//! elimination, the back-substitution, the covariance and the redundancy
//! numbers all see the same weighted problem: iteratively reweighted least
//! squares inside the iteration (Holland and Welsch 1977). The steps are
//! judged on the loss, which the weighted cost majorises; the history and
//! the covariance are the weighted problem's. With least squares (the default) no weight is
//! computed.
//!
//! # Watching a run
//!
//! [`solve_with_caches`] takes a [`Monitor`]: it sees each history record,
//! and each new iterate once its reduced system is built, with every
//! group's data cost `Σ |r_i|²` from that elimination pass (free: the pass
//! computes them anyway) and the points' caches. It may stop the run there,
//! before the step ([`Status::Stopped`]): the caller can change the state
//! (re-seed a group caught in a wrong minimum, say) and resume with the
//! caches the run hands back. Resumed unchanged, the run takes the steps it
//! would have taken (bit for bit when the problem's evaluation does not
//! depend on its caches' history).
//!
//! # Parallelism, determinism, memory
//!
//! Groups are cut into chunks of [`SolverOptions::groups_per_chunk`]. Chunks
//! run in parallel (rayon, in waves of 256 chunks); each reduces its rows into
//! its own partial `(G+1)²` matrix with buffers sized once per run (a group
//! is folded in batches of at most 256 rows, reduced rows are multiplied in
//! batches of 2048), and the partial results are summed sequentially in
//! chunk order.
//! Every kernel runs sequentially inside a chunk (`Par::Seq`), and the
//! points are linearised in batches of at most [`BATCH`] of one group, in
//! order, with one [`Problem::Workspace`] per chunk and pass. Hence results
//! are bit-identical for any number of threads (they do depend on
//! `groups_per_chunk`, at rounding level). Nothing is allocated per point:
//! each thread reuses its workspace (about 0.7 MB for `G = 33`). Per point
//! the solver keeps only the point's cache, its value and its trial value
//! (`2 · 8P` bytes + `size_of::<PointCache>()`, 32 bytes for `P = 2` and a
//! zero-sized cache); Jacobians are never stored across passes. During
//! back-substitution a thread holds `8P(C+3)` bytes per point of the group it
//! is working on.
//!
//! The point factor is computed once per pass: its panel
//! `[d_point; U_p; √(λD_p)]` (`m × P`, `m = R` without prior or damping) is
//! factorised and its `Q` formed explicitly; the point's `m − P` eliminated
//! rows are then `Q₂ᵀ [d_group | d_global | r]` computed straight from the
//! Jacobians (the "nullspace" form), without assembling the point's block.
//! Damping at the point level makes every point contribute `R` reduced rows
//! instead of `R − P`, so a Levenberg–Marquardt pass costs more than a
//! Gauss–Newton one.
//!
//! # Checking
//!
//! [`linear_step`] returns one step of the Schur solver without applying it
//! ([`reduced_step`] its global part and the minimum of the linearised
//! cost, from the reduced system alone), and [`dense_reference`] solves the same step, and inverts the normal
//! matrix, densely: for tests on small problems.
//!
//! # Example
//!
//! Points measured on circles of one common unknown radius (`G = 1`), with
//! unknown centres (`C = 2`), no point unknowns (`P = 0`), one row per point
//! (`R = 1`: distance to the centre minus the radius):
//!
//! ```
//! use nalgebra::{DVector, Dyn, OMatrix, SVector, U1, Vector1, Vector2};
//! use parcal_solver::{solve, Linearization, Problem, SolverOptions, State, Status};
//!
//! struct Circles { points: Vec<Vector2<f64>>, per_circle: usize }
//!
//! impl Problem<2, 0, 1> for Circles {
//!     type PointCache = ();
//!     type Workspace = ();
//!     type Anchor = ();
//!     type Error = std::convert::Infallible;
//!     type Jacobian = OMatrix<f64, U1, Dyn>; // dense, 1 x G
//!     type Global = f64; // the radius
//!     fn global_size(&self) -> usize { 1 }
//!     fn prepare_global(&self, global: &DVector<f64>) -> f64 { global[0] }
//!     fn n_groups(&self) -> usize { self.points.len() / self.per_circle }
//!     fn group_points(&self, k: usize) -> std::ops::Range<usize> {
//!         k * self.per_circle..(k + 1) * self.per_circle
//!     }
//!     fn initial_cache(&self, _i: usize) {}
//!     fn linearize(&self, i: usize, radius: &f64, centre: &Vector2<f64>,
//!                  _p: &SVector<f64, 0>, _cache: &mut (),
//!                  out: &mut Linearization<2, 0, 1>) -> Result<(), Self::Error> {
//!         let d = self.points[i] - centre;
//!         let n = d.norm();
//!         out.residual = Vector1::new(n - radius);
//!         out.d_global[0] = -1.0;
//!         out.d_group = (-d / n).transpose();
//!         Ok(())
//!     }
//! }
//!
//! let centres = [Vector2::new(0.0, 0.0), Vector2::new(5.0, 1.0)];
//! let points = centres.iter().flat_map(|c| {
//!     (0..5).map(move |j| c + 2.0 * Vector2::new((1.3 * j as f64).cos(), (1.3 * j as f64).sin()))
//! }).collect();
//! let problem = Circles { points, per_circle: 5 };
//! let initial = State {
//!     global: DVector::from_element(1, 1.5),
//!     groups: vec![Vector2::new(0.3, -0.2), Vector2::new(4.6, 1.2)],
//!     points: vec![SVector::zeros(); 10],
//! };
//! let solution = solve(&problem, initial, &SolverOptions::default(), &mut |_| {});
//! assert_eq!(solution.status, Status::Converged);
//! // The run ends where a step would move no unknown by more than 1e-3 of
//! // its standard deviation (the rows in units of their sigma, here 1).
//! let sigma = solution.covariance.as_ref().unwrap()[(0, 0)].sqrt();
//! assert!((solution.state.global[0] - 2.0).abs() < 1e-3 * sigma);
//! let centre_sigmas = solution.group_sigmas.as_ref().unwrap()[1];
//! let error = solution.state.groups[1] - centres[1];
//! assert!((0..2).all(|j| error[j].abs() < 1e-3 * centre_sigmas[j]));
//! ```

// Dense kernels read best with index loops over several arrays at once.
#![allow(clippy::needless_range_loop)]

mod backsub;
mod chunked_problem;
mod chunks;
mod covariance;
pub mod dense_reference;
mod diagnostics;
pub mod effects;
mod eliminate;
mod factor_product;
mod gram;
mod influence;
mod iterate;
mod local;
mod loss;
mod monitor;
mod options;
mod point_panel;
mod policy;
mod problem;
mod qr;
mod reduced;
mod redundancy;
pub mod refine;
mod rows;
mod solution;

pub use chunks::{filled, split_by};
pub use covariance::group_sigmas;
pub use diagnostics::{SpectrumDiagnostics, WeakDirection};
pub use influence::{RowId, RowInfluence, row_influence};
pub use iterate::{LinearStep, ReducedStep, linear_step, reduced_step, solve, solve_with_caches};
pub use loss::{CAUCHY_K, HUBER_K, Loss, Weighed};
pub use monitor::{Decision, Iterate, Monitor};
pub use options::{Method, SIGMA_TOLERANCE, SolverOptions};
pub use problem::{
    BATCH, GaussianPrior, GlobalJacobian, GlobalObservations, Linearization, LocalRows, Problem,
    State, WeighedRows, point_degrees_of_freedom,
};
pub use redundancy::{
    MIN_REDUNDANCY, PointRows, PriorLeverage, Redundancy, normalised_residual, redundancy,
};
pub use solution::{BlockId, IterationRecord, Solution, Status};
