//! The paper's experiments, row by row: for each experiment of Kotani & Ng (ICLR 2025), the
//! gathered runs that measure it, each run's dimension beside the figure the paper reports for
//! that run's settings ([`science::paper`]), whether they agree, and — where they do not — the
//! runs that are evidence of why, with what they show ([`judge`]). The README's table
//! ([`super::readme_table`]) and the page of the rows ([`super::rows_page`]) are written from it.
//!
//! The rows are listed in [`ROWS_FILE`] in the gathered folder (`results/`):
//!
//! ```toml
//! [[row]]
//! name = "Boosting, human Q"
//! experiment = "LMS + human Q (545 nm), boosted, three environments"
//! runs = ["LMS-boost-humanQ-16k", "LMS-boost-humanQ-huesphere-16k"]
//! evidence = ["LMS-boost-humanQ-idealised-24k"]
//! why = "trained 8 000 steps more, it stays 3-D …"
//! ```
//!
//! Every figure is read from the runs' `summary.json` and the paper's figure from their
//! settings; only `name`, `experiment` and `why` are words. A row whose runs differ from the
//! paper must say why (`why`, which may be "not shown"); a run named that was not gathered is
//! an error naming the file, the row and the field, so no row can silently drop a run. A row
//! none of whose runs the paper has a figure for is a row beyond the paper.

use super::Run;
use science::config::ConfigError;
use science::paper::Reported;
use serde::Deserialize;
use std::path::Path;

/// The file in a gathered folder that lists the paper's rows.
pub const ROWS_FILE: &str = "paper-rows.toml";

/// [`ROWS_FILE`], read.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PaperRows {
    /// The rows, in the order the tables show them.
    pub row: Vec<PaperRow>,
}

/// One experiment of the paper.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PaperRow {
    /// A short name: the README table's first cell and the heading of the row's section.
    pub name: String,
    /// The experiment, as the paper names it, with its settings.
    pub experiment: String,
    /// The gathered runs (folder names) that measure it.
    pub runs: Vec<String>,
    /// Runs that show why the measured figures differ from the paper's (longer, larger, oracle).
    #[serde(default)]
    pub evidence: Vec<String>,
    /// What `evidence` shows, in words; required when a run differs from the paper.
    #[serde(default)]
    pub why: String,
}

/// The rows of `dir`'s [`ROWS_FILE`], `None` when it has none.
pub fn read(dir: &Path) -> Result<Option<PaperRows>, ConfigError> {
    let path = dir.join(ROWS_FILE);
    if !path.is_file() {
        return Ok(None);
    }
    let text = std::fs::read_to_string(&path).map_err(|source| ConfigError::Read {
        path: path.clone(),
        source,
    })?;
    toml::from_str(&text)
        .map(Some)
        .map_err(|e| ConfigError::Parse {
            path: path.display().to_string(),
            message: science::config::one_line(&e.to_string()),
        })
}

/// One row with its runs found and each run set beside the paper's figure.
#[derive(Debug)]
pub struct JudgedRow<'a> {
    /// The row as listed.
    pub row: &'a PaperRow,
    /// Its runs, in the order listed.
    pub runs: Vec<&'a Run>,
    /// Its evidence runs, in the order listed.
    pub evidence: Vec<&'a Run>,
    /// Per run, what the paper reports for its settings (`None`: nothing).
    pub reported: Vec<Option<Reported>>,
    /// Per run, whether its measured dimension is the paper's (`None`: nothing to compare).
    pub agrees: Vec<Option<bool>>,
}

