//! `parcal paper` end to end on seed 1: the findings state the figures of
//! the report's own tables, and every picture it links is written.

use std::path::Path;

fn report(dir: &Path) -> String {
    parcal_report::paper::reproduce(1, dir, &mut |_| {}).unwrap();
    std::fs::read_to_string(dir.join("report.md")).unwrap()
}

/// The cells of the table row that starts with `| {first} |`.
fn row<'a>(md: &'a str, first: &str) -> Vec<&'a str> {
    let line = md
        .lines()
        .find(|l| l.starts_with(&format!("| {first} |")))
        .unwrap_or_else(|| panic!("no row {first:?}"));
    line.trim_matches('|').split(" | ").map(str::trim).collect()
}

#[test]
fn the_findings_state_the_tables_figures() {
    let dir = tempfile::tempdir().unwrap();
    let md = report(dir.path());
    let findings = &md[md.find("### Where and why they differ").unwrap()..];

    // NEES of the paper-prior runs, as in the convergence table.
    let nees_iii = row(&md, "III (paper prior)")[5];
    let nees_iv = row(&md, "IV (paper prior)")[5];
    assert!(
        findings.contains(&format!(
            "NEES is {nees_iii} (III) and {nees_iv} (IV) against an expected 33: over-confident."
        )),
        "{findings}"
    );
    // True registered error after IV with the propagated prior and the
    // design's before, as in the accuracy table ("rms / max").
    let rms = |cell: &str| cell.split(" / ").next().unwrap().to_string();
    let after = rms(row(&md, "IV (propagated prior), after")[4]);
    let before = rms(row(&md, "IV (propagated prior), before")[4]);
    assert!(
        findings.contains(&format!("falls from {before} um to "))
            && findings.contains(&format!("{after} um (IV) RMS.")),
        "{findings}"
    );
    // Iterations of I and II, as in the convergence table.
    let (i, ii) = (row(&md, "I (no prior)")[2], row(&md, "II (no prior)")[2]);
    assert!(
        findings.contains(&format!("in {i} (I) and {ii} (II) iterations")),
        "{findings}"
    );

    // Nothing left of the findings once written by hand.
    for stale in [
        "in the thousands",
        "~15-25",
        "~16 sigma",
        "~100 um",
        "one to two orders",
    ] {
        assert!(!md.contains(stale), "{stale:?} in report.md");
    }
    assert!(md.contains(
        "27 balls, 189 contacts, 1 um actuator and 1 um tool repeatability, 1 um radius error"
    ));
    assert!(md.contains("## Accuracy on the plane z = 400 (paper figs. 3, 7, 10)"));

    // Every picture linked is there, as SVG.
    let links: Vec<&str> = md
        .match_indices("](")
        .map(|(i, _)| {
            let rest = &md[i + 2..];
            &rest[..rest.find(')').unwrap()]
        })
        .collect();
    assert!(links.len() >= 10, "{links:?}");
    for link in links {
        assert!(link.ends_with(".svg"), "{link}");
        let svg = std::fs::read_to_string(dir.path().join(link)).unwrap();
        assert!(svg.starts_with("<svg") && svg.contains("<text"), "{link}");
    }
}
