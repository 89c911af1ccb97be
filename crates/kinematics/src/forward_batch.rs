//! Forward kinematics of up to eight contacts at once, one per SIMD lane
//! (eight `f64` in an AVX-512 register, or four in an AVX2 register, the
//! contacts four at a time): the Newton iteration of [`forward_in_place`],
//! its legs, closure LU, solve and step written once for all the lanes.
//!
//! The lanes run in lockstep: each pass evaluates the legs and factorises
//! the closure Jacobian of every lane, and a lane leaves when it converges
//! or takes a step shorter than [`crate::forward::SHORT_STEP`], with the solution the
//! scalar iteration would give (pose, legs, factorisation, step count). A
//! lane that would need the scalar iteration's rarer paths (a step that
//! does not reduce the residual and would be halved, a singular or
//! non-finite factorisation, the iteration limit) is handed to
//! [`forward_in_place`] from its start, which also reports its error, so
//! that every outcome is the scalar one. The closure LU pivots as
//! [`crate::lu6::Lu6`] does, by threshold: the lanes first try one
//! row order together (an earlier factorisation's), and fall back to
//! partial pivoting, each lane picking its own rows, when a lane would
//! pivot on a small entry. The factors can then differ from the scalar
//! code's by rounding; everything else is the same arithmetic in the same
//! order.
//!
//! A calibration needs of each solution only products with the tip
//! Jacobian `J_f`, and the lanes make them as each lane finishes, from the
//! lanes' own factorisation, so that the factors are never written back:
//! [`forward_jacobian_batch`] leaves `J_f` in factored form
//! ([`crate::FactoredTipJacobian`]: `K = P A^-1` from three transposed
//! solves, `R` and the leg directions; what an elimination's row
//! combinations need), [`forward_along_batch`] the first-order change along
//! a parameter step ([`crate::TipDerivatives::along`]: what a
//! back-substitution needs). The caller carries the row order the lanes try
//! first from call to call ([`PivotOrder`]).
//!
//! One source makes the kernels of both widths (`lane_kernels!`): the
//! lanes of an AVX-512 register where the machine has AVX-512F and a call
//! has more than four contacts, else those of an AVX2 register. The
//! results then depend on the machine by rounding, as the row order tried
//! first is shared by the contacts of one kernel call. On a machine
//! without AVX2 (or another architecture), and for a single contact, each
//! function runs the scalar code contact by contact.
//! `cargo bench -p parcal-benches --bench kinematics` compares the two
//! (docs/performance.md).

#![allow(
    clippy::needless_range_loop,
    reason = "index arithmetic over legs and matrix entries reads best"
)]

use std::ops::Range;

use crate::derivatives::{SolutionAlong, SolutionJacobian, SolutionRoom, TipDerivatives};
use crate::forward::forward_in_place;
use crate::lu6::Lu6;
use crate::{ForwardOptions, ForwardSolution, Geometry, KinematicsError, Params, Pose};

/// Contacts per call of the functions of this module: the lanes of an
/// AVX-512 register.
pub const LANES: usize = 8;

/// Forward kinematics of up to [`LANES`] contacts: the solution of item
/// `l` (`solution(&mut items[l])`) starts from its `pose` and becomes the
/// solution for actuator values `q[l]`, as [`forward_in_place`] makes it.
/// In SIMD lanes where the machine has AVX2 (module doc), contact by
/// contact otherwise.
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
    forward_in(
        Lanes::for_call(q.len()),
        geometry,
        q,
        options,
        items,
        &solution,
    )
}

/// [`forward_batch`] in the kernels `width`.
fn forward_in<T>(
    width: Option<Lanes>,
    geometry: &Geometry,
    q: &[&[f64; 6]],
    options: &ForwardOptions,
    items: &mut [T],
    solution: &impl Fn(&mut T) -> &mut ForwardSolution,
) -> Result<(), (usize, KinematicsError)> {
    let scalar = |l: usize, item: &mut T| forward_in_place(geometry, q[l], options, solution(item));
    match width {
        #[cfg(target_arch = "x86_64")]
        Some(Lanes::Eight) => avx512::forward(geometry, q, options, items, solution),
        #[cfg(target_arch = "x86_64")]
        Some(Lanes::Four) => in_fours(items, scalar, |group, items| {
            avx2::forward(geometry, &q[group], options, items, solution)
        }),
        None => one_by_one(items, scalar),
    }
}

/// [`TipDerivatives::forward`] of up to [`LANES`] contacts at once
/// ([`forward_batch`]): `items[l]` solved for actuator values `q[l]` from
/// `starts[l]`, in place, each left at its solution with its tool offset.
/// The lanes first try the row order of `items[0]`'s last factorisation.
/// An error is that of the first failing contact, with its index; the
/// other items are then unspecified.
///
/// # Panics
/// If `q`, `starts` and `items` differ in length or hold more than
/// [`LANES`] contacts.
pub fn forward_derivatives_batch(
    geometry: &Geometry,
    q: &[&[f64; 6]],
    starts: &[Pose],
    options: &ForwardOptions,
    items: &mut [TipDerivatives],
) -> Result<(), (usize, KinematicsError)> {
    assert_eq!(starts.len(), items.len(), "one start per contact");
    for (item, start) in items.iter_mut().zip(starts) {
        item.solution.pose = *start;
    }
    forward_batch(geometry, q, options, items, |item| &mut item.solution)?;
    for item in items.iter_mut() {
        item.tool = TipDerivatives::tool_at(geometry, &item.solution);
    }
    Ok(())
}

/// The row order in which the lanes first try to factorise the closure
/// Jacobians ([`crate::lu6::Lu6`]'s threshold pivoting, shared by the
/// lanes): the order of an earlier factorisation, carried from one call to
/// the next by the caller ([`forward_jacobian_batch`] and
/// [`forward_along_batch`] keep no factorisation). The default is the
/// identity, which the threshold test refuses for a hexapod's closure
/// Jacobian: the first call pivots partially, and its order is kept.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PivotOrder([u8; 6]);

