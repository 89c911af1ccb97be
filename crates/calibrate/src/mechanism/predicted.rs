//! Each held-out observation predicted by a calibration: its residual
//! rows `r` (observation's units), their own noise covariance `D_i`, and
//! their derivative `G_i = dr/dθ` with respect to the calibration's
//! global block `θ = (p, h)` (the parameters, then the trigger height),
//! through the [`Mechanism`] trait's analytic derivatives.
//!
//! - A probe height, a part distance, a measured point: the observation
//!   kind's own rows ([`parcal_observe::mechanism`]) at `θ̂` and the
//!   controller's configured parameters `p_c`, un-whitened (`r = σ r_w`,
//!   `G = σ dr_w/dθ`, `D = σ²`).
//! - A point sample whose position `m` was measured: the position its
//!   readings `q` imply, `x̂ = f(p̂, q)`, against `m` (3 rows, mm):
//!
//!   ```text
//!   r = x̂ − m,   G = dx/dp|_q = −G_x⁺ G_p,   D = Σ_m + σ_q² (G_xᵀ G_x)⁻¹,
//!   ```
//!
//!   `x̂` the forward kinematics: for more actuators than coordinates the
//!   maximum-likelihood pose of readings of equal noise `σ_q` (least
//!   squares in the readings, `parcal_kinematics::pose_fit`), `G_x⁺ =
//!   (G_xᵀ G_x)⁻¹ G_xᵀ`; for as many actuators as coordinates, the exact
//!   pose and `−G_x⁻¹ G_p`.
//! - A point sample at an unknown pose: its pose is its own unknown, fitted
//!   to its readings; with `A` actuators, `A − 3` combinations of the
//!   readings remain, what no pose change can absorb (the local unknown
//!   projected out, below): `r = g(p̂, x̂) − q`, `dr/dx = G_x`,
//!   `dr/dp = G_p`, `Σ = σ_q² I`, so `D = σ_q² I`. A delta's (`A = 3`)
//!   has no row: its readings only locate their own pose.
//! - A tracker's points: its frame is its own unknown (placed anew),
//!   fitted to its `K` points, which give `3K − 6` rows together (less
//!   its actuators' offsets when re-homed, its unknowns too), one
//!   observation named by the tracker ([`HeldOut::Tracker`]):
//!   `c = F̂(x_k) − P_k` ([`TrackerPoint`]), noise its covariance `W_k`.
//!   With poses, the body frame they see is its unknown too (mounted
//!   anew): `K` points and `J` poses of `A` actuators give `3K + AJ − 12`
//!   rows, located by Gauss-Newton on the whitened rows before the
//!   projection ([`tracker_unit`] for their unit).
//! - The touches of a ball: its centre `c` is its own unknown, fitted to
//!   its `K` touches, which give `K − 3` rows together, one observation
//!   named by the ball ([`HeldOut::Ball`]; a ball touched 4 times gives
//!   one row). The tool points the touches reach,
//!   `x_k = f(p̂, g(p_c, x_c,k))` ([`BallTouch`]), locate its centre `ĉ`,
//!   the best fit of the sphere of its calibrated radius `ρ` through them
//!   (as the calibration starts it, [`ball_centre`]), and
//!
//!   ```text
//!   r_k = |x_k − ĉ| − ρ,   dr_k/dc = −u_kᵀ,   dr_k/dp = u_kᵀ dx_k/dp|_q,
//!   u_k = (x_k − ĉ) / |x_k − ĉ|.
//!   ```
//!
//!   To first order `r = J_c δc + G_p δθ + e + δρ 1`, with `δc` the
//!   centre's error, `e` the touches' errors along their normals
//!   (`Cov(e) = diag(σ_k²)`) and `δρ` the error of the ball's calibrated
//!   radius (`σ_ρ` in `balls.csv`, common to all its touches), so that
//!
//!   ```text
//!   Σ = diag(σ_k²) + σ_ρ² 1 1ᵀ,
//!   D = N_⊥ᵀ Σ N_⊥ = σ_t² I + σ_ρ² (N_⊥ᵀ 1)(N_⊥ᵀ 1)ᵀ   (every σ_k = σ_t):
//!   ```
//!
//!   an uncertain radius adds an error common to the ball's rows, nearly
//!   none when a change of radius is nearly a shift of the centre
//!   (touches on a small cap: `1` nearly in the span of `J_c`).
//!
//! Projecting out a local unknown `u` of three coordinates (a pose, a
//! centre) from `m` residuals `r` with `dr/du = J` (rank 3), `dr/dp = G_p`
//! and noise covariance `Σ`: `N_⊥` is an orthonormal basis of the left
//! nullspace of `J` (`N_⊥ᵀ J = 0`), the last `m − 3` columns of `Q` of
//! `J = QR` (Householder: smooth in `J`), and
//!
//! ```text
//! r' = N_⊥ᵀ r,   G = N_⊥ᵀ G_p,   D = N_⊥ᵀ Σ N_⊥:
//! ```
//!
//! no error of `u` moves `r'` to first order, so that `r'` does not
//! depend on how `u` was fitted, nor `G` on how the fit moves with `θ`
//! (`dr'/dθ = N_⊥ᵀ (G_p + J du/dθ) = N_⊥ᵀ G_p`).
//!
//! With reference observations `N` (`parcal validate --reference N`),
//! each ball's centre is located by its first `N` touches alone, each
//! tracker's frame (and the body its poses see) by its first `N` points
//! and poses, and the others are predicted from them: `r' = r_o − J_o K
//! r_r`, `K` the local unknowns' weighted fit on the reference rows, each
//! row named by the observation it predicts, the fit's error in their
//! noise ([`predict_from_reference`]). A sample's pose is located by its
//! own readings: reference observations are refused beside samples.

use nalgebra::{DMatrix, DVector, Isometry3, Vector3};
use parcal_kinematics::mechanism::{Mechanism, MechanismError, tool_point_reading_jacobian};
use parcal_observe::mechanism::{BodyFrame, PointSample, Rows, TrackerFrame, TrackerPoint};
use parcal_observe::{FrameCorrection, PointBlock};

#[cfg(doc)]
use parcal_observe::mechanism::BallTouch;

use super::data::Observations;
use super::error::MechanismCalibrationError;
use super::observation::{HeldOut, ObservationKind, ObservationRef};
use super::touched_ball::{BallFit, ball_centre};
use super::trackers::{Seen, locate_frame, points_of, poses_of, reach};
use super::warm_start::WarmStart;

/// The most touches of one held-out ball: its rows' noise covariance is
/// dense, `(K − 3)²` numbers factored in `O(K³)`.
pub const MAX_HELD_OUT_TOUCHES_PER_BALL: usize = 1_000;

/// The predicted rows of one held-out observation, or of one ball's
/// touches (module doc).
#[derive(Debug, Clone, PartialEq)]
pub struct PredictedRows {
    /// What they are of.
    pub observation: HeldOut,
    /// `r`, its residual rows in the observation's units.
    pub residuals: DVector<f64>,
    /// `D_i`, their own noise covariance.
    pub noise: DMatrix<f64>,
    /// `G_i = dr/dθ` (rows × the global block).
    pub d_global: DMatrix<f64>,
    /// The observation each row predicts alone and its row there, when
    /// each row does (rows predicted from reference observations,
    /// [`predict_from_reference`]); empty when a row combines several (a
    /// projection) or is one of an observation's own rows.
    pub row_observations: Vec<(ObservationRef, usize)>,
}

/// Every observation of `observations` (validated) predicted at the
/// global block `global` (`p̂` then, with probes, `ĥ`) with the
/// controller's `configured` parameters (module doc), in the order of the
/// kinds, each kind's in its order, the touches ball by ball; samples at
/// an unknown pose of a mechanism of 3 actuators give none. An error
/// names a ball of more than [`MAX_HELD_OUT_TOUCHES_PER_BALL`] touches
/// before any work.
pub fn predict(
    mechanism: &dyn Mechanism,
    global: &DVector<f64>,
    configured: &[f64],
    observations: &Observations,
    reference: Option<usize>,
) -> Result<Vec<PredictedRows>, MechanismCalibrationError> {
    if reference.is_some() && !observations.samples.is_empty() {
        return Err(MechanismCalibrationError::InvalidData {
            what: "the reference observations".to_string(),
            reason: "they locate each held-out ball's centre and tracker's frame; a point sample's pose is located by its own readings: validate samples without reference observations".to_string(),
        });
    }
    let n = mechanism.parameters().len();
    let g = global.len();
    let params = &global.as_slice()[..n];
    let at = |kind, index| ObservationRef { kind, index };
    let failed = |observation, error: MechanismError| MechanismCalibrationError::Observation {
        observation,
        reason: error.to_string(),
    };
    let balls = touches_by_ball(observations)?;
    let mut predicted = Vec::new();
    for (k, probe) in observations.probes.iter().enumerate() {
        let id = at(ObservationKind::Probe, k);
        let trigger =
            global
                .get(n)
                .copied()
                .ok_or_else(|| MechanismCalibrationError::InvalidData {
                    what: "trigger height".to_string(),
                    reason:
                        "probe heights need one, and neither the calibration nor the data give it"
                            .to_string(),
                })?;
        let evaluated = probe
            .evaluate(mechanism, params, configured, trigger)
            .map_err(|e| failed(id, e))?;
        let mut rows = unwhitened(id, &evaluated.rows, &[probe.sigma], g);
        rows.d_global[(0, n)] = evaluated.d_trigger_height * probe.sigma;
        predicted.push(rows);
    }
    for (k, manual) in observations.manual_heights.iter().enumerate() {
        let id = at(ObservationKind::ManualHeight, k);
        let rows = manual
            .evaluate(mechanism, params, configured)
            .map_err(|e| failed(id, e))?;
        predicted.push(unwhitened(id, &rows, &[manual.sigma], g));
    }
    for (k, distance) in observations.distances.iter().enumerate() {
        let id = at(ObservationKind::Distance, k);
        let rows = distance
            .evaluate(mechanism, params, configured)
            .map_err(|e| failed(id, e))?;
        predicted.push(unwhitened(id, &rows, &[distance.sigma], g));
    }
    for (k, point) in observations.points.iter().enumerate() {
        let id = at(ObservationKind::Point, k);
        let rows = point
            .evaluate(mechanism, params, configured)
            .map_err(|e| failed(id, e))?;
        predicted.push(unwhitened(id, &rows, &point.sigma, g));
    }
    for (k, quantity) in observations.quantities.iter().enumerate() {
        let id = at(ObservationKind::Quantity, k);
        let rows = quantity
            .evaluate(mechanism, params)
            .map_err(|e| failed(id, e))?;
        predicted.push(unwhitened(id, &rows, &[quantity.sigma], g));
    }
    for (k, sample) in observations.samples.iter().enumerate() {
        let id = at(ObservationKind::Sample, k);
        if let Some(rows) =
            predict_sample(mechanism, params, id, sample, g).map_err(|e| failed(id, e))?
        {
            predicted.push(rows);
        }
    }
    for tracker in 0..observations.trackers.len() {
        predicted.push(predict_tracker(
            mechanism,
            params,
            configured,
            observations,
            (tracker, reference),
            g,
        )?);
    }
    for set in tied_sets(observations, balls)? {
        predicted.push(predict_balls(
            mechanism,
            params,
            configured,
            observations,
            set,
            reference,
            g,
        )?);
    }
    Ok(predicted)
}

