//! Forward kinematics of up to four contacts at once, one per SIMD lane
//! (four `f64` in an AVX register): the Newton iteration
//! of [`forward_in_place`], its legs, closure LU, solve and step written
//! once for four poses.
//!
//! The lanes run in lockstep: each pass evaluates the legs and factorises
//! the closure Jacobian of all four, and a lane leaves when it converges
//! or takes a step shorter than [`crate::forward::SHORT_STEP`], with the solution the
//! scalar iteration would give (pose, legs, factorisation, step count). A
//! lane that would need the scalar iteration's rarer paths (a step that
//! does not reduce the residual and would be halved, a singular or
//! non-finite factorisation, the iteration limit) is handed to
//! [`forward_in_place`] from its start, which also reports its error, so
//! that every outcome is the scalar one. The closure LU pivots as
//! [`crate::lu6::Lu6`] does, by threshold: the four lanes first try one
//! row order together (the previous factorisation's), and fall back to
//! partial pivoting, each lane picking its own rows, when a lane would
//! pivot on a small entry. The factors can then differ from the scalar
//! code's by rounding; everything else is the same arithmetic in the same
//! order.
//!
//! On a machine without AVX2 (or another architecture), and for a single
//! contact, [`forward_batch`] runs the scalar iteration contact by contact.
//! docs/performance.md gives what the lanes save.

#![allow(
    clippy::needless_range_loop,
    reason = "index arithmetic over legs and matrix entries reads best"
)]

use crate::forward::forward_in_place;
use crate::{ForwardOptions, ForwardSolution, Geometry, KinematicsError};

/// Contacts per call of [`forward_batch`].
pub const LANES: usize = 4;

/// Forward kinematics of up to [`LANES`] contacts: the solution of item
/// `l` (`solution(&mut items[l])`) starts from its `pose` and becomes the
/// solution for actuator values `q[l]`, as [`forward_in_place`] makes it.
/// In SIMD lanes where the machine has AVX2, contact by contact otherwise.
/// An error is that of the first failing contact, with its index; the
/// other solutions are then unspecified.
///
/// # Panics
/// If `q` and `items` differ in length or hold more than [`LANES`]
/// contacts.
pub fn forward_batch<T>(
    geometry: &Geometry,
    q: &[&[f64; 6]],
    options: &ForwardOptions,
    items: &mut [T],
    solution: impl Fn(&mut T) -> &mut ForwardSolution,
) -> Result<(), (usize, KinematicsError)> {
    assert!(
        q.len() == items.len() && q.len() <= LANES,
        "forward_batch takes up to {LANES} contacts, with one item each"
    );
    #[cfg(target_arch = "x86_64")]
    if q.len() > 1 && crate::simd::avx2_available() {
        return avx2::forward(geometry, q, options, items, solution);
    }
    for (l, item) in items.iter_mut().enumerate() {
        forward_in_place(geometry, q[l], options, solution(item)).map_err(|e| (l, e))?;
    }
    Ok(())
}

#[cfg(target_arch = "x86_64")]
mod avx2 {
    use nalgebra::{Quaternion, Translation3, UnitQuaternion};

    use super::LANES;
    use crate::forward::{SHORT_STEP, check_actuators, forward_in_place};
    use crate::lu6::{SINGULAR_PIVOT_RATIO, THRESHOLD};
    use crate::simd::{F64x4, Mask4};
    use crate::{ForwardOptions, ForwardSolution, Geometry, KinematicsError, Pose, Vec3};

    type Lane = F64x4;

    /// Every lane's bit.
    const ALL: u32 = (1 << LANES) - 1;

    /// Four poses: translations and unit quaternions `(i, j, k, w)`.
    #[derive(Clone, Copy)]
    struct Poses {
        translation: [Lane; 3],
        quaternion: [Lane; 4],
    }

    /// Four sets of legs: what [`crate::closure::Legs`] holds, with the closure residuals.
    struct LaneLegs {
        rotation: [[Lane; 3]; 3],
        rotated: [[Lane; 3]; 6],
        direction: [[Lane; 3]; 6],
        length: [Lane; 6],
        residual: [Lane; 6],
    }

