//! The paper's table, row by row: for each experiment of Kotani & Ng (ICLR 2025), the gathered
//! runs that measure it, each run's dimension and converged margins beside the figure the paper
//! reports for that run's settings ([`crate::paper`]), whether they agree, and — where they do
//! not — the runs that are evidence of why, with what they show.
//!
//! The rows are listed in [`ROWS_FILE`] in the gathered folder (`results/` for the README):
//!
//! ```toml
//! [[row]]
//! experiment = "LMS + human Q (545 nm), boosted, three environments"
//! runs = ["LMS-boost-humanQ-16k", "LMS-boost-humanQ-huesphere-16k"]
//! evidence = ["LMS-boost-humanQ-idealised-24k"]
//! why = "trained 8 000 steps more, it stays 3-D …"
//! ```
//!
//! Every figure in the table is read from the runs' `summary.json` and the paper's figure from
//! their settings; only `experiment` and `why` are words. A row whose runs differ from the paper
//! must say why (`why`, which may be "not shown"); a run named that was not gathered is an
//! error naming the file, the row and the field, so the table cannot silently drop a row.

use super::Run;
use crate::config::ConfigError;
use serde::Deserialize;
use std::path::Path;

/// The file in a gathered folder that lists the paper's rows.
pub const ROWS_FILE: &str = "paper-rows.toml";

/// [`ROWS_FILE`], read.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PaperRows {
    /// The rows, in the order the table shows them.
    pub row: Vec<PaperRow>,
}

/// One experiment of the paper.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PaperRow {
    /// The experiment, as the paper names it.
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
            message: crate::config::one_line(&e.to_string()),
        })
}

/// What the paper reports for a run's settings ([`crate::paper`]), and whether the run's
/// measured dimension agrees with it (`None` when the run has no measured dimension).
fn against_paper(run: &Run) -> (Option<crate::paper::Reported>, Option<bool>) {
    let reported = crate::paper::reported_for_settings(&run.settings);
    let measured = run
        .summary
        .as_ref()
        .filter(|s| !s.dimension_over_steps.is_empty());
    let agrees = reported
        .zip(measured)
        .map(|(p, s)| p.agrees_with(s.dimension));
    (reported, agrees)
}

/// `NAME: **d** (K1 …)`: a run and what it measured, and, where CMF-SIM measured several of
/// its checkpoints, their dimensions and how they read (`… — 3, 3, 4, 3 at 34 000–40 000
/// steps: on the border`), then the figure of those checkpoints' averaged weights, where
/// measured (`; weights averaged over 4 checkpoints, 34 000–40 000 steps: **3** (K1 …)`).
fn measured(run: &Run) -> String {
    let cell = super::table::dimension_cell(run);
    let cell = if cell.is_empty() {
        run.status.word().to_string()
    } else {
        super::table::emphasise_number(&cell, "**", "**")
    };
    let mut text = format!("{}: {cell}", run.folder);
    if let Some(verdict) = &run.over_checkpoints {
        text = format!("{text} — {}", verdict.brief());
    }
    if let Some(averaged) = &run.averaged {
        let figure = super::table::emphasise_number(&averaged.figure(), "**", "**");
        text = format!("{text}; {}: {figure}", averaged.span());
    }
    text
}

