//! `parcal report`: the page's verdict line, its numbers against
//! calibration.json's, non-blank figures, escaping, and the output checks.

use std::fs;
use std::path::Path;

use crate::common;
use common::{PAPER_FILES, copy_fixture, ok, parcal, s};

/// The text of the element with `id="verdict"`.
fn verdict_line(html: &str) -> &str {
    let start = html.find("id=\"verdict\"").expect("a verdict line");
    let text = &html[start..];
    let text = &text[text.find('>').unwrap() + 1..];
    &text[..text.find("</p>").unwrap()]
}

/// The inline SVG figures of the page.
fn figures(html: &str) -> Vec<&str> {
    html.split("<svg")
        .skip(1)
        .map(|rest| &rest[..rest.find("</svg>").expect("a closed svg")])
        .collect()
}

fn json(path: &Path) -> serde_json::Value {
    serde_json::from_str(&fs::read_to_string(path).unwrap()).unwrap()
}

#[test]
fn an_accepted_calibration_reports_its_verdict_numbers_and_figures() {
    let temp = tempfile::tempdir().unwrap();
    let data = copy_fixture("paper-seed1", temp.path(), &PAPER_FILES);
    let calibration = temp.path().join("calibration.json");
    ok(&["calibrate", s(&data), "--out", s(&calibration)]);
    let stdout = ok(&["report", s(&calibration), "--dataset", s(&data)]);
    assert!(stdout.contains("verdict: accepted"), "{stdout}");
    // Both forms, beside the calibration by default.
    let html = fs::read_to_string(temp.path().join("report.html")).unwrap();
    let c = json(&calibration);
    assert_eq!(c["verdict"], "accepted");
    assert!(
        verdict_line(&html).starts_with("ACCEPTED"),
        "{}",
        verdict_line(&html)
    );

    // The global test's numbers as calibration.json has them.
    let t = &c["global_test"];
    for number in [
        format!("{:.3}", t["variance_factor"].as_f64().unwrap()),
        format!(
            "[{:.3}, {:.3}]",
            t["interval"][0].as_f64().unwrap(),
            t["interval"][1].as_f64().unwrap()
        ),
        format!("<td class=\"num\">{}</td>", t["redundancy"]),
    ] {
        assert!(html.contains(&number), "{number} is not on the page");
    }
    // The largest normalised residual, with its line, and every parameter.
    let largest = &c["diagnostics"]["observations"]["largest"][0];
    let row = format!(
        "<td>measurements.csv</td><td class=\"num\">{}</td>",
        largest["line"]
    );
    assert!(html.contains(&row), "{row}");
    let w = format!("{:+.2}", largest["normalised_residual"].as_f64().unwrap());
    assert!(html.contains(&w), "{w}");
    let p = &c["parameters"];
    for k in 0..33 {
        let cell = format!(
            "<td>{}</td><td class=\"num\">{:.4}</td><td class=\"num\">{:.4}</td>",
            p["names"][k].as_str().unwrap(),
            p["values"][k].as_f64().unwrap(),
            p["sigma"][k].as_f64().unwrap()
        );
        assert!(html.contains(&cell), "{cell}");
    }

    // The external reliability on the map, as calibration.json has it.
    let external = &c["diagnostics"]["external_reliability"];
    assert_eq!(external.as_array().unwrap().len(), 5);
    assert!(html.contains("External reliability on the accuracy map"));
    for e in external.as_array().unwrap() {
        let cells = format!(
            "<td class=\"num\">{:.2}</td><td class=\"num\">{:.2}</td></tr>",
            e["map_rms_um"].as_f64().unwrap(),
            e["map_max_um"].as_f64().unwrap()
        );
        assert!(html.contains(&cells), "{cells}");
    }
    let first = format!(
        "registered tool tip by {:.2} µm RMS",
        external[0]["map_rms_um"].as_f64().unwrap()
    );
    assert!(html.contains(&first), "{first}");

    // Four figures, each with its data drawn: the histograms' bars, the
    // 33 x 33 correlation matrix and the 21 x 21 map.
    let svgs = figures(&html);
    assert_eq!(svgs.len(), 4, "histogram, redundancy, correlation, map");
    for svg in &svgs[..2] {
        assert!(svg.matches("<rect").count() > 5, "a histogram without bars");
    }
    assert!(svgs[0].contains("<polyline"), "the normal density curve");
    assert!(svgs[2].matches("<rect").count() >= 33 * 33, "the matrix");
    assert!(
        svgs[3].matches("<rect").count() >= 21 * 21,
        "the map's cells"
    );
    // Self-contained: no script, no resource fetched.
    for forbidden in ["<script", "src=", "href=", "@import", "url("] {
        assert!(!html.contains(forbidden), "the page has {forbidden}");
    }

    // Markdown says the same verdict; --out makes its directory.
    let md = fs::read_to_string(temp.path().join("report.md")).unwrap();
    assert!(md.contains("**ACCEPTED: "), "{md}");
    let elsewhere = temp.path().join("reports").join("paper");
    ok(&["report", s(&calibration), "--out", s(&elsewhere)]);
    let md = fs::read_to_string(elsewhere.join("report.md")).unwrap();
    assert!(md.contains("**ACCEPTED: "), "{md}");
    assert!(elsewhere.join("report.html").is_file());
}

