//! Log-log plot (SVG) of the time per iteration against the number of contacts,
//! 1 and 2 threads, from criterion's estimates of `cargo bench --bench
//! iteration` (target/criterion/iteration/<threads>/<contacts>/new/estimates.json).
//!
//! `cargo run -p parcal-benches --example plot_iteration -- docs/performance-iteration.svg`

use std::path::Path;

use parcal_report::plots::{LineChart, Series, line_chart};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let out = std::env::args()
        .nth(1)
        .unwrap_or_else(|| "performance-iteration.svg".into());
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../target/criterion/iteration");
    let mut series = Vec::new();
    for (threads, name) in [("1-thread", "1 thread"), ("2-thread", "2 threads")] {
        let mut points = Vec::new();
        for contacts in [1_000u32, 10_000, 100_000, 1_000_000] {
            let path = root
                .join(threads)
                .join(contacts.to_string())
                .join("new/estimates.json");
            let Ok(text) = std::fs::read_to_string(&path) else {
                continue;
            };
            let estimates: serde_json::Value = serde_json::from_str(&text)?;
            let nanoseconds = estimates["mean"]["point_estimate"]
                .as_f64()
                .ok_or("no mean in estimates.json")?;
            println!(
                "{threads} {contacts} contacts: {:.4} s per iteration",
                nanoseconds * 1e-9
            );
            points.push((f64::from(contacts), nanoseconds * 1e-9));
        }
        series.push((name, points));
    }
    let series: Vec<Series> = series
        .iter()
        .map(|(name, points)| Series { name, points })
        .collect();
    line_chart(
        Path::new(&out),
        &LineChart {
            title: "One Gauss-Newton iteration, simulation IV, propagated prior",
            x_label: "contacts",
            y_label: "time per iteration / s",
            series: &series,
            log_x: true,
            log_y: true,
        },
    )?;
    println!("wrote {out}");
    Ok(())
}
