//! What a caller implements: the residual blocks of one point, the optional
//! Gaussian priors, and the state the solver iterates on.

use std::ops::Range;

use nalgebra::allocator::Allocator;
use nalgebra::{
    Const, DMatrix, DVector, DefaultAllocator, Dim, Dyn, OMatrix, OVector, SMatrix, SVector,
};

use crate::loss::{Loss, Weighed};
use crate::qr::all_finite;

/// The Jacobian of a point's whitened residual (`R` rows) with respect to the
/// global block (`G` unknowns, [`Problem::global_size`]), as the
/// elimination uses it: through combinations of its rows and its product
/// with a vector. A dense `OMatrix<f64, Const<R>, Dyn>` (`R × G`) is one; a
/// problem whose global Jacobian is costly to form can implement the two
/// products directly (e.g. one transposed solve per combination instead of
/// `R` rows).
pub trait GlobalJacobian<const R: usize>: Sized {
    /// A zero Jacobian with `global_size` columns, the placeholder the
    /// solver hands to [`Problem::linearize`] to be overwritten.
    fn zeros(global_size: usize) -> Self;

    /// Writes `Σ_r c_r J[r, ·]` into `out` (all its `G` values).
    fn combine_rows(&self, c: &[f64; R], out: &mut [f64]);

    /// `J v` (`v`: `G` values).
    fn apply(&self, v: &DVector<f64>) -> SVector<f64, R>;

    /// `J ← factor · J`: the point's rows weighted by a robust loss
    /// ([`Linearization::weigh`]).
    fn scale(&mut self, factor: f64);

    /// Row `r` of `J`, written into `out` (`G` values).
    fn row(&self, r: usize, out: &mut [f64]) {
        let mut c = [0.0; R];
        c[r] = 1.0;
        self.combine_rows(&c, out);
    }

    /// Adds `Σ_r J[r, j]²` to `out[j]` (`G` values); `row` is scratch of
    /// the same length (the default forms each row there).
    fn add_column_norms2(&self, out: &mut [f64], row: &mut [f64]) {
        for r in 0..R {
            self.row(r, row);
            for (o, x) in out.iter_mut().zip(row.iter()) {
                *o += x * x;
            }
        }
    }

    /// Whether every entry is finite; `row` is scratch of `G` values.
    fn is_finite(&self, row: &mut [f64]) -> bool {
        (0..R).all(|r| {
            self.row(r, row);
            all_finite(row)
        })
    }
}

impl<const R: usize> GlobalJacobian<R> for OMatrix<f64, Const<R>, Dyn> {
    fn zeros(global_size: usize) -> Self {
        OMatrix::zeros_generic(Const::<R>, Dyn(global_size))
    }

    fn combine_rows(&self, c: &[f64; R], out: &mut [f64]) {
        for (o, column) in out.iter_mut().zip(self.column_iter()) {
            *o = (0..R).map(|r| c[r] * column[r]).sum();
        }
    }

    fn apply(&self, v: &DVector<f64>) -> SVector<f64, R> {
        self * v
    }

    fn scale(&mut self, factor: f64) {
        *self *= factor;
    }

    fn add_column_norms2(&self, out: &mut [f64], _row: &mut [f64]) {
        for (o, column) in out.iter_mut().zip(self.column_iter()) {
            *o += column.norm_squared();
        }
    }

    fn is_finite(&self, _row: &mut [f64]) -> bool {
        all_finite(self.as_slice())
    }
}

/// The whitened residual of one point and its Jacobians with respect to the
/// three blocks of unknowns it depends on; the global one as any
/// [`GlobalJacobian`] (by default a dense `R × G` matrix).
#[derive(Clone, Debug, PartialEq)]
pub struct Linearization<
    const C: usize,
    const P: usize,
    const R: usize,
    J = OMatrix<f64, Const<R>, Dyn>,
> {
    /// Whitened residual `r_i` (already multiplied by the square root of the
    /// measurement information).
    pub residual: SVector<f64, R>,
    /// `∂r_i/∂g`.
    pub d_global: J,
    /// `∂r_i/∂c_k(i)`.
    pub d_group: SMatrix<f64, R, C>,
    /// `∂r_i/∂p_i`.
    pub d_point: SMatrix<f64, R, P>,
}

