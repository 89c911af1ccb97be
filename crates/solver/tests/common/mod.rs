//! Synthetic three-level test problems: spheres of known radius with unknown
//! centres (groups, C = 3), touched at points measured through a smooth
//! nonlinear distortion with 8 unknown parameters (the global block).
//!
//! * [`Touches`]: P = 2 (the touch's two angles on the sphere), R = 3 (the
//!   measured point minus the distorted model point).
//! * [`Distances`]: P = 0, R = 1 (distance of the corrected measurement to
//!   the centre, minus the radius).
//!
//! Optionally ([`couple`]) the centres of some groups live in the global
//! block instead, after the 8 parameters (those groups are fixed), measured
//! against each other by distances (the global observations); and some
//! other groups are held at their values (fixed too).

use std::fmt;
use std::ops::Range;

use nalgebra::{
    DMatrix, DVector, Dyn, Matrix3, OMatrix, RowVector3, SMatrix, SVector, U1, U2, U3, Vector2,
    Vector3,
};
use parcal_solver::{
    GaussianPrior, GlobalObservations, Linearization, LocalRows, Loss, Problem, Solution, State,
};
use rand::rngs::StdRng;
use rand::{RngExt, SeedableRng};
use rand_distr::StandardNormal;

pub const G: usize = 8;

/// Random test inputs: rand's `StdRng`, seeded.
pub struct Rng(StdRng);

impl Rng {
    pub fn new(seed: u64) -> Self {
        Self(StdRng::seed_from_u64(seed))
    }
    /// Uniform in [0, 1).
    pub fn uniform(&mut self) -> f64 {
        self.0.random()
    }
    pub fn range(&mut self, lo: f64, hi: f64) -> f64 {
        self.0.random_range(lo..hi)
    }
    pub fn normal(&mut self) -> f64 {
        self.0.sample(StandardNormal)
    }
    pub fn vector<const N: usize>(&mut self, scale: f64) -> SVector<f64, N> {
        SVector::from_fn(|_, _| scale * self.normal())
    }
    /// A random symmetric positive definite information matrix.
    pub fn information<const N: usize>(&mut self, scale: f64) -> SMatrix<f64, N, N> {
        let a = SMatrix::<f64, N, N>::from_fn(|_, _| self.normal());
        scale * (a * a.transpose() + SMatrix::identity() * 0.5)
    }
}

/// The linear part `E(g)` of the distortion `D(y) = (I + E) y + g6 |y|² y +
/// g7 (y_x² + y_y²) e_z`.
fn linear_part(g: &SVector<f64, G>) -> Matrix3<f64> {
    Matrix3::new(g[0], g[3], 0.0, 0.0, g[1], g[4], g[5], 0.0, g[2])
}

/// `D(y; g)`, `∂D/∂y` and `∂D/∂g`; parameter `unseen` (if any) is ignored by
/// the model.
pub fn distort(
    y: &Vector3<f64>,
    g: &SVector<f64, G>,
    unseen: Option<usize>,
) -> (Vector3<f64>, Matrix3<f64>, SMatrix<f64, 3, G>) {
    let mut g = *g;
    if let Some(j) = unseen {
        g[j] = 0.0;
    }
    let n2 = y.norm_squared();
    let bowl = y.x * y.x + y.y * y.y;
    let d = y + linear_part(&g) * y + g[6] * n2 * y + Vector3::new(0.0, 0.0, g[7] * bowl);
    let mut dy = Matrix3::identity()
        + linear_part(&g)
        + g[6] * (n2 * Matrix3::identity() + 2.0 * y * y.transpose());
    dy[(2, 0)] += 2.0 * g[7] * y.x;
    dy[(2, 1)] += 2.0 * g[7] * y.y;
    let mut dg = SMatrix::<f64, 3, G>::zeros();
    dg[(0, 0)] = y.x;
    dg[(1, 1)] = y.y;
    dg[(2, 2)] = y.z;
    dg[(0, 3)] = y.y;
    dg[(1, 4)] = y.z;
    dg[(2, 5)] = y.x;
    dg.set_column(6, &(n2 * y));
    dg[(2, 7)] = bowl;
    if let Some(j) = unseen {
        dg.set_column(j, &Vector3::zeros());
    }
    (d, dy, dg)
}

