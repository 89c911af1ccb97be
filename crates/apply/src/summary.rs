//! A human-readable summary of a calibration to apply: the verdict, the
//! placed geometry against the design, the scales, the parameters with
//! their sigmas and the posterior covariance (as sigmas and correlations).

use std::fmt::Write as _;

use parcal_dataset::Calibration;

use crate::{AppliedModel, UNSEEN_TOOL};

/// The summary text (module doc).
pub fn summary(record: &Calibration, model: &AppliedModel) -> String {
    let mut out = String::new();
    write_summary(&mut out, record, model).expect("writing to a String");
    out
}

fn write_summary(out: &mut String, record: &Calibration, model: &AppliedModel) -> std::fmt::Result {
    let verdict = if record.verdict.is_empty() {
        "none"
    } else {
        &record.verdict
    };
    writeln!(out, "parcal calibration summary")?;
    writeln!(
        out,
        "verdict: {verdict}; converged: {}; status: {}",
        record.converged, record.status
    )?;
    for reason in &record.reasons {
        writeln!(out, "  - {reason}")?;
    }
    let p = &model.placement;
    writeln!(
        out,
        "\nplacement in the design frame (best rigid fit onto the design joints): base RMS {:.4} mm, platform and tool RMS {:.4} mm",
        p.base_rms, p.platform_rms
    )?;
    writeln!(
        out,
        "\ncalibrated geometry, design frame (mm), and its difference from the design:"
    )?;
    let (g, d) = (&model.calibrated, &model.design);
    let row = |out: &mut String,
               name: String,
               v: &parcal_kinematics::Vec3,
               dv: &parcal_kinematics::Vec3| {
        let delta = v - dv;
        writeln!(
            out,
            "  {name:<4} {:>12.4} {:>12.4} {:>12.4}   d = {:>8.4} {:>8.4} {:>8.4}",
            v.x, v.y, v.z, delta.x, delta.y, delta.z
        )
    };
    for i in 0..6 {
        row(out, format!("B{}", i + 1), &g.base[i], &d.base[i])?;
    }
    for i in 0..6 {
        row(out, format!("E{}", i + 1), &g.platform[i], &d.platform[i])?;
    }
    row(out, "E_T".to_string(), &g.tool, &d.tool)?;
    if !model.tool_calibrated {
        writeln!(out, "       {UNSEEN_TOOL}")?;
    }
    for i in 0..6 {
        writeln!(
            out,
            "  l{}   {:>12.4}   d = {:>8.4}   scale {} mm/{}",
            i + 1,
            g.legs[i],
            g.legs[i] - d.legs[i],
            model.scale[i],
            model.unit
        )?;
    }
    if let Some([min, max]) = model.stroke {
        writeln!(out, "  stroke [{min}, {max}] {}", model.unit)?;
    }
    let t = &record.parameters;
    writeln!(
        out,
        "\nparameters (canonical frames): value, posterior sigma"
    )?;
    for k in 0..t.names.len() {
        writeln!(
            out,
            "  {:<24} {:>14.6} {:>12.6}",
            t.names[k], t.values[k], t.sigma[k]
        )?;
    }
    if record.covariance.is_empty() {
        writeln!(out, "\ncovariance: not computed")?;
        return Ok(());
    }
    writeln!(
        out,
        "\nposterior covariance as correlations (row k: parameter k; sigma above)"
    )?;
    let c = &record.covariance;
    for (k, row) in c.iter().enumerate() {
        write!(out, "  {:<24}", t.names[k])?;
        for (j, v) in row.iter().enumerate() {
            let denominator = (c[k][k] * c[j][j]).sqrt();
            let r = if denominator > 0.0 {
                v / denominator
            } else {
                0.0
            };
            write!(out, " {r:>5.2}")?;
        }
        writeln!(out)?;
    }
    Ok(())
}
