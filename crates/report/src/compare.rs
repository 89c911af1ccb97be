//! Comparisons put into words, computed from the figures they compare, so
//! that a report never states a finding its numbers contradict.

use parcal_calibrate::conflict::chi_square_quantile;

/// Tail probability of the NEES test on each side.
const NEES_TAIL: f64 = 0.001;

/// How a NEES stands against chi-square(`dof`), its distribution when the
/// covariance is honest (expectation `dof`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NeesVerdict {
    /// Above the 99.9 % quantile: the covariance understates the error.
    OverConfident,
    /// Between the 0.1 % and 99.9 % quantiles.
    Consistent,
    /// Below the 0.1 % quantile: the covariance overstates the error.
    UnderConfident,
}

impl NeesVerdict {
    /// The verdict on a NEES of `dof` degrees of freedom.
    pub fn of(nees: f64, dof: usize) -> Self {
        if nees > chi_square_quantile(dof, 1.0 - NEES_TAIL) {
            Self::OverConfident
        } else if nees < chi_square_quantile(dof, NEES_TAIL) {
            Self::UnderConfident
        } else {
            Self::Consistent
        }
    }

    /// E.g. "over-confident".
    pub fn adjective(self) -> &'static str {
        match self {
            Self::OverConfident => "over-confident",
            Self::Consistent => "consistent with the truth",
            Self::UnderConfident => "under-confident",
        }
    }
}

/// "45011.5, above the 99.9% quantile 63.9 of chi-square(33) (the covariance
/// is over-confident)", or the same with "within the 0.1-99.9% range
/// 15.1-63.9" or "below the 0.1% quantile 15.1".
pub fn nees_sentence(nees: f64, dof: usize) -> String {
    let (low, high) = (
        chi_square_quantile(dof, NEES_TAIL),
        chi_square_quantile(dof, 1.0 - NEES_TAIL),
    );
    let verdict = NeesVerdict::of(nees, dof);
    let place = match verdict {
        NeesVerdict::OverConfident => format!("above the 99.9% quantile {high:.1}"),
        NeesVerdict::Consistent => format!("within the 0.1-99.9% range {low:.1}-{high:.1}"),
        NeesVerdict::UnderConfident => format!("below the 0.1% quantile {low:.1}"),
    };
    format!(
        "{nees:.1}, {place} of chi-square({dof}), expectation {dof}: the covariance is {}",
        verdict.adjective()
    )
}

/// How a value stands against a reference (both positive).
#[derive(Debug, Clone, Copy, PartialEq)]
enum Ratio {
    /// Within a factor 2 either way; the factor (at least 1).
    Within(f64),
    /// Smaller by the factor.
    Smaller(f64),
    /// Larger by the factor.
    Larger(f64),
}

impl Ratio {
    fn of(value: f64, reference: f64) -> Self {
        let r = value / reference;
        if (0.5..=2.0).contains(&r) {
            Self::Within(r.max(1.0 / r))
        } else if r < 1.0 {
            Self::Smaller(1.0 / r)
        } else {
            Self::Larger(r)
        }
    }

    fn factor(self) -> String {
        let f = match self {
            Self::Within(f) | Self::Smaller(f) | Self::Larger(f) => f,
        };
        if f < 10.0 {
            format!("{f:.1}")
        } else {
            format!("{f:.0}")
        }
    }

    /// The phrase around the factor(s): "within a factor {} of", "{} times
    /// smaller than", "{} times larger than".
    fn phrase(self, factors: &str) -> String {
        match self {
            Self::Within(_) => format!("within a factor {factors} of"),
            Self::Smaller(_) => format!("{factors} times smaller than"),
            Self::Larger(_) => format!("{factors} times larger than"),
        }
    }

    fn same_kind(self, other: Self) -> bool {
        std::mem::discriminant(&self) == std::mem::discriminant(&other)
    }
}

/// How each `(value, reference, label)` stands (all positive): one phrase
/// when all stand alike ("7.9 and 8.0 times larger than", "within a factor
/// 1.7 of" when the factors read the same), else each with its label ("3.0
/// times larger than (III) and within a factor 1.5 of (IV)").
pub fn ratios(items: &[(f64, f64, &str)]) -> String {
    let each: Vec<Ratio> = items.iter().map(|&(v, r, _)| Ratio::of(v, r)).collect();
    match each.first() {
        Some(&first) if each.iter().all(|r| r.same_kind(first)) => {
            let mut factors: Vec<String> = each.iter().map(|r| r.factor()).collect();
            if factors.iter().all(|f| *f == factors[0]) {
                factors.truncate(1);
            }
            first.phrase(&join(&factors))
        }
        _ => labelled(
            &each
                .iter()
                .zip(items)
                .map(|(r, &(_, _, label))| (r.phrase(&r.factor()), label))
                .collect::<Vec<_>>(),
        ),
    }
}