/// Unit vector at angles `(θ, φ)` and its derivatives.
pub fn direction(p: &Vector2<f64>) -> (Vector3<f64>, SMatrix<f64, 3, 2>) {
    let (st, ct) = p[0].sin_cos();
    let (sp, cp) = p[1].sin_cos();
    let u = Vector3::new(ct * cp, st * cp, sp);
    let du = SMatrix::<f64, 3, 2>::new(-st * cp, -ct * sp, ct * cp, -st * sp, 0.0, cp);
    (u, du)
}

/// An injected failure: `linearize` of `point` fails from its `call`-th call
/// on (counted by the point's cache, starting at 0).
#[derive(Clone, Copy, Debug)]
pub struct Fail {
    pub point: usize,
    pub call: u32,
}

#[derive(Debug)]
pub struct TestError(pub String);

impl fmt::Display for TestError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for TestError {}

/// A distance measured between two centres of the global block.
#[derive(Clone, Copy, Debug)]
pub struct Distance {
    /// Their places in [`Data::global_centres`].
    pub between: (usize, usize),
    pub measured: f64,
    pub sigma: f64,
}

/// Data and options shared by both models.
#[derive(Clone, Debug)]
pub struct Data {
    pub radius: f64,
    pub sigma: f64,
    pub measurements: Vec<Vector3<f64>>,
    pub starts: Vec<usize>,
    pub global_prior: Option<GaussianPrior<Dyn>>,
    pub group_priors: Option<Vec<GaussianPrior<U3>>>,
    pub point_priors: Option<Vec<GaussianPrior<U2>>>,
    pub fail: Option<Fail>,
    pub unseen: Option<usize>,
    /// The groups whose centres are global unknowns `G + 3j..G + 3j + 3`
    /// (`j`: their place here); these groups are fixed.
    pub global_centres: Vec<usize>,
    /// Groups held at their values (fixed).
    pub held: Vec<usize>,
    /// The global observations.
    pub distances: Vec<Distance>,
    /// A fault injected into [`Problem::global_observations`].
    pub observation_fault: Option<ObservationFault>,
    /// The loss of the points and global observations.
    pub loss: Loss,
    /// The rows of each global observation (`None`: one each).
    pub observation_rows: Option<Vec<usize>>,
    /// The effects ([`Problem::effects`]), if any.
    pub shifts: Option<Shifts>,
}

/// Two effects of a [`Touches`] case: the radius (`∂r/∂ρ = d_group u(θ)`,
/// the points' rows), and one that moves the group priors' means, the
/// global prior's and the global observations by the vectors here.
#[derive(Clone, Debug)]
pub struct Shifts {
    pub groups: Vec<Vector3<f64>>,
    pub global: DVector<f64>,
    pub observations: DVector<f64>,
}

impl Shifts {
    /// Pseudo-random shifts for `data` as it is.
    pub fn new(data: &Data, seed: u64) -> Self {
        let mut rng = Rng::new(seed ^ 0xEFFEC7);
        Self {
            groups: (0..data.n_groups()).map(|_| rng.vector::<3>(1.0)).collect(),
            global: DVector::from_fn(data.global_size(), |_, _| rng.normal()),
            observations: DVector::from_fn(data.distances.len(), |_, _| rng.normal()),
        }
    }
}

/// How [`Problem::global_observations`] goes wrong.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ObservationFault {
    /// It returns an error.
    Error,
    /// Its Jacobian has one column too many.
    WrongShape,
}