impl<const C: usize, const P: usize, const R: usize, J: GlobalJacobian<R>>
    Linearization<C, P, R, J>
{
    /// All-zero residual and Jacobians (`global_size` global columns), to be
    /// filled in.
    pub fn zeros(global_size: usize) -> Self {
        Self {
            residual: SVector::zeros(),
            d_global: J::zeros(global_size),
            d_group: SMatrix::zeros(),
            d_point: SMatrix::zeros(),
        }
    }

    /// Weighs the point's rows by the robust `loss` at their residual
    /// ([`Loss::observation`], the point one observation of
    /// [`point_degrees_of_freedom`] degrees): residual and Jacobians scaled
    /// by `√w`. Returns the weight and the point's term of the loss.
    pub fn weigh(&mut self, loss: Loss) -> Weighed {
        let weighed =
            loss.observation(self.residual.norm_squared(), point_degrees_of_freedom(R, P));
        if weighed.weight != 1.0 {
            let s = weighed.weight.sqrt();
            self.residual *= s;
            self.d_global.scale(s);
            self.d_group *= s;
            self.d_point *= s;
        }
        weighed
    }

    /// Whether every entry is finite; `row` is scratch of `G` values
    /// ([`GlobalJacobian::is_finite`]).
    pub fn is_finite(&self, row: &mut [f64]) -> bool {
        all_finite(self.residual.as_slice())
            && self.d_global.is_finite(row)
            && all_finite(self.d_group.as_slice())
            && all_finite(self.d_point.as_slice())
    }
}

/// A Gaussian prior `N(mean, information⁻¹)` on one block of unknowns of
/// dimension `D` (`Const<N>` for a group or point block, `Dyn` for the
/// global block); it adds `(x − mean)ᵀ · information · (x − mean)` to the
/// cost.
///
/// The information matrix must be symmetric positive semi-definite (a zero
/// eigenvalue means "no information in that direction"). Only its lower
/// triangle is read.
#[derive(Clone, Debug, PartialEq)]
pub struct GaussianPrior<D: Dim>
where
    DefaultAllocator: Allocator<D> + Allocator<D, D>,
{
    /// Prior mean.
    pub mean: OVector<f64, D>,
    /// Prior information (inverse covariance), full `N × N`.
    pub information: OMatrix<f64, D, D>,
}

impl<D: Dim> GaussianPrior<D>
where
    DefaultAllocator: Allocator<D> + Allocator<D, D>,
{
    /// A prior from its mean and full information matrix.
    pub fn new(mean: OVector<f64, D>, information: OMatrix<f64, D, D>) -> Self {
        Self { mean, information }
    }

    /// An independent prior: information `diag(1/σ²)`. An infinite σ gives
    /// zero information for that coordinate.
    pub fn from_sigmas(mean: OVector<f64, D>, sigmas: OVector<f64, D>) -> Self {
        let information = OMatrix::from_diagonal(&sigmas.map(|s| 1.0 / (s * s)));
        Self { mean, information }
    }

    /// The prior's cost `(x − mean)ᵀ · information · (x − mean)`, reading the
    /// lower triangle only.
    pub fn cost(&self, x: &OVector<f64, D>) -> f64 {
        let e = x - &self.mean;
        let n = e.len();
        let mut total = 0.0;
        for j in 0..n {
            total += self.information[(j, j)] * e[j] * e[j];
            for i in j + 1..n {
                total += 2.0 * self.information[(i, j)] * e[i] * e[j];
            }
        }
        total
    }
}

/// A point's whitened residual and its Jacobians with respect to its
/// group's block and its own, the global block's part held at an anchor
/// ([`Problem::local_rows`]): the rows of a local step.
#[derive(Clone, Debug, PartialEq)]
pub struct LocalRows<const C: usize, const P: usize, const R: usize> {
    /// Whitened residual `r_i`.
    pub residual: SVector<f64, R>,
    /// `∂r_i/∂c_k(i)`.
    pub d_group: SMatrix<f64, R, C>,
    /// `∂r_i/∂p_i`.
    pub d_point: SMatrix<f64, R, P>,
}

