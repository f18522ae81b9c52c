//! The README's answer to "Does it reproduce the paper?": the tally of the paper's rows, then
//! one short row per experiment — its name, the paper's figure for each run, the measured one,
//! whether they agree — and the rows beyond the paper apart. Every figure comes from the run
//! records through [`super::paper_rows::judge`]; the evidence behind each row is on the page of
//! the rows ([`super::rows_page`]).

use super::paper_rows::{tally, JudgedRow};
use super::table::md_escape;

/// The tally of the paper's rows in one sentence (bold).
pub fn tally_line(rows: &[JudgedRow<'_>]) -> String {
    let (paper, reproduced, compared, agreeing) = tally(rows);
    format!(
        "**{reproduced} of the paper's {paper} experiments reproduce in every run; {agreeing} of \
         their {compared} runs agree with the paper's figure.**"
    )
}

/// The tally, the table of the paper's rows and the table of the rows beyond the paper.
pub fn markdown(rows: &[JudgedRow<'_>]) -> String {
    let mut out = format!(
        "{}\n\n| experiment | paper | measured | agrees |\n|---|---|---|---|\n",
        tally_line(rows)
    );
    for row in rows.iter().filter(|r| !r.beyond_paper()) {
        let cells = [
            row.row.name.clone(),
            row.paper_figures(),
            row.measured_figures(),
            row.agrees_cell(),
        ]
        .map(|c| md_escape(&c));
        out.push_str(&format!("| {} |\n", cells.join(" | ")));
    }
    let beyond: Vec<&JudgedRow<'_>> = rows.iter().filter(|r| r.beyond_paper()).collect();
    if !beyond.is_empty() {
        out.push_str("\n| beyond the paper | measured |\n|---|---|\n");
        for row in beyond {
            let cells = [row.row.name.clone(), row.measured_figures()].map(|c| md_escape(&c));
            out.push_str(&format!("| {} |\n", cells.join(" | ")));
        }
    }
    out
}
