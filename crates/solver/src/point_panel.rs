//! Closed forms of the QR of a point's panel for the common shape: three
//! data rows (a touch's coordinates) and two point unknowns (its contact
//! angles), with or without the point prior's two rows. The general
//! Householder path ([`factor_point`](crate::eliminate::factor_point))
//! gives the same factorisation up to the signs of `R`'s rows and, with a
//! prior, an orthogonal change of basis of the eliminated rows (`Q₂` is
//! `Q₂ O`); every use of `Q₂` (the eliminated rows, their Gram product,
//! the leverages) is invariant under it.
//!
//! `Q` is written `m × m`, row-major, as the Householder path writes it;
//! the panel's `R` into the first two rows of `panel` (`P = 2` values a
//! row), the rows below zero.

use nalgebra::Vector3;

use crate::qr::RANK_TOLERANCE;

/// The closed form with a prior is taken only for a panel whose columns are
/// this far from dependent, `R_jj² > WELL_CONDITIONED · |column j|²`, in
/// both its data rows and the whole panel (a condition number below about
/// `10⁴`), where its Gram–Schmidt steps are as accurate as Householder
/// reflections and its rank is certain.
const WELL_CONDITIONED: f64 = 1e-8;

/// The column `Q[·, 2]` of a 3 x 2 panel `[c1 c2]` (its point-eliminated
/// row), into `q` (3 x 3, row-major; the other columns are not formed):
/// the unit normal `n = (c1 × c2) / |c1 × c2|` of the panel's columns,
/// which is the Householder path's column up to its sign. Returns whether
/// the panel has full rank by the Householder path's test,
/// `R_22² > RANK_TOLERANCE² |c2|²` with `R_22 = |c1 × c2| / |c1|`, i.e.
/// `|c1 × c2|² > RANK_TOLERANCE² |c1|² |c2|²` (false for a zero or
/// non-finite column).
#[inline(always)]
pub(crate) fn panel_normal(c1: &Vector3<f64>, c2: &Vector3<f64>, q: &mut [f64]) -> bool {
    let n = c1.cross(c2);
    let cross2 = n.norm_squared();
    let scale = cross2.sqrt().recip();
    for (r, x) in n.iter().enumerate() {
        q[r * 3 + 2] = x * scale;
    }
    cross2 > RANK_TOLERANCE * RANK_TOLERANCE * c1.norm_squared() * c2.norm_squared()
}

/// The rest of the QR of a 3 x 2 panel `[c1 c2]` beside
/// [`panel_normal`]'s column: `R` (2 x 2, upper triangular) into the first
/// two rows of `panel` (3 x 2, row-major, zero below the diagonal) and the
/// columns 0 and 1 of `Q` into `q` (3 x 3, row-major), by Gram-Schmidt:
/// `r11 = |c1|`, `q1 = c1 / r11`, `r12 = q1 · c2`, `q2 = u / r22` with
/// `u = c2 − r12 q1`, `r22 = |u|`; then `q1 × q2` is the normal. Meaningful
/// when [`panel_normal`] found the panel of full rank.
#[inline(always)]
pub(crate) fn panel_qr(c1: &Vector3<f64>, c2: &Vector3<f64>, panel: &mut [f64], q: &mut [f64]) {
    let r11 = c1.norm();
    let q1 = c1 / r11;
    let r12 = q1.dot(c2);
    let u = c2 - r12 * q1;
    let r22 = u.norm();
    panel[..6].copy_from_slice(&[r11, r12, 0.0, r22, 0.0, 0.0]);
    for r in 0..3 {
        q[r * 3] = q1[r];
        q[r * 3 + 1] = u[r] / r22;
    }
}

