//! Convergence of a run: every checkpoint of a run folder measured the same way — the learned
//! invariants against the eye's truth ([`science::invariants`]), optionally the calibrated
//! CMF-SIM with the run's full budget, and the held-out prediction gain the run logged — so
//! learning can be followed over steps (`colorvision convergence --run DIR [--cmf]`).
//!
//! Each checkpoint's measurement is kept in `DIR/convergence/step_<step>.json` and reused on
//! the next call (a study of a run still training picks up only its new checkpoints). The
//! table lands in `convergence.md` / `convergence.json`, the plots in `convergence_*.svg`.

mod report;
pub mod runs;

pub use report::table;
pub use science::verdict::{
    CheckpointCmf, CmfPoint, Reading, StudyRow, VerdictOverCheckpoints, CMF_FILE,
};

use crate::io::write_atomic;
use crate::run::error::RunError;
use cortex::Trainer;
use science::config::RunConfig;
use science::invariants;
use science::observer::ObserverKind;
use std::path::{Path, PathBuf};

/// At which checkpoints CMF-SIM measures.
#[derive(Clone, Debug, PartialEq)]
pub enum CmfAt {
    /// Nowhere (invariants only).
    Never,
    /// At every checkpoint.
    Every,
    /// At these steps.
    Steps(Vec<u64>),
}

impl CmfAt {
    fn at(&self, step: u64) -> bool {
        match self {
            CmfAt::Never => false,
            CmfAt::Every => true,
            CmfAt::Steps(s) => s.contains(&step),
        }
    }
}

/// Measures every checkpoint of the run folder `dir` (only those at the steps in `only` where
/// it is not empty; CMF-SIM where `cmf` says; the hidden and direction R² on `held_out_scenes`
/// held-out scenes), writes the table and plots of every checkpoint measured so far (this
/// call's and the kept ones), and returns those rows in step order.
pub fn study(
    dir: &Path,
    cmf: &CmfAt,
    only: &[u64],
    held_out_scenes: usize,
) -> Result<Vec<StudyRow>, RunError> {
    let config = crate::run::folder::read_valid_config(dir)?;
    let gains = heldout_gains(&dir.join("metrics.csv"));
    let out = dir.join("convergence");
    std::fs::create_dir_all(&out).map_err(|source| crate::io::IoError::Fs {
        path: out.clone(),
        source,
    })?;
    let mut checkpoints = cortex::checkpoint::newest_first(&dir.join("checkpoints"))?;
    checkpoints.reverse();
    let mut rows = Vec::new();
    for path in checkpoints {
        // A checkpoint whose metadata does not read goes on to be skipped with its error.
        let step = cortex::checkpoint::read_meta(&path).map(|m| m.step).ok();
        if let Some(step) = step.filter(|s| !only.is_empty() && !only.contains(s)) {
            rows.extend(kept_row(&out, step));
            continue;
        }
        match measure_checkpoint(&path, &config, &gains, &out, cmf, held_out_scenes) {
            Ok(row) => rows.push(row),
            Err(e) => println!("  {}: skipped ({e})", path.display()),
        }
    }
    let last = final_measurement(dir);
    report::write_outputs(&out, &config, &rows, last.clone())?;
    let points = VerdictOverCheckpoints::points_of(&rows);
    if let Some(verdict) = VerdictOverCheckpoints::with_final(points, last) {
        println!("  {}", verdict.describe());
    }
    Ok(rows)
}

/// The CMF-SIM the run in `dir` measured at its end (`summary.json`), if it finished and
/// measured one; a summary that does not read is reported and passed over.
fn final_measurement(dir: &Path) -> Option<CheckpointCmf> {
    let path = dir.join("summary.json");
    if !path.is_file() {
        return None;
    }
    match science::summary::Summary::read(&path) {
        Ok(summary) => CheckpointCmf::final_of(&summary),
        Err(e) => {
            println!(
                "  {}: does not read ({e}); the verdict leaves it out",
                path.display()
            );
            None
        }
    }
}

fn row_path(out: &Path, step: u64) -> PathBuf {
    out.join(format!("step_{step:08}.json"))
}

/// The measurement of the checkpoint at `step` kept in `out`, if any.
fn kept_row(out: &Path, step: u64) -> Option<StudyRow> {
    let text = std::fs::read_to_string(row_path(out, step)).ok()?;
    serde_json::from_str(&text).ok()
}