impl<const C: usize, const P: usize, const R: usize> Default for LocalRows<C, P, R> {
    fn default() -> Self {
        Self {
            residual: SVector::zeros(),
            d_group: SMatrix::zeros(),
            d_point: SMatrix::zeros(),
        }
    }
}

/// Residual rows that depend on the global block only, whitened, with their
/// dense Jacobian: `m` rows `r_o(g)` and `J_o = ∂r_o/∂g` (`m × G`), `m`
/// small (tens to a few hundred). [`Problem::global_observations`] fills
/// them in, resizing both as it needs.
#[derive(Clone, Debug, PartialEq)]
pub struct GlobalObservations {
    /// `r_o` (`m` values).
    pub residual: DVector<f64>,
    /// `J_o` (`m × G`).
    pub jacobian: DMatrix<f64>,
}

impl GlobalObservations {
    /// `rows` zero rows on a global block of `global_size` unknowns.
    pub fn zeros(rows: usize, global_size: usize) -> Self {
        Self {
            residual: DVector::zeros(rows),
            jacobian: DMatrix::zeros(rows, global_size),
        }
    }

    /// `|r_o|²`, their part of the cost.
    pub fn cost(&self) -> f64 {
        self.residual.norm_squared()
    }

    /// Weighs each observation's rows by the robust `loss` at their
    /// residual ([`Loss::observation`], an observation of `n` rows having
    /// `n` degrees of freedom): residual and Jacobian rows scaled by `√w`.
    /// `sizes`: the rows of each observation, `None`: one each
    /// ([`Problem::global_observation_rows`]). Fails with why `sizes` do
    /// not fit the rows.
    pub fn weigh(&mut self, loss: Loss, sizes: Option<&[usize]>) -> Result<WeighedRows, String> {
        let m = self.residual.len();
        let one_each = vec![1; m];
        let sizes = sizes.unwrap_or(&one_each);
        let total: usize = sizes.iter().sum();
        if total != m || sizes.contains(&0) {
            return Err(format!(
                "global observations of {total} rows in all (sizes {sizes:?}) for {m} rows"
            ));
        }
        let (mut weights, mut cost) = (Vec::with_capacity(m), 0.0);
        for &n in sizes {
            let first = weights.len();
            let rows = self.residual.rows(first, n);
            let weighed = loss.observation(rows.norm_squared(), n);
            let s = weighed.weight.sqrt();
            self.residual.rows_mut(first, n).scale_mut(s);
            self.jacobian.rows_mut(first, n).scale_mut(s);
            weights.resize(first + n, weighed.weight);
            cost += weighed.cost;
        }
        Ok(WeighedRows { weights, cost })
    }
}

/// The global observations weighed by a robust loss
/// ([`GlobalObservations::weigh`]).
#[derive(Clone, Debug, PartialEq)]
pub struct WeighedRows {
    /// Each row's weight (its observation's).
    pub weights: Vec<f64>,
    /// The observations' term of the loss.
    pub cost: f64,
}

/// The degrees of freedom of a point's `rows` residual rows as one
/// observation of a robust loss: `rows − point_unknowns` (at least 1), since
/// its own `point_unknowns` unknowns, which no other row sees, absorb as many
/// dimensions of its residual (three coordinates with two angles leave the
/// one normal to the surface).
pub const fn point_degrees_of_freedom(rows: usize, point_unknowns: usize) -> usize {
    if rows > point_unknowns {
        rows - point_unknowns
    } else {
        1
    }
}

/// Points linearised together at most ([`Problem::linearize_batch`]): a
/// group of up to 8 points (a ball's touches) in one call, so that a
/// problem pays its per-call work (its parameters prepared, its batch
/// gathered) once per group and runs the points in SIMD lanes of 4 (twice
/// that) as it likes.
pub const BATCH: usize = 8;

