//! Axis scales: padded ranges, tick positions and tick labels.
//!
//! Plotters' own tick choice gives no ticks at all on a log axis spanning
//! less than a decade and occasionally prints float noise, so the ticks are
//! chosen here and bound to the coordinate with `with_key_points`. A log axis
//! is drawn as a linear axis over `log10(value)`; every position in this
//! module is in those plot units.

use std::ops::Range;

use plotters::coord::ranged1d::{KeyPointHint, NoDefaultFormatting, Ranged, ValueFormatter};
use plotters::coord::types::RangedCoordf64;

/// How data values map to plot units.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Scale {
    Linear,
    Log10,
}

impl Scale {
    /// Plot units of a data value (finite, and positive on a log scale).
    pub(crate) fn to_plot(self, v: f64) -> f64 {
        match self {
            Scale::Linear => v,
            Scale::Log10 => v.log10(),
        }
    }
}

/// One axis: its range, labelled (major) ticks and unlabelled (minor) grid
/// positions, all in plot units.
#[derive(Debug, Clone)]
pub(crate) struct Axis {
    pub(crate) lo: f64,
    pub(crate) hi: f64,
    pub(crate) major: Vec<(f64, String)>,
    pub(crate) minor: Vec<f64>,
}

impl Axis {
    /// A linear axis over `lo..hi` (finite, `lo < hi`) with at most about
    /// `max_ticks` labelled ticks.
    pub(crate) fn linear(lo: f64, hi: f64, max_ticks: usize) -> Axis {
        let (ticks, step) = linear_ticks(lo, hi, max_ticks);
        let major = ticks
            .iter()
            .map(|&t| (t, format_linear(t, step, &ticks)))
            .collect();
        Axis {
            lo,
            hi,
            major,
            minor: Vec::new(),
        }
    }

    /// A logarithmic axis over `10^lo..10^hi` (`lo < hi`, finite): ticks at
    /// decades when at least three fit, else at 1-2-5 or 1..9 times a decade,
    /// else at round values in between.
    pub(crate) fn log10(lo: f64, hi: f64, max_ticks: usize) -> Axis {
        let decades: Vec<i32> = (lo.ceil() as i32..=hi.floor() as i32).collect();
        if decades.len() >= 3 {
            let stride = decades.len().div_ceil(max_ticks.max(1)) as i32;
            let mut major = Vec::new();
            let mut minor = Vec::new();
            for &k in &decades {
                if k.rem_euclid(stride) == 0 {
                    major.push((f64::from(k), pow10_label(k)));
                } else {
                    minor.push(f64::from(k));
                }
            }
            if stride == 1 && decades.len() <= 8 {
                minor = mantissa_positions(lo, hi, &[2, 3, 4, 5, 6, 7, 8, 9]);
            }
            return Axis {
                lo,
                hi,
                major,
                minor,
            };
        }
        for (labelled, unlabelled) in [
            (&[1u8, 2, 5][..], &[3u8, 4, 6, 7, 8, 9][..]),
            (&[1, 2, 3, 4, 5, 6, 7, 8, 9][..], &[][..]),
        ] {
            let positions = mantissa_positions(lo, hi, labelled);
            if positions.len() >= 3 {
                let major = positions.iter().map(|&p| (p, log_value_label(p))).collect();
                let minor = mantissa_positions(lo, hi, unlabelled);
                return Axis {
                    lo,
                    hi,
                    major,
                    minor,
                };
            }
        }
        // Less than about a tenth of a decade: round values, linearly spaced.
        let (vlo, vhi) = (10f64.powf(lo), 10f64.powf(hi));
        let (ticks, step) = if vlo < vhi && vlo.is_finite() && vhi.is_finite() {
            linear_ticks(vlo, vhi, max_ticks)
        } else {
            (Vec::new(), f64::NAN)
        };
        let major = ticks
            .iter()
            .filter(|&&t| t > 0.0)
            .map(|&t| (t.log10().clamp(lo, hi), format_linear(t, step, &ticks)))
            .collect();
        Axis {
            lo,
            hi,
            major,
            minor: Vec::new(),
        }
    }

    /// Positions of the labelled ticks.
    pub(crate) fn major_positions(&self) -> Vec<f64> {
        self.major.iter().map(|&(p, _)| p).collect()
    }

    /// The label of the tick nearest to `p` (plotters hands back exactly the
    /// positions it was given).
    pub(crate) fn label(&self, p: f64) -> String {
        self.major
            .iter()
            .min_by(|a, b| (a.0 - p).abs().total_cmp(&(b.0 - p).abs()))
            .map(|(_, label)| label.clone())
            .unwrap_or_default()
    }
}

/// Plotters coordinate over `lo..hi`: the major ticks are the bold key
/// points (labelled by [`Axis::label`]), the minor ones the light key points.
impl Ranged for Axis {
    type FormatOption = NoDefaultFormatting;
    type ValueType = f64;

    fn map(&self, value: &f64, limit: (i32, i32)) -> i32 {
        RangedCoordf64::from(self.lo..self.hi).map(value, limit)
    }