impl Data {
    pub fn n_groups(&self) -> usize {
        self.starts.len() - 1
    }
    fn range(&self, k: usize) -> Range<usize> {
        self.starts[k]..self.starts[k + 1]
    }
    pub fn global_size(&self) -> usize {
        G + 3 * self.global_centres.len()
    }
    fn is_fixed(&self, k: usize) -> bool {
        self.global_centres.contains(&k) || self.held.contains(&k)
    }
    /// The global column of group `k`'s centre, if it lives there.
    fn centre_column(&self, k: usize) -> Option<usize> {
        let j = self.global_centres.iter().position(|&g| g == k)?;
        Some(G + 3 * j)
    }
    /// The group of point `i`.
    fn group_of(&self, i: usize) -> usize {
        self.starts.partition_point(|&s| s <= i) - 1
    }
    /// Point `i`'s centre: from the global block if it lives there.
    fn centre(&self, i: usize, global: &DVector<f64>, group: &SVector<f64, 3>) -> Vector3<f64> {
        match self.centre_column(self.group_of(i)) {
            Some(col) => global.fixed_rows::<3>(col).into_owned(),
            None => *group,
        }
    }
    /// Writes `−s ∂D/∂g` and (for a centre of the global block) `d_centre`
    /// into a point's global Jacobian.
    fn global_jacobian<const R: usize>(
        &self,
        i: usize,
        d_params: &SMatrix<f64, R, G>,
        d_centre: &SMatrix<f64, R, 3>,
        out: &mut OMatrix<f64, nalgebra::Const<R>, Dyn>,
    ) {
        out.fill(0.0);
        out.fixed_columns_mut::<G>(0).copy_from(d_params);
        if let Some(col) = self.centre_column(self.group_of(i)) {
            out.fixed_columns_mut::<3>(col).copy_from(d_centre);
        }
    }
    /// The distances' whitened residuals and Jacobian.
    fn observations(
        &self,
        global: &DVector<f64>,
        out: &mut GlobalObservations,
    ) -> Result<(), TestError> {
        let mut columns = global.len();
        match self.observation_fault {
            Some(ObservationFault::Error) => {
                return Err(TestError("injected failure of the distances".into()));
            }
            Some(ObservationFault::WrongShape) => columns += 1,
            None => {}
        }
        *out = GlobalObservations::zeros(self.distances.len(), columns);
        for (r, d) in self.distances.iter().enumerate() {
            let (a, b) = (G + 3 * d.between.0, G + 3 * d.between.1);
            let e: Vector3<f64> = global.fixed_rows::<3>(a) - global.fixed_rows::<3>(b);
            let n = e.norm();
            out.residual[r] = (n - d.measured) / d.sigma;
            let u: RowVector3<f64> = e.transpose() / (n * d.sigma);
            out.jacobian.fixed_view_mut::<1, 3>(r, a).copy_from(&u);
            out.jacobian.fixed_view_mut::<1, 3>(r, b).copy_from(&(-u));
        }
        Ok(())
    }
    fn check_fail(&self, i: usize, calls: &mut u32) -> Result<(), TestError> {
        let call = *calls;
        *calls += 1;
        match self.fail {
            Some(f) if f.point == i && call >= f.call => Err(TestError(format!(
                "injected failure at point {i}, call {call}"
            ))),
            _ => Ok(()),
        }
    }
}

/// P = 2, R = 3: `r = (m − D(c + ρ u(θ, φ); g)) / σ`.
pub struct Touches(pub Data);

impl Touches {
    /// Point `i`'s rows at the global block `global`, into `out`.
    fn rows(
        &self,
        i: usize,
        global: &DVector<f64>,
        group: &SVector<f64, 3>,
        point: &SVector<f64, 2>,
        out: &mut Linearization<3, 2, 3>,
    ) {
        let (u, du) = direction(point);
        let y = self.0.centre(i, global, group) + self.0.radius * u;
        let (d, dy, dg) = distort(&y, &global.fixed_rows::<G>(0).into_owned(), self.0.unseen);
        let s = 1.0 / self.0.sigma;
        out.residual = s * (self.0.measurements[i] - d);
        self.0
            .global_jacobian(i, &(-s * dg), &(-s * dy), &mut out.d_global);
        out.d_group = -s * dy;
        out.d_point = -s * self.0.radius * dy * du;
    }
}