/// A least-squares problem with one global block (`G` unknowns,
/// [`global_size`](Problem::global_size)), `n_groups` group blocks (`C`
/// unknowns each) and one point block (`P` unknowns) per point; point `i`
/// has `R` whitened residual rows that depend on the global block, its
/// group's block and its own block only. Optionally, a few residual rows
/// depend on the global block only
/// ([`global_observations`](Problem::global_observations)), and some groups
/// are held fixed ([`group_is_fixed`](Problem::group_is_fixed)).
///
/// Points are numbered `0..n_points`; the points of group `k` are the
/// contiguous range [`group_points(k)`](Problem::group_points), and the ranges
/// of groups `0, 1, …` follow each other without gaps, starting at 0.
pub trait Problem<const C: usize, const P: usize, const R: usize>: Sync {
    /// Per-point state kept by the solver between evaluations (e.g. a warm
    /// start of an inner iteration). The solver keeps one per point for the
    /// whole run and hands it to every [`linearize`](Problem::linearize) of
    /// that point.
    type PointCache: Clone + Send + Sync;
    /// Working memory a problem carries from one batch of points to the
    /// next (e.g. the row order a factorisation tries first): the solver
    /// makes one (`Default`) per chunk of groups and pass over the points,
    /// and hands it to the chunk's batches in order, so that what it
    /// carries never depends on the number of threads. `()` if none.
    type Workspace: Default + Send;
    /// The error a linearisation can fail with.
    type Error: std::error::Error + Send + Sync + 'static;
    /// The global Jacobian of a point (`OMatrix<f64, Const<R>, Dyn>` when
    /// dense).
    type Jacobian: GlobalJacobian<R>;
    /// What the points' linearisations need of the global block: the block
    /// itself, or what they would otherwise each derive from it (e.g. a
    /// geometry built from parameters), made once per pass over the points
    /// by [`prepare_global`](Problem::prepare_global).
    type Global: Sync;
    /// What a point's rows take of the global block, as a linearisation
    /// along a step predicts it at the new global block
    /// ([`Problem::linearize_along_batch`]): what
    /// [`local_rows`](Problem::local_rows) evaluates them at, without the
    /// global block's own work (e.g. a tool point, without its forward
    /// kinematics). `()` for a problem without local rows.
    type Anchor: Clone + Default + Send;

    /// The number `G` of global unknowns: the length of the state's global
    /// block.
    fn global_size(&self) -> usize;

    /// [`Problem::Global`] at the global block `global`, before a pass over
    /// the points.
    fn prepare_global(&self, global: &DVector<f64>) -> Self::Global;

    /// Number of groups.
    fn n_groups(&self) -> usize;

    /// Points of group `k`: contiguous, groups in order partition `0..n_points`.
    fn group_points(&self, k: usize) -> Range<usize>;

    /// Whether group `k`'s block is held at its value in the state instead
    /// of being an unknown (the problem carries those unknowns elsewhere,
    /// e.g. in the global block, or they are known). Its points' rows then
    /// go to the reduced system without a group elimination; its step is
    /// zero and its sigmas are reported as zero. Its prior, if any, still
    /// adds its (constant) term to the cost. Default: no group is fixed.
    fn group_is_fixed(&self, k: usize) -> bool {
        let _ = k;
        false
    }

    /// The cache of point `i` before its first linearisation.
    fn initial_cache(&self, i: usize) -> Self::PointCache;

    /// Residual and Jacobians of point `i` at the given values of its blocks
    /// (the global one prepared, [`Problem::prepare_global`]), written into
    /// `out` (the solver reuses one linearisation for all the
    /// points it visits, so that nothing large is moved per point). Called
    /// from several threads at once (for different points).
    fn linearize(
        &self,
        i: usize,
        global: &Self::Global,
        group: &SVector<f64, C>,
        point: &SVector<f64, P>,
        cache: &mut Self::PointCache,
        out: &mut Linearization<C, P, R, Self::Jacobian>,
    ) -> Result<(), Self::Error>;