impl Default for PivotOrder {
    fn default() -> Self {
        Self([0, 1, 2, 3, 4, 5])
    }
}

impl PivotOrder {
    /// The row order of `factor`: where lanes whose matrices are near its
    /// matrix first try to factorise theirs.
    pub fn of(factor: &Lu6) -> Self {
        Self(factor.permutation())
    }
}

/// Forward kinematics of up to [`LANES`] contacts from `starts`, as
/// [`forward_batch`] runs it, and at each solution the first-order change
/// along the parameter direction `dp` ([`SolutionAlong`], what
/// [`SolutionAlong::solve`] gives), without keeping the derivatives: in SIMD
/// lanes where the machine has AVX2 (module doc), contact by contact
/// otherwise. `trial`
/// is the row order the lanes try first, updated for the next call. An
/// error is that of the first failing contact, with its index; the other
/// outputs are then unspecified.
///
/// # Panics
/// If `q`, `starts` and `out` differ in length or hold more than [`LANES`]
/// contacts.
pub fn forward_along_batch(
    geometry: &Geometry,
    q: &[&[f64; 6]],
    starts: &[Pose],
    dp: &Params,
    options: &ForwardOptions,
    trial: &mut PivotOrder,
    out: &mut [SolutionAlong],
) -> Result<(), (usize, KinematicsError)> {
    assert!(
        q.len() == starts.len() && q.len() == out.len() && q.len() <= LANES,
        "forward_along_batch takes up to {LANES} contacts, with a start and an output each"
    );
    let width = Lanes::for_call(q.len());
    along_in(width, geometry, q, starts, dp, options, trial, out)
}

/// [`forward_along_batch`] in the kernels `width`.
#[allow(clippy::too_many_arguments)]
#[cfg_attr(
    not(target_arch = "x86_64"),
    allow(unused_variables, reason = "`trial` serves the lanes only")
)]
fn along_in(
    width: Option<Lanes>,
    geometry: &Geometry,
    q: &[&[f64; 6]],
    starts: &[Pose],
    dp: &Params,
    options: &ForwardOptions,
    trial: &mut PivotOrder,
    out: &mut [SolutionAlong],
) -> Result<(), (usize, KinematicsError)> {
    let scalar = |l: usize, start: &Pose, out: &mut SolutionAlong| {
        *out = SolutionAlong::solve(geometry, q[l], start, dp, options)?;
        Ok(())
    };
    from_starts(width, starts, out, &scalar, |lanes, group, out, scalar| {
        let (q, starts) = (&q[group.clone()], &starts[group]);
        match lanes {
            #[cfg(target_arch = "x86_64")]
            Lanes::Eight => {
                avx512::forward_along(geometry, q, starts, dp, options, trial, out, scalar)
            }
            #[cfg(target_arch = "x86_64")]
            Lanes::Four => {
                avx2::forward_along(geometry, q, starts, dp, options, trial, out, scalar)
            }
        }
    })
}

/// Forward kinematics of up to [`LANES`] contacts from `starts`, as
/// [`forward_batch`] runs it, and at each solution `J_f` in factored form
/// (what [`SolutionJacobian::solve`] gives): the solution for `q[l]`
/// written where `solution(&mut items[l])` keeps it ([`SolutionRoom`], such
/// as a [`SolutionJacobian`]), the lanes' `J_f` straight into its room. In
/// SIMD lanes where the machine has AVX2 (module doc), contact by contact
/// otherwise. `trial` is the row order the lanes try first, updated for the
/// next call. An error is that
/// of the first failing contact, with its index; the other outputs are
/// then unspecified.
///
/// # Panics
/// If `q`, `starts` and `items` differ in length or hold more than
/// [`LANES`] contacts.
pub fn forward_jacobian_batch<T, R: SolutionRoom + ?Sized>(
    geometry: &Geometry,
    q: &[&[f64; 6]],
    starts: &[Pose],
    options: &ForwardOptions,
    trial: &mut PivotOrder,
    items: &mut [T],
    solution: impl Fn(&mut T) -> &mut R,
) -> Result<(), (usize, KinematicsError)> {
    assert!(
        q.len() == starts.len() && q.len() == items.len() && q.len() <= LANES,
        "forward_jacobian_batch takes up to {LANES} contacts, with a start and an item each"
    );
    let width = Lanes::for_call(q.len());
    jacobian_in(width, geometry, q, starts, options, trial, items, &solution)
}

/// [`forward_jacobian_batch`] in the kernels `width`.
#[allow(clippy::too_many_arguments)]
#[cfg_attr(
    not(target_arch = "x86_64"),
    allow(unused_variables, reason = "`trial` serves the lanes only")
)]
fn jacobian_in<T, R: SolutionRoom + ?Sized>(
    width: Option<Lanes>,
    geometry: &Geometry,
    q: &[&[f64; 6]],
    starts: &[Pose],
    options: &ForwardOptions,
    trial: &mut PivotOrder,
    items: &mut [T],
    solution: &impl Fn(&mut T) -> &mut R,
) -> Result<(), (usize, KinematicsError)> {
    let scalar = |l: usize, start: &Pose, item: &mut T| {
        let solved = SolutionJacobian::solve(geometry, q[l], start, options)?;
        *solution(item).solved(&solved.pose, &solved.tool_tip, solved.iterations) = solved.jacobian;
        Ok(())
    };
    from_starts(
        width,
        starts,
        items,
        &scalar,
        |lanes, group, items, scalar| {
            let (q, starts) = (&q[group.clone()], &starts[group]);
            match lanes {
                #[cfg(target_arch = "x86_64")]
                Lanes::Eight => avx512::forward_jacobian(
                    geometry, q, starts, options, trial, items, solution, scalar,
                ),
                #[cfg(target_arch = "x86_64")]
                Lanes::Four => avx2::forward_jacobian(
                    geometry, q, starts, options, trial, items, solution, scalar,
                ),
            }
        },
    )
}