impl Problem<3, 2, 3> for Touches {
    type PointCache = u32;
    type Workspace = ();
    /// The global block after the step itself: the local rows are the
    /// rows there, exactly.
    type Anchor = DVector<f64>;
    type Error = TestError;
    type Jacobian = OMatrix<f64, U3, Dyn>;
    type Global = DVector<f64>;
    fn global_size(&self) -> usize {
        self.0.global_size()
    }
    fn prepare_global(&self, global: &DVector<f64>) -> Self::Global {
        global.clone()
    }
    fn n_groups(&self) -> usize {
        self.0.n_groups()
    }
    fn group_points(&self, k: usize) -> Range<usize> {
        self.0.range(k)
    }
    fn group_is_fixed(&self, k: usize) -> bool {
        self.0.is_fixed(k)
    }
    fn initial_cache(&self, _i: usize) -> u32 {
        0
    }
    fn linearize(
        &self,
        i: usize,
        global: &DVector<f64>,
        group: &SVector<f64, 3>,
        point: &SVector<f64, 2>,
        cache: &mut u32,
        out: &mut Linearization<3, 2, 3>,
    ) -> Result<(), TestError> {
        self.0.check_fail(i, cache)?;
        self.rows(i, global, group, point, out);
        Ok(())
    }
    #[allow(clippy::too_many_arguments)]
    fn linearize_along_batch(
        &self,
        first: usize,
        global: &DVector<f64>,
        group: &SVector<f64, 3>,
        points: &[SVector<f64, 2>],
        caches: &mut [u32],
        dg: &DVector<f64>,
        out: &mut [Linearization<3, 2, 3>],
        steps: &mut [SVector<f64, 3>],
        anchors: &mut [DVector<f64>],
        _workspace: &mut (),
    ) -> Result<(), (usize, TestError)> {
        let each = out.iter_mut().zip(steps).zip(anchors);
        for (j, ((out, step), anchor)) in each.enumerate() {
            let i = first + j;
            *step = self
                .linearize_along(i, global, group, &points[j], &mut caches[j], dg, out)
                .map_err(|e| (i, e))?;
            *anchor = global + dg;
        }
        Ok(())
    }
    fn local_rows(
        &self,
        i: usize,
        anchor: &DVector<f64>,
        group: &SVector<f64, 3>,
        point: &SVector<f64, 2>,
        out: &mut LocalRows<3, 2, 3>,
    ) -> Result<bool, TestError> {
        let mut lin = Linearization::zeros(anchor.len());
        self.rows(i, anchor, group, point, &mut lin);
        *out = LocalRows {
            residual: lin.residual,
            d_group: lin.d_group,
            d_point: lin.d_point,
        };
        Ok(true)
    }
    fn global_observations(
        &self,
        global: &DVector<f64>,
        out: &mut GlobalObservations,
    ) -> Result<(), TestError> {
        self.0.observations(global, out)
    }
    fn global_prior(&self) -> Option<&GaussianPrior<Dyn>> {
        self.0.global_prior.as_ref()
    }
    fn group_prior(&self, k: usize) -> Option<GaussianPrior<U3>> {
        self.0.group_priors.as_ref().map(|p| p[k].clone())
    }
    fn point_prior(&self, i: usize) -> Option<GaussianPrior<U2>> {
        self.0.point_priors.as_ref().map(|p| p[i].clone())
    }
    fn loss(&self) -> Loss {
        self.0.loss
    }
    fn global_observation_rows(&self) -> Option<Vec<usize>> {
        self.0.observation_rows.clone()
    }
    fn effects(&self) -> usize {
        if self.0.shifts.is_some() { 2 } else { 0 }
    }
    fn point_effects(
        &self,
        _i: usize,
        lin: &Linearization<3, 2, 3>,
        point: &SVector<f64, 2>,
        out: &mut [SVector<f64, 3>],
    ) {
        out[0] = lin.d_group * direction(point).0;
    }
    fn group_prior_effects(&self, k: usize, out: &mut [SVector<f64, 3>]) {
        if let Some(shifts) = &self.0.shifts {
            out[1] = shifts.groups[k];
        }
    }
    fn global_effects(&self, prior_mean: &mut DMatrix<f64>, observations: &mut DMatrix<f64>) {
        if let Some(shifts) = &self.0.shifts {
            prior_mean.column_mut(1).copy_from(&shifts.global);
            observations.column_mut(1).copy_from(&shifts.observations);
        }
    }
}

/// P = 0, R = 1: `r = (|D(m; g) − c| − ρ) / σ` (the distortion used as a
/// correction of the measurement).
pub struct Distances(pub Data);