/// The Markdown table of `rows` over the gathered `runs`; `path` names the rows' file in errors.
pub fn markdown(rows: &PaperRows, runs: &[Run], path: &Path) -> Result<String, ConfigError> {
    let find = |row: &PaperRow, field: &str, name: &String| {
        runs.iter()
            .find(|r| &r.folder == name)
            .ok_or_else(|| ConfigError::InFile {
                path: path.display().to_string(),
                field: format!("row `{}`: {field}", row.experiment),
                reason: format!("`{name}` is not a run folder gathered here"),
            })
    };
    let mut out = String::from(
        "| the paper's experiment | paper | measured: run, CMF-SIM dimension (margins) | agrees | \
         why it differs: evidence |\n|---|---|---|---|---|\n",
    );
    for row in &rows.row {
        let measuring = (row.runs.iter())
            .map(|name| find(row, "runs", name))
            .collect::<Result<Vec<_>, _>>()?;
        let evidence = (row.evidence.iter())
            .map(|name| find(row, "evidence", name))
            .collect::<Result<Vec<_>, _>>()?;
        let (reported, verdicts): (Vec<_>, Vec<_>) =
            measuring.iter().map(|r| against_paper(r)).unzip();
        let differ = verdicts.iter().filter(|v| **v == Some(false)).count();
        if differ > 0 && row.why.trim().is_empty() {
            return Err(ConfigError::InFile {
                path: path.display().to_string(),
                field: format!("row `{}`: why", row.experiment),
                reason: format!(
                    "{differ} of its runs differ from the paper: say why (or that it is not shown)"
                ),
            });
        }
        let paper: Vec<String> = (reported.iter())
            .map(|p| p.map_or("—".into(), |p| p.to_string()))
            .collect();
        let agree = match (differ, verdicts.iter().any(Option::is_some)) {
            (_, false) => "—".to_string(),
            (0, true) => "yes".to_string(),
            (n, true) => format!("no ({n} of {})", measuring.len()),
        };
        let shown: Vec<String> = evidence.iter().map(|r| measured(r)).collect();
        let why = match (row.why.trim(), shown.is_empty()) {
            (why, true) => why.to_string(),
            (why, false) => format!("{why} ({})", shown.join("; ")).trim().to_string(),
        };
        let results: Vec<String> = measuring.iter().map(|r| measured(r)).collect();
        let cells = [
            row.experiment.as_str(),
            &paper.join(", "),
            &results.join("; "),
            &agree,
            &why,
        ]
        .map(super::table::md_escape);
        out.push_str(&format!("| {} |\n", cells.join(" | ")));
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::convergence::{CheckpointCmf, VerdictOverCheckpoints};
    use std::path::PathBuf;

    /// A finished run with these settings, measured `dimension` with these margins (the rest of
    /// its summary is a recorded run's).
    fn run(folder: &str, cones: &str, dimension: usize, margins: &[(usize, f64)]) -> Run {
        crate::gather::recorded_run(folder, cones, "L-8k", |summary| {
            summary.dimension = dimension;
            summary.converged_ratio_per_k = margins.to_vec();
        })
    }

    fn rows(toml: &str) -> PaperRows {
        toml::from_str(toml).unwrap()
    }

    fn runs() -> Vec<Run> {
        vec![
            run("mono", "L", 1, &[(1, 0.67)]),
            run("tri", "LMS", 2, &[(1, 1.5), (2, 0.8)]),
            run("longer", "LMS", 3, &[(2, 1.2), (3, 0.7)]),
        ]
    }

    fn path() -> PathBuf {
        PathBuf::from("results").join(ROWS_FILE)
    }

    #[test]
    fn each_run_stands_beside_the_paper_and_disagreements_are_counted() {
        let table = rows(
            r#"
            [[row]]
            experiment = "one and three classes"
            runs = ["mono", "tri"]
            evidence = ["longer"]
            why = "under-trained"
            "#,
        );
        let md = markdown(&table, &runs(), &path()).unwrap();
        let row = md.lines().nth(2).unwrap();
        assert_eq!(
            row,
            "| one and three classes | 1, 3 | mono: **1** (K1 0.67); tri: **2** (K1 1.50, K2 0.80) \
             | no (1 of 2) | under-trained (longer: **3** (K2 1.20, K3 0.70)) |"
        );
    }

    #[test]
    fn checkpoints_measured_on_the_way_are_read_beside_the_final_figure() {
        let mut border = run("border", "LMS", 3, &[(2, 1.2), (3, 0.96)]);
        let at = |step, dimension, margin| CheckpointCmf {
            step,
            dimension,
            per_k: vec![[dimension as f64, 1.0, margin]],
        };
        border.over_checkpoints = VerdictOverCheckpoints::from_points(vec![
            at(34_000, 3, 0.87),
            at(38_000, 4, 0.80),
            at(40_000, 3, 0.96),
        ]);
        let table = rows("[[row]]\nexperiment = \"x\"\nruns = [\"border\"]\n");
        let md = markdown(&table, std::slice::from_ref(&border), &path()).unwrap();
        assert!(
            md.contains("border: **3** (K2 1.20, K3 0.96) — 3, 4, 3 at 34 000–40 000 steps: on the border |"),
            "{md}"
        );
        // The averaged weights' figure follows, read from a record.
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("results");
        let file = crate::averaging::averaged_path(&root.join("LMSQ-humanQ-idealised-48k"));
        border.averaged = Some(crate::averaging::Averaged::read(&file).unwrap());
        let md = markdown(&table, &[border], &path()).unwrap();
        assert!(
            md.contains(
                "on the border; weights averaged over 8 checkpoints, 34 000–48 000 steps: **3** \
                 (K1 20.06, K2 1.36, K3 0.91) |"
            ),
            "{md}"
        );
    }

    #[test]
    fn a_row_that_differs_from_the_paper_must_say_why() {
        let table = rows("[[row]]\nexperiment = \"x\"\nruns = [\"tri\"]\n");
        let err = markdown(&table, &runs(), &path()).unwrap_err().to_string();
        assert!(
            err.contains(ROWS_FILE) && err.contains("row `x`: why"),
            "{err}"
        );
        // Evidence is shown even without words.
        let table =
            rows("[[row]]\nexperiment = \"x\"\nruns = [\"mono\"]\nevidence = [\"longer\"]\n");
        let md = markdown(&table, &runs(), &path()).unwrap();
        assert!(
            md.ends_with("| yes | (longer: **3** (K2 1.20, K3 0.70)) |\n"),
            "{md}"
        );
        // A row that agrees needs no words.
        let table = rows("[[row]]\nexperiment = \"x\"\nruns = [\"mono\", \"longer\"]\n");
        let md = markdown(&table, &runs(), &path()).unwrap();
        assert!(
            md.ends_with(
                "| x | 1, 3 | mono: **1** (K1 0.67); longer: **3** (K2 1.20, K3 0.70) | yes |  |\n"
            ),
            "{md}"
        );
    }

    #[test]
    fn a_run_not_gathered_is_an_error_naming_the_row_and_field() {
        for field in ["runs", "evidence"] {
            let text = format!("[[row]]\nexperiment = \"x\"\nruns = []\n{field} = [\"gone\"]\n");
            let text = text.replacen("runs = []\nruns", "runs", 1);
            let err = markdown(&rows(&text), &runs(), &path())
                .unwrap_err()
                .to_string();
            assert!(
                err.contains(&format!("row `x`: {field}")) && err.contains("`gone`"),
                "{err}"
            );
        }
    }

    #[test]
    fn a_run_the_paper_has_no_figure_for_gets_no_verdict() {
        let custom = run("custom", "L:560,X:600", 2, &[(1, 3.0), (2, 0.9)]);
        let table = rows("[[row]]\nexperiment = \"beyond\"\nruns = [\"custom\"]\n");
        let md = markdown(&table, &[custom], &path()).unwrap();
        assert!(
            md.ends_with("| beyond | — | custom: **2** (K1 3.00, K2 0.90) | — |  |\n"),
            "{md}"
        );
    }

    #[test]
    fn the_rows_file_is_optional_and_a_wrong_field_is_named() {
        let dir = std::env::temp_dir().join(format!("cv_paper_rows_{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        assert!(read(&dir).unwrap().is_none());
        std::fs::write(
            dir.join(ROWS_FILE),
            "[[row]]\nexperiment = \"x\"\nrun = []\n",
        )
        .unwrap();
        let err = read(&dir).unwrap_err().to_string();
        assert!(err.contains(ROWS_FILE) && err.contains("run"), "{err}");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