/// The SIMD kernels that run a call (module doc); none: the scalar code,
/// contact by contact.
#[derive(Clone, Copy, Debug)]
enum Lanes {
    /// AVX-512's eight lanes, the call's contacts at once.
    #[cfg(target_arch = "x86_64")]
    Eight,
    /// AVX2's four lanes, the call's contacts four at a time
    /// ([`in_fours`]).
    #[cfg(target_arch = "x86_64")]
    Four,
}

impl Lanes {
    /// The widest kernels of this machine for a call of `n` contacts:
    /// AVX-512's for more than four, AVX2's for two to four (or more,
    /// without AVX-512); none for one contact or without AVX2.
    fn for_call(n: usize) -> Option<Self> {
        #[cfg(target_arch = "x86_64")]
        if n > 1 && crate::simd::avx2_available() {
            return Some(if n > avx2::LANES && crate::simd::avx512_available() {
                Self::Eight
            } else {
                Self::Four
            });
        }
        let _ = n;
        None
    }
}

/// `run` on the contacts `0..n` in groups of `size` (the last one
/// shorter), in order, up to the first error, returned with its index
/// among the `n`.
pub fn in_groups(
    n: usize,
    size: usize,
    mut run: impl FnMut(Range<usize>) -> Result<(), (usize, KinematicsError)>,
) -> Result<(), (usize, KinematicsError)> {
    for first in (0..n).step_by(size) {
        run(first..(first + size).min(n)).map_err(|(l, e)| (first + l, e))?;
    }
    Ok(())
}

/// The one-contact solver of a call: contact `l` from `start` into its
/// item, its index among the call's contacts.
type Scalar<'a, T> = &'a dyn Fn(usize, &Pose, &mut T) -> Result<(), KinematicsError>;

/// A call of the contacts of `items`, contact `l` from `starts[l]`, in the
/// kernels `width`: `lanes(kernels, group, items, scalar)` runs the
/// contacts `group` (all of them in AVX-512's lanes, four at a time in
/// AVX2's) and hands a lane it leaves to `scalar`, as a group of one
/// contact and the scalar path go.
fn from_starts<T>(
    width: Option<Lanes>,
    starts: &[Pose],
    items: &mut [T],
    scalar: Scalar<'_, T>,
    mut lanes: impl FnMut(
        Lanes,
        Range<usize>,
        &mut [T],
        Scalar<'_, T>,
    ) -> Result<(), (usize, KinematicsError)>,
) -> Result<(), (usize, KinematicsError)> {
    let one = |l: usize, item: &mut T| scalar(l, &starts[l], item);
    match width {
        #[cfg(target_arch = "x86_64")]
        Some(Lanes::Eight) => lanes(Lanes::Eight, 0..items.len(), items, scalar),
        #[cfg(target_arch = "x86_64")]
        Some(Lanes::Four) => in_fours(items, one, |group, items| {
            let first = group.start;
            lanes(Lanes::Four, group, items, &|l, start, item| {
                scalar(first + l, start, item)
            })
        }),
        None => one_by_one(items, one),
    }
}

/// The contacts of `items` four at a time: `lanes(group, items)` on a
/// group of several (the contacts' range and their items), `scalar(l,
/// item)` on a group of one; the first error, with its index.
#[cfg(target_arch = "x86_64")]
fn in_fours<T>(
    items: &mut [T],
    mut scalar: impl FnMut(usize, &mut T) -> Result<(), KinematicsError>,
    mut lanes: impl FnMut(Range<usize>, &mut [T]) -> Result<(), (usize, KinematicsError)>,
) -> Result<(), (usize, KinematicsError)> {
    in_groups(items.len(), avx2::LANES, |group| match group.len() {
        1 => scalar(group.start, &mut items[group.start]).map_err(|e| (0, e)),
        _ => lanes(group.clone(), &mut items[group]),
    })
}

/// The scalar path of this module's functions: `solve(l, item)` contact
/// by contact, up to the first error, returned with its index.
fn one_by_one<T>(
    items: &mut [T],
    mut solve: impl FnMut(usize, &mut T) -> Result<(), KinematicsError>,
) -> Result<(), (usize, KinematicsError)> {
    for (l, item) in items.iter_mut().enumerate() {
        solve(l, item).map_err(|e| (l, e))?;
    }
    Ok(())
}