/// The QR of the 5 x 2 panel `A = [D_p; S]` of three data rows `D_p = [c1
/// c2]` and the point prior's rows `S = [[s00, s01], [0, s11]]` (its
/// information's upper-triangular square root), in closed form; `Q` into
/// `q` (5 x 5, row-major) from column `first_column` on, and for
/// `first_column < 2` `R` into `panel` (5 x 2, row-major).
///
/// `D_p = T R_d` by Gram–Schmidt (`T = [t1 t2]` orthonormal, `R_d` upper
/// triangular), and `n = t1 × t2` completes `T` to a basis. In these
/// coordinates the point's rows are `n`'s row, which the angles do not
/// move, and two tangent rows `R_d θ + …` beside the prior's `S θ + e`.
/// The angles are eliminated as a random effect: with `θ = S⁻¹ (η − e)`,
/// `η ~ N(0, I)`, the tangent rows' noise is `I + H Hᵀ`, `H = R_d S⁻¹`,
/// which `C⁻¹` whitens (`C Cᵀ = I + H Hᵀ`, Cholesky, every pivot at least
/// 1). So `Q₂ᵀ = [nᵀ, 0; C⁻¹ Tᵀ, −C⁻¹ H]`: orthonormal rows, zero on `A`.
/// `Q₁ = [T, 0; 0, I] W` and `R` from the QR `W R = [R_d; S]` (4 x 2, by
/// Gram–Schmidt).
///
/// Returns whether it took the panel: not one whose data rows or whole
/// columns are not well conditioned ([`WELL_CONDITIONED`]) or whose `S` is
/// singular or not finite, which the Householder path then factorises. A
/// panel it takes has full rank.
#[inline(always)]
pub(crate) fn prior_panel_qr(
    c1: &Vector3<f64>,
    c2: &Vector3<f64>,
    s: [f64; 3],
    panel: &mut [f64],
    q: &mut [f64],
    first_column: usize,
) -> bool {
    let [s00, s01, s11] = s;
    // Every quantity below is formed from the panel's dot products with as
    // few square roots and divisions in a row as may be: `R_d`'s entries
    // are `r11 = √a`, `r12 = ratio · r11`, `r22 = |u|`.
    let (a, b) = (c1.norm_squared(), c1.dot(c2));
    let ratio = b / a;
    let u = c2 - ratio * c1;
    let r22_2 = u.norm_squared();
    // `[R_d; S]`'s columns, in the coordinates `(t1, t2, prior rows)`.
    let (b1_2, b12) = (a + s00 * s00, b + s00 * s01);
    let d2 = c2.norm_squared();
    let b2_2 = d2 + s01 * s01 + s11 * s11;
    let rho22_2 = b2_2 - b12 * b12 / b1_2;
    let well = r22_2 > WELL_CONDITIONED * d2
        && rho22_2 > WELL_CONDITIONED * b2_2
        && (s00 * s11).is_normal();
    if !well {
        return false;
    }
    let (r11, r22) = (a.sqrt(), r22_2.sqrt());
    let r12 = ratio * r11;
    // Each vector scaled by one reciprocal, not divided entry by entry.
    let t1 = c1 * r11.recip();
    let t2 = u * r22.recip();
    let n = t1.cross(&t2);
    // `H = R_d S⁻¹` (upper triangular).
    let (i00, i11) = (s00.recip(), s11.recip());
    let g01 = (ratio - s01 * i00) * i11;
    let (h00, h01, h11) = (r11 * i00, r11 * g01, r22 * i11);
    // `C` of `I + H Hᵀ`, by its squares: `m00 = 1 + h00² + h01²`; its
    // second pivot `1 + h11² (1 + h00²) / m00`, without the cancellation
    // of `m11 − c10²`; `C⁻¹ = [k00, 0; k10, k11]`.
    let (h00_2, h11_2) = (a * i00 * i00, r22_2 * i11 * i11);
    let m00 = 1.0 + h00_2 + a * g01 * g01;
    let m00_inv = m00.recip();
    let pivot = 1.0 + h11_2 * (1.0 + h00_2) * m00_inv;
    let (k00, k11) = (m00.sqrt().recip(), pivot.sqrt().recip());
    let k10 = -h01 * h11 * k11 * m00_inv;
    for r in 0..3 {
        q[r * 5 + 2] = n[r];
        q[r * 5 + 3] = k00 * t1[r];
        q[r * 5 + 4] = k10 * t1[r] + k11 * t2[r];
    }
    q[15 + 2] = 0.0;
    q[20 + 2] = 0.0;
    q[15 + 3] = -k00 * h00;
    q[20 + 3] = -k00 * h01;
    q[15 + 4] = -k10 * h00;
    q[20 + 4] = -(k10 * h01 + k11 * h11);
    if first_column < 2 {
        // `W`'s columns: `w1 = b1 / ρ11`, `w2 = v / ρ22` with `v = b2 − ρ12
        // w1`, `ρ22 = |v|`.
        let rho11 = b1_2.sqrt();
        let rho11_inv = rho11.recip();
        let rho12 = b12 * rho11_inv;
        let w1 = [r11 * rho11_inv, 0.0, s00 * rho11_inv, 0.0];
        let b2 = [r12, r22, s01, s11];
        let v: [f64; 4] = std::array::from_fn(|a| b2[a] - rho12 * w1[a]);
        let rho22 = v.iter().map(|x| x * x).sum::<f64>().sqrt();
        let rho22_inv = rho22.recip();
        let w2 = v.map(|x| x * rho22_inv);
        for (j, w) in [w1, w2].iter().enumerate() {
            for r in 0..3 {
                q[r * 5 + j] = w[0] * t1[r] + w[1] * t2[r];
            }
            q[15 + j] = w[2];
            q[20 + j] = w[3];
        }
        panel[..10].copy_from_slice(&[rho11, rho12, 0.0, rho22, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]);
    }
    true
}