/// Balls predicted together: one ball and its touches, or the balls
/// held-out ball distances tie together (connected through them), with
/// their touches and those distances.
struct BallSet {
    /// The balls, increasing.
    balls: Vec<usize>,
    /// Each ball's touches (indices, increasing).
    touches: Vec<Vec<usize>>,
    /// The ball distances between them (indices, increasing).
    distances: Vec<usize>,
}

impl BallSet {
    /// What its rows are of: a ball, or balls tied by distances.
    fn held_out(&self) -> HeldOut {
        match (&self.balls[..], self.distances.is_empty()) {
            (&[ball], true) => HeldOut::Ball {
                ball,
                touches: self.touches[0].clone(),
            },
            _ => {
                let mut touches: Vec<usize> = self.touches.concat();
                touches.sort_unstable();
                HeldOut::TiedBalls {
                    balls: self.balls.clone(),
                    touches,
                    distances: self.distances.clone(),
                }
            }
        }
    }
}

/// The sets of balls predicted together ([`BallSet`]), from each ball's
/// `touches`: every ball touched or tied, the sets in the order of their
/// first ball. An error names a set of more than
/// [`MAX_HELD_OUT_TOUCHES_PER_BALL`] rows.
fn tied_sets(
    observations: &Observations,
    touches: Vec<Vec<usize>>,
) -> Result<Vec<BallSet>, MechanismCalibrationError> {
    // Each ball's set: the smallest ball it is tied to, by union of the
    // distances' two balls (the set's first ball its representative).
    let mut first: Vec<usize> = (0..touches.len()).collect();
    fn root(first: &mut [usize], mut b: usize) -> usize {
        while first[b] != b {
            first[b] = first[first[b]];
            b = first[b];
        }
        b
    }
    for d in &observations.ball_distances {
        let (a, b) = (root(&mut first, d.first), root(&mut first, d.second));
        let (low, high) = (a.min(b), a.max(b));
        first[high] = low;
    }
    let mut sets: Vec<BallSet> = Vec::new();
    let mut set_of = vec![usize::MAX; touches.len()];
    for (b, own) in touches.into_iter().enumerate() {
        let r = root(&mut first, b);
        if r == b {
            set_of[b] = sets.len();
            sets.push(BallSet {
                balls: Vec::new(),
                touches: Vec::new(),
                distances: Vec::new(),
            });
        }
        let set = &mut sets[set_of[r]];
        set.balls.push(b);
        set.touches.push(own);
    }
    for (k, d) in observations.ball_distances.iter().enumerate() {
        sets[set_of[root(&mut first, d.first)]].distances.push(k);
    }
    sets.retain(|set| !set.distances.is_empty() || !set.touches[0].is_empty());
    for set in &sets {
        let rows = set.touches.iter().map(Vec::len).sum::<usize>() + set.distances.len();
        if rows > MAX_HELD_OUT_TOUCHES_PER_BALL && set.balls.len() > 1 {
            return Err(MechanismCalibrationError::InvalidData {
                what: set.held_out().to_string(),
                reason: format!(
                    "their {rows} held-out touches and distances are more than the {MAX_HELD_OUT_TOUCHES_PER_BALL} predicted together: validate on fewer"
                ),
            });
        }
    }
    Ok(sets)
}

/// The touches of each ball (indices, increasing); an error names a touch
/// of a ball that does not exist, or a ball of more than
/// [`MAX_HELD_OUT_TOUCHES_PER_BALL`] touches.
fn touches_by_ball(
    observations: &Observations,
) -> Result<Vec<Vec<usize>>, MechanismCalibrationError> {
    let count = observations.balls.len();
    let mut balls = vec![Vec::new(); count];
    for (t, touch) in observations.touches.iter().enumerate() {
        let touches =
            balls
                .get_mut(touch.ball)
                .ok_or_else(|| MechanismCalibrationError::Observation {
                    observation: ObservationRef {
                        kind: ObservationKind::Touch,
                        index: t,
                    },
                    reason: format!(
                        "it touches ball {}, and there are {count} balls",
                        touch.ball
                    ),
                })?;
        touches.push(t);
    }
    match balls
        .iter()
        .position(|t| t.len() > MAX_HELD_OUT_TOUCHES_PER_BALL)
    {
        Some(b) => Err(MechanismCalibrationError::InvalidData {
            what: format!("ball {b}"),
            reason: format!(
                "its {} held-out touches are more than the {MAX_HELD_OUT_TOUCHES_PER_BALL} predicted together: validate on fewer",
                balls[b].len()
            ),
        }),
        None => Ok(balls),
    }
}

/// An observation kind's whitened `rows` back in its units (`σ` per row),
/// its derivative placed in the first columns of `g`.
fn unwhitened(observation: ObservationRef, rows: &Rows, sigma: &[f64], g: usize) -> PredictedRows {
    let m = rows.residual.len();
    let n = rows.d_params.ncols();
    let mut d_global = DMatrix::zeros(m, g);
    for i in 0..m {
        for j in 0..n {
            d_global[(i, j)] = rows.d_params[(i, j)] * sigma[i];
        }
    }
    PredictedRows {
        observation: HeldOut::Observation(observation),
        residuals: DVector::from_fn(m, |i, _| rows.residual[i] * sigma[i]),
        noise: DMatrix::from_fn(m, m, |i, j| if i == j { sigma[i] * sigma[i] } else { 0.0 }),
        d_global,
        row_observations: Vec::new(),
    }
}

/// A point sample's rows (module doc); `None` for one at an unknown pose
/// with no redundant reading.
fn predict_sample(
    mechanism: &dyn Mechanism,
    params: &[f64],
    observation: ObservationRef,
    sample: &PointSample,
    g: usize,
) -> Result<Option<PredictedRows>, MechanismError> {
    let actuators = mechanism.actuators().len();
    if sample.known_pose.is_none() && actuators <= 3 {
        return Ok(None);
    }
    let start = sample.known_pose.map_or([0.0; 3], |(pose, _)| pose);
    let pose = mechanism.forward(params, &sample.readings, &start)?;
    let jacobians = mechanism.reading_jacobians(params, pose.as_slice())?;
    let (g_x, g_p) = (&jacobians.d_pose, &jacobians.d_params);
    let variance = sample.sigma * sample.sigma;
    let rows = match sample.known_pose {
        Some((measured, sigma)) => {
            let (d_params, normal_inverse) = pose_derivative(g_x, g_p)?;
            let mut noise = &normal_inverse * variance;
            for k in 0..3 {
                noise[(k, k)] += sigma[k] * sigma[k];
            }
            PredictedRows {
                observation: HeldOut::Observation(observation),
                residuals: DVector::from_fn(3, |k, _| pose[k] - measured[k]),
                noise,
                d_global: widened(&d_params, g),
                row_observations: Vec::new(),
            }
        }
        None => {
            let predicted = mechanism.inverse(params, pose.as_slice())?;
            let local = LocalRows {
                residuals: predicted - DVector::from_column_slice(&sample.readings),
                d_local: g_x,
                d_params: g_p,
                noise: DMatrix::identity(actuators, actuators) * variance,
            };
            // J = G_x: a pose its readings do not locate is a singular one.
            project_out(HeldOut::Observation(observation), &local, g)
                .ok_or(MechanismError::Singular)?
        }
    };
    Ok(Some(rows))
}

