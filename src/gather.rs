//! `colorvision gather DIR`: one table of every run under `DIR` (a sweep folder, or any folder
//! of run folders), written as `DIR/gather.csv`, `DIR/gather.md` and `DIR/index.html` (each run
//! linked to its report, [`index`]) and printed as Markdown;
//! `--markdown` prints only the Markdown table (for the README) and writes nothing.
//!
//! A run folder is a folder holding `config.toml` or `summary.json`; folders inside a run
//! folder are not searched. Its numbers come from `summary.json` alone; its status is:
//! - `done`: `summary.json` reads;
//! - `unreadable`: `summary.json` does not read (reported on stderr by path; gather goes on);
//! - `running`: the run's `.lock` is there ([`crate::run_lock`]; the pid may be on another
//!   node, so it is shown, not checked);
//! - `failed`: the `failed.json` a sweep task leaves ([`crate::sweep::task::Failure`]), with
//!   its error;
//! - `stopped`: checkpoints but no summary (interrupted: `resume` continues it);
//! - `pending`: nothing yet.
//!
//! Steps of an unfinished run are those of its newest checkpoint folder (`step_<k>`). The
//! settings shown are those that vary between the runs ([`table::varying_keys`]). CMF-SIM's
//! dimension 0 is shown as `undefined` with the verdict's reason (e.g. no colour constancy).
//! A run that continued another run's cortex (`run --continue-from`, gene therapy, boosting)
//! has the setting `continued_from`: that run's folder name and step, from its `run.json` —
//! or the name of its record, when a gathered folder is the record of that run
//! ([`RECORD_FILE`]: `scripts/record-run.sh` copies a run's small files into `results/NAME` and
//! says which folder it was trained in).
//!
//! A folder that lists the paper's experiments ([`paper_rows::ROWS_FILE`], as `results/` does)
//! gets the paper's table, row by row, above the table of runs ([`paper_rows`]). A run whose
//! checkpoints CMF-SIM measured (`colorvision convergence --cmf`, [`OVER_CHECKPOINTS_FILE`])
//! shows there, beside its final figure, the dimensions at those checkpoints and its own end,
//! and how they read: settled, rising, falling or on the border ([`crate::convergence::verdict`]);
//! a run whose late checkpoints were averaged (`colorvision average`,
//! [`crate::averaging::averaged_path`]) shows the averaged cortex's figure after them.
//!
//! Runs whose colour-matching functions were compared with Stiles & Burch (`colorvision
//! stiles-burch --run DIR`) get a table of their own below the runs' table ([`stiles_burch`]);
//! runs with two cone classes, a table of their Neural Scope's hue axis beside an ideal
//! dichromat's ([`hue_axes`]).

pub mod hue_axes;
pub mod index;
pub mod paper_rows;
pub mod settings;
pub mod stiles_burch;
pub mod table;

pub(crate) use settings::run_settings;
pub use settings::{flatten, CONTINUED_FROM_KEY, RECORD_FILE};

use crate::averaging::Averaged;
use crate::convergence::{CheckpointCmf, VerdictOverCheckpoints};
use crate::run::Summary;
use crate::run_error::RunError;
use crate::sweep::task::{Failure, Manifest, FAILED_FILE};
use clap::Args;
use settings::{comparable, recorded_from};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Options of `gather`.
#[derive(Debug, Clone, Args)]
pub struct GatherOptions {
    /// A sweep folder, or any folder holding run folders (searched recursively).
    pub dir: PathBuf,
    /// Print only the Markdown table to stdout, and write no file.
    #[arg(long)]
    pub markdown: bool,
}

/// Where a run stands.
#[derive(Clone, Debug, PartialEq)]
pub enum Status {
    /// `summary.json` reads.
    Done,
    /// `summary.json` is there but does not read.
    Unreadable(String),
    /// A process holds the run's lock (its pid, if the lock names one).
    Running(Option<u32>),
    /// A sweep task failed with this error.
    Failed(String),
    /// Checkpoints, no summary: resumable.
    Stopped,
    /// Nothing run yet.
    Pending,
}

impl Status {
    /// One word.
    pub fn word(&self) -> &'static str {
        match self {
            Status::Done => "done",
            Status::Unreadable(_) => "unreadable",
            Status::Running(_) => "running",
            Status::Failed(_) => "failed",
            Status::Stopped => "stopped",
            Status::Pending => "pending",
        }
    }

    /// The error or detail that goes with the word.
    pub fn detail(&self) -> String {
        match self {
            Status::Unreadable(e) | Status::Failed(e) => e.clone(),
            Status::Running(Some(pid)) => format!("pid {pid}"),
            _ => String::new(),
        }
    }
}

