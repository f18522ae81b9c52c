//! The page of every run (`results/index.md`): one row per run, linked to its folder, with the
//! settings that vary between the runs, CMF-SIM's dimension and margins beside the paper's
//! figure, the held-out prediction gain and the learned invariants; then the colour-matching
//! functions against Stiles & Burch and the dichromats' hue axes, where measured.
//!
//! A setting that every run has and that varies gets a column of its own; one that only some
//! runs have (a tetrachromatic environment, the run a cortex was continued from) is written in
//! the runs that have it, in one column of such settings, so no column is mostly empty. The
//! status column is left out when every run is done.

use super::table::{dimension_column, display, emphasise_number, md_escape};
use super::Run;
use std::fmt::Write as _;

/// What the columns say.
const COLUMNS: &str = "Columns: the settings that vary between the runs (`continued_from`: the \
run and step whose cortex this run continued; `protocol`: the page that fixed the run's cells, \
steps, seeds and verdict rule before it ran, and the commit that added it — a run without one \
was measured before any protocol); steps done (a continued run's count goes on from \
its start); wall time in seconds on the machine the run was trained on; the paper's figure for \
the run's settings; CMF-SIM's dimension with each K's margin (the best set's worst error over \
the threshold, below 1 passes); gain: held-out error of \"next = this frame\" over the \
cortex's; C recall by nearest class centre and d′ per class; W surround r against the eye's \
DoG and W's DC gain; P error in cone spacings after the affine gauge; hidden R²: how much of \
each class's own signal the percept carries at the other classes' cones; directions R²: how \
much of each principal colour direction of the cone excitations it carries, strongest first \
(empty for a record measured before they existed).";

/// The page for `runs` with the varying settings `keys`.
pub fn markdown(runs: &[Run], keys: &[String]) -> String {
    let (own, shared): (Vec<String>, Vec<String>) = keys
        .iter()
        .cloned()
        .partition(|k| runs.iter().all(|r| r.settings.contains_key(k)));
    let (mut head, rows) = display(runs, &own);
    let dimension = dimension_column(&own);
    let mut rows: Vec<Vec<String>> = rows
        .into_iter()
        .zip(runs)
        .map(|(mut row, run)| {
            row[dimension] = emphasise_number(&row[dimension], "**", "**");
            row[0] = format!("[{0}]({0}/)", row[0]);
            let set: Vec<String> = (shared.iter())
                .filter_map(|k| Some(format!("{k} = {}", run.settings.get(k)?)))
                .collect();
            row.insert(own.len() + 1, set.join("; "));
            row
        })
        .collect();
    head.insert(own.len() + 1, "also set".into());
    let status = head.iter().position(|h| h == "status");
    if let Some(i) = status.filter(|&i| rows.iter().all(|r| r[i] == "done")) {
        head.remove(i);
        rows.iter_mut().for_each(|r| {
            r.remove(i);
        });
    }
    let mut out = format!(
        "# Every recorded run\n\nWritten by `colorvision gather results --markdown=runs` from \
         the records in this folder (`scripts/readme-tables.sh`); a test fails when it is out \
         of date. Each record holds its run's `config.toml`: `colorvision run --config \
         results/NAME/config.toml` repeats it. The paper's experiments, row by row, are in \
         [docs/results.md](../docs/results.md).\n\n{COLUMNS}\n\n| {} |\n|{}\n",
        head.join(" | "),
        "---|".repeat(head.len())
    );
    for row in rows {
        let row: Vec<String> = row.iter().map(|c| md_escape(c)).collect();
        let _ = writeln!(out, "| {} |", row.join(" | "));
    }
    out.push_str(&super::extra_tables(runs));
    out
}