/// The rows of a set of held-out balls (module doc): each ball's touches,
/// its centre `c` located by them alone, and the distances between the
/// set's balls, `r = |ĉ_a − ĉ_b| − L` (`dr/dc_a = uᵀ`, `dr/dc_b = −uᵀ`,
/// noise `σ_L²`), every centre then projected out together; with
/// `reference` touches `N`, each centre located by its ball's first `N`
/// touches and the set's other rows predicted from them
/// ([`predict_from_reference`]).
fn predict_balls(
    mechanism: &dyn Mechanism,
    params: &[f64],
    configured: &[f64],
    observations: &Observations,
    set: BallSet,
    reference: Option<usize>,
    g: usize,
) -> Result<PredictedRows, MechanismCalibrationError> {
    let all = &observations.touches;
    let mut reference_rows = Vec::new();
    let n = params.len();
    let m = set.touches.iter().map(Vec::len).sum::<usize>() + set.distances.len();
    let u = 3 * set.balls.len();
    let (mut residuals, mut d_local) = (DVector::zeros(m), DMatrix::zeros(m, u));
    let mut d_params = DMatrix::zeros(m, n);
    let mut noise = DMatrix::zeros(m, m);
    let mut centres = Vec::with_capacity(set.balls.len());
    let mut sources = Vec::with_capacity(m);
    let mut row = 0;
    for (s, (&b, touches)) in set.balls.iter().zip(&set.touches).enumerate() {
        let ball = observations.balls[b];
        let k = touches.len();
        let locating = match reference {
            None => touches.as_slice(),
            Some(n) if n < k => {
                reference_rows.extend(row..row + n);
                &touches[..n]
            }
            Some(n) => {
                return Err(MechanismCalibrationError::InvalidData {
                    what: format!("ball {b}"),
                    reason: format!(
                        "it has {k} held-out touches: none is left to predict after the {n} reference touches"
                    ),
                });
            }
        };
        let centre = ball_centre(
            mechanism,
            params,
            configured,
            all,
            locating,
            b,
            ball.radius,
            &mut Vec::new(),
            BallFit {
                warm_starts: &mut vec![WarmStart::default(); locating.len()],
                tips: &mut vec![Vector3::zeros(); locating.len()],
            },
        )?;
        let radius_variance = ball.radius_sigma.map_or(0.0, |s| s * s);
        noise.view_mut((row, row), (k, k)).fill(radius_variance);
        for &t in touches {
            let touch = &all[t];
            let observation = ObservationRef {
                kind: ObservationKind::Touch,
                index: t,
            };
            let evaluated = touch
                .evaluate(mechanism, params, configured, &centre, ball.radius, None)
                .map_err(|e| MechanismCalibrationError::Observation {
                    observation,
                    reason: format!("on ball {b}: {e}"),
                })?;
            sources.push((observation, 0));
            let sigma = touch.sigma;
            residuals[row] = evaluated.rows.residual[0] * sigma;
            d_local
                .view_mut((row, 3 * s), (1, 3))
                .copy_from(&(evaluated.d_centre * sigma));
            d_params
                .row_mut(row)
                .copy_from(&(evaluated.rows.d_params.row(0) * sigma));
            noise[(row, row)] += sigma * sigma;
            row += 1;
        }
        centres.push(centre);
    }
    let slot = |b: usize| set.balls.binary_search(&b).unwrap_or_default();
    for &k in &set.distances {
        let distance = &observations.ball_distances[k];
        let (a, b) = (slot(distance.first), slot(distance.second));
        let observation = ObservationRef {
            kind: ObservationKind::BallDistance,
            index: k,
        };
        let evaluated = distance.evaluate(&centres[a], &centres[b]).map_err(|e| {
            MechanismCalibrationError::Observation {
                observation,
                reason: e.to_string(),
            }
        })?;
        sources.push((observation, 0));
        let sigma = distance.sigma;
        residuals[row] = evaluated.residual * sigma;
        d_local
            .view_mut((row, 3 * a), (1, 3))
            .copy_from(&(evaluated.d_first * sigma));
        d_local
            .view_mut((row, 3 * b), (1, 3))
            .copy_from(&(evaluated.d_second * sigma));
        noise[(row, row)] = sigma * sigma;
        row += 1;
    }
    let held_out = set.held_out();
    let local = LocalRows {
        residuals,
        d_local: &d_local,
        d_params: &d_params,
        noise,
    };
    let (predicted, locating) = match reference {
        None => (project_out(held_out.clone(), &local, g), "held-out"),
        Some(_) => (
            predict_from_reference(held_out.clone(), &local, &reference_rows, &sources, g),
            "reference",
        ),
    };
    predicted.ok_or_else(|| MechanismCalibrationError::InvalidData {
        what: held_out.to_string(),
        reason: format!("the {locating} touches do not locate the centres"),
    })
}

/// The rows of tracker `tracker`'s points (module doc): its frame `F`
/// located by them alone (the best rigid motion of the tool points they
/// reach onto the points measured, Kabsch), each point's `c = F(T) − P`,
/// `dc/dp = R_F dT/dp|_q`, `dc/dC = [R_F d(Exp(ω) T)/dω | R_F]` on the
/// frame's correction `C` at zero, noise its covariance `W = L Lᵀ`, and
/// the frame's six unknowns projected out; for a re-homed tracker its
/// actuators' offsets too, `dc/do = R_F dT/dq`. With `reference`
/// observations `N`, `F` is located by its first `N` points and the other
/// points' rows are predicted from theirs ([`predict_from_reference`]).
fn predict_tracker(
    mechanism: &dyn Mechanism,
    params: &[f64],
    configured: &[f64],
    observations: &Observations,
    (tracker, reference): (usize, Option<usize>),
    g: usize,
) -> Result<PredictedRows, MechanismCalibrationError> {
    let all = &observations.tracker_points;
    let indices = points_of(all, tracker);
    let poses = poses_of(&observations.tracker_poses, tracker);
    let held_out = HeldOut::Tracker {
        tracker,
        points: indices.clone(),
        poses: poses.clone(),
    };
    let what = held_out.to_string();
    let locating = TrackerReference::of(&what, &indices, &poses, reference)?;
    if !poses.is_empty() {
        let seen = (tracker, &indices[..], &poses[..]);
        return predict_posed_tracker(
            mechanism,
            params,
            configured,
            observations,
            (seen, &locating),
            g,
        );
    }
    let seen = Seen {
        points: all,
        point_indices: locating.points,
        poses: &[],
        pose_indices: &[],
        body: &Isometry3::identity(),
    };
    let machine = (mechanism, configured);
    let (frame, mut reached) = locate_frame(machine, params, &seen, &what)?;
    // The locating points are the first: the others reached after them.
    let others = &indices[locating.points.len()..];
    reached.extend(reach(machine, params, all, others)?);
    let points: Vec<&TrackerPoint> = indices.iter().map(|&j| &all[j]).collect();
    // A re-homed tracker's offsets are its own unknowns too.
    let rehomed = observations.trackers[tracker].rehomed;
    let u = 6 + if rehomed {
        mechanism.actuators().len()
    } else {
        0
    };
    let (n, m) = (params.len(), 3 * points.len());
    let (mut residuals, mut d_local) = (DVector::zeros(m), DMatrix::zeros(m, u));
    let (mut d_params, mut noise) = (DMatrix::zeros(m, n), DMatrix::zeros(m, m));
    for (k, (point, reached)) in points.iter().zip(&reached).enumerate() {
        let measured = point.measured.into();
        let block = PointBlock {
            measured: &measured,
            tracker_reference: &frame,
            tracker: FrameCorrection::IDENTITY,
        }
        .evaluate(&reached.point);
        let rows = 3 * k;
        residuals.rows_mut(rows, 3).copy_from(&block.residual);
        d_local
            .view_mut((rows, 0), (3, 6))
            .copy_from(&block.d_tracker);
        if rehomed {
            let d_tip = mechanism
                .pose_of_warm_start(reached.warm_start.as_slice())
                .and_then(|pose| tool_point_reading_jacobian(mechanism, params, pose.as_slice()))
                .map_err(|e| MechanismCalibrationError::Observation {
                    observation: ObservationRef {
                        kind: ObservationKind::TrackerPoint,
                        index: indices[k],
                    },
                    reason: e.to_string(),
                })?;
            d_local
                .view_mut((rows, 6), (3, u - 6))
                .copy_from(&(block.d_tip * d_tip));
        }
        d_params
            .view_mut((rows, 0), (3, n))
            .copy_from(&(block.d_tip * reached.d_params.to_dense()));
        noise
            .view_mut((rows, rows), (3, 3))
            .copy_from(&point.weight.covariance());
    }
    let local = LocalRows {
        residuals,
        d_local: &d_local,
        d_params: &d_params,
        noise,
    };
    let located = if rehomed {
        "its frame and offsets"
    } else {
        "its frame"
    };
    locating
        .predict(held_out, &local, (&indices, &[], 0), g)
        .ok_or_else(|| MechanismCalibrationError::InvalidData {
            what,
            reason: format!("the {} points do not locate {located}", locating.name()),
        })
}

/// The observations that locate a held-out tracker's frame (and the body
/// its poses see): all of its points and poses, or with reference
/// observations `N` its first `N` points and first `N` poses, the others'
/// rows predicted from theirs.
struct TrackerReference<'a> {
    /// The locating points' indices.
    points: &'a [usize],
    /// The locating poses' indices.
    poses: &'a [usize],
    /// Whether they are the reference observations' (else all).
    reference: bool,
}