/// The lane kernels of one SIMD width, as module `$module`: `$width`
/// contacts in the lanes of `$lane` (comparisons `$mask`), compiled for the
/// target feature `$feature`. The same code for every width, so that each
/// lane is the same arithmetic.
macro_rules! lane_kernels {
    ($module:ident, $lane:ident, $mask:ident, $width:literal, $feature:literal) => {
        #[allow(unsafe_code, reason = "the SIMD kernels and their dispatch")]
        mod $module {
            use nalgebra::{Matrix3, Quaternion, Translation3, UnitQuaternion};

            use super::PivotOrder;
            use crate::derivatives::{SolutionAlong, SolutionRoom};
            use crate::forward::{SHORT_STEP, forward_in_place};
            use crate::lu6::{SINGULAR_PIVOT_RATIO, THRESHOLD};
            use crate::params::{BASE_INDEX, PLATFORM_INDEX, TOOL_OFFSET, leg_index};
            use crate::simd::{$lane, $mask};
            use crate::{
                ForwardOptions, ForwardSolution, Geometry, KinematicsError, Params, Pose, Vec3,
            };

            type Lane = $lane;
            type Mask = $mask;

            /// Contacts per call: one per lane.
            pub(in crate::forward_batch) const LANES: usize = $width;

            /// Every lane's bit.
            const ALL: u32 = (1 << LANES) - 1;

            /// The lanes' poses: translations and unit quaternions `(i, j, k, w)`.
            #[derive(Clone, Copy)]
            struct Poses {
                translation: [Lane; 3],
                quaternion: [Lane; 4],
            }

            /// The lanes' legs: what [`crate::closure::Legs`] holds, with the closure residuals.
            struct LaneLegs {
                rotation: [[Lane; 3]; 3],
                rotated: [[Lane; 3]; 6],
                direction: [[Lane; 3]; 6],
                length: [Lane; 6],
                residual: [Lane; 6],
            }

            /// The lanes' LU factorisations, packed as in [`crate::lu6::Lu6`] (the diagonal of `U` as
            /// its reciprocal), each lane's row order as lane values `0.0 ..= 5.0`.
            struct LaneLu {
                lu: [[Lane; 6]; 6],
                permutation: [Lane; 6],
                /// Whether a lane's pivots pass [`crate::lu6::Lu6`]'s singularity
                /// test.
                regular: u32,
            }

            /// Lanes leaving the iteration (the bits of `mask`) with their solution:
            /// the pose, and the legs and factorisation it was reached with.
            struct Finishing<'a> {
                mask: u32,
                poses: &'a Poses,
                legs: &'a LaneLegs,
                factor: &'a LaneLu,
                /// Newton steps taken.
                iterations: usize,
            }

            impl Finishing<'_> {
                /// The indices of the lanes leaving.
                fn lanes(&self) -> impl Iterator<Item = usize> {
                    lanes(self.mask)
                }
            }

            /// [`super::forward_batch`] in lanes; the machine runs `$feature` code. The rows are
            /// first tried in the order of item 0's last factorisation.
            pub(super) fn forward<T>(
                geometry: &Geometry,
                q: &[&[f64; 6]],
                options: &ForwardOptions,
                items: &mut [T],
                solution: impl Fn(&mut T) -> &mut ForwardSolution,
            ) -> Result<(), (usize, KinematicsError)> {
                let n = q.len();
                let starts: [Pose; LANES] =
                    std::array::from_fn(|l| solution(&mut items[l.min(n - 1)]).pose);
                let mut trial = solution(&mut items[0]).factor.permutation();
                let lanes = |starts: &_, feasible, items: &mut [T]| {
                    let mut finish = |lanes: &Finishing| unpack(lanes, items, &solution);
                    let trial = &mut trial;
                    // SAFETY: the caller checked that the machine runs `$feature` code.
                    unsafe { lockstep(geometry, q, options, starts, feasible, trial, &mut finish) }
                };
                let scalar = |l: usize, start: &Pose, item: &mut T| {
                    let solution = solution(item);
                    solution.pose = *start;
                    forward_in_place(geometry, q[l], options, solution)
                };
                run(q, &starts[..n], items, lanes, scalar)
            }

            /// [`super::forward_along_batch`] in lanes, `scalar` its contact by
            /// contact path; the machine runs `$feature` code.
            #[allow(clippy::too_many_arguments)]
            pub(super) fn forward_along(
                geometry: &Geometry,
                q: &[&[f64; 6]],
                starts: &[Pose],
                dp: &Params,
                options: &ForwardOptions,
                trial: &mut PivotOrder,
                out: &mut [SolutionAlong],
                scalar: impl FnMut(usize, &Pose, &mut SolutionAlong) -> Result<(), KinematicsError>,
            ) -> Result<(), (usize, KinematicsError)> {
                let trial = &mut trial.0;
                let lanes = |starts: &_, feasible, out: &mut [SolutionAlong]| {
                    // SAFETY: the caller checked that the machine runs `$feature` code.
                    unsafe {
                        along_lockstep(geometry, q, options, starts, feasible, dp, trial, out)
                    }
                };
                run(q, starts, out, lanes, scalar)
            }

            /// [`super::forward_jacobian_batch`] in lanes, `scalar` its contact by
            /// contact path; the machine runs `$feature` code.
            #[allow(clippy::too_many_arguments)]
            pub(super) fn forward_jacobian<T, R: SolutionRoom + ?Sized>(
                geometry: &Geometry,
                q: &[&[f64; 6]],
                starts: &[Pose],
                options: &ForwardOptions,
                trial: &mut PivotOrder,
                items: &mut [T],
                solution: &impl Fn(&mut T) -> &mut R,
                scalar: impl FnMut(usize, &Pose, &mut T) -> Result<(), KinematicsError>,
            ) -> Result<(), (usize, KinematicsError)> {
                let trial = &mut trial.0;
                let lanes = |starts: &_, feasible, items: &mut [T]| {
                    // SAFETY: the caller checked that the machine runs `$feature` code.
                    unsafe {
                        jacobian_lockstep(
                            geometry, q, options, starts, feasible, trial, items, solution,
                        )
                    }
                };
                run(q, starts, items, lanes, scalar)
            }

            /// The lanes' Newton iteration ([`lockstep`]), each lane's solution and
            /// `J_f` in factored form ([`closure_weights`]) written into its item
            /// as it finishes; returns the lanes left to the scalar path.
            #[allow(clippy::too_many_arguments)]
            #[target_feature(enable = $feature)]
            fn jacobian_lockstep<T, R: SolutionRoom + ?Sized>(
                geometry: &Geometry,
                q: &[&[f64; 6]],
                options: &ForwardOptions,
                starts: &[Pose; LANES],
                feasible: u32,
                trial: &mut [u8; 6],
                items: &mut [T],
                solution: &impl Fn(&mut T) -> &mut R,
            ) -> u32 {
                let mut finish = |lanes: &Finishing| {
                    let weights = closure_weights(geometry, lanes.legs, lanes.factor);
                    let tool_tips = tool_tips(geometry, lanes.poses);
                    let legs = lanes.legs;
                    let platform = platform_directions(legs);
                    for l in lanes.lanes() {
                        let at = |v: &Lane| v.as_array()[l];
                        let jacobian = solution(&mut items[l]).solved(
                            &pose_of(lanes.poses, l),
                            &vec_of(&tool_tips, l),
                            lanes.iterations,
                        );
                        for r in 0..6 {
                            for a in 0..3 {
                                jacobian.weights[(r, a)] = at(&weights[a][r]);
                            }
                            jacobian.directions[r] = vec_of(&legs.direction[r], l);
                            jacobian.platform_directions[r] = vec_of(&platform[r], l);
                        }
                        jacobian.rotation = Matrix3::from_fn(|r, c| at(&legs.rotation[r][c]));
                    }
                };
                lockstep(geometry, q, options, starts, feasible, trial, &mut finish)
            }

            /// The lanes' Newton iteration ([`lockstep`]), each lane's change along
            /// `dp` ([`along`]) written into `out` as it finishes; returns the
            /// lanes left to the scalar path.
            #[allow(clippy::too_many_arguments)]
            #[target_feature(enable = $feature)]
            fn along_lockstep(
                geometry: &Geometry,
                q: &[&[f64; 6]],
                options: &ForwardOptions,
                starts: &[Pose; LANES],
                feasible: u32,
                dp: &Params,
                trial: &mut [u8; 6],
                out: &mut [SolutionAlong],
            ) -> u32 {
                let mut finish = |lanes: &Finishing| {
                    let (delta, tip) = along(geometry, lanes.legs, lanes.factor, dp);
                    let predicted = step(lanes.poses, &delta);
                    let tool_tips = tool_tips(geometry, lanes.poses);
                    for l in lanes.lanes() {
                        out[l] = SolutionAlong {
                            pose: pose_of(lanes.poses, l),
                            predicted: pose_of(&predicted, l),
                            tool_tip: vec_of(&tool_tips, l),
                            tip: vec_of(&tip, l),
                            iterations: lanes.iterations,
                        };
                    }
                };
                lockstep(geometry, q, options, starts, feasible, trial, &mut finish)
            }

            /// `forward_batch` run on the contacts (a bit per lane) from `starts` padded
            /// to [`LANES`] with the last (it returns the lanes it leaves, among
            /// them those with an infeasible actuator value), then `scalar` on
            /// each contact left, from its start: the first error in contact order.
            fn run<T>(
                q: &[&[f64; 6]],
                starts: &[Pose],
                items: &mut [T],
                lanes: impl FnOnce(&[Pose; LANES], u32, &mut [T]) -> u32,
                mut scalar: impl FnMut(usize, &Pose, &mut T) -> Result<(), KinematicsError>,
            ) -> Result<(), (usize, KinematicsError)> {
                let n = q.len();
                // Filled in place: an array made by `from_fn` is moved out whole.
                let mut padded = [Pose::identity(); LANES];
                for (l, pose) in padded.iter_mut().enumerate() {
                    *pose = starts[l.min(n - 1)];
                }
                let fallback = lanes(&padded, (1 << n) - 1, items);
                if fallback == 0 {
                    return Ok(());
                }
                let mut errors: [Option<KinematicsError>; LANES] = Default::default();
                for l in 0..n {
                    if fallback & 1 << l != 0 {
                        errors[l] = scalar(l, &starts[l], &mut items[l]).err();
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
            /// lane) from `starts`, the rows of each factorisation first tried in the
            /// order `trial` (updated as [`factorise`] does): `finish` is handed the
            /// lanes as they finish, and the lanes left to the scalar iteration are
            /// returned, among them any whose actuator values the scalar iteration
            /// refuses (a leg length `l_i + q_i` not finite or not positive,
            /// [`crate::forward::check_actuators`]), so that it reports the error.
            /// Padding lanes repeat the last contact.
            #[inline]
            #[target_feature(enable = $feature)]
            fn lockstep(
                geometry: &Geometry,
                q: &[&[f64; 6]],
                options: &ForwardOptions,
                starts: &[Pose; LANES],
                mut active: u32,
                trial: &mut [u8; 6],
                finish: &mut impl FnMut(&Finishing),
            ) -> u32 {
                let n = q.len();
                let target: [Lane; 6] = std::array::from_fn(|i| {
                    Lane::new(std::array::from_fn(|l| {
                        geometry.legs[i] + q[l.min(n - 1)][i]
                    }))
                });
                let feasible = target.iter().fold(every_lane(), |m, t| {
                    m & t.gt(Lane::splat(0.0)) & t.is_finite()
                });
                let mut fallback = active & !feasible.bits();
                active &= feasible.bits();
                let mut poses = pack(starts);
                let mut previous = Lane::splat(f64::INFINITY);
                for step_count in 0..=options.max_iterations {
                    let legs = evaluate(geometry, &poses, &target);
                    let largest = amax(&legs.residual);
                    // The scalar iteration would halve this step (or stop on a
                    // non-finite residual).
                    let halved = !largest.lt(previous).bits() & active;
                    fallback |= halved;
                    active &= !halved;
                    let factor = factorise(&legs_rows(&legs), trial);
                    let converged = largest.lt(Lane::splat(options.tolerance)).bits() & active;
                    fallback |= converged & !factor.regular;
                    let done = converged & factor.regular;
                    if done != 0 {
                        finish(&Finishing {
                            mask: done,
                            poses: &poses,
                            legs: &legs,
                            factor: &factor,
                            iterations: step_count,
                        });
                    }
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
                    if short != 0 {
                        finish(&Finishing {
                            mask: short,
                            poses: &stepped,
                            legs: &legs,
                            factor: &factor,
                            iterations: step_count + 1,
                        });
                    }
                    active &= !short;
                    if active == 0 {
                        break;
                    }
                    poses = stepped;
                    previous = largest;
                }
                fallback
            }

            /// A mask with every lane set.
            #[inline]
            #[target_feature(enable = $feature)]
            fn every_lane() -> Mask {
                Lane::splat(0.0).eq(Lane::splat(0.0))
            }

            /// The lane indices whose bits are set in `mask`.
            fn lanes(mask: u32) -> impl Iterator<Item = usize> {
                (0..LANES).filter(move |l| mask & 1 << l != 0)
            }

            /// The starting poses, one per lane.
            #[inline]
            #[target_feature(enable = $feature)]
            fn pack(poses: &[Pose; LANES]) -> Poses {
                let lane =
                    |f: &dyn Fn(&Pose) -> f64| Lane::new(std::array::from_fn(|l| f(&poses[l])));
                Poses {
                    translation: std::array::from_fn(|c| lane(&|p| p.translation.vector[c])),
                    quaternion: std::array::from_fn(|c| lane(&|p| p.rotation.as_ref().coords[c])),
                }
            }

            /// `max_i |x_i|` in each lane (NaN if any entry is NaN, as a non-finite
            /// value must not pass a comparison).
            #[inline]
            #[target_feature(enable = $feature)]
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
            #[target_feature(enable = $feature)]
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
                // Each array built by `from_fn`: zeroed first, then filled, they
                // cost a 1 KB `memset` per evaluation.
                let rotated: [[Lane; 3]; 6] = std::array::from_fn(|leg| {
                    let e = geometry.platform[leg];
                    let (ex, ey, ez) = (Lane::splat(e.x), Lane::splat(e.y), Lane::splat(e.z));
                    std::array::from_fn(|r| {
                        rotation[r][0] * ex + rotation[r][1] * ey + rotation[r][2] * ez
                    })
                });
                let d: [[Lane; 3]; 6] = std::array::from_fn(|leg| {
                    std::array::from_fn(|r| {
                        rotated[leg][r] + t[r] - Lane::splat(geometry.base[leg][r])
                    })
                });
                let length: [Lane; 6] = std::array::from_fn(|leg| {
                    (d[leg][0] * d[leg][0] + d[leg][1] * d[leg][1] + d[leg][2] * d[leg][2]).sqrt()
                });
                let direction = std::array::from_fn(|leg| {
                    let inverse = Lane::splat(1.0) / length[leg];
                    d[leg].map(|v| v * inverse)
                });
                LaneLegs {
                    rotation,
                    rotated,
                    direction,
                    length,
                    residual: std::array::from_fn(|leg| length[leg] - target[leg]),
                }
            }

            /// [`crate::closure::Legs::closure_rows`] in lanes: row `i` is
            /// `[n_i^T, (a_i x n_i)^T]`.
            #[inline]
            #[target_feature(enable = $feature)]
            fn legs_rows(legs: &LaneLegs) -> [[Lane; 6]; 6] {
                std::array::from_fn(|leg| {
                    let [nx, ny, nz] = legs.direction[leg];
                    let [mx, my, mz] = cross(&legs.rotated[leg], &legs.direction[leg]);
                    [nx, ny, nz, mx, my, mz]
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
            #[target_feature(enable = $feature)]
            fn factorise(rows: &[[Lane; 6]; 6], trial: &mut [u8; 6]) -> LaneLu {
                let mut lu: [[Lane; 6]; 6] = std::array::from_fn(|k| rows[usize::from(trial[k])]);
                // Every lane accepted so far.
                let mut accepted = every_lane();
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
            #[target_feature(enable = $feature)]
            fn eliminate_in_order<const K: usize>(
                lu: &mut [[Lane; 6]; 6],
                accepted: &mut Mask,
            ) -> Lane {
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
            #[target_feature(enable = $feature)]
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
            #[target_feature(enable = $feature)]
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
            #[target_feature(enable = $feature)]
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

            /// [`crate::lu6::Lu6::solve_transpose`] in lanes.
            #[inline]
            #[target_feature(enable = $feature)]
            fn solve_transpose(factor: &LaneLu, b: &[Lane; 6]) -> [Lane; 6] {
                let lu = &factor.lu;
                let mut z = [Lane::splat(0.0); 6];
                for i in 0..6 {
                    let mut sum = Lane::splat(0.0);
                    for j in 0..i {
                        sum += lu[j][i] * z[j];
                    }
                    z[i] = (b[i] - sum) * lu[i][i];
                }
                for i in (0..6).rev() {
                    let mut sum = Lane::splat(0.0);
                    for j in i + 1..6 {
                        sum += lu[j][i] * z[j];
                    }
                    z[i] -= sum;
                }
                // `x[permutation[k]] = z[k]`.
                std::array::from_fn(|r| {
                    let mut x = z[0];
                    for k in 1..6 {
                        x = factor.permutation[k]
                            .eq(Lane::splat(r as f64))
                            .select(z[k], x);
                    }
                    x
                })
            }

            /// [`crate::TipDerivatives::closure_weights`] of the three base-frame
            /// axes in lanes: `K^T = A^-T P^T` by columns, `P^T e_a = (e_a, R E_T x
            /// e_a)`, at the solutions of `legs` and `factor`
            /// ([`crate::FactoredTipJacobian::weights`]).
            #[inline]
            #[target_feature(enable = $feature)]
            fn closure_weights(
                geometry: &Geometry,
                legs: &LaneLegs,
                factor: &LaneLu,
            ) -> [[Lane; 6]; 3] {
                let rotation = &legs.rotation;
                let e = geometry.tool;
                let (ex, ey, ez) = (Lane::splat(e.x), Lane::splat(e.y), Lane::splat(e.z));
                let tool: [Lane; 3] = std::array::from_fn(|r| {
                    rotation[r][0] * ex + rotation[r][1] * ey + rotation[r][2] * ez
                });
                std::array::from_fn(|axis| {
                    let h: [Lane; 3] =
                        std::array::from_fn(|c| Lane::splat(if c == axis { 1.0 } else { 0.0 }));
                    let m = cross(&tool, &h);
                    solve_transpose(factor, &[h[0], h[1], h[2], m[0], m[1], m[2]])
                })
            }

            /// `a x b`, as nalgebra's `cross`.
            #[inline]
            #[target_feature(enable = $feature)]
            fn cross(a: &[Lane; 3], b: &[Lane; 3]) -> [Lane; 3] {
                [
                    a[1] * b[2] - a[2] * b[1],
                    a[2] * b[0] - a[0] * b[2],
                    a[0] * b[1] - a[1] * b[0],
                ]
            }

            /// [`Geometry::tool_tip`] of each pose in lanes, with nalgebra's
            /// quaternion rotation `v + w t + q x t`, `t = 2 q x v` (`q` the
            /// quaternion's vector part, `w` its scalar), in its order: the
            /// scalar code's bits.
            #[inline]
            #[target_feature(enable = $feature)]
            fn tool_tips(geometry: &Geometry, poses: &Poses) -> [Lane; 3] {
                let [i, j, k, w] = poses.quaternion;
                let v = <[f64; 3]>::from(geometry.tool).map(|x| Lane::splat(x));
                let two = Lane::splat(2.0);
                let t = cross(&[i, j, k], &v).map(|x| x * two);
                let turn = cross(&[i, j, k], &t);
                std::array::from_fn(|r| t[r] * w + turn[r] + v[r] + poses.translation[r])
            }

            /// [`crate::forward::step`] with scale 1 in lanes: `t <- t + dt`, `R <-
            /// rot(w) R` by the Cayley quaternion `(1, w/2)`, normalised.
            #[inline]
            #[target_feature(enable = $feature)]
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

            /// Writes the lanes leaving into their solutions, number by number (no
            /// lane structure is copied).
            fn unpack<T>(
                lanes: &Finishing,
                items: &mut [T],
                solution: &impl Fn(&mut T) -> &mut ForwardSolution,
            ) {
                let (legs, factor) = (lanes.legs, lanes.factor);
                for l in lanes.lanes() {
                    let at = |v: &Lane| v.as_array()[l];
                    let solution = solution(&mut items[l]);
                    solution.pose = pose_of(lanes.poses, l);
                    let out = &mut solution.legs;
                    for r in 0..3 {
                        for c in 0..3 {
                            out.rotation[(r, c)] = at(&legs.rotation[r][c]);
                        }
                    }
                    for leg in 0..6 {
                        out.rotated[leg] = vec_of(&legs.rotated[leg], l);
                        out.direction[leg] = vec_of(&legs.direction[leg], l);
                        out.length[leg] = at(&legs.length[leg]);
                    }
                    let (lu, permutation) = solution.factor.factors_mut();
                    for r in 0..6 {
                        for c in 0..6 {
                            lu[r][c] = at(&factor.lu[r][c]);
                        }
                        permutation[r] = at(&factor.permutation[r]) as u8;
                    }
                    solution.iterations = lanes.iterations;
                }
            }

            /// Lane `l`'s pose.
            fn pose_of(poses: &Poses, l: usize) -> Pose {
                let [i, j, k, w] = poses.quaternion.each_ref().map(|v| v.as_array()[l]);
                Pose::from_parts(
                    Translation3::from(vec_of(&poses.translation, l)),
                    UnitQuaternion::new_unchecked(Quaternion::new(w, i, j, k)),
                )
            }

            /// Lane `l`'s vector.
            fn vec_of(v: &[Lane; 3], l: usize) -> Vec3 {
                Vec3::new(v[0].as_array()[l], v[1].as_array()[l], v[2].as_array()[l])
            }

            /// The leg directions in the platform frame, `R^T n_i` (column `c` of
            /// `R` dotted with `n_i`), in the scalar code's order
            /// ([`crate::FactoredTipJacobian::platform_directions`]).
            #[inline]
            #[target_feature(enable = $feature)]
            fn platform_directions(legs: &LaneLegs) -> [[Lane; 3]; 6] {
                let rotation = &legs.rotation;
                legs.direction.map(|n| {
                    std::array::from_fn(|c| {
                        rotation[0][c] * n[0] + rotation[1][c] * n[1] + rotation[2][c] * n[2]
                    })
                })
            }

            /// [`crate::TipDerivatives::along`] in lanes, at the solutions of
            /// `legs` and `factor`: the pose's first-order change `(dt, w) = -A^-1 v` along
            /// `dp` (leg `i`: `v_i = -n_i . dB_i + (R^T n_i) . dE_i - dl_i`) and
            /// `J_f dp = dt + w x R E_T + R dE_T`, in the scalar code's order.
            #[inline]
            #[target_feature(enable = $feature)]
            fn along(
                geometry: &Geometry,
                legs: &LaneLegs,
                factor: &LaneLu,
                dp: &Params,
            ) -> ([Lane; 6], [Lane; 3]) {
                let rotation = &legs.rotation;
                let param = |k: usize| Lane::splat(dp[k]);
                // `R x`, and `R^T x` (column `c` of `R` dotted with `x`).
                let rotate = |x: &[Lane; 3]| -> [Lane; 3] {
                    std::array::from_fn(|r| {
                        rotation[r][0] * x[0] + rotation[r][1] * x[1] + rotation[r][2] * x[2]
                    })
                };
                let platform = platform_directions(legs);
                let v: [Lane; 6] = std::array::from_fn(|i| {
                    let (n, n_platform) = (&legs.direction[i], &platform[i]);
                    let mut change = -param(leg_index(i));
                    for c in 0..3 {
                        if let Some(k) = BASE_INDEX[i][c] {
                            change -= n[c] * param(k);
                        }
                        if let Some(k) = PLATFORM_INDEX[i][c] {
                            change += n_platform[c] * param(k);
                        }
                    }
                    change
                });
                let pose = solve(factor, &v).map(|x| -x);
                let tool = rotate(&<[f64; 3]>::from(geometry.tool).map(|x| Lane::splat(x)));
                let tool_step = rotate(&std::array::from_fn(|c| param(TOOL_OFFSET + c)));
                let turn = cross(&[pose[3], pose[4], pose[5]], &tool);
                let tip = std::array::from_fn(|a| pose[a] + turn[a] + tool_step[a]);
                (pose, tip)
            }
        }
    };
}

#[cfg(target_arch = "x86_64")]
lane_kernels!(avx2, F64x4, Mask4, 4, "avx2");
#[cfg(target_arch = "x86_64")]
lane_kernels!(avx512, F64x8, Mask8, 8, "avx512f");

#[cfg(test)]
mod tests {
    use nalgebra::Translation3;

    use super::*;
    use crate::{actuators, paper, rotation_zyx};

    /// Eight contacts of the paper's true machine, each started from a pose
    /// a little away from its solution.
    fn eight_contacts(geometry: &Geometry) -> (Vec<[f64; 6]>, Vec<Pose>) {
        (0..8)
            .map(|k| {
                let k = f64::from(k);
                let pose = Pose::from_parts(
                    Translation3::new(-40.0 + 11.0 * k, 25.0 - 6.0 * k, 380.0 + 4.0 * k),
                    rotation_zyx(0.1 - 0.03 * k, -0.06 + 0.01 * k, 0.02 * k),
                );
                let start = Translation3::new(2e-3, -1e-3, 1e-3) * pose;
                (actuators(geometry, &pose), start)
            })
            .unzip()
    }

    /// Every width this machine runs: the widest first, then the
    /// narrower ones.
    fn widths() -> Vec<Option<Lanes>> {
        let mut widths = vec![None];
        #[cfg(target_arch = "x86_64")]
        if crate::simd::avx2_available() {
            widths.push(Some(Lanes::Four));
            if crate::simd::avx512_available() {
                widths.push(Some(Lanes::Eight));
            }
        }
        widths.reverse();
        widths
    }

    /// Five to eight contacts in one call reach the same solutions, to
    /// rounding, in each width the machine runs (AVX-512's lanes, AVX2's
    /// four at a time, the scalar code): poses, tool tips, `J_f`'s
    /// weights, and the change along a parameter step.
    #[test]
    fn every_width_reaches_the_same_solutions() {
        let geometry = paper::truth();
        let options = ForwardOptions::default();
        let (q, starts) = eight_contacts(&geometry);
        let dp = Params::repeat(1e-3);
        for n in 5..=8 {
            let q: Vec<&[f64; 6]> = q[..n].iter().collect();
            let starts = &starts[..n];
            let outcomes: Vec<_> = (widths().into_iter())
                .map(|width| {
                    let mut trial = PivotOrder::default();
                    let mut jacobians = vec![SolutionJacobian::default(); n];
                    let solved = jacobian_in(
                        width,
                        &geometry,
                        &q,
                        starts,
                        &options,
                        &mut trial,
                        &mut jacobians,
                        &|s| s,
                    );
                    assert_eq!(solved, Ok(()), "{width:?}");
                    let mut along = vec![SolutionAlong::default(); n];
                    let solved = along_in(
                        width, &geometry, &q, starts, &dp, &options, &mut trial, &mut along,
                    );
                    assert_eq!(solved, Ok(()), "{width:?}");
                    let mut forward: Vec<ForwardSolution> = (starts.iter())
                        .map(|start| ForwardSolution {
                            pose: *start,
                            ..ForwardSolution::default()
                        })
                        .collect();
                    let solved = forward_in(width, &geometry, &q, &options, &mut forward, &|s| s);
                    assert_eq!(solved, Ok(()), "{width:?}");
                    (width, jacobians, along, forward)
                })
                .collect();
            let (_, widest, widest_along, widest_forward) = &outcomes[0];
            for (width, jacobians, along, forward) in &outcomes[1..] {
                for l in 0..n {
                    let (a, b) = (&jacobians[l], &widest[l]);
                    assert_eq!(a.iterations, b.iterations, "{width:?}, contact {l}");
                    assert!((a.pose.translation.vector - b.pose.translation.vector).amax() < 1e-10);
                    assert!(a.pose.rotation.angle_to(&b.pose.rotation) < 1e-12);
                    assert!((a.tool_tip - b.tool_tip).amax() < 1e-10);
                    let weights = &b.jacobian.weights;
                    assert!((a.jacobian.weights - weights).amax() < 1e-9 * weights.amax());
                    let (a, b) = (&along[l], &widest_along[l]);
                    assert!(
                        (a.tip - b.tip).amax() < 1e-9 * b.tip.amax(),
                        "{width:?}, {l}"
                    );
                    let shift = a.predicted.translation.vector - b.predicted.translation.vector;
                    assert!(shift.amax() < 1e-10, "{width:?}, contact {l}");
                    let (a, b) = (&forward[l], &widest_forward[l]);
                    assert_eq!(a.iterations, b.iterations, "{width:?}, contact {l}");
                    assert!((a.pose.translation.vector - b.pose.translation.vector).amax() < 1e-10);
                }
            }
        }
    }

    /// Derivatives solved in place, eight at once, are each contact's own
    /// ([`TipDerivatives::forward`]) to rounding: the pose, and `dT/dq`
    /// through the tool offset kept beside the solution.
    #[test]
    fn derivatives_solved_in_place_are_each_contacts_own() {
        let geometry = paper::truth();
        let options = ForwardOptions::default();
        let (q, starts) = eight_contacts(&geometry);
        let q: Vec<&[f64; 6]> = q.iter().collect();
        let mut batch = vec![TipDerivatives::default(); q.len()];
        let solved = forward_derivatives_batch(&geometry, &q, &starts, &options, &mut batch);
        assert_eq!(solved, Ok(()));
        for (l, solved) in batch.iter().enumerate() {
            let mut own = TipDerivatives::default();
            own.forward(&geometry, q[l], &starts[l], &options).unwrap();
            let (a, b) = (solved.solution(), own.solution());
            assert!((a.pose.translation.vector - b.pose.translation.vector).amax() < 1e-10);
            assert!(
                a.pose.rotation.angle_to(&b.pose.rotation) < 1e-12,
                "contact {l}"
            );
            let (a, b) = (solved.d_q(), own.d_q());
            assert!((a - b).amax() < 1e-9 * b.amax(), "contact {l}");
        }
    }

    /// A failing contact in the second group of four is named by its index
    /// in the call, in each width.
    #[test]
    fn every_width_names_the_first_failing_contact() {
        let geometry = paper::truth();
        let options = ForwardOptions::default();
        let (mut q, starts) = eight_contacts(&geometry);
        q[6][2] = -1e3;
        q[7][0] = f64::NAN;
        let q: Vec<&[f64; 6]> = q.iter().collect();
        for width in widths() {
            let mut trial = PivotOrder::default();
            let mut jacobians = vec![SolutionJacobian::default(); 8];
            let failed = jacobian_in(
                width,
                &geometry,
                &q,
                &starts,
                &options,
                &mut trial,
                &mut jacobians,
                &|s| s,
            );
            assert!(matches!(failed, Err((6, _))), "{width:?}: {failed:?}");
            let mut along = vec![SolutionAlong::default(); 8];
            let dp = Params::repeat(1e-3);
            let failed = along_in(
                width, &geometry, &q, &starts, &dp, &options, &mut trial, &mut along,
            );
            assert!(matches!(failed, Err((6, _))), "{width:?}: {failed:?}");
        }
    }
}