    /// Four LU factorisations, packed as in [`crate::lu6::Lu6`] (the diagonal of `U` as
    /// its reciprocal), each lane's row order as lane values `0.0 ..= 5.0`.
    struct LaneLu {
        lu: [[Lane; 6]; 6],
        permutation: [Lane; 6],
        /// Whether a lane's pivots pass [`crate::lu6::Lu6`]'s singularity
        /// test.
        regular: u32,
    }

    /// [`super::forward_batch`] in lanes; the machine has AVX2.
    pub(super) fn forward<T>(
        geometry: &Geometry,
        q: &[&[f64; 6]],
        options: &ForwardOptions,
        items: &mut [T],
        solution: impl Fn(&mut T) -> &mut ForwardSolution,
    ) -> Result<(), (usize, KinematicsError)> {
        let n = q.len();
        let mut errors: [Option<KinematicsError>; LANES] = Default::default();
        for l in 0..n {
            errors[l] = check_actuators(geometry, q[l]).err();
        }
        let feasible = (0..n)
            .filter(|&l| errors[l].is_none())
            .fold(0u32, |m, l| m | 1 << l);
        let starts: [Pose; LANES] =
            std::array::from_fn(|l| solution(&mut items[l.min(n - 1)]).pose);
        // SAFETY: the caller checked that the machine runs AVX2.
        let fallback =
            unsafe { lockstep(geometry, q, options, &starts, feasible, items, &solution) };
        for l in 0..n {
            if fallback & 1 << l != 0 {
                let solution = solution(&mut items[l]);
                solution.pose = starts[l];
                errors[l] = forward_in_place(geometry, q[l], options, solution).err();
            }
        }
        match errors
            .into_iter()
            .enumerate()
            .find_map(|(l, e)| Some((l, e?)))
        {
            Some(failure) => Err(failure),
            None => Ok(()),
        }
    }

    /// The lanes' Newton iteration over the contacts in `active` (a bit per
    /// lane); returns the lanes left to the scalar iteration. Padding lanes
    /// repeat the last contact.
    #[target_feature(enable = "avx2")]
    fn lockstep<T>(
        geometry: &Geometry,
        q: &[&[f64; 6]],
        options: &ForwardOptions,
        starts: &[Pose; LANES],
        mut active: u32,
        items: &mut [T],
        solution: &impl Fn(&mut T) -> &mut ForwardSolution,
    ) -> u32 {
        let n = q.len();
        let target: [Lane; 6] = std::array::from_fn(|i| {
            F64x4::new(std::array::from_fn(|l| {
                geometry.legs[i] + q[l.min(n - 1)][i]
            }))
        });
        let mut trial = solution(&mut items[0]).factor.permutation();
        let mut poses = pack(starts);
        let mut fallback = 0;
        let mut previous = Lane::splat(f64::INFINITY);
        for step_count in 0..=options.max_iterations {
            let legs = evaluate(geometry, &poses, &target);
            let largest = amax(&legs.residual);
            // The scalar iteration would halve this step (or stop on a
            // non-finite residual).
            let halved = !largest.lt(previous).bits() & active;
            fallback |= halved;
            active &= !halved;
            let factor = factorise(&legs_rows(&legs), &mut trial);
            let converged = largest.lt(Lane::splat(options.tolerance)).bits() & active;
            fallback |= converged & !factor.regular;
            unpack(
                converged & factor.regular,
                &poses,
                &legs,
                &factor,
                step_count,
                items,
                solution,
            );
            active &= !converged;
            if step_count == options.max_iterations {
                fallback |= active;
                break;
            }
            fallback |= active & !factor.regular;
            active &= factor.regular;
            if active == 0 {
                break;
            }
            let delta = solve(&factor, &legs.residual.map(|r| -r));
            let stepped = step(&poses, &delta);
            let short = amax(&delta).le(Lane::splat(SHORT_STEP)).bits() & active;
            unpack(
                short,
                &stepped,
                &legs,
                &factor,
                step_count + 1,
                items,
                solution,
            );
            active &= !short;
            if active == 0 {
                break;
            }
            poses = stepped;
            previous = largest;
        }
        fallback
    }

    /// The lane indices whose bits are set in `mask`.
    fn lanes(mask: u32) -> impl Iterator<Item = usize> {
        (0..LANES).filter(move |l| mask & 1 << l != 0)
    }