impl<'a> TrackerReference<'a> {
    /// Of a tracker (`what`) of `points` and `poses`, with `reference`
    /// observations if any; an error when they leave none to predict.
    fn of(
        what: &str,
        points: &'a [usize],
        poses: &'a [usize],
        reference: Option<usize>,
    ) -> Result<Self, MechanismCalibrationError> {
        let Some(n) = reference else {
            return Ok(Self {
                points,
                poses,
                reference: false,
            });
        };
        let (p, q) = (n.min(points.len()), n.min(poses.len()));
        if p == points.len() && q == poses.len() {
            return Err(MechanismCalibrationError::InvalidData {
                what: what.to_string(),
                reason: format!(
                    "it has {} held-out points and {} poses: none is left to predict after the first {n} of each, which locate its frame",
                    points.len(),
                    poses.len()
                ),
            });
        }
        Ok(Self {
            points: &points[..p],
            poses: &poses[..q],
            reference: true,
        })
    }

    /// What the locating observations are called in an error: `held-out`
    /// or `reference`.
    fn name(&self) -> &'static str {
        if self.reference {
            "reference"
        } else {
            "held-out"
        }
    }

    /// `local`'s rows (the tracker's `points`' 3 each, then its `poses`'
    /// `actuators` each) with the local unknowns projected out, or, with
    /// reference observations, predicted from the locating ones' rows;
    /// `None` when these do not locate the unknowns.
    fn predict(
        &self,
        held_out: HeldOut,
        local: &LocalRows,
        (points, poses, actuators): (&[usize], &[usize], usize),
        g: usize,
    ) -> Option<PredictedRows> {
        if !self.reference {
            return project_out(held_out, local, g);
        }
        let pose_rows = 3 * points.len();
        let reference: Vec<usize> = (0..3 * self.points.len())
            .chain(pose_rows..pose_rows + actuators * self.poses.len())
            .collect();
        let of = |kind, indices: &[usize], rows| {
            let sources = indices.iter().flat_map(move |&index| {
                (0..rows).map(move |row| (ObservationRef { kind, index }, row))
            });
            sources.collect::<Vec<_>>()
        };
        let mut sources = of(ObservationKind::TrackerPoint, points, 3);
        sources.extend(of(ObservationKind::TrackerPose, poses, actuators));
        predict_from_reference(held_out, local, &reference, &sources, g)
    }
}

/// The unit of rows in noise standard deviations: a held-out tracker's
/// whose points (mm) and poses (the readings' unit) are projected together
/// ([`tracker_unit`]).
pub(crate) const NOISE_SIGMAS: &str = "noise sigmas";

/// The unit of a held-out tracker's projected rows: its points' (mm)
/// without poses, its poses' (the readings') without points, and with both
/// mm when the readings are, else [`NOISE_SIGMAS`] (the rows whitened: a
/// projection mixes them).
pub(crate) fn tracker_unit(mechanism: &dyn Mechanism, points: bool, poses: bool) -> &str {
    let readings = &*mechanism.actuators()[0].unit;
    match (points, poses) {
        (_, false) => "mm",
        (false, true) => readings,
        (true, true) if readings == "mm" => "mm",
        (true, true) => NOISE_SIGMAS,
    }
}

/// The most Gauss-Newton steps that locate a held-out tracker's frame and
/// the body frame its poses see.
const NUISANCE_ITERATIONS: usize = 50;

/// A held-out tracker's frame and body located when the step changes its
/// whitened rows by less than this (`|J δ|²`, in noise units squared).
const NUISANCE_TOLERANCE: f64 = 1e-12;

/// The rows of tracker `tracker` with its points `points` and poses
/// `poses` (module doc): its frame `F`, the body
/// frame `B` its poses see and a re-homed tracker's offsets are its own
/// unknowns (the tracker placed anew, the body mounted anew), located by
/// its points and poses together: from the frame [`locate_frame`] gives
/// through the data's body reference, Gauss-Newton on their whitened rows
/// ([`TrackerPose`](parcal_observe::mechanism::TrackerPose),
/// [`TrackerPoint`]) to the least-squares frames. There the rows are
/// un-whitened (`r = L r_w`, `D = L Lᵀ` for each observation's `L⁻¹`;
/// kept whitened when they are of two units, [`tracker_unit`]), and the
/// unknowns projected out. With reference observations (`locating`), the
/// frames are located by those alone and the other rows predicted from
/// theirs ([`TrackerReference::predict`]).
fn predict_posed_tracker(
    mechanism: &dyn Mechanism,
    params: &[f64],
    configured: &[f64],
    observations: &Observations,
    ((tracker, points, poses), locating): ((usize, &[usize], &[usize]), &TrackerReference),
    g: usize,
) -> Result<PredictedRows, MechanismCalibrationError> {
    let held_out = HeldOut::Tracker {
        tracker,
        points: points.to_vec(),
        poses: poses.to_vec(),
    };
    let what = held_out.to_string();
    let seen = Seen {
        points: &observations.tracker_points,
        point_indices: locating.points,
        poses: &observations.tracker_poses,
        pose_indices: locating.poses,
        body: &observations.body_reference,
    };
    let (reference, _) = locate_frame((mechanism, configured), params, &seen, &what)?;
    let rows = |points, poses| NuisanceRows {
        mechanism,
        params,
        configured,
        observations,
        reference,
        points,
        poses,
        offsets: observations.trackers[tracker].rehomed,
    };
    let not_located = |reason: &str| MechanismCalibrationError::InvalidData {
        what: what.clone(),
        reason: format!(
            "the {} points and poses do not locate its frame and body{reason}",
            locating.name()
        ),
    };
    let fitted = rows(locating.points, locating.poses);
    let mut nuisance = DVector::zeros(fitted.unknowns());
    let mut stacked = fitted.at(&nuisance)?;
    let mut converged = false;
    for _ in 0..NUISANCE_ITERATIONS {
        let normal = stacked.d_local.tr_mul(&stacked.d_local);
        let gradient = stacked.d_local.tr_mul(&stacked.residuals);
        let step = -normal
            .cholesky()
            .ok_or_else(|| not_located(""))?
            .solve(&gradient);
        let change = (&stacked.d_local * &step).norm_squared();
        nuisance += step;
        stacked = fitted.at(&nuisance)?;
        if change < NUISANCE_TOLERANCE {
            converged = true;
            break;
        }
    }
    if !converged {
        return Err(not_located(&format!(
            " within {NUISANCE_ITERATIONS} Gauss-Newton steps"
        )));
    }
    if locating.reference {
        stacked = rows(points, poses).at(&nuisance)?;
    }
    // Rows of two units stay whitened (`L = I`).
    let unit = tracker_unit(mechanism, !points.is_empty(), true);
    let factor = match unit {
        NOISE_SIGMAS => DMatrix::identity(stacked.factor.nrows(), stacked.factor.ncols()),
        _ => stacked.factor.clone(),
    };
    let factor = &factor;
    let local = LocalRows {
        residuals: factor * &stacked.residuals,
        d_local: &(factor * &stacked.d_local),
        d_params: &(factor * &stacked.d_params),
        noise: factor * factor.transpose(),
    };
    let actuators = mechanism.actuators().len();
    locating
        .predict(held_out, &local, (points, poses, actuators), g)
        .ok_or_else(|| not_located(""))
}

/// A held-out tracker's whitened rows as functions of its nuisance: its
/// frame's correction, the body's, and its offsets if re-homed.
struct NuisanceRows<'a> {
    mechanism: &'a dyn Mechanism,
    params: &'a [f64],
    configured: &'a [f64],
    observations: &'a Observations,
    /// `F₀`, the located frame the correction is of.
    reference: Isometry3<f64>,
    points: &'a [usize],
    poses: &'a [usize],
    offsets: bool,
}

/// The stacked whitened rows ([`NuisanceRows::at`]).
struct Stacked {
    /// `r_w`.
    residuals: DVector<f64>,
    /// `dr_w/du`.
    d_local: DMatrix<f64>,
    /// `dr_w/dp`.
    d_params: DMatrix<f64>,
    /// `L`, block-diagonal: what un-whitens each observation's rows.
    factor: DMatrix<f64>,
}

impl NuisanceRows<'_> {
    /// The nuisance's size: 12, and the actuators' offsets.
    fn unknowns(&self) -> usize {
        12 + if self.offsets {
            self.mechanism.actuators().len()
        } else {
            0
        }
    }

    /// Every point's and pose's whitened rows at the nuisance `u`.
    fn at(&self, u: &DVector<f64>) -> Result<Stacked, MechanismCalibrationError> {
        let correction = |start: usize| {
            FrameCorrection::from_params(&nalgebra::Vector6::from_column_slice(
                &u.as_slice()[start..start + 6],
            ))
        };
        let frame = TrackerFrame {
            reference: self.reference,
            correction: correction(0),
        };
        let body = BodyFrame {
            reference: self.observations.body_reference,
            correction: correction(6),
        };
        let offsets = self.offsets.then(|| &u.as_slice()[12..]);
        let actuators = self.mechanism.actuators().len();
        let m = 3 * self.points.len() + actuators * self.poses.len();
        let (n, w) = (self.params.len(), u.len());
        let mut stacked = Stacked {
            residuals: DVector::zeros(m),
            d_local: DMatrix::zeros(m, w),
            d_params: DMatrix::zeros(m, n),
            factor: DMatrix::zeros(m, m),
        };
        let failed = |kind, index, e: MechanismError| MechanismCalibrationError::Observation {
            observation: ObservationRef { kind, index },
            reason: e.to_string(),
        };
        let mut row = 0;
        for &j in self.points {
            let point = &self.observations.tracker_points[j];
            let evaluated = point
                .evaluate(
                    self.mechanism,
                    self.params,
                    self.configured,
                    &frame,
                    offsets,
                    None,
                )
                .map_err(|e| failed(ObservationKind::TrackerPoint, j, e))?;
            let unwhiten = point.weight.covariance().cholesky().map(|c| c.l());
            let unwhiten = unwhiten.ok_or_else(|| {
                failed(ObservationKind::TrackerPoint, j, MechanismError::Singular)
            })?;
            let d_frame = DMatrix::from_column_slice(3, 6, evaluated.d_frame.as_slice());
            let d_offsets = evaluated.d_offsets.as_ref();
            stacked.put(row, &evaluated.rows, &[(0, &d_frame)], d_offsets);
            stacked
                .factor
                .view_mut((row, row), (3, 3))
                .copy_from(&unwhiten);
            row += 3;
        }
        for &j in self.poses {
            let pose = &self.observations.tracker_poses[j];
            let evaluated = pose
                .evaluate(self.mechanism, self.params, &frame, &body, offsets)
                .map_err(|e| failed(ObservationKind::TrackerPose, j, e))?;
            let unwhiten = pose
                .row_whitening(self.mechanism, self.params)
                .solve_lower_triangular(&DMatrix::identity(actuators, actuators))
                .ok_or_else(|| failed(ObservationKind::TrackerPose, j, MechanismError::Singular))?;
            let locals = [(0, &evaluated.d_frame), (6, &evaluated.d_body)];
            stacked.put(row, &evaluated.rows, &locals, evaluated.d_offsets.as_ref());
            stacked
                .factor
                .view_mut((row, row), (actuators, actuators))
                .copy_from(&unwhiten);
            row += actuators;
        }
        Ok(stacked)
    }
}

