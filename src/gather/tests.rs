//! Reading a run folder: the verdict over its checkpoints and its averaged weights.

use super::read::{over_checkpoints, read_run};
use super::*;
use crate::convergence::CheckpointCmf;

/// The checkpoints measured on the way and the run's own final figure make one verdict;
/// a checkpoint past the run's steps (a later continuation measured in the same folder)
/// is not the run's, and a file that does not read is passed over.
#[test]
fn the_verdict_over_checkpoints_joins_the_final_figure() {
    let dir = std::env::temp_dir().join(format!("cv_gather_over_{}", std::process::id()));
    std::fs::create_dir_all(dir.join("convergence")).unwrap();
    let summary = recorded_run("x", "LMS", "LMSQ-humanQ-idealised-40k", |_| {})
        .summary
        .unwrap();
    assert_eq!((summary.steps, summary.dimension), (40_000, 3));
    let at = |step, dimension, margin| CheckpointCmf {
        step,
        dimension,
        per_k: vec![[dimension as f64, 1.0, margin]],
    };
    let points = [at(36_000, 3, 0.84), at(38_000, 4, 0.80), at(44_000, 4, 0.7)];
    let path = dir.join(OVER_CHECKPOINTS_FILE);
    std::fs::write(&path, serde_json::to_string(&points).unwrap()).unwrap();
    let verdict = over_checkpoints(&dir, Some(&summary)).unwrap();
    assert_eq!(verdict.steps, vec![36_000, 38_000, 40_000]);
    assert_eq!(verdict.dimensions, vec![3, 4, 3]);
    let k3 = verdict.per_k.iter().find(|k| k.k == 3).unwrap();
    assert_eq!((k3.tried, k3.passed), (2, 2), "{verdict:?}");
    std::fs::write(&path, "[{").unwrap();
    assert_eq!(over_checkpoints(&dir, Some(&summary)), None);
    std::fs::remove_dir_all(&dir).ok();
}