    /// The starting poses, one per lane.
    #[inline]
    #[target_feature(enable = "avx2")]
    fn pack(poses: &[Pose; LANES]) -> Poses {
        let lane = |f: &dyn Fn(&Pose) -> f64| F64x4::new(std::array::from_fn(|l| f(&poses[l])));
        Poses {
            translation: std::array::from_fn(|c| lane(&|p| p.translation.vector[c])),
            quaternion: std::array::from_fn(|c| lane(&|p| p.rotation.as_ref().coords[c])),
        }
    }

    /// `max_i |x_i|` in each lane (NaN if any entry is NaN, as a non-finite
    /// value must not pass a comparison).
    #[inline]
    #[target_feature(enable = "avx2")]
    fn amax(x: &[Lane; 6]) -> Lane {
        let mut largest = x[0].abs();
        let mut nan = x[0].is_nan();
        for v in &x[1..] {
            largest = largest.max(v.abs());
            nan = nan | v.is_nan();
        }
        nan.select(Lane::splat(f64::NAN), largest)
    }

    /// [`crate::closure::Legs::evaluate`] and
    /// [`crate::closure::Legs::residual`] in lanes, with the rotation matrix
    /// of `UnitQuaternion::to_rotation_matrix`.
    #[inline]
    #[target_feature(enable = "avx2")]
    fn evaluate(geometry: &Geometry, poses: &Poses, target: &[Lane; 6]) -> LaneLegs {
        let [i, j, k, w] = poses.quaternion;
        let two = Lane::splat(2.0);
        let (ww, ii, jj, kk) = (w * w, i * i, j * j, k * k);
        let (ij, wk, wj) = (i * j * two, w * k * two, w * j * two);
        let (ik, jk, wi) = (i * k * two, j * k * two, w * i * two);
        let rotation = [
            [ww + ii - jj - kk, ij - wk, wj + ik],
            [wk + ij, ww - ii + jj - kk, jk - wi],
            [ik - wj, wi + jk, ww - ii - jj + kk],
        ];
        let t = poses.translation;
        let mut legs = LaneLegs {
            rotation,
            rotated: [[Lane::splat(0.0); 3]; 6],
            direction: [[Lane::splat(0.0); 3]; 6],
            length: [Lane::splat(0.0); 6],
            residual: [Lane::splat(0.0); 6],
        };
        for leg in 0..6 {
            let e = geometry.platform[leg];
            let (ex, ey, ez) = (Lane::splat(e.x), Lane::splat(e.y), Lane::splat(e.z));
            let a: [Lane; 3] = std::array::from_fn(|r| {
                rotation[r][0] * ex + rotation[r][1] * ey + rotation[r][2] * ez
            });
            let d: [Lane; 3] =
                std::array::from_fn(|r| a[r] + t[r] - Lane::splat(geometry.base[leg][r]));
            let length = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
            let inverse = Lane::splat(1.0) / length;
            legs.rotated[leg] = a;
            legs.direction[leg] = d.map(|v| v * inverse);
            legs.length[leg] = length;
            legs.residual[leg] = length - target[leg];
        }
        legs
    }

    /// [`crate::closure::Legs::closure_rows`] in lanes: row `i` is
    /// `[n_i^T, (a_i x n_i)^T]`.
    #[inline]
    #[target_feature(enable = "avx2")]
    fn legs_rows(legs: &LaneLegs) -> [[Lane; 6]; 6] {
        std::array::from_fn(|leg| {
            let [nx, ny, nz] = legs.direction[leg];
            let [ax, ay, az] = legs.rotated[leg];
            [
                nx,
                ny,
                nz,
                ay * nz - az * ny,
                az * nx - ax * nz,
                ax * ny - ay * nx,
            ]
        })
    }