impl Stacked {
    /// Puts one observation's `rows` from `row` on: its residuals, `dr/dp`,
    /// each local derivative at its first nuisance column, its offsets'
    /// after the two frames.
    fn put(
        &mut self,
        row: usize,
        rows: &Rows,
        locals: &[(usize, &DMatrix<f64>)],
        d_offsets: Option<&DMatrix<f64>>,
    ) {
        let m = rows.residual.len();
        self.residuals.rows_mut(row, m).copy_from(&rows.residual);
        self.d_params
            .view_mut((row, 0), (m, rows.d_params.ncols()))
            .copy_from(&rows.d_params);
        for &(column, d) in locals {
            self.d_local
                .view_mut((row, column), (m, d.ncols()))
                .copy_from(d);
        }
        if let Some(d) = d_offsets {
            self.d_local
                .view_mut((row, 12), (m, d.ncols()))
                .copy_from(d);
        }
    }
}

/// Residuals with local unknowns `u` (a pose, a centre, or the centres
/// of tied balls; module doc).
struct LocalRows<'a> {
    /// `r` (`m`).
    residuals: DVector<f64>,
    /// `J = dr/du` (`m × 3`, or 3 columns a ball).
    d_local: &'a DMatrix<f64>,
    /// `G_p = dr/dp` (`m × n`).
    d_params: &'a DMatrix<f64>,
    /// `Σ = Cov(r)` (`m × m`).
    noise: DMatrix<f64>,
}

/// `local`'s rows with its local unknowns projected out (module doc), the
/// derivative widened to `g` columns; `None` when `J` is not of full
/// column rank (the rows do not locate the unknowns).
fn project_out(observation: HeldOut, local: &LocalRows, g: usize) -> Option<PredictedRows> {
    let j = local.d_local;
    let (m, u) = (j.nrows(), j.ncols());
    let spread = (j.transpose() * j).symmetric_eigenvalues();
    // False for a rank below u, and for a value that is not a number.
    let located = spread.min() > 1e-12 * spread.max();
    if m < u || !located {
        return None;
    }
    let mut q_t = DMatrix::identity(m, m);
    j.clone().qr().q_tr_mul(&mut q_t);
    let basis_t = q_t.rows(u, m - u);
    Some(PredictedRows {
        observation,
        residuals: basis_t * &local.residuals,
        noise: basis_t * &local.noise * basis_t.transpose(),
        d_global: widened(&(basis_t * local.d_params), g),
        row_observations: Vec::new(),
    })
}

/// `local`'s rows but its `reference` rows (increasing), predicted from
/// these (module doc), each named by its observation in `sources` (one
/// for each of `local`'s rows): with the rows split into the reference's
/// (`J_r`, noise `Σ_rr`) and the others' (`J_o`), the local unknowns' weighted
/// fit on the reference rows `K = (J_rᵀ Σ_rr⁻¹ J_r)⁻¹ J_rᵀ Σ_rr⁻¹`, and
/// `A = [−J_o K | I]` on them,
///
/// ```text
/// r' = A r = r_o − J_o K r_r,   G = A G_p,   D = A Σ Aᵀ:
/// ```
///
/// `A J = J_o − J_o K J_r = 0`, so that no error of the unknowns moves
/// `r'` to first order (nor `G`), as in [`project_out`], and `D` carries
/// the fit's error and the noise common to reference and other rows (a
/// ball's radius). `None` when the reference rows do not locate the
/// unknowns.
fn predict_from_reference(
    observation: HeldOut,
    local: &LocalRows,
    reference: &[usize],
    sources: &[(ObservationRef, usize)],
    g: usize,
) -> Option<PredictedRows> {
    let m = local.residuals.len();
    let others: Vec<usize> = (0..m)
        .filter(|i| reference.binary_search(i).is_err())
        .collect();
    let j_r = local.d_local.select_rows(reference);
    let weight = (local.noise.select_rows(reference))
        .select_columns(reference)
        .cholesky()?
        .inverse();
    let normal = j_r.transpose() * &weight * &j_r;
    let spread = normal.symmetric_eigenvalues();
    // False for a rank below the unknowns', and for a value that is not a
    // number.
    let located = spread.min() > 1e-12 * spread.max();
    if !located {
        return None;
    }
    let gain = normal.try_inverse()? * j_r.transpose() * weight;
    let fitted = -(local.d_local.select_rows(&others) * gain);
    let mut a = DMatrix::zeros(others.len(), m);
    for (column, &r) in fitted.column_iter().zip(reference) {
        a.set_column(r, &column);
    }
    for (i, &o) in others.iter().enumerate() {
        a[(i, o)] = 1.0;
    }
    Some(PredictedRows {
        observation,
        residuals: &a * &local.residuals,
        noise: &a * &local.noise * a.transpose(),
        d_global: widened(&(&a * local.d_params), g),
        row_observations: others.iter().map(|&o| sources[o]).collect(),
    })
}

/// `dx/dp|_q = −G_x⁺ G_p` of the readings' least-squares pose (module
/// doc), and `(G_xᵀ G_x)⁻¹`; an error at a singular configuration.
pub fn pose_derivative(
    g_x: &DMatrix<f64>,
    g_p: &DMatrix<f64>,
) -> Result<(DMatrix<f64>, DMatrix<f64>), MechanismError> {
    let normal_inverse = (g_x.transpose() * g_x)
        .try_inverse()
        .filter(|m| m.iter().all(|v| v.is_finite()))
        .ok_or(MechanismError::Singular)?;
    let d_params = -(&normal_inverse * g_x.transpose() * g_p);
    Ok((d_params, normal_inverse))
}