impl Problem<3, 0, 1> for Distances {
    type PointCache = u32;
    type Workspace = ();
    type Anchor = ();
    type Error = TestError;
    type Jacobian = OMatrix<f64, U1, Dyn>;
    type Global = DVector<f64>;
    fn global_size(&self) -> usize {
        self.0.global_size()
    }
    fn prepare_global(&self, global: &DVector<f64>) -> Self::Global {
        global.clone()
    }
    fn n_groups(&self) -> usize {
        self.0.n_groups()
    }
    fn group_points(&self, k: usize) -> Range<usize> {
        self.0.range(k)
    }
    fn group_is_fixed(&self, k: usize) -> bool {
        self.0.is_fixed(k)
    }
    fn initial_cache(&self, _i: usize) -> u32 {
        0
    }
    fn linearize(
        &self,
        i: usize,
        global: &DVector<f64>,
        group: &SVector<f64, 3>,
        _point: &SVector<f64, 0>,
        cache: &mut u32,
        out: &mut Linearization<3, 0, 1>,
    ) -> Result<(), TestError> {
        self.0.check_fail(i, cache)?;
        let params = global.fixed_rows::<G>(0).into_owned();
        let (y, _, dg) = distort(&self.0.measurements[i], &params, self.0.unseen);
        let e = y - self.0.centre(i, global, group);
        let n = e.norm();
        let s = 1.0 / self.0.sigma;
        let unit = e / n;
        out.residual = SVector::<f64, 1>::new(s * (n - self.0.radius));
        let d_centre = -s * unit.transpose();
        self.0.global_jacobian(
            i,
            &(s * unit.transpose() * dg),
            &d_centre,
            &mut out.d_global,
        );
        out.d_group = d_centre;
        Ok(())
    }
    fn global_observations(
        &self,
        global: &DVector<f64>,
        out: &mut GlobalObservations,
    ) -> Result<(), TestError> {
        self.0.observations(global, out)
    }
    fn global_prior(&self) -> Option<&GaussianPrior<Dyn>> {
        self.0.global_prior.as_ref()
    }
    fn group_prior(&self, k: usize) -> Option<GaussianPrior<U3>> {
        self.0.group_priors.as_ref().map(|p| p[k].clone())
    }
    fn loss(&self) -> Loss {
        self.0.loss
    }
    fn global_observation_rows(&self) -> Option<Vec<usize>> {
        self.0.observation_rows.clone()
    }
}

/// How to generate a test case.
#[derive(Clone, Copy, Debug)]
pub struct Spec {
    pub seed: u64,
    pub n_groups: usize,
    pub points_per_group: usize,
    /// Measurement noise (also the whitening σ); 0 for exact data.
    pub noise: f64,
    pub priors: bool,
}

impl Default for Spec {
    fn default() -> Self {
        Self {
            seed: 1,
            n_groups: 6,
            points_per_group: 8,
            noise: 1e-3,
            priors: false,
        }
    }
}

pub const RADIUS: f64 = 0.2;

pub fn true_global() -> SVector<f64, G> {
    SVector::from_column_slice(&[0.02, -0.015, 0.01, 0.012, -0.008, 0.006, 0.03, -0.02])
}

/// Touch angles spread over the sphere (away from the poles).
fn touch_angles(rng: &mut Rng, j: usize, n: usize) -> Vector2<f64> {
    let theta = 2.0 * std::f64::consts::PI * (j as f64 + 0.3 * rng.uniform()) / n as f64;
    let phi = rng.range(-1.0, 1.0);
    Vector2::new(theta, phi)
}

fn centres(rng: &mut Rng, n_groups: usize) -> Vec<SVector<f64, 3>> {
    (0..n_groups)
        .map(|_| {
            Vector3::new(
                rng.range(-1.0, 1.0),
                rng.range(-1.0, 1.0),
                rng.range(-1.0, 1.0),
            )
        })
        .collect()
}

