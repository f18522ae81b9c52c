//! The page of the paper's rows (`docs/results.md`): one section per row of
//! [`super::paper_rows::ROWS_FILE`], in its order, each with its verdict first — reproduced,
//! differing in some runs, or beyond the paper — then the experiment, every run's dimension with
//! its margins (and, where measured, its checkpoints' and averaged weights' figures), and for a
//! row that differs the words of why with the runs that are its evidence. Each run links to its
//! record. The page is written for a folder beside the gathered one (`docs/` beside `results/`).

use super::paper_rows::{tally, JudgedRow};
use super::table::{dimension_cell, emphasise_number};
use super::{readme_table, Run};
use std::fmt::Write as _;
use std::path::Path;

/// What every section's figures mean, said once at the top.
const READING: &str = "A run's figure is CMF-SIM's dimension at its end (**bold**) with each \
K's margin: the best primary set's worst error over every test wavelength divided by the \
threshold, after its solver converged (below 1 passes; \"K2 1.24\": the best two-primary set \
fails somewhere by 24 %). Where CMF-SIM also measured a run's late checkpoints, their dimensions \
follow, read as settled, rising (still gaining) or on the border (up and down); where the late \
checkpoints' weights were averaged, the averaged cortex's figure follows that.";

/// `NAME: **d** (K1 …)`, the name linked to its record under `records`; then, where CMF-SIM
/// measured several of its checkpoints, their dimensions and how they read (`— 3, 3, 4, 3 at
/// 34 000–40 000 steps: on the border`), and the figure of those checkpoints' averaged weights
/// (`; weights averaged over 4 checkpoints, 34 000–40 000 steps: **3** (K1 …)`).
pub fn measured(run: &Run, records: &str) -> String {
    let cell = dimension_cell(run);
    let cell = if cell.is_empty() {
        run.status.word().to_string()
    } else {
        emphasise_number(&cell, "**", "**")
    };
    let mut text = format!("[{name}]({records}/{name}/): {cell}", name = run.folder);
    if let Some(verdict) = &run.over_checkpoints {
        text = format!("{text} — {}", verdict.brief());
    }
    if let Some(averaged) = &run.averaged {
        let figure = emphasise_number(&averaged.figure(), "**", "**");
        text = format!("{text}; {}: {figure}", averaged.span());
    }
    text
}

/// The verdict of a row in a few words, bold.
fn verdict(row: &JudgedRow<'_>) -> String {
    let (compared, agreeing) = row.compared_and_agreeing();
    let word = if row.beyond_paper() {
        "Beyond the paper".to_string()
    } else if row.reproduced() {
        "Reproduced".to_string()
    } else if compared == 0 {
        "Not measured".to_string()
    } else {
        format!("Differs in {} of {compared} runs", compared - agreeing)
    };
    match row.beyond_paper() {
        true => format!("**{word}**: measured {}.", row.measured_figures()),
        false => format!(
            "**{word}**: the paper {}; measured {}.",
            row.paper_figures(),
            row.measured_figures()
        ),
    }
}

/// The page for the judged `rows` of the folder `dir` (its records linked as `../DIR_NAME/`).
pub fn markdown(rows: &[JudgedRow<'_>], dir: &Path) -> String {
    let name = dir.file_name().map_or_else(
        || dir.display().to_string(),
        |n| n.to_string_lossy().into_owned(),
    );
    let records = format!("../{name}");
    let (paper, ..) = tally(rows);
    let mut out = String::from("# Does it reproduce the paper? Row by row\n\n");
    let _ = write!(
        out,
        "The {paper} experiments of Kotani & Ng (ICLR 2025) measured here, and {} beyond them, \
         in the order of the README's table: each row's verdict, then its runs and, where it \
         differs, why. Written by `colorvision gather {name} --markdown=rows` from the run \
         records in [`{name}/`]({records}/) and [`paper-rows.toml`]({records}/paper-rows.toml) \
         (`scripts/readme-tables.sh`); a test fails when it is out of date.\n\n{}\n\n{READING}\n",
        rows.len() - paper,
        readme_table::tally_line(rows),
    );
    for row in rows {
        let _ = write!(
            out,
            "\n## {}\n\n{}\n\n{}.\n\n",
            row.row.name,
            verdict(row),
            row.row.experiment.trim_end_matches('.')
        );
        for run in &row.runs {
            let _ = writeln!(out, "- {}", measured(run, &records));
        }
        if !row.row.why.trim().is_empty() {
            let _ = write!(out, "\nWhy: {}\n", row.row.why.trim());
        }
        if !row.evidence.is_empty() {
            out.push_str("\nEvidence:\n\n");
            for run in &row.evidence {
                let _ = writeln!(out, "- {}", measured(run, &records));
            }
        }
    }
    out
}
