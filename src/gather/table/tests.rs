//! Tests of the paper's table and the runs' table: rows, cells, captions and what they say.

use super::*;
use crate::gather::Status;

fn run(folder: &str, settings: &[(&str, &str)], status: Status) -> Run {
    Run {
        folder: folder.into(),
        status,
        steps: None,
        summary: None,
        stiles_burch: None,
        over_checkpoints: None,
        other_location_seeds: Vec::new(),
        averaged: None,
        settings: settings
            .iter()
            .map(|(k, v)| (k.to_string(), v.to_string()))
            .collect(),
    }
}

#[test]
fn derived_settings_get_no_column_of_their_own() {
    let runs = [
        ("a", "LMS", "0", "11", "x"),
        ("b", "LMS", "1", "22", "x"),
        ("c", "LM", "0", "11", "y"),
        ("d", "LM", "1", "22", "y"),
    ]
    .map(|(f, cones, seed, derived, nested)| {
        let s = [
            ("cones", cones),
            ("seed", seed),
            ("retina.mosaic_seed", derived),
            ("retina.cones", nested),
            ("steps", "5"),
        ];
        run(f, &s, Status::Pending)
    });
    assert_eq!(varying_keys(&runs, &[]), ["cones", "seed"]);
    // A grid key named first keeps its column even when nested.
    let first = ["retina.cones".to_string()];
    assert_eq!(varying_keys(&runs, &first), ["retina.cones", "seed"]);
}

#[test]
fn a_setting_of_one_run_keeps_its_column_though_other_columns_single_the_run_out() {
    // `e` is the only run on a larger eye; cones and seed already make every row unique.
    let runs = [
        ("a", "LMS", "0", "64"),
        ("b", "LMS", "1", "64"),
        ("c", "LM", "0", "64"),
        ("d", "LM", "1", "64"),
        ("e", "LMS", "2", "128"),
    ]
    .map(|(f, cones, seed, size)| {
        let s = [
            ("cones", cones),
            ("seed", seed),
            ("retina.cones_per_side", size),
            // When it measured is no setting of what it learned: no column.
            ("schedule.cmf_every_steps", f),
        ];
        run(f, &s, Status::Pending)
    });
    let keys = varying_keys(&runs, &[]);
    assert_eq!(keys, ["cones", "seed", "retina.cones_per_side"]);
}

#[test]
fn errors_are_escaped_in_both_tables() {
    let r = run(
        "x",
        &[],
        Status::Failed("bad | value, \"quoted\"\nsecond line".into()),
    );
    let md = markdown(std::slice::from_ref(&r), &[]);
    assert!(
        md.contains("failed: bad \\| value, \"quoted\" second line"),
        "{md}"
    );
    let csv = csv(&[r], &[]);
    assert!(
        csv.contains(",\"bad | value, \"\"quoted\"\"\nsecond line\","),
        "{csv}"
    );
    assert_eq!(md.lines().next().unwrap().matches('|').count(), 15);
}

#[test]
fn an_unset_setting_reads_as_unset_in_the_readable_table_only() {
    let cones = ("cones", "LMSQ");
    let hue = ("retina.scenes.tetra.environment", "HueSphere");
    let runs = [
        run("natural", &[cones], Status::Pending),
        run("hue", &[cones, hue], Status::Pending),
    ];
    let keys = varying_keys(&runs, &[]);
    assert_eq!(keys, ["retina.scenes.tetra.environment"]);
    let (_, rows) = display(&runs, &keys);
    assert_eq!(
        (rows[0][1].as_str(), rows[1][1].as_str()),
        (UNSET_SETTING, "HueSphere")
    );
    let csv = csv(&runs, &keys);
    assert!(
        csv.lines().nth(1).unwrap().starts_with("natural,,"),
        "{csv}"
    );
}

#[test]
fn the_directions_column_reads_each_direction_s_r2_and_is_empty_when_not_measured() {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/results/LMS-quick-6k/summary.json"
    );
    let mut summary = science::summary::Summary::read(std::path::Path::new(path))
        .expect("the quick run's record reads");
    let recovery = &mut summary.invariants.as_mut().unwrap().recovery;
    recovery.directions = Some(science::invariants::directions::DirectionRecovery {
        classes: vec!["L".into(), "M".into(), "S".into()],
        weights: vec![vec![1.0, 0.0, 0.0]; 3],
        share: vec![0.6, 0.3, 0.1],
        r2: vec![0.934, 0.5, f64::NAN],
    });
    let measured = Run {
        summary: Some(summary.clone()),
        ..run("measured", &[], Status::Done)
    };
    summary.invariants.as_mut().unwrap().recovery.directions = None;
    let before = Run {
        summary: Some(summary),
        ..run("before", &[], Status::Done)
    };
    let runs = [measured, before];
    let (head, rows) = display(&runs, &[]);
    let column = head.iter().position(|h| h == "directions R²").unwrap();
    assert_eq!(
        (rows[0][column].as_str(), rows[1][column].as_str()),
        ("0.93/0.50/—", "")
    );
    let csv = csv(&runs, &[]);
    let column = csv
        .lines()
        .next()
        .unwrap()
        .split(',')
        .position(|h| h == "directions_r2");
    let cells: Vec<&str> = csv
        .lines()
        .skip(1)
        .map(|l| l.split(',').nth(column.unwrap()).unwrap())
        .collect();
    assert_eq!(cells, ["0.9340/0.5000/—", ""], "{csv}");
}

#[test]
fn the_paper_column_shows_what_the_paper_reports_for_each_run() {
    let environment = "retina.scenes.tetra.environment";
    let runs = [
        run("human", &[("cones", "LMSQ")], Status::Pending),
        run(
            "ideal",
            &[("cones", "LMSQ"), (environment, "Idealised")],
            Status::Pending,
        ),
        run("pigeon", &[("cones", "LMSQ,Q:506")], Status::Pending),
        run("custom", &[("cones", "L:560,S:419,X:600")], Status::Pending),
    ];
    let keys = varying_keys(&runs, &[]);
    let (head, rows) = display(&runs, &keys);
    let paper = dimension_column(&keys) - 1;
    assert_eq!(head[paper], "paper");
    let column: Vec<&str> = rows.iter().map(|r| r[paper].as_str()).collect();
    assert_eq!(column, ["3", "4", "4", "—"]);
    // Without setting columns (cones hold commas): run, status, detail, steps, wall, paper.
    let csv = csv(&runs, &[]);
    let csv_column: Vec<&str> = csv.lines().map(|l| l.split(',').nth(5).unwrap()).collect();
    assert_eq!(csv_column, ["paper_dimension", "3", "4", "4", ""], "{csv}");
}
