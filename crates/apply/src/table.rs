//! A correction table over a workspace grid, for controllers that take
//! one (or for interpolating corrected poses without parcal).
//!
//! At every node `x` of a grid in the six target coordinates
//! (`x, y, z, roll, pitch, yaw`; an axis may hold one value) the correction
//! is `c(x) = P'(x) - x`, the corrected pose ([`crate::corrected_pose`])
//! less the target, coordinate by coordinate (mm, rad). Between nodes it is
//! interpolated multilinearly (trilinear for a grid in position only):
//! `c(x) = sum over the cell's corners v of w_v c(v)`, `w_v` the product
//! over axes of `1 - |x_a - v_a| / h_a`. The interpolation error is
//! measured where it is largest for a smooth `c`, at the cell midpoints:
//! the exact correction there against the interpolated one
//! ([`CorrectionTable::midpoint_error`]).

use crate::{AppliedModel, ApplyError, Target, command, corrected_pose};

/// The axes of a grid of targets: values of `x, y, z, roll, pitch, yaw`,
/// each strictly increasing (mm, rad); nodes in row-major order, `x`
/// slowest.
#[derive(Debug, Clone, PartialEq)]
pub struct TableGrid {
    /// The values of each coordinate.
    pub axes: [Vec<f64>; 6],
}

impl TableGrid {
    /// Refuses an empty axis, a non-finite value, values not strictly
    /// increasing.
    pub fn check(&self) -> Result<(), ApplyError> {
        for (axis, values) in Target::COLUMNS.iter().zip(&self.axes) {
            if values.is_empty() {
                return Err(ApplyError::Grid(format!("axis {axis} has no value")));
            }
            if values.iter().any(|v| !v.is_finite()) {
                return Err(ApplyError::Grid(format!(
                    "axis {axis} has a non-finite value"
                )));
            }
            if values.windows(2).any(|w| w[1] <= w[0]) {
                return Err(ApplyError::Grid(format!(
                    "axis {axis} is not strictly increasing"
                )));
            }
        }
        Ok(())
    }

    /// Number of nodes.
    pub fn len(&self) -> usize {
        self.axes.iter().map(Vec::len).product()
    }

    /// Whether the grid has no node.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The node of multi-index `index`.
    fn node(&self, index: &[usize; 6]) -> [f64; 6] {
        std::array::from_fn(|a| self.axes[a][index[a]])
    }

    /// Row-major position of a multi-index.
    fn flat(&self, index: &[usize; 6]) -> usize {
        (0..6).fold(0, |flat, a| flat * self.axes[a].len() + index[a])
    }

    /// Every multi-index with `index[a] < limits[a]`, row-major.
    fn indices(limits: [usize; 6]) -> impl Iterator<Item = [usize; 6]> {
        let total: usize = limits.iter().product();
        (0..total).map(move |mut k| {
            let mut index = [0; 6];
            for a in (0..6).rev() {
                index[a] = k % limits[a];
                k /= limits[a];
            }
            index
        })
    }

    /// The nodes, row-major.
    pub fn nodes(&self) -> impl Iterator<Item = [f64; 6]> + '_ {
        Self::indices(self.axes.each_ref().map(Vec::len)).map(|i| self.node(&i))
    }

    /// The midpoints of the cells (along axes of one value, that value).
    pub fn midpoints(&self) -> impl Iterator<Item = [f64; 6]> + '_ {
        let cells = self
            .axes
            .each_ref()
            .map(|v| v.len().saturating_sub(1).max(1));
        Self::indices(cells).map(|index| {
            std::array::from_fn(|a| match self.axes[a].len() {
                1 => self.axes[a][0],
                _ => 0.5 * (self.axes[a][index[a]] + self.axes[a][index[a] + 1]),
            })
        })
    }
}

/// The corrections at the nodes of a grid.
#[derive(Debug, Clone, PartialEq)]
pub struct CorrectionTable {
    /// The grid.
    pub grid: TableGrid,
    /// `P'(x) - x` at every node, row-major (mm, rad).
    pub corrections: Vec<[f64; 6]>,
}

/// The table's interpolation error at the cell midpoints.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct InterpolationError {
    /// Midpoints compared.
    pub points: usize,
    /// RMS of the position error (mm).
    pub position_rms: f64,
    /// Largest position error (mm).
    pub position_max: f64,
    /// Largest error of an angle (rad).
    pub angle_max: f64,
}

/// The exact correction `P'(x) - x` at `x`.
fn correction(model: &AppliedModel, node: &[f64; 6]) -> Result<[f64; 6], crate::Refusal> {
    let target = Target::from_row(node);
    let corrected = corrected_pose(model, &command(model, &target)?)?.row();
    Ok(std::array::from_fn(|a| corrected[a] - node[a]))
}

impl CorrectionTable {
    /// The table of `model` on `grid`. A refused node is an error naming its
    /// row of the table (1-based).
    pub fn new(model: &AppliedModel, grid: &TableGrid) -> Result<Self, ApplyError> {
        grid.check()?;
        let corrections = grid
            .nodes()
            .enumerate()
            .map(|(k, node)| {
                correction(model, &node).map_err(|refusal| ApplyError::Refused {
                    row: k + 1,
                    refusal,
                })
            })
            .collect::<Result<_, _>>()?;
        Ok(Self {
            grid: grid.clone(),
            corrections,
        })
    }