#[test]
fn a_rejected_calibration_says_so_and_a_hostile_ball_id_is_escaped() {
    let temp = tempfile::tempdir().unwrap();
    let data = copy_fixture("paper-seed1", temp.path(), &PAPER_FILES[..3]);
    // Ball b02 renamed to markup, and a blunder of 0.05 mm in its first
    // contact's first reading.
    let hostile = "<img src=x onerror=alert(1)>&\"'";
    let artefacts = data.join("artefacts.json");
    let mut a = json(&artefacts);
    let old = a["balls"][1]["id"].as_str().unwrap().to_string();
    a["balls"][1]["id"] = hostile.into();
    fs::write(&artefacts, serde_json::to_string(&a).unwrap()).unwrap();
    let measurements = data.join("measurements.csv");
    let mut blundered = false;
    let text: Vec<String> = fs::read_to_string(&measurements)
        .unwrap()
        .lines()
        .map(|line| {
            let mut fields: Vec<String> = line.split(',').map(str::to_string).collect();
            if fields[0] == old {
                fields[0] = format!("\"{}\"", hostile.replace('"', "\"\""));
                if !blundered {
                    let q: f64 = fields[1].parse().unwrap();
                    fields[1] = (q + 0.05).to_string();
                    blundered = true;
                }
            }
            fields.join(",")
        })
        .collect();
    fs::write(&measurements, text.join("\n") + "\n").unwrap();

    let out = temp.path().join("calibration.json");
    let calibrate = parcal(&["calibrate", s(&data), "--out", s(&out)]);
    assert_eq!(calibrate.status.code(), Some(3), "a rejected calibration");
    let rejected = temp.path().join("calibration.rejected.json");
    let stdout = ok(&["report", s(&rejected)]);
    assert!(stdout.contains("verdict: rejected"), "{stdout}");
    let html = fs::read_to_string(temp.path().join("report.html")).unwrap();
    let line = verdict_line(&html);
    assert!(
        line.starts_with("REJECTED") && line.contains("global test failed"),
        "{line}"
    );
    // The blunder heads the largest normalised residuals, named by its ball.
    let c = json(&rejected);
    let largest = &c["diagnostics"]["observations"]["largest"][0];
    assert_eq!(largest["observes"], format!("ball {hostile}"));
    assert!(!html.contains(hostile) && !html.contains("<img"));
    assert!(html.contains("ball &lt;img src=x onerror=alert(1)&gt;&amp;&quot;&#39;"));
}