    /// [`Problem::linearize`] of the points `first..first + out.len()` (at
    /// most [`BATCH`], all of one group), their blocks and caches given in
    /// order. On failure: the first failing point and its error (the
    /// outputs are then unspecified). The default linearises the points one
    /// by one; a problem whose per-point work runs faster several points at
    /// a time (e.g. in SIMD lanes) does them together. The solver always
    /// linearises through this method, with its chunk's `workspace`.
    #[allow(clippy::too_many_arguments)]
    fn linearize_batch(
        &self,
        first: usize,
        global: &Self::Global,
        group: &SVector<f64, C>,
        points: &[SVector<f64, P>],
        caches: &mut [Self::PointCache],
        out: &mut [Linearization<C, P, R, Self::Jacobian>],
        workspace: &mut Self::Workspace,
    ) -> Result<(), (usize, Self::Error)> {
        let _ = workspace;
        for (j, (out, (point, cache))) in out.iter_mut().zip(points.iter().zip(caches)).enumerate()
        {
            let i = first + j;
            self.linearize(i, global, group, point, cache, out)
                .map_err(|e| (i, e))?;
        }
        Ok(())
    }

    /// Point `i`'s linearisation for back-substitution, which needs of
    /// `d_global` only its product with the global step `dg`: writes the
    /// linearisation into `out` (its `d_global` is not read afterwards: a
    /// problem need not write it) and returns `d_global · dg`. The default
    /// linearises fully; a problem can also update its point cache for the
    /// next iteration here.
    #[allow(clippy::too_many_arguments)]
    fn linearize_along(
        &self,
        i: usize,
        global: &Self::Global,
        group: &SVector<f64, C>,
        point: &SVector<f64, P>,
        cache: &mut Self::PointCache,
        dg: &DVector<f64>,
        out: &mut Linearization<C, P, R, Self::Jacobian>,
    ) -> Result<SVector<f64, R>, Self::Error> {
        self.linearize(i, global, group, point, cache, out)?;
        Ok(out.d_global.apply(dg))
    }

    /// [`Problem::linearize_along`] of the points `first..first +
    /// out.len()` as [`Problem::linearize_batch`] takes them; `d_global ·
    /// dg` of each into `steps`, and each point's anchor at the global
    /// block `g + dg`, to first order, into `anchors` (a problem with local
    /// rows; the default writes none).
    #[allow(clippy::too_many_arguments)]
    fn linearize_along_batch(
        &self,
        first: usize,
        global: &Self::Global,
        group: &SVector<f64, C>,
        points: &[SVector<f64, P>],
        caches: &mut [Self::PointCache],
        dg: &DVector<f64>,
        out: &mut [Linearization<C, P, R, Self::Jacobian>],
        steps: &mut [SVector<f64, R>],
        anchors: &mut [Self::Anchor],
        workspace: &mut Self::Workspace,
    ) -> Result<(), (usize, Self::Error)> {
        let _ = (workspace, anchors);
        let points = points.iter().zip(caches);
        for (j, ((out, step), (point, cache))) in out.iter_mut().zip(steps).zip(points).enumerate()
        {
            let i = first + j;
            *step = self
                .linearize_along(i, global, group, point, cache, dg, out)
                .map_err(|e| (i, e))?;
        }
        Ok(())
    }

    /// Point `i`'s rows at its group's block `group` and its own `point`,
    /// what they take of the global block held at `anchor`
    /// ([`Problem::Anchor`]), into `out`: the rows of local steps, which
    /// move a group's unknowns and its points' against a global block held
    /// fixed. Returns whether the problem has local rows (the default:
    /// none, and `out` is not written).
    fn local_rows(
        &self,
        i: usize,
        anchor: &Self::Anchor,
        group: &SVector<f64, C>,
        point: &SVector<f64, P>,
        out: &mut LocalRows<C, P, R>,
    ) -> Result<bool, Self::Error> {
        let _ = (i, anchor, group, point, out);
        Ok(false)
    }