    /// The CSV rows: the node, then its correction (`dx .. dyaw`).
    pub fn rows(&self) -> Vec<Vec<f64>> {
        self.grid
            .nodes()
            .zip(&self.corrections)
            .map(|(node, c)| node.iter().chain(c).copied().collect())
            .collect()
    }

    /// The CSV header of [`CorrectionTable::rows`].
    pub const HEADER: [&'static str; 12] = [
        "x", "y", "z", "roll", "pitch", "yaw", "dx", "dy", "dz", "droll", "dpitch", "dyaw",
    ];

    /// The interpolated correction at `x` (module doc); `None` outside the
    /// grid.
    pub fn interpolate(&self, x: &[f64; 6]) -> Option<[f64; 6]> {
        // Per axis: the lower node and the weight of the upper one.
        let mut lower = [0usize; 6];
        let mut weight = [0.0; 6];
        for a in 0..6 {
            let values = &self.grid.axes[a];
            let (first, last) = (values[0], values[values.len() - 1]);
            if values.len() == 1 {
                continue;
            }
            if !(first..=last).contains(&x[a]) {
                return None;
            }
            let i = values
                .partition_point(|v| *v <= x[a])
                .clamp(1, values.len() - 1)
                - 1;
            lower[a] = i;
            weight[a] = (x[a] - values[i]) / (values[i + 1] - values[i]);
        }
        let mut out = [0.0; 6];
        let corners = self.grid.axes.each_ref().map(|v| v.len().min(2));
        for corner in TableGrid::indices(corners) {
            let mut w = 1.0;
            let mut index = lower;
            for a in 0..6 {
                if self.grid.axes[a].len() > 1 {
                    index[a] += corner[a];
                    w *= if corner[a] == 1 {
                        weight[a]
                    } else {
                        1.0 - weight[a]
                    };
                }
            }
            let c = &self.corrections[self.grid.flat(&index)];
            for (o, v) in out.iter_mut().zip(c) {
                *o += w * v;
            }
        }
        Some(out)
    }

    /// The interpolation error at the cell midpoints: the exact correction
    /// of `model` there against [`CorrectionTable::interpolate`].
    pub fn midpoint_error(&self, model: &AppliedModel) -> Result<InterpolationError, ApplyError> {
        let (mut points, mut sum, mut position_max, mut angle_max) = (0, 0.0, 0.0f64, 0.0f64);
        for (k, x) in self.grid.midpoints().enumerate() {
            let exact = correction(model, &x).map_err(|refusal| ApplyError::Refused {
                row: k + 1,
                refusal,
            })?;
            let interpolated = self.interpolate(&x).expect("a midpoint is inside the grid");
            let e: [f64; 6] = std::array::from_fn(|a| interpolated[a] - exact[a]);
            let position = (e[0] * e[0] + e[1] * e[1] + e[2] * e[2]).sqrt();
            sum += position * position;
            position_max = position_max.max(position);
            angle_max = angle_max.max(e[3].abs().max(e[4].abs()).max(e[5].abs()));
            points += 1;
        }
        Ok(InterpolationError {
            points,
            position_rms: (sum / points as f64).sqrt(),
            position_max,
            angle_max,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tests::paper_model;

    fn grid(n: usize, tilt: bool) -> TableGrid {
        let span = |lo: f64, hi: f64, n: usize| -> Vec<f64> {
            (0..n)
                .map(|k| lo + (hi - lo) * k as f64 / (n - 1) as f64)
                .collect()
        };
        TableGrid {
            axes: [
                span(-100.0, 100.0, n),
                span(-100.0, 100.0, n),
                span(360.0, 440.0, 3),
                if tilt { span(-0.1, 0.1, 3) } else { vec![0.0] },
                vec![0.0],
                vec![0.0],
            ],
        }
    }

    #[test]
    fn the_table_is_exact_at_its_nodes_and_close_between_them() {
        let model = paper_model();
        let table = CorrectionTable::new(&model, &grid(5, true)).unwrap();
        assert_eq!(table.corrections.len(), 5 * 5 * 3 * 3);
        let node = table.grid.nodes().nth(37).unwrap();
        assert_eq!(table.interpolate(&node), Some(table.corrections[37]));
        assert_eq!(table.interpolate(&[0.0, 0.0, 500.0, 0.0, 0.0, 0.0]), None);
        // Finer grids interpolate better (the error of linear
        // interpolation falls with the square of the step).
        let coarse = CorrectionTable::new(&model, &grid(3, false)).unwrap();
        let fine = CorrectionTable::new(&model, &grid(9, false)).unwrap();
        let (coarse, fine) = (
            coarse.midpoint_error(&model).unwrap(),
            fine.midpoint_error(&model).unwrap(),
        );
        assert_eq!((coarse.points, fine.points), (2 * 2 * 2, 8 * 8 * 2));
        assert!(
            fine.position_max < coarse.position_max / 4.0,
            "{coarse:?} {fine:?}"
        );
    }

    #[test]
    fn bad_grids_are_named() {
        let mut g = grid(3, false);
        g.axes[4] = vec![0.1, 0.0];
        let message = CorrectionTable::new(&paper_model(), &g)
            .unwrap_err()
            .to_string();
        assert_eq!(
            message,
            "correction table grid: axis pitch is not strictly increasing"
        );
    }
}