#[test]
fn an_instrument_calibration_reports_its_rows_and_says_why_it_has_no_map() {
    let temp = tempfile::tempdir().unwrap();
    let data = copy_fixture("jugglebot", temp.path(), &["machine.json", "poses.csv"]);
    let calibration = temp.path().join("calibration.json");
    ok(&["calibrate", s(&data), "--out", s(&calibration)]);
    ok(&["report", s(&calibration)]);
    let html = fs::read_to_string(temp.path().join("report.html")).unwrap();
    let c = json(&calibration);
    let verdict = verdict_line(&html);
    let word = c["verdict"].as_str().unwrap().to_uppercase();
    assert!(verdict.starts_with(&word), "{verdict}");
    assert!(html.contains("<td>poses.csv</td>"));
    let tests = &c["diagnostics"]["observations"];
    assert!(html.contains(&format!("{} observations tested", tests["tested"])));
    assert!(html.contains("No accuracy map: the calibration did not calibrate the tool"));
    assert_eq!(figures(&html).len(), 3, "two histograms, the correlation");
}

/// Touches read in revolutions, the scales unknowns after the 33: the
/// report maps the 33 with their marginal covariance, as `parcal
/// accuracy` does.
#[test]
fn a_calibration_with_actuator_scales_reports_its_accuracy_map() {
    let temp = tempfile::tempdir().unwrap();
    let data = temp.path().join("rev");
    ok(&[
        "simulate",
        "--seed",
        "1",
        "--readings",
        "rev",
        "--out",
        s(&data),
    ]);
    let calibration = temp.path().join("calibration.json");
    ok(&["calibrate", s(&data), "--out", s(&calibration)]);
    assert_eq!(
        json(&calibration)["parameters"]["names"]
            .as_array()
            .unwrap()
            .len(),
        39
    );
    ok(&["report", s(&calibration), "--dataset", s(&data)]);
    let html = fs::read_to_string(temp.path().join("report.html")).unwrap();
    assert!(!html.contains("No accuracy map"), "{html}");
    let maps = temp.path().join("maps");
    let said = ok(&[
        "accuracy",
        s(&data),
        "--calibration",
        s(&calibration),
        "--out",
        s(&maps),
    ]);
    assert!(said.contains("calibration, after"), "{said}");
}

#[test]
fn a_report_never_overwrites_its_input_and_refuses_other_data() {
    let temp = tempfile::tempdir().unwrap();
    let data = copy_fixture("paper-seed1", temp.path(), &PAPER_FILES);
    // A calibration named report.md in the report's directory, and a
    // report.html there that links to the dataset's machine.json.
    let calibration = temp.path().join("report.md");
    ok(&["calibrate", s(&data), "--out", s(&calibration)]);
    let before = fs::read(&calibration).unwrap();
    let output = parcal(&["report", s(&calibration), "--dataset", s(&data)]);
    assert_eq!(output.status.code(), Some(1));
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(stderr.contains("which this run reads"), "{stderr}");
    assert_eq!(fs::read(&calibration).unwrap(), before);
    #[cfg(unix)]
    {
        let out = temp.path().join("linked");
        fs::create_dir(&out).unwrap();
        let machine = data.join("machine.json");
        let machine_before = fs::read(&machine).unwrap();
        std::os::unix::fs::symlink(&machine, out.join("report.html")).unwrap();
        let output = parcal(&[
            "report",
            s(&calibration),
            "--dataset",
            s(&data),
            "--out",
            s(&out),
        ]);
        assert_eq!(output.status.code(), Some(1));
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert!(stderr.contains("which this run reads"), "{stderr}");
        assert_eq!(fs::read(&machine).unwrap(), machine_before);
        assert!(!out.join("report.md").exists(), "nothing written");
    }

    let other = copy_fixture(
        "jugglebot",
        &temp.path().join("other"),
        &["machine.json", "poses.csv"],
    );
    let out = temp.path().join("r");
    let output = parcal(&[
        "report",
        s(&calibration),
        "--dataset",
        s(&other),
        "--out",
        s(&out),
    ]);
    assert_eq!(output.status.code(), Some(1));
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(stderr.contains("--other-data"), "{stderr}");
    assert!(!out.join("report.html").exists());
}