    /// The global observations at the global block `global`: residual rows
    /// that depend on it only (e.g. distances between ball centres that
    /// live in the global block), whitened, and their Jacobian, written
    /// into `out` (given with 0 rows and `G` columns; resized as needed).
    /// Evaluated once per pass over the points. Default: none.
    fn global_observations(
        &self,
        global: &DVector<f64>,
        out: &mut GlobalObservations,
    ) -> Result<(), Self::Error> {
        let _ = (global, out);
        Ok(())
    }

    /// The loss of every point's rows (one observation per point, of
    /// [`point_degrees_of_freedom`] degrees) and of every global
    /// observation ([`Problem::global_observation_rows`]); priors are never
    /// weighted. Default: least squares.
    fn loss(&self) -> Loss {
        Loss::Squared
    }

    /// The global observation rows grouped into observations, which a
    /// robust loss weighs as wholes: the rows of each, in order, summing to
    /// the rows [`Problem::global_observations`] writes; an observation of
    /// `n` rows has `n` degrees of freedom. Read only with a robust loss.
    /// Default: every row an observation.
    fn global_observation_rows(&self) -> Option<Vec<usize>> {
        None
    }

    /// Prior on the global block (`G` values).
    fn global_prior(&self) -> Option<&GaussianPrior<Dyn>> {
        None
    }

    /// Prior on the block of group `k`.
    fn group_prior(&self, k: usize) -> Option<GaussianPrior<Const<C>>> {
        let _ = k;
        None
    }

    /// Prior on the block of point `i`.
    fn point_prior(&self, i: usize) -> Option<GaussianPrior<Const<P>>> {
        let _ = i;
        None
    }

    /// The number `K` of effects ([`crate::effects`]): common changes `t`
    /// of the entered data that move the whitened rows linearly,
    /// `e(t) = e + t c`, whose projections [`crate::redundancy`] computes
    /// with the rows' redundancy. Default: none.
    fn effects(&self) -> usize {
        0
    }

    /// `c = ∂r_i/∂t` of point `i`'s data rows for each effect, at its
    /// point block `point` where it was linearised as `lin`, into `out`
    /// (`K` vectors, zero on entry). Default: the effects leave the
    /// points' rows alone.
    fn point_effects(
        &self,
        i: usize,
        lin: &Linearization<C, P, R, Self::Jacobian>,
        point: &SVector<f64, P>,
        out: &mut [SVector<f64, R>],
    ) {
        let _ = (i, lin, point, out);
    }

    /// `∂m/∂t` of the mean of group `k`'s prior for each effect, into
    /// `out` (`K` vectors, zero on entry): its rows `U(c − m)` move by
    /// `−U ∂m/∂t`. Default: the effects leave the group priors alone.
    fn group_prior_effects(&self, k: usize, out: &mut [SVector<f64, C>]) {
        let _ = (k, out);
    }

    /// `∂m_g/∂t` of the global prior's mean (`G × K`) and `c` of the
    /// global observation rows (`m × K`) for each effect, into the two
    /// matrices (zero on entry, of those shapes). Default: the effects
    /// leave them alone.
    fn global_effects(&self, prior_mean: &mut DMatrix<f64>, observations: &mut DMatrix<f64>) {
        let _ = (prior_mean, observations);
    }
}

/// Values of all unknowns (and of the fixed groups' blocks).
#[derive(Clone, Debug, PartialEq)]
pub struct State<const C: usize, const P: usize> {
    /// The global block (`G` values).
    pub global: DVector<f64>,
    /// One block per group.
    pub groups: Vec<SVector<f64, C>>,
    /// One block per point.
    pub points: Vec<SVector<f64, P>>,
}

impl<const C: usize, const P: usize> State<C, P> {
    /// Whether every value is finite.
    pub fn is_finite(&self) -> bool {
        self.global.iter().all(|v| v.is_finite())
            && self.groups.iter().all(|c| c.iter().all(|v| v.is_finite()))
            && self.points.iter().all(|p| p.iter().all(|v| v.is_finite()))
    }

    /// Total number of values: the number of unknowns when no group is
    /// fixed.
    pub fn n_unknowns(&self) -> usize {
        self.global.len() + C * self.groups.len() + P * self.points.len()
    }
}