    fn key_points<Hint: KeyPointHint>(&self, hint: Hint) -> Vec<f64> {
        if hint.weight().allow_light_points() {
            self.minor.clone()
        } else {
            self.major_positions()
        }
    }

    fn range(&self) -> Range<f64> {
        self.lo..self.hi
    }
}

impl ValueFormatter<f64> for Axis {
    fn format(value: &f64) -> String {
        format!("{value}")
    }

    fn format_ext(&self, value: &f64) -> String {
        self.label(*value)
    }
}

/// `min..max` (finite, `min <= max`, plot units) widened by `frac` of its
/// span on each side; a single value gets a range around it. `None` when the
/// result overflows.
pub(crate) fn padded(min: f64, max: f64, frac: f64, scale: Scale) -> Option<(f64, f64)> {
    let (lo, hi) = if min < max {
        let pad = (max - min) * frac;
        (min - pad, max + pad)
    } else {
        let d = match scale {
            Scale::Log10 => 0.5,
            Scale::Linear if min == 0.0 => 1.0,
            Scale::Linear => min.abs() * 0.1,
        };
        (min - d, max + d)
    };
    (lo.is_finite() && hi.is_finite() && (hi - lo).is_finite() && lo < hi).then_some((lo, hi))
}

/// Round tick values within `lo..=hi` and their spacing. Falls back to the
/// two ends when the range is too narrow for its magnitude.
fn linear_ticks(lo: f64, hi: f64, max_ticks: usize) -> (Vec<f64>, f64) {
    let fallback = (vec![lo, hi], hi - lo);
    let step = nice_step((hi - lo) / max_ticks.max(2) as f64);
    if !(step.is_finite() && step > 0.0) {
        return fallback;
    }
    // Tolerate rounding: 0.7 / 0.1 is 6.999999999999999.
    let (first, last) = ((lo / step - 1e-9).ceil(), (hi / step + 1e-9).floor());
    if !(first.is_finite() && last.is_finite())
        || first.abs() > 1e15
        || last.abs() > 1e15
        || last < first
        || last - first > 1000.0
    {
        return fallback;
    }
    let ticks = (first as i64..=last as i64)
        .map(|k| {
            let t = k as f64 * step;
            if t.abs() < step * 1e-9 { 0.0 } else { t }
        })
        .collect();
    (ticks, step)
}

/// The smallest of 1, 2, 2.5, 5 or 10 times a power of ten that is at least
/// `raw`.
fn nice_step(raw: f64) -> f64 {
    let mag = 10f64.powf(raw.log10().floor());
    let norm = raw / mag;
    let m = [1.0, 2.0, 2.5, 5.0, 10.0]
        .into_iter()
        .find(|&m| norm <= m * (1.0 + 1e-9))
        .unwrap_or(10.0);
    m * mag
}

/// Decimal (or, for very large or small ticks, exponent) notation with as
/// many digits as the tick spacing `step` needs; `ticks` is the whole set so
/// that all labels of an axis share one notation.
fn format_linear(v: f64, step: f64, ticks: &[f64]) -> String {
    minus_signs(format_number(v, step, ticks))
}

/// Typographic minus signs for hyphens.
fn minus_signs(s: String) -> String {
    s.replace('-', "−")
}

fn format_number(v: f64, step: f64, ticks: &[f64]) -> String {
    let exp = |x: f64| x.abs().log10().floor() as i32;
    let step_exp = if step.is_finite() && step > 0.0 {
        exp(step)
    } else {
        exp(v).saturating_sub(3)
    };
    let extra = if step.is_finite() && step > 0.0 {
        let mantissa = step / 10f64.powi(step_exp);
        // 2.5 needs one more digit than its exponent says.
        usize::from((mantissa - 2.5).abs() < 1e-6)
    } else {
        0
    };
    let max_abs = ticks.iter().fold(0.0f64, |m, t| m.max(t.abs()));
    if !(1e-3..1e6).contains(&max_abs) {
        if v == 0.0 {
            return "0".to_string();
        }
        let digits = exp(v).saturating_sub(step_exp).clamp(0, 15) as usize + extra;
        format!("{v:.digits$e}")
    } else {
        let digits = step_exp.saturating_neg().clamp(0, 15) as usize + extra;
        format!("{v:.digits$}")
    }
}

/// Positions `k + log10(m)` within `lo..=hi` for every decade `k` and
/// mantissa `m`, ascending.
fn mantissa_positions(lo: f64, hi: f64, mantissas: &[u8]) -> Vec<f64> {
    let mut out = Vec::new();
    for k in lo.floor() as i32..=hi.floor() as i32 {
        for &m in mantissas {
            let p = f64::from(k) + f64::from(m).log10();
            if (lo..=hi).contains(&p) {
                out.push(p);
            }
        }
    }
    out
}