/// One run folder, read.
#[derive(Clone, Debug)]
pub struct Run {
    /// Its path relative to the gathered folder (`.` for the folder itself).
    pub folder: String,
    /// Where it stands.
    pub status: Status,
    /// Its steps: the summary's, else the newest checkpoint's.
    pub steps: Option<u64>,
    /// Its summary, when done.
    pub summary: Option<Summary>,
    /// Its settings, flattened to dotted keys (from the summary, else `config.toml`).
    pub settings: BTreeMap<String, String>,
    /// Its colour-matching functions against Stiles & Burch, when measured
    /// ([`stiles_burch::TABLE_FILE`]).
    pub stiles_burch: Option<Vec<crate::stiles_burch::Row>>,
    /// CMF-SIM's verdict over its checkpoints, when `colorvision convergence --cmf` measured
    /// some ([`over_checkpoints`]).
    pub over_checkpoints: Option<VerdictOverCheckpoints>,
    /// The figure of its checkpoints' averaged weights, when `colorvision average` measured it
    /// into the run folder ([`crate::averaging::averaged_path`]).
    pub averaged: Option<Averaged>,
}

/// `colorvision gather`.
pub fn command(options: &GatherOptions) -> Result<(), RunError> {
    let dir = &options.dir;
    if !dir.is_dir() {
        return Err(RunError::Folder {
            path: dir.clone(),
            reason: "is not a folder".into(),
        });
    }
    let runs = gather(dir)?;
    if runs.is_empty() {
        return Err(RunError::Folder {
            path: dir.clone(),
            reason: "holds no run folder (a folder with config.toml or summary.json)".into(),
        });
    }
    let first = Manifest::read(dir).map(|m| m.keys).unwrap_or_default();
    let keys = table::varying_keys(&runs, &first);
    let mut markdown = table::markdown(&runs, &keys);
    if let Some(rows) = paper_rows::read(dir)? {
        let path = dir.join(paper_rows::ROWS_FILE);
        let paper = paper_rows::markdown(&rows, &runs, &path)?;
        markdown =
            format!("{paper}\nEvery run, with the settings that vary between runs:\n\n{markdown}");
    }
    for table in [stiles_burch::markdown(&runs), hue_axes::markdown(&runs)] {
        if !table.is_empty() {
            markdown = format!("{markdown}\n{table}");
        }
    }
    if options.markdown {
        print!("{markdown}");
        return Ok(());
    }
    crate::io::write_atomic(&dir.join("gather.csv"), table::csv(&runs, &keys).as_bytes())?;
    crate::io::write_atomic(&dir.join("gather.md"), markdown.as_bytes())?;
    index::write(dir, &runs, &keys)?;
    print!("{markdown}");
    let mut counts: BTreeMap<&str, usize> = BTreeMap::new();
    for r in &runs {
        *counts.entry(r.status.word()).or_default() += 1;
    }
    let counts: Vec<String> = counts.iter().map(|(w, n)| format!("{n} {w}")).collect();
    println!(
        "\n{} runs ({}); wrote {}/gather.csv, gather.md and index.html",
        runs.len(),
        counts.join(", "),
        dir.display()
    );
    Ok(())
}

/// Every run folder under `dir`, sorted by path; unreadable files are reported on stderr.
pub fn gather(dir: &Path) -> Result<Vec<Run>, RunError> {
    let mut folders = Vec::new();
    find_runs(dir, &mut folders)?;
    folders.sort();
    let names: Vec<String> = folders
        .iter()
        .map(|f| {
            let rel = f.strip_prefix(dir).unwrap_or(f).display().to_string();
            if rel.is_empty() {
                ".".into()
            } else {
                rel
            }
        })
        .collect();
    // A run continued from a run gathered here, or from a run recorded here, is named by that
    // run's row.
    let mut rows: BTreeMap<PathBuf, String> = folders
        .iter()
        .zip(&names)
        .filter_map(|(f, name)| Some((f.canonicalize().ok()?, name.clone())))
        .collect();
    for (f, name) in folders.iter().zip(&names) {
        if let Some(trained_in) = recorded_from(f) {
            rows.entry(comparable(&trained_in))
                .or_insert_with(|| name.clone());
        }
    }
    Ok(folders
        .iter()
        .zip(names)
        .map(|(f, name)| read_run(f, name, &rows))
        .collect())
}

fn is_run_folder(dir: &Path) -> bool {
    dir.join("config.toml").is_file() || dir.join("summary.json").is_file()
}

fn find_runs(dir: &Path, out: &mut Vec<PathBuf>) -> Result<(), RunError> {
    if is_run_folder(dir) {
        out.push(dir.to_path_buf());
        return Ok(());
    }
    for entry in std::fs::read_dir(dir).map_err(crate::io::fs_err(dir))? {
        let path = entry.map_err(crate::io::fs_err(dir))?.path();
        let hidden = path
            .file_name()
            .is_some_and(|n| n.to_string_lossy().starts_with('.'));
        if path.is_dir() && !hidden {
            find_runs(&path, out)?;
        }
    }
    Ok(())
}