fn measure_checkpoint(
    path: &Path,
    config: &RunConfig,
    gains: &[(u64, f64)],
    out: &Path,
    cmf: &CmfAt,
    held_out_scenes: usize,
) -> Result<StudyRow, RunError> {
    // The metadata alone names the step; loading the trainer below verifies every checksum.
    let meta = cortex::checkpoint::read_meta(path)?;
    let with_cmf = cmf.at(meta.step);
    let cached = row_path(out, meta.step);
    // A kept row is reused when it holds every measure asked for on as many held-out scenes of
    // the hidden measures' stream; one written before the colour directions were measured, or
    // on other scenes, is measured again, keeping its CMF-SIM.
    let kept = kept_row(out, meta.step);
    if let Some(row) = &kept {
        if row.recovery.directions.is_some()
            && row.held_out_scenes == held_out_scenes
            && row.fresh_tiles
            && (row.cmf.is_some() || !with_cmf)
        {
            return Ok(row.clone());
        }
    }
    let trainer = Trainer::continue_from(path, Some(config.cortex.clone()))?;
    // The same held-out scenes at every checkpoint.
    let mut scenes = science::heldout::hidden_source(config)?;
    let recovery = invariants::measure_with_scenes(&trainer.cortex, &mut scenes, held_out_scenes);
    let cmf = if let Some(kept) = kept.and_then(|row| row.cmf) {
        Some(kept)
    } else if with_cmf {
        let r = science::measure::measure_observer(config, ObserverKind::Cortex, Some(&trainer))?;
        let (base, energy): (f64, f64) = (r.base_error.iter().sum(), r.energy.iter().sum());
        Some(CmfPoint {
            dimension: r.dimension,
            base_over_energy: base / energy.max(f64::MIN_POSITIVE),
            per_k: r
                .per_k
                .iter()
                .map(|k| {
                    [
                        k.n_primaries as f64,
                        f64::from(u8::from(k.passed)),
                        k.converged_worst_ratio,
                    ]
                })
                .collect(),
            seconds: r.seconds,
        })
    } else {
        None
    };
    let wall_seconds = meta
        .run_state
        .as_ref()
        .and_then(|s| s.get("wall_seconds"))
        .and_then(|v| v.as_f64());
    let row = StudyRow {
        step: meta.step,
        heldout_gain: gains
            .iter()
            .rev()
            .find(|(s, _)| *s <= meta.step)
            .map(|&(_, g)| g),
        wall_seconds,
        recovery,
        held_out_scenes,
        fresh_tiles: true,
        cmf,
    };
    let text = serde_json::to_string_pretty(&row).expect("plain data");
    write_atomic(&cached, text.as_bytes())?;
    println!("  step {}: {}", row.step, report::describe_row(&row));
    Ok(row)
}