fn priors(rng: &mut Rng, spec: &Spec, truth: &State<3, 2>, data: &mut Data, with_points: bool) {
    if !spec.priors {
        return;
    }
    let mean = truth.global.fixed_rows::<G>(0) + rng.vector::<G>(0.01);
    let information = rng.information::<G>(1e3);
    data.global_prior = Some(GaussianPrior::new(
        DVector::from_column_slice(mean.as_slice()),
        DMatrix::from_column_slice(G, G, information.as_slice()),
    ));
    data.group_priors = Some(
        truth
            .groups
            .iter()
            .map(|c| GaussianPrior::new(c + rng.vector::<3>(0.01), rng.information::<3>(1e2)))
            .collect(),
    );
    if with_points {
        data.point_priors = Some(
            truth
                .points
                .iter()
                .map(|p| GaussianPrior::new(p + rng.vector::<2>(0.05), rng.information::<2>(10.0)))
                .collect(),
        );
    }
}

fn empty_data(spec: &Spec) -> Data {
    Data {
        radius: RADIUS,
        sigma: if spec.noise > 0.0 { spec.noise } else { 1e-3 },
        measurements: Vec::new(),
        starts: (0..=spec.n_groups)
            .map(|k| k * spec.points_per_group)
            .collect(),
        global_prior: None,
        group_priors: None,
        point_priors: None,
        fail: None,
        unseen: None,
        global_centres: Vec::new(),
        held: Vec::new(),
        distances: Vec::new(),
        observation_fault: None,
        loss: Loss::Squared,
        observation_rows: None,
        shifts: None,
    }
}

fn global_block(g: &SVector<f64, G>) -> DVector<f64> {
    DVector::from_column_slice(g.as_slice())
}

/// A [`Touches`] case and its truth.
pub fn touches(spec: Spec) -> (Touches, State<3, 2>) {
    let mut rng = Rng::new(spec.seed);
    let g = true_global();
    let groups = centres(&mut rng, spec.n_groups);
    let mut data = empty_data(&spec);
    let mut points = Vec::new();
    for c in &groups {
        for j in 0..spec.points_per_group {
            let p = touch_angles(&mut rng, j, spec.points_per_group);
            let y = c + RADIUS * direction(&p).0;
            let m = distort(&y, &g, None).0 + rng.vector::<3>(spec.noise);
            data.measurements.push(m);
            points.push(p);
        }
    }
    let truth = State {
        global: global_block(&g),
        groups,
        points,
    };
    priors(&mut rng, &spec, &truth, &mut data, true);
    (Touches(data), truth)
}

/// A [`Distances`] case and its truth.
pub fn distances(spec: Spec) -> (Distances, State<3, 0>) {
    let mut rng = Rng::new(spec.seed);
    let g = true_global();
    let groups = centres(&mut rng, spec.n_groups);
    let mut data = empty_data(&spec);
    for c in &groups {
        for j in 0..spec.points_per_group {
            let p = touch_angles(&mut rng, j, spec.points_per_group);
            let y = c + RADIUS * direction(&p).0;
            // Invert the correction D(m) = y by Newton.
            let mut m = y;
            for _ in 0..30 {
                let (d, dy, _) = distort(&m, &g, None);
                m -= dy.lu().solve(&(d - y)).expect("invertible distortion");
            }
            let noise = rng.normal() * spec.noise;
            data.measurements.push(m + noise * (y - c).normalize());
        }
    }
    let truth = State {
        global: global_block(&g),
        groups,
        points: vec![SVector::zeros(); spec.n_groups * spec.points_per_group],
    };
    let touches_truth = State {
        global: truth.global.clone(),
        groups: truth.groups.clone(),
        points: vec![Vector2::zeros(); truth.points.len()],
    };
    priors(&mut rng, &spec, &touches_truth, &mut data, false);
    (Distances(data), truth)
}