/// `average`'s figure in the run folder is read with the run; one that does not read is
/// passed over (and reported), not taken for the run's.
#[test]
fn the_averaged_weights_figure_is_read_with_the_run() {
    let dir = std::env::temp_dir().join(format!("cv_gather_avg_{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(dir.join(crate::averaging::AVERAGE_DIR)).unwrap();
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("results");
    let record = root.join("LMSQ-humanQ-idealised-48k");
    std::fs::copy(record.join("summary.json"), dir.join("summary.json")).unwrap();
    let rows = BTreeMap::new();
    assert_eq!(read_run(&dir, "x".into(), &rows).averaged, None);
    let file = crate::averaging::averaged_path(&dir);
    std::fs::copy(crate::averaging::averaged_path(&record), &file).unwrap();
    let averaged = read_run(&dir, "x".into(), &rows).averaged.unwrap();
    assert_eq!((averaged.steps.len(), averaged.dimension), (8, 3));
    assert_eq!(averaged.steps[0], 34_000);
    std::fs::write(&file, "{").unwrap();
    let run = read_run(&dir, "x".into(), &rows);
    assert_eq!((run.status, run.averaged), (Status::Done, None));
    std::fs::remove_dir_all(&dir).ok();
}

/// A fresh folder in the temporary directory holding only the default run's recorded summary:
/// a finished run folder for a test to add files to.
fn finished_run_folder(tag: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("cv_gather_{tag}_{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let record = Path::new(env!("CARGO_MANIFEST_DIR")).join("results/LMS-main-surfaces-12k");
    std::fs::copy(record.join("summary.json"), dir.join("summary.json")).unwrap();
    dir
}

/// The final checkpoint measured with other location seeds (a verdict on the border) makes the
/// run's dimension the median of all; the run's own seed, another step's measurement, an even
/// count and a file that does not read leave its own figure.
#[test]
fn other_location_seeds_on_the_final_checkpoint_give_the_median() {
    let dir = finished_run_folder("loc");
    let measure = |name: &str, text: &str| {
        std::fs::create_dir_all(dir.join(name)).unwrap();
        std::fs::write(dir.join(name).join("cmf_sim.json"), text).unwrap();
    };
    let read = || read_run(&dir, "x".into(), &BTreeMap::new());
    let run = read();
    assert_eq!(
        (run.dimension(), run.other_location_seeds.len()),
        (Some(3), 0)
    );
    measure("cmf-sim-step12000-loc0", r#"{"dimension": 1}"#); // the run's own seed
    measure("cmf-sim-step6000-loc1", r#"{"dimension": 1}"#); // another checkpoint
    measure("cmf-sim-step12000-loc1", r#"{"dimension": 2}"#);
    let run = read();
    assert_eq!(run.other_location_seeds, vec![(1, 2)]);
    assert_eq!(run.dimension(), Some(3), "two measurements have no median");
    let cell = super::table::dimension_cell(&run);
    assert!(
        cell.starts_with("3 (K1 ") && cell.ends_with("; other location seeds: 2 at 1"),
        "{cell}"
    );
    measure("cmf-sim-step12000-loc2", r#"{"dimension": 2}"#);
    let run = read();
    assert_eq!(run.other_location_seeds, vec![(1, 2), (2, 2)]);
    assert_eq!(run.dimension(), Some(2), "3, 2, 2: the median is 2");
    let cell = super::table::dimension_cell(&run);
    assert!(
        cell.starts_with("2 (median of 3 location seeds; its own: 3 (K1 ")
            && cell.ends_with("; the others: 2 at 1, 2 at 2)"),
        "{cell}"
    );
    measure("cmf-sim-step12000-loc2", "{");
    assert_eq!(
        read().dimension(),
        Some(3),
        "a file that does not read is passed over"
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// Undefined readings at other location seeds (dimension 0) are said as "undefined", and so is
/// their median.
#[test]
fn undefined_readings_at_other_location_seeds_are_said_as_undefined() {
    let dir = finished_run_folder("loc_undefined");
    for l in [1, 2] {
        let name = format!("cmf-sim-step12000-loc{l}");
        std::fs::create_dir_all(dir.join(&name)).unwrap();
        std::fs::write(dir.join(&name).join("cmf_sim.json"), r#"{"dimension": 0}"#).unwrap();
    }
    let run = read_run(&dir, "x".into(), &BTreeMap::new());
    assert_eq!(run.dimension(), Some(0), "3, 0, 0: the median is 0");
    let cell = super::table::dimension_cell(&run);
    assert!(
        cell.starts_with("undefined (median of 3 location seeds; its own: 3 (K1 ")
            && cell.ends_with("; the others: undefined at 1, undefined at 2)"),
        "{cell}"
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// A protocol arm trained without measuring (`train`) and measured at three location seeds on
/// its last checkpoint reads as their median, its own seed among them.
#[test]
fn an_arm_measured_only_at_location_seeds_reads_as_their_median() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("results");
    for (record, dimension) in [
        ("slow-colour-A0-seed0-12k", 2),
        ("slow-colour-B1-seed3-12k", 3),
    ] {
        let run = read_run(&root.join(record), "x".into(), &BTreeMap::new());
        let seeds: Vec<(u64, usize)> = (0..3).map(|seed| (seed, dimension)).collect();
        assert_eq!(run.other_location_seeds, seeds, "{record}");
        assert_eq!(run.dimension(), Some(dimension), "{record}");
    }
}

/// A record that names the protocol it was run under has that protocol among its settings; one
/// without, or whose record does not read, has none (it was measured before any protocol).
#[test]
fn a_record_names_its_protocol() {
    let dir = finished_run_folder("protocol");
    let protocol = |text: &str| {
        std::fs::write(dir.join(RECORD_FILE), text).unwrap();
        let run = read_run(&dir, "x".into(), &BTreeMap::new());
        run.settings.get(PROTOCOL_KEY).cloned()
    };
    let page = "docs/notebook/p.md @ f0603a6";
    let with = format!(r#"{{"trained_in": "/elsewhere/x", "protocol": "{page}"}}"#);
    assert_eq!(protocol(&with).as_deref(), Some(page));
    assert_eq!(protocol(r#"{"trained_in": "/elsewhere/x"}"#), None);
    assert_eq!(
        protocol(r#"{"protocol": "#),
        None,
        "a record that does not read"
    );
    std::fs::remove_dir_all(&dir).ok();
}