/// `d_params` with zero columns appended up to `g`.
fn widened(d_params: &DMatrix<f64>, g: usize) -> DMatrix<f64> {
    let mut wide = DMatrix::zeros(d_params.nrows(), g);
    wide.columns_mut(0, d_params.ncols()).copy_from(d_params);
    wide
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mechanism::data::Ball;
    use nalgebra::Isometry3;
    use nalgebra::Vector3;
    use parcal_kinematics::cable::CableRobot;
    use parcal_kinematics::delta::LinearDelta;
    use parcal_kinematics::hexapod::Hexapod;
    use parcal_kinematics::mechanism::{design, prior_sigma};
    use parcal_observe::mechanism::{Actuation, BallDistance, BallTouch};
    use parcal_observe::mechanism::{PointSample, TrackerPose};
    use parcal_simulate::Rng;

    /// `G_i = dr/dθ` of a cable robot's samples (four lines: the
    /// least-squares pose) against central differences of the predicted
    /// residuals, for a measured position and an unknown one.
    #[test]
    fn sample_derivatives_match_central_differences() {
        let robot = CableRobot::typical();
        let mut params = design(&robot);
        for (k, value) in params.iter_mut().enumerate() {
            *value += 0.3 * ((k as f64) * 1.7).sin();
        }
        let pose = [120.0, -80.0, 400.0];
        let readings: Vec<f64> = robot
            .inverse(params.as_slice(), &pose)
            .unwrap()
            .iter()
            .copied()
            .collect();
        let known = PointSample {
            readings: readings.clone(),
            sigma: 1.0,
            known_pose: Some(([121.0, -79.5, 400.2], [0.1; 3])),
            loads: None,
        };
        let unknown = PointSample {
            readings,
            sigma: 1.0,
            known_pose: None,
            loads: None,
        };
        let n = params.len();
        let id = ObservationRef {
            kind: ObservationKind::Sample,
            index: 0,
        };
        let steps = prior_sigma(&robot) * 1e-4;
        for sample in [&known, &unknown] {
            let at = |p: &DVector<f64>| {
                predict_sample(&robot, p.as_slice(), id, sample, n)
                    .unwrap()
                    .unwrap()
            };
            let analytic = at(&params).d_global;
            for k in 0..n {
                let (mut plus, mut minus) = (params.clone(), params.clone());
                plus[k] += steps[k];
                minus[k] -= steps[k];
                let column = (at(&plus).residuals - at(&minus).residuals) / (2.0 * steps[k]);
                let error = (&column - analytic.column(k)).amax();
                assert!(
                    error < 1e-6 * analytic.amax(),
                    "column {k}: {error:e} against {:e}",
                    analytic.amax()
                );
            }
        }
        // The unknown pose leaves one combination of the four readings.
        assert_eq!(at_rows(&robot, &params, &unknown), 1);
    }

    fn at_rows(robot: &CableRobot, params: &DVector<f64>, sample: &PointSample) -> usize {
        let id = ObservationRef {
            kind: ObservationKind::Sample,
            index: 0,
        };
        predict_sample(robot, params.as_slice(), id, sample, params.len())
            .unwrap()
            .unwrap()
            .residuals
            .len()
    }

    /// A typical delta, its configured (design) parameters and a true
    /// machine a few tenths away.
    fn delta() -> (LinearDelta, DVector<f64>, DVector<f64>) {
        let delta = LinearDelta::typical();
        let configured = design(&delta);
        let mut truth = configured.clone();
        for (k, value) in truth.iter_mut().enumerate() {
            *value += 0.3 * ((k as f64) * 1.3).sin();
        }
        (delta, configured, truth)
    }

    /// `K` touches of a ball of centre `centre` by the delta of true
    /// parameters `truth` whose controller runs `configured`: the tool
    /// point at `centre + (radius + ε_k) u_k`, `u_k` on the upper cap
    /// (polar angles up to 70°, a golden-angle spiral), `ε_k` from
    /// `error`, the commanded position the controller reports for it.
    fn touches(
        (delta, configured, truth): &(LinearDelta, DVector<f64>, DVector<f64>),
        centre: Vector3<f64>,
        radius: f64,
        k: usize,
        mut error: impl FnMut() -> f64,
    ) -> Vec<BallTouch> {
        let lowest = 70f64.to_radians().cos();
        (0..k)
            .map(|i| {
                let polar = (1.0 - (1.0 - lowest) * (i as f64 + 0.5) / k as f64).acos();
                let azimuth = 2.399_963 * i as f64;
                let u = Vector3::new(
                    polar.sin() * azimuth.cos(),
                    polar.sin() * azimuth.sin(),
                    polar.cos(),
                );
                let x = centre + (radius + error()) * u;
                let readings = delta.inverse(truth.as_slice(), x.as_slice()).unwrap();
                let commanded = delta
                    .forward(configured.as_slice(), readings.as_slice(), x.as_slice())
                    .unwrap();
                BallTouch::new(
                    0,
                    Actuation::Commanded([commanded[0], commanded[1], commanded[2]]),
                    0.01,
                )
            })
            .collect()
    }

    /// The rows of ball 0 of `observations` at `params`.
    fn ball_rows(
        machine: &(LinearDelta, DVector<f64>, DVector<f64>),
        params: &DVector<f64>,
        observations: &Observations,
        reference: Option<usize>,
    ) -> PredictedRows {
        let (delta, configured, _) = machine;
        let mut predicted = predict(
            delta,
            params,
            configured.as_slice(),
            observations,
            reference,
        )
        .unwrap();
        assert_eq!(predicted.len(), 1);
        predicted.remove(0)
    }

    /// `G = dr'/dθ` of the rows `at` the true parameters against central
    /// differences of the rows of `observations` over the parameters,
    /// steps of 1e-4 of their prior sigmas, to 1e-6 of `G`'s largest.
    fn assert_derivatives_match_differences(
        machine: &(LinearDelta, DVector<f64>, DVector<f64>),
        observations: &Observations,
        reference: Option<usize>,
        at: &PredictedRows,
    ) {
        let truth = &machine.2;
        let steps = prior_sigma(&machine.0) * 1e-4;
        for j in 0..truth.len() {
            let (mut plus, mut minus) = (truth.clone(), truth.clone());
            plus[j] += steps[j];
            minus[j] -= steps[j];
            let column = (ball_rows(machine, &plus, observations, reference).residuals
                - ball_rows(machine, &minus, observations, reference).residuals)
                / (2.0 * steps[j]);
            let error = (&column - at.d_global.column(j)).amax();
            assert!(
                error < 1e-6 * at.d_global.amax(),
                "column {j}: {error:e} against {:e}",
                at.d_global.amax()
            );
        }
    }

    /// Three balls of `radius` (a calibration sigma `radius_sigma`) on a
    /// ring, each touched `k` times with errors from `error`, and the
    /// distances of balls 0-1 and 1-2, `L = true + error()`, of sigma
    /// `distance_sigma`.
    fn tied_balls(
        machine: &(LinearDelta, DVector<f64>, DVector<f64>),
        radius: (f64, f64),
        k: usize,
        distance_sigma: f64,
        mut error: impl FnMut(f64) -> f64,
        turn: f64,
    ) -> Observations {
        let (radius, radius_sigma) = radius;
        let centres: Vec<Vector3<f64>> = (0..3)
            .map(|b| {
                let angle = turn + 2.1 * b as f64;
                Vector3::new(70.0 * angle.cos(), 70.0 * angle.sin(), 6.0)
            })
            .collect();
        let mut observations = Observations {
            balls: vec![Ball::new(radius, Some(radius_sigma)); 3],
            ..Default::default()
        };
        for (b, centre) in centres.iter().enumerate() {
            let true_radius = radius + error(radius_sigma);
            let mut own = touches(machine, *centre, true_radius, k, || error(0.01));
            for touch in &mut own {
                touch.ball = b;
            }
            observations.touches.extend(own);
        }
        observations.ball_distances = [(0, 1), (1, 2)]
            .into_iter()
            .map(|(a, b)| BallDistance {
                first: a,
                second: b,
                distance: (centres[a] - centres[b]).norm() + error(distance_sigma),
                sigma: distance_sigma,
            })
            .collect();
        observations
    }

    /// Three balls tied by two distances are predicted together: `3k + 2`
    /// rows less the 9 coordinates of their centres, their derivative
    /// `G = N_⊥ᵀ G_p` against central differences over the parameters.
    #[test]
    fn tied_balls_are_predicted_together_with_their_derivatives() {
        let machine = delta();
        let k = 6;
        let observations = tied_balls(&machine, (12.7, 0.002), k, 0.002, |_| 0.0, 0.4);
        let at = ball_rows(&machine, &machine.2, &observations, None);
        assert_eq!(at.residuals.len(), 3 * k + 2 - 9);
        assert!(at.residuals.amax() < 1e-9, "{}", at.residuals);
        assert_eq!(
            at.observation,
            HeldOut::TiedBalls {
                balls: vec![0, 1, 2],
                touches: (0..3 * k).collect(),
                distances: vec![0, 1],
            }
        );
        assert_derivatives_match_differences(&machine, &observations, None, &at);
    }

    /// Tied balls' rows of noisy touches and distances of the true machine:
    /// `T = r'ᵀ D⁻¹ r'` over 150 sets of three balls of 6 touches and two
    /// distances (1650 rows), the distances' sigma that of the touches, the
    /// radii's three times, has the mean of its `χ²` within 4 standard
    /// errors (`4 √(2/1650)` of `T/n`).
    #[test]
    fn tied_balls_rows_have_their_stated_noise() {
        let machine = delta();
        let mut noise = Rng::new(37, 0);
        let sets = (0..150).map(|draw| {
            let error = |sigma| noise.normal(sigma);
            tied_balls(&machine, (12.7, 0.03), 6, 0.01, error, draw as f64)
        });
        assert_rows_have_their_stated_noise("tied balls' rows", &machine, None, sets);
    }

    /// `T/n = Σ r'ᵀ D⁻¹ r' / n` over the predicted rows of each of `sets`
    /// (`n` rows in all) at the true machine: within 4 standard errors
    /// (`4 √(2/n)`) of 1, the mean of `χ²(n) / n`.
    fn assert_rows_have_their_stated_noise(
        what: &str,
        machine: &(LinearDelta, DVector<f64>, DVector<f64>),
        reference: Option<usize>,
        sets: impl Iterator<Item = Observations>,
    ) {
        let (mut statistic, mut rows) = (0.0, 0);
        for observations in sets {
            let predicted = ball_rows(machine, &machine.2, &observations, reference);
            let noise = predicted.noise.clone().cholesky().unwrap();
            statistic += predicted.residuals.dot(&noise.solve(&predicted.residuals));
            rows += predicted.residuals.len();
        }
        let ratio = statistic / rows as f64;
        let bound = 4.0 * (2.0 / rows as f64).sqrt();
        eprintln!("{what}: T/n = {ratio:.4} over {rows} rows (1 ± {bound:.4})");
        assert!(
            (ratio - 1.0).abs() < bound,
            "T/n = {ratio:.4}, bound {bound:.4}"
        );
    }

    /// A tracker's frame far from the mechanism's, turned about all axes.
    fn far_frame() -> Isometry3<f64> {
        Isometry3::new(
            Vector3::new(900.0, -400.0, 120.0),
            Vector3::new(0.1, -0.05, 2.0),
        )
    }

    /// The frame of a tracker's placement `draw` of a simulation: on a
    /// circle of 1 km about the mechanism, turned by `draw` radians.
    fn placement(draw: usize) -> Isometry3<f64> {
        let turn = draw as f64;
        Isometry3::new(
            Vector3::new(1000.0 * turn.cos(), 1000.0 * turn.sin(), 50.0),
            Vector3::new(0.0, 0.1, turn),
        )
    }

    /// One tracker's `k` points at commanded positions, measured by the
    /// delta of true parameters `truth` through the frame `frame`, each
    /// coordinate off by `error()`, of the correlated weight below.
    fn tracked(
        (delta, configured, truth): &(LinearDelta, DVector<f64>, DVector<f64>),
        frame: &Isometry3<f64>,
        k: usize,
        mut error: impl FnMut() -> f64,
    ) -> Observations {
        let covariance =
            nalgebra::Matrix3::new(1e-4, 2e-5, 0.0, 2e-5, 1.5e-4, -3e-5, 0.0, -3e-5, 4e-4);
        let weight = parcal_observe::CoordinateWhitening::from_covariance(&covariance).unwrap();
        let factor = covariance.cholesky().unwrap().l();
        let tracker_points = (0..k)
            .map(|j| {
                let t = j as f64;
                let at = Actuation::Commanded([
                    70.0 * (1.9 * t).cos(),
                    60.0 * (1.3 * t).sin(),
                    15.0 + 11.0 * t,
                ]);
                let reached = at
                    .tool_point(delta, truth.as_slice(), configured.as_slice(), None)
                    .unwrap();
                let noise = factor * Vector3::new(error(), error(), error());
                let seen = frame.transform_point(&reached.point.into()).coords + noise;
                TrackerPoint {
                    tracker: 0,
                    at,
                    measured: seen.into(),
                    weight,
                }
            })
            .collect();
        Observations {
            trackers: vec![crate::mechanism::data::Tracker::new("T")],
            tracker_points,
            ..Default::default()
        }
    }

    /// A held-out tracker's exact points: `3k − 6` rows, zero at the
    /// truth, `G = N_⊥ᵀ G_p` against central differences over the
    /// parameters.
    #[test]
    fn tracker_derivatives_match_central_differences() {
        let machine = delta();
        let frame = far_frame();
        let observations = tracked(&machine, &frame, 7, || 0.0);
        let at = ball_rows(&machine, &machine.2, &observations, None);
        assert_eq!(at.residuals.len(), 3 * 7 - 6);
        assert!(at.residuals.amax() < 1e-9, "{}", at.residuals);
        assert_eq!(
            at.observation,
            HeldOut::Tracker {
                tracker: 0,
                points: (0..7).collect(),
                poses: Vec::new(),
            }
        );
        assert_derivatives_match_differences(&machine, &observations, None, &at);
        // Re-homed, a delta's offsets are its own unknowns too: their
        // common part lifts the effector as the frame's z translation
        // does, so that its points cannot locate both, and it is refused.
        let mut rehomed = observations;
        rehomed.trackers[0] = crate::mechanism::data::Tracker::rehomed("T", Some(0.1));
        let (delta, configured, truth) = &machine;
        let error = predict(delta, truth, configured.as_slice(), &rehomed, None).unwrap_err();
        assert!(
            error
                .to_string()
                .starts_with("tracker 0 (tracker points 0-6): the held-out points do not locate its frame and offsets"),
            "{error}"
        );
    }

    /// A held-out tracker's rows of noisy points: `T = r'ᵀ D⁻¹ r'` over
    /// 200 placements of 8 points (3600 rows), the noise correlated as
    /// each point's weight states, has the mean of its `χ²` within 4
    /// standard errors.
    #[test]
    fn a_tracker_s_rows_have_their_stated_noise() {
        let machine = delta();
        let mut noise = Rng::new(37, 0);
        let sets = (0..200).map(|draw| {
            let frame = placement(draw);
            tracked(&machine, &frame, 8, || noise.normal(1.0))
        });
        assert_rows_have_their_stated_noise("a tracker's rows", &machine, None, sets);
    }

    /// A hexapod measured by a tracker at `frame`, a body mounted at `body`
    /// on its platform: `k` poses of the machine of parameters `truth`,
    /// each reading off by `error()` times 0.01 mm, and two tool points,
    /// each coordinate off by `error()` times 1 um (their stated noise);
    /// the body's reference a few hundredths off.
    fn posed(
        hexapod: &Hexapod,
        truth: &DVector<f64>,
        (frame, body): (&Isometry3<f64>, &Isometry3<f64>),
        k: usize,
        mut error: impl FnMut() -> f64,
    ) -> Observations {
        let sigma = 0.01;
        let at = crate::mechanism::problem::tests::hexapod_pose;
        let tracker_poses = (0..k)
            .map(|j| {
                let x = at(j);
                let q = hexapod.inverse(truth.as_slice(), &x).unwrap();
                let platform = hexapod.platform_frame(&x).unwrap();
                TrackerPose {
                    tracker: 0,
                    readings: q.iter().map(|q| q + sigma * error()).collect(),
                    measured: frame * platform * body,
                    weight: DMatrix::identity(6, 6) / sigma,
                }
            })
            .collect();
        let tracker_points = (k..k + 2)
            .map(|j| {
                let x = at(j);
                let tip = hexapod.tool_point(truth.as_slice(), &x).unwrap().point;
                let q = hexapod.inverse(truth.as_slice(), &x).unwrap();
                let off = Vector3::new(error(), error(), error()) * 1e-3;
                TrackerPoint {
                    tracker: 0,
                    at: Actuation::Readings(q.iter().copied().collect()),
                    measured: (frame.transform_point(&tip.into()).coords + off).into(),
                    weight: parcal_observe::CoordinateWhitening::isotropic(1e-3),
                }
            })
            .collect();
        Observations {
            trackers: vec![crate::mechanism::data::Tracker::new("T")],
            tracker_points,
            tracker_poses,
            body_reference: body
                * Isometry3::new(
                    Vector3::new(0.3, -0.2, 0.4),
                    Vector3::new(0.02, -0.01, 0.03),
                ),
            ..Default::default()
        }
    }

    /// A hexapod tracker's rows of `k` poses and 2 points (`posed`),
    /// predicted with `reference` observations: exact, zero at the truth
    /// and `G` against central differences over the parameters (returned
    /// for the caller's checks); noisy (seed `seed`), `T = r'ᵀ D⁻¹ r'`
    /// over 100 placements has the mean of its `χ²` within 4 standard
    /// errors.
    fn check_posed_rows(reference: Option<usize>, k: usize, seed: u64) -> PredictedRows {
        let hexapod = Hexapod::typical();
        let mut truth = design(&hexapod);
        for (k, value) in truth.iter_mut().enumerate() {
            *value += 0.05 * ((k as f64) * 1.7).sin();
        }
        let configured = design(&hexapod);
        let frame = far_frame();
        let body = Isometry3::new(Vector3::new(5.0, 8.0, 30.0), Vector3::new(0.03, 0.02, 2.6));
        let rows = |params: &DVector<f64>, observations: &Observations| {
            let mut predicted = predict(
                &hexapod,
                params,
                configured.as_slice(),
                observations,
                reference,
            )
            .unwrap();
            assert_eq!(predicted.len(), 1);
            predicted.remove(0)
        };
        let exact = posed(&hexapod, &truth, (&frame, &body), k, || 0.0);
        let at = rows(&truth, &exact);
        assert!(at.residuals.amax() < 1e-8, "{}", at.residuals);
        let steps = prior_sigma(&hexapod) * 1e-3;
        for j in 0..truth.len() {
            let (mut plus, mut minus) = (truth.clone(), truth.clone());
            plus[j] += steps[j];
            minus[j] -= steps[j];
            let column =
                (rows(&plus, &exact).residuals - rows(&minus, &exact).residuals) / (2.0 * steps[j]);
            // Central differences of a smooth function of step 1e-4 mm, the
            // located frames converged to 1e-6 of the noise.
            let error = (&column - at.d_global.column(j)).amax();
            assert!(error < 1e-5 * at.d_global.amax(), "column {j}: {error:e}");
        }
        let mut noise = Rng::new(seed, 0);
        let (mut total, mut n) = (0.0, 0);
        for draw in 0..100 {
            let frame = placement(draw);
            let observations = posed(&hexapod, &truth, (&frame, &body), k, || noise.normal(1.0));
            let at = rows(&truth, &observations);
            let d = at.noise.clone().cholesky().unwrap();
            total += at.residuals.dot(&d.solve(&at.residuals));
            n += at.residuals.len();
        }
        let mean = total / n as f64;
        let standard_error = (2.0 / n as f64).sqrt();
        println!("T/n {mean:.4} over {n} rows, standard error {standard_error:.4}");
        assert!((mean - 1.0).abs() < 4.0 * standard_error, "{mean}");
        at
    }

    /// A held-out tracker's poses locate its frame and the body anew:
    /// `6k + 3·2 − 12` rows of 6 poses ([`check_posed_rows`]).
    #[test]
    fn a_tracker_s_poses_locate_its_frame_and_body() {
        let at = check_posed_rows(None, 6, 41);
        assert_eq!(at.residuals.len(), 6 * 6 + 3 * 2 - 12);
        assert_eq!(
            at.observation.to_string(),
            "tracker 0 (tracker points 0-1, tracker poses 0-5)"
        );
    }

    /// A tracker's frame and the body located by its first 3 poses and
    /// first 3 points (both of its 2): its other 5 poses' rows, each named
    /// by its pose and reading ([`check_posed_rows`]).
    #[test]
    fn a_tracker_s_reference_poses_locate_its_frame_and_body() {
        let at = check_posed_rows(Some(3), 8, 47);
        assert_eq!(at.residuals.len(), 6 * 5);
        let pose = ObservationRef {
            kind: ObservationKind::TrackerPose,
            index: 3,
        };
        assert_eq!(
            (at.row_observations[0], at.row_observations[5]),
            ((pose, 0), (pose, 5))
        );
    }

    /// `G = N_⊥ᵀ G_p` of a ball's eight exact touches against central
    /// differences of its predicted rows over the parameters, and its
    /// noise's radius term `σ_ρ² (N_⊥ᵀ 1)(N_⊥ᵀ 1)ᵀ` against central
    /// differences over the ball's radius (`dr'/dρ = −N_⊥ᵀ 1`).
    #[test]
    fn ball_derivatives_match_central_differences() {
        let machine = delta();
        let (radius, radius_sigma, k) = (12.7, 0.002, 8);
        let centre = Vector3::new(40.0, -25.0, 6.0);
        let mut observations = Observations {
            balls: vec![Ball::new(radius, Some(radius_sigma))],
            touches: touches(&machine, centre, radius, k, || 0.0),
            ..Default::default()
        };
        let truth = &machine.2;
        let at = ball_rows(&machine, truth, &observations, None);
        assert_eq!(at.residuals.len(), k - 3);
        assert!(at.residuals.amax() < 1e-9, "{}", at.residuals);
        assert_eq!(
            at.observation,
            HeldOut::Ball {
                ball: 0,
                touches: (0..k).collect()
            }
        );
        assert_derivatives_match_differences(&machine, &observations, None, &at);
        let h = 1e-4;
        observations.balls[0].radius = radius + h;
        let plus = ball_rows(&machine, truth, &observations, None).residuals;
        observations.balls[0].radius = radius - h;
        let minus = ball_rows(&machine, truth, &observations, None).residuals;
        let d_radius = (plus - minus) / (2.0 * h);
        let common = &at.noise - DMatrix::identity(k - 3, k - 3) * (0.01 * 0.01);
        let expected = &d_radius * d_radius.transpose() * (radius_sigma * radius_sigma);
        let error = (&common - &expected).amax();
        assert!(
            error < 1e-6 * expected.amax(),
            "{error:e}: {common} {expected}"
        );
    }

    /// A ball's rows of noisy touches of the true machine: `T = r'ᵀ D⁻¹ r'`
    /// over 400 balls of 8 touches (2000 rows), the radius's error three
    /// times the touches' noise (so that a `D` without its radius's term
    /// fails), has the mean of its `χ²(2000)` within 4 standard errors
    /// (`4 √(2/2000)` of `T/n`).
    #[test]
    fn a_ball_s_rows_have_their_stated_noise() {
        let machine = delta();
        let sets = noisy_balls(&machine, 36);
        assert_rows_have_their_stated_noise("a ball's rows", &machine, None, sets);
    }

    /// 400 balls of radius 12.7 mm (a calibration sigma of 0.03 mm, their
    /// true radii drawn so), each touched 8 times with a noise of 0.01 mm
    /// by the true machine, from the random stream `seed`.
    fn noisy_balls(
        machine: &(LinearDelta, DVector<f64>, DVector<f64>),
        seed: u64,
    ) -> impl Iterator<Item = Observations> + '_ {
        let (radius, radius_sigma, sigma) = (12.7, 0.03, 0.01);
        let mut noise = Rng::new(seed, 0);
        (0..400).map(move |draw| {
            let centre = Vector3::new(60.0 * (draw as f64).cos(), 60.0 * (draw as f64).sin(), 6.0);
            let true_radius = radius + noise.normal(radius_sigma);
            Observations {
                balls: vec![Ball::new(radius, Some(radius_sigma))],
                touches: touches(machine, centre, true_radius, 8, || noise.normal(sigma)),
                ..Default::default()
            }
        })
    }

    /// Each ball's centre located by its first 4 touches: a ball of 8
    /// touches gives its other 4 rows, three balls of 6 tied by two
    /// distances their other 2 each and the distances; `G = A G_p`
    /// against central differences over the parameters.
    #[test]
    fn rows_predicted_from_reference_touches_have_their_derivatives() {
        let machine = delta();
        let centre = Vector3::new(40.0, -25.0, 6.0);
        let ball = Observations {
            balls: vec![Ball::new(12.7, Some(0.002))],
            touches: touches(&machine, centre, 12.7, 8, || 0.0),
            ..Default::default()
        };
        let tied = tied_balls(&machine, (12.7, 0.002), 6, 0.002, |_| 0.0, 0.4);
        for (observations, rows) in [(ball, 4), (tied, 3 * 2 + 2)] {
            let at = ball_rows(&machine, &machine.2, &observations, Some(4));
            assert_eq!(at.residuals.len(), rows);
            assert!(at.residuals.amax() < 1e-9, "{}", at.residuals);
            assert_derivatives_match_differences(&machine, &observations, Some(4), &at);
        }
    }

    /// Rows predicted from reference touches (each centre located by its
    /// ball's first 4) of noisy touches of the true machine: `T = r'ᵀ D⁻¹
    /// r'` has the mean of its `χ²` within 4 standard errors, over 400
    /// balls of 8 touches (1600 rows; the radius's error three times the
    /// touches' noise, common to the reference and the predicted touches)
    /// and over 150 sets of three tied balls of 6 touches (1200 rows).
    #[test]
    fn rows_predicted_from_reference_touches_have_their_stated_noise() {
        let machine = delta();
        let balls = noisy_balls(&machine, 38);
        assert_rows_have_their_stated_noise("a ball's rows from 4", &machine, Some(4), balls);
        let mut noise = Rng::new(39, 0);
        let sets = (0..150).map(|draw| {
            let error = |sigma| noise.normal(sigma);
            tied_balls(&machine, (12.7, 0.03), 6, 0.01, error, draw as f64)
        });
        assert_rows_have_their_stated_noise("tied balls' rows from 4", &machine, Some(4), sets);
    }

    /// Reference observations must leave a touch of each ball (a point or
    /// pose of each tracker) to predict and locate its centre (a sphere's
    /// fit needs 4), and are refused beside point samples (whose pose their
    /// own readings locate), each error naming what fails.
    #[test]
    fn reference_touches_are_refused_where_they_cannot_serve() {
        let machine = delta();
        let (delta, configured, truth) = &machine;
        let centre = Vector3::new(40.0, -25.0, 6.0);
        let ball = Observations {
            balls: vec![Ball::new(12.7, None)],
            touches: touches(&machine, centre, 12.7, 8, || 0.0),
            ..Default::default()
        };
        let said = |observations: &Observations, reference| {
            (predict(
                delta,
                truth,
                configured.as_slice(),
                observations,
                Some(reference),
            ))
            .unwrap_err()
            .to_string()
        };
        let all = said(&ball, 8);
        assert!(
            all.contains("ball 0")
                && all.contains("none is left to predict after the 8 reference touches"),
            "{all}"
        );
        let two = said(&ball, 2);
        assert!(
            two.starts_with("ball 0: its touches do not locate its centre"),
            "{two}"
        );
        let tracker = tracked(&machine, &Isometry3::identity(), 4, || 0.0);
        let none = said(&tracker, 4);
        assert!(
            none.starts_with("tracker 0 (tracker points 0-3): it has 4 held-out points and 0 poses: none is left to predict"),
            "{none}"
        );
        let sample = PointSample {
            readings: vec![0.0; 3],
            sigma: 0.01,
            known_pose: Some(([0.0, 0.0, 20.0], [0.01; 3])),
            loads: None,
        };
        let sampled = Observations {
            samples: vec![sample],
            ..ball
        };
        let beside = said(&sampled, 4);
        assert!(beside.contains("a point sample's pose"), "{beside}");
    }

    /// A tracker's frame located by its first 4 points: its other points'
    /// rows, each named by its point and coordinate, zero at the truth
    /// when exact, `G` against central differences; of noisy points, `T =
    /// r'ᵀ D⁻¹ r'` over 200 placements of 8 points (2400 rows) has the
    /// mean of its `χ²` within 4 standard errors.
    #[test]
    fn a_tracker_located_by_reference_points_predicts_the_others() {
        let machine = delta();
        let frame = far_frame();
        let observations = tracked(&machine, &frame, 7, || 0.0);
        let at = ball_rows(&machine, &machine.2, &observations, Some(4));
        assert_eq!(at.residuals.len(), 3 * 3);
        assert!(at.residuals.amax() < 1e-9, "{}", at.residuals);
        let point = |index| ObservationRef {
            kind: ObservationKind::TrackerPoint,
            index,
        };
        assert_eq!(at.row_observations[0], (point(4), 0));
        assert_eq!(at.row_observations[8], (point(6), 2));
        assert_derivatives_match_differences(&machine, &observations, Some(4), &at);
        let mut noise = Rng::new(43, 0);
        let sets = (0..200).map(|draw| {
            let frame = placement(draw);
            tracked(&machine, &frame, 8, || noise.normal(1.0))
        });
        assert_rows_have_their_stated_noise("a tracker's rows from 4", &machine, Some(4), sets);
    }

    /// A held-out ball of more touches than its bound is named before any
    /// touch is evaluated.
    #[test]
    fn a_ball_of_too_many_touches_is_named() {
        let (delta, configured, truth) = delta();
        let touch = BallTouch::new(1, Actuation::Commanded([0.0; 3]), 0.01);
        let ball = Ball::new(12.7, None);
        let observations = Observations {
            balls: vec![ball; 2],
            touches: vec![touch; MAX_HELD_OUT_TOUCHES_PER_BALL + 1],
            ..Default::default()
        };
        let error =
            predict(&delta, &truth, configured.as_slice(), &observations, None).unwrap_err();
        let said = error.to_string();
        assert!(
            said.starts_with("ball 1: its 1001 held-out touches"),
            "{said}"
        );
    }
}