/// Moves the centres of the groups `global_centres` into the global block
/// (after the 8 parameters; those groups become fixed), measures the
/// distance between every two of them (noise and whitening σ
/// `distance_sigma`), holds the groups `held` at their values, and extends
/// the global prior, if any, to the moved centres. Returns the truth in the
/// new layout (a moved group's own block keeps its value, unused).
pub fn couple<const P: usize>(
    data: &mut Data,
    truth: &State<3, P>,
    global_centres: &[usize],
    held: &[usize],
    distance_sigma: f64,
    seed: u64,
) -> State<3, P> {
    let mut rng = Rng::new(seed ^ 0x5EED);
    let mut global: Vec<f64> = truth.global.iter().copied().collect();
    for &k in global_centres {
        global.extend(truth.groups[k].iter());
    }
    let n = global.len();
    let global = DVector::from_vec(global);
    data.global_centres = global_centres.to_vec();
    data.held = held.to_vec();
    data.distances.clear();
    for a in 0..global_centres.len() {
        for b in a + 1..global_centres.len() {
            let e = truth.groups[global_centres[a]] - truth.groups[global_centres[b]];
            data.distances.push(Distance {
                between: (a, b),
                measured: e.norm() + distance_sigma * rng.normal(),
                sigma: distance_sigma,
            });
        }
    }
    if let Some(prior) = &mut data.global_prior {
        let old = prior.mean.len();
        let mut mean = global.clone();
        mean.rows_mut(0, old).copy_from(&prior.mean);
        let mut information = DMatrix::zeros(n, n);
        information
            .view_mut((0, 0), (old, old))
            .copy_from(&prior.information);
        for j in (old..n).step_by(3) {
            let noise = rng.vector::<3>(0.01);
            for t in 0..3 {
                mean[j + t] += noise[t];
            }
            information
                .view_mut((j, j), (3, 3))
                .copy_from(&rng.information::<3>(1e2));
        }
        *prior = GaussianPrior::new(mean, information);
    }
    State {
        global,
        groups: truth.groups.clone(),
        points: truth.points.clone(),
    }
}

/// `truth` moved by a deterministic perturbation: global by `dg` (per
/// component, random sign), centres by `dc`, angles by `dp`.
pub fn perturb<const P: usize>(
    truth: &State<3, P>,
    seed: u64,
    dg: f64,
    dc: f64,
    dp: f64,
) -> State<3, P> {
    let mut rng = Rng::new(seed ^ 0xABCDEF);
    State {
        global: truth.global.map(|x| x + dg * rng.normal()),
        groups: truth
            .groups
            .iter()
            .map(|c| c + rng.vector::<3>(dc))
            .collect(),
        points: truth
            .points
            .iter()
            .map(|p| p + rng.vector::<P>(dp))
            .collect(),
    }
}

/// Largest relative difference of two vectors, relative to the larger norm.
pub fn rel_diff(a: &[f64], b: &[f64]) -> f64 {
    let scale = a
        .iter()
        .chain(b)
        .map(|x| x.abs())
        .fold(0.0, f64::max)
        .max(1e-300);
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max)
        / scale
}

/// All values of a state, flattened (global, groups, points).
pub fn flatten<const C: usize, const P: usize>(s: &State<C, P>) -> Vec<f64> {
    let mut v: Vec<f64> = s.global.iter().copied().collect();
    v.extend(s.groups.iter().flat_map(|c| c.iter().copied()));
    v.extend(s.points.iter().flat_map(|p| p.iter().copied()));
    v
}

/// `f` on a pool of `threads` threads.
pub fn in_pool<T: Send>(threads: usize, f: impl FnOnce() -> T + Send) -> T {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap()
        .install(f)
}

/// The largest difference between two solutions' global unknowns and
/// group blocks, in the sigmas of `reference` (its covariance and group
/// sigmas).
pub fn sigmas_apart<const P: usize>(reference: &Solution<3, P>, other: &Solution<3, P>) -> f64 {
    let covariance = reference.covariance.as_ref().expect("covariance");
    let mut apart = 0.0_f64;
    for (j, (a, b)) in reference
        .state
        .global
        .iter()
        .zip(&other.state.global)
        .enumerate()
    {
        apart = apart.max((a - b).abs() / covariance[(j, j)].sqrt());
    }
    let sigmas = reference.group_sigmas.as_ref().expect("group sigmas");
    let groups = reference.state.groups.iter().zip(&other.state.groups);
    for ((a, b), s) in groups.zip(sigmas) {
        // A fixed group's sigmas are zero, and so is its difference.
        let z = (a - b).zip_map(s, |d, s| if d == 0.0 { 0.0 } else { d.abs() / s });
        apart = apart.max(z.amax());
    }
    apart
}