impl JudgedRow<'_> {
    /// Whether the paper has a figure for none of the row's runs.
    pub fn beyond_paper(&self) -> bool {
        self.reported.iter().all(Option::is_none)
    }

    /// Runs compared with the paper's figure, and of those the ones that agree.
    pub fn compared_and_agreeing(&self) -> (usize, usize) {
        let compared = self.agrees.iter().flatten().count();
        let agreeing = self.agrees.iter().flatten().filter(|a| **a).count();
        (compared, agreeing)
    }

    /// Whether every run compared agrees with the paper (and at least one was compared).
    pub fn reproduced(&self) -> bool {
        let (compared, agreeing) = self.compared_and_agreeing();
        compared > 0 && agreeing == compared
    }

    /// The paper's figures, one per run (`1, 1, 1`; `—` where it has none).
    pub fn paper_figures(&self) -> String {
        let figures: Vec<String> = (self.reported.iter())
            .map(|p| p.map_or("—".into(), |p| p.to_string()))
            .collect();
        figures.join(", ")
    }

    /// The measured figures, one per run (`1, 2, 3`; `undefined`; a run's status when it has
    /// none).
    pub fn measured_figures(&self) -> String {
        let figures: Vec<String> = self.runs.iter().map(|r| figure(r)).collect();
        figures.join(", ")
    }

    /// `yes`, `no (2 of 3 differ)` (runs that differ of those compared), or `—`.
    pub fn agrees_cell(&self) -> String {
        let (compared, agreeing) = self.compared_and_agreeing();
        match (compared, compared - agreeing) {
            (0, _) => "—".into(),
            (_, 0) => "yes".into(),
            (n, differ) => format!("no ({differ} of {n} differ)"),
        }
    }
}

/// A run's measured dimension ([`Run::dimension`]): `3`, `undefined`, or its status when it
/// measured none.
pub fn figure(run: &Run) -> String {
    match run.dimension() {
        Some(0) => "undefined".into(),
        Some(d) => d.to_string(),
        None => run.status.word().into(),
    }
}

/// What the paper reports for a run's settings ([`science::paper`]), and whether the run's
/// measured dimension agrees with it (`None` when the run has no measured dimension).
fn against_paper(run: &Run) -> (Option<Reported>, Option<bool>) {
    let reported = science::paper::reported_for_settings(&run.settings);
    let agrees = reported.zip(run.dimension()).map(|(p, d)| p.agrees_with(d));
    (reported, agrees)
}

/// Every row of `rows` judged over the gathered `runs`; `path` names the rows' file in errors
/// (a run not gathered; a row that differs from the paper without saying why).
pub fn judge<'a>(
    rows: &'a PaperRows,
    runs: &'a [Run],
    path: &Path,
) -> Result<Vec<JudgedRow<'a>>, ConfigError> {
    let in_row = |row: &PaperRow, field: &str, reason: String| ConfigError::InFile {
        path: path.display().to_string(),
        field: format!("row `{}`: {field}", row.name),
        reason,
    };
    let find = |row: &PaperRow, field: &str, name: &String| {
        runs.iter().find(|r| &r.folder == name).ok_or_else(|| {
            in_row(
                row,
                field,
                format!("`{name}` is not a run folder gathered here"),
            )
        })
    };
    let mut judged = Vec::new();
    for row in &rows.row {
        let measuring = (row.runs.iter())
            .map(|name| find(row, "runs", name))
            .collect::<Result<Vec<_>, _>>()?;
        let evidence = (row.evidence.iter())
            .map(|name| find(row, "evidence", name))
            .collect::<Result<Vec<_>, _>>()?;
        let (reported, agrees): (Vec<_>, Vec<_>) =
            measuring.iter().map(|r| against_paper(r)).unzip();
        let differ = agrees.iter().filter(|v| **v == Some(false)).count();
        if differ > 0 && row.why.trim().is_empty() {
            let reason = format!(
                "{differ} of its runs differ from the paper: say why (or that it is not shown)"
            );
            return Err(in_row(row, "why", reason));
        }
        judged.push(JudgedRow {
            row,
            runs: measuring,
            evidence,
            reported,
            agrees,
        });
    }
    Ok(judged)
}

/// The tally of the paper's rows: `(rows of the paper, rows reproduced in every run, runs
/// compared, runs agreeing)`; rows beyond the paper are not counted.
pub fn tally(rows: &[JudgedRow<'_>]) -> (usize, usize, usize, usize) {
    let paper: Vec<&JudgedRow<'_>> = rows.iter().filter(|r| !r.beyond_paper()).collect();
    let reproduced = paper.iter().filter(|r| r.reproduced()).count();
    let (compared, agreeing) = paper.iter().fold((0, 0), |(c, a), r| {
        let (rc, ra) = r.compared_and_agreeing();
        (c + rc, a + ra)
    });
    (paper.len(), reproduced, compared, agreeing)
}

#[cfg(test)]
mod tests;