/// Reads one run folder; a file that does not read is reported by path.
fn read_run(dir: &Path, folder: String, rows: &BTreeMap<PathBuf, String>) -> Run {
    let summary_path = dir.join("summary.json");
    let mut summary = None;
    let status = if summary_path.is_file() {
        match Summary::read(&summary_path) {
            Ok(s) => {
                summary = Some(s);
                Status::Done
            }
            Err(e) => {
                eprintln!("colorvision gather: {}: {e}", summary_path.display());
                Status::Unreadable(e)
            }
        }
    } else if dir.join(crate::run_lock::LOCK_FILE).is_file() {
        let pid = std::fs::read_to_string(dir.join(crate::run_lock::LOCK_FILE))
            .ok()
            .and_then(|t| t.trim().parse().ok());
        Status::Running(pid)
    } else if dir.join(FAILED_FILE).is_file() {
        Status::Failed(read_failure(&dir.join(FAILED_FILE)))
    } else if newest_checkpoint(dir).is_some() {
        Status::Stopped
    } else {
        Status::Pending
    };
    let settings = match &summary {
        Some(s) => toml::Value::try_from(&s.config).map_err(|e| e.to_string()),
        None => read_toml(&dir.join("config.toml")),
    };
    let settings = settings.unwrap_or_else(|e| {
        if dir.join("config.toml").is_file() {
            eprintln!("colorvision gather: {}/config.toml: {e}", dir.display());
        }
        toml::Value::Table(Default::default())
    });
    let settings = run_settings(dir, &settings, rows);
    let steps = summary
        .as_ref()
        .map(|s| s.steps)
        .or_else(|| newest_checkpoint(dir));
    let stiles_burch = stiles_burch::read(dir).and_then(|r| {
        r.map_err(|e| {
            let path = dir.join(stiles_burch::TABLE_FILE);
            eprintln!("colorvision gather: {}: {e}", path.display());
        })
        .ok()
    });
    let over_checkpoints = over_checkpoints(dir, summary.as_ref());
    let averaged = averaged(dir);
    Run {
        folder,
        status,
        steps,
        summary,
        settings,
        stiles_burch,
        over_checkpoints,
        averaged,
    }
}

/// Where a run folder (and its record) keeps the CMF-SIM of the checkpoints `colorvision
/// convergence --cmf` measured.
pub const OVER_CHECKPOINTS_FILE: &str = "convergence/cmf_over_checkpoints.json";

/// CMF-SIM's verdict over the checkpoints measured in `dir` ([`OVER_CHECKPOINTS_FILE`], those
/// up to the run's steps) and the run's own final measurement; `None` without two such
/// measurements. A file that does not read is reported on stderr and passed over.
fn over_checkpoints(dir: &Path, summary: Option<&Summary>) -> Option<VerdictOverCheckpoints> {
    let path = dir.join(OVER_CHECKPOINTS_FILE);
    let text = std::fs::read_to_string(&path).ok()?;
    let points: Vec<CheckpointCmf> = serde_json::from_str(&text)
        .map_err(|e| eprintln!("colorvision gather: {}: {e}", path.display()))
        .ok()?;
    VerdictOverCheckpoints::with_final(points, summary.and_then(CheckpointCmf::final_of))
}

/// What `colorvision average` measured of `dir`'s checkpoints, when it wrote into `dir`
/// ([`crate::averaging::averaged_path`]); a file that does not read is reported on stderr and
/// passed over.
fn averaged(dir: &Path) -> Option<Averaged> {
    let path = crate::averaging::averaged_path(dir);
    if !path.is_file() {
        return None;
    }
    Averaged::read(&path)
        .map_err(|e| eprintln!("colorvision gather: {}: {e}", path.display()))
        .ok()
}

fn read_failure(path: &Path) -> String {
    match crate::io::read_json::<Failure>(path) {
        Ok(f) => format!("{} (exit {})", f.error, f.exit_code),
        Err(e) => format!("{} does not read: {e}", path.display()),
    }
}

fn read_toml(path: &Path) -> Result<toml::Value, String> {
    let text = std::fs::read_to_string(path).map_err(|e| e.to_string())?;
    toml::from_str(&text).map_err(|e| crate::config::one_line(&e.to_string()))
}

/// The step of the newest `checkpoints/step_<k>` folder.
fn newest_checkpoint(dir: &Path) -> Option<u64> {
    std::fs::read_dir(dir.join("checkpoints"))
        .ok()?
        .filter_map(|e| e.ok())
        .filter_map(|e| {
            e.file_name()
                .to_string_lossy()
                .strip_prefix("step_")?
                .parse()
                .ok()
        })
        .max()
}

/// A finished run named `folder` whose summary is the recorded run `results/RECORD`'s, passed
/// through `edit`, with the setting `cones` (for the tables' tests).
#[cfg(test)]
pub(crate) fn recorded_run(
    folder: &str,
    cones: &str,
    record: &str,
    edit: impl FnOnce(&mut Summary),
) -> Run {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let path = root.join("results").join(record).join("summary.json");
    let mut summary = Summary::read(&path).unwrap();
    edit(&mut summary);
    Run {
        folder: folder.into(),
        status: Status::Done,
        steps: Some(summary.steps),
        summary: Some(summary),
        settings: [("cones".to_string(), cones.to_string())].into(),
        stiles_burch: None,
        over_checkpoints: None,
        averaged: None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
}
