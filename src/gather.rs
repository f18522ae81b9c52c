//! `colorvision gather DIR`: one table of every run under `DIR` (a sweep folder, or any folder
//! of run folders), written as `DIR/gather.csv`, `DIR/gather.md` and `DIR/index.html` (each run
//! linked to its report, [`index`]) and printed as Markdown. `--markdown` prints one text and
//! writes nothing ([`MarkdownPart`]): the README's answer to "Does it reproduce the paper?"
//! ([`readme_table`]), the page of the paper's rows ([`rows_page`]) or the page of every run
//! ([`runs_page`]).
//!
//! A run folder is a folder holding `config.toml` or `summary.json`; folders inside a run
//! folder are not searched. Its numbers come from `summary.json` alone; its status is:
//! - `done`: `summary.json` reads;
//! - `unreadable`: `summary.json` does not read (reported on stderr by path; gather goes on);
//! - `running`: the run's `.lock` is there ([`crate::run::lock`]; the pid may be on another
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
//! and how they read: settled, rising, falling or on the border ([`science::verdict`]);
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
mod read;
pub mod readme_table;
pub mod rows_page;
pub mod runs_page;
pub mod settings;
pub mod stiles_burch;
pub mod table;

pub use read::OVER_CHECKPOINTS_FILE;
pub(crate) use settings::run_settings;
pub use settings::{flatten, CONTINUED_FROM_KEY, PROTOCOL_KEY, RECORD_FILE};

use crate::averaging::Averaged;
use crate::convergence::VerdictOverCheckpoints;
use crate::run::error::RunError;
use crate::sweep::task::Manifest;
use clap::Args;
use read::read_run;
use science::summary::Summary;
use settings::{comparable, recorded_from};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Options of `gather`.
#[derive(Debug, Clone, Args)]
pub struct GatherOptions {
    /// A sweep folder, or any folder holding run folders (searched recursively).
    pub dir: PathBuf,
    /// Print one Markdown text to stdout, and write no file: `--markdown` (or `=readme`) the
    /// README's table (with results/paper-rows.toml: the paper's experiments and the tally;
    /// else every run), `=rows` the page of the paper's rows (docs/results.md), `=runs` the
    /// page of every run (results/index.md).
    #[arg(long, value_enum, num_args = 0..=1, require_equals = true, default_missing_value = "readme")]
    pub markdown: Option<MarkdownPart>,
}

/// The texts `gather --markdown` prints.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum MarkdownPart {
    /// The README's table: the paper's rows in brief with their tally, else every run.
    Readme,
    /// The page of the paper's rows: one section per row, verdict first, then the evidence.
    Rows,
    /// The page of every run: the settings that vary, the figures, the invariants.
    Runs,
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
    /// some ([`OVER_CHECKPOINTS_FILE`]).
    pub over_checkpoints: Option<VerdictOverCheckpoints>,
    /// CMF-SIM's dimension on its final checkpoint with location seeds other than the one its
    /// summary measured, by seed, where they were measured (`cmf-sim-step<N>-loc<L>/`: a verdict
    /// on the border, or a protocol's arm trained without measuring).
    pub other_location_seeds: Vec<(u64, usize)>,
    /// The figure of its checkpoints' averaged weights, when `colorvision average` measured it
    /// into the run folder ([`crate::averaging::averaged_path`]).
    pub averaged: Option<Averaged>,
}

impl Run {
    /// The dimension the run measured at its end, when it measured one: the median over its
    /// final checkpoint's location seeds where there is one ([`Run::location_median`]), else
    /// its final CMF-SIM's — a verdict is not one draw of where the lights are shown.
    pub fn dimension(&self) -> Option<usize> {
        (self.location_median().map(|(median, _)| median)).or(self.own_dimension())
    }

    /// The median dimension over every location seed its final checkpoint was measured with
    /// (its own CMF-SIM's and [`Run::other_location_seeds`]: a verdict on the border, or a
    /// protocol's arm measured only that way) and how many, when they are an odd number of
    /// three or more.
    pub fn location_median(&self) -> Option<(usize, usize)> {
        let mut all: Vec<usize> = self.other_location_seeds.iter().map(|(_, d)| *d).collect();
        all.extend(self.own_dimension());
        if all.len() < 3 || all.len().is_multiple_of(2) {
            return None;
        }
        all.sort_unstable();
        Some((all[all.len() / 2], all.len()))
    }

    /// The dimension of the run's own final CMF-SIM, when the run measured itself.
    fn own_dimension(&self) -> Option<usize> {
        (self.summary.as_ref())
            .filter(|s| !s.dimension_over_steps.is_empty())
            .map(|s| s.dimension)
    }
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
    let rows = paper_rows::read(dir)?;
    let rows_path = dir.join(paper_rows::ROWS_FILE);
    let judged = match &rows {
        Some(rows) => Some(paper_rows::judge(rows, &runs, &rows_path)?),
        None => None,
    };
    let tables = || {
        let all = [table::markdown(&runs, &keys), extra_tables(&runs)];
        all.join("")
    };
    let text = match (options.markdown, &judged) {
        (Some(MarkdownPart::Readme), Some(judged)) => readme_table::markdown(judged),
        (Some(MarkdownPart::Readme), None) => tables(),
        (Some(MarkdownPart::Rows), Some(judged)) => rows_page::markdown(judged, dir),
        (Some(MarkdownPart::Rows), None) => {
            return Err(RunError::Folder {
                path: rows_path,
                reason: "not found: --markdown=rows writes the page of the paper's rows it lists"
                    .into(),
            })
        }
        (Some(MarkdownPart::Runs), _) => runs_page::markdown(&runs, &keys),
        (None, Some(judged)) => format!(
            "{}\nEvery run, with the settings that vary between runs:\n\n{}",
            readme_table::markdown(judged),
            tables()
        ),
        (None, None) => tables(),
    };
    print!("{text}");
    if options.markdown.is_some() {
        return Ok(());
    }
    crate::io::write_atomic(&dir.join("gather.csv"), table::csv(&runs, &keys).as_bytes())?;
    crate::io::write_atomic(&dir.join("gather.md"), text.as_bytes())?;
    index::write(dir, &runs, &keys)?;
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

/// The tables below the runs' table, each preceded by a blank line: the colour-matching
/// functions against Stiles & Burch ([`stiles_burch`]) and the dichromats' hue axes
/// ([`hue_axes`]), where any run has them.
pub fn extra_tables(runs: &[Run]) -> String {
    let tables = [stiles_burch::markdown(runs), hue_axes::markdown(runs)];
    tables
        .iter()
        .filter(|t| !t.is_empty())
        .map(|t| format!("\n{t}"))
        .collect()
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
        other_location_seeds: Vec::new(),
        averaged: None,
    }
}

#[cfg(test)]
mod tests;