    /// The LU factorisation of each lane's matrix (rows `rows`), as
    /// [`crate::lu6::Lu6::factor_in_place`] makes it: the rows are first
    /// tried in the order `trial`, common to the lanes (no exchange), kept if
    /// every lane passes the threshold test; otherwise partial pivoting, each
    /// lane picking its own pivot rows by selects, and `trial` becomes lane
    /// 0's order. Then [`crate::lu6::Lu6`]'s singularity test per lane. One
    /// call per column, with compile-time indices, so that the matrices stay
    /// in registers.
    #[inline]
    #[target_feature(enable = "avx2")]
    fn factorise(rows: &[[Lane; 6]; 6], trial: &mut [u8; 6]) -> LaneLu {
        let mut lu: [[Lane; 6]; 6] = std::array::from_fn(|k| rows[usize::from(trial[k])]);
        // Every lane accepted so far.
        let mut accepted = Lane::splat(0.0).eq(Lane::splat(0.0));
        let mut pivots = [
            eliminate_in_order::<0>(&mut lu, &mut accepted),
            eliminate_in_order::<1>(&mut lu, &mut accepted),
            eliminate_in_order::<2>(&mut lu, &mut accepted),
            eliminate_in_order::<3>(&mut lu, &mut accepted),
            eliminate_in_order::<4>(&mut lu, &mut accepted),
            eliminate_in_order::<5>(&mut lu, &mut accepted),
        ];
        let mut permutation = trial.map(|k| Lane::splat(f64::from(k)));
        if accepted.bits() != ALL {
            lu = *rows;
            permutation = std::array::from_fn(|r| Lane::splat(r as f64));
            pivots = [
                eliminate_column::<0>(&mut lu, &mut permutation),
                eliminate_column::<1>(&mut lu, &mut permutation),
                eliminate_column::<2>(&mut lu, &mut permutation),
                eliminate_column::<3>(&mut lu, &mut permutation),
                eliminate_column::<4>(&mut lu, &mut permutation),
                eliminate_column::<5>(&mut lu, &mut permutation),
            ];
            *trial = permutation.map(|r| r.as_array()[0] as u8);
        }
        let mut smallest = pivots[0].abs();
        let mut largest = pivots[0].abs();
        let mut finite = pivots[0].is_finite();
        for pivot in &pivots[1..] {
            smallest = smallest.min(pivot.abs());
            largest = largest.max(pivot.abs());
            finite = finite & pivot.is_finite();
        }
        let regular = finite & smallest.gt(Lane::splat(SINGULAR_PIVOT_RATIO) * largest);
        LaneLu {
            lu,
            permutation,
            regular: regular.bits(),
        }
    }

    /// Step `K` of [`factorise`] in the trial order: row `K` is the pivot
    /// row; clears a lane of `accepted` where its pivot is below
    /// [`THRESHOLD`] times the largest entry under it (or NaN). Returns the
    /// pivot.
    #[inline]
    #[target_feature(enable = "avx2")]
    fn eliminate_in_order<const K: usize>(lu: &mut [[Lane; 6]; 6], accepted: &mut Mask4) -> Lane {
        let mut below = Lane::splat(0.0);
        for row in &lu[K + 1..] {
            below = below.max(row[K].abs());
        }
        let pivot = lu[K][K];
        *accepted = *accepted & pivot.abs().ge(Lane::splat(THRESHOLD) * below);
        eliminate_below::<K>(lu, pivot);
        pivot
    }

    /// Step `K` of [`factorise`] with partial pivoting: the pivot row chosen
    /// and exchanged in each lane, column `K` eliminated below it; returns
    /// the pivot.
    #[inline]
    #[target_feature(enable = "avx2")]
    fn eliminate_column<const K: usize>(
        lu: &mut [[Lane; 6]; 6],
        permutation: &mut [Lane; 6],
    ) -> Lane {
        let mut best = lu[K][K].abs();
        let mut pivot_row = Lane::splat(K as f64);
        for r in K + 1..6 {
            let candidate = lu[r][K].abs();
            let better = candidate.gt(best);
            best = better.select(candidate, best);
            pivot_row = better.select(Lane::splat(r as f64), pivot_row);
        }
        for r in K + 1..6 {
            let exchange = pivot_row.eq(Lane::splat(r as f64));
            for c in 0..6 {
                let (top, other) = (lu[K][c], lu[r][c]);
                lu[K][c] = exchange.select(other, top);
                lu[r][c] = exchange.select(top, other);
            }
            let (top, other) = (permutation[K], permutation[r]);
            permutation[K] = exchange.select(other, top);
            permutation[r] = exchange.select(top, other);
        }
        let pivot = lu[K][K];
        eliminate_below::<K>(lu, pivot);
        pivot
    }

