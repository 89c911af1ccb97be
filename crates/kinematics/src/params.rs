//! The 33 identifiable kinematic parameters (paper eq. 3).
//!
//! In the canonical frames ([`crate::frames`]) the coordinates
//! `x_b1 y_b1 z_b1 x_b2 z_b2 z_b3` and `x_e1 y_e1 z_e1 x_e2 z_e2 z_e3` are zero
//! by definition; the remaining 33, in the paper's order, are
//!
//! ```text
//! y_b2, x_b3, y_b3, x_b4, y_b4, z_b4, x_b5, y_b5, z_b5, x_b6, y_b6, z_b6,
//! l_1 .. l_6,
//! y_e2, x_e3, y_e3, x_e4, y_e4, z_e4, x_e5, y_e5, z_e5, x_e6, y_e6, z_e6,
//! x_eT, y_eT, z_eT
//! ```

use nalgebra::{SMatrix, SVector};

use crate::{Geometry, Vec3};

/// Number of identifiable kinematic parameters.
pub const N_PARAMS: usize = 33;

/// The parameter vector `p` in the order of [`PARAM_NAMES`] (mm).
pub type Params = SVector<f64, N_PARAMS>;

/// A covariance of the parameters (mm²), rows and columns in the order of
/// [`PARAM_NAMES`].
pub type ParamCovariance = SMatrix<f64, N_PARAMS, N_PARAMS>;

/// Parameter names in the paper's order.
pub const PARAM_NAMES: [&str; N_PARAMS] = [
    "y_b2", "x_b3", "y_b3", "x_b4", "y_b4", "z_b4", "x_b5", "y_b5", "z_b5", "x_b6", "y_b6", "z_b6",
    "l_1", "l_2", "l_3", "l_4", "l_5", "l_6", "y_e2", "x_e3", "y_e3", "x_e4", "y_e4", "z_e4",
    "x_e5", "y_e5", "z_e5", "x_e6", "y_e6", "z_e6", "x_eT", "y_eT", "z_eT",
];

/// The names of the actuators' scales `s_1..s_6` (mm per unit of their
/// readings: leg `i` is `l_i + s_i q_i` long), the parameters after
/// [`PARAM_NAMES`] when a calibration identifies them.
pub const SCALE_NAMES: [&str; 6] = ["s_1", "s_2", "s_3", "s_4", "s_5", "s_6"];

/// Index of leg length `l_1` in the parameter vector.
pub const LEG_OFFSET: usize = 12;
/// Index of the tool coordinate `x_eT` in the parameter vector.
pub const TOOL_OFFSET: usize = 30;

/// Parameter index of each coordinate of a joint (`None`: zero by definition).
pub type JointIndex = [Option<usize>; 3];

const fn joint_indices(first: usize) -> [JointIndex; 6] {
    [
        [None, None, None],
        [None, Some(first), None],
        [Some(first + 1), Some(first + 2), None],
        [Some(first + 3), Some(first + 4), Some(first + 5)],
        [Some(first + 6), Some(first + 7), Some(first + 8)],
        [Some(first + 9), Some(first + 10), Some(first + 11)],
    ]
}

/// Parameter index of each canonical base joint coordinate.
pub const BASE_INDEX: [JointIndex; 6] = joint_indices(0);
/// Parameter index of each canonical platform joint coordinate.
pub const PLATFORM_INDEX: [JointIndex; 6] = joint_indices(18);

/// The parameter index of an initial leg length `l_{leg+1}`.
pub const fn leg_index(leg: usize) -> usize {
    LEG_OFFSET + leg
}

/// Parameter vector of a geometry given in its canonical frames. The
/// coordinates that are zero by definition are not read: canonicalise first
/// ([`Geometry::canonicalize`]).
pub fn to_params(canonical: &Geometry) -> Params {
    let mut p = Params::zeros();
    for (joints, index) in [
        (&canonical.base, &BASE_INDEX),
        (&canonical.platform, &PLATFORM_INDEX),
    ] {
        for (joint, index) in joints.iter().zip(index) {
            for (value, slot) in joint.iter().zip(index) {
                if let Some(k) = slot {
                    p[*k] = *value;
                }
            }
        }
    }
    for (leg, l) in canonical.legs.iter().enumerate() {
        p[leg_index(leg)] = *l;
    }
    p.fixed_rows_mut::<3>(TOOL_OFFSET)
        .copy_from(&canonical.tool);
    p
}

/// The canonical geometry of a parameter vector.
pub fn from_params(p: &Params) -> Geometry {
    let joint = |index: &JointIndex| Vec3::from_fn(|c, _| index[c].map_or(0.0, |k| p[k]));
    Geometry {
        base: BASE_INDEX.map(|index| joint(&index)),
        platform: PLATFORM_INDEX.map(|index| joint(&index)),
        tool: p.fixed_rows::<3>(TOOL_OFFSET).into(),
        legs: std::array::from_fn(|leg| p[leg_index(leg)]),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::paper;

    #[test]
    fn indices_cover_every_parameter_once() {
        let mut seen = [0usize; N_PARAMS];
        let joints = BASE_INDEX.iter().chain(&PLATFORM_INDEX).flatten().flatten();
        for k in joints
            .copied()
            .chain((0..6).map(leg_index))
            .chain(TOOL_OFFSET..TOOL_OFFSET + 3)
        {
            seen[k] += 1;
        }
        assert_eq!(seen, [1; N_PARAMS]);
    }

    #[test]
    fn names_follow_the_layout() {
        assert_eq!(PARAM_NAMES[BASE_INDEX[1][1].unwrap()], "y_b2");
        assert_eq!(PARAM_NAMES[BASE_INDEX[5][2].unwrap()], "z_b6");
        assert_eq!(PARAM_NAMES[PLATFORM_INDEX[2][0].unwrap()], "x_e3");
        assert_eq!(PARAM_NAMES[PLATFORM_INDEX[3][2].unwrap()], "z_e4");
        assert_eq!(PARAM_NAMES[leg_index(5)], "l_6");
        assert_eq!(PARAM_NAMES[TOOL_OFFSET + 2], "z_eT");
    }

    #[test]
    fn params_round_trip_through_the_canonical_geometry() {
        let canonical = paper::truth().canonicalize().unwrap().geometry;
        let p = to_params(&canonical);
        assert_eq!(p[0], canonical.base[1].y);
        let back = from_params(&p);
        for (a, b) in back
            .base
            .iter()
            .chain(&back.platform)
            .zip(canonical.base.iter().chain(&canonical.platform))
        {
            assert!((a - b).norm() < 1e-12);
        }
        assert_eq!(back.legs, canonical.legs);
        assert_eq!(back.tool, canonical.tool);
        assert_eq!(to_params(&back), p);
    }
}
