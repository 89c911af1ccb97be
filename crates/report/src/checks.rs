//! The observations' checks in words: variance components, data
//! snooping's test or a robust loss's down-weighted observations, external
//! reliability, uncontrolled observations.

use parcal_calibrate::hypothesis::critical_value;
use parcal_calibrate::hypothesis::{MAX_REMOVALS, SNOOPING_LEVEL};
use parcal_calibrate::observation::ObservationId;
use parcal_calibrate::reliability::{Reliability, UNCONTROLLED, VarianceComponent};
use parcal_calibrate::robust::{DOWN_WEIGHTED, DownWeighted, too_many};

use crate::places::{location, place, place_and_row};

/// The observations' checks in words: the variance components, the
/// largest normalised residual against the data-snooping critical value
/// (with a robust loss, the observations it down-weighted instead), the
/// uncontrolled observations; `original` gives an observation's place in
/// the dataset given.
pub fn checks(
    reliability: &Reliability,
    original: &dyn Fn(ObservationId) -> ObservationId,
    reasons: &mut Vec<String>,
    warnings: &mut Vec<String>,
) {
    reasons.push(variance_components(&reliability.components));
    if let Some(down_weighted) = &reliability.down_weighted {
        reasons.push(down_weighted_sentence(down_weighted, original));
    } else if let Some(worst) = reliability.worst() {
        let w = worst.normalised().unwrap_or(0.0);
        let tests = reliability.tests();
        let critical = critical_value(SNOOPING_LEVEL, tests);
        let test = format!(
            "largest normalised residual {w:+.2} at {} (critical value {critical:.2} for {tests} tests at {}% family-wise)",
            place_and_row(original(worst.observation()), worst.row()),
            SNOOPING_LEVEL * 100.0
        );
        if w.abs() > critical {
            reasons.push(format!(
                "data-snooping test failed: {test}: that observation is likely a blunder; calibrate --snoop finds and removes blunders"
            ));
        } else {
            reasons.push(format!(
                "every observation passes the data-snooping test: {test}"
            ));
        }
    }
    let least: Vec<String> = reliability
        .least_reliable(3)
        .iter()
        .map(|(observation, lambda)| format!("{lambda:.1} at {}", place(original(*observation))))
        .collect();
    if !least.is_empty() {
        reasons.push(format!(
            "external reliability (what an undetected blunder of an observation's minimal detectable bias moves the parameters by, in their sigmas), largest: {}",
            least.join(", ")
        ));
    }
    let uncontrolled: Vec<String> = reliability
        .uncontrolled()
        .map(|c| place(original(c.observation())))
        .collect();
    if !uncontrolled.is_empty() {
        warnings.push(format!(
            "{} observations have a redundancy under {UNCONTROLLED} per test: an error in them would go into the parameters unseen ({})",
            uncontrolled.len(),
            uncontrolled.iter().take(10).cloned().collect::<Vec<_>>().join(", ")
        ));
    }
}

/// The observations a robust loss down-weighted in one sentence (the ten
/// most down-weighted named), in the place of data snooping's test
/// ([`parcal_calibrate::robust`]).
pub fn down_weighted_sentence(
    down_weighted: &[DownWeighted],
    original: &dyn Fn(ObservationId) -> ObservationId,
) -> String {
    if down_weighted.is_empty() {
        return format!(
            "the robust loss down-weighted no observation (none has a weight under {DOWN_WEIGHTED})"
        );
    }
    let mut worst: Vec<&DownWeighted> = down_weighted.iter().collect();
    worst.sort_by(|a, b| a.weight.total_cmp(&b.weight));
    let named: Vec<String> = worst
        .iter()
        .take(10)
        .map(|d| {
            format!(
                "{} (weight {:.2e}, residual {:.1} sigmas)",
                place(original(d.observation)),
                d.weight,
                d.residual
            )
        })
        .collect();
    let verdict = if too_many(down_weighted) {
        format!(
            "; more than the {MAX_REMOVALS} blunders data snooping would remove: the model, not a few observations, is wrong"
        )
    } else {
        String::new()
    };
    format!(
        "the robust loss down-weighted {} observation{} to a weight under {DOWN_WEIGHTED}, likely blunders: {}{}{verdict}",
        down_weighted.len(),
        if down_weighted.len() == 1 { "" } else { "s" },
        named.join(", "),
        and_more(down_weighted.len() - named.len()),
    )
}

/// The down-weighted observations of `reliability` as calibration.json
/// lists them, each with its file and line or field.
pub fn down_weighted_records(
    reliability: &Reliability,
    original: &dyn Fn(ObservationId) -> ObservationId,
) -> Vec<parcal_dataset::DownWeightedObservation> {
    let listed = reliability.down_weighted.as_deref().unwrap_or_default();
    listed
        .iter()
        .map(|d| {
            let (file, line, field) = location(original(d.observation));
            parcal_dataset::DownWeightedObservation {
                file: file.to_string(),
                line,
                field,
                weight: d.weight,
                residual_sigmas: d.residual,
            }
        })
        .collect()
}

/// The variance components of a run in one sentence.
pub fn variance_components(components: &[VarianceComponent]) -> String {
    let parts: Vec<String> = components
        .iter()
        .map(|c| {
            if c.estimable() {
                format!(
                    "{} {:.3} (redundancy {:.1})",
                    c.group,
                    c.factor(),
                    c.redundancy
                )
            } else {
                format!(
                    "{} not estimable (redundancy {:.1}: nothing checks them)",
                    c.group, c.redundancy
                )
            }
        })
        .collect();
    format!("variance components: {}", parts.join(", "))
}

/// The balls moved to their mirror image (re-seeded in a calibration, kept
/// at the image in a validation) a report names at most, one by one.
pub(crate) const NAMED_MIRRORED: usize = 10;

/// A sentence for each of the first [`NAMED_MIRRORED`] re-seeded balls
/// (`each`), then one counting the others (`rest` of their number), if any.
pub(crate) fn re_seeded_sentences<T>(
    balls: &[T],
    each: impl Fn(&T) -> String,
    rest: impl FnOnce(usize) -> String,
) -> Vec<String> {
    let more = balls.len().saturating_sub(NAMED_MIRRORED);
    let named = balls.iter().take(NAMED_MIRRORED).map(each);
    named.chain((more > 0).then(|| rest(more))).collect()
}

/// " and N more" after a list cut short, nothing if it was not.
pub(crate) fn and_more(more: usize) -> String {
    if more > 0 {
        format!(" and {more} more")
    } else {
        String::new()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A robust loss's down-weighted contact is named at its measurements.csv
    /// line, in the dataset given (`original`).
    #[test]
    fn the_down_weighted_sentence_names_the_observation_in_the_dataset_given() {
        let down_weighted = [DownWeighted {
            observation: ObservationId::Contact(37),
            weight: 0.01,
            residual: 12.0,
        }];
        let shifted = |o: ObservationId| match o {
            ObservationId::Contact(row) => ObservationId::Contact(row + 1),
            other => other,
        };
        let sentence = down_weighted_sentence(&down_weighted, &shifted);
        assert!(
            sentence.contains("down-weighted 1 observation")
                && sentence.contains("measurements.csv line 40"),
            "{sentence}"
        );
    }
}