/// `(step, improvement)` of every evaluated row of a run's metrics.csv (empty if unreadable).
fn heldout_gains(path: &Path) -> Vec<(u64, f64)> {
    let Ok(text) = std::fs::read_to_string(path) else {
        return Vec::new();
    };
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap_or("").split(',').collect();
    let Some(col) = header.iter().position(|&h| h == "improvement") else {
        return Vec::new();
    };
    lines
        .filter_map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            Some((f.first()?.parse().ok()?, f.get(col)?.parse().ok()?))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::run::{run, RunMode};

    #[test]
    fn every_checkpoint_is_measured_once_and_tabled() {
        let mut config = RunConfig::preset("tiny", "LM").unwrap();
        config.steps = 20;
        config.cortex.train.checkpoint_every_steps = 10;
        let dir =
            std::env::temp_dir().join(format!("colorvision_convergence_{}", std::process::id()));
        std::fs::remove_dir_all(&dir).ok();
        let mode = RunMode {
            cmf_sim: false,
            pictures: false,
            progress: false,
        };
        run(&config, &dir, mode).unwrap();
        let rows = study(&dir, &CmfAt::Never, &[], invariants::HELD_OUT_SCENES).unwrap();
        assert_eq!(
            rows.iter().map(|r| r.step).collect::<Vec<_>>(),
            vec![10, 20]
        );
        assert!(rows
            .iter()
            .all(|r| r.cmf.is_none() && r.recovery.c.is_some()));
        let md = std::fs::read_to_string(dir.join("convergence/convergence.md")).unwrap();
        assert_eq!(
            md.lines()
                .filter(|l| l.starts_with("| 10 ") || l.starts_with("| 20 "))
                .count(),
            2
        );
        // A second call reads the kept measurements instead of measuring again.
        let kept = dir.join("convergence/step_00000010.json");
        let before = std::fs::metadata(&kept).unwrap().modified().unwrap();
        let again = study(&dir, &CmfAt::Never, &[], invariants::HELD_OUT_SCENES).unwrap();
        assert_eq!(
            std::fs::metadata(&kept).unwrap().modified().unwrap(),
            before
        );
        assert_eq!(again.len(), 2);
        assert!(again.iter().all(|r| r.recovery.directions.is_some()));
        // Only the steps asked for; a kept row written before the colour directions existed
        // gets them and keeps its CMF-SIM.
        let mut old = again[1].clone();
        old.recovery.directions = None;
        old.cmf = Some(CmfPoint {
            dimension: 2,
            base_over_energy: 0.5,
            per_k: vec![[1.0, 0.0, 3.0], [2.0, 1.0, 0.5]],
            seconds: 1.0,
        });
        let text = serde_json::to_string(&old).unwrap();
        write_atomic(&dir.join("convergence/step_00000020.json"), text.as_bytes()).unwrap();
        let before = std::fs::metadata(&kept).unwrap().modified().unwrap();
        let only = study(&dir, &CmfAt::Never, &[20], invariants::HELD_OUT_SCENES).unwrap();
        assert_eq!(
            only.iter().map(|r| r.step).collect::<Vec<_>>(),
            vec![10, 20]
        );
        assert!(only[1].recovery.directions.is_some());
        assert_eq!(only[1].cmf.as_ref().map(|c| c.dimension), Some(2));
        // Step 10 was not asked for: listed from its kept row, not measured again.
        assert_eq!(
            std::fs::metadata(&kept).unwrap().modified().unwrap(),
            before
        );
        // On other held-out scenes the kept row is measured again (keeping its CMF-SIM), and
        // the table says which count each step used.
        let fewer = study(&dir, &CmfAt::Never, &[20], 8).unwrap();
        assert_eq!(
            fewer.iter().map(|r| r.held_out_scenes).collect::<Vec<_>>(),
            vec![invariants::HELD_OUT_SCENES, 8]
        );
        assert_eq!(fewer[1].cmf.as_ref().map(|c| c.dimension), Some(2));
        let md = std::fs::read_to_string(dir.join("convergence/convergence.md")).unwrap();
        let counts = format!(
            "on {} at step 10, 8 at step 20 held-out scenes",
            invariants::HELD_OUT_SCENES
        );
        assert!(md.contains(&counts), "{md}");
        // A kept row measured on the held-out eye's pool of reused tiles (written before the
        // hidden measures had their own stream) is measured again, on as many scenes.
        let mut reused = fewer[1].clone();
        reused.fresh_tiles = false;
        let text = serde_json::to_string(&reused).unwrap();
        write_atomic(&dir.join("convergence/step_00000020.json"), text.as_bytes()).unwrap();
        let again = study(&dir, &CmfAt::Never, &[20], 8).unwrap();
        assert!(again[1].fresh_tiles && again[1].held_out_scenes == 8);
        assert_eq!(again[1].cmf.as_ref().map(|c| c.dimension), Some(2));
        // The run's own final measurement joins CMF-SIM's verdict at the table's end.
        assert!(
            !md.contains("CMF-SIM at"),
            "one measurement is no verdict: {md}"
        );
        let last = CheckpointCmf::from_final(30, 3, &[(2, 1.2), (3, 0.5)]);
        let md = table(&config, &fewer, Some(last));
        assert!(md.contains("(steps 20–30): 2-D, 3-D — rising"), "{md}");
        // Two runs side by side: a line per run in each plot, every row of each in runs.md.
        let side = dir.join("side");
        let runs = [("a".to_string(), rows.clone()), ("b".to_string(), again)];
        runs::write(&side, &runs).unwrap();
        let svg = std::fs::read_to_string(side.join("runs_c_recall.svg")).unwrap();
        assert!(svg.contains(">a<") && svg.contains(">b<"), "{svg}");
        let md = std::fs::read_to_string(side.join("runs.md")).unwrap();
        let body: Vec<&str> = md.lines().skip(2).collect();
        assert_eq!(body.len(), 4, "{md}");
        assert!(
            body[0].starts_with("| 10 | a |") && body[3].starts_with("| 20 | b |"),
            "{md}"
        );
        std::fs::remove_dir_all(&dir).ok();
    }
}