/// Label of the value `10^p` where `p = k + log10(m)` for an integer mantissa
/// `m`: plain decimals from 0.001 to 999999, `m×10ᵏ` beyond.
fn log_value_label(p: f64) -> String {
    let k = p.floor() as i32;
    let m = 10f64.powf(p - f64::from(k)).round() as u32;
    let (k, m) = if m >= 10 { (k + 1, 1) } else { (k, m) };
    if (-3..6).contains(&k) {
        let v = f64::from(m) * 10f64.powi(k);
        let digits = (-k).max(0) as usize;
        format!("{v:.digits$}")
    } else if m == 1 {
        pow10_label(k)
    } else {
        format!("{m}×{}", pow10_label(k))
    }
}

/// `10ᵏ` with a superscript exponent.
pub(crate) fn pow10_label(k: i32) -> String {
    const SUPERSCRIPT: [char; 10] = ['⁰', '¹', '²', '³', '⁴', '⁵', '⁶', '⁷', '⁸', '⁹'];
    let mut s = String::from("10");
    if k < 0 {
        s.push('⁻');
    }
    for d in k.unsigned_abs().to_string().bytes() {
        s.push(SUPERSCRIPT[usize::from(d - b'0')]);
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    fn labels(axis: &Axis) -> Vec<&str> {
        axis.major.iter().map(|(_, l)| l.as_str()).collect()
    }

    #[test]
    fn linear_ticks_are_round() {
        assert_eq!(
            labels(&Axis::linear(-0.3, 10.4, 8)),
            ["0", "2", "4", "6", "8", "10"]
        );
        assert_eq!(
            labels(&Axis::linear(0.0, 1.0, 4)),
            ["0.00", "0.25", "0.50", "0.75", "1.00"]
        );
        assert_eq!(
            labels(&Axis::linear(0.1, 0.7, 8)),
            ["0.1", "0.2", "0.3", "0.4", "0.5", "0.6", "0.7"]
        );
        assert_eq!(
            labels(&Axis::linear(0.0, 2e-5, 4)),
            ["0", "5e−6", "1.0e−5", "1.5e−5", "2.0e−5"]
        );
        assert_eq!(
            labels(&Axis::linear(-3.0e6, 3.0e6, 6)),
            ["−3e6", "−2e6", "−1e6", "0", "1e6", "2e6", "3e6"]
        );
    }

    #[test]
    fn narrow_range_far_from_zero_does_not_hang() {
        let axis = Axis::linear(1e16, 1e16 + 4.0, 8);
        assert!(!axis.major.is_empty() && axis.major.len() <= 1001);
        let axis = Axis::linear(1e300, 1.0000001e300, 8);
        assert!(!axis.major.is_empty());
    }

    #[test]
    fn log_axis_uses_decades_when_wide() {
        let axis = Axis::log10(-12.3, 2.2, 8);
        assert_eq!(
            labels(&axis),
            [
                "10⁻¹²",
                "10⁻¹⁰",
                "10⁻⁸",
                "10⁻⁶",
                "10⁻⁴",
                "10⁻²",
                "10⁰",
                "10²"
            ]
        );
        let axis = Axis::log10(-4.2, -0.9, 8);
        assert_eq!(labels(&axis), ["10⁻⁴", "10⁻³", "10⁻²", "10⁻¹"]);
        assert_eq!(axis.minor.len(), 3 + 8 * 3); // 7e-5..9e-5, then 2..9 in three decades
    }

    #[test]
    fn log_axis_within_a_decade_or_two_has_ticks() {
        assert_eq!(
            labels(&Axis::log10(-0.4, 1.35, 8)),
            ["0.5", "1", "2", "5", "10", "20"]
        );
        assert_eq!(
            labels(&Axis::log10(0.45, 0.98, 8)),
            ["3", "4", "5", "6", "7", "8", "9"]
        );
        let axis = Axis::log10(3.1f64.log10(), 3.9f64.log10(), 8);
        assert!(axis.major.len() >= 3, "{:?}", axis.major);
        assert!(
            axis.major
                .iter()
                .all(|&(p, _)| (axis.lo..=axis.hi).contains(&p))
        );
        assert_eq!(
            labels(&Axis::log10(-6.6, -5.0, 8)),
            ["5×10⁻⁷", "10⁻⁶", "2×10⁻⁶", "5×10⁻⁶", "10⁻⁵"]
        );
    }

    #[test]
    fn padding() {
        assert_eq!(padded(0.0, 10.0, 0.05, Scale::Linear), Some((-0.5, 10.5)));
        assert_eq!(padded(2.0, 2.0, 0.05, Scale::Log10), Some((1.5, 2.5)));
        assert_eq!(padded(0.0, 0.0, 0.05, Scale::Linear), Some((-1.0, 1.0)));
        assert_eq!(padded(-f64::MAX, f64::MAX, 0.05, Scale::Linear), None);
    }

    #[test]
    fn superscripts() {
        assert_eq!(pow10_label(-12), "10⁻¹²");
        assert_eq!(pow10_label(0), "10⁰");
        assert_eq!(pow10_label(3), "10³");
    }
}