/// How values change from `from`: "falls from a to b (I) and c (II)" when
/// all fall (likewise "rises"), else each change with its label. Values
/// are written by `show`.
pub fn changes(from: f64, to: &[(f64, &str)], show: impl Fn(f64) -> String) -> String {
    let values = || {
        labelled(
            &to.iter()
                .map(|&(v, label)| (show(v), label))
                .collect::<Vec<_>>(),
        )
    };
    if to.iter().all(|&(v, _)| v < from) {
        format!("falls from {} to {}", show(from), values())
    } else if to.iter().all(|&(v, _)| v > from) {
        format!("rises from {} to {}", show(from), values())
    } else {
        let each: Vec<(String, &str)> = to
            .iter()
            .map(|&(v, label)| {
                let change = if v < from {
                    format!("falls from {} to {}", show(from), show(v))
                } else if v > from {
                    format!("rises from {} to {}", show(from), show(v))
                } else {
                    format!("stays at {}", show(from))
                };
                (change, label)
            })
            .collect();
        labelled(&each)
    }
}

/// "a (I) and b (II)": values with their labels, joined.
pub fn labelled(items: &[(String, impl AsRef<str>)]) -> String {
    let parts: Vec<String> = items
        .iter()
        .map(|(value, label)| format!("{value} ({})", label.as_ref()))
        .collect();
    join(&parts)
}

/// "a", "a and b", "a, b and c".
pub fn join(parts: &[String]) -> String {
    match parts {
        [] => String::new(),
        [one] => one.clone(),
        [rest @ .., last] => format!("{} and {last}", rest.join(", ")),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nees_is_judged_against_chi_square_quantiles() {
        // chi-square(33): 0.1 % quantile about 13.4, 99.9 % about 63.9.
        assert_eq!(NeesVerdict::of(33.4, 33), NeesVerdict::Consistent);
        assert_eq!(NeesVerdict::of(45011.5, 33), NeesVerdict::OverConfident);
        assert_eq!(NeesVerdict::of(5.0, 33), NeesVerdict::UnderConfident);
        let over = nees_sentence(45011.5, 33);
        assert!(
            over.starts_with("45011.5, above the 99.9% quantile 6"),
            "{over}"
        );
        assert!(over.ends_with("the covariance is over-confident"), "{over}");
        let fine = nees_sentence(33.4, 33);
        assert!(fine.contains("within the 0.1-99.9% range 1"), "{fine}");
        assert!(nees_sentence(5.0, 33).contains("below the 0.1% quantile"));
    }

    #[test]
    fn ratios_and_changes_follow_the_numbers() {
        assert_eq!(ratios(&[(16.4, 9.6, "III")]), "within a factor 1.7 of");
        assert_eq!(ratios(&[(9.6, 16.4, "III")]), "within a factor 1.7 of");
        assert_eq!(
            ratios(&[(40.3, 4053.0, "III"), (40.0, 4054.4, "IV")]),
            "101 times smaller than"
        );
        assert_eq!(ratios(&[(30.0, 10.0, "III")]), "3.0 times larger than");
        assert_eq!(
            ratios(&[(2.96e7, 3.76e6, "I"), (3.0e7, 3.76e6, "II")]),
            "7.9 and 8.0 times larger than"
        );
        assert_eq!(
            ratios(&[(30.0, 10.0, "III"), (15.0, 10.0, "IV")]),
            "3.0 times larger than (III) and within a factor 1.5 of (IV)"
        );
        let um = |v: f64| format!("{v:.1} um");
        assert_eq!(
            changes(97.3, &[(11.8, "I"), (11.6, "II")], um),
            "falls from 97.3 um to 11.8 um (I) and 11.6 um (II)"
        );
        assert_eq!(
            changes(9.6, &[(97.3, "I")], um),
            "rises from 9.6 um to 97.3 um (I)"
        );
        assert_eq!(
            changes(10.0, &[(5.0, "III"), (20.0, "IV"), (10.0, "V")], um),
            "falls from 10.0 um to 5.0 um (III), rises from 10.0 um to 20.0 um (IV) and stays at 10.0 um (V)"
        );
    }

    #[test]
    fn lists_are_joined_in_english() {
        assert_eq!(join(&[]), "");
        assert_eq!(join(&["a".into()]), "a");
        assert_eq!(join(&["a".into(), "b".into(), "c".into()]), "a, b and c");
        assert_eq!(
            labelled(&[("1.0".into(), "I"), ("2.0".into(), "II")]),
            "1.0 (I) and 2.0 (II)"
        );
    }
}