    /// Column `K` eliminated below the pivot row `K`; the pivot stored as
    /// its reciprocal (zero for a zero pivot, refused later).
    #[inline]
    #[target_feature(enable = "avx2")]
    fn eliminate_below<const K: usize>(lu: &mut [[Lane; 6]; 6], pivot: Lane) {
        let inverse = pivot
            .eq(Lane::splat(0.0))
            .select(Lane::splat(0.0), Lane::splat(1.0) / pivot);
        lu[K][K] = inverse;
        for r in K + 1..6 {
            let factor = lu[r][K] * inverse;
            lu[r][K] = factor;
            for c in K + 1..6 {
                lu[r][c] -= factor * lu[K][c];
            }
        }
    }

    /// [`crate::lu6::Lu6::solve`] in lanes.
    #[inline]
    #[target_feature(enable = "avx2")]
    fn solve(factor: &LaneLu, b: &[Lane; 6]) -> [Lane; 6] {
        let lu = &factor.lu;
        let mut x = [Lane::splat(0.0); 6];
        for i in 0..6 {
            let mut permuted = b[0];
            for r in 1..6 {
                let pick = factor.permutation[i].eq(Lane::splat(r as f64));
                permuted = pick.select(b[r], permuted);
            }
            let mut sum = Lane::splat(0.0);
            for j in 0..i {
                sum += lu[i][j] * x[j];
            }
            x[i] = permuted - sum;
        }
        for i in (0..6).rev() {
            let mut sum = Lane::splat(0.0);
            for j in i + 1..6 {
                sum += lu[i][j] * x[j];
            }
            x[i] = (x[i] - sum) * lu[i][i];
        }
        x
    }

    /// [`crate::forward::step`] with scale 1 in lanes: `t <- t + dt`, `R <-
    /// rot(w) R` by the Cayley quaternion `(1, w/2)`, normalised.
    #[inline]
    #[target_feature(enable = "avx2")]
    fn step(poses: &Poses, delta: &[Lane; 6]) -> Poses {
        let translation = std::array::from_fn(|c| poses.translation[c] + delta[c]);
        let half = Lane::splat(0.5);
        let (x, y, z) = (half * delta[3], half * delta[4], half * delta[5]);
        let [i, j, k, w] = poses.quaternion;
        // `(x, y, z, 1) * (i, j, k, w)` as nalgebra's quaternion product.
        let product = [
            i + x * w + y * k - z * j,
            j - x * k + y * w + z * i,
            k + x * j - y * i + z * w,
            w - x * i - y * j - z * k,
        ];
        let norm = product
            .iter()
            .fold(Lane::splat(0.0), |s, v| s + *v * *v)
            .sqrt();
        Poses {
            translation,
            quaternion: product.map(|v| v / norm),
        }
    }

    /// Writes the lanes in `finished` (a bit per lane) into their solutions,
    /// number by number (no lane structure is copied).
    #[inline]
    #[target_feature(enable = "avx2")]
    fn unpack<T>(
        finished: u32,
        poses: &Poses,
        legs: &LaneLegs,
        factor: &LaneLu,
        iterations: usize,
        items: &mut [T],
        solution: &impl Fn(&mut T) -> &mut ForwardSolution,
    ) {
        for l in lanes(finished) {
            let at = |v: &Lane| v.as_array()[l];
            let vec = |v: &[Lane; 3]| Vec3::new(at(&v[0]), at(&v[1]), at(&v[2]));
            let [i, j, k, w] = poses.quaternion.each_ref().map(at);
            let solution = solution(&mut items[l]);
            solution.pose = Pose::from_parts(
                Translation3::from(vec(&poses.translation)),
                UnitQuaternion::new_unchecked(Quaternion::new(w, i, j, k)),
            );
            let out = &mut solution.legs;
            for r in 0..3 {
                for c in 0..3 {
                    out.rotation[(r, c)] = at(&legs.rotation[r][c]);
                }
            }
            for leg in 0..6 {
                out.rotated[leg] = vec(&legs.rotated[leg]);
                out.direction[leg] = vec(&legs.direction[leg]);
                out.length[leg] = at(&legs.length[leg]);
            }
            let (lu, permutation) = solution.factor.factors_mut();
            for r in 0..6 {
                for c in 0..6 {
                    lu[r][c] = at(&factor.lu[r][c]);
                }
                permutation[r] = at(&factor.permutation[r]) as u8;
            }
            solution.iterations = iterations;
        }
    }
}