#[test]
fn a_calibration_that_did_not_converge_is_reported_rejected_without_a_map() {
    let temp = tempfile::tempdir().unwrap();
    let data = copy_fixture("paper-seed1", temp.path(), &PAPER_FILES);
    let out = temp.path().join("calibration.json");
    let calibrate = parcal(&[
        "calibrate",
        s(&data),
        "--max-iterations",
        "1",
        "--out",
        s(&out),
    ]);
    assert_eq!(calibrate.status.code(), Some(3));
    ok(&["report", s(&temp.path().join("calibration.rejected.json"))]);
    let html = fs::read_to_string(temp.path().join("report.html")).unwrap();
    let line = verdict_line(&html);
    assert!(
        line.starts_with("REJECTED") && line.contains("the solver stopped"),
        "{line}"
    );
    assert!(html.contains("No accuracy map: the calibration has no posterior covariance"));
    // A run at its iteration limit is not judged, and the page says so.
    assert!(html.contains("The observations were not tested: the run did not converge"));
}

#[test]
fn calibrate_with_report_writes_the_report_beside_the_calibration_rejected_too() {
    let temp = tempfile::tempdir().unwrap();
    let data = copy_fixture("paper-seed1", temp.path(), &PAPER_FILES);
    let out = temp.path().join("run").join("calibration.json");
    fs::create_dir(out.parent().unwrap()).unwrap();
    let stdout = ok(&["calibrate", s(&data), "--out", s(&out), "--report"]);
    let directory = out.parent().unwrap();
    assert!(stdout.contains("report written to"), "{stdout}");
    let html = fs::read_to_string(directory.join("report.html")).unwrap();
    let md = fs::read_to_string(directory.join("report.md")).unwrap();
    assert!(verdict_line(&html).starts_with("ACCEPTED"));
    // The same pages as `parcal report` of that file and dataset (the true
    // error of the simulation included).
    assert!(
        html.contains("true (simulation)"),
        "the true error beside the predicted"
    );
    let again = temp.path().join("again");
    ok(&["report", s(&out), "--dataset", s(&data), "--out", s(&again)]);
    assert_eq!(fs::read_to_string(again.join("report.html")).unwrap(), html);
    assert_eq!(fs::read_to_string(again.join("report.md")).unwrap(), md);

    // A run stopped by its iteration limit is rejected, and its report,
    // beside the accepted one's, says why; the accepted calibration.json
    // and its report are kept.
    let accepted = fs::read(&out).unwrap();
    let accepted_report = fs::read(directory.join("report.html")).unwrap();
    let rejected = parcal(&[
        "calibrate",
        s(&data),
        "--out",
        s(&out),
        "--max-iterations",
        "1",
        "--report",
    ]);
    assert_eq!(rejected.status.code(), Some(3));
    assert_eq!(fs::read(&out).unwrap(), accepted);
    assert_eq!(
        fs::read(directory.join("report.html")).unwrap(),
        accepted_report
    );
    let stdout = String::from_utf8_lossy(&rejected.stdout);
    assert!(stdout.contains("report.rejected.html"), "{stdout}");
    let html = fs::read_to_string(directory.join("report.rejected.html")).unwrap();
    let line = verdict_line(&html);
    assert!(
        line.starts_with("REJECTED") && line.contains("the solver stopped"),
        "{line}"
    );
    assert!(html.contains("calibration.rejected.json"));

    // The report may not replace the calibration.
    let output = parcal(&[
        "calibrate",
        s(&data),
        "--out",
        s(&directory.join("report.html")),
        "--report",
    ]);
    assert_eq!(output.status.code(), Some(1));
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(
        stderr.contains("would overwrite the calibration"),
        "{stderr}"
    );
    assert!(
        verdict_line(&fs::read_to_string(directory.join("report.rejected.html")).unwrap())
            .starts_with("REJECTED")
    );
}
