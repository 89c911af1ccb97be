//! Scale: a million contacts load from a snapshot in well under a second;
//! the CSV reader streams.

use crate::common;

use std::fs;
use std::time::Instant;

use common::*;
use parcal_dataset::*;

/// A dataset of `rows` contacts on 1000 balls, with directions and truth.
fn large(rows: usize) -> Dataset {
    let mut d = dataset(ALL);
    let template = d.artefacts.balls[0].clone();
    d.artefacts.distances.clear();
    d.artefacts.balls = (0..1000)
        .map(|i| Ball {
            id: format!("b{i:04}"),
            centre: [i as f64, 1.0 / 3.0, 400.0],
            ..template.clone()
        })
        .collect();
    let ball: Vec<u32> = (0..rows).map(|r| (r % 1000) as u32).collect();
    let q: Vec<[f64; 6]> = (0..rows)
        .map(|r| std::array::from_fn(|k| 100.0 + (r * 6 + k) as f64 / 7.0))
        .collect();
    let points: Vec<Point3> = (0..rows).map(|r| [r as f64 / 3.0, -1.0, 0.5]).collect();
    let truth = d.truth.as_mut().unwrap();
    truth.ball_centres = d.artefacts.balls.iter().map(|b| b.centre).collect();
    truth.ball_radii = vec![5.0; 1000];
    truth.contacts = points.clone();
    d.measurements = Measurements {
        ball,
        q,
        direction: Some(points),
    };
    d
}

/// A million contacts round-trip through a snapshot (the time it took is
/// printed, not judged: speed lives in the benchmarks).
#[test]
fn a_million_contacts_round_trip_through_a_snapshot() {
    let d = large(1_000_000);
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("large.parcal");
    d.write_snapshot(&path).unwrap();
    let start = Instant::now();
    let read = Dataset::read_snapshot(&path).unwrap();
    eprintln!(
        "snapshot: {} MB, 10^6 contacts (q, directions, truth) read in {:?}",
        fs::metadata(&path).unwrap().len() / 1_000_000,
        start.elapsed()
    );
    assert!(read == d);
}

#[test]
fn a_hundred_thousand_rows_stream_from_csv() {
    let d = large(100_000);
    let dir = tempfile::tempdir().unwrap();
    d.write(dir.path()).unwrap();
    let start = Instant::now();
    let read = Dataset::read(dir.path()).unwrap();
    eprintln!(
        "text files: 10^5 contacts (with truth.json) read in {:?}",
        start.elapsed()
    );
    assert_bitwise_eq(&read, &d);
}

/// Run by hand (`cargo test -p parcal-dataset --test integration scale:: -- --ignored
/// --nocapture`): the time to read 10^6 rows from the text files.
#[test]
#[ignore = "slow (writes ~200 MB); run by hand to time the text reader"]
fn a_million_rows_stream_from_csv() {
    let mut d = large(1_000_000);
    d.truth = None;
    let dir = tempfile::tempdir().unwrap();
    d.write(dir.path()).unwrap();
    let start = Instant::now();
    let read = Dataset::read(dir.path()).unwrap();
    eprintln!(
        "text files: 10^6 rows with directions ({} MB of CSV) read in {:?}",
        fs::metadata(dir.path().join(MEASUREMENTS_FILE))
            .unwrap()
            .len()
            / 1_000_000,
        start.elapsed()
    );
    assert_bitwise_eq(&read, &d);
}
